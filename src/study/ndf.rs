//! Normal distribution mapping against naive MIP filtering (`shvis study ndf`).
//!
//! On each specular scene — the built-in receding bumpy plane ([`crate::scene::bumpy`],
//! isotropic bumps, the paper's Fig. 1 setting of a surface receding to the horizon) and
//! the wavy sphere ([`crate::scene::wavy`], parallel ripples: the highlight must elongate,
//! the paper's Figs. 1–2) — the specular term of a directional light
//! ([`crate::render::specular`]) is rendered with the three filterings on each path and compared
//! with its footprint reference: relative RMSE and the highlight's energy (the sum over
//! the surface's pixels) against the reference's, over the pixels where the normal map is
//! minified at least [`MIN_MINIFICATION`]× and over the whole surface. Minification is the
//! texels per pixel along the larger footprint axis: analytic on the plane, from the
//! hardware's level of detail (`render::specular::normal_map_lod`) on the sphere. Writes
//! `ndf.md`, `ndf.json` and a composite `fig1_ndf_{scene}.png` per scene (reference · mip ·
//! ndf · ndfn).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Vec3, Vec4};
use serde::Serialize;

use super::ndf_diffuse::{DiffuseRow, DiffuseScene};
use super::report::{StudyReport, pretty_json};
use crate::gpu::TimingStats;
use crate::gpu::{Context, GpuError};
use crate::ndf::{self, NdfMaps};
use crate::reference::ReferenceSettings;
use crate::reference::specular::render_reference;
use crate::render::specular::{NormalFilter, SpecularLight, render_specular, upload_maps};
use crate::render::{Frame, FrameSettings, SceneGpu};
use crate::report::ReportError;
use crate::scene::{Scene, bumpy, wavy};
use crate::technique::HwPath;

/// Pixels counted as minified cover at least this many normal-map texels across.
pub const MIN_MINIFICATION: f32 = 4.0;

/// The scenes of the specular part.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SpecularScene {
    /// The receding bumpy plane.
    Bumpy,
    /// The wavy sphere.
    Wavy,
}

impl SpecularScene {
    pub const ALL: [SpecularScene; 2] = [SpecularScene::Bumpy, SpecularScene::Wavy];

    pub fn name(self) -> &'static str {
        match self {
            SpecularScene::Bumpy => "bumpy",
            SpecularScene::Wavy => "wavy",
        }
    }

    /// The scene, its lightmap at 256² (the specular term reads no lightmap).
    pub fn build(self) -> Result<Scene, crate::scene::SceneError> {
        match self {
            SpecularScene::Bumpy => bumpy::build(256),
            SpecularScene::Wavy => wavy::build(256),
        }
    }
}

impl std::str::FromStr for SpecularScene {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        SpecularScene::ALL
            .into_iter()
            .find(|v| v.name() == s)
            .ok_or_else(|| format!("unknown specular scene '{s}': use bumpy or wavy"))
    }
}

/// How the study runs.
#[derive(Clone, Debug)]
pub struct NdfStudySettings {
    pub scene: SpecularScene,
    pub sigma: f32,
    pub light_dir: Vec3,
    pub width: u32,
    pub height: u32,
    /// Sub-pixel strata of the reference (⌊√spp⌋², at most 64).
    pub spp: u32,
    pub paths: Vec<HwPath>,
    /// Timed frames per row.
    pub frames: u32,
}

/// One filtering on one path.
#[derive(Clone, Debug, Serialize)]
pub struct NdfRow {
    pub filter: NormalFilter,
    pub path: HwPath,
    /// Relative RMSE against the reference, minified pixels / the whole plane.
    pub rel_rmse_minified: f64,
    pub rel_rmse_all: f64,
    /// Σ image / Σ reference over the minified pixels / the whole plane.
    pub energy_minified: f64,
    pub energy_all: f64,
    pub ms_median: Option<f64>,
    /// Texture fetches per pixel (normal map + the NDF maps).
    pub lookups: u32,
}

/// The study's result.
#[derive(Clone, Debug, Serialize)]
pub struct NdfStudy {
    pub device: String,
    pub scene: SpecularScene,
    pub sigma: f32,
    pub light_dir: [f32; 3],
    pub width: u32,
    pub height: u32,
    pub strata: u32,
    pub plane_pixels: usize,
    pub minified_pixels: usize,
    pub ndf_levels: usize,
    pub ndf_build_s: f64,
    /// Relative RMSE of a reference with a quarter of the strata against the full one
    /// (minified pixels): an upper bound of the reference's own error.
    pub reference_self_error: f64,
    pub rows: Vec<NdfRow>,
}

