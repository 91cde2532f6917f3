//! The probe's model checked on the scene: a few shaders of known
//! counts — the probe's empty shader, and the material lookups every technique makes —
//! drawn over the bench's own mesh and camera, each against the model's time for it.
//!
//! The probe fits its costs over screen-filling grids of its own textures; a row's model
//! adds them up over the scene. Where a row is off its model, these say which part does not
//! carry over: the base (the empty shader: the scene's overdraw, triangles, edges) or one of
//! the lookups. They are why the albedo's sRGB decode is its own kind
//! ([`Kind::TrilinearSrgb`]): on lavapipe (2-vCPU Xeon, house, 1280×800) the albedo lookup
//! runs 1.34× a model that prices it as the normal map's UNORM one (1.05×), 1.7 ms a frame
//! in every row.
//!
//! Each check is timed on two builds of its pipeline and keeps the faster median (builds
//! differ, `states`), against the main model (the device's fastest state).

use std::sync::Arc;

use serde::Serialize;

use super::{CostCounts, CostModel, Kind};
use crate::cost::spirv;
use crate::gpu::{Context, GpuError, ShaderStage};
use crate::render::{SceneGpu, ShadingLoad};

/// One shader of known counts over the scene.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SceneCheck {
    pub name: &'static str,
    /// Per-pixel counts by kind (its lookups as written, the rest from its SPIR-V).
    pub counts: CostCounts,
    /// Median of its timed frames, of the faster of two builds.
    pub ms_median: f64,
    pub model_ms: f64,
}

impl SceneCheck {
    /// Measured over model.
    pub fn x_model(&self) -> f64 {
        self.ms_median / self.model_ms
    }
}

/// A check: its name, the fragment shader's body (after it reads the lightmap coordinates,
/// as every technique does, into `acc`) and its lookups.
type Check = (&'static str, &'static str, &'static [(Kind, u32)]);

const CHECKS: [Check; 3] = [
    ("empty shader", "", &[]),
    (
        "albedo lookup (sRGB)",
        "acc += texture(albedo_tex, in_uv_material);",
        &[(Kind::TrilinearSrgb, 1)],
    ),
    (
        "normal-map lookup (UNORM)",
        "acc += texture(normal_tex, in_uv_material);",
        &[(Kind::Trilinear2d, 1)],
    ),
];

/// Builds per check (the faster one's median is kept).
const BUILDS: usize = 2;

/// Times every check over `scene` and prices it with `model`; `load` is the scene's
/// ([`SceneGpu::shading_load`]), `pixels` the screen's.
///
/// # Errors
/// Shader compilation or Vulkan failures.
pub fn run(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    model: &CostModel,
    load: &ShadingLoad,
    pixels: f64,
    frames: u32,
) -> Result<Vec<SceneCheck>, GpuError> {
    CHECKS
        .iter()
        .map(|&(name, body, lookups)| {
            let source = super::shaders::fragment_shader(
                "",
                &format!("    acc.xy = in_uv_lightmap;\n    {body}\n"),
            );
            let spirv = crate::gpu::shader::compile_source(
                "scene_check.frag",
                &source,
                ShaderStage::Fragment,
                &[],
            )?;
            let counts = CostCounts::new(lookups, &spirv::count(&spirv));
            let resources = scene.common_resources();
            let mut ms_median = f64::INFINITY;
            for build in 0..BUILDS {
                let pipeline = scene.mesh_pipeline(
                    ctx,
                    &format!("scene_check.{}{build}", name.replace(' ', "_")),
                    &spirv,
                    &resources,
                )?;
                let mut ms = scene.time_pipeline(&pipeline, 3, frames.max(1))?;
                ms.sort_by(f64::total_cmp);
                ms_median = ms_median.min(ms[ms.len() / 2]);
            }
            Ok(SceneCheck {
                name,
                counts,
                ms_median,
                model_ms: model.predict(
                    &counts,
                    load.lanes / pixels,
                    scene.triangle_count(),
                    load.edge_pixels,
                ),
            })
        })
        .collect()
}

/// One line: each check's time, model and ratio.
pub fn summary(checks: &[SceneCheck]) -> String {
    checks
        .iter()
        .map(|c| {
            format!(
                "{} {:.3} ms (model {:.3}, ×{:.2})",
                c.name,
                c.ms_median,
                c.model_ms,
                c.x_model()
            )
        })
        .collect::<Vec<_>>()
        .join("; ")
}
