//! L×H lookup tables (Iwanicki–Sloan §3.2–3.3, DESIGN §2 `unc*`).
//!
//! For a lighting environment L and a surface normal n, the table stores the SH coefficients
//! (order O, the visibility order) of the product L·H_n, H_n(ω) = max(0, n·ω), so that the
//! shader evaluates eq. (4) as one dot product with the texel's visibility V:
//!
//! ```text
//! I(n) = ∫ L V H_n dω ≈ Σ_j V_j (L×H_n)_j,   (L×H_n)_j = Σ_k M_kj h_k(n)
//! ```
//!
//! M is the *product matrix* of §3.3 (`sh::product`): M_kj = Σ_i L_i ∫ y_i y_j y_k dω with
//! L projected to order O+2 (enough for the product with an order-3 H to be exact in the
//! bands the dot product reads), rows k over the clamped cosine's bands (order `h_order`,
//! 3 in the paper) and columns j over V's bands. h_k(n) are the coefficients of the clamped
//! cosine rotated to n: h_lm(n) = A_l y_lm(n), A_l = √(4π/(2l+1)) z_l (`sh::zonal`).
//! "Scaling the rows of the product matrix by the clamped-cosine coefficients oriented along
//! each table normal" (§3.3) is exactly Σ_k M_kj h_k(n). Truncating H to order 3 is a
//! measurable error (its odd bands ≥ 3 vanish, band 4 is the first dropped), so `h_order`
//! is a parameter.
//!
//! Cost per normal: h² basis values and h²·O²·3 multiply-adds (order 6, h 3: 972); a
//! 2×32² dual-paraboloid table (2048 normals) is ≈ 2 M multiply-adds, under a millisecond on
//! one core. Tests: `tests/lxh.rs` (DC visibility reproduces SH irradiance; against direct
//! quadrature of ∫ L V H for band-limited L and V).

use glam::DVec3;

use crate::sh::Order;
use crate::sh::basis::eval_basis;
use crate::sh::product::{Matrix, cached_gaunt_tensor};
use crate::sh::zonal::clamped_cosine_convolution;
use crate::sphere::SphereMap;

/// The per-lighting part of an L×H table: one product matrix per colour channel.
#[derive(Clone, Debug)]
pub struct LxhMatrices {
    pub v_order: Order,
    pub h_order: Order,
    /// M per colour (R, G, B): h² rows × O² columns.
    pub per_channel: [Matrix; 3],
    /// A_l y_lm scaling per row k (the clamped-cosine factor of band l(k)).
    row_factor: Vec<f64>,
}

impl LxhMatrices {
    /// Builds the matrices from RGB radiance SH of at least order `v_order + 2`.
    ///
    /// # Panics
    /// If `radiance_sh` is shorter than (v_order+2)² (a programming error: the lighting
    /// prep projects to that order).
    pub fn new(radiance_sh: &[[f64; 3]], v_order: Order, h_order: Order) -> LxhMatrices {
        let l_order = Order::new(v_order.get() + 2).unwrap_or(v_order);
        LxhMatrices::with_lighting_order(radiance_sh, l_order, v_order, h_order)
    }

    /// As [`new`](Self::new) with the lighting truncated to `l_order` instead of O + 2.
    /// With `h_order` ≥ `l_order` + `v_order` − 1 the clamped cosine is not truncated at all
    /// (L·V has no band beyond that), so `shade` is ∫ L_l V H dω exactly — the error
    /// ladder's "lighting truncated, cosine exact" rung (`crate::attribution`).
    ///
    /// # Panics
    /// If `radiance_sh` is shorter than `l_order`² (a programming error).
    pub fn with_lighting_order(
        radiance_sh: &[[f64; 3]],
        l_order: Order,
        v_order: Order,
        h_order: Order,
    ) -> LxhMatrices {
        assert!(
            radiance_sh.len() >= l_order.coeff_count(),
            "L×H needs lighting of order {l_order}, got {} coefficients",
            radiance_sh.len()
        );
        let tensor = cached_gaunt_tensor(l_order, v_order, h_order);
        let per_channel = [0, 1, 2].map(|c| {
            let l: Vec<f64> = radiance_sh[..l_order.coeff_count()]
                .iter()
                .map(|rgb| rgb[c])
                .collect();
            tensor.product_matrix(&l)
        });
        let row_factor = (0..h_order.get())
            .flat_map(|l| std::iter::repeat_n(clamped_cosine_convolution(l), (2 * l + 1) as usize))
            .collect();
        LxhMatrices {
            v_order,
            h_order,
            per_channel,
            row_factor,
        }
    }

