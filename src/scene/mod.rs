//! Scenes: triangle meshes with material and lightmap UVs, a material (albedo and
//! tangent-space normal map), and a camera (DESIGN §1: right-handed, +Y up, metres).
//!
//! `house` builds the procedural default scene, `gltf` loads glTF 2.0 files; `tangent`
//! (MikkTSpace frames) and `lightmap_uv` (chart packing, generated lightmap UVs) serve both.
//! The vertex layout here is the one the GPU reads (`glsl/scene/mesh.vert`), so it is
//! `#[repr(C)]` + `Pod`.

pub mod bumpy;
pub mod displace;
pub mod gltf;
pub mod height_field;
pub mod house;
pub mod lightmap_uv;
pub mod mip;
pub mod patio;
pub mod subdivide;
pub mod tangent;
pub mod wavy;

pub use height_field::HeightField;

use glam::{Mat4, Vec3, Vec4};

/// One mesh vertex, as uploaded to the GPU (68 bytes, tightly packed f32).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Vertex {
    /// World-space position, metres.
    pub position: [f32; 3],
    /// World-space shading normal (unit).
    pub normal: [f32; 3],
    /// World-space tangent (unit, along +u of `uv_material`); `w` = ±1 so that the
    /// bitangent is `w · cross(normal, tangent)` and points toward decreasing v (DESIGN §1).
    pub tangent: [f32; 4],
    /// Material texture coordinates (glTF TEXCOORD_0; tiling, origin top-left).
    pub uv_material: [f32; 2],
    /// Unique lightmap coordinates in [0, 1]² (glTF TEXCOORD_1; texel centres at (i+½)/res).
    pub uv_lightmap: [f32; 2],
    /// Linear RGB factor multiplied into the albedo texture.
    pub albedo_tint: [f32; 3],
}

/// An indexed triangle list.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub vertices: Vec<Vertex>,
    pub indices: Vec<u32>,
}

impl Mesh {
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// World-space corner positions of triangle `t`.
    pub fn triangle_positions(&self, t: usize) -> [Vec3; 3] {
        let i = &self.indices[3 * t..3 * t + 3];
        [0, 1, 2].map(|k| Vec3::from(self.vertices[i[k] as usize].position))
    }

    /// Axis-aligned bounds (min, max) of all vertices.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.vertices.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), v| {
                let p = Vec3::from(v.position);
                (lo.min(p), hi.max(p))
            },
        )
    }
}

/// The tangent-space normal of a normal-map texel as `common.glsl::tangent_space_normal`
/// decodes it (x, y scaled by `scale`, unit; flat for a zero vector).
pub fn decode_normal(texel: [u8; 4], scale: f32) -> Vec3 {
    let c = |v: u8| f32::from(v) / 255.0 * 2.0 - 1.0;
    let m = Vec3::new(c(texel[0]) * scale, c(texel[1]) * scale, c(texel[2]));
    m.try_normalize().unwrap_or(Vec3::Z)
}

/// An RGBA8 texture in row-major order, row 0 at the top (v = 0).
#[derive(Clone, Debug)]
pub struct Texture8 {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[u8; 4]>,
}

impl Texture8 {
    /// A 1×1 texture of `texel` (white albedo, flat normal map).
    pub fn solid(texel: [u8; 4]) -> Self {
        Texture8 {
            width: 1,
            height: 1,
            texels: vec![texel],
        }
    }

    /// A unit tangent-space normal as an RGBA8 normal-map texel (glTF convention: c ↦
    /// (c + 1)/2 rounded to the nearest 8-bit code; [`decode_normal`] inverts it).
    pub fn encode_normal(n: Vec3) -> [u8; 4] {
        let e = |c: f32| ((c * 0.5 + 0.5) * 255.0).round() as u8;
        [e(n.x), e(n.y), e(n.z), 255]
    }
}

/// The surface material shared by the whole mesh (per-vertex `albedo_tint` varies it).
#[derive(Clone, Debug)]
pub struct Material {
    /// sRGB-encoded base colour, tiled by `uv_material`.
    pub albedo: Texture8,
    /// Tangent-space normal map, glTF convention (+Y green = image up), tiled by `uv_material`.
    pub normal: Texture8,
    /// glTF `normalTexture.scale`: scales the map's x and y before renormalizing.
    pub normal_scale: f32,
    /// Height field of the surface the normal map describes, tiled like it (heights in
    /// texels of its own grid): what `ssbump`/`rnmao` shadow with and what
    /// [`displace`] builds the micro-geometry from. The house's bricks have
    /// one; a glTF scene takes one from `--height-map`.
    pub height: Option<HeightField>,
}

