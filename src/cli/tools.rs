//! `shvis sh`, `shvis ssbump` and `shvis normalmap`: tools around the renderer.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context as _, Result, bail};
use clap::{Args, Subcommand};

use shvis::normalmap::DrawMode;
use shvis::normalmap::cpu::RayDirection;
use shvis::normalmap::job::{self, Bakers, LowMesh, NormalMapJob};
use shvis::report::results::{self, ResultTable};
use shvis::tools::ssbump::{self, SsbumpJob};

use super::args::{GpuArgs, finite_f32, finite_f64};
use super::{say, with_gpu};

#[derive(Args, Debug)]
pub(super) struct ReportArgs {
    /// Bench tables (`table.json`) to set side by side, in column order.
    #[arg(required = true)]
    pub(super) tables: Vec<PathBuf>,
    /// A label per table, comma-separated (default: "device W×H").
    #[arg(long, value_delimiter = ',')]
    pub(super) labels: Vec<String>,
    /// The page to write (markdown), e.g. docs/results/<device>.md.
    #[arg(short, long)]
    pub(super) out: PathBuf,
}

/// Writes the comparison page of the tables.
pub(super) fn run_report(a: ReportArgs) -> Result<()> {
    if !a.labels.is_empty() && a.labels.len() != a.tables.len() {
        bail!(
            "--labels names {} tables, {} are given",
            a.labels.len(),
            a.tables.len()
        );
    }
    let inputs: Vec<(&str, &std::path::Path)> =
        a.tables.iter().map(|t| ("table", t.as_path())).collect();
    shvis::files::check_outputs_spare_inputs(&[("--out".to_string(), a.out.clone())], &inputs)?;
    let tables = a
        .tables
        .iter()
        .enumerate()
        .map(|(i, path)| ResultTable::read(path, a.labels.get(i).map(String::as_str)))
        .collect::<Result<Vec<_>, _>>()?;
    let page = results::comparison_page(&tables, &shvis::files::clock::utc_date_today());
    shvis::files::write(&a.out, page)
        .with_context(|| format!("{}: cannot write", a.out.display()))?;
    out!("wrote {}", a.out.display());
    Ok(())
}

#[derive(Args, Debug)]
pub(super) struct TechniquesArgs {
    /// Print the catalog as JSON (with every member's name) instead of lines.
    #[arg(long)]
    pub(super) json: bool,
}

/// Lists every technique family: names, paths, bake, paper, what it is.
pub(super) fn run_techniques(a: TechniquesArgs) -> Result<()> {
    let families = shvis::technique::catalog::families();
    if a.json {
        out!("{}", serde_json::to_string_pretty(&families)?);
        return Ok(());
    }
    for f in &families {
        let paths: Vec<String> = f.paths.iter().map(|p| p.to_string()).collect();
        out!("{} — {}", f.names, f.what);
        out!(
            "    {} · paths {} · bakes {} · names: {}",
            f.paper,
            paths.join(", "),
            f.bakes,
            f.members.len()
        );
    }
    Ok(())
}

#[derive(Args, Debug)]
pub(super) struct DevicesArgs {
    /// Print the list as JSON (one array) instead of lines.
    #[arg(long)]
    pub(super) json: bool,
    #[command(flatten)]
    pub(super) gpu: GpuArgs,
}

/// Lists the Vulkan devices, the one shvis picks first (marked `*`).
pub(super) fn run_devices(a: DevicesArgs) -> Result<()> {
    with_gpu(&a.gpu, |ctx| {
        let devices = ctx.devices();
        if a.json {
            out!("{}", serde_json::to_string_pretty(&devices)?);
            return Ok(());
        }
        for d in &devices {
            out!(
                "{} {} ({}) · driver {} · Vulkan {} · timestamps {} bits × {} ns · subgroup {}",
                if d.in_use { "*" } else { " " },
                d.name,
                d.kind,
                d.driver,
                d.api_version,
                d.timestamp_valid_bits,
                d.timestamp_period_ns,
                d.subgroup_size
            );
        }
        Ok(())
    })
}