    /// (L×H_n)_j for j < O², RGB, into `out`; `h` is scratch of h² values.
    pub fn eval_into(&self, n: DVec3, h: &mut [f64], out: &mut [[f64; 3]]) {
        eval_basis(self.h_order, n, h);
        for (hk, f) in h.iter_mut().zip(&self.row_factor) {
            *hk *= f;
        }
        let cols = self.v_order.coeff_count();
        // Channel-major accumulation over contiguous rows (vectorizes), then interleave.
        let mut acc = [[0.0f64; 36]; 3];
        if cols <= 36 {
            for (c, m) in self.per_channel.iter().enumerate() {
                let a = &mut acc[c][..cols];
                for (k, &hk) in h.iter().enumerate() {
                    if hk != 0.0 {
                        for (o, &mkj) in a.iter_mut().zip(m.row(k)) {
                            *o += mkj * hk;
                        }
                    }
                }
            }
            for (j, o) in out.iter_mut().enumerate().take(cols) {
                *o = [acc[0][j], acc[1][j], acc[2][j]];
            }
            return;
        }
        for o in out.iter_mut() {
            *o = [0.0; 3];
        }
        for (k, &hk) in h.iter().enumerate() {
            if hk == 0.0 {
                continue;
            }
            for (c, m) in self.per_channel.iter().enumerate() {
                for (o, &mkj) in out.iter_mut().zip(m.row(k)) {
                    o[c] += mkj * hk;
                }
            }
        }
    }

    /// (L×H_n)_j for j < O², RGB.
    pub fn eval(&self, n: DVec3) -> Vec<[f64; 3]> {
        let mut h = vec![0.0; self.h_order.coeff_count()];
        let mut out = vec![[0.0; 3]; self.v_order.coeff_count()];
        self.eval_into(n, &mut h, &mut out);
        out
    }

    /// Outgoing radiance integral I(n) = Σ_j V_j (L×H_n)_j for visibility `v` (O² values).
    pub fn shade(&self, n: DVec3, v: &[f64]) -> [f64; 3] {
        let lxh = self.eval(n);
        let mut sum = [0.0; 3];
        for (vj, t) in v.iter().zip(&lxh) {
            for c in 0..3 {
                sum[c] += vj * t[c];
            }
        }
        sum
    }
}

/// A table over the texel-centre normals of a sphere map: for texel t (flat index of
/// `SphereMap::texel_index`) and coefficient j, `values[t·O² + j]` RGB.
#[derive(Clone, Debug)]
pub struct LxhTable {
    pub map: SphereMap,
    pub v_order: Order,
    pub values: Vec<[f32; 3]>,
}

impl LxhTable {
    /// Σ_j v_j · (L×H)_j at texel `t` (RGB): the table of a vector `v` of SH coefficients
    /// (its first O² used) — a PCA basis vector's or mean's table T_k (Iwanicki–Sloan
    /// eq. (6)).
    pub fn project(&self, t: usize, v: &[f64]) -> [f32; 3] {
        let n = self.v_order.coeff_count();
        let mut s = [0.0f64; 3];
        for (j, vj) in v.iter().enumerate().take(n) {
            let e = self.values[t * n + j];
            for c in 0..3 {
                s[c] += vj * e[c] as f64;
            }
        }
        s.map(|x| x as f32)
    }
}

/// Fills an L×H table for every texel centre of `map` by the symmetric build
/// ([`SymmetricBuild`], §3.3); equal to [`build_table_direct`] to rounding.
pub fn build_table(m: &LxhMatrices, map: SphereMap) -> LxhTable {
    SymmetricBuild::new(map).build(m)
}

/// Fills an L×H table by evaluating [`LxhMatrices::eval_into`] at every texel centre
/// independently (the reference for [`build_table`]).
pub fn build_table_direct(m: &LxhMatrices, map: SphereMap) -> LxhTable {
    let n_coeffs = m.v_order.coeff_count();
    let res = map.res();
    let mut values = vec![[0.0f32; 3]; map.sample_count() * n_coeffs];
    let mut h = vec![0.0; m.h_order.coeff_count()];
    let mut out = vec![[0.0; 3]; n_coeffs];
    for face in 0..map.kind().face_count() {
        for j in 0..res {
            for i in 0..res {
                m.eval_into(map.texel_center_dir(face, i, j), &mut h, &mut out);
                let t = map.texel_index(face, i, j);
                for (dst, src) in values[t * n_coeffs..(t + 1) * n_coeffs]
                    .iter_mut()
                    .zip(&out)
                {
                    *dst = src.map(|v| v as f32);
                }
            }
        }
    }
    LxhTable {
        map,
        v_order: m.v_order,
        values,
    }
}

