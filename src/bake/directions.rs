//! The shared ray directions of the visibility bake and the SH projection of a texel's
//! visible set (Iwanicki–Sloan §3.1: v_i = ∫ V(ω) y_i(ω) dω).
//!
//! # Direction set
//!
//! One set of R unit directions serves *every* texel of a bake, so tracing can be
//! direction-major (all texels of a group trace direction r together, see
//! [`super::trace::Tracer::occluded_coherent`]). It is a spherical Fibonacci set
//! (Swinbank & Purser 2006; Marques et al. 2013)
//!
//! ```text
//! z_r = 1 − (2r + 1)/R,   φ_r = 2π · frac(r · (√5 − 1)/2),   r = 0 … R−1
//! ```
//!
//! — each point alone in a z-band of area 4π/R, the bands' azimuths spread by the golden
//! angle — turned by one uniformly random rotation of SO(3) drawn from a hash of the seed
//! (Shoemake's unit quaternion from three uniforms). The rotation makes every point
//! uniform on the sphere, so the estimator
//!
//! ```text
//! v_i ≈ Σ_r w · V(ω_r) · y_i(ω_r),   w = 4π/R                                   (1)
//! ```
//!
//! is unbiased over seeds, while for one seed it has the low error of a quasi-Monte Carlo
//! rule (the tests measure it against exact projections: `tests/bake_visibility.rs`).
//! There is no per-texel randomness: every texel sees the same rule, so neighbouring
//! texels with the same visibility get the same coefficients (no per-texel noise), and
//! the estimate's error is that of the rule on each texel's visibility function.
//!
//! The directions are finally sorted along a Morton curve of their octahedral map, so
//! that runs of 8 consecutive directions are neighbours on the sphere: a texel's visible
//! bits then come in runs of all-0 (below the horizon, behind an occluder) or all-1
//! bytes, and [`ShProjector`] skips the all-0 ones.
//!
//! # Projection (eq. (1) with a bitmask)
//!
//! A texel's visible set is a bitmask of R bits (bit r set when ray r escapes). With the
//! rule fixed, w·y_i(ω_r) is computed once (in f64). For each chunk of B consecutive
//! directions (B = 8 normally, smaller for huge R or order, [`ShProjector::new`]) a table
//! holds the partial sums Σ_{b ∈ pattern} w·y_i(ω_{cB+b}) of all 2^B bit patterns, so a
//! texel costs at most R/B table rows of order² f64 adds, summed in chunk order; all-zero
//! chunks are skipped and an all-visible 64-direction word (open sky) is one precomputed
//! row. The result depends only on the bitmask, never on the thread that computes it.

use std::f64::consts::PI;

use glam::{DQuat, DVec2, DVec3, Vec3};

use crate::sh::Order;
use crate::sh::basis::eval_basis;

/// Most bytes a projection table may take before [`ShProjector`] uses narrower chunks.
pub const TABLE_BUDGET_BYTES: usize = 32 << 20;

pub(crate) use crate::files::splitmix64;

/// Uniform in [0, 1) from the top 53 bits of `h`.
pub(crate) fn unit_f64(h: u64) -> f64 {
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Whether a ray leaving a surface with unit geometric `normal` along `dir` is traced:
/// strictly above the tangent plane (DESIGN §1: below it V = 0 and nothing is traced).
/// The one test every bake path and reference uses, in f32.
#[inline]
pub fn above_horizon(normal: Vec3, dir: Vec3) -> bool {
    normal.dot(dir) > 0.0
}

/// The shared stratified direction set of a bake (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct DirectionSet {
    /// Unit directions as traced (f32), in projection order.
    dirs: Vec<Vec3>,
    seed: u64,
}

