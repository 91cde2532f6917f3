//! The error attribution ladder: for a technique, a sequence of images from the
//! footprint reference to its GPU output, each rung removing one idealisation, so that the
//! cost table's error is explained step by step. The rungs between the point-sampled
//! reference and the GPU image are evaluated here, on the CPU in f64, at every covered
//! pixel of the point G-buffer (`reference::render_point_gbuffer`: the position, shading
//! normal, albedo and lightmap UV the technique's fragment shader sees):
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
use crate::bake::shlmap::{ShLightmapSettings, radiance_at_points};
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
    width: u32,
    height: u32,
    /// Frame index of each covered pixel.
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
    /// `shlmap`'s incident-radiance SH at each pixel, gathered on first use.
    sh_radiance: std::sync::OnceLock<Vec<[[f64; 3]; 9]>>,
    exact: ExactLightTable,
    /// Rung images by stem, kept between rows ([`LadderPixels::rung`]).
    rung_cache: Mutex<VecDeque<(String, Frame)>>,
    pub seconds: f64,
}

/// Rung images [`LadderPixels`] keeps: the rows of one technique (dx9 and dx10; `pcaM`
/// and `pcaMw`) come one after another, and 24 images (16 MB each at 1280×800) cover the
/// largest family's shared rungs.
const RUNG_CACHE_IMAGES: usize = 24;

