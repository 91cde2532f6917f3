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

use super::finish::TextureSlot;
use super::{HwPath, TechniqueError};
use crate::bake::lxh::LxhMatrices;
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

/// Largest magnitude of `values` (NaN-propagating only through `max`, so callers check
/// the result with `is_finite`); what [`f16_range_scale`] is given.
pub fn max_abs(values: impl IntoIterator<Item = f32>) -> f32 {
    values.into_iter().fold(0.0f32, |m, v| m.max(v.abs()))
}

/// Uniforms of glsl/include/grouped.glsl, block `GroupedParams` (std140).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TableParams {
    /// x: 1/scale of the tables' f16 range scaling; y: table texels per side.
    pub unscale_res: [f32; 4],
}

/// The L×H product matrices of visibility order `v_order` for `radiance_sh`, or an input
/// error when the lighting has fewer than the (O + 2)² coefficients they need.
pub fn lxh_matrices(
    radiance_sh: &[[f64; 3]],
    v_order: Order,
    h_order: Order,
    label: &str,
) -> Result<LxhMatrices, TechniqueError> {
    let need = Order::new(v_order.get() + 2).map_or(v_order.coeff_count(), |o| o.coeff_count());
    if radiance_sh.len() < need {
        return Err(TechniqueError::Input {
            label: label.into(),
            detail: format!(
                "needs lighting with {need} SH coefficients, got {}",
                radiance_sh.len()
            ),
        });
    }
    Ok(LxhMatrices::new(radiance_sh, v_order, h_order))
}

/// The tables' parameterization on each path.
pub fn table_map(path: HwPath, table_res: u32, label: &str) -> Result<SphereMap, TechniqueError> {
    let kind = match path {
        HwPath::Dx9 => Parameterization::DualParaboloid,
        HwPath::Dx10 => Parameterization::CubeDx10,
    };
    SphereMap::new(kind, table_res).map_err(|e| TechniqueError::Input {
        label: label.into(),
        detail: e.to_string(),
    })
}

/// dx9: `spheres` dual-paraboloid spheres side by side, row-major RGBA texels of a
/// (spheres · 2 · res) × res texture; `texel(t, s)` is sample t (`SphereMap::texel_index`)
/// of sphere s. Returns the width and the texels.
pub fn dx9_strip(
    map: SphereMap,
    spheres: usize,
    texel: impl Fn(usize, usize) -> [f32; 4],
) -> (u32, Vec<[f32; 4]>) {
    let tr = map.res() as usize;
    let width = spheres * 2 * tr;
    let mut texels = Vec::with_capacity(width * tr);
    for y in 0..tr {
        for x in 0..width {
            let (sphere, within) = (x / (2 * tr), x % (2 * tr));
            let (hemi, i) = (within / tr, within % tr);
            texels.push(texel(
                map.texel_index(hemi as u32, i as u32, y as u32),
                sphere,
            ));
        }
    }
    (width as u32, texels)
}

/// dx10: `cubes` cubes of 6 faces each, layer 6c + f, row-major RGBA texels per face;
/// `texel(t, c)` is sample t of cube c.
pub fn dx10_cube_layers(
    map: SphereMap,
    cubes: usize,
    texel: impl Fn(usize, usize) -> [f32; 4],
) -> Vec<Vec<[f32; 4]>> {
    let tr = map.res();
    let mut layers = Vec::with_capacity(cubes * 6);
    for cube in 0..cubes {
        for face in 0..6u32 {
            let face_texels = (0..tr)
                .flat_map(|j| (0..tr).map(move |i| (i, j)))
                .map(|(i, j)| texel(map.texel_index(face, i, j), cube))
                .collect();
            layers.push(face_texels);
        }
    }
    layers
}

