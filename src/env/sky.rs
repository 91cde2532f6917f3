//! The built-in procedural sky (`--env sky`, DESIGN §4): a smooth daylight gradient, a
//! dim ground, and a small, very bright sun disk — the "HDR sun" case of DESIGN §6 that
//! makes low-order SH ring and shadows matter.
//!
//! # Model (linear RGB radiance, +Y up, directions point *towards* the light)
//!
//! With elevation e = asin(y):
//!
//! ```text
//! sky(d)        = zenith + (horizon − zenith) · (1 − max(y, 0))^HORIZON_EXPONENT
//! background(d) = lerp(ground, sky(d), smoothstep(−b, +b, e)),   b = horizon_blend
//! L(d)          = background(d) + sun_radiance · [angle(d, sun_dir) ≤ sun_angular_radius]
//! ```
//!
//! The sun disk is antialiased: texels that can touch it carry the fraction of n² sample
//! points inside the disk, the points a Hammersley set spread uniformly in φ and in
//! cos θ = y (equal solid angle), so Σ texels (L − background)·Ω estimates sun_radiance ×
//! 2π(1 − cos r) to well under 1% (tested at 256…1024 wide). Other texels are the
//! background at their centre.
//!
//! Default: sun 35° above the horizon, coming from front-left-above a house whose front
//! faces +Z (viewer at +Z looking towards −Z has −X on the left); 1° radius; radiance
//! 2·10⁴ against a sky ≤ 1, so the sun is ≥ 10⁴× the brightest sky texel and delivers
//! ~10× the sky's irradiance on a surface facing it.

use std::f64::consts::PI;

use glam::DVec3;

use super::EnvMap;

/// Shape of the zenith → horizon gradient (larger: a thinner bright band at the horizon).
const HORIZON_EXPONENT: i32 = 3;
/// n (√ of the sample count per texel near the sun), at least; see [`sun_subdivisions`].
const MIN_SUN_SUBDIVISIONS: u32 = 32;
/// n per texel-size-over-sun-radius, so small suns stay accurate on coarse maps.
const SUBDIVISIONS_PER_SUN_RADIUS: f64 = 16.0;
/// Cap on n (a sun far below texel size is a point light anyway).
const MAX_SUN_SUBDIVISIONS: u32 = 128;

/// Parameters of [`sky`]; see the module doc for the model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyParams {
    /// Unit direction towards the sun's centre (+Y up).
    pub sun_dir: DVec3,
    /// Angular radius r of the sun disk, radians.
    pub sun_angular_radius: f64,
    /// Radiance inside the disk (all three channels; white sun).
    pub sun_radiance: f64,
    /// Sky radiance straight up (RGB).
    pub zenith: [f64; 3],
    /// Sky radiance at the horizon (RGB).
    pub horizon: [f64; 3],
    /// Ground radiance below the horizon (RGB).
    pub ground: [f64; 3],
    /// Half-width b of the smooth ground↔sky transition, radians of elevation.
    pub horizon_blend: f64,
}

/// Sun elevation of the default sky, degrees.
pub const DEFAULT_SUN_ELEVATION_DEG: f64 = 35.0;

impl Default for SkyParams {
    fn default() -> Self {
        SkyParams::with_sun_elevation(DEFAULT_SUN_ELEVATION_DEG)
    }
}

impl SkyParams {
    /// The default sky with the sun `degrees` above the horizon (`--env sky:DEG`; the
    /// grazing "low sun" is `sky:15`), at the default azimuth: 40° from +Z
    /// towards −X (front-left).
    pub fn with_sun_elevation(degrees: f64) -> Self {
        let elevation = degrees.to_radians();
        let azimuth = 40f64.to_radians();
        let sun_dir = DVec3::new(
            -elevation.cos() * azimuth.sin(),
            elevation.sin(),
            elevation.cos() * azimuth.cos(),
        );
        SkyParams {
            sun_dir,
            sun_angular_radius: 1f64.to_radians(),
            sun_radiance: 2.0e4,
            zenith: [0.30, 0.42, 0.62],
            horizon: [0.85, 0.92, 1.0],
            ground: [0.16, 0.14, 0.12],
            horizon_blend: 3f64.to_radians(),
        }
    }
}

impl SkyParams {
    /// Sky-and-ground radiance in direction `d` (unit), without the sun.
    pub fn background(&self, d: DVec3) -> [f64; 3] {
        let y = d.y.clamp(-1.0, 1.0);
        let t = (1.0 - y.max(0.0)).powi(HORIZON_EXPONENT);
        let sky: [f64; 3] =
            std::array::from_fn(|k| self.zenith[k] + (self.horizon[k] - self.zenith[k]) * t);
        let b = self.horizon_blend.max(1e-9);
        let s = ((y.asin() + b) / (2.0 * b)).clamp(0.0, 1.0);
        let w = s * s * (3.0 - 2.0 * s); // smoothstep
        std::array::from_fn(|k| self.ground[k] + (sky[k] - self.ground[k]) * w)
    }

    /// Exact solid angle of the sun disk, 2π(1 − cos r), sr.
    pub fn sun_solid_angle(&self) -> f64 {
        // 1 − cos r = 2 sin²(r/2), without cancellation for small r.
        4.0 * PI * (0.5 * self.sun_angular_radius).sin().powi(2)
    }
}

/// n, a power of two so that the N = n² Hammersley points stratify exactly
/// ([`sun_coverage`]).
fn sun_subdivisions(texel_angle: f64, sun_radius: f64) -> u32 {
    let n = (SUBDIVISIONS_PER_SUN_RADIUS * texel_angle / sun_radius.max(1e-12)).ceil();
    let n = (n.min(MAX_SUN_SUBDIVISIONS as f64) as u32).max(MIN_SUN_SUBDIVISIONS);
    n.next_power_of_two()
}