impl DirectionSet {
    /// The rotated, Morton-sorted spherical Fibonacci set of `rays` directions under
    /// `seed`. `rays = 0` gives an empty set.
    pub fn new(rays: u32, seed: u64) -> DirectionSet {
        let rotation = random_rotation(seed);
        let n = f64::from(rays.max(1));
        let golden = 0.5 * (5f64.sqrt() - 1.0);
        let mut keyed: Vec<(u64, Vec3)> = (0..rays)
            .map(|r| {
                let z = 1.0 - (2.0 * f64::from(r) + 1.0) / n;
                let phi = 2.0 * PI * (f64::from(r) * golden).fract();
                let s = (1.0 - z * z).max(0.0).sqrt();
                let d = rotation * DVec3::new(s * phi.cos(), s * phi.sin(), z);
                // Rounded to f32 once and renormalized, so the traced direction is unit.
                let d = d.as_vec3().normalize();
                (morton_key(d), d)
            })
            .collect();
        // Ties (equal keys) keep Fibonacci order: the sort is stable.
        keyed.sort_by_key(|&(k, _)| k);
        DirectionSet {
            dirs: keyed.into_iter().map(|(_, d)| d).collect(),
            seed,
        }
    }

    /// The directions, in projection order (bit r of a visibility mask is `dirs()[r]`).
    pub fn dirs(&self) -> &[Vec3] {
        &self.dirs
    }

    /// Number of directions R.
    pub fn len(&self) -> usize {
        self.dirs.len()
    }

    /// Whether the set is empty.
    pub fn is_empty(&self) -> bool {
        self.dirs.is_empty()
    }

    /// The seed the set was drawn with.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Quadrature weight of every direction, sr: 4π/R (eq. (1)).
    pub fn weight(&self) -> f64 {
        4.0 * PI / self.dirs.len().max(1) as f64
    }

    /// Number of u64 words of a visibility bitmask over this set.
    pub fn mask_words(&self) -> usize {
        self.dirs.len().div_ceil(64)
    }
}

/// A uniformly distributed rotation (Shoemake 1992) from a hash of `seed`.
fn random_rotation(seed: u64) -> DQuat {
    let h1 = splitmix64(seed ^ 0x5348_5649_535f_5649); // "SHVIS_VI"
    let h2 = splitmix64(h1);
    let h3 = splitmix64(h2);
    let (u1, u2, u3) = (unit_f64(h1), unit_f64(h2), unit_f64(h3));
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let (t2, t3) = (2.0 * PI * u2, 2.0 * PI * u3);
    DQuat::from_xyzw(a * t2.sin(), a * t2.cos(), b * t3.sin(), b * t3.cos()).normalize()
}

/// Morton key of a direction: octahedral map to [0, 1]², 16 bits per axis interleaved,
/// lower hemisphere (z < 0) after the upper one.
fn morton_key(d: Vec3) -> u64 {
    let d = d.as_dvec3();
    let l1 = d.x.abs() + d.y.abs() + d.z.abs();
    let p = DVec2::new(d.x, d.y) / l1;
    let q = DVec2::new(0.5 * (p.x + 1.0), 0.5 * (p.y + 1.0));
    let quantize = |c: f64| ((c.clamp(0.0, 1.0) * 65535.0).round() as u64).min(65535);
    let spread = |mut v: u64| {
        v = (v | (v << 8)) & 0x00ff_00ff;
        v = (v | (v << 4)) & 0x0f0f_0f0f;
        v = (v | (v << 2)) & 0x3333_3333;
        (v | (v << 1)) & 0x5555_5555
    };
    let lower = u64::from(d.z < 0.0) << 32;
    lower | spread(quantize(q.x)) | (spread(quantize(q.y)) << 1)
}

/// Projects visibility bitmasks over a [`DirectionSet`] onto SH (eq. (1); module doc).
#[derive(Clone, Debug)]
pub struct ShProjector {
    order: Order,
    rays: usize,
    /// Directions per chunk, B ∈ {8, 4, 2, 1}.
    chunk_bits: usize,
    /// `table[((c << B) + pattern) · n² + i]` = Σ_{b ∈ pattern} w·y_i(ω_{cB+b}).
    table: Vec<f64>,
    /// `full[w · n² + i]` = Σ over the 64 directions of mask word w of w·y_i: one row for
    /// an all-visible word (open sky) instead of 64/B.
    full: Vec<f64>,
}

