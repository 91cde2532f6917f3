//! The one way a technique becomes drawable: a uniform block, typed texture slots, the
//! technique's fragment shader, the path rules, the pipeline — and the cost table's memory
//! and lookup columns, computed from the image descriptions rather than written by hand.
//!
//! Bindings (glsl/include/common.glsl and `gpu::layout`): the scene's frame block, albedo
//! and normal map; the technique's uniform block at `BINDING_TECHNIQUE_PARAMS`; slot i at
//! `BINDING_TECHNIQUE_TEXTURE0 + i`, one image as a texture, several as a texture array
//! (dx9's `sampler2D t[N]`). A scene with a specular material term (`--specular`,
//! `crate::render::specular::SceneSpecular`) adds its block and moment maps at
//! `BINDING_SPECULAR_*`, counted in the path rules and the lookup columns like the
//! technique's own.

use std::sync::Arc;

use ash::vk;

use super::lighting::{LightingData, LightingSet};
use super::{HwPath, Technique, TechniqueError, TechniqueGpu, TechniqueStats};
use crate::gpu::{self, Context, Image, ImageDesc, layout};
use crate::render::SceneGpu;

/// What one binding's images hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlotKind {
    /// Values per lightmap texel (`super::texels`): each layer is one fetch per pixel.
    PerTexel,
    /// Normal-indexed tables (`super::tables`): each sphere (dx9: two hemisphere squares
    /// side by side; dx10, dx11: one cube of a cube array) is one dependent fetch per pixel.
    NormalTable,
    /// Material-space textures of the technique (`ssbump`'s SSBump / AO, the NDF moments of
    /// `uncOndf` / `preconvndf`), sampled with the material sampler: one fetch per layer; like albedo and normal map its bytes are
    /// the material's, not the lightmap's or the lighting's.
    Material,
    /// A fixed normal-indexed basis (`nmprtsvdM`'s U(n) on the disk of tangent-space
    /// normals, `super::nmprt`): one dependent fetch per layer; its bytes count with the
    /// tables'.
    NormalBasis,
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

    /// What [`stats`] needs to know of the slot.
    pub fn layout(&self) -> SlotLayout {
        SlotLayout {
            kind: self.kind,
            images: self.images.iter().map(|i| *i.desc()).collect(),
        }
    }
}

/// A slot's kind and image descriptions.
#[derive(Clone, Debug, PartialEq)]
pub struct SlotLayout {
    pub kind: SlotKind,
    pub images: Vec<ImageDesc>,
}

impl SlotLayout {
    /// Texture fetches per pixel from this slot.
    pub fn lookups(&self) -> u32 {
        self.images
            .iter()
            .map(|d| match self.kind {
                SlotKind::PerTexel | SlotKind::Material | SlotKind::NormalBasis => d.layers,
                SlotKind::NormalTable => match d.view_type {
                    vk::ImageViewType::CUBE | vk::ImageViewType::CUBE_ARRAY => d.layers / 6,
                    // dx9 strips: each sphere is two res × res hemisphere squares.
                    _ => d.width / (2 * d.height) * d.layers,
                },
            })
            .sum()
    }

    /// Bytes of GPU memory the slot's data takes (level 0 of every layer).
    pub fn bytes(&self) -> u64 {
        self.images.iter().map(ImageDesc::level0_bytes).sum()
    }
}

/// The cost-table columns of a technique with `params_bytes` of uniforms and `slots`;
/// `per_texel_lookups` overrides one fetch per per-texel layer for shaders that read the
/// lightmap otherwise (the clustered techniques' taps, `super::cluster`).
pub fn stats(
    params_bytes: usize,
    slots: &[SlotLayout],
    per_texel_lookups: Option<u32>,
) -> TechniqueStats {
    let of_kind = |kind: SlotKind| slots.iter().filter(move |s| s.kind == kind);
    // A shader that reads its per-texel groups tap by tap reads a ratio codec's norms (dx11,
    // BC6H) once a pixel besides.
    let norms = |s: &SlotLayout| -> u32 {
        s.images
            .iter()
            .filter(|d| d.format == vk::Format::BC6H_UFLOAT_BLOCK)
            .map(|d| d.layers)
            .sum()
    };
    let slot_lookups = |s: &SlotLayout| match (s.kind, per_texel_lookups) {
        (SlotKind::PerTexel, Some(n)) => n + norms(s),
        _ => s.lookups(),
    };
    TechniqueStats {
        texel_bytes: of_kind(SlotKind::PerTexel).map(SlotLayout::bytes).sum(),
        table_bytes: of_kind(SlotKind::NormalTable)
            .chain(of_kind(SlotKind::NormalBasis))
            .map(SlotLayout::bytes)
            .sum::<u64>()
            + params_bytes as u64,
        textures_bound: layout::MATERIAL_TEXTURES
            + slots.iter().map(|s| s.images.len() as u32).sum::<u32>(),
        lookups_per_pixel: layout::MATERIAL_TEXTURES + slots.iter().map(slot_lookups).sum::<u32>(),
    }
}

