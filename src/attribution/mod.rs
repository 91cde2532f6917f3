//! The error attribution ladder: for a technique, a sequence of images from the
//! footprint reference to its GPU output, each rung removing one idealisation, so that the
//! cost table's error is explained step by step. The rungs between the point-sampled
//! reference and the GPU image are evaluated here, on the CPU in f64, at every covered
//! pixel of a grid of the point G-buffer (`reference::render_point_gbuffer`: the position,
//! shading normal, albedo and lightmap UV the technique's fragment shader sees; the grid
//! every `stride`-th pixel in each direction, [`LadderPixels::pick`]):
//!
//! ```text
//! rung                     irradiance I at the pixel (radiance = albedo/π · max(0, I))
//! point reference          ∫ L V H_n dω, V the exact binary visibility (Monte Carlo)
//! visibility → order O     Σ_j V_j G_j(n),  V_j = ∫ V y_j at the pixel, G_j = ∫ L H_n y_j
//! lighting → order O+2     ∫ L_{O+2} V_O H_n dω   (H exact: the Gaunt product to order 2O+1)
//! clamped cosine → H order ∫ L_{O+2} V_O H_3 dω   (bake::lxh, the paper's eq. (4) in f64)
//! normal table             Σ_j V_j T̃_j(n): the L×H table at its texel centres, f16 with
//!                          its range scale, read with the path's parameterization and
//!                          bilinear filter (sphere::SphereMap::bilinear_taps)
//! lightmap texels          Σ_j Ṽ_j(uv) T̃_j(n): V from the f16 lightmap, bilinear at uv
//! GPU                      the technique's bench image
//! ```
//!
//! V_j at the pixel is traced exactly as the bake traces a texel (`bake::visibility::
//! bake_points`: same directions, same projection), from the pixel's own point along its
//! interpolated vertex normal. G_j uses the full environment map ([`exact_light`]).
//! `pca*` add "PCA compression" after the visibility rung (V projected onto the mean and
//! first M principal vectors, unquantized) and read M + 1 tables or, weights-only, the
//! uniform block of order-3 SH; `preconv` replaces V by the pixel's AO, then truncates
//! irradiance to order 3; `sh2` truncates V to order 2, lighting to order 3 (cosine exact),
//! then the product and the cosine to order 3 (its shader's math — a rung that measures 0,
//! since L₃·V₂ has no band above 3 and the clamped cosine's band 3 vanishes). `shlmap`
//! gathers the inter-reflected radiance at each pixel as its bake gathers a texel (order-3
//! SH, cosine exact), then reads its f16 lightmap. The engine bases (`l1`, `zh3`, …;
//! `sh::bases`) share that first rung, then "basis" (what the texel stores, evaluated by
//! `ShBasis::linear`: linear L1 for the L1 family, each other basis by its own formula) and,
//! for Geomerics and hallucinated ZH3,
//! "reconstruction" (their curve against the linear evaluation of the same values), then
//! the lightmap texels reconstructed as the shader does.
//!
//! Each rung's error is the relative RMSE between consecutive images (`report::metrics`),
//! so the rungs telescope from the reference to the GPU image. The last CPU rung differs
//! from the GPU only by arithmetic precision: f32 shading and the f16 target, ≈ 4·10⁻⁴ on
//! lavapipe; `pca*` reach ≈ 3·10⁻³ there, differences of about one 8-bit weight step that
//! llvmpipe's filtering of the RGBA8 weight textures adds (README, "Error attribution").

mod cluster;
pub mod exact_light;

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use glam::{DVec3, Vec3};
use half::f16;
use rayon::prelude::*;

use crate::bake::lxh::{LxhMatrices, build_table};
use crate::bake::pca::QuantizedPca;
use crate::bake::raster::texel_index_of;
use crate::bake::shlmap::{BakeEnv, BakeLighting, ShLightmapSettings, radiance_at_points};
use crate::bake::visibility::{PointVisibility, bake_points};
use crate::gpu::{Context, GpuError};
use crate::prepare::Prepared;
use crate::reference::render_point_gbuffer;
use crate::render::Frame;
use crate::report::table::AttributionKind;
use crate::sh::Order;
use crate::sh::bases::ShBasis;
use crate::sh::basis::eval_basis;
use crate::sphere::SphereMap;
use crate::technique::pca::{quantized_prefix, weights_only_block};
use crate::technique::tables::{f16_range_scale, max_abs, table_map};
use crate::technique::{HwPath, NmprtVariant, SeamMode, Technique, TechniqueError};
use exact_light::ExactLightTable;