impl LadderPixels {
    /// Renders the point G-buffer, traces the visibility at each covered pixel and
    /// tabulates the exact-lighting integrals.
    pub fn new(
        ctx: &Arc<Context>,
        prepared: &Prepared,
        width: u32,
        height: u32,
    ) -> Result<LadderPixels, GpuError> {
        let start = Instant::now();
        let g = render_point_gbuffer(ctx, &prepared.scene, width, height)?;
        let index: Vec<usize> = (0..g.position.rgba.len())
            .filter(|&i| g.position.rgba[i][3] >= 0.5)
            .collect();
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
            width,
            height,
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
            index,
            position: positions,
            normal_g: normals_g,
            vis,
            sh_radiance: std::sync::OnceLock::new(),
            exact,
            rung_cache: Mutex::new(VecDeque::new()),
            seconds: start.elapsed().as_secs_f64(),
        })
    }

    /// Covered pixels.
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
            &|| px.image(|k| shade(&lighting, px.normal[k], &compressed(k))),
        ),
        rung(
            AttributionKind::CosineOrder,
            format!("{base}.cosine_order"),
            &|| px.image(|k| shade(&lxh, px.normal[k], &compressed(k))),
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
    match technique {
        Technique::Unc { order } => row.unc(&mut rungs, order)?,
        Technique::Pca { m, weights_only } => row.pca(&mut rungs, m, weights_only)?,
        Technique::Vq { .. } | Technique::Cpca { .. } => row.clustered(&mut rungs)?,
        // The CPU ladder walks lightmap texels; per-vertex weights have none.
        Technique::PcaVertex { .. } => {}
        Technique::Preconv => row.preconv(&mut rungs),
        Technique::Sh2 => row.sh2(&mut rungs),
        // No ladder for the radiosity-normal-mapping family yet: its error is measured
        // against the displaced-geometry reference (`study rnm`), not split into rungs.
        // The NDF variants' rungs are their base technique's; their own step (the normal
        // map's filtering) is measured by `shvis study ndf`.
        // `nmprt*`: no ladder yet (its rungs would be the transfer bake's lighting order,
        // the normal basis' truncation and the bounces; only its total error is reported).
        Technique::Rnm { .. } | Technique::Ndf { .. } => {}
        // `nmprt*`: the technique's own model per pixel, exact (f32 texel values, f64
        // evaluation, the SVD basis evaluated rather than looked up); what remains to the
        // GPU image is f16 storage and the basis texture. No rungs before it yet (the
        // transfer's lighting order, the order-3 transferred radiance, the bounces).
        Technique::Nmprt { variant } => row.nmprt(&mut rungs, variant),
        Technique::Shlmap => row.lightmap_sh(&mut rungs, None),
        Technique::EngineSh { basis } => row.lightmap_sh(&mut rungs, Some(basis.sh_basis())),
        Technique::Local {
            basis: crate::technique::LocalBasis::HBasis(size),
        } => row.hbasis(&mut rungs, size),
        Technique::Local {
            basis: crate::technique::LocalBasis::Sg { lobes },
        } => row.sg(&mut rungs, lobes),
        Technique::Local {
            basis: crate::technique::LocalBasis::Dice(variant),
        } => row.dice(&mut rungs, variant),
    }
    Ok(rungs)
}

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
        // An SG fit depends on the run's solver: its rung is cached per solver.
        let sg = matches!(
            self.technique,
            Technique::Local {
                basis: crate::technique::LocalBasis::Sg { .. }
            }
        );
        let sg_solver = if sg {
            format!(".{}", self.prepared.sg_solver)
        } else {
            String::new()
        };
        self.push(
            rungs,
            AttributionKind::BlockCompression,
            format!("{}{sg_solver}.block", self.label),
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

    /// `unc`'s rungs: visibility, lighting and cosine orders, the normal table, the
    /// lightmap texels.
    fn unc(&self, rungs: &mut Vec<Rung>, order: Order) -> Result<(), TechniqueError> {
        let (px, prepared, technique, label) =
            (self.px, self.prepared, self.technique, &self.label);
        let radiance = &prepared.radiance_sh;
        let n2 = order.coeff_count();
        self.push_visibility(rungs, order);
        let lighting = exact_cosine(radiance, order.get() + 2, order);
        self.push(
            rungs,
            AttributionKind::LightingOrder,
            format!("{technique}.lighting_order"),
            &|| px.image(|k| shade(&lighting, px.normal[k], &px.visibility(k, n2))),
        );
        let lxh = LxhMatrices::new(radiance, order, prepared.h_order);
        self.push(
            rungs,
            AttributionKind::CosineOrder,
            format!("{technique}.cosine_order"),
            &|| px.image(|k| shade(&lxh, px.normal[k], &px.visibility(k, n2))),
        );
        let map = table_map(self.path, prepared.table_res, label)?;
        let table = build_table(&lxh, map);
        let stored = StoredTable::new(map, n2, |t, j| table.values[t * n2 + j]);
        let table_dot = |v: &[f64], k: usize| {
            dot_rgb(v, &stored.eval(px.normal[k]), n2).map(|x| x * stored.unscale)
        };
        self.push(
            rungs,
            AttributionKind::NormalTable,
            format!("{label}.normal_table"),
            &|| px.image(|k| table_dot(&px.visibility(k, n2), k)),
        );
        self.push(
            rungs,
            AttributionKind::LightmapTexels,
            format!("{label}.lightmap"),
            &|| px.image(|k| table_dot(&self.lightmap_v(k, n2), k)),
        );
        self.push_block_compression(rungs, n2, 1.0, &table_dot);
        Ok(())
    }

    /// `pcaM` and `pcaMw`'s rungs: visibility order, the PCA compression and the rungs of
    /// [`compression_rungs`], then the stored form (tables, or the weights-only block).
    fn pca(&self, rungs: &mut Vec<Rung>, m: u32, weights_only: bool) -> Result<(), TechniqueError> {
        let (px, label) = (self.px, &self.label);
        let model = &self.prepared.pca;
        let order = model.order;
        let n2 = order.coeff_count();
        if n2 > 36 {
            log::warn!(
                "{label}: the error ladder handles PCA of visibility up to order 6, the bake has order {order}; no CPU rungs"
            );
            return Ok(());
        }
        let m = (m as usize).min(model.basis.len());
        self.push_visibility(rungs, order);
        // V_e + Σ_k (V_k·(V − V_e)) V_k over the first m (orthonormal) vectors.
        let compressed = |k: usize| {
            let v = px.visibility(k, n2);
            let mut out = [0.0; 36];
            out[..n2].copy_from_slice(&model.mean[..n2]);
            for b in &model.basis[..m] {
                let w: f64 = (0..n2).map(|j| b[j] * (v[j] - model.mean[j])).sum();
                for j in 0..n2 {
                    out[j] += w * b[j];
                }
            }
            out
        };
        let base = format!("pca{m}");
        let lxh = self.push_compression(
            rungs,
            order,
            (
                AttributionKind::PcaCompression,
                format!("{base}.pca_compression"),
            ),
            &base,
            &compressed,
        );
        let q = quantized_prefix(model, m);
        // The stored weights, bilinear: UNORM8 reads as q / 255.
        let unorm = f64::from((1u32 << q.bits) - 1);
        let lightmap_u = |k: usize| {
            lightmap_bilinear(q.res, px.uv[k], q.m, |t, i| {
                f64::from(q.weights_unorm[t * q.m + i]) / unorm
            })
        };
        if weights_only {
            self.push_pca_weights_only_lightmap(rungs, order, &q, &lightmap_u);
        } else {
            self.push_pca_table_rungs(rungs, &lxh, &q, &compressed, &lightmap_u)?;
        }
        Ok(())
    }

    /// `pcaMw`'s lightmap rung: the stored weights `lightmap_u` applied to the uniform
    /// block of order-3 SH (`weights_only_block`), evaluated at the shading normal.
    fn push_pca_weights_only_lightmap(
        &self,
        rungs: &mut Vec<Rung>,
        order: Order,
        q: &QuantizedPca,
        lightmap_u: &(dyn Fn(usize) -> [f64; 36] + Sync),
    ) {
        let (px, technique) = (self.px, self.technique);
        let block = weights_only_block(&q.basis, &q.mean, order, &self.prepared.radiance_sh);
        let shade_weights = |u: &[f64], k: usize| {
            let mut y = [0.0; 9];
            eval_basis(Order::THREE, px.normal[k], &mut y);
            let mut e = [0.0; 3];
            for (i, yi) in y.iter().enumerate() {
                for c in 0..3 {
                    let mut coeff = f64::from(block[9 * q.m + i][c]);
                    for (b, ub) in u[..q.m].iter().enumerate() {
                        coeff += ub * f64::from(block[9 * b + i][c]);
                    }
                    e[c] += coeff * yi;
                }
            }
            e
        };
        self.push(
            rungs,
            AttributionKind::LightmapTexels,
            format!("{technique}.lightmap"),
            &|| px.image(|k| shade_weights(&lightmap_u(k), k)),
        );
        // The blocks decode to the weights' unorm values, as the RGBA8 lightmap reads.
        self.push_block_compression(rungs, q.m, 1.0, &shade_weights);
    }

    /// `pcaM`'s last rungs: the quantized basis's and mean's normal tables read with the
    /// compressed V's continuous weights (normal table), then with the stored weights
    /// `lightmap_u` (lightmap texels).
    fn push_pca_table_rungs(
        &self,
        rungs: &mut Vec<Rung>,
        lxh: &LxhMatrices,
        q: &QuantizedPca,
        compressed: &(dyn Fn(usize) -> [f64; 36] + Sync),
        lightmap_u: &(dyn Fn(usize) -> [f64; 36] + Sync),
    ) -> Result<(), TechniqueError> {
        let (px, label) = (self.px, &self.label);
        let n2 = self.prepared.pca.order.coeff_count();
        // Basis tables T_k = Σ_j V_kj (L×H)_j and the mean's, as pca.rs builds them.
        let map = table_map(self.path, self.prepared.table_res, label)?;
        let table = build_table(lxh, map);
        let project = |t: usize, v: &[f64]| table.project(t, v);
        let stored = StoredTable::new(map, q.m + 1, |t, i| {
            project(t, if i < q.m { &q.basis[i] } else { &q.mean })
        });
        let tables_dot = |u: &[f64], k: usize| {
            let t = stored.eval(px.normal[k]);
            let mut s = t[q.m];
            for (ui, ti) in u[..q.m].iter().zip(&t) {
                for c in 0..3 {
                    s[c] += ui * ti[c];
                }
            }
            s.map(|x| x * stored.unscale)
        };
        // The compressed V in the quantized basis's coordinates, unrounded.
        let continuous_u = |k: usize| {
            let v = compressed(k);
            let mut u = [0.0; 36];
            for (ui, b) in u.iter_mut().zip(&q.basis) {
                let norm2: f64 = b.iter().map(|x| x * x).sum();
                if norm2 > 0.0 {
                    *ui = (0..n2).map(|j| b[j] * (v[j] - q.mean[j])).sum::<f64>() / norm2;
                }
            }
            u
        };
        self.push(
            rungs,
            AttributionKind::NormalTable,
            format!("{label}.normal_table"),
            &|| px.image(|k| tables_dot(&continuous_u(k), k)),
        );
        self.push(
            rungs,
            AttributionKind::LightmapTexels,
            format!("{label}.lightmap"),
            &|| px.image(|k| tables_dot(&lightmap_u(k), k)),
        );
        self.push_block_compression(rungs, q.m, 1.0, &tables_dot);
        Ok(())
    }

    /// `vq*` and `cpca*`'s rungs: visibility order, the cluster compression and the rungs
    /// of [`compression_rungs`], then the stored lightmap as the shader reads it.
    fn clustered(&self, rungs: &mut Vec<Rung>) -> Result<(), TechniqueError> {
        let (px, technique, label) = (self.px, self.technique, &self.label);
        let need = technique.cluster_need().expect("a clustered technique");
        let model = crate::technique::cluster::find(&self.prepared.inputs(), need, label)?;
        let order = model.order;
        let n2 = order.coeff_count();
        self.push_visibility(rungs, order);
        let compressed = |k: usize| {
            let mut out = [0.0; 36];
            out[..n2].copy_from_slice(&model.compress(&px.visibility(k, n2)[..n2]));
            out
        };
        let base = technique.name();
        let lxh = self.push_compression(
            rungs,
            order,
            (
                AttributionKind::ClusterCompression,
                format!("{base}.compression"),
            ),
            &base,
            &compressed,
        );
        // The stored lightmap as the shader reads it (glsl/technique/cluster.frag).
        let q = model.quantize();
        let blended = matches!(
            technique,
            Technique::Vq {
                seams: SeamMode::Blended,
                ..
            } | Technique::Cpca {
                seams: SeamMode::Blended,
                ..
            }
        );
        let stored = |k: usize| -> [f64; 36] {
            let mut out = [0.0; 36];
            if blended {
                let (index, weight) = lightmap_taps(q.res, px.uv[k]);
                for (&t, &w) in index.iter().zip(&weight) {
                    for (o, v) in out.iter_mut().zip(q.reconstruct(t)) {
                        *o += w * v;
                    }
                }
            } else {
                let c = q.cluster_of[texel_index_of(q.res, px.uv[k])] as usize;
                let u: [f64; 36] = lightmap_bilinear(q.res, px.uv[k], q.m, |t, i| {
                    f64::from(q.weights_unorm[t * q.m + i]) / 255.0
                });
                out[..n2].copy_from_slice(&q.means[c][..n2]);
                for (b, ub) in q.bases[c].iter().zip(&u) {
                    for (o, bj) in out.iter_mut().zip(b) {
                        *o += ub * bj;
                    }
                }
            }
            out
        };
        self.push(
            rungs,
            AttributionKind::LightmapTexels,
            format!("{label}.lightmap"),
            &|| px.image(|k| shade(&lxh, px.normal[k], &stored(k))),
        );
        Ok(())
    }

    /// `preconv`'s rungs: V replaced by the pixel's AO, irradiance truncated to order 3,
    /// the AO lightmap's texels.
    fn preconv(&self, rungs: &mut Vec<Rung>) {
        let (px, prepared) = (self.px, self.prepared);
        let y00 = 0.5 / std::f64::consts::PI.sqrt();
        let ao = |k: usize| f64::from(px.vis.ao[k]);
        self.push(
            rungs,
            AttributionKind::AmbientOcclusion,
            "preconv.ambient_occlusion".into(),
            // ∫ L H_n = G_0 / y_00.
            &|| px.image(|k| self.exact(k)[0].map(|g| ao(k) * g / y00)),
        );
        let e3 = |k: usize| {
            crate::sh::zonal::eval_rgb(&prepared.irradiance_sh, Order::THREE, px.normal[k])
                .map(|e| e.max(0.0))
        };
        self.push(
            rungs,
            AttributionKind::IrradianceOrder,
            "preconv.irradiance_order".into(),
            &|| px.image(|k| e3(k).map(|e| ao(k) * e)),
        );
        let ao_map = &prepared.ao;
        self.push(
            rungs,
            AttributionKind::LightmapTexels,
            "preconv.lightmap".into(),
            &|| {
                px.image(|k| {
                    let a = lightmap_bilinear::<1>(ao_map.res, px.uv[k], 1, |t, _| {
                        f16_round(ao_map.values[t])
                    })[0];
                    e3(k).map(|e| a * e)
                })
            },
        );
        self.push_block_compression(rungs, 1, 1.0, &|v, k| e3(k).map(|e| v[0] * e));
    }

    /// `sh2`'s rungs: V truncated to order 2, lighting to order 3, then the product and
    /// the cosine to order 3, then the lightmap texels.
    fn sh2(&self, rungs: &mut Vec<Rung>) {
        let px = self.px;
        let radiance = &self.prepared.radiance_sh;
        let order = Order::TWO;
        let n2 = order.coeff_count();
        self.push_visibility(rungs, order);
        let lighting = exact_cosine(radiance, 3, order);
        self.push(
            rungs,
            AttributionKind::LightingOrder,
            "sh2.lighting_order".into(),
            &|| px.image(|k| shade(&lighting, px.normal[k], &px.visibility(k, n2))),
        );
        let product = LxhMatrices::with_lighting_order(radiance, Order::THREE, order, Order::THREE);
        self.push(
            rungs,
            AttributionKind::ProductOrder,
            "sh2.product_order".into(),
            &|| px.image(|k| shade(&product, px.normal[k], &px.visibility(k, n2))),
        );
        self.push(
            rungs,
            AttributionKind::LightmapTexels,
            "sh2.lightmap".into(),
            &|| px.image(|k| shade(&product, px.normal[k], &self.lightmap_v(k, n2))),
        );
        self.push_block_compression(rungs, n2, 1.0, &|v, k| shade(&product, px.normal[k], v));
    }

    /// `nmprt*`'s one rung: the technique's own model at each pixel (none without a
    /// transfer bake).
    fn nmprt(&self, rungs: &mut Vec<Rung>, variant: NmprtVariant) {
        let (px, prepared, technique) = (self.px, self.prepared, self.technique);
        let Some(transfer) = prepared.transfer.as_ref() else {
            return;
        };
        let recipe = crate::technique::nmprt::NmprtRecipe::new(variant, transfer.clone());
        let radiance = &prepared.radiance_sh;
        let irradiance = &prepared.irradiance_sh;
        self.push(
            rungs,
            AttributionKind::Technique,
            format!("{technique}.model"),
            &|| {
                let values = recipe.texel_values_all(radiance, irradiance);
                let v = recipe.values_per_texel();
                px.image(|k| {
                    let x = lightmap_bilinear::<36>(transfer.res, px.uv[k], v, |t, j| {
                        f64::from(values[t * v + j])
                    });
                    // The frame of the nearest covered tap.
                    let (taps, weights) = lightmap_taps(transfer.res, px.uv[k]);
                    let frame = taps
                        .iter()
                        .zip(weights)
                        .filter(|(t, _)| transfer.covered[**t])
                        .max_by(|a, b| a.1.total_cmp(&b.1))
                        .map_or([Vec3::ZERO; 3], |(t, _)| transfer.frames[*t]);
                    recipe.eval(&x[..v], px.normal[k], &frame, irradiance)
                })
            },
        );
    }

    /// The first rung of the lightmap families: incident radiance with inter-reflection
    /// gathered at each pixel as the bake gathers a texel, to order 3 (cosine exact, eq. (2)
    /// at the shading normal). Returns the SH lightmap and the gathered SH, `None` without
    /// an SH lightmap bake.
    fn push_radiance_order(
        &self,
        rungs: &mut Vec<Rung>,
    ) -> Option<(&'a crate::bake::shlmap::ShLightmap, &'a [[[f64; 3]; 9]])> {
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
                &prepared.radiance_sh,
                &settings,
                &px.position,
                &px.normal_g,
            )
        });
        self.push(
            rungs,
            AttributionKind::RadianceOrder,
            "shlmap.radiance_order".into(),
            &|| {
                px.image(|k| {
                    ShBasis::L2.irradiance(&ShBasis::L2.encode(&gathered[k], None), px.normal[k])
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
        // An SG fit depends on the run's solver: its rung is cached per solver.
        let sg = matches!(
            self.technique,
            Technique::Local {
                basis: crate::technique::LocalBasis::Sg { .. }
            }
        );
        let label = if sg {
            format!("{}.{}", self.technique, self.prepared.sg_solver)
        } else {
            self.technique.to_string()
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

    /// The rungs of a local basis (`hb*`, `sg*`, `dice*`): the pixel's gathered radiance,
    /// then the basis fitted to it through the pixel's own frame and evaluated at its
    /// tangent-space normal (`fit_eval`; rung `{basis_label}.basis`), then the lightmap's
    /// f16 values (`stored`, fitted through each texel's frame; `eval` reads them).
    fn local_basis(
        &self,
        rungs: &mut Vec<Rung>,
        basis_label: String,
        fit_eval: &FitEval<'_>,
        per_texel: usize,
        stored: &dyn Fn(&crate::bake::shlmap::ShLightmap) -> Vec<f32>,
        eval: &(dyn Fn(&[f64], glam::DVec3) -> [f64; 3] + Sync),
    ) {
        let px = self.px;
        let Some((map, gathered)) = self.push_radiance_order(rungs) else {
            return;
        };
        self.push(
            rungs,
            AttributionKind::Basis,
            format!("{basis_label}.basis"),
            &|| px.image(|k| fit_eval(&gathered[k], px.frame[k], px.tangent_normal[k])),
        );
        self.push_lightmap_values(rungs, map, per_texel, &|| stored(map), &|v, k| {
            eval(v, px.tangent_normal[k])
        });
    }

    /// The H-basis rungs ([`RowLadder::local_basis`]).
    fn hbasis(&self, rungs: &mut Vec<Rung>, size: crate::sh::hbasis::HBasisSize) {
        use crate::sh::hbasis;
        let rgb = |v: &[f64]| -> Vec<[f64; 3]> {
            (0..size.count())
                .map(|i| [v[3 * i], v[3 * i + 1], v[3 * i + 2]])
                .collect()
        };
        self.local_basis(
            rungs,
            self.technique.to_string(),
            &|radiance, frame, m| {
                hbasis::irradiance(&hbasis::project_irradiance(radiance, frame, size), m)
            },
            3 * size.count(),
            &|map| crate::technique::local::stored_texels(map, size),
            &|v, m| hbasis::irradiance(&rgb(v), m),
        );
    }

    /// The Ambient Dice rungs ([`RowLadder::local_basis`]): the fit at the ten vertices
    /// and its hybrid (or YCoCg) interpolation.
    fn dice(&self, rungs: &mut Vec<Rung>, variant: crate::sh::dice::DiceVariant) {
        let basis = crate::sh::dice::dice();
        self.local_basis(
            rungs,
            self.technique.to_string(),
            &|radiance, frame, m| {
                basis.irradiance(
                    variant,
                    &basis.project_irradiance(variant, radiance, frame),
                    m,
                )
            },
            variant.stored_values(),
            &|map| crate::technique::local::dice_stored_texels(map, variant),
            &|v, m| basis.irradiance(variant, v, m),
        );
    }

    /// The SG rungs ([`RowLadder::local_basis`]): the lobes fitted by the run's solver.
    fn sg(&self, rungs: &mut Vec<Rung>, lobes: u32) {
        use crate::technique::local::{fit_sg, sg_basis, sg_irradiance, sg_stored_texels};
        let basis = sg_basis(lobes);
        let solver = self.prepared.sg_solver;
        let rgb = |v: &[f64]| -> Vec<[f64; 3]> {
            (0..lobes as usize)
                .map(|i| [v[3 * i], v[3 * i + 1], v[3 * i + 2]])
                .collect()
        };
        self.local_basis(
            rungs,
            format!("{}.{solver}", self.technique),
            &|radiance, frame, m| {
                let mut stats = crate::sh::sg::FitStats::default();
                sg_irradiance(
                    &basis,
                    &fit_sg(&basis, radiance, frame, solver, &mut stats),
                    m,
                )
            },
            3 * lobes as usize,
            &|map| sg_stored_texels(map, lobes, solver).0,
            &|v, m| sg_irradiance(&basis, &rgb(v), m),
        );
    }

    /// `shlmap`'s rungs (`basis` `None`) and the engine bases' (module doc): the pixel's
    /// gathered order-3 radiance, then for a basis what it stores evaluated by
    /// [`ShBasis::linear`] and, where that differs, by its own reconstruction; then the
    /// lightmap texels. None without an SH lightmap bake.
    fn lightmap_sh(&self, rungs: &mut Vec<Rung>, basis: Option<ShBasis>) {
        let px = self.px;
        let Some((map, gathered)) = self.push_radiance_order(rungs) else {
            return;
        };
        let l2 = |c: &[[f64; 3]], n: DVec3| ShBasis::L2.irradiance(&ShBasis::L2.encode(c, None), n);
        let Some(basis) = basis else {
            // As the technique stores it (finite: the bench built it first).
            let scale = crate::technique::shlmap::stored_scale(map).unwrap_or(1.0);
            let unscale = f64::from(1.0 / scale);
            self.push(
                rungs,
                AttributionKind::LightmapTexels,
                "shlmap.lightmap".into(),
                &|| {
                    px.image(|k| {
                        let v = lightmap_bilinear::<27>(map.res, px.uv[k], 27, |t, j| {
                            f16_round(map.texel(t)[j / 3][j % 3] * scale)
                        });
                        let c: Vec<[f64; 3]> = (0..9)
                            .map(|i| std::array::from_fn(|ch| v[3 * i + ch] * unscale))
                            .collect();
                        l2(&c, px.normal[k])
                    })
                },
            );
            self.push_block_compression(rungs, 27, unscale, &|v, k| {
                let c: Vec<[f64; 3]> = (0..9)
                    .map(|i| std::array::from_fn(|ch| v[3 * i + ch]))
                    .collect();
                l2(&c, px.normal[k])
            });
            return;
        };
        let technique = self.technique;
        let linear = basis.linear();
        // The pixel's own hemisphere, as a texel's (the deringing's shaded normals).
        let shaded = |k: usize| Some(px.normal_g[k].as_dvec3());
        self.push(
            rungs,
            AttributionKind::Basis,
            format!("{}.basis", linear.label().replace(' ', "_").to_lowercase()),
            &|| {
                px.image(|k| {
                    linear.irradiance(&basis.encode(&gathered[k], shaded(k)), px.normal[k])
                })
            },
        );
        if linear != basis {
            self.push(
                rungs,
                AttributionKind::Reconstruction,
                format!("{technique}.reconstruction"),
                &|| {
                    px.image(|k| {
                        basis.irradiance(&basis.encode(&gathered[k], shaded(k)), px.normal[k])
                    })
                },
            );
        }
        self.push_lightmap_values(
            rungs,
            map,
            basis.stored_values(),
            &|| crate::technique::engine_sh::stored_texels(map, basis),
            &|v, k| basis.irradiance(v, px.normal[k]),
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
