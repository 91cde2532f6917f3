//! Vector quantization (VQ) and clustered PCA (CPCA) of the baked visibility
//! (Sloan's PRT course, "VQ", "PCA", "CPCA"; Iwanicki–Sloan §4 and its future work).
//!
//! Each covered texel holds an order-O visibility vector V(x) ∈ ℝⁿ (n = O²). The three
//! models of the course, with C(x) the texel's cluster:
//!
//! ```text
//! VQ     V(x) ≈ μ_C(x)                                  (piecewise constant)
//! PCA    V(x) ≈ V_e + Σ_{k<M} w_k(x) V_k                 (one affine subspace, `super::pca`)
//! CPCA   V(x) ≈ μ_C(x) + Σ_{k<M} w_k(x) B_C(x),k          (an affine subspace per cluster)
//! ```
//!
//! - **VQ** is k-means (Lloyd) on the covered texels' vectors, seeded by k-means++.
//! - **static CPCA** ("VQ + PCA"): the VQ clusters, then a PCA of each cluster
//!   (`super::pca::principal_subspace`): optimal for piecewise-constant reconstruction, not
//!   for the affine one it is used with.
//! - **iterative CPCA** ("VQPCA", "mixture of PC"): from the static clusters, reassign every
//!   texel to the cluster whose affine subspace reconstructs it best,
//!   ‖V − μ_c‖² − Σ_k (B_c,k · (V − μ_c))², refit each cluster's mean and PCA, repeat until
//!   no texel moves (or a cap). Each round cannot raise the total squared error.
//!
//! Determinism: the seeding draws from a seeded splitmix64 stream; per-texel work
//! (distances, assignment) runs in parallel but writes per-texel results only; every sum
//! over texels (means, covariances) runs in texel order within one cluster — so a model is
//! bit-identical for any thread count. Ties go to the lowest cluster index.
//!
//! Degenerate input: fewer distinct vectors than clusters leaves clusters empty (k-means++
//! finds no further point at positive distance); an empty cluster (during Lloyd or the
//! iterative rounds) is re-seeded with the texel reconstructed worst, or stays empty —
//! zero members, mean and basis 0 — when every texel is reconstructed exactly. A cluster of
//! one texel has that texel as mean and zero variance.
//!
//! Gutter texels (uncovered, non-zero: dilated) are assigned and projected after the fit,
//! like `super::pca`'s; texels further out get cluster 0 and weights 0.

use rayon::prelude::*;

use super::BakeError;
use super::directions::{splitmix64, unit_f64};
use super::pca::{dot, principal_subspace, rms};
use super::visibility::VisibilityMap;
use crate::sh::Order;

/// Version of the fit's results: bump it whenever `fit` changes what it returns, so cached
/// fits (`bake::cache::load_or_fit_clusters`) are rebuilt.
pub const FIT_VERSION: u32 = 1;

/// Lloyd iterations of k-means at most (it stops when no texel changes cluster).
pub const KMEANS_MAX_ITERATIONS: u32 = 100;
/// Reassign-and-refit rounds of iterative CPCA at most.
pub const CPCA_MAX_ROUNDS: u32 = 30;

/// How the clusters of a [`ClusteredModel`] were found.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Clustering {
    /// k-means; M = 0 gives VQ, M > 0 static CPCA.
    KMeans,
    /// Static CPCA refined by reassigning to the best-reconstructing subspace.
    Iterative,
}

/// One cluster: its mean and M orthonormal vectors (zero vectors past its rank).
#[derive(Clone, Debug, PartialEq)]
pub struct Cluster {
    pub mean: Vec<f64>,
    pub basis: Vec<Vec<f64>>,
    /// Covered texels in the cluster.
    pub members: usize,
}

/// A VQ or CPCA model of a visibility lightmap (module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct ClusteredModel {
    pub order: Order,
    pub res: u32,
    pub clustering: Clustering,
    /// Vectors per cluster (0: VQ).
    pub m: usize,
    pub clusters: Vec<Cluster>,
    /// Cluster of every texel (row-major).
    pub cluster_of: Vec<u32>,
    /// Texel-major, M per texel, in the texel's cluster's basis.
    pub weights: Vec<f32>,
    /// Lloyd iterations, then iterative rounds, that ran.
    pub iterations: u32,
}

