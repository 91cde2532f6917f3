//! SH visibility per lightmap texel, the per-texel data of the `unc*` and (through PCA)
//! `pca*` techniques (DESIGN §2; Iwanicki–Sloan §3.1).
//!
//! # What is baked
//!
//! For a covered texel at x with unit geometric normal n (DESIGN §1),
//!
//! ```text
//! V(x, ω) = 1 if the ray x + tω (t > 0) escapes the scene, 0 if it is blocked,
//!           0 for n·ω ≤ 0 (below the tangent plane the surface occludes itself),
//! v_i(x)  = ∫_S² V(x, ω) y_i(ω) dω ≈ Σ_r w V(x, ω_r) y_i(ω_r),  w = 4π/R      (1)
//! ```
//!
//! for every i < order² (Iwanicki–Sloan eq. (4)'s V_i, any order, default 6). The R
//! directions are one shared stratified set over the whole sphere per (rays, seed)
//! ([`super::directions`]); rays below the tangent plane are not traced (V = 0 there by
//! definition). The set is the same for every texel, so there is no per-texel noise: each
//! texel's estimate carries the rule's quadrature error on its own visibility function,
//! unbiased over seeds. `tests/bake_visibility.rs` measures that error against exact
//! projections (open plane, inner corner) and bounds seed-to-seed differences.
//!
//! The AO of the same rays, for the EXR and for `preconv`, is the cosine-weighted
//! escaping fraction with the ratio estimator AO = Σ_vis (n·ω_r) / Σ_{n·ω_r>0} (n·ω_r):
//! exactly 1 on an open plane, 0 in a closed box, the same rays as eq. (1).
//!
//! # How it is traced
//!
//! Rays leave [`Tracer::offset_origin`] (no acne, no leaks at contacts: see
//! [`super::trace`]). Covered texels are sorted by the dominant axis of their normal,
//! then along a Morton curve of their positions, and cut into groups of
//! [`PACKET_RAYS`] neighbours. A group traces direction by direction: all its texels
//! above the horizon of direction r form one coherent packet
//! ([`Tracer::occluded_coherent`], bit-identical to single rays), so the nodes near the
//! group stay in cache and each node is decoded once per packet. Each texel's escaping
//! rays form a bitmask of R bits, projected by table lookups ([`ShProjector`]). Groups
//! run in parallel (rayon); every texel's result depends only on its own rays, summed in
//! a fixed order, so a bake is bit-identical whatever the thread count.
//!
//! Finally the coefficients and AO are dilated [`DILATION_PASSES`] texels into the chart
//! gutters (one [`DilationPlan`] for both); gutter texels further out keep 0 coefficients and AO 1.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::{Vec3, Vec4};

use rayon::prelude::*;

use super::directions::{DirectionSet, ShProjector};
use super::raster::{DilationPlan, LightmapTexels};
use super::trace::{PACKET_RAYS, RayPacket, Tracer, advise_huge_pages};
use super::{BakeStats, progress_bar};
use crate::sh::Order;

/// Gutter texels filled around charts after the bake (as the AO bake does).
pub const DILATION_PASSES: u32 = 2;

/// What a visibility bake does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VisibilitySettings {
    /// SH order of the coefficients (bands l < order; default 6).
    pub order: Order,
    /// Directions per texel over the whole sphere (validated by
    /// [`super::validate_rays`]); about half are below a texel's horizon and not traced.
    pub rays: u32,
    /// Seed of the shared direction set's rotation.
    pub seed: u64,
    /// Show a progress bar on stderr.
    pub progress: bool,
}

impl Default for VisibilitySettings {
    fn default() -> Self {
        VisibilitySettings {
            order: Order::SIX,
            rays: 1024,
            seed: 0,
            progress: false,
        }
    }
}

