//! SH visibility bake against cases with known answers (DESIGN §6): an open
//! plane (the exact projection of the hemisphere indicator), the inner corner of a floor
//! and a wall (the quarter sphere), the floor of a closed box (exactly 0), a one-sided
//! ground lit only from below (dark to the SH truncation bound), a thin wall and a thick
//! wall standing on a floor (no leaks at the contact, no acne), thread-count
//! independence, seed-to-seed agreement, the coherent tracer against a single-ray
//! reference bit for bit, and the bake cache (round trip, damaged files rebuilt, keys).
//!
//! The exact projections integrate y_i over a lune {φ₀ ≤ φ ≤ φ₁} about +z with
//! Gauss–Legendre rules in θ and φ (the integrand is analytic there: spectral accuracy).

use std::cell::Cell;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use glam::{DVec3, Vec3};
use shvis::bake::cache::{
    HEADER_BYTES, load_or_bake_visibility, visibility_cache_path, visibility_key, write_exr_layers,
};
use shvis::bake::directions::{DirectionSet, ShProjector, above_horizon};
use shvis::bake::raster::{LightmapTexels, rasterize};
use shvis::bake::trace::Tracer;
use shvis::bake::visibility::{VisibilityMap, VisibilitySettings, bake_visibility};
use shvis::scene::{Mesh, house};

mod common;
use common::{FULL_UV, NO_UV, quad};
use shvis::sh::basis::eval_basis;
use shvis::sh::{Order, gauss_legendre};

/// Directions of the analytic tests.
const RAYS: u32 = 1024;

/// Bound on |rule − exact| for the projection onto y_l^m (l < 6) of an indicator whose
/// boundary is a great circle (or two half circles), for the shared set of R directions.
/// Each direction owns a cell of area w = 4π/R; only the ~√(πR) cells the boundary
/// crosses (length 2π over cells of side √w) are misjudged, each by at most
/// w·max|y_l^m| with max|y_l^m| ≤ √((2l+1)/4π), with signs that do not line up, so the
/// error is ~ w·max|y|·(πR)^¼ = 0.087 at R = 1024. Measured errors are 3–10× smaller.
fn quadrature_bound(rays: u32) -> f64 {
    let r = f64::from(rays);
    let w = 4.0 * PI / r;
    let max_y = (11.0 / (4.0 * PI)).sqrt();
    w * max_y * (PI * r).powf(0.25)
}

/// The bake rounds an f64 sum of ≤ R terms (each ≤ 0.012) to f32 once: half an ulp of
/// values ≤ 4 plus the table's different summation order, far below 1e-6.
const F32_ROUND: f64 = 1e-6;

// ---------------------------------------------------------------- scene helpers

/// Horizontal rectangle y = 0 over [x0, x1] × [z0, z1], facing +Y.
fn floor_rect(m: &mut Mesh, x0: f32, x1: f32, z0: f32, z1: f32, uv: [[f32; 2]; 4]) {
    let c = |x: f32, z: f32| Vec3::new(x, 0.0, z);
    quad(m, [c(x0, z1), c(x1, z1), c(x1, z0), c(x0, z0)], uv);
}

/// Axis-aligned box [lo, hi], faces outward, not baked.
fn closed_box(m: &mut Mesh, lo: Vec3, hi: Vec3, with_bottom: bool) {
    let p = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let (a, b) = (lo, hi);
    quad(
        m,
        [
            p(a.x, b.y, a.z),
            p(a.x, b.y, b.z),
            p(b.x, b.y, b.z),
            p(b.x, b.y, a.z),
        ],
        NO_UV,
    ); // top
    quad(
        m,
        [
            p(a.x, a.y, a.z),
            p(a.x, a.y, b.z),
            p(a.x, b.y, b.z),
            p(a.x, b.y, a.z),
        ],
        NO_UV,
    ); // −x
    quad(
        m,
        [
            p(b.x, a.y, b.z),
            p(b.x, a.y, a.z),
            p(b.x, b.y, a.z),
            p(b.x, b.y, b.z),
        ],
        NO_UV,
    ); // +x
    quad(
        m,
        [
            p(b.x, a.y, a.z),
            p(a.x, a.y, a.z),
            p(a.x, b.y, a.z),
            p(b.x, b.y, a.z),
        ],
        NO_UV,
    ); // −z
    quad(
        m,
        [
            p(a.x, a.y, b.z),
            p(b.x, a.y, b.z),
            p(b.x, b.y, b.z),
            p(a.x, b.y, b.z),
        ],
        NO_UV,
    ); // +z
    if with_bottom {
        quad(
            m,
            [
                p(a.x, a.y, b.z),
                p(a.x, a.y, a.z),
                p(b.x, a.y, a.z),
                p(b.x, a.y, b.z),
            ],
            NO_UV,
        );
    }
}

