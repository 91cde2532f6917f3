//! Scene + environment → everything techniques read (DESIGN §5's first stages): resolve
//! the scene and the environment by name or path, bake the lightmap data, and prepare the
//! lighting (SH projection, clamped-cosine convolution).

pub mod bake_layers;
pub mod reference_image;
pub mod single_frame;

use std::cell::OnceCell;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use crate::bake::ao::{AoMap, AoSettings, bake_ao};
use crate::bake::cache::{
    default_cache_dir, load_or_bake_sh_lightmap, load_or_bake_visibility, load_or_fit_clusters,
    sh_lightmap_key,
};
use crate::bake::cluster::{self, ClusteredModel};
use crate::bake::pca::{PcaModel, fit};
use crate::bake::raster::{LightmapTexels, rasterize};
use crate::bake::shlmap::{
    BakeEnv, BakeLighting, ShLightmap, ShLightmapSettings, bake_sh_lightmap,
};
use crate::bake::ssbump::{self, SsBumpMaps};
use crate::bake::trace::Tracer;
use crate::bake::transfer::{self, TransferMap, TransferSettings, bake_transfer};
use crate::bake::vertex_pca::{VertexPca, bake_vertex_pca};
use crate::bake::visibility::{VisibilityMap, VisibilitySettings, bake_visibility};
use crate::bake::{self, BakeError};
use crate::env::{self, EnvError, EnvMap};
use crate::scene::Mesh;
use crate::scene::{Scene, SceneError, gltf, house, patio};
use crate::sh::{Order, zonal};
use crate::technique::{Inputs, Technique, vertex};

/// What to prepare.
#[derive(Clone, Debug, PartialEq)]
pub struct PrepareSettings {
    /// `house` or a path to a glTF file.
    pub scene: String,
    /// `sky` or a path to an EXR/HDR environment map.
    pub env: String,
    /// Lightmap texels per side.
    pub vis_res: u32,
    /// Rays per texel.
    pub rays: u32,
    pub seed: u64,
    /// Show progress bars.
    pub progress: bool,
    /// SH order of the visibility bake (techniques use its first coefficients).
    pub order: Order,
    /// L×H table texels per hemisphere (dx9) / cube face (dx10, dx11) side.
    pub table_res: u32,
    /// Order of the clamped cosine in the L×H product (the paper's 3).
    pub h_order: Order,
    /// Each family's run options (`--sg-solve`: how `sgN` fits its amplitudes).
    pub options: crate::technique::FamilyOptions,
    /// Where bakes are cached (`None`: `bake::cache::default_cache_dir()`).
    pub cache_dir: Option<PathBuf>,
    /// Bake the SH lightmap (`shlmap`) with this many bounces; `None`: skip it.
    pub sh_lightmap_bounces: Option<u32>,
    /// The bases its bake fits from each texel's radiance samples (`Technique::sample_fit`
    /// of the run's techniques).
    pub sample_fits: Vec<crate::sh::samples::SampleFit>,
    /// What its rays read of the environment (`--bake-env`).
    pub bake_env: crate::bake::shlmap::BakeEnv,
    /// Bake transfer matrices (`nmprt*`) with this many bounces; `None`: skip them.
    pub transfer_bounces: Option<u32>,
    /// Their lighting order (≤ `LIGHTING_ORDER`).
    pub transfer_order: Order,
    /// `--height-map FILE --height-scale S`: the scene material's height field (replaces
    /// the built-in one), heights in texels = S × value.
    pub height_map: Option<(PathBuf, f64)>,
}

impl Default for PrepareSettings {
    fn default() -> Self {
        PrepareSettings {
            scene: "house".into(),
            env: "sky".into(),
            vis_res: 512,
            rays: 1024,
            seed: 0,
            progress: false,
            order: Order::SIX,
            table_res: 32,
            h_order: Order::THREE,
            options: crate::technique::FamilyOptions::default(),
            cache_dir: None,
            sh_lightmap_bounces: None,
            sample_fits: Vec::new(),
            bake_env: crate::bake::shlmap::BakeEnv::Sh,
            transfer_bounces: None,
            transfer_order: transfer::DEFAULT_LIGHTING_ORDER,
            height_map: None,
        }
    }
}

