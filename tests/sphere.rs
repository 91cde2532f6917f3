//! Sphere parameterizations (src/sphere): DESIGN §6's hard cases — Shirley–Chiu at the
//! disk centre and diagonals, the dual-paraboloid (and dual-ortho) equator, cube face
//! edges and corners — plus round trips and exact reconstruction of constant, linear and
//! uv-affine signals for all four kinds.

use glam::{DVec2, DVec3};
use shvis::sh::{Order, basis::eval_basis};
use shvis::sphere::{
    Parameterization, SphereMap, TexelGrid, concentric, dual_disk_to_texcoord, hemisphere_of,
};

/// Direction → uv → direction in f64 (projection, concentric map, their inverses).
const ROUND_TRIP: f64 = 1e-12;
/// Four weights times O(1) values summed in f64.
const EXACT: f64 = 1e-13;
/// Step across a seam (equator, cube edge, cube corner).
const DELTA: f64 = 1e-9;
/// Allowed change of a reconstruction over a step of [`DELTA`]: a continuous bilinear
/// reconstruction of an O(1) signal at res ≤ 64 varies by ≲ 100·δ; a seam would show
/// a jump of the order of the signal's change over one texel (≥ 1e-3 here).
const CONTINUITY: f64 = 1e-6;
/// The smallest jump we require the per-face (`dx9`) cube to show somewhere at res 4
/// for an order-3 SH function (its change over half a texel is ~0.1).
const DX9_JUMP: f64 = 1e-2;
/// Dual-ortho's projection is ill-conditioned at the equator (y = ±√(1−r²)): rounding of
/// r is amplified by ~1/|y|, so the direction round trip is checked for |y| ≥ this and
/// the band is checked in texcoord space.
const ORTHO_BAND: f64 = 1e-3;

fn all_maps(resolutions: &[u32]) -> Vec<SphereMap> {
    Parameterization::ALL
        .into_iter()
        .flat_map(|k| {
            resolutions
                .iter()
                .map(move |&r| SphereMap::new(k, r).expect("valid test resolution"))
        })
        .collect()
}

