//! `nmprt`, `nmprtsvdM`, `nmprtsvdMp`, `nmprthl2`, `nmprtratio`: normal mapping for PRT (Sloan, PRT
//! course, "Normal Mapping for PRT"). Per lightmap texel a transfer matrix M
//! (`bake::transfer`: order-3 transferred incident radiance from order-O lighting, shadows
//! and inter-reflection baked in) turns the distant lighting l into l' = M·l; the pixel
//! evaluates the clamped-cosine convolution of l' at the normal-mapped normal:
//!
//! ```text
//! e(n) = y(n)ᵀ C R M l                                   (course; C = diag A_l, R: world → tangent)
//! nmprt:       l' = M l (27 values), e(n_world) = y(n_world)ᵀ C l'       (R folded into n)
//! nmprtsvdM:   A(n) = y(n)ᵀ C over the disk of tangent normals = U S Vᵀ;
//!              per texel c = V_Mᵀ R l' (M per colour), e(n) = Σ_m (U S)_m(n) c_m
//! nmprthl2:    per texel h = H R l', H the least-squares fit of A(n) by the HL2 blend
//!              weights D_b(n) (Green eq. (3)), e(n) = Σ_b D_b(n) h_b
//! nmprtratio:  per texel ρ = lum(y(n_s)ᵀ C l') / lum(E(n_s)), e(n) = ρ · E(n),
//!              E the unshadowed irradiance of l, n_s the texel's shading normal
//! ```
//!
//! The normal basis A is taken with the lighting over the whole sphere (A_kj = A_l(j)·y_j(n_k),
//! cosine-weighted rows on a `BASIS_SIDE`² disk grid, `study::nmprt_svd`): the form whose
//! energies match the course's (98.7 / 99.2 % at M = 6) and whose M = 9 is exactly the full
//! evaluation. U S is stored as an M-channel texture on the disk (`n.xy·½ + ½`, bilinear),
//! built once.
//!
//! **Where the matrix–vector products run.** All relight through the dynamic-lighting
//! machinery (`super::lighting`). For `nmprt`, `nmprtsvdM`, `nmprthl2` and `nmprtratio`,
//! when the lighting changes the CPU forms each texel's values — M·l, then the rows W·R_t
//! (V_Mᵀ or H, formed once per texel) or the ratio — and the update uploads them as the
//! lighting set's per-texel images. `nmprtsvdMp` is the course's pixel shader: per texel
//! P = V_MᵀR M (M × O² per colour) as bake data, l in the uniform block, c = P l per pixel —
//! a lighting change writes the uniforms only; its 3·M·⌈O²/4⌉ layers are dx10 only.
//!
//! Shaders: `nmprt` runs `shlmap.frag` (same 27-value layout), `nmprthl2` `rnm.frag`
//! (three RGB lightmaps, Listing 1 weights), `nmprtratio` `preconv.frag` (ρ in the AO
//! slot), `nmprtsvdM` its own `nmprtsvd.frag`, `nmprtsvdMp` `nmprtsvdp.frag`.

use std::sync::{Arc, OnceLock};

use ash::vk;
use glam::{DMat3, DVec3, Vec3};
use half::f16;
use nalgebra::{DMatrix, SymmetricEigen};
use rayon::prelude::*;

use super::family::{Description, Family, Form, Refusal};
use super::finish::{SlotKind, TextureSlot};
use super::lighting::{LightingData, Recipe};
use super::preconv::PreconvParams;
use super::rnm::RnmVariant;
use super::shlmap::ShLightmapParams;
use super::spec::{BakeNeeds, ReferenceModel};
use super::tables::{f16_range_scale, max_abs};
use super::texels::{TexelGroups, VALUES_PER_TEXEL, pack_groups, upload_texel_groups};
use super::{HwPath, Inputs, ShaderReads, ShaderVariant, Technique, TechniqueError};
use crate::bake::raster::DilationPlan;
use crate::bake::transfer::{TRANSFER_ROWS, TransferMap};
use crate::bake::visibility::DILATION_PASSES;
use crate::gpu::Context;
use crate::gpu::Image;
use crate::sh::{Order, basis::eval_basis, rotate, zonal};

/// Disk grid side of the normal basis: the SVD's rows and U's texels.
pub const BASIS_SIDE: usize = 32;
/// Largest shadowed/unshadowed ratio stored (where the unshadowed irradiance is near zero,
/// inter-reflected light makes the ratio unbounded).
pub const RATIO_MAX: f64 = 16.0;

/// The clamped-cosine convolution factors A_l of the 9 order-3 coefficients.
fn convolution() -> [f64; TRANSFER_ROWS] {
    std::array::from_fn(|i| zonal::clamped_cosine_convolution((i as f64).sqrt() as u32))
}

/// A row of the course's A: y_j(n) convolved with the clamped cosine (lighting over the
/// whole sphere), e(n) = Σ_j A_j(n) l'_j.
pub fn convolved_basis(n: DVec3) -> [f64; TRANSFER_ROWS] {
    let mut y = [0.0; TRANSFER_ROWS];
    eval_basis(Order::THREE, n, &mut y);
    let a = convolution();
    std::array::from_fn(|j| a[j] * y[j])
}

