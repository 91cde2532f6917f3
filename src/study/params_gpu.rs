//! Appendix A on real texture hardware: the SH basis functions stored at texel centres of
//! each parameterization are sampled by a compute shader (glsl/study/reconstruct.comp) —
//! real cube-map arrays with seamless filtering for `cube-dx10`, 2D texture arrays with
//! clamp-to-edge for `cube-dx9` (per-face filtering, face chosen in the shader by the
//! Vulkan table) and for the two dual maps — and compared both with the exact basis values
//! and with the CPU emulation of `crate::sphere` (`BilinearTaps`).
//!
//! Where the two differ is the hardware's filtering arithmetic: texture units compute the
//! bilinear weights in fixed point (D3D10+ and Vulkan require at least 8 fractional bits of
//! sub-texel precision) and store/filter in f32, while the emulation is exact f64. The
//! report gives the largest and RMS difference per parameterization and resolution.

use std::sync::Arc;

use ash::vk;
use glam::DVec3;
use gpu_allocator::MemoryLocation;

use super::params::StudyError;
use super::report::StudyReport;
use crate::gpu::layout::ShaderIds;
use crate::gpu::{
    Buffer, ComputePipeline, ComputePipelineDesc, Context, GpuError, Image, ImageDesc, Resource,
    Sampler, SamplerKind, ShaderStage, compile_glsl,
};
use crate::sh::Order;
use crate::sh::basis::eval_basis;
use crate::sphere::{Parameterization, SphereMap};

/// Work-group size of glsl/study/reconstruct.comp.
const LOCAL_SIZE: u32 = 64;

/// `SHVIS_STUDY_PARAM`'s ids (glsl/study/reconstruct.comp): the parameterization sampled,
/// its index in `Parameterization::ALL`.
pub fn param_ids() -> ShaderIds {
    let name = |kind: Parameterization| match kind {
        Parameterization::DualOrtho => "PARAM_DUAL_ORTHO",
        Parameterization::DualParaboloid => "PARAM_DUAL_PARABOLOID",
        Parameterization::CubeDx9 => "PARAM_CUBE_DX9",
        Parameterization::CubeDx10 => "PARAM_CUBE_DX10",
    };
    ShaderIds {
        selector: "STUDY_PARAM",
        ids: Parameterization::ALL
            .iter()
            .map(|&kind| name(kind))
            .zip(0..)
            .collect(),
    }
}

/// The macros of the reconstruction shader for `Parameterization::ALL[index]`.
fn reconstruct_defines(index: u32) -> Vec<(&'static str, u32)> {
    let mut defines = vec![("STUDY_PARAM", index)];
    defines.extend(param_ids().ids);
    defines
}

/// One parameterization × resolution measured on the GPU.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct GpuStudyPoint {
    pub parameterization: Parameterization,
    pub order: u32,
    pub res: u32,
    pub samples: usize,
    /// MSE of the hardware reconstruction against the exact basis, averaged over the
    /// order's basis functions and the directions.
    pub mse_gpu: f64,
    /// The same for the CPU emulation at the same directions.
    pub mse_cpu: f64,
    /// Largest |GPU − CPU emulation| over basis functions and directions.
    pub max_abs_diff: f64,
    /// RMS of GPU − CPU emulation.
    pub rms_diff: f64,
}