/// The mirror symmetries the symmetric build uses: x → −x, y → −y, z → −z. In this
/// project's real SH (polar axis z, y_l^{m>0} ∝ Re (x+iy)^m, y_l^{m<0} ∝ Im (x+iy)^|m|,
/// times a polynomial in z of parity l − |m|; `sh::basis`) each one maps every basis
/// function to ± itself:
///
/// ```text
/// y → −y   flips m < 0                          (Im of the conjugate)
/// x → −x   flips m > 0 with m odd, m < 0 with |m| even   ((−1)^m conj)
/// z → −z   flips l − |m| odd
/// ```
///
/// (The paper's "negating in Z flips the bands with m odd" is the z-polar statement for a
/// split in z; here the tables' hemispheres split in y, where it is m < 0 that flips.)
/// Mirror `g` (bit 0: x, bit 1: y, bit 2: z) negates those coordinates.
pub fn mirror(g: u32, d: DVec3) -> DVec3 {
    DVec3::new(
        if g & 1 != 0 { -d.x } else { d.x },
        if g & 2 != 0 { -d.y } else { d.y },
        if g & 4 != 0 { -d.z } else { d.z },
    )
}

/// The parity class of SH coefficient (l, m) under the three mirrors: bit b set when
/// mirror b flips its sign (the rules of [`mirror`]).
pub fn parity_class(l: u32, m: i32) -> u32 {
    let flips_x = (m > 0 && m % 2 != 0) || (m < 0 && m % 2 == 0);
    let flips_y = m < 0;
    let flips_z = (l as i32 - m.abs()) % 2 != 0;
    u32::from(flips_x) | (u32::from(flips_y) << 1) | (u32::from(flips_z) << 2)
}

/// The L×H table build of §3.3 over a sphere map's mirror orbits: texel centres related by
/// the eight mirrors of [`mirror`] (a dual paraboloid's two hemispheres and its square's
/// mirror images; a cube's opposite faces) share one clamped-cosine evaluation. For an
/// orbit's representative n, with rows R_k = A_l(k) M_k (colour-interleaved), the build
/// sums the rows per parity class c, P_c = Σ_{k∈c} y_k(n) R_k (one pass over the h² rows),
/// and every image g·n gets Σ_c (−1)^{|c∧g|} P_c, since y_k(g·n) = ±y_k(n) with the sign
/// of class(k) ∧ g — the Walsh–Hadamard transform of the eight P_c, three butterfly stages.
/// A generic orbit of 8 normals costs h² row updates plus 24 vector add/subtracts instead
/// of 8 h² row updates (order 6, h 3: 33 instead of 72 passes over 108 values). Texels whose mirror image is not exactly another texel centre are
/// evaluated on their own.
pub struct SymmetricBuild {
    map: SphereMap,
    /// Per orbit: the representative's normal and its images under the 8 mirrors (texel
    /// index or none; image 0 is the representative itself).
    orbits: Vec<(DVec3, [Option<usize>; 8])>,
    /// Per texel in an orbit: another texel with the same centre (a dual map's equator
    /// ring, in both hemispheres), which gets the same values.
    alias_of: Vec<Option<usize>>,
    /// Texels in no orbit, evaluated directly.
    singles: Vec<usize>,
}