/// The normals of a `side`² grid of the unit disk (tangent-space x, y; z = √(1 − x² − y²),
/// the orthographic hemisphere the course's shader looks U up on), with their disk-area
/// weight.
pub fn disk_normals(side: usize) -> Vec<(DVec3, f64)> {
    let h = 2.0 / side as f64;
    let mut out = Vec::new();
    for j in 0..side {
        for i in 0..side {
            let x = -1.0 + (i as f64 + 0.5) * h;
            let y = -1.0 + (j as f64 + 0.5) * h;
            let r2 = x * x + y * y;
            if r2 < 1.0 {
                out.push((DVec3::new(x, y, (1.0 - r2).sqrt()), h * h));
            }
        }
    }
    out
}

/// The normal basis (module doc): V's columns by decreasing singular value and the HL2
/// least-squares rows.
#[derive(Clone, Debug, PartialEq)]
pub struct NormalBasis {
    /// `vectors[m][j]`: component j of right singular vector m.
    pub vectors: [[f64; TRANSFER_ROWS]; TRANSFER_ROWS],
    pub singular_values: [f64; TRANSFER_ROWS],
    /// `hl2[b][j]`: h_b = Σ_j hl2[b][j] l'_j.
    pub hl2: [[f64; TRANSFER_ROWS]; 3],
}

impl NormalBasis {
    /// The basis on a `side`² disk grid, rows cosine-weighted.
    pub fn new(side: usize) -> NormalBasis {
        let normals = disk_normals(side);
        let mut ata = DMatrix::<f64>::zeros(TRANSFER_ROWS, TRANSFER_ROWS);
        let mut ftf = DMatrix::<f64>::zeros(3, 3);
        let mut fta = DMatrix::<f64>::zeros(3, TRANSFER_ROWS);
        for (n, area) in &normals {
            let a = convolved_basis(*n);
            let d = crate::bake::ssbump::d_encoding(*n);
            for i in 0..TRANSFER_ROWS {
                for j in 0..TRANSFER_ROWS {
                    ata[(i, j)] += area * a[i] * a[j];
                }
            }
            for b in 0..3 {
                for c in 0..3 {
                    ftf[(b, c)] += area * d[b] * d[c];
                }
                for j in 0..TRANSFER_ROWS {
                    fta[(b, j)] += area * d[b] * a[j];
                }
            }
        }
        let eigen = SymmetricEigen::new(ata);
        let mut order: Vec<usize> = (0..TRANSFER_ROWS).collect();
        order.sort_by(|&x, &y| eigen.eigenvalues[y].total_cmp(&eigen.eigenvalues[x]));
        let vectors = std::array::from_fn(|m| {
            let col = order[m];
            std::array::from_fn(|j| eigen.eigenvectors[(j, col)])
        });
        let singular_values = std::array::from_fn(|m| eigen.eigenvalues[order[m]].max(0.0).sqrt());
        let h = ftf
            .try_inverse()
            .expect("the HL2 weights are independent functions of the normal")
            * fta;
        let hl2 = std::array::from_fn(|b| std::array::from_fn(|j| h[(b, j)]));
        NormalBasis {
            vectors,
            singular_values,
            hl2,
        }
    }

    /// The basis every `nmprtsvdM` / `nmprthl2` uses ([`BASIS_SIDE`]), built once.
    pub fn shared() -> Arc<NormalBasis> {
        static BASIS: OnceLock<Arc<NormalBasis>> = OnceLock::new();
        BASIS
            .get_or_init(|| Arc::new(NormalBasis::new(BASIS_SIDE)))
            .clone()
    }

    /// The share of ‖A‖² the first `m` singular values hold.
    pub fn energy(&self, m: usize) -> f64 {
        let total: f64 = self.singular_values.iter().map(|s| s * s).sum();
        self.singular_values[..m].iter().map(|s| s * s).sum::<f64>() / total
    }

    /// (U S)_m(n) = Σ_j A_j(n) V_jm: channel m of the basis texture at normal `n`.
    pub fn basis_value(&self, m: usize, n: DVec3) -> f64 {
        let a = convolved_basis(n);
        (0..TRANSFER_ROWS).map(|j| a[j] * self.vectors[m][j]).sum()
    }
}

/// The normal of the disk texel (i, j) of a `side`² grid (orthographic, `uv = n.xy·½ + ½`;
/// outside the unit circle: the rim).
pub fn disk_texel_normal(i: usize, j: usize, side: usize) -> DVec3 {
    let h = 2.0 / side as f64;
    let (x, y) = (-1.0 + (i as f64 + 0.5) * h, -1.0 + (j as f64 + 0.5) * h);
    let r2 = x * x + y * y;
    if r2 < 1.0 {
        DVec3::new(x, y, (1.0 - r2).sqrt())
    } else {
        DVec3::new(x, y, 0.0) / r2.sqrt()
    }
}