/// A pinhole camera (right-handed, looking down −Z in view space).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    pub z_near: f32,
    pub z_far: f32,
}

impl Camera {
    /// Right-handed view matrix: the camera looks down −Z, +Y up.
    pub fn view_from_world(&self) -> Mat4 {
        let f = (self.target - self.position).normalize();
        let s = f.cross(self.up).normalize();
        let u = s.cross(f);
        Mat4::from_cols(
            Vec4::new(s.x, u.x, -f.x, 0.0),
            Vec4::new(s.y, u.y, -f.y, 0.0),
            Vec4::new(s.z, u.z, -f.z, 0.0),
            Vec4::new(
                -s.dot(self.position),
                -u.dot(self.position),
                f.dot(self.position),
                1.0,
            ),
        )
    }

    /// Vulkan clip space: x right, y *down*, depth in [0, 1] (near → 0).
    pub fn clip_from_view(&self, aspect: f32) -> Mat4 {
        let h = 1.0 / (0.5 * self.fov_y).tan();
        let r = self.z_far / (self.z_near - self.z_far);
        Mat4::from_cols(
            Vec4::new(h / aspect, 0.0, 0.0, 0.0),
            Vec4::new(0.0, -h, 0.0, 0.0),
            Vec4::new(0.0, 0.0, r, -1.0),
            Vec4::new(0.0, 0.0, r * self.z_near, 0.0),
        )
    }

    pub fn clip_from_world(&self, aspect: f32) -> Mat4 {
        self.clip_from_view(aspect) * self.view_from_world()
    }

    /// Pixel coordinates (x right, y down, pixel centres at +0.5) of a world point, or
    /// `None` when it is behind the camera.
    pub fn project_to_pixel(&self, p_world: Vec3, width: u32, height: u32) -> Option<(f32, f32)> {
        let clip = self.clip_from_world(width as f32 / height as f32) * p_world.extend(1.0);
        if clip.w <= 0.0 {
            return None;
        }
        let ndc = clip.truncate() / clip.w;
        Some((
            (ndc.x * 0.5 + 0.5) * width as f32,
            (ndc.y * 0.5 + 0.5) * height as f32,
        ))
    }
}

impl Scene {
    /// `mesh` in white with a flat normal map, seen from the origin down −Z with a 90°
    /// vertical field of view (at z = −1 the view spans y ∈ ±1, x ∈ ±aspect): the device
    /// probe's screen-filling grids.
    pub fn flat_view(name: &str, mesh: Mesh) -> Scene {
        Scene {
            name: name.into(),
            mesh,
            material: Material {
                albedo: Texture8::solid([255; 4]),
                normal: Texture8::solid([128, 128, 255, 255]),
                normal_scale: 1.0,
                height: None,
            },
            camera: Camera {
                position: Vec3::ZERO,
                target: Vec3::NEG_Z,
                up: Vec3::Y,
                fov_y: 90f32.to_radians(),
                z_near: 0.1,
                z_far: 10.0,
            },
        }
    }

    /// The screen area of the triangle under an average shaded fragment, pixels: Σ a_i² /
    /// Σ a_i over the triangles' areas a_i on a `width` × `height` screen after clipping to
    /// the view (occlusion ignored, as every drawn fragment is shaded). What the device probe
    /// sizes its triangles by: a rasterizer works in blocks, and small triangles leave more
    /// of each block's lanes idle (`crate::probe`).
    pub fn pixel_weighted_triangle_area(&self, width: u32, height: u32) -> f64 {
        let clip_from_world = self.camera.clip_from_world(width as f32 / height as f32);
        let (mut sum, mut sum_sq) = (0.0f64, 0.0f64);
        for t in screen_triangles(&self.mesh, clip_from_world, width, height) {
            sum += t.area;
            sum_sq += t.area * t.area;
        }
        if sum > 0.0 { sum_sq / sum } else { 0.0 }
    }
}

