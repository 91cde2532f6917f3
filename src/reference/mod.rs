//! CPU ground truth for the techniques (DESIGN §5 `reference`).
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
//!
//! # Inter-reflection (`--bounces N`, for `shlmap`)
//!
//! With N > 0 a second image adds light reflected off the scene up to N times, the
//! quantity the SH lightmap bakes ([`crate::bake::shlmap`]). The integral splits into the
//! environment seen directly (the estimator above) and the surfaces seen instead of it:
//!
//! ```text
//! L_in(x, ω) = L_env(ω) V(x, ω) + ρ(x')/π · E_{N−1}(x')  (x' the front face hit along ω)
//! E_k(x')    = ∫ L_env V max(0, n'·ω) dω + [k > 0] ∫ ρ(x'')/π E_{k−1}(x'') max(0, n'·ω) dω
//! ```
//!
//! The surface part is estimated by one cosine-weighted direction about the shading normal
//! per sample (pdf cos/π, so the estimate is π × the radiance found; directions below n_g's
//! plane count 0), closest-hit traced; at the hit ([`crate::bake::surface`]: oriented
//! geometric normal n', albedo ρ, back faces reflect nothing) E is estimated recursively
//! the same way: one environment sample with a shadow ray plus, while bounces remain, one
//! more cosine-weighted direction. Every term is an unbiased estimate of its integral, so
//! the image converges to the N-bounce solution; the direct image comes from the same
//! samples at no extra cost.

pub mod specular;

use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use crate::bake::surface::SurfaceReader;
use crate::bake::trace::Tracer;
use crate::env::EnvMap;
use crate::env::sampler::{EnvSampler, Pcg32};
use crate::gpu::layout::ShaderIds;
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
    /// Reflections of light added in [`ReferenceImage::bounced`] (0: direct light only).
    pub bounces: u32,
    /// Integrate each pixel's footprint (box filter, stratified sub-pixel positions, the
    /// material textures at full resolution); `false`: one G-buffer sample at the pixel
    /// centre with MIP-filtered textures, the techniques' own sampling (`--point`).
    pub footprint: bool,
}

impl ReferenceSettings {
    /// The footprint reference of direct light at `width` × `height`, `spp` samples per
    /// pixel, seed 0: what the studies measure against.
    pub fn footprint_direct(width: u32, height: u32, spp: u32) -> Self {
        ReferenceSettings {
            width,
            height,
            spp,
            seed: 0,
            bounces: 0,
            footprint: true,
        }
    }
}

/// Most sub-pixel strata per side of the footprint reference (8 × 8 = 64 G-buffer sets).
pub const MAX_STRATA_SIDE: u32 = 8;

/// The sub-pixel strata of a reference: `side`² cells of the pixel, each sampled at one
/// jittered position shared by all pixels; sample s of a pixel belongs to cell s mod side².
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Strata {
    pub side: u32,
}

impl Strata {
    /// ⌊√spp⌋ per side (at most [`MAX_STRATA_SIDE`]) for the footprint, 1 for point sampling.
    pub fn new(settings: &ReferenceSettings) -> Strata {
        let side = if settings.footprint {
            ((settings.spp as f64).sqrt().floor() as u32).clamp(1, MAX_STRATA_SIDE)
        } else {
            1
        };
        Strata { side }
    }

    pub fn count(self) -> u32 {
        self.side * self.side
    }

    /// Samples of `spp` that fall in stratum `j`.
    pub fn samples_in(self, j: u32, spp: u32) -> u32 {
        (spp - j).div_ceil(self.count())
    }

    /// Sub-pixel position (x, y in [0, 1)², y down) of stratum `j` under `seed`.
    pub fn position(self, j: u32, seed: u64) -> [f32; 2] {
        let mut rng = Pcg32::new(seed ^ 0x5354_5241_5441, u64::from(j)); // "STRATA"
        let (cx, cy) = (j % self.side, j / self.side);
        let k = self.side as f64;
        [
            ((cx as f64 + rng.next_f64()) / k) as f32,
            ((cy as f64 + rng.next_f64()) / k) as f32,
        ]
    }
}

