//! Spherical Gaussian (SG) lightmaps: fixed lobes over a texel's tangent-frame hemisphere,
//! per-texel RGB amplitudes fitted to its incident radiance by one of five solvers, and the
//! diffuse irradiance of the fit at a normal (MJP's "SG Series" and BakingLab; The Order:
//! 1886's lightmaps).
//!
//! # Lobes
//!
//! G(ω; μ, λ) = e^{λ(μ·ω − 1)}. N lobes (5, 6, 9 or 12) over the hemisphere z ≥ 0 of the
//! tangent frame: axes on a spherical Fibonacci spiral, uniform in area (z_k = 1 − (k + ½)/N,
//! φ_k = k · golden angle), all of sharpness λ = N ln 2, so that a lobe falls to one half at
//! the edge of the cap of area 2π/N it stands for (1 − cos θ = 1/N). Over the hemisphere,
//! not the sphere: a lightmap texel's radiance is zero below its horizon (the bake gathers
//! n_g·ω > 0) and its normal-mapped normals look above it, so lobes below would store
//! nothing.
//!
//! # Fitting (per texel, per colour; `Solver`)
//!
//! The target is the texel's incident radiance L on the Q nodes ω_q (weights w_q) of a
//! hemisphere rule (`sh::hbasis::hemisphere_quadrature`), with G_qk = G_k(ω_q):
//!
//! ```text
//! projection       a_k = Σ_q w_q L_q G_qk / Σ_q w_q G_qk        (a lobe-weighted average)
//! least squares    a = argmin Σ_q w_q (Σ_k a_k G_qk − L_q)²     (SVD pseudo-inverse, f64)
//! NNLS             the same with a ≥ 0                           (Lawson–Hanson)
//! running average  passes over the nodes in scrambled order: for each, every lobe moves its
//!                  amplitude toward the value that would explain the node given the other
//!                  lobes, (L_q − Σ_{j≠k} a_j G_qj) G_qk / ⟨G_k²⟩, by the node's share of the
//!                  weight so far (MJP's progressive fit, meant for a path tracer's stream
//!                  of samples; ⟨G_k²⟩, which it estimates as it goes, is known here —
//!                  estimated, its first steps are large enough to diverge on these lobes)
//! running ≥ 0      the same, amplitudes clamped at 0 after each update
//! ```
//!
//! The least-squares system is the same for every texel (lobes and nodes are fixed in
//! tangent space), so its pseudo-inverse is computed once by SVD with singular values below
//! 10⁻¹⁰ of the largest dropped: 12 lobes of λ = 8.3 overlap little and are well
//! conditioned, but the solve stays stable whatever the lobes. Negative amplitudes of the
//! unconstrained fits are counted ([`FitStats`]).
//!
//! # Fitting from samples ([`SgBasis::fit_samples`])
//!
//! The same five solvers on a texel's radiance samples (directions ω_s, solid-angle weights
//! w_s, those with z > 0) in place of the nodes: projection and the normal equations
//! H = Σ_s w_s G_s G_sᵀ, c = Σ_s w_s G_s L_s are the sums above over the samples; least
//! squares solves H a = c by SVD (singular values below 10⁻¹⁰ of the largest dropped), NNLS
//! runs on the same H and c; the running average makes one pass over the samples in a fixed
//! scrambled order (a stride coprime to their count), as a path tracer's stream would,
//! with ⟨G_k²⟩ from the hemisphere rule.
//!
//! # Diffuse evaluation
//!
//! E(n) = Σ_k a_k ∫ G_k(ω) max(0, n·ω) dω, each term by Hill's fitted approximation of the
//! SG–clamped-cosine product (MJP, "SG Series Part 3", `SGIrradianceFitted`): with
//! t = μ·n, e = e^{−λ}, s = 1 + 2e² − 1/λ, b = (e − e²)/λ − e², x = √(1 − s),
//! u = 0.36 t + x/(4·0.36), y = u²/x where |0.36 t| ≤ x/(4·0.36), else max(0, t):
//! ∫ G max(0, n·ω) dω ≈ (s y + b) · 2π(1 − e^{−2λ})/λ. A test compares it with quadrature.

