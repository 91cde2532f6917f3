//! Diffuse techniques under NDF filtering against the footprint reference (part of
//! `shvis study ndf`).
//!
//! Per scene (the receding bumpy plane, the house): `unc6` / `preconv` and their NDF
//! variants (`technique::ndf_diffuse`) on each path, the footprint reference of the direct
//! light (`crate::reference`), and the normal map's level of detail per pixel
//! (`render::specular::normal_map_lod`). Errors are relative RMSE over the pixels where the map
//! is minified at least 4× (λ ≥ 2), over the magnified ones (λ ≤ 0), and over all; on the
//! magnified pixels the largest difference between a technique and its NDF variant is
//! reported too (the filter must change nothing there).

use std::sync::Arc;

use serde::Serialize;

use crate::gpu::Context;
use crate::prepare::{PrepareSettings, prepare};
use crate::reference::{ReferenceSettings, render_reference};
use crate::render::{Frame, FrameSettings, SceneGpu};
use crate::technique::{self, HwPath, NdfBase, Technique};

/// Side in pixels of the blocks of the block errors.
pub const BLOCK: usize = 8;

/// Pixels with λ at least this are "minified" (2^λ texels across a pixel).
pub const MINIFIED_LOD: f32 = 2.0;

/// How the diffuse part runs.
#[derive(Clone, Debug)]
pub struct DiffuseSettings {
    pub scenes: Vec<String>,
    /// The environment (`env::resolve`: `sky`, `sky:DEG` or a file).
    pub env: String,
    pub width: u32,
    pub height: u32,
    pub ref_spp: u32,
    pub vis_res: u32,
    pub paths: Vec<HwPath>,
    pub cache_dir: Option<std::path::PathBuf>,
    /// Sub-pixel strata per side of the techniques' own footprint truth.
    pub strata_side: u32,
    /// Where the images go (`diffuse_{scene}_{technique}.{path}_{mip,ndf,own}.exr`, the
    /// reference as `diffuse_{scene}_reference.exr`; `{scene}_{env}` for an environment
    /// other than `sky`); `None` writes none.
    pub image_dir: Option<std::path::PathBuf>,
}

/// One technique and its NDF variant on one path and scene.
#[derive(Clone, Debug, Serialize)]
pub struct DiffuseRow {
    pub scene: String,
    /// The environment's short name ([`env_label`]).
    pub env: String,
    pub technique: Technique,
    pub path: HwPath,
    /// Relative RMSE against the footprint reference: unfiltered / NDF, minified pixels.
    pub minified: [f64; 2],
    /// The same over magnified pixels and over all covered pixels.
    pub magnified: [f64; 2],
    pub all: [f64; 2],
    /// max |NDF − unfiltered| / max reference, over magnified pixels.
    pub magnified_max_change: f64,
    /// Relative RMSE against the technique's own footprint truth (its shading of the
    /// full-resolution normal map averaged over jittered sub-pixel renders): the
    /// normal-map filtering error alone, unfiltered / NDF, minified pixels.
    pub own_footprint_minified: [f64; 2],
    /// The same after averaging both images over blocks of [`BLOCK`]² pixels (blocks
    /// wholly minified): the systematic part, without the truth's sub-pixel sampling noise.
    pub own_footprint_blocks: [f64; 2],
    /// Against the footprint reference over the same blocks (its Monte Carlo noise
    /// averaged down).
    pub reference_blocks: [f64; 2],
    /// Texture fetches per pixel: unfiltered / NDF.
    pub lookups: [u32; 2],
}

/// Pixel counts of a scene's masks.
#[derive(Clone, Debug, Serialize)]
pub struct DiffuseScene {
    pub scene: String,
    pub env: String,
    pub minified_pixels: usize,
    pub magnified_pixels: usize,
    pub covered_pixels: usize,
    pub reference_rel_noise: f64,
    /// ‖footprint − point reference‖ / ‖footprint‖ over minified pixels: what integrating
    /// the footprint changes in the ground truth (normal-map filtering among it).
    pub footprint_step: f64,
}

