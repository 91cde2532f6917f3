//! Transfer matrices of normal mapping for PRT (Sloan, PRT course, "Normal Mapping for
//! PRT"): per lightmap texel a matrix M that maps distant SH lighting l
//! (order O, N = O² coefficients) to the order-3 SH of *transferred incident radiance* at
//! the texel — shadows and inter-reflection baked in, the lighting left free:
//!
//! ```text
//! e(n) = y(n)ᵀ C R M l        (course: C the clamped-cosine convolution, R the rotation
//!                              to tangent space; M here is in world space, R = I)
//! ```
//!
//! With the bake's shared direction set {ω_r} (weights w = 4π/R) and the SH lightmap's
//! notation (`super::shlmap`, eqs. (1)–(2)), per colour channel c:
//!
//! ```text
//! M⁰_c[i][j](x) = Σ_{r: n_g·ω_r > 0, escapes} w · y_i(ω_r) · y_j(ω_r)                 (1)
//! e^k_c[j](x)   = Σ_{i<9} A_{l(i)} · y_i(n_g(x)) · M^k_c[i][j](x)                      (2)
//! M^{k+1}_c[i][j](x) = M⁰[i][j](x)
//!                 + Σ_{r: hits the front of x'} w · y_i(ω_r) · ρ_c(x')/π · e^k_c[j](x') (3)
//! ```
//!
//! (2) is the irradiance of a unit lighting coefficient j at x; (3) re-traces the same
//! rays with it, read at the hit texel (dilated into the gutters, as the SH lightmap
//! does). M⁰ is the same for the three channels; the albedo makes the bounces coloured.
//! Because every step is linear in l, M·l equals the SH lightmap's coefficients for the
//! lighting l truncated to order O — except where the SH lightmap clamps a negative
//! bounce irradiance to 0, which a linear operator cannot do (smooth skies never reach
//! it; `tests/transfer.rs` holds the two equal).
//!
//! Storage: per texel, per channel, 9 rows of N f32 (texel-major); (1) and (2) summed in
//! f64, the hits of (3) in f32 (2× the SIMD width), each per texel in a fixed ray order
//! (bit-identical for any thread count); dilated like every other lightmap bake.
//!
//! Compression ([`TransferMap::compress`]): the course's "can be compressed just like
//! diffuse transfer" — PCA of the 3·9·N-vectors of the covered texels with the visibility
//! PCA's own principal-subspace fit (`super::pca`): M = mean + Σ_k w_k B_k, so that
//! M·l = mean·l + Σ_k w_k (B_k·l): per texel K weights, and K + 1 matrices whose products
//! with l are formed once per lighting change. [`TransferMap::compress_clustered`]: CPCA,
//! the same per cluster (`super::cluster`), M·l = μ_C·l + Σ_k w_k (B_C,k·l).

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use super::directions::DirectionSet;
use super::outer::add_outer_products;
use super::raster::{DilationPlan, LightmapTexels};
use super::surface::{PointGroup, RayEnd, SurfaceReader};
use super::trace::PACKET_RAYS;
use super::trace::Tracer;
use super::visibility::dilation_plan;
use super::{BakeStats, progress_bar};
use crate::scene::Scene;
use crate::sh::{Order, basis::eval_basis, zonal};

/// Rows of M: the order-3 SH of transferred incident radiance.
pub const TRANSFER_ROWS: usize = 9;

/// The lighting order the `nmprt*` techniques bake M for: the order of the lighting unc6's
/// L×H product takes (`prepare::LIGHTING_ORDER`), so the two see the sun equally sharp. At
/// order 6 the sun's truncation costs more than the inter-reflection gains (README:
/// 0.142 against unc6's 0.136 on the house, turned sun; 0.128 at order 8).
pub const DEFAULT_LIGHTING_ORDER: Order = Order::EIGHT;

/// What a transfer bake does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransferSettings {
    /// Order O of the lighting M takes (N = O² columns).
    pub lighting_order: Order,
    pub rays: u32,
    pub seed: u64,
    /// Reflections of light before it reaches a texel (0: shadowed direct light only).
    pub bounces: u32,
    pub progress: bool,
}

