//! The device probe and the cost model (`shvis probe`, run first by `shvis bench`).
//!
//! **Probe.** On the current Vulkan device, at the bench's target format and resolution, a
//! screen-filling grid of triangles as large as the scene's (`ProbeSettings::triangle_pixels`,
//! the scene's pixel-weighted triangle area: lavapipe shades in blocks, and the smaller the
//! triangles the more of a block's lanes idle — a bilinear lookup cost 2.3 ns per pixel over
//! two screen-filling triangles and 3.6 ns over 125-pixel ones) is drawn with generated
//! fragment shaders that each do N operations of one kind (straight-line code, no loops):
//! bilinear 2D lookups (RGBA16F, the lightmap sampler, a texture each, as dx9 binds them),
//! trilinear lookups (RGBA8 with MIP chains, the material sampler, ≈ 2.7 texels per pixel;
//! the same in sRGB, as the albedo, and in RGBA32F, as the NDF moment maps),
//! 2D-array lookups, cube-array lookups (32² faces, as the tables), dependent lookups (each
//! one's coordinates from the previous one's result, into textures the size of a dx9 table
//! strip), scalar fused multiply-adds (four independent vec4 chains), interpolated varyings
//! read, and uniform vec4 reads at constant and at per-pixel indices; plus the empty shader
//! (it writes its lightmap coordinates, which every technique reads) over the full screen,
//! over half of it, with the depth test off, and over grids of 2·64², 2·96², 2·128², 2·256²
//! triangles (the per-triangle cost), the shader that reads all 14 varyings over the 2·96²
//! and 2·256² grids (a varying's per-triangle cost), and a frame that shades nothing. The points' frames
//! (`gpu::pass`) are taken in rounds over all points so that a slow drift of a shared
//! device spreads over every point instead of landing on a few; cheap points get more
//! frames. A shared device also switches between speed states every few seconds (on this
//! project's VM the empty shader over the screen takes 1.7 or 3.4 ms, a neighbour's memory
//! traffic by the look of it): a monitor frame after each point's frames tells which state
//! they ran in ([`states`]); a model is fitted per state to the points' medians in it
//! (the main one: the fastest state every point ran in, the device least disturbed). A
//! point the first fit misses by more than 8 %, or with fewer than 5 frames in a state of
//! ≥ 10 % of the monitor frames, is timed in two more batches of rounds on freshly built
//! pipelines, its frames pooled with the first and its time that of its fastest build (a
//! build can run ≈ 25 % slow for as long as it lives, `states`).
//!
//! **Model.** The costs of [`crate::cost::CostModel`] are fitted to the points' medians by
//! a **minimax** fit: the costs that make the largest relative error over the points least
//! (a linear program, [`chebyshev_fit`]), as the model is judged by its worst point. A
//! least-squares fit (weighted by 1/t) leaves 7.6–9.5 % on the same points where this
//! leaves 6.1–8.0 %.

pub mod cache;
pub mod scene_check;
pub mod states;

use std::sync::Arc;

use ash::vk;
use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::cost::spirv::{self, OpCounts};
use crate::cost::{CostCounts, CostModel, Kind};
use crate::gpu::TimingStats;
use crate::gpu::{
    Buffer, Context, GpuError, Image, ImageDesc, MeshBuffers, Resource, Sampler, SamplerKind,
    ShaderStage, layout,
};
use crate::render::{FrameSettings, SceneGpu, ShadingLoad};
use crate::scene::{Mesh, Scene, Vertex};

pub use states::{DeviceStates, Segmented};

/// One microbenchmark.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ProbePoint {
    /// `None` for the empty shader.
    pub kind: Option<Kind>,
    /// Operations of `kind` generated.
    pub count: u32,
    /// Lanes busy per screen pixel (`SceneGpu::shading_load`).
    pub coverage: f64,
    /// Triangles drawn (2, or a grid's for the per-triangle cost).
    pub triangles: u32,
    /// Their edges on the screen, pixels.
    pub edge_pixels: f64,
    pub depth_test: bool,
    /// Whether its operations sit in a branch that no lane takes (the untaken-branch
    /// points, [`CostModel::untaken_share`]).
    pub in_untaken_branch: bool,
    /// What the shader's SPIR-V counts (all kinds), less `untaken`.
    pub counts: CostCounts,
    /// What its untaken branch counts.
    pub untaken: CostCounts,
    /// Median of its timed frames in the main state, of its fastest build there (of all
    /// its frames where none ran in it: `state_frames` 0).
    pub ms_median: f64,
    /// Batches of interleaved rounds it was timed in (1, or 1 + RETIME_BATCHES).
    pub batches: u32,
    /// Frames timed, and of them in the main state ([`states`]).
    pub frames: usize,
    pub state_frames: usize,
    /// The fitted model's prediction.
    pub model_ms: f64,
}

/// The model fitted to the points' frames in one speed state ([`states`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StateModel {
    pub state: usize,
    pub model: CostModel,
    /// Largest |model − measured| / measured over the points in this state.
    pub worst_relative_error: f64,
    /// The point of that error, and its frames in this state.
    pub worst_point: String,
}

impl StateModel {
    fn new(state: usize, model: CostModel, points: &[ProbePoint]) -> Self {
        let worst = points
            .iter()
            .max_by(|a, b| relative_error(a).total_cmp(&relative_error(b)));
        StateModel {
            state,
            model,
            worst_relative_error: worst.map_or(0.0, relative_error),
            worst_point: worst.map_or(String::new(), |p| {
                format!(
                    "{} ×{} ({:.3} ms measured over {} frames, {:.3} modelled)",
                    p.label(),
                    p.count,
                    p.ms_median,
                    p.state_frames,
                    p.model_ms
                )
            }),
        }
    }
}

impl ProbePoint {
    /// Its kind's name, or the empty shader's, and where its operations sit.
    pub fn label(&self) -> String {
        let name = self.kind.map_or("empty shader", Kind::name);
        if self.in_untaken_branch {
            format!("{name} in a branch no lane takes")
        } else {
            name.to_string()
        }
    }
}

/// |model − measured| / measured of a point.
fn relative_error(p: &ProbePoint) -> f64 {
    (p.model_ms - p.ms_median).abs() / p.ms_median
}

/// Largest [`relative_error`] over `points`.
fn worst_relative_error(points: &[ProbePoint]) -> f64 {
    points.iter().map(relative_error).fold(0.0, f64::max)
}

/// The probe's result.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Probe {
    pub device: String,
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    /// Fragments the screen-filling grid shades (`SceneGpu::shading_load`): one per
    /// pixel ([`CostModel::predict`]'s coverage is in lanes per pixel, `ProbePoint::coverage`).
    pub screen_fragments: u64,
    /// The triangles' screen area asked for, pixels, and the grid side it gave (2·side²
    /// triangles over 1.2 × the view each way).
    pub triangle_pixels: f64,
    pub grid: u32,
    pub model: CostModel,
    /// The speed states the monitor frames fell into; `model` and the points' medians are
    /// the main state's.
    pub states: DeviceStates,
    /// A model per state that every point has frames in (the main state's among them).
    pub state_models: Vec<StateModel>,
    pub points: Vec<ProbePoint>,
    pub seconds: f64,
    /// When it was measured, UTC ("YYYY-MM-DD HH:MM").
    #[serde(default)]
    pub measured_at: String,
    /// The cache file it was read from, when a bench reused it (`cache`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reused_from: Option<String>,
}

impl Probe {
    /// Largest |model − measured| / measured over the points.
    pub fn worst_relative_error(&self) -> f64 {
        worst_relative_error(&self.points)
    }

    /// The model of `state`, if the probe fitted one.
    pub fn model_of(&self, state: usize) -> Option<&CostModel> {
        self.state_models
            .iter()
            .find(|m| m.state == state)
            .map(|m| &m.model)
    }

