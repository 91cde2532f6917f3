//! `shvis bake --baker gpu`: the GPU simulator's visibility bake of a mesh and, when asked,
//! its distance from the CPU ray tracer's bake against the quadrature noise (the tracer
//! with two seeds), with the AO texels where the simulator leaks light or shows acne.

use std::sync::Arc;

use crate::gpu::{Context, GpuError};
use crate::scene::Mesh;

use super::gpu_visibility::{self, GpuVisibilitySettings};
use super::visibility::{VisibilityMap, VisibilitySettings, bake_visibility};
use super::{raster, trace};

/// AO difference above which a texel counts as a leak (the GPU's AO higher) or acne (lower).
pub const LEAK_THRESHOLD: f32 = 0.02;

/// Covered texels whose AO differs between two bakes by more than a threshold.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AoDisagreement {
    /// `gpu` above `cpu`: light leaking past the depth maps.
    pub leaks: usize,
    /// `gpu` below `cpu`: self-shadowing acne.
    pub acne: usize,
}

/// Counts the covered texels of `cpu` whose AO in `gpu` is above or below it by more than
/// `threshold`.
pub fn ao_disagreement(gpu: &VisibilityMap, cpu: &VisibilityMap, threshold: f32) -> AoDisagreement {
    let mut count = AoDisagreement::default();
    for i in 0..cpu.ao.len() {
        if cpu.covered[i] {
            let d = gpu.ao[i] - cpu.ao[i];
            count.leaks += usize::from(d > threshold);
            count.acne += usize::from(d < -threshold);
        }
    }
    count
}

/// Bakes `mesh`'s visibility at `vis_res`² texels on `ctx` with the GPU simulator and says
/// how long it took; with `compare_cpu` also runs the CPU bake (and one with the next
/// seed) and says how far the two are apart.
pub fn bake_checked(
    ctx: &Arc<Context>,
    mesh: &Mesh,
    vis_res: u32,
    settings: &VisibilitySettings,
    gpu: &GpuVisibilitySettings,
    compare_cpu: bool,
    say: &mut dyn FnMut(&str),
) -> Result<VisibilityMap, GpuError> {
    let texels = raster::rasterize(mesh, vis_res);
    let baked = gpu_visibility::bake_visibility_gpu(ctx, mesh, &texels, settings, gpu)?;
    let gpu_ms = baked.gpu_ms.map_or("no timestamps".into(), |(d, p)| {
        format!("GPU {d:.1} ms directions + {p:.1} ms projection")
    });
    say(&format!(
        "gpu simulator on {}: {}² depth maps, bias {} + {}·tanθ texels: {:.2} s ({:.2} s set-up; {gpu_ms})",
        ctx.device_name(),
        gpu.depth_res,
        gpu.bias_texels,
        gpu.slope_bias_texels,
        baked.map.stats.seconds,
        baked.setup_s
    ));
    if compare_cpu {
        let tracer = trace::Tracer::new(mesh);
        let cpu = bake_visibility(&tracer, &texels, settings);
        let other_seed = bake_visibility(
            &tracer,
            &texels,
            &VisibilitySettings {
                seed: settings.seed + 1,
                ..*settings
            },
        );
        let noise = gpu_visibility::quadrature_noise(&cpu, &other_seed);
        let AoDisagreement { leaks, acne } = ao_disagreement(&baked.map, &cpu, LEAK_THRESHOLD);
        say(&format!(
            "gpu AO above the cpu's by > 0.02 (leaks): {leaks} texels; below (acne): {acne}"
        ));
        let d = gpu_visibility::compare(&cpu, &baked.map, noise);
        say(&format!(
            "gpu vs cpu: {:.3} % of {} texels differ by more than the quadrature noise {noise:.4} (L2 of the coefficients; RMS difference {:.4}); cpu bake {:.2} s, gpu {:.2} s ({:.2}×)",
            100.0 * d.fraction_above,
            d.texels,
            d.rms,
            cpu.stats.seconds,
            baked.map.stats.seconds,
            baked.map.stats.seconds / cpu.stats.seconds
        ));
    }
    Ok(baked.map)
}
