//! Lighting that changes per frame (Iwanicki–Sloan §3.3): the environment's SH
//! rotated about the up axis (+Y) by an angle per frame — the sun moving — and a
//! cross-fade between two environments (time of day), both applied to the SH coefficients
//! the techniques' lighting-dependent data is built from (order O + 2 for the L×H tables).
//!
//! ```text
//! L_f = (1 − t_f) · Rot_y(θ_f) L_a + t_f · Rot_y(θ_f) L_b,   θ_f = θ₀ + f·Δθ,
//! t_f = clamp((f − f₀) / n_fade, 0, 1)
//! ```
//!
//! Rotation is exact in SH (`sh::rotate`: per-band orthogonal blocks, g(ω) = f(Rᵀω)), and
//! every table of the techniques is linear in L, so a table built from L_f equals the same
//! blend of the tables of L_a and L_b (`tests/lxh.rs`). Which techniques can follow it is
//! [`crate::technique::Technique::dynamic_lighting`] (`shlmap` bakes its lighting in).

use glam::DMat3;

use crate::sh::Order;
use crate::sh::rotate::{apply_rotation_rgb, rotation_matrices};

/// A per-frame lighting schedule over SH radiance (RGB, one order for both maps).
#[derive(Clone, Debug, PartialEq)]
pub struct LightingSchedule {
    pub order: Order,
    /// Radiance SH of the first environment.
    pub from: Vec<[f64; 3]>,
    /// The environment faded to, if any (same order).
    pub to: Option<Vec<[f64; 3]>>,
    /// Rotation about +Y per frame, radians (positive: counter-clockwise seen from above).
    pub radians_per_frame: f64,
    /// Frame the fade starts at and how many frames it takes (0: a cut).
    pub fade_start: u32,
    pub fade_frames: u32,
}

impl LightingSchedule {
    /// A rotation of `from` by `turns` full turns over `frames` frames, no fade.
    pub fn rotating(order: Order, from: Vec<[f64; 3]>, turns: f64, frames: u32) -> Self {
        LightingSchedule {
            order,
            from,
            to: None,
            radians_per_frame: turns * std::f64::consts::TAU / f64::from(frames.max(1)),
            fade_start: 0,
            fade_frames: 0,
        }
    }

    /// Rotation angle at `frame`, radians.
    pub fn angle(&self, frame: u32) -> f64 {
        self.radians_per_frame * f64::from(frame)
    }

    /// Blend weight of `to` at `frame`, in [0, 1] (0 without `to`).
    pub fn fade(&self, frame: u32) -> f64 {
        if self.to.is_none() {
            return 0.0;
        }
        if frame < self.fade_start {
            return 0.0;
        }
        if self.fade_frames == 0 {
            return 1.0;
        }
        (f64::from(frame - self.fade_start) / f64::from(self.fade_frames)).min(1.0)
    }

    /// The radiance SH at `frame` (module doc).
    pub fn at(&self, frame: u32) -> Vec<[f64; 3]> {
        let n = self.order.coeff_count();
        let t = self.fade(frame);
        let blended: Vec<[f64; 3]> = match &self.to {
            Some(to) if t > 0.0 => blend(&self.from[..n], &to[..n], t),
            _ => self.from[..n].to_vec(),
        };
        let matrices = rotation_matrices(self.order, rotation_about_y(self.angle(frame)));
        apply_rotation_rgb(&matrices, &blended)
    }
}

/// (1 − t)·a + t·b per coefficient and colour.
pub fn blend(a: &[[f64; 3]], b: &[[f64; 3]], t: f64) -> Vec<[f64; 3]> {
    a.iter()
        .zip(b)
        .map(|(x, y)| std::array::from_fn(|c| (1.0 - t) * x[c] + t * y[c]))
        .collect()
}

/// The rotation by `angle` about +Y (right-handed: +Z turns towards +X).
pub fn rotation_about_y(angle: f64) -> DMat3 {
    DMat3::from_rotation_y(angle)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::EnvMap;
    use crate::env::project::project_sh;
    use glam::DVec3;

    /// A smooth analytic environment with a bright lobe and a gradient.
    fn lobes(d: DVec3, spin: DMat3) -> [f32; 3] {
        let d = spin.transpose() * d;
        let sun = DVec3::new(0.5, 0.6, -0.62).normalize();
        let lobe = (8.0 * (d.dot(sun) - 1.0)).exp();
        let sky = 0.3 + 0.2 * d.y;
        [
            (sky + 2.0 * lobe) as f32,
            (sky + 1.5 * lobe) as f32,
            (0.5 + 0.1 * d.x) as f32,
        ]
    }

    /// Rotating the projection equals projecting the rotated map, within the projection's
    /// own error (estimated as the difference between two map resolutions).
    #[test]
    fn rotated_projection_equals_projection_of_the_rotated_map() {
        let order = Order::new(8).unwrap();
        let angle = 1.1;
        let r = rotation_about_y(angle);
        let map = |w: u32, spin: DMat3| EnvMap::from_fn(w, w / 2, |d| lobes(d, spin));
        let base = project_sh(&map(512, DMat3::IDENTITY), order);
        let rotated_map = project_sh(&map(512, r), order);
        let finer = project_sh(&map(1024, r), order);
        let schedule = LightingSchedule {
            radians_per_frame: angle,
            ..LightingSchedule::rotating(order, base, 0.0, 1)
        };
        let rotated = schedule.at(1);
        let dist = |a: &[[f64; 3]], b: &[[f64; 3]]| {
            a.iter()
                .zip(b)
                .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).powi(2)))
                .sum::<f64>()
                .sqrt()
        };
        let norm = dist(&rotated_map, &vec![[0.0; 3]; rotated_map.len()]);
        let projection_error = dist(&rotated_map, &finer);
        let diff = dist(&rotated, &rotated_map);
        eprintln!(
            "rotation vs re-projection {:.2e}, projection error {:.2e} (relative)",
            diff / norm,
            projection_error / norm
        );
        assert!(
            diff <= 3.0 * projection_error + 1e-12 * norm,
            "rotation {diff:e} vs projection error {projection_error:e}"
        );
        assert!(diff < 1e-3 * norm, "{diff:e} of {norm:e}");
    }

    #[test]
    fn fade_runs_from_zero_to_one_and_a_full_turn_comes_back() {
        let order = Order::THREE;
        let a: Vec<[f64; 3]> = (0..9).map(|i| [i as f64, 1.0, -(i as f64)]).collect();
        let b: Vec<[f64; 3]> = (0..9).map(|i| [1.0, i as f64, 2.0]).collect();
        let s = LightingSchedule {
            to: Some(b.clone()),
            fade_start: 10,
            fade_frames: 20,
            ..LightingSchedule::rotating(order, a.clone(), 1.0, 40)
        };
        assert_eq!(
            (s.fade(0), s.fade(10), s.fade(20), s.fade(30), s.fade(99)),
            (0.0, 0.0, 0.5, 1.0, 1.0)
        );
        // Frame 40: one full turn, fully faded to b.
        for (x, y) in s.at(40).iter().zip(&b) {
            for c in 0..3 {
                assert!((x[c] - y[c]).abs() < 1e-12);
            }
        }
        // Frame 0: a itself.
        for (x, y) in s.at(0).iter().zip(&a) {
            for c in 0..3 {
                assert!((x[c] - y[c]).abs() < 1e-12);
            }
        }
    }
}