#[derive(Subcommand, Debug)]
pub(super) enum ShCommand {
    /// Reads directions "x y z" per line on stdin, prints the order² basis values per line.
    Eval {
        #[arg(long)]
        order: u32,
    },
    /// Prints the environment's RGB SH coefficients, one line "r g b" per coefficient.
    Project {
        #[arg(long, default_value = "sky")]
        env: String,
        #[arg(long)]
        order: u32,
    },
    /// Prints the irradiance E(n) = ∫ L max(0, n·ω) dω as "r g b": from SH of the given
    /// order (default 3), or by direct quadrature over the texels with --exact.
    Irradiance {
        #[arg(long, default_value = "sky")]
        env: String,
        /// The normal "x,y,z" (normalized; zero or NaN is an error).
        #[arg(long, allow_hyphen_values = true)]
        normal: String,
        #[arg(long, conflicts_with = "exact")]
        order: Option<u32>,
        #[arg(long)]
        exact: bool,
    },
}

#[derive(Args, Debug)]
pub(super) struct SsbumpArgs {
    /// Height map (a PNG or an RGB EXR; luminance in [0, 1]), or `house`: the built-in bricks'
    /// height field in texels, the one their normal map is derived from.
    #[arg(long = "height-map")]
    height: PathBuf,
    /// Height of a white texel, in texels (with `house`: a factor on its heights); at most
    /// 100.
    #[arg(long = "height-scale", value_parser = finite_f64)]
    scale: f64,
    /// Rays per texel.
    #[arg(long, default_value_t = 300, value_parser = clap::value_parser!(u32).range(1..=65536))]
    rays: u32,
    /// Bilateral pre-filter: spatial σ in texels (0: off); the range σ is 5 % of the height
    /// range.
    #[arg(long, default_value_t = 0.0, value_parser = finite_f64)]
    bilateral: f64,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Output .png: also writes .exr beside it, and `*_d.png` (plain D), `*_ao.png` (AO).
    #[arg(short, long)]
    out: PathBuf,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum BakerArg {
    /// The paper's method (one render of the high mesh per low triangle).
    Gpu,
    /// Ray casting along the low mesh's interpolated normal (the check).
    Cpu,
}

#[derive(Args, Debug)]
pub(super) struct NormalmapArgs {
    /// High mesh: a glTF file, or `sphere:LEVEL` (a unit icosphere of 20·4^LEVEL
    /// triangles with exact normals).
    #[arg(long)]
    high: String,
    /// Low mesh with unique material UVs in [0, 1]: a glTF file or `sphere:LEVEL`
    /// (generated UVs). Leave out with --simplify.
    #[arg(
        long,
        required_unless_present = "simplify",
        conflicts_with = "simplify"
    )]
    low: Option<String>,
    /// Make the low mesh by simplifying the high one to this fraction of its triangles
    /// (meshoptimizer), with UVs from the chart generator.
    #[arg(long, value_parser = finite_f32)]
    simplify: Option<f32>,
    /// Map texels per side.
    #[arg(long = "map-res", default_value_t = 1024)]
    res: u32,
    /// Border-expansion passes (texels filled around each chart).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(0..=1024))]
    expand: u32,
    /// Search distance from the low surface, metres (default: 5 % of the low mesh's
    /// bounding-box diagonal).
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f32)]
    distance: Option<f32>,
    /// Turn vertex mirroring off (the paper's Fig. 4 failure, for comparison).
    #[arg(long)]
    no_mirror: bool,
    /// Draw the whole high mesh per low triangle instead of its prism candidates.
    #[arg(long)]
    no_cull: bool,
    /// One draw call per low triangle (with a scissor) instead of one multi-draw indirect.
    #[arg(long)]
    direct_draws: bool,
    /// Who makes the map: `gpu` (the paper's method) or `cpu` (ray casting, the check).
    #[arg(long, value_enum, default_value = "gpu")]
    baker: BakerArg,
    /// With `--baker gpu`: also ray-cast the map on the CPU (`*_cpu` beside `--out`) and
    /// print their angular difference.
    #[arg(long)]
    compare_cpu: bool,
    /// CPU rays along each low triangle's face normal (the GPU's projection direction)
    /// instead of the interpolated normal.
    #[arg(long)]
    cpu_face_rays: bool,
    /// Output .png or .exr: the tangent-space map; the other format and `*_object` (object
    /// space) are written beside it.
    #[arg(short, long)]
    out: PathBuf,
    /// Also write the low mesh as this .gltf (+ .bin), its normal texture the PNG.
    #[arg(long)]
    gltf: Option<PathBuf>,
    #[command(flatten)]
    gpu: GpuArgs,
}