/// Floor and a wall x = 0 (facing +X) meeting along the z axis; only a 1 cm patch at
/// x ∈ [1, 11] mm next to the corner carries the lightmap. 200 m of wall and floor: the
/// horizon they leave open is ~1e-4 rad, far below the quadrature bound.
fn inner_corner() -> Mesh {
    let h = 100.0;
    let mut m = Mesh::default();
    floor_rect(&mut m, -h, h, -h, h, NO_UV);
    floor_rect(&mut m, 0.001, 0.011, -0.005, 0.005, FULL_UV);
    let w = |y: f32, z: f32| Vec3::new(0.0, y, z);
    quad(
        &mut m,
        [w(0.0, h), w(0.0, -h), w(2.0 * h, -h), w(2.0 * h, h)],
        NO_UV,
    );
    m
}

fn settings(rays: u32, seed: u64) -> VisibilitySettings {
    VisibilitySettings {
        order: Order::SIX,
        rays,
        seed,
        progress: false,
    }
}

fn bake(mesh: &Mesh, res: u32, s: &VisibilitySettings) -> (LightmapTexels, VisibilityMap) {
    let texels = rasterize(mesh, res);
    let map = bake_visibility(&Tracer::new(mesh), &texels, s);
    (texels, map)
}

// ---------------------------------------------------------------- exact projections

/// ∫ f(ω) y_i(ω) dω over the lune φ ∈ [φ₀, φ₁] (about +z, φ from +x toward +y), i <
/// order², by 96 × 96 Gauss–Legendre nodes in (θ, φ).
fn lune_projection(order: Order, phi0: f64, phi1: f64, f: impl Fn(DVec3) -> f64) -> Vec<f64> {
    let (x, w) = gauss_legendre(96);
    let n2 = order.coeff_count();
    let mut out = vec![0.0; n2];
    let mut y = vec![0.0; n2];
    for (xt, wt) in x.iter().zip(&w) {
        let theta = 0.5 * PI * (xt + 1.0);
        for (xp, wp) in x.iter().zip(&w) {
            let phi = phi0 + 0.5 * (phi1 - phi0) * (xp + 1.0);
            let d = DVec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            let weight = wt * 0.5 * PI * wp * 0.5 * (phi1 - phi0) * theta.sin() * f(d);
            eval_basis(order, d, &mut y);
            for (o, v) in out.iter_mut().zip(&y) {
                *o += weight * v;
            }
        }
    }
    out
}

/// The shared rule of eq. (1) applied to the indicator `visible`, in f64.
fn rule_projection(dirs: &DirectionSet, order: Order, visible: impl Fn(Vec3) -> bool) -> Vec<f64> {
    let n2 = order.coeff_count();
    let (mut out, mut y) = (vec![0.0; n2], vec![0.0; n2]);
    for &d in dirs.dirs() {
        if visible(d) {
            eval_basis(order, d.as_dvec3().normalize(), &mut y);
            for (o, v) in out.iter_mut().zip(&y) {
                *o += dirs.weight() * v;
            }
        }
    }
    out
}

