//! Ray lanes of the coherent walk ([`super::Tracer::occluded_coherent`]): the handful of
//! per-lane float operations it needs, as one trait with a 4-lane (glam's SSE `Vec4`),
//! an 8-lane (AVX2) and a 16-lane (AVX-512F) implementation. Every operation is the
//! IEEE operation that glam's `Vec4` performs per lane, with the same operand order for
//! min/max (`maxps a, b` returns b when either is NaN), so a walk gives the same bits at
//! every width; the widest the CPU has is picked at run time ([`Width::detect`]).

use glam::Vec4;

use super::{NodeTest, RayPacket, child_masks_by_block};

/// A vector of `WIDTH` f32 lanes. Methods are `#[inline(always)]` so that, inlined into a
/// function compiled with the matching target feature, the intrinsics inline too.
pub(super) trait RayLanes: Copy {
    const WIDTH: usize;
    /// Lanes `src[0..WIDTH]`.
    fn load(src: &[f32]) -> Self;
    /// The lanes into `dst[0..WIDTH]`.
    fn store(self, dst: &mut [f32]);
    fn splat(v: f32) -> Self;
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    fn div(self, o: Self) -> Self;
    /// Per lane `self > o ? self : o` (`maxps` operand order).
    fn max(self, o: Self) -> Self;
    /// Per lane `self < o ? self : o` (`minps` operand order).
    fn min(self, o: Self) -> Self;
    /// Bit i set where lane i has self ≤ o (ordered).
    fn le(self, o: Self) -> u32;
    /// Bit i set where lane i has self < o (ordered).
    fn lt(self, o: Self) -> u32;
    /// Bit i set where lane i has self ≥ o (ordered).
    fn ge(self, o: Self) -> u32;
    /// Bit i set where lane i's sign bit is set.
    fn negative(self) -> u32;

    /// Into `masks`, the rays of `mask` (bit i = ray i of `packet`) that enter each child
    /// slot of the node, as obvhs's single-ray `CwBvhNode::intersect_ray_simd` decides per
    /// ray; returns the set of slots some ray enters. (A buffer of the caller's: returned
    /// by value, the 64 bytes would be copied through the stack at every node.)
    #[inline(always)]
    fn child_masks(test: &NodeTest, packet: &RayPacket, mask: u64, masks: &mut [u64; 8]) -> u32 {
        *masks = child_masks_by_block::<Self>(test, packet, mask);
        (0..8).fold(0u32, |e, c| e | u32::from(masks[c] != 0) << c)
    }
}

impl RayLanes for Vec4 {
    const WIDTH: usize = 4;
    #[inline(always)]
    fn load(src: &[f32]) -> Self {
        Vec4::from_slice(src)
    }
    #[inline(always)]
    fn store(self, dst: &mut [f32]) {
        self.write_to_slice(dst);
    }
    #[inline(always)]
    fn splat(v: f32) -> Self {
        Vec4::splat(v)
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        self + o
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        self - o
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        self * o
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        self / o
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        Vec4::max(self, o)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        Vec4::min(self, o)
    }
    #[inline(always)]
    fn le(self, o: Self) -> u32 {
        self.cmple(o).bitmask()
    }
    #[inline(always)]
    fn lt(self, o: Self) -> u32 {
        self.cmplt(o).bitmask()
    }
    #[inline(always)]
    fn ge(self, o: Self) -> u32 {
        self.cmpge(o).bitmask()
    }
    #[inline(always)]
    fn negative(self) -> u32 {
        self.is_negative_bitmask()
    }
}

/// The lane width a walk runs at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Width {
    Sse4,
    #[cfg(target_arch = "x86_64")]
    Avx2x8,
    #[cfg(target_arch = "x86_64")]
    Avx512x16,
}