/// Texel-major vectors of `dim` f32 each (a visibility or transfer lightmap) and the
/// covered texels among them.
struct Samples<'a> {
    data: &'a [f32],
    dim: usize,
    covered: Vec<usize>,
}

impl Samples<'_> {
    /// The vector of covered sample `i`.
    fn vector(&self, i: usize) -> &[f32] {
        self.texel(self.covered[i])
    }

    fn texel(&self, t: usize) -> &[f32] {
        &self.data[t * self.dim..(t + 1) * self.dim]
    }
}

/// A fit of texel-major vectors ([`fit_vectors`]): what [`ClusteredModel`] holds besides
/// the vectors' meaning.
pub struct VectorFit {
    pub clusters: Vec<Cluster>,
    pub cluster_of: Vec<u32>,
    pub weights: Vec<f32>,
    pub iterations: u32,
}

fn squared_distance(v: &[f32], mean: &[f64]) -> f64 {
    v.iter()
        .zip(mean)
        .map(|(&a, &b)| (f64::from(a) - b).powi(2))
        .sum()
}

/// Squared error of reconstructing `v` with `cluster` (orthonormal basis):
/// ‖d‖² − Σ_k (B_k·d)², d = v − μ. Each dot product is summed in coordinate order and the
/// squares in basis order, as one at a time would; four basis vectors are taken together
/// so that their chains of additions overlap.
fn subspace_error(v: &[f32], cluster: &Cluster) -> f64 {
    let d = from_mean(v, &cluster.mean);
    // `Iterator::sum`'s start, so that the sums are the ones `dot` and `sum` give.
    let mut along = -0.0f64;
    for group in cluster.basis.chunks(4) {
        // Lanes past the group's end repeat its first vector and are not read back.
        let lane = |k: usize| &group.get(k).unwrap_or(&group[0])[..d.len()];
        let [b0, b1, b2, b3] = [lane(0), lane(1), lane(2), lane(3)];
        let mut sums = [-0.0f64; 4];
        for (j, &x) in d.iter().enumerate() {
            sums[0] += b0[j] * x;
            sums[1] += b1[j] * x;
            sums[2] += b2[j] * x;
            sums[3] += b3[j] * x;
        }
        for s in &sums[..group.len()] {
            along += s.powi(2);
        }
    }
    (dot(&d, &d) - along).max(0.0)
}

/// v − μ, in f64.
fn from_mean(v: &[f32], mean: &[f64]) -> Vec<f64> {
    v.iter()
        .zip(mean)
        .map(|(&a, &b)| f64::from(a) - b)
        .collect()
}

/// The cluster with the smallest `cost`, lowest index on ties; and that cost.
fn best(clusters: usize, cost: impl Fn(usize) -> f64) -> (u32, f64) {
    let mut best = (0u32, f64::INFINITY);
    for c in 0..clusters {
        let e = cost(c);
        if e < best.1 {
            best = (c as u32, e);
        }
    }
    best
}

/// [`best`] over [`squared_distance`] to each of `means`: the same sums (each in
/// coordinate order), four means at a time so that their four chains of additions overlap.
fn nearest_mean(v: &[f32], means: &[Vec<f64>]) -> (u32, f64) {
    let mut nearest = (0u32, f64::INFINITY);
    let mut keep = |c: usize, e: f64| {
        if e < nearest.1 {
            nearest = (c as u32, e);
        }
    };
    let mut quads = means.chunks_exact(4);
    for (q, quad) in quads.by_ref().enumerate() {
        let [m0, m1, m2, m3] = [&quad[0], &quad[1], &quad[2], &quad[3]].map(|m| &m[..v.len()]);
        let mut e = [0.0f64; 4];
        for (j, &a) in v.iter().enumerate() {
            let a = f64::from(a);
            e[0] += (a - m0[j]).powi(2);
            e[1] += (a - m1[j]).powi(2);
            e[2] += (a - m2[j]).powi(2);
            e[3] += (a - m3[j]).powi(2);
        }
        for (k, e) in e.into_iter().enumerate() {
            keep(4 * q + k, e);
        }
    }
    let done = means.len() - quads.remainder().len();
    for (k, mean) in quads.remainder().iter().enumerate() {
        keep(done + k, squared_distance(v, mean));
    }
    nearest
}