/// Checks every covered texel of `map` against the rule's projection of `visible` (to
/// f32 rounding) and the exact projection (to the quadrature bound); returns the largest
/// |rule − exact|.
fn check_against_exact(
    map: &VisibilityMap,
    seed: u64,
    visible: impl Fn(Vec3) -> bool,
    exact: &[f64],
) -> f64 {
    let dirs = DirectionSet::new(RAYS, seed);
    let rule = rule_projection(&dirs, map.order, visible);
    let mut worst = 0.0f64;
    for (i, e) in exact.iter().enumerate() {
        worst = worst.max((rule[i] - e).abs());
    }
    assert!(
        worst < quadrature_bound(RAYS),
        "rule error {worst} ≥ bound {}",
        quadrature_bound(RAYS)
    );
    let mut checked = 0;
    for t in (0..map.covered.len()).filter(|&t| map.covered[t]) {
        for (i, &c) in map.texel(t).iter().enumerate() {
            assert!(
                (f64::from(c) - rule[i]).abs() < F32_ROUND,
                "texel {t} coefficient {i}: bake {c} vs rule {}",
                rule[i]
            );
        }
        checked += 1;
    }
    assert!(checked > 0, "no covered texel");
    worst
}

// ---------------------------------------------------------------- analytic cases

#[test]
fn open_plane_projects_the_upper_hemisphere() {
    let mut m = Mesh::default();
    floor_rect(&mut m, -10.0, 10.0, -10.0, 10.0, FULL_UV);
    let s = settings(RAYS, 5);
    let (texels, map) = bake(&m, 16, &s);
    assert_eq!(texels.covered_count(), 256);
    // Upper hemisphere y ≥ 0 = lune φ ∈ [0, π] about +z.
    let exact = lune_projection(s.order, 0.0, PI, |_| 1.0);
    let worst = check_against_exact(&map, s.seed, |d| above_horizon(Vec3::Y, d), &exact);
    eprintln!(
        "open plane: rule error {worst:.2e}, bound {:.2e}",
        quadrature_bound(RAYS)
    );
    assert!(map.ao.iter().all(|&a| a == 1.0), "an open plane has AO 1");
    // Only the traced half of the directions counts.
    let per_texel = map.stats.rays_traced as f64 / 256.0;
    assert!(
        (per_texel - 512.0).abs() < 32.0,
        "{per_texel} rays per texel"
    );
}

#[test]
fn inner_corner_projects_the_quarter_sphere() {
    let s = settings(RAYS, 6);
    let (texels, map) = bake(&inner_corner(), 16, &s);
    assert_eq!(texels.covered_count(), 256);
    // y ≥ 0 and x ≥ 0 = lune φ ∈ [0, π/2] about +z (the corner line).
    let exact = lune_projection(s.order, 0.0, 0.5 * PI, |_| 1.0);
    let visible = |d: Vec3| above_horizon(Vec3::Y, d) && d.x > 0.0;
    let worst = check_against_exact(&map, s.seed, visible, &exact);
    eprintln!(
        "inner corner: rule error {worst:.2e}, bound {:.2e}",
        quadrature_bound(RAYS)
    );
}

#[test]
fn closed_box_floor_is_exactly_black() {
    let mut m = Mesh::default();
    floor_rect(&mut m, -1.0, 1.0, -1.0, 1.0, FULL_UV);
    closed_box(
        &mut m,
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(1.0, 2.0, 1.0),
        false,
    );
    let (texels, map) = bake(&m, 16, &settings(256, 1));
    assert_eq!(texels.covered_count(), 256);
    for t in 0..256 {
        assert!(
            map.texel(t).iter().all(|&c| c == 0.0),
            "texel {t}: {:?}",
            map.texel(t)
        );
        assert_eq!(map.ao[t], 0.0);
    }
    assert!(map.stats.rays_traced > 0);
}

