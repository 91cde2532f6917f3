//! GPU normal-map generation measured (`shvis study normalmap`).
//!
//! 1. **Timings like the paper's Tables 1 and 2**: generation time of the GPU method
//!    ([`crate::normalmap::gpu`]) and of the CPU ray caster ([`crate::normalmap::cpu`])
//!    against the high and low triangle counts (icospheres: high 20k–328k, low 80–1280, at
//!    one resolution) and against the resolution (128²–2048²), medians of `repeats` runs;
//!    and the draw strategies (one multi-draw indirect or one draw per low triangle, with
//!    and without culling) on one pair.
//! 2. **A real model** simplified to a few per cent of its triangles: angular difference
//!    of the GPU map to the CPU map with rays along the interpolated normal (the software
//!    bakers' way) and along the face normal (the GPU's projection direction — what is
//!    left is the method, not the direction).
//! 3. **Rendering**: the generated map on the low mesh through `unc6`, and the flat
//!    low mesh (interpolated normals), each against `shvis reference` of the *high* mesh
//!    from the same camera, the high mesh's own material textures replaced by white and
//!    flat so only geometry differs.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

use super::report::{StudyReport, pretty_json};
use crate::gpu::Context;
use crate::normalmap::cpu::{self, RayDirection};
use crate::normalmap::simplify::{simplify, sphere_high, sphere_low};
use crate::normalmap::{self, AngleStats, DrawMode, NormalMapError, NormalMapSettings, output};
use crate::prepare::{PrepareError, PrepareSettings, prepare};
use crate::reference::{ReferenceSettings, render_reference};
use crate::render::{FrameSettings, SceneGpu};
use crate::report::ReportError;
use crate::report::metrics::image_error;
use crate::scene::Texture8;
use crate::technique::{self, HwPath, Technique, TechniqueError};

/// How the study runs.
#[derive(Clone, Debug)]
pub struct NormalMapStudySettings {
    /// Runs per timing (the median is reported).
    pub repeats: u32,
    /// Map side of Table 1 and of the strategy table.
    pub res: u32,
    /// The real model (a glTF file); `None` skips parts 2 and 3.
    pub model: Option<PathBuf>,
    /// Fractions of the model's triangles kept by simplification.
    pub ratios: Vec<f32>,
    /// Map side for the model.
    pub model_res: u32,
    /// Rendering (part 3).
    pub env: String,
    pub vis_res: u32,
    pub rays: u32,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub paths: Vec<HwPath>,
}

/// One timed configuration.
#[derive(Clone, Debug, Serialize)]
pub struct TimingRow {
    pub table: &'static str,
    pub high_triangles: usize,
    pub low_triangles: usize,
    pub res: u32,
    pub draws: DrawMode,
    pub cull: bool,
    /// Median wall time of the whole GPU bake (culling, uploads, pipelines, the command
    /// buffer, readback), seconds.
    pub gpu_total_s: f64,
    /// Median time of the one command buffer, submission to readback, seconds.
    pub gpu_execute_s: f64,
    /// Median GPU timestamps of the projection pass, ms (`None` without timestamps).
    pub gpu_project_ms: Option<f64>,
    /// High triangles drawn, summed over the low triangles.
    pub triangles_drawn: u64,
    /// Median wall time of the CPU baker, seconds (`None`: not run for this row).
    pub cpu_total_s: Option<f64>,
}

/// The GPU map of a real model against the CPU maps.
#[derive(Clone, Debug, Serialize)]
pub struct ModelRow {
    pub model: String,
    pub ratio: f32,
    pub high_triangles: usize,
    pub low_triangles: usize,
    pub res: u32,
    pub max_distance: f32,
    /// Interior texels, GPU vs CPU with interpolated-normal rays.
    pub vs_cpu: Option<AngleStats>,
    /// Interior texels, GPU vs CPU with face-normal rays.
    pub vs_cpu_face: Option<AngleStats>,
    pub gpu_s: f64,
    pub cpu_s: f64,
    /// Relative RMSE against the high mesh's reference, per path: (path, with the map,
    /// flat low mesh).
    pub render: Vec<(HwPath, f64, f64)>,
    pub reference_noise: Option<f64>,
}

/// Everything the study measured.
#[derive(Clone, Debug, Serialize)]
pub struct NormalMapStudy {
    pub device: String,
    pub timings: Vec<TimingRow>,
    pub models: Vec<ModelRow>,
}