/// What every rung needs at each covered pixel, computed once per bench.
pub struct LadderPixels {
    /// The ladder's grid: every `stride`-th pixel of the frame in each direction
    /// ([`LadderPixels::pick`]), `width` × `height` of them.
    stride: u32,
    width: u32,
    height: u32,
    /// The frame's width, of which the grid picks.
    frame_width: u32,
    /// Grid index of each covered pixel.
    index: Vec<usize>,
    normal: Vec<DVec3>,
    albedo_over_pi: Vec<[f64; 3]>,
    uv: Vec<[f32; 2]>,
    position: Vec<Vec3>,
    /// Interpolated vertex normal (the horizon of the rays).
    normal_g: Vec<Vec3>,
    /// The normal map's tangent-space normal and world frame (tangent, bitangent, vertex
    /// normal) at each pixel: what the H-basis is evaluated and projected in.
    tangent_normal: Vec<DVec3>,
    frame: Vec<[DVec3; 3]>,
    /// Visibility (bake order) and AO at each pixel.
    vis: PointVisibility,
    /// `shlmap`'s incident-radiance SH at each pixel and the bases its bake fitted from
    /// samples, fitted at each pixel from the same rays; gathered on first use.
    sh_radiance: std::sync::OnceLock<crate::bake::shlmap::GatheredPoints>,
    exact: ExactLightTable,
    /// Rung images by stem, kept between rows ([`LadderPixels::rung`]).
    rung_cache: Mutex<VecDeque<(String, Frame)>>,
    /// L×H products at every covered pixel's normal by name, kept between rows
    /// ([`LadderPixels::products`]).
    product_cache: Mutex<VecDeque<(String, Arc<PixelProducts>)>>,
    pub seconds: f64,
}

/// (L×H_n)_j for j < O² at every covered pixel's normal n (pixel-major, O² per pixel).
struct PixelProducts {
    per_pixel: usize,
    values: Vec<[f64; 3]>,
}

impl PixelProducts {
    /// [`shade`] at covered pixel `k`: the same sum of the same products.
    fn shade(&self, k: usize, v: &[f64]) -> [f64; 3] {
        let n = self.per_pixel;
        dot_rgb(v, &self.values[k * n..(k + 1) * n], n)
    }
}

/// Rung images [`LadderPixels`] keeps: the rows of one technique (dx9 and dx10; `pcaM`
/// and `pcaMw`) come one after another, and 24 images (16 MB each at 1280×800 and every pixel) cover the
/// largest family's shared rungs.
const RUNG_CACHE_IMAGES: usize = 24;

/// Per-pixel L×H products [`LadderPixels`] keeps: the lighting-order and cosine-order
/// matrices at the bake's order, which every compressed visibility of that order (the PCA,
/// VQ and CPCA rows after `unc6`) shades with (0.5 GB each at 1280×800, every pixel, order 6).
const PRODUCT_CACHE_TABLES: usize = 2;

impl LadderPixels {
    /// Renders the point G-buffer at `width` × `height`, traces the visibility at each
    /// covered pixel of the grid of every `stride`-th pixel in each direction and
    /// tabulates the exact-lighting integrals.
    ///
    /// # Panics
    /// With `stride` 0 (a bug of the caller).
    pub fn new(
        ctx: &Arc<Context>,
        prepared: &Prepared,
        width: u32,
        height: u32,
        stride: u32,
    ) -> Result<LadderPixels, GpuError> {
        assert!(stride > 0, "the ladder's stride is at least 1");
        let start = Instant::now();
        let g = render_point_gbuffer(ctx, &prepared.scene, width, height)?;
        let (grid_width, grid_height) = (width.div_ceil(stride), height.div_ceil(stride));
        // Frame index of each covered grid pixel, and its grid index.
        let (index, grid_index): (Vec<usize>, Vec<usize>) = (0..grid_height)
            .flat_map(|gy| (0..grid_width).map(move |gx| (gx, gy)))
            .map(|(gx, gy)| {
                let frame = (gy * stride * width + gx * stride) as usize;
                (frame, (gy * grid_width + gx) as usize)
            })
            .filter(|&(i, _)| g.position.rgba[i][3] >= 0.5)
            .unzip();
        let v3 = |f: &Frame, i: usize| Vec3::from_slice(&f.rgba[i][..3]);
        let normals_g: Vec<Vec3> = index
            .iter()
            .map(|&i| v3(&g.vertex_normal, i).normalize_or_zero())
            .collect();
        let tracer = crate::bake::trace::Tracer::new(&prepared.scene.mesh);
        let positions: Vec<Vec3> = index.iter().map(|&i| v3(&g.position, i)).collect();
        let vis = bake_points(
            &tracer,
            &positions,
            &normals_g,
            &prepared.visibility_settings,
        );
        let exact = ExactLightTable::new(&prepared.env, prepared.visibility_settings.order);
        let pi = std::f64::consts::PI;
        Ok(LadderPixels {
            stride,
            width: grid_width,
            height: grid_height,
            frame_width: width,
            normal: index
                .iter()
                .map(|&i| v3(&g.normal, i).as_dvec3().normalize_or_zero())
                .collect(),
            albedo_over_pi: index
                .iter()
                .map(|&i| std::array::from_fn(|c| g.albedo.rgba[i][c] as f64 / pi))
                .collect(),
            uv: index
                .iter()
                .map(|&i| [g.uv_lightmap.rgba[i][0], g.uv_lightmap.rgba[i][1]])
                .collect(),
            tangent_normal: index
                .iter()
                .map(|&i| v3(&g.tangent_normal, i).as_dvec3())
                .collect(),
            frame: index
                .iter()
                .zip(&normals_g)
                .map(|(&i, n)| [v3(&g.tangent, i), v3(&g.bitangent, i), *n].map(|c| c.as_dvec3()))
                .collect(),
            index: grid_index,
            position: positions,
            normal_g: normals_g,
            vis,
            sh_radiance: std::sync::OnceLock::new(),
            exact,
            rung_cache: Mutex::new(VecDeque::new()),
            product_cache: Mutex::new(VecDeque::new()),
            seconds: start.elapsed().as_secs_f64(),
        })
    }