/// Order-3 RGB SH `x` (world space) in the tangent frame `frame` = [t, b, n] (columns):
/// the coefficients of g(ω_t) = f(F ω_t). A left-handed frame is rotated as right-handed
/// (b negated) and then mirrored in y (the coefficients odd in y negated: y, xy, yz).
pub fn to_tangent(frame: &[Vec3; 3], x: &[[f64; 3]; TRANSFER_ROWS]) -> [[f64; 3]; TRANSFER_ROWS] {
    let (t, b, n) = (
        frame[0].as_dvec3(),
        frame[1].as_dvec3(),
        frame[2].as_dvec3(),
    );
    let mirrored = t.cross(b).dot(n) < 0.0;
    let f = DMat3::from_cols(t, if mirrored { -b } else { b }, n);
    let f = if (f.transpose() * f).abs_diff_eq(DMat3::IDENTITY, 1e-4) {
        f
    } else {
        // A degenerate frame: any right-handed one about the normal.
        let n = n.try_normalize().unwrap_or(DVec3::Z);
        let t = n.any_orthonormal_vector();
        DMat3::from_cols(t, n.cross(t), n)
    };
    // An f32 frame is orthonormal to ~1e-7; the rotation wants one to 1e-9.
    let (t, n) = (f.x_axis.normalize(), f.z_axis.normalize());
    let t = (t - n * n.dot(t)).normalize();
    let f = DMat3::from_cols(t, n.cross(t), n);
    let matrices = rotate::rotation_matrices(Order::THREE, f.transpose());
    let mut out = rotate::apply_rotation_rgb(&matrices, x);
    if mirrored {
        for k in [1, 4, 5] {
            out[k] = out[k].map(|v| -v);
        }
    }
    std::array::from_fn(|k| out[k])
}

/// What an `nmprt*` technique evaluates its transfer matrices with: everything its
/// lighting rebuild needs, owned (`super::lighting::LightingRecipe`).
pub struct NmprtRecipe {
    pub variant: NmprtVariant,
    pub transfer: Arc<TransferMap>,
    pub basis: Arc<NormalBasis>,
    /// Fills the gutters of the values formed at covered texels.
    dilation: DilationPlan,
    /// `nmprtsvdM` / `nmprthl2`: per covered texel the rows of W·R_t (W = V_Mᵀ or H, R_t
    /// the texel's world → tangent change), `rows` × 9 f64 — formed once, so a lighting
    /// change costs M·l and this small product per texel.
    tangent_rows: Vec<f64>,
    rows: usize,
    /// `nmprtsvdMp`: the factor undoing its matrices' f16 range scaling.
    pixel_unscale: f32,
}

impl NmprtRecipe {
    pub fn new(variant: NmprtVariant, transfer: Arc<TransferMap>) -> NmprtRecipe {
        let dilation = DilationPlan::new(&transfer.covered, transfer.res, DILATION_PASSES);
        let basis = NormalBasis::shared();
        let w: Vec<[f64; TRANSFER_ROWS]> = match variant {
            NmprtVariant::Svd { m } | NmprtVariant::SvdPixel { m } => {
                basis.vectors[..m as usize].to_vec()
            }
            NmprtVariant::Hl2 => basis.hl2.to_vec(),
            NmprtVariant::Full | NmprtVariant::Ratio => Vec::new(),
        };
        let rows = w.len();
        let mut tangent_rows = vec![0.0f64; transfer.covered.len() * rows * TRANSFER_ROWS];
        if rows > 0 {
            tangent_rows
                .par_chunks_mut(rows * TRANSFER_ROWS)
                .enumerate()
                .filter(|(t, _)| transfer.covered[*t])
                .for_each(|(t, out)| {
                    // Row r of W·R = (Rᵀ w_r)ᵀ: each unit vector's image gives a column.
                    let mut columns = [[[0.0f64; 3]; TRANSFER_ROWS]; TRANSFER_ROWS];
                    for (j, column) in columns.iter_mut().enumerate() {
                        let mut e = [[0.0f64; 3]; TRANSFER_ROWS];
                        e[j] = [1.0; 3];
                        *column = to_tangent(&transfer.frames[t], &e);
                    }
                    for (r, wr) in w.iter().enumerate() {
                        for j in 0..TRANSFER_ROWS {
                            out[r * TRANSFER_ROWS + j] = (0..TRANSFER_ROWS)
                                .map(|i| wr[i] * columns[j][i][0])
                                .sum::<f64>();
                        }
                    }
                });
        }
        NmprtRecipe {
            variant,
            transfer,
            basis,
            dilation,
            tangent_rows,
            rows,
            pixel_unscale: 1.0,
        }
    }

