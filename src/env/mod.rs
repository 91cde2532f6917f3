//! Distant lighting environments: equirectangular radiance maps, their loading
//! ([`equirect`]), the built-in procedural sky ([`sky`]) and their SH projection
//! ([`project`]), and their importance sampling ([`sampler`]).
//!
//! # Conventions (DESIGN §1)
//!
//! Radiance is linear RGB (W·sr⁻¹·m⁻² up to a global scale). A map is equirectangular,
//! 2:1, stored row-major with row 0 at the top. A direction d = (x, y, z) (+Y up) maps to
//!
//! ```text
//! u = 0.5 + atan2(x, −z) / (2π),   v = acos(y) / π,   (u, v) = (0, 0) the top-left corner
//! ```
//!
//! i.e. the map's pole is +Y (v = 0), −Z is the centre of the image (u = 0.5), +X is at
//! u = 0.75. With φ = 2π(u − 0.5) and θ = πv the inverse is
//! d = (sin θ sin φ, cos θ, −sin θ cos φ). Texel (x, y) covers u ∈ [x, x+1]/W,
//! v ∈ [y, y+1]/H; its centre is at ((x+½)/W, (y+½)/H) and its solid angle is exact:
//!
//! ```text
//! Ω(y) = Δφ · (cos θ_top − cos θ_bottom) = (2π/W) · 2 sin(θ_mid) sin(Δθ/2),  Δθ = π/H
//! ```
//!
//! (the product form avoids cancellation near the poles); Σ Ω = 4π to rounding.
//!
//! Loading: OpenEXR (first layer with R, G, B channels, any sample type, as f32) and
//! Radiance RGBE `.hdr`, detected by magic bytes, never by extension. Every texel must be
//! finite (NaN/Inf is an error naming the first one, DESIGN §6); negative values are
//! clamped to 0 with a warning. A 1:1 image is a Debevec angular probe ([`angular`]),
//! resampled onto a 2:1 map on load — when its content says so (no light outside the
//! inscribed disk); otherwise it is refused as ambiguous unless the path is given as
//! `angular:PATH` ([`resolve`]).

pub mod angular;
pub mod equirect;
pub mod project;
pub mod sampler;
pub mod schedule;
pub mod sh_file;
pub mod sky;

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use glam::{DVec2, DVec3};

/// Name that [`resolve`] maps to the built-in sky (DESIGN §4 `--env sky`).
pub const BUILTIN_SKY: &str = "sky";
/// Width of the built-in sky returned by [`resolve`] (height is half of it).
pub const BUILTIN_SKY_WIDTH: u32 = 512;

/// Errors of loading and writing environment maps; each message is one line naming the
/// file. The underlying I/O error, where there is one, follows via `source()` (printed by
/// `{err:#}` in `main.rs`).
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    /// The file could not be opened or read.
    #[error("{}: cannot read", .path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file could not be written.
    #[error("{}: cannot write: {detail}", .path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What the encoder reported.
        detail: String,
    },
    /// Not an OpenEXR/Radiance file, or the decoder failed.
    #[error("{}: {detail}", .path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        detail: String,
    },
    /// The image has no texels.
    #[error("{}: image is empty ({width}×{height})", .path.display())]
    Empty {
        /// The file.
        path: PathBuf,
        /// Width in texels.
        width: u32,
        /// Height in texels.
        height: u32,
    },
    /// Not 2:1.
    #[error(
        "{}: {width}×{height} is neither a 2:1 equirectangular map nor a 1:1 angular probe",
        .path.display()
    )]
    Shape {
        /// The file.
        path: PathBuf,
        /// Width in texels.
        width: u32,
        /// Height in texels.
        height: u32,
    },
    /// Fewer rows than [`equirect::MIN_ENV_HEIGHT`] (an angular probe: after its resampling).
    #[error(
        "{}: {width}×{height} is too small to light with (one row cannot tell the sky from the ground): an equirectangular map needs at least {}×{} texels, an angular probe {}×{}",
        .path.display(),
        2 * equirect::MIN_ENV_HEIGHT,
        equirect::MIN_ENV_HEIGHT,
        equirect::MIN_ENV_HEIGHT,
        equirect::MIN_ENV_HEIGHT
    )]
    TooSmall {
        /// The file.
        path: PathBuf,
        /// Width in texels.
        width: u32,
        /// Height in texels.
        height: u32,
    },
    /// A 1:1 image with light outside its inscribed disk: not recognisably an angular probe.
    #[error(
        "{}: {width}×{width} has {:.1}% of its light outside the inscribed disk, so it is not read as an angular probe (a mirror ball, a cropped panorama?); to read it as one anyway, pass --env angular:{}",
        .path.display(), 100.0 * .outside, .path.display()
    )]
    Ambiguous {
        /// The file.
        path: PathBuf,
        /// Side in texels.
        width: u32,
        /// Share of the luminance outside the disk.
        outside: f64,
    },
    /// Some texels are NaN or infinite.
    #[error(
        "{}: {count} texels are NaN or infinite (first at x={x}, y={y})",
        .path.display()
    )]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// Number of texels with a non-finite channel.
        count: usize,
        /// Column of the first such texel (row-major order).
        x: u32,
        /// Row of the first such texel (row 0 at the top).
        y: u32,
    },
}