/// What stops the diffuse comparison.
#[derive(Debug, thiserror::Error)]
pub enum DiffuseStudyError {
    #[error(transparent)]
    Prepare(#[from] crate::prepare::PrepareError),
    #[error(transparent)]
    Technique(#[from] technique::TechniqueError),
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    #[error(transparent)]
    Report(#[from] crate::report::ReportError),
}

/// An environment's short name: `sky`/`sky:DEG` as given, a file by its stem.
pub fn env_label(env: &str) -> String {
    if env.starts_with("sky") {
        return env.to_string();
    }
    std::path::Path::new(env.trim_start_matches("angular:"))
        .file_stem()
        .map_or_else(|| env.to_string(), |s| s.to_string_lossy().into_owned())
}

/// The name of a scene × environment's images (`diffuse_{tag}_…`): the scene's file stem,
/// with the environment's for any but the default sky, file-safe (letters, digits, `_`).
pub fn image_tag(scene: &str, env: &str) -> String {
    let scene = super::rnm::env_stem(scene);
    if env_label(env) == "sky" {
        scene
    } else {
        format!("{scene}_{}", super::rnm::env_stem(env))
    }
}

/// Relative RMSE of `test` against `reference` over `mask`.
fn rel_rmse(test: &Frame, reference: &Frame, mask: &[bool]) -> f64 {
    let (mut se, mut sq) = (0.0, 0.0);
    for ((t, r), _) in test
        .rgba
        .iter()
        .zip(&reference.rgba)
        .zip(mask)
        .filter(|(_, m)| **m)
    {
        for c in 0..3 {
            se += (f64::from(t[c]) - f64::from(r[c])).powi(2);
            sq += f64::from(r[c]).powi(2);
        }
    }
    if sq > 0.0 { (se / sq).sqrt() } else { f64::NAN }
}

/// Relative RMSE of `test` against `reference` after averaging both over [`BLOCK`]²
/// pixel blocks lying wholly in `mask`.
fn block_rel_rmse(test: &Frame, reference: &Frame, mask: &[bool]) -> f64 {
    let (w, h) = (reference.width as usize, reference.height as usize);
    let (mut se, mut sq) = (0.0, 0.0);
    for by in 0..h / BLOCK {
        for bx in 0..w / BLOCK {
            let pixels: Vec<usize> = (0..BLOCK * BLOCK)
                .map(|k| (by * BLOCK + k / BLOCK) * w + bx * BLOCK + k % BLOCK)
                .collect();
            if !pixels.iter().all(|&i| mask[i]) {
                continue;
            }
            for c in 0..3 {
                let mean = |f: &Frame| pixels.iter().map(|&i| f64::from(f.rgba[i][c])).sum::<f64>();
                let (t, r) = (mean(test), mean(reference));
                se += (t - r).powi(2);
                sq += r * r;
            }
        }
    }
    if sq > 0.0 { (se / sq).sqrt() } else { f64::NAN }
}

/// `tech` on `scene` (built with `material_level0`) averaged over `side`² jittered
/// sub-pixel positions: the technique's shading integrated over each pixel's footprint with
/// the full-resolution normal map. Pixels some stratum misses are uncovered.
pub fn own_footprint(
    scene: &mut SceneGpu,
    tech: &technique::TechniqueGpu,
    side: u32,
) -> Result<Frame, crate::gpu::GpuError> {
    let count = side * side;
    let mut sum: Vec<[f64; 4]> = Vec::new();
    for j in 0..count {
        scene.set_jitter(crate::reference::specular::stratum_jitter(7, j, side))?;
        let frame = tech.render(scene, 0, 1)?;
        sum.resize(frame.rgba.len(), [0.0; 4]);
        for (acc, p) in sum.iter_mut().zip(&frame.rgba) {
            if p[3] > 0.5 {
                for c in 0..3 {
                    acc[c] += f64::from(p[c]);
                }
                acc[3] += 1.0;
            }
        }
    }
    scene.set_jitter([0.0, 0.0])?;
    let (w, h) = (scene.target().width(), scene.target().height());
    Ok(Frame {
        width: w,
        height: h,
        rgba: sum
            .iter()
            .map(|a| {
                let k = a[3].max(1.0);
                let covered = if a[3] >= f64::from(count) { 1.0 } else { 0.0 };
                [
                    (a[0] / k) as f32,
                    (a[1] / k) as f32,
                    (a[2] / k) as f32,
                    covered,
                ]
            })
            .collect(),
        ms: Vec::new(),
    })
}

/// Runs the diffuse comparison on every scene of `s`.
pub fn run(
    ctx: &Arc<Context>,
    s: &DiffuseSettings,
) -> Result<(Vec<DiffuseScene>, Vec<DiffuseRow>), DiffuseStudyError> {
    let bases = [
        NdfBase::Unc {
            order: crate::sh::Order::SIX,
        },
        NdfBase::Preconv,
    ];
    let techniques: Vec<Technique> = bases
        .iter()
        .flat_map(|&base| {
            [
                base.technique(),
                Technique::Ndf(crate::technique::Ndf { base }),
            ]
        })
        .collect();
    let (mut scenes, mut rows) = (Vec::new(), Vec::new());
    let env = env_label(&s.env);
    for name in &s.scenes {
        let tag = image_tag(name, &s.env);
        let mut prepared = prepare(&PrepareSettings {
            scene: name.clone(),
            env: s.env.clone(),
            vis_res: s.vis_res,
            cache_dir: s.cache_dir.clone(),
            ..PrepareSettings::default()
        })?;
        prepared.prepare_techniques(&techniques)?;
        let reference_settings = ReferenceSettings::footprint_direct(s.width, s.height, s.ref_spp);
        let reference = render_reference(ctx, &prepared.scene, &prepared.env, &reference_settings)?;
        let point = render_reference(
            ctx,
            &prepared.scene,
            &prepared.env,
            &ReferenceSettings {
                footprint: false,
                ..reference_settings
            },
        )?;
        let gpu = SceneGpu::new(
            ctx,
            &prepared.scene,
            &FrameSettings {
                width: s.width,
                height: s.height,
                ..FrameSettings::default()
            },
        )?;
        let mut level0 = SceneGpu::new(
            ctx,
            &prepared.scene,
            &FrameSettings {
                width: s.width,
                height: s.height,
                material_level0: true,
                ..FrameSettings::default()
            },
        )?;
        let lod = crate::render::specular::normal_map_lod(ctx, &gpu)?;
        let covered: Vec<bool> = lod
            .iter()
            .zip(&reference.frame.rgba)
            .map(|(l, r)| l.is_some() && r[3] > 0.5)
            .collect();
        let mask = |keep: fn(f32) -> bool| -> Vec<bool> {
            lod.iter()
                .zip(&covered)
                .map(|(l, &c)| c && l.is_some_and(keep))
                .collect()
        };
        let minified = mask(|l| l >= MINIFIED_LOD);
        let magnified = mask(|l| l <= 0.0);
        if let Some(dir) = &s.image_dir {
            crate::report::image::write_exr(
                &dir.join(format!("diffuse_{tag}_reference.exr")),
                &reference.frame,
            )?;
        }
        let count = |m: &[bool]| m.iter().filter(|&&b| b).count();
        scenes.push(DiffuseScene {
            scene: name.clone(),
            env: env.clone(),
            minified_pixels: count(&minified),
            magnified_pixels: count(&magnified),
            covered_pixels: count(&covered),
            reference_rel_noise: reference.rel_noise,
            footprint_step: rel_rmse(&point.frame, &reference.frame, &minified),
        });
        let peak = reference
            .frame
            .rgba
            .iter()
            .flat_map(|p| p[..3].iter().copied())
            .fold(0.0f32, f32::max)
            .max(1e-12);
        let inputs = prepared.inputs();
        let view = SceneView {
            name,
            env: &env,
            tag: &tag,
            gpu: &gpu,
            reference: &reference.frame,
            covered: &covered,
            minified: &minified,
            magnified: &magnified,
            peak,
        };
        for &base in &bases {
            for &path in &s.paths {
                rows.push(compare_pair(
                    ctx,
                    &view,
                    &mut level0,
                    &inputs,
                    base,
                    path,
                    s,
                )?);
            }
        }
    }
    Ok((scenes, rows))
}

/// What each technique pair on one scene is measured against: the scene's GPU scene, its
/// footprint reference and pixel masks, and the names its rows and images carry.
struct SceneView<'a> {
    name: &'a str,
    env: &'a str,
    /// The scene's image name ([`DiffuseSettings::image_dir`]).
    tag: &'a str,
    gpu: &'a SceneGpu,
    reference: &'a Frame,
    covered: &'a [bool],
    minified: &'a [bool],
    magnified: &'a [bool],
    /// The reference's largest channel value (at least 1e-12).
    peak: f32,
}

/// Renders `base`'s technique and its NDF variant on `path` and measures both against the
/// footprint reference and the technique's own footprint truth (rendered on `level0`),
/// writing the images where `s` asks; one row.
fn compare_pair(
    ctx: &Arc<Context>,
    view: &SceneView<'_>,
    level0: &mut SceneGpu,
    inputs: &technique::Inputs<'_>,
    base: NdfBase,
    path: HwPath,
    s: &DiffuseSettings,
) -> Result<DiffuseRow, DiffuseStudyError> {
    let SceneView {
        name,
        env,
        tag,
        gpu,
        reference,
        covered,
        minified,
        magnified,
        peak,
    } = *view;
    let pair = [
        base.technique(),
        Technique::Ndf(crate::technique::Ndf { base }),
    ];
    let mut frames = Vec::new();
    let mut lookups = [0; 2];
    for (k, &t) in pair.iter().enumerate() {
        let tech = technique::build(ctx, gpu, t, path, inputs)?;
        lookups[k] = tech.stats.lookups_per_pixel;
        frames.push(tech.render(gpu, 0, 1)?);
    }
    let pick = |m: &[bool]| -> [f64; 2] { [0, 1].map(|k| rel_rmse(&frames[k], reference, m)) };
    let truth_tech = technique::build(ctx, level0, base.technique(), path, inputs)?;
    let truth = own_footprint(level0, &truth_tech, s.strata_side)?;
    let own_mask: Vec<bool> = minified
        .iter()
        .zip(&truth.rgba)
        .map(|(&m, t)| m && t[3] > 0.5)
        .collect();
    let own = [0, 1].map(|k| rel_rmse(&frames[k], &truth, &own_mask));
    if let Some(dir) = &s.image_dir {
        let stem = format!("diffuse_{tag}_{}.{path}", base.technique());
        for (frame, kind) in [(&frames[0], "mip"), (&frames[1], "ndf"), (&truth, "own")] {
            crate::report::image::write_exr(&dir.join(format!("{stem}_{kind}.exr")), frame)?;
        }
    }
    let change = frames[0]
        .rgba
        .iter()
        .zip(&frames[1].rgba)
        .zip(magnified)
        .filter(|(_, m)| **m)
        .flat_map(|((a, b), _)| (0..3).map(move |c| (a[c] - b[c]).abs()))
        .fold(0.0f32, f32::max);
    Ok(DiffuseRow {
        scene: name.to_string(),
        env: env.to_string(),
        technique: base.technique(),
        path,
        minified: pick(minified),
        magnified: pick(magnified),
        all: pick(covered),
        magnified_max_change: f64::from(change / peak),
        own_footprint_minified: own,
        own_footprint_blocks: [0, 1].map(|k| block_rel_rmse(&frames[k], &truth, &own_mask)),
        reference_blocks: [0, 1].map(|k| block_rel_rmse(&frames[k], reference, minified)),
        lookups,
    })
}

/// "before → after" of an (unfiltered, NDF) pair.
pub fn arrow(pair: [f64; 2]) -> String {
    if pair.iter().all(|v| v.is_nan()) {
        // No pixel of that kind in the view.
        return "—".to_string();
    }
    format!("{:.4} → {:.4}", pair[0], pair[1])
}

/// The markdown section of the diffuse rows.
pub fn markdown(scenes: &[DiffuseScene], rows: &[DiffuseRow]) -> String {
    let mut md = String::from(
        "\n## Diffuse techniques under NDF filtering (`--normal-filter ndf`)\n\n\
         Relative RMSE, unfiltered → NDF variant, against the footprint reference (direct \
         light) over pixels where the normal map is minified ≥ 4× (λ ≥ 2), magnified \
         (λ ≤ 0) and all, and against the technique's own footprint truth (its shading of \
         the full-resolution normal map averaged over 16² jittered sub-pixel renders: the \
         normal-map filtering error alone); `8² blocks`: both images averaged over 8×8-pixel \
         blocks first (the systematic part, without sampling noise). On magnified pixels the \
         largest change the filter makes (÷ the reference's peak).\n\n",
    );
    for s in scenes {
        md.push_str(&format!(
            "- `{}` under `{}`: {} covered pixels, {} minified, {} magnified; reference noise {:.4}\n",
            s.scene, s.env, s.covered_pixels, s.minified_pixels, s.magnified_pixels, s.reference_rel_noise
        ));
    }
    md.push_str(
        "\n| scene | env | technique | path | minified | minified, 8² blocks | magnified | all | own footprint, minified | own footprint, 8² blocks | max change (magnified) | lookups/px |\n\
         |---|---|---|---|---|---|---|---|---|---|---:|---|\n",
    );
    for r in rows {
        md.push_str(&format!(
            "| {} | {} | {} → {}ndf | {} | {} | {} | {} | {} | {} | {} | {:.1e} | {} → {} |\n",
            r.scene,
            r.env,
            r.technique,
            r.technique,
            r.path,
            arrow(r.minified),
            arrow(r.reference_blocks),
            arrow(r.magnified),
            arrow(r.all),
            arrow(r.own_footprint_minified),
            arrow(r.own_footprint_blocks),
            r.magnified_max_change,
            r.lookups[0],
            r.lookups[1]
        ));
    }
    md
}