/// Per texel the three channels' 9 × N transfer matrices.
#[derive(Clone, Debug, PartialEq)]
pub struct TransferMap {
    pub res: u32,
    pub lighting_order: Order,
    pub bounces: u32,
    /// Texel-major: texel t, channel c, row i, column j at
    /// `((t·3 + c)·9 + i)·N + j`.
    pub matrices: Vec<f32>,
    pub covered: Vec<bool>,
    /// The normal map's frame at each texel centre, world space: tangent, bitangent (with
    /// the tangent's handedness) and shading normal, as `glsl/include/common.glsl` builds
    /// it per pixel (zero where not covered) — what turns l' into tangent space.
    pub frames: Vec<[glam::Vec3; 3]>,
    pub stats: BakeStats,
}

impl TransferMap {
    /// N = O², the columns of each matrix.
    pub fn columns(&self) -> usize {
        self.lighting_order.coeff_count()
    }

    /// The 3 × 9 × N floats of texel `index`.
    pub fn texel(&self, index: usize) -> &[f32] {
        let size = 3 * TRANSFER_ROWS * self.columns();
        &self.matrices[index * size..(index + 1) * size]
    }

    /// l' = M l at texel `index`: the 9 RGB coefficients of transferred incident radiance
    /// for lighting `l` (RGB SH with at least N coefficients), in f64.
    pub fn transferred(&self, index: usize, l: &[[f64; 3]]) -> [[f64; 3]; TRANSFER_ROWS] {
        apply(self.texel(index), self.columns(), l)
    }
}

/// A PCA-compressed [`TransferMap`] (module doc): the mean matrix, K basis matrices and K
/// weights per texel.
#[derive(Clone, Debug, PartialEq)]
pub struct CompressedTransfer {
    pub lighting_order: Order,
    /// 3·9·N, in [`TransferMap::matrices`]' per-texel layout.
    pub mean: Vec<f64>,
    /// K vectors of 3·9·N, by decreasing variance.
    pub basis: Vec<Vec<f64>>,
    /// Texel-major, K per texel.
    pub weights: Vec<f32>,
    /// The share of the covered texels' variance the K vectors hold.
    pub energy: f64,
}

impl CompressedTransfer {
    /// l' = M l at texel `index` from the compressed matrices.
    pub fn transferred(&self, index: usize, l: &[[f64; 3]]) -> [[f64; 3]; TRANSFER_ROWS] {
        let k = self.basis.len();
        let w = &self.weights[index * k..(index + 1) * k];
        let m = super::pca::combine(&self.mean, &self.basis, w.iter().map(|&x| f64::from(x)));
        apply(&m, self.lighting_order.coeff_count(), l)
    }
}

/// l' = M l for one texel's 3 × 9 × N matrices `m` (any float type). The lighting is
/// split into one contiguous row per colour first, so each output is a plain dot product
/// (vectorized; the `nmprt*` rebuild runs through here for every texel).
fn apply<T: Copy + Into<f64>>(m: &[T], n: usize, l: &[[f64; 3]]) -> [[f64; 3]; TRANSFER_ROWS] {
    let mut channels = [[0.0f64; MAX_APPLY_COLUMNS]; 3];
    if n > MAX_APPLY_COLUMNS {
        return apply_strided(m, n, l);
    }
    for (j, rgb) in l[..n].iter().enumerate() {
        for c in 0..3 {
            channels[c][j] = rgb[c];
        }
    }
    let mut out = [[0.0; 3]; TRANSFER_ROWS];
    for (i, row) in out.iter_mut().enumerate() {
        for (c, value) in row.iter_mut().enumerate() {
            let base = (c * TRANSFER_ROWS + i) * n;
            *value = dot4(&m[base..base + n], &channels[c][..n]);
        }
    }
    out
}

