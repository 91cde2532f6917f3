//! SH lightmap: per lightmap texel, the order-3 SH of *incident radiance* including
//! inter-reflection, for one static lighting — the `shlmap` baseline of Iwanicki–Sloan §5
//! ("SH lightmaps (storing 3rd order SH lighting)"; DESIGN §2).
//!
//! # What is baked
//!
//! For a covered texel at x with geometric normal n_g and the bake's shared direction set
//! {ω_r} (weights w = 4π/R, [`super::directions`]),
//!
//! ```text
//! c_i(x) = Σ_{r: n_g·ω_r > 0} w · L_in(x, ω_r) · y_i(ω_r),   i < 9                   (1)
//! L_in(x, ω) = L_env(ω)                         if the ray escapes
//!            = ρ(x')/π · E_{k−1}(x')            if it hits the front of a surface at x'
//!            = 0                                if it hits a back face
//! E_k(x)    = Σ_{l<3} A_l Σ_m c^k_lm(x) y_lm(n_g(x))                                  (2)
//! ```
//!
//! Bounce k = 0 is direct light only (E_{−1} = 0); each further bounce re-traces the same
//! rays with the previous bounce's irradiance (2) read at the hit texel of the lightmap
//! (gutters dilated, so hits near chart borders read their chart). `bounces` = N gives
//! light that has reflected up to N times before reaching x. L_env is the environment's SH
//! at the lighting order (8), the same smooth lighting the `unc*` tables use, evaluated at
//! each ray direction: a small sun is not aliased by the shared directions (or, with
//! `--bake-env pixels`, the map itself, eq. (6)). ρ is the surface's albedo
//! ([`super::surface`]).
//!
//! Shading (`glsl/technique/shlmap.frag`) convolves the 9 coefficients with the clamped
//! cosine (A_l: π, 2π/3, π/4) and evaluates at the normal-mapped normal — the paper's
//! "shade by convolution at the normal". The coefficients of (1) include directions below
//! the shading normal but above n_g's plane, so a bent normal sees what it should.
//!
//! # Radiosity-normal-mapping lightmaps (`rnm`)
//!
//! The same rays also gather, per texel, the three lightmaps of Green's radiosity normal
//! mapping: the irradiance around each HL2 basis direction B_i ([`super::ssbump::hl2_basis`])
//! carried into world space by the texel's normal-map frame (interpolated vertex normal
//! n_s, tangent t, bitangent w·(n_s × t) — the frame the shader decodes the normal map in):
//!
//! ```text
//! E_i(x) = Σ_{r: n_g·ω_r > 0} w · L_in(x, ω_r) · max(0, ω_r · B_i(x)),   i < 3           (3)
//! ```
//!
//! The lobe is the clamped cosine about B_i, cut by the geometric horizon like (1): what
//! Valve's radiosity tool gathers (each bump lightmap is the irradiance a surface facing B_i
//! would receive). Three such lobes do not add up to the cosine about the normal — under a
//! uniform sky each gathers π(1 + 1/√3)/2 ≈ 0.79π, not π — so, as Valve's tools do when they
//! store the maps (`ColorSpace::LinearToBumpedLightmap` rescales the three to the flat
//! lightmap), each texel's three values are scaled per channel by
//!
//! ```text
//! k⁺ = E⁺_flat / (⅓ Σ_i E⁺_i),   E⁺ = (3) with L_in⁺ = max(0, L_in),
//! E⁺_flat = Σ_r w · L_in⁺(x, ω_r) · max(0, ω_r · n_s)                                    (4)
//! ```
//!
//! with the normalization matched to Listing 1 (Σ D_i = 1, D = ⅓ for the unperturbed
//! normal): the unperturbed normal then shades with the irradiance about n_s (exactly where
//! the radiance is non-negative), and
//! the lobes keep their ratios — the direction of the light. L_in is (1)'s, so the maps
//! carry the same visibility and inter-reflection as the SH lightmap and the two compare
//! like for like.
//!
//! k⁺ is the lobes' geometry — how much of the light about n_s the three tilted lobes
//! catch — measured on the positive part of the radiance, where it is well posed: every
//! direction of the n_s hemisphere lies in some lobe with max_i ω·B_i ≥ (1/√3) ω·n_s, so
//! ⅓ Σ E⁺_i ≥ E⁺_flat / (3√3) and k⁺ ≤ 3√3 ≈ 5.2. The signed L_in cannot give it: the
//! environment's order-8 SH rings below zero around a small sun, a channel's three signed
//! lobes can cancel to almost nothing while the flat one does not, and the plain ratio
//! E_flat / ⅓ Σ E_i reached 10⁴ (a covered texel) and 10⁷ (a gutter) on the house at
//! 128² × 256 rays. Nor can the gathers themselves drop the negative part: the ringing,
//! which cancels in the signed sums, would add its positive half (rnm 1.7× too bright on
//! the same house).
//!
//! # Bases fitted from the samples (`--basis-fit samples`)
//!
//! The last pass knows each ray's whole radiance — the environment where it escapes (the
//! direct pass gathered it into (1)), the bounce where it hits a front face, nothing off a
//! back face or below the horizon — so there every tangent-frame basis the run asks for is
//! fitted from the texel's samples,
//!
//! ```text
//! S(x) = {(Tᵀ ω_r, w, L_in(x, ω_r)) : r < R},   L_in = 0 below n_g's horizon            (5)
//! ```
//!
//! T the texel's orthonormal normal-map frame ([`texel_frame`]), by `crate::sh::samples`
//! (the H-basis, SG under each solver, Ambient Dice, the ambient cube): the same rays as
//! (1), no basis fitted from another. A texel's samples live only while it is fitted; the
//! fits are stored per texel ([`FittedBasis`], f16 under a power-of-two scale per texel and
//! basis: [`BlockF16`]) and dilated like the coefficients.
//! L_env is what the bake's lighting gives at the ray's direction, as for (1).
//!
//! # The environment the rays see (`--bake-env`)
//!
//! With `sh` (the default) L_env is the environment's SH at the lighting order (8) at each
//! shared direction: the smooth lighting the PRT techniques see, so every row of a table is
//! lit alike; a small sun is not aliased, it is blurred and rings. With `pixels` it is the
//! full-resolution map (piecewise constant, `crate::env::sampler`), and each texel traces
//! M = R/4 rays of its own drawn from the map in proportion to luminance × solid angle
//! (pdf_env, the same in every pass: a stream of the seed and the texel). The shared
//! directions (uniform, pdf 1/4π) and the texel's own are combined by the balance
//! heuristic (Veach & Guibas 1995): every ray s, of either kind, carries its whole L_in and
//! enters (1), (3)–(5) with the weight
//!
//! ```text
//! w(ω_s) = 1 / (R/4π + M · pdf_env(ω_s))                                                 (6)
//! ```
//!
//! in place of 4π/R, which keeps each sum unbiased for its integral: a sun that the shared
//! directions would miss, or hit at 4π/R each, is reached by the texel's own rays and
//! weighed by their density. With `sh` M = 0 and (6) is 4π/R.
//!
//! Texels are independent within a pass and sum their rays in a fixed order, so a bake is
//! bit-identical for any thread count. Results are dilated
//! [`DILATION_PASSES`](super::visibility::DILATION_PASSES) texels into the gutters, as the
//! visibility bake's are.

