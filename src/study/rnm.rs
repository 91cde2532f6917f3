//! Radiosity normal mapping against real micro-geometry (`shvis study rnm`).
//!
//! For one scene with a height-mapped material (default `patio`) and each environment:
//!
//! 1. the flat scene with its normal map is prepared and baked as for `bench` (SH lightmap
//!    with `bounces` of inter-reflection and the `rnm` lightmaps with it; SSBump and AO of
//!    the height field), and `rnm`, `rnmao`, `ssbump`, `shlmap`, `unc6` render it on each
//!    path;
//! 2. two references from the same camera: the **flat** scene (normal map, footprint
//!    integrated) — what each technique approximates — and the **displaced** scene
//!    ([`crate::scene::displace`]: the bricks as geometry) — what it should look like, the
//!    self-shadowing included;
//! 3. each technique's relative RMSE against both, each reference with the light model
//!    the technique bakes (`shlmap` and the `rnm` family: `bounces` of inter-reflection;
//!    `unc6`: direct light, [`Technique::reference`]).
//!
//! It writes `rnm.md`, `rnm.json` and per environment the paper's Fig. 1 composite
//! `fig1_<env>.png`: normal mapped (`rnm`) · with AO (`rnmao`) · self-shadowed (`ssbump`)
//! · displaced reference, left to right.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::Serialize;

use super::report::{StudyReport, pretty_json};
use crate::gpu::{Context, GpuError};
use crate::prepare::{PrepareError, PrepareSettings, prepare};
use crate::reference::{ReferenceImage, ReferenceSettings, render_reference};
use crate::render::{Frame, FrameSettings, SceneGpu};
use crate::report::ReportError;
use crate::report::metrics::image_error;
use crate::scene::displace::{DisplaceError, displace};
use crate::technique::{self, HwPath, ReferenceModel, Technique, TechniqueError};

/// The techniques compared, in table order.
pub const STUDY_TECHNIQUES: [&str; 5] = ["rnm", "rnmao", "ssbump", "shlmap", "unc6"];

/// The Fig. 1 panels, left to right (the displaced reference follows).
const FIGURE_TECHNIQUES: [&str; 3] = ["rnm", "rnmao", "ssbump"];

/// How the study runs.
#[derive(Clone, Debug)]
pub struct RnmStudySettings {
    pub scene: String,
    pub vis_res: u32,
    pub rays: u32,
    pub seed: u64,
    pub bounces: u32,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel of both references.
    pub spp: u32,
    pub paths: Vec<HwPath>,
    pub cache_dir: Option<PathBuf>,
}

/// One technique on one path under one environment.
#[derive(Clone, Debug, Serialize)]
pub struct RnmRow {
    pub env: String,
    pub technique: Technique,
    pub path: HwPath,
    /// `direct` or `bounced`: the light model of both references it is compared with.
    pub light_model: &'static str,
    /// Relative RMSE against the displaced-geometry reference.
    pub vs_displaced: f64,
    /// Relative RMSE against the flat, normal-mapped reference.
    pub vs_flat: f64,
}

/// The study's result for one environment.
#[derive(Clone, Debug, Serialize)]
pub struct EnvResult {
    pub env: String,
    pub rows: Vec<RnmRow>,
    /// Relative noise of the references' bounced images.
    pub displaced_noise: f64,
    pub flat_noise: f64,
    pub displaced_triangles: usize,
    pub seconds: f64,
    #[serde(skip)]
    pub figure: Option<Frame>,
}