/// Σ a_j b_j in four interleaved partial sums (a fixed order the compiler can vectorize;
/// one running sum cannot be reordered).
fn dot4<T: Copy + Into<f64>>(a: &[T], b: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = a4
        .remainder()
        .iter()
        .zip(b4.remainder())
        .map(|(&x, &y)| x.into() * y)
        .sum();
    for (x, y) in a4.zip(b4) {
        for k in 0..4 {
            acc[k] += x[k].into() * y[k];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// Columns [`apply`] splits on the stack: lighting of order ≤ 8 (`prepare::LIGHTING_ORDER`).
const MAX_APPLY_COLUMNS: usize = 64;

/// [`apply`] reading the interleaved lighting directly (orders above 8).
fn apply_strided<T: Copy + Into<f64>>(
    m: &[T],
    n: usize,
    l: &[[f64; 3]],
) -> [[f64; 3]; TRANSFER_ROWS] {
    let mut out = [[0.0; 3]; TRANSFER_ROWS];
    for (i, row) in out.iter_mut().enumerate() {
        for (c, value) in row.iter_mut().enumerate() {
            let base = (c * TRANSFER_ROWS + i) * n;
            *value = (0..n).map(|j| m[base + j].into() * l[j][c]).sum();
        }
    }
    out
}

/// A CPCA-compressed [`TransferMap`] (module doc): per texel a cluster and M weights in
/// its affine subspace, M·l = μ_C·l + Σ_k w_k (B_C,k·l).
#[derive(Clone, Debug, PartialEq)]
pub struct ClusteredTransfer {
    pub lighting_order: Order,
    /// Vectors per cluster.
    pub m: usize,
    /// Means and bases in [`TransferMap::matrices`]' per-texel layout.
    pub clusters: Vec<super::cluster::Cluster>,
    pub cluster_of: Vec<u32>,
    /// Texel-major, M per texel.
    pub weights: Vec<f32>,
}

impl ClusteredTransfer {
    /// l' = M l at texel `index` from its cluster's mean, basis and weights.
    pub fn transferred(&self, index: usize, l: &[[f64; 3]]) -> [[f64; 3]; TRANSFER_ROWS] {
        let cluster = &self.clusters[self.cluster_of[index] as usize];
        let w = &self.weights[index * self.m..(index + 1) * self.m];
        let m = super::pca::combine(
            &cluster.mean,
            &cluster.basis,
            w.iter().map(|&x| f64::from(x)),
        );
        apply(&m, self.lighting_order.coeff_count(), l)
    }
}

impl TransferMap {
    /// CPCA of the covered texels' matrices with `k` clusters of `m` vectors — the
    /// visibility's VQ/CPCA fit (`super::cluster::fit_vectors`) on the 3·9·N-vectors.
    ///
    /// # Errors
    /// As [`super::cluster::fit`].
    pub fn compress_clustered(
        &self,
        k: usize,
        m: usize,
        clustering: super::cluster::Clustering,
        seed: u64,
    ) -> Result<ClusteredTransfer, super::BakeError> {
        let size = 3 * TRANSFER_ROWS * self.columns();
        let fit = super::cluster::fit_vectors(
            &self.matrices,
            size,
            &self.covered,
            k,
            m,
            clustering,
            seed,
        )?;
        Ok(ClusteredTransfer {
            lighting_order: self.lighting_order,
            m,
            clusters: fit.clusters,
            cluster_of: fit.cluster_of,
            weights: fit.weights,
        })
    }

    /// PCA with `k` vectors of the covered texels' matrices (module doc).
    ///
    /// # Errors
    /// [`super::BakeError::PcaBasisOutOfRange`] unless 1 ≤ k ≤ 3·9·N;
    /// [`super::BakeError::EmptyLightmap`] when no texel is covered.
    pub fn compress(&self, k: usize) -> Result<CompressedTransfer, super::BakeError> {
        let size = 3 * TRANSFER_ROWS * self.columns();
        if k == 0 || k > size {
            return Err(super::BakeError::PcaBasisOutOfRange { m: k, n: size });
        }
        let covered: Vec<usize> = (0..self.covered.len())
            .filter(|&t| self.covered[t])
            .collect();
        if covered.is_empty() {
            return Err(super::BakeError::EmptyLightmap);
        }
        let (mean, eigenvalues, mut basis) =
            super::pca::principal_subspace(covered.iter().map(|&t| self.texel(t)), size);
        basis.truncate(k);
        let total: f64 = eigenvalues.iter().sum();
        let kept: f64 = eigenvalues.iter().take(k).sum();
        let weights = super::pca::project_weights(&self.covered, |t| self.texel(t), &mean, &basis);
        Ok(CompressedTransfer {
            lighting_order: self.lighting_order,
            mean,
            basis,
            weights,
            energy: if total > 0.0 { kept / total } else { 1.0 },
        })
    }
}

/// Channel `c` of covered texel `k`'s matrix: of `current` (three channels per texel), or
/// with none of `direct` (one for every channel).
fn channel_of<'a>(
    current: Option<&'a [f32]>,
    direct: &'a [f32],
    k: usize,
    c: usize,
    per_channel: usize,
) -> &'a [f32] {
    match current {
        Some(m) => &m[(k * 3 + c) * per_channel..][..per_channel],
        None => &direct[k * per_channel..][..per_channel],
    }
}

/// What every pass of one transfer bake reads: the texels and their rays, the matrices'
/// shape and the counter of traced rays.
struct TransferPass<'a> {
    tracer: &'a Tracer,
    texels: &'a LightmapTexels,
    dirs: &'a DirectionSet,
    /// The covered texels' indices, the order of every per-texel buffer.
    covered: &'a [u32],
    /// N, the columns of each matrix.
    n: usize,
    per_channel: usize,
    per_texel: usize,
    /// The quadrature weight of one direction.
    weight: f64,
    progress: bool,
    rays_done: &'a AtomicU64,
}