/// A baked SH visibility lightmap.
#[derive(Clone, Debug, PartialEq)]
pub struct VisibilityMap {
    /// Texels per side.
    pub res: u32,
    /// SH order of the coefficients.
    pub order: Order,
    /// Coefficients v_i of eq. (1), texel-major: texel t (row-major, y·res + x) holds
    /// `coeffs[t·order² .. (t+1)·order²]` at flat index l(l+1)+m; gutters dilated.
    pub coeffs: Vec<f32>,
    /// Which texels were baked (the rest are dilated, or 0).
    pub covered: Vec<bool>,
    /// Cosine-weighted escaping fraction of the same rays, in [0, 1]; gutters dilated,
    /// 1 further out.
    pub ao: Vec<f32>,
    /// Rays and time of the bake.
    pub stats: BakeStats,
}

impl VisibilityMap {
    /// The order² coefficients of texel `index` (row-major y·res + x).
    ///
    /// # Panics
    /// If `index` ≥ res².
    pub fn texel(&self, index: usize) -> &[f32] {
        let n2 = self.order.coeff_count();
        &self.coeffs[index * n2..(index + 1) * n2]
    }
}

/// Covered texels in tracing order: by the dominant axis (and sign) of the normal, then
/// along a Morton curve of the position in the texels' bounding box (10 bits per axis).
fn texel_order(texels: &LightmapTexels) -> Vec<u32> {
    let covered: Vec<u32> = (0..texels.covered.len() as u32)
        .filter(|&i| texels.covered[i as usize])
        .collect();
    coherent_order(&SurfacePoints::of(texels), covered)
}

/// Where rays leave: world positions and unit geometric normals, indexed alike.
#[derive(Clone, Copy)]
struct SurfacePoints<'a> {
    position: &'a [Vec3],
    normal: &'a [Vec3],
}

impl<'a> SurfacePoints<'a> {
    fn of(texels: &'a LightmapTexels) -> Self {
        SurfacePoints {
            position: &texels.position,
            normal: &texels.normal,
        }
    }
}

/// `points` sorted for coherent packets: by the dominant axis of the normal, then along a
/// Morton curve of the positions (ties by index).
fn coherent_order(texels: &SurfacePoints<'_>, covered: Vec<u32>) -> Vec<u32> {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for &i in &covered {
        let p = texels.position[i as usize];
        (lo, hi) = (lo.min(p), hi.max(p));
    }
    let scale = 1023.0 / (hi - lo).max(Vec3::splat(1e-30));
    let spread = |v: u32| {
        let mut v = u64::from(v) & 0x3ff;
        v = (v | (v << 16)) & 0x0300_00ff;
        v = (v | (v << 8)) & 0x0300_f00f;
        v = (v | (v << 4)) & 0x030c_30c3;
        (v | (v << 2)) & 0x0924_9249
    };
    let key = |i: u32| {
        let n = texels.normal[i as usize];
        let a = n.abs();
        let axis = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            2
        } else {
            4
        };
        let sign = u64::from(n[axis / 2] < 0.0);
        let q = ((texels.position[i as usize] - lo) * scale)
            .round()
            .clamp(Vec3::ZERO, Vec3::splat(1023.0))
            .as_uvec3();
        let morton = spread(q.x) | (spread(q.y) << 1) | (spread(q.z) << 2);
        ((axis as u64 + sign) << 32) | morton
    };
    let mut order = covered;
    order.par_sort_by_cached_key(|&i| (key(i), i));
    order
}

/// Result of one texel group.
struct GroupResult {
    /// order² coefficients per texel of the group.
    coeffs: Vec<f32>,
    ao: Vec<f32>,
    rays: u64,
    /// Time inside the tracer's queries alone, ns (no horizon test, projection or AO);
    /// 0 when not timed.
    trace_ns: u64,
}

