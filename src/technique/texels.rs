//! Per-texel (lightmap) data on the GPU: values packed 4 per RGBA texel into groups, and
//! their images on each path (DESIGN §2):
//!
//! ```text
//! group g of texel t = values 4g … 4g+3 of t (the last group padded with zeros)
//! dx9:  one 2D texture per group            (sampler2D per_texel_tex[G])
//!       or, for a shader that picks its groups per pixel, one atlas of the groups as
//!       res × res tiles, row-major, `columns` wide (sampler2D per_texel_atlas)
//! dx10: one 2D array, layer g = group g      (sampler2DArray per_texel_tex)
//! dx11: dx10's layout, block-compressed      (`super::block`)
//! ```
//!
//! The atlas is how DX9-class hardware indexes data by a computed number: sampler arrays
//! take constant indices only, a texture coordinate anything.
//!
//! Shaders read them through `glsl/include/per_texel.glsl`.

use std::sync::Arc;

use ash::vk;

use super::{HwPath, TechniqueError};
use crate::gpu::{Context, Image, ImageDesc};

/// Values per RGBA texel.
pub const VALUES_PER_TEXEL: usize = 4;

/// Packs `values` values per texel into ⌈values/4⌉ RGBA groups: `groups[g][4t + k]` is
/// value `4g + k` of texel `t` (`value(t, j)`), `T::default()` past the last value.
pub fn pack_groups<T: Copy + Default>(
    texels: usize,
    values: usize,
    value: impl Fn(usize, usize) -> T,
) -> Vec<Vec<T>> {
    let groups = values.div_ceil(VALUES_PER_TEXEL);
    let mut out = vec![vec![T::default(); texels * VALUES_PER_TEXEL]; groups];
    for t in 0..texels {
        for j in 0..values {
            out[j / VALUES_PER_TEXEL][t * VALUES_PER_TEXEL + j % VALUES_PER_TEXEL] = value(t, j);
        }
    }
    out
}

/// A technique's per-texel data on the CPU: ⌈values/4⌉ groups of res² texels of `format`.
#[derive(Clone, Debug, PartialEq)]
pub struct TexelGroups {
    pub format: vk::Format,
    pub res: u32,
    /// Texel bytes per group.
    pub groups: Vec<Vec<u8>>,
    /// Debug name of the images ("unc6.dx9.visibility").
    pub name: String,
    /// On dx9, the groups as one atlas instead of a texture each ([`TexelGroups::with_dx9_atlas`]).
    pub dx9_atlas: Option<Atlas>,
}

/// The groups side by side in one texture: group g at tile (g mod columns, g div columns).
#[derive(Clone, Debug, PartialEq)]
pub struct Atlas {
    pub columns: u32,
    pub rows: u32,
    pub bytes: Vec<u8>,
}

/// The atlas width in tiles for `groups` groups: of ⌈√G⌉ … 2⌈√G⌉ columns, the fewest
/// padding tiles (then the fewest columns).
pub fn atlas_columns(groups: u32) -> u32 {
    let low = (f64::from(groups).sqrt().ceil() as u32).max(1);
    (low..=2 * low)
        .min_by_key(|&c| (c * groups.div_ceil(c), c))
        .unwrap_or(low)
}

impl TexelGroups {
    /// Groups of plain-old-data texels (`pack_groups`' output).
    pub fn new<T: bytemuck::Pod>(
        format: vk::Format,
        res: u32,
        groups: &[Vec<T>],
        name: String,
    ) -> Self {
        TexelGroups {
            format,
            res,
            groups: groups
                .iter()
                .map(|g| bytemuck::cast_slice(g).to_vec())
                .collect(),
            name,
            dx9_atlas: None,
        }
    }

    /// The same data, laid out on dx9 as one atlas ([`atlas_columns`] wide; tiles past the
    /// last group are zeros).
    pub fn with_dx9_atlas(mut self) -> Self {
        let groups = self.groups.len() as u32;
        let columns = atlas_columns(groups);
        let rows = groups.div_ceil(columns);
        let texel = crate::gpu::image::format_texel_bytes(self.format).unwrap_or(0) as usize;
        let (res, row_bytes) = (self.res as usize, self.res as usize * texel);
        let width_bytes = columns as usize * row_bytes;
        let mut bytes = vec![0u8; width_bytes * rows as usize * res];
        for (g, data) in self.groups.iter().enumerate() {
            let (col, row) = (g % columns as usize, g / columns as usize);
            for y in 0..res {
                let dst = (row * res + y) * width_bytes + col * row_bytes;
                bytes[dst..dst + row_bytes]
                    .copy_from_slice(&data[y * row_bytes..(y + 1) * row_bytes]);
            }
        }
        self.dx9_atlas = Some(Atlas {
            columns,
            rows,
            bytes,
        });
        self
    }

    /// Uploads the groups on `path` ([`image_layout`], or the dx9 atlas).
    pub fn upload(&self, ctx: &Arc<Context>, path: HwPath) -> Result<Vec<Image>, TechniqueError> {
        self.image_levels_named(path)
            .into_iter()
            .map(|(desc, levels, name)| Ok(Image::with_data(ctx, &desc, &levels, &name)?))
            .collect()
    }

