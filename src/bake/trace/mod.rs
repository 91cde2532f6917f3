//! Occlusion and closest-hit rays against a mesh, over an obvhs compressed-wide BVH
//! (CWBVH, Ylitie et al. 2017) whose leaves are clusters of up to
//! [`CLUSTER`](cluster::CLUSTER) = 16 triangles ([`cluster`]); Möller–Trumbore
//! intersection, both faces of a triangle occlude.
//!
//! Self-intersection (DESIGN §6 "rays grazing surfaces"): a ray leaving a surface starts at
//! [`Tracer::offset_origin`], the surface point moved along its geometric normal by
//! [`Tracer::ray_epsilon`] = max(1e-4 × scene diagonal, 64 ulp of the largest coordinate),
//! and only hits with t ≥ [`Tracer::t_min`] (1e-3 of that) count. With a direction in the
//! upper hemisphere the ray then moves away from the plane of its own triangle, even when
//! grazing, so it cannot hit it, while geometry a millimetre away (the inner corner of a
//! floor and a wall) still occludes for scenes up to tens of metres. The scale-relative term
//! keeps the offset meaningful for scenes in other units; the ulp term keeps it above f32
//! rounding for scenes far from the origin.
//!
//! Triangles with zero area or non-finite corners are left out of the BVH: they cannot
//! occlude anything.
//!
//! # Coherent queries
//!
//! [`Tracer::occluded_coherent`] answers up to [`PACKET_RAYS`] rays that share one
//! direction (the visibility bake's direction-major order, [`super::visibility`]) in one
//! walk of the CWBVH with a mask of the rays still alive per stack entry. Each node is
//! decoded once for the packet: the child planes picked by the direction's signs, u8 →
//! f32, times extent·(1/d) — everything but the origin term is shared because the
//! direction is. The rays are stored by coordinate (SoA). With AVX2 a node's 8 child slots
//! sit in the lanes of one register (decoded by vector once per node) and each live ray
//! costs one 8-slot slab test — obvhs's own single-ray test at 8 wide — whose byte of
//! entered slots is transposed into the slots' ray masks (`movemask_epi8`); without AVX2
//! the rays go in blocks of 4 lanes, each block costing one 4-ray slab test per occupied
//! child ([`lanes`]). Few rays of a packet reach a node below the top levels, so a test
//! per ray beats a test per child and block; a node reached by one ray skips the
//! transposition (each slot it enters gets the whole mask). The entered slots are then
//! walked as bit sets, not a branch per slot. In a leaf each live ray meets the cluster's
//! triangles W lanes at a time (16 / W vector tests, stopping at the first hit); a ray
//! found occluded leaves every mask.
//!
//! # Why clusters
//!
//! With obvhs's own leaves (1–3 triangles, 1.5 on average on big, 507k triangles, at a
//! mean depth of 6.9) most of big's query time went to the chain of boxes from the root
//! down to each origin's own leaf, which every direction from a texel walks, and to cold
//! reads of single triangles. Leaves of 16 triangles (11.2 on average on big, 45k
//! clusters under 9.2k nodes, 0.7 MB of nodes) take a level off that chain and turn a
//! leaf's triangles into a few vector tests on adjacent cache lines. Big's bake, the
//! sizes run by turns (2 threads): 20.3–21.0 Mrays/s with 16 a cluster, 14.5–17.7 with 24,
//! 17.4–19.2 with 32, 14.3–14.8 with obvhs's leaves; 8 a cluster gave 16.4–19.2 run by
//! turns with obvhs's leaves at 14.3–15.1. The peer house (23k triangles) runs at least as
//! fast; the built-in house (448 large triangles) bakes about 15 % slower, a ray that
//! crosses a cluster's box meeting all its triangles.
//!
//! The two vCPUs of the machine these figures come from see about 8 MiB of its L3: a
//! chain of dependent loads costs 18 ns a load within 8 MiB and 110–150 ns beyond 12 MiB,
//! with huge pages or without. Big's clusters are 35 MB (768 bytes each), so on big the
//! first read of a cluster is a DRAM read, while its nodes stay in the cache.
//!
//! Measured with obvhs's leaves and not kept: splitting each ray at a near radius r
//! (per packet each origin's near set, the triangles whose box meets a cube of half-side
//! a bit over r less those wholly below its horizon, tested 8 per vector, the other rays
//! walking with the node tests' lower bound on t raised from 1e-4 to r) ran big's queries
//! at 17–22 Mrays/s against 15–16, but gathering the sets cost 0.06 s a thread of a 0.5 s
//! bake (bake 12.0–18.0 against 13.5–15.4; the house about 4 % slower). Fans of one
//! texel's directions instead of packets of one direction, packets of two neighbouring
//! directions, prefetching the children a packet enters, four walks interleaved a visit
//! at a time, and testing two rays' nodes per AVX-512 register (Zen 4 runs a 512-bit
//! operation as two 256-bit ones) were no faster either.
//!
//! A node reached by at least [`PACKET_TEST_RAYS`] rays is first tested for the whole
//! packet (AVX2 walk): every operation of the slab test is monotonic in each origin
//! coordinate, rounding included, so evaluated at the two ends of the box of the query's
//! origins it bounds every ray's t_min and t_max; where the bounds decide every slot (all
//! rays enter it, or none does) the per-ray tests are skipped, and each ray's answer is
//! the one its own test gives. Nodes reached by many rays are the upper ones, large beside
//! the packet. Lower nodes and leaves are not tested so: with obvhs's leaves, 58 % of the
//! house's child tests and 96 % of its triangle tests were undecided at 64 texels per
//! packet, and the walk was slower with it.
//!
//! Bit-identity: [`Tracer::occluded`] walks the same BVH with obvhs's single-ray
//! traversal, meeting a cluster's triangles one by one with obvhs's `Triangle::intersect`.
//! Every per-ray operation of the coherent walk is the very IEEE operation, in the very
//! order and with the same min/max operand order (NaN handling), that obvhs's
//! `CwBvhNode::intersect_ray_simd` and `Triangle::intersect` perform (products shared by
//! the packet are the same products), and a ray enters a child exactly when its own
//! single-ray traversal would, so each ray's answer is bit-for-bit that of
//! [`Tracer::occluded`] — only the order of visits differs, which an any-hit query does
//! not see. Tested here (random triangle soup, axis-aligned and finite-`t_max` rays) and
//! in `tests/bake_visibility.rs` (whole bakes against a single-ray reference).
//!
//! # Closest hits
//!
//! [`Tracer::closest_coherent`] is the same walk for the nearest hit of each ray, as the
//! lightmap bakes' gathers need it (`super::surface::PointGroup`): every ray
//! keeps the far end of its interval (∞, then its nearest hit so far), the node tests cull
//! by it per ray instead of by one shared `t_max`, a triangle's hit replaces a ray's when
//! strictly nearer (in a cluster, of equal ts the first lane's, as [`Tracer::closest_hit`]
//! keeps), and no ray leaves the walk early. Each ray's `t` is the nearest
//! [`Tracer::closest_hit`] finds (the same operations); only where two triangles are hit
//! at exactly the same `t` may the walks' orders pick different ones.