impl SymmetricBuild {
    /// Finds the orbits of `map`'s texel centres (a one-off per map, cached by callers that
    /// rebuild often).
    pub fn new(map: SphereMap) -> SymmetricBuild {
        let res = map.res();
        let samples = map.sample_count();
        let dir_of = |t: usize| texel_dir(map, t);
        let index_of = |d: DVec3| -> Option<usize> {
            let (face, uv) = map.dir_to_texcoord(d);
            let (i, j) = (uv.x * f64::from(res) - 0.5, uv.y * f64::from(res) - 0.5);
            let (ri, rj) = (i.round(), j.round());
            if (i - ri).abs() > 1e-6 || (j - rj).abs() > 1e-6 || ri < 0.0 || rj < 0.0 {
                return None;
            }
            let (ri, rj) = (ri as u32, rj as u32);
            if ri >= res || rj >= res {
                return None;
            }
            let t = map.texel_index(face, ri, rj);
            (dir_of(t).distance(d) < 1e-12).then_some(t)
        };
        let mut done = vec![false; samples];
        let mut orbits = Vec::new();
        for t in 0..samples {
            let d = dir_of(t);
            if done[t] || d.x < 0.0 || d.y < 0.0 || d.z < 0.0 {
                continue;
            }
            let mut images = [None; 8];
            for (g, image) in images.iter_mut().enumerate() {
                let found = if g == 0 {
                    Some(t)
                } else {
                    index_of(mirror(g as u32, d))
                };
                if let Some(u) = found.filter(|&u| !done[u] || u == t) {
                    *image = Some(u);
                    done[u] = true;
                }
            }
            orbits.push((d, images));
        }
        // A texel whose centre is another's (a dual map's equator ring, in both
        // hemispheres) copies it; the rest are evaluated on their own.
        let (mut alias_of, mut singles) = (vec![None; samples], Vec::new());
        for t in (0..samples).filter(|&t| !done[t]) {
            match index_of(dir_of(t)).filter(|&u| u != t && done[u] && alias_of[u].is_none()) {
                Some(u) => alias_of[u] = Some(t),
                None => singles.push(t),
            }
        }
        SymmetricBuild {
            map,
            orbits,
            alias_of,
            singles,
        }
    }

    /// Orbits (each one clamped-cosine evaluation).
    pub fn orbit_count(&self) -> usize {
        self.orbits.len()
    }

    /// Texels built from an orbit (or copied from one), and evaluated on their own.
    pub fn coverage(&self) -> (usize, usize) {
        let mut seen = vec![false; self.map.sample_count()];
        for (_, images) in &self.orbits {
            for &t in images.iter().flatten() {
                seen[t] = true;
            }
        }
        let aliases = self.alias_of.iter().flatten().count();
        (
            seen.iter().filter(|&&s| s).count() + aliases,
            self.singles.len(),
        )
    }

    /// The sphere map whose texel centres this build covers.
    pub fn map(&self) -> SphereMap {
        self.map
    }

    /// The table for `m` over this build's map, f64, `values[t·O²·3 + 3j + c]`.
    pub fn build_f64(&self, m: &LxhMatrices) -> Vec<f64> {
        let width = 3 * m.v_order.coeff_count();
        let mut out = vec![0.0; self.map.sample_count() * width];
        self.build_into(m, |t, v| out[t * width..(t + 1) * width].copy_from_slice(v));
        out
    }

    /// The table for `m`, stored as f32 ([`LxhTable`]).
    pub fn build(&self, m: &LxhMatrices) -> LxhTable {
        let mut table = LxhTable {
            map: self.map,
            v_order: m.v_order,
            values: vec![[0.0f32; 3]; self.map.sample_count() * m.v_order.coeff_count()],
        };
        self.rebuild(m, &mut table);
        table
    }

    /// Overwrites `table` (same map and visibility order) with the table for `m`, reusing
    /// its memory: the per-frame path of dynamic lighting.
    ///
    /// # Panics
    /// If `table` was built for another map or order (a bug of the caller).
    pub fn rebuild(&self, m: &LxhMatrices, table: &mut LxhTable) {
        assert!(
            table.map == self.map && table.v_order == m.v_order,
            "table of another map or order"
        );
        let width = 3 * m.v_order.coeff_count();
        let flat: &mut [f32] = bytemuck::cast_slice_mut(&mut table.values);
        self.build_into(m, |t, v| {
            for (dst, src) in flat[t * width..(t + 1) * width].iter_mut().zip(v) {
                *dst = *src as f32;
            }
        });
    }

    /// Calls `write(t, values)` once per texel t with its 3·O² colour-interleaved values.
    /// The loops run under the CPU's best vector extension (`pulp` dispatch: AVX2 + FMA
    /// where present, scalar otherwise).
    fn build_into(&self, m: &LxhMatrices, mut write: impl FnMut(usize, &[f64])) {
        let (hn, vn) = (m.h_order.coeff_count(), m.v_order.coeff_count());
        let width = 3 * vn;
        // R_k = A_l(k) M_k, colour-interleaved, grouped by parity class.
        let mut rows = vec![0.0; hn * width];
        let mut class = vec![0u32; hn];
        for l in 0..m.h_order.get() {
            for mm in -(l as i32)..=(l as i32) {
                let k = (l as i32 * (l as i32 + 1) + mm) as usize;
                class[k] = parity_class(l, mm);
                for (c, matrix) in m.per_channel.iter().enumerate() {
                    for (j, &v) in matrix.row(k).iter().enumerate() {
                        rows[k * width + 3 * j + c] = v * m.row_factor[k];
                    }
                }
            }
        }
        pulp::Arch::new().dispatch(OrbitPass {
            build: self,
            rows: &rows,
            class: &class,
            h_order: m.h_order,
            width,
            write: &mut write,
        });
    }
}