    /// `nmprtsvdMp`'s per-texel matrices P = V_Mᵀ R M (M × O² per colour), dilated, range-
    /// scaled into f16: row (m, c) in ⌈O²/4⌉ RGBA groups, group g of the texel's data =
    /// (3m + c)·⌈O²/4⌉ + k holding columns 4k … 4k+3; and the scale.
    fn pixel_matrices(&self, label: &str) -> Result<(Vec<Vec<f16>>, f32), TechniqueError> {
        let map = &*self.transfer;
        let n = map.columns();
        let row_groups = n.div_ceil(VALUES_PER_TEXEL);
        if row_groups > PIXEL_MAX_ROW_GROUPS {
            return Err(TechniqueError::Input {
                label: label.into(),
                detail: format!(
                    "takes lighting of order ≤ 8; the transfer bake has order {}",
                    map.lighting_order
                ),
            });
        }
        let stride = row_groups * VALUES_PER_TEXEL;
        let size = self.rows * 3 * stride;
        let texels = (map.res * map.res) as usize;
        let mut values = vec![0.0f32; texels * size];
        values
            .par_chunks_mut(size)
            .enumerate()
            .filter(|(t, _)| map.covered[*t])
            .for_each(|(t, out)| {
                let m = map.texel(t);
                let rows = &self.tangent_rows[t * self.rows * TRANSFER_ROWS..]
                    [..self.rows * TRANSFER_ROWS];
                for (r, w) in rows.chunks_exact(TRANSFER_ROWS).enumerate() {
                    for c in 0..3 {
                        let dst = &mut out[(3 * r + c) * stride..][..n];
                        for (i, &wi) in w.iter().enumerate() {
                            let src = &m[(c * TRANSFER_ROWS + i) * n..][..n];
                            for (d, &x) in dst.iter_mut().zip(src) {
                                *d += (wi * f64::from(x)) as f32;
                            }
                        }
                    }
                }
            });
        self.dilation.apply_vectors(&mut values, size);
        let largest = max_abs(values.iter().copied());
        if !largest.is_finite() {
            return Err(TechniqueError::Input {
                label: label.into(),
                detail: "the transfer matrices are not finite".into(),
            });
        }
        let scale = f16_range_scale(largest);
        let groups = pack_groups(texels, size, |t, j| {
            f16::from_f32(values[t * size + j] * scale)
        });
        Ok((groups, scale))
    }

    /// `nmprtsvdMp`'s uniform block for lighting `l`: the matrices' unscale and l per
    /// colour (the rows' layout is compiled in, `LightingData::defines`).
    fn pixel_params(&self, l: &[[f64; 3]]) -> NmprtPixelParams {
        let n = self.transfer.columns();
        let mut light = [[0.0f32; 4]; 3 * PIXEL_MAX_ROW_GROUPS];
        for (j, rgb) in l[..n].iter().enumerate() {
            for c in 0..3 {
                light[c * PIXEL_MAX_ROW_GROUPS + j / 4][j % 4] = rgb[c] as f32;
            }
        }
        NmprtPixelParams {
            unscale: [self.pixel_unscale, 0.0, 0.0, 0.0],
            light,
        }
    }

    /// Σ_j (W R_t)_rj x_j per colour for the rows of texel `t`.
    fn tangent_project(&self, t: usize, x: &[[f64; 3]; TRANSFER_ROWS]) -> Vec<[f64; 3]> {
        let rows = &self.tangent_rows[t * self.rows * TRANSFER_ROWS..][..self.rows * TRANSFER_ROWS];
        rows.chunks_exact(TRANSFER_ROWS)
            .map(|row| std::array::from_fn(|c| row.iter().zip(x).map(|(&w, v)| w * v[c]).sum()))
            .collect()
    }

    /// Values stored per texel: 27, 3M, 12 (three RGB groups), 1.
    pub fn values_per_texel(&self) -> usize {
        match self.variant {
            NmprtVariant::Full => 3 * TRANSFER_ROWS,
            NmprtVariant::Svd { m } | NmprtVariant::SvdPixel { m } => 3 * m as usize,
            NmprtVariant::Hl2 => 3 * VALUES_PER_TEXEL,
            NmprtVariant::Ratio => 1,
        }
    }

    /// Texel `t`'s values for lighting `l` (RGB SH, ≥ O² coefficients) and its order-3
    /// irradiance `irradiance`, in f64 (module doc; the layout of
    /// [`Self::values_per_texel`]).
    pub fn texel_values(&self, t: usize, l: &[[f64; 3]], irradiance: &[[f64; 3]]) -> Vec<f64> {
        let transferred = self.transfer.transferred(t, l);
        let frame = &self.transfer.frames[t];
        match self.variant {
            NmprtVariant::Full => transferred.iter().flatten().copied().collect(),
            NmprtVariant::Svd { .. } | NmprtVariant::SvdPixel { .. } => self
                .tangent_project(t, &transferred)
                .into_iter()
                .flatten()
                .collect(),
            NmprtVariant::Hl2 => {
                let mut out = vec![0.0; 3 * VALUES_PER_TEXEL];
                for (b, h) in self.tangent_project(t, &transferred).iter().enumerate() {
                    out[VALUES_PER_TEXEL * b..][..3].copy_from_slice(h);
                }
                out
            }
            NmprtVariant::Ratio => {
                let n = frame[2].as_dvec3();
                let a = convolved_basis(n);
                let mut y = [0.0; TRANSFER_ROWS];
                eval_basis(Order::THREE, n, &mut y);
                let lum = |rgb: [f64; 3]| 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
                let shadowed = lum(std::array::from_fn(|c| {
                    (0..TRANSFER_ROWS).map(|j| a[j] * transferred[j][c]).sum()
                }));
                let unshadowed = lum(std::array::from_fn(|c| {
                    (0..TRANSFER_ROWS).map(|j| y[j] * irradiance[j][c]).sum()
                }));
                let ratio = if unshadowed > 0.0 {
                    (shadowed / unshadowed).clamp(0.0, RATIO_MAX)
                } else {
                    0.0
                };
                vec![ratio]
            }
        }
    }

