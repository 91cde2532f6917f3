//! A lightmap texel's incident radiance as samples, and every tangent-frame lightmap basis
//! fitted from them: the H-basis, spherical Gaussians under each solver, Ambient Dice and
//! the ambient cube (BakingLab's way: every mode from the same per-texel samples, none
//! from another basis).
//!
//! # Samples
//!
//! A texel's samples are its bake's rays: tangent-space unit directions ω_s (the world
//! direction carried through the transpose of the texel's orthonormal normal-map frame),
//! solid-angle weights w_s (4π/R for R shared directions) and RGB radiance L_s, zero where
//! the ray was not traced (below the geometric horizon) or hit a back face.
//!
//! # Fits
//!
//! - SH of any order (world or tangent space alike): c_i = Σ_s w_s L_s y_i(ω_s)
//!   ([`project_sh`]) — the bake's `shlmap` coefficients are this sum at order 3, so the SH
//!   lightmap family and its engine variants are the same from samples as from L2.
//! - `sgN` under each solver: [`SgBasis::fit_samples`] (`sh::sg`, Fitting from samples).
//! - The irradiance bases — `hb4`/`hb6`, `dice`/`dicey`, `acube`/`acubels` — store a fit of
//!   the irradiance E(m) = ∫ L(ω) max(0, m·ω) dω over the hemisphere of normals m. Each fit
//!   is linear in E, so in L: with E estimated from the samples,
//!
//!   ```text
//!   c_k = Σ_s w_s L_s κ_k(ω_s),   κ_k(ω) = the fit applied to E(m) = max(0, m·ω)      (1)
//!   ```
//!
//!   the fit's kernel κ: `hbasis::irradiance_kernel` (the projection ∫ H_k(m) max(0, m·ω)
//!   dm), `Dice::hybrid_kernel`/`linear_kernel` (the pseudo-inverse over the Dice rule's
//!   nodes), `ambient_cube::least_squares_kernel` (the least-squares solve over the octant
//!   rule) and, for Valve's projection C_±a = E(±e_a), κ = max(0, ±ω_a) exactly. (1) is
//!   the same fit the `l2` path makes of E from order-3 SH, with E's samples in place of
//!   the SH; only the source differs.
//!
//! # Kernel tables
//!
//! κ costs one evaluation per fitting node (72 for Dice, 484 for the cube's least squares),
//! so each kernel is tabulated once at the vertices of a [`TABLE_RES`]² grid over the
//! octahedral square of the sphere and read bilinearly: the octahedral map is continuous on
//! the square (its folds meet at z = 0 from both sides), κ is continuous, so the table
//! converges as 1/res² away from κ's kinks (the great circles m_q·ω = 0) and as 1/res
//! across them. At 256 a test reads the Dice table at 500 directions within 2 % of the
//! exact kernels' scale, and fits from the tables of a smooth sky's 16 384 samples match the
//! `l2` path's quadrature fits of the same function within 0.5 % of their scale.

use std::sync::OnceLock;

use glam::{DVec2, DVec3};

use super::Order;
use super::ambient_cube::{self, CubeFit, FACES, UPPER_FACES};
use super::basis::eval_basis;
use super::dice::{self, DiceVariant, STORED_VERTICES, rgb_to_ycocg};
use super::hbasis::{self, HBasisSize};
use super::sg::{FitStats, SampleDesign, Solver};

/// Where a run's tangent-frame bases are fitted from (`--basis-fit`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum BasisFit {
    /// The texel's radiance samples, the rays of the bake (this module).
    #[default]
    Samples,
    /// The texel's order-3 SH, read at each fit's nodes.
    L2,
}

impl BasisFit {
    pub const ALL: [BasisFit; 2] = [BasisFit::Samples, BasisFit::L2];

    pub fn name(self) -> &'static str {
        match self {
            BasisFit::Samples => "samples",
            BasisFit::L2 => "l2",
        }
    }
}

