//! The command line (DESIGN §4), a thin shell: clap types grouped by command, each
//! command's run turning its arguments into the library's settings and calling the
//! library. `anyhow` lives here and in main.rs only; every failure becomes one `error: …`
//! line and a non-zero exit.

/// Prints a line on standard output (`shvis::files::stdout`); a line that cannot be written
/// (a full device) is the command's error.
macro_rules! out {
    ($($arg:tt)*) => {
        shvis::files::stdout::print_line(format_args!($($arg)*))
            .map_err(|e| anyhow::anyhow!("cannot write to standard output: {e}"))?
    };
}
/// Prints a note on standard error; one that cannot be written (a full or closed stderr)
/// is dropped: a note is not the run's result.
macro_rules! note {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}
mod args;
mod bake;
mod bench;
mod export;
mod render;
mod study;
mod tools;
mod view;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context as _, Result, bail};
use clap::{Parser, Subcommand};

use shvis::gpu::{Context, ContextDesc};
use shvis::prepare::PrepareSettings;
use shvis::technique::{HwPath, Technique};

use args::{GpuArgs, SceneArgs};

/// Largest frame side accepted before asking the device (which may allow less).
const MAX_FRAME_SIDE: u32 = 16384;
/// PNG exposure unless `--exposure` says otherwise.
const DEFAULT_EXPOSURE_EV: f32 = -1.0;
/// Most bounces of inter-reflection accepted (each adds a pass over the lightmap).
const MAX_BOUNCES: u32 = 16;

#[derive(Parser, Debug)]
#[command(
    name = "shvis",
    version = concat!(env!("CARGO_PKG_VERSION"), " (", env!("SHVIS_GIT_COMMIT"), ")"),
    about = "Normal mapping with low-frequency precomputed visibility (Iwanicki & Sloan): bake, render, measure"
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Bake SH visibility and ambient occlusion and write them as EXR layers for inspection.
    Bake(bake::BakeArgs),
    /// Render one technique on one hardware path to a PNG or EXR.
    Render(render::RenderArgs),
    /// Write a technique's baked data for an engine: KTX2 files, the uniform block, the
    /// decode shader and a manifest.
    Export(export::ExportArgs),
    /// Ground truth: G-buffer on the GPU, ray-cast visibility and importance-sampled
    /// environment integration on the CPU; prints its noise level.
    Reference(render::ReferenceArgs),
    /// Time every technique × path and write table.md, table.json and images.
    Bench(bench::BenchArgs),
    /// Microbenchmarks of the current device (lookups by kind, float ops, varyings,
    /// uniform reads, depth test) and the cost model fitted to them → probe.md, probe.json
    /// (`shvis bench` runs it first).
    Probe(bench::ProbeArgs),
    /// A window: the scene with any technique × path switched by keys, an orbit camera,
    /// the sun turned or animated with the dynamic-lighting machinery, an overlay with GPU
    /// ms and frame rate. Needs a display (X11; `xvfb-run -a` without one).
    View(view::ViewArgs),
    /// Dynamic lighting (§3.3): turn the environment about +Y over a run of frames, rebuild
    /// each technique's lighting data every K frames, and report rebuild and GPU times and
    /// the errors at sampled frames (static and lag).
    Relight(view::RelightArgs),
    /// SH utilities for checking the math from outside (17 significant digits).
    #[command(subcommand)]
    Sh(tools::ShCommand),
    /// Reproduce the paper's side studies.
    #[command(subcommand)]
    Study(study::StudyCommand),
    /// Self-shadowed bump map from a height map (Green, Valve): writes the SSBump
    /// (D · directional occlusion) as 16-bit PNG and EXR, the plain D encoding and scalar AO.
    Ssbump(tools::SsbumpArgs),
    /// Normal map of a high-polygon mesh for a low one, on the GPU (Gumbau et al.):
    /// tangent- and object-space 16-bit PNG + EXR, optionally the low mesh as glTF.
    Normalmap(tools::NormalmapArgs),
    /// List the Vulkan devices: name, kind, driver, Vulkan version, timer, subgroup size;
    /// `*` marks the one shvis picks (the first discrete GPU, or `--device`'s).
    Devices(tools::DevicesArgs),
    /// Every technique family: its names, what it is, its paper, its paths, what it bakes.
    Techniques(tools::TechniquesArgs),
    /// A results page: bench tables (`table.json`) side by side per technique and path,
    /// ms and ×preconv beside the paper's GTX 295 column, as markdown (docs/results/).
    Report(tools::ReportArgs),
}

