//! glTF loading (src/scene/gltf/, DESIGN §1): node transforms on positions, normals and
//! tangents (mirroring included), the camera from its node, generated lightmap UVs without
//! overlapping texels, every kind of bad input as one clear error (never a panic), the real
//! Avocado and NormalTangentMirrorTest models, and a deterministic stand-in for the
//! `fuzz/` target (mutated `.glb` and `.gltf` bytes through `load_from_slice`).
//!
//! Files are written programmatically: [`Gltf`] collects accessors in one binary buffer and
//! writes `.gltf` + `.bin`, `.gltf` with a base64 data URI, or `.glb`.

mod common;
mod scratch;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Mat3, Mat4, Quat, Vec2, Vec3, Vec4};
use serde_json::{Value, json};
use shvis::scene::gltf::{LoadReport, load, load_from_slice, load_with_report};
use shvis::scene::{Mesh, Scene, SceneError};

use scratch::Scratch;

/// f32 transforms of unit-sized data.
const TOL: f32 = 1e-5;

// ---- A tiny glTF writer ---------------------------------------------------------------

#[derive(Default)]
struct Gltf {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    /// Extra top-level members (meshes, nodes, scenes, …).
    root: serde_json::Map<String, Value>,
}

impl Gltf {
    fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()}));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    /// A float accessor of `ty` ("VEC2", "VEC3", "VEC4").
    fn floats(&mut self, data: &[f32], ty: &str) -> usize {
        let dims = match ty {
            "VEC2" => 2,
            "VEC3" => 3,
            _ => 4,
        };
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessors
            .push(json!({"bufferView": view, "componentType": 5126,
            "count": data.len() / dims, "type": ty}));
        self.accessors.len() - 1
    }

    /// A POSITION accessor (VEC3 with the min/max glTF requires, clamped to finite).
    fn positions(&mut self, data: &[f32]) -> usize {
        let a = self.floats(data, "VEC3");
        let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        for p in data.chunks(3).map(Vec3::from_slice) {
            (lo, hi) = (lo.min(p), hi.max(p));
        }
        let finite = |v: Vec3| v.clamp(Vec3::splat(f32::MIN), Vec3::splat(f32::MAX));
        let (lo, hi) = (finite(lo), finite(hi));
        self.accessors[a]["min"] = json!(lo.to_array());
        self.accessors[a]["max"] = json!(hi.to_array());
        a
    }

    fn indices(&mut self, data: &[u32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessors
            .push(json!({"bufferView": view, "componentType": 5125,
            "count": data.len(), "type": "SCALAR"}));
        self.accessors.len() - 1
    }

    /// `image` as a PNG in the buffer, the file's only image and texture (index 0).
    fn embed_texture(&mut self, image: &image::RgbaImage) {
        let mut png = Vec::new();
        if let Err(e) = image.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        {
            panic!("{e}");
        }
        let view = self.view(&png);
        self.set(
            "images",
            json!([{"bufferView": view, "mimeType": "image/png"}]),
        );
        self.set("textures", json!([{"source": 0}]));
    }

    fn set(&mut self, key: &str, value: Value) {
        self.root.insert(key.to_string(), value);
    }

    fn json(&self, buffer_uri: Option<String>) -> Value {
        let mut root = self.root.clone();
        root.insert("asset".into(), json!({"version": "2.0"}));
        let mut buffer = json!({"byteLength": self.bin.len()});
        if let Some(uri) = buffer_uri {
            buffer["uri"] = json!(uri);
        }
        root.insert("buffers".into(), json!([buffer]));
        root.insert("bufferViews".into(), json!(self.views));
        root.insert("accessors".into(), json!(self.accessors));
        Value::Object(root)
    }

    /// `.gltf` + `.bin` in `dir`; returns the `.gltf` path.
    fn write(&self, dir: &Path, name: &str) -> PathBuf {
        let bin = format!("{name}.bin");
        write_file(&dir.join(&bin), &self.bin);
        let path = dir.join(format!("{name}.gltf"));
        write_file(&path, self.json(Some(bin)).to_string().as_bytes());
        path
    }

    /// A self-contained `.gltf` (base64 data URI).
    fn embedded(&self) -> Vec<u8> {
        let uri = format!("data:application/octet-stream;base64,{}", base64(&self.bin));
        self.json(Some(uri)).to_string().into_bytes()
    }

    /// A `.glb`.
    fn glb(&self) -> Vec<u8> {
        let mut json = self.json(None).to_string().into_bytes();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let mut bin = self.bin.clone();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let total = 12 + 8 + json.len() + 8 + bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json);
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
        out
    }
}

fn write_file(path: &Path, bytes: &[u8]) {
    if let Err(e) = std::fs::write(path, bytes) {
        panic!("{}: {e}", path.display());
    }
}