use glam::DVec3;

use super::hbasis::hemisphere_quadrature;

/// How amplitudes are fitted (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Solver {
    Projection,
    LeastSquares,
    NonNegative,
    RunningAverage,
    RunningAverageNonNegative,
}

impl Solver {
    pub const ALL: [Solver; 5] = [
        Solver::Projection,
        Solver::LeastSquares,
        Solver::NonNegative,
        Solver::RunningAverage,
        Solver::RunningAverageNonNegative,
    ];

    /// The CLI name (`--sg-solve`).
    pub fn name(self) -> &'static str {
        match self {
            Solver::Projection => "projection",
            Solver::LeastSquares => "ls",
            Solver::NonNegative => "nnls",
            Solver::RunningAverage => "running",
            Solver::RunningAverageNonNegative => "running-nn",
        }
    }
}

impl std::fmt::Display for Solver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Solver {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Solver::ALL
            .into_iter()
            .find(|v| v.name() == s)
            .ok_or_else(|| {
                let known: Vec<&str> = Solver::ALL.iter().map(|v| v.name()).collect();
                format!("unknown SG solver '{s}'; known: {}", known.join(", "))
            })
    }
}

/// The solver `--sg-solve` defaults to: the best of `shvis study bases`' SG rows fitted from
/// the pixels, on average over the built-in skies and the shared probes (the one-pass
/// running average from samples diverges on some of them).
pub const DEFAULT_SOLVER: Solver = Solver::LeastSquares;

impl Default for Solver {
    fn default() -> Solver {
        DEFAULT_SOLVER
    }
}

/// Passes of the running average over the fitting nodes.
pub const RUNNING_PASSES: usize = 8;
/// A lobe whose mean of G² is below this takes no update (as MJP's guard).
const RUNNING_MIN_WEIGHT: f64 = 1e-5;

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// Lobe counts an `sgN` name may take.
pub const LOBE_COUNTS: [usize; 4] = [5, 6, 9, 12];

/// Gauss–Legendre nodes per unit of z of the fitting rule: 8 × 16 = 128 nodes.
pub const FIT_N: usize = 8;

/// The basis of `n` lobes, built once per n and shared.
pub fn shared_basis(n: usize) -> std::sync::Arc<SgBasis> {
    static BASES: std::sync::Mutex<Vec<std::sync::Arc<SgBasis>>> =
        std::sync::Mutex::new(Vec::new());
    let mut bases = BASES.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(b) = bases.iter().find(|b| b.len() == n) {
        return b.clone();
    }
    let b = std::sync::Arc::new(SgBasis::new(n));
    bases.push(b.clone());
    b
}

/// N fixed lobes and everything the solvers precompute for them (module doc).
#[derive(Clone, Debug)]
pub struct SgBasis {
    pub axes: Vec<DVec3>,
    pub sharpness: f64,
    /// Fitting nodes (tangent space) and weights.
    nodes: Vec<(DVec3, f64)>,
    /// G_qk, node-major.
    g: Vec<f64>,
    /// The least-squares pseudo-inverse P (N × Q): a = P L.
    pinv: Vec<f64>,
}

/// What a fit did: amplitudes the unconstrained solvers made negative.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FitStats {
    pub amplitudes: u64,
    pub negative: u64,
}

