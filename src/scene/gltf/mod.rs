//! glTF 2.0 scenes (`.gltf` with external or data-URI buffers, `.glb`), DESIGN §1 and §4
//! (`--scene PATH`).
//!
//! What is read: every primitive of mode TRIANGLES of every mesh instance reached from the
//! default scene (else the first), walking the node hierarchy with world transforms:
//! positions by the world matrix M, normals by M's inverse-transpose, TANGENT xyz by M's
//! upper 3×3, all renormalized. A transform with det M < 0 mirrors the mesh, so the winding
//! is swapped (triangles stay counter-clockwise around their normal) and the tangent's w is
//! negated (the bitangent w·(n × t) must still follow the mirrored surface).
//!
//! - NORMAL: as given; when absent, area-weighted smooth normals over the primitive's
//!   indexed triangles (the brief's choice; glTF asks for flat normals, which the same code
//!   gives for unshared vertices).
//! - TANGENT: used as given (DESIGN §1); when absent, MikkTSpace on (u, 1 − v)
//!   ([`super::tangent`]), computed on the world-space triangles.
//! - TEXCOORD_0: material UVs (default (0, 0)). TEXCOORD_1: lightmap UVs, used as given only
//!   when every primitive has them in [0, 1] and no mesh is instanced twice (two instances
//!   of one layout would share texels); otherwise generated for the whole scene by
//!   [`super::lightmap_uv::generate`].
//! - Material: shvis renders one albedo and one normal texture per scene, so the first
//!   primitive with a base-colour texture supplies the albedo, the first with a normal
//!   texture the normal map and its `scale`; different textures on other primitives are
//!   ignored with one warning. Each primitive's base-colour factor (linear RGB) times its
//!   COLOR_0 (RGB of a VEC3 or VEC4 accessor, as glTF multiplies them) becomes its
//!   vertices' `albedo_tint`. Missing textures: 1×1 white albedo, 1×1 flat normal.
//!   Images are decoded to RGBA8, row 0 at the top (glTF's image origin). Only these two
//!   images are decoded.
//! - Camera: the first perspective camera met in the hierarchy (world position, forward
//!   −Z, up +Y, `yfov`, `znear`, `zfar` or [`DEFAULT_Z_FAR_SCALE`] × the scene size);
//!   else [`super::framing_camera`].
//!
//! URI policy: buffers and images come from the `.glb` BIN chunk, base64 `data:`
//! URIs, or relative paths (percent-decoded) that stay inside the glTF file's folder. An
//! absolute path, a `file:` URI, any other scheme (`http:` …) or a relative path that climbs
//! out of the folder (`../`) is refused with one error naming the URI: a scene file must not
//! make shvis open files elsewhere on the machine (`file:///etc/passwd`). Referenced files
//! must be regular files of at most [`MAX_REFERENCED_FILE_BYTES`]. Textures are checked
//! from their header (at most 16384 texels a side, and the memory available) before they
//! are decoded.
//!
//! Robustness (a file never panics the loader; `tests/scene_gltf.rs` and `fuzz/`): the
//! `gltf` crate parses and validates the JSON (index references, enums); this module reads
//! buffers, images and accessors itself with checked arithmetic, because the crate's own
//! readers assume valid offsets (and its URI decoder and `.glb` length handling can panic or
//! over-allocate on hostile input). Errors are [`SceneError::Gltf`], one line naming the
//! file. Skipped with one warning each and counted in [`LoadReport`]: degenerate triangles
//! (zero area), triangles with zero TEXCOORD_0 area (no tangent frame), primitives of other
//! modes (points, lines, strips, fans). Errors: malformed JSON or `.glb`, missing or short
//! buffers and images, out-of-range accessors, indices ≥ the vertex count, index counts not
//! a multiple of 3, non-finite attribute values, node cycles, no scene, no meshes, no usable
//! triangles, and charts that do not fit the lightmap.
//!
//! This file is the loader: the document, the node walk, each primitive read, transformed,
//! filtered and appended in named steps, the lightmap UVs, the material and the camera.
//! Beside it, `accessor` decodes accessors and buffer views (checked offsets and strides,
//! normalized and sparse values, index buffers) into a primitive's checked attributes and
//! indices, and `uri` holds the URI policy above and reads what it allows; `write` writes a
//! scene back as glTF (`shvis export`'s geometry).

mod accessor;
mod uri;
pub mod write;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Mat3, Mat4, Quat, Vec2, Vec3, Vec4};
use gltf::mesh::{Mode, Semantic};
use rustc_hash::FxHashMap;

use super::lightmap_uv;
use super::{Camera, Material, Mesh, Scene, SceneError, Texture8, Vertex, framing_camera, tangent};
use accessor::{PrimitiveData, read_primitive};
use uri::read_uri;

pub use uri::{MAX_REFERENCED_FILE_BYTES, percent_encode};

