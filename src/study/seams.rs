//! Cluster-boundary seams in screen space (`shvis study seams`): how much a
//! clustered technique (`vqK`, `cpcaK_M`) jumps where neighbouring pixels read texels of
//! different clusters, with the seam mitigation ([`SeamMode::Blended`]) and without
//! ([`SeamMode::Naive`]).
//!
//! For every pair of horizontally or vertically adjacent covered pixels p, q on one surface
//! (coplanar interpolated normals, lightmap UVs less than two texels apart) whose nearest
//! lightmap texels lie in different clusters, the discontinuity is
//!
//! ```text
//! d(p, q) = |ΔY_technique − ΔY_unc6| / mean Y_unc6,   ΔY = Y(p) − Y(q)
//! ```
//!
//! Y the luminance of the linear image, `unc6` on the same path the uncompressed,
//! bilinearly filtered visibility the clusters compress: the jump the compression adds on
//! top of the image's own gradient, relative to the image's mean luminance over covered
//! pixels (a per-pair scale would blow up in black shadow). Pairs inside one cluster give the same statistic as the
//! floor to read the boundary figures against.

use std::sync::Arc;

use serde::Serialize;

use crate::gpu::Context;
use crate::prepare::Prepared;
use crate::reference::render_point_gbuffer;
use crate::render::{Frame, FrameSettings, SceneGpu};
use crate::technique::{self, HwPath, SeamMode, Technique, TechniqueError};
use crate::technique::{Cpca, Vq};

/// Discontinuity statistics of one set of pixel pairs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct PairStats {
    pub pairs: usize,
    pub mean: f64,
    pub p99: f64,
    pub max: f64,
}

impl PairStats {
    fn of(mut d: Vec<f64>) -> Self {
        if d.is_empty() {
            return PairStats::default();
        }
        d.sort_by(f64::total_cmp);
        let p99 = d[((d.len() - 1) as f64 * 0.99).round() as usize];
        PairStats {
            pairs: d.len(),
            mean: d.iter().sum::<f64>() / d.len() as f64,
            p99,
            max: *d.last().expect("not empty"),
        }
    }
}

/// One technique's seams.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SeamRow {
    pub technique: Technique,
    pub path: HwPath,
    /// Pairs across a cluster boundary.
    pub boundary: PairStats,
    /// Pairs inside one cluster (the floor).
    pub interior: PairStats,
}

/// Relative luminance of linear RGB (Rec. 709).
fn luminance(rgb: [f32; 4]) -> f64 {
    0.2126 * f64::from(rgb[0]) + 0.7152 * f64::from(rgb[1]) + 0.0722 * f64::from(rgb[2])
}

