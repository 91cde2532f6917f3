//! What a ray sees where it hits the scene: the surface attributes that inter-reflection
//! needs (DESIGN §1's shading model applied at a hit point), shared by the SH lightmap bake
//! ([`super::shlmap`]) and the reference's bounces ([`crate::reference`]) so both read the
//! scene the same way.
//!
//! At a hit on triangle t with barycentrics (u, v):
//! - the *oriented geometric normal*: the winding normal, flipped when it disagrees with
//!   the interpolated vertex normal — the side the surface is shaded on, as
//!   [`super::raster`] bakes it. A ray arriving from behind that side sees the back face,
//!   which reflects nothing;
//! - the *albedo*: the material's sRGB texture decoded to linear, bilinear with repeat at
//!   the interpolated `uv_material` (as the GPU's sampler reads it, without mipmaps),
//!   times the interpolated `albedo_tint`;
//! - the lightmap texel containing the interpolated `uv_lightmap`.
//!
//! The lightmap bakes' gathers (and the error ladder's, which gathers at pixels as the bake
//! does at texels) trace their shared directions through a [`PointGroup`]: up to 64 nearby
//! points at a time, one coherent walk per direction (`super::trace`, Closest hits), each
//! point seeing its rays in the directions' order as a point-at-a-time gather would.

use glam::{Vec2, Vec3};

use super::directions::above_horizon;
use super::raster::LightmapTexels;
use super::trace::{Hit, PACKET_RAYS, RayPacket, Tracer};
use crate::scene::{Scene, Texture8};

/// The attributes of a hit point (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    pub position: Vec3,
    /// Unit oriented geometric normal.
    pub normal: Vec3,
    /// Whether the ray arrived on the shaded side (`dir · normal < 0`).
    pub front_face: bool,
    /// Linear RGB albedo.
    pub albedo: Vec3,
    /// Lightmap UV (TEXCOORD_1 or generated).
    pub uv_lightmap: Vec2,
}

/// Reads hit points of one scene; holds the albedo texture decoded to linear once.
pub struct SurfaceReader<'a> {
    scene: &'a Scene,
    albedo: LinearTexture,
}

impl<'a> SurfaceReader<'a> {
    pub fn new(scene: &'a Scene) -> Self {
        SurfaceReader {
            scene,
            albedo: LinearTexture::from_srgb(&scene.material.albedo),
        }
    }

    /// The surface at `hit` of a ray along unit `dir`.
    pub fn at(&self, hit: &Hit, origin: Vec3, dir: Vec3) -> SurfacePoint {
        let mesh = &self.scene.mesh;
        let t = hit.triangle as usize;
        let corner = |k: usize| &mesh.vertices[mesh.indices[3 * t + k] as usize];
        let (a, b, c) = (corner(0), corner(1), corner(2));
        let w = [1.0 - hit.u - hit.v, hit.u, hit.v];
        let mix3 = |f: &dyn Fn(&crate::scene::Vertex) -> [f32; 3]| {
            Vec3::from(f(a)) * w[0] + Vec3::from(f(b)) * w[1] + Vec3::from(f(c)) * w[2]
        };
        let mix2 = |f: &dyn Fn(&crate::scene::Vertex) -> [f32; 2]| {
            Vec2::from(f(a)) * w[0] + Vec2::from(f(b)) * w[1] + Vec2::from(f(c)) * w[2]
        };
        let [p0, p1, p2] = mesh.triangle_positions(t);
        let mut normal = (p1 - p0).cross(p2 - p0).normalize_or_zero();
        if normal.dot(mix3(&|v| v.normal)) < 0.0 {
            normal = -normal;
        }
        let tint = mix3(&|v| v.albedo_tint);
        let uv_material = mix2(&|v| v.uv_material);
        SurfacePoint {
            position: origin + dir * hit.t,
            normal,
            front_face: dir.dot(normal) < 0.0,
            albedo: self.albedo.bilinear_repeat(uv_material) * tint,
            uv_lightmap: mix2(&|v| v.uv_lightmap),
        }
    }
}

/// An RGB texture in linear f32, row 0 at v = 0.
struct LinearTexture {
    width: u32,
    height: u32,
    texels: Vec<Vec3>,
}

