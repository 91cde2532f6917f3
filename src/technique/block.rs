//! The `dx11` path's per-texel data: a technique's per-texel groups
//! (`super::texels`) block-compressed as DX11-class hardware stores them, and the decode
//! the shaders apply (`glsl/include/per_texel.glsl`). Encoding and the independent decoder
//! are `crate::bake::block`'s.
//!
//! **Ratios to a per-texel norm** — values of either sign and any magnitude in 8-bit
//! blocks (the packing `shvis study block` found to hold where offsets and plain BC6H do
//! not; here with the norm in place of L0, so no ratio is ever clamped):
//!
//! ```text
//! n_c(t)  = max over the values j of colour c of |v_j(t)|        BC6H, one RGB layer
//! r_j(t)  = v_j(t) / n_colour(j)(t)   ∈ [−1, 1]   (0 where n = 0)
//! s_j(t)  = (128 + round(127 r)) / 255                            BC7, layer g = group g
//! v_j     = (255 s − 128) / 127 · n_colour(j)                     the shader's decode
//! ```
//!
//! colour(j) is [`NormColours`]: one norm per texel, or one per colour where values are RGB.
//! A texel whose values are all 0 (a black texel, the gutter) stores r = 0 and takes the
//! largest norm of its block ([`fill_empty_norms`]): it decodes to the block's BC7 error
//! of 0 (1–3 % of its neighbours; exactly 0 where the block keeps 128), instead of an
//! exact 0 that would cost the covered texels of its block their BC6H range.
//! Norms above the largest half float are clamped and counted, with a warning.
//!
//! **One value per texel in [0, 1]** (`preconv`'s AO): BC4, read as dx10 reads R16F.
//!
//! The GPU filters s and n bilinearly apart, then multiplies; where n changes between
//! neighbouring texels that differs from filtering the decoded values
//! ([`DecodedBlocks::filtered`] does as the GPU does).
//!
//! Techniques whose per-texel data is not a set of values (cluster indices), is rebuilt for
//! each lighting (`nmprt*`) or absent (per-vertex PCA) have no `dx11` row: each family's
//! `form_on` says so, and names its codec where it has one.
//!
//! The codec is a shader id (`gpu::layout::ShaderIds`, [`codec_ids`]); this module also
//! gathers the macros every compile of a technique's shader takes: the path's, the
//! codec, and every id a technique shader selects by ([`path_defines`], [`shader_ids`]).

use std::sync::Arc;

use ash::vk;
use half::f16;

use super::texels::{ImageBytes, TexelGroups, VALUES_PER_TEXEL};
use super::{HwPath, Technique, TechniqueError};
use crate::bake::block::{self as bc, Bc6hQuality, Bc7Quality, Clamped};
use crate::gpu::layout::ShaderIds;
use crate::gpu::{Context, Image, ImageDesc};

/// How a technique's per-texel data is stored on `dx11` (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockCodec {
    /// One value per texel in [0, 1]: BC4.
    Bc4,
    /// Ratios to a per-texel norm: BC7 ratios, BC6H norms.
    Ratio(NormColours),
}

/// Which norm divides value j of a texel (j = 4g + i: channel i of group g).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormColours {
    /// One norm for every value.
    One,
    /// RGB triplets packed 4 per group (value 3k + c has colour c): `shlmap`'s layout.
    Triplets,
    /// An RGB triple per group (channel i has colour i, alpha goes with red): `rnm`'s.
    GroupRgb,
}

impl NormColours {
    /// The colour (0, 1, 2) of value `j`.
    pub fn colour(self, j: usize) -> usize {
        match self {
            NormColours::One => 0,
            NormColours::Triplets => j % 3,
            NormColours::GroupRgb => (j % VALUES_PER_TEXEL) % 3,
        }
    }
}

impl BlockCodec {
    /// The value of the shader macro `SHVIS_PER_TEXEL_CODEC` (glsl/include/per_texel.glsl),
    /// named there by [`codec_ids`].
    pub fn shader_value(self) -> u32 {
        match self {
            BlockCodec::Bc4 => 1,
            BlockCodec::Ratio(NormColours::One) => 2,
            BlockCodec::Ratio(NormColours::Triplets) => 3,
            BlockCodec::Ratio(NormColours::GroupRgb) => 4,
        }
    }
}

/// `SHVIS_PER_TEXEL_CODEC` where the per-texel data is stored as dx10 stores it.
const NO_CODEC: u32 = 0;

/// `SHVIS_PER_TEXEL_CODEC`'s ids: none (dx9, dx10, and dx11 without a block form) and each
/// [`BlockCodec`]'s.
pub fn codec_ids() -> ShaderIds {
    let ratio = |colours: NormColours| BlockCodec::Ratio(colours).shader_value();
    ShaderIds {
        selector: "PER_TEXEL_CODEC",
        ids: vec![
            ("CODEC_NONE", NO_CODEC),
            ("CODEC_BC4", BlockCodec::Bc4.shader_value()),
            ("CODEC_RATIO_ONE", ratio(NormColours::One)),
            ("CODEC_RATIO_TRIPLETS", ratio(NormColours::Triplets)),
            ("CODEC_RATIO_GROUP_RGB", ratio(NormColours::GroupRgb)),
        ],
    }
}

