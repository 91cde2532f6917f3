//! `shvis bake`.

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;

use shvis::prepare::VisibilityBaker;
use shvis::prepare::bake_layers::{self, BakeLayersJob};

use super::args::{BakerArgs, GpuArgs, SceneArgs, VisibilityBakerArg};
use super::{OUT_REPLACED, RunInputs, prepare_settings, say, with_gpu};

#[derive(Args, Debug)]
pub(super) struct BakeArgs {
    /// Bake nothing: check that --out holds a complete bake (its manifest.json lists every
    /// file with the size and hash it has, and the files are exactly the layers of its
    /// order and ao.exr) and print its settings; exit 1 if not.
    #[arg(long)]
    check: bool,
    /// Also run the standalone cosine-sampled AO bake (`bake::ao`) and print its figures;
    /// the AO layer written is the visibility bake's, as the techniques use.
    #[arg(long)]
    separate_ao: bool,
    /// `--baker gpu`: also run the CPU bake (and one with the next seed, for the
    /// quadrature noise) and print how far the GPU's coefficients are from it.
    #[arg(long)]
    compare_cpu: bool,
    /// Output folder (visibility_K.exr, ao.exr, manifest.json), written as one run: an
    /// existing one must be empty or an earlier bake, which is replaced whole.
    #[arg(short, long)]
    out: PathBuf,
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    baker: BakerArgs,
    #[command(flatten)]
    gpu: GpuArgs,
}

pub(super) fn run_bake(a: BakeArgs) -> Result<()> {
    a.baker.check()?;
    if a.check {
        let manifest = shvis::files::Manifest::verify(&a.out).map_err(anyhow::Error::msg)?;
        check_bake_files(&a.out, &manifest)?;
        out!(
            "{}: complete, {} files, settings {}",
            a.out.display(),
            manifest.files.len(),
            manifest.settings
        );
        return Ok(());
    }
    if a.compare_cpu && a.baker.baker != VisibilityBakerArg::Gpu {
        bail!("--compare-cpu compares the GPU bake with the CPU one: only with --baker gpu");
    }
    let settings = prepare_settings(&a.scene, "sky", &[], 0)?;
    let job = BakeLayersJob {
        vis_res: shvis::bake::validate_res(a.scene.vis_res)?,
        rays: shvis::bake::validate_rays(a.scene.rays)?,
        separate_ao: a.separate_ao,
        compare_cpu: a.compare_cpu,
        out: a.out.clone(),
    };
    // The bake replaces --out whole: checked before it, not after.
    RunInputs::of_scene(&a.scene).check_outside(&a.out, OUT_REPLACED)?;
    shvis::files::check_replaceable_dir(&a.out, "--out", shvis::bake::cache::is_bake_dir)?;
    match a.baker.baker {
        VisibilityBakerArg::Cpu => {
            let cache_dir = shvis::bake::cache::default_cache_dir();
            shvis::files::check_writable_dir(&cache_dir, "the bake cache (SHVIS_CACHE_DIR)")?;
            Ok(bake_layers::run(
                &job,
                &settings,
                &VisibilityBaker::Cpu,
                &mut say,
            )?)
        }
        VisibilityBakerArg::Gpu => with_gpu(&a.gpu, |ctx| {
            let baker = a.baker.visibility_baker(ctx);
            Ok(bake_layers::run(&job, &settings, &baker, &mut say)?)
        }),
    }
}

/// The files a complete bake of the manifest's order holds, no more and no fewer:
/// `visibility_0.exr` … (one per four coefficients), `ao.exr` and the manifest.
fn check_bake_files(out: &std::path::Path, manifest: &shvis::files::Manifest) -> Result<()> {
    let order = manifest.settings["order"]
        .as_u64()
        .filter(|o| (1..=u64::from(shvis::sh::MAX_ORDER)).contains(o))
        .ok_or_else(|| {
            anyhow::anyhow!(
                "{}: its settings name no SH order: not a bake's manifest",
                out.join(shvis::files::MANIFEST_NAME).display()
            )
        })?;
    let layers = (order * order).div_ceil(4);
    let mut expected: Vec<String> = (0..layers).map(|k| format!("visibility_{k}.exr")).collect();
    expected.push("ao.exr".into());
    let mut listed: Vec<String> = manifest.files.iter().map(|f| f.name.clone()).collect();
    let mut present: Vec<String> = std::fs::read_dir(out)?
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n != shvis::files::MANIFEST_NAME)
        .collect();
    expected.sort();
    listed.sort();
    present.sort();
    if listed != expected {
        bail!(
            "{}: an order-{order} bake has {}; its manifest lists {}",
            out.display(),
            expected.join(", "),
            listed.join(", ")
        );
    }
    if present != expected {
        bail!(
            "{}: an order-{order} bake has {}; the folder holds {}",
            out.display(),
            expected.join(", "),
            present.join(", ")
        );
    }
    Ok(())
}