use std::time::Duration;

use glam::{Vec3, Vec3A, Vec4};
use obvhs::{
    cwbvh::{CwBvh, node::CwBvhNode},
    ray::{Ray, RayHit, safe_inverse},
    triangle::Triangle,
};

use crate::scene::Mesh;

mod cluster;
mod lanes;

/// The variable that picks the tracer's SIMD width, and the widths it takes.
pub const LANES_ENV: &str = "SHVIS_TRACE_LANES";
/// The values [`LANES_ENV`] may hold.
pub const LANES_VALUES: [&str; 3] = ["4", "8", "16"];
use cluster::{Cluster, LaneRay};
use lanes::{RayLanes, Width};

/// Normal offset of ray origins relative to the scene's bounding-box diagonal.
pub const EPSILON_PER_EXTENT: f32 = 1e-4;

/// Most rays of one [`Tracer::occluded_coherent`] query (one bit each of a `u64` mask).
pub const PACKET_RAYS: usize = 64;
/// obvhs's node-test lower bound on t (`cwbvh::node::EPSILON`, crate-private there),
/// repeated so that coherent node tests equal single-ray ones bit for bit.
const NODE_T_MIN: f32 = 0.0001;

/// Origins of one coherent query, stored by coordinate (ray i = entry i of each axis,
/// loaded [`RayLanes::WIDTH`] rays at a time), and the traversal stack, reused across
/// queries.
#[derive(Clone, Debug)]
pub struct RayPacket {
    x: [f32; PACKET_RAYS],
    y: [f32; PACKET_RAYS],
    z: [f32; PACKET_RAYS],
    len: usize,
    /// Per ray, the far end of its interval: the query's `t_max` for any-hit queries, the
    /// nearest hit so far for closest-hit ones.
    t_far: [f32; PACKET_RAYS],
    /// Per ray, the BVH primitive of its nearest hit so far ([`NO_HIT`]: none).
    primitive: [u32; PACKET_RAYS],
    /// In an any-hit walk, the box of the query's origins (lowest, highest corner), for
    /// deciding a node for all its rays at once ([`PACKET_TEST_RAYS`]); `None` in a
    /// closest-hit walk, whose rays' intervals differ.
    origin_box: Option<(Vec3A, Vec3A)>,
    stack: Vec<(u32, u64)>,
}

/// Fewest rays at a node for which the AVX2 walk first tries to decide the node's children
/// for the whole packet from its origins' box ([`RayPacket::origin_box`]).
const PACKET_TEST_RAYS: u32 = 16;

/// [`RayPacket`]'s primitive of a ray that hit nothing.
const NO_HIT: u32 = u32::MAX;