/// Half-angle of the cone around the brightest texel that [`EnvMap::dominant_light`]
/// gathers, degrees.
pub const DOMINANT_LIGHT_CONE_DEG: f64 = 5.0;
/// Fraction of the brightest luminance a texel needs to count as part of that light.
pub const DOMINANT_LIGHT_FRACTION: f32 = 0.01;

/// An equirectangular radiance map (DESIGN §1; layout in the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    /// Width in texels (twice the height for maps from [`resolve`] and [`sky::sky`]).
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Linear RGB radiance, row-major, row 0 at the top (v = 0, direction +Y).
    pub texels: Vec<[f32; 3]>,
}

impl EnvMap {
    /// Builds a map by evaluating `radiance` at every texel centre
    /// ([`EnvMap::texel_center_dir`]); handy for tests and analytic environments.
    pub fn from_fn(width: u32, height: u32, radiance: impl Fn(DVec3) -> [f32; 3]) -> EnvMap {
        let mut map = EnvMap {
            width,
            height,
            texels: Vec::with_capacity(width as usize * height as usize),
        };
        for y in 0..height {
            for x in 0..width {
                let d = map.texel_center_dir(x, y);
                map.texels.push(radiance(d));
            }
        }
        map
    }

    /// Unit direction (+Y up) → equirect (u, v) in [0, 1]² (module doc, DESIGN §1).
    /// `d` need not be normalised but must be non-zero; u is in [0, 1] with the seam
    /// (u = 0 ≡ 1) at +Z.
    pub fn dir_to_uv(d: DVec3) -> DVec2 {
        let d = d.normalize();
        let u = 0.5 + d.x.atan2(-d.z) / (2.0 * PI);
        let v = d.y.clamp(-1.0, 1.0).acos() / PI;
        DVec2::new(u, v)
    }

    /// Equirect (u, v) → unit direction; inverse of [`EnvMap::dir_to_uv`].
    pub fn uv_to_dir(uv: DVec2) -> DVec3 {
        let phi = 2.0 * PI * (uv.x - 0.5);
        let theta = PI * uv.y;
        let (sin_t, cos_t) = theta.sin_cos();
        let (sin_p, cos_p) = phi.sin_cos();
        DVec3::new(sin_t * sin_p, cos_t, -sin_t * cos_p)
    }

    /// Direction through the centre of texel (`x`, `y`).
    pub fn texel_center_dir(&self, x: u32, y: u32) -> DVec3 {
        Self::uv_to_dir(DVec2::new(
            (x as f64 + 0.5) / self.width as f64,
            (y as f64 + 0.5) / self.height as f64,
        ))
    }

    /// Exact solid angle (sr) of any texel in row `y`:
    /// Δφ · (cos θ_top − cos θ_bottom), written as a product to avoid cancellation.
    pub fn texel_solid_angle(&self, y: u32) -> f64 {
        let d_phi = 2.0 * PI / self.width as f64;
        let d_theta = PI / self.height as f64;
        let theta_mid = (y as f64 + 0.5) * d_theta;
        d_phi * 2.0 * theta_mid.sin() * (0.5 * d_theta).sin()
    }

