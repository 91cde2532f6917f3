//! PCA compression of the baked SH visibility, the per-texel data of the `pca*`
//! techniques (Iwanicki–Sloan §4; quantization after Sloan's PRT course notes, "Quantize
//! PCA coefficients").
//!
//! # What PCA does here
//!
//! Each covered texel holds an order-O visibility vector V(x) ∈ ℝⁿ, n = O² (n = 36 for
//! order 6, [`super::visibility`]). PCA replaces it by a mean and M ≪ n basis vectors
//! shared by the whole lightmap, and M weights per texel (Iwanicki–Sloan eq. (5)):
//!
//! ```text
//! V(x) ≈ V_e + Σ_{k<M} w_k(x) V_k,   w_k(x) = V_k · (V(x) − V_e)                    (5)
//! I    = Σ_k w_k(x) ∫ L V_k H  +  ∫ L V_e H                                        (6)
//! ```
//!
//! so a renderer needs M + 1 `L × V_k × H` tables (or M + 1 products V_k·L) instead of
//! n coefficients per texel. V_e is the mean over covered texels and the V_k are the
//! eigenvectors of the covariance C = (1/N) Σ (V − V_e)(V − V_e)ᵀ over the N covered
//! texels (f64), by decreasing eigenvalue λ_k: the M-dimensional affine subspace that
//! minimises the mean squared coefficient error. Since the SH basis is orthonormal, that
//! coefficient L2 error is the L2 error of the visibility function over the sphere.
//!
//! Conventions: eigenvalues are clamped to ≥ 0 (round-off makes zero ones slightly
//! negative); each eigenvector's largest-magnitude component (first such on a tie) is
//! positive, so a fit is deterministic. Weights are stored as f32 for every texel that is
//! covered or has a non-zero coefficient (the dilated gutters: averages of covered
//! texels, so their weights stay inside the covered range); texels further out get
//! weight 0 (they reconstruct to V_e and are never sampled).
//!
//! # Energy captured
//!
//! [`PcaModel::energy_captured`]`(M)` = Σ_{k<M} λ_k / Σ_k λ_k is the fraction of the
//! covered texels' variance about V_e that M vectors keep; the mean squared coefficient
//! error of the fit is exactly Σ_{k≥M} λ_k (up to the f32 weights). Zero variance counts
//! as fully captured (1.0).
//!
//! # Quantization
//!
//! Per basis vector k the weights span [lo_k, hi_k] (over every stored texel). They are
//! stored as b-bit UNORM
//!
//! ```text
//! q_k = round((w_k − lo_k) / (hi_k − lo_k) · (2^b − 1)),   u_k = q_k / (2^b − 1) ∈ [0, 1]
//! V  ≈ V_e' + Σ_k u_k V_k',   V_e' = V_e + Σ_k lo_k V_k,   V_k' = (hi_k − lo_k) V_k
//! ```
//!
//! i.e. the scale and offset are pushed into the basis and mean, which stay in full
//! precision (the course's "scale the basis vector by the inverse"), and the texture is a
//! plain UNORM fetch. A basis with hi_k = lo_k gets scale 0 and u = 0. Rounding moves
//! each weight by at most half an LSB, (hi_k − lo_k) / (2(2^b − 1)); the basis is
//! orthonormal, so a texel's reconstruction moves by at most
//! ‖δ‖ ≤ √(Σ_k (hi_k − lo_k)²) / (2(2^b − 1)) ([`QuantizedPca::error_bound`]).

use nalgebra::DMatrix;

use super::BakeError;
use super::visibility::VisibilityMap;
use crate::sh::Order;

/// A PCA fit of a visibility lightmap (module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct PcaModel {
    /// Visibility order (n = order² coefficients).
    pub order: Order,
    /// n: the mean V_e of eq. (5) over covered texels.
    pub mean: Vec<f64>,
    /// M orthonormal vectors of n, by decreasing eigenvalue.
    pub basis: Vec<Vec<f64>>,
    /// All n covariance eigenvalues, decreasing, clamped ≥ 0.
    pub eigenvalues: Vec<f64>,
    /// Texel-major, M per texel (row-major y·res + x); 0 for uncovered all-zero texels.
    pub weights: Vec<f32>,
    /// Texels per side.
    pub res: u32,
}