fn base64(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [0, 1, 2].map(|k| u32::from(chunk.get(k).copied().unwrap_or(0)));
        let n = b[0] << 16 | b[1] << 8 | b[2];
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ABC[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A fresh temporary directory for one test.
fn temp_dir(test: &str) -> Scratch {
    Scratch::new("scene-gltf", test)
}

/// A unit quad in the XY plane facing +Z: positions, normals, tangents (+X, w = +1), UVs
/// with v = 0 at the top (+Y), counter-clockwise indices.
struct Quad;
impl Quad {
    const P: [f32; 12] = [0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.];
    const N: [f32; 12] = [0., 0., 1., 0., 0., 1., 0., 0., 1., 0., 0., 1.];
    const T: [f32; 16] = [
        1., 0., 0., 1., 1., 0., 0., 1., 1., 0., 0., 1., 1., 0., 0., 1.,
    ];
    const UV: [f32; 8] = [0., 1., 1., 1., 1., 0., 0., 0.];
    const I: [u32; 6] = [0, 1, 2, 0, 2, 3];
}

/// Adds a quad mesh primitive (with or without normals/tangents) and returns its JSON.
fn quad_primitive(g: &mut Gltf, normals: bool, tangents: bool) -> Value {
    let mut attributes = json!({
        "POSITION": g.positions(&Quad::P),
        "TEXCOORD_0": g.floats(&Quad::UV, "VEC2"),
    });
    if normals {
        attributes["NORMAL"] = json!(g.floats(&Quad::N, "VEC3"));
    }
    if tangents {
        attributes["TANGENT"] = json!(g.floats(&Quad::T, "VEC4"));
    }
    json!({"attributes": attributes, "indices": g.indices(&Quad::I)})
}

fn ok(result: Result<Scene, SceneError>, what: &str) -> Scene {
    match result {
        Ok(s) => s,
        Err(e) => panic!("{what}: {e}"),
    }
}

fn ok_report(path: &Path, res: u32) -> (Scene, LoadReport) {
    match load_with_report(path, res) {
        Ok(s) => s,
        Err(e) => panic!("{}: {e}", path.display()),
    }
}

/// Asserts a one-line `SceneError::Gltf` naming `path` and containing `needle`.
fn expect_error(path: &Path, needle: &str) {
    match load(path, 64) {
        Ok(_) => panic!(
            "{} loaded; expected an error about '{needle}'",
            path.display()
        ),
        Err(e) => {
            let msg = e.to_string();
            println!("{msg}");
            assert!(matches!(e, SceneError::Gltf { .. }), "{msg}");
            assert!(!msg.contains('\n'), "not one line: {msg}");
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
            assert!(msg.contains(name.as_deref().unwrap_or("?")), "{msg}");
            assert!(msg.contains(needle), "'{msg}' lacks '{needle}'");
        }
    }
}

// ---- Transforms and camera -----------------------------------------------------------

#[test]
fn node_transforms_apply_to_positions_normals_tangents_and_camera() {
    let dir = temp_dir("transforms");
    let mut g = Gltf::default();
    let quad = quad_primitive(&mut g, true, true);
    g.set(
        "meshes",
        json!([{"primitives": [quad]}, {"primitives": [quad]}]),
    );
    let rot = Quat::from_rotation_y(0.5) * Quat::from_rotation_x(-0.3);
    let parent = Mat4::from_scale_rotation_translation(Vec3::ONE, rot, Vec3::new(1.0, 2.0, 3.0));
    let child = Mat4::from_scale_rotation_translation(
        Vec3::new(2.0, 0.5, 3.0),
        Quat::from_rotation_z(0.25),
        Vec3::new(0.0, 1.0, 0.0),
    );
    let mirror = Mat4::from_scale_rotation_translation(
        Vec3::new(-1.0, 1.0, 1.0),
        Quat::IDENTITY,
        Vec3::new(5.0, 0.0, 0.0),
    );
    let cam_local =
        Mat4::from_rotation_translation(Quat::from_rotation_y(0.4), Vec3::new(0.0, 0.0, 8.0));
    let q = |m: &Mat4| {
        let (_, r, _) = m.to_scale_rotation_translation();
        r.to_array()
    };
    g.set(
        "nodes",
        json!([
            {"translation": [1.0, 2.0, 3.0], "rotation": rot.to_array(), "children": [1, 2, 3]},
            {"translation": [0.0, 1.0, 0.0], "rotation": q(&child), "scale": [2.0, 0.5, 3.0], "mesh": 0},
            {"matrix": mirror.to_cols_array(), "mesh": 1},
            {"translation": [0.0, 0.0, 8.0], "rotation": q(&cam_local), "camera": 0}
        ]),
    );
    g.set("scenes", json!([{"nodes": [0]}]));
    g.set("scene", json!(0));
    g.set(
        "cameras",
        json!([{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.1, "zfar": 50.0}}]),
    );
    let path = g.write(&dir, "transforms");
    let (scene, report) = ok_report(&path, 64);
    assert_eq!(report.degenerate_triangles, 0);
    assert!(report.camera_from_file && !report.generated_tangents);
    assert!(
        report.generated_charts.is_some(),
        "no TEXCOORD_1: generated"
    );

    // Expected frames, from glam directly.
    let cases = [(parent * child, false), (parent * mirror, true)];
    let p_local: Vec<Vec3> = Quad::P.chunks(3).map(Vec3::from_slice).collect();
    let m = &scene.mesh;
    assert_eq!(m.triangle_count(), 4);
    let mut matched = 0;
    for (world, mirrored) in cases {
        let linear = Mat3::from_mat4(world);
        let n_world = (linear.inverse().transpose() * Vec3::Z).normalize();
        let t_world = (linear * Vec3::X).normalize();
        // Bitangent: image up = local +Y (w = +1, n × t = +Y), carried by the transform.
        let b_world = (linear * Vec3::Y).normalize();
        for v in &m.vertices {
            let p = Vec3::from(v.position);
            if !p_local
                .iter()
                .any(|&l| (world.transform_point3(l) - p).length() < TOL)
            {
                continue;
            }
            matched += 1;
            let n = Vec3::from(v.normal);
            let t = Vec4::from(v.tangent);
            assert!((n - n_world).length() < TOL, "normal {n} vs {n_world}");
            assert!(
                (t.truncate() - t_world).length() < TOL,
                "tangent {t} vs {t_world}"
            );
            assert_eq!(
                t.w,
                if mirrored { -1.0 } else { 1.0 },
                "w, mirrored {mirrored}"
            );
            let b = t.w * n.cross(t.truncate());
            assert!(b.dot(b_world) > 0.0, "bitangent {b} vs {b_world}");
        }
    }
    assert_eq!(
        matched, 8,
        "every output vertex matches one transformed corner"
    );
    // Winding agrees with the normals, mirrored instance included.
    for t in 0..m.triangle_count() {
        let [a, b, c] = m.triangle_positions(t);
        let n = Vec3::from(m.vertices[m.indices[3 * t] as usize].normal);
        assert!((b - a).cross(c - a).dot(n) > 0.0, "triangle {t} winding");
    }

    let cam_world = parent * cam_local;
    let cam = scene.camera;
    assert!((cam.position - cam_world.transform_point3(Vec3::ZERO)).length() < TOL);
    let forward = (cam.target - cam.position).normalize();
    assert!((forward - cam_world.transform_vector3(Vec3::NEG_Z)).length() < TOL);
    assert!((cam.up - cam_world.transform_vector3(Vec3::Y)).length() < TOL);
    assert_eq!((cam.fov_y, cam.z_near, cam.z_far), (0.7, 0.1, 50.0));

    // It renders with preconv from the camera it defines: the quads' centres land on
    // covered pixels of that view, validation stays silent.
    let prepared = shvis::prepare::prepare(&shvis::prepare::PrepareSettings {
        scene: path.to_string_lossy().into_owned(),
        vis_res: 64,
        rays: 16,
        cache_dir: Some(dir.join("cache")),
        ..Default::default()
    })
    .expect("the glTF prepares");
    let ctx = common::validated_context();
    let (w, h) = (160, 100);
    let frame = common::render(
        &ctx,
        &prepared,
        shvis::technique::Technique::Preconv(shvis::technique::Preconv),
        shvis::technique::HwPath::Dx10,
        &shvis::render::FrameSettings {
            width: w,
            height: h,
            ..Default::default()
        },
    );
    let mut seen = 0;
    for (world, _) in cases {
        let centre = world.transform_point3(Vec3::new(0.5, 0.5, 0.0));
        let Some((x, y)) = cam.project_to_pixel(centre, w, h) else {
            continue;
        };
        if x < 0.0 || y < 0.0 || x as u32 >= w || y as u32 >= h {
            continue; // outside the file camera's view
        }
        seen += 1;
        assert!(
            frame.covered(x as u32, y as u32),
            "quad centre {centre} at ({x}, {y}) not drawn"
        );
    }
    assert!(seen >= 1, "the file's camera sees no quad centre");
}

#[test]
fn missing_normals_and_tangents_are_generated_and_camera_frames_bounds() {
    let mut g = Gltf::default();
    let quad = quad_primitive(&mut g, false, false);
    g.set("meshes", json!([{"primitives": [quad]}]));
    g.set("nodes", json!([{"mesh": 0, "scale": [0.05, 0.05, 0.05]}]));
    g.set("scenes", json!([{"nodes": [0]}]));
    let scene = ok(load_from_slice(&g.embedded(), 64), "embedded");
    for v in &scene.mesh.vertices {
        assert!((Vec3::from(v.normal) - Vec3::Z).length() < TOL);
        let t = Vec4::from(v.tangent);
        assert!(
            (t.truncate() - Vec3::X).length() < TOL,
            "MikkTSpace tangent {t}"
        );
        // Image up (decreasing v) is +Y: w·(n × t) = +Y.
        assert_eq!(t.w, 1.0);
    }
    let (lo, hi) = scene.mesh.bounds();
    let centre = 0.5 * (lo + hi);
    let cam = scene.camera;
    assert!((cam.target - centre).length() < TOL);
    let d = (cam.position - centre).length();
    assert!(d > 0.05 && d < 1.0, "framing distance {d} for a 5 cm quad");
    assert!(cam.z_near > 0.0 && cam.z_near < d - 0.04 && cam.z_far > d + 0.04);
    assert!(cam.position.y > centre.y, "elevated");
}

// ---- Lightmap UVs ---------------------------------------------------------------------

/// Texel centres inside a lightmap-UV triangle (inclusive, small tolerance).
fn covered_texels(uv: [Vec2; 3], res: u32) -> Vec<u32> {
    let p = uv.map(|c| c.as_dvec2() * f64::from(res));
    let area = (p[1] - p[0]).perp_dot(p[2] - p[0]);
    let mut out = Vec::new();
    if area.abs() < 1e-12 {
        return out;
    }
    let lo = p[0].min(p[1]).min(p[2]).floor().max(glam::DVec2::ZERO);
    let hi = p[0]
        .max(p[1])
        .max(p[2])
        .ceil()
        .min(glam::DVec2::splat(f64::from(res)));
    for y in lo.y as u32..hi.y as u32 {
        for x in lo.x as u32..hi.x as u32 {
            let c = glam::DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
            let inside = (0..3).all(|k| {
                let (a, b) = (p[(k + 1) % 3], p[(k + 2) % 3]);
                (b - a).perp_dot(c - a) / area >= -1e-6
            });
            if inside {
                out.push(y * res + x);
            }
        }
    }
    out
}

/// Chart id per triangle: triangles sharing a vertex, or a corner with the same position
/// and lightmap UV (a material seam inside a chart), are in one chart.
fn charts(m: &Mesh) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..m.vertices.len()).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let union = |a: usize, b: usize, p: &mut Vec<usize>| {
        let (ra, rb) = (find(p, a), find(p, b));
        p[ra] = rb;
    };
    for t in m.indices.chunks(3) {
        union(t[0] as usize, t[1] as usize, &mut parent);
        union(t[0] as usize, t[2] as usize, &mut parent);
    }
    let mut first: HashMap<([u32; 3], [u32; 2]), usize> = HashMap::new();
    for (i, v) in m.vertices.iter().enumerate() {
        let key = (
            v.position.map(f32::to_bits),
            v.uv_lightmap.map(f32::to_bits),
        );
        let j = *first.entry(key).or_insert(i);
        union(i, j, &mut parent);
    }
    m.indices
        .chunks(3)
        .map(|t| find(&mut parent, t[0] as usize))
        .collect()
}