/// Errors of the study, one line each.
#[derive(Debug, thiserror::Error)]
pub enum RnmStudyError {
    #[error(transparent)]
    Prepare(#[from] PrepareError),
    #[error(transparent)]
    Technique(#[from] TechniqueError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Displace(#[from] DisplaceError),
    #[error(transparent)]
    Report(#[from] ReportError),
    #[error("{0}: no pixel is covered in both the image and the reference")]
    NoOverlap(String),
}

/// Runs the study under environment `env` (a `--env` name).
pub fn run_env(
    ctx: &Arc<Context>,
    env: &str,
    settings: &RnmStudySettings,
) -> Result<EnvResult, RnmStudyError> {
    let started = std::time::Instant::now();
    let techniques: Vec<Technique> = STUDY_TECHNIQUES
        .iter()
        .map(|t| t.parse().expect("a valid name"))
        .collect();
    let mut prepared = prepare(&PrepareSettings {
        scene: settings.scene.clone(),
        env: env.to_string(),
        vis_res: settings.vis_res,
        rays: settings.rays,
        seed: settings.seed,
        sh_lightmap_bounces: Some(settings.bounces),
        cache_dir: settings.cache_dir.clone(),
        ..PrepareSettings::default()
    })?;
    prepared.prepare_techniques(&techniques)?;
    let reference_settings = ReferenceSettings {
        width: settings.width,
        height: settings.height,
        spp: settings.spp,
        seed: settings.seed,
        bounces: settings.bounces,
        footprint: true,
    };
    let displaced_scene = displace(&prepared.scene)?;
    let displaced = render_reference(ctx, &displaced_scene, &prepared.env, &reference_settings)?;
    let flat = render_reference(ctx, &prepared.scene, &prepared.env, &reference_settings)?;
    let frame_settings = FrameSettings {
        width: settings.width,
        height: settings.height,
        ..FrameSettings::default()
    };
    let scene_gpu = SceneGpu::new(ctx, &prepared.scene, &frame_settings)?;
    let inputs = prepared.inputs();
    let mut rows = Vec::new();
    let mut panels: Vec<Option<Frame>> = vec![None; FIGURE_TECHNIQUES.len()];
    for &technique in &techniques {
        for &path in &settings.paths {
            let label = format!("{technique}.{path}");
            let built = technique::build(ctx, &scene_gpu, technique, path, &inputs)?;
            let frame = built.render(&scene_gpu, 1, 1)?;
            let (light_model, pick) = match technique.reference() {
                ReferenceModel::Direct => ("direct", direct_frame as fn(&ReferenceImage) -> &Frame),
                ReferenceModel::InterReflected => {
                    ("bounced", bounced_frame as fn(&ReferenceImage) -> &Frame)
                }
            };
            let error = |reference: &ReferenceImage| {
                image_error(&frame, pick(reference))
                    .map(|e| e.rel_rmse)
                    .ok_or_else(|| RnmStudyError::NoOverlap(label.clone()))
            };
            rows.push(RnmRow {
                env: env.to_string(),
                technique,
                path,
                light_model,
                vs_displaced: error(&displaced)?,
                vs_flat: error(&flat)?,
            });
            let name = technique.name();
            if let Some(k) = FIGURE_TECHNIQUES.iter().position(|&t| t == name)
                && (panels[k].is_none() || path == HwPath::Dx10)
            {
                panels[k] = Some(frame);
            }
        }
    }
    let mut figure_frames: Vec<&Frame> = panels.iter().flatten().collect();
    figure_frames.push(bounced_frame(&displaced));
    let figure = (figure_frames.len() == FIGURE_TECHNIQUES.len() + 1)
        .then(|| super::side_by_side(&figure_frames));
    Ok(EnvResult {
        env: env.to_string(),
        rows,
        displaced_noise: bounced_noise(&displaced),
        flat_noise: bounced_noise(&flat),
        displaced_triangles: displaced_scene.mesh.triangle_count(),
        seconds: started.elapsed().as_secs_f64(),
        figure,
    })
}

fn direct_frame(r: &ReferenceImage) -> &Frame {
    &r.frame
}

fn bounced_frame(r: &ReferenceImage) -> &Frame {
    r.bounced.as_ref().map_or(&r.frame, |b| &b.frame)
}

fn bounced_noise(r: &ReferenceImage) -> f64 {
    r.bounced.as_ref().map_or(r.rel_noise, |b| b.rel_noise)
}

/// A file-name-safe stem of an `--env` name: "sky:15" → "sky15", a path → its file stem.
pub fn env_stem(env: &str) -> String {
    let stem = Path::new(env)
        .file_stem()
        .map_or(env.to_string(), |s| s.to_string_lossy().into_owned());
    stem.chars()
        .filter(|c| c.is_ascii_alphanumeric() || *c == '_')
        .collect()
}

/// The Fig. 1 composites an earlier run wrote into `dir`: one `fig1_<env>.png` per
/// environment its `rnm.json` lists (none where there is no such report: a folder's other
/// files are not the study's to remove).
pub fn earlier_figures(dir: &Path) -> Vec<PathBuf> {
    let Ok(bytes) = crate::files::read_bounded(&dir.join("rnm.json"), 1 << 24, "rnm.json") else {
        return Vec::new();
    };
    let Ok(serde_json::Value::Array(results)) = serde_json::from_slice(&bytes) else {
        return Vec::new();
    };
    results
        .iter()
        .filter_map(|r| r.get("env")?.as_str())
        .map(|env| dir.join(format!("fig1_{}.png", env_stem(env))))
        .collect()
}

/// Writes the Fig. 1 composites, then the report `rnm.md`, `rnm.json`
/// ([`super::report::write`]) into `dir`; returns the paths.
pub fn write_report(
    results: &[EnvResult],
    settings: &RnmStudySettings,
    device: &str,
    dir: &Path,
    exposure_ev: f32,
) -> Result<Vec<PathBuf>, ReportError> {
    let mut written = Vec::new();
    let mut md = format!(
        "# Radiosity normal mapping against real micro-geometry\n\n\
         Scene `{}` ({}² lightmap, {} rays, {} bounces), {}×{}, references {} spp \
         (footprint), device {device}. Relative RMSE of each technique against the \
         displaced-geometry reference (the truth) and against the flat normal-mapped \
         reference (what it approximates), each with the technique's light model.\n",
        settings.scene,
        settings.vis_res,
        settings.rays,
        settings.bounces,
        settings.width,
        settings.height,
        settings.spp
    );
    for r in results {
        md.push_str(&format!(
            "\n## `{}`\n\nDisplaced reference: {} triangles, noise {:.4}; flat reference noise {:.4}; {:.0} s.\n\n\
             | technique | path | light | vs displaced | vs flat |\n|---|---|---|---:|---:|\n",
            r.env, r.displaced_triangles, r.displaced_noise, r.flat_noise, r.seconds
        ));
        for row in &r.rows {
            md.push_str(&format!(
                "| {} | {} | {} | {:.4} | {:.4} |\n",
                row.technique, row.path, row.light_model, row.vs_displaced, row.vs_flat
            ));
        }
        if let Some(fig) = &r.figure {
            let path = dir.join(format!("fig1_{}.png", env_stem(&r.env)));
            crate::report::image::write_frame(&path, fig, exposure_ev)?;
            md.push_str(&format!(
                "\n![rnm · rnmao · ssbump · displaced reference]({})\n",
                path.file_name()
                    .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
            ));
            written.push(path);
        }
    }
    let study_report = StudyReport {
        stem: "rnm",
        json: Some(pretty_json(dir, "rnm", &results)?),
        markdown: md,
    };
    written.extend(super::report::write(dir, &study_report)?);
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn earlier_figures_are_those_the_earlier_report_lists() {
        let dir = std::env::temp_dir().join(format!("shvis-rnm-earlier-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        assert!(
            earlier_figures(&dir).is_empty(),
            "no report, nothing of the study's"
        );
        std::fs::write(
            dir.join("rnm.json"),
            r#"[{"env": "sky:15", "rows": []}, {"env": "a/studio.exr", "rows": []}]"#,
        )
        .unwrap();
        assert_eq!(
            earlier_figures(&dir),
            [dir.join("fig1_sky15.png"), dir.join("fig1_studio.png")]
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn env_stems_are_file_safe() {
        assert_eq!(env_stem("sky:15"), "sky15");
        assert_eq!(
            env_stem("../shared/assets/env/potsdamer_platz_1k.exr"),
            "potsdamer_platz_1k"
        );
    }
}
