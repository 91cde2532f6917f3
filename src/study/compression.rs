//! Compression of the baked visibility against storage (`shvis study compression`): global
//! PCA (`bake::pca`), VQ and static / iterative CPCA (`bake::cluster`) fitted to the same
//! order-6 visibility, each with the bytes it would take on the GPU and its reconstruction
//! error.
//!
//! Storage, as the `pca*` techniques lay it out (`technique::pca`, `technique::tables`):
//!
//! ```text
//! per texel   ⌈M/4⌉ · 4 bytes of RGBA8 weights, plus a cluster index (1 byte ≤ 256
//!             clusters, else 2) for VQ and CPCA
//! tables      per cluster 3 · ⌈M/4⌉ + 1 RGBA16F spheres (colour T_k groups and the mean),
//!             a sphere being 2 · res² texels of 8 bytes (dx9 dual paraboloid)
//! ```
//!
//! With a GPU, [`screen_errors`] renders the compression techniques built on these models
//! (`pcaMw`, `vqK`, `cpcaK_M[s]`, `pcaMv[E]`, whose per-texel layout differs from the table
//! route above: the index shares the last RGBA8 texel, per-cluster blocks are uniforms) and
//! measures each image against `unc6`'s.
//!
//! The error is the RMS over covered texels of the coefficient L2 error, which is the L2
//! error of the visibility function over the sphere (the SH basis is orthonormal), before
//! weight quantization and again with the weights in 8 bits per vector range as the
//! techniques store them (PCA: one range per vector over the whole map; CPCA: per cluster).
//! It does not depend on the lighting; what each model costs in image error under a given
//! environment is the renderer's to measure ([`screen_errors`]).

use std::fmt::Write as _;
use std::time::Instant;

use serde::Serialize;

use crate::bake::BakeError;
use crate::bake::cache::load_or_fit_clusters;
use crate::bake::cluster::{self, Clustering};
use crate::bake::pca::{self, rms};
use crate::bake::visibility::VisibilityMap;
use crate::gpu::Context;
use crate::prepare::Prepared;
use crate::render::{Frame, FrameSettings, SceneGpu};
use crate::report::metrics::image_error;
use crate::sh::Order;
use crate::technique::{self, HwPath, Technique, TechniqueError, TechniqueStats};
use std::sync::Arc;

/// The model of one row.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Model {
    Pca,
    Vq,
    /// VQ clusters, then PCA per cluster.
    CpcaStatic,
    /// Clusters refined by reassignment to the best affine subspace.
    CpcaIterative,
}

impl Model {
    fn name(self) -> &'static str {
        match self {
            Model::Pca => "PCA",
            Model::Vq => "VQ",
            Model::CpcaStatic => "static CPCA",
            Model::CpcaIterative => "iterative CPCA",
        }
    }
}

/// One fitted model.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Row {
    pub model: Model,
    /// Clusters (1 for PCA).
    pub k: usize,
    /// Vectors per cluster (0 for VQ).
    pub m: usize,
    pub bytes_per_texel: usize,
    pub texel_bytes: u64,
    pub table_bytes: u64,
    pub total_bytes: u64,
    /// RMS visibility error over covered texels.
    pub rms_error: f64,
    /// The same with the weights quantized to 8 bits as the techniques store them.
    pub rms_error_quantized: f64,
    /// Clusters that ended with a covered texel.
    pub clusters_used: usize,
    pub seconds: f64,
}

/// Bytes of a model with `k` clusters of `m` vectors (module doc) over a `res`² lightmap
/// with `table_res`² tables.
pub fn storage(k: usize, m: usize, res: u32, table_res: u32, indexed: bool) -> (usize, u64, u64) {
    let groups = m.div_ceil(4);
    let index = match (indexed, k) {
        (false, _) => 0,
        (true, ..=256) => 1,
        (true, _) => 2,
    };
    let per_texel = 4 * groups + index;
    let texel_bytes = per_texel as u64 * u64::from(res) * u64::from(res);
    let sphere = 2 * u64::from(table_res) * u64::from(table_res) * 8;
    let table_bytes = k as u64 * (3 * groups as u64 + 1) * sphere;
    (per_texel, texel_bytes, table_bytes)
}