use std::ops::{Add, Mul};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::{DVec3, Vec3};

use rayon::prelude::*;

use super::directions::{DirectionSet, above_horizon};
use super::raster::{LightmapTexels, texel_index_of};
use super::surface::{PointGroup, RayEnd, SurfaceReader, trace_ray};
use super::trace::{PACKET_RAYS, Tracer};
use super::visibility::dilation_plan;
use super::{BakeStats, progress_bar};
use crate::env::EnvMap;
use crate::env::sampler::{EnvSampler, Pcg32};
use crate::scene::Scene;
use crate::sh::samples::{Sample, SampleFit};
use crate::sh::sg::FitStats;
use crate::sh::{Order, basis::eval_basis, zonal};

/// Coefficients per texel and colour (order 3).
pub const SH_LIGHTMAP_COEFFS: usize = 9;

/// Default number of bounces of inter-reflection (the paper does not say).
pub const DEFAULT_BOUNCES: u32 = 2;

/// What an SH lightmap bake does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShLightmapSettings {
    /// Rays per texel (shared direction set).
    pub rays: u32,
    pub seed: u64,
    /// Reflections of light before it reaches a texel (0 = direct only).
    pub bounces: u32,
    pub progress: bool,
}

/// Order-3 SH of incident radiance per lightmap texel, RGB.
#[derive(Clone, Debug, PartialEq)]
pub struct ShLightmap {
    pub res: u32,
    pub bounces: u32,
    /// Texel-major, `SH_LIGHTMAP_COEFFS` RGB triples per texel (res² × 9).
    pub coeffs: Vec<[f32; 3]>,
    pub covered: Vec<bool>,
    /// Unit geometric normal n_g per texel, dilated like `coeffs` (the mean of its sources,
    /// renormalised); zero where nothing reached. The hemisphere of normals a texel is
    /// shaded with (`sh::bases`' deringing).
    pub normal: Vec<Vec3>,
    /// The normal map's frame per texel (columns: tangent, bitangent, interpolated normal,
    /// as `glsl/include/common.glsl` builds it), dilated like `coeffs`; zero where nothing
    /// reached. What tangent-space bases (`sh::hbasis`) are projected through.
    pub frame: Vec<glam::Mat3>,
    /// With `bounces` > 0: the irradiance E_{N−1} of eq. (2) per texel (dilated) that the
    /// last bounce read at its hits — what [`radiance_at_points`] reads to gather the same
    /// light at other points. Empty for a direct-only bake.
    pub bounce_source: Vec<Vec3>,
    /// Eqs. (3)–(4): per texel the RGB irradiance around the three world-space HL2 basis
    /// directions, rescaled to the flat irradiance (dilated like `coeffs`): the `rnm`
    /// lightmaps.
    pub basis_irradiance: Vec<[Vec3; 3]>,
    /// The tangent-frame bases fitted from each texel's radiance samples (eq. (5)).
    pub fitted: FittedBases,
    /// What its rays read of the environment (eq. (1) or (6)).
    pub env: BakeEnv,
    /// Rays and time of the bake, all bounces.
    pub stats: BakeStats,
}

/// The bases fitted from every covered texel's samples (eq. (5)), stored compactly: covered
/// texels in row-major order, each fit's values one after another, as a block of f16
/// mantissas under one power-of-two scale per texel and fit ([`BlockF16`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FittedBases {
    /// The fits, in the order asked for.
    pub fits: Vec<SampleFit>,
    /// Per fit, the amplitudes its SG solver made negative over the covered texels.
    pub negative: Vec<u64>,
    /// Σ `fit.stored_values()` per covered texel, each `f16` of a value over its block's
    /// scale.
    pub(crate) values: Vec<half::f16>,
    /// `fits.len()` per covered texel: each block's power-of-two scale.
    pub(crate) scales: Vec<f32>,
}

impl FittedBases {
    /// Values per covered texel, all fits.
    pub fn per_texel(&self) -> usize {
        self.fits.iter().map(|f| f.stored_values()).sum()
    }
}

/// One block of values kept as f16 under a shared power-of-two scale 2^e, the smallest with
/// every |v| ≤ 2^e: a value keeps f16's 11-bit precision down to 2^−14 of its block's
/// largest (the f16 textures the techniques store keep the same 11 bits), and the
/// sun-sized values f16 alone would overflow stay finite. Half the bytes of f32.
pub struct BlockF16;

impl BlockF16 {
    /// `block` written into `out` (same length); its scale.
    pub fn encode(block: &[f32], out: &mut [half::f16]) -> f32 {
        let largest = block
            .iter()
            .filter(|v| v.is_finite())
            .fold(0.0f32, |m, v| m.max(v.abs()));
        let scale = if largest > 0.0 {
            2.0f32.powi(largest.log2().ceil() as i32)
        } else {
            1.0
        };
        for (o, v) in out.iter_mut().zip(block) {
            *o = half::f16::from_f32(v / scale);
        }
        scale
    }

    /// The values of a block (into `out`, same length).
    pub fn decode(block: &[half::f16], scale: f32, out: &mut [f32]) {
        for (o, v) in out.iter_mut().zip(block) {
            *o = v.to_f32() * scale;
        }
    }
}

