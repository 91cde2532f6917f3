//! `shvis bake`: a scene's visibility and AO baked by the CPU tracer or the GPU simulator
//! and written as EXR layers with a manifest, for inspection; optionally the standalone
//! cosine-sampled AO bake's figures beside it.

use std::path::PathBuf;

use crate::bake::gpu_check::bake_checked;
use crate::bake::visibility::VisibilitySettings;

use super::{
    PrepareError, PrepareSettings, VisibilityBaker, bake_scene_ao, bake_scene_visibility,
    resolve_scene,
};

/// What `shvis bake` writes, beside its [`PrepareSettings`] (scene, order, seed).
#[derive(Clone, Debug, PartialEq)]
pub struct BakeLayersJob {
    /// Lightmap texels per side (checked: `bake::validate_res`).
    pub vis_res: u32,
    /// Rays per texel (checked: `bake::validate_rays`).
    pub rays: u32,
    /// Also run the standalone AO bake and say its figures.
    pub separate_ao: bool,
    /// With the GPU baker: also bake on the CPU and say how far apart the two are.
    pub compare_cpu: bool,
    /// Output directory (it must exist and take files).
    pub out: PathBuf,
}

/// Bakes the scene of `settings` with `baker` and writes the layers into `job.out`.
pub fn run(
    job: &BakeLayersJob,
    settings: &PrepareSettings,
    baker: &VisibilityBaker,
    say: &mut dyn FnMut(&str),
) -> Result<(), PrepareError> {
    let (vis_res, rays) = (job.vis_res, job.rays);
    let scene = resolve_scene(&settings.scene, vis_res)?;
    if job.separate_ao {
        let ao = bake_scene_ao(&scene, vis_res, rays, settings.seed, true)?;
        say(&format!(
            "separate AO bake: {vis_res}² texels ({} covered) × {rays} rays: {}",
            ao.covered.iter().filter(|&&c| c).count(),
            ao.stats
        ));
    }
    let (visibility, name) = match baker {
        VisibilityBaker::Cpu => (
            bake_scene_visibility(&scene, vis_res, rays, settings)?,
            "Cpu",
        ),
        VisibilityBaker::Gpu { ctx, settings: gpu } => {
            let vis_settings = VisibilitySettings {
                order: settings.order,
                rays,
                seed: settings.seed,
                progress: true,
            };
            let map = bake_checked(
                ctx,
                &scene.mesh,
                vis_res,
                &vis_settings,
                gpu,
                job.compare_cpu,
                say,
            )?;
            (map, "Gpu")
        }
    };
    say(&format!(
        "visibility and AO bake ({name}): order {} × {rays} rays, {} triangles: {}",
        visibility.order,
        scene.mesh.triangle_count(),
        visibility.stats
    ));
    let manifest_settings = serde_json::json!({
        "scene": settings.scene,
        "vis_res": vis_res,
        "rays": rays,
        "order": settings.order.get(),
        "seed": settings.seed,
        "baker": name.to_lowercase(),
    });
    crate::bake::cache::write_exr_layers(&job.out, &visibility, manifest_settings)?;
    say(&format!(
        "wrote {}/ (visibility coefficient and ao EXR layers)",
        job.out.display()
    ));
    Ok(())
}