/// Every id set a technique's shaders select by: the per-texel codec, the engine SH
/// bases, the `rnm` weights, the clustered decode's count paths (the cost model's builds)
/// and the scene's specular filtering.
pub fn shader_ids() -> Vec<ShaderIds> {
    vec![
        codec_ids(),
        super::sh_variant::basis_ids(),
        super::rnm::variant_ids(),
        super::cluster::count_path_ids(),
        crate::render::specular::filter_ids(),
    ]
}

/// Every id of [`shader_ids`] as a define (`CODEC_BC4`, 1): [`path_defines`] gives them to
/// every compile of a technique's shader.
pub fn shader_id_defines() -> Vec<(&'static str, u32)> {
    shader_ids().into_iter().flat_map(|set| set.ids).collect()
}

/// How `technique`'s per-texel data is block-compressed on `dx11`, or the error of a row
/// without a `dx11` form ([`Technique::form_on`]).
///
/// # Errors
/// A technique without a dx11 form.
pub fn dx11_codec(technique: Technique, label: &str) -> Result<BlockCodec, TechniqueError> {
    let form = technique
        .form_on(HwPath::Dx11)
        .map_err(|why| super::refused(label, HwPath::Dx11, why))?;
    form.codec().ok_or_else(|| TechniqueError::Input {
        label: label.into(),
        detail: "its dx11 form stores no blocks".into(),
    })
}

/// The shader macros of `technique` on `path`: the path's, the codec's
/// (`SHVIS_PER_TEXEL_CODEC`: on `dx11` the technique's, else `CODEC_NONE`, the data stored
/// as dx10 stores it) and every shader id ([`shader_id_defines`]).
pub fn path_defines(technique: Technique, path: HwPath) -> Vec<(&'static str, u32)> {
    let codec = technique
        .form_on(path)
        .ok()
        .and_then(|form| form.codec())
        .map_or(NO_CODEC, BlockCodec::shader_value);
    let mut defines = path.shader_defines().to_vec();
    defines.push(("PER_TEXEL_CODEC", codec));
    defines.extend(shader_id_defines());
    defines
}

/// The BC6H quality of the norms: the study's default (the fastest within 5 % of the best).
pub const NORM_QUALITY: Bc6hQuality = Bc6hQuality::Basic;

/// The BC7 quality of the ratios (`shvis study block`'s `bc7-norm` rows).
pub const RATIO_QUALITY: Bc7Quality = Bc7Quality::Basic;

/// A technique's per-texel groups block-compressed ([`compress`]).
#[derive(Clone, Debug, PartialEq)]
pub struct BlockTexels {
    pub codec: BlockCodec,
    pub res: u32,
    /// The groups' blocks, one layer each (BC7 ratios, or BC4 values).
    pub layers: Vec<Vec<u8>>,
    /// The norms' BC6H blocks (ratio codecs).
    pub norms: Option<Vec<u8>>,
    /// Norms clamped into BC6H's range.
    pub clamped: Clamped,
    /// Debug name of the images ("shlmap.dx11.radiance").
    pub name: String,
}

/// The values of each group as f32 (`[texel][channel]`, res² texels), from `texels`' format.
fn group_values(
    texels: &TexelGroups,
    label: &str,
) -> Result<(usize, Vec<Vec<f32>>), TechniqueError> {
    let (channels, value): (usize, fn(&[u8]) -> f32) = match texels.format {
        vk::Format::R16G16B16A16_SFLOAT => (4, |b| f16::from_le_bytes([b[0], b[1]]).to_f32()),
        vk::Format::R16_SFLOAT => (1, |b| f16::from_le_bytes([b[0], b[1]]).to_f32()),
        vk::Format::R8G8B8A8_UNORM => (4, |b| f32::from(b[0]) / 255.0),
        other => {
            return Err(TechniqueError::Input {
                label: label.into(),
                detail: format!("per-texel data of format {other:?} has no block-compressed form"),
            });
        }
    };
    let bytes =
        crate::gpu::image::format_texel_bytes(texels.format).unwrap_or(1) as usize / channels;
    let groups = texels
        .groups
        .iter()
        .map(|g| g.chunks_exact(bytes).map(value).collect())
        .collect();
    Ok((channels, groups))
}

/// Gives each texel whose values are all 0 (gutter, black texels: ratio 0, so any norm
/// decodes to 0) the largest norm of its 4 × 4 block: BC6H then spends the block's range
/// on the covered texels only, and the filter at a chart's edge blends the edge texel's
/// ratio by a norm near its own, not by 0.
fn fill_empty_norms(norms: &mut [[f32; 3]], res: u32) {
    let res = res as usize;
    for by in (0..res).step_by(4) {
        for bx in (0..res).step_by(4) {
            let block = || {
                (by..(by + 4).min(res))
                    .flat_map(move |y| (bx..(bx + 4).min(res)).map(move |x| y * res + x))
            };
            let fill: [f32; 3] =
                std::array::from_fn(|c| block().map(|t| norms[t][c]).fold(0.0, f32::max));
            for t in block() {
                if norms[t] == [0.0; 3] {
                    norms[t] = fill;
                }
            }
        }
    }
}