/// Traces and projects one group of ≤ [`PACKET_RAYS`] texels (module doc).
fn bake_group(
    tracer: &Tracer,
    texels: &SurfacePoints<'_>,
    dirs: &DirectionSet,
    projector: &ShProjector,
    group: &[u32],
    time_queries: bool,
) -> GroupResult {
    let n2 = projector.order().coeff_count();
    let words = dirs.mask_words();
    let normals: Vec<Vec3> = group.iter().map(|&i| texels.normal[i as usize]).collect();
    let origins: Vec<Vec3> = group
        .iter()
        .zip(&normals)
        .map(|(&i, &n)| tracer.offset_origin(texels.position[i as usize], n))
        .collect();
    let mut packet = RayPacket::new(&origins);
    let mut masks = vec![0u64; group.len() * words];
    let (mut up_cos, mut vis_cos) = (vec![0.0f64; group.len()], vec![0.0f64; group.len()]);
    let mut rays = 0u64;
    let mut trace_ns = 0u64;
    // The normals by coordinate, so that the 64 horizon tests of a direction vectorize;
    // n·d summed in `Vec3::dot`'s order (x, y, z), as [`super::directions::above_horizon`] computes it.
    let mut normal_axes = [[0.0f32; PACKET_RAYS]; 3];
    for (k, n) in normals.iter().enumerate() {
        (normal_axes[0][k], normal_axes[1][k], normal_axes[2][k]) = (n.x, n.y, n.z);
    }
    let [nx, ny, nz] = &normal_axes;
    let mut cos = [0.0f32; PACKET_RAYS];
    for (r, &d) in dirs.dirs().iter().enumerate() {
        for k in 0..PACKET_RAYS {
            cos[k] = nx[k] * d.x + ny[k] * d.y + nz[k] * d.z;
        }
        // Four horizon tests per comparison; lanes past the group have n = 0, so cos = 0.
        let active = (0..PACKET_RAYS / 4).fold(0u64, |a, j| {
            let above = Vec4::from_slice(&cos[4 * j..]).cmpgt(Vec4::ZERO).bitmask();
            a | u64::from(above) << (4 * j)
        });
        if active == 0 {
            continue;
        }
        rays += u64::from(active.count_ones());
        let queried = time_queries.then(Instant::now);
        let visible = active & !tracer.occluded_coherent(&mut packet, d, f32::INFINITY, active);
        if let Some(queried) = queried {
            trace_ns += queried.elapsed().as_nanos() as u64;
        }
        let (word, bit) = (r / 64, r % 64);
        let mut todo = active;
        while todo != 0 {
            let k = todo.trailing_zeros() as usize;
            todo &= todo - 1;
            // No branch on visibility (it mispredicts): an occluded ray adds +0.0 (c's bits
            // masked off, as cos·0 would give), which leaves a sum that started at +0.0 as
            // it was.
            let escaped = visible >> k & 1;
            let c = f64::from(cos[k]);
            up_cos[k] += c;
            vis_cos[k] += f64::from_bits(c.to_bits() & escaped.wrapping_neg());
            masks[k * words + word] |= escaped << bit;
        }
    }
    let mut coeffs = vec![0.0f32; group.len() * n2];
    let mut sum = vec![0.0f64; n2];
    for k in 0..group.len() {
        sum.fill(0.0);
        projector.project(&masks[k * words..(k + 1) * words], &mut sum);
        for (c, s) in coeffs[k * n2..(k + 1) * n2].iter_mut().zip(&sum) {
            *c = *s as f32;
        }
    }
    let ao = up_cos
        .iter()
        .zip(&vis_cos)
        .map(|(&up, &vis)| if up > 0.0 { (vis / up) as f32 } else { 1.0 })
        .collect();
    GroupResult {
        coeffs,
        ao,
        rays,
        trace_ns,
    }
}