/// One basis of [`FittedBases`], read back per texel.
#[derive(Clone, Copy, Debug)]
pub struct FittedBasis<'a> {
    pub fit: SampleFit,
    /// Its place among the fits, and its values' offset within a covered texel's.
    index: usize,
    offset: usize,
    map: &'a ShLightmap,
}

impl FittedBasis<'_> {
    /// What the solver did: amplitudes counted over every covered texel, and how many were
    /// negative.
    pub fn stats(&self) -> FitStats {
        let covered = self.map.covered.iter().filter(|&&c| c).count() as u64;
        FitStats {
            amplitudes: match self.fit {
                SampleFit::Sg { .. } => covered * self.fit.stored_values() as u64,
                _ => 0,
            },
            negative: self.map.fitted.negative[self.index],
        }
    }

    /// The values of every texel (texel-major, `fit.stored_values()` each), dilated into
    /// the gutters as the SH coefficients are; zeros where nothing reached.
    pub fn texel_values(&self) -> Vec<f32> {
        let map = self.map;
        let n = self.fit.stored_values();
        let fitted = &map.fitted;
        let (per_texel, fits) = (fitted.per_texel(), fitted.fits.len());
        let texels = (map.res * map.res) as usize;
        let mut values = vec![0.0f32; texels * n];
        let covered = (0..texels).filter(|&t| map.covered[t]);
        for (k, t) in covered.enumerate() {
            let src = k * per_texel + self.offset;
            BlockF16::decode(
                &fitted.values[src..src + n],
                fitted.scales[k * fits + self.index],
                &mut values[t * n..(t + 1) * n],
            );
        }
        dilation_plan(&map.covered, map.res).apply_vectors(&mut values, n);
        values
    }
}

impl ShLightmap {
    /// The values of `fit` per texel, if the bake fitted it.
    pub fn fitted(&self, fit: SampleFit) -> Option<FittedBasis<'_>> {
        let mut offset = 0;
        for (index, f) in self.fitted.fits.iter().enumerate() {
            if *f == fit {
                return Some(FittedBasis {
                    fit,
                    index,
                    offset,
                    map: self,
                });
            }
            offset += f.stored_values();
        }
        None
    }

    /// The 9 RGB coefficients of texel `index` (row-major y·res + x).
    pub fn texel(&self, index: usize) -> &[[f32; 3]] {
        &self.coeffs[index * SH_LIGHTMAP_COEFFS..(index + 1) * SH_LIGHTMAP_COEFFS]
    }

    /// Irradiance E(n) = ∫ L_in max(0, n·ω) dω at texel `index` from its order-3 SH, eq. (2).
    pub fn irradiance(&self, index: usize, n: Vec3) -> Vec3 {
        irradiance_at(self.texel(index), n)
    }
}

/// Eq. (2): clamped-cosine convolution of order-3 RGB coefficients, evaluated at `n`.
pub fn irradiance_at(coeffs: &[[f32; 3]], n: Vec3) -> Vec3 {
    let radiance: Vec<[f64; 3]> = coeffs.iter().map(|c| c.map(f64::from)).collect();
    let irradiance = zonal::irradiance_from_radiance(&radiance, Order::THREE);
    let e = zonal::eval_rgb(
        &irradiance,
        Order::THREE,
        n.as_dvec3().normalize_or(DVec3::Z),
    );
    Vec3::new(e[0] as f32, e[1] as f32, e[2] as f32)
}

/// The lobe axes of texel `i` in world space: the three HL2 basis directions of eq. (3),
/// then the shading normal n_s of eq. (4).
pub fn world_basis(texels: &LightmapTexels, i: usize) -> [DVec3; RNM_LOBES] {
    let [t, b, n] = texel_frame(texels, i);
    let [b0, b1, b2] =
        super::ssbump::hl2_basis().map(|v| (t * v.x + b * v.y + n * v.z).normalize());
    [b0, b1, b2, n]
}

/// Texel `i`'s normal-map frame [tangent, bitangent, normal] (orthonormal), as
/// `glsl/include/common.glsl` builds it from the interpolated normal and tangent.
pub fn texel_frame(texels: &LightmapTexels, i: usize) -> [DVec3; 3] {
    let n = texels.shading_normal[i].normalize_or(texels.normal[i]);
    let t = crate::scene::tangent::orthonormalize(n, texels.tangent[i]);
    let b = n.cross(t.truncate()) * t.w;
    [t.truncate().as_dvec3(), b.as_dvec3(), n.as_dvec3()]
}

/// A ray's sample in the texel's frame (eq. (5)).
fn sample_in(frame: &[DVec3; 3], d: Vec3, weight: f64, radiance: [f64; 3]) -> Sample {
    let d = d.as_dvec3();
    Sample {
        dir: DVec3::new(frame[0].dot(d), frame[1].dot(d), frame[2].dot(d)),
        weight,
        radiance,
    }
}

/// Eq. (5) at each point of a group: every basis of `fits` fitted from the point's
/// samples (`points`, [`SampleFit::fit_group`]), in f32 one fit after another (`slot`
/// values per point, at least their sum); each fit's negative amplitudes added to
/// `negative` (one counter per fit).
fn fit_points(
    fits: &[SampleFit],
    points: &[&[Sample]],
    slot: usize,
    negative: &[AtomicU64],
) -> Vec<Vec<f32>> {
    let mut out = vec![vec![0.0f32; slot]; points.len()];
    let mut offset = 0;
    for (fit, negative) in fits.iter().zip(negative) {
        for (o, (v, s)) in out.iter_mut().zip(fit.fit_group(points)) {
            for (o, x) in o[offset..offset + v.len()].iter_mut().zip(v) {
                *o = x as f32;
            }
            negative.fetch_add(s.negative, Ordering::Relaxed);
        }
        offset += fit.stored_values();
    }
    out
}

/// A texel's slots in [`FittedBases`]: its values and its blocks' scales.
type TexelSlots<'a> = (&'a mut [half::f16], &'a mut [f32]);

