//! Normal-indexed lookup tables on the GPU (the L×H tables of `unc*`, the T_k(n) of
//! `pca*`): their parameterization per path, their layout in textures, and f16 range
//! scaling (Iwanicki–Sloan §3.3; DESIGN §2).
//!
//! A table set has G groups of 4 values per colour, plus optionally one RGB "mean" table
//! (PCA's V_e term):
//!
//! ```text
//! dx9  3 2D textures (one per colour), the G dual-paraboloid spheres side by side, each two
//!      hemisphere squares wide: | g0 +Y | g0 −Y | g1 +Y | … ;  mean: one more, one sphere
//! dx10 one cube-map array, cube c·G + g; mean: cube 3G
//! ```
//!
//! Tables are RGBA16F; one whose largest magnitude exceeds `F16_TABLE_MAX` is scaled down
//! and the shader multiplies back (glsl/include/grouped.glsl), keeping f16's relative
//! precision under an HDR sun.

use std::sync::Arc;

use ash::vk;
use half::f16;
use half::slice::HalfFloatSliceExt;

use super::finish::TextureSlot;
use super::{HwPath, TechniqueError};
use crate::bake::lxh::{LxhMatrices, LxhTable, SymmetricBuild};
use crate::gpu::{Context, Image, ImageDesc};
use crate::sh::Order;
use crate::sphere::{Parameterization, SphereMap};

/// Largest table magnitude stored in f16: far below 65504, so filtering and the products
/// stay finite, far above f16's subnormals.
pub const F16_TABLE_MAX: f32 = 16384.0;

/// Factor that brings values whose largest magnitude is `max_abs` into f16's safe range
/// (`F16_TABLE_MAX`); 1 when they already fit. Shaders multiply by its inverse.
pub fn f16_range_scale(max_abs: f32) -> f32 {
    if max_abs > F16_TABLE_MAX {
        F16_TABLE_MAX / max_abs
    } else {
        1.0
    }
}

/// [`f16_range_scale`] of `values`, or `None` when one is not finite: the scale of baked
/// per-texel values before their f16 storage.
pub fn finite_f16_scale(values: impl IntoIterator<Item = f32>) -> Option<f32> {
    let max = max_abs(values);
    max.is_finite().then(|| f16_range_scale(max))
}

/// Largest magnitude of `values`, NaN if any is NaN (`f32::max` alone would skip it), so
/// callers check the result with `is_finite`; what [`f16_range_scale`] is given.
pub fn max_abs(values: impl IntoIterator<Item = f32>) -> f32 {
    values.into_iter().fold(0.0f32, |m, v| {
        if m.is_nan() || v.is_nan() {
            f32::NAN
        } else {
            m.max(v.abs())
        }
    })
}

/// Uniforms of glsl/include/grouped.glsl, block `GroupedParams` (std140).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TableParams {
    /// x: 1/scale of the tables' f16 range scaling; y: table texels per side.
    pub unscale_res: [f32; 4],
}
crate::gpu::layout::glsl_block!(TableParams = "GroupedParams" { unscale_res });

/// The L×H table of visibility order `v_order` for `radiance_sh` over `build`'s map
/// (`bake::lxh`: product matrices, then the symmetric build), or an input error when the
/// lighting has fewer than the (O + 2)² coefficients the product needs.
pub fn lxh_table(
    build: &SymmetricBuild,
    radiance_sh: &[[f64; 3]],
    v_order: Order,
    h_order: Order,
    label: &str,
) -> Result<LxhTable, TechniqueError> {
    let need = Order::new(v_order.get() + 2).map_or(v_order.coeff_count(), |o| o.coeff_count());
    super::require_coefficients(radiance_sh, need, "lighting", label)?;
    Ok(build.build(&LxhMatrices::new(radiance_sh, v_order, h_order)))
}