/// The byte a ratio of 0 is stored as (module doc).
pub const RATIO_OFFSET: f32 = 128.0;
/// The bytes a ratio of 1 adds to [`RATIO_OFFSET`] (module doc).
pub const RATIO_DIVISOR: f32 = 127.0;

/// The ratio r ∈ [−1, 1] as the 8-bit value BC7 stores (module doc).
fn ratio_byte(r: f32) -> u8 {
    (RATIO_OFFSET + (RATIO_DIVISOR * r.clamp(-1.0, 1.0)).round()) as u8
}

/// The ratio an 8-bit (or filtered, ×255) stored value decodes to.
pub fn byte_ratio(s: f32) -> f32 {
    (s - RATIO_OFFSET) / RATIO_DIVISOR
}

/// Compresses `texels` with `codec` (module doc), the ratios at [`RATIO_QUALITY`]. `label`
/// names the row in errors.
///
/// # Errors
/// A format the codec cannot take; for BC4, values outside [0, 1]; non-finite values.
pub fn compress(
    texels: &TexelGroups,
    codec: BlockCodec,
    label: &str,
) -> Result<BlockTexels, TechniqueError> {
    compress_at(texels, codec, label, RATIO_QUALITY)
}

/// [`compress`] with the ratios at BC7 quality `ratio_quality` (the study's comparison).
///
/// # Errors
/// As [`compress`].
pub fn compress_at(
    texels: &TexelGroups,
    codec: BlockCodec,
    label: &str,
    ratio_quality: Bc7Quality,
) -> Result<BlockTexels, TechniqueError> {
    let input = |detail: String| TechniqueError::Input {
        label: label.into(),
        detail,
    };
    let (channels, groups) = group_values(texels, label)?;
    if groups.iter().flatten().any(|v| !v.is_finite()) {
        return Err(input("per-texel data holds a non-finite value".into()));
    }
    let res = texels.res;
    let name = texels.name.clone();
    match codec {
        BlockCodec::Bc4 => {
            if channels != 1 {
                return Err(input(format!(
                    "BC4 takes one value per texel, the data has {channels}"
                )));
            }
            if let Some(v) = groups.iter().flatten().find(|v| !(0.0..=1.0).contains(*v)) {
                return Err(input(format!(
                    "BC4 takes values in [0, 1]; the data holds {v}"
                )));
            }
            let layers = groups
                .iter()
                .map(|g| {
                    let bytes: Vec<u8> = g.iter().map(|v| (v * 255.0).round() as u8).collect();
                    bc::encode_bc4(&bytes, res)
                })
                .collect();
            Ok(BlockTexels {
                codec,
                res,
                layers,
                norms: None,
                clamped: Clamped::default(),
                name,
            })
        }
        BlockCodec::Ratio(colours) => {
            if channels != VALUES_PER_TEXEL {
                return Err(input(format!(
                    "ratio blocks take RGBA groups, the data has {channels} channels"
                )));
            }
            let texel_count = (res * res) as usize;
            let mut norms = vec![[0f32; 3]; texel_count];
            for (g, group) in groups.iter().enumerate() {
                for (t, texel) in group.chunks_exact(VALUES_PER_TEXEL).enumerate() {
                    for (i, v) in texel.iter().enumerate() {
                        let c = colours.colour(VALUES_PER_TEXEL * g + i);
                        norms[t][c] = norms[t][c].max(v.abs());
                    }
                }
            }
            if colours == NormColours::One {
                for n in &mut norms {
                    *n = [n[0]; 3];
                }
            }
            let ratio_norms = norms.clone();
            fill_empty_norms(&mut norms, res);
            let (norm_blocks, clamped) = bc::encode_bc6h(&norms, res, NORM_QUALITY);
            if clamped != Clamped::default() {
                log::warn!(
                    "{label}: {} per-texel norms above the largest half float ({}) stored as {}",
                    clamped.above,
                    bc::HALF_MAX,
                    bc::HALF_MAX
                );
            }
            let layers: Vec<Vec<u8>> = groups
                .iter()
                .enumerate()
                .map(|(g, group)| {
                    let rgba: Vec<[u8; 4]> = group
                        .chunks_exact(VALUES_PER_TEXEL)
                        .enumerate()
                        .map(|(t, texel)| {
                            std::array::from_fn(|i| {
                                let n = ratio_norms[t][colours.colour(VALUES_PER_TEXEL * g + i)];
                                ratio_byte(if n > 0.0 { texel[i] / n } else { 0.0 })
                            })
                        })
                        .collect();
                    bc::encode_bc7_at(&rgba, res, true, ratio_quality)
                })
                .collect();
            Ok(BlockTexels {
                codec,
                res,
                layers,
                norms: Some(norm_blocks),
                clamped,
                name,
            })
        }
    }
}

impl BlockTexels {
    /// The image formats: the groups' layers, then the norms'.
    fn formats(&self) -> (vk::Format, Option<vk::Format>) {
        match self.codec {
            BlockCodec::Bc4 => (vk::Format::BC4_UNORM_BLOCK, None),
            BlockCodec::Ratio(_) => (
                vk::Format::BC7_UNORM_BLOCK,
                Some(vk::Format::BC6H_UFLOAT_BLOCK),
            ),
        }
    }