/// Eq. (5) at a group of texels (their gathers' samples): [`fit_points`] kept as one
/// [`BlockF16`] per fit in each texel's slots (`values` and `scales` hold the group's,
/// texel after texel).
fn fit_texels(
    fits: &[SampleFit],
    gathers: &[TexelGather],
    values: &mut [half::f16],
    scales: &mut [f32],
    negative: &[AtomicU64],
) {
    if fits.is_empty() {
        return;
    }
    let slot = values.len() / gathers.len();
    let scale_slot = scales.len() / gathers.len();
    let points: Vec<&[Sample]> = gathers.iter().map(|g| g.samples.as_slice()).collect();
    let fitted = fit_points(fits, &points, slot, negative);
    for ((fitted, values), scales) in fitted
        .iter()
        .zip(values.chunks_mut(slot))
        .zip(scales.chunks_mut(scale_slot))
    {
        let slots: TexelSlots = (values, scales);
        let mut offset = 0;
        for (fit, scale) in fits.iter().zip(slots.1.iter_mut()) {
            let n = fit.stored_values();
            *scale = BlockF16::encode(
                &fitted[offset..offset + n],
                &mut slots.0[offset..offset + n],
            );
            offset += n;
        }
    }
}

/// Lobes gathered per texel: three basis directions and the flat normal (eqs. (3)–(4)).
pub const RNM_LOBES: usize = 4;

/// The lobes gathered per texel: [`RNM_LOBES`] of L_in, then the same of L_in⁺ (eq. (4)).
const GATHERED_LOBES: usize = 2 * RNM_LOBES;

/// Eq. (4): the three basis irradiances scaled per channel by k⁺, the flat lobe's ratio to
/// their mean in the positive parts (zero where those gathered nothing); k⁺ ≤ 3√3.
fn normalized_to_flat(lobes: &[Vec3; GATHERED_LOBES]) -> [Vec3; 3] {
    let positive = &lobes[RNM_LOBES..];
    let mean = (positive[0] + positive[1] + positive[2]) / 3.0;
    let k = Vec3::select(mean.cmpgt(Vec3::ZERO), positive[3] / mean, Vec3::ZERO);
    [lobes[0] * k, lobes[1] * k, lobes[2] * k]
}

/// What one texel gathers in a pass: eq. (1)'s sums, the RNM lobes' and, where the pass
/// fits bases, its samples in ray order.
struct TexelGather {
    normal: Vec3,
    lobes: [DVec3; RNM_LOBES],
    frame: [DVec3; 3],
    sum: [[f64; 3]; SH_LIGHTMAP_COEFFS],
    rnm: [DVec3; GATHERED_LOBES],
    samples: Vec<Sample>,
}

impl TexelGather {
    fn new(texels: &LightmapTexels, i: usize) -> TexelGather {
        TexelGather {
            normal: texels.normal[i],
            lobes: world_basis(texels, i),
            frame: texel_frame(texels, i),
            sum: [[0.0; 3]; SH_LIGHTMAP_COEFFS],
            rnm: [DVec3::ZERO; GATHERED_LOBES],
            samples: Vec::new(),
        }
    }

    /// The direct pass's ray: the environment where `visible` (`None`: below the horizon).
    fn direct(&mut self, ray: &Ray, visible: Option<bool>, fitting: bool) {
        let mut radiance = [0.0; 3];
        if visible == Some(true) {
            radiance = ray.env;
            accumulate(&mut self.sum, &ray.y, ray.scaled(radiance));
            accumulate_lobes(&mut self.rnm, &self.lobes, ray.d, ray.scaled(radiance));
        }
        if fitting {
            self.samples
                .push(sample_in(&self.frame, ray.d, ray.weight, radiance));
        }
    }

    /// A bounce pass's ray ending at `end` (`None`: below the horizon): light `bounced`
    /// off a front face is gathered; every ray's full radiance is a sample.
    fn bounce(
        &mut self,
        ray: &Ray,
        end: Option<RayEnd<'_>>,
        bounced: &impl Fn(&super::surface::SurfacePoint) -> [f64; 3],
        fitting: bool,
    ) {
        let l = match end {
            Some(RayEnd::Escaped) => ray.env,
            Some(RayEnd::Front(surface)) => {
                let l = bounced(surface);
                accumulate(&mut self.sum, &ray.y, ray.scaled(l));
                accumulate_lobes(&mut self.rnm, &self.lobes, ray.d, ray.scaled(l));
                l
            }
            Some(RayEnd::Back) | None => [0.0; 3],
        };
        if fitting {
            self.samples
                .push(sample_in(&self.frame, ray.d, ray.weight, l));
        }
    }

    /// Eq. (1)'s coefficients and the RNM lobes' irradiance of the pass.
    fn sums(&self, weight: f64) -> (Sh9Rgb, BasisIrradiance) {
        (
            Sh9Rgb::from_sums(&self.sum, weight),
            BasisIrradiance::from_sums(&self.rnm, weight),
        )
    }
}

/// The covered texels `group` as a group of points traced together, and their gathers.
fn texel_group(
    tracer: &Tracer,
    texels: &LightmapTexels,
    group: &[u32],
) -> (PointGroup, Vec<TexelGather>) {
    let gathers = group
        .iter()
        .map(|&i| TexelGather::new(texels, i as usize))
        .collect();
    (PointGroup::of_texels(tracer, texels, group), gathers)
}

