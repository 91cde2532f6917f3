//! Images (2D, 2D arrays, cube arrays) with views and memory, upload of texel data through
//! a staging buffer, and samplers.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::Allocation;

use super::{Context, GpuError};

/// What an image is: small `Copy` description with chained setters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageDesc {
    pub format: vk::Format,
    pub width: u32,
    pub height: u32,
    pub layers: u32,
    pub mip_levels: u32,
    pub view_type: vk::ImageViewType,
    pub usage: vk::ImageUsageFlags,
    pub aspect: vk::ImageAspectFlags,
}

impl ImageDesc {
    /// Bytes of mip level 0 over all layers (0 for a format shvis does not upload).
    pub fn level0_bytes(&self) -> u64 {
        format_level_bytes(self.format, self.width, self.height).unwrap_or(0) * self.layers as u64
    }

    /// A sampled 2D texture that is filled by upload.
    pub fn texture_2d(format: vk::Format, width: u32, height: u32) -> Self {
        ImageDesc {
            format,
            width,
            height,
            layers: 1,
            mip_levels: 1,
            view_type: vk::ImageViewType::TYPE_2D,
            usage: vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST,
            aspect: vk::ImageAspectFlags::COLOR,
        }
    }
    /// A sampled 2D array texture of `layers` layers (the `dx10` per-texel data).
    pub fn texture_2d_array(format: vk::Format, width: u32, height: u32, layers: u32) -> Self {
        ImageDesc {
            layers,
            view_type: vk::ImageViewType::TYPE_2D_ARRAY,
            ..Self::texture_2d(format, width, height)
        }
    }
    /// A sampled cube-map array of `cubes` cubes, `size`² texels per face; layer
    /// 6·cube + face, faces in +X, −X, +Y, −Y, +Z, −Z order (Vulkan's).
    pub fn texture_cube_array(format: vk::Format, size: u32, cubes: u32) -> Self {
        ImageDesc {
            layers: 6 * cubes,
            view_type: vk::ImageViewType::CUBE_ARRAY,
            ..Self::texture_2d(format, size, size)
        }
    }
    pub fn mip_levels(mut self, levels: u32) -> Self {
        self.mip_levels = levels;
        self
    }
    pub fn usage(mut self, usage: vk::ImageUsageFlags) -> Self {
        self.usage = usage;
        self
    }
    pub fn aspect(mut self, aspect: vk::ImageAspectFlags) -> Self {
        self.aspect = aspect;
        self
    }

    fn create_flags(&self) -> vk::ImageCreateFlags {
        match self.view_type {
            vk::ImageViewType::CUBE | vk::ImageViewType::CUBE_ARRAY => {
                vk::ImageCreateFlags::CUBE_COMPATIBLE
            }
            _ => vk::ImageCreateFlags::empty(),
        }
    }
}

/// A `vk::Image` with one view over all its levels and layers, destroyed in `Drop`.
pub struct Image {
    ctx: Arc<Context>,
    raw: vk::Image,
    view: vk::ImageView,
    allocation: Option<Allocation>,
    desc: ImageDesc,
}

impl Image {
    /// `name` reads like a capture label: "preconv.dx10.ao", "scene.albedo".
    pub fn new(ctx: &Arc<Context>, desc: &ImageDesc, name: &str) -> Result<Self, GpuError> {
        if matches!(desc.view_type, vk::ImageViewType::CUBE_ARRAY) && !ctx.supports_cube_arrays() {
            return Err(GpuError::MissingFeature {
                device: ctx.device_name().to_string(),
                feature: format!("cube-map arrays (imageCubeArray) for '{name}'"),
            });
        }
        if desc.usage.contains(vk::ImageUsageFlags::SAMPLED)
            && !ctx.supports_linear_filter(desc.format)
        {
            return Err(GpuError::MissingFeature {
                device: ctx.device_name().to_string(),
                feature: format!("linear filtering of {:?} for '{name}'", desc.format),
            });
        }
        let max = ctx.limits().max_image_dimension2_d;
        if desc.width == 0 || desc.height == 0 || desc.width > max || desc.height > max {
            return Err(GpuError::Invalid {
                what: name.into(),
                detail: format!(
                    "image size {}×{} is outside 1..={max} on this device",
                    desc.width, desc.height
                ),
            });
        }
        let info = vk::ImageCreateInfo::default()
            .flags(desc.create_flags())
            .image_type(vk::ImageType::TYPE_2D)
            .format(desc.format)
            .extent(vk::Extent3D {
                width: desc.width,
                height: desc.height,
                depth: 1,
            })
            .mip_levels(desc.mip_levels)
            .array_layers(desc.layers)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(desc.usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: the create-info borrows nothing beyond this call.
        let raw = unsafe { ctx.device().create_image(&info, None) }
            .map_err(|e| GpuError::vulkan("vkCreateImage", name, e))?;
        let mut image = Image {
            ctx: ctx.clone(),
            raw,
            view: vk::ImageView::null(),
            allocation: None,
            desc: *desc,
        };
        // SAFETY: `raw` is a live image of this device.
        let req = unsafe { ctx.device().get_image_memory_requirements(raw) };
        let allocation = ctx.allocate(name, req, MemoryLocation::GpuOnly, false)?;
        // SAFETY: the allocation satisfies `req` and is bound once.
        unsafe {
            ctx.device()
                .bind_image_memory(raw, allocation.memory(), allocation.offset())
        }
        .map_err(|e| GpuError::vulkan("vkBindImageMemory", name, e))?;
        image.allocation = Some(allocation);
        let view_info = vk::ImageViewCreateInfo::default()
            .image(raw)
            .view_type(desc.view_type)
            .format(desc.format)
            .subresource_range(image.full_range());
        // SAFETY: the view covers existing levels/layers of a bound image.
        image.view = unsafe { ctx.device().create_image_view(&view_info, None) }
            .map_err(|e| GpuError::vulkan("vkCreateImageView", name, e))?;
        ctx.set_name(raw, name);
        ctx.set_name(image.view, name);
        Ok(image)
    }

    /// Creates a sampled image and uploads `levels[mip][layer]` (tightly packed texels) to
    /// it, leaving it in SHADER_READ_ONLY_OPTIMAL.
    pub fn with_data(
        ctx: &Arc<Context>,
        desc: &ImageDesc,
        levels: &[Vec<&[u8]>],
        name: &str,
    ) -> Result<Self, GpuError> {
        let image = Self::new(ctx, desc, name)?;
        super::upload::upload_image(ctx, &image, levels, name)?;
        Ok(image)
    }

    pub fn raw(&self) -> vk::Image {
        self.raw
    }
    pub fn view(&self) -> vk::ImageView {
        self.view
    }
    pub fn desc(&self) -> &ImageDesc {
        &self.desc
    }
    pub(crate) fn full_range(&self) -> vk::ImageSubresourceRange {
        vk::ImageSubresourceRange {
            aspect_mask: self.desc.aspect,
            base_mip_level: 0,
            level_count: self.desc.mip_levels,
            base_array_layer: 0,
            layer_count: self.desc.layers,
        }
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        // SAFETY: all GPU work is submit-and-wait, so nothing in flight uses the image;
        // destroying a null view is valid.
        unsafe {
            self.ctx.device().destroy_image_view(self.view, None);
            self.ctx.device().destroy_image(self.raw, None);
        }
        if let Some(a) = self.allocation.take() {
            self.ctx.free(a);
        }
    }
}

/// How a texture is filtered and addressed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SamplerKind {
    /// Tiling material textures: trilinear, repeat.
    MaterialRepeat,
    /// Lightmap and lookup tables: bilinear, clamp to edge, no mips.
    LinearClamp,
}

