//! `shvis export`: a technique's baked data as KTX2 files, a manifest and the decode
//! shader (`shvis::export`; docs/export.md).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use shvis::gpu::HwPath;
use shvis::technique::Technique;

use super::args::SceneArgs;
use super::{MAX_BOUNCES, OUT_REPLACED, RunInputs, prepare_settings};

#[derive(Args, Debug)]
pub(super) struct ExportArgs {
    /// Technique name (`shvis techniques`).
    #[arg(long, value_parser = super::parse_one_technique)]
    technique: Technique,
    /// Hardware path whose layout the files hold: dx10 (RGBA16F/RGBA8 arrays) or dx11
    /// (block-compressed).
    #[arg(long, default_value = "dx11")]
    path: HwPath,
    /// `sky` (built-in), an .exr/.hdr equirectangular map (2:1) or angular probe (1:1,
    /// detected by content; `angular:PATH` forces it), or `sh:FILE` (SH radiance
    /// coefficients as `shvis sh project` prints them).
    #[arg(long, default_value = "sky")]
    env: String,
    /// Bounces of inter-reflection baked for shlmap and the bases derived from it.
    #[arg(long, default_value_t = shvis::bake::shlmap::DEFAULT_BOUNCES, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    /// Output folder: the KTX2 files, params.bin, decode.glsl and manifest.json, written as
    /// one run (an earlier export there is replaced whole; any other non-empty folder is
    /// refused).
    #[arg(short, long)]
    out: PathBuf,
    #[command(flatten)]
    scene: SceneArgs,
}

pub(super) fn run_export(a: ExportArgs) -> Result<()> {
    // Refusals before the bake, not after it.
    if let Some(refused) = shvis::export::refusal(a.technique, a.path) {
        return Err(refused.into());
    }
    if a.path == HwPath::Dx9 {
        anyhow::bail!(
            "{}.dx9: export writes the dx10 and dx11 layouts (arrays, cube maps); pass --path dx10 or dx11",
            a.technique
        );
    }
    // The export replaces --out whole: no input may lie inside it.
    RunInputs::of_scene(&a.scene)
        .env("--env", &a.env)
        .check_outside(&a.out, OUT_REPLACED)?;
    shvis::files::check_replaceable_dir(&a.out, "--out", shvis::export::is_export_dir)?;
    let settings = prepare_settings(&a.scene, &a.env, &[a.technique], a.bounces)?;
    let mut prepared = shvis::prepare::prepare(&settings)?;
    prepared.prepare_techniques(&[a.technique])?;
    let export = shvis::export::export(&prepared, a.technique, a.path)?;
    export.write(&a.out)?;
    for (name, bytes) in &export.files {
        out!("{:>10} bytes  {}", bytes.len(), a.out.join(name).display());
    }
    Ok(())
}