/// The bases the SH lightmap bake must fit from its samples for `techniques` under
/// `options`, each once, in the techniques' order.
pub fn sample_fits_for(
    techniques: &[crate::technique::Technique],
    options: &crate::technique::FamilyOptions,
) -> Vec<crate::sh::samples::SampleFit> {
    let mut fits = Vec::new();
    for fit in techniques.iter().filter_map(|t| t.sample_fit(options)) {
        if !fits.contains(&fit) {
            fits.push(fit);
        }
    }
    fits
}

/// Baked and lighting data for one scene and environment.
pub struct Prepared {
    pub scene: Scene,
    pub env: EnvMap,
    /// Ambient occlusion from the visibility bake's rays.
    pub ao: AoMap,
    /// SH visibility per lightmap texel.
    pub visibility: VisibilityMap,
    /// How `visibility` was traced (rays, seed, order): what the error ladder repeats at
    /// each pixel.
    pub visibility_settings: VisibilitySettings,
    /// PCA of `visibility` with `PCA_MAX_BASIS` vectors (`pca*` use prefixes of it).
    pub pca: PcaModel,
    /// SH of the environment's radiance, RGB, to order `LIGHTING_ORDER` (≥ visibility + 2).
    pub radiance_sh: Vec<[f64; 3]>,
    /// Order-3 SH of irradiance: `radiance_sh` convolved with the clamped cosine.
    pub irradiance_sh: Vec<[f64; 3]>,
    pub table_res: u32,
    pub h_order: Order,
    pub options: crate::technique::FamilyOptions,
    /// Order-3 SH of incident radiance with inter-reflection, when asked for.
    pub sh_lightmap: Option<ShLightmap>,
    /// Transfer matrices with inter-reflection (lighting of order
    /// `PrepareSettings::transfer_order`), when asked for.
    pub transfer: Option<Arc<TransferMap>>,
    /// VQ / CPCA fits of `visibility` the techniques of the run need
    /// ([`Prepared::fit_clusters`]).
    pub clusters: Vec<ClusteredModel>,
    /// Seed of the cluster fits (the bake's seed).
    pub seed: u64,
    /// Where bakes and fits are cached.
    pub cache_dir: PathBuf,
    /// Visibility baked at mesh vertices for `pcaMv` ([`Prepared::bake_vertex_pca`]).
    pub vertex_pca: Vec<VertexPca>,
    /// The material's SSBump and AO for `ssbump` / `rnmao` ([`Prepared::bake_ssbump`]).
    pub ssbump: Option<SsBumpMaps>,
    /// The moments of the material's normal map for `uncOndf` / `preconvndf`
    /// ([`Prepared::build_ndf_moments`]).
    pub ndf_moments: Option<crate::ndf::NdfMaps>,
}

/// Order of the lighting projection: L×H of order-6 visibility needs lighting of order 8
/// (O + 2, Iwanicki–Sloan §3.3).
pub const LIGHTING_ORDER: u32 = 8;

/// The largest PCA basis of the cost table (`pca24`).
pub const PCA_MAX_BASIS: usize = 24;

/// Smallest `--table-res`.
pub const TABLE_RES_MIN: u32 = 4;
/// Largest `--table-res`.
pub const TABLE_RES_MAX: u32 = 256;
/// Valid `--table-res` values (DESIGN §2: 16–32 per hemisphere is adequate; more for study).
pub const TABLE_RES_RANGE: std::ops::RangeInclusive<u32> = TABLE_RES_MIN..=TABLE_RES_MAX;
/// Highest visibility order: the L×H product needs lighting of order + 2 ≤ `sh::MAX_ORDER`.
pub const MAX_VISIBILITY_ORDER: u32 = crate::sh::MAX_ORDER - 2;

/// The smallest lightmap resolution scene `name` can be baked at (the built-in house's
/// charts and gutters need more texels than generated UVs).
pub fn min_vis_res(name: &str) -> u32 {
    match name {
        // The patio's walls and floor are packed as the house's are.
        "house" | "patio" => house::MIN_LIGHTMAP_RES,
        _ => bake::MIN_RES,
    }
}

/// Bytes a visibility bake of `res`² texels at `order` plans to hold at once: the
/// coefficients as baked (f32), their cache encoding and the prepared copy, plus per-texel
/// geometry, AO and flags (~64 bytes).
pub fn bake_memory_bytes(res: u32, order: u32) -> u64 {
    let texels = u64::from(res) * u64::from(res);
    texels.saturating_mul(12 * u64::from(order) * u64::from(order) + 64)
}