/// Bakes SH visibility (and the AO of the same rays) for every covered texel, then
/// dilates [`DILATION_PASSES`] texels into the gutters (see the module doc). A lightmap
/// with no covered texel gives all-zero coefficients.
pub fn bake_visibility(
    tracer: &Tracer,
    texels: &LightmapTexels,
    settings: &VisibilitySettings,
) -> VisibilityMap {
    let start = Instant::now();
    let res = texels.res as usize;
    let n2 = settings.order.coeff_count();
    let dirs = DirectionSet::new(settings.rays, settings.seed);
    let projector = ShProjector::new(&dirs, settings.order);
    let order = texel_order(texels);
    let ordered = start.elapsed().as_secs_f64();
    let points = SurfacePoints::of(texels);
    let progress = progress_bar(settings.progress, order.len(), "visibility");
    let rays_done = AtomicU64::new(0);
    // Two clock reads a query cost a few per cent of a small scene's bake: only with
    // RUST_LOG=debug, which logs the queries' own rate.
    let time_queries = log::log_enabled!(log::Level::Debug);
    let groups: Vec<&[u32]> = order.chunks(PACKET_RAYS).collect();
    // One group per job: rayon otherwise runs one contiguous run of groups per thread,
    // and groups in tracing order differ in cost (by normal axis), so a thread idled for
    // a tenth of the bake. The same holds for the other bakes' groups and rows.
    let trace = || -> Vec<GroupResult> {
        groups
            .par_iter()
            .with_max_len(1)
            .map(|group| {
                let result = bake_group(tracer, &points, &dirs, &projector, group, time_queries);
                let total = rays_done.fetch_add(result.rays, Ordering::Relaxed) + result.rays;
                if settings.progress {
                    let s = start.elapsed().as_secs_f64().max(1e-9);
                    progress.set_message(format!("{:.2} Mrays/s", total as f64 / s * 1e-6));
                    progress.inc(group.len() as u64);
                }
                result
            })
            .collect()
    };
    // The dilation plan needs only the coverage: a job beside the groups, off the
    // serial tail.
    let (results, plan) = rayon::join(trace, || dilation_plan(&texels.covered, texels.res));
    progress.finish_and_clear();
    let traced = start.elapsed().as_secs_f64();

    // Scattered to texels row by row in parallel (each row's pages are first touched
    // by the thread that fills them).
    let mut slot_of = vec![u32::MAX; res * res];
    for (slot, &i) in order.iter().enumerate() {
        slot_of[i as usize] = slot as u32;
    }
    let mut coeffs = vec![0.0f32; res * res * n2];
    // Not touched yet: 2 MiB pages make its first touch and the dilation's passes
    // cheaper (fewer page faults and TLB misses over tens of MB).
    advise_huge_pages(&coeffs);
    let mut ao = vec![1.0f32; res * res];
    coeffs
        .par_chunks_mut((res * n2).max(1))
        .zip(ao.par_chunks_mut(res.max(1)))
        .zip(slot_of.par_chunks(res.max(1)))
        .for_each(|((coeff_row, ao_row), slots)| {
            for (x, &slot) in slots.iter().enumerate() {
                if slot == u32::MAX {
                    continue;
                }
                let (result, k) = (
                    &results[slot as usize / PACKET_RAYS],
                    slot as usize % PACKET_RAYS,
                );
                coeff_row[x * n2..(x + 1) * n2]
                    .copy_from_slice(&result.coeffs[k * n2..(k + 1) * n2]);
                ao_row[x] = result.ao[k];
            }
        });
    let results_trace_ns: u64 = results.iter().map(|r| r.trace_ns).sum();
    drop(results);
    dilate_visibility(&plan, &mut coeffs, n2, &mut ao);
    let map = VisibilityMap {
        res: texels.res,
        order: settings.order,
        coeffs,
        covered: texels.covered.clone(),
        ao,
        stats: BakeStats {
            rays_traced: rays_done.into_inner(),
            seconds: start.elapsed().as_secs_f64(),
        },
    };
    log::debug!(
        "visibility bake phases: set-up and order {ordered:.3} s, trace (and dilation plan) {:.3} s, scatter and dilate {:.3} s",
        traced - ordered,
        map.stats.seconds - traced
    );
    log::info!(
        "visibility bake: {} texels × {} directions (order {}): {} traced",
        order.len(),
        settings.rays,
        settings.order.get(),
        map.stats,
    );
    if time_queries {
        // The tracer's own throughput, as a ray-tracing library's is measured (Embree's
        // harness in ../shared/peers times its occlusion queries alone): rays over the
        // query time summed over the threads, per thread.
        let threads = rayon::current_num_threads() as f64;
        let query_s = results_trace_ns as f64 * 1e-9 / threads;
        log::debug!(
            "visibility bake: the queries alone {:.2} Mrays/s on {threads} threads",
            if query_s > 0.0 {
                map.stats.rays_traced as f64 / query_s * 1e-6
            } else {
                0.0
            }
        );
    }
    map
}