pub(super) fn run_sh(c: ShCommand) -> Result<()> {
    use shvis::tools;
    use std::io::Write;
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    match c {
        ShCommand::Eval { order } => tools::eval(order, std::io::stdin().lock(), &mut out)?,
        ShCommand::Project { env, order } => tools::project(&env, order, &mut out)?,
        ShCommand::Irradiance {
            env,
            normal,
            order,
            exact,
        } => tools::irradiance(&env, &normal, order, exact, &mut out)?,
    }
    out.flush()?;
    Ok(())
}

pub(super) fn run_ssbump(a: SsbumpArgs) -> Result<()> {
    let job = SsbumpJob {
        height: a.height,
        scale: a.scale,
        rays: a.rays,
        bilateral: a.bilateral,
        seed: a.seed,
        out: a.out,
    };
    job.check()?;
    let started = Instant::now();
    let s = ssbump::run(&job)?;
    let [o0, o1, o2] = s.mean_occlusion;
    out!(
        "ssbump {}×{}, {} rays per texel: mean occlusion {o0:.4} {o1:.4} {o2:.4}, mean AO {:.4}; wrote {} (+ .exr, _d, _ao) in {:.1} s",
        s.width,
        s.height,
        job.rays,
        s.mean_ao,
        job.out.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

pub(super) fn run_normalmap(a: NormalmapArgs) -> Result<()> {
    if a.cpu_face_rays && a.baker == BakerArg::Gpu && !a.compare_cpu {
        bail!(
            "--cpu-face-rays steers the CPU baker's rays: only with --baker cpu or --compare-cpu"
        );
    }
    if a.baker == BakerArg::Cpu {
        // The CPU baker casts rays without a device; mirroring, culling and the draw mode
        // belong to the GPU's projection.
        let gpu_only = [
            ("--no-mirror", a.no_mirror),
            ("--no-cull", a.no_cull),
            ("--direct-draws", a.direct_draws),
            ("--device", a.gpu.device.is_some()),
            ("--validate", a.gpu.validate),
        ];
        if let Some((option, _)) = gpu_only.iter().find(|(_, set)| *set) {
            bail!("{option} applies to the GPU baker only: not with --baker cpu");
        }
    }
    let low = match (a.low, a.simplify) {
        (Some(low), _) => LowMesh::Load(low),
        (None, Some(ratio)) => LowMesh::Simplify(ratio),
        (None, None) => bail!("give --low or --simplify"),
    };
    let job = NormalMapJob {
        high: a.high,
        low,
        res: a.res,
        expand: a.expand,
        distance: a.distance,
        mirror: !a.no_mirror,
        cull: !a.no_cull,
        draws: if a.direct_draws {
            DrawMode::Direct
        } else {
            DrawMode::Indirect
        },
        bakers: match (a.baker, a.compare_cpu) {
            (BakerArg::Gpu, false) => Bakers::Gpu,
            (BakerArg::Gpu, true) => Bakers::Both,
            (BakerArg::Cpu, false) => Bakers::Cpu,
            (BakerArg::Cpu, true) => bail!("--compare-cpu: only with --baker gpu"),
        },
        cpu_rays: if a.cpu_face_rays {
            RayDirection::Face
        } else {
            RayDirection::Interpolated
        },
        out: a.out,
        gltf: a.gltf,
    };
    job.check()?;
    let meshes = job::load(&job, &mut say)?;
    if job.needs_gpu() {
        with_gpu(&a.gpu, |ctx| {
            Ok(job::bake(&job, &meshes, Some(ctx), &mut say)?)
        })
    } else {
        Ok(job::bake(&job, &meshes, None, &mut say)?)
    }
}