impl RayPacket {
    /// A packet of `origins` (ray i = bit i of the query masks).
    ///
    /// # Panics
    /// With more than [`PACKET_RAYS`] origins (a bug in the caller).
    pub fn new(origins: &[Vec3]) -> RayPacket {
        assert!(
            origins.len() <= PACKET_RAYS,
            "{} origins exceed a packet of {PACKET_RAYS}",
            origins.len()
        );
        let mut packet = RayPacket {
            x: [0.0; PACKET_RAYS],
            y: [0.0; PACKET_RAYS],
            z: [0.0; PACKET_RAYS],
            len: origins.len(),
            t_far: [f32::INFINITY; PACKET_RAYS],
            primitive: [NO_HIT; PACKET_RAYS],
            origin_box: None,
            stack: Vec::with_capacity(256),
        };
        for (i, o) in origins.iter().enumerate() {
            (packet.x[i], packet.y[i], packet.z[i]) = (o.x, o.y, o.z);
        }
        packet
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the packet has no ray.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Mask of all rays of the packet.
    pub fn all(&self) -> u64 {
        if self.len == PACKET_RAYS {
            !0
        } else {
            (1u64 << self.len) - 1
        }
    }
}

/// `(first_ray, lanes)` of every block of `width` (< 64) consecutive rays with a ray in
/// `mask`, `lanes` = that block's bits of `mask`. An iterator, not a closure-taking
/// function: a closure is compiled without the walk's target features unless inlined, and
/// then every lane operation in it is a call.
#[inline(always)]
fn blocks(width: usize, mask: u64) -> impl Iterator<Item = (usize, u32)> {
    let block_bits = (1u64 << width) - 1;
    let mut todo = mask;
    std::iter::from_fn(move || {
        (todo != 0).then(|| {
            let first = todo.trailing_zeros() as usize / width * width;
            let lanes = ((todo >> first) & block_bits) as u32;
            todo &= !(block_bits << first);
            (first, lanes)
        })
    })
}

/// The near and far planes of child slot `c` along one axis, picked by the direction's
/// sign, u8 → f32 times extent·(1/d), splat.
#[inline(always)]
fn near_far<L: RayLanes>(
    lo: &[u8; 8],
    hi: &[u8; 8],
    negative: bool,
    scale: f32,
    c: usize,
) -> (L, L) {
    let (near, far) = if negative {
        (hi[c], lo[c])
    } else {
        (lo[c], hi[c])
    };
    (
        L::splat(f32::from(near) * scale),
        L::splat(f32::from(far) * scale),
    )
}

/// The set bits of a slot set or ray mask, lowest first.
#[inline(always)]
fn slots(set: impl Into<u64>) -> impl Iterator<Item = usize> {
    let mut todo: u64 = set.into();
    std::iter::from_fn(move || {
        (todo != 0).then(|| {
            let c = todo.trailing_zeros() as usize;
            todo &= todo - 1;
            c
        })
    })
}

/// Any-hit ray queries against a static mesh.
pub struct Tracer {
    /// Over the triangle clusters; `None` for a mesh without a usable triangle: nothing
    /// occludes.
    bvh: Option<CwBvh>,
    /// The clusters in BVH primitive order ([`cluster`]).
    clusters: Vec<Cluster>,
    /// Cluster k's triangles are `triangles[starts[k]..starts[k + 1]]`, lane by lane.
    starts: Vec<u32>,
    /// Triangles cluster by cluster.
    triangles: Vec<Triangle>,
    /// Mesh triangle index of each of `triangles`.
    mesh_triangles: Vec<u32>,
    ray_epsilon: f32,
    /// Lanes of the coherent walk on this CPU.
    width: Width,
}

/// A copy of `items` in memory the kernel is asked to back with 2 MiB pages (Linux's
/// `MADV_HUGEPAGE`, before the copy touches it; elsewhere a plain copy). Walks read the
/// nodes and triangles at random: on big scenes (tens of MB) 4 KiB pages add a TLB miss to
/// most of the cache misses the walk waits on.
fn in_huge_pages<T: Copy>(items: &[T]) -> Vec<T> {
    let mut copy = Vec::with_capacity(items.len());
    #[cfg(target_os = "linux")]
    advise_range(copy.as_ptr() as usize, copy.capacity() * size_of::<T>());
    copy.extend_from_slice(items);
    copy
}

/// Asks the kernel to back the whole 2 MiB pages inside `items` with 2 MiB pages (Linux's
/// `MADV_HUGEPAGE`; elsewhere nothing). Pages already touched keep their 4 KiB pages: call
/// it on a fresh allocation (`vec![0.0; n]` of tens of MB) before filling it.
pub fn advise_huge_pages<T>(items: &[T]) {
    #[cfg(target_os = "linux")]
    advise_range(items.as_ptr() as usize, size_of_val(items));
    #[cfg(not(target_os = "linux"))]
    let _ = items;
}

/// Asks for 2 MiB pages over the whole 2 MiB pages inside `len` bytes from `start`.
#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
fn advise_range(start: usize, len: usize) {
    const HUGE_PAGE: usize = 2 << 20;
    let (begin, end) = (
        start.next_multiple_of(HUGE_PAGE),
        (start + len) / HUGE_PAGE * HUGE_PAGE,
    );
    if end > begin {
        // SAFETY: advice over pages of this allocation; it changes no memory contents, and
        // a refusal (EINVAL where THP is off) leaves ordinary pages.
        unsafe {
            libc::madvise(begin as *mut libc::c_void, end - begin, libc::MADV_HUGEPAGE);
        }
    }
}

/// The nearest surface along a ray ([`Tracer::closest_hit`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Index of the mesh triangle hit (`Mesh::indices[3·triangle..]`).
    pub triangle: u32,
    /// Distance along the unit direction, metres.
    pub t: f32,
    /// Barycentric weights of the triangle's corners 1 and 2 at the hit (corner 0 gets
    /// 1 − u − v).
    pub u: f32,
    pub v: f32,
}

/// `dir` with −0.0 components made +0.0 (x + 0.0 = +0.0 for x = ±0.0). obvhs picks a
/// node's near slab by `dir < 0` but scales by `safe_inverse(dir)`, which keeps the sign
/// of a zero: for a −0.0 component the two disagree and the ray misses every node it
/// meets flat on (a ray straight down, −n of an up-facing normal, onto a floor).
fn canonical_direction(dir: Vec3) -> Vec3A {
    Vec3A::from(dir) + Vec3A::ZERO
}