    /// Radiance of texel (`x`, `y`).
    ///
    /// # Panics
    /// If the texel is outside the map.
    pub fn texel(&self, x: u32, y: u32) -> [f32; 3] {
        assert!(
            x < self.width && y < self.height,
            "texel ({x}, {y}) outside"
        );
        self.texels[y as usize * self.width as usize + x as usize]
    }

    /// Row-major index of the texel whose solid angle holds direction `d` (non-zero).
    pub fn texel_index(&self, d: DVec3) -> usize {
        let uv = Self::dir_to_uv(d);
        let (w, h) = (self.width as usize, self.height as usize);
        let x = ((uv.x * w as f64) as usize).min(w - 1);
        let y = ((uv.y * h as f64) as usize).min(h - 1);
        y * w + x
    }

    /// Radiance in direction `d` (non-zero) read as piecewise constant: the texel that
    /// holds it (how `sampler` and `project` read the map).
    pub fn radiance_at(&self, d: DVec3) -> [f32; 3] {
        self.texels[self.texel_index(d)]
    }

    /// Bilinearly filtered radiance in direction `d` (non-zero), between texel centres;
    /// wraps around in u, clamps in v (the first and last rows extend to the poles).
    pub fn sample_bilinear(&self, d: DVec3) -> [f32; 3] {
        let uv = Self::dir_to_uv(d);
        let (w, h) = (self.width as i64, self.height as i64);
        let px = uv.x * w as f64 - 0.5;
        let py = (uv.y * h as f64 - 0.5).clamp(0.0, (h - 1) as f64);
        let (x0f, y0f) = (px.floor(), py.floor());
        let (fx, fy) = ((px - x0f) as f32, (py - y0f) as f32);
        let x0 = (x0f as i64).rem_euclid(w);
        let x1 = (x0 + 1) % w;
        let y0 = (y0f as i64).clamp(0, h - 1);
        let y1 = (y0 + 1).min(h - 1);
        let at = |x: i64, y: i64| self.texels[(y * w + x) as usize];
        let (a, b, c, e) = (at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1));
        std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (e[k] - c[k]) * fx;
            top + (bottom - top) * fy
        })
    }

    /// The map's dominant light as a directional one (`--specular`: "the sun of the
    /// environment"): around the brightest texel (by luminance), the texels within
    /// [`DOMINANT_LIGHT_CONE_DEG`] of it that reach [`DOMINANT_LIGHT_FRACTION`] of its
    /// luminance; their irradiance Σ L dω (RGB, at normal incidence) and the direction of
    /// their luminance-weighted centroid. The built-in sky's sun is that; for a captured
    /// probe it is its brightest small region. `None` for a black map.
    pub fn dominant_light(&self) -> Option<(DVec3, [f64; 3])> {
        let luminance = |t: [f32; 3]| 0.2126 * t[0] + 0.7152 * t[1] + 0.0722 * t[2];
        let (brightest, peak) = self
            .texels
            .iter()
            .enumerate()
            .map(|(i, &t)| (i, luminance(t)))
            .max_by(|a, b| a.1.total_cmp(&b.1))?;
        if peak.is_nan() || peak <= 0.0 {
            return None;
        }
        let w = self.width as usize;
        let centre = self.texel_center_dir((brightest % w) as u32, (brightest / w) as u32);
        let cos_cone = DOMINANT_LIGHT_CONE_DEG.to_radians().cos();
        let (mut irradiance, mut weighted) = ([0.0f64; 3], DVec3::ZERO);
        for (i, &t) in self.texels.iter().enumerate() {
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            let d = self.texel_center_dir(x, y);
            if luminance(t) < DOMINANT_LIGHT_FRACTION * peak || d.dot(centre) < cos_cone {
                continue;
            }
            let d_omega = self.texel_solid_angle(y);
            for (e, c) in irradiance.iter_mut().zip(t) {
                *e += f64::from(c) * d_omega;
            }
            weighted += d * f64::from(luminance(t)) * d_omega;
        }
        Some((weighted.try_normalize().unwrap_or(centre), irradiance))
    }

    /// Writes the map as an RGB f32 OpenEXR file (fixtures, debugging).
    ///
    /// # Errors
    /// [`EnvError::Write`] if the file cannot be created or encoded.
    pub fn save_exr(&self, path: impl AsRef<Path>) -> Result<(), EnvError> {
        equirect::save_exr(self, path.as_ref())
    }
}