/// Asserts lightmap UVs in [0, 1] and no texel covered by two charts; returns the number
/// of covered texels.
fn assert_disjoint_charts(m: &Mesh, res: u32, what: &str) -> usize {
    for v in &m.vertices {
        assert!(
            v.uv_lightmap.iter().all(|c| (0.0..=1.0).contains(c)),
            "{what}: {:?}",
            v.uv_lightmap
        );
    }
    let chart = charts(m);
    let mut owner: HashMap<u32, usize> = HashMap::new();
    let mut covered = 0;
    for (t, tri) in m.indices.chunks(3).enumerate() {
        let uv = [0, 1, 2].map(|k| Vec2::from(m.vertices[tri[k] as usize].uv_lightmap));
        for texel in covered_texels(uv, res) {
            covered += 1;
            let o = *owner.entry(texel).or_insert(chart[t]);
            assert_eq!(o, chart[t], "{what} at {res}: texel {texel} in two charts");
        }
    }
    covered
}

/// A closed, bumpy sphere (UV sphere, shared vertices, a material seam) without TEXCOORD_1.
fn sphere(g: &mut Gltf, with_uv1: bool) -> Value {
    let (rings, segments) = (10, 16);
    let (mut p, mut n, mut uv) = (Vec::new(), Vec::new(), Vec::new());
    for r in 0..=rings {
        for s in 0..=segments {
            let (theta, phi) = (
                std::f32::consts::PI * r as f32 / rings as f32,
                std::f32::consts::TAU * s as f32 / segments as f32,
            );
            let d = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            let radius = 1.0 + 0.1 * (3.0 * phi).sin() * theta.sin();
            p.extend((d * radius).to_array());
            n.extend(d.to_array());
            uv.extend([s as f32 / segments as f32, r as f32 / rings as f32]);
        }
    }
    let mut idx = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let a = r * (segments + 1) + s;
            let (b, c, d) = (a + 1, a + segments + 1, a + segments + 2);
            // Skip the zero-area pole triangles.
            if r != 0 {
                idx.extend([a, b, c]);
            }
            if r != rings - 1 {
                idx.extend([b, d, c]);
            }
        }
    }
    let mut attributes = json!({
        "POSITION": g.positions(&p),
        "NORMAL": g.floats(&n, "VEC3"),
        "TEXCOORD_0": g.floats(&uv, "VEC2"),
    });
    if with_uv1 {
        let uv1: Vec<f32> = uv.iter().map(|c| 0.1 + 0.8 * c).collect();
        attributes["TEXCOORD_1"] = json!(g.floats(&uv1, "VEC2"));
    }
    json!({"attributes": attributes, "indices": g.indices(&idx)})
}