/// The orbit loop of [`SymmetricBuild::build_into`] as a `pulp` operation, so that it is
/// compiled once per instruction set and `axpy`/`butterfly` vectorize under it.
struct OrbitPass<'a, W> {
    build: &'a SymmetricBuild,
    rows: &'a [f64],
    class: &'a [u32],
    h_order: Order,
    width: usize,
    write: &'a mut W,
}

impl<W: FnMut(usize, &[f64])> pulp::WithSimd for OrbitPass<'_, W> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let OrbitPass {
            build,
            rows,
            class,
            h_order,
            width,
            write,
        } = self;
        let hn = h_order.coeff_count();
        let map = build.map;
        let dir_of = |t: usize| texel_dir(map, t);

        let mut y = vec![0.0; hn];
        // P_c per parity class, then in place their Walsh–Hadamard transform: entry g
        // becomes Σ_c (−1)^{|c∧g|} P_c, the table at the image under mirror g.
        let mut partial = vec![0.0; 8 * width];
        let mut single = vec![0.0; width];
        for (rep, images) in &build.orbits {
            eval_basis(h_order, *rep, &mut y);
            // The first row of a class is assigned, later ones added; empty classes zeroed.
            let mut started = [false; 8];
            for (k, &yk) in y.iter().enumerate() {
                let c = class[k] as usize;
                let p = &mut partial[c * width..][..width];
                let row = &rows[k * width..(k + 1) * width];
                if started[c] {
                    axpy(p, yk, row);
                } else {
                    scale_into(p, yk, row);
                    started[c] = true;
                }
            }
            for c in (0..8).filter(|&c| !started[c]) {
                partial[c * width..][..width].fill(0.0);
            }
            for bit in [1usize, 2, 4] {
                for c in (0..8).filter(|c| c & bit == 0) {
                    let (lo, hi) = partial.split_at_mut((c | bit) * width);
                    butterfly(&mut lo[c * width..][..width], &mut hi[..width]);
                }
            }
            for (g, image) in images.iter().enumerate() {
                if let Some(t) = *image {
                    let values = &partial[g * width..(g + 1) * width];
                    write(t, values);
                    if let Some(a) = build.alias_of[t] {
                        write(a, values);
                    }
                }
            }
        }
        for &t in &build.singles {
            eval_basis(h_order, dir_of(t), &mut y);
            single.fill(0.0);
            for (k, &yk) in y.iter().enumerate() {
                axpy(&mut single, yk, &rows[k * width..(k + 1) * width]);
            }
            write(t, &single);
        }
    }
}

/// Centre direction of flat texel index `t` (`SphereMap::texel_index`) of `map`.
fn texel_dir(map: SphereMap, t: usize) -> DVec3 {
    let res = map.res() as usize;
    let (face, rest) = ((t / (res * res)) as u32, t % (res * res));
    map.texel_center_dir(face, (rest % res) as u32, (rest / res) as u32)
}

/// dst = a · x, elementwise.
#[inline(always)]
fn scale_into(dst: &mut [f64], a: f64, x: &[f64]) {
    for (d, x) in dst.iter_mut().zip(x) {
        *d = a * x;
    }
}

/// (a, b) ← (a + b, a − b), elementwise.
#[inline(always)]
fn butterfly(a: &mut [f64], b: &mut [f64]) {
    for (x, y) in a.iter_mut().zip(b.iter_mut()) {
        let (s, d) = (*x + *y, *x - *y);
        *x = s;
        *y = d;
    }
}

/// dst += a · x, in fixed 4-lane chunks the compiler turns into vector FMAs under the
/// dispatched target features (no nightly `std::simd`; the tail is scalar).
#[inline(always)]
fn axpy(dst: &mut [f64], a: f64, x: &[f64]) {
    let n = dst.len().min(x.len());
    let (d4, dt) = dst[..n].split_at_mut(n - n % 4);
    let (x4, xt) = x[..n].split_at(n - n % 4);
    for (d, x) in d4.chunks_exact_mut(4).zip(x4.chunks_exact(4)) {
        for lane in 0..4 {
            d[lane] += a * x[lane];
        }
    }
    for (d, x) in dt.iter_mut().zip(xt) {
        *d += a * x;
    }
}