/// Texels per pixel of the plane y = 0 at each pixel (0 off the plane): the larger of the
/// UV steps to the right and down neighbours' rays, in normal-map texels.
pub fn minification(scene: &Scene, width: u32, height: u32) -> Vec<f32> {
    let cam = scene.camera;
    let inverse = cam.clip_from_world(width as f32 / height as f32).inverse();
    let uv_at = |px: f32, py: f32| -> Option<glam::Vec2> {
        let ndc = |z: f32| {
            let p = inverse
                * Vec4::new(
                    px / width as f32 * 2.0 - 1.0,
                    py / height as f32 * 2.0 - 1.0,
                    z,
                    1.0,
                );
            p.truncate() / p.w
        };
        let (a, b) = (ndc(0.0), ndc(0.5));
        let dir = b - a;
        if dir.y.abs() < 1e-12 {
            return None;
        }
        let t = -a.y / dir.y;
        (t > 0.0).then(|| {
            let p = a + dir * t;
            glam::Vec2::new(p.x, p.z)
        })
    };
    let texels_per_metre = bumpy::NORMAL_MAP_SIDE as f32;
    (0..width * height)
        .map(|i| {
            let (x, y) = ((i % width) as f32 + 0.5, (i / width) as f32 + 0.5);
            match (uv_at(x, y), uv_at(x + 1.0, y), uv_at(x, y + 1.0)) {
                (Some(c), Some(r), Some(d)) => {
                    (r - c).length().max((d - c).length()) * texels_per_metre
                }
                _ => 0.0,
            }
        })
        .collect()
}

fn compare(test: &Frame, reference: &Frame, mask: &[bool]) -> (f64, f64) {
    let (mut se, mut ref_sq, mut sum_t, mut sum_r) = (0.0, 0.0, 0.0, 0.0);
    for ((t, r), &m) in test.rgba.iter().zip(&reference.rgba).zip(mask) {
        if !m {
            continue;
        }
        for c in 0..3 {
            let (tv, rv) = (f64::from(t[c]), f64::from(r[c]));
            se += (tv - rv).powi(2);
            ref_sq += rv * rv;
            sum_t += tv;
            sum_r += rv;
        }
    }
    let rmse = if ref_sq > 0.0 {
        (se / ref_sq).sqrt()
    } else {
        f64::NAN
    };
    let energy = if sum_r > 0.0 { sum_t / sum_r } else { f64::NAN };
    (rmse, energy)
}

/// Runs the study; returns it and the composite (dx10 where rendered, else dx9).
pub fn run(ctx: &Arc<Context>, s: &NdfStudySettings) -> Result<(NdfStudy, Frame), GpuError> {
    let scene = s.scene.build().map_err(|e| GpuError::Invalid {
        what: "study ndf".into(),
        detail: e.to_string(),
    })?;
    let started = std::time::Instant::now();
    let maps: NdfMaps = ndf::build(&scene.material.normal, scene.material.normal_scale, s.sigma);
    let ndf_build_s = started.elapsed().as_secs_f64();
    let mut gpu = SceneGpu::new(
        ctx,
        &scene,
        &FrameSettings {
            width: s.width,
            height: s.height,
            flat_normals: false,
            float32_target: true,
            material_level0: false,
        },
    )?;
    let light = SpecularLight {
        direction: s.light_dir.normalize(),
        radiance: Vec3::ONE,
    };
    let reference_settings = ReferenceSettings::footprint_direct(s.width, s.height, s.spp);
    let reference = render_reference(
        ctx,
        &mut gpu,
        scene.camera.position,
        &maps,
        &light,
        &reference_settings,
    )?;
    // The reference's own error: a quarter of the strata, another seed, against it.
    let coarse = render_reference(
        ctx,
        &mut gpu,
        scene.camera.position,
        &maps,
        &light,
        &ReferenceSettings {
            spp: (s.spp / 4).max(1),
            seed: 1,
            ..reference_settings
        },
    )?;
    let texels: Vec<f32> = match s.scene {
        SpecularScene::Bumpy => minification(&scene, s.width, s.height),
        SpecularScene::Wavy => crate::render::specular::normal_map_lod(ctx, &gpu)?
            .into_iter()
            .map(|lod| lod.map_or(0.0, f32::exp2))
            .collect(),
    };
    let plane: Vec<bool> = reference
        .rgba
        .iter()
        .zip(&texels)
        .map(|(r, &m)| r[3] > 0.5 && m > 0.0)
        .collect();
    let minified: Vec<bool> = plane
        .iter()
        .zip(&texels)
        .map(|(&p, &m)| p && m >= MIN_MINIFICATION)
        .collect();
    let reference_self_error = compare(&coarse, &reference, &minified).0;
    let mut rows = Vec::new();
    let mut panels: Vec<Option<Frame>> = vec![None; 3];
    for &path in &s.paths {
        let images = upload_maps(ctx, &maps, path)?;
        for (k, filter) in NormalFilter::ALL.into_iter().enumerate() {
            let frame = render_specular(ctx, &gpu, &maps, &images, &light, filter, path, s.frames)?;
            let (rel_rmse_minified, energy_minified) = compare(&frame, &reference, &minified);
            let (rel_rmse_all, energy_all) = compare(&frame, &reference, &plane);
            rows.push(NdfRow {
                filter,
                path,
                rel_rmse_minified,
                rel_rmse_all,
                energy_minified,
                energy_all,
                ms_median: TimingStats::from_ms(&frame.ms).map(|t| t.ms_median),
                lookups: 1 + filter.extra_lookups(),
            });
            if panels[k].is_none() || path == HwPath::Dx10 {
                panels[k] = Some(frame);
            }
        }
    }
    let mut figure = vec![&reference];
    figure.extend(panels.iter().flatten());
    let composite = super::side_by_side(&figure);
    Ok((
        NdfStudy {
            device: ctx.device_name().to_string(),
            scene: s.scene,
            sigma: s.sigma,
            light_dir: light.direction.to_array(),
            width: s.width,
            height: s.height,
            strata: {
                let side = ((s.spp.max(1) as f64).sqrt().ceil() as u32)
                    .min(crate::reference::specular::MAX_REFERENCE_SIDE);
                side * side
            },
            reference_self_error,
            plane_pixels: plane.iter().filter(|&&p| p).count(),
            minified_pixels: minified.iter().filter(|&&p| p).count(),
            ndf_levels: maps.levels.len(),
            ndf_build_s,
            rows,
        },
        composite,
    ))
}