/// The mesh's triangles that can occlude (module doc): indices in range, finite corners,
/// non-zero area; with their mesh triangle index.
pub fn usable_triangles(mesh: &Mesh) -> Vec<(u32, [Vec3; 3])> {
    (0..mesh.triangle_count())
        .filter(|&t| {
            mesh.indices[3 * t..3 * t + 3]
                .iter()
                .all(|&i| (i as usize) < mesh.vertices.len())
        })
        .map(|t| (t as u32, mesh.triangle_positions(t)))
        .filter(|(_, p)| {
            let finite = p.iter().all(|v| v.is_finite());
            finite && (p[1] - p[0]).cross(p[2] - p[0]).length_squared() > 0.0
        })
        .collect()
}

/// [`Tracer::ray_epsilon`] of a scene with these triangle corners (0 for none).
pub fn ray_epsilon_of(corners: impl Iterator<Item = Vec3>) -> f32 {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    let mut any = false;
    for v in corners {
        (lo, hi) = (lo.min(v), hi.max(v));
        any = true;
    }
    if !any {
        return 0.0;
    }
    let extent = (hi - lo).length();
    let largest = lo.abs().max(hi.abs()).max_element();
    (EPSILON_PER_EXTENT * extent).max(64.0 * f32::EPSILON * largest)
}

impl Tracer {
    /// Builds the BVH over the mesh's triangles (see the module doc for what is skipped).
    pub fn new(mesh: &Mesh) -> Tracer {
        let input = usable_triangles(mesh);
        let (input_triangles, input): (Vec<u32>, Vec<Triangle>) = input
            .into_iter()
            .map(|(t, p)| {
                let tri = Triangle {
                    v0: p[0].into(),
                    v1: p[1].into(),
                    v2: p[2].into(),
                };
                (t, tri)
            })
            .unzip();
        let ray_epsilon = ray_epsilon_of(
            input
                .iter()
                .flat_map(|t| [t.v0, t.v1, t.v2].map(Vec3::from)),
        );
        if input.is_empty() {
            return Tracer {
                bvh: None,
                clusters: Vec::new(),
                starts: vec![0],
                triangles: input,
                mesh_triangles: input_triangles,
                ray_epsilon,
                width: Width::detect(),
            };
        }
        let mut build_time = Duration::ZERO;
        let clustered = cluster::build(&input, &mut build_time);
        let triangles: Vec<Triangle> = clustered.order.iter().map(|&i| input[i as usize]).collect();
        let mesh_triangles = clustered
            .order
            .iter()
            .map(|&i| input_triangles[i as usize])
            .collect();
        log::debug!(
            "BVH over {} triangles built in {:.3} s",
            input.len(),
            build_time.as_secs_f64()
        );
        let mut bvh = clustered.bvh;
        bvh.nodes = in_huge_pages(&bvh.nodes);
        Tracer {
            bvh: Some(bvh),
            clusters: in_huge_pages(&clustered.clusters),
            starts: clustered.starts,
            triangles: in_huge_pages(&triangles),
            mesh_triangles,
            ray_epsilon,
            width: Width::detect(),
        }
    }

    /// Number of triangles in the BVH (degenerate ones left out).
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The normal offset of ray origins, metres (see the module doc).
    pub fn ray_epsilon(&self) -> f32 {
        self.ray_epsilon
    }

    /// Smallest hit distance counted, metres: 1e-3 × [`Self::ray_epsilon`].
    pub fn t_min(&self) -> f32 {
        1e-3 * self.ray_epsilon
    }

    /// Origin for rays leaving the surface at `position` with unit geometric `normal`.
    pub fn offset_origin(&self, position: Vec3, normal: Vec3) -> Vec3 {
        position + normal * self.ray_epsilon
    }

    /// Whether any triangle lies along the ray `origin + t·dir`, t ∈ [`Self::t_min`], `t_max`]
    /// (`dir` unit length, so t is metres; `t_max` may be infinite).
    pub fn occluded(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        let Some(bvh) = &self.bvh else {
            return false;
        };
        let ray = Ray::new(
            Vec3A::from(origin),
            canonical_direction(dir),
            self.t_min(),
            t_max,
        );
        !bvh.ray_traverse_miss(ray, |ray, k| self.nearest_in_cluster(ray, k).0)
    }

    /// The nearest t at which `ray` meets a triangle of cluster `k` within its interval
    /// (∞: none), by obvhs's `Triangle::intersect`, and that triangle (of equal ts the
    /// first in the cluster's lane order).
    fn nearest_in_cluster(&self, ray: &Ray, k: usize) -> (f32, u32) {
        let (first, end) = (self.starts[k], self.starts[k + 1]);
        (first..end).fold((f32::INFINITY, first), |(best, at), i| {
            let t = self.triangles[i as usize].intersect(ray);
            if t < best { (t, i) } else { (best, at) }
        })
    }