    /// The images: a 2D array of the groups' layers, and for the ratio codecs a one-layer
    /// array of the norms; each with its level-0 layers and debug name.
    pub fn image_levels(&self) -> Vec<ImageBytes<'_>> {
        let (groups, norms) = self.formats();
        let mut images = vec![(
            ImageDesc::texture_2d_array(groups, self.res, self.res, self.layers.len() as u32),
            vec![self.layers.iter().map(Vec::as_slice).collect()],
            self.name.clone(),
        )];
        if let (Some(format), Some(blocks)) = (norms, &self.norms) {
            images.push((
                ImageDesc::texture_2d_array(format, self.res, self.res, 1),
                vec![vec![blocks.as_slice()]],
                format!("{}.norms", self.name),
            ));
        }
        images
    }

    /// Uploads the images, after checking the device samples their formats.
    ///
    /// # Errors
    /// A device without BC support (`textureCompressionBC`, or a format it cannot filter).
    pub fn upload(&self, ctx: &Arc<Context>, label: &str) -> Result<Vec<Image>, TechniqueError> {
        let (groups, norms) = self.formats();
        for format in std::iter::once(groups).chain(norms) {
            if !ctx.supports_block_format(format) {
                return Err(TechniqueError::Input {
                    label: label.into(),
                    detail: format!(
                        "{} cannot sample {format:?} (textureCompressionBC); the dx11 path needs block-compressed textures",
                        ctx.device_name()
                    ),
                });
            }
        }
        self.image_levels()
            .into_iter()
            .map(|(desc, levels, name)| Ok(Image::with_data(ctx, &desc, &levels, &name)?))
            .collect()
    }

    /// The layers, norms and clamp counts as cache bytes ([`BlockTexels::from_bytes`]).
    fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        let mut blob = |b: &[u8]| {
            out.extend_from_slice(&(b.len() as u64).to_le_bytes());
            out.extend_from_slice(b);
        };
        for layer in &self.layers {
            blob(layer);
        }
        blob(self.norms.as_deref().unwrap_or(&[]));
        out.extend_from_slice(&(self.layers.len() as u64).to_le_bytes());
        out.extend_from_slice(&self.clamped.below.to_le_bytes());
        out.extend_from_slice(&self.clamped.above.to_le_bytes());
        out
    }

    /// The blocks of `texels` under `codec` from [`BlockTexels::to_bytes`]' bytes; `None`
    /// when they do not fit (another layer count or size).
    fn from_bytes(bytes: &[u8], codec: BlockCodec, texels: &TexelGroups) -> Option<BlockTexels> {
        let tail = bytes.len().checked_sub(24)?;
        let word = |at: usize| Some(u64::from_le_bytes(bytes.get(at..at + 8)?.try_into().ok()?));
        let layers = word(tail)? as usize;
        let clamped = Clamped {
            below: word(tail + 8)?,
            above: word(tail + 16)?,
        };
        let mut at = 0;
        let mut blobs = Vec::new();
        for _ in 0..=layers {
            let len = word(at)? as usize;
            blobs.push(bytes.get(at + 8..at + 8 + len)?.to_vec());
            at += 8 + len;
        }
        let norms = blobs.pop()?;
        let per_layer = match codec {
            BlockCodec::Bc4 => bc::compressed_bytes(texels.res) / 2,
            BlockCodec::Ratio(_) => bc::compressed_bytes(texels.res),
        };
        let fits = at == tail
            && layers == texels.groups.len()
            && blobs.iter().all(|b| b.len() == per_layer)
            && match codec {
                BlockCodec::Bc4 => norms.is_empty(),
                BlockCodec::Ratio(_) => norms.len() == bc::compressed_bytes(texels.res),
            };
        fits.then(|| BlockTexels {
            codec,
            res: texels.res,
            layers: blobs,
            norms: (!norms.is_empty()).then_some(norms),
            clamped,
            name: texels.name.clone(),
        })
    }

    /// Bytes per texel on the GPU (whole blocks over res²).
    pub fn bytes_per_texel(&self) -> f64 {
        let bytes: usize = self.layers.iter().map(Vec::len).sum::<usize>()
            + self.norms.as_ref().map_or(0, Vec::len);
        bytes as f64 / f64::from(self.res * self.res)
    }

    /// The blocks decoded on the CPU by the independent decoder ([`DecodedBlocks`]).
    pub fn decode(&self) -> DecodedBlocks {
        let res = self.res;
        let (stored, norms, colours) = match (self.codec, &self.norms) {
            (BlockCodec::Ratio(colours), Some(norms)) => (
                self.layers
                    .iter()
                    .map(|layer| {
                        bc::decode_bc7(layer, res)
                            .iter()
                            .flat_map(|s| s.map(|v| byte_ratio(f32::from(v))))
                            .collect()
                    })
                    .collect(),
                Some(bc::decode_bc6h(norms, res)),
                colours,
            ),
            _ => (
                self.layers
                    .iter()
                    .map(|layer| {
                        bc::decode_bc4(layer, res)
                            .iter()
                            .flat_map(|&v| [f32::from(v) / 255.0, 0.0, 0.0, 0.0])
                            .collect()
                    })
                    .collect(),
                None,
                NormColours::One,
            ),
        };
        DecodedBlocks {
            res,
            stored,
            norms,
            colours,
        }
    }

    /// What the GPU reads at each texel: `[group][texel · 4 + channel]` ([`DecodedBlocks::value`]).
    pub fn decoded_values(&self) -> Vec<Vec<f32>> {
        let decoded = self.decode();
        let texels = (self.res * self.res) as usize;
        (0..self.layers.len())
            .map(|g| {
                (0..texels * VALUES_PER_TEXEL)
                    .map(|k| {
                        decoded.value(
                            k / VALUES_PER_TEXEL,
                            VALUES_PER_TEXEL * g + k % VALUES_PER_TEXEL,
                        )
                    })
                    .collect()
            })
            .collect()
    }
}