/// Writes `fig1_ndf_{scene}.png` per specular study, then the report `ndf.md`, `ndf.json`
/// ([`super::report::write`]) into `dir`; returns their paths.
pub fn write_report(
    studies: &[(NdfStudy, Frame)],
    diffuse: Option<&(Vec<DiffuseScene>, Vec<DiffuseRow>)>,
    dir: &Path,
) -> Result<Vec<PathBuf>, ReportError> {
    let mut md = "# Normal distribution mapping\n".to_string();
    let mut written = Vec::new();
    for (study, composite) in studies {
        let scene = study.scene.name();
        md.push_str(&format!(
            "\n## Specular, `{scene}`\n\nDevice {}; {}×{}, base spread σ = {}, light toward {:?}; \
             footprint reference over {} sub-pixel strata (a quarter of them differ from it by {:.4}); {} surface pixels, {} minified ≥ {}×. NDF maps: {} levels, built in {:.2} s.\n\n\
             | filter | path | rel. RMSE (minified) | energy (minified) | rel. RMSE (surface) | energy (surface) | ms median | lookups/px |\n\
             |---|---|---:|---:|---:|---:|---:|---:|\n",
            study.device,
            study.width,
            study.height,
            study.sigma,
            study.light_dir,
            study.strata,
            study.reference_self_error,
            study.plane_pixels,
            study.minified_pixels,
            MIN_MINIFICATION,
            study.ndf_levels,
            study.ndf_build_s
        ));
        // "—" where a mask is empty or its reference black (the pixel counts above say so).
        let figure = |v: f64, digits: usize| {
            if v.is_finite() {
                format!("{v:.digits$}")
            } else {
                "—".to_string()
            }
        };
        for r in &study.rows {
            md.push_str(&format!(
                "| spec{} | {} | {} | {} | {} | {} | {} | {} |\n",
                r.filter.name(),
                r.path,
                figure(r.rel_rmse_minified, 4),
                figure(r.energy_minified, 3),
                figure(r.rel_rmse_all, 4),
                figure(r.energy_all, 3),
                r.ms_median.map_or("-".into(), |m| format!("{m:.2}")),
                r.lookups
            ));
        }
        let name = format!("fig1_ndf_{scene}.png");
        md.push_str(&format!("\n![reference · mip · ndf · ndfn]({name})\n"));
        // Expose so the reference's 99th percentile is white.
        let mut values: Vec<f32> = composite
            .rgba
            .iter()
            .map(|p| p[0])
            .filter(|v| *v > 0.0)
            .collect();
        values.sort_by(f32::total_cmp);
        let p99 = values
            .get(values.len() * 99 / 100)
            .copied()
            .unwrap_or(1.0)
            .max(1e-9);
        let fig = dir.join(name);
        crate::report::image::write_frame(&fig, composite, -p99.log2())?;
        written.push(fig);
    }
    if let Some((scenes, rows)) = diffuse {
        md.push_str(&super::ndf_diffuse::markdown(scenes, rows));
    }
    let specular: Vec<&NdfStudy> = studies.iter().map(|(s, _)| s).collect();
    let json = pretty_json(
        dir,
        "ndf",
        &serde_json::json!({
            "specular": specular,
            "diffuse": diffuse.map(|(scenes, rows)| serde_json::json!({"scenes": scenes, "rows": rows})),
        }),
    )?;
    let study_report = StudyReport {
        stem: "ndf",
        markdown: md,
        json: Some(json),
    };
    written.extend(super::report::write(dir, &study_report)?);
    Ok(written)
}