    /// Every texel's values (the layout of [`Self::values_per_texel`]) for `radiance_sh`
    /// and its order-3 irradiance, formed at the covered texels and dilated into the
    /// gutters: what [`Self::lighting`] stores in f16.
    pub fn texel_values_all(
        &self,
        radiance_sh: &[[f64; 3]],
        irradiance_sh: &[[f64; 3]],
    ) -> Vec<f32> {
        let map = &*self.transfer;
        let v = self.values_per_texel();
        let texels = (map.res * map.res) as usize;
        let mut values = vec![0.0f32; texels * v];
        values
            .par_chunks_mut(v)
            .enumerate()
            .with_min_len(256)
            .filter(|(t, _)| map.covered[*t])
            .for_each(|(t, out)| {
                for (o, x) in out
                    .iter_mut()
                    .zip(self.texel_values(t, radiance_sh, irradiance_sh))
                {
                    *o = x as f32;
                }
            });
        self.dilation.apply_vectors(&mut values, v);
        values
    }

    /// What the pixel shader computes (before the albedo) from a pixel's interpolated
    /// `values`, its normal-mapped world normal `n` and the texel's frame (module doc; the
    /// SVD basis evaluated exactly rather than from its texture).
    pub fn eval(
        &self,
        values: &[f64],
        n: DVec3,
        frame: &[Vec3; 3],
        irradiance_sh: &[[f64; 3]],
    ) -> [f64; 3] {
        let tangent = || {
            let [t, b, ns] = frame.map(|v| v.as_dvec3());
            DVec3::new(t.dot(n), b.dot(n), ns.dot(n))
                .try_normalize()
                .unwrap_or(DVec3::Z)
        };
        let e: [f64; 3] = match self.variant {
            NmprtVariant::Full => {
                let a = convolved_basis(n);
                std::array::from_fn(|c| (0..TRANSFER_ROWS).map(|j| a[j] * values[3 * j + c]).sum())
            }
            NmprtVariant::Svd { m } | NmprtVariant::SvdPixel { m } => {
                let nt = tangent();
                let u: Vec<f64> = (0..m as usize)
                    .map(|k| self.basis.basis_value(k, nt))
                    .collect();
                std::array::from_fn(|c| {
                    u.iter()
                        .enumerate()
                        .map(|(k, uk)| uk * values[3 * k + c])
                        .sum()
                })
            }
            NmprtVariant::Hl2 => {
                let d = crate::bake::ssbump::d_encoding(tangent());
                std::array::from_fn(|c| {
                    (0..3)
                        .map(|b| d[b] * values[VALUES_PER_TEXEL * b + c])
                        .sum()
                })
            }
            NmprtVariant::Ratio => {
                let mut y = [0.0; TRANSFER_ROWS];
                eval_basis(Order::THREE, n, &mut y);
                std::array::from_fn(|c| {
                    let e: f64 = (0..TRANSFER_ROWS).map(|j| y[j] * irradiance_sh[j][c]).sum();
                    e.max(0.0) * values[0]
                })
            }
        };
        e.map(|x| x.max(0.0))
    }

    /// The lighting data for `radiance_sh` (≥ O² coefficients) and its order-3
    /// irradiance: every covered texel's values, dilated into the gutters, in f16 (range-
    /// scaled but for the ratio), and the shader's uniform block.
    pub fn lighting(
        &self,
        radiance_sh: &[[f64; 3]],
        irradiance_sh: &[[f64; 3]],
        label: &str,
    ) -> Result<LightingData, TechniqueError> {
        let map = &*self.transfer;
        super::require_coefficients(radiance_sh, map.columns(), "lighting", label)?;
        super::require_coefficients(irradiance_sh, TRANSFER_ROWS, "irradiance", label)?;
        if let NmprtVariant::SvdPixel { .. } = self.variant {
            // Nothing per texel depends on the lighting: the pixel shader multiplies.
            let params = self.pixel_params(radiance_sh);
            return Ok(LightingData {
                defines: vec![pixel_row_groups(map.columns())],
                ..LightingData::params(bytemuck::bytes_of(&params).to_vec())
            });
        }
        let v = self.values_per_texel();
        let texels = (map.res * map.res) as usize;
        let values = self.texel_values_all(radiance_sh, irradiance_sh);
        let name = format!("{label}.transferred");
        if self.variant == NmprtVariant::Ratio {
            let ratio: Vec<f16> = values.iter().map(|&x| f16::from_f32(x)).collect();
            let params = PreconvParams {
                irradiance_sh: super::rgb_order3_block(irradiance_sh),
            };
            return Ok(LightingData {
                params: bytemuck::bytes_of(&params).to_vec(),
                tables: None,
                texels: Some(TexelGroups::new(
                    vk::Format::R16_SFLOAT,
                    map.res,
                    &[ratio],
                    name,
                )),
                defines: Vec::new(),
            });
        }
        let largest = max_abs(values.iter().copied());
        if !largest.is_finite() {
            return Err(TechniqueError::Input {
                label: label.into(),
                detail: "the transferred radiance is not finite (non-finite lighting?)".into(),
            });
        }
        let scale = f16_range_scale(largest);
        let groups = pack_groups(texels, v, |t, j| f16::from_f32(values[t * v + j] * scale));
        let params = ShLightmapParams {
            unscale: [1.0 / scale, 0.0, 0.0, 0.0],
        };
        Ok(LightingData {
            params: bytemuck::bytes_of(&params).to_vec(),
            tables: None,
            texels: Some(TexelGroups::new(
                vk::Format::R16G16B16A16_SFLOAT,
                map.res,
                &groups,
                name,
            )),
            defines: Vec::new(),
        })
    }
}

