//! Scene + environment → everything techniques read (DESIGN §5's first stages): resolve
//! the scene and the environment by name or path, bake the lightmap data, and prepare the
//! lighting (SH projection, clamped-cosine convolution).

use std::time::Instant;

use crate::bake::ao::{AoMap, AoSettings, bake_ao};
use crate::bake::raster::rasterize;
use crate::bake::trace::Tracer;
use crate::bake::{self, BakeError};
use crate::env::{self, EnvError, EnvMap};
use crate::scene::{Scene, SceneError, gltf, house};
use crate::sh::{Order, zonal};
use crate::technique::Inputs;

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
        }
    }
}

/// Baked and lighting data for one scene and environment.
pub struct Prepared {
    pub scene: Scene,
    pub env: EnvMap,
    pub ao: AoMap,
    /// Order-3 SH of the environment's radiance, RGB.
    pub radiance_sh: Vec<[f64; 3]>,
    /// Order-3 SH of irradiance: `radiance_sh` convolved with the clamped cosine.
    pub irradiance_sh: Vec<[f64; 3]>,
}

impl Prepared {
    pub fn inputs(&self) -> Inputs<'_> {
        Inputs {
            ao: &self.ao,
            irradiance_sh: &self.irradiance_sh,
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
}

/// The built-in scene by name, or a scene file.
pub fn resolve_scene(name: &str, vis_res: u32) -> Result<Scene, SceneError> {
    match name {
        "house" => house::build(vis_res),
        p if p.ends_with(".gltf") || p.ends_with(".glb") => {
            gltf::load(std::path::Path::new(p), vis_res)
        }
        other => Err(SceneError::Unknown(other.to_string())),
    }
}

/// Validates inputs (cheap checks first), then bakes and prepares the lighting.
pub fn prepare(settings: &PrepareSettings) -> Result<Prepared, PrepareError> {
    let vis_res = bake::validate_res(settings.vis_res)?;
    let rays = bake::validate_rays(settings.rays)?;
    let env = env::resolve(&settings.env)?;
    let scene = resolve_scene(&settings.scene, vis_res)?;
    let ao = bake_scene_ao(&scene, vis_res, rays, settings.seed, settings.progress)?;
    let order3 = Order::new(3).expect("3 is a valid order");
    let t = Instant::now();
    let radiance_sh = env::project::project_sh(&env, order3);
    let irradiance_sh = zonal::irradiance_from_radiance(&radiance_sh, order3);
    log::info!(
        "env: {}×{} projected to order 3 in {:.1} ms",
        env.width,
        env.height,
        t.elapsed().as_secs_f64() * 1e3
    );
    Ok(Prepared {
        scene,
        env,
        ao,
        radiance_sh,
        irradiance_sh,
    })
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