#[test]
fn generated_lightmap_uvs_have_no_overlapping_texels() {
    let dir = temp_dir("lightmap");
    let mut g = Gltf::default();
    let prim = sphere(&mut g, false);
    let quad = quad_primitive(&mut g, true, true);
    g.set("meshes", json!([{"primitives": [prim, quad]}]));
    g.set("nodes", json!([{"mesh": 0}]));
    g.set("scenes", json!([{"nodes": [0]}]));
    let path = g.write(&dir, "sphere");
    for res in [64, 256] {
        let (scene, report) = ok_report(&path, res);
        let charts = report.generated_charts.unwrap_or(0);
        assert!(charts > 4, "res {res}: {charts} charts");
        let covered = assert_disjoint_charts(&scene.mesh, res, "sphere");
        println!("res {res}: {charts} charts, {covered} covered texels");
        assert!(
            covered > (res * res / 8) as usize,
            "res {res}: only {covered} texels used"
        );
    }
}

#[test]
fn texcoord_1_is_used_as_given_unless_instanced() {
    let mut g = Gltf::default();
    let prim = sphere(&mut g, true);
    g.set("meshes", json!([{"primitives": [prim]}]));
    g.set(
        "nodes",
        json!([{"mesh": 0}, {"mesh": 0, "translation": [3.0, 0.0, 0.0]}]),
    );
    g.set("scenes", json!([{"nodes": [0]}]));
    let once = ok(load_from_slice(&g.glb(), 64), "once");
    assert!(
        once.mesh.vertices.iter().all(|v| v
            .uv_lightmap
            .iter()
            .all(|c| (0.1 - TOL..=0.9 + TOL).contains(c))),
        "TEXCOORD_1 as given"
    );
    // Two instances of one layout would share texels: generated instead.
    g.set("scenes", json!([{"nodes": [0, 1]}]));
    let twice = ok(load_from_slice(&g.glb(), 128), "twice");
    assert_disjoint_charts(&twice.mesh, 128, "instanced");
}