/// The checks of [`prepare`] that need no file, run by the command line before it opens a
/// device or bakes: the lightmap resolution against the scene's range (one message for
/// every scene), rays, order, table resolution and the bake's memory; and
/// [`warn_if_few_rays`].
///
/// # Errors
/// One line naming the option and its range, or the memory it needs.
pub fn check_settings(settings: &PrepareSettings) -> Result<(), PrepareError> {
    let min = min_vis_res(&settings.scene);
    if !(min..=bake::MAX_RES).contains(&settings.vis_res) {
        return Err(PrepareError::VisRes {
            res: settings.vis_res,
            min,
            max: bake::MAX_RES,
            scene: settings.scene.clone(),
        });
    }
    bake::validate_rays(settings.rays)?;
    if settings.order.get() > MAX_VISIBILITY_ORDER {
        return Err(PrepareError::Order(settings.order.get()));
    }
    if !TABLE_RES_RANGE.contains(&settings.table_res) {
        return Err(PrepareError::TableRes(settings.table_res));
    }
    crate::limits::check_memory(
        format_args!(
            "--vis-res {} × --order {}: the visibility bake",
            settings.vis_res,
            settings.order.get()
        ),
        bake_memory_bytes(settings.vis_res, settings.order.get()),
        "lower --vis-res or --order",
    )?;
    if settings.transfer_bounces.is_some() {
        if settings.transfer_order.get() > LIGHTING_ORDER {
            return Err(PrepareError::TransferOrder(settings.transfer_order.get()));
        }
        let n = settings.transfer_order.coeff_count() as u64;
        let texels = u64::from(settings.vis_res) * u64::from(settings.vis_res);
        // Per texel and matrix entry: the f32 result, the f64 matrices of two bounces and a
        // third of the f64 unbounced one (shared by the colours).
        let bytes = texels.saturating_mul(3 * 9 * n * (4 + 16 + 3));
        crate::limits::check_memory(
            format_args!("--vis-res {}: the transfer-matrix bake", settings.vis_res),
            bytes,
            "lower --vis-res",
        )?;
    }
    if settings.sh_lightmap_bounces.is_some() && !settings.sample_fits.is_empty() {
        let per_texel: usize = settings.sample_fits.iter().map(|f| f.stored_values()).sum();
        let texels = u64::from(settings.vis_res) * u64::from(settings.vis_res);
        // The fitted values (f32 per covered texel, at most every texel) and one basis'
        // values spread over the lightmap and dilated when a technique reads them.
        let widest = settings.sample_fits.iter().map(|f| f.stored_values()).max();
        let bytes = texels.saturating_mul(4 * (per_texel + widest.unwrap_or(0)) as u64);
        crate::limits::check_memory(
            format_args!(
                "--vis-res {}: {} bases fitted from the SH lightmap's samples",
                settings.vis_res,
                settings.sample_fits.len()
            ),
            bytes,
            "lower --vis-res or fit from the order-3 SH (--basis-fit l2)",
        )?;
    }
    warn_if_few_rays(settings.rays, settings.order);
    Ok(())
}

/// Warns, once per process, when there are fewer rays per texel than SH coefficients to
/// project (the projection is rank-deficient: visibility comes out badly wrong).
pub fn warn_if_few_rays(rays: u32, order: Order) {
    static WARNED: std::sync::Once = std::sync::Once::new();
    let n2 = order.coeff_count();
    if (rays as usize) < n2 {
        WARNED.call_once(|| {
            log::warn!(
                "--rays {rays} is fewer than the {n2} SH coefficients of --order {} each texel projects: the visibility of unc*/pca*/cluster techniques will be badly wrong (use at least {n2})",
                order.get()
            );
        });
    }
}

impl Prepared {
    /// Fits the VQ / CPCA models `techniques` need that are not fitted yet (k-means with
    /// the bake's seed, `bake::cluster`), logging each fit's time and error.
    pub fn fit_clusters(&mut self, techniques: &[Technique]) -> Result<(), PrepareError> {
        for need in techniques.iter().filter_map(|t| t.needs().clusters) {
            if self.clusters.iter().any(|c| need.is_met_by(c)) {
                continue;
            }
            let t = Instant::now();
            let (k, m) = (need.k as usize, need.m as usize);
            let model = load_or_fit_clusters(
                &self.cache_dir,
                &self.visibility,
                k,
                m,
                need.clustering,
                self.seed,
                || cluster::fit(&self.visibility, k, m, need.clustering, self.seed),
            )?;
            log::info!(
                "{:?} {} × {}: {} iterations, ready in {:.1} s, RMS visibility error {:.4}",
                need.clustering,
                need.k,
                need.m,
                model.iterations,
                t.elapsed().as_secs_f64(),
                model.rms_reconstruction_error(&self.visibility)
            );
            self.clusters.push(model);
        }
        Ok(())
    }

