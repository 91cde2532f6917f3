//! A window's surface and swapchain for `shvis view`: the frame the viewer has
//! composed on the host (sRGB 8-bit, with its overlay) is copied into the acquired
//! swapchain image and presented. One frame in flight: the image is acquired with a fence,
//! the copy is submitted and waited for (`Context::one_shot`), then presented with no
//! semaphore to wait on — simple, and on lavapipe the copy is not what limits the rate.
//!
//! The surface comes from `ash-window` (X11 under Xvfb with lavapipe, or whatever the
//! platform has); format B8G8R8A8_UNORM or R8G8B8A8_UNORM (the bytes are already
//! sRGB-encoded), present mode IMMEDIATE, else MAILBOX, else FIFO. With `TRANSFER_SRC`
//! usage the presented image can be read back ([`Presenter::present`]'s screenshot).

use std::ffi::CStr;
use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;
use raw_window_handle::{RawDisplayHandle, RawWindowHandle};

use super::{Buffer, Context, GpuError};

/// Instance extensions a surface on `display` needs.
///
/// # Errors
/// [`GpuError::MissingFeature`] when the platform has no Vulkan surface support.
pub fn surface_extensions(display: RawDisplayHandle) -> Result<Vec<&'static CStr>, GpuError> {
    let names = ash_window::enumerate_required_extensions(display).map_err(|e| {
        GpuError::MissingFeature {
            device: "this display".into(),
            feature: format!("a Vulkan surface ({e})"),
        }
    })?;
    // SAFETY: ash-window returns pointers to the static extension-name constants of ash.
    Ok(names
        .iter()
        .map(|&p| unsafe { CStr::from_ptr(p) })
        .collect())
}

/// The surface, its swapchain and the buffers a present goes through.
pub struct Presenter {
    ctx: Arc<Context>,
    surface_fn: ash::khr::surface::Instance,
    swapchain_fn: ash::khr::swapchain::Device,
    surface: vk::SurfaceKHR,
    swapchain: vk::SwapchainKHR,
    images: Vec<vk::Image>,
    format: vk::Format,
    extent: vk::Extent2D,
    acquired: vk::Fence,
    staging: Buffer,
    readback: Option<Buffer>,
    present_mode: vk::PresentModeKHR,
}