    /// The nearest triangle along `origin + t·dir`, t ∈ [[`Self::t_min`], ∞) (`dir` unit
    /// length), with its barycentrics; `None` when the ray escapes. Both faces count.
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        let ray = Ray::new(
            Vec3A::from(origin),
            canonical_direction(dir),
            self.t_min(),
            f32::INFINITY,
        );
        let mut hit = RayHit::none();
        let mut nearest = 0;
        let found = bvh.ray_traverse(ray, &mut hit, |ray, k| {
            let (t, triangle) = self.nearest_in_cluster(ray, k);
            // The traversal keeps a hit strictly nearer than its nearest so far.
            if t < ray.tmax {
                nearest = triangle;
            }
            t
        });
        found.then(|| self.hit_at(nearest, origin, dir, hit.t))
    }

    /// The [`Hit`] of BVH primitive `primitive` at distance `t` along `origin + t·dir`.
    fn hit_at(&self, primitive: u32, origin: Vec3, dir: Vec3, t: f32) -> Hit {
        let tri = &self.triangles[primitive as usize];
        // Barycentrics of the hit point (Möller–Trumbore's u, v recomputed in f32).
        let p = Vec3A::from(origin) + Vec3A::from(dir) * t;
        let (e1, e2, d) = (tri.v1 - tri.v0, tri.v2 - tri.v0, p - tri.v0);
        let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let (dp1, dp2) = (d.dot(e1), d.dot(e2));
        let det = d11 * d22 - d12 * d12;
        let (u, v) = if det > 0.0 {
            (
                ((d22 * dp1 - d12 * dp2) / det).clamp(0.0, 1.0),
                ((d11 * dp2 - d12 * dp1) / det).clamp(0.0, 1.0),
            )
        } else {
            (0.0, 0.0)
        };
        Hit {
            triangle: self.mesh_triangles[primitive as usize],
            t,
            u,
            v,
        }
    }

    /// [`Self::occluded`] for the rays of `packet` selected by `active` (bit i = origin
    /// i), all along the unit `dir`, in one coherent BVH walk (module doc). Returns the
    /// mask of the active rays that are occluded; each bit equals what
    /// [`Self::occluded`] answers for that ray.
    pub fn occluded_coherent(
        &self,
        packet: &mut RayPacket,
        dir: Vec3,
        t_max: f32,
        active: u64,
    ) -> u64 {
        let active = active & packet.all();
        let Some(query) = self.coherent_query(dir, t_max).filter(|_| active != 0) else {
            return 0;
        };
        match self.width {
            Width::Sse4 => query.walk::<Vec4>(packet, active),
            // SAFETY: `Width::detect` found the feature on this CPU.
            #[cfg(target_arch = "x86_64")]
            #[allow(unsafe_code)]
            Width::Avx2x8 => unsafe { query.walk_avx2(packet, active) },
            #[cfg(target_arch = "x86_64")]
            #[allow(unsafe_code)]
            Width::Avx512x16 => unsafe { query.walk_avx512(packet, active) },
        }
    }

    /// What a coherent walk along the unit `dir` up to `t_max` shares across its rays;
    /// `None` for a mesh without a usable triangle.
    fn coherent_query(&self, dir: Vec3, t_max: f32) -> Option<CoherentQuery<'_>> {
        let bvh = self.bvh.as_ref().filter(|bvh| !bvh.nodes.is_empty())?;
        Some(CoherentQuery {
            bvh,
            clusters: &self.clusters,
            starts: &self.starts,
            t_min: self.t_min(),
            t_max,
            dir: canonical_direction(dir),
        })
    }

    /// [`Self::closest_hit`] for the rays of `packet` selected by `active`, all along the
    /// unit `dir`, in one coherent BVH walk (module doc, Closest hits): `hits[i]` is ray
    /// i's nearest hit (`None` for a ray that escapes or is not active). Each ray's `t` is
    /// the one [`Self::closest_hit`] finds; its triangle too, but for hits at exactly equal
    /// `t` on two triangles (a shared edge), where the walks' orders may pick either.
    pub fn closest_coherent(
        &self,
        packet: &mut RayPacket,
        dir: Vec3,
        active: u64,
        hits: &mut [Option<Hit>; PACKET_RAYS],
    ) {
        *hits = [None; PACKET_RAYS];
        let active = active & packet.all();
        let Some(query) = self
            .coherent_query(dir, f32::INFINITY)
            .filter(|_| active != 0)
        else {
            return;
        };
        match self.width {
            Width::Sse4 => query.walk_closest::<Vec4>(packet, active),
            // SAFETY: `Width::detect` found the feature on this CPU.
            #[cfg(target_arch = "x86_64")]
            #[allow(unsafe_code)]
            Width::Avx2x8 => unsafe { query.walk_closest_avx2(packet, active) },
            #[cfg(target_arch = "x86_64")]
            #[allow(unsafe_code)]
            Width::Avx512x16 => unsafe { query.walk_closest_avx512(packet, active) },
        }
        for i in slots(active) {
            let primitive = packet.primitive[i];
            if primitive != NO_HIT {
                let origin = Vec3::new(packet.x[i], packet.y[i], packet.z[i]);
                hits[i] = Some(self.hit_at(primitive, origin, dir, packet.t_far[i]));
            }
        }
    }
}

/// One node of a coherent walk against its rays: what [`RayLanes::child_masks`] needs.
struct NodeTest<'a> {
    node: &'a CwBvhNode,
    /// The node's extent times 1/d, per axis.
    adj: Vec3A,
    /// 1/d as `Ray::new` computes it.
    inv: Vec3A,
    /// d < 0 per axis: which child planes are near.
    negative: [bool; 3],
}