/// RGBA groups of `nmprtsvdM`'s per-texel values (3M) and basis channels (M).
pub fn svd_groups(m: u32) -> (u32, u32) {
    (
        (3 * m).div_ceil(VALUES_PER_TEXEL as u32),
        m.div_ceil(VALUES_PER_TEXEL as u32),
    )
}

/// The fragment shader of each variant (module doc).
pub fn fragment_shader(variant: NmprtVariant) -> ShaderVariant {
    match variant {
        NmprtVariant::Full => super::shlmap::fragment_shader(),
        NmprtVariant::Hl2 => super::rnm::fragment_shader(RnmVariant::NormalMap),
        NmprtVariant::Ratio => super::preconv::fragment_shader(),
        NmprtVariant::Svd { m } => {
            let (groups, layers) = svd_groups(m);
            ShaderVariant {
                path: "technique/nmprtsvd.frag",
                defines: vec![
                    ("NMPRT_VECTORS", m),
                    ("NMPRT_GROUPS", groups),
                    ("NMPRT_BASIS_LAYERS", layers),
                ],
            }
        }
        NmprtVariant::SvdPixel { m } => ShaderVariant {
            path: "technique/nmprtsvdp.frag",
            defines: vec![
                ("NMPRT_VECTORS", m),
                ("NMPRT_MAX_ROW_GROUPS", PIXEL_MAX_ROW_GROUPS as u32),
                ("NMPRT_BASIS_LAYERS", m.div_ceil(VALUES_PER_TEXEL as u32)),
            ],
        },
    }
}

/// The define `nmprtsvdMp`'s shader is compiled with for lighting of `columns` SH
/// coefficients ([`LightingData::defines`]): the RGBA groups of a matrix row.
pub fn pixel_row_groups(columns: usize) -> (&'static str, u32) {
    (
        "NMPRT_ROW_GROUPS",
        columns.div_ceil(VALUES_PER_TEXEL) as u32,
    )
}

/// RGBA groups of one row of `nmprtsvdMp`'s per-texel matrices at most: lighting of order
/// ≤ 8 (`prepare::LIGHTING_ORDER`), ⌈64/4⌉.
pub const PIXEL_MAX_ROW_GROUPS: usize = 16;

/// Uniforms of glsl/technique/nmprtsvdp.frag, block `NmprtPixelParams` (std140).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct NmprtPixelParams {
    /// x: factor undoing the matrices' f16 range scaling.
    pub unscale: [f32; 4],
    /// Colour c, group k at `c·16 + k`: lighting coefficients 4k … 4k+3.
    pub light: [[f32; 4]; 3 * PIXEL_MAX_ROW_GROUPS],
}
crate::gpu::layout::glsl_block!(NmprtPixelParams = "NmprtPixelParams" { unscale, light });

/// No per-texel bake data (the lighting's per-texel images replace it) and the recipe.
pub(crate) fn prepare(
    variant: NmprtVariant,
    inputs: &Inputs<'_>,
    label: &str,
) -> Result<(TexelGroups, Recipe), TechniqueError> {
    let transfer = inputs.transfer.ok_or_else(|| TechniqueError::Input {
        label: label.into(),
        detail: "needs the transfer-matrix bake".into(),
    })?;
    if let NmprtVariant::Svd { m } | NmprtVariant::SvdPixel { m } = variant
        && !NMPRT_SVD_VECTORS.contains(&m)
    {
        return Err(TechniqueError::Input {
            label: label.into(),
            detail: format!("keeps {m} singular vectors; 1 to 9 exist"),
        });
    }
    let mut recipe = NmprtRecipe::new(variant, transfer.clone());
    let texels = match variant {
        NmprtVariant::SvdPixel { .. } => {
            let (groups, scale) = recipe.pixel_matrices(label)?;
            recipe.pixel_unscale = 1.0 / scale;
            TexelGroups::new(
                vk::Format::R16G16B16A16_SFLOAT,
                transfer.res,
                &groups,
                format!("{label}.matrices"),
            )
        }
        NmprtVariant::Full | NmprtVariant::Svd { .. } | NmprtVariant::Hl2 | NmprtVariant::Ratio => {
            TexelGroups {
                format: vk::Format::R16G16B16A16_SFLOAT,
                res: transfer.res,
                groups: Vec::new(),
                name: format!("{label}.none"),
                dx9_atlas: None,
            }
        }
    };
    Ok((texels, Recipe::Nmprt(Arc::new(recipe))))
}