/// Why the study failed.
#[derive(Debug, thiserror::Error)]
pub enum NormalMapStudyError {
    #[error(transparent)]
    NormalMap(#[from] NormalMapError),
    #[error(transparent)]
    Prepare(#[from] PrepareError),
    #[error(transparent)]
    Technique(#[from] TechniqueError),
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    #[error(transparent)]
    Report(#[from] ReportError),
    #[error("{0}")]
    Scene(#[from] crate::scene::SceneError),
    #[error("{0}: the low-mesh render and the high-mesh reference share no pixel")]
    NoOverlap(String),
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Times one configuration (`with_cpu`: the CPU baker too).
fn time_pair(
    ctx: &Arc<Context>,
    table: &'static str,
    (high, low): (&crate::scene::Mesh, &crate::scene::Mesh),
    settings: &NormalMapSettings,
    repeats: u32,
    with_cpu: bool,
) -> Result<TimingRow, NormalMapStudyError> {
    let (mut total, mut execute, mut project) = (Vec::new(), Vec::new(), Vec::new());
    let mut drawn = 0;
    for _ in 0..repeats.max(1) {
        let (_, t) = normalmap::gpu::bake(ctx, high, low, settings)?;
        total.push(t.total_s);
        execute.push(t.execute_s);
        if let Some(ms) = t.gpu_ms {
            project.push(ms.project);
        }
        drawn = t.triangles_drawn;
    }
    let cpu_total_s = if with_cpu {
        let mut runs = Vec::new();
        for _ in 0..repeats.max(1) {
            runs.push(
                cpu::bake(high, low, settings, RayDirection::Interpolated)?
                    .1
                    .total_s,
            );
        }
        Some(median(runs))
    } else {
        None
    };
    Ok(TimingRow {
        table,
        high_triangles: high.triangle_count(),
        low_triangles: low.triangle_count(),
        res: settings.res,
        draws: settings.draws,
        cull: settings.cull,
        gpu_total_s: median(total),
        gpu_execute_s: median(execute),
        gpu_project_ms: (!project.is_empty()).then(|| median(project)),
        triangles_drawn: drawn,
        cpu_total_s,
    })
}

/// Part 1 (module doc), printing each row as it is measured.
pub fn timings(
    ctx: &Arc<Context>,
    s: &NormalMapStudySettings,
) -> Result<Vec<TimingRow>, NormalMapStudyError> {
    let mut rows = Vec::new();
    let mut push = |row: TimingRow| {
        let _ = crate::files::stdout::print_line(format_args!(
            "  {} high {} low {} {}² {:?} cull {}: gpu {:.3} s (execute {:.3} s), cpu {}",
            row.table,
            row.high_triangles,
            row.low_triangles,
            row.res,
            row.draws,
            row.cull,
            row.gpu_total_s,
            row.gpu_execute_s,
            row.cpu_total_s.map_or("-".into(), |c| format!("{c:.3} s"))
        ));
        rows.push(row);
    };
    let highs: Vec<_> = [5, 6, 7].map(|l| sphere_high(l, 1.0)).into();
    for high in &highs {
        for low_level in [1, 2, 3] {
            let low = sphere_low(low_level, 1.0, s.res)?;
            let settings = NormalMapSettings::new(&low, s.res);
            push(time_pair(
                ctx,
                "triangles",
                (high, &low),
                &settings,
                s.repeats,
                true,
            )?);
        }
    }
    let high = &highs[2];
    for res in [128, 512, 1024, 2048] {
        let low = sphere_low(2, 1.0, res)?;
        let settings = NormalMapSettings::new(&low, res);
        push(time_pair(
            ctx,
            "resolution",
            (high, &low),
            &settings,
            s.repeats,
            true,
        )?);
    }
    let low = sphere_low(3, 1.0, s.res)?;
    for (draws, cull) in [
        (DrawMode::Indirect, true),
        (DrawMode::Direct, true),
        (DrawMode::Indirect, false),
        (DrawMode::Direct, false),
    ] {
        if draws == DrawMode::Indirect && !ctx.supports_multi_draw_indirect() {
            continue;
        }
        let settings = NormalMapSettings {
            draws,
            cull,
            ..NormalMapSettings::new(&low, s.res)
        };
        push(time_pair(
            ctx,
            "strategy",
            (high, &low),
            &settings,
            s.repeats,
            false,
        )?);
    }
    Ok(rows)
}

/// Parts 2 and 3 for one simplification ratio of the model; writes the low mesh's glTF
/// and map into `dir`.
pub fn model_row(
    ctx: &Arc<Context>,
    s: &NormalMapStudySettings,
    model: &Path,
    ratio: f32,
    dir: &Path,
) -> Result<ModelRow, NormalMapStudyError> {
    let mut high_scene = crate::scene::gltf::load(model, 1024)?;
    let white = Texture8 {
        width: 1,
        height: 1,
        texels: vec![[255; 4]],
    };
    high_scene.material.albedo = white;
    high_scene.material.normal = Texture8 {
        width: 1,
        height: 1,
        texels: vec![[128, 128, 255, 255]],
    };
    for v in &mut high_scene.mesh.vertices {
        v.albedo_tint = [1.0; 3];
    }
    let high = &high_scene.mesh;
    let (low, _) = simplify(high, ratio, s.model_res)?;
    let settings = NormalMapSettings::new(&low, s.model_res);
    let started = Instant::now();
    let (image, _) = normalmap::gpu::bake(ctx, high, &low, &settings)?;
    let gpu_s = started.elapsed().as_secs_f64();
    let started = Instant::now();
    let (rays, _) = cpu::bake(high, &low, &settings, RayDirection::Interpolated)?;
    let cpu_s = started.elapsed().as_secs_f64();
    let (face_rays, _) = cpu::bake(high, &low, &settings, RayDirection::Face)?;
    let interior = image.interior();
    let stem = format!(
        "{}_{}pct",
        model
            .file_stem()
            .map_or("model".into(), |s| s.to_string_lossy().into_owned()),
        ratio_percent(ratio)
    );
    let frames = normalmap::low_texels(&low, s.model_res);
    let tangent = normalmap::tangent_space(&image, &frames);
    let png = dir.join(format!("{stem}.png"));
    output::write_map(&png, s.model_res, &tangent, [0.0, 0.0, 1.0])?;
    output::write_map(
        &dir.join(format!("{stem}_object.png")),
        s.model_res,
        &image.texels,
        [0.0; 3],
    )?;
    let gltf = dir.join(format!("{stem}.gltf"));
    output::write_low_gltf(&gltf, &low, Some(&format!("{stem}.png")))?;

    // Part 3: unc6 on the low mesh (mapped and flat) against the high mesh's reference.
    let mut prepared = prepare(&PrepareSettings {
        scene: gltf.display().to_string(),
        env: s.env.clone(),
        vis_res: s.vis_res,
        rays: s.rays,
        cache_dir: Some(dir.join("cache")),
        ..PrepareSettings::default()
    })?;
    prepared.scene.camera = high_scene.camera;
    let reference = render_reference(
        ctx,
        &high_scene,
        &prepared.env,
        &ReferenceSettings::footprint_direct(s.width, s.height, s.spp),
    )?;
    let unc6: Technique = "unc6".parse().expect("a technique name");
    prepared.prepare_techniques(&[unc6])?;
    let inputs = prepared.inputs();
    let mut render = Vec::new();
    let errors = |flat_normals: bool| -> Result<Vec<f64>, NormalMapStudyError> {
        let scene_gpu = SceneGpu::new(
            ctx,
            &prepared.scene,
            &FrameSettings {
                width: s.width,
                height: s.height,
                flat_normals,
                ..FrameSettings::default()
            },
        )?;
        let mut out = Vec::new();
        for &path in &s.paths {
            let built = technique::build(ctx, &scene_gpu, unc6, path, &inputs)?;
            let frame = built.render(&scene_gpu, 1, 1)?;
            let name = format!(
                "{stem}.unc6.{path}{}",
                if flat_normals { ".flat" } else { "" }
            );
            crate::report::image::write_frame(&dir.join(format!("{name}.png")), &frame, -1.0)?;
            out.push(
                image_error(&frame, &reference.frame)
                    .ok_or_else(|| NormalMapStudyError::NoOverlap(name.clone()))?
                    .rel_rmse,
            );
        }
        Ok(out)
    };
    let mapped = errors(false)?;
    let flat = errors(true)?;
    for (k, &path) in s.paths.iter().enumerate() {
        render.push((path, mapped[k], flat[k]));
    }
    crate::report::image::write_frame(
        &dir.join(format!("{stem}.reference.png")),
        &reference.frame,
        -1.0,
    )?;
    Ok(ModelRow {
        model: model.display().to_string(),
        ratio,
        high_triangles: high.triangle_count(),
        low_triangles: low.triangle_count(),
        res: s.model_res,
        max_distance: settings.max_distance,
        vs_cpu: normalmap::compare(&image, &rays, &interior),
        vs_cpu_face: normalmap::compare(&image, &face_rays, &interior),
        gpu_s,
        cpu_s,
        render,
        reference_noise: Some(reference.rel_noise),
    })
}

fn stats_cell(s: &Option<AngleStats>) -> String {
    s.map_or("-".into(), |s| {
        format!("{:.3}° / {:.2}°", s.median_deg, s.p99_deg)
    })
}

/// Writes the report `normalmap.md` and `normalmap.json` into `dir`
/// ([`super::report::write`]); returns their paths.
pub fn write_report(study: &NormalMapStudy, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
    let mut md = format!(
        "# GPU normal-map generation\n\nDevice: {}. Times are medians; \"GPU total\" is the whole bake \
         (culling, uploads, shader compiles, pipelines, the one command buffer, readback), \
         \"execute\" the command buffer alone, \"project\" its projection pass by timestamps.\n",
        study.device
    );
    let ms = |s: f64| format!("{:.0}", s * 1e3);
    for (table, title) in [
        (
            "triangles",
            "Time against high and low triangle counts (the paper's Table 1)",
        ),
        (
            "resolution",
            "Time against resolution (the paper's Table 2)",
        ),
        ("strategy", "Draw strategies"),
    ] {
        md.push_str(&format!(
            "\n## {title}\n\n| high tris | low tris | res | draws | cull | high tris drawn | GPU total ms | execute ms | project ms | CPU ms |\n|---:|---:|---:|---|---|---:|---:|---:|---:|---:|\n"
        ));
        for r in study.timings.iter().filter(|r| r.table == table) {
            md.push_str(&format!(
                "| {} | {} | {}² | {:?} | {} | {} | {} | {} | {} | {} |\n",
                r.high_triangles,
                r.low_triangles,
                r.res,
                r.draws,
                if r.cull { "yes" } else { "no" },
                r.triangles_drawn,
                ms(r.gpu_total_s),
                ms(r.gpu_execute_s),
                r.gpu_project_ms.map_or("-".into(), |m| format!("{m:.1}")),
                r.cpu_total_s.map_or("-".into(), ms),
            ));
        }
    }
    if !study.models.is_empty() {
        md.push_str(
            "\n## Real model: GPU map against the CPU baker, and rendered through unc6\n\n\
             Angles over interior texels (median / 99th percentile). Relative RMSE of `unc6` \
             on the low mesh against the reference of the high mesh, with the generated map \
             and flat (interpolated normals).\n\n\
             | model | kept | high tris | low tris | res | vs CPU (interpolated rays) | vs CPU (face rays) | GPU s | CPU s | unc6 error: mapped / flat | reference noise |\n\
             |---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|\n",
        );
        for m in &study.models {
            let render: Vec<String> = m
                .render
                .iter()
                .map(|(p, a, b)| format!("{p} {a:.4} / {b:.4}"))
                .collect();
            md.push_str(&format!(
                "| {} | {} % | {} | {} | {}² | {} | {} | {:.2} | {:.2} | {} | {} |\n",
                Path::new(&m.model)
                    .file_name()
                    .map_or(m.model.clone(), |f| f.to_string_lossy().into_owned()),
                ratio_percent(m.ratio),
                m.high_triangles,
                m.low_triangles,
                m.res,
                stats_cell(&m.vs_cpu),
                stats_cell(&m.vs_cpu_face),
                m.gpu_s,
                m.cpu_s,
                render.join("; "),
                m.reference_noise.map_or("-".into(), |n| format!("{n:.4}"))
            ));
        }
    }
    let study_report = StudyReport {
        stem: "normalmap",
        json: Some(pretty_json(dir, "normalmap", study)?),
        markdown: md,
    };
    Ok(super::report::write(dir, &study_report)?)
}

/// Whether `name` is one of the files the study writes per model and ratio
/// (`{model}_{percent}pct…`, [`ratio_percent`]).
pub fn is_ratio_output(name: &str) -> bool {
    name.match_indices("pct").any(|(at, _)| {
        let before = &name[..at];
        let number = before.rsplit('_').next().unwrap_or("");
        before.contains('_')
            && number.bytes().any(|b| b.is_ascii_digit())
            && number.bytes().all(|b| b.is_ascii_digit() || b == b'.')
    })
}

/// `ratio` (a fraction of the model's triangles) in percent as the study names its files
/// and rows: up to three decimals, trailing zeros dropped ("50", "0.4", "0.125").
pub fn ratio_percent(ratio: f32) -> String {
    let text = format!("{:.3}", f64::from(ratio) * 100.0);
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratios_name_their_files_apart_and_are_told_from_other_files() {
        assert_eq!(ratio_percent(0.5), "50");
        assert_eq!(ratio_percent(0.004), "0.4");
        assert_eq!(ratio_percent(0.00125), "0.125");
        assert_eq!(ratio_percent(1.0), "100");
        for ours in ["Avocado_50pct.png", "m_0.4pct_object.exr", "m_12pct.gltf"] {
            assert!(is_ratio_output(ours), "{ours}");
        }
        for theirs in [
            "normalmap.md",
            "pct.png",
            "m_pct.png",
            "m_x1pct.png",
            "notes.txt",
        ] {
            assert!(!is_ratio_output(theirs), "{theirs}");
        }
    }
}