impl SgBasis {
    /// The basis of `n` lobes (any n ≥ 1; the techniques use [`LOBE_COUNTS`]).
    pub fn new(n: usize) -> SgBasis {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let axes: Vec<DVec3> = (0..n)
            .map(|k| {
                let z = 1.0 - (k as f64 + 0.5) / n as f64;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = golden * k as f64;
                DVec3::new(r * phi.cos(), r * phi.sin(), z)
            })
            .collect();
        let sharpness = n as f64 * std::f64::consts::LN_2;
        let nodes = hemisphere_quadrature(FIT_N);
        let g: Vec<f64> = nodes
            .iter()
            .flat_map(|&(d, _)| axes.iter().map(move |&mu| lobe(mu, sharpness, d)))
            .collect();
        // Weighted least squares: minimise ‖W^½ (G a − L)‖, a = (W^½ G)⁺ W^½ L.
        let q = nodes.len();
        let mut wg = nalgebra::DMatrix::<f64>::zeros(q, n);
        for (i, &(_, w)) in nodes.iter().enumerate() {
            for k in 0..n {
                wg[(i, k)] = w.sqrt() * g[i * n + k];
            }
        }
        let svd = wg.svd(true, true);
        let largest = svd.singular_values.max();
        let pinv_w = svd
            .pseudo_inverse(1e-10 * largest)
            .expect("the SVD was computed with U and V");
        let mut pinv = vec![0.0; n * q];
        for k in 0..n {
            for (i, &(_, w)) in nodes.iter().enumerate() {
                pinv[k * q + i] = pinv_w[(k, i)] * w.sqrt();
            }
        }
        SgBasis {
            axes,
            sharpness,
            nodes,
            g,
            pinv,
        }
    }

    /// Lobes.
    pub fn len(&self) -> usize {
        self.axes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.axes.is_empty()
    }

    /// The fitting nodes (tangent space) and weights.
    pub fn nodes(&self) -> &[(DVec3, f64)] {
        &self.nodes
    }

    /// Amplitudes (one per lobe) fitting `radiance` given at [`Self::nodes`], one colour.
    pub fn fit(&self, radiance: &[f64], solver: Solver, stats: &mut FitStats) -> Vec<f64> {
        let (n, q) = (self.len(), self.nodes.len());
        assert_eq!(radiance.len(), q, "one radiance value per node");
        let a = match solver {
            Solver::Projection => (0..n)
                .map(|k| {
                    let (mut num, mut den) = (0.0, 0.0);
                    for (i, &(_, w)) in self.nodes.iter().enumerate() {
                        num += w * radiance[i] * self.g[i * n + k];
                        den += w * self.g[i * n + k];
                    }
                    if den > 0.0 { num / den } else { 0.0 }
                })
                .collect(),
            Solver::LeastSquares => self.least_squares(radiance),
            Solver::NonNegative => self.nnls(radiance),
            Solver::RunningAverage => self.running_average(radiance, false),
            Solver::RunningAverageNonNegative => self.running_average(radiance, true),
        };
        stats.amplitudes += n as u64;
        stats.negative += a.iter().filter(|&&v| v < 0.0).count() as u64;
        a
    }

    fn least_squares(&self, radiance: &[f64]) -> Vec<f64> {
        let q = self.nodes.len();
        (0..self.len())
            .map(|k| {
                self.pinv[k * q..(k + 1) * q]
                    .iter()
                    .zip(radiance)
                    .map(|(p, l)| p * l)
                    .sum()
            })
            .collect()
    }

    /// Lawson–Hanson active-set NNLS on the weighted system (module doc).
    fn nnls(&self, radiance: &[f64]) -> Vec<f64> {
        let n = self.len();
        let w: Vec<f64> = self.nodes.iter().map(|&(_, w)| w).collect();
        // Normal equations in f64: H = Gᵀ W G, c = Gᵀ W L; NNLS on ½aᵀHa − cᵀa.
        let h = normal_matrix(&self.g, &w, n);
        let c = normal_rhs(&self.g, &w, radiance, n);
        nnls_normal(&h, &c, n)
    }

    fn running_average(&self, radiance: &[f64], non_negative: bool) -> Vec<f64> {
        let w: Vec<f64> = self.nodes.iter().map(|&(_, w)| w).collect();
        running_average(
            &self.g,
            &w,
            radiance,
            self.mean_g2(),
            RUNNING_PASSES,
            non_negative,
        )
    }

