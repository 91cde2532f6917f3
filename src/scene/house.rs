//! The built-in procedural scene `house` (DESIGN §4, `--scene house`): a scene made to
//! stress low-frequency visibility — a flat-roofed house whose roof runs on over a porch
//! carried by four pillars (the overhang), door and window openings, front steps, window
//! sills and a fence of thin posts, on a 30 m × 30 m ground plane.
//!
//! Everything is built from axis-aligned boxes, +Y up, metres (DESIGN §1). Each visible box
//! face is one quad (two triangles, counter-clockwise seen from outside, so the winding
//! normal is the face normal); faces resting on the ground or hidden under the roof are
//! skipped. Walls with openings are a grid of cells cut at the opening edges: the solid
//! cells emit their two broad faces merged into vertical runs, and a reveal face wherever a
//! solid cell borders an opening.
//!
//! Per quad, with face normal n and tangent t (walls: t = Y × n, so +u runs to the right
//! seen from outside; horizontal faces: t = +X):
//! - the image-up direction is b = n × t (world +Y on walls),
//! - `uv_material` = (p·t, −p·b) in metres (one texture tile per metre), so v decreases
//!   along b, and the tangent is (t, w = +1): w·(n × t) = b points to decreasing v (DESIGN §1).
//!
//! Lightmap UVs (DESIGN §1 "Lightmap"): every quad is its own chart, laid out texel-aligned:
//! a chart of w×h texels maps the quad corners exactly onto texel boundaries, so every texel
//! whose centre lies in the chart rectangle is fully covered. Chart sizes come from one
//! uniform density (texels per metre; the ground gets half of it), the largest for which the
//! shared shelf packer ([`lightmap_uv::pack_charts`]) fits all charts with [`GUTTER_TEXELS`]
//! empty texels between charts and around the border (bisection on the density). The 224 charts of at least 1×1 texels
//! plus gutters need [`MIN_LIGHTMAP_RES`] texels per side at least.
//!
//! The material is a procedural tiling brick texture (sRGB albedo) with a normal map derived
//! from a height field (mortar grooves, bevelled brick edges) by wrapped central differences
//! (glTF convention: green = +Y = image up). Tests at the bottom check the mesh (no
//! degenerate triangles, orthonormal frames), the chart layout (inside [0,1], no overlaps)
//! and the [`landmarks`] used by image tests.

use glam::{DVec2, Vec2, Vec3};

use super::lightmap_uv::{self, ChartRect as Chart, ChartSize};
use super::{Camera, Material, Mesh, Scene, SceneError, Texture8, Vertex};

pub use super::lightmap_uv::GUTTER_TEXELS;

/// Smallest lightmap resolution the house's charts fit in (one texel per chart plus gutters).
pub const MIN_LIGHTMAP_RES: u32 = 64;
/// Largest lightmap resolution accepted.
pub const MAX_LIGHTMAP_RES: u32 = 8192;
/// Side of the square brick textures, texels.
pub const TEXTURE_SIZE: u32 = 256;

// Dimensions, metres.
const HALF_X: f32 = 4.0; // house footprint x ∈ [−4, 4]
const HALF_Z: f32 = 3.0; // house footprint z ∈ [−3, 3]; the front (door, porch) faces +Z
const WALL: f32 = 0.25; // wall thickness
const HEIGHT: f32 = 3.0; // wall height = roof underside
const ROOF_TOP: f32 = 3.25;
const ROOF_OVERHANG: f32 = 0.3; // beyond the walls on the sides and back
const PORCH_END: f32 = 6.0; // the roof runs on to z = 6 over the porch
const GROUND_HALF: f32 = 15.0;
const FENCE_X: f32 = -6.5;

// Linear RGB tints (≤ 0.9), multiplied into the brick albedo.
pub(super) const TINT_WALL: Vec3 = Vec3::new(0.85, 0.74, 0.62);
const TINT_ROOF: Vec3 = Vec3::new(0.32, 0.3, 0.29);
const TINT_GROUND: Vec3 = Vec3::new(0.36, 0.42, 0.34);
const TINT_PILLAR: Vec3 = Vec3::new(0.88, 0.88, 0.85);
const TINT_STONE: Vec3 = Vec3::new(0.6, 0.6, 0.58);
const TINT_WOOD: Vec3 = Vec3::new(0.55, 0.4, 0.28);