impl std::fmt::Display for BasisFit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for BasisFit {
    type Err = String;
    fn from_str(s: &str) -> Result<BasisFit, String> {
        BasisFit::ALL
            .into_iter()
            .find(|b| b.name() == s)
            .ok_or_else(|| format!("unknown basis fit '{s}' (samples, l2)"))
    }
}

/// One radiance sample of a texel (module doc, Samples).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Unit direction in the texel's tangent frame (z along its normal).
    pub dir: DVec3,
    /// Solid angle the sample stands for (sr).
    pub weight: f64,
    /// RGB radiance arriving from `dir`.
    pub radiance: [f64; 3],
}

/// A basis and its fit, as a bake computes it per texel from the samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SampleFit {
    HBasis(HBasisSize),
    Sg { lobes: u32, solver: Solver },
    Dice(DiceVariant),
    AmbientCube(CubeFit),
}

impl SampleFit {
    /// Values per texel, in the layout the technique stores: RGB per function (3i + c) for
    /// the H-basis, the lobes and the cube's faces; [`DiceVariant::stored_values`] for Dice.
    pub fn stored_values(self) -> usize {
        match self {
            SampleFit::HBasis(size) => 3 * size.count(),
            SampleFit::Sg { lobes, .. } => 3 * lobes as usize,
            SampleFit::Dice(variant) => variant.stored_values(),
            SampleFit::AmbientCube(_) => ambient_cube::STORED_VALUES,
        }
    }

    /// The values fitting `samples` (module doc, Fits), and for SG what the solver made
    /// negative.
    pub fn fit(self, samples: &[Sample]) -> (Vec<f64>, FitStats) {
        self.fit_group(&[samples]).pop().expect("one fit per point")
    }

    /// [`SampleFit::fit`] of each point's samples in `points`, the same values point by
    /// point. A tabulated kernel is read sample index by sample index across the points:
    /// nearby points (a group of texels or pixels) see a shared direction at nearby
    /// tangent-space directions, so the reads stay in cache where a point at a time would
    /// wander over the whole table.
    pub fn fit_group(self, points: &[&[Sample]]) -> Vec<(Vec<f64>, FitStats)> {
        let plain = |values: Vec<Vec<f64>>| -> Vec<(Vec<f64>, FitStats)> {
            values
                .into_iter()
                .map(|v| (v, FitStats::default()))
                .collect()
        };
        match self {
            SampleFit::HBasis(size) => plain(
                kernel_fit_group(points, hbasis_table())
                    .into_iter()
                    .map(|h| h.iter().take(size.count()).flatten().copied().collect())
                    .collect(),
            ),
            SampleFit::Sg { lobes, solver } => {
                // A point whose samples have the previous one's directions and weights (a
                // flat surface) reuses its design: the same operations on the same values.
                let basis = super::sg::shared_basis(lobes as usize);
                let mut design: Option<(Vec<DVec3>, Vec<f64>, SampleDesign)> = None;
                points
                    .iter()
                    .map(|samples| {
                        let mut stats = FitStats::default();
                        let dirs: Vec<DVec3> = samples.iter().map(|s| s.dir).collect();
                        let weights: Vec<f64> = samples.iter().map(|s| s.weight).collect();
                        let radiance: Vec<[f64; 3]> = samples.iter().map(|s| s.radiance).collect();
                        let same = design
                            .as_ref()
                            .is_some_and(|(d, w, _)| *d == dirs && *w == weights);
                        if !same {
                            let made = basis.sample_design(&dirs, &weights, solver);
                            design = Some((dirs, weights, made));
                        }
                        let (_, _, made) = design.as_ref().expect("made above");
                        let values = made
                            .fit(&radiance, &mut stats)
                            .into_iter()
                            .flatten()
                            .collect();
                        (values, stats)
                    })
                    .collect()
            }
            SampleFit::Dice(variant) => plain(dice_fit_group(points, variant)),
            SampleFit::AmbientCube(fit) => plain(cube_fit_group(points, fit)),
        }
    }
}