    /// Amplitudes (RGB, one per lobe) fitting radiance samples: unit tangent-space
    /// directions `dirs`, solid-angle weights `weights`, RGB `radiance` (module doc, Fitting
    /// from samples). Samples at z ≤ 0 are left out (the lobes cover the upper hemisphere).
    ///
    /// # Panics
    /// If the three slices differ in length (a bug of the caller).
    pub fn fit_samples(
        &self,
        dirs: &[DVec3],
        weights: &[f64],
        radiance: &[[f64; 3]],
        solver: Solver,
        stats: &mut FitStats,
    ) -> Vec<[f64; 3]> {
        self.sample_design(dirs, weights, solver)
            .fit(radiance, stats)
    }

    /// What [`SgBasis::fit_samples`] computes from the directions and weights alone, for
    /// fitting any radiance at them ([`SampleDesign::fit`]): points whose samples share
    /// directions and weights (texels or pixels of one flat surface) share it.
    pub fn sample_design(
        &self,
        dirs: &[DVec3],
        weights: &[f64],
        solver: Solver,
    ) -> SampleDesign<'_> {
        assert_eq!(dirs.len(), weights.len(), "one weight per direction");
        let n = self.len();
        let upper: Vec<usize> = (0..dirs.len()).filter(|&s| dirs[s].z > 0.0).collect();
        let g: Vec<f64> = upper
            .iter()
            .flat_map(|&s| {
                self.axes
                    .iter()
                    .map(move |&mu| lobe(mu, self.sharpness, dirs[s]))
            })
            .collect();
        let w: Vec<f64> = upper.iter().map(|&s| weights[s]).collect();
        let (h, svd) = match solver {
            Solver::LeastSquares | Solver::NonNegative => {
                let h = normal_matrix(&g, &w, n);
                let svd = (solver == Solver::LeastSquares).then(|| {
                    let svd = nalgebra::DMatrix::from_row_slice(n, n, &h).svd(true, true);
                    let tol = 1e-10 * svd.singular_values.max();
                    (svd, tol)
                });
                (h, svd)
            }
            _ => (Vec::new(), None),
        };
        SampleDesign {
            basis: self,
            samples: dirs.len(),
            solver,
            upper,
            g,
            w,
            h,
            svd,
        }
    }

    /// Each lobe's mean of G² over the hemisphere (by the fitting rule).
    fn mean_g2(&self) -> Vec<f64> {
        let n = self.len();
        let area: f64 = self.nodes.iter().map(|&(_, w)| w).sum();
        (0..n)
            .map(|k| {
                self.nodes
                    .iter()
                    .enumerate()
                    .map(|(i, &(_, w))| w * self.g[i * n + k].powi(2))
                    .sum::<f64>()
                    / area
            })
            .collect()
    }

    /// Σ_k a_k G_k(m) at tangent-space `m`, one colour.
    pub fn radiance(&self, amplitudes: &[f64], m: DVec3) -> f64 {
        self.axes
            .iter()
            .zip(amplitudes)
            .map(|(&mu, a)| a * lobe(mu, self.sharpness, m))
            .sum()
    }

    /// E(n) = Σ_k a_k · (Hill's fitted SG–cosine integral) at tangent-space normal `n`
    /// (module doc), one colour.
    pub fn irradiance(&self, amplitudes: &[f64], n: DVec3) -> f64 {
        self.axes
            .iter()
            .zip(amplitudes)
            .map(|(&mu, a)| a * cosine_integral_fitted(mu.dot(n), self.sharpness))
            .sum()
    }
}

/// The samples' side of a fit from samples ([`SgBasis::sample_design`]): the upper
/// samples' lobe values and weights and, for the least-squares solvers, the normal matrix
/// (and its SVD).
pub struct SampleDesign<'a> {
    basis: &'a SgBasis,
    samples: usize,
    solver: Solver,
    upper: Vec<usize>,
    g: Vec<f64>,
    w: Vec<f64>,
    h: Vec<f64>,
    svd: Option<(nalgebra::SVD<f64, nalgebra::Dyn, nalgebra::Dyn>, f64)>,
}