impl ShProjector {
    /// Tables for `dirs` at `order`: chunks of 8 directions when the table fits
    /// [`TABLE_BUDGET_BYTES`], else 4, 2 or 1.
    pub fn new(dirs: &DirectionSet, order: Order) -> ShProjector {
        let n2 = order.coeff_count();
        let rays = dirs.len();
        let bytes = |b: usize| rays.div_ceil(b) * (1usize << b) * n2 * 8;
        let chunk_bits = [8, 4, 2]
            .into_iter()
            .find(|&b| bytes(b) <= TABLE_BUDGET_BYTES)
            .unwrap_or(1);
        Self::with_chunk_bits(dirs, order, chunk_bits)
    }

    /// As [`Self::new`] with an explicit chunk width (1, 2, 4 or 8 directions; benches
    /// and tests compare them).
    ///
    /// # Panics
    /// If `chunk_bits` is not 1, 2, 4 or 8 (a bug in the caller).
    pub fn with_chunk_bits(dirs: &DirectionSet, order: Order, chunk_bits: usize) -> ShProjector {
        assert!(
            matches!(chunk_bits, 1 | 2 | 4 | 8),
            "chunk width {chunk_bits} is not 1, 2, 4 or 8"
        );
        let n2 = order.coeff_count();
        let rays = dirs.len();
        let w = dirs.weight();
        // w·y_i(ω_r), evaluated at the traced (f32) direction.
        let mut wy = vec![0.0f64; rays * n2];
        for (r, d) in dirs.dirs().iter().enumerate() {
            let row = &mut wy[r * n2..(r + 1) * n2];
            eval_basis(order, d.as_dvec3().normalize(), row);
            row.iter_mut().for_each(|v| *v *= w);
        }
        let chunks = rays.div_ceil(chunk_bits);
        let patterns = 1usize << chunk_bits;
        let mut table = vec![0.0f64; chunks * patterns * n2];
        for c in 0..chunks {
            let base = c * patterns;
            for p in 1..patterns {
                // Pattern p = (p without its highest bit) + that bit's direction.
                let high = usize::BITS - 1 - p.leading_zeros();
                let rest = p & !(1 << high);
                let r = c * chunk_bits + high as usize;
                for i in 0..n2 {
                    let add = if r < rays { wy[r * n2 + i] } else { 0.0 };
                    table[(base + p) * n2 + i] = table[(base + rest) * n2 + i] + add;
                }
            }
        }
        let words = rays.div_ceil(64);
        let mut full = vec![0.0f64; words * n2];
        for (r, row) in wy.chunks_exact(n2).enumerate() {
            for (f, v) in full[(r / 64) * n2..(r / 64 + 1) * n2].iter_mut().zip(row) {
                *f += v;
            }
        }
        ShProjector {
            order,
            rays,
            chunk_bits,
            table,
            full,
        }
    }

    /// The SH order of the output.
    pub fn order(&self) -> Order {
        self.order
    }

    /// Directions per table chunk.
    pub fn chunk_bits(&self) -> usize {
        self.chunk_bits
    }

