//! Debevec angular light probes (1:1 images, the format of the paper's Fig. 7 probes;
//! DESIGN §1).
//!
//! # Layout
//!
//! Pixel (col, row) of an N × N probe has its centre at image coordinates
//! s = (col + ½)/N, t = (row + ½)/N (row 0 at the top); with a = 2s − 1 (right) and
//! b = 1 − 2t (up), r = √(a² + b²), the pixel sees
//!
//! ```text
//! θ = π r (angle from −Z, the image centre),  d = (a/r · sin θ, b/r · sin θ, −cos θ)
//! ```
//!
//! so the centre looks along −Z (the centre of this project's equirect maps too), the disk's
//! rim r = 1 is +Z, and pixels with r > 1 see nothing. dΩ = sin θ dθ dφ = π sin(πr)/r da db
//! = 4π sin(πr)/r ds dt: the Jacobian vanishes at the rim, so a pixel's **exact** solid
//! angle is the integral of a continuous function over the part of the pixel inside the
//! disk ([`AngularProbe::texel_solid_angle`]: Gauss–Legendre, refined on rim pixels;
//! Σ Ω = 4π to 1e-9).
//!
//! # Use
//!
//! `equirect::load` reads a 1:1 image as a probe (the shape decides: an equirect map is
//! 2:1) and [`AngularProbe::to_equirect`] resamples it (bilinear in the probe, 4 × 4
//! samples per equirect texel weighted by solid angle) onto a 2N × N equirect map, which is
//! what the rest of the pipeline reads. [`AngularProbe::project_sh`] projects the probe
//! itself with its exact pixel solid angles (tests compare the two routes).

use std::f64::consts::PI;

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::EnvMap;
use crate::sh::basis::eval_basis;
use crate::sh::{Order, gauss_legendre};

/// An N × N angular probe (module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct AngularProbe {
    pub size: u32,
    /// Linear RGB radiance, row-major, row 0 at the top.
    pub texels: Vec<[f32; 3]>,
}

/// Gauss–Legendre nodes per pixel side inside the disk, and sub-squares per side of a rim
/// pixel (each with the same rule).
const NODES: usize = 4;
const RIM_SPLIT: u32 = 8;

impl AngularProbe {
    /// Share of the image's luminance in pixels wholly outside the disk (which an angular
    /// probe leaves black). A 1:1 image with light there is not a clean probe — a cropped
    /// panorama, a mirror-ball photo with its surroundings — and is not read as one unless
    /// asked for (`angular:` in `--env`, [`super::equirect::load`]).
    pub fn light_outside_disk(&self) -> f64 {
        let n = f64::from(self.size);
        let (mut outside, mut total) = (0.0f64, 0.0f64);
        for (i, t) in self.texels.iter().enumerate() {
            let lum = f64::from(0.2126 * t[0] + 0.7152 * t[1] + 0.0722 * t[2]).max(0.0);
            let (col, row) = (
                (i % self.size as usize) as f64,
                (i / self.size as usize) as f64,
            );
            // The pixel's point nearest the centre, in disk coordinates a, b ∈ [−1, 1].
            let nearest = |lo: f64| {
                let (a0, a1) = (2.0 * lo / n - 1.0, 2.0 * (lo + 1.0) / n - 1.0);
                if a0 <= 0.0 && a1 >= 0.0 {
                    0.0
                } else {
                    a0.abs().min(a1.abs())
                }
            };
            if nearest(col).hypot(nearest(row)) > 1.0 {
                outside += lum;
            }
            total += lum;
        }
        if total > 0.0 { outside / total } else { 0.0 }
    }

    /// Image coordinates (s, t) ∈ [0, 1]² of direction `d` (non-zero).
    pub fn dir_to_st(d: DVec3) -> DVec2 {
        let d = d.normalize();
        let theta = (-d.z).clamp(-1.0, 1.0).acos();
        let r = theta / PI;
        let side = (d.x * d.x + d.y * d.y).sqrt();
        let (a, b) = if side > 0.0 {
            (d.x / side * r, d.y / side * r)
        } else {
            (r, 0.0)
        };
        DVec2::new(0.5 * (a + 1.0), 0.5 * (1.0 - b))
    }