/// A triangle's screen footprint after clipping to the view, pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenTriangle {
    pub area: f64,
    /// The clipped polygon's perimeter (edges along the view's border included).
    pub perimeter: f64,
}

/// The triangles of `mesh` as `clip_from_world` puts them on a `width` × `height` screen,
/// each clipped to the view (occlusion ignored; empty polygons left out).
pub fn screen_triangles(
    mesh: &Mesh,
    clip_from_world: glam::Mat4,
    width: u32,
    height: u32,
) -> impl Iterator<Item = ScreenTriangle> + '_ {
    let clip: Vec<Vec4> = mesh
        .vertices
        .iter()
        .map(|v| clip_from_world * Vec3::from(v.position).extend(1.0))
        .collect();
    mesh.indices.chunks_exact(3).filter_map(move |tri| {
        let polygon = clip_to_view(tri.iter().map(|&i| clip[i as usize]).collect());
        if polygon.len() < 3 {
            return None;
        }
        let pixels: Vec<(f64, f64)> = polygon
            .iter()
            .map(|c| {
                (
                    f64::from(c.x / c.w) * 0.5 * f64::from(width),
                    f64::from(c.y / c.w) * 0.5 * f64::from(height),
                )
            })
            .collect();
        let edges = (0..pixels.len()).map(|k| (pixels[k], pixels[(k + 1) % pixels.len()]));
        let twice: f64 = edges.clone().map(|(a, b)| a.0 * b.1 - b.0 * a.1).sum();
        let perimeter = edges.map(|(a, b)| (b.0 - a.0).hypot(b.1 - a.1)).sum();
        Some(ScreenTriangle {
            area: 0.5 * twice.abs(),
            perimeter,
        })
    })
}

/// Sutherland–Hodgman clipping of a clip-space polygon to the view volume's side and near
/// planes (w ± x ≥ 0, w ± y ≥ 0, z ≥ 0).
fn clip_to_view(mut polygon: Vec<Vec4>) -> Vec<Vec4> {
    let planes: [fn(Vec4) -> f32; 5] = [
        |c| c.w + c.x,
        |c| c.w - c.x,
        |c| c.w + c.y,
        |c| c.w - c.y,
        |c| c.z,
    ];
    for distance in planes {
        let mut out = Vec::with_capacity(polygon.len() + 1);
        for k in 0..polygon.len() {
            let (a, b) = (polygon[k], polygon[(k + 1) % polygon.len()]);
            let (da, db) = (distance(a), distance(b));
            if da >= 0.0 {
                out.push(a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                out.push(a + (b - a) * (da / (da - db)));
            }
        }
        polygon = out;
        if polygon.is_empty() {
            break;
        }
    }
    polygon
}

/// Vertical field of view of [`framing_camera`], degrees.
pub const FRAMING_FOV_Y_DEG: f32 = 50.0;

/// A camera for a scene that brings none: it looks at the centre of `bounds` (min, max)
/// from the front-right diagonal (+X, +Z), elevated by about 25°, far enough that the
/// bounding sphere fills the 50° vertical field of view; near and far planes bracket the
/// sphere. Works at any scale (centimetre models included) and for empty or flat bounds.
pub fn framing_camera(bounds: (Vec3, Vec3)) -> Camera {
    let (lo, hi) = bounds;
    let (centre, radius) = if lo.is_finite() && hi.is_finite() && lo.cmple(hi).all() {
        (0.5 * (lo + hi), (0.5 * (hi - lo).length()).max(1e-6))
    } else {
        (Vec3::ZERO, 1.0)
    };
    let fov_y = FRAMING_FOV_Y_DEG.to_radians();
    // Distance at which the sphere just fits the vertical field of view, plus a margin.
    let distance = 1.1 * radius / (0.5 * fov_y).sin();
    let direction = Vec3::new(1.0, 0.65, 1.2).normalize();
    Camera {
        position: centre + direction * distance,
        target: centre,
        up: Vec3::Y,
        fov_y,
        z_near: (distance - radius).max(0.0) * 0.5 + distance * 1e-3,
        z_far: (distance + radius) * 2.0,
    }
}

/// Everything a technique needs from a scene.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    pub mesh: Mesh,
    pub material: Material,
    pub camera: Camera,
}