/// The SH coefficients (RGB, order² of them) of the samples, in their frame.
pub fn project_sh(samples: &[Sample], order: Order) -> Vec<[f64; 3]> {
    let mut y = vec![0.0; order.coeff_count()];
    let mut c = vec![[0.0; 3]; order.coeff_count()];
    for s in samples {
        eval_basis(order, s.dir, &mut y);
        for (ci, yi) in c.iter_mut().zip(&y) {
            for k in 0..3 {
                ci[k] += s.weight * s.radiance[k] * yi;
            }
        }
    }
    c
}

/// (1) with a tabulated kernel at each point of `points`: Σ_s w_s L_s κ(ω_s), RGB per
/// kernel row; sample index outermost ([`SampleFit::fit_group`]), each point's sum in its
/// samples' order.
fn kernel_fit_group(points: &[&[Sample]], table: &KernelTable) -> Vec<Vec<[f64; 3]>> {
    let rows = table.rows;
    // Per point, channel-major sums (contiguous rows per channel: the loop vectorizes).
    let mut sums = vec![0.0f64; points.len() * 3 * rows];
    let mut k = vec![0.0; rows];
    let longest = points.iter().map(|p| p.len()).max().unwrap_or(0);
    for i in 0..longest {
        // Points of one flat surface see sample i at the same direction: read once.
        let mut read_at = None;
        for (samples, sums) in points.iter().zip(sums.chunks_mut(3 * rows)) {
            let Some(s) = samples.get(i) else {
                continue;
            };
            if s.radiance == [0.0; 3] {
                continue;
            }
            if read_at != Some(s.dir) {
                table.read(s.dir, &mut k);
                read_at = Some(s.dir);
            }
            for (c, sums) in sums.chunks_mut(rows).enumerate() {
                let wl = s.weight * s.radiance[c];
                for (o, ki) in sums.iter_mut().zip(&k) {
                    *o += wl * ki;
                }
            }
        }
    }
    sums.chunks(3 * rows)
        .map(|p| {
            (0..rows)
                .map(|r| [p[r], p[rows + r], p[2 * rows + r]])
                .collect()
        })
        .collect()
}

fn dice_fit_group(points: &[&[Sample]], variant: DiceVariant) -> Vec<Vec<f64>> {
    match variant {
        DiceVariant::Rgb => kernel_fit_group(points, dice_hybrid_table())
            .into_iter()
            .map(|x| {
                let mut out = vec![0.0; variant.stored_values()];
                for v in 0..STORED_VERTICES {
                    for k in 0..3 {
                        for c in 0..3 {
                            out[9 * v + 3 * k + c] = x[3 * v + k][c];
                        }
                    }
                }
                out
            })
            .collect(),
        DiceVariant::YCoCg => {
            let ycocg: Vec<Vec<Sample>> = points
                .iter()
                .map(|samples| {
                    samples
                        .iter()
                        .map(|s| Sample {
                            radiance: rgb_to_ycocg(s.radiance),
                            ..*s
                        })
                        .collect()
                })
                .collect();
            let ycocg: Vec<&[Sample]> = ycocg.iter().map(Vec::as_slice).collect();
            // Y by the hybrid kernels, Co and Cg by the linear ones (`sh::dice`, YCoCg).
            let y = kernel_fit_group(&ycocg, dice_hybrid_table());
            let chroma = kernel_fit_group(&ycocg, dice_linear_table());
            y.into_iter()
                .zip(chroma)
                .map(|(y, chroma)| {
                    let mut out = vec![0.0; variant.stored_values()];
                    for v in 0..STORED_VERTICES {
                        for k in 0..3 {
                            out[5 * v + k] = y[3 * v + k][0];
                        }
                        out[5 * v + 3] = chroma[v][1];
                        out[5 * v + 4] = chroma[v][2];
                    }
                    out
                })
                .collect()
        }
    }
}