    /// The probe as markdown: the model's costs and every point against its prediction.
    pub fn to_markdown(&self) -> String {
        let m = &self.model;
        let mut s = format!(
            "device: {} · {}×{} ({} fragments shaded by the screen grid of 2·{}² triangles, {:.0} pixels each) · at least {} timed frames per point (more for cheap ones), in interleaved rounds · {:.1} s, measured {} UTC{}\n\n\
             fixed {:.3} ms per frame; {:.3} µs per triangle, {:.2} ns more per varying float it carries; {:.3} ns per pixel of triangle edge; empty shader {:.3} ms per screen of lanes, of which the depth test {:.3} ms\n\n\
             | kind | ms per unit per screen of lanes | ns per unit per lane |\n|---|---:|---:|\n",
            self.device,
            self.width,
            self.height,
            self.screen_fragments,
            self.grid,
            0.72 * f64::from(self.width) * f64::from(self.height)
                / f64::from(self.grid * self.grid),
            self.frames,
            self.seconds,
            self.measured_at,
            self.reused_from
                .as_ref()
                .map_or(String::new(), |f| format!(" (reused from {f})")),
            m.fixed_ms,
            1e3 * m.per_triangle_ms,
            1e6 * m.per_triangle_varying_ms,
            1e6 * m.per_edge_pixel_ms,
            m.pixel_ms,
            m.depth_test_ms
        );
        let pixels = f64::from(self.width) * f64::from(self.height);
        for kind in Kind::ALL {
            s += &format!(
                "| {} | {:.4} | {:.3} |\n",
                kind.name(),
                m.cost(kind),
                m.cost(kind) * 1e6 / pixels
            );
        }
        s += &format!(
            "\nA branch that no lane of a SIMD batch takes costs {:.2} of its straight-line work (0: the device jumps over it; 1: it runs it with the lanes masked off)\n",
            m.untaken_share
        );
        let retimed = self.points.iter().filter(|p| p.batches > 1).count();
        s += &format!(
            "\ndevice: {} (a monitor frame after every point's frames; ms median: of the point's frames in the main state, of its fastest build there)\n\n{retimed} point(s) that the first fit missed by more than {:.0} %, or that had fewer than {MIN_STATE_FRAMES} frames in a state holding {:.0} % of the monitor frames or more, timed in {RETIME_BATCHES} more batches of rounds\n",
            self.states.describe(),
            100.0 * RETIME_ERROR,
            100.0 * STATE_MODEL_SHARE
        );
        for m in &self.state_models {
            s += &format!(
                "\nstate {} (monitor frame {:.3} ms){}: largest model error {:.1} % ({}); fixed {:.3} ms, empty shader {:.3} ms per screen, ns per unit per lane: {}\n",
                m.state,
                self.states.monitor_ms[m.state],
                if m.state == self.states.main_state {
                    ", the main model (the table below)"
                } else {
                    ""
                },
                100.0 * m.worst_relative_error,
                m.worst_point,
                m.model.fixed_ms,
                m.model.pixel_ms,
                Kind::ALL
                    .iter()
                    .map(|&k| format!("{} {:.3}", k.name(), m.model.cost(k) * 1e6 / pixels))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        s += "\n| point | count | lanes per pixel | triangles | edge pixels | depth | batches | frames in state / timed | ms median | model ms | model / measured |\n|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|\n";
        for p in &self.points {
            s += &format!(
                "| {} | {} | {:.2} | {} | {:.0} | {} | {} | {} / {} | {:.3} | {:.3} | {:.3} |\n",
                p.label(),
                p.count,
                p.coverage,
                p.triangles,
                p.edge_pixels,
                if p.depth_test { "on" } else { "off" },
                p.batches,
                p.state_frames,
                p.frames,
                p.ms_median,
                p.model_ms,
                p.model_ms / p.ms_median
            );
        }
        s += &format!(
            "\nlargest model error over the points: {:.1} %\n",
            100.0 * self.worst_relative_error()
        );
        s
    }
}

/// How the probe runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeSettings {
    pub width: u32,
    pub height: u32,
    /// Screen area of the probe's triangles, pixels: the scene's
    /// [`Scene::pixel_weighted_triangle_area`] (`shvis bench`), the built-in house's by default.
    pub triangle_pixels: f64,
    pub warmup: u32,
    pub frames: u32,
}

/// Textures per lookup kind (as dx9 binds separate textures; arrays get as many layers):
/// every lookup of a probe point reads its own texture, as every per-texel group and table
/// of a technique is its own (repeated reads of one texture hit its cache and cost less).
const TEXTURES: u32 = 16;
/// Side of the probe's textures.
const TEXTURE_SIDE: u32 = 512;
/// Grid sides of the per-triangle points: small triangles (125, 55, 31 and 8 pixels at
/// 1280×800), as a scene's many small ones (pca12v25's 115k triangles are ≈ 7 pixels).
const TRIANGLE_GRIDS: [u32; 4] = [64, 96, 128, 256];
/// Grid sides (of [`TRIANGLE_GRIDS`]) over which the shader that reads every varying is
/// drawn too: the per-triangle cost of a varying.
pub const VARYING_GRIDS: [u32; 2] = [96, 256];
/// The varyings the probe's shaders can read (the scene vertex's 14 floats).
const MAX_PROBE_VARYINGS: u32 = 14;

/// The counts `kind`'s probe points are generated with (the lookups' from 1, as the rows
/// use 1–3 of many kinds).
pub fn probe_counts(kind: Kind) -> &'static [u32] {
    match kind {
        Kind::FloatOp => &[64, 128, 256, 512],
        Kind::Varying => &[2, 5, 9, MAX_PROBE_VARYINGS],
        Kind::UniformRead => &[32, 64, 128, 256],
        Kind::IndexedUniformRead => &[18, 36, 72, 144],
        Kind::TexelFetch => &[4, 8, 12, 16],
        Kind::TrilinearWide | Kind::TrilinearSrgb => &[1, 2, 4, 8],
        // No points of its own: the indexed reads' points enter one loop each.
        Kind::Loop => &[],
        _ => &[1, 2, 4, 8, 12, 16],
    }
}

/// Points faster than this get proportionally more frames (up to 20×) after the first round.
const CHEAP_POINT_MS: f64 = 40.0;
/// Interleaved rounds the timed frames are split into.
const PROBE_ROUNDS: u32 = 10;
/// A point the first fit misses by more than this (relative) is timed again.
const RETIME_ERROR: f64 = 0.08;
/// Batches a missed point is timed again in.
const RETIME_BATCHES: usize = 2;
/// A state with this share of the monitor frames gets a model: the points with fewer than
/// [`MIN_STATE_FRAMES`] in it are timed again.
const STATE_MODEL_SHARE: f64 = 0.1;
/// Frames in a state below which a point's median there is too few to fit (one run put the
/// 2·128² grid at 1.10× the model on 2 frames).
const MIN_STATE_FRAMES: usize = 5;
/// The untaken-branch points: indexed uniform reads (a cluster's block, as the clustered
/// techniques' boundary path reads them) in a branch that no lane takes.
pub const UNTAKEN_BRANCH_READS: &[u32] = &[32, 64, 128];
/// Uniform vec4s in the probe's block.
const UNIFORM_VEC4S: u32 = 256;

/// The probe's scene: a quad filling the screen (or its left half) from a camera at the
/// origin, split into `grid`² quads, lightmap UVs over [0, 1]² across it, material UVs at
/// ≈ 2.7 texels of a 512² map per pixel.
fn probe_scene(width: u32, height: u32, left_half: bool, grid: u32) -> Scene {
    let aspect = width as f32 / height as f32;
    let (x0, x1) = (-1.2 * aspect, if left_half { 0.0 } else { 1.2 * aspect });
    let material_scale = 2.7 * width as f32 / TEXTURE_SIDE as f32;
    let vertex = |x: f32, y: f32| {
        let lightmap = Vec2::new((x / aspect + 1.0) * 0.5, (1.0 - y) * 0.5);
        Vertex {
            position: [x, y, -1.0],
            normal: [0.0, 0.0, 1.0],
            tangent: [1.0, 0.0, 0.0, 1.0],
            uv_material: (lightmap * material_scale).to_array(),
            uv_lightmap: lightmap.to_array(),
            albedo_tint: [1.0; 3],
        }
    };
    // columns × grid quads, two triangles each; the left half keeps the quads' size. Grid 0:
    // one triangle of zero area (a frame that shades nothing).
    let columns = if left_half { grid / 2 } else { grid };
    let mut mesh = Mesh::default();
    if grid == 0 {
        mesh.vertices = vec![vertex(0.0, 0.0); 3];
        mesh.indices = vec![0, 1, 2];
    } else {
        for j in 0..=grid {
            for i in 0..=columns {
                let (fx, fy) = (i as f32 / columns as f32, j as f32 / grid as f32);
                mesh.vertices
                    .push(vertex(x0 + (x1 - x0) * fx, -1.2 + 2.4 * fy));
            }
        }
        for j in 0..grid {
            for i in 0..columns {
                let a = j * (columns + 1) + i;
                let (b, c, d) = (a + 1, a + columns + 2, a + columns + 1);
                mesh.indices.extend([a, b, c, a, c, d]);
            }
        }
    }
    Scene::flat_view("probe", mesh)
}