/// SplitMix64 stream → uniform unit directions (fixed seed, reproducible).
fn random_dirs(n: usize, seed: u64) -> Vec<DVec3> {
    let mut state = seed;
    let mut next = || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut x = state;
        x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((x ^ (x >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| {
            let z = 1.0 - 2.0 * next();
            let phi = std::f64::consts::TAU * next();
            let s = (1.0 - z * z).max(0.0).sqrt();
            DVec3::new(s * phi.cos(), s * phi.sin(), z)
        })
        .collect()
}

/// A smooth non-constant test signal: a mix of order-3 SH basis functions.
fn sh_signal(d: DVec3) -> f64 {
    let mut y = [0.0; 9];
    eval_basis(Order::THREE, d.normalize(), &mut y);
    y.iter()
        .enumerate()
        .map(|(i, v)| v * (1.0 + i as f64 * 0.37))
        .sum()
}

fn recon(map: &SphereMap, grid: &TexelGrid, d: DVec3) -> f64 {
    map.reconstruct_bilinear(grid, d.normalize())
}

#[test]
fn round_trip_dir_texcoord_dir_all_kinds() {
    let dirs = random_dirs(20_000, 7);
    for map in all_maps(&[2, 7, 16, 64]) {
        let mut worst = 0.0f64;
        for &d in &dirs {
            if map.kind() == Parameterization::DualOrtho && d.y.abs() < ORTHO_BAND {
                continue;
            }
            let (face, uv) = map.dir_to_texcoord(d);
            assert!(
                uv.cmpge(DVec2::ZERO).all() && uv.cmple(DVec2::ONE).all(),
                "{uv}"
            );
            let back = map.texcoord_to_dir(face, uv);
            worst = worst.max((back - d).length());
        }
        assert!(
            worst < ROUND_TRIP,
            "{} res {}: {worst:e}",
            map.kind(),
            map.res()
        );
    }
}

#[test]
fn dual_ortho_equator_band_round_trips_in_texcoord_space() {
    for map in all_maps(&[2, 16, 64]) {
        if map.kind() != Parameterization::DualOrtho {
            continue;
        }
        for k in 0..1000 {
            let phi = k as f64 * 0.0062831853;
            let y = ORTHO_BAND * ((k % 21) as f64 / 10.0 - 1.0);
            let s = (1.0 - y * y).sqrt();
            let d = DVec3::new(s * phi.cos(), y, s * phi.sin());
            let (face, uv) = map.dir_to_texcoord(d);
            let (face2, uv2) = map.dir_to_texcoord(map.texcoord_to_dir(face, uv));
            assert!(face2 == face || y == 0.0);
            assert!((uv2 - uv).length() < ROUND_TRIP, "{d}: {uv} -> {uv2}");
        }
    }
}

#[test]
fn shirley_chiu_at_disk_centre_and_diagonals() {
    assert_eq!(concentric::square_to_disk(DVec2::ZERO), DVec2::ZERO);
    assert_eq!(concentric::disk_to_square(DVec2::ZERO), DVec2::ZERO);
    // Diagonals ↔ 45° rays, |q| = |a|: the branch switch is invisible.
    for t in [1e-12, 0.3, 0.999, 1.0] {
        for (sx, sy) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
            let p = DVec2::new(sx * t, sy * t);
            let q = concentric::square_to_disk(p);
            assert!((q.length() - t).abs() < EXACT * t, "{p} -> {q}");
            assert!((q.x.abs() - q.y.abs()).abs() < EXACT * t, "{p} -> {q}");
            let back = concentric::disk_to_square(q);
            assert!((back - p).length() < EXACT * t, "{p} -> {q} -> {back}");
            // Either side of the diagonal: continuous.
            let side_a = concentric::square_to_disk(p + DVec2::new(sx * 1e-10, 0.0));
            let side_b = concentric::square_to_disk(p + DVec2::new(0.0, sy * 1e-10));
            assert!((side_a - side_b).length() < 1e-9, "{side_a} vs {side_b}");
        }
    }
    // The centre of every dual map is the pole, in both hemispheres.
    for map in all_maps(&[2, 3, 16]) {
        if !map.kind().is_cube() {
            assert_eq!(map.texcoord_to_dir(0, DVec2::splat(0.5)), DVec3::Y);
            assert_eq!(map.texcoord_to_dir(1, DVec2::splat(0.5)), -DVec3::Y);
        }
    }
}

#[test]
fn dual_equator_same_texcoord_both_hemispheres() {
    for map in all_maps(&[2, 5, 16, 33]) {
        if map.kind().is_cube() {
            continue;
        }
        let res = f64::from(map.res());
        let (lo, hi) = (0.5 / res, 1.0 - 0.5 / res);
        for k in 0..720 {
            let phi = k as f64 * std::f64::consts::TAU / 720.0;
            let d = DVec3::new(phi.cos(), 0.0, phi.sin());
            let (up, down) = (map.dual_texcoord_in(0, d), map.dual_texcoord_in(1, d));
            assert_eq!(up, down, "{} {d}", map.kind());
            assert_eq!(map.dir_to_texcoord(d), (0, up));
            // On the outer ring of texel centres: one coordinate is the first/last centre.
            let ring = [up.x, up.y]
                .iter()
                .any(|&c| (c - lo).abs() < EXACT || (c - hi).abs() < EXACT);
            let inside = up.cmpge(DVec2::splat(lo - EXACT)).all()
                && up.cmple(DVec2::splat(hi + EXACT)).all();
            assert!(ring && inside, "{} res {res}: {d} -> {up}", map.kind());
        }
        // Outer-ring texels: identical equator directions in both hemispheres.
        let r = map.res();
        for k in 0..r {
            for (i, j) in [(k, 0), (k, r - 1), (0, k), (r - 1, k)] {
                let (a, b) = (map.texel_center_dir(0, i, j), map.texel_center_dir(1, i, j));
                assert_eq!(a, b);
                assert_eq!(a.y, 0.0);
            }
        }
        // The rim of the disk is the ring too.
        assert_eq!(
            dual_disk_to_texcoord(DVec2::new(1.0, 0.0), r),
            DVec2::new(hi, 0.5)
        );
    }
}

#[test]
fn dual_reconstruction_continuous_across_equator() {
    for map in all_maps(&[2, 5, 16, 64]) {
        if map.kind().is_cube() {
            continue;
        }
        let grid = TexelGrid::from_fn(map, sh_signal);
        for k in 0..500 {
            let phi = k as f64 * 0.012566;
            let e = DVec3::new(phi.cos(), 0.0, phi.sin());
            let above = e + DVec3::Y * DELTA;
            let below = e - DVec3::Y * DELTA;
            assert_eq!(hemisphere_of(above.normalize()), 0);
            assert_eq!(hemisphere_of(below.normalize()), 1);
            let (a, b, c) = (
                recon(&map, &grid, above),
                recon(&map, &grid, below),
                recon(&map, &grid, e),
            );
            assert!(
                (a - b).abs() < CONTINUITY && (a - c).abs() < CONTINUITY,
                "{} res {}: {e}: {a} {c} {b}",
                map.kind(),
                map.res()
            );
        }
    }
}

/// Points on each of the 12 cube edges (parameter t along the edge) and the two
/// across-edge offsets: `(edge point, offset toward one face, offset toward the other)`.
fn edge_probes() -> Vec<(DVec3, DVec3, DVec3)> {
    let axes = [DVec3::X, DVec3::Y, DVec3::Z];
    let mut out = Vec::new();
    for a in 0..3 {
        for b in (a + 1)..3 {
            let c = 3 - a - b;
            for (sa, sb) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
                for k in 0..41 {
                    let t = -0.975 + k as f64 * 0.04875;
                    let p = axes[a] * sa + axes[b] * sb + axes[c] * t;
                    // Moving +a·sa makes a the major axis; +b·sb makes b.
                    out.push((p, axes[a] * sa * DELTA, axes[b] * sb * DELTA));
                }
            }
        }
    }
    assert_eq!(out.len(), 12 * 41);
    out
}

