//! The one way a technique becomes drawable: a uniform block, typed texture slots, the
//! technique's fragment shader, the path rules, the pipeline — and the cost table's memory
//! and lookup columns, computed from the image descriptions rather than written by hand.
//!
//! Bindings (glsl/include/common.glsl and `gpu::layout`): the scene's frame block, albedo
//! and normal map; the technique's uniform block at `BINDING_TECHNIQUE_PARAMS`; slot i at
//! `BINDING_TECHNIQUE_TEXTURE0 + i`, one image as a texture, several as a texture array
//! (dx9's `sampler2D t[N]`).

use std::sync::Arc;

use ash::vk;

use super::{HwPath, Technique, TechniqueError, TechniqueGpu, TechniqueStats};
use crate::gpu::{self, Context, Image, layout};
use crate::render::SceneGpu;

/// What one binding's images hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlotKind {
    /// Values per lightmap texel (`super::texels`): each layer is one fetch per pixel.
    PerTexel,
    /// Normal-indexed tables (`super::tables`): each sphere (dx9: two hemisphere squares
    /// side by side; dx10: one cube of a cube array) is one dependent fetch per pixel.
    NormalTable,
}

/// The images bound at one binding.
pub struct TextureSlot {
    pub kind: SlotKind,
    pub images: Vec<Image>,
}

impl TextureSlot {
    pub fn per_texel(images: Vec<Image>) -> Self {
        TextureSlot {
            kind: SlotKind::PerTexel,
            images,
        }
    }

    pub fn normal_tables(images: Vec<Image>) -> Self {
        TextureSlot {
            kind: SlotKind::NormalTable,
            images,
        }
    }

    /// Texture fetches per pixel from this slot.
    pub fn lookups(&self) -> u32 {
        self.images
            .iter()
            .map(|image| {
                let d = image.desc();
                match self.kind {
                    SlotKind::PerTexel => d.layers,
                    SlotKind::NormalTable => match d.view_type {
                        vk::ImageViewType::CUBE | vk::ImageViewType::CUBE_ARRAY => d.layers / 6,
                        _ => d.width / (2 * d.height) * d.layers,
                    },
                }
            })
            .sum()
    }

    /// Bytes of GPU memory the slot's data takes (level 0 of every layer).
    pub fn bytes(&self) -> u64 {
        self.images.iter().map(|i| i.desc().level0_bytes()).sum()
    }
}

/// The cost-table columns of a technique with `params` bytes of uniforms and `slots`.
pub fn stats(params: &[u8], slots: &[TextureSlot]) -> TechniqueStats {
    let of_kind = |kind: SlotKind| slots.iter().filter(move |s| s.kind == kind);
    TechniqueStats {
        texel_bytes: of_kind(SlotKind::PerTexel).map(TextureSlot::bytes).sum(),
        table_bytes: of_kind(SlotKind::NormalTable)
            .map(TextureSlot::bytes)
            .sum::<u64>()
            + params.len() as u64,
        textures_bound: layout::MATERIAL_TEXTURES
            + slots.iter().map(|s| s.images.len() as u32).sum::<u32>(),
        lookups_per_pixel: layout::MATERIAL_TEXTURES
            + slots.iter().map(TextureSlot::lookups).sum::<u32>(),
    }
}

/// Makes `technique` on `path` drawable: checks the path rules, uploads `params` as its
/// uniform block, compiles its fragment shader ([`super::fragment_shader`]) and builds the
/// pipeline over `slots`.
pub fn finish(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    technique: Technique,
    path: HwPath,
    params: &[u8],
    slots: Vec<TextureSlot>,
) -> Result<TechniqueGpu, TechniqueError> {
    let label = format!("{technique}.{path}");
    let images: Vec<&Image> = slots.iter().flat_map(|s| &s.images).collect();
    check_path_rules(&label, path, &images)?;
    let stats = stats(params, &slots);
    let params_buffer = gpu::Buffer::with_data(
        ctx,
        params,
        vk::BufferUsageFlags::UNIFORM_BUFFER,
        &format!("{label}.params"),
    )?;
    let shader = super::fragment_shader(technique);
    let mut defines = vec![path.shader_define()];
    defines.extend_from_slice(&shader.defines);
    let fragment = gpu::compile_glsl(shader.path, gpu::ShaderStage::Fragment, &defines)?;
    let sampler = scene.lightmap_sampler();
    let mut resources = scene.common_resources();
    resources.push((
        layout::BINDING_TECHNIQUE_PARAMS,
        gpu::Resource::Uniform(&params_buffer),
    ));
    for (binding, slot) in (layout::BINDING_TECHNIQUE_TEXTURE0..).zip(&slots) {
        let resource = match slot.images.as_slice() {
            [one] => gpu::Resource::Texture(one, sampler),
            many => gpu::Resource::TextureArray(many.iter().map(|i| (i, sampler)).collect()),
        };
        resources.push((binding, resource));
    }
    let pipeline = scene.mesh_pipeline(ctx, &label, &fragment, &resources)?;
    drop(resources);
    Ok(TechniqueGpu {
        technique,
        path,
        pipeline,
        stats,
        _images: slots.into_iter().flat_map(|s| s.images).collect(),
        _buffers: vec![params_buffer],
    })
}

/// Enforces the `dx9` rules in code (DESIGN §2): only 2D textures, at most
/// `DX9_MAX_TEXTURES` per draw counting albedo and normal map.
pub fn check_path_rules(
    label: &str,
    path: HwPath,
    technique_textures: &[&Image],
) -> Result<(), TechniqueError> {
    match path {
        HwPath::Dx10 => return Ok(()),
        HwPath::Dx9 => {}
    }
    let total = technique_textures.len() as u32 + layout::MATERIAL_TEXTURES;
    if total > layout::DX9_MAX_TEXTURES {
        return Err(TechniqueError::Dx9Rule {
            label: label.into(),
            detail: format!(
                "needs {total} textures per draw, dx9 allows {}",
                layout::DX9_MAX_TEXTURES
            ),
        });
    }
    if let Some(img) = technique_textures
        .iter()
        .find(|i| i.desc().view_type != vk::ImageViewType::TYPE_2D)
    {
        return Err(TechniqueError::Dx9Rule {
            label: label.into(),
            detail: format!(
                "binds a {:?} texture; dx9 allows only 2D textures",
                img.desc().view_type
            ),
        });
    }
    Ok(())
}