/// Errors from building or loading a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error(
        "unknown scene '{0}': use 'house', 'patio', 'bumpy', 'wavy' or a path to a .gltf/.glb file"
    )]
    Unknown(String),
    /// A glTF file that cannot be read or used; `message` says what is wrong.
    #[error("{path}: {message}")]
    Gltf { path: String, message: String },
    #[error("lightmap resolution {res} is out of range {min}..={max}")]
    LightmapRes { res: u32, min: u32, max: u32 },
    /// The generated lightmap charts do not fit a lightmap of this resolution.
    #[error("{charts} lightmap charts do not fit a {res}² lightmap; raise --vis-res")]
    ChartsDoNotFit { res: u32, charts: usize },
    /// A `--height-map` that cannot be used.
    #[error("{path}: {message}")]
    HeightMap { path: String, message: String },
}

/// Largest height map accepted (texels), as for material textures.
pub const MAX_HEIGHT_MAP_TEXELS: usize = 16384 * 16384;

/// The first bytes of an OpenEXR file.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// Reads a height map (PNG, EXR…: its luminance, 8/16-bit images as [0, 1]) as heights
/// in texels: `scale` × value (`--height-map FILE --height-scale S`). The map tiles
/// by the material UVs like the normal map, and should describe the same surface.
///
/// # Errors
/// [`SceneError::HeightMap`] for an unreadable file, an empty or huge image, non-finite
/// texels, or a scale outside (0, [`height_field::MAX_HEIGHT_SCALE`]].
pub fn load_height_map(path: &std::path::Path, scale: f64) -> Result<HeightField, SceneError> {
    let err = |message: String| SceneError::HeightMap {
        path: path.display().to_string(),
        message,
    };
    if !(scale.is_finite() && scale > 0.0 && scale <= height_field::MAX_HEIGHT_SCALE) {
        return Err(err(format!(
            "height scale {scale:?} must be in (0, {}]",
            height_field::MAX_HEIGHT_SCALE
        )));
    }
    // Regular files only (a FIFO would block, /dev/zero never end); sized from the header.
    let bytes = crate::files::read_bounded(path, 4 << 30, "a height map").map_err(|e| {
        err(match e {
            crate::files::FileError::Io { cause, .. } => {
                format!("cannot read the height map: {cause}")
            }
            e => e
                .to_string()
                .replacen(&format!("{}: ", path.display()), "", 1),
        })
    })?;
    if bytes.starts_with(&EXR_MAGIC) {
        let map = crate::env::equirect::decode_exr_rgb(&bytes, path).map_err(|e| {
            err(e
                .to_string()
                .replacen(&format!("{}: ", path.display()), "", 1))
        })?;
        let (width, height) = (map.width as usize, map.height as usize);
        if width * height == 0 || width * height > MAX_HEIGHT_MAP_TEXELS {
            return Err(err(format!("{width}×{height} is not a usable height map")));
        }
        // Luminance, as `to_luma32f` weighs a PNG's channels (Rec. 709).
        let h: Vec<f64> = map
            .texels
            .iter()
            .map(|t| {
                (0.2126 * f64::from(t[0]) + 0.7152 * f64::from(t[1]) + 0.0722 * f64::from(t[2]))
                    * scale
            })
            .collect();
        if h.iter().any(|v| !v.is_finite()) {
            return Err(err("the height map has non-finite texels".into()));
        }
        return Ok(HeightField { width, height, h });
    }
    let reader = || {
        image::ImageReader::new(std::io::Cursor::new(&bytes))
            .with_guessed_format()
            .map_err(|e| err(format!("cannot read the height map: {e}")))
    };
    let (w, h) = reader()?
        .into_dimensions()
        .map_err(|e| err(format!("cannot read the height map: {e}")))?;
    if u64::from(w) * u64::from(h) > MAX_HEIGHT_MAP_TEXELS as u64 {
        return Err(err(format!("{w}×{h} is not a usable height map")));
    }
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(u64::from(w) * u64::from(h) * 16 + (1 << 20));
    let mut r = reader()?;
    r.limits(limits);
    let image = r
        .decode()
        .map_err(|e| err(format!("cannot read the height map: {e}")))?
        .to_luma32f();
    let (width, height) = (image.width() as usize, image.height() as usize);
    if width * height == 0 || width * height > MAX_HEIGHT_MAP_TEXELS {
        return Err(err(format!("{width}×{height} is not a usable height map")));
    }
    let h: Vec<f64> = image.pixels().map(|p| f64::from(p.0[0]) * scale).collect();
    if h.iter().any(|v| !v.is_finite()) {
        return Err(err("the height map has non-finite texels".into()));
    }
    Ok(HeightField { width, height, h })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_weighted_triangle_area_clips_to_the_view() {
        // 90° vertical field of view at z = −1: the view is x ∈ ±aspect, y ∈ ±1. A quad
        // twice that each way, split on its diagonal, leaves half the screen to each
        // triangle (unclipped each would be twice the screen); a small triangle fully in
        // view adds its own area, weighted by it.
        let (w, h) = (320u32, 200u32);
        let a = w as f32 / h as f32;
        let v = |x: f32, y: f32, z: f32| Vertex {
            position: [x, y, z],
            ..Vertex::default()
        };
        let mut mesh = Mesh {
            vertices: vec![
                v(-2.0 * a, -2.0, -1.0),
                v(2.0 * a, -2.0, -1.0),
                v(2.0 * a, 2.0, -1.0),
                v(-2.0 * a, 2.0, -1.0),
            ],
            indices: vec![0, 1, 2, 0, 2, 3],
        };
        let scene = |mesh: Mesh| Scene::flat_view("quad", mesh);
        let half = f64::from(w * h) / 2.0;
        let area = scene(mesh.clone()).pixel_weighted_triangle_area(w, h);
        assert!((area - half).abs() < 1e-3 * half, "{area} against {half}");
        // A triangle of 0.1 × 0.1 view units: (0.1 · h/2)² / 2 pixels.
        let small = (0.1 * f64::from(h) / 2.0).powi(2) / 2.0;
        let n = mesh.vertices.len() as u32;
        mesh.vertices
            .extend([v(0.0, 0.0, -1.0), v(0.1, 0.0, -1.0), v(0.1, 0.1, -1.0)]);
        mesh.indices.extend([n, n + 1, n + 2]);
        let want = (2.0 * half * half + small * small) / (2.0 * half + small);
        let area = scene(mesh.clone()).pixel_weighted_triangle_area(w, h);
        assert!((area - want).abs() < 1e-3 * want, "{area} against {want}");
        // Perimeters: the clipped halves are the screen's two triangles (2 sides and the
        // diagonal each), the small one 0.1 + 0.1 + 0.1·√2 view units.
        let s = scene(mesh);
        let clip_from_world = s.camera.clip_from_world(a);
        let perimeter: f64 = screen_triangles(&s.mesh, clip_from_world, w, h)
            .map(|t| t.perimeter)
            .sum();
        let (wf, hf) = (f64::from(w), f64::from(h));
        let want = 2.0 * (wf + hf + wf.hypot(hf)) + (2.0 + 2f64.sqrt()) * 0.1 * hf / 2.0;
        assert!(
            (perimeter - want).abs() < 1e-3 * want,
            "{perimeter} against {want}"
        );
    }

    #[test]
    fn height_maps_read_as_luminance_times_scale_and_bad_ones_are_refused() {
        let dir = std::env::temp_dir().join(format!("shvis-height-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("ramp.png");
        // A 16-bit ramp 0, ⅓, ⅔, 1 along x.
        let data: Vec<u16> = (0..8).map(|i| (i % 4) * 21845).collect();
        image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(4, 2, data)
            .unwrap()
            .save(&path)
            .unwrap();
        let field = load_height_map(&path, 6.0).unwrap();
        assert_eq!((field.width, field.height), (4, 2));
        for (i, h) in field.h.iter().enumerate() {
            let want = 2.0 * (i % 4) as f64;
            assert!((h - want).abs() < 1e-4, "texel {i}: {h}, want {want}");
        }
        for scale in [0.0, -1.0, f64::NAN] {
            assert!(load_height_map(&path, scale).is_err(), "scale {scale}");
        }
        let e = load_height_map(&dir.join("missing.png"), 1.0).unwrap_err();
        assert!(e.to_string().contains("missing.png"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