/// The GLSL of a probe point: `count` operations of `kind` (`None`: the empty shader), in
/// a branch that no lane takes where `untaken`; `counted`: the build whose SPIR-V is
/// counted (its loops unrolled, as the techniques' count builds), else the drawn one.
fn probe_source(kind: Option<Kind>, count: u32, untaken: bool, counted: bool) -> String {
    let t0 = "SHVIS_BINDING_TECHNIQUE_TEXTURE0";
    let mut decl = String::new();
    let mut body = String::new();
    let step = format!("{:.8}", 1.0 / TEXTURE_SIDE as f64);
    match kind {
        // Every technique reads at least its lightmap coordinates; a shader that reads no
        // varying can skip lavapipe's interpolation set-up (5.4 against 8.0 ms per screen
        // over 2·32² triangles at 1280×800 in one run), a path no technique takes.
        // (A loop's cost has no points of its own.)
        None | Some(Kind::Loop) => body += "    acc.xy = in_uv_lightmap;\n",
        Some(
            k @ (Kind::Bilinear2d | Kind::Trilinear2d | Kind::TrilinearWide | Kind::TrilinearSrgb),
        ) => {
            let uv = if k == Kind::Bilinear2d {
                "in_uv_lightmap"
            } else {
                "in_uv_material"
            };
            decl = format!(
                "layout(set = 0, binding = {t0}) uniform sampler2D probe_tex[{TEXTURES}];\n"
            );
            for k in 0..count {
                body += &format!(
                    "    acc += texture(probe_tex[{}], {uv} + vec2({} * {step}, 0.0));\n",
                    k % TEXTURES,
                    k / TEXTURES
                );
            }
        }
        Some(Kind::TexelFetch) => {
            decl = format!(
                "layout(set = 0, binding = {t0}) uniform sampler2D probe_tex[{TEXTURES}];\n"
            );
            body += &format!(
                "    ivec2 texel = clamp(ivec2(in_uv_lightmap * {TEXTURE_SIDE}.0), ivec2(0), ivec2({}));\n",
                TEXTURE_SIDE - 2
            );
            for k in 0..count {
                body += &format!(
                    "    acc += texelFetch(probe_tex[{}], texel + ivec2({}, {}), 0);\n",
                    (k / 4) % TEXTURES,
                    k & 1,
                    (k >> 1) & 1
                );
            }
        }
        Some(Kind::Array2d) => {
            decl = format!("layout(set = 0, binding = {t0}) uniform sampler2DArray probe_tex;\n");
            for k in 0..count {
                body += &format!(
                    "    acc += texture(probe_tex, vec3(in_uv_lightmap + vec2({} * {step}, 0.0), {}.0));\n",
                    k / TEXTURES,
                    k % TEXTURES
                );
            }
        }
        Some(Kind::CubeArray) => {
            decl = format!("layout(set = 0, binding = {t0}) uniform samplerCubeArray probe_tex;\n");
            body += "    vec3 d = vec3(in_uv_lightmap * 2.0 - 1.0, 1.0);\n";
            for k in 0..count {
                body += &format!(
                    "    acc += texture(probe_tex, vec4(d + vec3({} * {step}), {}.0));\n",
                    k / TEXTURES,
                    k % TEXTURES
                );
            }
        }
        Some(Kind::Dependent2d) => {
            decl = format!(
                "layout(set = 0, binding = {t0}) uniform sampler2D probe_tex[{TEXTURES}];\n"
            );
            body += "    vec2 c = in_uv_lightmap;\n";
            for k in 0..count {
                body += &format!(
                    "    {{ vec4 s = texture(probe_tex[{}], c); c += (s.xy - 0.5) * {step}; acc += s; }}\n",
                    k % TEXTURES
                );
            }
        }
        Some(Kind::FloatOp) => {
            // Four independent vec4 chains of fma(v, m, b): 16 float ops per round. m and b
            // come from the lightmap coordinates, which no compiler can fold; read from the
            // uniform block, they tied the uniform read's cost to these points, where two
            // reads cost far less than two of a long run of reads.
            body += "    vec4 m = vec4(0.999) + in_uv_lightmap.xyxy * 1e-6, b = in_uv_lightmap.yxyx * 1e-3;\n";
            body += "    vec4 c0 = vec4(in_uv_lightmap, 0.0, 1.0), c1 = c0.yxzw, c2 = c0.xxyy, c3 = c0.yyxx;\n";
            for _ in 0..count.div_ceil(16) {
                body += "    c0 = fma(c0, m, b); c1 = fma(c1, m, b); c2 = fma(c2, m, b); c3 = fma(c3, m, b);\n";
            }
            body += "    acc = c0 + c1 + c2 + c3;\n";
        }
        Some(Kind::Varying) => {
            let floats: [&str; MAX_PROBE_VARYINGS as usize] = [
                "in_normal_world.x",
                "in_normal_world.y",
                "in_normal_world.z",
                "in_tangent_world.x",
                "in_tangent_world.y",
                "in_tangent_world.z",
                "in_tangent_world.w",
                "in_uv_material.x",
                "in_uv_material.y",
                "in_uv_lightmap.x",
                "in_uv_lightmap.y",
                "in_albedo_tint.x",
                "in_albedo_tint.y",
                "in_albedo_tint.z",
            ];
            for f in floats.iter().take(count as usize) {
                body += &format!("    acc.x += {f};\n");
            }
        }
        Some(Kind::UniformRead) => {
            decl = format!(
                "layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform Probe {{ vec4 v[{UNIFORM_VEC4S}]; }} probe;\n"
            );
            // The lightmap coordinates read as every technique reads them: a shader that
            // reads no varying skips lavapipe's interpolation set-up, and without them these
            // points ran 1.7 ms under the empty shader's base (their reads, 0.62–0.66 ms
            // each, were fitted at 0.52–0.56).
            body += "    acc.xy = in_uv_lightmap;\n";
            for k in 0..count.min(UNIFORM_VEC4S) {
                body += &format!("    acc += probe.v[{k}];\n");
            }
        }
        Some(Kind::IndexedUniformRead) => {
            decl = format!(
                "layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform Probe {{ vec4 v[{UNIFORM_VEC4S}]; }} probe;\n"
            );
            // A base that varies across the screen, as a cluster id does between texels.
            body += "    int base = int(in_uv_lightmap.x * 8.0) & 7;\n";
            if untaken {
                // Straight-line (a loop no lane enters is skipped, `CostModel::untaken_share`).
                for k in 0..count.min(UNIFORM_VEC4S - 8) {
                    body += &format!("    acc += probe.v[base + {k}];\n");
                }
            } else {
                // As a cluster decode reads them: a loop over blocks of 9, each read's RGB
                // scaled and summed (cluster.frag's `block_dot`), kept a loop where drawn and
                // unrolled where counted.
                let blocks = count.min(UNIFORM_VEC4S - 8) / 9;
                let attribute = if counted { "unroll" } else { "dont_unroll" };
                body += "    vec3 e = vec3(0.0);\n    float y = in_uv_lightmap.y;\n";
                body += &format!(
                    "    [[{attribute}]] for (int k = 0; k < {blocks}; ++k) {{\n        int at = base + 9 * k;\n"
                );
                for i in 0..9 {
                    body += &format!("        e += probe.v[at + {i}].rgb * y;\n");
                }
                body += "    }\n    acc.rgb += e;\n";
            }
        }
    }
    if untaken {
        // Lightmap coordinates are never below 0: no lane takes it, and no compiler knows.
        body = format!("    if (in_uv_lightmap.x < -1.0) {{\n{body}    }}\n");
    }
    fragment_shader(&decl, &body)
}

/// A probe fragment shader: `decl` after the shared interface (`common.glsl`), `body` adding
/// into `vec4 acc`, which it writes out scaled down (so nothing is dead code).
fn fragment_shader(decl: &str, body: &str) -> String {
    format!(
        "#version 450\n#extension GL_GOOGLE_include_directive : require\n\
         #extension GL_EXT_control_flow_attributes : require\n#define SHVIS_FRAGMENT 1\n\
         #include \"common.glsl\"\n{decl}layout(location = 0) out vec4 out_color;\n\
         void main() {{\n    vec4 acc = vec4(0.0);\n{body}    out_color = vec4(acc.rgb * 1e-3 + 0.5, 1.0);\n}}\n"
    )
}

/// The probe's textures and uniform block.
struct ProbeResources {
    bilinear: Vec<Image>,
    /// For the dependent lookups: the size of a dx9 table strip (9 spheres of 2 × 32²).
    tables: Vec<Image>,
    trilinear: Vec<Image>,
    trilinear_wide: Vec<Image>,
    trilinear_srgb: Vec<Image>,
    array: Image,
    cube_array: Image,
    uniforms: Buffer,
}