/// Prefix of an `--env` path that reads a 1:1 image as an angular probe whatever its
/// content ([`equirect::SquareLayout::Angular`]).
pub const ANGULAR_PREFIX: &str = "angular:";

/// Prefix of an `--env` given by its SH coefficients ([`sh_file`]).
pub const SH_PREFIX: &str = "sh:";

/// The file an `--env` argument reads ([`resolve`]): the path after `angular:` or `sh:`, or
/// the argument itself; `None` for the built-in sky.
pub fn file_of(name_or_path: &str) -> Option<&Path> {
    if name_or_path == BUILTIN_SKY || name_or_path.starts_with("sky:") {
        return None;
    }
    let path = [ANGULAR_PREFIX, SH_PREFIX]
        .iter()
        .find_map(|prefix| name_or_path.strip_prefix(prefix))
        .unwrap_or(name_or_path);
    Some(Path::new(path))
}

/// `--env` argument → map: [`BUILTIN_SKY`] ("sky") is the procedural sky
/// ([`sky::sky`], [`BUILTIN_SKY_WIDTH`] × half, default [`sky::SkyParams`]); `sky:DEG` the
/// same with the sun DEG° high ([`sky::SkyParams::with_sun_elevation`]);
/// `angular:PATH` a 1:1 image read as an angular probe; `sh:FILE` SH coefficients as
/// `shvis sh project` prints them ([`sh_file`]); anything else a path loaded by
/// [`equirect::load`] (1:1 images detected by content).
///
/// # Errors
/// Whatever [`equirect::load`] reports for the file.
pub fn resolve(name_or_path: &str) -> Result<EnvMap, EnvError> {
    if name_or_path == BUILTIN_SKY {
        Ok(sky::sky(BUILTIN_SKY_WIDTH, &sky::SkyParams::default()))
    } else if let Some(degrees) = name_or_path.strip_prefix("sky:") {
        let elevation: f64 = degrees
            .parse()
            .ok()
            .filter(|e: &f64| (1.0..=90.0).contains(e))
            .ok_or_else(|| EnvError::Format {
                path: PathBuf::from(name_or_path),
                detail: "sky:DEG takes a sun elevation in degrees, 1 to 90".into(),
            })?;
        Ok(sky::sky(
            BUILTIN_SKY_WIDTH,
            &sky::SkyParams::with_sun_elevation(elevation),
        ))
    } else if let Some(path) = name_or_path.strip_prefix(ANGULAR_PREFIX) {
        if path.is_empty() {
            return Err(EnvError::Format {
                path: PathBuf::from(name_or_path),
                detail: "angular:PATH needs the path of a 1:1 angular probe".into(),
            });
        }
        equirect::load_as(Path::new(path), equirect::SquareLayout::Angular)
    } else if let Some(path) = name_or_path.strip_prefix(SH_PREFIX) {
        if path.is_empty() {
            return Err(EnvError::Format {
                path: PathBuf::from(name_or_path),
                detail: "sh:FILE needs the path of a file of SH coefficients (r g b per line)"
                    .into(),
            });
        }
        sh_file::environment(Path::new(path))
    } else {
        equirect::load(Path::new(name_or_path))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two f64 trigonometric round trips.
    const ROUND_TRIP: f64 = 1e-13;

    #[test]
    fn uv_convention_matches_design() {
        let cases = [
            (DVec3::NEG_Z, DVec2::new(0.5, 0.5)),
            (DVec3::X, DVec2::new(0.75, 0.5)),
            (DVec3::NEG_X, DVec2::new(0.25, 0.5)),
        ];
        for (d, uv) in cases {
            let got = EnvMap::dir_to_uv(d);
            assert!((got - uv).length() < ROUND_TRIP, "{d} -> {got}, want {uv}");
        }
        // At the poles u is arbitrary; v is exact.
        assert_eq!(EnvMap::dir_to_uv(DVec3::Y).y, 0.0);
        assert_eq!(EnvMap::dir_to_uv(DVec3::NEG_Y).y, 1.0);
        // +Z sits on the seam: u = 0 or 1.
        let u = EnvMap::dir_to_uv(DVec3::Z).x;
        assert!(u.abs() < ROUND_TRIP || (u - 1.0).abs() < ROUND_TRIP, "{u}");
    }

    #[test]
    fn the_dominant_light_of_the_sky_is_its_sun() {
        let params = sky::SkyParams::with_sun_elevation(30.0);
        let map = sky::sky(512, &params);
        let (dir, e) = map.dominant_light().unwrap();
        assert!(
            dir.angle_between(params.sun_dir).to_degrees() < 0.5,
            "{dir}"
        );
        // All of the sun's irradiance, little of the sky's around it.
        let sun = params.sun_radiance * params.sun_solid_angle();
        let lum = 0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2];
        assert!((lum / sun - 1.0).abs() < 0.05, "{lum} vs {sun}");
        assert!(
            EnvMap::from_fn(8, 4, |_| [0.0; 3])
                .dominant_light()
                .is_none()
        );
    }

    #[test]
    fn sky_takes_a_sun_elevation() {
        let low = resolve("sky:15").expect("sky:15");
        let brightest = low
            .texels
            .iter()
            .enumerate()
            .max_by(|a, b| a.1[1].total_cmp(&b.1[1]))
            .map(|(i, _)| i)
            .unwrap();
        let row = brightest / low.width as usize;
        let elevation = 90.0 - (row as f64 + 0.5) / low.height as f64 * 180.0;
        assert!((elevation - 15.0).abs() < 1.0, "{elevation}");
        for bad in ["sky:", "sky:0", "sky:91", "sky:x", "sky:NaN"] {
            assert!(resolve(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn uv_round_trip() {
        for i in 0..40 {
            for j in 1..20 {
                let uv = DVec2::new((i as f64 + 0.3) / 40.0, j as f64 / 20.0);
                let d = EnvMap::uv_to_dir(uv);
                let back = EnvMap::dir_to_uv(d);
                assert!((back - uv).length() < ROUND_TRIP, "{uv} -> {d} -> {back}");
            }
        }
    }

    #[test]
    fn solid_angles_sum_to_4pi_and_match_difference_form() {
        let map = EnvMap::from_fn(64, 32, |_| [0.0; 3]);
        let mut total = 0.0;
        for y in 0..32 {
            let omega = map.texel_solid_angle(y);
            let (t0, t1) = (PI * y as f64 / 32.0, PI * (y + 1) as f64 / 32.0);
            let diff = 2.0 * PI / 64.0 * (t0.cos() - t1.cos());
            assert!((omega - diff).abs() < 1e-15, "row {y}: {omega} vs {diff}");
            total += 64.0 * omega;
        }
        assert!((total - 4.0 * PI).abs() < 1e-12, "{total}");
    }

    #[test]
    fn bilinear_wraps_in_u_and_hits_centres() {
        let map = EnvMap::from_fn(8, 4, |d| [d.x as f32, d.y as f32, d.z as f32]);
        for y in 0..4 {
            for x in 0..8 {
                let d = map.texel_center_dir(x, y);
                let s = map.sample_bilinear(d);
                assert!(
                    (0..3).all(|k| (s[k] - map.texel(x, y)[k]).abs() < 1e-6),
                    "({x},{y}): {s:?}"
                );
            }
        }
        // Across the seam (+Z, u = 0 ≡ 1): the mean of the first and last columns.
        let row = 1;
        let s = map.sample_bilinear(EnvMap::uv_to_dir(DVec2::new(0.0, 0.375)));
        let (a, b) = (map.texel(0, row), map.texel(7, row));
        assert!((0..3).all(|k| (s[k] - 0.5 * (a[k] + b[k])).abs() < 1e-6));
        // Poles clamp to the first/last row.
        let top = map.sample_bilinear(DVec3::Y);
        assert!(top.iter().all(|c| c.is_finite()));
    }
}