#[test]
fn ground_lit_only_from_below_stays_dark() {
    let mut m = Mesh::default();
    floor_rect(&mut m, -10.0, 10.0, -10.0, 10.0, FULL_UV);
    let s = settings(RAYS, 2);
    let (_, map) = bake(&m, 16, &s);
    let v: Vec<f64> = map.texel(0).iter().map(|&c| f64::from(c)).collect();
    // L = max(0, −y): the lune φ ∈ [π, 2π] weighted by −y; and its mirror from above.
    let below = lune_projection(s.order, PI, 2.0 * PI, |d| -d.y);
    let above = lune_projection(s.order, 0.0, PI, |d| d.y);
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(a, b)| a * b).sum::<f64>();
    // ∫ V L = 0 exactly; its order-6 estimate Σ v_i L_i = ∫ V (L_n − L) + Σ e_i L_i, with
    // ‖V‖² = 2π (hemisphere), ‖L − L_n‖² = ‖L‖² − Σ L_i² = 2π/3 − Σ L_i² (Cauchy–Schwarz),
    // and ‖e‖ ≤ 6 × the per-coefficient quadrature bound (36 coefficients).
    let tail = (2.0 * PI / 3.0 - dot(&below, &below)).max(0.0).sqrt();
    let truncation_bound =
        (2.0 * PI).sqrt() * tail + 6.0 * quadrature_bound(RAYS) * dot(&below, &below).sqrt();
    let dark = dot(&v, &below);
    let lit = dot(&v, &above);
    eprintln!("lit from below {dark:.3e} (bound {truncation_bound:.3e}), from above {lit:.4} (π)");
    assert!(dark.abs() < truncation_bound, "{dark} ≥ {truncation_bound}");
    // From above the same plane receives ∫ max(0, y) dω = π.
    assert!((lit - PI).abs() < truncation_bound, "{lit} vs π");
    assert!(lit > 20.0 * dark.abs());
    // Sharper: the exact order-6 value of Σ v_i L_i (V projected exactly, the pure
    // truncation error ∫ V L_n) plus the quadrature error, each coefficient within the
    // bound: |Σ e_i L_i| ≤ bound · Σ |L_i|.
    let hemisphere = lune_projection(s.order, 0.0, PI, |_| 1.0);
    let truncation = dot(&hemisphere, &below);
    let quadrature = quadrature_bound(RAYS) * below.iter().map(|l| l.abs()).sum::<f64>();
    eprintln!("  exact truncated value {truncation:.3e}, quadrature term ≤ {quadrature:.3e}");
    assert!(
        (dark - truncation).abs() < quadrature,
        "{dark} vs {truncation}"
    );
}

/// Floor [−1, 1]² (64² texels of 3.1 cm) with a zero-thickness wall x = 0 (1 m high,
/// z ∈ [−1, 1]) standing on it and a closed 20 cm thick wall x ∈ [0.5, 0.7] whose bottom
/// face lies in the floor.
fn walls_on_floor() -> Mesh {
    let mut m = Mesh::default();
    floor_rect(&mut m, -1.0, 1.0, -1.0, 1.0, FULL_UV);
    let w = |y: f32, z: f32| Vec3::new(0.0, y, z);
    quad(
        &mut m,
        [w(0.0, 1.0), w(0.0, -1.0), w(1.0, -1.0), w(1.0, 1.0)],
        NO_UV,
    );
    closed_box(
        &mut m,
        Vec3::new(0.5, 0.0, -1.0),
        Vec3::new(0.7, 1.0, 1.0),
        true,
    );
    m
}

/// Rays whose crossing of a wall's plane lies this close to the wall's rim are not
/// judged: they may pass either side of the rim within f32 rounding.
const RIM_MARGIN: f32 = 1e-3;

#[test]
fn thin_wall_blocks_exactly_its_rays_and_thick_wall_footprint_is_black() {
    let m = walls_on_floor();
    let texels = rasterize(&m, 64);
    let tracer = Tracer::new(&m);
    let dirs = DirectionSet::new(RAYS, 3);
    let mut judged = 0;
    for t in (0..texels.covered.len()).filter(|&t| texels.covered[t]) {
        let p = texels.position[t];
        // Texels next to the thin wall, on both sides, away from its ends.
        if p.x.abs() > 0.05 || p.z.abs() > 0.5 {
            continue;
        }
        let o = tracer.offset_origin(p, texels.normal[t]);
        for &d in dirs.dirs() {
            if !above_horizon(texels.normal[t], d) || d.x * p.x >= 0.0 {
                continue; // rays away from the thin wall: the thick one is checked below
            }
            let hit_t = -o.x / d.x;
            let q = o + d * hit_t;
            let inside = q.y > RIM_MARGIN && q.y < 1.0 - RIM_MARGIN && q.z.abs() < 1.0 - RIM_MARGIN;
            let outside = q.y > 1.0 + RIM_MARGIN || q.z.abs() > 1.0 + RIM_MARGIN;
            let blocked = tracer.occluded(o, d, f32::INFINITY);
            if inside {
                assert!(
                    blocked,
                    "texel {t} at {p}: ray {d} leaks through the wall at {q}"
                );
                judged += 1;
            } else if outside && p.x < 0.0 {
                // Over or around the wall, on the side away from the thick wall: open sky.
                assert!(
                    !blocked,
                    "texel {t} at {p}: ray {d} wrongly blocked (acne?)"
                );
                judged += 1;
            }
        }
    }
    assert!(judged > 10_000, "only {judged} rays judged");
    // The thick wall's footprint: floor texels whose centre lies under it see nothing.
    let map = bake_visibility(&tracer, &texels, &settings(256, 3));
    let mut under = 0;
    for t in (0..texels.covered.len()).filter(|&t| texels.covered[t]) {
        let p = texels.position[t];
        if p.x > 0.5 && p.x < 0.7 {
            assert!(
                map.texel(t).iter().all(|&c| c == 0.0),
                "texel {t} at {p} leaks"
            );
            under += 1;
        }
    }
    assert!(under >= 3 * 64, "{under} texels under the thick wall");
}

