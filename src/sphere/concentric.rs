//! Shirley–Chiu concentric map between square and disk (Shirley & Chiu 1997, "A Low
//! Distortion Map Between Disk and Square", JGT 2(3)), used by the dual-hemisphere
//! parameterizations ([`super::dual_paraboloid`], [`super::dual_ortho`]) so that the whole
//! square texture is used (Iwanicki–Sloan §3.2 and App. A, DESIGN §2 `dx9`).
//!
//! Square [−1, 1]² ↔ unit disk, centre ↔ centre, square edge ↔ rim. With (a, b) in the
//! square, the four triangular sectors split by the diagonals map to four wedges:
//!
//! ```text
//! |a| > |b|:  r = a,  φ = (π/4)·(b/a)          (right and left sectors)
//! otherwise:  r = b,  φ = π/2 − (π/4)·(a/b)    (top and bottom sectors)
//! disk point = (r cos φ, r sin φ)              (signed r covers both sectors of a pair)
//! ```
//!
//! The inverse reads the sector from |x| ≥ |y|: a = ±‖q‖, b = a·atan(y/x)/(π/4), and
//! symmetrically in the other pair. Both maps are exact inverses (up to rounding),
//! continuous across the diagonals (on a diagonal both formulas give φ = ±π/4, ±3π/4),
//! preserve fractional area, and send the centre to the centre without a division by
//! zero. Tests: `round_trip_hits_centre_and_diagonals`, `edges_go_to_rim`.

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};

use glam::DVec2;

/// Square [−1, 1]² → unit disk (Shirley & Chiu 1997); preserves fractional area.
///
/// The square's edge maps onto the unit circle, its centre to the disk centre.
pub fn square_to_disk(p: DVec2) -> DVec2 {
    let (a, b) = (p.x, p.y);
    if a == 0.0 && b == 0.0 {
        return DVec2::ZERO;
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, FRAC_PI_4 * (b / a))
    } else {
        // |b| ≥ |a| and not both zero, so b ≠ 0.
        (b, FRAC_PI_2 - FRAC_PI_4 * (a / b))
    };
    let (sin, cos) = phi.sin_cos();
    DVec2::new(r * cos, r * sin)
}

/// Unit disk → square [−1, 1]²; inverse of [`square_to_disk`].
///
/// Points outside the unit disk extend the map radially (they land outside the square).
pub fn disk_to_square(q: DVec2) -> DVec2 {
    let (x, y) = (q.x, q.y);
    let r = x.hypot(y);
    if r == 0.0 {
        return DVec2::ZERO;
    }
    if x.abs() >= y.abs() {
        // Right/left sector: φ = atan(y/x) ∈ [−π/4, π/4], r = a carries the sign of x.
        let a = r.copysign(x);
        DVec2::new(a, a * (y / x).atan() / FRAC_PI_4)
    } else {
        // Top/bottom sector: π/2 − φ = atan(x/y), r = b carries the sign of y.
        let b = r.copysign(y);
        DVec2::new(b * (x / y).atan() / FRAC_PI_4, b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two f64 trigonometric round trips; anything looser would hide a wrong branch.
    const ROUND_TRIP: f64 = 1e-13;

    /// `n`×`n` grid over the square including both edges; odd `n` contains 0 and both
    /// diagonals exactly.
    fn grid_square(n: usize) -> impl Iterator<Item = DVec2> {
        let step = 2.0 / (n - 1) as f64;
        (0..n * n)
            .map(move |k| DVec2::new(-1.0 + (k % n) as f64 * step, -1.0 + (k / n) as f64 * step))
    }

    #[test]
    fn round_trip_hits_centre_and_diagonals() {
        for p in grid_square(65) {
            let q = square_to_disk(p);
            let back = disk_to_square(q);
            assert!((back - p).length() < ROUND_TRIP, "{p} -> {q} -> {back}");
        }
        assert_eq!(square_to_disk(DVec2::ZERO), DVec2::ZERO);
        assert_eq!(disk_to_square(DVec2::ZERO), DVec2::ZERO);
        assert_eq!(square_to_disk(DVec2::new(-0.0, 0.0)), DVec2::ZERO);
        // Diagonals go to the 45° rays.
        for t in [1e-300, 1e-9, 0.25, 0.5, 1.0] {
            for (sx, sy) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
                let q = square_to_disk(DVec2::new(sx * t, sy * t));
                let expect = DVec2::new(sx, sy) * (t * std::f64::consts::FRAC_1_SQRT_2);
                assert!(
                    (q - expect).length() < ROUND_TRIP * t,
                    "{t}: {q} vs {expect}"
                );
            }
        }
    }

    #[test]
    fn continuous_across_diagonals() {
        // Just either side of the diagonal a = b the two formulas must agree.
        for t in [0.1, 0.5, 0.9, 1.0] {
            let eps = 1e-12;
            let above = square_to_disk(DVec2::new(t - eps, t));
            let below = square_to_disk(DVec2::new(t, t - eps));
            assert!((above - below).length() < 10.0 * eps, "{above} vs {below}");
        }
    }

    #[test]
    fn edges_go_to_rim() {
        for p in grid_square(33) {
            if p.x.abs() == 1.0 || p.y.abs() == 1.0 {
                let q = square_to_disk(p);
                assert!((q.length() - 1.0).abs() < ROUND_TRIP, "{p} -> {q}");
            }
        }
    }

    #[test]
    fn disk_round_trip_from_disk_side() {
        for k in 0..1000 {
            let phi = k as f64 * 0.785; // not a multiple of π/4: visits every sector
            let r = (k as f64 / 999.0).sqrt();
            let q = DVec2::new(r * phi.cos(), r * phi.sin());
            let back = square_to_disk(disk_to_square(q));
            assert!((back - q).length() < ROUND_TRIP, "{q} -> {back}");
        }
    }
}