// ---- Bad input ------------------------------------------------------------------------

/// One valid quad scene, altered by `edit` before writing.
fn quad_file(dir: &Path, name: &str, edit: impl FnOnce(&mut Gltf) -> Option<Value>) -> PathBuf {
    let mut g = Gltf::default();
    let quad = quad_primitive(&mut g, true, true);
    g.set("meshes", json!([{"primitives": [quad]}]));
    g.set("nodes", json!([{"mesh": 0}]));
    g.set("scenes", json!([{"nodes": [0]}]));
    let replaced = edit(&mut g);
    let path = g.write(dir, name);
    if let Some(json) = replaced {
        write_file(&path, json.to_string().as_bytes());
    }
    path
}

#[test]
fn bad_files_are_one_line_errors() {
    let dir = temp_dir("bad");
    let malformed = dir.join("malformed.gltf");
    write_file(
        &malformed,
        b"{ \"asset\": {\"version\": \"2.0\"}, \"meshes\": [ ",
    );
    expect_error(&malformed, "invalid glTF");
    expect_error(&dir.join("absent.gltf"), "cannot read");

    let missing_bin = quad_file(&dir, "missing_bin", |_| None);
    if let Err(e) = std::fs::remove_file(dir.join("missing_bin.bin")) {
        panic!("{e}");
    }
    expect_error(&missing_bin, "not found");

    let past_view = quad_file(&dir, "past_view", |g| {
        g.accessors[0]["count"] = json!(400);
        None
    });
    expect_error(&past_view, "run past");

    let bad_index = quad_file(&dir, "bad_index", |g| {
        let i = g.indices(&[0, 1, 7]);
        g.set(
            "meshes",
            json!([{"primitives": [{"attributes": {"POSITION": 0}, "indices": i}]}]),
        );
        None
    });
    expect_error(&bad_index, "out of range");

    let bad_accessor_ref = quad_file(&dir, "bad_accessor_ref", |g| {
        g.set(
            "meshes",
            json!([{"primitives": [{"attributes": {"POSITION": 99}}]}]),
        );
        None
    });
    expect_error(&bad_accessor_ref, "invalid glTF");

    let nan = quad_file(&dir, "nan", |g| {
        let mut p = Quad::P;
        p[4] = f32::NAN;
        let a = g.positions(&p);
        g.set(
            "meshes",
            json!([{"primitives": [{"attributes": {"POSITION": a}}]}]),
        );
        None
    });
    expect_error(&nan, "not finite");

    let inf = quad_file(&dir, "inf", |g| {
        let mut p = Quad::P;
        p[0] = f32::INFINITY;
        let a = g.positions(&p);
        g.set(
            "meshes",
            json!([{"primitives": [{"attributes": {"POSITION": a}}]}]),
        );
        None
    });
    expect_error(&inf, "not finite");

    let ragged = quad_file(&dir, "ragged", |g| {
        let i = g.indices(&[0, 1, 2, 0]);
        g.set(
            "meshes",
            json!([{"primitives": [{"attributes": {"POSITION": 0}, "indices": i}]}]),
        );
        None
    });
    expect_error(&ragged, "whole number of triangles");

    let all_degenerate = quad_file(&dir, "all_degenerate", |g| {
        let a = g.positions(&[0., 0., 0., 1., 0., 0., 2., 0., 0.]);
        g.set(
            "meshes",
            json!([{"primitives": [{"attributes": {"POSITION": a}}]}]),
        );
        None
    });
    expect_error(&all_degenerate, "no usable triangles");

    let empty_scene = quad_file(&dir, "empty_scene", |g| {
        g.set("scenes", json!([{"nodes": []}]));
        None
    });
    expect_error(&empty_scene, "no meshes");

    let no_scene = quad_file(&dir, "no_scene", |g| {
        g.root.remove("scenes");
        None
    });
    expect_error(&no_scene, "no scene");

    let cycle = quad_file(&dir, "cycle", |g| {
        g.set(
            "nodes",
            json!([{"mesh": 0, "children": [1]}, {"children": [0]}]),
        );
        None
    });
    expect_error(&cycle, "");

    let points_only = quad_file(&dir, "points_only", |g| {
        g.set(
            "meshes",
            json!([{"primitives": [{"attributes": {"POSITION": 0}, "mode": 0}]}]),
        );
        None
    });
    expect_error(&points_only, "no usable triangles");

    let too_bright = quad_file(&dir, "too_bright", |g| {
        g.set(
            "materials",
            json!([{"pbrMetallicRoughness": {"baseColorFactor": [1.5, 1.0, 1.0, 1.0]}}]),
        );
        if let Some(meshes) = g.root.get_mut("meshes") {
            meshes[0]["primitives"][0]["material"] = json!(0);
        }
        None
    });
    expect_error(&too_bright, "baseColorFactor");

    let flat_scale = quad_file(&dir, "flat_scale", |g| {
        g.embed_texture(&image::RgbaImage::from_pixel(
            2,
            2,
            image::Rgba([128, 128, 255, 255]),
        ));
        g.set(
            "materials",
            json!([{"normalTexture": {"index": 0, "scale": 1e39}}]),
        );
        if let Some(meshes) = g.root.get_mut("meshes") {
            meshes[0]["primitives"][0]["material"] = json!(0);
        }
        None
    });
    // JSON has no infinity: a scale past f32 is refused as out of range.
    expect_error(&flat_scale, "number out of range");

    let dark_colour = quad_file(&dir, "dark_colour", |g| {
        let c = g.floats(
            &[0.5, 0.5, 0.5, -1.0, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5],
            "VEC3",
        );
        if let Some(meshes) = g.root.get_mut("meshes") {
            meshes[0]["primitives"][0]["attributes"]["COLOR_0"] = json!(c);
        }
        None
    });
    expect_error(&dark_colour, "COLOR_0");

    // 1000 instances of a mesh whose accessors claim 6 M corners: refused before any read.
    let many = quad_file(&dir, "many_instances", |g| {
        for a in &mut g.accessors {
            a["count"] = json!(6_000_000);
        }
        let nodes: Vec<Value> = (0..1000).map(|_| json!({"mesh": 0})).collect();
        let refs: Vec<usize> = (0..1000).collect();
        g.set("nodes", json!(nodes));
        g.set("scenes", json!([{"nodes": refs}]));
        None
    });
    expect_error(&many, "triangle corners");

    let short_glb = dir.join("short.glb");
    write_file(&short_glb, b"glTF\x02\0\0\0\x04\0\0\0");
    expect_error(&short_glb, "header length");
    let truncated_glb = dir.join("truncated.glb");
    let mut g = Gltf::default();
    let quad = quad_primitive(&mut g, true, true);
    g.set("meshes", json!([{"primitives": [quad]}]));
    g.set("nodes", json!([{"mesh": 0}]));
    g.set("scenes", json!([{"nodes": [0]}]));
    let glb = g.glb();
    write_file(&truncated_glb, &glb[..glb.len() - 40]);
    expect_error(&truncated_glb, "truncated .glb: its header gives");
    // A truncated .glb whose header was rewritten to match still has a chunk past the end.
    let mut cut = glb[..glb.len() - 40].to_vec();
    let len = cut.len() as u32;
    cut[8..12].copy_from_slice(&len.to_le_bytes());
    write_file(&truncated_glb, &cut);
    expect_error(&truncated_glb, "runs past the file's end");
    let not_glb = dir.join("not-binary.glb");
    write_file(&not_glb, b"PK\x03\x04 a zip file, not a glb");
    expect_error(&not_glb, "not a binary glTF");

    // Bad lightmap resolution is its own error.
    assert!(matches!(
        load(&missing_bin, 4),
        Err(SceneError::LightmapRes { .. })
    ));
}