// ---------------------------------------------------------------- determinism

/// A single-ray reference of the bake: Tracer::occluded per ray, the same projection.
fn reference_bake(
    tracer: &Tracer,
    texels: &LightmapTexels,
    s: &VisibilitySettings,
) -> (Vec<Vec<f32>>, Vec<f32>, u64) {
    let dirs = DirectionSet::new(s.rays, s.seed);
    let projector = ShProjector::new(&dirs, s.order);
    let n2 = s.order.coeff_count();
    let (mut coeffs, mut ao, mut traced) = (Vec::new(), Vec::new(), 0u64);
    for t in 0..texels.covered.len() {
        if !texels.covered[t] {
            coeffs.push(Vec::new());
            ao.push(1.0);
            continue;
        }
        let n = texels.normal[t];
        let o = tracer.offset_origin(texels.position[t], n);
        let mut mask = vec![0u64; dirs.mask_words()];
        let (mut up, mut vis) = (0.0f64, 0.0f64);
        for (r, &d) in dirs.dirs().iter().enumerate() {
            if !above_horizon(n, d) {
                continue;
            }
            traced += 1;
            let c = f64::from(n.dot(d));
            up += c;
            if !tracer.occluded(o, d, f32::INFINITY) {
                vis += c;
                mask[r / 64] |= 1 << (r % 64);
            }
        }
        let mut sum = vec![0.0f64; n2];
        projector.project(&mask, &mut sum);
        coeffs.push(sum.iter().map(|&v| v as f32).collect());
        ao.push(if up > 0.0 { (vis / up) as f32 } else { 1.0 });
    }
    (coeffs, ao, traced)
}

#[test]
fn coherent_bake_equals_single_ray_reference_bit_for_bit() {
    for (name, mesh, res) in [
        ("house", house::build(64).expect("house builds").mesh, 64),
        ("walls", walls_on_floor(), 32),
        ("corner", inner_corner(), 16),
    ] {
        let texels = rasterize(&mesh, res);
        let tracer = Tracer::new(&mesh);
        let s = settings(200, 11); // not a multiple of 64: partial mask words
        let map = bake_visibility(&tracer, &texels, &s);
        let (coeffs, ao, traced) = reference_bake(&tracer, &texels, &s);
        assert_eq!(map.stats.rays_traced, traced, "{name}");
        for t in (0..texels.covered.len()).filter(|&t| texels.covered[t]) {
            let got: Vec<u32> = map.texel(t).iter().map(|c| c.to_bits()).collect();
            let want: Vec<u32> = coeffs[t].iter().map(|c| c.to_bits()).collect();
            assert_eq!(got, want, "{name} texel {t}");
            assert_eq!(map.ao[t].to_bits(), ao[t].to_bits(), "{name} texel {t} AO");
        }
    }
}

#[test]
fn bakes_are_bit_identical_for_one_and_two_threads() {
    let scene = house::build(64).expect("house builds");
    let texels = rasterize(&scene.mesh, 64);
    let tracer = Tracer::new(&scene.mesh);
    let s = settings(128, 4);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("a thread pool")
            .install(|| bake_visibility(&tracer, &texels, &s))
    };
    let (one, two) = (run(1), run(2));
    let bits = |m: &VisibilityMap| m.coeffs.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
    assert!(
        bits(&one) == bits(&two),
        "coefficients differ between 1 and 2 threads"
    );
    assert!(
        one.ao
            .iter()
            .zip(&two.ao)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
    assert_eq!(one.stats.rays_traced, two.stats.rays_traced);
}