/// Makes `technique` on `path` drawable with `sets` copies of its lighting data (1, or 2
/// for double-buffered dynamic lighting, `super::lighting`): checks the path rules, uploads
/// each copy's uniform block and tables, compiles the fragment shader
/// ([`Technique::fragment_shader`], unless `own_fragment` gives SPIR-V in its place) once and builds one pipeline per copy over the per-texel
/// images (binding TEXTURE0: the bake's, shared by the copies, or — when the lighting data
/// has per-texel images — that copy's), the technique's extra slot if it has one (material
/// textures, a normal basis; the next binding) and that copy's tables (the bindings after
/// those).
#[allow(clippy::too_many_arguments)]
pub fn finish(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    technique: Technique,
    path: HwPath,
    per_texel: Vec<Image>,
    extra: Option<TextureSlot>,
    lighting: &LightingData,
    sets: usize,
    own_fragment: Option<Vec<u32>>,
) -> Result<TechniqueGpu, TechniqueError> {
    let label = format!("{technique}.{path}");
    let shared_per_texel = TextureSlot::per_texel(per_texel);
    let fragment = match own_fragment {
        Some(spirv) => spirv,
        None => compile_fragment(technique, path, scene, &lighting.defines)?,
    };
    check_uniform_size(ctx, lighting.params.len(), &label)?;
    let reads = technique.reads();
    let mut built = Vec::with_capacity(sets);
    let mut stats = TechniqueStats::default();
    for set in 0..sets.max(1) {
        let suffix = set_suffix(set);
        let tables = match &lighting.tables {
            Some(tables) => tables.upload(ctx, &suffix)?,
            None => Vec::new(),
        };
        let own_per_texel = match &lighting.texels {
            Some(texels) => {
                let mut texels = texels.clone();
                texels.name += &suffix;
                Some(TextureSlot::per_texel(texels.upload(ctx, path)?))
            }
            None => None,
        };
        let slots = bound_slots(&shared_per_texel, extra.as_ref(), &own_per_texel, &tables);
        let mut images: Vec<&Image> = slots.iter().flat_map(|s| &s.images).collect();
        images.extend(scene.specular().into_iter().flat_map(|s| s.images(path)));
        check_path_rules(&label, path, &images)?;
        let layouts: Vec<SlotLayout> = slots.iter().map(|s| s.layout()).collect();
        stats = self::stats(
            lighting.params.len(),
            &layouts,
            reads.per_texel_taps.map(|t| t.lookups),
        );
        if !reads.reads_normal_map {
            stats.lookups_per_pixel -= 1;
        }
        let table_lookups: u32 = layouts
            .iter()
            .filter(|l| l.kind == SlotKind::NormalTable)
            .map(SlotLayout::lookups)
            .sum();
        stats.lookups_per_pixel += (reads.table_fetches - 1) * table_lookups;
        add_specular_stats(scene, path, &mut stats);
        let params = params_buffer(ctx, &lighting.params, &label, &suffix)?;
        let resources = resources(scene, &params, path, &slots);
        let pipeline =
            scene.mesh_pipeline(ctx, &format!("{label}{suffix}"), &fragment, &resources)?;
        drop(resources);
        built.push(LightingSet {
            pipeline,
            params,
            tables,
            own_per_texel,
            defines: lighting.defines.clone(),
        });
    }
    Ok(TechniqueGpu::new(
        ctx,
        technique,
        path,
        stats,
        shared_per_texel,
        extra,
        fragment,
        built,
    ))
}