/// Triangles with |e₁ × e₂| ≤ this × |e₁|·|e₂| (sine of the corner angle) are degenerate.
/// Relative, so it is scale-free (Avocado is 6 cm); f32 positions resolve sines ~1e-7.
pub const DEGENERATE_SINE: f32 = 1e-7;
/// TEXCOORD_0 triangles with |Δuv₁ × Δuv₂| below this have no tangent frame (UV units; one
/// texel of an 8192² texture has area 1.5e-8).
pub const MIN_UV_AREA: f32 = 1e-12;
/// Lightmap UVs given in a file may stray this far outside [0, 1] (exporter rounding).
const LIGHTMAP_UV_SLACK: f32 = 1e-4;
/// Positions farther than this from the origin, metres, are refused (squared lengths and
/// areas must stay finite in f32).
pub const MAX_ABS_POSITION: f32 = 1e12;
/// Largest texture side accepted (the usual Vulkan `maxImageDimension2D`).
const MAX_TEXTURE_SIDE: u32 = 16384;
/// A camera without `zfar` sees this many scene diagonals far.
pub const DEFAULT_Z_FAR_SCALE: f32 = 100.0;
/// Flat normal-map texel (0, 0, 1).
const FLAT_NORMAL: [u8; 4] = [128, 128, 255, 255];

/// What loading did besides building the scene (the counts behind its warnings).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadReport {
    /// Triangles skipped because their 3D area is zero.
    pub degenerate_triangles: usize,
    /// Triangles skipped because their TEXCOORD_0 area is zero.
    pub zero_uv_area_triangles: usize,
    /// Primitives skipped because their mode is not TRIANGLES.
    pub skipped_primitives: usize,
    /// Whether TANGENTs were generated (MikkTSpace) for at least one primitive.
    pub generated_tangents: bool,
    /// Number of generated lightmap charts, `None` when TEXCOORD_1 was used as given.
    pub generated_charts: Option<usize>,
    /// Whether the camera came from the file (else it frames the bounds).
    pub camera_from_file: bool,
}

/// Loads a `.gltf` or `.glb` file with lightmap UVs for a `lightmap_res`² lightmap.
///
/// # Errors
/// [`SceneError::LightmapRes`] for a resolution outside
/// [`lightmap_uv::MIN_LIGHTMAP_RES`]..=[`lightmap_uv::MAX_LIGHTMAP_RES`]; [`SceneError::Gltf`] for anything wrong with
/// the file (module doc).
pub fn load(path: &Path, lightmap_res: u32) -> Result<Scene, SceneError> {
    load_with_report(path, lightmap_res).map(|(scene, _)| scene)
}

/// [`load`], also returning what was skipped or generated.
///
/// # Errors
/// As [`load`].
pub fn load_with_report(path: &Path, lightmap_res: u32) -> Result<(Scene, LoadReport), SceneError> {
    let file = path.display().to_string();
    lightmap_uv::check_res(lightmap_res)?;
    let bytes = crate::files::read_bounded(path, MAX_REFERENCED_FILE_BYTES, "a glTF file")
        .map_err(|e| {
            let detail = match e {
                crate::files::FileError::Io { cause, .. } => format!("cannot read: {cause}"),
                e => e.to_string().replacen(&format!("{file}: "), "", 1),
            };
            gltf_error(&file, detail)
        })?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| file.clone());
    Loader {
        file,
        base: Some(base),
    }
    .load(&name, &bytes, lightmap_res)
}

/// Every file a [`load`] of `path` reads: the file itself and the buffers and images it
/// references by relative URI (those the URI policy allows), for the checks that keep a
/// run's outputs off its inputs. A file that cannot be read or parsed gives itself alone
/// (its load then says what is wrong).
pub fn files_read(path: &Path) -> Vec<PathBuf> {
    let mut files = vec![path.to_path_buf()];
    let Some(json) = json_chunk(path) else {
        return files;
    };
    let Ok(document) = gltf::Gltf::from_slice_without_validation(&json) else {
        return files;
    };
    let base = path.parent().unwrap_or(Path::new(""));
    let buffers = document.buffers().filter_map(|b| match b.source() {
        gltf::buffer::Source::Uri(uri) => Some(uri),
        gltf::buffer::Source::Bin => None,
    });
    let images = document.images().filter_map(|i| match i.source() {
        gltf::image::Source::Uri { uri, .. } => Some(uri),
        gltf::image::Source::View { .. } => None,
    });
    for uri in buffers.chain(images) {
        if let Some(relative) = uri::relative_path(uri) {
            files.push(base.join(relative));
        }
    }
    files
}

/// The JSON of a `.gltf`, or the JSON chunk of a `.glb` (its binary chunk left unread), as
/// a document [`gltf::Gltf::from_slice_without_validation`] parses; `None` when unreadable.
fn json_chunk(path: &Path) -> Option<Vec<u8>> {
    use std::io::Read;
    // Only a regular file: opening a FIFO would wait for a writer (the loader refuses it).
    if !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return None;
    }
    let mut file = std::fs::File::open(path).ok()?;
    let mut header = [0u8; 20];
    let n = file.read(&mut header).ok()?;
    if header[..n.min(4)] == b"glTF"[..n.min(4)] {
        // A GLB (or the start of one): only a whole JSON chunk is parsed here, as text; a
        // malformed GLB is the loader's to report.
        if n < 20 || &header[16..20] != b"JSON" {
            return None;
        }
        let len = u32::from_le_bytes(header[12..16].try_into().ok()?) as u64;
        let mut json = Vec::new();
        file.take(len.min(MAX_REFERENCED_FILE_BYTES))
            .read_to_end(&mut json)
            .ok()?;
        // A chunk that itself starts like a GLB would be parsed as one (unchecked).
        return (json.len() as u64 == len && !json.starts_with(b"glTF")).then_some(json);
    }
    crate::files::read_bounded(path, MAX_REFERENCED_FILE_BYTES, "a glTF file").ok()
}