#[test]
fn different_seeds_agree_within_quadrature_error() {
    let mesh = inner_corner();
    let (_, a) = bake(&mesh, 16, &settings(RAYS, 100));
    let (_, b) = bake(&mesh, 16, &settings(RAYS, 200));
    assert_ne!(
        a.coeffs, b.coeffs,
        "different seeds must give different direction sets"
    );
    // Each bake is within the bound of the exact value.
    let bound = 2.0 * quadrature_bound(RAYS);
    let worst = a
        .coeffs
        .iter()
        .zip(&b.coeffs)
        .map(|(x, y)| f64::from((x - y).abs()))
        .fold(0.0, f64::max);
    eprintln!("seeds 100 vs 200: largest difference {worst:.2e}, bound {bound:.2e}");
    assert!(worst < bound, "{worst} ≥ {bound}");
}

// ---------------------------------------------------------------- cache and EXR

/// A fresh, empty directory for one test.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shvis-bake-vis-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

fn small_plane() -> Mesh {
    let mut m = Mesh::default();
    floor_rect(&mut m, -1.0, 1.0, -1.0, 1.0, FULL_UV);
    closed_box(
        &mut m,
        Vec3::new(-0.2, 0.0, -0.2),
        Vec3::new(0.2, 0.5, 0.2),
        false,
    );
    m
}

/// `load_or_bake_visibility` on the small plane; returns the map and whether it baked.
fn load_or_bake(dir: &std::path::Path, s: &VisibilitySettings) -> (VisibilityMap, bool) {
    let m = small_plane();
    let baked = Cell::new(false);
    let map = load_or_bake_visibility(dir, &m, 16, s, || {
        baked.set(true);
        bake(&m, 16, s).1
    })
    .expect("cache usable");
    (map, baked.get())
}

/// Equal bakes up to their wall-clock time.
fn same_bake(a: &VisibilityMap, b: &VisibilityMap) -> bool {
    let bits = |m: &VisibilityMap| m.coeffs.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
    (a.res, a.order, &a.covered, a.stats.rays_traced)
        == (b.res, b.order, &b.covered, b.stats.rays_traced)
        && bits(a) == bits(b)
        && a.ao
            .iter()
            .zip(&b.ao)
            .all(|(x, y)| x.to_bits() == y.to_bits())
}