fn cube_fit_group(points: &[&[Sample]], fit: CubeFit) -> Vec<Vec<f64>> {
    let upper = (fit == CubeFit::LeastSquares).then(|| kernel_fit_group(points, cube_table()));
    points
        .iter()
        .enumerate()
        .map(|(p, samples)| {
            // Valve's projection: C_±a = E(±e_a), κ = max(0, ±ω_a) (exact, no table).
            let mut c = [[0.0; 3]; FACES];
            for s in *samples {
                for (face, axis) in ambient_cube::AXES.iter().enumerate() {
                    let k = s.dir.dot(*axis).max(0.0) * s.weight;
                    for ch in 0..3 {
                        c[face][ch] += k * s.radiance[ch];
                    }
                }
            }
            if let Some(upper) = &upper {
                c[..UPPER_FACES].copy_from_slice(&upper[p]);
            }
            c.into_iter().flatten().collect()
        })
        .collect()
}

/// Grid intervals per side of a kernel table (module doc, Kernel tables).
pub const TABLE_RES: usize = 256;

/// A vector-valued function of direction tabulated at the vertices of the octahedral
/// square's grid, read bilinearly.
pub struct KernelTable {
    rows: usize,
    res: usize,
    /// Vertex-major: `rows` values per vertex, (res + 1)² vertices, row v = y index.
    values: Vec<f32>,
}

impl KernelTable {
    /// Tabulates `kernel` (returning `rows` values) at `res` intervals per side.
    pub fn new(rows: usize, res: usize, kernel: impl Fn(DVec3) -> Vec<f64>) -> Self {
        let side = res + 1;
        // Sequential: a table is built inside `OnceLock`s that parallel fits reach, and a
        // rayon worker waiting inside the build could steal a task that waits on it.
        let values: Vec<f32> = (0..side * side)
            .flat_map(|i| {
                let uv = DVec2::new(
                    -1.0 + 2.0 * (i % side) as f64 / res as f64,
                    -1.0 + 2.0 * (i / side) as f64 / res as f64,
                );
                let k = kernel(octahedral_decode(uv));
                assert_eq!(k.len(), rows, "a kernel returns its rows");
                k.into_iter().map(|v| v as f32)
            })
            .collect();
        KernelTable { rows, res, values }
    }

    /// The kernel's rows at unit direction `dir`, bilinearly, into `out`.
    pub fn read(&self, dir: DVec3, out: &mut [f64]) {
        let uv = octahedral_encode(dir);
        let f = (uv + 1.0) * 0.5 * self.res as f64;
        let x0 = (f.x.floor().max(0.0) as usize).min(self.res - 1);
        let y0 = (f.y.floor().max(0.0) as usize).min(self.res - 1);
        let (tx, ty) = (f.x - x0 as f64, f.y - y0 as f64);
        let (rows, side) = (self.rows, self.res + 1);
        let [w00, w10, w01, w11] = [
            (1.0 - tx) * (1.0 - ty),
            tx * (1.0 - ty),
            (1.0 - tx) * ty,
            tx * ty,
        ];
        let tap = |dx: usize, dy: usize| {
            let base = ((y0 + dy) * side + x0 + dx) * rows;
            &self.values[base..base + rows]
        };
        // One pass over the four taps' rows (summed in the taps' order from zero).
        for ((((o, &a), &b), &c), &d) in out[..rows]
            .iter_mut()
            .zip(tap(0, 0))
            .zip(tap(1, 0))
            .zip(tap(0, 1))
            .zip(tap(1, 1))
        {
            *o = w00 * f64::from(a) + w10 * f64::from(b) + w01 * f64::from(c) + w11 * f64::from(d);
        }
    }
}

/// The octahedral square [−1, 1]² of unit `d`.
pub fn octahedral_encode(d: DVec3) -> DVec2 {
    let p = d / (d.x.abs() + d.y.abs() + d.z.abs()).max(1e-300);
    if p.z >= 0.0 {
        DVec2::new(p.x, p.y)
    } else {
        DVec2::new((1.0 - p.y.abs()) * sign(p.x), (1.0 - p.x.abs()) * sign(p.y))
    }
}

