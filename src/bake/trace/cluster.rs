//! Triangle clusters: the leaves of the tracer's BVH ([`super::Tracer`]). A cluster is up to
//! [`CLUSTER`] triangles that lie together, stored by lane (structure of arrays) with the
//! ray-independent part of Möller–Trumbore precomputed, so that one ray meets all of them
//! in [`CLUSTER`] / W vector tests at W lanes.
//!
//! Clusters are cut from a binary BVH of the triangles (obvhs's PLOC build): every highest
//! subtree holding at most [`CLUSTER`] triangles is one cluster (a leaf of more is cut in
//! runs of [`CLUSTER`]). The compressed-wide BVH is then built over the clusters' boxes,
//! one cluster per leaf slot.
//!
//! The lanes hold v0, e1 = v0 − v1, e2 = v2 − v0 and n = e1 × e2 as obvhs's
//! `Triangle::intersect` computes them (glam's Vec3A operations, so the same bits), and a
//! test performs that function's operations in its order per lane: q = d × c with
//! c = v0 − o, u = (q·e2)/(n·d), v = (q·e1)/(n·d), w = 1 − u − v, t = (n·c)/(n·d); a hit
//! has no sign bit set in u, v or w and n·d ≠ 0 (a ±∞ reciprocal is never 0, so as in
//! obvhs only the reciprocal is tested). An unused lane holds v0 = NaN: its t is NaN, which
//! no comparison accepts.

use std::time::Duration;

use glam::Vec3A;
use obvhs::{
    BvhBuildParams,
    aabb::Aabb,
    bvh2::{Bvh2, builder::build_bvh2_from_tris},
    cwbvh::{CwBvh, builder::build_cwbvh},
    triangle::Triangle,
};

use super::lanes::RayLanes;

/// Most triangles in a cluster: two AVX2 vectors of lanes (the sizes measured: the
/// module doc of [`super`], "Why clusters").
pub const CLUSTER: usize = 16;

/// One cluster's Möller–Trumbore constants by lane (module doc); 768 bytes, 12 cache
/// lines.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Cluster {
    v0: [[f32; CLUSTER]; 3],
    e1: [[f32; CLUSTER]; 3],
    e2: [[f32; CLUSTER]; 3],
    n: [[f32; CLUSTER]; 3],
}

/// A ray direction and interval splat into lanes, shared by the tests of one query.
pub struct LaneRay<L> {
    pub d: [L; 3],
    pub t_min: L,
    pub t_max: L,
}

impl<L: RayLanes> LaneRay<L> {
    #[inline(always)]
    pub fn new(d: Vec3A, t_min: f32, t_max: f32) -> Self {
        LaneRay {
            d: [L::splat(d.x), L::splat(d.y), L::splat(d.z)],
            t_min: L::splat(t_min),
            t_max: L::splat(t_max),
        }
    }
}

impl Cluster {
    /// For the ray from `o` along `ray.d`, lanes `k..k + L::WIDTH`: each lane's t and the
    /// lanes that hit (inside the triangle, n·d ≠ 0; t not yet checked).
    #[inline(always)]
    fn lanes<L: RayLanes>(&self, o: &[L; 3], ray: &LaneRay<L>, k: usize) -> (L, u32) {
        let load = |a: &[[f32; CLUSTER]; 3]| {
            [
                L::load(&a[0][k..]),
                L::load(&a[1][k..]),
                L::load(&a[2][k..]),
            ]
        };
        let [dx, dy, dz] = ray.d;
        let one = L::splat(1.0);
        let [nx, ny, nz] = load(&self.n);
        let inv_det = one.div(nx.mul(dx).add(ny.mul(dy)).add(nz.mul(dz)));
        let [vx, vy, vz] = load(&self.v0);
        let (cx, cy, cz) = (vx.sub(o[0]), vy.sub(o[1]), vz.sub(o[2]));
        // q = d × c
        let qx = dy.mul(cz).sub(dz.mul(cy));
        let qy = dz.mul(cx).sub(dx.mul(cz));
        let qz = dx.mul(cy).sub(dy.mul(cx));
        let [e2x, e2y, e2z] = load(&self.e2);
        let [e1x, e1y, e1z] = load(&self.e1);
        let u = qx.mul(e2x).add(qy.mul(e2y)).add(qz.mul(e2z)).mul(inv_det);
        let v = qx.mul(e1x).add(qy.mul(e1y)).add(qz.mul(e1z)).mul(inv_det);
        let w = one.sub(u).sub(v);
        let outside = u.negative() | v.negative() | w.negative();
        let zero = L::splat(0.0);
        let zero_det = inv_det.le(zero) & inv_det.ge(zero);
        let t = nx.mul(cx).add(ny.mul(cy)).add(nz.mul(cz)).mul(inv_det);
        (t, !(outside | zero_det))
    }

    /// Whether the ray from `o` hits a triangle of the cluster at t ∈ [t_min, t_max)
    /// (obvhs's any-hit traversal counts a hit when t < t_max).
    #[inline(always)]
    pub fn any_hit<L: RayLanes>(&self, o: &[L; 3], ray: &LaneRay<L>) -> bool {
        (0..CLUSTER).step_by(L::WIDTH).any(|k| {
            let (t, inside) = self.lanes(o, ray, k);
            inside & t.ge(ray.t_min) & t.lt(ray.t_max) != 0
        })
    }

