//! Per-texel (lightmap) data on the GPU: values packed 4 per RGBA texel into groups, and
//! their images on each path (DESIGN §2):
//!
//! ```text
//! group g of texel t = values 4g … 4g+3 of t (the last group padded with zeros)
//! dx9:  one 2D texture per group            (sampler2D per_texel_tex[G])
//! dx10: one 2D array, layer g = group g      (sampler2DArray per_texel_tex)
//! ```
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
        }
    }

    /// Uploads the groups on `path` ([`upload_texel_groups`]).
    pub fn upload(&self, ctx: &Arc<Context>, path: HwPath) -> Result<Vec<Image>, TechniqueError> {
        let bytes: Vec<&[u8]> = self.groups.iter().map(Vec::as_slice).collect();
        upload_texel_groups(ctx, path, self.res, self.format, &bytes, &self.name)
    }

    /// The images the groups become on `path`, each with its bytes (one slice per layer,
    /// level 0) and debug name ([`image_layout`]).
    pub fn image_levels(&self, path: HwPath) -> Vec<(ImageDesc, Vec<Vec<&[u8]>>)> {
        let bytes: Vec<&[u8]> = self.groups.iter().map(Vec::as_slice).collect();
        image_layout(path, self.res, self.format, &bytes, &self.name)
            .into_iter()
            .map(|(desc, levels, _)| (desc, levels))
            .collect()
    }
}

/// An image's description, its level-0 layers' bytes and its debug name.
type ImageBytes<'a> = (ImageDesc, Vec<Vec<&'a [u8]>>, String);

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
        HwPath::Dx10 => vec![(
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
}