/// [`RayLanes::child_masks`] a block of `L::WIDTH` rays at a time: each occupied child's
/// planes picked by the direction's signs, u8 → f32, times extent·(1/d), splat once per
/// node; then per block of rays the origin term (p − o)·(1/d) and one slab test per
/// child, whose movemask is that child's rays of the block.
#[inline(always)]
fn child_masks_by_block<L: RayLanes>(test: &NodeTest, packet: &RayPacket, mask: u64) -> [u64; 8] {
    let (node, adj, inv) = (test.node, test.adj, test.inv);
    let [rdx, rdy, rdz] = test.negative;
    let s = L::splat;
    let node_t_min = s(NODE_T_MIN);
    let (inv_x, inv_y, inv_z) = (s(inv.x), s(inv.y), s(inv.z));
    let occupied = u64::from_le_bytes(node.child_meta);
    let mut slabs = [[s(0.0); 6]; 8];
    let mut children = [0usize; 8];
    let mut child_count = 0;
    for c in 0..8 {
        if (occupied >> (8 * c)) & 0xff == 0 {
            continue; // empty slot
        }
        let (x0, x1) = near_far::<L>(&node.child_min_x, &node.child_max_x, rdx, adj.x, c);
        let (y0, y1) = near_far::<L>(&node.child_min_y, &node.child_max_y, rdy, adj.y, c);
        let (z0, z1) = near_far::<L>(&node.child_min_z, &node.child_max_z, rdz, adj.z, c);
        slabs[child_count] = [x0, x1, y0, y1, z0, z1];
        children[child_count] = c;
        child_count += 1;
    }
    let mut child_masks = [0u64; 8];
    let (px, py, pz) = (s(node.p.x), s(node.p.y), s(node.p.z));
    for (first, lanes) in blocks(L::WIDTH, mask) {
        // obvhs's slab test with its operand order of _mm_max_ps/_mm_min_ps (NaN handling).
        let ox = px.sub(L::load(&packet.x[first..])).mul(inv_x);
        let oy = py.sub(L::load(&packet.y[first..])).mul(inv_y);
        let oz = pz.sub(L::load(&packet.z[first..])).mul(inv_z);
        let ray_t_far = L::load(&packet.t_far[first..]);
        for (k, [x0, x1, y0, y1, z0, z1]) in slabs[..child_count].iter().enumerate() {
            let tmin = x0.add(ox).max(y0.add(oy).max(z0.add(oz))).max(node_t_min);
            let tmax = x1.add(ox).min(y1.add(oy).min(z1.add(oz))).min(ray_t_far);
            let hits = tmin.le(tmax) & lanes;
            child_masks[children[k]] |= u64::from(hits) << first;
        }
    }
    child_masks
}

/// A node of a coherent walk entered by its rays: the entered slots split into leaves and
/// internal nodes (as bit sets: a branch per slot mispredicts), the rays entering each
/// slot in the walk's buffer ([`RayLanes::child_masks`]).
struct Entered {
    leaves: u32,
    internal: u32,
}

impl Entered {
    #[inline(always)]
    fn node<L: RayLanes>(
        query: &CoherentQuery,
        node: &CwBvhNode,
        inv: Vec3A,
        packet: &RayPacket,
        mask: u64,
        child_masks: &mut [u64; 8],
    ) -> Entered {
        let d = query.dir;
        let test = NodeTest {
            node,
            adj: node.compute_extent() * inv,
            inv,
            negative: [d.x < 0.0, d.y < 0.0, d.z < 0.0],
        };
        let entered = L::child_masks(&test, packet, mask, child_masks);
        let internal = entered & u32::from(node.imask);
        let leaves = entered & !internal;
        Entered { leaves, internal }
    }

    /// The internal children in the order a walk pushes them: far to near (obvhs's
    /// priority, slot ^ octant of the direction), so the nearest is walked next.
    #[inline(always)]
    fn internal_far_to_near(&self, d: Vec3A) -> impl Iterator<Item = usize> {
        let oct = (if d.x < 0.0 { 0 } else { 4 })
            | (if d.y < 0.0 { 0 } else { 2 })
            | (if d.z < 0.0 { 0 } else { 1 });
        let by_priority = slots(self.internal).fold(0u32, |p, c| p | 1 << (c ^ oct));
        slots(by_priority).map(move |priority| priority ^ oct)
    }
}

/// One [`Tracer::occluded_coherent`] query: what the walk shares across its rays.
struct CoherentQuery<'a> {
    bvh: &'a CwBvh,
    clusters: &'a [Cluster],
    starts: &'a [u32],
    t_min: f32,
    t_max: f32,
    /// Unit direction, −0.0 components made +0.0.
    dir: Vec3A,
}