#[test]
fn seamless_is_continuous_across_every_edge() {
    for res in [2, 3, 4, 16, 64] {
        let map = SphereMap::new(Parameterization::CubeDx10, res).expect("valid res");
        let grid = TexelGrid::from_fn(map, sh_signal);
        for (p, to_a, to_b) in edge_probes() {
            let (fa, fb) = (
                map.dir_to_texcoord((p + to_a).normalize()).0,
                map.dir_to_texcoord((p + to_b).normalize()).0,
            );
            assert_ne!(fa, fb, "probes must straddle the edge at {p}");
            let (a, b) = (recon(&map, &grid, p + to_a), recon(&map, &grid, p + to_b));
            let on = recon(&map, &grid, p);
            assert!(
                (a - b).abs() < CONTINUITY && (a - on).abs() < CONTINUITY,
                "res {res} edge at {p}: {a} {on} {b}"
            );
        }
    }
}

#[test]
fn seamless_is_continuous_at_all_8_corners() {
    for res in [2, 3, 4, 16, 64] {
        let map = SphereMap::new(Parameterization::CubeDx10, res).expect("valid res");
        let grid = TexelGrid::from_fn(map, sh_signal);
        for corner in 0..8 {
            let s = DVec3::new(
                if corner & 1 == 0 { 1.0 } else { -1.0 },
                if corner & 2 == 0 { 1.0 } else { -1.0 },
                if corner & 4 == 0 { 1.0 } else { -1.0 },
            );
            let at = recon(&map, &grid, s);
            // Step into each of the three faces, and along each of the three edges.
            let steps = [
                DVec3::X * s.x,
                DVec3::Y * s.y,
                DVec3::Z * s.z,
                -DVec3::X * s.x,
                -DVec3::Y * s.y,
                -DVec3::Z * s.z,
                DVec3::new(2.0 * s.x, s.y, 0.0),
                DVec3::new(0.0, -s.y, 3.0 * s.z),
            ];
            let mut faces = std::collections::BTreeSet::new();
            for step in steps {
                let d = s + step * DELTA;
                faces.insert(map.dir_to_texcoord(d.normalize()).0);
                let v = recon(&map, &grid, d);
                assert!(
                    (v - at).abs() < CONTINUITY,
                    "res {res} corner {s}: {v} vs {at}"
                );
            }
            assert_eq!(faces.len(), 3, "probes must touch the 3 faces at {s}");
        }
    }
}

#[test]
fn dx9_cube_jumps_across_edges() {
    let map = SphereMap::new(Parameterization::CubeDx9, 4).expect("valid res");
    let grid = TexelGrid::from_fn(map, sh_signal);
    let jump = edge_probes()
        .into_iter()
        .map(|(p, to_a, to_b)| (recon(&map, &grid, p + to_a) - recon(&map, &grid, p + to_b)).abs())
        .fold(0.0, f64::max);
    assert!(jump > DX9_JUMP, "largest jump across a dx9 edge {jump}");
    // …while a constant has no seam even per face.
    let one = TexelGrid::from_fn(map, |_| 1.0);
    for (p, to_a, to_b) in edge_probes() {
        assert!((recon(&map, &one, p + to_a) - recon(&map, &one, p + to_b)).abs() < EXACT);
    }
}