/// Loads a `.glb` or `.gltf` held in memory; only embedded data (the GLB BIN chunk, data
/// URIs) can be referenced. The entry point of the `gltf_scene` fuzz target.
///
/// # Errors
/// As [`load`]; external file references are errors.
pub fn load_from_slice(bytes: &[u8], lightmap_res: u32) -> Result<Scene, SceneError> {
    lightmap_uv::check_res(lightmap_res)?;
    Loader {
        file: "<memory>".to_string(),
        base: None,
    }
    .load("gltf", bytes, lightmap_res)
    .map(|(scene, _)| scene)
}

fn gltf_error(file: &str, message: impl Into<String>) -> SceneError {
    SceneError::Gltf {
        path: file.to_string(),
        message: message.into(),
    }
}

/// One mesh instance: the mesh and its node's world matrix.
struct Instance<'a> {
    mesh: gltf::Mesh<'a>,
    world_from_mesh: Mat4,
}

/// The textures chosen for the scene, by image index.
#[derive(Default)]
struct TextureChoice {
    albedo: Option<usize>,
    normal: Option<(usize, f32)>,
    ignored: Vec<String>,
}

struct Loader {
    /// The file's name for messages.
    file: String,
    /// Directory of relative URIs; `None` when loading from memory.
    base: Option<PathBuf>,
}

impl Loader {
    fn err(&self, message: impl Into<String>) -> SceneError {
        gltf_error(&self.file, message)
    }

    fn load(
        &self,
        name: &str,
        bytes: &[u8],
        lightmap_res: u32,
    ) -> Result<(Scene, LoadReport), SceneError> {
        let (document, blob) = self.parse(bytes)?;
        let buffers = self.buffers(&document, blob)?;
        let mut report = LoadReport::default();

        let scene = document
            .default_scene()
            .or_else(|| document.scenes().next())
            .ok_or_else(|| self.err("no scene to draw"))?;
        let (instances, camera_node) = self.walk(&document, &scene)?;
        if instances.is_empty() {
            return Err(self.err("the scene has no meshes"));
        }
        let mut uses: HashMap<usize, usize> = HashMap::new();
        for inst in &instances {
            *uses.entry(inst.mesh.index()).or_default() += 1;
        }

        let mut mesh = Mesh::default();
        let mut textures = TextureChoice::default();
        let all_have_uv1 =
            self.append_instances(&instances, &buffers, &mut mesh, &mut textures, &mut report)?;
        if report.degenerate_triangles + report.zero_uv_area_triangles > 0 {
            log::warn!(
                "{}: skipped {} degenerate and {} zero-UV-area triangle(s)",
                self.file,
                report.degenerate_triangles,
                report.zero_uv_area_triangles
            );
        }
        if mesh.indices.is_empty() {
            return Err(self.err(format!(
                "no usable triangles ({} degenerate, {} with zero UV area, {} primitive(s) not \
                 triangle lists)",
                report.degenerate_triangles,
                report.zero_uv_area_triangles,
                report.skipped_primitives
            )));
        }
        if !textures.ignored.is_empty() {
            log::warn!(
                "{}: shvis uses one albedo and one normal texture per scene; ignoring {}",
                self.file,
                textures.ignored.join(", ")
            );
        }

        let instanced_once = uses.values().all(|&n| n == 1);
        self.lightmap_uvs(
            &mut mesh,
            all_have_uv1,
            instanced_once,
            lightmap_res,
            &mut report,
        )?;
        let material = self.material(&document, &textures, &buffers)?;
        let bounds = mesh.bounds();
        let camera = self.camera(&document, camera_node, bounds, &mut report);
        Ok((
            Scene {
                name: name.to_string(),
                mesh,
                material,
                camera,
            },
            report,
        ))
    }

    /// The document in `bytes` and its `.glb` BIN chunk, validated.
    fn parse(&self, bytes: &[u8]) -> Result<(gltf::Document, Option<Vec<u8>>), SceneError> {
        let named_glb = self.file.to_ascii_lowercase().ends_with(".glb");
        check_glb_header(bytes, named_glb).map_err(|m| self.err(m))?;
        let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(bytes)
            .map_err(|e| self.err(crate::files::decoder_error("glTF", e)))?;
        // gltf-json's own validation indexes POSITION accessors unchecked: check them first.
        let json = document.into_json();
        for (m, mesh) in json.meshes.iter().enumerate() {
            for (p, prim) in mesh.primitives.iter().enumerate() {
                let position = gltf::json::validation::Checked::Valid(Semantic::Positions);
                if let Some(a) = prim.attributes.get(&position)
                    && a.value() >= json.accessors.len()
                {
                    return Err(self.err(format!(
                        "invalid glTF: meshes[{m}].primitives[{p}] POSITION refers to \
                         accessor {} of {}",
                        a.value(),
                        json.accessors.len()
                    )));
                }
            }
        }
        let document = gltf::Document::from_json(json).map_err(|e| match e {
            // Its message starts with "invalid glTF:" and lists every problem.
            gltf::Error::Validation(_) => self.err(e.to_string()),
            _ => self.err(crate::files::decoder_error("glTF", e)),
        })?;
        Ok((document, blob))
    }

