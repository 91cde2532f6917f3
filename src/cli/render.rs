//! `shvis render` and `shvis reference`: one image each.

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;

use shvis::prepare::reference_image::{self, ReferenceJob};
use shvis::prepare::single_frame::{self, FrameJob};
use shvis::prepare::{Prepared, prepare_with};
use shvis::reference::ReferenceSettings;
use shvis::render::FrameSettings;
use shvis::report::image::frame_format;
use shvis::technique::{HwPath, Technique};

use super::args::{
    BakerArgs, GpuArgs, NormalFilterArg, SceneArgs, SpecularArgs, finite_f32, with_normal_filter,
};
use super::{
    DEFAULT_EXPOSURE_EV, MAX_BOUNCES, MAX_FRAME_SIDE, RunInputs, check_frame_memory,
    prepare_settings, with_gpu,
};

#[derive(Args, Debug)]
pub(super) struct RenderArgs {
    /// `sky` (built-in), an .exr/.hdr equirectangular map (2:1) or angular probe (1:1,
    /// detected by content; `angular:PATH` forces it), or `sh:FILE` (SH radiance
    /// coefficients as `shvis sh project` prints them).
    #[arg(long, default_value = "sky")]
    env: String,
    /// Technique name (see `shvis bench`): unc3…unc6, pca4…pca24, pca4w…pca24w, shlmap,
    /// preconv, sh2.
    #[arg(long, value_parser = super::parse_one_technique)]
    technique: Technique,
    /// Hardware path: dx9, dx10 or dx11.
    #[arg(long, default_value = "dx10")]
    path: HwPath,
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 800, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    /// Exposure in EV applied before sRGB encoding (PNG only). The default −1 keeps the
    /// built-in sky's sunlit ground out of clipping.
    #[arg(long, default_value_t = DEFAULT_EXPOSURE_EV, allow_hyphen_values = true, value_parser = finite_f32)]
    exposure: f32,
    /// Bounces of inter-reflection baked for shlmap and the nmprt* transfer matrices.
    #[arg(long, default_value_t = shvis::bake::shlmap::DEFAULT_BOUNCES, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    /// How unc* and preconv read the normal map: `mip` (its MIP chain of averaged normals)
    /// or `ndf` (filtered as a distribution, Olano & North: the techniques' `…ndf`
    /// variants; the other techniques have none and stay as they are).
    #[arg(long, value_enum, default_value_t = NormalFilterArg::Mip)]
    normal_filter: NormalFilterArg,
    /// Ignore the normal map (shade with interpolated normals).
    #[arg(long)]
    flat_normals: bool,
    /// Output image: .png (sRGB) or .exr (linear).
    #[arg(short, long)]
    out: PathBuf,
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    baker: BakerArgs,
    #[command(flatten)]
    gpu: GpuArgs,
    #[command(flatten)]
    specular: SpecularArgs,
}

#[derive(Args, Debug)]
pub(super) struct ReferenceArgs {
    /// A built-in scene (`house`, `patio`: a brick corner, `bumpy`, `wavy`) or a .gltf/.glb file.
    #[arg(long, default_value = "house")]
    scene: String,
    #[arg(long, default_value = "sky")]
    env: String,
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 800, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    /// Environment samples per pixel.
    #[arg(long = "ref-spp", default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    spp: u32,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Lightmap resolution the scene is built for (only the built-in house's UVs use it).
    #[arg(long, default_value_t = 512)]
    vis_res: u32,
    #[arg(long, default_value_t = DEFAULT_EXPOSURE_EV, allow_hyphen_values = true, value_parser = finite_f32)]
    exposure: f32,
    /// Reflections of light to include (0: direct light only, the model of every technique
    /// but shlmap; shlmap bakes 2 by default).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    /// One G-buffer sample at each pixel centre with MIP-filtered textures (the techniques'
    /// own sampling) instead of integrating the pixel footprint at full texture resolution.
    #[arg(long)]
    point: bool,
    /// Render the scene's height-mapped surfaces as real displaced micro-geometry (a vertex
    /// per height texel; flat shading normals): the ground truth of self-shadowing (small
    /// scenes such as `patio`).
    #[arg(long)]
    displaced: bool,
    /// Output image: .exr (linear) or .png (sRGB).
    #[arg(short, long)]
    out: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

pub(super) fn run_render(a: RenderArgs) -> Result<()> {
    a.baker.check()?;
    frame_format(&a.out)?;
    check_frame_memory(a.width, a.height, 48)?;
    shvis::files::check_writable_file(&a.out, "--out")?;
    RunInputs::of_scene(&a.scene)
        .env("--env", &a.env)
        .check_spared_by(&[("--out".to_string(), a.out.clone())])?;
    let technique = with_normal_filter(vec![a.technique], a.normal_filter)[0];
    // A path the technique has no form on is refused before its bake.
    if let Err(why) = technique.form_on(a.path) {
        let label = format!("{technique}.{}", a.path);
        return Err(shvis::technique::refused(&label, a.path, why).into());
    }
    let settings = prepare_settings(&a.scene, &a.env, &[technique], a.bounces)?;
    // The device next: a missing GPU should not cost a bake.
    let label = with_gpu(&a.gpu, |ctx| {
        let mut prepared: Prepared = prepare_with(&settings, &a.baker.visibility_baker(ctx))?;
        prepared.prepare_techniques(&[technique])?;
        let job = FrameJob {
            technique,
            path: a.path,
            frame: FrameSettings {
                width: a.width,
                height: a.height,
                flat_normals: a.flat_normals,
                ..FrameSettings::default()
            },
            specular: a.specular.term(&prepared.env)?,
            out: a.out.clone(),
            exposure: a.exposure,
        };
        Ok(single_frame::render_to_file(ctx, &prepared, &job)?)
    })?;
    out!("wrote {} ({label})", a.out.display());
    Ok(())
}

pub(super) fn run_reference(a: ReferenceArgs) -> Result<()> {
    frame_format(&a.out)?;
    check_frame_memory(a.width, a.height, 160)?;
    shvis::files::check_writable_file(&a.out, "--out")?;
    RunInputs::default()
        .env("--env", &a.env)
        .scene("--scene", &a.scene)
        .check_spared_by(&[("--out".to_string(), a.out.clone())])?;
    let min = shvis::prepare::min_vis_res(&a.scene);
    if !(min..=shvis::bake::MAX_RES).contains(&a.vis_res) {
        bail!(
            "--vis-res {} is out of range {min}..={} for scene '{}'",
            a.vis_res,
            shvis::bake::MAX_RES,
            a.scene
        );
    }
    let job = ReferenceJob {
        scene: a.scene.clone(),
        env: a.env.clone(),
        vis_res: a.vis_res,
        displaced: a.displaced,
        settings: ReferenceSettings {
            width: a.width,
            height: a.height,
            spp: a.spp,
            seed: a.seed,
            bounces: a.bounces,
            footprint: !a.point,
        },
        out: a.out.clone(),
        exposure: a.exposure,
    };
    let done = with_gpu(&a.gpu, |ctx| {
        Ok(reference_image::render_to_file(ctx, &job)?)
    })?;
    let sampling = match done.strata_side {
        1 if a.point => "point-sampled".to_string(),
        side => format!("footprint {side}×{side} strata"),
    };
    out!(
        "reference: {} spp, {sampling}, {} bounces, {:.1} M rays in {:.1} s; noise (relative standard error of the image) {:.4}",
        a.spp,
        a.bounces,
        done.rays as f64 / 1e6,
        done.seconds,
        done.noise
    );
    out!("wrote {}", a.out.display());
    Ok(())
}