/// The slots a lighting set's pipeline binds, in binding order from
/// `BINDING_TECHNIQUE_TEXTURE0`: its own per-texel images or else the bake's, the
/// technique's extra slot, its tables.
pub(crate) fn bound_slots<'a>(
    shared_per_texel: &'a TextureSlot,
    extra: Option<&'a TextureSlot>,
    own_per_texel: &'a Option<TextureSlot>,
    tables: &'a [TextureSlot],
) -> Vec<&'a TextureSlot> {
    std::iter::once(own_per_texel.as_ref().unwrap_or(shared_per_texel))
        .chain(extra)
        .chain(tables)
        .collect()
}

/// Everything a technique's pipeline binds: [`base_resources`] and `slots` from
/// `BINDING_TECHNIQUE_TEXTURE0` on (one image as a texture, several as a texture array;
/// material textures with the material sampler, the rest with the lightmap's).
pub(crate) fn resources<'a>(
    scene: &'a SceneGpu,
    params: &'a gpu::Buffer,
    path: HwPath,
    slots: &[&'a TextureSlot],
) -> Vec<(u32, gpu::Resource<'a>)> {
    let mut resources = base_resources(scene, params, path);
    assert!(
        layout::BINDING_TECHNIQUE_TEXTURE0 + (slots.len() as u32)
            <= layout::BINDING_SPECULAR_PARAMS,
        "technique bindings reach the specular term's"
    );
    for (binding, slot) in (layout::BINDING_TECHNIQUE_TEXTURE0..).zip(slots) {
        let sampler = match slot.kind {
            SlotKind::Material => scene.material_sampler(),
            SlotKind::PerTexel | SlotKind::NormalTable | SlotKind::NormalBasis => {
                scene.lightmap_sampler()
            }
        };
        let resource = match slot.images.as_slice() {
            [one] => gpu::Resource::Texture(one, sampler),
            many => gpu::Resource::TextureArray(many.iter().map(|i| (i, sampler)).collect()),
        };
        resources.push((binding, resource));
    }
    resources
}

/// What the scene's specular term (if any) adds to a technique's columns on `path`: its
/// moment maps as textures bound and fetched per pixel (the mip filtering re-reads the
/// normal map, which the technique fetches already).
pub(crate) fn add_specular_stats(scene: &SceneGpu, path: HwPath, stats: &mut TechniqueStats) {
    if let Some(specular) = scene.specular() {
        stats.textures_bound += specular.images(path).len() as u32;
        stats.lookups_per_pixel += specular.term.filter.extra_lookups();
    }
}