    /// Appends every triangle-list primitive of the `instances` to `mesh` and records their
    /// textures; primitives of other modes are skipped (one warning for all). Returns
    /// whether every appended primitive has TEXCOORD_1.
    fn append_instances(
        &self,
        instances: &[Instance],
        buffers: &[Vec<u8>],
        mesh: &mut Mesh,
        textures: &mut TextureChoice,
        report: &mut LoadReport,
    ) -> Result<bool, SceneError> {
        // Every instance's corners become vertices of one mesh with u32 indices: the total is
        // bounded before any is read (a small file can instance a large mesh many times).
        let triangle_lists = || {
            instances
                .iter()
                .flat_map(|inst| inst.mesh.primitives())
                .filter(|prim| prim.mode() == Mode::Triangles)
        };
        let count = |acc: Option<gltf::Accessor>| acc.map_or(0, |a| a.count() as u64);
        let corners = triangle_lists()
            .map(|prim| count(prim.indices().or_else(|| prim.get(&Semantic::Positions))))
            .fold(0u64, u64::saturating_add);
        // Corners share their primitive's vertices (a vertex splits only where its
        // tangents differ, which no file relies on for its size).
        let vertices = triangle_lists()
            .map(|prim| count(prim.get(&Semantic::Positions)))
            .fold(0u64, u64::saturating_add);
        if corners > u64::from(u32::MAX) {
            return Err(self.err(format!(
                "the scene's instances hold {corners} triangle corners, more than the {} one mesh indexes",
                u32::MAX
            )));
        }
        let (per_vertex, per_corner) = (
            std::mem::size_of::<Vertex>() as u64,
            std::mem::size_of::<u32>() as u64,
        );
        crate::limits::check_memory(
            format_args!("its instances' {vertices} vertices and {corners} triangle corners"),
            vertices
                .saturating_mul(per_vertex)
                .saturating_add(corners.saturating_mul(per_corner)),
            "",
        )
        .map_err(|e| self.err(e.to_string()))?;
        let mut all_have_uv1 = true;
        let mut modes_skipped: Vec<String> = Vec::new();
        for inst in instances {
            for prim in inst.mesh.primitives() {
                let what = format!("mesh {} primitive {}", inst.mesh.index(), prim.index());
                if prim.mode() != Mode::Triangles {
                    report.skipped_primitives += 1;
                    modes_skipped.push(format!("{what} ({:?})", prim.mode()));
                    continue;
                }
                all_have_uv1 &= prim.get(&Semantic::TexCoords(1)).is_some();
                self.choose_textures(&prim, textures);
                self.append_primitive(&what, &prim, inst, buffers, mesh, report)?;
            }
        }
        if !modes_skipped.is_empty() {
            log::warn!(
                "{}: skipped {} primitive(s) that are not triangle lists: {}",
                self.file,
                modes_skipped.len(),
                modes_skipped.join(", ")
            );
        }
        Ok(all_have_uv1)
    }

    /// The lightmap UVs: TEXCOORD_1 as given (clamped to [0, 1]) where every primitive has
    /// it (`all_have_uv1`), within [0, 1] up to exporter rounding, and no mesh is drawn
    /// twice (`instanced_once`); else charts generated for the whole scene (counted in
    /// `report`, with a warning where TEXCOORD_1 was there but unusable).
    fn lightmap_uvs(
        &self,
        mesh: &mut Mesh,
        all_have_uv1: bool,
        instanced_once: bool,
        lightmap_res: u32,
        report: &mut LoadReport,
    ) -> Result<(), SceneError> {
        let given_ok = all_have_uv1
            && instanced_once
            && mesh.vertices.iter().all(|v| {
                v.uv_lightmap
                    .iter()
                    .all(|&c| (-LIGHTMAP_UV_SLACK..=1.0 + LIGHTMAP_UV_SLACK).contains(&c))
            });
        if given_ok {
            for v in &mut mesh.vertices {
                v.uv_lightmap = v.uv_lightmap.map(|c| c.clamp(0.0, 1.0));
            }
        } else {
            if all_have_uv1 {
                log::warn!(
                    "{}: TEXCOORD_1 is outside [0, 1] or shared by instanced meshes; \
                     generating lightmap UVs",
                    self.file
                );
            }
            let charting = std::time::Instant::now();
            let charts = lightmap_uv::generate(mesh, lightmap_res).map_err(|e| {
                self.err(format!(
                    "{} lightmap charts do not fit a {lightmap_res}² lightmap; raise --vis-res",
                    e.charts
                ))
            })?;
            log::debug!(
                "{}: {} lightmap charts generated in {:.3} s",
                self.file,
                charts.charts,
                charting.elapsed().as_secs_f64()
            );
            report.generated_charts = Some(charts.charts);
        }
        Ok(())
    }

