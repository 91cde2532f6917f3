//! The GPU visibility simulator (PRT course, "GPU simulator"): the [`super::visibility`]
//! bake's eq. (1) with the rays replaced by depth maps, so big scenes bake on the device
//! that renders them. `shvis bake --baker gpu`.
//!
//! For each direction d_r of the bake's own set ([`DirectionSet`], same rays and seed) the
//! scene is drawn orthographically along d_r over its bounding box (the window fitted to
//! the box's projection) into a `res`² map of the *sky distance* s(p) = σ − (p − c)·d_r
//! (σ: the box's furthest extent along d_r) of the nearest surface
//! (`crate::gpu::visibility_sim`). A texel whose ray origin o (the CPU bake's
//! [`super::trace::Tracer::offset_origin`]) is above its horizon escapes along d_r when
//!
//! ```text
//! s(o) ≤ map(o) + b,   b = h·(b₀ + b₁·min(tan θ, 10)),   h = the larger texel side,   cos θ = n·d_r
//! ```
//!
//! i.e. nothing lies nearer the sky than o by more than the bias — the depth test — refined
//! by an exact test. The depth pass also stores each map texel's triangle; the triangles of
//! the 3 × 3 texels around o are intersected with the line o + t·d_r (Möller–Trumbore, both
//! faces). One at t ≥ the CPU tracer's t_min lies on the ray: o is occluded, as the CPU
//! tracer finds. One that the line crosses at o's own surface (t within −(2ε/cos θ + h)
//! of o, ε the origin's offset) is the nearest surface to the sky there: o escapes, whatever
//! the depth test says. Only where no triangle around o crosses its line does the depth
//! test decide. The map samples the texel's own surface up to h/√2 away in the image
//! plane, where it is up to h/√2·tan θ nearer the sky: the slope term b₁ covers that, the
//! constant b₀ the rasterizer's and f32's rounding. Why the exact test: within a map texel
//! of an occluder's silhouette (a floor texel at the foot of a wall) the depth test reads
//! the floor beside the wall (a leak) or the wall where it does not cover o (a false
//! shadow); the triangles around o settle it on the very ray the CPU traces. On the peers'
//! house at 2048² the texels beyond the quadrature noise are 0.45 % with it, 1.81 % without
//! (README). Then v_i = Σ_{escaping r} w·y_i(d_r), w = 4π/R, and the AO of the same rays,
//! as on the CPU; gutters are dilated the same way.
//!
//! What still differs from the CPU bake: an occluder of triangles smaller than a map texel
//! (or one seen edge-on, thinner than a texel) may cover o without being any texel's
//! nearest surface — then the exact test does not see it and the depth test decides, with
//! its bias. That shrinks with h: the default 4096² keeps the peers' `big` (507k triangles,
//! a displaced sphere) at 0.38 % of texels beyond the quadrature noise, against 1.75 % at
//! 2048² ([`compare`] counts them; `tests/bake_visibility.rs` holds the simulator to the CPU
//! bake).

use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;

use super::directions::{DirectionSet, above_horizon};
use super::raster::LightmapTexels;
use super::trace::{ray_epsilon_of, usable_triangles};
use super::visibility::{VisibilityMap, VisibilitySettings, dilate_visibility, dilation_plan};
use super::{BakeStats, progress_bar};
use crate::gpu::visibility_sim::{self, DirectionView, SimulationJob};
use crate::gpu::{Context, GpuError};
use crate::scene::Mesh;
use crate::sh::Order;
use crate::sh::basis::eval_basis;

/// Largest depth map side the simulator accepts.
pub const MAX_DEPTH_RES: u32 = 8192;

/// How the simulator renders and compares (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuVisibilitySettings {
    /// Depth-map texels per side.
    pub depth_res: u32,
    /// b₀: constant bias, depth-map texels.
    pub bias_texels: f32,
    /// b₁: bias per unit tan θ, depth-map texels.
    pub slope_bias_texels: f32,
}

impl Default for GpuVisibilitySettings {
    fn default() -> Self {
        GpuVisibilitySettings {
            depth_res: 4096,
            bias_texels: 0.1,
            slope_bias_texels: 0.5,
        }
    }
}

/// A GPU bake and where its time went.
pub struct GpuVisibilityBake {
    pub map: VisibilityMap,
    /// GPU ms of the direction passes and of the projection (`None` without timestamps).
    pub gpu_ms: Option<(f64, f64)>,
    /// Uploads, shader compiles and pipelines, seconds.
    pub setup_s: f64,
}