    /// The nearest hit of the ray from `o` at t ∈ [t_min, `t_far`): its lane and t; of
    /// equal ts the lowest lane, as a walk over the lanes in order keeping strictly nearer
    /// hits finds.
    #[inline(always)]
    pub fn nearest<L: RayLanes>(
        &self,
        o: &[L; 3],
        ray: &LaneRay<L>,
        t_far: f32,
    ) -> Option<(usize, f32)> {
        let mut best: Option<(usize, f32)> = None;
        let mut ts = [0.0f32; CLUSTER];
        for k in (0..CLUSTER).step_by(L::WIDTH) {
            let far = L::splat(best.map_or(t_far, |(_, t)| t));
            let (t, inside) = self.lanes(o, ray, k);
            let mut hits = inside & t.ge(ray.t_min) & t.lt(far);
            if hits == 0 {
                continue;
            }
            t.store(&mut ts[k..]);
            while hits != 0 {
                let lane = hits.trailing_zeros() as usize;
                hits &= hits - 1;
                if best.is_none_or(|(_, b)| ts[k + lane] < b) {
                    best = Some((k + lane, ts[k + lane]));
                }
            }
        }
        best
    }
}

/// The BVH over the clusters of `tris`, the clusters in its primitive order, and each
/// cluster's first triangle in `order` (one more entry: the end), `order` being the
/// triangles (indices into `tris`) cluster by cluster.
pub struct Clustered {
    pub bvh: CwBvh,
    pub clusters: Vec<Cluster>,
    pub starts: Vec<u32>,
    pub order: Vec<u32>,
}

/// Clusters `tris` (module doc) and builds the BVH over them; `build_time` gets the BVH
/// builds' core time. `tris` must not be empty.
pub fn build(tris: &[Triangle], build_time: &mut Duration) -> Clustered {
    let bvh2 = build_bvh2_from_tris(tris, BvhBuildParams::medium_build(), build_time);
    let groups = cut(&bvh2);
    let boxes: Vec<Aabb> = groups
        .iter()
        .map(|group| {
            group.iter().fold(Aabb::empty(), |mut b, &p| {
                let tri = &tris[p as usize];
                b.extend(tri.v0);
                b.extend(tri.v1);
                b.extend(tri.v2);
                b
            })
        })
        .collect();
    let mut params = BvhBuildParams::medium_build();
    params.max_prims_per_leaf = 1;
    let bvh = build_cwbvh(&boxes, params, build_time);
    let mut clusters = Vec::with_capacity(groups.len());
    let mut starts = Vec::with_capacity(groups.len() + 1);
    let mut order = Vec::with_capacity(tris.len());
    for &g in &bvh.primitive_indices {
        let group = &groups[g as usize];
        starts.push(order.len() as u32);
        order.extend_from_slice(group);
        let mut cluster = Cluster {
            v0: [[f32::NAN; CLUSTER]; 3],
            e1: [[0.0; CLUSTER]; 3],
            e2: [[0.0; CLUSTER]; 3],
            n: [[0.0; CLUSTER]; 3],
        };
        for (lane, &p) in group.iter().enumerate() {
            let tri = &tris[p as usize];
            let (e1, e2) = (tri.v0 - tri.v1, tri.v2 - tri.v0);
            let n = e1.cross(e2);
            for axis in 0..3 {
                cluster.v0[axis][lane] = tri.v0[axis];
                cluster.e1[axis][lane] = e1[axis];
                cluster.e2[axis][lane] = e2[axis];
                cluster.n[axis][lane] = n[axis];
            }
        }
        clusters.push(cluster);
    }
    starts.push(order.len() as u32);
    log::debug!(
        "{} triangles in {} clusters ({:.1} each), {} BVH nodes",
        tris.len(),
        groups.len(),
        tris.len() as f64 / groups.len() as f64,
        bvh.nodes.len()
    );
    Clustered {
        bvh,
        clusters,
        starts,
        order,
    }
}

/// The triangles of every highest subtree of `bvh2` with at most [`CLUSTER`] of them,
/// leaves of more cut in runs of [`CLUSTER`].
fn cut(bvh2: &Bvh2) -> Vec<Vec<u32>> {
    // Triangles under each node: over the nodes in reverse depth-first order, so that
    // children are counted before their parent.
    let mut preorder = Vec::with_capacity(bvh2.nodes.len());
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        preorder.push(i);
        let node = &bvh2.nodes[i];
        if node.prim_count == 0 {
            stack.extend([node.first_index as usize, node.first_index as usize + 1]);
        }
    }
    let mut counts = vec![0u32; bvh2.nodes.len()];
    for &i in preorder.iter().rev() {
        let node = &bvh2.nodes[i];
        counts[i] = if node.prim_count > 0 {
            node.prim_count
        } else {
            let first = node.first_index as usize;
            counts[first] + counts[first + 1]
        };
    }
    let mut groups = Vec::new();
    stack.push(0);
    while let Some(i) = stack.pop() {
        let node = &bvh2.nodes[i];
        if counts[i] as usize > CLUSTER && node.prim_count == 0 {
            stack.push(node.first_index as usize + 1);
            stack.push(node.first_index as usize);
            continue;
        }
        let mut prims = Vec::with_capacity(counts[i] as usize);
        let mut below = vec![i];
        while let Some(j) = below.pop() {
            let node = &bvh2.nodes[j];
            if node.prim_count > 0 {
                let first = node.first_index as usize;
                prims.extend_from_slice(
                    &bvh2.primitive_indices[first..first + node.prim_count as usize],
                );
            } else {
                below.push(node.first_index as usize + 1);
                below.push(node.first_index as usize);
            }
        }
        groups.extend(prims.chunks(CLUSTER).map(<[u32]>::to_vec));
    }
    groups
}