/// k-means++ seeds: up to `k` distinct sample indices (fewer when there are fewer
/// distinct vectors).
fn seeds(samples: &Samples<'_>, k: usize, seed: u64) -> Vec<usize> {
    let count = samples.covered.len();
    let mut state = splitmix64(seed ^ 0x5eed_c1a5_7e25);
    let mut draw = || {
        state = splitmix64(state);
        unit_f64(state)
    };
    let first = ((draw() * count as f64) as usize).min(count - 1);
    let mut chosen = vec![first];
    let mut d2: Vec<f64> = (0..count)
        .into_par_iter()
        .map(|i| squared_distance(samples.vector(i), &to_f64(samples.vector(first))))
        .collect();
    while chosen.len() < k {
        let total: f64 = d2.iter().sum();
        if total <= 0.0 {
            break;
        }
        let target = draw() * total;
        let mut acc = 0.0;
        let mut next = count - 1;
        for (i, &d) in d2.iter().enumerate() {
            acc += d;
            if acc > target && d > 0.0 {
                next = i;
                break;
            }
        }
        if d2[next] <= 0.0 {
            break;
        }
        chosen.push(next);
        let centre = to_f64(samples.vector(next));
        d2.par_iter_mut().enumerate().for_each(|(i, d)| {
            *d = d.min(squared_distance(samples.vector(i), &centre));
        });
    }
    chosen
}

fn to_f64(v: &[f32]) -> Vec<f64> {
    v.iter().map(|&c| f64::from(c)).collect()
}

/// Means of the clusters of `assignment` (sums in sample order); an empty cluster keeps
/// `previous`' mean.
fn cluster_means(
    samples: &Samples<'_>,
    assignment: &[u32],
    previous: &[Vec<f64>],
    n: usize,
) -> (Vec<Vec<f64>>, Vec<usize>) {
    let k = previous.len();
    let mut sums = vec![vec![0.0f64; n]; k];
    let mut counts = vec![0usize; k];
    for (i, &c) in assignment.iter().enumerate() {
        counts[c as usize] += 1;
        for (acc, &v) in sums[c as usize].iter_mut().zip(samples.vector(i)) {
            *acc += f64::from(v);
        }
    }
    let means = sums
        .into_iter()
        .zip(&counts)
        .zip(previous)
        .map(|((s, &count), old)| {
            if count == 0 {
                old.clone()
            } else {
                s.into_iter().map(|v| v / count as f64).collect()
            }
        })
        .collect();
    (means, counts)
}

/// Moves the sample with the largest error in `errors` (lowest index on ties) into each
/// empty cluster, one per cluster; returns whether any moved. Samples with zero error are
/// never moved (an empty cluster then stays empty).
fn reseed_empty(assignment: &mut [u32], errors: &mut [f64], counts: &mut [usize]) -> bool {
    let mut moved = false;
    for c in 0..counts.len() {
        if counts[c] > 0 {
            continue;
        }
        let mut worst = None::<(usize, f64)>;
        for (i, &e) in errors.iter().enumerate() {
            // Keep the donor cluster non-empty.
            if e > 0.0 && counts[assignment[i] as usize] > 1 && worst.is_none_or(|(_, w)| e > w) {
                worst = Some((i, e));
            }
        }
        if let Some((i, _)) = worst {
            counts[assignment[i] as usize] -= 1;
            assignment[i] = c as u32;
            counts[c] = 1;
            errors[i] = 0.0;
            moved = true;
        }
    }
    moved
}

