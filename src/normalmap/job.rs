//! `shvis normalmap` as one call: load (or simplify) the meshes, bake the map on the GPU,
//! the CPU or both, write it in tangent and object space as 16-bit PNG and EXR, with both
//! bakers the angular difference image, and optionally a glTF of the low mesh that uses
//! the map — every file of the run as one set (`files::FileSet`). Progress lines go to
//! `say` as they happen.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use crate::bake::raster::LightmapTexels;
use crate::files::FileSet;
use crate::gpu::Context;
use crate::scene::Mesh;

use super::cpu::RayDirection;
use super::{
    DrawMode, MeshRole, NormalImage, NormalMapError, NormalMapSettings, angle_deg, compare,
    default_max_distance, load_mesh, low_texels, output, simplify, tangent_space,
};

/// Angle between the two bakers' normals shown white in the difference image, degrees.
pub const DIFFERENCE_WHITE_DEG: f64 = 10.0;

/// Where the low mesh comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum LowMesh {
    /// A glTF file or `sphere:LEVEL` ([`load_mesh`]).
    Load(String),
    /// The high mesh simplified to this fraction of its triangles.
    Simplify(f32),
}

/// Which bakers run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bakers {
    /// The paper's method.
    Gpu,
    /// Ray casting (the check).
    Cpu,
    /// Both: the GPU's map at `out`, the CPU's as `*_cpu`, and their difference `*_diff`.
    Both,
}

/// What `shvis normalmap` makes.
#[derive(Clone, Debug, PartialEq)]
pub struct NormalMapJob {
    /// High mesh: a glTF file or `sphere:LEVEL`.
    pub high: String,
    pub low: LowMesh,
    /// Map texels per side.
    pub res: u32,
    /// Border-expansion passes.
    pub expand: u32,
    /// Search distance, metres (`None`: [`default_max_distance`] of the low mesh).
    pub distance: Option<f32>,
    pub mirror: bool,
    pub cull: bool,
    pub draws: DrawMode,
    pub bakers: Bakers,
    /// The CPU baker's ray direction.
    pub cpu_rays: RayDirection,
    /// Output .png or .exr (the tangent-space map; the other format and `*_object`
    /// beside it).
    pub out: PathBuf,
    /// Also the low mesh as this .gltf (+ .bin), its normal texture the PNG.
    pub gltf: Option<PathBuf>,
}

impl NormalMapJob {
    /// Checks the output names and the resolution, before any work.
    pub fn check(&self) -> Result<(), NormalMapError> {
        let invalid = |m: String| Err(NormalMapError::Invalid(m));
        let ext = self.out.extension().and_then(|e| e.to_str());
        if !matches!(ext, Some("png" | "exr")) {
            return invalid(format!(
                "{}: the output must be a .png or .exr",
                self.out.display()
            ));
        }
        if let Some(g) = &self.gltf {
            if g.extension().and_then(|e| e.to_str()) != Some("gltf") {
                return invalid(format!("{}: --gltf must name a .gltf file", g.display()));
            }
            // The glTF's image URI: the map must lie where the glTF can reference it.
            relative_uri(g, &self.out.with_extension("png")).map_err(NormalMapError::Invalid)?;
        }
        if !(super::MIN_RES..=super::MAX_RES).contains(&self.res) {
            return invalid(format!(
                "--map-res {} is outside {}..={}",
                self.res,
                super::MIN_RES,
                super::MAX_RES
            ));
        }
        let files = |option: &'static str, name: &str| -> Vec<(&'static str, PathBuf)> {
            if name.starts_with("sphere:") {
                return Vec::new();
            }
            // With the buffers and images the glTF references.
            crate::scene::gltf::files_read(std::path::Path::new(name))
                .into_iter()
                .map(|path| (option, path))
                .collect()
        };
        let mut inputs = files("--high", &self.high);
        if let LowMesh::Load(low) = &self.low {
            inputs.extend(files("--low", low));
        }
        let inputs: Vec<(&str, &std::path::Path)> =
            inputs.iter().map(|(o, p)| (*o, p.as_path())).collect();
        crate::files::check_outputs_spare_inputs(&self.outputs(), &inputs)
            .map_err(|e| NormalMapError::Invalid(e.to_string()))
    }

    /// Every file the job may write, with the option that names it.
    fn outputs(&self) -> Vec<(String, PathBuf)> {
        let stem = self.out.with_extension("").display().to_string();
        let mut outputs = Vec::new();
        for side in ["", "_object", "_cpu", "_cpu_object"] {
            for ext in ["png", "exr"] {
                let option = if side.is_empty() {
                    "--out".to_string()
                } else {
                    format!("--out's {side} file")
                };
                outputs.push((option, PathBuf::from(format!("{stem}{side}.{ext}"))));
            }
        }
        outputs.push((
            "--out's _diff file".into(),
            PathBuf::from(format!("{stem}_diff.png")),
        ));
        if let Some(g) = &self.gltf {
            outputs.push(("--gltf".into(), g.clone()));
            outputs.push(("--gltf's buffer".into(), g.with_extension("bin")));
        }
        outputs
    }

    /// Whether the job bakes on a device.
    pub fn needs_gpu(&self) -> bool {
        self.bakers != Bakers::Cpu
    }
}