/// Parses the arguments and runs the command.
pub fn run(cli: Cli) -> Result<()> {
    check_environment()?;
    match cli.command {
        Command::Bake(a) => bake::run_bake(a).context("bake"),
        Command::Render(a) => render::run_render(a).context("render"),
        Command::Export(a) => export::run_export(a).context("export"),
        Command::Reference(a) => render::run_reference(a).context("reference"),
        Command::Bench(a) => bench::run_bench(a).context("bench"),
        Command::Probe(a) => bench::run_probe(a).context("probe"),
        Command::Relight(a) => view::run_relight(a).context("relight"),
        Command::View(a) => view::run_view(a).context("view"),
        Command::Sh(c) => tools::run_sh(c).context("sh"),
        Command::Study(c) => study::run_study(c),
        Command::Ssbump(a) => tools::run_ssbump(a).context("ssbump"),
        Command::Normalmap(a) => tools::run_normalmap(a).context("normalmap"),
        Command::Devices(a) => tools::run_devices(a).context("devices"),
        Command::Report(a) => tools::run_report(a).context("report"),
        Command::Techniques(a) => tools::run_techniques(a).context("techniques"),
    }
}

/// Opens the device `gpu` names, runs `work` on it, then — with `--validate` — fails the
/// command if validation reported any error or warning. Every command that opens a device
/// goes through here; an error of `work` comes first and skips the check.
fn with_gpu<T>(gpu: &GpuArgs, work: impl FnOnce(&Arc<Context>) -> Result<T>) -> Result<T> {
    let ctx = Context::new(&ContextDesc {
        validate: gpu.validate,
        device: gpu.device.clone(),
        ..ContextDesc::default()
    })?;
    log::info!("device: {}", ctx.device_name());
    let value = work(&ctx)?;
    let (errors, warnings) = ctx.message_counts();
    check_validation(gpu.validate, errors, warnings)?;
    Ok(value)
}

/// With `--validate`, any validation error or warning fails the command.
fn check_validation(validate: bool, errors: u32, warnings: u32) -> Result<()> {
    if validate && (errors > 0 || warnings > 0) {
        bail!("validation reported {errors} errors and {warnings} warnings (see the log above)");
    }
    Ok(())
}

/// Prints a library progress line on stdout; a failure to write it is remembered and fails
/// the command at its end (`shvis::files::stdout::failure`).
fn say(line: &str) {
    let _ = shvis::files::stdout::print_line(format_args!("{line}"));
}

/// The frames' memory on the host, checked before any work: `bytes_per_pixel` covers the
/// readbacks (RGBA32F) and the images a command keeps (render 48, reference's G-buffers and
/// sums 160, the bench's reference, row and ladder images 320).
fn check_frame_memory(width: u32, height: u32, bytes_per_pixel: u64) -> Result<()> {
    Ok(shvis::limits::check_memory(
        format_args!("--width {width} × --height {height}: the frames"),
        shvis::limits::image_bytes(u64::from(width), u64::from(height), bytes_per_pixel),
        "lower --width or --height",
    )?)
}