/// The reference image and how noisy it is.
pub struct ReferenceImage {
    pub frame: Frame,
    /// √(Σ σ²_pixel) / √(Σ value²) over covered pixels and channels: the relative RMS
    /// error the Monte Carlo noise alone would give.
    pub rel_noise: f64,
    /// With `bounces` > 0: direct plus inter-reflected light (module doc).
    pub bounced: Option<BouncedImage>,
    pub seconds: f64,
    pub rays: u64,
    /// How the pixel footprint was sampled (1 × 1: point sampling).
    pub strata: Strata,
}

/// The reference with inter-reflection.
pub struct BouncedImage {
    pub bounces: u32,
    pub frame: Frame,
    /// As [`ReferenceImage::rel_noise`].
    pub rel_noise: f64,
}

/// Per-image sums of the noise estimate.
#[derive(Clone, Copy, Default)]
struct NoiseSums {
    var: f64,
    sq: f64,
}

impl NoiseSums {
    fn rel_noise(&self) -> f64 {
        if self.sq > 0.0 {
            (self.var / self.sq).sqrt()
        } else {
            0.0
        }
    }
}

/// Mean and variance of the mean of one pixel's samples, per channel.
#[derive(Clone, Copy, Default)]
struct PixelSums {
    sum: [f64; 3],
    sum_sq: [f64; 3],
}

impl PixelSums {
    /// Adds the sample `v` · `k` (per channel).
    fn add(&mut self, v: Vec3, k: [f64; 3]) {
        for c in 0..3 {
            let v = v[c] as f64 * k[c];
            self.sum[c] += v;
            self.sum_sq[c] += v * v;
        }
    }

    /// Writes `k` × the mean of `spp` samples into `out` (alpha `coverage`) and adds to the
    /// noise sums.
    fn finish(
        &self,
        spp: u32,
        k: [f64; 3],
        coverage: f32,
        out: &mut [f32; 4],
        noise: &mut NoiseSums,
    ) {
        let n = spp as f64;
        for c in 0..3 {
            let mean = self.sum[c] / n;
            let var_of_mean = (self.sum_sq[c] / n - mean * mean).max(0.0) / n;
            out[c] = (k[c] * mean) as f32;
            noise.var += k[c] * k[c] * var_of_mean;
            noise.sq += (k[c] * mean).powi(2);
        }
        out[3] = coverage;
    }
}

/// What one pixel has gathered over the strata.
#[derive(Clone, Copy, Default)]
struct PixelAccumulator {
    direct: PixelSums,
    total: PixelSums,
    /// Samples that landed on geometry (the rest see the background, radiance 0).
    covered: u32,
    /// Point sampling: the pixel's albedo/π, applied to the mean.
    scale: [f64; 3],
}

/// The four G-buffer images of one sub-pixel position.
struct GBuffer {
    position: Frame,
    normal: Frame,
    albedo: Frame,
    vertex_normal: Frame,
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
            detail: "--ref-spp must be at least 1".into(),
        });
    }
    let start = Instant::now();
    let mut gpu = SceneGpu::new(
        ctx,
        scene,
        &FrameSettings {
            width: settings.width,
            height: settings.height,
            flat_normals: false,
            float32_target: true,
            material_level0: false,
        },
    )?;
    let pipelines = gbuffer_pipelines(ctx, &gpu, settings.footprint, 4)?;
    let tracer = Tracer::new(&scene.mesh);
    let sampler = EnvSampler::new(env);
    let surfaces = SurfaceReader::new(scene);
    let paths = Paths {
        tracer: &tracer,
        sampler: &sampler,
        surfaces: &surfaces,
    };
    let strata = Strata::new(settings);
    let w = settings.width as usize;
    let mut pixels = vec![PixelAccumulator::default(); w * settings.height as usize];
    let mut rays = 0u64;
    for j in 0..strata.count().min(settings.spp) {
        if settings.footprint {
            let [sx, sy] = strata.position(j, settings.seed);
            gpu.set_jitter([0.5 - sx, 0.5 - sy])?;
        }
        let mut frames = Vec::with_capacity(4);
        for pipeline in &pipelines {
            frames.push(gpu.render_pipeline(pipeline, 0, 1)?);
        }
        let [position, normal, albedo, vertex_normal] =
            <[Frame; 4]>::try_from(frames).map_err(|_| GpuError::Invalid {
                what: "reference".into(),
                detail: "G-buffer passes".into(),
            })?;
        let gbuffer = GBuffer {
            position,
            normal,
            albedo,
            vertex_normal,
        };
        let job = StratumJob {
            paths: &paths,
            gbuffer: &gbuffer,
            settings,
            strata,
            stratum: j,
        };
        rays += pixels
            .par_chunks_mut(w)
            .enumerate()
            .with_max_len(1)
            .map(|(y, row)| job.accumulate_row(y, row))
            .sum::<u64>();
    }
    Ok(finish_image(&pixels, settings, strata, start, rays))
}

