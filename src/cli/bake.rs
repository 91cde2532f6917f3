//! `shvis bake`.

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;

use shvis::prepare::VisibilityBaker;
use shvis::prepare::bake_layers::{self, BakeLayersJob};

use super::args::{BakerArgs, GpuArgs, SceneArgs, VisibilityBakerArg};
use super::{create_dir, prepare_settings, say, with_gpu};

#[derive(Args, Debug)]
pub(super) struct BakeArgs {
    /// Bake nothing: check that --out holds a complete bake (its manifest.json lists every
    /// file with the size and hash it has) and print its settings; exit 1 if not.
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
    /// Output directory (ao.exr).
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
    if a.check {
        let manifest = shvis::files::Manifest::verify(&a.out).map_err(anyhow::Error::msg)?;
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
    create_dir(&a.out)?;
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