/// Prints a run's markdown table and where its files went.
fn print_table(markdown: &str, out: &Path, tables: &str, started: Instant) -> Result<()> {
    out!("{markdown}");
    out!(
        "wrote {}/{tables} and images in {:.1} s",
        out.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Prints the files a run wrote, one `wrote PATH` line each.
fn print_written(paths: &[PathBuf]) -> Result<()> {
    for p in paths {
        out!("wrote {}", p.display());
    }
    Ok(())
}

/// The `SHVIS_*` variables that hold values, checked before any work: one that does not
/// parse is an error, not ignored.
fn check_environment() -> Result<()> {
    use shvis::bake::trace::{LANES_ENV, LANES_VALUES};
    use shvis::limits::{MEMORY_LIMIT_ENV, parse_bytes};
    let value = |name: &str| match std::env::var(name) {
        Ok(v) => Ok(Some(v)),
        Err(std::env::VarError::NotPresent) => Ok(None),
        Err(std::env::VarError::NotUnicode(v)) => Err(anyhow::anyhow!("{name}={v:?}: not text")),
    };
    if let Some(v) = value(MEMORY_LIMIT_ENV)?
        && parse_bytes(&v).is_none()
    {
        bail!("{MEMORY_LIMIT_ENV}={v:?}: expected bytes, as 4096, 512M or 8G");
    }
    if let Some(v) = value(LANES_ENV)?
        && !LANES_VALUES.contains(&v.trim())
    {
        bail!(
            "{LANES_ENV}={v:?}: expected one of {} (SIMD lanes)",
            LANES_VALUES.join(", ")
        );
    }
    if std::env::var_os(shvis::report::plot::FONT_ENV).is_some() {
        shvis::report::plot::register_plot_font().map_err(anyhow::Error::msg)?;
    }
    Ok(())
}

/// The files a run reads, each with the option that names it: a scene's (a glTF and the
/// buffers and images it references), environments' and any others, for the checks that
/// keep its outputs off them.
#[derive(Default)]
struct RunInputs(Vec<(&'static str, PathBuf)>);

/// How [`RunInputs::check_outside`] names the `--out` of a run that writes files into it.
const OUT_FOLDER: &str = "--out (the folder the run writes into)";
/// … and of a run that replaces it whole (`files::replace_dir`).
const OUT_REPLACED: &str = "--out (a folder the run replaces whole)";

impl RunInputs {
    /// The files of `--scene` and `--height-map`.
    fn of_scene(scene: &SceneArgs) -> Self {
        RunInputs::default()
            .scene("--scene", &scene.scene)
            .file("--height-map", scene.height_map.as_deref())
    }

    /// The files of the scene `name` (none for a built-in scene).
    fn scene(mut self, option: &'static str, name: &str) -> Self {
        let files = shvis::prepare::scene_files(name);
        self.0.extend(files.into_iter().map(|f| (option, f)));
        self
    }

    /// The file of the environment `spec` (none for the built-in sky).
    fn env(mut self, option: &'static str, spec: &str) -> Self {
        if let Some(file) = shvis::env::file_of(spec) {
            self.0.push((option, file.to_path_buf()));
        }
        self
    }

    /// A file read as it is named.
    fn file(mut self, option: &'static str, path: Option<&Path>) -> Self {
        self.0.extend(path.map(|p| (option, p.to_path_buf())));
        self
    }

    /// The pairs as the `shvis::files` checks take them.
    fn pairs(&self) -> Vec<(&str, &Path)> {
        self.0.iter().map(|(o, p)| (*o, p.as_path())).collect()
    }

    /// Refuses `outputs` that are any of these files.
    fn check_spared_by(&self, outputs: &[(String, PathBuf)]) -> Result<()> {
        Ok(shvis::files::check_outputs_spare_inputs(
            outputs,
            &self.pairs(),
        )?)
    }

    /// Refuses an output folder `dir` that holds any of these files.
    fn check_outside(&self, dir: &Path, output: &str) -> Result<()> {
        Ok(shvis::files::check_inputs_outside(
            dir,
            output,
            &self.pairs(),
        )?)
    }
}

/// Creates the `--out` directory and checks it takes files, before any work.
fn create_dir(dir: &Path) -> Result<()> {
    Ok(shvis::files::check_writable_dir(dir, "--out")?)
}

/// `all` or a comma-separated list of names.
fn parse_list<T>(list: &str, all: &[T]) -> Result<Vec<T>>
where
    T: std::str::FromStr + Copy + PartialEq + std::fmt::Display,
    T::Err: std::error::Error + Send + Sync + 'static,
{
    if list == "all" {
        return Ok(all.to_vec());
    }
    parse_each_once(list)
}

/// A `--techniques` value: a named set (`all`, `paper`, `headline`:
/// `technique::catalog::named_set`) or a comma-separated list of names. A set is given
/// alone; an unknown name's error lists the sets beside the names.
fn parse_techniques(list: &str) -> Result<Vec<Technique>> {
    use shvis::technique::catalog::{SET_NAMES, named_set};
    if let Some(set) = named_set(list.trim()) {
        return Ok(set);
    }
    if let Some(set) = list
        .split(',')
        .map(str::trim)
        .find(|e| SET_NAMES.contains(e))
    {
        bail!(
            "'{list}': {set} is a set of techniques and is given alone (--techniques {set}); to add others, list every technique by name (`shvis techniques` names them)"
        );
    }
    parse_each_once(list).map_err(|e| {
        if e.downcast_ref::<shvis::technique::ParseError>().is_some() {
            anyhow::anyhow!("{e}; or a set, given alone: {}", SET_NAMES.join(", "))
        } else {
            e
        }
    })
}

/// A `--technique` value: one technique's name; a named set is explained, not unknown.
fn parse_one_technique(name: &str) -> Result<Technique> {
    use shvis::technique::catalog::SET_NAMES;
    if SET_NAMES.contains(&name.trim()) {
        bail!(
            "'{name}' is a set of techniques; --technique takes one name (`shvis techniques` names them; bench and relight take sets)"
        );
    }
    Ok(name.trim().parse()?)
}

/// A comma-separated list of names, each at most once.
fn parse_each_once<T>(list: &str) -> Result<Vec<T>>
where
    T: std::str::FromStr + PartialEq + std::fmt::Display,
    T::Err: std::error::Error + Send + Sync + 'static,
{
    let mut items: Vec<T> = Vec::new();
    for (i, s) in list.split(',').enumerate() {
        if s.trim().is_empty() {
            bail!(
                "'{list}': entry {} is empty (a comma too many, or none between two names)",
                i + 1
            );
        }
        items.push(s.trim().parse()?);
        named_once(&format!("'{list}'"), &items)?;
    }
    Ok(items)
}

/// Refuses a list `option` names an item of twice (its rows would repeat).
fn named_once<T: PartialEq + std::fmt::Display>(option: &str, items: &[T]) -> Result<()> {
    for (i, item) in items.iter().enumerate() {
        if items[..i].contains(item) {
            bail!("{option}: {item} is named twice");
        }
    }
    Ok(())
}

/// Clears `out` of what an earlier run left there before this one writes into it: the
/// temporaries of a killed run and the report files `reports`, so that a run that stops
/// early never leaves a report describing other images.
fn clear_earlier_run(out: &std::path::Path, reports: &[&str]) {
    shvis::files::remove_stale_temps(out);
    for stale in reports {
        let _ = std::fs::remove_file(out.join(stale));
    }
}

/// Removes the files and folders in `out` that `written_by_run` names as the command's own
/// (an earlier run's images, a study's optional outputs), so that the folder describes one
/// run.
fn clear_earlier_files(out: &std::path::Path, written_by_run: fn(&str) -> bool) {
    let Ok(entries) = std::fs::read_dir(out) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        if !name.to_str().is_some_and(written_by_run) {
            continue;
        }
        match entry.file_type() {
            Ok(t) if t.is_file() => {
                let _ = std::fs::remove_file(entry.path());
            }
            Ok(t) if t.is_dir() => {
                let _ = std::fs::remove_dir_all(entry.path());
            }
            _ => {}
        }
    }
}

/// The technique × path pairs a run measures are those that fit the path's rules
/// (`Technique::runs_on`). One that does not fails the run with the reason, unless
/// `techniques` came from a named set or `skip_unsupported` is given — then each is named on
/// stderr; a run left with no pair fails either way.
fn check_rows(
    list: &str,
    techniques: &[Technique],
    paths: &[HwPath],
    skip_unsupported: bool,
) -> Result<()> {
    let unsupported: Vec<String> = techniques
        .iter()
        .flat_map(|&t| {
            paths
                .iter()
                .filter_map(move |&p| t.form_on(p).err().map(|why| format!("{t}.{p} ({why})")))
        })
        .collect();
    let runnable = techniques.len() * paths.len() - unsupported.len();
    if runnable == 0 {
        bail!(
            "no row to measure: {}; add --paths dx10",
            unsupported.join(", ")
        );
    }
    if unsupported.is_empty() {
        return Ok(());
    }
    let named_set = shvis::technique::catalog::named_set(list.trim()).is_some();
    if !named_set && !skip_unsupported {
        bail!(
            "cannot run {}; leave it out, or pass --skip-unsupported to measure the rest",
            unsupported.join(", ")
        );
    }
    note!(
        "note: left out, as they cannot run: {}",
        unsupported.join(", ")
    );
    Ok(())
}

/// The bake settings of `scene` under `env` for `techniques`: the inter-reflected bakes
/// (SH lightmap, transfer matrices) with `bounces` where a technique needs them.
fn prepare_settings(
    scene: &SceneArgs,
    env: &str,
    techniques: &[Technique],
    bounces: u32,
) -> Result<PrepareSettings> {
    let needs = |f: fn(&shvis::technique::BakeNeeds) -> bool| {
        techniques.iter().any(|t| f(&t.needs())).then_some(bounces)
    };
    let options = shvis::technique::FamilyOptions {
        Hemisphere: shvis::technique::HemisphereOptions {
            solver: scene.sg_solve,
            fit: scene.basis_fit,
        },
        AmbientCube: scene.basis_fit,
        ..Default::default()
    };
    let sample_fits = shvis::prepare::sample_fits_for(techniques, &options);
    let settings = PrepareSettings {
        scene: scene.scene.clone(),
        env: env.to_string(),
        vis_res: scene.vis_res,
        rays: scene.rays,
        seed: scene.seed,
        progress: true,
        order: shvis::sh::Order::new(scene.order).context("--order")?,
        table_res: scene.table_res,
        h_order: shvis::sh::Order::new(scene.h_order).context("--h-order")?,
        options,
        cache_dir: None,
        sh_lightmap_bounces: needs(|n| n.sh_lightmap),
        sample_fits,
        bake_env: scene.bake_env,
        transfer_bounces: needs(|n| n.transfer),
        transfer_order: shvis::sh::Order::new(scene.transfer_order).context("--transfer-order")?,
        height_map: scene
            .height_map
            .clone()
            .map(|path| (path, scene.height_scale)),
    };
    // Every range and the bake's memory, before a device is opened or a file read.
    shvis::prepare::check_settings(&settings)?;
    Ok(settings)
}

/// The scene of `scene` under `env` prepared for `techniques` (inter-reflected bakes with
/// the default bounces), on the CPU baker.
fn prepare_for(
    scene: &SceneArgs,
    env: &str,
    techniques: &[Technique],
    bounces: u32,
) -> Result<shvis::prepare::Prepared> {
    let mut prepared =
        shvis::prepare::prepare(&prepare_settings(scene, env, techniques, bounces)?)?;
    prepared.prepare_techniques(techniques)?;
    Ok(prepared)
}

#[cfg(test)]
mod tests {
    use std::collections::{BTreeMap, BTreeSet};

    use clap::CommandFactory;

    use super::Cli;

    /// Every leaf command ("bench", "study rnm") and its long options, from clap's tree.
    fn commands() -> BTreeMap<String, BTreeSet<String>> {
        fn walk(cmd: &clap::Command, prefix: &str, out: &mut BTreeMap<String, BTreeSet<String>>) {
            for sub in cmd.get_subcommands().filter(|s| s.get_name() != "help") {
                let name = format!("{prefix}{}", sub.get_name());
                if sub.has_subcommands() {
                    walk(sub, &format!("{name} "), out);
                } else {
                    let options = sub
                        .get_arguments()
                        .filter_map(|a| a.get_long())
                        .filter(|l| !matches!(*l, "help" | "version"))
                        .map(|l| format!("--{l}"))
                        .collect();
                    out.insert(name, options);
                }
            }
        }
        let mut out = BTreeMap::new();
        walk(&Cli::command(), "", &mut out);
        out
    }

    /// The `--options` of the table rows in `text` ("| `--name …` | …").
    fn table_options(text: &str) -> BTreeSet<String> {
        text.lines()
            .filter_map(|l| l.strip_prefix("| `--"))
            .map(|rest| {
                let name: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '-')
                    .collect();
                format!("--{name}")
            })
            .collect()
    }

    /// docs/guide.md's sections: heading → text, for "shvis …" headings and the shared
    /// option groups (by their anchors).
    fn guide_sections(guide: &str) -> BTreeMap<String, String> {
        let mut sections = BTreeMap::new();
        let mut current: Option<String> = None;
        for line in guide.lines() {
            if let Some(heading) = line
                .strip_prefix("## ")
                .or_else(|| line.strip_prefix("### "))
            {
                let key = match heading.strip_prefix("shvis ") {
                    Some(command) => command.trim().to_string(),
                    None => format!("#{}", heading.trim().to_lowercase().replace(' ', "-")),
                };
                current = Some(key.clone());
                sections.insert(key, String::new());
            } else if let Some(key) = &current {
                let text = sections.get_mut(key).expect("inserted with the heading");
                text.push_str(line);
                text.push('\n');
            }
        }
        sections
    }

    /// Each command's section in docs/guide.md names exactly its options: its own table's,
    /// plus the shared groups it links (`(#device-options)`, …).
    fn guide_mismatches(guide: &str) -> Vec<String> {
        let sections = guide_sections(guide);
        let mut problems = Vec::new();
        for (command, options) in commands() {
            let Some(text) = sections.get(&command) else {
                problems.push(format!("`shvis {command}` has no section in docs/guide.md"));
                continue;
            };
            let own = table_options(text);
            let mut documented = own.clone();
            for (anchor, shared) in sections.iter().filter(|(k, _)| k.starts_with('#')) {
                if text.contains(&format!("({anchor})")) {
                    documented.extend(table_options(shared));
                }
            }
            for missing in options.difference(&documented) {
                problems.push(format!(
                    "`shvis {command} {missing}` is not in docs/guide.md"
                ));
            }
            for stray in own.difference(&options) {
                problems.push(format!(
                    "docs/guide.md names `shvis {command} {stray}`, which does not exist"
                ));
            }
        }
        problems
    }

    #[test]
    fn the_guide_names_every_option_and_no_other() {
        let guide = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/guide.md"))
            .expect("docs/guide.md");
        let problems = guide_mismatches(&guide);
        assert!(problems.is_empty(), "\n{}", problems.join("\n"));
        // The check itself: a removed option and an invented one are both found.
        let removed = guide.replace("| `--strict` |", "| strict |");
        assert!(
            guide_mismatches(&removed)
                .iter()
                .any(|p| p.contains("shvis bench --strict` is not in"))
        );
        let invented = guide.replace("| `--strict` |", "| `--strictest` |");
        assert!(
            guide_mismatches(&invented)
                .iter()
                .any(|p| p.contains("`shvis bench --strictest`, which does not exist"))
        );
    }

    /// Options that are refused where they would do nothing have no clap default (clap
    /// cannot tell a default from a typed value); their help names the default the code
    /// fills in, so the two must agree.
    #[test]
    fn optional_settings_name_their_real_default_in_help() {
        let gpu = shvis::bake::gpu_visibility::GpuVisibilitySettings::default();
        let cases = [
            (
                "bench",
                "ladder_stride",
                shvis::bench::DEFAULT_LADDER_STRIDE.to_string(),
            ),
            ("render", "depth_res", gpu.depth_res.to_string()),
            ("render", "depth_bias", gpu.bias_texels.to_string()),
            ("render", "slope_bias", gpu.slope_bias_texels.to_string()),
        ];
        let cli = Cli::command();
        for (command, id, default) in cases {
            let sub = cli.find_subcommand(command).expect(command);
            let arg = sub.get_arguments().find(|a| a.get_id() == id).expect(id);
            let help = arg.get_help().map(|h| h.to_string()).unwrap_or_default();
            assert!(
                help.contains(&format!("default {default}")),
                "{command} --{id}: help {help:?} does not name the default {default}"
            );
        }
    }
}