/// `technique`'s fragment shader ([`Technique::fragment_shader`]) compiled for `path`, reading
/// the material textures at full resolution for a `material_level0` scene and adding the
/// scene's specular term when it has one.
pub(crate) fn compile_fragment(
    technique: Technique,
    path: HwPath,
    scene: &SceneGpu,
    extra_defines: &[(&'static str, u32)],
) -> Result<Vec<u32>, TechniqueError> {
    compile_fragment_source(technique, None, path, scene, extra_defines)
}

/// [`compile_fragment`] with another source under `glsl/` in place of the technique's
/// (`Some`: a cost model count shader, `crate::cost::CountPlan::shader`), given the
/// technique's defines all the same.
pub(crate) fn compile_fragment_source(
    technique: Technique,
    source: Option<&'static str>,
    path: HwPath,
    scene: &SceneGpu,
    extra_defines: &[(&'static str, u32)],
) -> Result<Vec<u32>, TechniqueError> {
    let mut shader = technique.fragment_shader();
    if let Some(source) = source {
        shader.path = source;
    }
    let mut defines = super::block::path_defines(technique, path);
    defines.push(("MATERIAL_LEVEL0", scene.material_level0() as u32));
    defines.extend_from_slice(&shader.defines);
    defines.extend_from_slice(extra_defines);
    if let Some(specular) = scene.specular() {
        defines.extend(specular.defines());
    }
    Ok(gpu::compile_glsl(
        shader.path,
        gpu::ShaderStage::Fragment,
        &defines,
    )?)
}

/// A lighting set's uniform block "{label}.params{suffix}" holding `params`.
pub(crate) fn params_buffer(
    ctx: &Arc<Context>,
    params: &[u8],
    label: &str,
    suffix: &str,
) -> Result<gpu::Buffer, TechniqueError> {
    Ok(gpu::Buffer::with_data(
        ctx,
        params,
        vk::BufferUsageFlags::UNIFORM_BUFFER,
        &format!("{label}.params{suffix}"),
    )?)
}

/// The scene's common bindings, its specular term's on `path` and the technique's uniform
/// block: what every technique binds besides its own textures.
pub(crate) fn base_resources<'a>(
    scene: &'a SceneGpu,
    params: &'a gpu::Buffer,
    path: HwPath,
) -> Vec<(u32, gpu::Resource<'a>)> {
    let mut resources = scene.common_resources();
    if let Some(specular) = scene.specular() {
        resources.extend(specular.resources(scene, path));
    }
    resources.push((
        layout::BINDING_TECHNIQUE_PARAMS,
        gpu::Resource::Uniform(params),
    ));
    resources
}

/// An input error unless a uniform block of `bytes` fits the device's
/// `maxUniformBufferRange` (the clustered blocks reach 64 KiB; Vulkan guarantees 16 KiB).
pub(crate) fn check_uniform_size(
    ctx: &Context,
    bytes: usize,
    label: &str,
) -> Result<(), TechniqueError> {
    let limit = ctx.limits().max_uniform_buffer_range as usize;
    if bytes > limit {
        return Err(TechniqueError::Input {
            label: label.into(),
            detail: format!(
                "needs a {bytes}-byte uniform block; {} allows {limit} (maxUniformBufferRange)",
                ctx.device_name()
            ),
        });
    }
    Ok(())
}

/// The debug-name suffix of lighting set `set`: set 0 keeps the plain names, a second copy
/// is "….b".
pub(crate) fn set_suffix(set: usize) -> String {
    if set == 0 {
        String::new()
    } else {
        format!(".{}", (b'a' + set as u8) as char)
    }
}

/// Enforces the `dx9` rules in code (DESIGN §2): only 2D textures, at most
/// `DX9_MAX_TEXTURES` per draw counting albedo and normal map.
pub fn check_path_rules(
    label: &str,
    path: HwPath,
    technique_textures: &[&Image],
) -> Result<(), TechniqueError> {
    match path {
        HwPath::Dx10 | HwPath::Dx11 => return Ok(()),
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

#[cfg(test)]
mod tests {
    use super::*;

    const F16X4: vk::Format = vk::Format::R16G16B16A16_SFLOAT;

    fn slot(kind: SlotKind, images: Vec<ImageDesc>) -> SlotLayout {
        SlotLayout { kind, images }
    }

    #[test]
    fn dx9_unc6_counts_its_textures_lookups_and_bytes() {
        // 9 visibility groups at 512², 3 colour strips of 9 spheres at 32².
        let texels = slot(
            SlotKind::PerTexel,
            vec![ImageDesc::texture_2d(F16X4, 512, 512); 9],
        );
        let tables = slot(
            SlotKind::NormalTable,
            vec![ImageDesc::texture_2d(F16X4, 9 * 2 * 32, 32); 3],
        );
        let s = stats(16, &[texels, tables], None);
        assert_eq!(s.textures_bound, 2 + 9 + 3);
        assert_eq!(s.lookups_per_pixel, 2 + 9 + 27);
        assert_eq!(s.texel_bytes, 9 * 512 * 512 * 8);
        assert_eq!(s.table_bytes, 3 * 9 * 2 * 32 * 32 * 8 + 16);
    }

    #[test]
    fn dx10_pca4_counts_cubes_and_layers() {
        // One weight layer (RGBA8) and one cube array: 3 colour cubes + the mean.
        let weights = slot(
            SlotKind::PerTexel,
            vec![ImageDesc::texture_2d_array(
                vk::Format::R8G8B8A8_UNORM,
                256,
                256,
                1,
            )],
        );
        let tables = slot(
            SlotKind::NormalTable,
            vec![ImageDesc::texture_cube_array(F16X4, 32, 4)],
        );
        let s = stats(0, &[weights, tables], None);
        assert_eq!((s.textures_bound, s.lookups_per_pixel), (4, 2 + 1 + 4));
        assert_eq!(s.texel_bytes, 256 * 256 * 4);
        assert_eq!(s.table_bytes, 4 * 6 * 32 * 32 * 8);
    }
}