impl CoherentQuery<'_> {
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn walk_avx2(&self, packet: &mut RayPacket, active: u64) -> u64 {
        self.walk::<lanes::Avx2>(packet, active)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn walk_avx512(&self, packet: &mut RayPacket, active: u64) -> u64 {
        self.walk::<lanes::Avx512>(packet, active)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn walk_closest_avx2(&self, packet: &mut RayPacket, active: u64) {
        self.walk_closest::<lanes::Avx2>(packet, active)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn walk_closest_avx512(&self, packet: &mut RayPacket, active: u64) {
        self.walk_closest::<lanes::Avx512>(packet, active)
    }

    /// The walk (module doc), `L::WIDTH` rays per vector operation.
    #[inline(always)]
    fn walk<L: RayLanes>(&self, packet: &mut RayPacket, active: u64) -> u64 {
        let (bvh, d) = (self.bvh, self.dir);
        // As Ray::new computes it.
        let inv = Vec3A::new(safe_inverse(d.x), safe_inverse(d.y), safe_inverse(d.z));
        let s = L::splat;
        let ray = LaneRay::<L>::new(d, self.t_min, self.t_max);
        let mut occluded = 0u64;
        let mut child_masks = [0u64; 8];
        packet.t_far = [self.t_max; PACKET_RAYS];
        packet.origin_box = Some(slots(active).fold(
            (Vec3A::INFINITY, Vec3A::NEG_INFINITY),
            |(lo, hi), i| {
                let o = Vec3A::new(packet.x[i], packet.y[i], packet.z[i]);
                (lo.min(o), hi.max(o))
            },
        ));
        let mut stack = std::mem::take(&mut packet.stack);
        stack.clear();
        stack.push((0, active));
        while let Some((node_index, mask)) = stack.pop() {
            let mask = mask & !occluded;
            if mask == 0 {
                continue;
            }
            let node = &bvh.nodes[node_index as usize];
            let entered = Entered::node::<L>(self, node, inv, packet, mask, &mut child_masks);
            // Leaves first (any hit removes rays from everything below).
            for c in slots(entered.leaves) {
                let (first, count) = node.child_primitives(c);
                for k in first..first + count {
                    let cluster = &self.clusters[k as usize];
                    let mut live = child_masks[c] & !occluded;
                    while live != 0 {
                        let i = live.trailing_zeros() as usize;
                        live &= live - 1;
                        let o = [s(packet.x[i]), s(packet.y[i]), s(packet.z[i])];
                        if cluster.any_hit(&o, &ray) {
                            occluded |= 1 << i;
                        }
                    }
                }
            }
            if occluded == active {
                break;
            }
            for c in entered.internal_far_to_near(d) {
                let m = child_masks[c] & !occluded;
                if m != 0 {
                    stack.push((node.child_node_index(c), m));
                }
            }
        }
        packet.stack = stack;
        occluded
    }

    /// The closest-hit walk (module doc, Closest hits): each ray's interval ends at its
    /// nearest hit so far (`packet.t_far`, its primitive in `packet.primitive`), which the
    /// node tests cull by; children are walked near first.
    #[inline(always)]
    fn walk_closest<L: RayLanes>(&self, packet: &mut RayPacket, active: u64) {
        let (bvh, d) = (self.bvh, self.dir);
        let inv = Vec3A::new(safe_inverse(d.x), safe_inverse(d.y), safe_inverse(d.z));
        let s = L::splat;
        let ray = LaneRay::<L>::new(d, self.t_min, f32::INFINITY);
        packet.t_far = [f32::INFINITY; PACKET_RAYS];
        packet.primitive = [NO_HIT; PACKET_RAYS];
        packet.origin_box = None;
        let mut child_masks = [0u64; 8];
        let mut stack = std::mem::take(&mut packet.stack);
        stack.clear();
        stack.push((0, active));
        while let Some((node_index, mask)) = stack.pop() {
            let node = &bvh.nodes[node_index as usize];
            let entered = Entered::node::<L>(self, node, inv, packet, mask, &mut child_masks);
            for c in slots(entered.leaves) {
                let (first, count) = node.child_primitives(c);
                for k in first..first + count {
                    let cluster = &self.clusters[k as usize];
                    for i in slots(child_masks[c]) {
                        let o = [s(packet.x[i]), s(packet.y[i]), s(packet.z[i])];
                        if let Some((lane, t)) = cluster.nearest(&o, &ray, packet.t_far[i]) {
                            packet.t_far[i] = t;
                            packet.primitive[i] = self.starts[k as usize] + lane as u32;
                        }
                    }
                }
            }
            for c in entered.internal_far_to_near(d) {
                let m = child_masks[c];
                if m != 0 {
                    stack.push((node.child_node_index(c), m));
                }
            }
        }
        packet.stack = stack;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Vertex;

    fn mesh(tris: &[[Vec3; 3]]) -> Mesh {
        let mut m = Mesh::default();
        for t in tris {
            for p in t {
                m.indices.push(m.vertices.len() as u32);
                m.vertices.push(Vertex {
                    position: p.to_array(),
                    ..Vertex::default()
                });
            }
        }
        m
    }

    #[test]
    fn closest_hit_finds_an_axis_aligned_floor_straight_below() {
        let floor = mesh(&[
            [
                Vec3::new(-1.0, -1.0, 0.0),
                Vec3::new(1.0, -1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
            ],
            [
                Vec3::new(-1.0, -1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(-1.0, 1.0, 0.0),
            ],
        ]);
        let tracer = Tracer::new(&floor);
        for origin in [
            Vec3::new(-0.5, 0.0, 0.05),
            Vec3::new(0.5, 0.3, 0.05),
            Vec3::new(0.2, -0.7, -0.3),
        ] {
            let dir = if origin.z > 0.0 { -Vec3::Z } else { Vec3::Z };
            let hit = tracer.closest_hit(origin, dir).expect("the floor is hit");
            assert!((hit.t - origin.z.abs()).abs() < 1e-6, "{hit:?}");
        }
        assert!(
            tracer
                .closest_hit(Vec3::new(1.5, 0.0, 0.05), -Vec3::Z)
                .is_none()
        );
    }

    #[test]
    fn hits_in_range_only_and_both_faces() {
        let tri = [
            Vec3::new(-1.0, -1.0, 5.0),
            Vec3::new(1.0, -1.0, 5.0),
            Vec3::new(0.0, 1.0, 5.0),
        ];
        let tracer = Tracer::new(&mesh(&[tri]));
        assert_eq!(tracer.triangle_count(), 1);
        assert!(tracer.occluded(Vec3::ZERO, Vec3::Z, f32::INFINITY));
        assert!(tracer.occluded(Vec3::new(0.0, 0.0, 10.0), Vec3::NEG_Z, f32::INFINITY));
        assert!(!tracer.occluded(Vec3::ZERO, Vec3::Z, 4.9));
        assert!(!tracer.occluded(Vec3::ZERO, Vec3::NEG_Z, f32::INFINITY));
        assert!(!tracer.occluded(Vec3::new(3.0, 0.0, 0.0), Vec3::Z, f32::INFINITY));
    }

    #[test]
    fn degenerate_and_empty_meshes_occlude_nothing() {
        let p = Vec3::new(0.0, 0.0, 1.0);
        let tracer = Tracer::new(&mesh(&[[p, p, Vec3::ONE]]));
        assert_eq!(tracer.triangle_count(), 0);
        assert!(!tracer.occluded(Vec3::ZERO, Vec3::Z, f32::INFINITY));
        assert!(!Tracer::new(&Mesh::default()).occluded(Vec3::ZERO, Vec3::Z, 1.0));
    }

    /// Uniform numbers in [−1, 1) from a linear congruential generator seeded `seed`.
    fn uniform(seed: u64) -> impl FnMut() -> f32 {
        let mut h = seed;
        move || {
            h = h
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((h >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        }
    }

    /// A cloud of 3000 small random triangles.
    fn soup(next: &mut impl FnMut() -> f32) -> Vec<[Vec3; 3]> {
        (0..3000)
            .map(|_| {
                let c = Vec3::new(next(), next(), next()) * 4.0;
                [0, 1, 2].map(|_| c + Vec3::new(next(), next(), next()) * 0.3)
            })
            .collect()
    }

    /// `count` ray origins on a grid inside the soup.
    fn grid_origins(count: usize) -> Vec<Vec3> {
        (0..count)
            .map(|i| Vec3::new((i % 8) as f32 * 0.1, (i / 8) as f32 * 0.1, 0.05))
            .collect()
    }

    #[test]
    fn coherent_queries_equal_single_rays_bit_for_bit() {
        let mut next = uniform(1);
        let mut tracer = Tracer::new(&mesh(&soup(&mut next)));
        let origins = grid_origins(61);
        let mut packet = RayPacket::new(&origins);
        let widths = Width::available();
        for k in 0..200 * widths.len() {
            tracer.width = widths[k / 200];
            let dir = Vec3::new(next(), next(), next()).normalize_or(Vec3::X);
            let dir = if k % 17 == 0 { Vec3::Y } else { dir }; // axis-aligned: 1/0 slabs
            let active = if k % 3 == 0 {
                !0
            } else {
                0x5555_aaaa_0f0f_f0f0
            };
            let t_max = if k % 5 == 0 { 2.0 } else { f32::INFINITY };
            let got = tracer.occluded_coherent(&mut packet, dir, t_max, active);
            for (i, &o) in origins.iter().enumerate() {
                let want = active >> i & 1 == 1 && tracer.occluded(o, dir, t_max);
                let width = tracer.width;
                assert_eq!(got >> i & 1 == 1, want, "direction {k}, ray {i}, {width:?}");
            }
            assert_eq!(got >> origins.len(), 0);
        }
    }

    #[test]
    fn coherent_closest_hits_equal_single_rays() {
        let mut next = uniform(7);
        let mut tracer = Tracer::new(&mesh(&soup(&mut next)));
        let origins = grid_origins(57);
        let mut packet = RayPacket::new(&origins);
        let mut hits = [None; PACKET_RAYS];
        let widths = Width::available();
        let mut hit_count = 0;
        for k in 0..200 * widths.len() {
            tracer.width = widths[k / 200];
            let dir = Vec3::new(next(), next(), next()).normalize_or(Vec3::X);
            let dir = if k % 17 == 0 { Vec3::NEG_Y } else { dir };
            let active = if k % 3 == 0 {
                !0
            } else {
                0x5555_aaaa_0f0f_f0f0
            };
            tracer.closest_coherent(&mut packet, dir, active, &mut hits);
            for (i, &o) in origins.iter().enumerate() {
                let want = if active >> i & 1 == 1 {
                    tracer.closest_hit(o, dir)
                } else {
                    None
                };
                let width = tracer.width;
                assert_eq!(hits[i], want, "direction {k}, ray {i}, {width:?}");
                hit_count += usize::from(want.is_some());
            }
            assert!(hits[origins.len()..].iter().all(Option::is_none));
        }
        assert!(hit_count > 1000, "the soup is hit ({hit_count} hits)");
    }

    #[test]
    fn grazing_rays_from_offset_origins_miss_their_own_plane() {
        // A 20 m plane in two triangles; rays barely above the horizon from points on it.
        let a = [
            Vec3::new(-10.0, 0.0, -10.0),
            Vec3::new(-10.0, 0.0, 10.0),
            Vec3::new(10.0, 0.0, 10.0),
        ];
        let b = [a[0], a[2], Vec3::new(10.0, 0.0, -10.0)];
        let tracer = Tracer::new(&mesh(&[a, b]));
        for k in 0..64 {
            let phi = k as f32 * 0.1;
            let p = Vec3::new(3.0 * phi.sin(), 0.0, 2.0 * phi.cos());
            let dir = Vec3::new(phi.cos(), 1e-6, phi.sin()).normalize();
            let o = tracer.offset_origin(p, Vec3::Y);
            assert!(
                !tracer.occluded(o, dir, f32::INFINITY),
                "ray {k} hit its own plane"
            );
        }
    }
}