    /// The scene's material: the chosen textures decoded, else a white albedo and a flat
    /// normal map.
    fn material(
        &self,
        document: &gltf::Document,
        textures: &TextureChoice,
        buffers: &[Vec<u8>],
    ) -> Result<Material, SceneError> {
        Ok(Material {
            albedo: match textures.albedo {
                Some(i) => self.texture(document, i, buffers)?,
                None => Texture8::solid([255; 4]),
            },
            normal: match textures.normal {
                Some((i, _)) => self.texture(document, i, buffers)?,
                None => Texture8::solid(FLAT_NORMAL),
            },
            normal_scale: textures.normal.map_or(1.0, |(_, s)| s),
            height: None,
        })
    }

    /// The camera of `camera_node` (the first perspective camera met: its index and world
    /// matrix) where it is usable, else one that frames `bounds` (with a warning where the
    /// file's is unusable).
    fn camera(
        &self,
        document: &gltf::Document,
        camera_node: Option<(usize, Mat4)>,
        bounds: (Vec3, Vec3),
        report: &mut LoadReport,
    ) -> Camera {
        match camera_node.map(|(cam, world)| (cam, file_camera(document, cam, world, bounds))) {
            Some((_, Ok(camera))) => {
                report.camera_from_file = true;
                camera
            }
            Some((index, Err(why))) => {
                log::warn!(
                    "{}: camera {index} is unusable ({why}); rendering from a camera that frames the scene instead",
                    self.file
                );
                framing_camera(bounds)
            }
            None => framing_camera(bounds),
        }
    }