/// Bakes the SH lightmap of `scene` under `lighting` (see the module doc), fitting each
/// basis of `fits` from every texel's samples in the last pass.
pub fn bake_sh_lightmap(
    scene: &Scene,
    tracer: &Tracer,
    texels: &LightmapTexels,
    lighting: &BakeLighting<'_>,
    settings: &ShLightmapSettings,
    fits: &[SampleFit],
) -> ShLightmap {
    let start = Instant::now();
    let res = texels.res as usize;
    let dirs = DirectionSet::new(settings.rays, settings.seed);
    let weight = dirs.weight();
    let rays_of = RaySet::new(&dirs, lighting, settings.seed);
    let surfaces = SurfaceReader::new(scene);
    let covered: Vec<u32> = (0..res * res)
        .filter(|&i| texels.covered[i])
        .map(|i| i as u32)
        .collect();
    let rays_done = AtomicU64::new(0);
    // The fits see the full radiance of each ray, known in the last pass only; they are
    // written in place, covered texel after covered texel (one slot each without fits).
    let fits_in = |pass: u32| if pass == settings.bounces { fits } else { &[] };
    let per_texel: usize = fits.iter().map(|f| f.stored_values()).sum();
    let (slot, scale_slot) = (per_texel.max(1), fits.len().max(1));
    let mut fit_values = vec![half::f16::ZERO; covered.len() * slot];
    let mut fit_scales = vec![0.0f32; covered.len() * scale_slot];
    let negative: Vec<AtomicU64> = fits.iter().map(|_| AtomicU64::new(0)).collect();

    // Bounce 0: direct light through the visible directions (any-hit rays), texels
    // traced in groups (coherent walks over the shared directions), their own rays singly.
    let bar = progress_bar(settings.progress, covered.len(), "SH lightmap direct");
    let direct_fits = fits_in(0);
    let shared_dirs: Vec<Vec3> = rays_of.shared.iter().map(|r| r.d).collect();
    let direct: Vec<(Sh9Rgb, BasisIrradiance)> = covered
        .par_chunks(PACKET_RAYS)
        .zip(
            fit_values
                .par_chunks_mut(PACKET_RAYS * slot)
                .zip(fit_scales.par_chunks_mut(PACKET_RAYS * scale_slot)),
        )
        .with_max_len(1)
        .flat_map_iter(|(group, (values, scales))| {
            let (mut points, mut gathers) = texel_group(tracer, texels, group);
            let mut rays = points.for_each_visibility(tracer, &shared_dirs, |k, r, visible| {
                gathers[k].direct(&rays_of.shared[r], visible, !direct_fits.is_empty());
            });
            for (k, gather) in gathers.iter_mut().enumerate() {
                for ray in &rays_of.own(u64::from(group[k])) {
                    let visible = above_horizon(gather.normal, ray.d)
                        .then(|| !tracer.occluded(points.origin(k), ray.d, f32::INFINITY));
                    rays += u64::from(visible.is_some());
                    gather.direct(ray, visible, !direct_fits.is_empty());
                }
            }
            fit_texels(direct_fits, &gathers, values, scales, &negative);
            rays_done.fetch_add(rays, Ordering::Relaxed);
            bar.inc(group.len() as u64);
            gathers.into_iter().map(move |g| g.sums(weight))
        })
        .collect();
    bar.finish_and_clear();
    let mut current = direct.clone();
    let mut bounce_source = Vec::new();
    let dilation = dilation_plan(&texels.covered, texels.res);

    for bounce in 1..=settings.bounces {
        // Irradiance of the previous bounce at every texel, dilated into the gutters.
        let mut irradiance = vec![Vec3::ZERO; res * res];
        for (k, &i) in covered.iter().enumerate() {
            let i = i as usize;
            irradiance[i] = irradiance_at(&current[k].0.as_rgb(), texels.normal[i]).max(Vec3::ZERO);
        }
        dilation.apply(&mut irradiance);
        let bar = progress_bar(
            settings.progress,
            covered.len(),
            &format!("SH lightmap bounce {bounce}"),
        );
        let pass_fits = fits_in(bounce);
        // With fits every direction is a sample: escaped rays carry the environment
        // (gathered into (1) in the direct pass), front hits the bounce, the rest nothing.
        let fitting = !pass_fits.is_empty();
        let bounced = |surface: &super::surface::SurfacePoint| -> [f64; 3] {
            let e = irradiance[texels.texel_index(surface.uv_lightmap.into())];
            (surface.albedo * e / std::f32::consts::PI)
                .as_dvec3()
                .into()
        };
        current = covered
            .par_chunks(PACKET_RAYS)
            .zip(direct.par_chunks(PACKET_RAYS))
            .zip(
                fit_values
                    .par_chunks_mut(PACKET_RAYS * slot)
                    .zip(fit_scales.par_chunks_mut(PACKET_RAYS * scale_slot)),
            )
            .with_max_len(1)
            .flat_map_iter(|((group, direct), (values, scales))| {
                let (mut points, mut gathers) = texel_group(tracer, texels, group);
                let mut rays = points.for_each_hit(tracer, &surfaces, &shared_dirs, |k, r, end| {
                    gathers[k].bounce(&rays_of.shared[r], end, &bounced, fitting);
                });
                for (k, gather) in gathers.iter_mut().enumerate() {
                    let origin = points.origin(k);
                    for ray in &rays_of.own(u64::from(group[k])) {
                        if above_horizon(gather.normal, ray.d) {
                            rays += 1;
                            trace_ray(tracer, &surfaces, origin, ray.d, |end| {
                                gather.bounce(ray, Some(end), &bounced, fitting)
                            });
                        } else {
                            gather.bounce(ray, None, &bounced, fitting);
                        }
                    }
                }
                fit_texels(pass_fits, &gathers, values, scales, &negative);
                rays_done.fetch_add(rays, Ordering::Relaxed);
                bar.inc(group.len() as u64);
                gathers.into_iter().zip(direct).map(move |(g, direct)| {
                    let (sh, rnm) = g.sums(weight);
                    (direct.0 + sh, direct.1 + rnm)
                })
            })
            .collect();
        bar.finish_and_clear();
        bounce_source = irradiance;
    }

    let mut planes = vec![Sh9Rgb::default(); res * res];
    let mut rnm = vec![BasisIrradiance::default(); res * res];
    for (k, &i) in covered.iter().enumerate() {
        planes[i as usize] = current[k].0;
        rnm[i as usize] = current[k].1;
    }
    dilation.apply(&mut planes);
    dilation.apply(&mut rnm);
    let fitted = FittedBases {
        fits: fits.to_vec(),
        negative: negative.into_iter().map(AtomicU64::into_inner).collect(),
        values: if per_texel > 0 {
            fit_values
        } else {
            Vec::new()
        },
        scales: if per_texel > 0 {
            fit_scales
        } else {
            Vec::new()
        },
    };
    let mut normal = texels.normal.clone();
    dilation.apply(&mut normal);
    let mut frame: Vec<glam::Mat3> = (0..res * res)
        .map(|i| {
            if !texels.covered[i] {
                return glam::Mat3::ZERO;
            }
            let [t, b, n] = texel_frame(texels, i).map(|c| c.as_vec3());
            glam::Mat3::from_cols(t, b, n)
        })
        .collect();
    dilation.apply(&mut frame);
    let map = ShLightmap {
        res: texels.res,
        bounces: settings.bounces,
        coeffs: planes.iter().flat_map(|p| p.as_rgb()).collect(),
        covered: texels.covered.clone(),
        normal: normal.iter().map(|n| n.normalize_or_zero()).collect(),
        frame,
        bounce_source,
        basis_irradiance: rnm.iter().map(|b| normalized_to_flat(&b.0)).collect(),
        fitted,
        env: lighting.env(),
        stats: BakeStats {
            rays_traced: rays_done.into_inner(),
            seconds: start.elapsed().as_secs_f64(),
        },
    };
    log::info!(
        "SH lightmap bake: {} texels × {} directions ({} per texel from the environment's pixels), {} bounces, {} bases fitted from samples: {}",
        covered.len(),
        settings.rays,
        rays_of.env_rays,
        settings.bounces,
        fits.len(),
        map.stats
    );
    map
}