/// The tables' parameterization on each path.
pub fn table_map(path: HwPath, table_res: u32, label: &str) -> Result<SphereMap, TechniqueError> {
    let kind = match path {
        HwPath::Dx9 => Parameterization::DualParaboloid,
        HwPath::Dx10 | HwPath::Dx11 => Parameterization::CubeDx10,
    };
    SphereMap::new(kind, table_res).map_err(|e| TechniqueError::Input {
        label: label.into(),
        detail: e.to_string(),
    })
}

/// One table image's description and RGBA16F texels per layer, on the CPU.
#[derive(Clone, Debug, PartialEq)]
pub struct TableImage {
    pub desc: ImageDesc,
    /// RGBA texels per layer.
    pub layers: Vec<Vec<[f16; 4]>>,
    /// Debug name of the image ("unc6.dx9.lxh.red").
    pub name: String,
}

/// A table set on the CPU, laid out as the GPU binds it, and the factor the shader
/// multiplies sums by: what a lighting change recomputes.
#[derive(Clone, Debug, PartialEq)]
pub struct NormalTableData {
    /// The images in binding order.
    pub images: Vec<TableImage>,
    /// Images per binding: dx9 `[3]` or `[3, 1]` (colours, mean), dx10 `[1]`.
    pub slot_sizes: Vec<usize>,
    pub unscale: f32,
}

impl NormalTableData {
    /// The uniform block the shader decodes these tables with (`table_res` per side).
    pub fn params(&self, table_res: u32) -> TableParams {
        TableParams {
            unscale_res: [self.unscale, table_res as f32, 0.0, 0.0],
        }
    }

    /// The texel bytes of image `i`, one slice per layer (level 0 only).
    pub fn image_levels(&self, i: usize) -> Vec<Vec<&[u8]>> {
        vec![
            self.images[i]
                .layers
                .iter()
                .map(|l| bytemuck::cast_slice(l))
                .collect(),
        ]
    }

    /// Creates and fills the images, `suffix` appended to their names, grouped into the
    /// slots they bind as.
    pub fn upload(
        &self,
        ctx: &Arc<Context>,
        suffix: &str,
    ) -> Result<Vec<TextureSlot>, TechniqueError> {
        let mut images = Vec::with_capacity(self.images.len());
        for (i, table) in self.images.iter().enumerate() {
            let name = format!("{}{suffix}", table.name);
            images.push(Image::with_data(
                ctx,
                &table.desc,
                &self.image_levels(i),
                &name,
            )?);
        }
        let mut images = images.into_iter();
        Ok(self
            .slot_sizes
            .iter()
            .map(|&n| TextureSlot::normal_tables(images.by_ref().take(n).collect()))
            .collect())
    }
}