fn probe_resources(ctx: &Arc<Context>) -> Result<ProbeResources, GpuError> {
    let side = TEXTURE_SIDE;
    // A smooth pseudo-random pattern (RGBA16F halves, RGBA8 bytes).
    let value = |i: u32, x: u32, y: u32| -> f32 {
        let h = crate::bake::directions::splitmix64(
            u64::from(i) << 40 | u64::from(y) << 20 | u64::from(x),
        );
        crate::bake::directions::unit_f64(h) as f32
    };
    let halves = |i: u32, s: u32| -> Vec<u8> {
        (0..s * s * 4)
            .flat_map(|j| half::f16::from_f32(value(i, j % (s * 4), j / (s * 4))).to_le_bytes())
            .collect()
    };
    let f16 = vk::Format::R16G16B16A16_SFLOAT;
    let bilinear = (0..TEXTURES)
        .map(|i| {
            let data = halves(i, side);
            Image::with_data(
                ctx,
                &ImageDesc::texture_2d(f16, side, side),
                &[vec![data.as_slice()]],
                &format!("probe.bilinear{i}"),
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    let (table_w, table_h) = (9 * 2 * 32, 32);
    let tables = (0..TEXTURES)
        .map(|i| {
            let data: Vec<u8> = (0..table_w * table_h * 4)
                .flat_map(|j| {
                    half::f16::from_f32(value(i, j % (table_w * 4), j / (table_w * 4)))
                        .to_le_bytes()
                })
                .collect();
            Image::with_data(
                ctx,
                &ImageDesc::texture_2d(f16, table_w, table_h),
                &[vec![data.as_slice()]],
                &format!("probe.table{i}"),
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    // The same texels, as RGBA8 (material textures: the normal map's UNORM, the albedo's
    // sRGB) and as RGBA32F (NDF moment maps).
    let mip_chains = |format: vk::Format, name: &str| {
        let wide = format == crate::ndf::MOMENT_FORMAT;
        (0..TEXTURES)
            .map(|i| {
                let texels: Vec<[f32; 4]> = (0..side * side)
                    .map(|j| std::array::from_fn(|c| value(i, (j % side) * 4 + c as u32, j / side)))
                    .collect();
                let levels = crate::scene::mip::box_mip_levels(side, side, texels);
                let bytes: Vec<Vec<u8>> = levels
                    .iter()
                    .map(|(_, _, t)| {
                        if wide {
                            bytemuck::cast_slice(t).to_vec()
                        } else {
                            t.iter()
                                .flat_map(|p| p.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8))
                                .collect()
                        }
                    })
                    .collect();
                let data: Vec<Vec<&[u8]>> = bytes.iter().map(|b| vec![b.as_slice()]).collect();
                Image::with_data(
                    ctx,
                    &ImageDesc::texture_2d(format, side, side).mip_levels(levels.len() as u32),
                    &data,
                    &format!("probe.{name}{i}"),
                )
            })
            .collect::<Result<Vec<_>, _>>()
    };
    let trilinear = mip_chains(vk::Format::R8G8B8A8_UNORM, "trilinear")?;
    let trilinear_wide = mip_chains(crate::ndf::MOMENT_FORMAT, "trilinear_wide")?;
    let trilinear_srgb = mip_chains(vk::Format::R8G8B8A8_SRGB, "trilinear_srgb")?;
    let layers: Vec<Vec<u8>> = (0..TEXTURES).map(|i| halves(i, side)).collect();
    let array = Image::with_data(
        ctx,
        &ImageDesc::texture_2d_array(f16, side, side, TEXTURES),
        &[layers.iter().map(Vec::as_slice).collect()],
        "probe.array",
    )?;
    let cube_side = 32;
    let faces: Vec<Vec<u8>> = (0..6 * TEXTURES).map(|i| halves(i, cube_side)).collect();
    let cube_array = Image::with_data(
        ctx,
        &ImageDesc::texture_cube_array(f16, cube_side, TEXTURES),
        &[faces.iter().map(Vec::as_slice).collect()],
        "probe.cube_array",
    )?;
    let block: Vec<f32> = (0..UNIFORM_VEC4S * 4)
        .map(|i| if i < 4 { 0.999 } else { 1e-3 * (i % 7) as f32 })
        .collect();
    let uniforms = Buffer::with_data(
        ctx,
        bytemuck::cast_slice(&block),
        vk::BufferUsageFlags::UNIFORM_BUFFER,
        "probe.uniforms",
    )?;
    Ok(ProbeResources {
        bilinear,
        tables,
        trilinear,
        trilinear_wide,
        trilinear_srgb,
        array,
        cube_array,
        uniforms,
    })
}

/// Runs the probe (module doc).
///
/// # Errors
/// Vulkan or shader failures, and a fit that is not finite (a device whose timings are
/// all zero).
pub fn run(ctx: &Arc<Context>, s: &ProbeSettings) -> Result<Probe, GpuError> {
    run_with_monitor(ctx, s).map(|(probe, _)| probe)
}

/// [`run`], keeping its [`Monitor`].
pub fn run_with_monitor(
    ctx: &Arc<Context>,
    s: &ProbeSettings,
) -> Result<(Probe, Monitor), GpuError> {
    let started = std::time::Instant::now();
    let base = base_grid(s.width, s.height, s.triangle_pixels);
    let gpu = probe_target(ctx, s, base)?;
    let nothing_mesh = upload_probe_mesh(ctx, s, false, 0)?;
    let full_mesh = upload_probe_mesh(ctx, s, false, base)?;
    let half_mesh = upload_probe_mesh(ctx, s, true, base)?;
    let grids = TRIANGLE_GRIDS
        .iter()
        .map(|&g| upload_probe_mesh(ctx, s, false, g))
        .collect::<Result<Vec<_>, _>>()?;
    let (res, linear) = point_resources(ctx)?;
    let planner = PointPlanner {
        ctx,
        gpu: &gpu,
        res: &res,
        linear: &linear,
        pixels: f64::from(s.width) * f64::from(s.height),
        loads: shading_loads(
            ctx,
            &gpu,
            [&nothing_mesh, &full_mesh, &half_mesh]
                .into_iter()
                .chain(&grids),
        )?,
    };
    let screen_fragments = planner.load_of(&full_mesh.0).map_or(0, |l| l.fragments);

    // Every point's pipeline first, then the timed frames in interleaved rounds.
    let specs = point_specs(ctx, &nothing_mesh.0, &full_mesh.0, &half_mesh.0, &grids);
    let mut planned = specs
        .into_iter()
        .map(|(kind, count, untaken, depth_test, mesh)| {
            let (point, pipeline) = planner.plan(kind, count, untaken, depth_test, mesh)?;
            Ok(Planned {
                point,
                pipeline,
                build: 0,
                mesh,
            })
        })
        .collect::<Result<Vec<_>, GpuError>>()?;
    let batches = Batches::new(&gpu, s, &planned, &full_mesh.0)?;
    let all: Vec<usize> = (0..planned.len()).collect();
    let (mut timed, mut monitor) =
        batches.time_batch(&planned, &all, &vec![f64::NAN; planned.len()])?;
    let mut states = DeviceStates::from_monitor(&monitor);
    let mut points: Vec<ProbePoint> = planned.iter().map(|p| p.point.clone()).collect();
    measure(&mut points, &timed, &states, states.main_state);
    let mut model = fit_points(ctx, &points)?;
    // A point the fit misses by more than RETIME_ERROR, or with fewer than MIN_STATE_FRAMES
    // frames in a state that held at least STATE_MODEL_SHARE of the monitor frames, is
    // timed in RETIME_BATCHES more batches, each on a pipeline built afresh (a build can run
    // a shader ≈ 25 % slower than another for as long as it lives, `states`); its segments
    // join the first ones, each point's time is its fastest build's, and the states are
    // told apart again over every monitor frame.
    let missed = missed_points(&model, &points, &timed, &states);
    if !missed.is_empty() {
        retime(
            &planner,
            &batches,
            &mut planned,
            &missed,
            &points,
            &mut timed,
            &mut monitor,
        )?;
        states = DeviceStates::from_monitor(&monitor);
        measure(&mut points, &timed, &states, states.main_state);
        for &i in &missed {
            points[i].batches = 1 + RETIME_BATCHES as u32;
        }
        model = fit_points(ctx, &points)?;
    }
    let model = main_model(ctx, &mut states, &mut points, &timed, model)?;
    for p in &mut points {
        p.model_ms = predict_point(&model, p);
    }
    let state_models = state_models(ctx, &model, &points, &timed, &states)?;
    let monitor_pipeline = planned.swap_remove(batches.monitor_index).pipeline;
    drop(planned);
    let probe = Probe {
        device: ctx.device_name().to_string(),
        width: s.width,
        height: s.height,
        frames: batches.rounds * batches.per_round,
        screen_fragments,
        triangle_pixels: s.triangle_pixels,
        grid: base,
        model,
        states: states.clone(),
        state_models,
        points,
        seconds: started.elapsed().as_secs_f64(),
        measured_at: cache::utc_now(),
        reused_from: None,
    };
    let monitor = Monitor {
        pipeline: monitor_pipeline,
        mesh: full_mesh.0,
        _resources: res,
        _linear: linear,
        gpu,
        states,
    };
    Ok((probe, monitor))
}

/// The monitor of a probe measured before (`states` its speed states), built alone: the
/// empty shader over the screen of `s`'s grid, as [`run_with_monitor`] builds it.
pub fn monitor(
    ctx: &Arc<Context>,
    s: &ProbeSettings,
    states: DeviceStates,
) -> Result<Monitor, GpuError> {
    let base = base_grid(s.width, s.height, s.triangle_pixels);
    let gpu = probe_target(ctx, s, base)?;
    let full_mesh = upload_probe_mesh(ctx, s, false, base)?;
    let (res, linear) = point_resources(ctx)?;
    let planner = PointPlanner {
        ctx,
        gpu: &gpu,
        res: &res,
        linear: &linear,
        pixels: f64::from(s.width) * f64::from(s.height),
        loads: shading_loads(ctx, &gpu, std::iter::once(&full_mesh))?,
    };
    let (_, pipeline) = planner.plan(None, 0, false, true, &full_mesh.0)?;
    Ok(Monitor {
        pipeline,
        mesh: full_mesh.0,
        _resources: res,
        _linear: linear,
        gpu,
        states,
    })
}

/// The probe's scene on the GPU at `s`'s size, over a `base`² grid of triangle pairs.
fn probe_target(ctx: &Arc<Context>, s: &ProbeSettings, base: u32) -> Result<SceneGpu, GpuError> {
    SceneGpu::new(
        ctx,
        &probe_scene(s.width, s.height, false, base),
        &FrameSettings {
            width: s.width,
            height: s.height,
            ..FrameSettings::default()
        },
    )
}

/// The textures and uniforms every probe point binds, and the lightmap-like sampler.
fn point_resources(ctx: &Arc<Context>) -> Result<(ProbeResources, Sampler), GpuError> {
    Ok((
        probe_resources(ctx)?,
        Sampler::new(ctx, SamplerKind::LinearClamp, "probe.linear")?,
    ))
}

/// Uploads the probe's mesh over the screen (or its left half) with a `grid`² grid of
/// triangle pairs (0: the mesh that shades nothing).
fn upload_probe_mesh(
    ctx: &Arc<Context>,
    s: &ProbeSettings,
    left_half: bool,
    grid: u32,
) -> Result<(MeshBuffers, Mesh), GpuError> {
    let m = probe_scene(s.width, s.height, left_half, grid).mesh;
    let buffers = MeshBuffers::new(
        ctx,
        bytemuck::cast_slice(&m.vertices),
        &m.indices,
        &format!("probe.mesh{}{grid}", if left_half { ".half" } else { "" }),
    )?;
    Ok((buffers, m))
}

/// The shading load of each of `meshes`, keyed by its buffers' address.
fn shading_loads<'m>(
    ctx: &Arc<Context>,
    gpu: &SceneGpu,
    meshes: impl Iterator<Item = &'m (MeshBuffers, Mesh)>,
) -> Result<Vec<(*const MeshBuffers, ShadingLoad)>, GpuError> {
    let mut loads = Vec::new();
    for (buffers, m) in meshes {
        let load = gpu.shading_load(ctx, Some((buffers, m)))?;
        loads.push((buffers as *const MeshBuffers, load));
    }
    Ok(loads)
}

/// What a probe point is drawn as: its kind (`None`: the empty shader), operation count,
/// whether they sit in an untaken branch, whether the depth test is on, and its mesh.
type PointSpec<'m> = (Option<Kind>, u32, bool, bool, &'m MeshBuffers);

/// Every probe point (module doc), in the order they are built and timed.
fn point_specs<'m>(
    ctx: &Arc<Context>,
    nothing_mesh: &'m MeshBuffers,
    full_mesh: &'m MeshBuffers,
    half_mesh: &'m MeshBuffers,
    grids: &'m [(MeshBuffers, Mesh)],
) -> Vec<PointSpec<'m>> {
    let mut specs: Vec<PointSpec<'m>> = vec![
        (None, 0, false, true, nothing_mesh),
        (None, 0, false, true, full_mesh),
        (None, 0, false, true, half_mesh),
        (None, 0, false, false, full_mesh),
    ];
    specs.extend(grids.iter().map(|g| (None, 0, false, true, &g.0)));
    // A device that cannot filter RGBA32F (optional in Vulkan) gets no such points: its
    // cost stays 0 (and the NDF rows, which need it, refuse to build there).
    let wide_filters = ctx.supports_linear_filter(crate::ndf::MOMENT_FORMAT);
    for kind in Kind::ALL
        .into_iter()
        .filter(|&k| k != Kind::TrilinearWide || wide_filters)
    {
        for &count in probe_counts(kind) {
            specs.push((Some(kind), count, false, true, full_mesh));
        }
    }
    for (g, _) in grids
        .iter()
        .zip(TRIANGLE_GRIDS)
        .filter(|(_, side)| VARYING_GRIDS.contains(side))
    {
        specs.push((Some(Kind::Varying), MAX_PROBE_VARYINGS, false, true, &g.0));
    }
    for &count in UNTAKEN_BRANCH_READS {
        specs.push((Some(Kind::IndexedUniformRead), count, true, true, full_mesh));
    }
    specs
}