    /// Loads every buffer: the GLB BIN chunk, data URIs, or files next to the glTF.
    fn buffers(
        &self,
        document: &gltf::Document,
        mut blob: Option<Vec<u8>>,
    ) -> Result<Vec<Vec<u8>>, SceneError> {
        // The buffers' declared lengths, all held at once (a buffer shorter than its length
        // is refused below, so this bounds what is read).
        let declared = document
            .buffers()
            .map(|b| b.length() as u64)
            .fold(0u64, u64::saturating_add);
        crate::limits::check_memory(format_args!("its buffers' {declared} bytes"), declared, "")
            .map_err(|e| self.err(e.to_string()))?;
        let mut out = Vec::new();
        for buffer in document.buffers() {
            let data = match buffer.source() {
                gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                    self.err(format!(
                        "buffer {} refers to a GLB BIN chunk that is missing",
                        buffer.index()
                    ))
                })?,
                gltf::buffer::Source::Uri(uri) => read_uri(self.base.as_deref(), uri)
                    .map_err(|m| self.err(format!("buffer {}: {m}", buffer.index())))?,
            };
            if data.len() < buffer.length() {
                return Err(self.err(format!(
                    "buffer {} holds {} bytes but byteLength is {}",
                    buffer.index(),
                    data.len(),
                    buffer.length()
                )));
            }
            // Bytes past byteLength belong to no view: not kept.
            let mut data = data;
            data.truncate(buffer.length());
            data.shrink_to_fit();
            out.push(data);
        }
        Ok(out)
    }

    /// Mesh instances (depth-first, in child order) and the first perspective camera node.
    #[allow(clippy::type_complexity)]
    fn walk<'a>(
        &self,
        document: &'a gltf::Document,
        scene: &gltf::Scene<'a>,
    ) -> Result<(Vec<Instance<'a>>, Option<(usize, Mat4)>), SceneError> {
        let mut visited = vec![false; document.nodes().count()];
        let mut instances = Vec::new();
        let mut camera = None;
        let mut stack: Vec<(gltf::Node<'a>, Mat4)> =
            scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
        stack.reverse();
        while let Some((node, parent)) = stack.pop() {
            let seen = visited
                .get_mut(node.index())
                .ok_or_else(|| self.err("bad node"))?;
            if *seen {
                return Err(self.err(format!(
                    "node {} is reached twice (a cycle or a shared child)",
                    node.index()
                )));
            }
            *seen = true;
            let world = parent * local_matrix(&node);
            if let Some(mesh) = node.mesh() {
                instances.push(Instance {
                    mesh,
                    world_from_mesh: world,
                });
            }
            if let Some(cam) = node.camera() {
                let perspective = document
                    .as_json()
                    .cameras
                    .get(cam.index())
                    .is_some_and(|c| c.perspective.is_some());
                if camera.is_none() && perspective {
                    camera = Some((cam.index(), world));
                }
            }
            let children: Vec<_> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|c| (c, world)));
        }
        Ok((instances, camera))
    }

    /// Records the primitive's textures, or notes them as ignored when others were chosen.
    fn choose_textures(&self, prim: &gltf::Primitive, choice: &mut TextureChoice) {
        let material = prim.material();
        if let Some(info) = material.pbr_metallic_roughness().base_color_texture() {
            let image = info.texture().source().index();
            match choice.albedo {
                None => choice.albedo = Some(image),
                Some(i) if i != image => {
                    choice.ignored.push(format!("base-colour image {image}"));
                }
                Some(_) => {}
            }
        }
        if let Some(normal) = material.normal_texture() {
            let image = normal.texture().source().index();
            match choice.normal {
                None => choice.normal = Some((image, normal.scale())),
                Some((i, _)) if i != image => {
                    choice.ignored.push(format!("normal image {image}"));
                }
                Some(_) => {}
            }
        }
        choice.ignored.dedup();
    }

    /// Reads, transforms, filters and appends one triangle-list primitive.
    fn append_primitive(
        &self,
        what: &str,
        prim: &gltf::Primitive,
        inst: &Instance,
        buffers: &[Vec<u8>],
        mesh: &mut Mesh,
        report: &mut LoadReport,
    ) -> Result<(), SceneError> {
        let err = |m: String| self.err(format!("{what}: {m}"));
        let PrimitiveData {
            positions,
            count,
            normals,
            tangents,
            uv0,
            uv1,
            colors,
            indices,
        } = read_primitive(prim, buffers).map_err(err)?;

        // World space.
        let m = inst.world_from_mesh;
        let linear = Mat3::from_mat4(m);
        let mirrored = linear.determinant() < 0.0;
        let normal_from_mesh = linear.inverse().transpose();
        let p = world_positions(m, &positions).map_err(err)?;
        let uv = |values: &Option<Vec<f32>>| -> Vec<Vec2> {
            match values {
                Some(v) => v.chunks_exact(2).map(Vec2::from_slice).collect(),
                None => vec![Vec2::ZERO; count],
            }
        };
        let (uv0_v, uv1_v) = (uv(&uv0), uv(&uv1));

        let kept = keep_triangles(
            &indices,
            &p,
            uv0.is_some().then_some(uv0_v.as_slice()),
            mirrored,
            report,
        );
        if kept.is_empty() {
            return Ok(());
        }
        let n = vertex_normals(count, &kept, &p, normals.as_deref(), normal_from_mesh);

        // Tangents per corner: given (upper 3×3, w mirrored), else MikkTSpace.
        let flat: Vec<u32> = kept.iter().flatten().copied().collect();
        let corner_tangents: Vec<Vec4> = match &tangents {
            Some(t) => given_tangents(&flat, t, linear, mirrored, &n),
            None => {
                report.generated_tangents = true;
                if uv0.is_some() {
                    tangent::generate(&p, &n, &uv0_v, &flat)
                } else {
                    flat.iter()
                        .map(|&i| tangent::fallback_tangent(n[i as usize]))
                        .collect()
                }
            }
        };

        let material = prim
            .material()
            .index()
            .map_or_else(|| "(the default)".to_string(), |i| i.to_string());
        let factor = prim.material().pbr_metallic_roughness().base_color_factor();
        // A fraction of the light reflected, per channel (glTF 2.0 §5.22).
        if !factor.iter().all(|x| (0.0..=1.0).contains(x)) {
            return Err(err(format!(
                "material {material}: baseColorFactor {factor:?} has a value outside [0, 1]"
            )));
        }
        let tint = |k: usize| -> [f32; 3] {
            let c = colors
                .as_ref()
                .map_or([1.0; 3], |c| [c[3 * k], c[3 * k + 1], c[3 * k + 2]]);
            [factor[0] * c[0], factor[1] * c[1], factor[2] * c[2]]
        };
        let vertex = |k: usize, t: Vec4| Vertex {
            position: p[k].to_array(),
            normal: n[k].to_array(),
            tangent: t.to_array(),
            uv_material: uv0_v[k].to_array(),
            uv_lightmap: uv1_v[k].to_array(),
            albedo_tint: tint(k),
        };
        append_corners(mesh, p.len(), &flat, &corner_tangents, vertex);
        Ok(())
    }

    /// Decodes image `index` to RGBA8.
    fn texture(
        &self,
        document: &gltf::Document,
        index: usize,
        buffers: &[Vec<u8>],
    ) -> Result<Texture8, SceneError> {
        let err = |m: String| self.err(format!("image {index}: {m}"));
        let image = document
            .images()
            .nth(index)
            .ok_or_else(|| err("missing".into()))?;
        let bytes: Vec<u8> = match image.source() {
            gltf::image::Source::Uri { uri, .. } => {
                read_uri(self.base.as_deref(), uri).map_err(err)?
            }
            gltf::image::Source::View { view, .. } => {
                let data = buffers
                    .get(view.buffer().index())
                    .ok_or_else(|| err("bad buffer".into()))?;
                view.offset()
                    .checked_add(view.length())
                    .and_then(|end| data.get(view.offset()..end))
                    .ok_or_else(|| err("buffer view runs past its buffer".into()))?
                    .to_vec()
            }
        };
        let decoded = decode_texture(&bytes).map_err(err)?;
        let (width, height) = decoded.dimensions();
        Ok(Texture8 {
            width,
            height,
            texels: decoded
                .into_raw()
                .chunks_exact(4)
                .map(|c| [c[0], c[1], c[2], c[3]])
                .collect(),
        })
    }
}

