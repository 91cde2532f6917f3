//! CPU ground truth for the techniques (DESIGN §5 `reference`, issue 5).
//!
//! Per pixel, the same rasterization as the techniques gives world position, shading
//! (normal-mapped) normal, linear albedo and the interpolated vertex normal — four
//! G-buffer passes into RGBA32F (glsl/reference/gbuffer.frag) — and the CPU integrates
//!
//! ```text
//! radiance = albedo/π · ∫ L(ω) V(x, ω) max(0, n_s·ω) dω,   V = 0 below the tangent plane of n_g
//! ```
//!
//! (DESIGN §1's shading model, Iwanicki–Sloan eq. (4) without any SH truncation) by Monte
//! Carlo over the full-resolution environment map: texels are importance-sampled in
//! proportion to luminance × exact solid angle, a direction uniform in solid angle within
//! the chosen texel, so pdf(ω) = p_texel / Ω_texel exactly and the estimator is unbiased for
//! the piecewise-constant map (the same reading of the map as `env::project`). Visibility
//! is an any-hit ray from the G-buffer point offset along n_g (`bake::trace`). Samples come
//! from a per-pixel PCG stream seeded by (seed, pixel): identical results for any thread
//! count. The noise level is estimated from the per-pixel sample variance and reported as
//! the image's relative standard error, comparable to the techniques' relative RMSE.

use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use crate::bake::trace::Tracer;
use crate::env::EnvMap;
use crate::gpu::{Context, GpuError, ShaderStage, compile_glsl};
use crate::render::{Frame, FrameSettings, SceneGpu};
use crate::scene::Scene;

/// How the reference is rendered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceSettings {
    pub width: u32,
    pub height: u32,
    /// Environment samples per pixel.
    pub spp: u32,
    pub seed: u64,
}

/// The reference image and how noisy it is.
pub struct ReferenceImage {
    pub frame: Frame,
    /// √(Σ σ²_pixel) / √(Σ value²) over covered pixels and channels: the relative RMS
    /// error the Monte Carlo noise alone would give.
    pub rel_noise: f64,
    pub seconds: f64,
    pub rays: u64,
}

/// Renders the reference for `scene` under `env` from the scene's camera.
pub fn render_reference(
    ctx: &Arc<Context>,
    scene: &Scene,
    env: &EnvMap,
    settings: &ReferenceSettings,
) -> Result<ReferenceImage, GpuError> {
    if settings.spp == 0 {
        return Err(GpuError::Invalid {
            what: "reference".into(),
            detail: "--spp must be at least 1".into(),
        });
    }
    let start = Instant::now();
    let gpu = SceneGpu::new(
        ctx,
        scene,
        &FrameSettings {
            width: settings.width,
            height: settings.height,
            flat_normals: false,
            float32_target: true,
        },
    )?;
    let mut passes = Vec::with_capacity(4);
    for output in 0..4u32 {
        let name = format!(
            "reference.gbuffer.{}",
            ["position", "normal", "albedo", "vertex_normal"][output as usize]
        );
        let fragment = compile_glsl(
            "reference/gbuffer.frag",
            ShaderStage::Fragment,
            &[("GBUFFER", 1), ("GBUFFER_OUTPUT", output)],
        )?;
        let pipeline = gpu.mesh_pipeline(ctx, &name, &fragment, &gpu.common_resources())?;
        passes.push(gpu.render_pipeline(&pipeline, 0, 1)?);
    }
    let [position, normal, albedo, vertex_normal] =
        <[Frame; 4]>::try_from(passes).map_err(|_| GpuError::Invalid {
            what: "reference".into(),
            detail: "G-buffer passes".into(),
        })?;

    let tracer = Tracer::new(&scene.mesh);
    let sampler = EnvSampler::new(env);
    let (w, h) = (settings.width as usize, settings.height as usize);
    let rows: Vec<(Vec<[f32; 4]>, f64, f64, u64)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut row = vec![[0.0f32; 4]; w];
            let (mut var_sum, mut sq_sum, mut rays) = (0.0, 0.0, 0u64);
            for (x, out) in row.iter_mut().enumerate() {
                let i = y * w + x;
                if position.rgba[i][3] < 0.5 {
                    continue;
                }
                let p = Vec3::from_slice(&position.rgba[i][..3]);
                let n_s = Vec3::from_slice(&normal.rgba[i][..3]).normalize_or_zero();
                let n_g = Vec3::from_slice(&vertex_normal.rgba[i][..3]).normalize_or_zero();
                let a = &albedo.rgba[i];
                let origin = tracer.offset_origin(p, n_g);
                let mut rng = Pcg32::new(settings.seed, i as u64);
                let mut sum = [0.0f64; 3];
                let mut sum_sq = [0.0f64; 3];
                for _ in 0..settings.spp {
                    let (dir, radiance, pdf) = sampler.sample(&mut rng);
                    let cos = n_s.dot(dir);
                    if cos <= 0.0 || n_g.dot(dir) <= 0.0 || pdf <= 0.0 {
                        continue;
                    }
                    rays += 1;
                    if tracer.occluded(origin, dir, f32::INFINITY) {
                        continue;
                    }
                    for c in 0..3 {
                        let v = radiance[c] as f64 * cos as f64 / pdf;
                        sum[c] += v;
                        sum_sq[c] += v * v;
                    }
                }
                let n = settings.spp as f64;
                for c in 0..3 {
                    let mean = sum[c] / n;
                    let var_of_mean = (sum_sq[c] / n - mean * mean).max(0.0) / n;
                    let k = a[c] as f64 / std::f64::consts::PI;
                    out[c] = (k * mean) as f32;
                    var_sum += k * k * var_of_mean;
                    sq_sum += (k * mean).powi(2);
                }
                out[3] = 1.0;
            }
            (row, var_sum, sq_sum, rays)
        })
        .collect();
    let mut rgba = Vec::with_capacity(w * h);
    let (mut var_sum, mut sq_sum, mut rays) = (0.0, 0.0, 0u64);
    for (row, v, s, r) in rows {
        rgba.extend(row);
        var_sum += v;
        sq_sum += s;
        rays += r;
    }
    Ok(ReferenceImage {
        frame: Frame {
            width: settings.width,
            height: settings.height,
            rgba,
            ms: vec![],
        },
        rel_noise: if sq_sum > 0.0 {
            (var_sum / sq_sum).sqrt()
        } else {
            0.0
        },
        seconds: start.elapsed().as_secs_f64(),
        rays,
    })
}