/// World points for image tests, each visible from the default camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Landmarks {
    /// On the ground under the porch roof, well inside the overhang.
    pub under_overhang: Vec3,
    /// On the ground in the open (normal +Y like `under_overhang`), far from all geometry.
    pub open_ground: Vec3,
    /// On the front face of the house wall (normal +Z), between the door and a window.
    pub brick_wall: Vec3,
}

/// The house's landmark points (see [`Landmarks`]).
pub fn landmarks() -> Landmarks {
    Landmarks {
        under_overhang: Vec3::new(-2.3, 0.0, 4.0),
        open_ground: Vec3::new(-10.0, 0.0, 8.0),
        brick_wall: Vec3::new(1.05, 1.5, HALF_Z),
    }
}

/// The default camera: the porch, pillars, door and front walls from an elevated front-right
/// corner, 50° vertical field of view.
pub fn camera() -> Camera {
    Camera {
        position: Vec3::new(9.0, 3.8, 14.0),
        target: Vec3::new(-0.6, 1.0, 3.0),
        up: Vec3::Y,
        fov_y: 50f32.to_radians(),
        z_near: 0.05,
        z_far: 200.0,
    }
}

/// Builds the house scene with lightmap UVs packed for `lightmap_res`² texels.
///
/// # Errors
/// [`SceneError::LightmapRes`] when `lightmap_res` is outside
/// [`MIN_LIGHTMAP_RES`]..=[`MAX_LIGHTMAP_RES`].
pub fn build(lightmap_res: u32) -> Result<Scene, SceneError> {
    Ok(Scene {
        name: "house".to_string(),
        mesh: quads_mesh(&quads(), lightmap_res)?,
        material: Material {
            albedo: brick_albedo(),
            normal: brick_normal(),
            normal_scale: 1.0,
            height: Some(brick_height_field()),
        },
        camera: camera(),
    })
}

/// A planar rectangle: corner `origin`, unit edge directions `t` (tangent, +u) and `b`
/// (image up), extents `size` in metres along them; normal n = t × b.
#[derive(Clone, Copy, Debug)]
pub(super) struct Quad {
    pub(super) origin: Vec3,
    pub(super) t: Vec3,
    pub(super) b: Vec3,
    pub(super) size: Vec2,
    pub(super) tint: Vec3,
    /// Charted at half the texel density (the ground is large and smooth in visibility).
    pub(super) half_density: bool,
}

impl Quad {
    fn normal(&self) -> Vec3 {
        self.t.cross(self.b)
    }
}

// Face bits for `add_box`.
const PX: u8 = 1;
const NX: u8 = 2;
const PY: u8 = 4;
const NY: u8 = 8;
const PZ: u8 = 16;
const NZ: u8 = 32;
const ALL: u8 = 63;
const SIDES: u8 = PX | NX | PZ | NZ;

/// The face of box [lo, hi] with outward axis normal `n`, as a quad.
fn box_face(lo: Vec3, hi: Vec3, n: Vec3, tint: Vec3) -> Quad {
    let t = if n.y.abs() > 0.5 {
        Vec3::X
    } else {
        Vec3::Y.cross(n)
    };
    let b = n.cross(t);
    let (s0, s1) = (lo.dot(t).min(hi.dot(t)), lo.dot(t).max(hi.dot(t)));
    let (r0, r1) = (lo.dot(b).min(hi.dot(b)), lo.dot(b).max(hi.dot(b)));
    let plane = if n.dot(Vec3::ONE) > 0.0 { hi } else { lo }.dot(n);
    Quad {
        origin: t * s0 + b * r0 + n * plane,
        t,
        b,
        size: Vec2::new(s1 - s0, r1 - r0),
        tint,
        half_density: false,
    }
}