/// The point-sampled G-buffer with the lightmap UV: what the techniques' fragment shaders
/// see at each pixel centre, for the CPU rungs of the error ladder (`crate::attribution`).
pub struct PointGBuffer {
    pub position: Frame,
    /// Normal-mapped shading normal (MIP-filtered normal map, as the techniques read it).
    pub normal: Frame,
    /// Linear albedo (MIP-filtered).
    pub albedo: Frame,
    /// Interpolated vertex normal (the tangent plane of "V = 0 below").
    pub vertex_normal: Frame,
    /// Lightmap UV in .xy.
    pub uv_lightmap: Frame,
    /// The normal map's tangent-space normal.
    pub tangent_normal: Frame,
    /// Tangent and bitangent of the normal map's world frame (`common.glsl`'s
    /// `tangent_frame`; the interpolated vertex normal is the third column).
    pub tangent: Frame,
    pub bitangent: Frame,
}

/// Renders [`PointGBuffer`] of `scene` from its camera (RGBA32F, no jitter).
pub fn render_point_gbuffer(
    ctx: &Arc<Context>,
    scene: &Scene,
    width: u32,
    height: u32,
) -> Result<PointGBuffer, GpuError> {
    let gpu = SceneGpu::new(
        ctx,
        scene,
        &FrameSettings {
            width,
            height,
            flat_normals: false,
            float32_target: true,
            material_level0: false,
        },
    )?;
    let mut frames = Vec::with_capacity(GBUFFER_OUTPUTS as usize);
    for pipeline in &gbuffer_pipelines(ctx, &gpu, false, GBUFFER_OUTPUTS)? {
        frames.push(gpu.render_pipeline(pipeline, 0, 1)?);
    }
    let mut frames = frames.into_iter();
    let mut next = || frames.next().expect("a pass per G-buffer output");
    Ok(PointGBuffer {
        position: next(),
        normal: next(),
        albedo: next(),
        vertex_normal: next(),
        uv_lightmap: next(),
        tangent_normal: next(),
        tangent: next(),
        bitangent: next(),
    })
}

/// Outputs of `glsl/reference/gbuffer.frag` ([`PointGBuffer`]'s frames).
const GBUFFER_OUTPUTS: u32 = 8;

/// The ids of `SHVIS_GBUFFER_OUTPUT`, the output glsl/reference/gbuffer.frag writes, in
/// output order.
const GBUFFER_OUTPUT_NAMES: [&str; GBUFFER_OUTPUTS as usize] = [
    "GBUFFER_POSITION",
    "GBUFFER_NORMAL",
    "GBUFFER_ALBEDO",
    "GBUFFER_VERTEX_NORMAL",
    "GBUFFER_UV_LIGHTMAP",
    "GBUFFER_TANGENT_NORMAL",
    "GBUFFER_TANGENT",
    "GBUFFER_BITANGENT",
];

/// `SHVIS_GBUFFER_OUTPUT`'s ids: output i is i.
pub fn gbuffer_output_ids() -> ShaderIds {
    ShaderIds {
        selector: "GBUFFER_OUTPUT",
        ids: GBUFFER_OUTPUT_NAMES.iter().copied().zip(0..).collect(),
    }
}