/// A probe point with its pipeline, ready to time.
struct Planned<'m> {
    point: ProbePoint,
    pipeline: crate::gpu::MeshPipeline,
    /// How many times `pipeline` was rebuilt (`states`: builds differ).
    build: usize,
    mesh: &'m MeshBuffers,
}

/// What building a probe point's pipeline needs: the probe scene's GPU state, the textures
/// and samplers the points read, and the shading load of each mesh.
struct PointPlanner<'a> {
    ctx: &'a Arc<Context>,
    gpu: &'a SceneGpu,
    res: &'a ProbeResources,
    linear: &'a Sampler,
    /// Screen pixels, what a mesh's busy lanes are divided by.
    pixels: f64,
    /// Lanes per screen pixel of each mesh: the coverage the model's per-pixel costs
    /// multiply ([`shading_loads`]).
    loads: Vec<(*const MeshBuffers, ShadingLoad)>,
}

impl<'a> PointPlanner<'a> {
    /// The shading load of `mesh` (one of those the planner was given).
    fn load_of(&self, mesh: &MeshBuffers) -> Option<ShadingLoad> {
        self.loads
            .iter()
            .find(|(m, _)| std::ptr::eq(*m, mesh))
            .map(|(_, l)| *l)
    }

    /// Compiles a probe point's shader, counts its operations and builds its pipeline
    /// over `mesh`; the point's timings are still to be taken.
    fn plan(
        &self,
        kind: Option<Kind>,
        count: u32,
        untaken: bool,
        depth_test: bool,
        mesh: &MeshBuffers,
    ) -> Result<(ProbePoint, crate::gpu::MeshPipeline), GpuError> {
        let name = format!(
            "probe.{}{count}{}",
            kind.map_or("empty".to_string(), |k| format!("{k:?}").to_lowercase()),
            if untaken { ".untaken" } else { "" }
        );
        let compile = |count, counted| {
            crate::gpu::shader::compile_source(
                &format!("{name}.frag"),
                &probe_source(kind, count, untaken, counted),
                ShaderStage::Fragment,
                &[],
            )
        };
        let spirv = compile(count, false)?;
        // Operations per pixel from the build with every loop unrolled (the drawn one where
        // it has no loop to unroll), loops entered from the drawn one.
        let drawn = spirv::count(&spirv);
        let unrolled = if probe_source(kind, count, untaken, true)
            == probe_source(kind, count, untaken, false)
        {
            drawn
        } else {
            spirv::count(&compile(count, true)?)
        };
        let ops = OpCounts {
            kept_loops: drawn.kept_loops,
            ..unrolled
        };
        let resources = self.point_resources(kind);
        let pipeline = self
            .gpu
            .mesh_pipeline_with_depth(self.ctx, &name, &spirv, &resources, depth_test)?;
        // SPIR-V counts both sides of a branch: the untaken work is what the point counts
        // beyond the same shader with none of the operations.
        let all = CostCounts::new(&lookups_of(kind, count), &ops);
        let untaken_counts = if untaken {
            all.less(&CostCounts::new(&[], &spirv::count(&compile(0, true)?)))
        } else {
            CostCounts::default()
        };
        let point = ProbePoint {
            kind,
            count,
            coverage: self.load_of(mesh).map_or(0.0, |l| l.lanes / self.pixels),
            triangles: mesh.triangle_count(),
            edge_pixels: self.load_of(mesh).map_or(0.0, |l| l.edge_pixels),
            depth_test,
            in_untaken_branch: untaken,
            counts: all.less(&untaken_counts),
            untaken: untaken_counts,
            ms_median: f64::NAN,
            batches: 1,
            frames: 0,
            state_frames: 0,
            model_ms: f64::NAN,
        };
        Ok((point, pipeline))
    }

    /// What a point of `kind` binds: the scene's common resources, the uniform block and
    /// the textures its lookups read.
    fn point_resources(&self, kind: Option<Kind>) -> Vec<(u32, Resource<'a>)> {
        let (res, linear, material) = (self.res, self.linear, self.gpu.material_sampler());
        let mut resources = self.gpu.common_resources();
        resources.push((
            layout::BINDING_TECHNIQUE_PARAMS,
            Resource::Uniform(&res.uniforms),
        ));
        let t0 = layout::BINDING_TECHNIQUE_TEXTURE0;
        match kind {
            Some(Kind::Bilinear2d | Kind::TexelFetch) => resources.push((
                t0,
                Resource::TextureArray(res.bilinear.iter().map(|i| (i, linear)).collect()),
            )),
            Some(Kind::Dependent2d) => resources.push((
                t0,
                Resource::TextureArray(res.tables.iter().map(|i| (i, linear)).collect()),
            )),
            Some(Kind::Trilinear2d) => resources.push((
                t0,
                Resource::TextureArray(res.trilinear.iter().map(|i| (i, material)).collect()),
            )),
            Some(Kind::TrilinearWide) => resources.push((
                t0,
                Resource::TextureArray(res.trilinear_wide.iter().map(|i| (i, material)).collect()),
            )),
            Some(Kind::TrilinearSrgb) => resources.push((
                t0,
                Resource::TextureArray(res.trilinear_srgb.iter().map(|i| (i, material)).collect()),
            )),
            Some(Kind::Array2d) => resources.push((t0, Resource::Texture(&res.array, linear))),
            Some(Kind::CubeArray) => {
                resources.push((t0, Resource::Texture(&res.cube_array, linear)));
            }
            _ => {}
        }
        resources
    }
}

/// The texture lookups a point of `kind` makes: `count` of its kind where it is a lookup.
fn lookups_of(kind: Option<Kind>, count: u32) -> Vec<(Kind, u32)> {
    match kind {
        Some(
            k @ (Kind::Bilinear2d
            | Kind::TexelFetch
            | Kind::Trilinear2d
            | Kind::TrilinearWide
            | Kind::TrilinearSrgb
            | Kind::Array2d
            | Kind::CubeArray
            | Kind::Dependent2d),
        ) => {
            vec![(k, count)]
        }
        _ => vec![],
    }
}

/// How the points' frames are taken: in `rounds` interleaved rounds of `per_round` frames
/// each (module doc), with a frame of the monitor point after each point's frames.
struct Batches<'a> {
    gpu: &'a SceneGpu,
    warmup: u32,
    rounds: u32,
    per_round: u32,
    /// The planned point that monitors the device: the empty shader over the screen.
    monitor_index: usize,
}