/// Appends the faces of box [lo, hi] selected by the bit mask `faces`.
fn add_box(quads: &mut Vec<Quad>, lo: Vec3, hi: Vec3, faces: u8, tint: Vec3) {
    let normals = [
        (PX, Vec3::X),
        (NX, Vec3::NEG_X),
        (PY, Vec3::Y),
        (NY, Vec3::NEG_Y),
        (PZ, Vec3::Z),
        (NZ, Vec3::NEG_Z),
    ];
    for (bit, n) in normals {
        if faces & bit != 0 {
            quads.push(box_face(lo, hi, n, tint));
        }
    }
}

/// A straight wall from `s` = `span.0` to `span.1` along `along` (X or Z), across `depth`
/// (the other horizontal axis), from the ground to [`HEIGHT`], with rectangular openings
/// `(s0, s1, y0, y1)`. `caps` emits the two end faces (false where the wall butts into
/// another). The top face is never emitted: the roof slab rests on it.
fn add_wall(
    quads: &mut Vec<Quad>,
    along: Vec3,
    span: (f32, f32),
    depth: (f32, f32),
    openings: &[(f32, f32, f32, f32)],
    caps: bool,
) {
    let across = if along == Vec3::X { Vec3::Z } else { Vec3::X };
    let world = |s: f32, y: f32, d: f32| along * s + Vec3::Y * y + across * d;
    let mut s_cuts = vec![span.0, span.1];
    let mut y_cuts = vec![0.0, HEIGHT];
    for o in openings {
        s_cuts.extend([o.0, o.1]);
        y_cuts.extend([o.2, o.3]);
    }
    for cuts in [&mut s_cuts, &mut y_cuts] {
        cuts.sort_by(f32::total_cmp);
        cuts.dedup();
    }
    let (cols, rows) = (s_cuts.len() - 1, y_cuts.len() - 1);
    let solid = |i: usize, j: usize| {
        let (s, y) = (
            0.5 * (s_cuts[i] + s_cuts[i + 1]),
            0.5 * (y_cuts[j] + y_cuts[j + 1]),
        );
        !openings
            .iter()
            .any(|o| s > o.0 && s < o.1 && y > o.2 && y < o.3)
    };
    let cell_box = |i0: usize, i1: usize, j0: usize, j1: usize| {
        let a = world(s_cuts[i0], y_cuts[j0], depth.0);
        let b = world(s_cuts[i1], y_cuts[j1], depth.1);
        (a.min(b), a.max(b))
    };
    // Broad faces (±across): per column, maximal vertical runs of solid cells.
    for i in 0..cols {
        let mut j = 0;
        while j < rows {
            if !solid(i, j) {
                j += 1;
                continue;
            }
            let start = j;
            while j < rows && solid(i, j) {
                j += 1;
            }
            let (lo, hi) = cell_box(i, i + 1, start, j);
            quads.push(box_face(lo, hi, across, TINT_WALL));
            quads.push(box_face(lo, hi, -across, TINT_WALL));
        }
    }
    // Reveals and end caps (±along): where a solid cell borders an opening or the wall end,
    // merged over vertical runs.
    for k in 0..=cols {
        for dir in [1.0f32, -1.0] {
            // Face at cut k with normal dir·along belongs to the cell on the −dir side.
            let (cell, other) = if dir > 0.0 {
                (k.checked_sub(1), (k < cols).then_some(k))
            } else {
                ((k < cols).then_some(k), k.checked_sub(1))
            };
            let Some(cell) = cell else { continue };
            let exposed = |j: usize| {
                solid(cell, j)
                    && match other {
                        Some(o) => !solid(o, j),
                        None => caps,
                    }
            };
            let mut j = 0;
            while j < rows {
                if !exposed(j) {
                    j += 1;
                    continue;
                }
                let start = j;
                while j < rows && exposed(j) {
                    j += 1;
                }
                let (lo, hi) = cell_box(cell, cell + 1, start, j);
                quads.push(box_face(lo, hi, along * dir, TINT_WALL));
            }
        }
    }
    // Sills and lintels inside openings (±Y): per column, where solid meets an opening.
    for i in 0..cols {
        for j in 1..rows {
            let (below, above) = (solid(i, j - 1), solid(i, j));
            if below && !above {
                let (lo, hi) = cell_box(i, i + 1, j - 1, j);
                quads.push(box_face(lo, hi, Vec3::Y, TINT_WALL));
            } else if above && !below {
                let (lo, hi) = cell_box(i, i + 1, j, j + 1);
                quads.push(box_face(lo, hi, Vec3::NEG_Y, TINT_WALL));
            }
        }
    }
}