    /// `frame` (of the G-buffer's size) at the ladder's grid: what the rungs are compared
    /// with.
    pub fn pick(&self, frame: &Frame) -> Frame {
        let s = self.stride as usize;
        let rgba = (0..self.height as usize)
            .flat_map(|gy| {
                (0..self.width as usize).map(move |gx| gy * s * self.frame_width as usize + gx * s)
            })
            .map(|i| frame.rgba[i])
            .collect();
        Frame {
            width: self.width,
            height: self.height,
            rgba,
            ms: vec![],
        }
    }

    /// Every how many pixels of the frame, in each direction, the ladder evaluates one.
    pub fn stride(&self) -> u32 {
        self.stride
    }

    /// Covered pixels of the grid.
    pub fn len(&self) -> usize {
        self.index.len()
    }

    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// Rays traced for the per-pixel visibility.
    pub fn rays_traced(&self) -> u64 {
        self.vis.rays_traced
    }

    /// The first `n2` visibility coefficients at pixel `k`, f64.
    fn visibility(&self, k: usize, n2: usize) -> [f64; 36] {
        let mut v = [0.0; 36];
        for (o, &c) in v.iter_mut().zip(&self.vis.point(k)[..n2]) {
            *o = f64::from(c);
        }
        v
    }

    /// The rung image named `stem`, made by `make` unless a recent row made it already:
    /// equal stems are equal images ([`Rung`]), so the rungs that do not depend on the
    /// path (or on the weights-only variant) are computed once per technique.
    fn rung(&self, stem: &str, make: &dyn Fn() -> Frame) -> Frame {
        let cached = |cache: &VecDeque<(String, Frame)>| {
            cache
                .iter()
                .find(|(s, _)| s == stem)
                .map(|(_, f)| f.clone())
        };
        if let Some(frame) = cached(&self.rung_cache.lock().expect("rung cache")) {
            return frame;
        }
        let frame = make();
        let mut cache = self.rung_cache.lock().expect("rung cache");
        if cache.len() == RUNG_CACHE_IMAGES {
            cache.pop_front();
        }
        cache.push_back((stem.to_string(), frame.clone()));
        frame
    }

    /// The products of `m` at every covered pixel's normal, named `name` (equal names are
    /// equal matrices), made on first use and kept for the rows after
    /// ([`PRODUCT_CACHE_TABLES`]).
    fn products(&self, name: &str, m: &LxhMatrices) -> Arc<PixelProducts> {
        let cached = |cache: &VecDeque<(String, Arc<PixelProducts>)>| {
            cache
                .iter()
                .find(|(s, _)| s == name)
                .map(|(_, p)| Arc::clone(p))
        };
        if let Some(products) = cached(&self.product_cache.lock().expect("product cache")) {
            return products;
        }
        let (hn, per_pixel) = (m.h_order.coeff_count(), m.v_order.coeff_count());
        let mut values = vec![[0.0; 3]; self.len() * per_pixel];
        values
            .par_chunks_mut(per_pixel)
            .enumerate()
            .for_each(|(k, out)| {
                let mut h = [0.0; 256];
                m.eval_into(self.normal[k], &mut h[..hn], out);
            });
        let products = Arc::new(PixelProducts { per_pixel, values });
        let mut cache = self.product_cache.lock().expect("product cache");
        if cache.len() == PRODUCT_CACHE_TABLES {
            cache.pop_front();
        }
        cache.push_back((name.to_string(), Arc::clone(&products)));
        products
    }