/// k-means on the covered texels: the assignment, the means and the iterations run.
fn kmeans(samples: &Samples<'_>, k: usize, seed: u64, n: usize) -> (Vec<u32>, Vec<Vec<f64>>, u32) {
    let seeds = seeds(samples, k, seed);
    let mut means: Vec<Vec<f64>> = (0..k)
        .map(|c| {
            seeds
                .get(c)
                .map_or(vec![0.0; n], |&i| to_f64(samples.vector(i)))
        })
        .collect();
    // Clusters without a seed (fewer distinct vectors than k) never attract a sample.
    let live = seeds.len();
    let mut assignment = vec![u32::MAX; samples.covered.len()];
    let mut iterations = 0;
    while iterations < KMEANS_MAX_ITERATIONS {
        iterations += 1;
        let assigned: Vec<(u32, f64)> = (0..samples.covered.len())
            .into_par_iter()
            .map(|i| nearest_mean(samples.vector(i), &means[..live]))
            .collect();
        let changed = assigned.iter().zip(&assignment).any(|(a, &old)| a.0 != old);
        let mut next: Vec<u32> = assigned.iter().map(|a| a.0).collect();
        let mut errors: Vec<f64> = assigned.iter().map(|a| a.1).collect();
        let (_, mut counts) = cluster_means(samples, &next, &means, n);
        let reseeded = reseed_empty(&mut next[..], &mut errors, &mut counts[..live]);
        means = cluster_means(samples, &next, &means, n).0;
        assignment = next;
        if !changed && !reseeded {
            break;
        }
    }
    (assignment, means, iterations)
}

/// Mean and the first `m` principal vectors of each cluster (in parallel over clusters,
/// each summed in sample order).
fn fit_clusters(
    samples: &Samples<'_>,
    assignment: &[u32],
    k: usize,
    m: usize,
    n: usize,
) -> Vec<Cluster> {
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); k];
    for (i, &c) in assignment.iter().enumerate() {
        members[c as usize].push(i);
    }
    members
        .par_iter()
        .map(|idx| {
            if idx.is_empty() {
                return Cluster {
                    mean: vec![0.0; n],
                    basis: vec![vec![0.0; n]; m],
                    members: 0,
                };
            }
            let (mean, eigenvalues, mut basis) =
                principal_subspace(idx.iter().map(|&i| samples.vector(i)), n);
            basis.truncate(m);
            // Directions of zero variance carry nothing (and would be arbitrary).
            for (b, &l) in basis.iter_mut().zip(&eigenvalues) {
                if l <= 0.0 {
                    b.iter_mut().for_each(|c| *c = 0.0);
                }
            }
            Cluster {
                mean,
                basis,
                members: idx.len(),
            }
        })
        .collect()
}

/// Fits a VQ (`m` = 0) or CPCA model with `k` clusters of `m` vectors (module doc).
///
/// # Errors
/// [`BakeError::EmptyLightmap`] when no texel is covered; [`BakeError::PcaBasisOutOfRange`]
/// unless m ≤ order² and 1 ≤ k ≤ 65536.
pub fn fit(
    vis: &VisibilityMap,
    k: usize,
    m: usize,
    clustering: Clustering,
    seed: u64,
) -> Result<ClusteredModel, BakeError> {
    let n = vis.order.coeff_count();
    let fit = fit_vectors(&vis.coeffs, n, &vis.covered, k, m, clustering, seed)?;
    Ok(ClusteredModel {
        order: vis.order,
        res: vis.res,
        clustering,
        m,
        clusters: fit.clusters,
        cluster_of: fit.cluster_of,
        weights: fit.weights,
        iterations: fit.iterations,
    })
}