impl<'a> Batches<'a> {
    /// The rounds for `s`'s frames, and the monitor among `planned` (its mesh `screen`).
    ///
    /// # Errors
    /// No empty-shader point over the screen among `planned`.
    fn new(
        gpu: &'a SceneGpu,
        s: &ProbeSettings,
        planned: &[Planned],
        screen: &MeshBuffers,
    ) -> Result<Self, GpuError> {
        // A slow drift of the device (another tenant, clocks) would otherwise land on
        // whichever points ran during it; in rounds it spreads over all of them and the
        // median drops it. The faster switches between speed states are told apart by the
        // monitor (`states`).
        let rounds = s.frames.clamp(1, PROBE_ROUNDS);
        let per_round = s.frames.div_ceil(rounds);
        let monitor_index = planned
            .iter()
            .position(|p| {
                p.point.kind.is_none() && p.point.depth_test && std::ptr::eq(p.mesh, screen)
            })
            .ok_or_else(|| GpuError::Invalid {
                what: "probe".into(),
                detail: "no empty-shader point over the screen to monitor the device with".into(),
            })?;
        Ok(Batches {
            gpu,
            warmup: s.warmup,
            rounds,
            per_round,
            monitor_index,
        })
    }

    /// One monitor frame (`monitor_frame`) of the monitor point, ms.
    fn read_monitor(&self, planned: &[Planned]) -> Result<f64, GpuError> {
        let m = &planned[self.monitor_index];
        monitor_frame(self.gpu, &m.pipeline, m.mesh)
    }

    /// One batch: the timed frames of the points `which`, in interleaved rounds, a monitor
    /// frame after each point's frames; returns their segments and the monitor frames.
    /// Cheap points get more frames (a millisecond of jitter is 10 % of them), scaled by a
    /// known median or, failing that, by the batch's first round.
    fn time_batch(
        &self,
        planned: &[Planned],
        which: &[usize],
        known_ms: &[f64],
    ) -> Result<(Vec<Segmented>, Vec<f64>), GpuError> {
        let mut timed = vec![Segmented::default(); which.len()];
        let mut before = self.read_monitor(planned)?;
        let mut monitor = vec![before];
        for round in 0..self.rounds {
            let warmup = if round == 0 {
                self.warmup
            } else {
                self.warmup.min(1)
            };
            for (&i, t) in which.iter().zip(&mut timed) {
                let ms = if known_ms[i].is_finite() {
                    Some(known_ms[i])
                } else if round > 0 {
                    TimingStats::from_ms(&t.all()).map(|first| first.ms_median)
                } else {
                    None
                };
                let frames = match ms {
                    Some(ms) => {
                        let scale = (CHEAP_POINT_MS / ms).clamp(1.0, 20.0);
                        (f64::from(self.per_round) * scale).round() as u32
                    }
                    None => self.per_round,
                };
                let p = &planned[i];
                let got = self
                    .gpu
                    .time_pipeline_on(&p.pipeline, p.mesh, warmup, frames)?;
                let after = self.read_monitor(planned)?;
                t.push(p.build, before, got, after);
                monitor.push(after);
                before = after;
            }
        }
        Ok((timed, monitor))
    }
}

/// Each point at the median of its frames in `state`, of its fastest build there (of all
/// its frames where none ran in it: `state_frames` 0).
fn measure(points: &mut [ProbePoint], timed: &[Segmented], states: &DeviceStates, state: usize) {
    for (p, t) in points.iter_mut().zip(timed) {
        let (median, in_state) = t.median_in(states, state);
        p.ms_median = median
            .or_else(|| t.fastest_build_median())
            .unwrap_or(f64::NAN);
        p.frames = t.all().len();
        p.state_frames = in_state;
    }
}

/// [`fit`], an error where the timings fit no model.
fn fit_points(ctx: &Context, points: &[ProbePoint]) -> Result<CostModel, GpuError> {
    fit(points).ok_or_else(|| GpuError::Invalid {
        what: "probe".into(),
        detail: format!("{}: the timings do not fit a cost model", ctx.device_name()),
    })
}

/// The points to time again (`run_with_monitor`): those `model` misses, and those with
/// too few frames in a state that held a good share of the monitor frames.
fn missed_points(
    model: &CostModel,
    points: &[ProbePoint],
    timed: &[Segmented],
    states: &DeviceStates,
) -> Vec<usize> {
    (0..points.len())
        .filter(|&i| {
            let p = &points[i];
            let predicted = predict_point(model, p);
            let unseen = (0..states.count()).any(|state| {
                states.shares[state] >= STATE_MODEL_SHARE
                    && timed[i].ran_in(states, state).len() < MIN_STATE_FRAMES
            });
            unseen || (predicted - p.ms_median).abs() > RETIME_ERROR * p.ms_median
        })
        .collect()
}

/// Times the `missed` points in RETIME_BATCHES more batches, each on pipelines built
/// afresh; their segments join theirs in `timed`, the batches' monitor frames `monitor`.
fn retime(
    planner: &PointPlanner,
    batches: &Batches,
    planned: &mut [Planned],
    missed: &[usize],
    points: &[ProbePoint],
    timed: &mut [Segmented],
    monitor: &mut Vec<f64>,
) -> Result<(), GpuError> {
    let known: Vec<f64> = points.iter().map(|p| p.ms_median).collect();
    for _ in 0..RETIME_BATCHES {
        for &i in missed {
            let p = &planned[i];
            let (_, pipeline) = planner.plan(
                p.point.kind,
                p.point.count,
                p.point.in_untaken_branch,
                p.point.depth_test,
                p.mesh,
            )?;
            planned[i].pipeline = pipeline;
            planned[i].build += 1;
        }
        let (batch, batch_monitor) = batches.time_batch(planned, missed, &known)?;
        for (&i, t) in missed.iter().zip(batch) {
            timed[i].0.extend(t.0);
        }
        monitor.extend(batch_monitor);
    }
    Ok(())
}

/// The main model: the fastest state that every point has frames in — the device least
/// disturbed by its neighbours (in the slower state of this VM texture lookups cost
/// more the more a shader makes: 16 bilinear lookups 0.90× the model where 4 are 1.10×,
/// a shared memory bus by the look of it) — else the state most monitor frames fell in.
/// Makes that state `states.main_state` and measures and fits `points` there where it is
/// not already; else returns `model`.
fn main_model(
    ctx: &Context,
    states: &mut DeviceStates,
    points: &mut [ProbePoint],
    timed: &[Segmented],
    model: CostModel,
) -> Result<CostModel, GpuError> {
    let fastest_seen = (0..states.count()).find(|&state| every_point_ran_in(timed, states, state));
    if let Some(fastest) = fastest_seen.filter(|&f| f != states.main_state) {
        states.main_state = fastest;
        measure(points, timed, states, fastest);
        return fit_points(ctx, points);
    }
    Ok(model)
}

/// Whether every point has frames in `state`.
fn every_point_ran_in(timed: &[Segmented], states: &DeviceStates, state: usize) -> bool {
    timed
        .iter()
        .all(|t| t.0.iter().any(|s| states.ran_in(s, state)))
}

/// A model per state that every point has frames in (`model` for the main state): the
/// bench compares a row's frames in a state with that state's model.
fn state_models(
    ctx: &Context,
    model: &CostModel,
    points: &[ProbePoint],
    timed: &[Segmented],
    states: &DeviceStates,
) -> Result<Vec<StateModel>, GpuError> {
    let mut state_models = Vec::new();
    for state in 0..states.count() {
        if state == states.main_state {
            state_models.push(StateModel::new(state, model.clone(), points));
        } else if every_point_ran_in(timed, states, state) {
            let mut in_state = points.to_vec();
            measure(&mut in_state, timed, states, state);
            let state_model = fit_points(ctx, &in_state)?;
            for p in &mut in_state {
                p.model_ms = predict_point(&state_model, p);
            }
            state_models.push(StateModel::new(state, state_model, &in_state));
        }
    }
    Ok(state_models)
}

/// The probe's monitor point (the empty shader over the screen), kept past the probe for
/// `shvis bench` to read between every few frames of its rows, so that they are compared
/// with the model of the state they ran in (`states`).
pub struct Monitor {
    pipeline: crate::gpu::MeshPipeline,
    mesh: MeshBuffers,
    /// What the pipeline's descriptor set refers to (every probe point binds the uniforms).
    _resources: ProbeResources,
    _linear: Sampler,
    gpu: SceneGpu,
    /// The states the probe told apart.
    pub states: DeviceStates,
}

impl Monitor {
    /// One monitor frame now, ms (NaN without timestamps).
    pub fn read(&self) -> Result<f64, GpuError> {
        monitor_frame(&self.gpu, &self.pipeline, &self.mesh)
    }
}

/// A monitor reading: one untimed frame of `pipeline` over `mesh` (the first frame after
/// heavy work runs slow, `states`), then one timed, ms (NaN without timestamps).
fn monitor_frame(
    gpu: &SceneGpu,
    pipeline: &crate::gpu::MeshPipeline,
    mesh: &MeshBuffers,
) -> Result<f64, GpuError> {
    let ms = gpu.time_pipeline_on(pipeline, mesh, 1, 1)?;
    Ok(ms.first().copied().unwrap_or(f64::NAN))
}