    /// Bakes the per-vertex visibility `techniques` (`pcaMv`) need that is not baked yet,
    /// with the lightmap bake's rays and seed, logging vertex counts, time and error.
    pub fn bake_vertex_pca(&mut self, techniques: &[Technique]) {
        let mut tracer = None;
        for &t in techniques {
            let Some((m, max_edge_cm)) = t.needs().vertex_pca else {
                continue;
            };
            if self
                .vertex_pca
                .iter()
                .any(|v| vertex::is_bake_of(v, m, max_edge_cm))
            {
                continue;
            }
            let edge = vertex::max_edge_m(max_edge_cm);
            let start = Instant::now();
            let tracer = tracer.get_or_insert_with(|| Tracer::new(&self.scene.mesh));
            let q = crate::technique::pca::quantized_prefix(&self.pca, m as usize);
            let settings = VisibilitySettings {
                progress: false,
                ..self.visibility_settings
            };
            let bake = bake_vertex_pca(tracer, &self.scene.mesh, edge, &q, &settings);
            log::info!(
                "{t}: {} vertices, {} triangles baked in {:.1} s; RMS visibility error {:.4}, {} weights clamped",
                bake.mesh.vertices.len(),
                bake.mesh.triangle_count(),
                start.elapsed().as_secs_f64(),
                bake.rms_error,
                bake.clamped
            );
            self.vertex_pca.push(bake);
        }
    }

    /// Everything the run's techniques need beyond the bake: cluster fits and vertex bakes.
    pub fn prepare_techniques(&mut self, techniques: &[Technique]) -> Result<(), PrepareError> {
        self.fit_clusters(techniques)?;
        self.bake_vertex_pca(techniques);
        self.bake_ssbump(techniques);
        self.build_ndf_moments(techniques);
        Ok(())
    }

    /// Builds the moment MIP chain of the material's normal map when a technique of
    /// `techniques` filters with it (`crate::ndf::moment_maps`).
    pub fn build_ndf_moments(&mut self, techniques: &[Technique]) {
        if self.ndf_moments.is_some() || !techniques.iter().any(|t| t.needs().ndf_moments) {
            return;
        }
        let t = Instant::now();
        let material = &self.scene.material;
        // The height field the normal map describes, where there is one (and the map is
        // unscaled): the same normals without the map's 8-bit quantization.
        let (maps, source) = match &material.height {
            Some(field) if material.normal_scale == 1.0 => {
                (crate::ndf::moment_maps_from_height(field), "height field")
            }
            _ => (
                crate::ndf::moment_maps(&material.normal, material.normal_scale),
                "normal map",
            ),
        };
        log::info!(
            "NDF moments from the {source}: {}×{} texels, {} levels in {:.2} s",
            maps.levels[0].width,
            maps.levels[0].height,
            maps.levels.len(),
            t.elapsed().as_secs_f64()
        );
        self.ndf_moments = Some(maps);
    }

    /// Bakes the material's SSBump and AO from its height field when a technique of
    /// `techniques` reads them and the material has one (without one those techniques
    /// refuse to build, naming `--height-map`).
    pub fn bake_ssbump(&mut self, techniques: &[Technique]) {
        if self.ssbump.is_some() || !techniques.iter().any(|t| t.needs().ssbump) {
            return;
        }
        if let Some(field) = &self.scene.material.height {
            let t = Instant::now();
            let maps = SsBumpMaps::bake(field, ssbump::DEFAULT_RAYS, self.seed);
            log::info!(
                "SSBump: {}×{} texels × {} rays in {:.2} s",
                maps.width,
                maps.height,
                ssbump::DEFAULT_RAYS,
                t.elapsed().as_secs_f64()
            );
            self.ssbump = Some(maps);
        }
    }