/// The default rows: PCA at 4…16 vectors, VQ at 16…256 clusters, CPCA at 8 and 32
/// clusters of 3…15 vectors, static and iterative.
pub fn default_configs() -> Vec<(Model, usize, usize)> {
    let mut configs: Vec<(Model, usize, usize)> =
        [4, 8, 12, 16].iter().map(|&m| (Model::Pca, 1, m)).collect();
    configs.extend([16, 64, 256].iter().map(|&k| (Model::Vq, k, 0)));
    for model in [Model::CpcaStatic, Model::CpcaIterative] {
        for k in [8, 32] {
            for m in [3, 7, 11, 15] {
                configs.push((model, k, m));
            }
        }
    }
    configs
}

/// Fits every `(model, k, m)` of `configs` to `vis`, through the bake cache in `cache_dir`
/// when given (`bake::cache::load_or_fit_clusters`; `seconds` is then the load time).
pub fn run(
    vis: &VisibilityMap,
    configs: &[(Model, usize, usize)],
    table_res: u32,
    seed: u64,
    cache_dir: Option<&std::path::Path>,
) -> Result<Vec<Row>, BakeError> {
    let mut rows = Vec::with_capacity(configs.len());
    for &(model, k, m) in configs {
        let start = Instant::now();
        let covered = || (0..vis.covered.len()).filter(|&t| vis.covered[t]);
        let truth = |t: usize| {
            vis.texel(t)
                .iter()
                .map(|&c| f64::from(c))
                .collect::<Vec<f64>>()
        };
        let (rms_error, rms_error_quantized, clusters_used) = match model {
            Model::Pca => {
                let fit = pca::fit(vis, m)?;
                let q = fit.quantize(8);
                let quantized = rms(covered().map(|t| (truth(t), q.reconstruct(t))));
                (fit.rms_reconstruction_error(vis), quantized, 1)
            }
            Model::Vq | Model::CpcaStatic | Model::CpcaIterative => {
                let clustering = match model {
                    Model::CpcaIterative => Clustering::Iterative,
                    _ => Clustering::KMeans,
                };
                let m = if model == Model::Vq { 0 } else { m };
                let fit = match cache_dir {
                    Some(dir) => load_or_fit_clusters(dir, vis, k, m, clustering, seed, || {
                        cluster::fit(vis, k, m, clustering, seed)
                    })?,
                    None => cluster::fit(vis, k, m, clustering, seed)?,
                };
                let q = fit.quantize();
                let quantized = rms(covered().map(|t| (truth(t), q.reconstruct(t))));
                (
                    fit.rms_reconstruction_error(vis),
                    quantized,
                    fit.clusters_used(),
                )
            }
        };
        let (bytes_per_texel, texel_bytes, table_bytes) =
            storage(k, m, vis.res, table_res, model != Model::Pca);
        rows.push(Row {
            model,
            k,
            m,
            bytes_per_texel,
            texel_bytes,
            table_bytes,
            total_bytes: texel_bytes + table_bytes,
            rms_error,
            rms_error_quantized,
            clusters_used,
            seconds: start.elapsed().as_secs_f64(),
        });
        log::info!(
            "compression: {} K={k} M={m}: {rms_error:.5} in {:.1} s",
            model.name(),
            start.elapsed().as_secs_f64()
        );
    }
    Ok(rows)
}

/// The rows as a markdown table, sorted by total bytes.
pub fn to_markdown(rows: &[Row], res: u32, table_res: u32) -> String {
    let mut sorted: Vec<&Row> = rows.iter().collect();
    sorted.sort_by_key(|r| (r.total_bytes, r.model as u8));
    let mut s = format!(
        "Visibility compression against storage: {res}² lightmap, {table_res}² tables (dx9 layout), RMS visibility error over covered texels (unquantized weights; then with the weights in 8 bits as stored)\n\n\
         | model | K | M | bytes/texel | texel KiB | table KiB | total KiB | RMS error | 8-bit weights | clusters used | s |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n"
    );
    for r in sorted {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.0} | {:.0} | {:.0} | {:.5} | {:.5} | {} | {:.1} |",
            r.model.name(),
            r.k,
            r.m,
            r.bytes_per_texel,
            r.texel_bytes as f64 / 1024.0,
            r.table_bytes as f64 / 1024.0,
            r.total_bytes as f64 / 1024.0,
            r.rms_error,
            r.rms_error_quantized,
            r.clusters_used,
            r.seconds
        );
    }
    s
}