/// The seams of `technique` with each seam mode, on `path`, at `width` × `height` from the
/// scene's camera.
pub fn measure(
    ctx: &Arc<Context>,
    prepared: &Prepared,
    technique: Technique,
    path: HwPath,
    width: u32,
    height: u32,
) -> Result<Vec<SeamRow>, TechniqueError> {
    let need = technique
        .needs()
        .clusters
        .ok_or_else(|| TechniqueError::Input {
            label: technique.name(),
            detail: "seams are measured for clustered techniques (vqK, cpcaK_M)".into(),
        })?;
    let model = technique::cluster::find(&prepared.inputs(), need, &technique.name())?;
    let gbuffer = render_point_gbuffer(ctx, &prepared.scene, width, height)?;
    let settings = FrameSettings {
        width,
        height,
        ..FrameSettings::default()
    };
    let scene = SceneGpu::new(ctx, &prepared.scene, &settings)?;
    let render = |t: Technique| -> Result<Frame, TechniqueError> {
        let gpu = technique::build(ctx, &scene, t, path, &prepared.inputs())?;
        Ok(gpu.render(&scene, 0, 1)?)
    };
    let truth = render(Technique::Unc(crate::technique::Unc {
        order: crate::sh::Order::SIX,
    }))?;
    let covered: Vec<f64> = truth
        .rgba
        .iter()
        .filter(|p| p[3] > 0.0)
        .map(|&p| luminance(p))
        .collect();
    let mean_luminance = covered.iter().sum::<f64>() / covered.len().max(1) as f64;
    if !(mean_luminance > 0.0 && mean_luminance.is_finite()) {
        return Err(TechniqueError::Input {
            label: technique.name(),
            detail: "the unc6 image is black or not finite; no scale for the seams".into(),
        });
    }
    let res = model.res;
    let texel = |px: usize| -> Option<(usize, [f64; 2])> {
        let uv = gbuffer.uv_lightmap.rgba[px];
        if gbuffer.position.rgba[px][3] == 0.0 || !uv[0].is_finite() || !uv[1].is_finite() {
            return None;
        }
        let st = [
            f64::from(uv[0]) * f64::from(res),
            f64::from(uv[1]) * f64::from(res),
        ];
        let i = (st[0].floor() as i64).clamp(0, i64::from(res) - 1) as usize;
        let j = (st[1].floor() as i64).clamp(0, i64::from(res) - 1) as usize;
        Some((j * res as usize + i, st))
    };
    // Pixel pairs on one surface and whether they straddle a boundary.
    let mut pairs: Vec<(usize, usize, bool)> = Vec::new();
    let (w, h) = (width as usize, height as usize);
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            for q in [(x + 1 < w).then(|| p + 1), (y + 1 < h).then(|| p + w)]
                .into_iter()
                .flatten()
            {
                let (Some((tp, sp)), Some((tq, sq))) = (texel(p), texel(q)) else {
                    continue;
                };
                let (np, nq) = (gbuffer.vertex_normal.rgba[p], gbuffer.vertex_normal.rgba[q]);
                let same_plane = (0..3).map(|c| np[c] * nq[c]).sum::<f32>() > 0.999;
                let near_in_uv = (sp[0] - sq[0]).hypot(sp[1] - sq[1]) < 2.0;
                if same_plane && near_in_uv {
                    pairs.push((p, q, model.cluster_of[tp] != model.cluster_of[tq]));
                }
            }
        }
    }
    let mut rows = Vec::new();
    for seams in SeamMode::ALL {
        let t = with_seams(technique, seams);
        let image = render(t)?;
        let (mut boundary, mut interior) = (Vec::new(), Vec::new());
        for &(p, q, across) in &pairs {
            if image.rgba[p][3] == 0.0 || image.rgba[q][3] == 0.0 {
                continue;
            }
            let (tp, tq) = (luminance(truth.rgba[p]), luminance(truth.rgba[q]));
            let jump = (luminance(image.rgba[p]) - luminance(image.rgba[q])) - (tp - tq);
            let d = jump.abs() / mean_luminance;
            if across {
                boundary.push(d)
            } else {
                interior.push(d)
            }
        }
        rows.push(SeamRow {
            technique: t,
            path,
            boundary: PairStats::of(boundary),
            interior: PairStats::of(interior),
        });
    }
    Ok(rows)
}

/// The rows as a markdown table.
pub fn to_markdown(rows: &[SeamRow], width: u32, height: u32) -> String {
    use std::fmt::Write as _;
    let mut s = format!(
        "Seams at cluster boundaries, {width}×{height}: |ΔY − ΔY_unc6| / mean Y_unc6 over adjacent \
         pixel pairs on one surface\n\n\
         | technique | path | boundary pairs | mean | p99 | max | interior pairs | mean | p99 | max |\n\
         |---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n"
    );
    for r in rows {
        let (b, i) = (r.boundary, r.interior);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.4} | {:.4} | {:.4} | {} | {:.4} | {:.4} | {:.4} |",
            r.technique, r.path, b.pairs, b.mean, b.p99, b.max, i.pairs, i.mean, i.p99, i.max
        );
    }
    s
}
/// `technique` (a clustered one) crossing cluster boundaries by `seams`.
fn with_seams(technique: Technique, seams: SeamMode) -> Technique {
    if let Technique::Vq(vq) = technique {
        return Vq { seams, ..vq }.into();
    }
    if let Technique::Cpca(cpca) = technique {
        return Cpca { seams, ..cpca }.into();
    }
    technique
}