/// [`fit`] for any texel-major vectors: `data` holds `dim` values per texel, `covered`
/// one flag per texel (the transfer matrices' CPCA, `bake::transfer`, fits through here).
///
/// # Errors
/// As [`fit`], with n = `dim`.
pub fn fit_vectors(
    data: &[f32],
    dim: usize,
    covered: &[bool],
    k: usize,
    m: usize,
    clustering: Clustering,
    seed: u64,
) -> Result<VectorFit, BakeError> {
    let n = dim;
    if m > n {
        return Err(BakeError::PcaBasisOutOfRange { m, n });
    }
    if k == 0 || k > 1 << 16 {
        return Err(BakeError::ClusterCountOutOfRange { k });
    }
    let texels = covered.len();
    let samples = Samples {
        data,
        dim,
        covered: (0..texels).filter(|&t| covered[t]).collect(),
    };
    if samples.covered.is_empty() {
        return Err(BakeError::EmptyLightmap);
    }
    let (mut assignment, _, mut iterations) = kmeans(&samples, k, seed, n);
    let mut clusters = fit_clusters(&samples, &assignment, k, m, n);
    if clustering == Clustering::Iterative && m > 0 {
        for _ in 0..CPCA_MAX_ROUNDS {
            iterations += 1;
            let assigned: Vec<(u32, f64)> = (0..samples.covered.len())
                .into_par_iter()
                .map(|i| {
                    best(k, |c| {
                        if clusters[c].members == 0 {
                            f64::INFINITY
                        } else {
                            subspace_error(samples.vector(i), &clusters[c])
                        }
                    })
                })
                .collect();
            let mut next: Vec<u32> = assigned.iter().map(|a| a.0).collect();
            let mut errors: Vec<f64> = assigned.iter().map(|a| a.1).collect();
            let mut counts = vec![0usize; k];
            for &c in &next {
                counts[c as usize] += 1;
            }
            let reseeded = reseed_empty(&mut next, &mut errors, &mut counts);
            let changed = next != assignment;
            assignment = next;
            if !changed && !reseeded {
                break;
            }
            clusters = fit_clusters(&samples, &assignment, k, m, n);
        }
    }
    // Every stored texel (covered, or a non-zero gutter texel) gets its best cluster and
    // weights; the covered ones keep the fit's assignment.
    let mut cluster_of = vec![0u32; texels];
    for (i, &t) in samples.covered.iter().enumerate() {
        cluster_of[t] = assignment[i];
    }
    let gutter: Vec<usize> = (0..texels)
        .filter(|&t| !covered[t] && samples.texel(t).iter().any(|&c| c != 0.0))
        .collect();
    let cost = |v: &[f32], c: usize| {
        if clusters[c].members == 0 {
            f64::INFINITY
        } else if m == 0 {
            squared_distance(v, &clusters[c].mean)
        } else {
            subspace_error(v, &clusters[c])
        }
    };
    let gutter_clusters: Vec<u32> = gutter
        .par_iter()
        .map(|&t| best(k, |c| cost(samples.texel(t), c)).0)
        .collect();
    for (&t, &c) in gutter.iter().zip(&gutter_clusters) {
        cluster_of[t] = c;
    }
    let mut weights = vec![0.0f32; texels * m];
    if m > 0 {
        for t in samples.covered.iter().chain(&gutter) {
            let cluster = &clusters[cluster_of[*t] as usize];
            let d = from_mean(samples.texel(*t), &cluster.mean);
            for (w, b) in weights[t * m..(t + 1) * m].iter_mut().zip(&cluster.basis) {
                *w = dot(b, &d) as f32;
            }
        }
    }
    Ok(VectorFit {
        clusters,
        cluster_of,
        weights,
        iterations,
    })
}

impl ClusteredModel {
    /// μ_C + Σ_k w_k B_C,k of `texel`, n coefficients.
    pub fn reconstruct(&self, texel: usize) -> Vec<f64> {
        let cluster = &self.clusters[self.cluster_of[texel] as usize];
        let mut v = cluster.mean.clone();
        for (b, &w) in cluster
            .basis
            .iter()
            .zip(&self.weights[texel * self.m..(texel + 1) * self.m])
        {
            for (acc, &c) in v.iter_mut().zip(b) {
                *acc += f64::from(w) * c;
            }
        }
        v
    }

    /// RMS over covered texels of the coefficient L2 error against `vis` (= the L2 error
    /// of the visibility function, the SH basis being orthonormal).
    pub fn rms_reconstruction_error(&self, vis: &VisibilityMap) -> f64 {
        let texels = (self.res as usize).pow(2);
        rms((0..texels).filter(|&t| vis.covered[t]).map(|t| {
            let v = vis.texel(t).iter().map(|&c| f64::from(c)).collect();
            (v, self.reconstruct(t))
        }))
    }