/// SH visibility and AO at arbitrary surface points, as [`bake_visibility`] computes them
/// per texel (same direction set, packets, projection and AO estimator), without a
/// lightmap: the error ladder's visibility at each pixel (`crate::attribution`).
#[derive(Clone, Debug, PartialEq)]
pub struct PointVisibility {
    pub order: Order,
    /// `order²` coefficients per point, point-major.
    pub coeffs: Vec<f32>,
    pub ao: Vec<f32>,
    pub rays_traced: u64,
}

impl PointVisibility {
    /// The coefficients of point `i`.
    pub fn point(&self, i: usize) -> &[f32] {
        let n2 = self.order.coeff_count();
        &self.coeffs[i * n2..(i + 1) * n2]
    }
}

/// [`PointVisibility`] of points `position[i]` with unit geometric normals `normal[i]`.
///
/// # Panics
/// If the slices differ in length (a bug of the caller).
pub fn bake_points(
    tracer: &Tracer,
    position: &[Vec3],
    normal: &[Vec3],
    settings: &VisibilitySettings,
) -> PointVisibility {
    assert_eq!(position.len(), normal.len(), "one normal per point");
    let n2 = settings.order.coeff_count();
    let dirs = DirectionSet::new(settings.rays, settings.seed);
    let projector = ShProjector::new(&dirs, settings.order);
    let points = SurfacePoints { position, normal };
    let order = coherent_order(&points, (0..position.len() as u32).collect());
    let groups: Vec<&[u32]> = order.chunks(PACKET_RAYS).collect();
    let time_queries = false;
    let results: Vec<GroupResult> = groups
        .par_iter()
        .with_max_len(1)
        .map(|group| bake_group(tracer, &points, &dirs, &projector, group, time_queries))
        .collect();
    let mut out = PointVisibility {
        order: settings.order,
        coeffs: vec![0.0; position.len() * n2],
        ao: vec![1.0; position.len()],
        rays_traced: 0,
    };
    for (group, result) in groups.iter().zip(&results) {
        for (k, &i) in group.iter().enumerate() {
            let i = i as usize;
            out.coeffs[i * n2..(i + 1) * n2].copy_from_slice(&result.coeffs[k * n2..(k + 1) * n2]);
            out.ao[i] = result.ao[k];
        }
        out.rays_traced += result.rays;
    }
    out
}

/// The dilation every lightmap of `res`² texels with coverage `covered` gets (each bake's
/// results, and the SH lightmap's fitted bases read back): [`DILATION_PASSES`] texels into
/// the chart gutters.
pub(crate) fn dilation_plan(covered: &[bool], res: u32) -> DilationPlan {
    DilationPlan::new(covered, res, DILATION_PASSES)
}

/// Dilates a visibility bake's coefficient vectors (`n2` per texel) and AO into the chart
/// gutters with `plan` ([`dilation_plan`]; the CPU bake and the GPU simulator).
pub(crate) fn dilate_visibility(
    plan: &DilationPlan,
    coeffs: &mut [f32],
    n2: usize,
    ao: &mut [f32],
) {
    plan.apply_vectors(coeffs, n2);
    plan.apply(ao);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Mesh, Vertex};

    #[test]
    fn texel_order_visits_every_covered_texel_once() {
        let v = |p: [f32; 3], uv: [f32; 2]| Vertex {
            position: p,
            normal: [0.0, 1.0, 0.0],
            uv_lightmap: uv,
            ..Vertex::default()
        };
        let mesh = Mesh {
            vertices: vec![
                v([0.0, 0.0, 0.0], [0.0, 0.0]),
                v([1.0, 0.0, 0.0], [1.0, 0.0]),
                v([1.0, 0.0, 1.0], [1.0, 1.0]),
                v([0.0, 0.0, 1.0], [0.0, 1.0]),
            ],
            indices: vec![0, 3, 2, 0, 2, 1],
        };
        let texels = super::super::raster::rasterize(&mesh, 16);
        let mut order = texel_order(&texels);
        assert_eq!(order.len(), 256);
        order.sort();
        order.dedup();
        assert_eq!(order.len(), 256);
    }
}