/// Importance sampling of an equirect map by luminance × texel solid angle.
pub struct EnvSampler<'a> {
    env: &'a EnvMap,
    /// Cumulative weights over texels (row-major), last = total.
    cdf: Vec<f64>,
}

impl<'a> EnvSampler<'a> {
    pub fn new(env: &'a EnvMap) -> Self {
        let mut cdf = Vec::with_capacity(env.texels.len());
        let mut total = 0.0;
        for y in 0..env.height {
            let omega = env.texel_solid_angle(y);
            for x in 0..env.width {
                let [r, g, b] = env.texel(x, y);
                total +=
                    (0.2126 * r as f64 + 0.7152 * g as f64 + 0.0722 * b as f64).max(0.0) * omega;
                cdf.push(total);
            }
        }
        EnvSampler { env, cdf }
    }

    /// (direction, radiance, pdf per steradian) of one sample.
    fn sample(&self, rng: &mut Pcg32) -> (Vec3, [f32; 3], f64) {
        let total = *self.cdf.last().unwrap_or(&0.0);
        if total <= 0.0 {
            return (Vec3::Y, [0.0; 3], 0.0);
        }
        let target = rng.next_f64() * total;
        let t = self
            .cdf
            .partition_point(|&c| c <= target)
            .min(self.cdf.len() - 1);
        let (w, h) = (self.env.width as usize, self.env.height as usize);
        let (x, y) = (t % w, t / w);
        let p_texel = (self.cdf[t] - if t > 0 { self.cdf[t - 1] } else { 0.0 }) / total;
        let omega = self.env.texel_solid_angle(y as u32);
        // Uniform in solid angle within the texel: φ uniform, cos θ uniform.
        let pi = std::f64::consts::PI;
        let (theta0, theta1) = (pi * y as f64 / h as f64, pi * (y + 1) as f64 / h as f64);
        let cos_theta = theta0.cos() + rng.next_f64() * (theta1.cos() - theta0.cos());
        let u = (x as f64 + rng.next_f64()) / w as f64;
        let phi = 2.0 * pi * (u - 0.5);
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let dir = Vec3::new(
            (sin_theta * phi.sin()) as f32,
            cos_theta as f32,
            (-sin_theta * phi.cos()) as f32,
        );
        (dir, self.env.texels[t], p_texel / omega)
    }
}

/// PCG32 (O'Neill), one stream per pixel.
struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed ^ 0x853C_49E6_748F_EA9B);
        rng.next_u32();
        rng
    }
    fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }
    /// Uniform in [0, 1) with 53 bits.
    fn next_f64(&mut self) -> f64 {
        let hi = (self.next_u32() >> 5) as u64;
        let lo = (self.next_u32() >> 6) as u64;
        ((hi << 26) | lo) as f64 / (1u64 << 53) as f64
    }
}