/// The macros of G-buffer output `output` (material textures at full resolution with
/// `level0`).
fn gbuffer_defines(output: u32, level0: bool) -> Vec<(&'static str, u32)> {
    let mut defines = vec![
        ("GBUFFER", 1),
        ("GBUFFER_OUTPUT", output),
        ("MATERIAL_LEVEL0", level0 as u32),
    ];
    defines.extend(gbuffer_output_ids().ids);
    defines
}

/// The first `outputs` G-buffer pipelines (position, shading normal, albedo, vertex normal,
/// lightmap UV, tangent-space normal, tangent, bitangent); with `level0` the material textures are read at full resolution.
pub(crate) fn gbuffer_pipelines(
    ctx: &Arc<Context>,
    gpu: &SceneGpu,
    level0: bool,
    outputs: u32,
) -> Result<Vec<crate::gpu::MeshPipeline>, GpuError> {
    (0..outputs)
        .map(|output| {
            let id = GBUFFER_OUTPUT_NAMES[output as usize];
            let name = format!(
                "reference.gbuffer.{}",
                id.trim_start_matches("GBUFFER_").to_lowercase()
            );
            let fragment = compile_glsl(
                "reference/gbuffer.frag",
                ShaderStage::Fragment,
                &gbuffer_defines(output, level0),
            )?;
            gpu.mesh_pipeline(ctx, &name, &fragment, &gpu.common_resources())
        })
        .collect()
}

/// The samples of one stratum for every pixel.
struct StratumJob<'a> {
    paths: &'a Paths<'a>,
    gbuffer: &'a GBuffer,
    settings: &'a ReferenceSettings,
    strata: Strata,
    stratum: u32,
}

impl StratumJob<'_> {
    /// Adds this stratum's samples of row `y` to `row`; returns the rays traced.
    fn accumulate_row(&self, y: usize, row: &mut [PixelAccumulator]) -> u64 {
        let (g, settings) = (self.gbuffer, self.settings);
        let (tracer, w) = (self.paths.tracer, settings.width as usize);
        let n = self.strata.samples_in(self.stratum, settings.spp);
        let bounces = settings.bounces;
        let mut rays = 0u64;
        for (x, acc) in row.iter_mut().enumerate() {
            let i = y * w + x;
            if g.position.rgba[i][3] < 0.5 {
                continue;
            }
            let p = Vec3::from_slice(&g.position.rgba[i][..3]);
            let n_s = Vec3::from_slice(&g.normal.rgba[i][..3]).normalize_or_zero();
            let n_g = Vec3::from_slice(&g.vertex_normal.rgba[i][..3]).normalize_or_zero();
            let origin = tracer.offset_origin(p, n_g);
            let albedo_over_pi =
                std::array::from_fn(|c| g.albedo.rgba[i][c] as f64 / std::f64::consts::PI);
            // Point sampling scales the mean by the one albedo; the footprint each sample.
            let k = if settings.footprint {
                albedo_over_pi
            } else {
                acc.scale = albedo_over_pi;
                [1.0; 3]
            };
            let stream = i as u64 * u64::from(self.strata.count()) + u64::from(self.stratum);
            let mut rng = Pcg32::new(settings.seed, stream);
            for _ in 0..n {
                let d = self.paths.direct(origin, n_s, n_g, &mut rng, &mut rays);
                acc.direct.add(d, k);
                if bounces > 0 {
                    let e = self
                        .paths
                        .indirect(origin, n_s, n_g, bounces - 1, &mut rng, &mut rays);
                    acc.total.add(d + e, k);
                }
            }
            acc.covered += n;
        }
        rays
    }
}