/// `positions` (flat xyz) by the world matrix, checked finite and within
/// [`MAX_ABS_POSITION`] of the origin.
fn world_positions(world_from_mesh: Mat4, positions: &[f32]) -> Result<Vec<Vec3>, String> {
    let p: Vec<Vec3> = positions
        .chunks_exact(3)
        .map(|c| world_from_mesh.transform_point3(Vec3::from_slice(c)))
        .collect();
    if p.iter().any(|v| !v.is_finite()) {
        return Err("the node transform gives non-finite positions".into());
    }
    if p.iter().any(|v| v.abs().max_element() > MAX_ABS_POSITION) {
        return Err(format!("positions reach beyond ±{MAX_ABS_POSITION:e} m"));
    }
    Ok(p)
}

/// The triangles of `indices` to keep, wound counter-clockwise in world space (their
/// corners swapped where the transform is `mirrored`): those of zero area, and where the
/// primitive has TEXCOORD_0 (`uv0`) those of zero UV area, are skipped and counted in
/// `report`.
fn keep_triangles(
    indices: &[u32],
    p: &[Vec3],
    uv0: Option<&[Vec2]>,
    mirrored: bool,
    report: &mut LoadReport,
) -> Vec<[u32; 3]> {
    let mut kept: Vec<[u32; 3]> = Vec::with_capacity(indices.len() / 3);
    for t in indices.chunks_exact(3) {
        let tri = if mirrored {
            [t[0], t[2], t[1]]
        } else {
            [t[0], t[1], t[2]]
        };
        let [a, b, c] = tri.map(|i| p[i as usize]);
        let (e1, e2) = (b - a, c - a);
        let scale = e1.length() * e2.length();
        // Written so that NaN-free zero areas and zero-length edges both count.
        let area_ok = e1.cross(e2).length() > DEGENERATE_SINE * scale;
        if !area_ok || scale == 0.0 {
            report.degenerate_triangles += 1;
            continue;
        }
        if let Some(uv0) = uv0 {
            let [ua, ub, uc] = tri.map(|i| uv0[i as usize]);
            if (ub - ua).perp_dot(uc - ua).abs() < MIN_UV_AREA {
                report.zero_uv_area_triangles += 1;
                continue;
            }
        }
        kept.push(tri);
    }
    kept
}