    pub fn inputs(&self) -> Inputs<'_> {
        Inputs {
            cache_dir: Some(&self.cache_dir),
            ao: &self.ao,
            irradiance_sh: &self.irradiance_sh,
            radiance_sh: &self.radiance_sh,
            visibility: Some(&self.visibility),
            pca: Some(&self.pca),
            clusters: &self.clusters,
            vertex_pca: &self.vertex_pca,
            sh_lightmap: self.sh_lightmap.as_ref(),
            ssbump: self.ssbump.as_ref(),
            ndf_moments: self.ndf_moments.as_ref(),
            transfer: self.transfer.as_ref(),
            table_res: self.table_res,
            h_order: self.h_order,
            options: self.options,
        }
    }
}

/// Errors of preparation, each one line naming the input.
#[derive(Debug, thiserror::Error)]
pub enum PrepareError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Env(#[from] EnvError),
    #[error(transparent)]
    Bake(#[from] BakeError),
    #[error("--transfer-order {0} is above the prepared lighting's order {LIGHTING_ORDER}")]
    TransferOrder(u32),
    #[error("--table-res {0} is out of range 4..=256")]
    TableRes(u32),
    #[error(
        "--order {0} is out of range 1..=28 (the L×H product needs lighting of order + 2 ≤ 30)"
    )]
    Order(u32),
    #[error("--vis-res {res} is out of range {min}..={max} for scene '{scene}'")]
    VisRes {
        res: u32,
        min: u32,
        max: u32,
        scene: String,
    },
    /// The lighting derived from `--env` (its SH, the SH lightmap baked from it) holds a
    /// value that is not finite: the file's values overflowed the arithmetic.
    #[error(
        "{env}: the lighting it gives is not finite ({what}): its values overflow the arithmetic; scale the environment down"
    )]
    NonFiniteLighting { env: String, what: String },
    #[error(transparent)]
    Limit(#[from] crate::limits::LimitError),
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    #[error(transparent)]
    File(#[from] crate::files::FileError),
}

/// Refuses lighting that is not finite, naming the environment `env` it came from, before
/// any technique is built from it (a technique's tables would only say "not finite").
fn check_lighting(
    env: &str,
    radiance_sh: &[[f64; 3]],
    irradiance_sh: &[[f64; 3]],
    sh_lightmap: Option<&ShLightmap>,
) -> Result<(), PrepareError> {
    let not_finite = |what: String| PrepareError::NonFiniteLighting {
        env: env.to_string(),
        what,
    };
    for (name, coeffs) in [("radiance", radiance_sh), ("irradiance", irradiance_sh)] {
        if let Some(i) = coeffs.iter().position(|c| c.iter().any(|v| !v.is_finite())) {
            return Err(not_finite(format!(
                "its {name} SH coefficient {i} is {:?}",
                coeffs[i]
            )));
        }
    }
    if let Some(map) = sh_lightmap
        && crate::technique::shlmap::stored_scale(map).is_none()
    {
        return Err(not_finite("the SH lightmap baked from it".into()));
    }
    Ok(())
}

/// Whether `name` is a glTF path (`.gltf`/`.glb`, any case).
pub fn is_gltf_path(name: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    lower.ends_with(".gltf") || lower.ends_with(".glb")
}

/// The files a run reads for the scene `name`: a glTF file and the buffers and images it
/// references; none for a built-in scene.
pub fn scene_files(name: &str) -> Vec<std::path::PathBuf> {
    if is_gltf_path(name) {
        gltf::files_read(std::path::Path::new(name))
    } else {
        Vec::new()
    }
}

/// The built-in scene by name, or a scene file.
pub fn resolve_scene(name: &str, vis_res: u32) -> Result<Scene, SceneError> {
    match name {
        "house" => house::build(vis_res),
        "patio" => patio::build(vis_res),
        "bumpy" => crate::scene::bumpy::build(vis_res),
        "wavy" => crate::scene::wavy::build(vis_res),
        p if is_gltf_path(p) => gltf::load(std::path::Path::new(p), vis_res),
        other => Err(SceneError::Unknown(other.to_string())),
    }
}

/// Who bakes the visibility: the CPU ray tracer (through the bake cache) or the PRT
/// course's GPU simulator on a device (`bake::gpu_visibility`; not cached — its bakes must
/// never be mistaken for the tracer's).
pub enum VisibilityBaker {
    Cpu,
    Gpu {
        ctx: Arc<crate::gpu::Context>,
        settings: crate::bake::gpu_visibility::GpuVisibilitySettings,
    },
}

/// Validates inputs (cheap checks first), then bakes and prepares the lighting.
pub fn prepare(settings: &PrepareSettings) -> Result<Prepared, PrepareError> {
    prepare_with(settings, &VisibilityBaker::Cpu)
}

/// [`prepare`] with the visibility baked by `baker`.
pub fn prepare_with(
    settings: &PrepareSettings,
    baker: &VisibilityBaker,
) -> Result<Prepared, PrepareError> {
    check_settings(settings)?;
    let cache_dir = settings.cache_dir.clone().unwrap_or_else(default_cache_dir);
    crate::files::check_writable_dir(&cache_dir, "the bake cache (SHVIS_CACHE_DIR)")?;
    let vis_res = bake::validate_res(settings.vis_res)?;
    let rays = bake::validate_rays(settings.rays)?;
    let env = env::resolve(&settings.env)?;
    if !TABLE_RES_RANGE.contains(&settings.table_res) {
        return Err(PrepareError::TableRes(settings.table_res));
    }
    let mut scene = resolve_scene(&settings.scene, vis_res)?;
    if let Some((path, scale)) = &settings.height_map {
        scene.material.height = Some(crate::scene::load_height_map(path, *scale)?);
    }
    let geometry = BakeGeometry::new(&scene.mesh, vis_res);
    let visibility = match baker {
        VisibilityBaker::Cpu => bake_visibility_cached(&geometry, rays, settings)?,
        VisibilityBaker::Gpu { ctx, settings: gpu } => {
            let baked = crate::bake::gpu_visibility::bake_visibility_gpu(
                ctx,
                &scene.mesh,
                geometry.texels(),
                &VisibilitySettings {
                    order: settings.order,
                    rays,
                    seed: settings.seed,
                    progress: settings.progress,
                },
                gpu,
            )?;
            log::info!(
                "visibility on the GPU simulator ({}): {}² depth maps, {:.2} s",
                ctx.device_name(),
                gpu.depth_res,
                baked.map.stats.seconds
            );
            baked.map
        }
    };
    let ao = AoMap {
        res: visibility.res,
        values: visibility.ao.clone(),
        covered: visibility.covered.clone(),
        stats: visibility.stats,
    };
    let t = Instant::now();
    let pca = fit(
        &visibility,
        PCA_MAX_BASIS.min(visibility.order.coeff_count()),
    )?;
    log::info!(
        "PCA: {} vectors in {:.2} s; energy captured by 4/8/12/16/24: {:.4} {:.4} {:.4} {:.4} {:.4}",
        pca.basis.len(),
        t.elapsed().as_secs_f64(),
        pca.energy_captured(4),
        pca.energy_captured(8),
        pca.energy_captured(12),
        pca.energy_captured(16),
        pca.energy_captured(24)
    );
    let order3 = Order::THREE;
    let lighting_order = Order::new(LIGHTING_ORDER.max(settings.order.get() + 2))
        .map_err(|_| PrepareError::Order(settings.order.get()))?;
    let t = Instant::now();
    let radiance_sh = env::project::project_sh(&env, lighting_order);
    let irradiance_sh = zonal::irradiance_from_radiance(&radiance_sh[..9], order3);
    log::info!(
        "env: {}×{} projected to order {lighting_order} in {:.1} ms",
        env.width,
        env.height,
        t.elapsed().as_secs_f64() * 1e3
    );
    // Through the bake cache: a second run of the same scene, lighting and settings (an
    // export after a bench, say) reads it back.
    let sh_lightmap = match settings.sh_lightmap_bounces {
        None => None,
        Some(bounces) => {
            let lighting = match settings.bake_env {
                BakeEnv::Sh => BakeLighting::Sh(&radiance_sh),
                BakeEnv::Pixels => BakeLighting::Pixels(&env),
            };
            let sh_settings = ShLightmapSettings {
                rays,
                seed: settings.seed,
                bounces,
                progress: settings.progress,
            };
            let fits = &settings.sample_fits;
            let key = sh_lightmap_key(&scene, settings.vis_res, &lighting, &sh_settings, fits);
            Some(load_or_bake_sh_lightmap(
                &cache_dir,
                key,
                settings.vis_res,
                fits,
                || {
                    bake_sh_lightmap(
                        &scene,
                        geometry.tracer(),
                        geometry.texels(),
                        &lighting,
                        &sh_settings,
                        fits,
                    )
                },
            )?)
        }
    };
    check_lighting(
        &settings.env,
        &radiance_sh,
        &irradiance_sh,
        sh_lightmap.as_ref(),
    )?;
    let transfer = settings.transfer_bounces.map(|bounces| {
        Arc::new(bake_transfer(
            &scene,
            geometry.tracer(),
            geometry.texels(),
            &TransferSettings {
                lighting_order: settings.transfer_order,
                rays,
                seed: settings.seed,
                bounces,
                progress: settings.progress,
            },
        ))
    });
    drop(geometry);
    Ok(Prepared {
        sh_lightmap,
        transfer,
        scene,
        env,
        ao,
        visibility,
        visibility_settings: VisibilitySettings {
            order: settings.order,
            rays,
            seed: settings.seed,
            progress: false,
        },
        pca,
        radiance_sh,
        irradiance_sh,
        table_res: settings.table_res,
        h_order: settings.h_order,
        options: settings.options,
        clusters: Vec::new(),
        seed: settings.seed,
        cache_dir: settings.cache_dir.clone().unwrap_or_else(default_cache_dir),
        vertex_pca: Vec::new(),
        ssbump: None,
        ndf_moments: None,
    })
}

/// The lightmap texels of a mesh and its ray tracer, each built on first use and then
/// shared by the bakes of one `prepare` (a cached visibility bake needs neither).
pub struct BakeGeometry<'a> {
    mesh: &'a Mesh,
    res: u32,
    texels: OnceCell<LightmapTexels>,
    tracer: OnceCell<Tracer>,
}