/// The compression rows rendered by default ([`screen_errors`]): global PCA (weights-only,
/// the same route as the clustered rows), VQ, static and iterative CPCA, per-vertex PCA at
/// three densities.
pub const SCREEN_TECHNIQUES: &[&str] = &[
    "pca8w",
    "pca12w",
    "pca16w",
    "vq64",
    "vq256",
    "cpca8_7s",
    "cpca8_7",
    "cpca8_11s",
    "cpca8_11",
    "cpca8_15s",
    "cpca8_15",
    "pca12v",
    "pca12v50",
    "pca12v25",
];

/// One technique's on-screen compression error.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ScreenRow {
    pub technique: Technique,
    pub path: HwPath,
    /// Per-texel (or per-vertex) bytes plus tables and uniforms, as bound on the GPU.
    pub bytes: u64,
    pub texel_bytes: u64,
    /// Relative RMSE of its image against `unc6`'s on the same path: the compression's own
    /// error on screen, without the reference's noise or the visibility order's error.
    pub rel_rmse_vs_unc6: f64,
}

/// Renders `techniques` and `unc6` on each of `paths` at `width` × `height` and compares
/// (the techniques' bake data must be prepared: `Prepared::prepare_techniques`).
pub fn screen_errors(
    ctx: &Arc<Context>,
    prepared: &Prepared,
    techniques: &[Technique],
    paths: &[HwPath],
    width: u32,
    height: u32,
) -> Result<Vec<ScreenRow>, TechniqueError> {
    let settings = FrameSettings {
        width,
        height,
        ..FrameSettings::default()
    };
    let scene = SceneGpu::new(ctx, &prepared.scene, &settings)?;
    let mut rows = Vec::new();
    for &path in paths {
        let render = |t: Technique| -> Result<(Frame, TechniqueStats), TechniqueError> {
            let gpu = technique::build(ctx, &scene, t, path, &prepared.inputs())?;
            Ok((gpu.render(&scene, 0, 1)?, gpu.stats))
        };
        let (truth, _) = render(Technique::Unc(crate::technique::Unc { order: Order::SIX }))?;
        for &t in techniques {
            let (frame, stats) = render(t)?;
            let error = image_error(&frame, &truth).ok_or_else(|| TechniqueError::Input {
                label: format!("{t}.{path}"),
                detail: "no pixel covered in both images".into(),
            })?;
            rows.push(ScreenRow {
                technique: t,
                path,
                bytes: stats.texel_bytes + stats.table_bytes,
                texel_bytes: stats.texel_bytes,
                rel_rmse_vs_unc6: error.rel_rmse,
            });
        }
    }
    Ok(rows)
}

/// The on-screen rows as a markdown table, by path and bytes.
pub fn screen_markdown(rows: &[ScreenRow], env: &str, width: u32, height: u32) -> String {
    let mut sorted: Vec<&ScreenRow> = rows.iter().collect();
    sorted.sort_by_key(|r| (r.path, r.bytes));
    let mut s = format!(
        "On screen under {env}, {width}×{height}: relative RMSE against unc6 on the same path (the compression's own error)\n\n\
         | technique | path | per-texel/vertex KiB | total KiB | rel. RMSE vs unc6 |\n\
         |---|---|---:|---:|---:|\n"
    );
    for r in sorted {
        let _ = writeln!(
            s,
            "| {} | {} | {:.0} | {:.0} | {:.4} |",
            r.technique,
            r.path,
            r.texel_bytes as f64 / 1024.0,
            r.bytes as f64 / 1024.0,
            r.rel_rmse_vs_unc6
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn storage_counts_weights_index_and_tables() {
        // pca16 at 512², 32² tables: 16 B per texel, 13 spheres of 16 KiB (the cost table's
        // 213008 bytes less the 16-byte uniform block).
        let (b, texels, tables) = storage(1, 16, 512, 32, false);
        assert_eq!((b, texels, tables), (16, 16 * 512 * 512, 13 * 16384));
        // CPCA 32 × 7: index + 2 RGBA8 groups; 32 clusters of 7 spheres.
        assert_eq!(storage(32, 7, 512, 32, true).0, 9);
        assert_eq!(storage(32, 7, 512, 32, true).2, 32 * 7 * 16384);
        // VQ: an index only (2 bytes past 256 clusters), one mean sphere per cluster.
        assert_eq!(
            storage(1024, 0, 512, 32, true),
            (2, 2 * 512 * 512, 1024 * 16384)
        );
    }
}