#[test]
fn degenerate_and_zero_uv_triangles_are_skipped_and_counted() {
    let dir = temp_dir("skipped");
    let path = quad_file(&dir, "skipped", |g| {
        // Quad corners 0..3, a collinear triple (4, 5, 6) and a triangle whose UVs coincide.
        let mut p = Quad::P.to_vec();
        p.extend([2., 0., 0., 3., 0., 0., 4., 0., 0.]);
        p.extend([0., 0., 1., 1., 0., 1., 0., 1., 1.]);
        let mut uv = Quad::UV.to_vec();
        uv.extend([0., 0., 1., 0., 0., 1.]);
        uv.extend([0.5, 0.5, 0.5, 0.5, 0.5, 0.5]);
        let (a, t) = (g.positions(&p), g.floats(&uv, "VEC2"));
        let i = g.indices(&[0, 1, 2, 0, 2, 3, 4, 5, 6, 7, 8, 9]);
        let points = g.positions(&[0., 0., 0.]);
        g.set(
            "meshes",
            json!([{"primitives": [
                {"attributes": {"POSITION": a, "TEXCOORD_0": t}, "indices": i},
                {"attributes": {"POSITION": points}, "mode": 0}
            ]}]),
        );
        None
    });
    let (scene, report) = ok_report(&path, 64);
    assert_eq!(scene.mesh.triangle_count(), 2);
    assert_eq!(report.degenerate_triangles, 1);
    assert_eq!(report.zero_uv_area_triangles, 1);
    assert_eq!(report.skipped_primitives, 1);
}