    /// `v` (n coefficients) in the model: projected on the cluster that reconstructs it
    /// best (VQ: the nearest mean), as the fit assigns gutter texels.
    pub fn compress(&self, v: &[f64]) -> Vec<f64> {
        let v32: Vec<f32> = v.iter().map(|&x| x as f32).collect();
        let (c, _) = best(self.clusters.len(), |c| {
            let cluster = &self.clusters[c];
            if cluster.members == 0 {
                f64::INFINITY
            } else if self.m == 0 {
                squared_distance(&v32, &cluster.mean)
            } else {
                subspace_error(&v32, cluster)
            }
        });
        let cluster = &self.clusters[c as usize];
        let d: Vec<f64> = v.iter().zip(&cluster.mean).map(|(a, b)| a - b).collect();
        super::pca::combine(
            &cluster.mean,
            &cluster.basis,
            cluster.basis.iter().map(|b| dot(b, &d)),
        )
    }

    /// Clusters with at least one covered texel.
    pub fn clusters_used(&self) -> usize {
        self.clusters.iter().filter(|c| c.members > 0).count()
    }
}

/// A clustered model with its weights as 8-bit UNORM, each cluster's per-vector range
/// pushed into its basis and mean as `bake::pca::PcaModel::quantize` does for one
/// cluster: V ≈ μ_C' + Σ_k (q_k / 255) B_C,k'.
#[derive(Clone, Debug, PartialEq)]
pub struct QuantizedClusters {
    pub order: Order,
    pub res: u32,
    pub m: usize,
    /// Per cluster: μ_C' = μ_C + Σ_k lo_C,k B_C,k.
    pub means: Vec<Vec<f64>>,
    /// Per cluster, M vectors B_C,k' = (hi_C,k − lo_C,k) B_C,k.
    pub bases: Vec<Vec<Vec<f64>>>,
    /// Texel-major, M per texel.
    pub weights_unorm: Vec<u8>,
    /// Cluster of every texel (row-major).
    pub cluster_of: Vec<u32>,
}

impl QuantizedClusters {
    /// μ_C' + Σ_k (q_k / 255) B_C,k' of `texel`.
    pub fn reconstruct(&self, texel: usize) -> Vec<f64> {
        let c = self.cluster_of[texel] as usize;
        let q = &self.weights_unorm[texel * self.m..(texel + 1) * self.m];
        super::pca::combine(
            &self.means[c],
            &self.bases[c],
            q.iter().map(|&q| f64::from(q) / 255.0),
        )
    }
}