/// The unit direction of a point of the octahedral square.
pub fn octahedral_decode(uv: DVec2) -> DVec3 {
    let z = 1.0 - uv.x.abs() - uv.y.abs();
    let (x, y) = if z >= 0.0 {
        (uv.x, uv.y)
    } else {
        (
            (1.0 - uv.y.abs()) * sign(uv.x),
            (1.0 - uv.x.abs()) * sign(uv.y),
        )
    };
    DVec3::new(x, y, z).normalize()
}

fn sign(v: f64) -> f64 {
    if v >= 0.0 { 1.0 } else { -1.0 }
}

fn hbasis_table() -> &'static KernelTable {
    static TABLE: OnceLock<KernelTable> = OnceLock::new();
    TABLE.get_or_init(|| KernelTable::new(6, TABLE_RES, |d| hbasis::irradiance_kernel(d).to_vec()))
}

fn dice_hybrid_table() -> &'static KernelTable {
    static TABLE: OnceLock<KernelTable> = OnceLock::new();
    TABLE.get_or_init(|| {
        KernelTable::new(3 * STORED_VERTICES, TABLE_RES, |d| {
            dice::dice().hybrid_kernel(d)
        })
    })
}

fn dice_linear_table() -> &'static KernelTable {
    static TABLE: OnceLock<KernelTable> = OnceLock::new();
    TABLE.get_or_init(|| {
        KernelTable::new(STORED_VERTICES, TABLE_RES, |d| {
            dice::dice().linear_kernel(d)
        })
    })
}