/// A technique's dx11 blocks decoded: per group the stored ratios (or BC4 values) and per
/// texel the norms, kept apart as the GPU filters them.
#[derive(Clone, Debug, PartialEq)]
pub struct DecodedBlocks {
    pub res: u32,
    /// `[group][texel · 4 + channel]`: r ∈ [−1, 1], or the BC4 value in channel 0.
    stored: Vec<Vec<f32>>,
    /// The norms per texel (ratio codecs).
    norms: Option<Vec<[f32; 3]>>,
    colours: NormColours,
}

impl DecodedBlocks {
    /// Value `j` of texel `t`.
    pub fn value(&self, t: usize, j: usize) -> f32 {
        let r = self.stored[j / VALUES_PER_TEXEL][VALUES_PER_TEXEL * t + j % VALUES_PER_TEXEL];
        match &self.norms {
            Some(norms) => r * norms[t][self.colours.colour(j)],
            None => r,
        }
    }

    /// Value `j` where the sampler blends `texels` by `weights`: the stored ratio and the
    /// norm filtered apart, then multiplied, as the shader decodes (module doc).
    pub fn filtered(&self, texels: &[usize; 4], weights: &[f64; 4], j: usize) -> f64 {
        let (g, i) = (j / VALUES_PER_TEXEL, j % VALUES_PER_TEXEL);
        let blend = |f: &dyn Fn(usize) -> f32| -> f64 {
            texels
                .iter()
                .zip(weights)
                .map(|(&t, &w)| w * f64::from(f(t)))
                .sum()
        };
        let r = blend(&|t| self.stored[g][VALUES_PER_TEXEL * t + i]);
        match &self.norms {
            Some(norms) => r * blend(&|t| norms[t][self.colours.colour(j)]),
            None => r,
        }
    }
}

/// What the encoding depends on besides the data: the encoder and its settings. Part of
/// the cache key, so a change of either re-encodes.
const ENCODER_TAG: &str =
    "intel_tex_2 0.5: bc7 alpha_basic, bc6h basic, bc4; ratio 128+127r; norms filled per block";

/// [`compress`] through the bake cache in `cache_dir` (none: no cache): the blocks are
/// part of the bake, keyed by the data, the codec and [`ENCODER_TAG`].
///
/// # Errors
/// [`compress`]'s; a cache folder that cannot be written.
pub fn compress_cached(
    texels: &TexelGroups,
    codec: BlockCodec,
    label: &str,
    cache_dir: Option<&std::path::Path>,
) -> Result<BlockTexels, TechniqueError> {
    let Some(dir) = cache_dir else {
        return compress(texels, codec, label);
    };
    let mut id = Vec::new();
    id.extend_from_slice(ENCODER_TAG.as_bytes());
    id.extend_from_slice(&codec.shader_value().to_le_bytes());
    id.extend_from_slice(&texels.format.as_raw().to_le_bytes());
    id.extend_from_slice(&texels.res.to_le_bytes());
    for g in &texels.groups {
        id.extend_from_slice(&(g.len() as u64).to_le_bytes());
        id.extend_from_slice(g);
    }
    let key = crate::files::hash64(&id);
    crate::bake::cache::load_or_build_blob(
        dir,
        "blocks",
        "dx11 blocks",
        key,
        |bytes| {
            let block = BlockTexels::from_bytes(bytes, codec, texels).ok_or_else(|| {
                "the dx11 blocks do not fit the data (another layer count or size)".to_string()
            })?;
            block.verify(texels)?;
            Ok(block)
        },
        || {
            compress(texels, codec, label)
                .map_err(|e| crate::bake::BakeError::Derived(e.to_string()))
        },
        BlockTexels::to_bytes,
    )
    .map_err(|e| TechniqueError::Input {
        label: label.into(),
        detail: e.to_string(),
    })
}

/// BC4's largest error: one of its 7 steps of the block's range (at most the block's largest
/// value), plus the 8-bit rounding of its input and of its endpoints (an encoder need not
/// take the block's extremes as endpoints).
const BC4_ERROR: (f32, f32) = (1.0 / 7.0, 2.0 / 255.0);

/// How far beyond the image's largest |value| a ratio block may decode. A ratio block has
/// no per-value bound worth the name: BC6H may hold a norm of a block that mixes
/// magnitudes at twice its value, and a black gutter texel takes its block's norm (a texel
/// of the house's `shlmapw` decodes 1.1 × its block's largest |value| away from its own);
/// what only data of another image does is caught by the RMS bound, as a whole.
const RATIO_RANGE: f32 = 2.0;