    /// The image of irradiance `irradiance(k)` at covered pixel k (module doc's radiance).
    fn image(&self, irradiance: impl Fn(usize) -> [f64; 3] + Sync) -> Frame {
        let values: Vec<[f32; 4]> = (0..self.len())
            .into_par_iter()
            .map(|k| {
                let e = irradiance(k);
                let a = self.albedo_over_pi[k];
                [
                    (a[0] * e[0].max(0.0)) as f32,
                    (a[1] * e[1].max(0.0)) as f32,
                    (a[2] * e[2].max(0.0)) as f32,
                    1.0,
                ]
            })
            .collect();
        let mut rgba = vec![[0.0f32; 4]; (self.width * self.height) as usize];
        for (&i, v) in self.index.iter().zip(values) {
            rgba[i] = v;
        }
        Frame {
            width: self.width,
            height: self.height,
            rgba,
            ms: vec![],
        }
    }
}

/// One CPU rung: the step that leads to it, a file stem naming the image (equal stems are
/// equal images, so shared rungs are written once) and the image.
pub struct Rung {
    pub step: AttributionKind,
    pub stem: String,
    pub frame: Frame,
}

/// Σ_j v_j t_j per colour over the first `n` values.
fn dot_rgb(v: &[f64], t: &[[f64; 3]], n: usize) -> [f64; 3] {
    let mut s = [0.0; 3];
    for (vj, tj) in v[..n].iter().zip(&t[..n]) {
        for c in 0..3 {
            s[c] += vj * tj[c];
        }
    }
    s
}

/// `m.shade(n, v)` without allocations (h order ≤ 16, O ≤ 6).
fn shade(m: &LxhMatrices, n: DVec3, v: &[f64]) -> [f64; 3] {
    let mut h = [0.0; 256];
    let mut out = [[0.0; 3]; 36];
    let (hn, vn) = (m.h_order.coeff_count(), m.v_order.coeff_count());
    m.eval_into(n, &mut h[..hn], &mut out[..vn]);
    dot_rgb(v, &out, vn)
}

/// [`LadderPixels::products`]' name of [`exact_cosine`] at the lighting order the ladder
/// pairs with visibility of `order` (O + 2).
fn lighting_order_name(order: Order) -> String {
    format!(
        "lighting order {} × visibility order {order}",
        order.get() + 2
    )
}

/// [`LadderPixels::products`]' name of the L×H matrices of visibility `order` with the
/// run's H order.
fn cosine_order_name(order: Order) -> String {
    format!("L×H at visibility order {order}")
}

/// The exact-cosine product of lighting of order `l` with visibility of order `v`
/// (`LxhMatrices::with_lighting_order` with H to order l + v − 1).
fn exact_cosine(radiance_sh: &[[f64; 3]], l: u32, v: Order) -> LxhMatrices {
    let order = |n: u32| Order::new(n).expect("orders of the ladder are ≤ 16");
    LxhMatrices::with_lighting_order(radiance_sh, order(l), v, order(l + v.get() - 1))
}

/// Bilinear taps of a res² lightmap texture at `uv` (clamp to edge, texel centres at
/// (i + ½)/res), as the GPU's `LinearClamp` sampler.
fn lightmap_taps(res: u32, uv: [f32; 2]) -> ([usize; 4], [f64; 4]) {
    let last = f64::from(res - 1);
    let x = f64::from(uv[0]) * f64::from(res) - 0.5;
    let y = f64::from(uv[1]) * f64::from(res) - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (a, b) = (x - x0, y - y0);
    let c = |v: f64| v.clamp(0.0, last) as usize;
    let (i0, i1, j0, j1) = (c(x0), c(x0 + 1.0), c(y0), c(y0 + 1.0));
    let r = res as usize;
    (
        [j0 * r + i0, j0 * r + i1, j1 * r + i0, j1 * r + i1],
        [(1.0 - a) * (1.0 - b), a * (1.0 - b), (1.0 - a) * b, a * b],
    )
}

/// A local basis fitted to a pixel's order-3 radiance through its frame (tangent, bitangent,
/// normal) and evaluated at its tangent-space normal.
type FitEval<'f> = dyn Fn(&[[f64; 3]], [glam::DVec3; 3], glam::DVec3) -> [f64; 3] + Sync + 'f;

/// Most values per texel a derived basis' rung reads (`dice`: 90).
const LIGHTMAP_MAX_VALUES: usize = 96;

