//! The Vulkan layer (ash): instance and device selection, validation and debug names,
//! memory (gpu-allocator), buffers and images, shaders (shaderc), the mesh pipeline,
//! timestamp queries, the offscreen target and readback; what a compiled shader declares
//! (its blocks, [`reflect`]) and the Rust half of that contract (`layout`).
//!
//! It knows nothing of SH or techniques: `technique/` describes what to bind and which
//! shader to run, this layer turns that into Vulkan objects. Every object is owned by one
//! value holding `Arc<Context>` that destroys it in `Drop`, and carries a debug name
//! (VK_EXT_debug_utils) so a RenderDoc capture reads like the code.
//! The hardware paths ([`HwPath`]) are named here, below everything that binds by them.
//! `unsafe` is allowed here (`crate::UNSAFE_MODULES`); each block says why it is sound.

pub mod buffer;
pub mod compute;
pub mod context;
mod debug;
mod descriptors;
pub mod frame_timing;
pub mod image;
pub mod layout;
pub mod normal_bake;
pub mod pass;
mod pass_objects;
pub mod path;
pub mod reflect;
pub mod shader;
pub mod swapchain;
pub mod target;
pub mod timing;
pub mod upload;
pub mod visibility_sim;

pub use buffer::Buffer;
pub use compute::{ComputePipeline, ComputePipelineDesc};
pub use context::{Context, ContextDesc, DeviceSummary, MessageCounts};
pub use descriptors::Resource;
pub use image::{Image, ImageDesc, Sampler, SamplerKind};
pub use pass::{MeshBuffers, MeshPipeline, MeshPipelineDesc, VertexLayout};
pub use path::{HwPath, UnknownPath};
pub use shader::{ShaderStage, compile_glsl, compile_source, flattened_glsl};
pub use target::RenderTarget;
pub use timing::TimingStats;
pub use upload::PendingUpload;

use ash::vk;

/// Errors of the Vulkan layer; each message is one line naming what failed.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "cannot load the Vulkan loader (libvulkan.so.1): {0}; install it with 'apt-get install libvulkan1 mesa-vulkan-drivers'"
    )]
    Loader(String),
    #[error(
        "no Vulkan device found (the loader saw no driver: check VK_ICD_FILENAMES/VK_DRIVER_FILES, or install mesa-vulkan-drivers for lavapipe)"
    )]
    NoDevice,
    #[error("no Vulkan device name contains '{wanted}'; available: {available}")]
    NoMatchingDevice { wanted: String, available: String },
    #[error(
        "validation was requested but VK_LAYER_KHRONOS_validation is not installed ('apt-get install vulkan-validationlayers')"
    )]
    NoValidationLayer,
    #[error("{device}: lacks {feature}")]
    MissingFeature { device: String, feature: String },
    #[error("{call} failed for '{what}': {result}")]
    Vulkan {
        call: &'static str,
        what: String,
        result: vk::Result,
    },
    #[error("allocating memory for '{what}': {source}")]
    Alloc {
        what: String,
        source: gpu_allocator::AllocationError,
    },
    #[error("{0}")]
    Shader(String),
    #[error("'{what}': {detail}")]
    Invalid { what: String, detail: String },
}

impl GpuError {
    pub(crate) fn vulkan(call: &'static str, what: &str, result: vk::Result) -> Self {
        GpuError::Vulkan {
            call,
            what: what.to_string(),
            result,
        }
    }
}