#[test]
fn cache_round_trip_is_bit_identical() {
    let dir = temp_dir("round-trip");
    let s = settings(64, 1);
    let (first, baked) = load_or_bake(&dir, &s);
    assert!(baked);
    let (second, baked) = load_or_bake(&dir, &s);
    assert!(!baked, "the second call must read the cache");
    assert_eq!(first, second);
    let bits = |m: &VisibilityMap| m.coeffs.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&first), bits(&second));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn truncated_or_corrupted_cache_is_rebuilt() {
    let dir = temp_dir("damaged");
    let s = settings(64, 1);
    let (good, _) = load_or_bake(&dir, &s);
    let path = visibility_cache_path(&dir, visibility_key(&small_plane(), 16, &s));
    let bytes = std::fs::read(&path).expect("cache file written");
    let damaged: Vec<(&str, Vec<u8>)> = vec![
        ("truncated payload", bytes[..bytes.len() - 7].to_vec()),
        ("truncated header", bytes[..HEADER_BYTES - 3].to_vec()),
        ("flipped payload byte", {
            let mut b = bytes.clone();
            b[HEADER_BYTES + (bytes.len() - HEADER_BYTES) / 2] ^= 0x10;
            b
        }),
        ("wrong magic", {
            let mut b = bytes.clone();
            b[0] = b'X';
            b
        }),
        ("wrong version", {
            let mut b = bytes.clone();
            b[8] ^= 0xff;
            b
        }),
        ("wrong key", {
            let mut b = bytes.clone();
            b[16] ^= 1;
            b
        }),
    ];
    for (what, b) in damaged {
        std::fs::write(&path, &b).expect("write damaged cache");
        let (map, baked) = load_or_bake(&dir, &s);
        assert!(baked, "{what}: must be rebuilt, not trusted");
        assert!(same_bake(&map, &good), "{what}: rebuilt map differs");
        let (again, baked) = load_or_bake(&dir, &s);
        assert!(
            !baked && same_bake(&again, &good),
            "{what}: file not rewritten"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn different_settings_or_scene_change_the_key() {
    let m = small_plane();
    let s = settings(64, 1);
    let key = visibility_key(&m, 16, &s);
    assert_eq!(
        key,
        visibility_key(
            &m,
            16,
            &VisibilitySettings {
                progress: true,
                ..s
            }
        )
    );
    assert_ne!(key, visibility_key(&m, 32, &s));
    assert_ne!(key, visibility_key(&m, 16, &settings(65, 1)));
    assert_ne!(key, visibility_key(&m, 16, &settings(64, 2)));
    let order4 = VisibilitySettings {
        order: Order::FOUR,
        ..s
    };
    assert_ne!(key, visibility_key(&m, 16, &order4));
    let mut moved = m.clone();
    moved.vertices[0].position[1] += 1e-6;
    assert_ne!(key, visibility_key(&moved, 16, &s));
    let mut reindexed = m.clone();
    reindexed.indices.swap(0, 1);
    assert_ne!(key, visibility_key(&reindexed, 16, &s));
}

/// An EXR layer's channels: (name, samples).
type Channels = Vec<(String, Vec<f32>)>;

/// The one layer of the OpenEXR file at `path`: its size and each channel's name and f32
/// samples (row-major), channels in the file's (alphabetical) order. Fails the test for a
/// file of more than one layer or a channel not stored as f32.
fn read_exr_channels(path: &Path) -> ((usize, usize), Channels) {
    use exr::prelude::{FlatSamples, read_all_flat_layers_from_file};
    let image =
        read_all_flat_layers_from_file(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(image.layer_data.len(), 1, "{}: layers", path.display());
    let layer = &image.layer_data[0];
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| match &c.sample_data {
            FlatSamples::F32(samples) => (c.name.to_string(), samples.clone()),
            _ => panic!("{}: channel {} is not f32", path.display(), c.name),
        })
        .collect();
    ((layer.size.0, layer.size.1), channels)
}

/// `visibility_{k}.exr` holds coefficients 4k..4k+3 in R, G, B, A (zero past order²) and
/// `ao.exr` the AO in Y, as f32 under lossless RLE: read back, every sample is the baked
/// value bit for bit. Order 3 leaves three zero channels in its last layer; order 6 fills
/// all nine.
#[test]
fn exr_layers_read_back_as_written() {
    for order in [Order::THREE, Order::SIX] {
        let dir = temp_dir(&format!("exr-{order}"));
        let s = VisibilitySettings {
            order,
            ..settings(64, 1)
        };
        let (_, map) = bake(&small_plane(), 16, &s);
        write_exr_layers(&dir, &map, serde_json::json!({"test": true})).expect("EXR written");
        let res = map.res as usize;
        let n2 = order.coeff_count();
        let layers = n2.div_ceil(4);
        for k in 0..layers {
            let path = dir.join(format!("visibility_{k}.exr"));
            let (size, channels) = read_exr_channels(&path);
            assert_eq!(size, (res, res), "{}: size", path.display());
            let names: Vec<&str> = channels.iter().map(|(n, _)| n.as_str()).collect();
            assert_eq!(names, ["A", "B", "G", "R"], "{}: channels", path.display());
            for (name, samples) in &channels {
                let j = "RGBA".find(name.as_str()).expect("an RGBA channel");
                let i = 4 * k + j;
                for (t, &got) in samples.iter().enumerate() {
                    let want = if i < n2 { map.coeffs[t * n2 + i] } else { 0.0 };
                    assert_eq!(
                        got.to_bits(),
                        want.to_bits(),
                        "{} {name} (coefficient {i}), texel {t}: {got} against {want}",
                        path.display()
                    );
                }
            }
        }
        assert!(
            !dir.join(format!("visibility_{layers}.exr")).exists(),
            "order {order}: {layers} layers, no more"
        );
        let path = dir.join("ao.exr");
        let (size, channels) = read_exr_channels(&path);
        assert_eq!(size, (res, res), "{}: size", path.display());
        let names: Vec<&str> = channels.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["Y"], "{}: channels", path.display());
        for (t, (&got, &want)) in channels[0].1.iter().zip(&map.ao).enumerate() {
            assert_eq!(
                got.to_bits(),
                want.to_bits(),
                "ao.exr texel {t}: {got} against {want}"
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}

// ---------------------------------------------------------------- GPU simulator

mod gpu_simulator {
    use super::*;
    use shvis::bake::gpu_visibility::{
        GpuVisibilitySettings, bake_visibility_gpu, compare, quadrature_noise,
    };

    fn gpu_bake(
        mesh: &Mesh,
        texels: &LightmapTexels,
        s: &VisibilitySettings,
        depth_res: u32,
    ) -> VisibilityMap {
        let ctx = common::validated_context();
        let gpu = GpuVisibilitySettings {
            depth_res,
            ..GpuVisibilitySettings::default()
        };
        let baked = bake_visibility_gpu(&ctx, mesh, texels, s, &gpu).expect("the simulator runs");
        common::assert_validation_clean(&ctx, "gpu visibility bake");
        baked.map
    }

    #[test]
    fn equals_the_cpu_bake_where_every_ray_escapes() {
        let mut m = Mesh::default();
        floor_rect(&mut m, -10.0, 10.0, -10.0, 10.0, FULL_UV);
        let s = settings(256, 3);
        let (texels, cpu) = bake(&m, 16, &s);
        let gpu = gpu_bake(&m, &texels, &s, 256);
        assert!(gpu.ao.iter().all(|&a| a == 1.0), "an open plane has AO 1");
        assert_eq!(gpu.stats.rays_traced, cpu.stats.rays_traced);
        // Same escaping rays: only the f32 (GPU) against f64 (CPU) sum of ≤ 256 terms.
        let worst = cpu
            .coeffs
            .iter()
            .zip(&gpu.coeffs)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-5, "largest coefficient difference {worst:.2e}");
    }

    #[test]
    fn follows_the_cpu_bake_beside_a_wall_and_on_the_house() {
        let s = settings(128, 0);
        let other = settings(128, 1);
        // A wall x = 0 over a 20 m floor, the lightmap on 5 m of floor beside it; the CPU
        // tests' inner corner, a 1 cm patch 1 mm from a 200 m wall — 1/20 of one 20 cm map
        // texel, where the depth test alone shadows or leaks on every texel (100 %) and the
        // exact test of the triangles around each point settles most directions (the rest:
        // the wall nearly edge-on, thinner than a map texel); and the built-in house.
        let mut corner = Mesh::default();
        floor_rect(&mut corner, -10.0, 10.0, -10.0, 10.0, NO_UV);
        floor_rect(&mut corner, 0.5, 5.5, -2.5, 2.5, FULL_UV);
        let w = |y: f32, z: f32| Vec3::new(0.0, y, z);
        quad(
            &mut corner,
            [w(0.0, 10.0), w(0.0, -10.0), w(20.0, -10.0), w(20.0, 10.0)],
            NO_UV,
        );
        let house = house::build(64).expect("the built-in house").mesh;
        for (name, mesh, res, bound) in [
            ("corner", &corner, 16, 0.01),
            ("inner corner", &inner_corner(), 16, 0.15),
            ("house", &house, 64, 0.02),
        ] {
            let (texels, cpu) = bake(mesh, res, &s);
            let (_, cpu_other) = bake(mesh, res, &other);
            let noise = quadrature_noise(&cpu, &cpu_other);
            let gpu = gpu_bake(mesh, &texels, &s, 1024);
            let d = compare(&cpu, &gpu, noise);
            eprintln!(
                "{name}: {:.2} % of {} texels beyond the quadrature noise {noise:.4}, RMS {:.4}",
                100.0 * d.fraction_above,
                d.texels,
                d.rms
            );
            assert!(d.texels > 0);
            assert!(d.rms < noise, "{name}: RMS {} ≥ noise {noise}", d.rms);
            assert!(d.fraction_above <= bound, "{name}: {d:?}");
        }
    }
}
