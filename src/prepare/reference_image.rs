//! `shvis reference`: the ground-truth image of a scene under an environment (optionally
//! its height-mapped surfaces displaced into real geometry), written as EXR or PNG.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use crate::bake::{self, BakeError};
use crate::env::{self, EnvError};
use crate::gpu::{Context, GpuError};
use crate::reference::{ReferenceSettings, render_reference};
use crate::report::ReportError;
use crate::report::image::write_frame;
use crate::scene::SceneError;
use crate::scene::displace::{DisplaceError, displace};

use super::resolve_scene;

/// What `shvis reference` renders and where it writes it.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceJob {
    /// A built-in scene or a glTF file ([`resolve_scene`]).
    pub scene: String,
    /// An environment (`env::resolve`).
    pub env: String,
    /// Lightmap resolution the scene is built for.
    pub vis_res: u32,
    /// Render the height-mapped surfaces as displaced micro-geometry.
    pub displaced: bool,
    pub settings: ReferenceSettings,
    /// Output .exr or .png.
    pub out: PathBuf,
    /// Exposure in EV of a PNG.
    pub exposure: f32,
}

/// Figures of a written reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceOutcome {
    /// Rays cast.
    pub rays: u64,
    pub seconds: f64,
    /// Relative standard error of the image written (the bounced one with bounces).
    pub noise: f64,
    /// Sub-pixel strata per side.
    pub strata_side: u32,
}

/// Errors of [`render_to_file`].
#[derive(Debug, thiserror::Error)]
pub enum ReferenceJobError {
    #[error(transparent)]
    Bake(#[from] BakeError),
    #[error(transparent)]
    Env(#[from] EnvError),
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Displace(#[from] DisplaceError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Report(#[from] ReportError),
}

/// Renders the reference of `job` on `ctx` and writes it.
pub fn render_to_file(
    ctx: &Arc<Context>,
    job: &ReferenceJob,
) -> Result<ReferenceOutcome, ReferenceJobError> {
    let vis_res = bake::validate_res(job.vis_res)?;
    let env = env::resolve(&job.env)?;
    let mut scene = resolve_scene(&job.scene, vis_res)?;
    if job.displaced {
        let t = Instant::now();
        scene = displace(&scene)?;
        log::info!(
            "displaced {}: {} triangles in {:.1} s",
            scene.name,
            scene.mesh.triangle_count(),
            t.elapsed().as_secs_f64()
        );
    }
    let image = render_reference(ctx, &scene, &env, &job.settings)?;
    let (frame, noise) = match &image.bounced {
        Some(b) => (&b.frame, b.rel_noise),
        None => (&image.frame, image.rel_noise),
    };
    write_frame(&job.out, frame, job.exposure)?;
    Ok(ReferenceOutcome {
        rays: image.rays,
        seconds: image.seconds,
        noise,
        strata_side: image.strata.side,
    })
}
