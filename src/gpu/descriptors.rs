//! One descriptor set (set 0) with its layout and pool, built from a list of resources;
//! shared by the mesh pass and compute pipelines.

use std::sync::Arc;

use ash::vk;

use super::{Buffer, Context, GpuError, Image, Sampler};

/// What is bound at a binding.
pub enum Resource<'a> {
    Uniform(&'a Buffer),
    Storage(&'a Buffer),
    Texture(&'a Image, &'a Sampler),
    /// An array of textures at one binding (`uniform sampler2D t[N]`).
    TextureArray(Vec<(&'a Image, &'a Sampler)>),
}

impl Resource<'_> {
    fn descriptor_type(&self) -> vk::DescriptorType {
        match self {
            Resource::Uniform(_) => vk::DescriptorType::UNIFORM_BUFFER,
            Resource::Storage(_) => vk::DescriptorType::STORAGE_BUFFER,
            Resource::Texture(..) | Resource::TextureArray(_) => {
                vk::DescriptorType::COMBINED_IMAGE_SAMPLER
            }
        }
    }

    fn count(&self) -> u32 {
        match self {
            Resource::TextureArray(t) => t.len() as u32,
            _ => 1,
        }
    }
}

/// A descriptor set layout, a pool and the one set allocated from it, written once.
pub(crate) struct DescriptorSet {
    ctx: Arc<Context>,
    pub(crate) layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    pub(crate) set: vk::DescriptorSet,
}

impl DescriptorSet {
    pub(crate) fn new(
        ctx: &Arc<Context>,
        resources: &[(u32, Resource<'_>)],
        stages: vk::ShaderStageFlags,
        name: &str,
    ) -> Result<Self, GpuError> {
        let device = ctx.device();
        let mut ds = DescriptorSet {
            ctx: ctx.clone(),
            layout: vk::DescriptorSetLayout::null(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
        };
        let bindings: Vec<_> = resources
            .iter()
            .map(|(binding, r)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(*binding)
                    .descriptor_type(r.descriptor_type())
                    .descriptor_count(r.count())
                    .stage_flags(stages)
            })
            .collect();
        let layout_info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY (this and the calls below): create-infos borrow locals alive for each
        // call; handles are stored in `ds` at once, so Drop destroys them on any error.
        ds.layout = unsafe { device.create_descriptor_set_layout(&layout_info, None) }
            .map_err(|e| GpuError::vulkan("vkCreateDescriptorSetLayout", name, e))?;
        ctx.set_name(ds.layout, name);

        let mut sizes: Vec<vk::DescriptorPoolSize> = Vec::new();
        for (_, r) in resources {
            let ty = r.descriptor_type();
            match sizes.iter_mut().find(|s| s.ty == ty) {
                Some(s) => s.descriptor_count += r.count(),
                None => sizes.push(vk::DescriptorPoolSize {
                    ty,
                    descriptor_count: r.count(),
                }),
            }
        }
        if sizes.is_empty() {
            return Ok(ds); // nothing to bind: an empty layout is still valid
        }
        let pool_info = vk::DescriptorPoolCreateInfo::default()
            .max_sets(1)
            .pool_sizes(&sizes);
        // SAFETY: see above.
        ds.pool = unsafe { device.create_descriptor_pool(&pool_info, None) }
            .map_err(|e| GpuError::vulkan("vkCreateDescriptorPool", name, e))?;
        ctx.set_name(ds.pool, name);
        let layouts = [ds.layout];
        let alloc_info = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(ds.pool)
            .set_layouts(&layouts);
        // SAFETY: see above.
        ds.set = unsafe { device.allocate_descriptor_sets(&alloc_info) }
            .map_err(|e| GpuError::vulkan("vkAllocateDescriptorSets", name, e))?[0];
        ctx.set_name(ds.set, name);

        let buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = resources
            .iter()
            .map(|(_, r)| match r {
                Resource::Uniform(b) | Resource::Storage(b) => [vk::DescriptorBufferInfo {
                    buffer: b.raw(),
                    offset: 0,
                    range: vk::WHOLE_SIZE,
                }],
                _ => [vk::DescriptorBufferInfo::default()],
            })
            .collect();
        let image_info = |img: &Image, sampler: &Sampler| vk::DescriptorImageInfo {
            sampler: sampler.raw(),
            image_view: img.view(),
            image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        };
        let image_infos: Vec<Vec<vk::DescriptorImageInfo>> = resources
            .iter()
            .map(|(_, r)| match r {
                Resource::Texture(img, sampler) => vec![image_info(img, sampler)],
                Resource::TextureArray(t) => t.iter().map(|(i, s)| image_info(i, s)).collect(),
                _ => vec![vk::DescriptorImageInfo::default()],
            })
            .collect();
        let writes: Vec<_> = resources
            .iter()
            .enumerate()
            .map(|(i, (binding, r))| {
                let w = vk::WriteDescriptorSet::default()
                    .dst_set(ds.set)
                    .dst_binding(*binding)
                    .descriptor_type(r.descriptor_type());
                match r {
                    Resource::Texture(..) | Resource::TextureArray(_) => {
                        w.image_info(&image_infos[i])
                    }
                    _ => w.buffer_info(&buffer_infos[i]),
                }
            })
            .collect();
        // SAFETY: the set, buffers, views and samplers are live; infos outlive the call.
        unsafe { device.update_descriptor_sets(&writes, &[]) };
        Ok(ds)
    }
}

impl Drop for DescriptorSet {
    fn drop(&mut self) {
        // SAFETY: submissions are waited for; null handles are valid to destroy; the set
        // is freed with its pool.
        unsafe {
            self.ctx.device().destroy_descriptor_pool(self.pool, None);
            self.ctx
                .device()
                .destroy_descriptor_set_layout(self.layout, None);
        }
    }
}