    /// Adds eq. (1) for the visible set `mask` (bit r of `mask[r / 64]` set when
    /// direction r escapes; bits ≥ R ignored) to `out` (order² values, f64).
    ///
    /// # Panics
    /// If `mask` has fewer than ⌈R/64⌉ words or `out` fewer than order² values.
    pub fn project(&self, mask: &[u64], out: &mut [f64]) {
        let n2 = self.order.coeff_count();
        let out = &mut out[..n2];
        let b = self.chunk_bits;
        let per_word = 64 / b;
        let chunks = self.rays.div_ceil(b);
        let pattern_mask = (1u64 << b) - 1;
        for (wi, &word) in mask[..self.rays.div_ceil(64)].iter().enumerate() {
            if word == 0 {
                continue;
            }
            if word == !0 && (wi + 1) * 64 <= self.rays {
                for (o, f) in out.iter_mut().zip(&self.full[wi * n2..(wi + 1) * n2]) {
                    *o += f;
                }
                continue;
            }
            for k in 0..per_word {
                let c = wi * per_word + k;
                if c >= chunks {
                    break;
                }
                let p = ((word >> (k * b)) & pattern_mask) as usize;
                if p == 0 {
                    continue;
                }
                let row = &self.table[((c << b) + p) * n2..((c << b) + p + 1) * n2];
                for (o, t) in out.iter_mut().zip(row) {
                    *o += t;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::basis::eval_basis_vec;

    /// f32-rounded unit directions renormalized: length within a few ulp of 1.
    const UNIT: f32 = 1e-6;
    /// Table sums vs a plain sum of the same ≤ 1024 f64 terms of size ≤ 0.01.
    const SUM_ORDER: f64 = 1e-13;

    #[test]
    fn set_is_unit_deterministic_and_seeded() {
        let a = DirectionSet::new(1000, 3);
        assert_eq!(a.len(), 1000);
        assert!(a.dirs().iter().all(|d| (d.length() - 1.0).abs() < UNIT));
        assert_eq!(a, DirectionSet::new(1000, 3));
        assert_ne!(a.dirs(), DirectionSet::new(1000, 4).dirs());
        assert!(DirectionSet::new(0, 1).is_empty());
    }

    #[test]
    fn rule_integrates_low_bands_nearly_exactly() {
        // A well-spread rule integrates y_0^0 exactly (by construction: Σ w = 4π) and
        // the l ≥ 1 bands (zero mean) to about its discrepancy, ~R^{-3/4}·4π.
        let set = DirectionSet::new(1024, 0);
        let order = Order::new(4).expect("valid");
        let mut sum = vec![0.0; order.coeff_count()];
        for d in set.dirs() {
            let y = eval_basis_vec(order, d.as_dvec3().normalize());
            for (s, v) in sum.iter_mut().zip(y) {
                *s += set.weight() * v;
            }
        }
        assert!((sum[0] - (4.0 * PI).sqrt()).abs() < 1e-9, "{}", sum[0]);
        for (i, s) in sum.iter().enumerate().skip(1) {
            assert!(s.abs() < 1e-2, "band of coefficient {i}: {s}");
        }
    }

    #[test]
    fn table_projection_matches_plain_sum_for_every_chunk_width() {
        let set = DirectionSet::new(1000, 7); // not a multiple of 8 or 64
        let order = Order::SIX;
        let mut mask = vec![0u64; set.mask_words()];
        for r in 0..set.len() {
            if !splitmix64(r as u64).is_multiple_of(3) {
                mask[r / 64] |= 1 << (r % 64);
            }
        }
        mask[3] = !0; // an all-visible word takes the precomputed row
        mask[set.len() / 64] |= !0 << (set.len() % 64); // bits past R are ignored
        let mut plain = vec![0.0; 36];
        for r in 0..set.len() {
            if mask[r / 64] >> (r % 64) & 1 == 1 {
                let y = eval_basis_vec(order, set.dirs()[r].as_dvec3().normalize());
                for (p, v) in plain.iter_mut().zip(y) {
                    *p += set.weight() * v;
                }
            }
        }
        for b in [1, 2, 4, 8] {
            let proj = ShProjector::with_chunk_bits(&set, order, b);
            let mut out = vec![0.0; 36];
            proj.project(&mask, &mut out);
            for i in 0..36 {
                assert!((out[i] - plain[i]).abs() < SUM_ORDER, "B={b} i={i}");
            }
        }
        assert_eq!(ShProjector::new(&set, order).chunk_bits(), 8);
    }

    #[test]
    fn consecutive_directions_are_neighbours() {
        // Morton order: the mean angle between consecutive directions is a few times
        // the rule's spacing √(4π/R), not the ~90° of an unsorted set.
        let set = DirectionSet::new(4096, 1);
        let mean: f64 = set
            .dirs()
            .windows(2)
            .map(|w| f64::from(w[0].dot(w[1]).clamp(-1.0, 1.0)).acos())
            .sum::<f64>()
            / 4095.0;
        let spacing = (4.0 * PI / 4096.0).sqrt();
        assert!(
            mean < 4.0 * spacing,
            "mean step {mean} vs spacing {spacing}"
        );
    }
}