/// Fits the mean and the `m` leading principal vectors of `vis`'s covered texels and
/// projects every covered or gutter texel (module doc).
///
/// # Errors
/// [`BakeError::PcaBasisOutOfRange`] unless 1 ≤ m ≤ order²;
/// [`BakeError::EmptyLightmap`] when no texel is covered.
pub fn fit(vis: &VisibilityMap, m: usize) -> Result<PcaModel, BakeError> {
    let n = vis.order.coeff_count();
    if m == 0 || m > n {
        return Err(BakeError::PcaBasisOutOfRange { m, n });
    }
    let texels = (vis.res as usize).pow(2);
    let covered: Vec<usize> = (0..texels).filter(|&t| vis.covered[t]).collect();
    if covered.is_empty() {
        return Err(BakeError::EmptyLightmap);
    }
    let (mean, eigenvalues, mut basis) =
        principal_subspace(covered.iter().map(|&t| vis.texel(t)), n);
    basis.truncate(m);
    let weights = project_weights(&vis.covered, |t| vis.texel(t), &mean, &basis);
    Ok(PcaModel {
        order: vis.order,
        mean,
        basis,
        eigenvalues,
        weights,
        res: vis.res,
    })
}

/// The mean, the covariance eigenvalues (decreasing, clamped ≥ 0) and all n eigenvectors
/// (module doc's conventions: sorted by decreasing eigenvalue, signs fixed) of `vectors`,
/// each of `n` values, accumulated in f64 in the order given — so a fit is deterministic
/// for a given order of its vectors. No vectors: a zero mean and zero eigenvalues.
pub(crate) fn principal_subspace<'a>(
    vectors: impl Iterator<Item = &'a [f32]> + Clone,
    n: usize,
) -> (Vec<f64>, Vec<f64>, Vec<Vec<f64>>) {
    // Two passes: the mean, then the centred covariance (upper triangle, mirrored).
    let mut mean = vec![0.0f64; n];
    let mut count = 0usize;
    for v in vectors.clone() {
        for (acc, &c) in mean.iter_mut().zip(v) {
            *acc += f64::from(c);
        }
        count += 1;
    }
    let count = count.max(1) as f64;
    mean.iter_mut().for_each(|v| *v /= count);
    let mut cov = DMatrix::<f64>::zeros(n, n);
    let mut d = vec![0.0f64; n];
    for v in vectors {
        for ((d, &c), &mu) in d.iter_mut().zip(v).zip(&mean) {
            *d = f64::from(c) - mu;
        }
        for i in 0..n {
            for j in i..n {
                cov[(i, j)] += d[i] * d[j];
            }
        }
    }
    for i in 0..n {
        for j in i..n {
            cov[(i, j)] /= count;
            cov[(j, i)] = cov[(i, j)];
        }
    }
    let eig = cov.symmetric_eigen();
    let mut pairs: Vec<(f64, Vec<f64>)> = (0..n)
        .map(|k| {
            let mut v: Vec<f64> = eig.eigenvectors.column(k).iter().copied().collect();
            fix_sign(&mut v);
            (eig.eigenvalues[k].max(0.0), v)
        })
        .collect();
    // Stable sort on decreasing eigenvalue; NaN cannot occur for a finite covariance.
    pairs.sort_by(|a, b| b.0.total_cmp(&a.0));
    let eigenvalues = pairs.iter().map(|p| p.0).collect();
    let basis = pairs.into_iter().map(|p| p.1).collect();
    (mean, eigenvalues, basis)
}

/// Per texel (texel-major) the weights ⟨basis_k, v − mean⟩ of its vector `vector(t)`, for
/// the covered texels and the gutter texels that hold data (uncovered all-zero ones stay 0).
pub(crate) fn project_weights<'a>(
    covered: &[bool],
    vector: impl Fn(usize) -> &'a [f32],
    mean: &[f64],
    basis: &[Vec<f64>],
) -> Vec<f32> {
    let m = basis.len();
    let mut weights = vec![0.0f32; covered.len() * m];
    let mut d = vec![0.0f64; mean.len()];
    for (t, &is_covered) in covered.iter().enumerate() {
        let v = vector(t);
        if !is_covered && v.iter().all(|&c| c == 0.0) {
            continue;
        }
        for ((&c, &mu), d) in v.iter().zip(mean).zip(d.iter_mut()) {
            *d = f64::from(c) - mu;
        }
        for (w, b) in weights[t * m..(t + 1) * m].iter_mut().zip(basis) {
            *w = dot(b, &d) as f32;
        }
    }
    weights
}

/// Makes the largest-magnitude component (the first on a tie) positive.
fn fix_sign(v: &mut [f64]) {
    let mut big = 0;
    for (i, c) in v.iter().enumerate() {
        if c.abs() > v[big].abs() {
            big = i;
        }
    }
    if v[big] < 0.0 {
        v.iter_mut().for_each(|c| *c = -*c);
    }
}

pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// mean + Σ_k w_k basis_k.
pub(crate) fn combine(mean: &[f64], basis: &[Vec<f64>], w: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v = mean.to_vec();
    for (b, w) in basis.iter().zip(w) {
        for (acc, &c) in v.iter_mut().zip(b) {
            *acc += w * c;
        }
    }
    v
}