impl Width {
    /// AVX2's 8 lanes where the CPU has them, else 4. `SHVIS_TRACE_LANES=4|8|16` picks
    /// another width (if the CPU has it), for comparisons. Only the 8-lane walk tests a
    /// node a ray at a time (the 4- and 16-lane ones a block of rays per child); on this
    /// project's AMD EPYC (Zen 4) the queries alone run at 8 / 16 / 4 lanes: big 15–17 /
    /// 6.5 / 8.6 Mrays/s, house 79–85 / 41 / 41–46 (2 threads, 512² × 256).
    pub(super) fn detect() -> Width {
        let cap: usize = std::env::var(super::LANES_ENV)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(8);
        #[cfg(target_arch = "x86_64")]
        {
            if cap >= 16 && std::arch::is_x86_feature_detected!("avx512f") {
                return Width::Avx512x16;
            }
            if cap >= 8 && std::arch::is_x86_feature_detected!("avx2") {
                return Width::Avx2x8;
            }
        }
        let _ = cap;
        Width::Sse4
    }

    /// Every width the running CPU can walk at (for tests).
    #[cfg(test)]
    pub(super) fn available() -> Vec<Width> {
        let mut widths = vec![Width::Sse4];
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                widths.push(Width::Avx2x8);
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                widths.push(Width::Avx512x16);
            }
        }
        widths
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) use x86::{Avx2, Avx512};