impl<'a> BakeGeometry<'a> {
    pub fn new(mesh: &'a Mesh, res: u32) -> Self {
        BakeGeometry {
            mesh,
            res,
            texels: OnceCell::new(),
            tracer: OnceCell::new(),
        }
    }
    pub fn texels(&self) -> &LightmapTexels {
        self.texels.get_or_init(|| rasterize(self.mesh, self.res))
    }
    pub fn tracer(&self) -> &Tracer {
        self.tracer.get_or_init(|| Tracer::new(self.mesh))
    }
}

/// Rasterizes the lightmap and bakes SH visibility, through the bake cache.
pub fn bake_scene_visibility(
    scene: &Scene,
    vis_res: u32,
    rays: u32,
    settings: &PrepareSettings,
) -> Result<VisibilityMap, BakeError> {
    bake_visibility_cached(&BakeGeometry::new(&scene.mesh, vis_res), rays, settings)
}

fn bake_visibility_cached(
    geometry: &BakeGeometry<'_>,
    rays: u32,
    settings: &PrepareSettings,
) -> Result<VisibilityMap, BakeError> {
    let vis_settings = VisibilitySettings {
        order: settings.order,
        rays,
        seed: settings.seed,
        progress: settings.progress,
    };
    let cache_dir = settings.cache_dir.clone().unwrap_or_else(default_cache_dir);
    // A lightmap no texel of which is covered bakes nothing worth caching or measuring.
    geometry.texels().require_covered()?;
    load_or_bake_visibility(
        &cache_dir,
        geometry.mesh,
        geometry.res,
        &vis_settings,
        || bake_visibility(geometry.tracer(), geometry.texels(), &vis_settings),
    )
}