impl LinearTexture {
    fn from_srgb(tex: &Texture8) -> Self {
        let lut: Vec<f32> = (0..256)
            .map(|i| {
                let c = i as f32 / 255.0;
                if c <= 0.04045 {
                    c / 12.92
                } else {
                    ((c + 0.055) / 1.055).powf(2.4)
                }
            })
            .collect();
        LinearTexture {
            width: tex.width.max(1),
            height: tex.height.max(1),
            texels: if tex.texels.is_empty() {
                vec![Vec3::ONE]
            } else {
                tex.texels
                    .iter()
                    .map(|t| Vec3::new(lut[t[0] as usize], lut[t[1] as usize], lut[t[2] as usize]))
                    .collect()
            },
        }
    }

    /// Bilinear with repeat wrapping, texel centres at (i+½)/size.
    fn bilinear_repeat(&self, uv: Vec2) -> Vec3 {
        if self.texels.len() == 1 {
            return self.texels[0];
        }
        let (w, h) = (self.width as i64, self.height as i64);
        let x = uv.x * w as f32 - 0.5;
        let y = uv.y * h as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return self.texels[0];
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        // The wrapped columns and rows of the four texels: one division each for x0 and
        // y0; their neighbours wrap by a comparison.
        let (x0, y0) = ((x0 as i64).rem_euclid(w), (y0 as i64).rem_euclid(h));
        let next = |i: i64, n: i64| if i + 1 == n { 0 } else { i + 1 };
        let (x1, y1) = (next(x0, w), next(y0, h));
        let fetch = |xi: i64, yi: i64| self.texels[(yi * w + xi) as usize];
        let top = fetch(x0, y0) * (1.0 - fx) + fetch(x1, y0) * fx;
        let bottom = fetch(x0, y1) * (1.0 - fx) + fetch(x1, y1) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

/// Where a traced ray of a gather ended.
pub(crate) enum RayEnd<'a> {
    /// It left the scene: the environment's radiance arrives along it.
    Escaped,
    /// It hit the front of a surface.
    Front(&'a SurfacePoint),
    /// It hit the back of a surface: nothing arrives along it.
    Back,
}

/// One ray from `origin` along `d` (the gathers' own rays, traced singly): `f` called
/// with where it ended.
pub(crate) fn trace_ray<T>(
    tracer: &super::trace::Tracer,
    surfaces: &SurfaceReader<'_>,
    origin: Vec3,
    d: Vec3,
    f: impl FnOnce(RayEnd<'_>) -> T,
) -> T {
    let Some(hit) = tracer.closest_hit(origin, d) else {
        return f(RayEnd::Escaped);
    };
    let surface = surfaces.at(&hit, origin, d);
    if surface.front_face {
        f(RayEnd::Front(&surface))
    } else {
        f(RayEnd::Back)
    }
}

/// A group of at most [`PACKET_RAYS`] points the gathers trace together, nearby points
/// (consecutive texels or pixels) for coherence: each point's ray origin and unit normal.
pub(crate) struct PointGroup {
    packet: RayPacket,
    normals: Vec<Vec3>,
    origins: Vec<Vec3>,
}

impl PointGroup {
    /// The group of surface points `positions` with unit geometric `normals`, their rays
    /// leaving from [`Tracer::offset_origin`].
    ///
    /// # Panics
    /// With more than [`PACKET_RAYS`] points or a normal per point missing (a bug in the
    /// caller).
    pub(crate) fn new(tracer: &Tracer, positions: &[Vec3], normals: Vec<Vec3>) -> PointGroup {
        assert_eq!(positions.len(), normals.len(), "one normal per point");
        let origins: Vec<Vec3> = positions
            .iter()
            .zip(&normals)
            .map(|(&p, &n)| tracer.offset_origin(p, n))
            .collect();
        PointGroup {
            packet: RayPacket::new(&origins),
            normals,
            origins,
        }
    }

    /// The covered lightmap texels `group` (texel indices) as a group of points.
    pub(crate) fn of_texels(tracer: &Tracer, texels: &LightmapTexels, group: &[u32]) -> PointGroup {
        let positions: Vec<Vec3> = group.iter().map(|&i| texels.position[i as usize]).collect();
        let normals = group.iter().map(|&i| texels.normal[i as usize]).collect();
        PointGroup::new(tracer, &positions, normals)
    }

    /// Number of points.
    pub(crate) fn len(&self) -> usize {
        self.origins.len()
    }

    /// Point `k`'s ray origin.
    pub(crate) fn origin(&self, k: usize) -> Vec3 {
        self.origins[k]
    }

    /// The points whose horizon `d` is above, as a mask.
    fn above(&self, d: Vec3) -> u64 {
        self.normals
            .iter()
            .enumerate()
            .fold(0, |m, (k, &n)| m | u64::from(above_horizon(n, d)) << k)
    }

    /// For each direction `r` of `dirs` in turn, every point `k` in order: `f(k, r, end)`,
    /// `end` where the ray from point k along `dirs[r]` ended, `None` where the direction
    /// is below its horizon (not traced). One coherent closest-hit walk per direction
    /// ([`Tracer::closest_coherent`]); each point sees its rays in the order of `dirs`, as a
    /// point-at-a-time gather would give them. Returns the rays traced.
    pub(crate) fn for_each_hit(
        &mut self,
        tracer: &Tracer,
        surfaces: &SurfaceReader<'_>,
        dirs: &[Vec3],
        mut f: impl FnMut(usize, usize, Option<RayEnd<'_>>),
    ) -> u64 {
        let mut hits = [None; PACKET_RAYS];
        let mut rays = 0u64;
        for (r, &d) in dirs.iter().enumerate() {
            let active = self.above(d);
            rays += u64::from(active.count_ones());
            tracer.closest_coherent(&mut self.packet, d, active, &mut hits);
            for k in 0..self.len() {
                if active >> k & 1 == 0 {
                    f(k, r, None);
                    continue;
                }
                match &hits[k] {
                    None => f(k, r, Some(RayEnd::Escaped)),
                    Some(hit) => {
                        let surface = surfaces.at(hit, self.origins[k], d);
                        let end = if surface.front_face {
                            RayEnd::Front(&surface)
                        } else {
                            RayEnd::Back
                        };
                        f(k, r, Some(end));
                    }
                }
            }
        }
        rays
    }

    /// For each direction `r` of `dirs` in turn, every point `k` in order: `f(k, r,
    /// visible)`, `visible` whether the ray from point k along `dirs[r]` escapes, `None`
    /// where the direction is below its horizon (not traced). One coherent any-hit walk
    /// per direction ([`Tracer::occluded_coherent`]). Returns the rays traced.
    pub(crate) fn for_each_visibility(
        &mut self,
        tracer: &Tracer,
        dirs: &[Vec3],
        mut f: impl FnMut(usize, usize, Option<bool>),
    ) -> u64 {
        let mut rays = 0u64;
        for (r, &d) in dirs.iter().enumerate() {
            let active = self.above(d);
            rays += u64::from(active.count_ones());
            let occluded = tracer.occluded_coherent(&mut self.packet, d, f32::INFINITY, active);
            for k in 0..self.len() {
                let traced = active >> k & 1 == 1;
                f(k, r, traced.then_some(occluded >> k & 1 == 0));
            }
        }
        rays
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_decode_and_repeat() {
        let tex = Texture8 {
            width: 2,
            height: 1,
            texels: vec![[255, 255, 255, 255], [0, 0, 0, 255]],
        };
        let lin = LinearTexture::from_srgb(&tex);
        // Texel centres read back exactly; repeat wraps u by whole periods.
        assert_eq!(lin.bilinear_repeat(Vec2::new(0.25, 0.5)), Vec3::ONE);
        assert_eq!(lin.bilinear_repeat(Vec2::new(0.75, 0.5)), Vec3::ZERO);
        assert_eq!(lin.bilinear_repeat(Vec2::new(-0.75, 0.5)), Vec3::ONE);
        // Halfway between the two centres across the seam: the average.
        let mid = lin.bilinear_repeat(Vec2::new(0.0, 0.5));
        assert!((mid - Vec3::splat(0.5)).abs().max_element() < 1e-6);
        // sRGB 128 is linear 0.2158.
        let grey = LinearTexture::from_srgb(&Texture8 {
            width: 1,
            height: 1,
            texels: vec![[128, 128, 128, 255]],
        });
        assert!((grey.texels[0].x - 0.2158).abs() < 1e-3);
    }
}