/// The model's time for a probe point (its depth test's part taken off where it is off).
fn predict_point(model: &CostModel, p: &ProbePoint) -> f64 {
    let depth_off = if p.depth_test {
        0.0
    } else {
        model.depth_test_ms
    };
    let counts = model.with_untaken(&p.counts, &p.untaken);
    model.predict(&counts, p.coverage, p.triangles, p.edge_pixels) - p.coverage * depth_off
}

/// Side of the grid whose triangles cover `triangle_pixels` each on a `width` × `height`
/// screen (the grid spans 1.2 × the view each way), even so that the half screen halves it.
fn base_grid(width: u32, height: u32, triangle_pixels: f64) -> u32 {
    let cells = 0.5 * 1.44 * f64::from(width) * f64::from(height) / triangle_pixels.max(1.0);
    let half = (0.5 * cells.sqrt()).round().clamp(1.0, 128.0) as u32;
    2 * half
}

/// Minimax fit of the model (module doc) to the points: the costs, none below zero, and the
/// untaken-branch share that make the largest relative error over the points least.
fn fit(points: &[ProbePoint]) -> Option<CostModel> {
    // Unknowns: fixed, the per-triangle and per-edge-pixel costs, p, the depth test's part
    // d, the per-triangle cost of a varying c_TV, then c_k; t = fixed + T·(c_T + n_V c_TV)
    // + E·c_E + f·(p − d·[depth test off] + Σ n_k c_k), each row over its t so that errors
    // are relative. An untaken-branch point's n_k are its taken counts plus the share s of
    // its branch's: s multiplies the costs, so each s of a grid over [0, 1] gets its own
    // linear program and the least worst error wins (from s = 1 down, ties kept: without
    // such points s = 1, as SPIR-V counts both sides of a branch). Fitting s after the
    // costs, to the branch points alone, left them 12–18 % off on a CPU whose straight-line
    // reads cost 15 % more than the looped reads the costs came from.
    const KIND0: usize = 6;
    let row = |p: &ProbePoint, share: f64| -> Vec<f64> {
        let counts = CostCounts::shared([(1.0, p.counts), (share, p.untaken)]);
        (0..KIND0 + Kind::ALL.len())
            .map(|c| {
                let column = match c {
                    0 => 1.0,
                    1 => f64::from(p.triangles),
                    2 => p.edge_pixels,
                    3 => p.coverage,
                    4 if p.depth_test => 0.0,
                    4 => -p.coverage,
                    5 => f64::from(p.triangles) * counts.0[Kind::Varying.index()],
                    _ => p.coverage * counts.0[c - KIND0],
                };
                column / p.ms_median
            })
            .collect()
    };
    let shares: Vec<f64> = if points.iter().any(|p| p.in_untaken_branch) {
        (0..=UNTAKEN_SHARE_STEPS)
            .rev()
            .map(|step| step as f64 / UNTAKEN_SHARE_STEPS as f64)
            .collect()
    } else {
        vec![1.0]
    };
    let mut best: Option<(f64, f64, Vec<f64>)> = None;
    for share in shares {
        let rows: Vec<Vec<f64>> = points.iter().map(|p| row(p, share)).collect();
        let Some(x) = chebyshev_fit(&rows) else {
            continue;
        };
        if !x.iter().all(|v| v.is_finite()) {
            continue;
        }
        let worst = rows
            .iter()
            .map(|r| (r.iter().zip(&x).map(|(a, x)| a * x).sum::<f64>() - 1.0).abs())
            .fold(0.0, f64::max);
        if best.as_ref().is_none_or(|(w, _, _)| worst < w - 1e-9) {
            best = Some((worst, share, x));
        }
    }
    let (_, share, x) = best?;
    Some(CostModel {
        fixed_ms: x[0],
        pixel_ms: x[3],
        depth_test_ms: x[4],
        per_triangle_ms: x[1],
        per_edge_pixel_ms: x[2],
        per_triangle_varying_ms: x[5],
        per_unit_ms: std::array::from_fn(|k| x[k + KIND0]),
        untaken_share: share,
    })
}

/// Steps of the grid over [0, 1] the untaken-branch share is fitted on (0.05 apart).
const UNTAKEN_SHARE_STEPS: usize = 20;