/// Bakes `settings`' visibility of `texels` on `ctx` (module doc).
///
/// # Errors
/// A depth map outside 1..=[`MAX_DEPTH_RES`] or the device's framebuffer limit, a mesh
/// with no usable triangle or a lightmap with no covered texel, or a failing Vulkan call.
pub fn bake_visibility_gpu(
    ctx: &Arc<Context>,
    mesh: &Mesh,
    texels: &LightmapTexels,
    settings: &VisibilitySettings,
    gpu: &GpuVisibilitySettings,
) -> Result<GpuVisibilityBake, GpuError> {
    let start = Instant::now();
    let invalid = |detail: String| GpuError::Invalid {
        what: "gpu visibility bake".into(),
        detail,
    };
    if !(1..=MAX_DEPTH_RES).contains(&gpu.depth_res) {
        return Err(invalid(format!(
            "--depth-res {} is outside 1..={MAX_DEPTH_RES}",
            gpu.depth_res
        )));
    }
    let triangles = usable_triangles(mesh);
    let covered: Vec<u32> = (0..texels.covered.len() as u32)
        .filter(|&i| texels.covered[i as usize])
        .collect();
    if triangles.is_empty() || covered.is_empty() {
        return Err(invalid(
            "the mesh has no usable triangle or the lightmap no covered texel".into(),
        ));
    }
    let corners = || triangles.iter().flat_map(|(_, p)| *p);
    let epsilon = ray_epsilon_of(corners());
    let scene_box = SceneBox::around(corners());

    let positions: Vec<[f32; 3]> = corners().map(|v| v.to_array()).collect();
    let points: Vec<[f32; 4]> = covered
        .iter()
        .flat_map(|&i| {
            let (p, n) = (texels.position[i as usize], texels.normal[i as usize]);
            let o = p + n * epsilon;
            [o.extend(1.0).to_array(), n.extend(0.0).to_array()]
        })
        .collect();
    let dirs = DirectionSet::new(settings.rays, settings.seed);
    let n2 = settings.order.coeff_count();
    let mask_words = dirs.len().div_ceil(32) as u32;
    let weighted_basis = quadrature_basis(&dirs, settings.order);
    let views = direction_views(
        &dirs,
        &scene_box,
        gpu,
        covered.len() as u32,
        mask_words,
        epsilon,
    );
    let directions: Vec<[f32; 4]> = dirs
        .dirs()
        .iter()
        .map(|d| d.extend(0.0).to_array())
        .collect();

    let bar = progress_bar(settings.progress, dirs.len(), "gpu visibility (directions)");
    let progress = |done: usize| bar.set_position(done as u64);
    let result = visibility_sim::run(
        ctx,
        &SimulationJob {
            res: gpu.depth_res,
            positions: &positions,
            points: &points,
            views: &views,
            directions: &directions,
            weighted_basis: &weighted_basis,
            coeff_count: n2 as u32,
            progress: &progress,
        },
    )?;
    bar.finish_and_clear();

    let (coeffs, ao, rays_traced) = texel_results(texels, &covered, &dirs, &result, n2);
    let map = VisibilityMap {
        res: texels.res,
        order: settings.order,
        coeffs,
        covered: texels.covered.clone(),
        ao,
        stats: BakeStats {
            rays_traced,
            seconds: start.elapsed().as_secs_f64(),
        },
    };
    log::info!(
        "gpu visibility bake: {} texels × {} directions (order {}), {}² depth maps: {}",
        covered.len(),
        dirs.len(),
        settings.order.get(),
        gpu.depth_res,
        map.stats
    );
    Ok(GpuVisibilityBake {
        map,
        gpu_ms: result.gpu_ms,
        setup_s: result.setup_s,
    })
}

/// The scene's bounding box: its centre, and its corners relative to the centre.
struct SceneBox {
    centre: Vec3,
    corners: Vec<Vec3>,
}

impl SceneBox {
    /// The box around `points`, each half-extent at least 1e-6.
    fn around(points: impl Iterator<Item = Vec3>) -> SceneBox {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for v in points {
            (lo, hi) = (lo.min(v), hi.max(v));
        }
        let centre = 0.5 * (lo + hi);
        let half = (0.5 * (hi - lo)).max(Vec3::splat(1e-6));
        let corners: Vec<Vec3> = (0..8)
            .map(|k| {
                let sign = Vec3::new(
                    if k & 1 == 0 { -1.0 } else { 1.0 },
                    if k & 2 == 0 { -1.0 } else { 1.0 },
                    if k & 4 == 0 { -1.0 } else { 1.0 },
                );
                sign * half
            })
            .collect();
        SceneBox { centre, corners }
    }

    /// The window and sky range along `axis`: the box's projection, with a margin that
    /// keeps every corner strictly inside.
    fn fit(&self, axis: Vec3) -> (f32, f32) {
        let (mut a, mut b) = (f32::INFINITY, f32::NEG_INFINITY);
        for q in &self.corners {
            (a, b) = (a.min(q.dot(axis)), b.max(q.dot(axis)));
        }
        let margin = 0.01 * (b - a) + 1e-6;
        (a - margin, b + margin)
    }
}

/// Per direction of `dirs` the order-`order` SH basis times the direction's weight, f32.
fn quadrature_basis(dirs: &DirectionSet, order: Order) -> Vec<f32> {
    let n2 = order.coeff_count();
    let weight = dirs.weight();
    let mut basis = vec![0.0f64; n2];
    let mut weighted = Vec::with_capacity(dirs.len() * n2);
    for d in dirs.dirs() {
        eval_basis(order, d.as_dvec3().normalize(), &mut basis);
        weighted.extend(basis.iter().map(|&y| (weight * y) as f32));
    }
    weighted
}