#[test]
fn constant_reconstructed_exactly_everywhere() {
    let mut probes = random_dirs(5000, 11);
    probes.extend(
        edge_probes()
            .into_iter()
            .flat_map(|(p, a, b)| [p, p + a, p + b]),
    );
    for c in 0..8 {
        let s = |bit: u32| if c & bit == 0 { 1.0 } else { -1.0 };
        probes.push(DVec3::new(s(1), s(2), s(4)));
    }
    for k in 0..64 {
        let phi = k as f64 * 0.098;
        probes.push(DVec3::new(phi.cos(), 0.0, phi.sin()));
    }
    for map in all_maps(&[2, 3, 8, 31]) {
        let grid = TexelGrid::from_fn(map, |_| 1.5);
        for &d in &probes {
            let v = recon(&map, &grid, d);
            assert!(
                (v - 1.5).abs() < EXACT,
                "{} res {} at {d}: {v}",
                map.kind(),
                map.res()
            );
        }
    }
}

#[test]
fn linear_function_exact_at_texel_centres() {
    let f = |d: DVec3| 0.25 + d.dot(DVec3::new(0.7, -1.3, 2.1));
    for map in all_maps(&[2, 3, 8, 31]) {
        let grid = TexelGrid::from_fn(map, f);
        for face in 0..map.kind().face_count() {
            for k in 0..map.res() * map.res() {
                let d = map.texel_center_dir(face, k % map.res(), k / map.res());
                let v = map.reconstruct_bilinear(&grid, d);
                assert!(
                    (v - f(d)).abs() < EXACT,
                    "{} at {d}: {v} vs {}",
                    map.kind(),
                    f(d)
                );
            }
        }
    }
}

#[test]
fn affine_in_uv_reproduced_inside_each_image() {
    // Bilinear filtering reproduces any function affine in (u, v) wherever all four taps
    // lie in the image: everywhere for the shrunk dual maps, inside the ring of texel
    // centres for cube faces. This checks the weights and the texel-centre convention.
    let g = |face: u32, uv: DVec2| 0.1 * f64::from(face) + 0.9 * uv.x - 1.7 * uv.y;
    for map in all_maps(&[2, 3, 8, 31]) {
        let r = map.res();
        let values = (0..map.sample_count() as u32)
            .map(|t| {
                let (face, k) = (t / (r * r), t % (r * r));
                let uv = DVec2::new(f64::from(k % r) + 0.5, f64::from(k / r) + 0.5) / f64::from(r);
                g(face, uv)
            })
            .collect();
        let grid = TexelGrid::new(map, values).expect("sized to the map");
        let (lo, hi) = (0.5 / f64::from(r), 1.0 - 0.5 / f64::from(r));
        for d in random_dirs(5000, 3) {
            let (face, uv) = map.dir_to_texcoord(d);
            if map.kind().is_cube()
                && !(uv.cmpge(DVec2::splat(lo)).all() && uv.cmple(DVec2::splat(hi)).all())
            {
                continue;
            }
            let v = map.reconstruct_bilinear(&grid, d);
            assert!(
                (v - g(face, uv)).abs() < EXACT,
                "{} res {r} at {d}: {v} vs {}",
                map.kind(),
                g(face, uv)
            );
        }
    }
}

#[test]
fn seamless_error_shrinks_with_resolution_and_beats_dx9() {
    // Smoke test of what the App. A study measures: mean squared reconstruction error
    // of an SH signal falls with resolution, and seamless filtering beats per-face.
    let dirs = random_dirs(20_000, 5);
    let mse = |kind, res| {
        let map = SphereMap::new(kind, res).expect("valid res");
        let grid = TexelGrid::from_fn(map, sh_signal);
        dirs.iter()
            .map(|&d| (recon(&map, &grid, d) - sh_signal(d)).powi(2))
            .sum::<f64>()
            / dirs.len() as f64
    };
    let (dx10_4, dx10_16) = (
        mse(Parameterization::CubeDx10, 4),
        mse(Parameterization::CubeDx10, 16),
    );
    let dx9_4 = mse(Parameterization::CubeDx9, 4);
    assert!(dx10_16 < dx10_4 / 50.0, "{dx10_4:e} -> {dx10_16:e}");
    assert!(dx10_4 < dx9_4, "dx10 {dx10_4:e} vs dx9 {dx9_4:e}");
}