/// Means, coverage and noise of the accumulated pixels.
fn finish_image(
    pixels: &[PixelAccumulator],
    settings: &ReferenceSettings,
    strata: Strata,
    start: Instant,
    rays: u64,
) -> ReferenceImage {
    let bounces = settings.bounces;
    let mut rgba = vec![[0.0f32; 4]; pixels.len()];
    let mut rgba_bounced = vec![[0.0f32; 4]; if bounces > 0 { pixels.len() } else { 0 }];
    let (mut noise, mut noise_bounced) = (NoiseSums::default(), NoiseSums::default());
    for (i, acc) in pixels.iter().enumerate() {
        if acc.covered == 0 {
            continue;
        }
        let (k, coverage) = if settings.footprint {
            ([1.0; 3], acc.covered as f32 / settings.spp as f32)
        } else {
            (acc.scale, 1.0)
        };
        acc.direct
            .finish(settings.spp, k, coverage, &mut rgba[i], &mut noise);
        if bounces > 0 {
            acc.total.finish(
                settings.spp,
                k,
                coverage,
                &mut rgba_bounced[i],
                &mut noise_bounced,
            );
        }
    }
    let frame = |rgba| Frame {
        width: settings.width,
        height: settings.height,
        rgba,
        ms: vec![],
    };
    ReferenceImage {
        frame: frame(rgba),
        rel_noise: noise.rel_noise(),
        bounced: (bounces > 0).then(|| BouncedImage {
            bounces,
            frame: frame(rgba_bounced),
            rel_noise: noise_bounced.rel_noise(),
        }),
        seconds: start.elapsed().as_secs_f64(),
        rays,
        strata,
    }
}

/// The estimators of the module doc over one scene and environment.
struct Paths<'a> {
    tracer: &'a Tracer,
    sampler: &'a EnvSampler<'a>,
    surfaces: &'a SurfaceReader<'a>,
}

impl Paths<'_> {
    /// One sample of ∫ L_env V max(0, n_s·ω) dω (V = 0 below n_g's plane).
    fn direct(&self, origin: Vec3, n_s: Vec3, n_g: Vec3, rng: &mut Pcg32, rays: &mut u64) -> Vec3 {
        let (dir, radiance, pdf) = self.sampler.sample(rng);
        let cos = n_s.dot(dir);
        if cos <= 0.0 || n_g.dot(dir) <= 0.0 || pdf <= 0.0 {
            return Vec3::ZERO;
        }
        *rays += 1;
        if self.tracer.occluded(origin, dir, f32::INFINITY) {
            return Vec3::ZERO;
        }
        Vec3::from(radiance) * (cos as f64 / pdf) as f32
    }

    /// One sample of ∫ ρ(x')/π E_k(x') max(0, n_s·ω) dω over the surfaces seen from
    /// `origin`, k = `remaining` further reflections.
    fn indirect(
        &self,
        origin: Vec3,
        n_s: Vec3,
        n_g: Vec3,
        remaining: u32,
        rng: &mut Pcg32,
        rays: &mut u64,
    ) -> Vec3 {
        if n_s == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let dir = cosine_sample(n_s, rng);
        if n_g.dot(dir) <= 0.0 {
            return Vec3::ZERO;
        }
        *rays += 1;
        let Some(hit) = self.tracer.closest_hit(origin, dir) else {
            return Vec3::ZERO;
        };
        let surface = self.surfaces.at(&hit, origin, dir);
        if !surface.front_face {
            return Vec3::ZERO;
        }
        let n = surface.normal;
        let next = self.tracer.offset_origin(surface.position, n);
        let mut e = self.direct(next, n, n, rng, rays);
        if remaining > 0 {
            e += self.indirect(next, n, n, remaining - 1, rng, rays);
        }
        // π · (ρ/π · E): the cosine-weighted pdf cancels the cosine and 1/π.
        surface.albedo * e
    }
}

/// A direction about unit `n` with pdf max(0, n·ω)/π (Malley's method).
fn cosine_sample(n: Vec3, rng: &mut Pcg32) -> Vec3 {
    let (u1, u2) = (rng.next_f64(), rng.next_f64());
    let r = u1.sqrt();
    let phi = 2.0 * std::f64::consts::PI * u2;
    let (t, b) = n.any_orthonormal_pair();
    let z = (1.0 - u1).max(0.0).sqrt();
    (t * (r * phi.cos()) as f32 + b * (r * phi.sin()) as f32 + n * z as f32).normalize()
}

#[cfg(test)]
mod tests {
    use crate::gpu::{ShaderStage, compile_glsl};

    #[test]
    fn every_g_buffer_output_compiles() {
        for output in 0..super::GBUFFER_OUTPUTS {
            compile_glsl(
                "reference/gbuffer.frag",
                ShaderStage::Fragment,
                &super::gbuffer_defines(output, output % 2 == 1),
            )
            .unwrap();
        }
    }
}