    /// Direction seen at image coordinates (s, t), or `None` outside the disk.
    pub fn st_to_dir(st: DVec2) -> Option<DVec3> {
        let (a, b) = (2.0 * st.x - 1.0, 1.0 - 2.0 * st.y);
        let r = (a * a + b * b).sqrt();
        if r > 1.0 {
            return None;
        }
        if r == 0.0 {
            return Some(DVec3::NEG_Z);
        }
        let (sin, cos) = (PI * r).sin_cos();
        Some(DVec3::new(a / r * sin, b / r * sin, -cos))
    }

    /// dΩ / (ds dt) at (s, t): 4π sin(πr)/r inside the disk, 0 outside.
    fn jacobian(st: DVec2) -> f64 {
        let (a, b) = (2.0 * st.x - 1.0, 1.0 - 2.0 * st.y);
        let r = (a * a + b * b).sqrt();
        if r > 1.0 {
            0.0
        } else if r < 1e-12 {
            4.0 * PI * PI
        } else {
            4.0 * PI * (PI * r).sin() / r
        }
    }

    /// A probe with `radiance` evaluated at every pixel centre inside the disk (0 outside).
    pub fn from_fn(size: u32, radiance: impl Fn(DVec3) -> [f32; 3] + Sync) -> AngularProbe {
        let n = size as usize;
        let texels = (0..n * n)
            .into_par_iter()
            .map(|i| {
                let st = DVec2::new(
                    ((i % n) as f64 + 0.5) / n as f64,
                    ((i / n) as f64 + 0.5) / n as f64,
                );
                Self::st_to_dir(st).map_or([0.0; 3], &radiance)
            })
            .collect();
        AngularProbe { size, texels }
    }