/// Per direction of `dirs` its orthographic view of `scene_box` (module doc): window and
/// sky range fitted to the box, biases in texels of a `gpu.depth_res`² map.
fn direction_views(
    dirs: &DirectionSet,
    scene_box: &SceneBox,
    gpu: &GpuVisibilitySettings,
    point_count: u32,
    mask_words: u32,
    epsilon: f32,
) -> Vec<DirectionView> {
    dirs.dirs()
        .iter()
        .enumerate()
        .map(|(r, &d)| {
            let (u, v) = d.any_orthonormal_pair();
            let ((u0, u1), (v0, v1), (d0, d1)) =
                (scene_box.fit(u), scene_box.fit(v), scene_box.fit(d));
            // The larger texel side sets the bias.
            let texel = (u1 - u0).max(v1 - v0) / gpu.depth_res as f32;
            DirectionView {
                axis_u: u.extend(0.5 * (u0 + u1)).to_array(),
                axis_v: v.extend(0.5 * (v0 + v1)).to_array(),
                axis_d: d.extend(d1).to_array(),
                centre: scene_box.centre.extend(gpu.bias_texels * texel).to_array(),
                window: [
                    0.5 * (u1 - u0),
                    0.5 * (v1 - v0),
                    d1 - d0,
                    gpu.slope_bias_texels * texel,
                ],
                res: gpu.depth_res,
                direction: r as u32,
                point_count,
                mask_words,
                t_min: 1e-3 * epsilon,
                epsilon,
                pad: [0; 2],
            }
        })
        .collect()
}

/// The simulator's per-point coefficients and AO written to their texels (zero and one
/// elsewhere), gutters dilated, and the rays above each texel's horizon counted.
fn texel_results(
    texels: &LightmapTexels,
    covered: &[u32],
    dirs: &DirectionSet,
    result: &visibility_sim::SimulationResult,
    n2: usize,
) -> (Vec<f32>, Vec<f32>, u64) {
    let res = texels.res as usize;
    let mut coeffs = vec![0.0f32; res * res * n2];
    let mut ao = vec![1.0f32; res * res];
    let mut rays_traced = 0u64;
    for (k, &i) in covered.iter().enumerate() {
        let i = i as usize;
        coeffs[i * n2..(i + 1) * n2].copy_from_slice(&result.coeffs[k * n2..(k + 1) * n2]);
        ao[i] = result.ao[k];
        let n = texels.normal[i];
        rays_traced += dirs.dirs().iter().filter(|&&d| above_horizon(n, d)).count() as u64;
    }
    dilate_visibility(
        &dilation_plan(&texels.covered, texels.res),
        &mut coeffs,
        n2,
        &mut ao,
    );
    (coeffs, ao, rays_traced)
}

/// How a bake `b` differs from a reference bake `a` of the same texels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BakeDifference {
    /// Covered texels compared.
    pub texels: usize,
    /// The threshold: L2 norm of a texel's coefficient difference.
    pub threshold: f64,
    /// Fraction of texels whose difference exceeds it.
    pub fraction_above: f64,
    /// RMS over texels of the L2 difference.
    pub rms: f64,
}

/// Per covered texel the L2 norm of `a`'s and `b`'s coefficient difference.
fn texel_differences(a: &VisibilityMap, b: &VisibilityMap) -> Vec<f64> {
    let n2 = a.order.coeff_count().min(b.order.coeff_count());
    (0..a.covered.len())
        .filter(|&i| a.covered[i] && b.covered.get(i) == Some(&true))
        .map(|i| {
            let (x, y) = (a.texel(i), b.texel(i));
            (0..n2)
                .map(|k| (f64::from(x[k]) - f64::from(y[k])).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .collect()
}

/// The quadrature noise of one bake, from two bakes with different direction sets
/// (seeds): the RMS over texels of their L2 difference over √2 (the two errors are
/// independent, so their difference has twice one's variance).
pub fn quadrature_noise(seed_a: &VisibilityMap, seed_b: &VisibilityMap) -> f64 {
    let d = texel_differences(seed_a, seed_b);
    (d.iter().map(|x| x * x).sum::<f64>() / d.len().max(1) as f64).sqrt() / 2f64.sqrt()
}

/// How `b` differs from `a`, counting texels above `threshold`.
pub fn compare(a: &VisibilityMap, b: &VisibilityMap, threshold: f64) -> BakeDifference {
    let d = texel_differences(a, b);
    let n = d.len().max(1) as f64;
    BakeDifference {
        texels: d.len(),
        threshold,
        fraction_above: d.iter().filter(|&&x| x > threshold).count() as f64 / n,
        rms: (d.iter().map(|x| x * x).sum::<f64>() / n).sqrt(),
    }
}