impl ClusteredModel {
    /// The weights as 8-bit UNORM per cluster and vector range ([`QuantizedClusters`]),
    /// over every texel the fit stored (covered and gutter texels alike).
    pub fn quantize(&self) -> QuantizedClusters {
        let (k, m) = (self.clusters.len(), self.m);
        let mut lo = vec![vec![f64::INFINITY; m]; k];
        let mut hi = vec![vec![f64::NEG_INFINITY; m]; k];
        for (t, &c) in self.cluster_of.iter().enumerate() {
            for j in 0..m {
                let w = f64::from(self.weights[t * m + j]);
                lo[c as usize][j] = lo[c as usize][j].min(w);
                hi[c as usize][j] = hi[c as usize][j].max(w);
            }
        }
        let scale: Vec<Vec<f64>> = (0..k)
            .map(|c| {
                (0..m)
                    .map(|j| (hi[c][j] - lo[c][j]).max(0.0))
                    .map(|s| if s.is_finite() { s } else { 0.0 })
                    .collect()
            })
            .collect();
        let lo: Vec<Vec<f64>> = lo
            .into_iter()
            .map(|l| {
                l.into_iter()
                    .map(|v| if v.is_finite() { v } else { 0.0 })
                    .collect()
            })
            .collect();
        let means = (0..k)
            .map(|c| {
                let cl = &self.clusters[c];
                super::pca::combine(&cl.mean, &cl.basis, lo[c].iter().copied())
            })
            .collect();
        let bases = (0..k)
            .map(|c| {
                self.clusters[c]
                    .basis
                    .iter()
                    .zip(&scale[c])
                    .map(|(b, &s)| b.iter().map(|x| x * s).collect())
                    .collect()
            })
            .collect();
        let weights_unorm = self
            .cluster_of
            .iter()
            .enumerate()
            .flat_map(|(t, &c)| {
                let (c, lo, scale) = (c as usize, &lo, &scale);
                (0..m).map(move |j| {
                    if scale[c][j] == 0.0 {
                        0
                    } else {
                        let u = (f64::from(self.weights[t * m + j]) - lo[c][j]) / scale[c][j];
                        (u * 255.0).round().clamp(0.0, 255.0) as u8
                    }
                })
            })
            .collect();
        QuantizedClusters {
            order: self.order,
            res: self.res,
            m,
            means,
            bases,
            weights_unorm,
            cluster_of: self.cluster_of.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A res × res map whose covered texels hold `f(t)`.
    fn map(res: u32, f: impl Fn(usize) -> Vec<f32>) -> VisibilityMap {
        let texels = (res * res) as usize;
        VisibilityMap {
            res,
            order: Order::TWO,
            coeffs: (0..texels).flat_map(&f).collect(),
            covered: vec![true; texels],
            ao: vec![1.0; texels],
            stats: Default::default(),
        }
    }

    /// Four well-separated blobs along a line in each, jittered deterministically.
    fn blobs(t: usize) -> Vec<f32> {
        let h = splitmix64(t as u64);
        let centre = [[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [10.0, 10.0]][t % 4];
        let u = unit_f64(h) as f32 - 0.5;
        let v = unit_f64(splitmix64(h)) as f32 - 0.5;
        vec![centre[0] + u, centre[1] + 3.0 * u + 0.1 * v, u * 2.0, v]
    }

    /// The one-at-a-time form `subspace_error` must equal bit for bit.
    fn subspace_error_one_at_a_time(v: &[f32], cluster: &Cluster) -> f64 {
        let d = from_mean(v, &cluster.mean);
        let along: f64 = cluster.basis.iter().map(|b| dot(b, &d).powi(2)).sum();
        (dot(&d, &d) - along).max(0.0)
    }

    #[test]
    fn subspace_error_equals_one_dot_product_at_a_time() {
        let mut state = 7u64;
        let mut draw = || {
            state = splitmix64(state);
            (unit_f64(state) - 0.5) * 10f64.powi((state % 5) as i32 - 2)
        };
        for (n, m) in [(36, 11), (36, 0), (9, 1), (16, 4), (49, 7), (25, 9)] {
            for _ in 0..20 {
                let v: Vec<f32> = (0..n).map(|_| draw() as f32).collect();
                let cluster = Cluster {
                    mean: (0..n).map(|_| draw()).collect(),
                    basis: (0..m)
                        .map(|_| (0..n).map(|_| 0.05 * draw()).collect())
                        .collect(),
                    members: 1,
                };
                assert_eq!(
                    subspace_error(&v, &cluster).to_bits(),
                    subspace_error_one_at_a_time(&v, &cluster).to_bits(),
                    "n = {n}, m = {m}"
                );
            }
        }
    }

    #[test]
    fn kmeans_finds_separated_blobs_and_cpca_fits_inside_them() {
        let vis = map(8, blobs);
        let vq = fit(&vis, 4, 0, Clustering::KMeans, 1).unwrap();
        assert_eq!(vq.clusters_used(), 4);
        // Every blob is one cluster.
        for t in 0..64 {
            assert_eq!(vq.cluster_of[t], vq.cluster_of[t % 4], "texel {t}");
        }
        let cpca = fit(&vis, 4, 1, Clustering::KMeans, 1).unwrap();
        let iter = fit(&vis, 4, 1, Clustering::Iterative, 1).unwrap();
        let (e_vq, e_cpca, e_iter) = (
            vq.rms_reconstruction_error(&vis),
            cpca.rms_reconstruction_error(&vis),
            iter.rms_reconstruction_error(&vis),
        );
        assert!(e_cpca < 0.5 * e_vq, "{e_cpca} vs {e_vq}");
        assert!(e_iter <= e_cpca + 1e-12, "{e_iter} vs {e_cpca}");
    }

    #[test]
    fn models_are_bit_identical_for_one_and_two_threads() {
        let vis = map(16, |t| {
            let h = splitmix64(t as u64 * 7 + 3);
            (0..4)
                .map(|j| (unit_f64(splitmix64(h + j)) as f32) * (1.0 + (t % 5) as f32))
                .collect()
        });
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    [
                        fit(&vis, 6, 0, Clustering::KMeans, 9).unwrap(),
                        fit(&vis, 6, 2, Clustering::KMeans, 9).unwrap(),
                        fit(&vis, 6, 2, Clustering::Iterative, 9).unwrap(),
                    ]
                })
        };
        assert_eq!(run(1), run(2));
    }