impl SampleDesign<'_> {
    /// [`SgBasis::fit_samples`] of `radiance` at the design's samples.
    ///
    /// # Panics
    /// If `radiance` has not one value per sample (a bug of the caller).
    pub fn fit(&self, radiance: &[[f64; 3]], stats: &mut FitStats) -> Vec<[f64; 3]> {
        assert_eq!(radiance.len(), self.samples, "one radiance per sample");
        let (g, w) = (&self.g, &self.w);
        let n = self.basis.len();
        let l: Vec<[f64; 3]> = self.upper.iter().map(|&s| radiance[s]).collect();
        let channel = |c: usize| -> Vec<f64> { l.iter().map(|v| v[c]).collect() };
        let per_colour: [Vec<f64>; 3] = match self.solver {
            Solver::Projection => std::array::from_fn(|c| {
                let lc = channel(c);
                (0..n)
                    .map(|k| {
                        let (mut num, mut den) = (0.0, 0.0);
                        for (i, &wi) in w.iter().enumerate() {
                            num += wi * lc[i] * g[i * n + k];
                            den += wi * g[i * n + k];
                        }
                        if den > 0.0 { num / den } else { 0.0 }
                    })
                    .collect()
            }),
            Solver::LeastSquares | Solver::NonNegative => {
                let rhs: [Vec<f64>; 3] = std::array::from_fn(|c| normal_rhs(g, w, &channel(c), n));
                match &self.svd {
                    None => rhs.map(|c| nnls_normal(&self.h, &c, n)),
                    Some((svd, tol)) => rhs.map(|c| {
                        svd.solve(&nalgebra::DVector::from_vec(c), *tol)
                            .map(|a| a.iter().copied().collect())
                            .unwrap_or_else(|_| vec![0.0; n])
                    }),
                }
            }
            Solver::RunningAverage | Solver::RunningAverageNonNegative => {
                let non_negative = self.solver == Solver::RunningAverageNonNegative;
                std::array::from_fn(|c| {
                    running_average(g, w, &channel(c), self.basis.mean_g2(), 1, non_negative)
                })
            }
        };
        stats.amplitudes += 3 * n as u64;
        stats.negative += per_colour.iter().flatten().filter(|&&v| v < 0.0).count() as u64;
        (0..n)
            .map(|k| std::array::from_fn(|c| per_colour[c][k]))
            .collect()
    }
}

/// H = Gᵀ W G (n × n, row-major) of the lobe values `g` (sample-major, n per sample).
fn normal_matrix(g: &[f64], w: &[f64], n: usize) -> Vec<f64> {
    let mut h = vec![0.0; n * n];
    for (i, &wi) in w.iter().enumerate() {
        let row = &g[i * n..(i + 1) * n];
        for k in 0..n {
            for j in 0..n {
                h[k * n + j] += wi * row[k] * row[j];
            }
        }
    }
    h
}

/// c = Gᵀ W L.
fn normal_rhs(g: &[f64], w: &[f64], radiance: &[f64], n: usize) -> Vec<f64> {
    let mut c = vec![0.0; n];
    for (i, (&wi, &l)) in w.iter().zip(radiance).enumerate() {
        for k in 0..n {
            c[k] += wi * g[i * n + k] * l;
        }
    }
    c
}

