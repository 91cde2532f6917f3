//! A material's height field (bump texture): heights in texel units, wrapped at the borders
//! (bump textures tile). The SSBump bake (`bake::ssbump`), the NDF moments of a height
//! field (`ndf`) and displaced geometry (`scene::displace`) read it.

use glam::DVec3;
use rayon::prelude::*;

/// The largest height scale (texels of height of a white texel, or the factor on the
/// built-in bricks' heights): relief of 100 texels is far beyond a bump map's, and it keeps
/// the SSBump bake's ray marches short (`bake::ssbump`).
pub const MAX_HEIGHT_SCALE: f64 = 100.0;

/// A height field: `width` × `height` heights in texel units, row 0 at the top (image up).
#[derive(Clone, Debug, PartialEq)]
pub struct HeightField {
    pub width: usize,
    pub height: usize,
    pub h: Vec<f64>,
}

impl HeightField {
    fn at(&self, x: i64, y: i64) -> f64 {
        let (w, h) = (self.width as i64, self.height as i64);
        self.h[(y.rem_euclid(h) * w + x.rem_euclid(w)) as usize]
    }

    /// Bilinear height at continuous texel coordinates (texel centres at integers), wrapped.
    pub fn sample(&self, x: f64, y: f64) -> f64 {
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (i, j) = (x0 as i64, y0 as i64);
        let top = self.at(i, j) * (1.0 - fx) + self.at(i + 1, j) * fx;
        let bottom = self.at(i, j + 1) * (1.0 - fx) + self.at(i + 1, j + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// Tangent-space normal at texel (x, y) by central differences (+Y is image up, so
    /// the row below is −Y).
    pub fn normal(&self, x: usize, y: usize) -> DVec3 {
        let (x, y) = (x as i64, y as i64);
        let dhdx = 0.5 * (self.at(x + 1, y) - self.at(x - 1, y));
        let dhdy = 0.5 * (self.at(x, y - 1) - self.at(x, y + 1));
        DVec3::new(-dhdx, -dhdy, 1.0).normalize()
    }

    /// Edge-preserving smoothing (Tomasi–Manduchi): Gaussian in texels (`sigma_spatial`)
    /// times Gaussian in height (`sigma_range`, texel units), radius 3σ, wrapped.
    pub fn bilateral(&self, sigma_spatial: f64, sigma_range: f64) -> HeightField {
        if sigma_spatial <= 0.0 {
            return self.clone();
        }
        let r = (3.0 * sigma_spatial).ceil() as i64;
        let h: Vec<f64> = (0..self.width * self.height)
            .into_par_iter()
            .map(|t| {
                let (x, y) = ((t % self.width) as i64, (t / self.width) as i64);
                let centre = self.h[t];
                let (mut sum, mut weight) = (0.0, 0.0);
                for dy in -r..=r {
                    for dx in -r..=r {
                        let v = self.at(x + dx, y + dy);
                        // The centre's weight is 1 at any σ: 0 / (2σ²) is NaN where σ² underflows.
                        let d2 = (dx * dx + dy * dy) as f64;
                        let ds = if d2 == 0.0 {
                            0.0
                        } else {
                            d2 / (2.0 * sigma_spatial * sigma_spatial)
                        };
                        let dr =
                            (v - centre).powi(2) / (2.0 * sigma_range * sigma_range).max(1e-300);
                        let w = (-ds - dr).exp();
                        sum += w * v;
                        weight += w;
                    }
                }
                sum / weight
            })
            .collect();
        HeightField { h, ..*self }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A spatial σ far below a texel (down to one whose square underflows) leaves every
    /// height as it was: the centre weighs 1, the neighbours nothing.
    #[test]
    fn a_spatial_sigma_far_below_a_texel_leaves_the_heights() {
        let field = HeightField {
            width: 4,
            height: 3,
            h: (0..12).map(|i| f64::from(i * i % 7)).collect(),
        };
        for sigma in [1e-3, 1e-160, 1e-300] {
            assert_eq!(field.bilateral(sigma, 0.5), field, "σ = {sigma}");
        }
    }
}
