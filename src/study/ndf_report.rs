//! `shvis study ndf` as one call: the specular study on each scene, the diffuse part under
//! each environment, every row said as it is measured, and the report written.

use std::path::PathBuf;
use std::sync::Arc;

use glam::Vec3;

use crate::gpu::{Context, GpuError};
use crate::report::ReportError;
use crate::technique::HwPath;

use super::ndf::{self, NdfStudySettings, SpecularScene};
use super::ndf_diffuse::{
    self, DiffuseRow, DiffuseScene, DiffuseSettings, DiffuseStudyError, arrow,
};

/// Strata per side of the diffuse part's footprint reference.
pub const DIFFUSE_STRATA_SIDE: u32 = 16;

/// The whole study's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct NdfRunSettings {
    /// Scenes of the specular part.
    pub scenes: Vec<SpecularScene>,
    /// Base spread σ of a full-resolution texel's normals.
    pub sigma: f32,
    /// Direction toward the light on the bumpy plane (the wavy sphere's is its own).
    pub light_dir: Vec3,
    pub width: u32,
    pub height: u32,
    /// Reference sub-pixel samples of the specular part.
    pub spp: u32,
    pub paths: Vec<HwPath>,
    /// Timed frames per row.
    pub frames: u32,
    /// Scenes of the diffuse part (empty names are dropped; none: no diffuse part).
    pub diffuse_scenes: Vec<String>,
    /// Environments each diffuse scene is measured under.
    pub diffuse_envs: Vec<String>,
    /// Reference samples per pixel of the diffuse part.
    pub diffuse_spp: u32,
    /// Lightmap resolution of the diffuse part's bakes.
    pub vis_res: u32,
    /// Output directory (it must exist).
    pub out: PathBuf,
}

/// Errors of [`run`].
#[derive(Debug, thiserror::Error)]
pub enum NdfRunError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Diffuse(#[from] DiffuseStudyError),
    #[error(transparent)]
    Report(#[from] ReportError),
}

/// Runs the study on `ctx`, saying each scene's rows, and writes ndf.md, ndf.json and the
/// composites; returns the files written.
pub fn run(
    ctx: &Arc<Context>,
    s: &NdfRunSettings,
    say: &mut dyn FnMut(&str),
) -> Result<Vec<PathBuf>, NdfRunError> {
    let mut studies = Vec::new();
    for &scene in &s.scenes {
        let settings = NdfStudySettings {
            scene,
            sigma: s.sigma,
            light_dir: match scene {
                SpecularScene::Bumpy => s.light_dir,
                SpecularScene::Wavy => crate::scene::wavy::light_dir(),
            },
            width: s.width,
            height: s.height,
            spp: s.spp,
            paths: s.paths.clone(),
            frames: s.frames,
        };
        let (study, composite) = ndf::run(ctx, &settings)?;
        say(&format!(
            "{}: {} surface pixels, {} minified ≥ {}×; reference {} strata (a quarter of them: {:.4} from it); relative RMSE / energy against the footprint reference (minified | whole surface):",
            scene.name(),
            study.plane_pixels,
            study.minified_pixels,
            ndf::MIN_MINIFICATION,
            study.strata,
            study.reference_self_error
        ));
        for r in &study.rows {
            say(&format!(
                "  spec{:<4} {:<4} {:.4} / {:.3} | {:.4} / {:.3}  {} ms",
                r.filter.name(),
                r.path.name(),
                r.rel_rmse_minified,
                r.energy_minified,
                r.rel_rmse_all,
                r.energy_all,
                r.ms_median.map_or("-".into(), |m| format!("{m:.2}"))
            ));
        }
        studies.push((study, composite));
    }
    let diffuse = diffuse_part(ctx, s, say)?;
    Ok(ndf::write_report(&studies, diffuse.as_ref(), &s.out)?)
}

/// The diffuse part's scenes and rows.
type DiffusePart = (Vec<DiffuseScene>, Vec<DiffuseRow>);

/// The diffuse part under every environment, said scene by scene and row by row; `None`
/// without diffuse scenes.
fn diffuse_part(
    ctx: &Arc<Context>,
    s: &NdfRunSettings,
    say: &mut dyn FnMut(&str),
) -> Result<Option<DiffusePart>, NdfRunError> {
    let diffuse_scenes: Vec<String> = s
        .diffuse_scenes
        .iter()
        .filter(|s| !s.is_empty())
        .cloned()
        .collect();
    if diffuse_scenes.is_empty() {
        return Ok(None);
    }
    let (mut scenes, mut rows) = (Vec::new(), Vec::new());
    for env in &s.diffuse_envs {
        let (sc, r) = ndf_diffuse::run(
            ctx,
            &DiffuseSettings {
                scenes: diffuse_scenes.clone(),
                env: env.clone(),
                width: s.width,
                height: s.height,
                ref_spp: s.diffuse_spp,
                vis_res: s.vis_res,
                paths: s.paths.clone(),
                cache_dir: None,
                strata_side: DIFFUSE_STRATA_SIDE,
                image_dir: Some(s.out.clone()),
            },
        )?;
        scenes.extend(sc);
        rows.extend(r);
    }
    for sc in &scenes {
        say(&format!(
            "  {} ({}): {} covered, {} minified, {} magnified pixels; footprint vs point reference {:.4}",
            sc.scene,
            sc.env,
            sc.covered_pixels,
            sc.minified_pixels,
            sc.magnified_pixels,
            sc.footprint_step
        ));
    }
    say(
        "diffuse: relative RMSE against the footprint reference, unfiltered → ndf (minified ≥ 4× | magnified | all; max change where magnified):",
    );
    for r in &rows {
        say(&format!(
            "  {:<6} {:<10} {:<8} {:<4} {} (8² blocks {}) | {} | {}; {:.1e}; own footprint {} (8² blocks {})",
            r.scene,
            r.env,
            r.technique.name(),
            r.path.name(),
            arrow(r.minified),
            arrow(r.reference_blocks),
            arrow(r.magnified),
            arrow(r.all),
            r.magnified_max_change,
            arrow(r.own_footprint_minified),
            arrow(r.own_footprint_blocks)
        ));
    }
    Ok(Some((scenes, rows)))
}