/// The running average (module doc) over samples with lobe values `g` (sample-major, n
/// per sample), weights `w` and one colour's `radiance`, `passes` times over in a fixed
/// scrambled order (a stride coprime to the count).
fn running_average(
    g: &[f64],
    w: &[f64],
    radiance: &[f64],
    mean_g2: Vec<f64>,
    passes: usize,
    non_negative: bool,
) -> Vec<f64> {
    let n = mean_g2.len();
    let q = w.len();
    let mut a = vec![0.0; n];
    if q == 0 {
        return a;
    }
    let mut total = 0.0;
    // The progressive fit expects samples in random order: they are visited with a stride
    // coprime to their count (a fixed scramble).
    let stride = (0..q)
        .map(|s| (q * 5 / 8 + s) | 1)
        .find(|&s| gcd(s, q) == 1)
        .unwrap_or(1);
    for step in 0..passes * q {
        let i = (step * stride) % q;
        let wi = w[i];
        if wi <= 0.0 {
            continue;
        }
        total += wi;
        let gi = &g[i * n..(i + 1) * n];
        let estimate: f64 = a.iter().zip(gi).map(|(a, g)| a * g).sum();
        for k in 0..n {
            if mean_g2[k] < RUNNING_MIN_WEIGHT {
                continue;
            }
            // The value this sample asks of lobe k given the others' current
            // contribution, averaged in with the sample's share of the weight so far.
            let others = estimate - a[k] * gi[k];
            let wanted = (radiance[i] - others) * gi[k] / mean_g2[k];
            a[k] += (wanted - a[k]) * wi / total;
            if non_negative {
                a[k] = a[k].max(0.0);
            }
        }
    }
    a
}

/// G(d; μ, λ).
pub fn lobe(mu: DVec3, sharpness: f64, d: DVec3) -> f64 {
    (sharpness * (mu.dot(d) - 1.0)).exp()
}

/// ∫ G(ω; μ, λ) dω over the sphere: 2π(1 − e^{−2λ})/λ.
pub fn lobe_integral(sharpness: f64) -> f64 {
    2.0 * std::f64::consts::PI * (1.0 - (-2.0 * sharpness).exp()) / sharpness
}

/// Hill's fitted ∫ G(ω; μ, λ) max(0, n·ω) dω for t = μ·n (module doc).
pub fn cosine_integral_fitted(t: f64, sharpness: f64) -> f64 {
    const C0: f64 = 0.36;
    const C1: f64 = 1.0 / (4.0 * C0);
    let e = (-sharpness).exp();
    let e2 = e * e;
    let r = 1.0 / sharpness;
    let scale = 1.0 + 2.0 * e2 - r;
    let bias = (e - e2) * r - e2;
    let x = (1.0 - scale).max(0.0).sqrt();
    let x0 = C0 * t;
    let x1 = C1 * x;
    let y = if x0.abs() <= x1 {
        let u = x0 + x1;
        u * u / x
    } else {
        t.clamp(0.0, 1.0)
    };
    (scale * y + bias) * lobe_integral(sharpness)
}

/// NNLS min ½aᵀHa − cᵀa, a ≥ 0, for symmetric positive semi-definite H (n × n, row-major):
/// Lawson and Hanson's active-set method on the normal equations, at most 3n outer steps.
pub fn nnls_normal(h: &[f64], c: &[f64], n: usize) -> Vec<f64> {
    let mut a = vec![0.0; n];
    let mut passive = vec![false; n];
    let tolerance = 1e-12 * c.iter().map(|v| v.abs()).fold(0.0, f64::max).max(1e-300);
    for _ in 0..3 * n {
        // Gradient of the objective's negative: c − H a.
        let grad: Vec<f64> = (0..n)
            .map(|k| c[k] - (0..n).map(|j| h[k * n + j] * a[j]).sum::<f64>())
            .collect();
        let Some((best, &g)) = grad
            .iter()
            .enumerate()
            .filter(|(k, _)| !passive[*k])
            .max_by(|x, y| x.1.total_cmp(y.1))
        else {
            break;
        };
        if g <= tolerance {
            break;
        }
        passive[best] = true;
        // Inner loop: solve on the passive set, step back while a variable would go negative.
        loop {
            let set: Vec<usize> = (0..n).filter(|&k| passive[k]).collect();
            let z = solve_subset(h, c, n, &set);
            if set.iter().zip(&z).all(|(_, &v)| v > 0.0) {
                a = vec![0.0; n];
                for (&k, &v) in set.iter().zip(&z) {
                    a[k] = v;
                }
                break;
            }
            // Move from a toward z as far as feasibility allows, drop what hits zero.
            let mut alpha = f64::INFINITY;
            for (&k, &v) in set.iter().zip(&z) {
                if v <= 0.0 {
                    alpha = alpha.min(a[k] / (a[k] - v));
                }
            }
            for (&k, &v) in set.iter().zip(&z) {
                a[k] += alpha * (v - a[k]);
                if a[k] <= 1e-15 * (1.0 + v.abs()) {
                    a[k] = 0.0;
                    passive[k] = false;
                }
            }
            if !passive.iter().any(|&p| p) {
                break;
            }
        }
    }
    a
}