/// Tables at the texel centres of `map` (dual paraboloid for dx9, cube for dx10):
/// `value(t, g, c)` is the RGBA of sample t, group g, colour c; `mean(t)` the RGB of the
/// optional mean table. Range-scaled into f16 (module doc) and laid out as the module doc
/// draws: sample t = face·res² + j·res + i (`SphereMap::texel_index`) is texel (i, j) of
/// hemisphere / cube face `face`.
pub fn normal_table_data(
    path: HwPath,
    map: SphereMap,
    groups: usize,
    value: impl Fn(usize, usize, usize) -> [f32; 4],
    mean: Option<&dyn Fn(usize) -> [f32; 3]>,
    name: &str,
) -> Result<NormalTableData, TechniqueError> {
    // Plane p: colour c, group g at p = c·groups + g, the mean last; planes[p·samples + t].
    // Filled sample-major (each sample's values are read once, in order) with plain loops:
    // the table rebuild of `shvis relight` runs through here.
    let samples = map.sample_count();
    let face_texels = (map.res() * map.res()) as usize;
    let plane_count = 3 * groups + usize::from(mean.is_some());
    let mut planes = vec![[0.0f32; 4]; plane_count * samples];
    for t in 0..samples {
        for c in 0..3 {
            for g in 0..groups {
                planes[(c * groups + g) * samples + t] = value(t, g, c);
            }
        }
        if let Some(m) = mean {
            let [r, g, b] = m(t);
            planes[3 * groups * samples + t] = [r, g, b, 0.0];
        }
    }
    let max_abs = max_abs(
        bytemuck::cast_slice::<[f32; 4], f32>(&planes)
            .iter()
            .copied(),
    );
    if !max_abs.is_finite() {
        return Err(TechniqueError::Input {
            label: name.into(),
            detail: "a normal-indexed table is not finite (non-finite lighting?)".into(),
        });
    }
    let scale = f16_range_scale(max_abs);
    let to_f16 = |texels: &[[f32; 4]]| -> Vec<[f16; 4]> {
        let mut out = vec![[f16::ZERO; 4]; texels.len()];
        let (src, dst) = (
            bytemuck::cast_slice::<[f32; 4], f32>(texels),
            bytemuck::cast_slice_mut::<[f16; 4], f16>(&mut out),
        );
        let mut scaled = [0.0f32; 256];
        for (s, d) in src.chunks(scaled.len()).zip(dst.chunks_mut(scaled.len())) {
            for (x, v) in scaled.iter_mut().zip(s) {
                *x = v * scale;
            }
            d.convert_from_f32_slice(&scaled[..s.len()]);
        }
        out
    };
    let plane = |p: usize| &planes[p * samples..(p + 1) * samples];
    let fmt = vk::Format::R16G16B16A16_SFLOAT;
    let tr = map.res();
    let res = tr as usize;
    let (images, slot_sizes) = match path {
        HwPath::Dx9 => {
            // Strip of planes p0 … p0 + spheres − 1: row y is, per sphere, row y of its +Y
            // hemisphere then row y of its −Y one.
            let strip = |p0: usize, spheres: usize, n: &str| {
                let width = spheres * 2 * res;
                let mut texels = Vec::with_capacity(width * res);
                for y in 0..res {
                    for p in p0..p0 + spheres {
                        for hemi in 0..2 {
                            let start = hemi * face_texels + y * res;
                            texels.extend_from_slice(&plane(p)[start..start + res]);
                        }
                    }
                }
                TableImage {
                    desc: ImageDesc::texture_2d(fmt, width as u32, tr),
                    layers: vec![to_f16(&texels)],
                    name: format!("{name}.{n}"),
                }
            };
            let mut images: Vec<TableImage> = ["red", "green", "blue"]
                .iter()
                .enumerate()
                .map(|(c, n)| strip(c * groups, groups, n))
                .collect();
            let mut slot_sizes = vec![3];
            if mean.is_some() {
                images.push(strip(3 * groups, 1, "mean"));
                slot_sizes.push(1);
            }
            (images, slot_sizes)
        }
        HwPath::Dx10 | HwPath::Dx11 => {
            // Cube p is plane p; its layer f is face f's samples, already row-major.
            let image = TableImage {
                desc: ImageDesc::texture_cube_array(fmt, tr, plane_count as u32),
                layers: planes.chunks(face_texels).map(to_f16).collect(),
                name: name.to_string(),
            };
            (vec![image], vec![1])
        }
    };
    Ok(NormalTableData {
        images,
        slot_sizes,
        unscale: 1.0 / scale,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f16_range_scale_keeps_small_tables_and_fits_large_ones() {
        assert_eq!(f16_range_scale(0.0), 1.0);
        assert_eq!(f16_range_scale(F16_TABLE_MAX), 1.0);
        for max_abs in [F16_TABLE_MAX * 1.0001, 65504.0, 1e5, 1e30] {
            let s = f16_range_scale(max_abs);
            assert!(s < 1.0, "{max_abs}");
            let stored = f16::from_f32(max_abs * s).to_f32();
            assert!(
                stored.is_finite() && stored <= F16_TABLE_MAX * 1.001,
                "{max_abs}"
            );
            assert!((stored / s / max_abs - 1.0).abs() < 1e-3, "{max_abs}");
        }
    }

    #[test]
    fn max_abs_sees_nan_and_infinity() {
        assert_eq!(max_abs([1.0, -3.0, 2.0]), 3.0);
        assert!(max_abs([1.0, f32::NAN, 2.0]).is_nan());
        assert!(max_abs([f32::NAN, 2.0]).is_nan());
        assert_eq!(max_abs([1.0, f32::NEG_INFINITY]), f32::INFINITY);
    }

    /// Value of sample t (< 54), group g (< 3), colour c, lane k: a distinct integer below
    /// 2048, so exact in f16.
    fn encode(t: usize, g: usize, c: usize) -> [f32; 4] {
        std::array::from_fn(|k| (((t * 3 + g) * 3 + c) * 4 + k) as f32)
    }

    #[test]
    fn dx9_strip_puts_sphere_g_hemisphere_h_at_columns_2g_plus_h() {
        let map = SphereMap::new(Parameterization::DualParaboloid, 4).unwrap();
        let tr = 4usize;
        let mean = |t: usize| [t as f32, 1.0, 2.0];
        let data = normal_table_data(HwPath::Dx9, map, 3, encode, Some(&mean), "t").unwrap();
        assert_eq!(data.slot_sizes, vec![3, 1]);
        assert_eq!(data.unscale, 1.0);
        for c in 0..3 {
            let image = &data.images[c];
            assert_eq!(
                (image.desc.width, image.desc.height),
                (3 * 2 * tr as u32, tr as u32)
            );
            let texels = &image.layers[0];
            for y in 0..tr {
                for g in 0..3 {
                    for hemi in 0..2 {
                        for i in 0..tr {
                            let x = g * 2 * tr + hemi * tr + i;
                            let t = map.texel_index(hemi as u32, i as u32, y as u32);
                            let got = texels[y * 3 * 2 * tr + x].map(f16::to_f32);
                            assert_eq!(got, encode(t, g, c), "colour {c} x {x} y {y}");
                        }
                    }
                }
            }
        }
        let mean_strip = &data.images[3].layers[0];
        for (x, y) in [(0, 0), (5, 2), (7, 3)] {
            let t = map.texel_index((x / tr) as u32, (x % tr) as u32, y as u32);
            let got = mean_strip[y * 2 * tr + x].map(f16::to_f32);
            assert_eq!(got, [t as f32, 1.0, 2.0, 0.0]);
        }
    }

    #[test]
    fn dx10_layers_are_cube_major_then_face() {
        let map = SphereMap::new(Parameterization::CubeDx10, 3).unwrap();
        let data = normal_table_data(HwPath::Dx10, map, 2, encode, None, "t").unwrap();
        let image = &data.images[0];
        assert_eq!(image.desc.layers, 6 * 3 * 2);
        assert_eq!(image.layers.len(), 36);
        for (l, layer) in image.layers.iter().enumerate() {
            // Cube c·groups + g holds colour c, group g.
            let (cube, face) = (l / 6, (l % 6) as u32);
            let (c, g) = (cube / 2, cube % 2);
            for j in 0..3u32 {
                for i in 0..3u32 {
                    let got = layer[(j * 3 + i) as usize].map(f16::to_f32);
                    assert_eq!(got, encode(map.texel_index(face, i, j), g, c));
                }
            }
        }
    }

    #[test]
    fn tables_out_of_f16_range_are_scaled_and_non_finite_ones_refused() {
        let map = SphereMap::new(Parameterization::CubeDx10, 2).unwrap();
        let big = |t: usize, _: usize, _: usize| [1e6 * (t + 1) as f32, 0.0, -1.0, 0.0];
        let data = normal_table_data(HwPath::Dx10, map, 1, big, None, "t").unwrap();
        let top = data.images[0].layers[0][3][0].to_f32() * data.unscale;
        assert!((top / 4e6 - 1.0).abs() < 1e-3, "{top}");
        let nan = |t: usize, _: usize, _: usize| [if t == 5 { f32::NAN } else { 1.0 }; 4];
        assert!(normal_table_data(HwPath::Dx9, map, 1, nan, None, "t").is_err());
    }
}