// ---- Real models ----------------------------------------------------------------------

fn asset(rel: &str) -> Option<PathBuf> {
    let path = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/assets/models"
    ))
    .join(rel);
    if path.exists() {
        Some(path)
    } else {
        println!("note: {} is absent; test skipped", path.display());
        None
    }
}

#[test]
fn avocado_loads_with_generated_lightmap_uvs() {
    let Some(path) = asset("Avocado/Avocado.gltf") else {
        return;
    };
    let res = 256;
    let (scene, report) = ok_report(&path, res);
    let (lo, hi) = scene.mesh.bounds();
    let size = hi - lo;
    println!("avocado: bounds {lo} … {hi}, {report:?}");
    // ≈ 4.3 × 6.3 × 2.8 cm, rotated 180° about +Y (x and z extents unchanged).
    assert!(
        (size - Vec3::new(0.0426, 0.0629, 0.0276))
            .abs()
            .max_element()
            < 0.002,
        "{size}"
    );
    assert!(report.generated_charts.is_some() && !report.generated_tangents);
    assert_eq!(
        report.degenerate_triangles + report.zero_uv_area_triangles,
        0
    );
    assert_eq!(scene.mesh.triangle_count(), 682);
    assert_eq!(
        (scene.material.albedo.width, scene.material.albedo.height),
        (2048, 2048)
    );
    assert_eq!(
        (scene.material.normal.width, scene.material.normal.height),
        (2048, 2048)
    );
    let covered = assert_disjoint_charts(&scene.mesh, res, "avocado");
    println!("avocado: {covered} of {} texels covered", res * res);
    // Chart rectangles and gutters cost space, but most of the lightmap must be surface.
    assert!(
        covered > (res * res / 4) as usize,
        "{covered} texels covered"
    );
    // The framing camera sees the whole avocado from centimetres away.
    let d = (scene.camera.position - scene.camera.target).length();
    assert!(d > 0.03 && d < 0.3, "camera distance {d}");
    for v in &scene.mesh.vertices {
        let (n, t) = (Vec3::from(v.normal), Vec4::from(v.tangent));
        assert!((n.length() - 1.0).abs() < TOL && (t.truncate().length() - 1.0).abs() < TOL);
        assert!(n.dot(t.truncate()).abs() < TOL);
    }
}