/// What [`radiance_at_points`] gathers at each point.
pub struct GatheredPoints {
    /// Eq. (1)'s 9 RGB coefficients per point.
    pub sh: Vec<[[f64; 3]; SH_LIGHTMAP_COEFFS]>,
    /// The fits asked for, and per point their values concatenated in that order (eq. (5)).
    pub fits: Vec<SampleFit>,
    pub fitted: Vec<f32>,
}

impl GatheredPoints {
    /// Values per point of all the fits.
    pub fn fitted_per_point(&self) -> usize {
        self.fits.iter().map(|f| f.stored_values()).sum()
    }

    /// The values of `fit` at point `k`, if gathered.
    pub fn fitted_at(&self, fit: SampleFit, k: usize) -> Option<&[f32]> {
        let mut offset = 0;
        for f in &self.fits {
            if *f == fit {
                let base = k * self.fitted_per_point() + offset;
                return Some(&self.fitted[base..base + f.stored_values()]);
            }
            offset += f.stored_values();
        }
        None
    }
}

/// Eq. (1) at arbitrary points `position[i]` with unit geometric normals `normal[i]`, as
/// the last pass of the bake that made `map` gathers it at a texel: the same directions
/// (`settings`' rays and seed) and `lighting` (with `pixels`, each point's own
/// environment-importance rays, eq. (6)), and light bounced
/// off the surfaces hit read from `map.bounce_source` (the error ladder's per-pixel
/// `shlmap` rung, `crate::attribution`). With the same rays, every basis the bake fitted
/// (`map.fitted`) is fitted at each point from its samples in `frame[i]` (tangent,
/// bitangent, normal; orthonormalised here as [`texel_frame`] does).
///
/// # Panics
/// If the slices differ in length (a bug of the caller).
#[allow(clippy::too_many_arguments)]
pub fn radiance_at_points(
    scene: &Scene,
    tracer: &Tracer,
    map: &ShLightmap,
    lighting: &BakeLighting<'_>,
    settings: &ShLightmapSettings,
    position: &[Vec3],
    normal: &[Vec3],
    frame: &[[DVec3; 3]],
) -> GatheredPoints {
    assert_eq!(position.len(), normal.len(), "one normal per point");
    assert_eq!(position.len(), frame.len(), "one frame per point");
    let dirs = DirectionSet::new(settings.rays, settings.seed);
    let weight = dirs.weight();
    let rays_of = RaySet::new(&dirs, lighting, settings.seed);
    let surfaces = SurfaceReader::new(scene);
    let bounced = !map.bounce_source.is_empty();
    // The radiance arriving along `ray` from where it ended (`None`: below the horizon):
    // the environment where it escapes, light bounced off a front face, nothing off a
    // back face.
    let arriving = |ray: &Ray, end: Option<RayEnd<'_>>| -> [f64; 3] {
        match end {
            Some(RayEnd::Escaped) => ray.env,
            Some(RayEnd::Front(surface)) => {
                let t = texel_index_of(map.res, surface.uv_lightmap.into());
                let l = surface.albedo * map.bounce_source[t] / std::f32::consts::PI;
                l.as_dvec3().into()
            }
            Some(RayEnd::Back) | None => [0.0; 3],
        }
    };
    let shared_dirs: Vec<Vec3> = rays_of.shared.iter().map(|r| r.d).collect();
    let fits: Vec<SampleFit> = map.fitted.fits.clone();
    let negative: Vec<AtomicU64> = fits.iter().map(|_| AtomicU64::new(0)).collect();
    let mut gathered = GatheredPoints {
        sh: vec![[[0.0; 3]; SH_LIGHTMAP_COEFFS]; position.len()],
        fitted: Vec::new(),
        fits,
    };
    let per_point = gathered.fitted_per_point();
    // Points in groups of PACKET_RAYS traced together, each point's values written in
    // place (one slot per point where nothing is fitted, so that both sides have a chunk
    // per group).
    const CHUNK: usize = PACKET_RAYS;
    let slot = per_point.max(1);
    let mut fitted = vec![0.0f32; position.len() * slot];
    let fits = &gathered.fits;
    gathered
        .sh
        .par_chunks_mut(CHUNK)
        .zip(fitted.par_chunks_mut(CHUNK * slot))
        .enumerate()
        .with_max_len(1)
        .for_each(|(chunk, (sh_out, fitted_out))| {
            let points = chunk * CHUNK..chunk * CHUNK + sh_out.len();
            let normals = normal[points.clone()].to_vec();
            let frames: Vec<[DVec3; 3]> = frame[points.clone()]
                .iter()
                .map(orthonormal_frame)
                .collect();
            let mut sums = vec![[[0.0f64; 3]; SH_LIGHTMAP_COEFFS]; sh_out.len()];
            let mut samples = vec![Vec::new(); sh_out.len()];
            let mut take = |j: usize, ray: &Ray, end: Option<RayEnd<'_>>| {
                let traced = end.is_some();
                let radiance = arriving(ray, end);
                if traced {
                    accumulate(&mut sums[j], &ray.y, ray.scaled(radiance));
                }
                if !fits.is_empty() {
                    samples[j].push(sample_in(&frames[j], ray.d, ray.weight, radiance));
                }
            };
            let mut group = PointGroup::new(tracer, &position[points.clone()], normals);
            if bounced {
                group.for_each_hit(tracer, &surfaces, &shared_dirs, |j, r, end| {
                    take(j, &rays_of.shared[r], end)
                });
            } else {
                group.for_each_visibility(tracer, &shared_dirs, |j, r, visible| {
                    let end = visible.map(|v| if v { RayEnd::Escaped } else { RayEnd::Back });
                    take(j, &rays_of.shared[r], end)
                });
            }
            for (j, k) in points.enumerate() {
                let origin = group.origin(j);
                for ray in &rays_of.own(k as u64) {
                    if !above_horizon(normal[k], ray.d) {
                        take(j, ray, None);
                    } else if bounced {
                        trace_ray(tracer, &surfaces, origin, ray.d, |end| {
                            take(j, ray, Some(end))
                        });
                    } else {
                        let visible = !tracer.occluded(origin, ray.d, f32::INFINITY);
                        take(
                            j,
                            ray,
                            Some(if visible {
                                RayEnd::Escaped
                            } else {
                                RayEnd::Back
                            }),
                        );
                    }
                }
            }
            for (out, sum) in sh_out.iter_mut().zip(&sums) {
                *out = sum.map(|c| c.map(|v| v * weight));
            }
            if per_point > 0 {
                let points: Vec<&[Sample]> = samples.iter().map(Vec::as_slice).collect();
                let values = fit_points(fits, &points, per_point, &negative);
                for (out, v) in fitted_out.chunks_mut(per_point).zip(values) {
                    out.copy_from_slice(&v);
                }
            }
        });
    if per_point > 0 {
        gathered.fitted = fitted;
    }
    gathered
}