/// Reconstructs the order-`max_order` basis on the GPU for each `(parameterization, res)`
/// at `directions`, reporting orders 3 and `max_order` (or just `max_order` if ≤ 3).
pub fn run_gpu_study(
    ctx: &Arc<Context>,
    configs: &[(Parameterization, u32)],
    max_order: Order,
    directions: &[DVec3],
) -> Result<Vec<GpuStudyPoint>, GpuError> {
    let basis_count = max_order.coeff_count();
    let exact: Vec<f64> = directions
        .iter()
        .flat_map(|&d| {
            let mut y = vec![0.0; basis_count];
            eval_basis(max_order, d, &mut y);
            y
        })
        .collect();
    let dir_data: Vec<[f32; 4]> = directions
        .iter()
        .map(|d| [d.x as f32, d.y as f32, d.z as f32, 0.0])
        .collect();
    let dir_buffer = Buffer::with_data(
        ctx,
        bytemuck::cast_slice(&dir_data),
        vk::BufferUsageFlags::STORAGE_BUFFER,
        "study.params.directions",
    )?;
    let values = Buffer::new(
        ctx,
        (directions.len() * basis_count * 4) as u64,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::GpuToCpu,
        "study.params.values",
    )?;
    let sampler = Sampler::new(ctx, SamplerKind::LinearClamp, "study.params.sampler")?;
    let mut points = Vec::new();
    for &(kind, res) in configs {
        let map = SphereMap::new(kind, res).map_err(|e| GpuError::Invalid {
            what: "study".into(),
            detail: e.to_string(),
        })?;
        let name = format!("study.params.{kind}.{res}");
        // Texel data: per basis function, per image (hemisphere or face), row-major.
        let faces = kind.face_count();
        let per_image = (res * res) as usize;
        let mut grids = vec![0.0f64; basis_count * map.sample_count()];
        let mut y = vec![0.0; basis_count];
        for f in 0..faces {
            for j in 0..res {
                for i in 0..res {
                    eval_basis(max_order, map.texel_center_dir(f, i, j), &mut y);
                    let t = map.texel_index(f, i, j);
                    for b in 0..basis_count {
                        grids[b * map.sample_count() + t] = y[b];
                    }
                }
            }
        }
        let texels: Vec<f32> = grids.iter().map(|&v| v as f32).collect();
        let layers: Vec<&[u8]> = texels
            .chunks_exact(per_image)
            .map(bytemuck::cast_slice)
            .collect();
        let desc = if kind == Parameterization::CubeDx10 {
            ImageDesc::texture_cube_array(vk::Format::R32_SFLOAT, res, basis_count as u32)
        } else {
            ImageDesc::texture_2d_array(
                vk::Format::R32_SFLOAT,
                res,
                res,
                basis_count as u32 * faces,
            )
        };
        let image = Image::with_data(ctx, &desc, &[layers], &name)?;
        let param_index = Parameterization::ALL
            .iter()
            .position(|&p| p == kind)
            .expect("kind is one of ALL") as u32;
        let spirv = compile_glsl(
            "study/reconstruct.comp",
            ShaderStage::Compute,
            &reconstruct_defines(param_index),
        )?;
        let pipeline = ComputePipeline::new(
            ctx,
            &ComputePipelineDesc {
                name: &name,
                spirv: &spirv,
                resources: &[
                    (0, Resource::Storage(&dir_buffer)),
                    (1, Resource::Storage(&values)),
                    (2, Resource::Texture(&image, &sampler)),
                ],
                push_constant_bytes: 12,
            },
        )?;
        let push: [u32; 3] = [
            directions.len() as u32,
            basis_count as u32,
            (res as f32).to_bits(),
        ];
        pipeline.dispatch(
            [(directions.len() as u32).div_ceil(LOCAL_SIZE), 1, 1],
            bytemuck::cast_slice(&push),
        )?;
        let gpu: &[f32] = bytemuck::cast_slice(values.read()?);
        let orders: Vec<u32> = if max_order.get() > 3 {
            vec![3, max_order.get()]
        } else {
            vec![max_order.get()]
        };
        for order in orders {
            let n_basis = (order * order) as usize;
            let (mut se_gpu, mut se_cpu, mut se_diff, mut max_diff) = (0.0, 0.0, 0.0, 0.0f64);
            for (k, &d) in directions.iter().enumerate() {
                let taps = map.bilinear_taps(d);
                for b in 0..n_basis {
                    let truth = exact[k * basis_count + b];
                    let g = gpu[k * basis_count + b] as f64;
                    let grid = &grids[b * map.sample_count()..(b + 1) * map.sample_count()];
                    let c = taps.apply(grid);
                    se_gpu += (g - truth).powi(2);
                    se_cpu += (c - truth).powi(2);
                    se_diff += (g - c).powi(2);
                    max_diff = max_diff.max((g - c).abs());
                }
            }
            let n = (directions.len() * n_basis) as f64;
            points.push(GpuStudyPoint {
                parameterization: kind,
                order,
                res,
                samples: map.sample_count(),
                mse_gpu: se_gpu / n,
                mse_cpu: se_cpu / n,
                max_abs_diff: max_diff,
                rms_diff: (se_diff / n).sqrt(),
            });
        }
    }
    Ok(points)
}