/// All quads of the scene, in a fixed order.
fn quads() -> Vec<Quad> {
    let mut q = Vec::new();
    // Ground: one-sided, normal +Y, half texel density.
    q.push(Quad {
        origin: Vec3::new(-GROUND_HALF, 0.0, GROUND_HALF),
        t: Vec3::X,
        b: Vec3::NEG_Z,
        size: Vec2::splat(2.0 * GROUND_HALF),
        tint: TINT_GROUND,
        half_density: true,
    });

    // Walls: front and back span the full width, the sides fit between them.
    let front = (HALF_Z - WALL, HALF_Z);
    let back = (-HALF_Z, -HALF_Z + WALL);
    let windows_front = [(-3.2, -1.6, 0.9, 2.1), (1.6, 3.2, 0.9, 2.1)];
    let door = (-0.5, 0.5, 0.3, 2.2);
    let mut front_openings = windows_front.to_vec();
    front_openings.push(door);
    add_wall(
        &mut q,
        Vec3::X,
        (-HALF_X, HALF_X),
        front,
        &front_openings,
        true,
    );
    add_wall(
        &mut q,
        Vec3::X,
        (-HALF_X, HALF_X),
        back,
        &[(-1.0, 1.0, 0.9, 2.1)],
        true,
    );
    let side_window = [(-0.75, 0.75, 1.0, 2.0)];
    let inner_z = (-HALF_Z + WALL, HALF_Z - WALL);
    add_wall(
        &mut q,
        Vec3::Z,
        inner_z,
        (-HALF_X, -HALF_X + WALL),
        &side_window,
        false,
    );
    add_wall(
        &mut q,
        Vec3::Z,
        inner_z,
        (HALF_X - WALL, HALF_X),
        &side_window,
        false,
    );

    // Roof slab over the house and the porch (the overhang).
    add_box(
        &mut q,
        Vec3::new(-HALF_X - ROOF_OVERHANG, HEIGHT, -HALF_Z - ROOF_OVERHANG),
        Vec3::new(HALF_X + ROOF_OVERHANG, ROOF_TOP, PORCH_END),
        ALL,
        TINT_ROOF,
    );
    // Porch pillars carrying the roof's front edge.
    for x in [-3.9, -1.4, 1.4, 3.9] {
        add_box(
            &mut q,
            Vec3::new(x - 0.125, 0.0, PORCH_END - 0.5),
            Vec3::new(x + 0.125, HEIGHT, PORCH_END - 0.25),
            SIDES,
            TINT_PILLAR,
        );
    }
    // Two front steps up to the door threshold (y = 0.3).
    add_box(
        &mut q,
        Vec3::new(-0.8, 0.0, HALF_Z),
        Vec3::new(0.8, 0.15, HALF_Z + 0.6),
        PX | NX | PY | PZ,
        TINT_STONE,
    );
    add_box(
        &mut q,
        Vec3::new(-0.8, 0.15, HALF_Z),
        Vec3::new(0.8, 0.3, HALF_Z + 0.3),
        PX | NX | PY | PZ,
        TINT_STONE,
    );
    // Window sills sticking out of the front and right walls.
    for (x0, x1, y0, _) in windows_front {
        add_box(
            &mut q,
            Vec3::new(x0 - 0.1, y0 - 0.08, HALF_Z),
            Vec3::new(x1 + 0.1, y0, HALF_Z + 0.12),
            PX | NX | PY | NY | PZ,
            TINT_STONE,
        );
    }
    add_box(
        &mut q,
        Vec3::new(HALF_X, 0.92, -0.85),
        Vec3::new(HALF_X + 0.12, 1.0, 0.85),
        PX | PY | NY | PZ | NZ,
        TINT_STONE,
    );
    // Fence left of the house: thin posts every 0.5 m and a rail threaded through them.
    for k in 0..20 {
        let z = -2.5 + 0.5 * k as f32;
        add_box(
            &mut q,
            Vec3::new(FENCE_X - 0.03, 0.0, z - 0.03),
            Vec3::new(FENCE_X + 0.03, 1.0, z + 0.03),
            SIDES | PY,
            TINT_WOOD,
        );
    }
    add_box(
        &mut q,
        Vec3::new(FENCE_X - 0.015, 0.8, -2.7),
        Vec3::new(FENCE_X + 0.015, 0.88, 7.2),
        ALL,
        TINT_WOOD,
    );
    q
}