fn cube_table() -> &'static KernelTable {
    static TABLE: OnceLock<KernelTable> = OnceLock::new();
    TABLE.get_or_init(|| {
        KernelTable::new(UPPER_FACES, TABLE_RES, |d| {
            ambient_cube::least_squares_kernel(d).to_vec()
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::zonal;

    /// Every fit this module makes.
    fn every_fit() -> Vec<SampleFit> {
        let mut fits = vec![
            SampleFit::HBasis(HBasisSize::H4),
            SampleFit::HBasis(HBasisSize::H6),
            SampleFit::Dice(DiceVariant::Rgb),
            SampleFit::Dice(DiceVariant::YCoCg),
            SampleFit::AmbientCube(CubeFit::Projection),
            SampleFit::AmbientCube(CubeFit::LeastSquares),
        ];
        for lobes in [6, 9, 12] {
            for solver in Solver::ALL {
                fits.push(SampleFit::Sg { lobes, solver });
            }
        }
        fits
    }

    /// A spherical Fibonacci set of `n` directions turned off its axis, weights 4π/n.
    fn directions(n: usize) -> Vec<(DVec3, f64)> {
        let turn = glam::DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1);
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        (0..n)
            .map(|r| {
                let z = 1.0 - (2.0 * r as f64 + 1.0) / n as f64;
                let rho = (1.0 - z * z).max(0.0).sqrt();
                let phi = golden * r as f64;
                (
                    turn * DVec3::new(rho * phi.cos(), rho * phi.sin(), z),
                    4.0 * std::f64::consts::PI / n as f64,
                )
            })
            .collect()
    }

    /// Order-3 radiance, positive everywhere.
    fn smooth_sky() -> Vec<[f64; 3]> {
        let mut c = vec![[0.0; 3]; 9];
        c[0] = [2.0, 1.8, 1.5];
        c[1] = [0.2, 0.1, 0.0];
        c[2] = [0.6, 0.5, 0.4];
        c[3] = [-0.3, 0.1, 0.2];
        c[4] = [0.1, 0.1, 0.05];
        c[6] = [0.1; 3];
        c[8] = [-0.1, 0.05, 0.1];
        c
    }

    fn samples_of(radiance: impl Fn(DVec3) -> [f64; 3], n: usize) -> Vec<Sample> {
        directions(n)
            .into_iter()
            .map(|(dir, weight)| Sample {
                dir,
                weight,
                radiance: radiance(dir),
            })
            .collect()
    }

    fn max_difference(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    fn scale(values: &[f64]) -> f64 {
        values
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()))
            .max(1e-300)
    }

    #[test]
    fn samples_that_are_all_zero_fit_to_zero() {
        let samples = samples_of(|_| [0.0; 3], 256);
        for fit in every_fit() {
            let (v, _) = fit.fit(&samples);
            assert_eq!(v.len(), fit.stored_values(), "{fit:?}");
            assert!(v.iter().all(|&x| x == 0.0), "{fit:?}: {v:?}");
        }
        for fit in every_fit() {
            let (v, _) = fit.fit(&[]);
            assert!(v.iter().all(|&x| x == 0.0), "{fit:?} of no samples");
        }
    }

    #[test]
    fn every_fit_scales_linearly_with_a_sun_of_1e5() {
        let sun = DVec3::new(0.3, -0.2, 0.9).normalize();
        let base = |d: DVec3| {
            let s = d.dot(sun).max(0.0).powi(64);
            [0.2 + s, 0.3 + 0.5 * s, 0.25 + 0.2 * s]
        };
        let samples = samples_of(base, 1024);
        let bright: Vec<Sample> = samples
            .iter()
            .map(|s| Sample {
                radiance: s.radiance.map(|v| v * 1e5),
                ..*s
            })
            .collect();
        for fit in every_fit() {
            let (a, _) = fit.fit(&samples);
            let (b, _) = fit.fit(&bright);
            let tol = 1e-9 * scale(&a);
            for (x, y) in a.iter().zip(&b) {
                assert!((y / 1e5 - x).abs() <= tol, "{fit:?}: {x} vs {}", y / 1e5);
            }
        }
    }

    #[test]
    fn one_direction_carrying_all_the_energy_fits_finitely() {
        let mut samples = samples_of(|_| [0.0; 3], 512);
        let k = samples.iter().position(|s| s.dir.z > 0.5).unwrap();
        samples[k].radiance = [1e3, 2e3, 5e2];
        for fit in every_fit() {
            let (v, _) = fit.fit(&samples);
            assert!(v.iter().all(|x| x.is_finite()), "{fit:?}");
            assert!(v.iter().any(|&x| x != 0.0), "{fit:?} saw nothing");
        }
        // The projection cube is that sample's cosine on each face, exactly.
        let (v, _) = SampleFit::AmbientCube(CubeFit::Projection).fit(&samples);
        let s = samples[k];
        for (face, axis) in ambient_cube::AXES.iter().enumerate() {
            let want = s.weight * s.dir.dot(*axis).max(0.0) * s.radiance[0];
            assert!((v[3 * face] - want).abs() <= 1e-12 * want.abs().max(1.0));
        }
    }

    #[test]
    fn nnls_and_the_non_negative_running_average_stay_non_negative() {
        // Light from a narrow band near the horizon and darkness above: the unconstrained
        // fits ring below zero.
        let samples = samples_of(
            |d| {
                if d.z > 0.0 && d.z < 0.15 && d.x > 0.0 {
                    [50.0, 40.0, 30.0]
                } else {
                    [0.0; 3]
                }
            },
            2048,
        );
        for lobes in [6, 9, 12] {
            let (ls, _) = SampleFit::Sg {
                lobes,
                solver: Solver::LeastSquares,
            }
            .fit(&samples);
            assert!(ls.iter().any(|&a| a < 0.0), "least squares rings");
            for solver in [Solver::NonNegative, Solver::RunningAverageNonNegative] {
                let (a, stats) = SampleFit::Sg { lobes, solver }.fit(&samples);
                assert!(a.iter().all(|&v| v >= 0.0), "sg{lobes} {solver}: {a:?}");
                assert_eq!(stats.negative, 0);
            }
        }
    }

    /// The fit from 16k samples of an order-3 radiance agrees with the same fit of that
    /// function made by the `l2` path's quadrature, within the samples' noise.
    #[test]
    fn a_fit_from_samples_matches_the_dense_quadrature_fit() {
        let sky = smooth_sky();
        let eval = |d: DVec3| zonal::eval_rgb(&sky, Order::THREE, d);
        let samples = samples_of(eval, 16384);
        let frame = [DVec3::X, DVec3::Y, DVec3::Z];
        let cases: Vec<(SampleFit, Vec<f64>)> = vec![
            (
                SampleFit::HBasis(HBasisSize::H6),
                hbasis::project_irradiance(&sky, frame, HBasisSize::H6)
                    .into_iter()
                    .flatten()
                    .collect(),
            ),
            (
                SampleFit::Dice(DiceVariant::Rgb),
                dice::dice().project_irradiance(DiceVariant::Rgb, &sky, frame),
            ),
            (
                SampleFit::Dice(DiceVariant::YCoCg),
                dice::dice().project_irradiance(DiceVariant::YCoCg, &sky, frame),
            ),
            (
                SampleFit::AmbientCube(CubeFit::Projection),
                ambient_cube::project_irradiance(&sky, frame, CubeFit::Projection)
                    .into_iter()
                    .flatten()
                    .collect(),
            ),
            (
                SampleFit::AmbientCube(CubeFit::LeastSquares),
                ambient_cube::project_irradiance(&sky, frame, CubeFit::LeastSquares)
                    .into_iter()
                    .flatten()
                    .collect(),
            ),
        ];
        for (fit, want) in cases {
            let (got, _) = fit.fit(&samples);
            let err = max_difference(&got, &want);
            assert!(
                err < 5e-3 * scale(&want),
                "{fit:?}: {err} of {}",
                scale(&want)
            );
        }
        // SG: the nodes see the function on the hemisphere, the samples too.
        for solver in [
            Solver::Projection,
            Solver::LeastSquares,
            Solver::NonNegative,
        ] {
            let basis = crate::sh::sg::shared_basis(9);
            let want: Vec<f64> = {
                let mut stats = FitStats::default();
                let per: [Vec<f64>; 3] = std::array::from_fn(|c| {
                    let l: Vec<f64> = basis.nodes().iter().map(|&(m, _)| eval(m)[c]).collect();
                    basis.fit(&l, solver, &mut stats)
                });
                (0..9)
                    .flat_map(|k| (0..3).map(move |c| (k, c)))
                    .map(|(k, c)| per[c][k])
                    .collect()
            };
            let (got, _) = SampleFit::Sg { lobes: 9, solver }.fit(&samples);
            let err = max_difference(&got, &want);
            assert!(
                err < 2e-2 * scale(&want),
                "sg9 {solver}: {err} of {}",
                scale(&want)
            );
        }
    }

    #[test]
    fn the_kernel_tables_read_the_exact_kernels() {
        let mut worst = 0.0f64;
        let mut k = vec![0.0; 3 * STORED_VERTICES];
        for (d, _) in directions(500) {
            dice_hybrid_table().read(d, &mut k);
            let exact = dice::dice().hybrid_kernel(d);
            worst = worst.max(
                (0..k.len())
                    .map(|i| (k[i] - exact[i]).abs())
                    .fold(0.0, f64::max),
            );
        }
        let scale = directions(500)
            .iter()
            .map(|&(d, _)| scale(&dice::dice().hybrid_kernel(d)))
            .fold(0.0, f64::max);
        assert!(worst < 2e-2 * scale, "{worst} of {scale}");
    }

    #[test]
    fn the_octahedral_map_round_trips() {
        for (d, _) in directions(300) {
            let back = octahedral_decode(octahedral_encode(d));
            assert!((back - d).length() < 1e-12, "{d} → {back}");
        }
    }

    #[test]
    fn sh_projection_of_samples_recovers_an_order_3_function() {
        let sky = smooth_sky();
        let samples = samples_of(|d| zonal::eval_rgb(&sky, Order::THREE, d), 8192);
        let c = project_sh(&samples, Order::THREE);
        for (got, want) in c.iter().zip(&sky) {
            for k in 0..3 {
                assert!((got[k] - want[k]).abs() < 2e-3, "{got:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn basis_fit_names_parse() {
        for b in BasisFit::ALL {
            assert_eq!(b.name().parse::<BasisFit>(), Ok(b));
        }
        assert!("l3".parse::<BasisFit>().is_err());
    }
}