/// RMS over texels of the per-texel coefficient L2 distance.
pub(crate) fn rms(pairs: impl Iterator<Item = (Vec<f64>, Vec<f64>)>) -> f64 {
    let (mut sum, mut count) = (0.0f64, 0usize);
    for (a, b) in pairs {
        sum += a.iter().zip(&b).map(|(x, y)| (x - y).powi(2)).sum::<f64>();
        count += 1;
    }
    if count == 0 {
        0.0
    } else {
        (sum / count as f64).sqrt()
    }
}

impl PcaModel {
    /// Basis size M.
    pub fn m(&self) -> usize {
        self.basis.len()
    }

    /// Σ_{k<m} λ_k / Σ_k λ_k (module doc); 1.0 when Σλ = 0; m is clamped to n.
    pub fn energy_captured(&self, m: usize) -> f64 {
        let total: f64 = self.eigenvalues.iter().sum();
        if total <= 0.0 {
            return 1.0;
        }
        let kept: f64 = self.eigenvalues.iter().take(m).sum();
        (kept / total).min(1.0)
    }

    /// The M weights of texel `texel` (row-major y·res + x).
    ///
    /// # Panics
    /// If `texel` ≥ res².
    pub fn texel_weights(&self, texel: usize) -> &[f32] {
        let m = self.m();
        &self.weights[texel * m..(texel + 1) * m]
    }

    /// mean + Σ_k w_k basis_k of texel `texel`, n coefficients.
    ///
    /// # Panics
    /// If `texel` ≥ res².
    pub fn reconstruct(&self, texel: usize) -> Vec<f64> {
        let w = self.texel_weights(texel).iter().map(|&w| f64::from(w));
        combine(&self.mean, &self.basis, w)
    }

    /// RMS over `vis`'s covered texels of the coefficient-vector L2 error (= the L2 error
    /// over the sphere, the SH basis being orthonormal); 0 with no covered texel.
    ///
    /// # Panics
    /// If `vis` has another resolution or order than the fit.
    pub fn rms_reconstruction_error(&self, vis: &VisibilityMap) -> f64 {
        assert_eq!(
            (vis.res, vis.order),
            (self.res, self.order),
            "PCA: other map"
        );
        let texels = (self.res as usize).pow(2);
        rms((0..texels).filter(|&t| vis.covered[t]).map(|t| {
            let v = vis.texel(t).iter().map(|&c| f64::from(c)).collect();
            (v, self.reconstruct(t))
        }))
    }

    /// Quantizes the weights to `bits`-bit UNORM with each basis vector's range pushed
    /// into the basis and mean (module doc).
    ///
    /// # Panics
    /// Unless 1 ≤ bits ≤ 16 (the shaders use 8 or 16).
    pub fn quantize(&self, bits: u32) -> QuantizedPca {
        assert!((1..=16).contains(&bits), "PCA quantization: {bits} bits");
        let m = self.m();
        let levels = f64::from((1u32 << bits) - 1);
        let mut lo = vec![f64::INFINITY; m];
        let mut hi = vec![f64::NEG_INFINITY; m];
        for w in self.weights.chunks_exact(m) {
            for k in 0..m {
                lo[k] = lo[k].min(f64::from(w[k]));
                hi[k] = hi[k].max(f64::from(w[k]));
            }
        }
        let scale: Vec<f64> = (0..m)
            .map(|k| if hi[k] > lo[k] { hi[k] - lo[k] } else { 0.0 })
            .collect();
        let lo: Vec<f64> = lo
            .into_iter()
            .map(|l| if l.is_finite() { l } else { 0.0 })
            .collect();
        let mean = combine(&self.mean, &self.basis, lo.iter().copied());
        let basis = self
            .basis
            .iter()
            .zip(&scale)
            .map(|(b, &s)| b.iter().map(|c| c * s).collect())
            .collect();
        let weights_unorm = self
            .weights
            .chunks_exact(m)
            .flat_map(|w| {
                (0..m).map(|k| {
                    if scale[k] == 0.0 {
                        0
                    } else {
                        let u = (f64::from(w[k]) - lo[k]) / scale[k];
                        (u * levels).round().clamp(0.0, levels) as u16
                    }
                })
            })
            .collect();
        QuantizedPca {
            bits,
            mean,
            basis,
            weights_unorm,
            m,
            res: self.res,
        }
    }
}