/// `n` (≤ N) per-texel values at `uv`, bilinear, in an array of N; `texel(t, j)` is value j
/// of texel t as stored.
fn lightmap_bilinear<const N: usize>(
    res: u32,
    uv: [f32; 2],
    n: usize,
    texel: impl Fn(usize, usize) -> f64,
) -> [f64; N] {
    assert!(n <= N, "{n} values per texel, at most {N}");
    let (index, weight) = lightmap_taps(res, uv);
    let mut out = [0.0; N];
    for (&t, &w) in index.iter().zip(&weight) {
        if w == 0.0 {
            continue;
        }
        for (j, o) in out.iter_mut().enumerate().take(n) {
            *o += w * texel(t, j);
        }
    }
    out
}

fn f16_round(v: f32) -> f64 {
    f64::from(f16::from_f32(v).to_f32())
}

/// A normal-indexed table as the GPU stores it: `count` RGB values per texel of `map`,
/// range-scaled and rounded to f16 (`technique::tables`), read back bilinearly.
struct StoredTable {
    map: SphereMap,
    count: usize,
    values: Vec<[f64; 3]>,
    /// What the shader multiplies its sums by.
    unscale: f64,
}

impl StoredTable {
    fn new(map: SphereMap, count: usize, value: impl Fn(usize, usize) -> [f32; 3]) -> Self {
        let samples = map.sample_count();
        let raw: Vec<[f32; 3]> = (0..samples * count)
            .map(|i| value(i / count, i % count))
            .collect();
        let scale = f16_range_scale(max_abs(raw.iter().flatten().copied()));
        StoredTable {
            map,
            count,
            values: raw
                .iter()
                .map(|v| v.map(|x| f16_round(x * scale)))
                .collect(),
            unscale: f64::from(1.0 / scale),
        }
    }

    /// The `count` values at `n`, bilinear (not yet unscaled).
    fn eval(&self, n: DVec3) -> [[f64; 3]; 36] {
        let taps = self.map.bilinear_taps(n);
        let mut out = [[0.0; 3]; 36];
        for (&i, &w) in taps.index.iter().zip(&taps.weight) {
            if w == 0.0 {
                continue;
            }
            let base = i as usize * self.count;
            for (o, v) in out.iter_mut().zip(&self.values[base..base + self.count]) {
                for c in 0..3 {
                    o[c] += w * v[c];
                }
            }
        }
        out
    }
}

/// The rungs of a compressed visibility (`compressed(k)`, order `order`, at ladder pixel
/// k): the compression under exact light (`compression`: its kind and stem), then the
/// lighting and the clamped cosine truncated; with the L×H matrices the later rungs use.
fn compression_rungs(
    px: &LadderPixels,
    prepared: &Prepared,
    order: Order,
    compression: (AttributionKind, String),
    base: &str,
    compressed: &(dyn Fn(usize) -> [f64; 36] + Sync),
) -> (Vec<(AttributionKind, String, Frame)>, LxhMatrices) {
    let radiance = &prepared.radiance_sh;
    let n2 = order.coeff_count();
    let exact = |k: usize| {
        let mut g = [[0.0; 3]; 36];
        px.exact.eval(px.normal[k], &mut g);
        g
    };
    let lighting = exact_cosine(radiance, order.get() + 2, order);
    let lxh = LxhMatrices::new(radiance, order, prepared.h_order);
    let (compression_kind, compression_stem) = compression;
    let rung = |kind, stem: String, make: &dyn Fn() -> Frame| (kind, px.rung(&stem, make), stem);
    let rungs = [
        rung(compression_kind, compression_stem, &|| {
            px.image(|k| dot_rgb(&compressed(k), &exact(k), n2))
        }),
        rung(
            AttributionKind::LightingOrder,
            format!("{base}.lighting_order"),
            &|| {
                let products = px.products(&lighting_order_name(order), &lighting);
                px.image(|k| products.shade(k, &compressed(k)))
            },
        ),
        rung(
            AttributionKind::CosineOrder,
            format!("{base}.cosine_order"),
            &|| {
                let products = px.products(&cosine_order_name(order), &lxh);
                px.image(|k| products.shade(k, &compressed(k)))
            },
        ),
    ];
    let rungs = rungs.into_iter().map(|(k, f, stem)| (k, stem, f)).collect();
    (rungs, lxh)
}