/// Bakes the transfer matrices of `scene` over `texels` (module doc).
pub fn bake_transfer(
    scene: &Scene,
    tracer: &Tracer,
    texels: &LightmapTexels,
    settings: &TransferSettings,
) -> TransferMap {
    let start = Instant::now();
    let res = texels.res as usize;
    let n = settings.lighting_order.coeff_count();
    let per_channel = TRANSFER_ROWS * n;
    let per_texel = 3 * per_channel;
    let dirs = DirectionSet::new(settings.rays, settings.seed);
    let weight = dirs.weight();
    let basis = DirectionBasis::new(&dirs, settings.lighting_order, n);
    let surfaces = SurfaceReader::new(scene);
    let covered: Vec<u32> = (0..res * res)
        .filter(|&i| texels.covered[i])
        .map(|i| i as u32)
        .collect();
    let rays_done = AtomicU64::new(0);
    let pass = TransferPass {
        tracer,
        texels,
        dirs: &dirs,
        covered: &covered,
        n,
        per_channel,
        per_texel,
        weight,
        progress: settings.progress,
        rays_done: &rays_done,
    };

    // Eq. (1): the unbounced matrix, one for the three channels.
    let direct = bake_direct(&pass, &basis);

    // The bounces' gathers read the rows' basis in f32.
    let rows_f32: Vec<[f32; TRANSFER_ROWS]> = basis
        .rows
        .iter()
        .map(|rows| rows.map(|y| y as f32))
        .collect();
    let dilation = dilation_plan(&texels.covered, texels.res);
    let a: Vec<f64> = (0..TRANSFER_ROWS)
        .map(|i| zonal::clamped_cosine_convolution((i as f64).sqrt() as u32))
        .collect();
    // M^k per covered texel, three channels; `None`: M⁰, the same for every channel.
    let mut current: Option<Vec<f32>> = None;
    for bounce in 1..=settings.bounces {
        let irradiance = gather_irradiance(&pass, current.as_deref(), &direct, &a, &dilation);
        let next = bake_bounce(&pass, &surfaces, &rows_f32, &irradiance, &direct, bounce);
        current = Some(next);
    }

    let matrices = assemble_matrices(&pass, current.as_deref(), &direct, &dilation);
    let map = TransferMap {
        res: texels.res,
        lighting_order: settings.lighting_order,
        bounces: settings.bounces,
        matrices,
        covered: texels.covered.clone(),
        frames: texel_frames(texels),
        stats: BakeStats {
            rays_traced: rays_done.into_inner(),
            seconds: start.elapsed().as_secs_f64(),
        },
    };
    log::info!(
        "transfer bake: {} texels × {} directions, 9 × {n} matrices, {} bounces: {}",
        covered.len(),
        settings.rays,
        settings.bounces,
        map.stats
    );
    map
}

/// Per direction of `dirs`: the 9 rows' basis values and the N columns' (order
/// `lighting_order`).
struct DirectionBasis {
    rows: Vec<[f64; TRANSFER_ROWS]>,
    /// Direction r's N values at `r·N..(r + 1)·N`.
    columns: Vec<f64>,
    n: usize,
}

impl DirectionBasis {
    fn new(dirs: &DirectionSet, lighting_order: Order, n: usize) -> DirectionBasis {
        let mut rows = Vec::with_capacity(dirs.dirs().len());
        let mut columns = vec![0.0; dirs.dirs().len() * n];
        for (d, cols) in dirs.dirs().iter().zip(columns.chunks_mut(n)) {
            let d = d.as_dvec3().normalize();
            let mut row = [0.0; TRANSFER_ROWS];
            eval_basis(Order::THREE, d, &mut row);
            rows.push(row);
            eval_basis(lighting_order, d, cols);
        }
        DirectionBasis { rows, columns, n }
    }

    /// Direction `r`'s N column values.
    fn columns(&self, r: usize) -> &[f64] {
        &self.columns[r * self.n..][..self.n]
    }
}