/// The meshes of a job and its bake settings ([`load`]).
pub struct JobMeshes {
    pub high: Mesh,
    pub low: Mesh,
    pub settings: NormalMapSettings,
    started: Instant,
}

/// Loads (or simplifies) the meshes and settles the bake settings; says what it got.
pub fn load(job: &NormalMapJob, say: &mut dyn FnMut(&str)) -> Result<JobMeshes, NormalMapError> {
    let started = Instant::now();
    let high = load_mesh(&job.high, MeshRole::High)?;
    let low = match &job.low {
        LowMesh::Load(low) => load_mesh(low, MeshRole::Low { res: job.res })?,
        LowMesh::Simplify(ratio) => {
            let (low, report) = simplify::simplify(&high, *ratio, job.res)?;
            say(&format!(
                "simplified {} → {} triangles (meshoptimizer error {:.2e} of the extent), {} charts",
                report.from_triangles, report.to_triangles, report.relative_error, report.charts
            ));
            low
        }
    };
    let settings = NormalMapSettings {
        expand: job.expand,
        max_distance: job.distance.unwrap_or_else(|| default_max_distance(&low)),
        mirror: job.mirror,
        cull: job.cull,
        draws: job.draws,
        ..NormalMapSettings::new(&low, job.res)
    };
    say(&format!(
        "high {} triangles, low {} triangles, {}² texels, search distance {:.4} m",
        high.triangle_count(),
        low.triangle_count(),
        job.res,
        settings.max_distance
    ));
    Ok(JobMeshes {
        high,
        low,
        settings,
        started,
    })
}

/// Bakes `meshes` with the job's bakers (`ctx`: the device of the GPU baker) and writes
/// the files.
pub fn bake(
    job: &NormalMapJob,
    meshes: &JobMeshes,
    ctx: Option<&Arc<Context>>,
    say: &mut dyn FnMut(&str),
) -> Result<(), NormalMapError> {
    let JobMeshes {
        high,
        low,
        settings,
        started,
    } = meshes;
    let frames = low_texels(low, job.res);
    let low_texels = frames.covered_count();
    let stem = job.out.with_extension("");
    let mut files = FileSet::new();
    let gpu_image = if job.needs_gpu() {
        let ctx =
            ctx.ok_or_else(|| NormalMapError::Invalid("the GPU baker needs a device".to_string()))?;
        let (image, t) = super::gpu::bake(ctx, high, low, settings)?;
        let gpu_ms = t.gpu_ms.map_or("no timestamps".to_string(), |ms| {
            format!(
                "GPU mask {:.2} + project {:.2} + expand {:.2} ms",
                ms.mask, ms.project, ms.expand
            )
        });
        say(&format!(
            "gpu ({}): {} renders, {} high triangles drawn, {} of the low mesh's {low_texels} texels; {gpu_ms}; prepare {:.3} s, setup {:.3} s, execute {:.3} s, total {:.3} s",
            ctx.device_name(),
            t.renders,
            t.triangles_drawn,
            image.covered_count(),
            t.prepare_s,
            t.setup_s,
            t.execute_s,
            t.total_s
        ));
        write_maps(&mut files, &image, &frames, &stem, "", job.res)?;
        Some(image)
    } else {
        None
    };
    if job.bakers != Bakers::Gpu {
        let (image, t) = super::cpu::bake(high, low, settings, job.cpu_rays)?;
        say(&format!(
            "cpu: {} rays, {} of the low mesh's {low_texels} texels; BVH {:.3} s, trace {:.3} s, total {:.3} s",
            t.rays,
            image.covered_count(),
            t.bvh_s,
            t.trace_s,
            t.total_s
        ));
        let suffix = if gpu_image.is_some() { "_cpu" } else { "" };
        write_maps(&mut files, &image, &frames, &stem, suffix, job.res)?;
        if let Some(gpu_image) = &gpu_image {
            match compare(gpu_image, &image, &gpu_image.interior()) {
                Some(stats) => say(&format!("gpu vs cpu, interior texels: {stats}")),
                None => say("gpu vs cpu: no interior texel generated by both"),
            }
            let path = PathBuf::from(format!("{}_diff.png", stem.display()));
            output::write_map(
                &files.stage(&path),
                job.res,
                &difference_image(gpu_image, &image),
                [0.0; 3],
            )
            .map_err(naming(&path))?;
        }
    }
    let gltf_line = match &job.gltf {
        Some(g) => {
            let png = PathBuf::from(format!("{}.png", stem.display()));
            let uri = relative_uri(g, &png).map_err(NormalMapError::Invalid)?;
            let (document, buffer) = output::low_gltf(g, low, Some(&uri))?;
            let bin = g.with_extension("bin");
            crate::files::write(files.stage(&bin), &buffer).map_err(|e| io_error(&bin, e))?;
            crate::files::write(files.stage(g), document).map_err(|e| io_error(g, e))?;
            Some(format!("wrote {} (normal texture {uri})", g.display()))
        }
        None => None,
    };
    for (_, path) in job
        .outputs()
        .iter()
        .filter(|(option, _)| !option.starts_with("--gltf"))
    {
        files.replaces(path);
    }
    files.commit()?;
    if let Some(line) = gltf_line {
        say(&line);
    }
    say(&format!(
        "wrote {}.{{png,exr}} and {}_object.{{png,exr}} in {:.1} s",
        stem.display(),
        stem.display(),
        started.elapsed().as_secs_f64()
    ));
    Ok(())
}