/// The quads as charts for the shared packer ([`lightmap_uv::pack_charts`]): the ground at
/// half density.
pub(super) fn pack_charts(quads: &[Quad], res: u32) -> Option<Vec<Chart>> {
    let charts: Vec<ChartSize> = quads
        .iter()
        .map(|q| ChartSize {
            size: DVec2::new(f64::from(q.size.x), f64::from(q.size.y)),
            density_scale: if q.half_density { 0.5 } else { 1.0 },
        })
        .collect();
    lightmap_uv::pack_charts(&charts, res).map(|p| p.rects)
}

/// Triangulates the quads: 4 vertices and 2 counter-clockwise triangles each.
/// The mesh of `quads` charted for a `lightmap_res`² lightmap: the built-in scenes made
/// of quads (the house, `patio`, `bumpy`).
///
/// # Errors
/// [`SceneError::LightmapRes`] when the resolution is outside the house's range or the
/// charts do not fit.
pub(super) fn quads_mesh(quads: &[Quad], lightmap_res: u32) -> Result<Mesh, SceneError> {
    let out_of_range = || SceneError::LightmapRes {
        res: lightmap_res,
        min: MIN_LIGHTMAP_RES,
        max: MAX_LIGHTMAP_RES,
    };
    if !(MIN_LIGHTMAP_RES..=MAX_LIGHTMAP_RES).contains(&lightmap_res) {
        return Err(out_of_range());
    }
    let charts = pack_charts(quads, lightmap_res).ok_or_else(out_of_range)?;
    Ok(mesh(quads, &charts, lightmap_res))
}

pub(super) fn mesh(quads: &[Quad], charts: &[Chart], res: u32) -> Mesh {
    let mut m = Mesh::default();
    let inv_res = 1.0 / res as f32;
    for (q, c) in quads.iter().zip(charts) {
        let n = q.normal();
        // w·(n × t) must be the image-up direction b (DESIGN §1); it is by construction.
        let w = n.cross(q.t).dot(q.b).signum();
        let base = m.vertices.len() as u32;
        for (s, r) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
            let p = q.origin + q.t * (s * q.size.x) + q.b * (r * q.size.y);
            m.vertices.push(Vertex {
                position: p.to_array(),
                normal: n.to_array(),
                tangent: q.t.extend(w).to_array(),
                uv_material: [p.dot(q.t), -p.dot(q.b)],
                uv_lightmap: [
                    (c.x as f32 + s * c.w as f32) * inv_res,
                    (c.y as f32 + r * c.h as f32) * inv_res,
                ],
                albedo_tint: q.tint.to_array(),
            });
        }
        m.indices
            .extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    m
}

// ---- Brick material -------------------------------------------------------------------

/// Bricks across one texture tile (offset by half a brick on odd rows).
const BRICKS_ACROSS: f32 = 3.0;
/// Brick rows per tile; even, so the half-brick offset tiles vertically.
const BRICK_ROWS: f32 = 6.0;
/// Half the mortar joint width, texels.
const MORTAR_HALF: f32 = 2.0;
/// Width of the rounded brick edge, texels.
const BEVEL: f32 = 3.5;
/// Brick face height above the mortar, texels: with `BEVEL` the edges tilt ≈ 45°.
const RELIEF: f32 = 3.5;