/// x ≥ 0 with the least max_r |a_r·x − 1| (a linear program, `microlp`), and among those
/// the least Σ_r |a_r·x − 1|: the Chebyshev solution can leave a cost free over a range
/// where it does not move the worst row, and the second program settles it by the rest.
/// Columns are scaled to a largest entry of 1 (the triangle counts run to 10⁵, the
/// per-pixel ones near 1); a column of zeros stays at 0. `None` where a program fails.
fn chebyshev_fit(rows: &[Vec<f64>]) -> Option<Vec<f64>> {
    use microlp::{ComparisonOp, OptimizationDirection, Problem};
    let n = rows.first()?.len();
    let scale: Vec<f64> = (0..n)
        .map(|c| rows.iter().map(|r| r[c].abs()).fold(0.0, f64::max))
        .collect();
    let solve = |worst_bound: Option<f64>| -> Option<(Vec<f64>, f64)> {
        let mut lp = Problem::new(OptimizationDirection::Minimize);
        let vars: Vec<Option<microlp::Variable>> = scale
            .iter()
            .map(|&s| (s > 0.0).then(|| lp.add_var(0.0, (0.0, f64::INFINITY))))
            .collect();
        // Stage 1: one bound e on every row's error. Stage 2: a bound u_r per row, each
        // at most the first stage's e (a hair over it: the solver's tolerance).
        let worst = worst_bound
            .is_none()
            .then(|| lp.add_var(1.0, (0.0, f64::INFINITY)));
        for r in rows {
            let error = worst
                .unwrap_or_else(|| lp.add_var(1.0, (0.0, worst_bound.unwrap_or(f64::INFINITY))));
            let terms: Vec<(microlp::Variable, f64)> = vars
                .iter()
                .zip(r)
                .zip(&scale)
                .filter_map(|((v, &a), &s)| v.map(|v| (v, a / s)))
                .collect();
            let mut below = terms.clone();
            below.push((error, -1.0));
            lp.add_constraint(&below, ComparisonOp::Le, 1.0);
            let mut above = terms;
            above.push((error, 1.0));
            lp.add_constraint(&above, ComparisonOp::Ge, 1.0);
        }
        let solution = lp.solve().ok()?.into_solution().ok()?;
        let x = vars
            .iter()
            .zip(&scale)
            .map(|(v, &s)| v.map_or(0.0, |v| solution.var_value(v) / s))
            .collect();
        Some((x, solution.objective()))
    };
    let (x, worst) = solve(None)?;
    solve(Some(worst * (1.0 + 1e-6) + 1e-9))
        .or(Some((x, worst)))
        .map(|(x, _)| x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn probe_shaders_compile_and_count_what_they_were_generated_with() {
        for kind in Kind::ALL {
            for &count in probe_counts(kind) {
                let spirv = crate::gpu::shader::compile_source(
                    "probe.frag",
                    &probe_source(Some(kind), count, false, true),
                    ShaderStage::Fragment,
                    &[],
                )
                .unwrap();
                let ops = spirv::count(&spirv);
                assert_eq!(ops.loops, 0, "{kind:?} {count}");
                match kind {
                    Kind::UniformRead => assert!(ops.uniform_reads >= count, "{ops:?}"),
                    Kind::IndexedUniformRead => {
                        assert_eq!(ops.indexed_uniform_reads, count, "{ops:?}");
                    }
                    Kind::Varying => assert_eq!(ops.varying_reads, count, "{ops:?}"),
                    Kind::FloatOp => assert!(ops.float_ops >= count, "{ops:?}"),
                    _ => assert_eq!(ops.samples, count, "{kind:?}: {ops:?}"),
                }
            }
        }
        for &count in UNTAKEN_BRANCH_READS {
            let source = probe_source(Some(Kind::IndexedUniformRead), count, true, true);
            let spirv = crate::gpu::shader::compile_source(
                "probe.frag",
                &source,
                ShaderStage::Fragment,
                &[],
            )
            .unwrap();
            // SPIR-V counts the branch's reads though no lane runs them.
            let ops = spirv::count(&spirv);
            assert_eq!(ops.indexed_uniform_reads, count, "{ops:?}");
            assert!(source.contains("if (in_uv_lightmap.x < -1.0)"), "{source}");
        }
    }

    #[test]
    fn a_geometry_cost_the_fit_would_put_below_zero_is_held_at_zero() {
        // Timings with no per-triangle cost and a little noise that pulls it negative: the
        // model keeps it at zero, and the edges carry the grids.
        let mut points = Vec::new();
        let mut push = |triangles: u32, edge_pixels: f64, coverage: f64, ms: f64| {
            points.push(ProbePoint {
                kind: None,
                count: 0,
                coverage,
                triangles,
                edge_pixels,
                depth_test: true,
                in_untaken_branch: false,
                counts: CostCounts::default(),
                untaken: CostCounts::default(),
                ms_median: ms,
                batches: 1,
                frames: 0,
                state_frames: 0,
                model_ms: 0.0,
            });
        };
        push(1, 0.0, 0.0, 0.5);
        push(8, 1e4, 1.0, 2.5 + 0.05);
        push(4, 5e3, 0.5, 1.5 + 0.025);
        push(8192, 4e5, 1.0, 2.5 + 2.0);
        push(18432, 6e5, 1.0, 2.5 + 3.0 - 0.2);
        push(32768, 8e5, 1.0, 2.5 + 4.0 - 0.3);
        push(8, 1e4, 1.0, 1.9);
        points.last_mut().unwrap().depth_test = false;
        let model = fit(&points).unwrap();
        assert_eq!(model.per_triangle_ms, 0.0, "{model:?}");
        assert!(model.per_edge_pixel_ms > 0.0, "{model:?}");
    }

    #[test]
    fn the_fit_bounds_the_worst_point_not_the_sum_of_squares() {
        // A linear device whose points are off by ±4 % (one point at 0 work off by 4 % too,
        // that a least-squares fit weighs least): the costs it was timed from miss no point
        // by more than 4 %, so neither may the fit.
        let mut points = Vec::new();
        for (i, (triangles, coverage, lookups)) in [
            (1, 0.0, 0.0),
            (8, 1.0, 0.0),
            (4, 0.5, 0.0),
            (8, 1.0, 1.0),
            (8, 1.0, 2.0),
            (8, 1.0, 4.0),
            (8, 1.0, 8.0),
            (8, 1.0, 16.0),
        ]
        .into_iter()
        .enumerate()
        {
            let mut counts = CostCounts::default();
            counts.0[0] = lookups;
            let truth = 0.3 + f64::from(triangles) * 1e-3 + coverage * (1.0 + 2.0 * lookups);
            let off = [1.04, 0.96, 1.04, 1.04, 0.96, 1.04, 0.96, 1.04][i];
            points.push(ProbePoint {
                kind: None,
                count: 0,
                coverage,
                triangles,
                edge_pixels: 0.0,
                depth_test: true,
                in_untaken_branch: false,
                counts,
                untaken: CostCounts::default(),
                ms_median: truth * off,
                batches: 1,
                frames: 0,
                state_frames: 0,
                model_ms: 0.0,
            });
        }
        let mut off = points[1].clone();
        off.depth_test = false;
        off.ms_median *= 0.8;
        points.push(off);
        let model = fit(&points).unwrap();
        for p in &mut points {
            p.model_ms = predict_point(&model, p);
        }
        let worst = worst_relative_error(&points);
        assert!(worst <= 0.04 + 1e-6, "worst {worst}: {model:?}");
        assert!(worst > 0.0, "the points are not on one line: {model:?}");
    }

    /// Known costs for the synthetic device.
    fn linear_truth() -> CostModel {
        CostModel {
            fixed_ms: 0.4,
            pixel_ms: 1.2,
            depth_test_ms: 0.3,
            per_triangle_ms: 2e-4,
            per_edge_pixel_ms: 5e-6,
            per_triangle_varying_ms: 1.5e-6,
            per_unit_ms: [
                2.0, 3.0, 2.5, 4.0, 2.2, 0.01, 0.05, 0.5, 1.5, 1.2, 3.0, 4.5, 3.6,
            ],
            untaken_share: 0.6,
        }
    }

    /// Timings of every probe point on a device that runs `truth`, but for the reads in an
    /// untaken branch, which cost `branch_read_cost` × the indexed reads' cost.
    fn synthetic_points(truth: &CostModel, branch_read_cost: f64) -> Vec<ProbePoint> {
        // Edges of a screen of 1000 × 600 pixels cut into 2·g² right triangles.
        let edges = |g: u32| {
            let (w, h) = (1000.0 / f64::from(g), 600.0 / f64::from(g));
            f64::from(2 * g * g) * (w + h + w.hypot(h))
        };
        let mut points = Vec::new();
        let mut push_with = |kind: Option<Kind>,
                             counts: CostCounts,
                             untaken: CostCounts,
                             coverage: f64,
                             depth: bool,
                             triangles: u32| {
            let grid = f64::from(triangles / 2).sqrt().round() as u32;
            let edge_pixels = if coverage > 0.0 {
                edges(grid) * coverage
            } else {
                0.0
            };
            // The branch's reads at `branch_read_cost` × the looped reads' cost.
            let mut branch = untaken;
            branch.0[Kind::IndexedUniformRead.index()] *= branch_read_cost;
            let done = truth.with_untaken(&counts, &branch);
            let ms = truth.predict(&done, coverage, triangles, edge_pixels)
                - if depth {
                    0.0
                } else {
                    coverage * truth.depth_test_ms
                };
            points.push(ProbePoint {
                kind,
                count: 0,
                coverage,
                triangles,
                edge_pixels,
                depth_test: depth,
                in_untaken_branch: untaken != CostCounts::default(),
                counts,
                untaken,
                ms_median: ms,
                batches: 1,
                frames: 0,
                state_frames: 0,
                model_ms: 0.0,
            });
        };
        let mut push = |kind, counts, coverage, depth, triangles| {
            push_with(
                kind,
                counts,
                CostCounts::default(),
                coverage,
                depth,
                triangles,
            );
        };
        push(None, CostCounts::default(), 0.0, true, 1);
        let base = 2 * 40 * 40;
        push(None, CostCounts::default(), 1.0, true, base);
        push(None, CostCounts::default(), 0.5, true, base / 2);
        push(None, CostCounts::default(), 1.0, false, base);
        for g in TRIANGLE_GRIDS {
            push(None, CostCounts::default(), 1.0, true, 2 * g * g);
        }
        for g in VARYING_GRIDS {
            let mut c = CostCounts::default();
            c.0[Kind::Varying.index()] = f64::from(MAX_PROBE_VARYINGS);
            push(Some(Kind::Varying), c, 1.0, true, 2 * g * g);
        }
        for kind in Kind::ALL {
            for &n in probe_counts(kind) {
                let mut c = CostCounts::default();
                c.0[kind.index()] = f64::from(n);
                c.0[Kind::Varying.index()] += 2.0;
                c.0[Kind::FloatOp.index()] += 7.0;
                if kind == Kind::IndexedUniformRead {
                    c.0[Kind::Loop.index()] = 1.0;
                }
                push(Some(kind), c, 1.0, true, base);
            }
        }
        for &n in UNTAKEN_BRANCH_READS {
            let mut c = CostCounts::default();
            c.0[Kind::Varying.index()] = 3.0;
            c.0[Kind::FloatOp.index()] = 1.0;
            let mut u = CostCounts::default();
            u.0[Kind::IndexedUniformRead.index()] = f64::from(n);
            u.0[Kind::FloatOp.index()] = 4.0 * f64::from(n);
            push_with(Some(Kind::IndexedUniformRead), c, u, 1.0, true, base);
        }
        points
    }

    #[test]
    fn the_fit_recovers_a_linear_device() {
        // Synthetic timings from known costs: the fit must give them back.
        let truth = linear_truth();
        let points = synthetic_points(&truth, 1.0);
        let model = fit(&points).unwrap();
        assert!(
            (model.untaken_share - truth.untaken_share).abs() < 1e-6,
            "{model:?}"
        );
        assert!((model.fixed_ms - truth.fixed_ms).abs() < 1e-9, "{model:?}");
        assert!((model.pixel_ms - truth.pixel_ms).abs() < 1e-6, "{model:?}");
        assert!((model.depth_test_ms - truth.depth_test_ms).abs() < 1e-9);
        assert!(
            (model.per_triangle_ms - truth.per_triangle_ms).abs() < 1e-9,
            "{model:?}"
        );
        assert!(
            (model.per_edge_pixel_ms - truth.per_edge_pixel_ms).abs() < 1e-11,
            "{model:?}"
        );
        assert!(
            (model.per_triangle_varying_ms - truth.per_triangle_varying_ms).abs() < 1e-11,
            "{model:?}"
        );
        for (m, t) in model.per_unit_ms.iter().zip(truth.per_unit_ms) {
            assert!((m - t).abs() < 1e-6 * t.max(1.0), "{m} vs {t}");
        }
    }
    #[test]
    fn the_share_is_fitted_with_the_costs_so_the_branch_points_count_in_the_worst() {
        // A CPU whose straight-line reads in an untaken branch cost 1.25× its looped reads
        // (lavapipe on a 2-vCPU Xeon: 0.61 against 0.52 ns): fitted to the other points
        // first and the share after, the branch points are the ones the model misses.
        let truth = CostModel {
            untaken_share: 1.0,
            ..linear_truth()
        };
        let points = synthetic_points(&truth, 1.25);
        let worst = |model: &CostModel| {
            points
                .iter()
                .map(|p| (predict_point(model, p) / p.ms_median - 1.0).abs())
                .fold(0.0, f64::max)
        };
        let others: Vec<ProbePoint> = points
            .iter()
            .filter(|p| !p.in_untaken_branch)
            .cloned()
            .collect();
        let costs_first = fit(&others).unwrap();
        assert_eq!(costs_first.untaken_share, 1.0);
        let together = fit(&points).unwrap();
        assert_eq!(together.untaken_share, 1.0, "{together:?}");
        println!(
            "worst point: {:.1} % fitted together, {:.1} % with the share fitted after",
            100.0 * worst(&together),
            100.0 * worst(&costs_first)
        );
        // One cost two groups of points disagree on: the minimax splits the gap, about half.
        assert!(worst(&together) < 0.6 * worst(&costs_first));
    }
}