/// The solution of H_SS z = c_S on the index set S (Cholesky-free: a small LU via nalgebra).
fn solve_subset(h: &[f64], c: &[f64], n: usize, set: &[usize]) -> Vec<f64> {
    let m = set.len();
    let hs = nalgebra::DMatrix::from_fn(m, m, |i, j| h[set[i] * n + set[j]]);
    let cs = nalgebra::DVector::from_fn(m, |i, _| c[set[i]]);
    match hs.clone().lu().solve(&cs) {
        Some(z) => z.iter().copied().collect(),
        // Singular on this set: the least-squares solution instead.
        None => {
            let svd = hs.svd(true, true);
            let tol = 1e-12 * svd.singular_values.max();
            svd.solve(&cs, tol)
                .map(|z| z.iter().copied().collect())
                .unwrap_or_else(|_| vec![0.0; m])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fitted_cosine_integral_is_close_to_quadrature() {
        let rule = crate::sh::project::sphere_quadrature(96);
        for sharpness in [2.0, 6.2, 8.3] {
            for t in [-1.0, -0.5, 0.0, 0.3, 0.7, 1.0] {
                let mu = DVec3::new((1.0f64 - t * t).sqrt(), 0.0, t);
                let exact: f64 = rule
                    .iter()
                    .map(|&(d, w)| w * lobe(mu, sharpness, d) * d.z.max(0.0))
                    .sum();
                let fitted = cosine_integral_fitted(t, sharpness);
                let peak = cosine_integral_fitted(1.0, sharpness);
                assert!(
                    (fitted - exact).abs() < 0.05 * peak,
                    "λ {sharpness} t {t}: {fitted} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn nnls_matches_brute_force_on_small_cases() {
        // Every subset's unconstrained optimum, kept if feasible; the best is the NNLS one.
        let cases: [(&[f64], &[f64]); 3] = [
            (
                &[2.0, 0.5, 0.0, 0.5, 1.0, 0.2, 0.0, 0.2, 1.5],
                &[1.0, -1.0, 0.5],
            ),
            (
                &[1.0, 0.9, 0.1, 0.9, 1.0, 0.2, 0.1, 0.2, 1.0],
                &[0.3, 0.8, -0.2],
            ),
            (
                &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
                &[-1.0, -2.0, -3.0],
            ),
        ];
        for (h, c) in cases {
            let n = 3;
            let objective = |a: &[f64]| -> f64 {
                let mut v = 0.0;
                for k in 0..n {
                    v -= c[k] * a[k];
                    for j in 0..n {
                        v += 0.5 * a[k] * h[k * n + j] * a[j];
                    }
                }
                v
            };
            let mut best = (objective(&[0.0; 3]), vec![0.0; 3]);
            for mask in 1..8u32 {
                let set: Vec<usize> = (0..n).filter(|k| mask & (1 << k) != 0).collect();
                let z = solve_subset(h, c, n, &set);
                if z.iter().all(|&v| v >= 0.0) {
                    let mut a = vec![0.0; n];
                    for (&k, &v) in set.iter().zip(&z) {
                        a[k] = v;
                    }
                    let o = objective(&a);
                    if o < best.0 {
                        best = (o, a);
                    }
                }
            }
            let got = nnls_normal(h, c, n);
            assert!(got.iter().all(|&v| v >= 0.0), "{got:?}");
            assert!(
                (objective(&got) - best.0).abs() < 1e-12,
                "{got:?} vs {:?}",
                best.1
            );
        }
    }

    #[test]
    fn each_solver_fits_a_lobe_of_the_basis_and_least_squares_beats_the_others() {
        let basis = SgBasis::new(9);
        // Radiance that is exactly 2 × lobe 3 + 0.5 × lobe 7: least squares recovers it.
        let target: Vec<f64> = basis
            .nodes()
            .iter()
            .map(|&(d, _)| {
                2.0 * lobe(basis.axes[3], basis.sharpness, d)
                    + 0.5 * lobe(basis.axes[7], basis.sharpness, d)
            })
            .collect();
        let mut stats = FitStats::default();
        let ls = basis.fit(&target, Solver::LeastSquares, &mut stats);
        for (k, a) in ls.iter().enumerate() {
            let want = match k {
                3 => 2.0,
                7 => 0.5,
                _ => 0.0,
            };
            assert!((a - want).abs() < 1e-8, "lobe {k}: {a}");
        }
        let nn = basis.fit(&target, Solver::NonNegative, &mut stats);
        for (a, b) in nn.iter().zip(&ls) {
            assert!((a - b).abs() < 1e-6 && *a >= 0.0, "{nn:?}");
        }
        // Weighted squared error of each fit: least squares is the smallest by definition.
        let error = |a: &[f64]| -> f64 {
            basis
                .nodes()
                .iter()
                .zip(&target)
                .map(|(&(d, w), l)| w * (basis.radiance(a, d) - l).powi(2))
                .sum()
        };
        for solver in Solver::ALL {
            let a = basis.fit(&target, solver, &mut stats);
            assert!(a.iter().all(|v| v.is_finite()), "{solver:?}");
            assert!(error(&a) >= error(&ls) - 1e-12, "{solver:?}");
        }
    }

    #[test]
    fn hard_cases() {
        let basis = SgBasis::new(12);
        let mut stats = FitStats::default();
        // A black texel: every solver gives zeros.
        let black = vec![0.0; basis.nodes().len()];
        for solver in Solver::ALL {
            assert!(
                basis
                    .fit(&black, solver, &mut stats)
                    .iter()
                    .all(|&a| a == 0.0)
            );
        }
        // One direction exactly between two lobes (a narrow lobe there), a sun of 1e5: the
        // fit scales linearly (least squares) and stays non-negative where it must.
        let between = (basis.axes[0] + basis.axes[1]).normalize();
        let sun: Vec<f64> = basis
            .nodes()
            .iter()
            .map(|&(d, _)| 1e5 * lobe(between, 60.0, d))
            .collect();
        let unit: Vec<f64> = sun.iter().map(|v| v / 1e5).collect();
        let a = basis.fit(&sun, Solver::LeastSquares, &mut stats);
        let b = basis.fit(&unit, Solver::LeastSquares, &mut stats);
        for (x, y) in a.iter().zip(&b) {
            assert!((x - 1e5 * y).abs() <= 1e-6 * (1.0 + x.abs()));
        }
        // The unconstrained fit of a narrow light rings negative somewhere; NNLS and the
        // clamped running average do not.
        let mut counted = FitStats::default();
        let _ = basis.fit(&unit, Solver::LeastSquares, &mut counted);
        assert!(counted.negative > 0, "{counted:?}");
        for solver in [Solver::NonNegative, Solver::RunningAverageNonNegative] {
            assert!(
                basis
                    .fit(&unit, solver, &mut stats)
                    .iter()
                    .all(|&a| a >= 0.0)
            );
        }
        // The lobe nearest the light gets the largest amplitude.
        let nn = basis.fit(&unit, Solver::NonNegative, &mut stats);
        let largest = (0..basis.len())
            .max_by(|&i, &j| nn[i].total_cmp(&nn[j]))
            .unwrap();
        let nearest = (0..basis.len())
            .max_by(|&i, &j| {
                basis.axes[i]
                    .dot(between)
                    .total_cmp(&basis.axes[j].dot(between))
            })
            .unwrap();
        let tie = basis.axes[largest].dot(between) >= basis.axes[nearest].dot(between) - 1e-9;
        assert!(largest == nearest || tie, "{nn:?}");
    }
}