/// Eq. (1) per covered texel: the unbounced matrix M⁰, summed in f64 over the escaping
/// directions of `basis` (one for the three channels).
fn bake_direct(pass: &TransferPass<'_>, basis: &DirectionBasis) -> Vec<f32> {
    let TransferPass {
        tracer,
        texels,
        dirs,
        covered,
        per_channel,
        weight,
        progress,
        rays_done,
        ..
    } = *pass;
    let bar = progress_bar(progress, covered.len(), "transfer direct");
    let mut direct = vec![0.0f32; covered.len() * per_channel];
    // Texels in groups traced together (coherent walks over the shared directions); each
    // texel's escaping directions are then summed on their own, in the order of `dirs`.
    direct
        .par_chunks_mut(PACKET_RAYS * per_channel)
        .zip(covered.par_chunks(PACKET_RAYS))
        .with_max_len(1)
        .for_each(|(out, group)| {
            let mut points = PointGroup::of_texels(tracer, texels, group);
            let mut escaping = vec![Vec::new(); group.len()];
            let rays = points.for_each_visibility(tracer, dirs.dirs(), |k, r, visible| {
                if visible == Some(true) {
                    escaping[k].push(r);
                }
            });
            let mut rows = Vec::new();
            let mut cols = Vec::new();
            let mut m = vec![0.0f64; per_channel];
            for (out, escaping) in out.chunks_mut(per_channel).zip(&escaping) {
                rows.clear();
                rows.extend(escaping.iter().map(|&r| basis.rows[r]));
                cols.clear();
                cols.extend(escaping.iter().map(|&r| basis.columns(r)));
                m.fill(0.0);
                add_outer_products(&mut m, &rows, &cols);
                for (o, v) in out.iter_mut().zip(&m) {
                    *o = (v * weight) as f32;
                }
            }
            rays_done.fetch_add(rays, Ordering::Relaxed);
            bar.inc(group.len() as u64);
        });
    bar.finish_and_clear();
    direct
}

/// Eq. (2) at every texel: 3 × N irradiance row vectors of M^k (`current`, or `direct`
/// for every channel), written to the lightmap and dilated into the gutters.
fn gather_irradiance(
    pass: &TransferPass<'_>,
    current: Option<&[f32]>,
    direct: &[f32],
    a: &[f64],
    dilation: &DilationPlan,
) -> Vec<f32> {
    let TransferPass {
        texels,
        covered,
        n,
        per_channel,
        ..
    } = *pass;
    let res = texels.res as usize;
    let mut gathered = vec![0.0f32; covered.len() * 3 * n];
    gathered
        .par_chunks_mut(3 * n)
        .enumerate()
        .with_min_len(64)
        .for_each(|(k, out)| {
            let nd = texels.normal[covered[k] as usize].as_dvec3().normalize();
            let mut y = [0.0f64; TRANSFER_ROWS];
            eval_basis(Order::THREE, nd, &mut y);
            let mut e = vec![0.0f64; n];
            for c in 0..3 {
                let m = channel_of(current, direct, k, c, per_channel);
                e.iter_mut().for_each(|v| *v = 0.0);
                for row in 0..TRANSFER_ROWS {
                    let ay = a[row] * y[row];
                    for (ej, &mij) in e.iter_mut().zip(&m[row * n..(row + 1) * n]) {
                        *ej += ay * f64::from(mij);
                    }
                }
                for (o, &v) in out[c * n..(c + 1) * n].iter_mut().zip(&e) {
                    *o = v as f32;
                }
            }
        });
    let mut irradiance = vec![0.0f32; res * res * 3 * n];
    for (k, &i) in covered.iter().enumerate() {
        let i = i as usize;
        irradiance[i * 3 * n..(i + 1) * 3 * n].copy_from_slice(&gathered[k * 3 * n..][..3 * n]);
    }
    drop(gathered);
    dilation.apply_vectors(&mut irradiance, 3 * n);
    irradiance
}