#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod x86 {
    use std::arch::x86_64::*;

    use super::{NodeTest, RayLanes, RayPacket};

    /// The arithmetic methods of [`RayLanes`] for a register wrapper `$lanes` of `$width`
    /// lanes, from its intrinsics (the same shape for AVX2 and AVX-512F).
    macro_rules! arithmetic {
        ($lanes:ident, $width:literal, $load:ident, $store:ident, $set1:ident, $add:ident, $sub:ident, $mul:ident, $div:ident, $max:ident, $min:ident) => {
            #[inline(always)]
            fn load(src: &[f32]) -> Self {
                assert!(src.len() >= $width);
                $lanes(unsafe { $load(src.as_ptr()) })
            }
            #[inline(always)]
            fn store(self, dst: &mut [f32]) {
                assert!(dst.len() >= $width);
                unsafe { $store(dst.as_mut_ptr(), self.0) }
            }
            #[inline(always)]
            fn splat(v: f32) -> Self {
                $lanes(unsafe { $set1(v) })
            }
            #[inline(always)]
            fn add(self, o: Self) -> Self {
                $lanes(unsafe { $add(self.0, o.0) })
            }
            #[inline(always)]
            fn sub(self, o: Self) -> Self {
                $lanes(unsafe { $sub(self.0, o.0) })
            }
            #[inline(always)]
            fn mul(self, o: Self) -> Self {
                $lanes(unsafe { $mul(self.0, o.0) })
            }
            #[inline(always)]
            fn div(self, o: Self) -> Self {
                $lanes(unsafe { $div(self.0, o.0) })
            }
            #[inline(always)]
            fn max(self, o: Self) -> Self {
                $lanes(unsafe { $max(self.0, o.0) })
            }
            #[inline(always)]
            fn min(self, o: Self) -> Self {
                $lanes(unsafe { $min(self.0, o.0) })
            }
        };
    }

    /// [`RayLanes::child_masks`] a ray at a time, the node's 8 child slots in the lanes of
    /// an AVX register — obvhs's `intersect_ray_simd` at 8 wide. The child planes are
    /// decoded once per node (u8 → f32 of all 8 slots by vector), each live ray costs one
    /// 8-slot slab test whose movemask is its byte of entered slots, and the 64 bytes are
    /// transposed into the slots' ray masks by `movemask_epi8`. Cheaper than a block of
    /// rays per child where few rays of a block reach the node (big: 3 of 8).
    ///
    /// # Safety
    /// The CPU must have AVX2: called only inlined into a walk compiled with it, which
    /// `Width::detect` picked after checking.
    #[inline(always)]
    unsafe fn child_masks_by_ray(
        test: &NodeTest,
        packet: &RayPacket,
        mask: u64,
        child_masks: &mut [u64; 8],
    ) -> u32 {
        let node = test.node;
        let (adj, inv) = (test.adj, test.inv);
        unsafe {
            let decode = |planes: &[u8; 8], scale: f32| {
                let bytes = _mm_loadl_epi64(planes.as_ptr().cast());
                _mm256_mul_ps(
                    _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(bytes)),
                    _mm256_set1_ps(scale),
                )
            };
            let near_far = |lo: &[u8; 8], hi: &[u8; 8], neg: bool, scale: f32| {
                let (near, far) = if neg { (hi, lo) } else { (lo, hi) };
                (decode(near, scale), decode(far, scale))
            };
            let [rdx, rdy, rdz] = test.negative;
            let (x0, x1) = near_far(&node.child_min_x, &node.child_max_x, rdx, adj.x);
            let (y0, y1) = near_far(&node.child_min_y, &node.child_max_y, rdy, adj.y);
            let (z0, z1) = near_far(&node.child_min_z, &node.child_max_z, rdz, adj.z);
            let meta = _mm_loadl_epi64(node.child_meta.as_ptr().cast());
            let empty = _mm_movemask_epi8(_mm_cmpeq_epi8(meta, _mm_setzero_si128())) as u32;
            let occupied = !empty & 0xff;
            let node_t_min = _mm256_set1_ps(super::super::NODE_T_MIN);
            let p = node.p;
            if let Some((lo, hi)) = packet
                .origin_box
                .filter(|_| mask.count_ones() >= super::super::PACKET_TEST_RAYS)
            {
                // Every op of the slab test is monotonic in each origin coordinate
                // (rounding included), so over the box each ray's t_min and t_max lie
                // between their values at the box's ends: where the bounds decide every
                // slot, they decide it for each ray as its own test would.
                let ends = |p: f32, lo: f32, hi: f32, inv: f32| {
                    let (a, b) = ((p - lo) * inv, (p - hi) * inv);
                    (_mm256_set1_ps(a.min(b)), _mm256_set1_ps(a.max(b)))
                };
                let (ox_lo, ox_hi) = ends(p.x, lo.x, hi.x, inv.x);
                let (oy_lo, oy_hi) = ends(p.y, lo.y, hi.y, inv.y);
                let (oz_lo, oz_hi) = ends(p.z, lo.z, hi.z, inv.z);
                let t_far = _mm256_set1_ps(packet.t_far[mask.trailing_zeros() as usize]);
                let t_min = |ox, oy, oz| {
                    let t = _mm256_max_ps(
                        _mm256_add_ps(x0, ox),
                        _mm256_max_ps(_mm256_add_ps(y0, oy), _mm256_add_ps(z0, oz)),
                    );
                    _mm256_max_ps(t, node_t_min)
                };
                let t_max = |ox, oy, oz| {
                    let t = _mm256_min_ps(
                        _mm256_add_ps(x1, ox),
                        _mm256_min_ps(_mm256_add_ps(y1, oy), _mm256_add_ps(z1, oz)),
                    );
                    _mm256_min_ps(t, t_far)
                };
                let (t_min_lo, t_min_hi) = (t_min(ox_lo, oy_lo, oz_lo), t_min(ox_hi, oy_hi, oz_hi));
                let (t_max_lo, t_max_hi) = (t_max(ox_lo, oy_lo, oz_lo), t_max(ox_hi, oy_hi, oz_hi));
                let all =
                    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t_min_hi, t_max_lo)) as u32;
                let none =
                    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(t_min_lo, t_max_hi)) as u32;
                if (all | none | !occupied) & 0xff == 0xff {
                    let all = all & occupied;
                    whole_mask_at(child_masks, all, mask);
                    return all;
                }
            }
            let mut entered = [0u8; super::super::PACKET_RAYS];
            let mut any = 0u32;
            let mut todo = mask;
            while todo != 0 {
                let i = todo.trailing_zeros() as usize;
                todo &= todo - 1;
                // (p − origin)·(1/d), as obvhs's Vec3A arithmetic per lane.
                let ox = _mm256_set1_ps((p.x - packet.x[i]) * inv.x);
                let oy = _mm256_set1_ps((p.y - packet.y[i]) * inv.y);
                let oz = _mm256_set1_ps((p.z - packet.z[i]) * inv.z);
                let tmin = _mm256_max_ps(
                    _mm256_add_ps(x0, ox),
                    _mm256_max_ps(_mm256_add_ps(y0, oy), _mm256_add_ps(z0, oz)),
                );
                let tmax = _mm256_min_ps(
                    _mm256_add_ps(x1, ox),
                    _mm256_min_ps(_mm256_add_ps(y1, oy), _mm256_add_ps(z1, oz)),
                );
                let tmin = _mm256_max_ps(tmin, node_t_min);
                let tmax = _mm256_min_ps(tmax, _mm256_set1_ps(packet.t_far[i]));
                let hits =
                    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tmin, tmax)) as u32 & occupied;
                entered[i] = hits as u8;
                any |= hits;
            }
            if mask & (mask - 1) == 0 {
                // One ray: each slot it enters gets the whole mask.
                whole_mask_at(child_masks, any, mask);
                return any;
            }
            *child_masks = [0; 8];
            // Transpose: bit c of ray i's byte → bit i of slot c's mask.
            for half in 0..2 {
                if (mask >> (32 * half)) as u32 == 0 {
                    continue;
                }
                let bytes = _mm256_loadu_si256(entered[32 * half..].as_ptr().cast());
                let mut slots = any;
                while slots != 0 {
                    let c = slots.trailing_zeros();
                    slots &= slots - 1;
                    let shifted = _mm256_sll_epi16(bytes, _mm_cvtsi32_si128(7 - c as i32));
                    let rays = _mm256_movemask_epi8(shifted) as u32;
                    child_masks[c as usize] |= u64::from(rays) << (32 * half);
                }
            }
            any
        }
    }

    /// `child_masks` = `mask` at the slots of `slots`, 0 at the others.
    #[inline(always)]
    fn whole_mask_at(child_masks: &mut [u64; 8], slots: u32, mask: u64) {
        *child_masks = [0; 8];
        let mut todo = slots;
        while todo != 0 {
            child_masks[todo.trailing_zeros() as usize] = mask;
            todo &= todo - 1;
        }
    }

    /// Eight lanes in an AVX register; only used inside `#[target_feature(enable = "avx2")]`.
    #[derive(Clone, Copy)]
    pub(in super::super) struct Avx2(__m256);

    // SAFETY (every block below): these methods run only inlined into functions compiled
    // with the feature enabled, which the caller checked at run time (`Width::detect`).
    impl RayLanes for Avx2 {
        const WIDTH: usize = 8;
        arithmetic!(
            Avx2,
            8,
            _mm256_loadu_ps,
            _mm256_storeu_ps,
            _mm256_set1_ps,
            _mm256_add_ps,
            _mm256_sub_ps,
            _mm256_mul_ps,
            _mm256_div_ps,
            _mm256_max_ps,
            _mm256_min_ps
        );
        #[inline(always)]
        fn le(self, o: Self) -> u32 {
            unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0)) as u32 }
        }
        #[inline(always)]
        fn lt(self, o: Self) -> u32 {
            unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(self.0, o.0)) as u32 }
        }
        #[inline(always)]
        fn ge(self, o: Self) -> u32 {
            unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(self.0, o.0)) as u32 }
        }
        #[inline(always)]
        fn negative(self) -> u32 {
            unsafe { _mm256_movemask_ps(self.0) as u32 }
        }
        #[inline(always)]
        fn child_masks(
            test: &NodeTest,
            packet: &RayPacket,
            mask: u64,
            masks: &mut [u64; 8],
        ) -> u32 {
            unsafe { child_masks_by_ray(test, packet, mask, masks) }
        }
    }

    /// Sixteen lanes in an AVX-512 register; only used inside
    /// `#[target_feature(enable = "avx512f")]`.
    #[derive(Clone, Copy)]
    pub(in super::super) struct Avx512(__m512);

    impl RayLanes for Avx512 {
        const WIDTH: usize = 16;
        arithmetic!(
            Avx512,
            16,
            _mm512_loadu_ps,
            _mm512_storeu_ps,
            _mm512_set1_ps,
            _mm512_add_ps,
            _mm512_sub_ps,
            _mm512_mul_ps,
            _mm512_div_ps,
            _mm512_max_ps,
            _mm512_min_ps
        );
        #[inline(always)]
        fn le(self, o: Self) -> u32 {
            u32::from(unsafe { _mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn lt(self, o: Self) -> u32 {
            u32::from(unsafe { _mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn ge(self, o: Self) -> u32 {
            u32::from(unsafe { _mm512_cmp_ps_mask::<_CMP_GE_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn negative(self) -> u32 {
            u32::from(unsafe {
                _mm512_cmplt_epi32_mask(_mm512_castps_si512(self.0), _mm512_setzero_si512())
            })
        }
    }
}