/// `frame` (tangent, bitangent, normal) made orthonormal about its normal, the
/// bitangent's handedness kept.
fn orthonormal_frame(frame: &[DVec3; 3]) -> [DVec3; 3] {
    let n = frame[2].normalize_or(DVec3::Z);
    let t = (frame[0] - n * n.dot(frame[0])).normalize_or(n.any_orthonormal_vector());
    let sign = if frame[1].dot(n.cross(t)) < 0.0 {
        -1.0
    } else {
        1.0
    };
    [t, n.cross(t) * sign, n]
}

/// What the bake's rays read of the environment where they escape (`--bake-env`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BakeEnv {
    /// Its SH at the lighting order, evaluated at each shared direction (eq. (1)).
    #[default]
    Sh,
    /// The full-resolution map, importance-sampled beside the shared directions (eq. (6)).
    Pixels,
}

impl BakeEnv {
    pub const ALL: [BakeEnv; 2] = [BakeEnv::Sh, BakeEnv::Pixels];

    pub fn name(self) -> &'static str {
        match self {
            BakeEnv::Sh => "sh",
            BakeEnv::Pixels => "pixels",
        }
    }
}

impl std::fmt::Display for BakeEnv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for BakeEnv {
    type Err = String;
    fn from_str(s: &str) -> Result<BakeEnv, String> {
        BakeEnv::ALL
            .into_iter()
            .find(|b| b.name() == s)
            .ok_or_else(|| format!("unknown bake environment '{s}' (sh, pixels)"))
    }
}

/// The environment a bake's rays see: its SH, or the map itself (`BakeEnv`).
#[derive(Clone, Copy, Debug)]
pub enum BakeLighting<'a> {
    /// Radiance SH, RGB, any order ≥ 1.
    Sh(&'a [[f64; 3]]),
    /// The map at full resolution.
    Pixels(&'a EnvMap),
}

impl BakeLighting<'_> {
    pub fn env(&self) -> BakeEnv {
        match self {
            BakeLighting::Sh(_) => BakeEnv::Sh,
            BakeLighting::Pixels(_) => BakeEnv::Pixels,
        }
    }
}

/// Shared directions per environment-importance ray of a texel with `pixels` (M = R / 4).
pub const SHARED_RAYS_PER_ENV_RAY: u32 = 4;

/// One ray of a gather: its direction, the order-3 SH basis there, the environment's
/// radiance if it escapes, and its weight w(ω) of eq. (6) in sr.
struct Ray {
    d: Vec3,
    y: [f64; SH_LIGHTMAP_COEFFS],
    env: [f64; 3],
    weight: f64,
    /// w(ω) over the shared rays' 4π/R, by which its radiance enters the sums that are
    /// scaled by 4π/R at the end (exactly 1 with `sh`).
    ratio: f64,
}

impl Ray {
    fn scaled(&self, radiance: [f64; 3]) -> [f64; 3] {
        radiance.map(|c| c * self.ratio)
    }
}

/// The rays of eq. (6): the shared directions, and with `pixels` each texel's own
/// environment-importance directions (the same in every pass, drawn from a stream of the
/// seed and the texel).
struct RaySet<'a> {
    shared: Vec<Ray>,
    sampler: Option<EnvSampler<'a>>,
    /// M, environment-importance rays per texel (0 with `sh` or a black map).
    env_rays: u32,
    /// 4π/R.
    weight: f64,
    seed: u64,
}