/// Builds the CPU rungs of `technique` on `path` (module doc); empty for `shlmap` without
/// an SH lightmap bake.
pub fn cpu_rungs(
    px: &LadderPixels,
    prepared: &Prepared,
    technique: Technique,
    path: HwPath,
) -> Result<Vec<Rung>, TechniqueError> {
    let row = RowLadder {
        px,
        prepared,
        technique,
        path,
        label: format!("{technique}.{path}"),
    };
    let mut rungs = Vec::new();
    family_rungs(technique, &row, &mut rungs)?;
    Ok(rungs)
}

/// A family's rungs: the ladder's per-family interface, implemented beside the ladder, one
/// file per family, dispatched over the registry ([`crate::technique::registry`]).
trait LadderRecipe {
    /// Appends the rungs of this member's row to `rungs`.
    fn rungs(self, row: &RowLadder<'_>, rungs: &mut Vec<Rung>) -> Result<(), TechniqueError>;
}

/// `mod` of every family's recipe, one file per family named as its technique module.
macro_rules! declare_ladder_modules {
    ($($variant:ident: $module:ident::$family:ident,)*) => {
        $(mod $module;)*
    };
}
crate::technique::registry::with_families!(declare_ladder_modules);

macro_rules! define_family_rungs {
    ($($variant:ident: $module:ident::$family:ident,)*) => {
        /// `technique`'s rungs, by its family's [`LadderRecipe`].
        fn family_rungs(
            technique: Technique,
            row: &RowLadder<'_>,
            rungs: &mut Vec<Rung>,
        ) -> Result<(), TechniqueError> {
            match technique {
                $(Technique::$variant(member) => LadderRecipe::rungs(member, row, rungs),)*
            }
        }
    };
}
crate::technique::registry::with_families!(define_family_rungs);

/// What the rungs of one bench row share: the ladder's pixels, the prepared scene, the
/// row's technique and path, and its label (`technique.path`, the stem of the rungs that
/// depend on the path).
struct RowLadder<'a> {
    px: &'a LadderPixels,
    prepared: &'a Prepared,
    technique: Technique,
    path: HwPath,
    label: String,
}

impl<'a> RowLadder<'a> {
    /// Appends the rung `stem`, made through the cache (`LadderPixels::rung`) by `make`.
    fn push(
        &self,
        rungs: &mut Vec<Rung>,
        step: AttributionKind,
        stem: String,
        make: &dyn Fn() -> Frame,
    ) {
        let frame = self.px.rung(&stem, make);
        rungs.push(Rung { step, stem, frame });
    }

    /// G_j at covered pixel `k`: the exact-lighting integrals at its shading normal.
    fn exact(&self, k: usize) -> [[f64; 3]; 36] {
        let mut g = [[0.0; 3]; 36];
        self.px.exact.eval(self.px.normal[k], &mut g);
        g
    }

    /// The first `n2` visibility coefficients at pixel `k` as the bake's f16 lightmap holds
    /// them, bilinear at the pixel's lightmap UV.
    fn lightmap_v(&self, k: usize, n2: usize) -> [f64; 36] {
        let visibility = &self.prepared.visibility;
        let bake_n2 = visibility.order.coeff_count();
        lightmap_bilinear(visibility.res, self.px.uv[k], n2, |t, j| {
            f16_round(visibility.coeffs[t * bake_n2 + j])
        })
    }

    /// Appends the first rung: the pixel's visibility truncated to `order` under exact
    /// light (shared by every technique of that order, so not named after the row).
    fn push_visibility(&self, rungs: &mut Vec<Rung>, order: Order) {
        let px = self.px;
        let n2 = order.coeff_count();
        self.push(
            rungs,
            AttributionKind::VisibilityOrder,
            format!("visibility_order{order}"),
            &|| px.image(|k| dot_rgb(&px.visibility(k, n2), &self.exact(k), n2)),
        );
    }

    /// On `dx11`, appends the block compression rung: the lightmap rung's `eval` of
    /// `per_texel` values, each what the technique's blocks decode to (×`unscale`, the
    /// inverse of its range scale), filtered at the pixel's lightmap UV as the shader
    /// filters them (`DecodedBlocks::filtered`). A row whose data
    /// cannot be compressed was refused before its ladder; a failure here is logged and
    /// leaves the rung out (its share then stays in the CPU → GPU rung).
    fn push_block_compression(
        &self,
        rungs: &mut Vec<Rung>,
        per_texel: usize,
        unscale: f64,
        eval: &(dyn Fn(&[f64], usize) -> [f64; 3] + Sync),
    ) {
        if self.path != HwPath::Dx11 {
            return;
        }
        let px = self.px;
        let decoded =
            match crate::technique::dx11_decoded_values(self.technique, &self.prepared.inputs()) {
                Ok(decoded) => decoded,
                Err(e) => {
                    log::warn!("{}: no block compression rung: {e}", self.label);
                    return;
                }
            };
        // A fit that depends on the run's options (an SG's solver) is cached per option.
        let tag = self
            .technique
            .options_tag(&self.prepared.options)
            .map_or(String::new(), |tag| format!(".{tag}"));
        self.push(
            rungs,
            AttributionKind::BlockCompression,
            format!("{}{tag}.block", self.label),
            &|| {
                px.image(|k| {
                    let (texels, weights) = lightmap_taps(decoded.res, px.uv[k]);
                    let v: Vec<f64> = (0..per_texel)
                        .map(|j| decoded.filtered(&texels, &weights, j) * unscale)
                        .collect();
                    eval(&v, k)
                })
            },
        );
    }

