//! Appendix A on the real device: hardware reconstruction of the stored SH basis agrees
//! with the CPU emulation of `shvis::sphere` up to the texture unit's sub-texel precision,
//! and validation stays silent.

mod common;

use shvis::sh::Order;
use shvis::sphere::Parameterization;
use shvis::study::params::study_directions;
use shvis::study::params_gpu::run_gpu_study;

/// Vulkan requires ≥ 8 bits of sub-texel precision: a weight may be off by 2⁻⁹, so a
/// reconstruction by at most 2⁻⁹ × (the largest difference between neighbouring texels,
/// ≤ 2·max|y| ≈ 2 for order 6 at res 8) ≈ 4e-3, plus f32 storage.
const SUBTEXEL_BOUND: f64 = 4e-3;
/// The GPU's MSE may differ from the emulation's only by that rounding: relative 5 %.
const MSE_AGREEMENT: f64 = 0.05;

#[test]
fn hardware_reconstruction_matches_the_emulation() {
    let ctx = common::validated_context();
    let configs: Vec<_> = Parameterization::ALL.iter().map(|&p| (p, 8)).collect();
    let dirs = study_directions(4096, 7);
    let points = run_gpu_study(&ctx, &configs, Order::SIX, &dirs).expect("GPU study runs");
    assert_eq!(points.len(), 8);
    for p in &points {
        println!(
            "{} res {} order {}: mse gpu {:.4e} cpu {:.4e}, max |gpu−cpu| {:.2e}, rms {:.2e}",
            p.parameterization, p.res, p.order, p.mse_gpu, p.mse_cpu, p.max_abs_diff, p.rms_diff
        );
        assert!(p.max_abs_diff < SUBTEXEL_BOUND, "{p:?}");
        assert!(
            (p.mse_gpu - p.mse_cpu).abs() <= MSE_AGREEMENT * p.mse_cpu,
            "{p:?}"
        );
    }
    common::assert_validation_clean(&ctx, "study");
}
