//! Dual paraboloid parameterization (Heidrich & Seidel 1998, "View-independent
//! Environment Maps", Eurographics/SIGGRAPH Workshop on Graphics Hardware), the `dx9`
//! L×H table layout of Iwanicki–Sloan §3.2 (DESIGN §2).
//!
//! Hemisphere split on the world +Y axis (DESIGN §1: +Y up; L×H tables are indexed by
//! normals, so 0 = upper hemisphere y ≥ 0, 1 = lower y < 0). The paraboloid
//! f(r) = ½ − ½r² reflects the hemisphere's directions onto the unit disk:
//!
//! ```text
//! project:    p = (x, z) / (1 + |y|)                          (|p| ≤ 1, equator ↔ rim)
//! unproject:  d = (2p.x, ±(1 − |p|²), 2p.y) / (1 + |p|²)      (+ for hemisphere 0)
//! ```
//!
//! Both hemispheres use the same tangential axes (disk x = world x, disk y = world z), so
//! an equator direction has the *same* disk point, hence the same texcoord, in both
//! images — the property that makes the shrunk map of [`super`] continuous across the
//! equator (test `equator_same_texcoord_both_hemispheres` in `super`). The disk is then
//! stretched to the square by [`super::concentric`] and shrunk onto the texel centres by
//! [`super::dual_disk_to_texcoord`].

use glam::{DVec2, DVec3};

/// Disk point of `dir` seen from `hemisphere` (0: +Y, 1: −Y).
///
/// Meaningful for directions in that closed hemisphere; the formula uses |y|, so a
/// direction on the equator gives bit-identical points from both hemispheres.
pub fn project(hemisphere: u32, dir: DVec3) -> DVec2 {
    debug_assert!(hemisphere < 2, "hemisphere {hemisphere}");
    DVec2::new(dir.x, dir.z) / (1.0 + dir.y.abs())
}

/// Unit direction of disk point `p` in `hemisphere` (0: +Y, 1: −Y); inverse of
/// [`project`]. Points outside the unit disk are pulled back onto the rim (the equator).
pub fn unproject(hemisphere: u32, p: DVec2) -> DVec3 {
    debug_assert!(hemisphere < 2, "hemisphere {hemisphere}");
    let r2 = p.length_squared();
    if r2 >= 1.0 {
        // On or past the rim: the equator, exactly (y = 0, no ±ε from 1 − r²).
        let q = p / r2.sqrt();
        return DVec3::new(q.x, 0.0, q.y);
    }
    let sign = if hemisphere == 0 { 1.0 } else { -1.0 };
    DVec3::new(2.0 * p.x, sign * (1.0 - r2), 2.0 * p.y) / (1.0 + r2)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One division and a few products in f64.
    const ROUND_TRIP: f64 = 1e-14;

    #[test]
    fn poles_centre_equator_rim() {
        assert_eq!(project(0, DVec3::Y), DVec2::ZERO);
        assert_eq!(project(1, -DVec3::Y), DVec2::ZERO);
        assert_eq!(unproject(0, DVec2::ZERO), DVec3::Y);
        assert_eq!(unproject(1, DVec2::ZERO), -DVec3::Y);
        let e = DVec3::new(0.6, 0.0, -0.8);
        assert_eq!(project(0, e), project(1, e));
        assert!((project(0, e).length() - 1.0).abs() < ROUND_TRIP);
        assert_eq!(unproject(1, DVec2::new(0.6, -0.8)), e);
    }

    #[test]
    fn round_trip_both_hemispheres() {
        for k in 0..2000 {
            let z = 1.0 - 2.0 * (k as f64 + 0.5) / 2000.0;
            let phi = k as f64 * 2.399963229728653; // golden angle
            let s = (1.0 - z * z).sqrt();
            let d = DVec3::new(s * phi.cos(), z, s * phi.sin());
            let h = u32::from(d.y < 0.0);
            let back = unproject(h, project(h, d));
            assert!((back - d).length() < ROUND_TRIP, "{d} -> {back}");
        }
    }
}
