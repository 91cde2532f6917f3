//! Dual orthographic parameterization: each hemisphere is projected orthographically
//! along ±Y onto the unit disk (the first of the four candidates of Iwanicki–Sloan
//! App. A). Same split, axes and square mapping as [`super::dual_paraboloid`]:
//!
//! ```text
//! project:    p = (x, z)                                   (|p| ≤ 1, equator ↔ rim)
//! unproject:  d = (p.x, ±√(1 − |p|²), p.y)                 (+ for hemisphere 0)
//! ```
//!
//! The projection compresses the sphere near the equator (dθ = dr / cos θ), which is
//! why it needs more samples than the paraboloid for the same error (Figure 8). It is
//! also ill-conditioned there: a direction 1e-3 from the equator loses ~3 digits in
//! y through the round trip (√ of a difference of nearly equal numbers), so the round-trip
//! test of [`super`] measures it away from a thin equatorial band and checks the band
//! in texcoord space instead.

use glam::{DVec2, DVec3};

/// Disk point of `dir` seen from `hemisphere` (0: +Y, 1: −Y): its tangential components.
///
/// Independent of the hemisphere (both use world x and z), so the equator is shared
/// exactly. Input that is slightly longer than unit is pulled back onto the disk.
pub fn project(hemisphere: u32, dir: DVec3) -> DVec2 {
    debug_assert!(hemisphere < 2, "hemisphere {hemisphere}");
    let p = DVec2::new(dir.x, dir.z);
    let r2 = p.length_squared();
    if r2 > 1.0 { p / r2.sqrt() } else { p }
}

/// Unit direction of disk point `p` in `hemisphere` (0: +Y, 1: −Y); inverse of
/// [`project`]. Points on or outside the rim give the equator direction exactly (y = 0).
pub fn unproject(hemisphere: u32, p: DVec2) -> DVec3 {
    debug_assert!(hemisphere < 2, "hemisphere {hemisphere}");
    let r2 = p.length_squared();
    if r2 >= 1.0 {
        let q = p / r2.sqrt();
        return DVec3::new(q.x, 0.0, q.y);
    }
    let sign = if hemisphere == 0 { 1.0 } else { -1.0 };
    // 1 − r² as (1 − r)(1 + r) keeps the small difference accurate near the rim.
    let r = r2.sqrt();
    DVec3::new(p.x, sign * ((1.0 - r) * (1.0 + r)).sqrt(), p.y)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square root and a few products in f64; at |y| ≥ 0.01 the √ amplifies the
    /// rounding of r² by ≤ 1/(2|y|) = 50, so ~1e-14 is expected.
    const ROUND_TRIP: f64 = 1e-13;

    #[test]
    fn poles_and_equator() {
        assert_eq!(unproject(0, DVec2::ZERO), DVec3::Y);
        assert_eq!(unproject(1, DVec2::ZERO), -DVec3::Y);
        let e = DVec3::new(0.6, 0.0, -0.8);
        assert_eq!(project(0, e), project(1, e));
        assert_eq!(unproject(0, DVec2::new(0.6, -0.8)), e);
    }

    #[test]
    fn round_trip_away_from_equator() {
        for k in 0..2000 {
            let z = 1.0 - 2.0 * (k as f64 + 0.5) / 2000.0;
            if z.abs() < 0.01 {
                continue; // the ill-conditioned band of the module doc
            }
            let phi = k as f64 * 2.399963229728653;
            let s = (1.0 - z * z).sqrt();
            let d = DVec3::new(s * phi.cos(), z, s * phi.sin());
            let h = u32::from(d.y < 0.0);
            let back = unproject(h, project(h, d));
            assert!((back - d).length() < ROUND_TRIP, "{d} -> {back}");
        }
    }
}