    /// The images the groups become on `path`, each with its bytes (one slice per layer,
    /// level 0) and debug name ([`image_layout`]).
    pub fn image_levels(&self, path: HwPath) -> Vec<(ImageDesc, Vec<Vec<&[u8]>>)> {
        self.image_levels_named(path)
            .into_iter()
            .map(|(desc, levels, _)| (desc, levels))
            .collect()
    }

    fn image_levels_named(&self, path: HwPath) -> Vec<ImageBytes<'_>> {
        match (&self.dx9_atlas, path) {
            (Some(atlas), HwPath::Dx9) if !self.groups.is_empty() => vec![(
                ImageDesc::texture_2d(self.format, atlas.columns * self.res, atlas.rows * self.res),
                vec![vec![atlas.bytes.as_slice()]],
                format!("{}.atlas", self.name),
            )],
            _ => {
                let bytes: Vec<&[u8]> = self.groups.iter().map(Vec::as_slice).collect();
                image_layout(path, self.res, self.format, &bytes, &self.name)
            }
        }
    }
}

/// An image's description, its level-0 layers' bytes and its debug name.
pub type ImageBytes<'a> = (ImageDesc, Vec<Vec<&'a [u8]>>, String);

/// Per-texel groups as images (`groups[g]` = res² texels of `format`): one 2D texture per
/// group on dx9, one 2D array on dx10; each with its level-0 layers and name.
fn image_layout<'a>(
    path: HwPath,
    res: u32,
    format: vk::Format,
    groups: &[&'a [u8]],
    name: &str,
) -> Vec<ImageBytes<'a>> {
    if groups.is_empty() {
        return Vec::new();
    }
    match path {
        HwPath::Dx9 => groups
            .iter()
            .enumerate()
            .map(|(g, bytes)| {
                (
                    ImageDesc::texture_2d(format, res, res),
                    vec![vec![*bytes]],
                    format!("{name}.{g}"),
                )
            })
            .collect(),
        HwPath::Dx10 | HwPath::Dx11 => vec![(
            ImageDesc::texture_2d_array(format, res, res, groups.len() as u32),
            vec![groups.to_vec()],
            name.to_string(),
        )],
    }
}

/// Uploads per-texel groups ([`image_layout`]).
pub fn upload_texel_groups(
    ctx: &Arc<Context>,
    path: HwPath,
    res: u32,
    format: vk::Format,
    groups: &[&[u8]],
    name: &str,
) -> Result<Vec<Image>, TechniqueError> {
    image_layout(path, res, format, groups, name)
        .into_iter()
        .map(|(desc, levels, name)| Ok(Image::with_data(ctx, &desc, &levels, &name)?))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_hold_four_consecutive_values_and_pad_with_zeros() {
        // Value j of texel t encoded as 100 t + j + 1 (0 is the padding).
        let groups = pack_groups(3, 9, |t, j| (100 * t + j + 1) as u32);
        assert_eq!(groups.len(), 3);
        for (g, group) in groups.iter().enumerate() {
            assert_eq!(group.len(), 3 * 4);
            for t in 0..3 {
                for k in 0..4 {
                    let j = 4 * g + k;
                    let want = if j < 9 { (100 * t + j + 1) as u32 } else { 0 };
                    assert_eq!(group[4 * t + k], want, "group {g} texel {t} lane {k}");
                }
            }
        }
        assert_eq!(pack_groups(5, 4, |_, _| 1u8).len(), 1);
        assert!(pack_groups(5, 0, |_, _| 1u8).is_empty());
    }

    #[test]
    fn the_atlas_puts_each_group_in_its_tile() {
        assert_eq!(atlas_columns(23), 6);
        assert_eq!(atlas_columns(13), 7);
        assert_eq!(atlas_columns(4), 2);
        assert_eq!(atlas_columns(1), 1);
        // 7 groups of 2×2 RGBA16F texels, texel (x, y) of group g holding 100 g + 10 y + x:
        // 4 × 2 tiles, the last one padding.
        let res = 2;
        let groups: Vec<Vec<u16>> = (0..7u16)
            .map(|g| {
                (0..4u16)
                    .flat_map(|t| [100 * g + 10 * (t / 2) + t % 2; 4])
                    .collect()
            })
            .collect();
        let texels = TexelGroups::new(vk::Format::R16G16B16A16_SFLOAT, res, &groups, "t".into())
            .with_dx9_atlas();
        let atlas = texels.dx9_atlas.as_ref().unwrap();
        assert_eq!((atlas.columns, atlas.rows), (4, 2));
        let values: &[u16] = bytemuck::cast_slice(&atlas.bytes);
        let width = (atlas.columns * res) as usize;
        for g in 0..8u16 {
            for (y, x) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                let (col, row) = ((g % 4) as usize, (g / 4) as usize);
                let at = ((row * 2 + y) * width + col * 2 + x) * 4;
                let want = if g < 7 {
                    100 * g + 10 * y as u16 + x as u16
                } else {
                    0
                };
                assert_eq!(values[at], want, "group {g} texel ({x}, {y})");
            }
        }
        let images = texels.image_levels(HwPath::Dx9);
        assert_eq!(images.len(), 1);
        assert_eq!((images[0].0.width, images[0].0.height), (8, 4));
        assert_eq!(texels.image_levels(HwPath::Dx10)[0].0.layers, 7);
    }
}