/// Largest relative RMS error of a whole ratio-coded image (the house's bakes: 0.5–2.7 %
/// over 21 techniques; smooth noise with a phase per value, the encoder's hard case: 10 %).
const IMAGE_RMS_BOUND: f64 = 0.25;

impl BlockTexels {
    /// Whether these blocks can be `texels`' (a cache file's claim, checked before use):
    /// every decoded value finite; under BC4 within [`BC4_ERROR`] of its source value,
    /// relative to its 4 × 4 block's largest; under the ratio codecs within
    /// [`RATIO_RANGE`] × the image's largest |value| (clamped to half float range as the
    /// norms are), and the image's relative RMS error within [`IMAGE_RMS_BOUND`].
    ///
    /// # Errors
    /// What fails, with the first texel where it does.
    pub fn verify(&self, texels: &TexelGroups) -> Result<(), String> {
        let (channels, groups) = group_values(texels, "cache").map_err(|e| e.to_string())?;
        let decoded = self.decoded_values();
        let res = self.res as usize;
        let source = |g: usize, t: usize, c: usize| -> f32 {
            groups[g][channels * t + c].clamp(-f32::from(f16::MAX), f32::from(f16::MAX))
        };
        let image_scale = (0..groups.len())
            .flat_map(|g| (0..res * res).flat_map(move |t| (0..channels).map(move |c| (g, t, c))))
            .fold(0f32, |m, (g, t, c)| m.max(source(g, t, c).abs()));
        let (mut err2, mut sum2) = (0f64, 0f64);
        for (by, bx) in
            (0..res.div_ceil(4)).flat_map(|by| (0..res.div_ceil(4)).map(move |bx| (by, bx)))
        {
            let block_texels: Vec<usize> = (0..16)
                .map(|i| (4 * by + i / 4, 4 * bx + i % 4))
                .filter(|&(y, x)| y < res && x < res)
                .map(|(y, x)| y * res + x)
                .collect();
            let all = || {
                block_texels.iter().flat_map(|&t| {
                    (0..groups.len()).flat_map(move |g| (0..channels).map(move |c| (g, t, c)))
                })
            };
            let block_scale = all().fold(0f32, |m, (g, t, c)| m.max(source(g, t, c).abs()));
            for (g, t, c) in all() {
                let (d, v) = (decoded[g][VALUES_PER_TEXEL * t + c], source(g, t, c));
                let (fits, bound) = match self.codec {
                    BlockCodec::Bc4 => {
                        let bound = BC4_ERROR.0 * block_scale + BC4_ERROR.1;
                        (
                            (d - v).abs() <= bound,
                            format!("within {bound} of its value"),
                        )
                    }
                    BlockCodec::Ratio(_) => {
                        let bound = RATIO_RANGE * image_scale;
                        (d.abs() <= bound, format!("within ±{bound}"))
                    }
                };
                if !d.is_finite() || !fits {
                    return Err(format!(
                        "texel ({}, {}) of group {g} decodes to {d}, its value is {v}: not {bound} as the encoder keeps it",
                        t % res,
                        t / res
                    ));
                }
                err2 += f64::from(d - v).powi(2);
                sum2 += f64::from(v).powi(2);
            }
        }
        let rms = if sum2 > 0.0 {
            (err2 / sum2).sqrt()
        } else {
            0.0
        };
        if matches!(self.codec, BlockCodec::Ratio(_)) && rms > IMAGE_RMS_BOUND {
            return Err(format!(
                "the image's relative RMS error is {rms:.3}, beyond the encoder's {IMAGE_RMS_BOUND}"
            ));
        }
        Ok(())
    }
}