/// SplitMix64 finalizer: a well-mixed 64-bit hash.
fn hash64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// The brick pattern at texel (x, y): height in texels and the brick's id (row, column
/// modulo the tile), `None` in the mortar.
fn brick_at(x: u32, y: u32) -> (f32, Option<(u32, u32)>) {
    let size = TEXTURE_SIZE as f32;
    let (brick_w, brick_h) = (size / BRICKS_ACROSS, size / BRICK_ROWS);
    let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
    let row = (py / brick_h).floor();
    let offset = if row as u32 % 2 == 1 { 0.5 } else { 0.0 };
    let col_f = px / brick_w + offset;
    let col = col_f.floor();
    let (fx, fy) = (col_f - col, py / brick_h - row);
    // Distance to the brick outline, texels.
    let edge = (fx.min(1.0 - fx) * brick_w).min(fy.min(1.0 - fy) * brick_h);
    if edge < MORTAR_HALF {
        return (0.0, None);
    }
    let t = ((edge - MORTAR_HALF) / BEVEL).min(1.0);
    let bevel = t * (2.0 - t); // quarter-round profile: steep at the joint, flat on the face
    let col = (col as u32) % BRICKS_ACROSS as u32;
    (RELIEF * bevel, Some((row as u32, col)))
}

/// Linear → sRGB 8-bit (IEC 61966-2-1).
fn srgb8(linear: f32) -> u8 {
    let c = linear.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// Brick albedo: per-brick colour variation from an integer hash, light mortar.
pub(super) fn brick_albedo() -> Texture8 {
    let n = TEXTURE_SIZE;
    let mut texels = Vec::with_capacity((n * n) as usize);
    for y in 0..n {
        for x in 0..n {
            let colour = match brick_at(x, y).1 {
                None => Vec3::new(0.78, 0.76, 0.71),
                Some((row, col)) => {
                    let h = hash64(u64::from(row) << 32 | u64::from(col));
                    let unit = |k: u32| ((h >> (16 * k)) & 0xffff) as f32 / 65535.0;
                    let brightness = 0.7 + 0.4 * unit(0);
                    let warmth = 0.85 + 0.3 * unit(1);
                    Vec3::new(0.62 * warmth, 0.3, 0.18 / warmth) * brightness
                }
            };
            let c = colour.min(Vec3::splat(0.9));
            texels.push([srgb8(c.x), srgb8(c.y), srgb8(c.z), 255]);
        }
    }
    Texture8 {
        width: n,
        height: n,
        texels,
    }
}

/// The brick height field the normal map is derived from (heights in texels, the texture's
/// resolution): the surface `shvis ssbump --height-map house` shadows.
pub fn brick_height_field() -> super::HeightField {
    let n = TEXTURE_SIZE;
    super::HeightField {
        width: n as usize,
        height: n as usize,
        h: (0..n * n)
            .map(|i| f64::from(brick_at(i % n, i / n).0))
            .collect(),
    }
}

/// Tangent-space normal map of the brick height field: central differences with
/// wrap-around, n ∝ (−∂h/∂x, +∂h/∂y_img, 1) (y_img grows downward, green = image up),
/// stored as (n·0.5 + 0.5)·255.
pub(super) fn brick_normal() -> Texture8 {
    let n = TEXTURE_SIZE;
    let height: Vec<f32> = (0..n * n).map(|i| brick_at(i % n, i / n).0).collect();
    let h = |x: u32, y: u32| height[((y % n) * n + x % n) as usize];
    let mut texels = Vec::with_capacity((n * n) as usize);
    for y in 0..n {
        for x in 0..n {
            let dhdx = 0.5 * (h(x + 1, y) - h(x + n - 1, y));
            let dhdy = 0.5 * (h(x, y + 1) - h(x, y + n - 1));
            let nrm = Vec3::new(-dhdx, dhdy, 1.0).normalize();
            texels.push(Texture8::encode_normal(nrm));
        }
    }
    Texture8 {
        width: n,
        height: n,
        texels,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// f32 cross products of metre-sized edges: anything above this is a real triangle.
    const MIN_AREA: f32 = 1e-6;
    /// Normals and tangents come from exact axis vectors; f32 rounding only.
    const UNIT: f32 = 1e-5;

    fn scene(res: u32) -> Scene {
        match build(res) {
            Ok(s) => s,
            Err(e) => panic!("house at {res}: {e}"),
        }
    }

    #[test]
    fn no_degenerate_triangles_and_orthonormal_frames() {
        let s = scene(512);
        let m = &s.mesh;
        assert!(m.triangle_count() > 100);
        for t in 0..m.triangle_count() {
            let [a, b, c] = m.triangle_positions(t);
            let cross = (b - a).cross(c - a);
            assert!(cross.length() > MIN_AREA, "triangle {t} is degenerate");
            let v = m.vertices[m.indices[3 * t] as usize];
            let n = Vec3::from(v.normal);
            // Winding agrees with the face normal (counter-clockwise from outside).
            assert!(
                cross.normalize().dot(n) > 1.0 - UNIT,
                "triangle {t} winding"
            );
        }
        for (i, v) in m.vertices.iter().enumerate() {
            let n = Vec3::from(v.normal);
            let t = Vec3::new(v.tangent[0], v.tangent[1], v.tangent[2]);
            assert!((n.length() - 1.0).abs() < UNIT, "vertex {i}: normal {n}");
            assert!((t.length() - 1.0).abs() < UNIT, "vertex {i}: tangent {t}");
            assert!(n.dot(t).abs() < UNIT, "vertex {i}: tangent not ⊥ normal");
            assert_eq!(v.tangent[3].abs(), 1.0, "vertex {i}: w");
            assert!(v.albedo_tint.iter().all(|&c| (0.0..=0.9).contains(&c)));
            let uv = v.uv_lightmap;
            assert!(
                uv.iter().all(|c| (0.0..=1.0).contains(c)),
                "vertex {i}: {uv:?}"
            );
        }
    }

    #[test]
    fn tangent_frame_follows_material_uv() {
        // Along each triangle, +u moves along the tangent and decreasing v along the
        // bitangent w·(n × t); on walls image-up is world +Y.
        let s = scene(256);
        let m = &s.mesh;
        for t in 0..m.triangle_count() {
            let idx = &m.indices[3 * t..3 * t + 3];
            let v: Vec<Vertex> = idx.iter().map(|&i| m.vertices[i as usize]).collect();
            let n = Vec3::from(v[0].normal);
            let tan = Vec3::new(v[0].tangent[0], v[0].tangent[1], v[0].tangent[2]);
            let bit = v[0].tangent[3] * n.cross(tan);
            for k in 1..3 {
                let dp = Vec3::from(v[k].position) - Vec3::from(v[0].position);
                let du = v[k].uv_material[0] - v[0].uv_material[0];
                let dv = v[k].uv_material[1] - v[0].uv_material[1];
                assert!((dp.dot(tan) - du).abs() < UNIT, "triangle {t}: u");
                assert!((dp.dot(bit) + dv).abs() < UNIT, "triangle {t}: v");
            }
            if n.y.abs() < 0.5 {
                assert!(bit.dot(Vec3::Y) > 1.0 - UNIT, "wall triangle {t}: image up");
            }
        }
    }

    /// Texel rectangles of the charts, read back from the mesh's lightmap UVs.
    fn chart_rects(m: &Mesh, res: u32) -> Vec<[f32; 4]> {
        m.vertices
            .chunks(4)
            .map(|quad| {
                let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
                for v in quad {
                    let p = Vec2::from(v.uv_lightmap) * res as f32;
                    (lo, hi) = (lo.min(p), hi.max(p));
                }
                [lo.x, lo.y, hi.x, hi.y]
            })
            .collect()
    }

    /// Texel boundaries are multiples of 1/res; f32 keeps them within this many texels.
    const TEXEL_SNAP: f32 = 1e-3;

    #[test]
    fn charts_are_texel_aligned_disjoint_with_gutters() {
        for res in [64, 512, 1000] {
            let s = scene(res);
            let rects = chart_rects(&s.mesh, res);
            let g = GUTTER_TEXELS as f32 - TEXEL_SNAP;
            for (i, r) in rects.iter().enumerate() {
                for c in r {
                    assert!(
                        (c - c.round()).abs() < TEXEL_SNAP,
                        "res {res} chart {i}: {r:?}"
                    );
                }
                assert!(r[2] - r[0] >= 1.0 - TEXEL_SNAP && r[3] - r[1] >= 1.0 - TEXEL_SNAP);
                assert!(
                    r[0] >= g && r[1] >= g,
                    "res {res} chart {i} in the border gutter"
                );
                let far = res as f32 - g;
                assert!(
                    r[2] <= far && r[3] <= far,
                    "res {res} chart {i} in the border gutter"
                );
                for (j, o) in rects.iter().enumerate().skip(i + 1) {
                    let apart = r[2] + g <= o[0]
                        || o[2] + g <= r[0]
                        || r[3] + g <= o[1]
                        || o[3] + g <= r[1];
                    assert!(apart, "res {res}: charts {i} {r:?} and {j} {o:?} overlap");
                }
            }
        }
    }

    #[test]
    fn density_grows_with_resolution_and_ground_is_half() {
        let quads = quads();
        let small = pack_charts(&quads, 256).map(|c| c[0].w);
        let large = pack_charts(&quads, 1024).map(|c| c[0].w);
        assert!(large > small, "ground chart {large:?} vs {small:?}");
        let charts = pack_charts(&quads, 1024).unwrap_or_default();
        // Quad 1 is a house wall face; density ratio from the charts ≈ 2 (ceil rounding).
        let ground = charts[0].w as f32 / quads[0].size.x;
        let wall = charts[1].h as f32 / quads[1].size.y;
        assert!(
            (wall / ground - 2.0).abs() < 0.2,
            "wall {wall} vs ground {ground}"
        );
    }

    #[test]
    fn out_of_range_resolutions_are_errors() {
        for res in [0, 16, MIN_LIGHTMAP_RES - 1, MAX_LIGHTMAP_RES + 1] {
            assert!(matches!(build(res), Err(SceneError::LightmapRes { .. })));
        }
    }

    #[test]
    fn landmarks_project_into_the_default_image() {
        let cam = camera();
        let l = landmarks();
        for (name, p) in [
            ("under_overhang", l.under_overhang),
            ("open_ground", l.open_ground),
            ("brick_wall", l.brick_wall),
        ] {
            let Some((x, y)) = cam.project_to_pixel(p, 1280, 800) else {
                panic!("{name} is behind the camera");
            };
            assert!(
                (40.0..1240.0).contains(&x) && (40.0..760.0).contains(&y),
                "{name} at pixel ({x}, {y})"
            );
        }
    }

    #[test]
    fn the_height_field_and_the_normal_map_describe_one_surface() {
        let field = brick_height_field();
        let map = brick_normal();
        for (t, texel) in map.texels.iter().enumerate() {
            let n = field.normal(t % field.width, t / field.width);
            for (c, v) in [n.x, n.y, n.z].iter().enumerate() {
                let stored = f64::from(texel[c]) / 255.0 * 2.0 - 1.0;
                assert!(
                    (stored - v).abs() <= 1.0 / 255.0 + 1e-6,
                    "texel {t} channel {c}"
                );
            }
        }
    }

    #[test]
    fn textures_tile_and_normals_point_out() {
        let (albedo, normal) = (brick_albedo(), brick_normal());
        assert_eq!(albedo.texels.len(), (TEXTURE_SIZE * TEXTURE_SIZE) as usize);
        // Mortar on the tile border rows/columns on both sides: the pattern wraps.
        let n = TEXTURE_SIZE;
        assert_eq!(brick_at(0, 0).1, None);
        assert_eq!(brick_at(0, n - 1).1, None);
        let mut tilted = 0;
        for t in &normal.texels {
            let z = t[2] as f32 / 255.0 * 2.0 - 1.0;
            assert!(z > 0.3, "normal map z {z}");
            tilted += usize::from(z < 0.9);
        }
        // The relief must be visible: a good share of strongly tilted texels.
        assert!(tilted > normal.texels.len() / 10, "{tilted} tilted texels");
    }
}