impl<'a> RaySet<'a> {
    fn new(dirs: &DirectionSet, lighting: &BakeLighting<'a>, seed: u64) -> RaySet<'a> {
        let weight = dirs.weight();
        let sampler = match *lighting {
            BakeLighting::Sh(_) => None,
            BakeLighting::Pixels(map) => Some(EnvSampler::new(map)).filter(|s| s.total() > 0.0),
        };
        let env_rays = if sampler.is_some() {
            (dirs.len() as u32 / SHARED_RAYS_PER_ENV_RAY).max(1)
        } else {
            0
        };
        let mut set = RaySet {
            shared: Vec::new(),
            sampler,
            env_rays,
            weight,
            seed,
        };
        let sh_order = match *lighting {
            BakeLighting::Sh(radiance_sh) => {
                Order::new((radiance_sh.len() as f64).sqrt() as u32).unwrap_or(Order::ONE)
            }
            BakeLighting::Pixels(_) => Order::ONE,
        };
        set.shared = dirs
            .dirs()
            .iter()
            .map(|&d| {
                let env = match *lighting {
                    BakeLighting::Sh(radiance_sh) => {
                        zonal::eval_rgb(radiance_sh, sh_order, d.as_dvec3().normalize())
                    }
                    BakeLighting::Pixels(map) => map.radiance_at(d.as_dvec3()).map(f64::from),
                };
                let pdf = set.sampler.as_ref().map_or(0.0, |s| s.pdf(d));
                set.ray(d, env, pdf)
            })
            .collect();
        set
    }

    /// The ray along `d` bringing `env` where it escapes, drawn by the environment's
    /// sampler with density `pdf`: w(ω) = 1 / (R/4π + M pdf(ω)) (eq. (6)).
    fn ray(&self, d: Vec3, env: [f64; 3], pdf: f64) -> Ray {
        let ratio = 1.0 / (1.0 + f64::from(self.env_rays) * pdf * self.weight);
        let mut y = [0.0; SH_LIGHTMAP_COEFFS];
        eval_basis(Order::THREE, d.as_dvec3().normalize(), &mut y);
        Ray {
            d,
            y,
            env,
            weight: self.weight * ratio,
            ratio,
        }
    }

    /// The environment-importance rays of texel (or point) `stream`; none with `sh`.
    fn own(&self, stream: u64) -> Vec<Ray> {
        let Some(sampler) = &self.sampler else {
            return Vec::new();
        };
        let mut rng = Pcg32::new(self.seed ^ 0x454E_5652_4159, stream); // "ENVRAY"
        (0..self.env_rays)
            .map(|_| {
                let (d, radiance, pdf) = sampler.sample(&mut rng);
                self.ray(d, radiance.map(f64::from), pdf)
            })
            .collect()
    }
}

fn accumulate(
    sum: &mut [[f64; 3]; SH_LIGHTMAP_COEFFS],
    y: &[f64; SH_LIGHTMAP_COEFFS],
    radiance: [f64; 3],
) {
    for (s, &y) in sum.iter_mut().zip(y) {
        for c in 0..3 {
            s[c] += radiance[c] * y;
        }
    }
}

/// Eqs. (3)–(4)'s sums: `radiance` (RGB) arriving along `d` into each lobe max(0, d·axis).
fn accumulate_lobes(
    sum: &mut [DVec3; GATHERED_LOBES],
    lobes: &[DVec3; RNM_LOBES],
    d: Vec3,
    radiance: [f64; 3],
) {
    let d = d.as_dvec3();
    let radiance = DVec3::from(radiance);
    let positive = radiance.max(DVec3::ZERO);
    for (k, b) in lobes.iter().enumerate() {
        let lobe = d.dot(*b).max(0.0);
        sum[k] += radiance * lobe;
        sum[RNM_LOBES + k] += positive * lobe;
    }
}

/// 9 RGB coefficients as one value that [`dilate`] can average.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Sh9Rgb([f32; 3 * SH_LIGHTMAP_COEFFS]);

impl Sh9Rgb {
    fn from_sums(sum: &[[f64; 3]; SH_LIGHTMAP_COEFFS], weight: f64) -> Self {
        let mut out = [0.0f32; 3 * SH_LIGHTMAP_COEFFS];
        for (i, s) in sum.iter().enumerate() {
            for c in 0..3 {
                out[3 * i + c] = (s[c] * weight) as f32;
            }
        }
        Sh9Rgb(out)
    }

    fn as_rgb(&self) -> [[f32; 3]; SH_LIGHTMAP_COEFFS] {
        std::array::from_fn(|i| [self.0[3 * i], self.0[3 * i + 1], self.0[3 * i + 2]])
    }
}

/// Eqs. (3)–(4)'s RGB lobe irradiances of a texel, as one value [`dilate`] can average.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct BasisIrradiance([Vec3; GATHERED_LOBES]);

impl BasisIrradiance {
    fn from_sums(sum: &[DVec3; GATHERED_LOBES], weight: f64) -> Self {
        BasisIrradiance(sum.map(|s| (s * weight).as_vec3()))
    }
}

impl Add for BasisIrradiance {
    type Output = BasisIrradiance;
    fn add(self, o: BasisIrradiance) -> BasisIrradiance {
        BasisIrradiance(std::array::from_fn(|k| self.0[k] + o.0[k]))
    }
}

impl Mul<f32> for BasisIrradiance {
    type Output = BasisIrradiance;
    fn mul(self, s: f32) -> BasisIrradiance {
        BasisIrradiance(self.0.map(|v| v * s))
    }
}

impl Add for Sh9Rgb {
    type Output = Sh9Rgb;
    fn add(self, o: Sh9Rgb) -> Sh9Rgb {
        Sh9Rgb(std::array::from_fn(|k| self.0[k] + o.0[k]))
    }
}

impl Mul<f32> for Sh9Rgb {
    type Output = Sh9Rgb;
    fn mul(self, s: f32) -> Sh9Rgb {
        Sh9Rgb(self.0.map(|v| v * s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A constant environment of radiance 1 over the upper hemisphere of +z has order-3
    /// coefficients whose clamped-cosine convolution at +z is exactly π (the hemisphere's
    /// band 2 vanishes), the irradiance of an open plane.
    #[test]
    fn hemisphere_convolves_to_pi() {
        let s = std::f32::consts::PI.sqrt();
        let mut c = [[0.0f32; 3]; SH_LIGHTMAP_COEFFS];
        c[0] = [s; 3];
        c[2] = [(3.0 * std::f32::consts::PI).sqrt() / 2.0; 3];
        let e = irradiance_at(&c, Vec3::Z);
        assert!(
            (e - Vec3::splat(std::f32::consts::PI)).abs().max_element() < 1e-5,
            "{e}"
        );
        // Facing away: the hemisphere's irradiance at −z is 0.
        assert!(irradiance_at(&c, -Vec3::Z).abs().max_element() < 1e-5);
    }

    fn round_trip(block: &[f32]) -> Vec<f32> {
        let mut packed = vec![half::f16::ZERO; block.len()];
        let scale = BlockF16::encode(block, &mut packed);
        let mut out = vec![0.0; block.len()];
        BlockF16::decode(&packed, scale, &mut out);
        out
    }

    #[test]
    fn a_block_keeps_f16_precision_relative_to_its_largest_value() {
        // A sun of 1e5 beside sky-sized and ringing negative values: f16 alone would
        // overflow the first.
        let block = [1.0e5f32, -3.2e4, 17.5, 0.25, -0.031, 12.0, 0.0];
        for (a, b) in block.iter().zip(round_trip(&block)) {
            assert!(b.is_finite());
            let tolerance = a.abs() * 2f32.powi(-11) + 1.0e5 * 2f32.powi(-24);
            assert!((a - b).abs() <= tolerance, "{a} → {b}");
        }
    }

    #[test]
    fn zero_and_exact_blocks_come_back_exactly() {
        assert_eq!(round_trip(&[0.0; 5]), vec![0.0; 5]);
        let exact = [0.5f32, -1.0, 1024.0, 3.0];
        assert_eq!(round_trip(&exact), exact.to_vec());
    }
}
