//! `shvis render`: one frame of one technique on one hardware path over a prepared scene,
//! written as PNG (sRGB, with an exposure) or EXR (linear).

use std::path::PathBuf;
use std::sync::Arc;

use crate::gpu::{Context, GpuError};
use crate::render::specular::SpecularTerm;
use crate::render::{FrameSettings, SceneGpu};
use crate::report::ReportError;
use crate::report::image::write_frame;
use crate::technique::{self, HwPath, Technique, TechniqueError};

use super::Prepared;

/// What to render and where to write it.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameJob {
    /// Built from `prepared` (its data prepared for it: `Prepared::prepare_techniques`).
    pub technique: Technique,
    pub path: HwPath,
    pub frame: FrameSettings,
    /// A specular term added to the technique's lighting.
    pub specular: Option<SpecularTerm>,
    /// Output .png or .exr.
    pub out: PathBuf,
    /// Exposure in EV of a PNG.
    pub exposure: f32,
}

/// Errors of [`render_to_file`].
#[derive(Debug, thiserror::Error)]
pub enum FrameJobError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Technique(#[from] TechniqueError),
    #[error(transparent)]
    Report(#[from] ReportError),
}

/// Renders `job` on `ctx` and writes the frame; returns the technique's label. Pixels the
/// f16 target clipped are logged as a warning.
pub fn render_to_file(
    ctx: &Arc<Context>,
    prepared: &Prepared,
    job: &FrameJob,
) -> Result<String, FrameJobError> {
    let mut scene_gpu = SceneGpu::new(ctx, &prepared.scene, &job.frame)?;
    if let Some(term) = job.specular {
        scene_gpu.add_specular(ctx, &prepared.scene, term)?;
    }
    let tech = technique::build(ctx, &scene_gpu, job.technique, job.path, &prepared.inputs())?;
    let frame = tech.render(&scene_gpu, 0, 1)?;
    let clipped = frame.clipped_pixels();
    if clipped > 0 {
        log::warn!(
            "{}: {clipped} pixels clipped at the f16 target's 65504 (or not finite): the environment is too bright for this target; scale it down",
            tech.label()
        );
    }
    write_frame(&job.out, &frame, job.exposure)?;
    Ok(tech.label())
}