/// PCA weights as b-bit UNORM with the per-basis scale and offset in the basis and mean
/// (module doc): V ≈ mean + Σ_k (q_k / (2^b − 1)) basis_k.
#[derive(Clone, Debug, PartialEq)]
pub struct QuantizedPca {
    /// Bits per weight.
    pub bits: u32,
    /// n: V_e' = V_e + Σ_k lo_k V_k.
    pub mean: Vec<f64>,
    /// M vectors of n: V_k' = (hi_k − lo_k) V_k (no longer unit length).
    pub basis: Vec<Vec<f64>>,
    /// Texel-major, M per texel, 0..=2^bits − 1.
    pub weights_unorm: Vec<u16>,
    /// Basis size M.
    pub m: usize,
    /// Texels per side.
    pub res: u32,
}

impl QuantizedPca {
    /// V_e' + Σ_k u_k V_k' of texel `texel`, n coefficients.
    ///
    /// # Panics
    /// If `texel` ≥ res².
    pub fn reconstruct(&self, texel: usize) -> Vec<f64> {
        let levels = f64::from((1u32 << self.bits) - 1);
        let q = &self.weights_unorm[texel * self.m..(texel + 1) * self.m];
        combine(
            &self.mean,
            &self.basis,
            q.iter().map(|&q| f64::from(q) / levels),
        )
    }

    /// Largest per-texel coefficient L2 error the rounding can cause:
    /// √(Σ_k ‖V_k'‖²) / (2(2^b − 1)) = √(Σ_k (hi_k − lo_k)²) / (2(2^b − 1)).
    pub fn error_bound(&self) -> f64 {
        let levels = f64::from((1u32 << self.bits) - 1);
        let sq: f64 = self.basis.iter().map(|b| dot(b, b)).sum();
        sq.sqrt() / (2.0 * levels)
    }

    /// RMS over every texel of the coefficient L2 distance to `model`'s unquantized
    /// reconstruction.
    ///
    /// # Panics
    /// If `model` has another resolution or basis size.
    pub fn rms_error_against(&self, model: &PcaModel) -> f64 {
        assert_eq!(
            (model.res, model.m()),
            (self.res, self.m),
            "PCA: other model"
        );
        let texels = (self.res as usize).pow(2);
        rms((0..texels).map(|t| (self.reconstruct(t), model.reconstruct(t))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(res: u32, order: Order, f: impl Fn(usize, usize) -> f32) -> VisibilityMap {
        let n = order.coeff_count();
        let texels = (res as usize).pow(2);
        VisibilityMap {
            res,
            order,
            coeffs: (0..texels * n).map(|i| f(i / n, i % n)).collect(),
            covered: vec![true; texels],
            ao: vec![1.0; texels],
            stats: crate::bake::BakeStats::default(),
        }
    }

    #[test]
    fn basis_size_is_checked() {
        let vis = map(4, Order::THREE, |t, i| (t * 7 + i) as f32);
        assert!(matches!(
            fit(&vis, 0),
            Err(BakeError::PcaBasisOutOfRange { m: 0, n: 9 })
        ));
        assert!(fit(&vis, 10).is_err() && fit(&vis, 9).is_ok());
        let msg = fit(&vis, 10).map(|_| ()).map_err(|e| e.to_string());
        assert_eq!(
            msg,
            Err("PCA basis size 10 is out of range 1..=9".to_string())
        );
    }

    #[test]
    fn no_covered_texel_is_an_error() {
        let mut vis = map(4, Order::THREE, |_, _| 1.0);
        vis.covered.fill(false);
        assert!(matches!(fit(&vis, 2), Err(BakeError::EmptyLightmap)));
    }

    #[test]
    fn sign_is_fixed_by_largest_component() {
        let mut v = vec![0.1, -0.9, 0.3];
        fix_sign(&mut v);
        assert_eq!(v, vec![-0.1, 0.9, -0.3]);
    }

    #[test]
    fn basis_is_orthonormal_and_eigenvalues_sorted() {
        // Pseudo-random data through an integer hash: full rank, distinct eigenvalues.
        let vis = map(8, Order::THREE, |t, i| {
            let h = ((t as u32).wrapping_mul(2_654_435_761) ^ (i as u32).wrapping_mul(40_503))
                .wrapping_mul(0x9e37_79b9);
            (h >> 8) as f32 / (1u32 << 24) as f32 * (1.0 + i as f32)
        });
        let model = fit(&vis, 9).unwrap();
        for (a, ba) in model.basis.iter().enumerate() {
            for (b, bb) in model.basis.iter().enumerate() {
                let want = if a == b { 1.0 } else { 0.0 };
                assert!((dot(ba, bb) - want).abs() < 1e-12, "basis {a}·{b}");
            }
        }
        assert!(model.eigenvalues.windows(2).all(|w| w[0] >= w[1]));
        // The full basis reconstructs up to the f32 weights.
        assert!(model.rms_reconstruction_error(&vis) < 1e-6);
    }
}