/// Renders the sky as a `width` × `width/2` equirectangular map (`width` is rounded down
/// to an even number ≥ 2).
pub fn sky(width: u32, params: &SkyParams) -> EnvMap {
    let height = (width / 2).max(1);
    let width = 2 * height;
    let sun_dir = params.sun_dir.normalize();
    let r = params.sun_angular_radius.max(0.0);
    let cos_r = r.cos();
    let d_phi = 2.0 * PI / width as f64;
    let d_theta = PI / height as f64;
    // A texel can touch the disk only if its centre is within r + Δθ + Δφ of the sun's
    // centre (a path along the meridian, then along the parallel, bounds the distance).
    let cos_near = (r + d_theta + d_phi).min(PI).cos();
    let n = sun_subdivisions(d_theta.max(d_phi), r);

    EnvMap::from_texels_fn(width, height, |x, y, centre| {
        let mut l = params.background(centre);
        if params.sun_radiance != 0.0 && centre.dot(sun_dir) >= cos_near {
            let cover = sun_coverage(x, y, width, height, n, sun_dir, cos_r);
            for c in &mut l {
                *c += params.sun_radiance * cover;
            }
        }
        l.map(|c| c as f32)
    })
}

/// Fraction of texel (x, y)'s solid angle inside the disk {d : d·sun_dir ≥ cos r},
/// estimated with the N = n² points of a Hammersley set mapped uniformly in φ and in
/// y = cos θ (equal solid angle). Both marginals are stratified at 1/N, so even a sun at
/// the pole — where every texel of a row sees the same ring — errs by ≤ 1/N per texel.
fn sun_coverage(
    x: u32,
    y: u32,
    width: u32,
    height: u32,
    n: u32,
    sun_dir: DVec3,
    cos_r: f64,
) -> f64 {
    let y_top = (PI * y as f64 / height as f64).cos();
    let y_bottom = (PI * (y + 1) as f64 / height as f64).cos();
    let count = n * n;
    let mut inside = 0u64;
    for i in 0..count {
        let fu = (i as f64 + 0.5) / count as f64;
        // Base-2 radical inverse of i, centred in its 1/N stratum.
        let fv = i.reverse_bits() as f64 / 2f64.powi(32) + 0.5 / count as f64;
        let cy = y_top + (y_bottom - y_top) * fv;
        let s = (1.0 - cy * cy).max(0.0).sqrt();
        let phi = 2.0 * PI * ((x as f64 + fu) / width as f64 - 0.5);
        let d = DVec3::new(s * phi.sin(), cy, -s * phi.cos());
        if d.dot(sun_dir) >= cos_r {
            inside += 1;
        }
    }
    inside as f64 / count as f64
}

impl EnvMap {
    /// Builds a map from `f(x, y, centre_dir)` per texel.
    fn from_texels_fn(width: u32, height: u32, f: impl Fn(u32, u32, DVec3) -> [f32; 3]) -> EnvMap {
        let mut map = EnvMap {
            width,
            height,
            texels: Vec::with_capacity(width as usize * height as usize),
        };
        for y in 0..height {
            for x in 0..width {
                let centre = map.texel_center_dir(x, y);
                map.texels.push(f(x, y, centre));
            }
        }
        map
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The brief's bound on the antialiased sun's total power.
    const SUN_POWER: f64 = 0.01;

    fn sun_power(width: u32, params: &SkyParams) -> [f64; 3] {
        let with = sky(width, params);
        let without = sky(
            width,
            &SkyParams {
                sun_radiance: 0.0,
                ..*params
            },
        );
        let mut p = [0.0; 3];
        for y in 0..with.height {
            let omega = with.texel_solid_angle(y);
            for x in 0..with.width {
                let (a, b) = (with.texel(x, y), without.texel(x, y));
                for k in 0..3 {
                    p[k] += (a[k] as f64 - b[k] as f64) * omega;
                }
            }
        }
        p
    }

    #[test]
    fn sun_power_matches_disk_solid_angle() {
        let mut params = SkyParams::default();
        for (width, radius_deg) in [(256, 1.0), (512, 1.0), (1024, 1.0), (512, 0.25), (128, 3.0)] {
            params.sun_angular_radius = f64::to_radians(radius_deg);
            let want = params.sun_radiance * params.sun_solid_angle();
            for (k, got) in sun_power(width, &params).iter().enumerate() {
                let rel = (got - want).abs() / want;
                assert!(
                    rel < SUN_POWER,
                    "width {width} r={radius_deg}° channel {k}: {got} vs {want}"
                );
            }
        }
        // At the zenith, where texels are thin wedges.
        params.sun_dir = DVec3::Y;
        params.sun_angular_radius = 1f64.to_radians();
        let want = params.sun_radiance * params.sun_solid_angle();
        let got = sun_power(512, &params)[0];
        assert!(
            (got - want).abs() / want < SUN_POWER,
            "zenith sun: {got} vs {want}"
        );
    }

    #[test]
    fn default_sun_is_front_left_above_and_unit() {
        let p = SkyParams::default();
        assert!((p.sun_dir.length() - 1.0).abs() < 1e-12);
        assert!(
            p.sun_dir.x < 0.0 && p.sun_dir.y > 0.5 && p.sun_dir.z > 0.0,
            "{}",
            p.sun_dir
        );
        let elevation = p.sun_dir.y.asin().to_degrees();
        assert!((elevation - 35.0).abs() < 1e-9, "{elevation}");
    }
}