    /// Appends [`compression_rungs`] of `compressed` and returns the L×H matrices the
    /// later rungs use.
    fn push_compression(
        &self,
        rungs: &mut Vec<Rung>,
        order: Order,
        compression: (AttributionKind, String),
        base: &str,
        compressed: &(dyn Fn(usize) -> [f64; 36] + Sync),
    ) -> LxhMatrices {
        let (shared, lxh) =
            compression_rungs(self.px, self.prepared, order, compression, base, compressed);
        rungs.extend(
            shared
                .into_iter()
                .map(|(step, stem, frame)| Rung { step, stem, frame }),
        );
        lxh
    }

    /// The SH lightmap and what its rays gather at each pixel (eq. (1)'s SH and the bake's
    /// sample fits), traced on first use; `None` without an SH lightmap bake.
    fn gathered(
        &self,
    ) -> Option<(
        &'a crate::bake::shlmap::ShLightmap,
        &'a crate::bake::shlmap::GatheredPoints,
    )> {
        let (px, prepared) = (self.px, self.prepared);
        let map = prepared.sh_lightmap.as_ref()?;
        let settings = ShLightmapSettings {
            rays: prepared.visibility_settings.rays,
            seed: prepared.visibility_settings.seed,
            bounces: map.bounces,
            progress: false,
        };
        let gathered = px.sh_radiance.get_or_init(|| {
            let tracer = crate::bake::trace::Tracer::new(&prepared.scene.mesh);
            radiance_at_points(
                &prepared.scene,
                &tracer,
                map,
                &match map.env {
                    BakeEnv::Sh => BakeLighting::Sh(&prepared.radiance_sh),
                    BakeEnv::Pixels => BakeLighting::Pixels(&prepared.env),
                },
                &settings,
                &px.position,
                &px.normal_g,
                &px.frame,
            )
        });
        Some((map, gathered))
    }

    /// The first rung of the lightmap families: incident radiance with inter-reflection
    /// gathered at each pixel as the bake gathers a texel, to order 3 (cosine exact, eq. (2)
    /// at the shading normal). Returns the SH lightmap and the gathered points, `None`
    /// without an SH lightmap bake.
    fn push_radiance_order(
        &self,
        rungs: &mut Vec<Rung>,
    ) -> Option<(
        &'a crate::bake::shlmap::ShLightmap,
        &'a crate::bake::shlmap::GatheredPoints,
    )> {
        let px = self.px;
        let (map, gathered) = self.gathered()?;
        self.push(
            rungs,
            AttributionKind::RadianceOrder,
            "shlmap.radiance_order".into(),
            &|| {
                px.image(|k| {
                    ShBasis::L2.irradiance(&ShBasis::L2.encode(&gathered.sh[k], None), px.normal[k])
                })
            },
        );
        Some((map, gathered))
    }

    /// The lightmap-texels rung of a technique that stores `per_texel` values derived from
    /// the SH lightmap (`stored`: texel-major, before the f16 scale; made only when the rung
    /// is not cached): the values at each pixel as the GPU reads them — range-scaled, f16,
    /// bilinear at the pixel's lightmap UV — and `eval`uated there.
    fn push_lightmap_values(
        &self,
        rungs: &mut Vec<Rung>,
        map: &crate::bake::shlmap::ShLightmap,
        per_texel: usize,
        stored: &dyn Fn() -> Vec<f32>,
        eval: &(dyn Fn(&[f64], usize) -> [f64; 3] + Sync),
    ) {
        let px = self.px;
        // The stored values and their f16 range scale, made once for both rungs (a local
        // basis fits every texel to make them).
        let made = std::cell::OnceCell::new();
        let stored_scaled = || {
            let (values, scale) = made.get_or_init(|| {
                let values = stored();
                let scale = crate::technique::tables::finite_f16_scale(values.iter().copied())
                    .unwrap_or(1.0);
                (values, scale)
            });
            (values.as_slice(), *scale)
        };
        // A fit that depends on the run's options (an SG's solver) is cached per option.
        let label = match self.technique.options_tag(&self.prepared.options) {
            Some(tag) => format!("{}.{tag}", self.technique),
            None => self.technique.to_string(),
        };
        self.push(
            rungs,
            AttributionKind::LightmapTexels,
            format!("{label}.lightmap"),
            &|| {
                let (stored, scale) = stored_scaled();
                let unscale = f64::from(1.0 / scale);
                px.image(|k| {
                    let v: [f64; LIGHTMAP_MAX_VALUES] =
                        lightmap_bilinear(map.res, px.uv[k], per_texel, |t, j| {
                            f16_round(stored[t * per_texel + j] * scale) * unscale
                        });
                    eval(&v[..per_texel], k)
                })
            },
        );
        if self.path == HwPath::Dx11 {
            let (_, scale) = stored_scaled();
            self.push_block_compression(rungs, per_texel, f64::from(1.0 / scale), eval);
        }
    }