/// Writes `image` into `files` as `{stem}{suffix}.{png,exr}` (tangent space) and
/// `{stem}{suffix}_object.{png,exr}` (object space).
fn write_maps(
    files: &mut FileSet,
    image: &NormalImage,
    frames: &LightmapTexels,
    stem: &Path,
    suffix: &str,
    res: u32,
) -> Result<(), NormalMapError> {
    let tangent = tangent_space(image, frames);
    for ext in ["png", "exr"] {
        let path = |s: &str| PathBuf::from(format!("{}{suffix}{s}.{ext}", stem.display()));
        let (map, object) = (path(""), path("_object"));
        output::write_map(&files.stage(&map), res, &tangent, [0.0, 0.0, 1.0])
            .map_err(naming(&map))?;
        output::write_map(&files.stage(&object), res, &image.texels, [0.0; 3])
            .map_err(naming(&object))?;
    }
    Ok(())
}

/// An I/O error of writing `path`.
fn io_error(path: &Path, e: impl std::fmt::Display) -> NormalMapError {
    NormalMapError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// An I/O error of writing `path`'s temporary in a [`FileSet`], naming `path` instead.
fn naming(path: &Path) -> impl Fn(NormalMapError) -> NormalMapError + '_ {
    move |e| match e {
        NormalMapError::Io { message, .. } => io_error(path, message),
        e => e,
    }
}

/// The angle between two maps' normals as a grey map for [`output::write_map`]:
/// [`DIFFERENCE_WHITE_DEG`] and more white, black where either has no normal.
pub fn difference_image(a: &NormalImage, b: &NormalImage) -> Vec<[f32; 4]> {
    (0..b.texels.len())
        .map(|i| {
            let both = a.texels[i][3] > 0.0 && b.texels[i][3] > 0.0;
            let angle = angle_deg(a.normal(i), b.normal(i));
            let v = if both {
                (angle / DIFFERENCE_WHITE_DEG).min(1.0) as f32 * 2.0 - 1.0
            } else {
                -1.0
            };
            [v, v, v, 1.0]
        })
        .collect()
}

/// `dir` with its links and `.`/`..` resolved, folders the run has yet to create included:
/// the longest existing ancestor canonicalized, the rest appended.
fn resolved(dir: &Path) -> Result<PathBuf, String> {
    use std::path::Component;
    let absolute = std::path::absolute(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut existing = absolute.as_path();
    let mut missing = Vec::new();
    let mut path = loop {
        if let Ok(path) = existing.canonicalize() {
            break path;
        }
        match (existing.parent(), existing.components().next_back()) {
            (Some(parent), Some(last)) => {
                missing.push(last);
                existing = parent;
            }
            _ => return Err(format!("{}: no existing folder above it", dir.display())),
        }
    };
    for part in missing.into_iter().rev() {
        match part {
            Component::ParentDir => {
                path.pop();
            }
            Component::CurDir => {}
            part => path.push(part),
        }
    }
    Ok(path)
}

/// `target` as a URI relative to the folder of `from`, the glTF that references it: its
/// path below that folder, each segment percent-encoded. A glTF references only files in
/// its folder or below it (`scene::gltf`'s URI policy), so a `target` elsewhere is an
/// error, as is a name that is not UTF-8.
pub fn relative_uri(from: &Path, target: &Path) -> Result<String, String> {
    let dir = |p: &Path| {
        p.parent()
            .filter(|d| !d.as_os_str().is_empty())
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
    };
    let (base, folder) = (resolved(&dir(from))?, resolved(&dir(target))?);
    let below = folder.strip_prefix(&base).map_err(|_| {
        format!(
            "{} lies outside the folder of --gltf {} ({}): a glTF references only files in its folder or below it; write --out there",
            target.display(),
            from.display(),
            base.display()
        )
    })?;
    let name = target
        .file_name()
        .ok_or_else(|| format!("{}: not a file name", target.display()))?;
    let mut segments = Vec::new();
    for part in below.iter().chain([name]) {
        let part = part
            .to_str()
            .ok_or_else(|| format!("{}: the name is not UTF-8", target.display()))?;
        segments.push(crate::scene::gltf::percent_encode(part));
    }
    Ok(segments.join("/"))
}