/// `nmprtsvdM`'s basis texture (U S on the disk, M channels in ⌈M/4⌉ RGBA16F layers: 2D
/// textures on dx9, one 2D array on dx10); none for the other variants.
pub fn basis_images(
    ctx: &Arc<Context>,
    variant: NmprtVariant,
    path: HwPath,
    label: &str,
) -> Result<Vec<Image>, TechniqueError> {
    let m = match variant {
        NmprtVariant::Svd { m } | NmprtVariant::SvdPixel { m } => m,
        NmprtVariant::Full | NmprtVariant::Hl2 | NmprtVariant::Ratio => return Ok(Vec::new()),
    };
    let basis = NormalBasis::shared();
    let side = BASIS_SIDE;
    let groups = pack_groups(side * side, m as usize, |t, k| {
        f16::from_f64(basis.basis_value(k, disk_texel_normal(t % side, t / side, side)))
    });
    let bytes: Vec<&[u8]> = groups.iter().map(|g| bytemuck::cast_slice(g)).collect();
    upload_texel_groups(
        ctx,
        path,
        side as u32,
        vk::Format::R16G16B16A16_SFLOAT,
        &bytes,
        &format!("{label}.normal_basis"),
    )
}

/// How `nmprt*` evaluates the transferred radiance at the normal-mapped normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NmprtVariant {
    /// `nmprt`: y(n)ᵀ C l', the 27 coefficients of l' per texel.
    Full,
    /// `nmprtsvdM`: the course's normal basis, e(n) = U(n) S_M V_Mᵀ R l' — M values per
    /// colour per texel, U(n) looked up by the tangent-space normal.
    Svd { m: u32 },
    /// `nmprtsvdMp`: the same normal basis with the course's pixel shader — per texel the
    /// M × O² matrices V_Mᵀ R M (per colour) as bake data, the lighting l in uniforms, the
    /// matrix–vector product per pixel; nothing per texel changes with the lighting. Its
    /// 3·M·⌈O²/4⌉ RGBA layers exceed dx9's 16 textures: dx10 only.
    SvdPixel { m: u32 },
    /// `nmprthl2`: three rows — the least-squares fit of e(n) by the HL2 blend weights,
    /// three RGB values per texel blended like `rnm`.
    Hl2,
    /// `nmprtratio`: the shadowed/unshadowed luminance ratio at the texel's shading normal
    /// times the unshadowed irradiance at the normal-mapped normal.
    Ratio,
}

/// Singular vectors an `nmprtsvdM` name may keep (M = 9 is the full evaluation).
pub const NMPRT_SVD_VECTORS: std::ops::RangeInclusive<u32> = 1..=9;

/// The normal-mapping-for-PRT family (Sloan, PRT course; module doc): per texel a transfer
/// matrix M (`bake::transfer`: shadows and inter-reflection baked, lighting free) gives
/// transferred incident radiance l' = M·l, formed on the CPU when the lighting changes and
/// evaluated per pixel at the normal-mapped normal in one of four ways ([`NmprtVariant`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Nmprt {
    pub variant: NmprtVariant,
}

impl Family for Nmprt {
    type Options = ();
    const DESCRIPTION: Description = Description {
        names: "nmprt, nmprtsvdM, nmprtsvdMp, nmprthl2, nmprtratio",
        what: "normal mapping for PRT: transfer matrices per texel, evaluated at the normal",
        paper: "Sloan, PRT course (normal mapping)",
        in_paper_table: false,
    };
    const EXAMPLE: Nmprt = Nmprt {
        variant: NmprtVariant::Full,
    };

    fn members() -> Vec<Nmprt> {
        [NmprtVariant::Full, NmprtVariant::Hl2, NmprtVariant::Ratio]
            .into_iter()
            .chain(NMPRT_SVD_VECTORS.map(|m| NmprtVariant::Svd { m }))
            .chain(NMPRT_SVD_VECTORS.map(|m| NmprtVariant::SvdPixel { m }))
            .map(|variant| Nmprt { variant })
            .collect()
    }

    fn table_rows() -> Vec<Nmprt> {
        [
            NmprtVariant::Full,
            NmprtVariant::Svd { m: 4 },
            NmprtVariant::Svd { m: 6 },
            NmprtVariant::SvdPixel { m: 4 },
            NmprtVariant::Hl2,
            NmprtVariant::Ratio,
        ]
        .map(|variant| Nmprt { variant })
        .to_vec()
    }

    fn headline(path: HwPath) -> Vec<Nmprt> {
        match path {
            HwPath::Dx9 | HwPath::Dx10 => vec![Nmprt {
                variant: NmprtVariant::Svd { m: 4 },
            }],
            HwPath::Dx11 => Vec::new(),
        }
    }