/// The per-texel images of `technique` on `path`: on `dx11` block-compressed (refused
/// with the reason where its data has no such form; through the cache in `cache_dir`),
/// else as `texels` uploads them.
pub fn upload_per_texel(
    ctx: &Arc<Context>,
    texels: &TexelGroups,
    technique: Technique,
    path: HwPath,
    label: &str,
    cache_dir: Option<&std::path::Path>,
) -> Result<Vec<Image>, TechniqueError> {
    match path {
        HwPath::Dx11 => {
            let codec = dx11_codec(technique, label)?;
            if texels.groups.is_empty() {
                return Ok(Vec::new());
            }
            compress_cached(texels, codec, label, cache_dir)?.upload(ctx, label)
        }
        HwPath::Dx9 | HwPath::Dx10 => texels.upload(ctx, path),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rgba16f(res: u32, groups: usize, value: impl Fn(usize, usize) -> f32) -> TexelGroups {
        let texels = (res * res) as usize;
        let data: Vec<Vec<f16>> = (0..groups)
            .map(|g| {
                (0..texels * 4)
                    .map(|k| f16::from_f32(value(k / 4, 4 * g + k % 4)))
                    .collect()
            })
            .collect();
        TexelGroups::new(vk::Format::R16G16B16A16_SFLOAT, res, &data, "t".into())
    }

    /// Largest |decoded − stored| over the texels, relative to each texel's largest value.
    fn worst_relative(texels: &TexelGroups, block: &BlockTexels) -> f32 {
        let (_, groups) = group_values(texels, "t").unwrap();
        let decoded = block.decoded_values();
        let n = (texels.res * texels.res) as usize;
        (0..n)
            .map(|t| {
                let scale = groups
                    .iter()
                    .flat_map(|g| &g[4 * t..4 * t + 4])
                    .fold(0f32, |m, v| m.max(v.abs()));
                let err = groups
                    .iter()
                    .zip(&decoded)
                    .flat_map(|(g, d)| (4 * t..4 * t + 4).map(move |k| (g[k] - d[k]).abs()))
                    .fold(0f32, f32::max);
                if scale > 0.0 { err / scale } else { err }
            })
            .fold(0f32, f32::max)
    }

    #[test]
    fn signed_high_order_terms_and_hdr_round_trip_within_a_few_per_cent_of_the_texel() {
        // SH-like RGB data: L0 positive over four decades, higher terms of either sign.
        let res = 16;
        let texels = rgba16f(res, 7, |t, j| {
            let (x, y) = ((t as u32 % res) as f32, (t as u32 / res) as f32);
            let l0 = 10f32.powf(x / res as f32 * 4.0 - 1.0);
            let k = j / 3;
            if j >= 27 {
                0.0
            } else if k == 0 {
                l0 * [1.0, 0.8, 0.6][j % 3]
            } else {
                l0 * 0.5 * ((k as f32 + y * 0.3).sin())
            }
        });
        let block = compress(&texels, BlockCodec::Ratio(NormColours::Triplets), "t").unwrap();
        assert_eq!(block.layers.len(), 7);
        assert_eq!(block.clamped, Clamped::default());
        assert_eq!(block.bytes_per_texel(), 8.0);
        let worst = worst_relative(&texels, &block);
        assert!(
            worst < 0.05,
            "worst texel error {worst} of its largest value"
        );
    }

    #[test]
    fn a_black_texel_decodes_to_zero_and_beyond_half_is_clamped_and_counted() {
        let res = 8;
        let texels = rgba16f(res, 1, |t, _| match t {
            0 => 0.0,
            _ => 1.0,
        });
        let block = compress(&texels, BlockCodec::Ratio(NormColours::One), "t").unwrap();
        let decoded = block.decoded_values();
        assert_eq!(&decoded[0][..4], &[0.0; 4], "L0 = 0 stores black");
        // f16 holds nothing above 65504, so the data goes through f32 groups.
        let mut texels = texels;
        texels.format = vk::Format::R8G8B8A8_UNORM;
        texels.groups = vec![vec![255; (res * res * 4) as usize]];
        let (_, mut groups) = group_values(&texels, "t").unwrap();
        groups[0][0] = 1e6;
        let norms: Vec<[f32; 3]> = groups[0]
            .chunks(4)
            .map(|v| [v[0].abs().max(v[1]); 3])
            .collect();
        let (_, clamped) = bc::encode_bc6h(&norms, res, NORM_QUALITY);
        assert_eq!(
            clamped.above, 3,
            "one norm (three channels) above the largest half, counted"
        );
    }

    #[test]
    fn a_block_across_a_chart_border_and_its_gutter_keeps_the_covered_texels() {
        // Each 4 × 4 block holds two columns of black gutter texels beside two of a chart.
        // One chart beside the gutter: every covered texel within 5 % of its own scale.
        let res = 8;
        let chart = |bright: f32, dim: f32| {
            rgba16f(res, 3, move |t, j| {
                let (x, y) = (t % res as usize, t / res as usize);
                let base = match x % 4 {
                    0 | 1 => 0.0,
                    2 => bright,
                    _ => dim,
                } * (1.0 + 0.1 * y as f32);
                base * [1.0, -0.5, 0.25, 0.7][j % 4]
            })
        };
        let texels = chart(50.0, 20.0);
        let block = compress(&texels, BlockCodec::Ratio(NormColours::GroupRgb), "t").unwrap();
        let worst = worst_relative(&texels, &block);
        assert!(worst < 0.05, "worst texel error {worst} of its scale");
        let decoded = block.decoded_values();
        for y in 0..res as usize {
            for x in [0, 1, 4, 5] {
                let t = y * res as usize + x;
                assert!(
                    decoded.iter().all(|g| g[4 * t..4 * t + 4] == [0.0; 4]),
                    "gutter stays black"
                );
            }
        }
        // Two charts 2500 : 1 apart in one block: BC6H's endpoints cannot hold both
        // magnitudes and the gutter well; the dim chart's texels err by up to 10–15 % of
        // their own scale (docs/dx11.md).
        let texels = chart(50.0, 0.02);
        let block = compress(&texels, BlockCodec::Ratio(NormColours::GroupRgb), "t").unwrap();
        let worst = worst_relative(&texels, &block);
        assert!(worst < 0.2, "worst texel error {worst} of its scale");
    }

    #[test]
    fn ao_goes_to_bc4_and_out_of_range_values_are_refused() {
        let res = 8;
        let ao: Vec<f16> = (0..res * res)
            .map(|t| f16::from_f32(t as f32 / 63.0))
            .collect();
        let texels = TexelGroups::new(vk::Format::R16_SFLOAT, res, &[ao], "ao".into());
        let block = compress(&texels, BlockCodec::Bc4, "t").unwrap();
        assert_eq!(block.bytes_per_texel(), 0.5);
        let back = block.decoded_values();
        for (t, v) in back[0].iter().step_by(4).enumerate() {
            // BC4: 8 levels between a block's extremes, here at most 27/63 apart.
            assert!((v - t as f32 / 63.0).abs() < 0.035, "{t}: {v}");
        }
        let bad = TexelGroups::new(
            vk::Format::R16_SFLOAT,
            res,
            &[vec![f16::from_f32(2.0); 64]],
            "ao".into(),
        );
        assert!(compress(&bad, BlockCodec::Bc4, "t").is_err());
        assert!(compress(&texels, BlockCodec::Ratio(NormColours::One), "t").is_err());
    }

    #[test]
    fn the_blocks_are_cached_with_the_bake_and_a_damaged_file_is_rebuilt() {
        let dir = std::env::temp_dir().join(format!("shvis-blocks-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let texels = rgba16f(8, 2, |t, j| (t as f32 * 0.1 + j as f32).sin());
        let codec = BlockCodec::Ratio(NormColours::One);
        let fresh = compress_cached(&texels, codec, "t", Some(&dir)).unwrap();
        let files: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        assert_eq!(files.len(), 1, "one cache file");
        assert_eq!(
            compress_cached(&texels, codec, "t", Some(&dir)).unwrap(),
            fresh
        );
        let mut bytes = std::fs::read(&files[0]).unwrap();
        let last = bytes.len() - 1;
        bytes[last] ^= 0xFF;
        std::fs::write(&files[0], &bytes).unwrap();
        assert_eq!(
            compress_cached(&texels, codec, "t", Some(&dir)).unwrap(),
            fresh,
            "rebuilt"
        );
        // Other data, another key.
        let other = rgba16f(8, 2, |t, j| (t as f32 * 0.2 + j as f32).cos());
        assert_ne!(
            compress_cached(&other, codec, "t", Some(&dir)).unwrap(),
            fresh
        );
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);
        // A file whose header and checksum hold but whose blocks are the other data's: the
        // decoded values are checked against the data, refused, rebuilt and rewritten.
        let other_block = compress(&other, codec, "t").unwrap();
        assert!(other_block.verify(&texels).is_err());
        assert_eq!(fresh.verify(&texels), Ok(()));
        let key = u64::from_str_radix(
            files[0]
                .file_stem()
                .unwrap()
                .to_str()
                .unwrap()
                .trim_start_matches("blocks-"),
            16,
        )
        .unwrap();
        std::fs::write(
            &files[0],
            crate::bake::cache::blob_file(key, &other_block.to_bytes()),
        )
        .unwrap();
        assert_eq!(
            compress_cached(&texels, codec, "t", Some(&dir)).unwrap(),
            fresh,
            "rebuilt"
        );
        assert_eq!(
            std::fs::read(&files[0]).unwrap(),
            crate::bake::cache::blob_file(key, &fresh.to_bytes()),
            "rewritten"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn fresh_blocks_pass_their_own_check_and_shifted_ones_do_not() {
        // The encoder's hardest case (two magnitudes in a block) and BC4 pass; the same
        // blocks claimed for data scaled by 1.5 do not.
        let res = 8;
        let hard = rgba16f(res, 3, |t, j| {
            let x = t % res as usize;
            [0.0, 0.0, 50.0, 0.02][x % 4] * [1.0, -0.5, 0.25, 0.7][j % 4]
        });
        let block = compress(&hard, BlockCodec::Ratio(NormColours::GroupRgb), "t").unwrap();
        assert_eq!(block.verify(&hard), Ok(()));
        let ao = TexelGroups {
            res,
            format: vk::Format::R16_SFLOAT,
            groups: vec![
                (0..res * res)
                    .flat_map(|t| f16::from_f32(t as f32 / 63.0).to_le_bytes())
                    .collect(),
            ],
            name: "ao".into(),
            dx9_atlas: None,
        };
        assert_eq!(
            compress(&ao, BlockCodec::Bc4, "t").unwrap().verify(&ao),
            Ok(())
        );
        let scaled = rgba16f(res, 2, |t, j| 2.0 * (t as f32 * 0.1 + j as f32).sin());
        let plain = rgba16f(res, 2, |t, j| (t as f32 * 0.1 + j as f32).sin());
        let e = compress(&plain, BlockCodec::Ratio(NormColours::One), "t")
            .unwrap()
            .verify(&scaled);
        assert!(e.is_err(), "{e:?}");
    }

    #[test]
    fn every_technique_has_a_codec_or_a_reason() {
        for &t in Technique::all() {
            match t.form_on(HwPath::Dx11) {
                Ok(form) => assert!(form.codec().is_some_and(|c| c.shader_value() > 0), "{t}"),
                Err(reason) => assert!(!reason.to_string().is_empty()),
            }
        }
        let codec = |name: &str| dx11_codec(name.parse().unwrap(), name);
        assert!(codec("shlmap").is_ok() && codec("unc6").is_ok());
        let e = codec("vq16").unwrap_err().to_string();
        assert!(
            e.contains("cannot run on dx11") && e.contains("cluster indices"),
            "{e}"
        );
    }
}
