//! Importance sampling of an equirect map ([`EnvSampler`]) and the random streams that
//! drive it ([`Pcg32`]): what the reference renderer (`crate::reference`) and the SH
//! lightmap bake with `--bake-env pixels` (`crate::bake::shlmap`) read of the full-resolution
//! environment.
//!
//! The map is read as piecewise constant: a texel t with luminance Y_t and exact solid angle
//! Ω_t ([`EnvMap::texel_solid_angle`]) is chosen with probability
//!
//! ```text
//! p_t = Y_t Ω_t / Σ_u Y_u Ω_u,     pdf(ω) = p_t / Ω_t   for ω in texel t                  (1)
//! ```
//!
//! and the direction is uniform in solid angle within it (φ uniform, cos θ uniform), so (1)
//! is the density exactly and Σ f(ω_s)/pdf(ω_s) is unbiased for the map as
//! `crate::env::project` reads it.

use glam::Vec3;

use super::EnvMap;

/// Importance sampling of an equirect map by luminance × texel solid angle.
pub struct EnvSampler<'a> {
    env: &'a EnvMap,
    /// Cumulative weights over texels (row-major), last = total.
    cdf: Vec<f64>,
    /// A guide table (Devroye, *Non-Uniform Random Variate Generation*, §III.2.4): entry
    /// b is the first texel whose `cdf` exceeds b/n of the total (n = texels), so that a
    /// search for the first texel above a target starts at most a few texels short of it
    /// — the texel a binary search over `cdf` finds, at one or two cache misses.
    guide: Vec<u32>,
    /// Per row, [`EnvMap::texel_solid_angle`].
    row_solid_angles: Vec<f64>,
    /// cos θ at the row edges: row y spans `edge_cos[y]` to `edge_cos[y + 1]`.
    edge_cos: Vec<f64>,
}

impl<'a> EnvSampler<'a> {
    pub fn new(env: &'a EnvMap) -> Self {
        let row_solid_angles: Vec<f64> =
            (0..env.height).map(|y| env.texel_solid_angle(y)).collect();
        let mut cdf = Vec::with_capacity(env.texels.len());
        let mut total = 0.0;
        for (y, &omega) in (0..env.height).zip(&row_solid_angles) {
            for x in 0..env.width {
                let [r, g, b] = env.texel(x, y);
                total +=
                    (0.2126 * r as f64 + 0.7152 * g as f64 + 0.0722 * b as f64).max(0.0) * omega;
                cdf.push(total);
            }
        }
        let count = cdf.len();
        let mut guide = Vec::with_capacity(count);
        let mut t = 0;
        for b in 0..count {
            let start = b as f64 * total / count as f64;
            while t + 1 < count && cdf[t] <= start {
                t += 1;
            }
            guide.push(t as u32);
        }
        let h = env.height as f64;
        EnvSampler {
            env,
            cdf,
            guide,
            row_solid_angles,
            edge_cos: (0..=env.height)
                .map(|y| (std::f64::consts::PI * y as f64 / h).cos())
                .collect(),
        }
    }