impl Presenter {
    /// A surface on the window and a `width × height` swapchain for it.
    ///
    /// # Errors
    /// No surface, a queue that cannot present to it, no usable format, or a failing call.
    pub fn new(
        ctx: &Arc<Context>,
        display: RawDisplayHandle,
        window: RawWindowHandle,
        width: u32,
        height: u32,
    ) -> Result<Self, GpuError> {
        let what = "window";
        // SAFETY: the handles come from a live window that outlives the presenter (the
        // viewer drops the presenter before the window).
        let surface = unsafe {
            ash_window::create_surface(ctx.entry(), ctx.instance(), display, window, None)
        }
        .map_err(|e| GpuError::vulkan("vkCreate*SurfaceKHR", what, e))?;
        let surface_fn = ash::khr::surface::Instance::new(ctx.entry(), ctx.instance());
        let pd = ctx.physical_device();
        // SAFETY: plain queries on a live surface and physical device.
        let (supported, caps, formats, modes) = unsafe {
            (
                surface_fn
                    .get_physical_device_surface_support(pd, ctx.queue_family(), surface)
                    .unwrap_or(false),
                surface_fn.get_physical_device_surface_capabilities(pd, surface),
                surface_fn.get_physical_device_surface_formats(pd, surface),
                surface_fn.get_physical_device_surface_present_modes(pd, surface),
            )
        };
        let cleanup = |e: GpuError| {
            // SAFETY: nothing else uses the surface yet.
            unsafe { surface_fn.destroy_surface(surface, None) };
            e
        };
        if !supported {
            return Err(cleanup(GpuError::MissingFeature {
                device: ctx.device_name().to_string(),
                feature: "presentation from its graphics queue to this window".into(),
            }));
        }
        let caps = caps.map_err(|e| cleanup(GpuError::vulkan("surface capabilities", what, e)))?;
        let formats = formats.map_err(|e| cleanup(GpuError::vulkan("surface formats", what, e)))?;
        let modes = modes.map_err(|e| cleanup(GpuError::vulkan("present modes", what, e)))?;
        let Some(format) = [vk::Format::B8G8R8A8_UNORM, vk::Format::R8G8B8A8_UNORM]
            .into_iter()
            .find(|f| formats.iter().any(|s| s.format == *f))
        else {
            return Err(cleanup(GpuError::MissingFeature {
                device: ctx.device_name().to_string(),
                feature: "an 8-bit UNORM BGRA or RGBA surface format".into(),
            }));
        };
        let color_space = formats
            .iter()
            .find(|s| s.format == format)
            .map_or(vk::ColorSpaceKHR::SRGB_NONLINEAR, |s| s.color_space);
        let present_mode = [
            vk::PresentModeKHR::IMMEDIATE,
            vk::PresentModeKHR::MAILBOX,
            vk::PresentModeKHR::FIFO,
        ]
        .into_iter()
        .find(|m| modes.contains(m))
        .unwrap_or(vk::PresentModeKHR::FIFO);
        let extent = if caps.current_extent.width == u32::MAX {
            vk::Extent2D { width, height }
        } else {
            caps.current_extent
        };
        let mut usage = vk::ImageUsageFlags::TRANSFER_DST;
        let readable = caps
            .supported_usage_flags
            .contains(vk::ImageUsageFlags::TRANSFER_SRC);
        if readable {
            usage |= vk::ImageUsageFlags::TRANSFER_SRC;
        }
        let image_count = (caps.min_image_count + 1).min(if caps.max_image_count == 0 {
            u32::MAX
        } else {
            caps.max_image_count
        });
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(surface)
            .min_image_count(image_count)
            .image_format(format)
            .image_color_space(color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(usage)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(vk::CompositeAlphaFlagsKHR::OPAQUE)
            .present_mode(present_mode)
            .clipped(true);
        let swapchain_fn = ash::khr::swapchain::Device::new(ctx.instance(), ctx.device());
        // SAFETY: the create-info borrows locals alive for the call.
        let swapchain = unsafe { swapchain_fn.create_swapchain(&info, None) }
            .map_err(|e| cleanup(GpuError::vulkan("vkCreateSwapchainKHR", what, e)))?;
        // SAFETY: a live swapchain.
        let images = unsafe { swapchain_fn.get_swapchain_images(swapchain) }
            .map_err(|e| GpuError::vulkan("vkGetSwapchainImagesKHR", what, e))?;
        for (i, image) in images.iter().enumerate() {
            ctx.set_name(*image, &format!("view.swapchain[{i}]"));
        }
        ctx.set_name(swapchain, "view.swapchain");
        let (acquired, staging, readback) = create_frame_objects(ctx, extent, readable, what)?;
        log::info!(
            "swapchain: {}×{} {:?}, {} images, {:?}",
            extent.width,
            extent.height,
            format,
            images.len(),
            present_mode
        );
        Ok(Presenter {
            ctx: ctx.clone(),
            surface_fn,
            swapchain_fn,
            surface,
            swapchain,
            images,
            format,
            extent,
            acquired,
            staging,
            readback,
            present_mode,
        })
    }

    /// The swapchain's size.
    pub fn extent(&self) -> (u32, u32) {
        (self.extent.width, self.extent.height)
    }

    /// The present mode chosen.
    pub fn present_mode(&self) -> vk::PresentModeKHR {
        self.present_mode
    }

    /// Copies `rgb8` (row-major RGB, the swapchain's size, sRGB-encoded) into the next image
    /// and presents it. With `screenshot`, also reads the image back before presenting and
    /// returns it as RGB8.
    ///
    /// # Errors
    /// A size mismatch, an out-of-date swapchain, a failing call, or a screenshot on a
    /// surface whose images cannot be read.
    pub fn present(&mut self, rgb8: &[u8], screenshot: bool) -> Result<Option<Vec<u8>>, GpuError> {
        let (w, h) = (self.extent.width as usize, self.extent.height as usize);
        if rgb8.len() != w * h * 3 {
            return Err(GpuError::Invalid {
                what: "view frame".into(),
                detail: format!("{} bytes for a {w}×{h} swapchain", rgb8.len()),
            });
        }
        let bgra = self.format == vk::Format::B8G8R8A8_UNORM;
        let texels: Vec<u8> = rgb8
            .chunks_exact(3)
            .flat_map(|p| {
                if bgra {
                    [p[2], p[1], p[0], 255]
                } else {
                    [p[0], p[1], p[2], 255]
                }
            })
            .collect();
        self.staging.write(&texels)?;
        let device = self.ctx.device();
        // SAFETY: a live swapchain and an unsignalled fence, waited for and reset below.
        let (index, _suboptimal) = unsafe {
            self.swapchain_fn.acquire_next_image(
                self.swapchain,
                u64::MAX,
                vk::Semaphore::null(),
                self.acquired,
            )
        }
        .map_err(|e| GpuError::vulkan("vkAcquireNextImageKHR", "view.swapchain", e))?;
        // SAFETY: the fence belongs to this device.
        unsafe {
            device
                .wait_for_fences(&[self.acquired], true, u64::MAX)
                .and_then(|()| device.reset_fences(&[self.acquired]))
        }
        .map_err(|e| GpuError::vulkan("vkWaitForFences", "view.acquired", e))?;
        let image = self.images[index as usize];
        let read = match (&self.readback, screenshot) {
            (Some(b), true) => Some(b.raw()),
            (None, true) => {
                return Err(GpuError::MissingFeature {
                    device: self.ctx.device_name().to_string(),
                    feature: "readable swapchain images (TRANSFER_SRC) for --screenshot".into(),
                });
            }
            _ => None,
        };
        let staging = self.staging.raw();
        let extent = self.extent;
        self.ctx.one_shot("view.present", |cmd| {
            record_present_copy(device, cmd, image, staging, read, extent);
        })?;
        let shot = match (&self.readback, screenshot) {
            (Some(b), true) => Some(
                b.read()?
                    .chunks_exact(4)
                    .flat_map(|p| {
                        if bgra {
                            [p[2], p[1], p[0]]
                        } else {
                            [p[0], p[1], p[2]]
                        }
                    })
                    .collect(),
            ),
            _ => None,
        };
        let swapchains = [self.swapchain];
        let indices = [index];
        let info = vk::PresentInfoKHR::default()
            .swapchains(&swapchains)
            .image_indices(&indices);
        // SAFETY: the copy into the image has completed (one_shot waited), so presenting
        // without a wait semaphore is ordered after it.
        unsafe { self.swapchain_fn.queue_present(self.ctx.queue(), &info) }
            .map_err(|e| GpuError::vulkan("vkQueuePresentKHR", "view.swapchain", e))?;
        Ok(shot)
    }
}

/// The acquire fence, the staging buffer for a frame of `extent` and, where the images
/// are `readable`, the screenshot's readback buffer.
fn create_frame_objects(
    ctx: &Arc<Context>,
    extent: vk::Extent2D,
    readable: bool,
    what: &str,
) -> Result<(vk::Fence, Buffer, Option<Buffer>), GpuError> {
    // SAFETY: a plain object creation on the live device.
    let acquired = unsafe {
        ctx.device()
            .create_fence(&vk::FenceCreateInfo::default(), None)
    }
    .map_err(|e| GpuError::vulkan("vkCreateFence", what, e))?;
    ctx.set_name(acquired, "view.acquired");
    let bytes = u64::from(extent.width) * u64::from(extent.height) * 4;
    let staging = Buffer::new(
        ctx,
        bytes,
        vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::CpuToGpu,
        "view.staging",
    )?;
    let readback = if readable {
        Some(Buffer::new(
            ctx,
            bytes,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
            "view.readback",
        )?)
    } else {
        None
    };
    Ok((acquired, staging, readback))
}

/// Records a present's commands into `cmd`: the acquired `image` to transfer layout, the
/// frame copied in from `staging`, with `read` the image copied out to that readback
/// buffer, then the image to present layout.
fn record_present_copy(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    image: vk::Image,
    staging: vk::Buffer,
    read: Option<vk::Buffer>,
    extent: vk::Extent2D,
) {
    let range = vk::ImageSubresourceRange::default()
        .aspect_mask(vk::ImageAspectFlags::COLOR)
        .level_count(1)
        .layer_count(1);
    // One layout transition of the image, recorded at once.
    let transition =
        |from,
         to,
         access: (vk::AccessFlags, vk::AccessFlags),
         stages: (vk::PipelineStageFlags, vk::PipelineStageFlags)| {
            let barrier = vk::ImageMemoryBarrier::default()
                .old_layout(from)
                .new_layout(to)
                .src_access_mask(access.0)
                .dst_access_mask(access.1)
                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .image(image)
                .subresource_range(range);
            // SAFETY: recording into one_shot's command buffer; `Presenter::present`
            // acquired the image and waited for its acquire fence before recording.
            unsafe {
                device.cmd_pipeline_barrier(
                    cmd,
                    stages.0,
                    stages.1,
                    vk::DependencyFlags::empty(),
                    &[],
                    &[],
                    &[barrier],
                );
            }
        };
    let region = vk::BufferImageCopy::default()
        .image_subresource(
            vk::ImageSubresourceLayers::default()
                .aspect_mask(vk::ImageAspectFlags::COLOR)
                .layer_count(1),
        )
        .image_extent(vk::Extent3D {
            width: extent.width,
            height: extent.height,
            depth: 1,
        });
    transition(
        vk::ImageLayout::UNDEFINED,
        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        (vk::AccessFlags::empty(), vk::AccessFlags::TRANSFER_WRITE),
        (
            vk::PipelineStageFlags::TOP_OF_PIPE,
            vk::PipelineStageFlags::TRANSFER,
        ),
    );
    // SAFETY: as above; the staging buffer holds the frame.
    unsafe {
        device.cmd_copy_buffer_to_image(
            cmd,
            staging,
            image,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            &[region],
        );
    }
    let mut layout = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
    if let Some(buffer) = read {
        transition(
            layout,
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            (
                vk::AccessFlags::TRANSFER_WRITE,
                vk::AccessFlags::TRANSFER_READ,
            ),
            (
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::TRANSFER,
            ),
        );
        layout = vk::ImageLayout::TRANSFER_SRC_OPTIMAL;
        // SAFETY: as above; the readback buffer is as large as the image.
        unsafe { device.cmd_copy_image_to_buffer(cmd, image, layout, buffer, &[region]) };
        super::buffer::record_transfer_to_host(device, cmd, buffer);
    }
    transition(
        layout,
        vk::ImageLayout::PRESENT_SRC_KHR,
        (
            vk::AccessFlags::TRANSFER_WRITE | vk::AccessFlags::TRANSFER_READ,
            vk::AccessFlags::empty(),
        ),
        (
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::BOTTOM_OF_PIPE,
        ),
    );
}

impl Drop for Presenter {
    fn drop(&mut self) {
        let device = self.ctx.device();
        // SAFETY: after the device is idle nothing uses the swapchain, fence or surface.
        unsafe {
            let _ = device.device_wait_idle();
            device.destroy_fence(self.acquired, None);
            self.swapchain_fn.destroy_swapchain(self.swapchain, None);
            self.surface_fn.destroy_surface(self.surface, None);
        }
    }
}