/// World-space normals of the `count` vertices: given ones (flat xyz) by
/// `normal_from_mesh` (the inverse-transpose), else area-weighted smooth over the `kept`
/// triangles, else +Y.
fn vertex_normals(
    count: usize,
    kept: &[[u32; 3]],
    p: &[Vec3],
    normals: Option<&[f32]>,
    normal_from_mesh: Mat3,
) -> Vec<Vec3> {
    let mut smooth = vec![Vec3::ZERO; count];
    for tri in kept {
        let [a, b, c] = tri.map(|i| p[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in tri {
            smooth[i as usize] += n;
        }
    }
    (0..count)
        .map(|i| {
            let given = normals
                .and_then(|v| (normal_from_mesh * Vec3::from_slice(&v[3 * i..])).try_normalize());
            given
                .or_else(|| smooth[i].try_normalize())
                .unwrap_or(Vec3::Y)
        })
        .collect()
}

/// The given tangents (flat xyzw) of the corners `flat`: xyz by the upper 3×3 `linear`, w
/// negated where the transform is `mirrored`, made perpendicular to the normal `n`.
fn given_tangents(flat: &[u32], t: &[f32], linear: Mat3, mirrored: bool, n: &[Vec3]) -> Vec<Vec4> {
    flat.iter()
        .map(|&i| {
            let i = i as usize;
            let given = Vec4::from_slice(&t[4 * i..]);
            let w = if (given.w < 0.0) != mirrored {
                -1.0
            } else {
                1.0
            };
            tangent::orthonormalize(n[i], (linear * given.truncate()).extend(w))
        })
        .collect()
}

/// Appends the corners `flat` (indices among the primitive's `vertex_count` vertices) with
/// their tangents to `mesh`, splitting a vertex only where its corners' tangents differ;
/// `vertex(k, t)` is vertex k with tangent t.
fn append_corners(
    mesh: &mut Mesh,
    vertex_count: usize,
    flat: &[u32],
    corner_tangents: &[Vec4],
    vertex: impl Fn(usize, Vec4) -> Vertex,
) {
    // A vertex's first tangent's index kept per vertex (most have one); the others
    // in a map.
    let mut first_tangent: Vec<Option<([u32; 4], u32)>> = vec![None; vertex_count];
    let mut remap: FxHashMap<(u32, [u32; 4]), u32> = FxHashMap::default();
    for (&i, t) in flat.iter().zip(corner_tangents) {
        let bits = t.to_array().map(f32::to_bits);
        let first = first_tangent[i as usize];
        if let Some((first_bits, index)) = first
            && first_bits == bits
        {
            mesh.indices.push(index);
            continue;
        }
        let mut new_vertex = || {
            mesh.vertices.push(vertex(i as usize, *t));
            (mesh.vertices.len() - 1) as u32
        };
        let index = match first {
            None => {
                let index = new_vertex();
                first_tangent[i as usize] = Some((bits, index));
                index
            }
            Some(_) => *remap.entry((i, bits)).or_insert_with(new_vertex),
        };
        mesh.indices.push(index);
    }
}

/// Decodes a texture to RGBA8 after checking its header's size against
/// [`MAX_TEXTURE_SIDE`] and the memory available; the decoder's own allocation limit is set
/// to what that size needs (its default 512 MiB would refuse a 16384² texture).
fn decode_texture(bytes: &[u8]) -> Result<image::RgbaImage, String> {
    let reader = || {
        image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| format!("cannot read: {e}"))
    };
    let (width, height) = reader()?
        .into_dimensions()
        .map_err(|e| format!("cannot decode: {e}"))?;
    if width == 0 || height == 0 || width.max(height) > MAX_TEXTURE_SIDE {
        return Err(format!(
            "{width}×{height} is outside 1..={MAX_TEXTURE_SIDE} texels per side"
        ));
    }
    // The decoded image (up to 16 bytes a texel for 32-bit float formats) and its RGBA8 copy.
    let need = crate::limits::image_bytes(u64::from(width), u64::from(height), 20);
    crate::limits::check_memory(
        format_args!("decoding its {width}×{height} texels"),
        need,
        "",
    )
    .map_err(|e| e.to_string())?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(need);
    let mut r = reader()?;
    r.limits(limits);
    Ok(r.decode()
        .map_err(|e| format!("cannot decode: {e}"))?
        .to_rgba8())
}

/// What is wrong with a binary glTF's framing, before the parser reads it: a file named
/// `.glb` that does not start with `glTF`, a header length below the header's or past the
/// file's end, a chunk that runs past the end. Text glTF (`named_glb` false, no magic)
/// passes through.
fn check_glb_header(bytes: &[u8], named_glb: bool) -> Result<(), String> {
    const HEADER: usize = 12;
    if !bytes.starts_with(b"glTF") {
        if named_glb {
            let start: String = bytes
                .iter()
                .take(4)
                .map(|&b| std::ascii::escape_default(b).to_string())
                .collect();
            return Err(format!(
                "not a binary glTF: a .glb starts with 'glTF', this file with '{start}'"
            ));
        }
        return Ok(());
    }
    let u32_at = |at: usize| {
        bytes
            .get(at..at + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let length = u32_at(8).ok_or_else(|| {
        format!(
            "truncated .glb: {} bytes, less than its 12-byte header",
            bytes.len()
        )
    })?;
    if length < HEADER {
        return Err(format!(".glb header length {length} is below 12"));
    }
    if length > bytes.len() {
        return Err(format!(
            "truncated .glb: its header gives {length} bytes, the file holds {}",
            bytes.len()
        ));
    }
    let mut at = HEADER;
    while let Some(chunk) = u32_at(at) {
        if at + 8 + chunk > bytes.len() {
            let kind: String = bytes[at + 4..(at + 8).min(bytes.len())]
                .iter()
                .filter(|b| b.is_ascii_alphanumeric())
                .map(|&b| b as char)
                .collect();
            return Err(format!(
                "truncated .glb: its {kind} chunk of {chunk} bytes runs past the file's end ({} bytes)",
                bytes.len()
            ));
        }
        at += 8 + chunk;
    }
    Ok(())
}

/// The node's local matrix (TRS with the rotation renormalized, or the matrix).
fn local_matrix(node: &gltf::Node) -> Mat4 {
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => Mat4::from_cols_array_2d(&matrix),
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let q = Quat::from_array(rotation);
            let q = if q.length_squared() > 0.0 && q.is_finite() {
                q.normalize()
            } else {
                Quat::IDENTITY
            };
            Mat4::from_scale_rotation_translation(Vec3::from(scale), q, Vec3::from(translation))
        }
    }
}

/// The camera of node matrix `world` (perspective checked by the caller), or what makes its
/// transform or projection unusable.
fn file_camera(
    document: &gltf::Document,
    index: usize,
    world: Mat4,
    bounds: (Vec3, Vec3),
) -> Result<Camera, String> {
    let p = document
        .as_json()
        .cameras
        .get(index)
        .and_then(|c| c.perspective.as_ref())
        .ok_or("not a perspective camera")?;
    let position = world.transform_point3(Vec3::ZERO);
    let forward = world
        .transform_vector3(Vec3::NEG_Z)
        .try_normalize()
        .ok_or("its node's transform collapses the view direction")?;
    let up = world
        .transform_vector3(Vec3::Y)
        .try_normalize()
        .ok_or("its node's transform collapses the up direction")?;
    let size = (bounds.1 - bounds.0).length().max(f32::MIN_POSITIVE);
    let z_far = p
        .zfar
        .filter(|&f| f.is_finite() && f > p.znear)
        .unwrap_or(DEFAULT_Z_FAR_SCALE * size);
    if !position.is_finite() || forward.cross(up).length() <= DEGENERATE_SINE {
        return Err("its node's transform is degenerate".into());
    }
    if !(p.yfov > 0.0 && p.yfov < std::f32::consts::PI) {
        return Err(format!("yfov {} is outside (0, π)", p.yfov));
    }
    if !(p.znear > 0.0 && z_far > p.znear) {
        return Err(format!("znear {} must be > 0 and below zfar", p.znear));
    }
    Ok(Camera {
        position,
        target: position + forward,
        up,
        fov_y: p.yfov,
        z_near: p.znear,
        z_far,
    })
}