    /// (direction, radiance, pdf per steradian) of one sample.
    pub fn sample(&self, rng: &mut Pcg32) -> (Vec3, [f32; 3], f64) {
        let total = *self.cdf.last().unwrap_or(&0.0);
        if total <= 0.0 {
            return (Vec3::Y, [0.0; 3], 0.0);
        }
        let target = rng.next_f64() * total;
        let w = self.env.width as usize;
        // The first texel whose cdf exceeds the target (the last one if none does),
        // scanned from the guide entry of the slice below the target's: that slice starts
        // below the target whatever the rounding of the slice index.
        let count = self.cdf.len();
        let slice = ((target / total * count as f64) as usize).min(count - 1);
        let mut t = self.guide[slice.saturating_sub(1)] as usize;
        while t + 1 < count && self.cdf[t] <= target {
            t += 1;
        }
        let (x, y) = (t % w, t / w);
        let p_texel = (self.cdf[t] - if t > 0 { self.cdf[t - 1] } else { 0.0 }) / total;
        let omega = self.row_solid_angles[y];
        // Uniform in solid angle within the texel: φ uniform, cos θ uniform.
        let pi = std::f64::consts::PI;
        let (cos0, cos1) = (self.edge_cos[y], self.edge_cos[y + 1]);
        let cos_theta = cos0 + rng.next_f64() * (cos1 - cos0);
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

    /// The total Σ Y_t Ω_t of (1); 0 for a black map, which has no samples.
    pub fn total(&self) -> f64 {
        *self.cdf.last().unwrap_or(&0.0)
    }

    /// Eq. (1): the density per steradian with which [`EnvSampler::sample`] draws `dir`.
    pub fn pdf(&self, dir: Vec3) -> f64 {
        let total = self.total();
        if total <= 0.0 {
            return 0.0;
        }
        let t = self.env.texel_index(dir.as_dvec3());
        let y = (t / self.env.width as usize) as u32;
        let p_texel = self.cdf[t] - if t > 0 { self.cdf[t - 1] } else { 0.0 };
        p_texel / total / self.row_solid_angles[y as usize]
    }

    /// The map's radiance along `dir`, read as (1) reads it: the texel that holds it.
    pub fn radiance(&self, dir: Vec3) -> [f32; 3] {
        self.env.radiance_at(dir.as_dvec3())
    }
}

/// PCG32 (O'Neill), one stream per pixel.
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed ^ 0x853C_49E6_748F_EA9B);
        rng.next_u32();
        rng
    }
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }
    /// Uniform in [0, 1) with 53 bits.
    pub fn next_f64(&mut self) -> f64 {
        let hi = (self.next_u32() >> 5) as u64;
        let lo = (self.next_u32() >> 6) as u64;
        ((hi << 26) | lo) as f64 / (1u64 << 53) as f64
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;

    fn test_map() -> EnvMap {
        // A dim sky with a small bright sun.
        let sun = DVec3::new(0.3, 0.8, -0.5).normalize();
        EnvMap::from_fn(64, 32, |d| {
            if d.dot(sun) > 0.995 {
                [5000.0, 4000.0, 3000.0]
            } else {
                [0.2, 0.3, 0.5]
            }
        })
    }

    #[test]
    fn samples_have_the_density_pdf_gives_them_and_the_radiance_of_their_texel() {
        let map = test_map();
        let sampler = EnvSampler::new(&map);
        let mut rng = Pcg32::new(7, 3);
        for _ in 0..1000 {
            let (dir, radiance, pdf) = sampler.sample(&mut rng);
            assert!((dir.length() - 1.0).abs() < 1e-5);
            let expected = sampler.pdf(dir);
            assert!((pdf - expected).abs() <= 1e-9 * pdf, "{pdf} vs {expected}");
            assert_eq!(radiance, sampler.radiance(dir));
        }
    }

    #[test]
    fn the_density_integrates_to_one_and_the_estimator_to_the_map_integral() {
        let map = test_map();
        let sampler = EnvSampler::new(&map);
        // ∫ pdf dω over the texels, exactly.
        let mut integral = 0.0;
        let mut irradiance_up = 0.0;
        for y in 0..map.height {
            for x in 0..map.width {
                let d = map.texel_center_dir(x, y).as_vec3();
                integral += sampler.pdf(d) * map.texel_solid_angle(y);
                irradiance_up +=
                    map.texel(x, y)[1] as f64 * d.y.max(0.0) as f64 * map.texel_solid_angle(y);
            }
        }
        assert!((integral - 1.0).abs() < 1e-9, "{integral}");
        // The importance-sampled estimate of the upward irradiance (green) agrees.
        let mut rng = Pcg32::new(1, 1);
        let n = 200_000;
        let estimate: f64 = (0..n)
            .map(|_| {
                let (d, l, pdf) = sampler.sample(&mut rng);
                l[1] as f64 * d.y.max(0.0) as f64 / pdf
            })
            .sum::<f64>()
            / n as f64;
        assert!(
            (estimate - irradiance_up).abs() < 0.01 * irradiance_up,
            "{estimate} vs {irradiance_up}"
        );
    }
}