    /// The probe of an equirect map: per pixel the solid-angle-weighted mean of 4 × 4
    /// bilinear samples of `env` inside the disk (0 for pixels wholly outside).
    pub fn from_equirect(env: &EnvMap, size: u32) -> AngularProbe {
        let n = size as usize;
        let texels = (0..n * n)
            .into_par_iter()
            .map(|i| {
                let (x, y) = ((i % n) as f64, (i / n) as f64);
                let (mut sum, mut weight) = ([0.0f64; 3], 0.0f64);
                for sy in 0..4 {
                    for sx in 0..4 {
                        let st = DVec2::new(
                            (x + (f64::from(sx) + 0.5) / 4.0) / n as f64,
                            (y + (f64::from(sy) + 0.5) / 4.0) / n as f64,
                        );
                        let Some(d) = Self::st_to_dir(st) else {
                            continue;
                        };
                        let w = Self::jacobian(st);
                        let l = env.sample_bilinear(d);
                        for c in 0..3 {
                            sum[c] += w * f64::from(l[c]);
                        }
                        weight += w;
                    }
                }
                if weight > 0.0 {
                    sum.map(|v| (v / weight) as f32)
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        AngularProbe { size, texels }
    }

    /// Quadrature nodes (s, t, weight = Jacobian × area) covering pixel (col, row): a
    /// 4 × 4 Gauss rule, on 8 × 8 sub-squares where the disk's rim crosses the pixel.
    fn pixel_nodes(&self, col: u32, row: u32, out: &mut Vec<(DVec2, f64)>) {
        out.clear();
        let n = f64::from(self.size);
        let (x0, y0) = (f64::from(col) / n, f64::from(row) / n);
        let h = 1.0 / n;
        let corner_r = |s: f64, t: f64| ((2.0 * s - 1.0).powi(2) + (1.0 - 2.0 * t).powi(2)).sqrt();
        let radii = [
            corner_r(x0, y0),
            corner_r(x0 + h, y0),
            corner_r(x0, y0 + h),
            corner_r(x0 + h, y0 + h),
        ];
        // The pixel nearest the centre contains r = 0 but no corner says so: test the
        // nearest point of the pixel to the centre as well.
        let near = corner_r((0.5f64).clamp(x0, x0 + h), (0.5f64).clamp(y0, y0 + h));
        let min_r = radii.iter().copied().fold(near, f64::min);
        if min_r > 1.0 {
            return;
        }
        let split = if radii.iter().any(|&r| r > 1.0) {
            RIM_SPLIT
        } else {
            1
        };
        let (g, w) = gauss_legendre(NODES);
        let sub = h / f64::from(split);
        for sy in 0..split {
            for sx in 0..split {
                let (bx, by) = (x0 + f64::from(sx) * sub, y0 + f64::from(sy) * sub);
                for (gi, wi) in g.iter().zip(&w) {
                    for (gj, wj) in g.iter().zip(&w) {
                        let st =
                            DVec2::new(bx + 0.5 * sub * (gi + 1.0), by + 0.5 * sub * (gj + 1.0));
                        let weight = Self::jacobian(st) * wi * wj * 0.25 * sub * sub;
                        if weight > 0.0 {
                            out.push((st, weight));
                        }
                    }
                }
            }
        }
    }

    /// Exact solid angle of pixel (col, row), sr (module doc).
    pub fn texel_solid_angle(&self, col: u32, row: u32) -> f64 {
        let mut nodes = Vec::new();
        self.pixel_nodes(col, row, &mut nodes);
        nodes.iter().map(|(_, w)| w).sum()
    }

    /// RGB SH of the probe, each pixel constant over its exact patch of the sphere.
    pub fn project_sh(&self, order: Order) -> Vec<[f64; 3]> {
        let n2 = order.coeff_count();
        let size = self.size;
        let rows: Vec<Vec<[f64; 3]>> = (0..size)
            .into_par_iter()
            .map(|row| {
                let mut acc = vec![[0.0f64; 3]; n2];
                let (mut nodes, mut y) = (Vec::new(), vec![0.0; n2]);
                for col in 0..size {
                    let l = self.texels[(row * size + col) as usize];
                    if l == [0.0; 3] {
                        continue;
                    }
                    self.pixel_nodes(col, row, &mut nodes);
                    for &(st, w) in &nodes {
                        let Some(d) = Self::st_to_dir(st) else {
                            continue;
                        };
                        eval_basis(order, d, &mut y);
                        for (a, yi) in acc.iter_mut().zip(&y) {
                            for c in 0..3 {
                                a[c] += f64::from(l[c]) * w * yi;
                            }
                        }
                    }
                }
                acc
            })
            .collect();
        (0..n2)
            .map(|i| std::array::from_fn(|c| rows.iter().map(|r| r[i][c]).sum()))
            .collect()
    }

    /// Bilinear radiance at image coordinates `st` (clamped to the image), from the taps
    /// whose centres are inside the disk (weights renormalized), so the rim does not blend
    /// in the black outside.
    fn sample(&self, st: DVec2) -> [f32; 3] {
        let n = self.size as i64;
        let (x, y) = (st.x * n as f64 - 0.5, st.y * n as f64 - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (mut sum, mut total) = ([0.0f64; 3], 0.0f64);
        for (dx, dy, w) in [
            (0.0, 0.0, (1.0 - fx) * (1.0 - fy)),
            (1.0, 0.0, fx * (1.0 - fy)),
            (0.0, 1.0, (1.0 - fx) * fy),
            (1.0, 1.0, fx * fy),
        ] {
            let (i, j) = (
                ((x0 + dx) as i64).clamp(0, n - 1),
                ((y0 + dy) as i64).clamp(0, n - 1),
            );
            let centre = DVec2::new((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            if w <= 0.0 || Self::st_to_dir(centre).is_none() {
                continue;
            }
            let l = self.texels[(j * n + i) as usize];
            for c in 0..3 {
                sum[c] += w * f64::from(l[c]);
            }
            total += w;
        }
        if total > 0.0 {
            sum.map(|v| (v / total) as f32)
        } else {
            // Past the outermost centres: the nearest pixel.
            let (i, j) = (
                (x.round() as i64).clamp(0, n - 1),
                (y.round() as i64).clamp(0, n - 1),
            );
            self.texels[(j * n + i) as usize]
        }
    }

    /// The probe resampled onto a `width` × `width`/2 equirect map: per texel the
    /// solid-angle-weighted mean of 4 × 4 bilinear probe samples (module doc).
    pub fn to_equirect(&self, width: u32) -> EnvMap {
        let (w, h) = (width.max(2), (width / 2).max(1));
        let texels = (0..(w * h) as usize)
            .into_par_iter()
            .map(|i| {
                let (x, y) = ((i % w as usize) as f64, (i / w as usize) as f64);
                let (mut sum, mut weight) = ([0.0f64; 3], 0.0f64);
                for sy in 0..4 {
                    for sx in 0..4 {
                        let uv = DVec2::new(
                            (x + (f64::from(sx) + 0.5) / 4.0) / f64::from(w),
                            (y + (f64::from(sy) + 0.5) / 4.0) / f64::from(h),
                        );
                        let d = EnvMap::uv_to_dir(uv);
                        let sin_theta = (PI * uv.y).sin();
                        let l = self.sample(Self::dir_to_st(d));
                        for c in 0..3 {
                            sum[c] += f64::from(l[c]) * sin_theta;
                        }
                        weight += sin_theta;
                    }
                }
                sum.map(|v| (v / weight.max(1e-300)) as f32)
            })
            .collect();
        EnvMap {
            width: w,
            height: h,
            texels,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::project::project_sh;

    /// A smooth analytic environment: sky gradient and a broad lobe.
    fn analytic(d: DVec3) -> [f32; 3] {
        let sun = DVec3::new(0.4, 0.5, 0.77).normalize();
        let lobe = (6.0 * (d.dot(sun) - 1.0)).exp();
        [
            (0.4 + 0.3 * d.y + 3.0 * lobe) as f32,
            (0.5 + 0.2 * d.x + 2.0 * lobe) as f32,
            (0.6 - 0.2 * d.z) as f32,
        ]
    }

    fn rel(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
        let (mut d, mut n) = (0.0, 0.0);
        for (x, y) in a.iter().zip(b) {
            for c in 0..3 {
                d += (x[c] - y[c]).powi(2);
                n += y[c].powi(2);
            }
        }
        (d / n).sqrt()
    }

    #[test]
    fn directions_round_trip_and_solid_angles_sum_to_four_pi() {
        for d in [
            DVec3::NEG_Z,
            DVec3::X,
            DVec3::new(0.3, -0.8, 0.52).normalize(),
            DVec3::new(-0.2, 0.1, 0.97).normalize(),
        ] {
            let back = AngularProbe::st_to_dir(AngularProbe::dir_to_st(d)).unwrap();
            assert!(back.distance(d) < 1e-12, "{d} → {back}");
        }
        // Every pixel 1, including rim pixels whose centre is just outside the disk.
        let probe = AngularProbe {
            size: 64,
            texels: vec![[1.0; 3]; 64 * 64],
        };
        let total: f64 = (0..64)
            .flat_map(|r| (0..64).map(move |c| (c, r)))
            .map(|(c, r)| probe.texel_solid_angle(c, r))
            .sum();
        assert!((total - 4.0 * PI).abs() < 1e-6, "{total}");
        // A constant probe projects to its DC term only.
        let sh = probe.project_sh(Order::THREE);
        assert!((sh[0][0] - (4.0 * PI).sqrt()).abs() < 1e-6, "{:?}", sh[0]);
        assert!(sh[1..].iter().flatten().all(|v| v.abs() < 1e-6));
    }

    /// The same analytic environment as an equirect map and as an angular probe projects to
    /// the same SH within 1e-3, directly and through the probe's equirect resampling.
    #[test]
    fn analytic_environment_projects_alike_in_both_layouts() {
        let order = Order::new(8).unwrap();
        let equirect = project_sh(&EnvMap::from_fn(1024, 512, analytic), order);
        let probe = AngularProbe::from_fn(512, analytic);
        let direct = probe.project_sh(order);
        let resampled = project_sh(&probe.to_equirect(1024), order);
        let (e1, e2) = (rel(&direct, &equirect), rel(&resampled, &equirect));
        eprintln!("probe vs equirect SH: direct {e1:.2e}, resampled {e2:.2e}");
        assert!(e1 < 1e-3 && e2 < 1e-3, "{e1} {e2}");
    }
}