/// Eq. (3) for bounce `bounce`: per covered texel M⁰ (`direct`) plus the hits' sums in
/// f32 (in ray order) of `irradiance` read at the hit texel, weighted by its albedo.
fn bake_bounce(
    pass: &TransferPass<'_>,
    surfaces: &SurfaceReader<'_>,
    rows_f32: &[[f32; TRANSFER_ROWS]],
    irradiance: &[f32],
    direct: &[f32],
    bounce: u32,
) -> Vec<f32> {
    let TransferPass {
        tracer,
        texels,
        dirs,
        covered,
        n,
        per_channel,
        per_texel,
        weight,
        progress,
        rays_done,
    } = *pass;
    let bar = progress_bar(
        progress,
        covered.len(),
        &format!("transfer bounce {bounce}"),
    );
    // Eq. (3): each texel's front hits gathered by a coherent walk, then summed on their
    // own, in f32 in ray order.
    let mut next = vec![0.0f32; covered.len() * per_texel];
    next.par_chunks_mut(PACKET_RAYS * per_texel)
        .zip(covered.par_chunks(PACKET_RAYS))
        .zip(direct.par_chunks(PACKET_RAYS * per_channel))
        .with_max_len(1)
        .for_each(|((out, group), direct)| {
            let mut points = PointGroup::of_texels(tracer, texels, group);
            let mut hits: Vec<Vec<FrontHit>> = vec![Vec::new(); group.len()];
            let rays = points.for_each_hit(tracer, surfaces, dirs.dirs(), |k, r, end| {
                let Some(RayEnd::Front(surface)) = end else {
                    return;
                };
                hits[k].push(FrontHit {
                    direction: r,
                    texel: texels.texel_index(surface.uv_lightmap.into()),
                    albedo: (surface.albedo / std::f32::consts::PI).to_array(),
                });
            });
            let weight = weight as f32;
            let mut scaled_rows = Vec::new();
            let mut gathered = Vec::new();
            let mut sums = vec![0.0f32; per_channel];
            for ((out, hits), d0) in out
                .chunks_mut(per_texel)
                .zip(&hits)
                .zip(direct.chunks(per_channel))
            {
                for c in 0..3 {
                    scaled_rows.clear();
                    scaled_rows.extend(
                        hits.iter()
                            .map(|h| rows_f32[h.direction].map(|y| y * h.albedo[c])),
                    );
                    gathered.clear();
                    gathered.extend(
                        hits.iter()
                            .map(|h| &irradiance[(h.texel * 3 + c) * n..][..n]),
                    );
                    sums.fill(0.0);
                    add_outer_products(&mut sums, &scaled_rows, &gathered);
                    for ((o, &d), &v) in out[c * per_channel..][..per_channel]
                        .iter_mut()
                        .zip(d0)
                        .zip(&sums)
                    {
                        *o = d + weight * v;
                    }
                }
            }
            rays_done.fetch_add(rays, Ordering::Relaxed);
            bar.inc(group.len() as u64);
        });
    bar.finish_and_clear();
    next
}

/// A ray of eq. (3) that hit the front of a surface: its direction, the hit's lightmap
/// texel and albedo / π.
#[derive(Clone, Copy)]
struct FrontHit {
    direction: usize,
    texel: usize,
    albedo: [f32; 3],
}

/// Every texel's three channels' matrices in the lightmap — M^k (`current`) or M⁰
/// (`direct`) for each channel — dilated into the gutters.
fn assemble_matrices(
    pass: &TransferPass<'_>,
    current: Option<&[f32]>,
    direct: &[f32],
    dilation: &DilationPlan,
) -> Vec<f32> {
    let TransferPass {
        texels,
        covered,
        per_channel,
        per_texel,
        ..
    } = *pass;
    let res = texels.res as usize;
    let mut matrices = vec![0.0f32; res * res * per_texel];
    for (k, &i) in covered.iter().enumerate() {
        let out = &mut matrices[i as usize * per_texel..][..per_texel];
        for c in 0..3 {
            out[c * per_channel..][..per_channel].copy_from_slice(channel_of(
                current,
                direct,
                k,
                c,
                per_channel,
            ));
        }
    }
    dilation.apply_vectors(&mut matrices, per_texel);
    matrices
}

/// The normal map's frame at each texel centre, world space (zero where not covered):
/// tangent, bitangent with the tangent's handedness, shading normal.
fn texel_frames(texels: &LightmapTexels) -> Vec<[glam::Vec3; 3]> {
    let res = texels.res as usize;
    (0..res * res)
        .map(|i| {
            if !texels.covered[i] {
                return [glam::Vec3::ZERO; 3];
            }
            let n = texels.shading_normal[i].normalize_or(texels.normal[i]);
            let t = crate::scene::tangent::orthonormalize(n, texels.tangent[i]);
            [t.truncate(), n.cross(t.truncate()) * t.w, n]
        })
        .collect()
}