/// `gpu.csv` of `shvis study params`: one line per point, header first.
pub fn gpu_csv(points: &[GpuStudyPoint]) -> String {
    let mut csv =
        String::from("parameterization,order,res,samples,mse_gpu,mse_cpu,max_abs_diff,rms_diff\n");
    for p in points {
        csv += &format!(
            "{},{},{},{},{:.9e},{:.9e},{:.3e},{:.3e}\n",
            p.parameterization,
            p.order,
            p.res,
            p.samples,
            p.mse_gpu,
            p.mse_cpu,
            p.max_abs_diff,
            p.rms_diff
        );
    }
    csv
}

/// The markdown section `shvis study params` appends to params.md: hardware vs emulation.
pub fn gpu_summary_markdown(points: &[GpuStudyPoint], device: &str, directions: usize) -> String {
    let mut s = format!(
        "\n## On texture hardware\n\nDevice: {device}; {directions} directions (a subset of the \
         CPU set); the basis stored as R32_SFLOAT, sampled with linear filtering: real cube-map \
         arrays for cube-dx10, 2D arrays (per-face clamp-to-edge) for cube-dx9 and the dual maps.\n\n\
         | parameterization | order | res | samples | MSE (GPU) | MSE (CPU emulation) | max \\|GPU − CPU\\| | RMS GPU − CPU |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|\n"
    );
    for p in points {
        s += &format!(
            "| {} | {} | {} | {} | {:.4e} | {:.4e} | {:.2e} | {:.2e} |\n",
            p.parameterization,
            p.order,
            p.res,
            p.samples,
            p.mse_gpu,
            p.mse_cpu,
            p.max_abs_diff,
            p.rms_diff
        );
    }
    let worst = points.iter().map(|p| p.max_abs_diff).fold(0.0, f64::max);
    s += &format!(
        "\nLargest difference between the hardware and the exact-weight emulation: {worst:.2e} \
         (Vulkan guarantees ≥ 8 bits of sub-texel precision, i.e. weights within 2⁻⁹; a GPU \
         that uses exactly 8 bits shows differences near 1e-3 here).\n"
    );
    s
}

/// The GPU half of `shvis study params`: reconstructs every parameterization × resolution
/// on `ctx` at the first `gpu_directions` of the study's `directions` (same `seed`), writes
/// `gpu.csv` into `dir` and appends the summary to its `params.md` (the report's markdown,
/// through [`super::report::write`]; `params.json` stays as the CPU half wrote it).
/// Returns the CSV path.
///
/// # Errors
/// The GPU's, or [`StudyError::Io`] when a file cannot be written.
pub fn run_and_write(
    ctx: &Arc<Context>,
    dir: &std::path::Path,
    directions: usize,
    gpu_directions: usize,
    seed: u64,
) -> Result<std::path::PathBuf, StudyError> {
    let mut dirs = super::params::study_directions(directions.min(gpu_directions.max(1)), seed);
    dirs.truncate(gpu_directions.max(1));
    let configs: Vec<(Parameterization, u32)> = Parameterization::ALL
        .iter()
        .flat_map(|&p| super::params::resolutions(p).iter().map(move |&r| (p, r)))
        .collect();
    let points = run_gpu_study(ctx, &configs, Order::SIX, &dirs)?;
    let io = |path: &std::path::Path| {
        let path = path.to_path_buf();
        move |source| StudyError::Io { path, source }
    };
    let csv_path = dir.join("gpu.csv");
    crate::files::write(&csv_path, gpu_csv(&points)).map_err(io(&csv_path))?;
    let mut md = std::fs::read_to_string(dir.join("params.md")).unwrap_or_default();
    md += &gpu_summary_markdown(&points, ctx.device_name(), dirs.len());
    super::report::write(
        dir,
        &StudyReport {
            stem: "params",
            markdown: md,
            json: None,
        },
    )?;
    Ok(csv_path)
}

#[cfg(test)]
mod tests {
    use crate::gpu::{ShaderStage, compile_glsl};

    #[test]
    fn the_reconstruction_shader_compiles_for_every_parameterization() {
        for param in 0..4 {
            compile_glsl(
                "study/reconstruct.comp",
                ShaderStage::Compute,
                &super::reconstruct_defines(param),
            )
            .unwrap();
        }
    }
}