/// One table image's description and f16 RGBA texels per layer, on the CPU.
#[derive(Clone, Debug, PartialEq)]
pub struct TableImage {
    pub desc: ImageDesc,
    pub layers: Vec<Vec<f16>>,
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
/// optional mean table. Range-scaled into f16 (module doc).
pub fn normal_table_data(
    path: HwPath,
    map: SphereMap,
    groups: usize,
    value: impl Fn(usize, usize, usize) -> [f32; 4],
    mean: Option<&dyn Fn(usize) -> [f32; 3]>,
    name: &str,
) -> Result<NormalTableData, TechniqueError> {
    let value = &value;
    let max_abs = max_abs((0..map.sample_count()).flat_map(|t| {
        let tables = (0..groups).flat_map(move |g| (0..3).flat_map(move |c| value(t, g, c)));
        tables.chain(mean.map_or([0.0; 3], |m| m(t)))
    }));
    if !max_abs.is_finite() {
        return Err(TechniqueError::Input {
            label: name.into(),
            detail: "a normal-indexed table is not finite (non-finite lighting?)".into(),
        });
    }
    let scale = f16_range_scale(max_abs);
    let to_f16 = |texels: &[[f32; 4]]| -> Vec<f16> {
        texels
            .iter()
            .flatten()
            .map(|&v| f16::from_f32(v * scale))
            .collect()
    };
    let mean_rgba = |t: usize| -> [f32; 4] {
        mean.map_or([0.0; 4], |m| {
            let [r, g, b] = m(t);
            [r, g, b, 0.0]
        })
    };
    let fmt = vk::Format::R16G16B16A16_SFLOAT;
    let tr = map.res();
    let (images, slot_sizes) = match path {
        HwPath::Dx9 => {
            let strip = |spheres: usize, texel: &dyn Fn(usize, usize) -> [f32; 4], n: &str| {
                let (width, texels) = dx9_strip(map, spheres, texel);
                TableImage {
                    desc: ImageDesc::texture_2d(fmt, width, tr),
                    layers: vec![to_f16(&texels)],
                    name: format!("{name}.{n}"),
                }
            };
            let mut images: Vec<TableImage> = ["red", "green", "blue"]
                .iter()
                .enumerate()
                .map(|(c, n)| strip(groups, &|t, g| value(t, g, c), n))
                .collect();
            let mut slot_sizes = vec![3];
            if mean.is_some() {
                images.push(strip(1, &|t, _| mean_rgba(t), "mean"));
                slot_sizes.push(1);
            }
            (images, slot_sizes)
        }
        HwPath::Dx10 => {
            let cubes = 3 * groups + mean.is_some() as usize;
            let layers = dx10_cube_layers(map, cubes, |t, cube| {
                if cube < 3 * groups {
                    value(t, cube % groups, cube / groups)
                } else {
                    mean_rgba(t)
                }
            });
            let image = TableImage {
                desc: ImageDesc::texture_cube_array(fmt, tr, cubes as u32),
                layers: layers.iter().map(|l| to_f16(l)).collect(),
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
    fn dx9_strip_puts_sphere_s_hemisphere_h_at_columns_2s_plus_h() {
        let map = SphereMap::new(Parameterization::DualParaboloid, 4).unwrap();
        let tr = 4usize;
        let encode = |t: usize, s: usize| [t as f32, s as f32, 0.0, 1.0];
        let (width, texels) = dx9_strip(map, 3, encode);
        assert_eq!(width as usize, 3 * 2 * tr);
        assert_eq!(texels.len(), 3 * 2 * tr * tr);
        for y in 0..tr {
            for s in 0..3 {
                for hemi in 0..2 {
                    for i in 0..tr {
                        let x = s * 2 * tr + hemi * tr + i;
                        let t = map.texel_index(hemi as u32, i as u32, y as u32);
                        assert_eq!(texels[y * width as usize + x], encode(t, s), "x {x} y {y}");
                    }
                }
            }
        }
        // Every sample of every sphere appears exactly once.
        let mut seen = vec![0u32; map.sample_count() * 3];
        for v in &texels {
            seen[v[1] as usize * map.sample_count() + v[0] as usize] += 1;
        }
        assert!(seen.iter().all(|&n| n == 1));
    }

    #[test]
    fn dx10_layers_are_cube_major_then_face() {
        let map = SphereMap::new(Parameterization::CubeDx10, 3).unwrap();
        let layers = dx10_cube_layers(map, 2, |t, c| [t as f32, c as f32, 0.0, 0.0]);
        assert_eq!(layers.len(), 12);
        for (l, layer) in layers.iter().enumerate() {
            let (cube, face) = (l / 6, (l % 6) as u32);
            for j in 0..3u32 {
                for i in 0..3u32 {
                    let v = layer[(j * 3 + i) as usize];
                    assert_eq!(v[0] as usize, map.texel_index(face, i, j));
                    assert_eq!(v[1] as usize, cube);
                }
            }
        }
    }
}