/// A `vk::Sampler`, destroyed in `Drop`.
pub struct Sampler {
    ctx: Arc<Context>,
    raw: vk::Sampler,
}

impl Sampler {
    pub fn new(ctx: &Arc<Context>, kind: SamplerKind, name: &str) -> Result<Self, GpuError> {
        let (address, mip, max_lod) = match kind {
            SamplerKind::MaterialRepeat => (
                vk::SamplerAddressMode::REPEAT,
                vk::SamplerMipmapMode::LINEAR,
                vk::LOD_CLAMP_NONE,
            ),
            SamplerKind::LinearClamp => (
                vk::SamplerAddressMode::CLAMP_TO_EDGE,
                vk::SamplerMipmapMode::NEAREST,
                0.0,
            ),
        };
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .mipmap_mode(mip)
            .address_mode_u(address)
            .address_mode_v(address)
            .address_mode_w(address)
            .max_lod(max_lod);
        // SAFETY: plain create-info.
        let raw = unsafe { ctx.device().create_sampler(&info, None) }
            .map_err(|e| GpuError::vulkan("vkCreateSampler", name, e))?;
        ctx.set_name(raw, name);
        Ok(Sampler {
            ctx: ctx.clone(),
            raw,
        })
    }
    pub fn raw(&self) -> vk::Sampler {
        self.raw
    }
}

impl Drop for Sampler {
    fn drop(&mut self) {
        // SAFETY: no submission in flight (submit-and-wait everywhere).
        unsafe { self.ctx.device().destroy_sampler(self.raw, None) };
    }
}

/// The block side and bytes per block of a block-compressed `format` (BC4: 4 × 4 texels in
/// 8 bytes; BC6H, BC7: in 16), `None` for others.
pub fn format_block(format: vk::Format) -> Option<(u32, u32)> {
    Some(match format {
        vk::Format::BC4_UNORM_BLOCK => (4, 8),
        vk::Format::BC6H_UFLOAT_BLOCK | vk::Format::BC7_UNORM_BLOCK => (4, 16),
        _ => return None,
    })
}

/// Bytes of one `width` × `height` layer of `format` (whole blocks for a block-compressed
/// one), `None` for a format shvis does not upload.
pub fn format_level_bytes(format: vk::Format, width: u32, height: u32) -> Option<u64> {
    let (side, bytes) = format_block(format).or_else(|| Some((1, format_texel_bytes(format)?)))?;
    Some(u64::from(width.div_ceil(side)) * u64::from(height.div_ceil(side)) * u64::from(bytes))
}

/// Bytes per texel of an uncompressed `format` shvis uploads.
pub fn format_texel_bytes(format: vk::Format) -> Option<u32> {
    Some(match format {
        vk::Format::R8_UNORM => 1,
        vk::Format::R16_SFLOAT => 2,
        vk::Format::R32_SFLOAT => 4,
        vk::Format::R8G8B8A8_UNORM | vk::Format::R8G8B8A8_SRGB => 4,
        vk::Format::R16G16B16A16_SFLOAT => 8,
        vk::Format::R32G32B32A32_SFLOAT => 16,
        _ => return None,
    })
}