    /// The rungs of a basis over the tangent frame (the hemisphere bases, the ambient
    /// cube): the pixel's gathered radiance, then the basis fitted to it through the pixel's
    /// own frame and evaluated at its tangent-space normal (rung `{basis_label}.basis`),
    /// then the lightmap's f16 values (`eval` reads them). Where the run fits the bases
    /// from samples (`--basis-fit samples`), the basis rung is the fit of the pixel's own
    /// radiance samples (the bake's rays traced from the pixel) and the lightmap holds the
    /// bake's fits; otherwise (`l2`) the basis is fitted to the pixel's order-3 SH
    /// (`fit_eval`) and the lightmap to each texel's (`stored`).
    fn tangent_basis(
        &self,
        rungs: &mut Vec<Rung>,
        basis_label: String,
        fit_eval: &FitEval<'_>,
        per_texel: usize,
        stored: &dyn Fn(&crate::bake::shlmap::ShLightmap) -> Vec<f32>,
        eval: &(dyn Fn(&[f64], glam::DVec3) -> [f64; 3] + Sync),
    ) {
        let px = self.px;
        // The run's fit from samples, where the bake made it.
        let sampled = self
            .technique
            .sample_fit(&self.prepared.options)
            .filter(|&fit| {
                let map = self.prepared.sh_lightmap.as_ref();
                map.is_some_and(|m| m.fitted(fit).is_some())
            });
        let gathered = match sampled {
            // From samples: straight from the incident radiance, no order-3 SH between.
            Some(_) => self.gathered(),
            None => self.push_radiance_order(rungs),
        };
        let Some((map, gathered)) = gathered else {
            return;
        };
        match sampled {
            Some(fit) => self.push(
                rungs,
                AttributionKind::SampledBasis,
                format!("{basis_label}.basis.samples"),
                &|| {
                    px.image(|k| {
                        // The pixels are fitted with every fit of the bake.
                        let values = gathered.fitted_at(fit, k).unwrap_or_default();
                        let v: Vec<f64> = values.iter().map(|&x| f64::from(x)).collect();
                        eval(&v, px.tangent_normal[k])
                    })
                },
            ),
            None => self.push(
                rungs,
                AttributionKind::Basis,
                format!("{basis_label}.basis"),
                &|| px.image(|k| fit_eval(&gathered.sh[k], px.frame[k], px.tangent_normal[k])),
            ),
        }
        let fitted = sampled.and_then(|fit| map.fitted(fit));
        self.push_lightmap_values(
            rungs,
            map,
            per_texel,
            &|| match fitted {
                Some(f) => f.texel_values(),
                None => stored(map),
            },
            &|v, k| eval(v, px.tangent_normal[k]),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lightmap_taps_match_clamp_to_edge_bilinear() {
        // At a texel centre: that texel alone.
        let (i, w) = lightmap_taps(4, [1.5 / 4.0, 2.5 / 4.0]);
        let total: f64 = i
            .iter()
            .zip(&w)
            .filter(|(t, _)| **t == 2 * 4 + 1)
            .map(|(_, w)| w)
            .sum();
        assert!((total - 1.0).abs() < 1e-12, "{i:?} {w:?}");
        // Half-way between texels 0 and 1 of row 0, and past the edge: clamped.
        let (i, w) = lightmap_taps(4, [1.0 / 4.0, 0.0]);
        assert_eq!((i[0], i[1]), (0, 1));
        assert!((w[0] + w[2] - 0.5).abs() < 1e-12 && (w[1] + w[3] - 0.5).abs() < 1e-12);
        let (i, _) = lightmap_taps(4, [1.0, 1.0]);
        assert!(i.iter().all(|&t| t == 15));
    }
}