    #[test]
    fn identical_vectors_leave_clusters_empty_and_reconstruct_exactly() {
        let vis = map(4, |_| vec![0.5, -0.25, 0.125, 1.0]);
        for clustering in [Clustering::KMeans, Clustering::Iterative] {
            let model = fit(&vis, 5, 2, clustering, 3).unwrap();
            assert_eq!(model.clusters_used(), 1);
            assert_eq!(model.clusters.len(), 5);
            assert!(
                model
                    .clusters
                    .iter()
                    .all(|c| c.mean.iter().all(|v| v.is_finite()))
            );
            assert_eq!(model.rms_reconstruction_error(&vis), 0.0);
        }
    }

    #[test]
    fn a_single_member_cluster_is_its_member() {
        // 15 texels near the origin, one far away: k = 2 gives the outlier its own cluster.
        let vis = map(4, |t| {
            if t == 9 {
                vec![100.0, 100.0, 0.0, 0.0]
            } else {
                vec![t as f32 * 0.01, 0.0, 0.0, 0.0]
            }
        });
        let model = fit(&vis, 2, 1, Clustering::Iterative, 5).unwrap();
        let outlier = &model.clusters[model.cluster_of[9] as usize];
        assert_eq!(outlier.members, 1);
        assert_eq!(outlier.mean, vec![100.0, 100.0, 0.0, 0.0]);
        assert!(outlier.basis[0].iter().all(|&c| c == 0.0));
        assert!(model.rms_reconstruction_error(&vis) < 1e-6);
    }

    #[test]
    fn more_clusters_than_texels_and_bad_sizes() {
        let vis = map(2, |t| vec![t as f32, 0.0, 1.0, 0.0]);
        let model = fit(&vis, 10, 0, Clustering::KMeans, 0).unwrap();
        assert_eq!(model.clusters_used(), 4);
        assert_eq!(model.rms_reconstruction_error(&vis), 0.0);
        assert!(fit(&vis, 0, 0, Clustering::KMeans, 0).is_err());
        assert!(fit(&vis, 2, 5, Clustering::KMeans, 0).is_err());
    }

    #[test]
    fn quantized_clusters_reconstruct_within_half_a_step_per_vector() {
        let vis = map(8, blobs);
        let model = fit(&vis, 4, 2, Clustering::Iterative, 3).unwrap();
        let q = model.quantize();
        assert_eq!(q.weights_unorm.len(), 64 * 2);
        for t in 0..64 {
            let c = q.cluster_of[t] as usize;
            // Rounding moves each weight by at most half a step of its vector's range.
            let bound: f64 = q.bases[c]
                .iter()
                .map(|b| dot(b, b).sqrt() / (2.0 * 255.0))
                .sum();
            let want = model.reconstruct(t);
            let got = q.reconstruct(t);
            let err = rms(std::iter::once((want, got)));
            assert!(err <= bound + 1e-9, "texel {t}: {err} > {bound}");
        }
        // A cluster whose members share a weight gets a zero vector, not a NaN.
        let same = map(4, |_| vec![1.0, 2.0, 3.0, 4.0]);
        let q = fit(&same, 1, 2, Clustering::KMeans, 0).unwrap().quantize();
        assert!(q.bases[0].iter().flatten().all(|&x| x == 0.0));
        assert_eq!(q.reconstruct(5), vec![1.0, 2.0, 3.0, 4.0]);
    }
}