    fn name(self) -> String {
        match self.variant {
            NmprtVariant::Full => "nmprt".into(),
            NmprtVariant::Svd { m } => format!("nmprtsvd{m}"),
            NmprtVariant::SvdPixel { m } => format!("nmprtsvd{m}p"),
            NmprtVariant::Hl2 => "nmprthl2".into(),
            NmprtVariant::Ratio => "nmprtratio".into(),
        }
    }

    fn paper_ms(self) -> Option<f64> {
        None
    }

    fn needs(self) -> BakeNeeds {
        BakeNeeds {
            transfer: true,
            ..BakeNeeds::default()
        }
    }

    fn reference(self) -> ReferenceModel {
        ReferenceModel::InterReflected
    }

    fn dynamic_lighting(self) -> bool {
        true
    }

    fn ndf_variant(self) -> Option<Technique> {
        None
    }

    fn form_on(self, path: HwPath) -> Result<Form, Refusal> {
        match (path, self.variant) {
            (HwPath::Dx9, NmprtVariant::SvdPixel { .. }) => Err(Refusal::Dx9Textures),
            (HwPath::Dx11, _) => Err(Refusal::RebuiltPerLighting),
            (HwPath::Dx9 | HwPath::Dx10, _) => Ok(Form {
                per_lighting_texels: true,
                ..Form::TEXTURES
            }),
        }
    }

    fn prepare(
        self,
        _: HwPath,
        inputs: &Inputs<'_>,
        _: &(),
        label: &str,
    ) -> Result<(TexelGroups, Recipe), TechniqueError> {
        prepare(self.variant, inputs, label)
    }

    fn extra_slot(
        self,
        ctx: &Arc<Context>,
        path: HwPath,
        _: &Inputs<'_>,
        label: &str,
    ) -> Result<Option<TextureSlot>, TechniqueError> {
        let images = basis_images(ctx, self.variant, path, label)?;
        Ok((!images.is_empty()).then_some(TextureSlot {
            kind: SlotKind::NormalBasis,
            images,
        }))
    }

    fn fragment_shader(self) -> ShaderVariant {
        fragment_shader(self.variant)
    }

    fn reads(self) -> ShaderReads {
        ShaderReads::PLAIN
    }

    fn options_tag(self, _: &()) -> Option<String> {
        None
    }

    fn sample_fit(self, _: &()) -> Option<crate::sh::samples::SampleFit> {
        None
    }

    fn values(self) -> Option<super::values::ValueMap> {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nine_vectors_are_the_full_evaluation() {
        let basis = NormalBasis::new(16);
        // Any l': Σ_m (US)_m(n) (Vᵀl')_m = y(n)ᵀ C l' when all nine are kept.
        let x: [[f64; 3]; 9] =
            std::array::from_fn(|j| [0.3 + j as f64, -0.2 * j as f64, (j as f64).sin()]);
        // c_m = Σ_j V_jm x_j (red channel), as the recipe's rows W = V_Mᵀ form it.
        let c: Vec<[f64; 1]> = basis
            .vectors
            .iter()
            .map(|v| [(0..9).map(|j| v[j] * x[j][0]).sum()])
            .collect();
        for n in [DVec3::Z, DVec3::new(0.3, -0.5, 0.81).normalize(), DVec3::X] {
            let full: f64 = convolved_basis(n)
                .iter()
                .zip(&x)
                .map(|(a, v)| a * v[0])
                .sum();
            let svd: f64 = (0..9).map(|m| basis.basis_value(m, n) * c[m][0]).sum();
            assert!(
                (full - svd).abs() < 1e-10 * full.abs().max(1.0),
                "{full} {svd}"
            );
        }
    }

    #[test]
    fn tangent_frame_change_matches_evaluation_in_both_handednesses() {
        let x: [[f64; 3]; 9] = std::array::from_fn(|j| [1.0 + j as f64 * 0.37, 0.0, 0.0]);
        let n = Vec3::new(0.2, 0.9, -0.3).normalize();
        let t = n.any_orthonormal_vector();
        for w in [1.0f32, -1.0] {
            let b = n.cross(t) * w;
            let frame = [t, b, n];
            let tangent = to_tangent(&frame, &x);
            for d in [DVec3::new(0.3, 0.4, 0.866), DVec3::new(-0.7, 0.1, 0.7)] {
                let d = d.normalize();
                let world =
                    (t.as_dvec3() * d.x + b.as_dvec3() * d.y + n.as_dvec3() * d.z).normalize();
                let eval = |c: &[[f64; 3]; 9], dir: DVec3| {
                    let mut y = [0.0; 9];
                    eval_basis(Order::THREE, dir, &mut y);
                    (0..9).map(|j| y[j] * c[j][0]).sum::<f64>()
                };
                let (a, b) = (eval(&tangent, d), eval(&x, world));
                assert!((a - b).abs() < 1e-5 * b.abs().max(1.0), "w {w}: {a} {b}");
            }
        }
    }
}