#[test]
fn mirror_test_keeps_given_tangent_signs() {
    let Some(path) = asset("NormalTangentMirrorTest/NormalTangentMirrorTest.gltf") else {
        return;
    };
    let (scene, report) = ok_report(&path, 512);
    assert!(!report.generated_tangents);
    let flipped = scene
        .mesh
        .vertices
        .iter()
        .filter(|v| v.tangent[3] < 0.0)
        .count();
    // 80 file vertices have w = −1; chart splitting may duplicate some of them.
    assert!(flipped >= 80, "{flipped} vertices with w = −1");
    assert_disjoint_charts(&scene.mesh, 512, "mirror test");
}

// ---- Fuzz stand-in --------------------------------------------------------------------

use common::Rng;

/// A valid scene with every feature the loader reads, including an embedded PNG.
fn fuzz_seed() -> Gltf {
    let mut g = Gltf::default();
    let quad = quad_primitive(&mut g, true, true);
    let prim = sphere(&mut g, false);
    let img = image::RgbaImage::from_fn(4, 4, |x, y| {
        image::Rgba([x as u8 * 60, y as u8 * 60, 9, 255])
    });
    g.embed_texture(&img);
    g.set(
        "materials",
        json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "baseColorFactor": [0.5, 0.6, 0.7, 1.0]},
                "normalTexture": {"index": 0, "scale": 0.5}}]),
    );
    let mut quad = quad;
    quad["material"] = json!(0);
    g.set("meshes", json!([{"primitives": [quad, prim]}]));
    g.set(
        "nodes",
        json!([{"mesh": 0, "children": [1], "scale": [1.0, 2.0, 1.0]}, {"camera": 0, "translation": [0, 0, 5]}]),
    );
    g.set(
        "cameras",
        json!([{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}]),
    );
    g.set("scenes", json!([{"nodes": [0]}]));
    g
}

/// Numbers substituted into the JSON by the token mutator: edges of every range the loader
/// checks.
const HOSTILE_NUMBERS: &[&str] = &[
    "0",
    "1",
    "-1",
    "2",
    "3",
    "4",
    "7",
    "255",
    "65535",
    "4294967295",
    "18446744073709551615",
    "1e30",
    "-1e30",
    "0.5",
    "5121",
    "5123",
    "5125",
    "5126",
    "99999999",
];

#[test]
fn mutated_files_never_panic() {
    let seed = fuzz_seed();
    let glb = seed.glb();
    let text = seed.embedded();
    assert!(load_from_slice(&glb, 64).is_ok() && load_from_slice(&text, 64).is_ok());
    let mut rng = Rng(0x5eed_1234_abcd_0001);
    let (mut loaded, mut failed) = (0, 0);
    let mut run = |bytes: &[u8], what: String| {
        let outcome = std::panic::catch_unwind(|| load_from_slice(bytes, 64).is_ok());
        match outcome {
            Ok(true) => loaded += 1,
            Ok(false) => failed += 1,
            Err(_) => panic!("{what} panicked"),
        }
    };
    // Byte flips and truncations of the .glb.
    for case in 0..250 {
        let mut bytes = glb.clone();
        if case % 5 == 4 {
            bytes.truncate(rng.below(glb.len()));
        } else {
            for _ in 0..=rng.below(4) {
                let i = rng.below(bytes.len());
                bytes[i] ^= 1 << rng.below(8);
            }
        }
        run(&bytes, format!("glb mutation {case}"));
    }
    // Numbers in the JSON replaced by hostile values (structure intact, so the mutations
    // reach accessors, indices, transforms and cameras rather than the JSON parser).
    let json = String::from_utf8_lossy(&text).into_owned();
    let numbers: Vec<(usize, usize)> = {
        let b = json.as_bytes();
        let mut spans = Vec::new();
        let mut i = 0;
        while i < b.len() {
            if b[i].is_ascii_digit() && (i == 0 || !b[i - 1].is_ascii_alphanumeric()) {
                let start = if i > 0 && b[i - 1] == b'-' { i - 1 } else { i };
                while i < b.len() && (b[i].is_ascii_digit() || b".eE-+".contains(&b[i])) {
                    i += 1;
                }
                spans.push((start, i));
            } else {
                i += 1;
            }
        }
        spans
    };
    for case in 0..250 {
        let mut spans: Vec<(usize, usize)> = (0..=rng.below(3))
            .map(|_| numbers[rng.below(numbers.len())])
            .collect();
        spans.sort_unstable();
        spans.dedup();
        let mut out = String::with_capacity(json.len());
        let mut last = 0;
        for (s, e) in spans {
            out.push_str(&json[last..s]);
            out.push_str(HOSTILE_NUMBERS[rng.below(HOSTILE_NUMBERS.len())]);
            last = e;
        }
        out.push_str(&json[last..]);
        run(out.as_bytes(), format!("json mutation {case}"));
    }
    println!("{loaded} mutated files loaded, {failed} rejected with an error");
    assert!(failed > 0 && loaded > 0);
}