/// Rasterizes the lightmap and bakes ambient occlusion.
pub fn bake_scene_ao(
    scene: &Scene,
    vis_res: u32,
    rays: u32,
    seed: u64,
    progress: bool,
) -> Result<AoMap, BakeError> {
    let texels = rasterize(&scene.mesh, vis_res);
    if !texels.covered.iter().any(|&c| c) {
        return Err(BakeError::EmptyLightmap);
    }
    let tracer = Tracer::new(&scene.mesh);
    Ok(bake_ao(
        &tracer,
        &texels,
        &AoSettings {
            rays,
            seed,
            progress,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lighting_that_is_not_finite_is_refused_naming_the_environment() {
        let good = vec![[1.0; 3]; 9];
        assert!(check_lighting("sh:x.sh", &good, &good, None).is_ok());
        let mut bad = good.clone();
        bad[4][1] = f64::INFINITY;
        let e = check_lighting("sh:x.sh", &bad, &good, None)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(
                "sh:x.sh: the lighting it gives is not finite (its radiance SH coefficient 4 is [1.0, inf, 1.0])"
            ),
            "{e}"
        );
        let e = check_lighting("sky", &good, &bad, None)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("sky: ") && e.contains("irradiance SH coefficient 4"),
            "{e}"
        );
    }
}
