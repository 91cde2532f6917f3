//! The Vulkan context: loader, instance (validation and debug-utils when asked), physical
//! device choice, logical device with one graphics queue, the gpu-allocator, a command
//! pool for one-shot work, and debug naming.
//!
//! Device choice: `--device SUBSTRING` picks the first device whose name contains it
//! (case-insensitive); otherwise discrete > integrated > virtual > CPU (lavapipe when it is
//! alone). The chosen name is in [`Context::device_name`].

use std::ffi::{CStr, CString, c_char, c_void};
use std::mem::ManuallyDrop;
use std::sync::Mutex;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, Allocator, AllocatorCreateDesc};

pub use super::debug::MessageCounts;
use super::{GpuError, debug};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// How to create a [`Context`].
#[derive(Clone, Debug, Default)]
pub struct ContextDesc {
    /// Turn on VK_LAYER_KHRONOS_validation (an error when it is not installed).
    pub validate: bool,
    /// Pick the first device whose name contains this (case-insensitive).
    pub device: Option<String>,
    /// Instance extensions a window surface needs (`gpu::swapchain::surface_extensions`);
    /// when there are any, the device must also have VK_KHR_swapchain (`shvis view`).
    pub surface_extensions: Vec<&'static CStr>,
}

/// Everything Vulkan that lives as long as the program: see the module doc.
pub struct Context {
    // Field order is irrelevant: `Drop` tears down explicitly in reverse creation order.
    entry: ash::Entry,
    instance: ash::Instance,
    debug_instance: Option<ash::ext::debug_utils::Instance>,
    messenger: vk::DebugUtilsMessengerEXT,
    debug_device: Option<ash::ext::debug_utils::Device>,
    physical: vk::PhysicalDevice,
    device: ash::Device,
    queue: vk::Queue,
    queue_family: u32,
    allocator: ManuallyDrop<Mutex<Allocator>>,
    command_pool: Mutex<vk::CommandPool>,
    device_name: String,
    limits: vk::PhysicalDeviceLimits,
    timestamp_valid_bits: u32,
    image_cube_array: bool,
    texture_compression_bc: bool,
    multi_draw_indirect: bool,
    fragment_subgroup_ops: vk::SubgroupFeatureFlags,
    messages: std::sync::Arc<MessageCounts>,
}

impl Context {
    /// Loads Vulkan, creates the instance and picks and opens a device.
    ///
    /// # Errors
    /// No loader, no device, no device matching `desc.device`, a missing validation layer,
    /// or a failing Vulkan call.
    pub fn new(desc: &ContextDesc) -> Result<std::sync::Arc<Self>, GpuError> {
        // SAFETY: loading the system loader runs its initialisers; we hold the entry for the
        // context's lifetime.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::Loader(e.to_string()))?;
        let names = InstanceNames::new(&entry, desc)?;
        let messages = std::sync::Arc::<MessageCounts>::default();
        let mut messenger_info = messenger_create_info(&messages);
        let instance = create_instance(&entry, &names, &mut messenger_info)?;
        let (debug_instance, messenger) =
            create_messenger(&entry, &instance, names.has_debug_utils, &messenger_info)?;

        // From here on a failure must destroy what exists: build a partial context whose
        // Drop tolerates null handles.
        let picked = pick_device(&instance, desc.device.as_deref());
        let (physical, queue_family, device_name) = match picked {
            Ok(p) => p,
            Err(e) => {
                destroy_instance(&instance, (debug_instance.as_ref(), messenger));
                return Err(e);
            }
        };
        let info = PhysicalInfo::query(&instance, physical);
        let multi_draw_indirect = info.multi_draw_indirect();
        let debug = (debug_instance.as_ref(), messenger);
        let device = open_device(
            &instance,
            physical,
            queue_family,
            &device_name,
            &info,
            desc,
            debug,
        )?;
        // SAFETY: the family/index pair was requested in `device_info` (`open_device`).
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let debug_device = names
            .has_debug_utils
            .then(|| ash::ext::debug_utils::Device::new(&instance, &device));
        let (allocator, pool) =
            create_allocator_and_pool(&instance, &device, physical, queue_family, debug)?;
        let ctx = Context {
            entry,
            instance,
            debug_instance,
            messenger,
            debug_device,
            physical,
            device,
            queue,
            queue_family,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            command_pool: Mutex::new(pool),
            device_name: device_name.clone(),
            limits: info.props.limits,
            timestamp_valid_bits: info.families[queue_family as usize].timestamp_valid_bits,
            image_cube_array: info.features.image_cube_array != 0,
            texture_compression_bc: info.features.texture_compression_bc != 0,
            multi_draw_indirect,
            fragment_subgroup_ops: info.fragment_subgroup_ops,
            messages,
        };
        ctx.set_name(pool, "shvis.command_pool");
        ctx.set_name(ctx.queue, "shvis.queue");
        Ok(std::sync::Arc::new(ctx))
    }

    pub fn device(&self) -> &ash::Device {
        &self.device
    }
    /// The loaded Vulkan entry points (surface creation needs them).
    pub fn entry(&self) -> &ash::Entry {
        &self.entry
    }

    pub fn instance(&self) -> &ash::Instance {
        &self.instance
    }
    pub fn physical_device(&self) -> vk::PhysicalDevice {
        self.physical
    }
    pub fn queue(&self) -> vk::Queue {
        self.queue
    }
    pub fn queue_family(&self) -> u32 {
        self.queue_family
    }
    /// The device's name as the driver reports it, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
    pub fn device_name(&self) -> &str {
        &self.device_name
    }

    /// Every Vulkan device of this instance (`shvis devices`), the one in use marked.
    pub fn devices(&self) -> Vec<DeviceSummary> {
        // SAFETY: a plain query on the live instance.
        let physicals = unsafe { self.instance.enumerate_physical_devices() }.unwrap_or_default();
        physicals
            .into_iter()
            .map(|pd| DeviceSummary::query(&self.instance, pd, pd == self.physical))
            .collect()
    }

    /// The device in use, as [`Self::devices`] lists it.
    pub fn device_summary(&self) -> DeviceSummary {
        DeviceSummary::query(&self.instance, self.physical, true)
    }
    pub fn limits(&self) -> &vk::PhysicalDeviceLimits {
        &self.limits
    }
    /// Whether the graphics queue writes timestamps (and so `shvis bench` can time frames).
    pub fn supports_timestamps(&self) -> bool {
        self.timestamp_valid_bits > 0
    }
    pub fn timestamp_valid_bits(&self) -> u32 {
        self.timestamp_valid_bits
    }
    /// Whether `multiDrawIndirect` and `drawIndirectFirstInstance` are enabled.
    pub fn supports_multi_draw_indirect(&self) -> bool {
        self.multi_draw_indirect
    }

    /// Whether fragment shaders may use subgroup votes (`subgroupAny`; the cost model's
    /// divergence measure, `cost::CountPlan`).
    pub fn supports_fragment_subgroup_vote(&self) -> bool {
        self.fragment_subgroup_ops
            .contains(vk::SubgroupFeatureFlags::VOTE)
    }

    /// Whether fragment shaders may use subgroup ballots (`subgroupBallot`; the lanes a
    /// draw occupies, `render::SceneGpu::shading_load`).
    pub fn supports_fragment_subgroup_ballot(&self) -> bool {
        self.fragment_subgroup_ops
            .contains(vk::SubgroupFeatureFlags::BALLOT)
    }

    pub fn supports_cube_arrays(&self) -> bool {
        self.image_cube_array
    }

    /// Whether the device samples block-compressed `format` with linear filtering: the
    /// `textureCompressionBC` feature (enabled where present) and the format's own
    /// properties.
    pub fn supports_block_format(&self, format: vk::Format) -> bool {
        self.texture_compression_bc && self.supports_linear_filter(format)
    }

    /// Whether optimal-tiling images of `format` can be sampled with linear filtering.
    pub fn supports_linear_filter(&self, format: vk::Format) -> bool {
        // SAFETY: a plain query on the physical device of this instance.
        let props = unsafe {
            self.instance
                .get_physical_device_format_properties(self.physical, format)
        };
        props
            .optimal_tiling_features
            .contains(vk::FormatFeatureFlags::SAMPLED_IMAGE_FILTER_LINEAR)
    }
    /// Validation/debug messages counted so far: tests assert (0, 0).
    pub fn message_counts(&self) -> (u32, u32) {
        self.messages.get()
    }

    /// The live counter itself, to check messages of teardown after the context is gone.
    pub fn message_counter(&self) -> std::sync::Arc<MessageCounts> {
        self.messages.clone()
    }

    /// Gives `handle` a debug name visible in validation messages and captures.
    pub fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        let Some(dd) = &self.debug_device else { return };
        let Ok(cname) = CString::new(name) else {
            return;
        };
        let info = vk::DebugUtilsObjectNameInfoEXT::default()
            .object_handle(handle)
            .object_name(&cname);
        // SAFETY: `handle` is a live object of this device; the name outlives the call.
        if let Err(e) = unsafe { dd.set_debug_utils_object_name(&info) } {
            log::debug!("naming '{name}' failed: {e}");
        }
    }

    /// Opens a debug label region on `cmd` (no-op without debug utils).
    pub(crate) fn begin_label(&self, cmd: vk::CommandBuffer, name: &str) {
        let Some(dd) = &self.debug_device else { return };
        let Ok(cname) = CString::new(name) else {
            return;
        };
        let label = vk::DebugUtilsLabelEXT::default().label_name(&cname);
        // SAFETY: `cmd` is in the recording state (callers' contract).
        unsafe { dd.cmd_begin_debug_utils_label(cmd, &label) };
    }

    pub(crate) fn end_label(&self, cmd: vk::CommandBuffer) {
        if let Some(dd) = &self.debug_device {
            // SAFETY: paired with `begin_label` on the same recording command buffer.
            unsafe { dd.cmd_end_debug_utils_label(cmd) };
        }
    }

    pub(crate) fn allocate(
        &self,
        name: &str,
        requirements: vk::MemoryRequirements,
        location: gpu_allocator::MemoryLocation,
        linear: bool,
    ) -> Result<Allocation, GpuError> {
        let mut alloc = self.allocator.lock().unwrap_or_else(|p| p.into_inner());
        alloc
            .allocate(&AllocationCreateDesc {
                name,
                requirements,
                location,
                linear,
                allocation_scheme: gpu_allocator::vulkan::AllocationScheme::GpuAllocatorManaged,
            })
            .map_err(|source| GpuError::Alloc {
                what: name.to_string(),
                source,
            })
    }

    /// Returns memory to the allocator; logs (never panics) on failure, as it runs in Drop.
    pub(crate) fn free(&self, allocation: Allocation) {
        let mut alloc = self.allocator.lock().unwrap_or_else(|p| p.into_inner());
        if let Err(e) = alloc.free(allocation) {
            log::error!("freeing GPU memory: {e}");
        }
    }

    /// Records `record` into a fresh command buffer labelled `name`, submits it and waits.
    pub(crate) fn one_shot(
        &self,
        name: &str,
        record: impl FnOnce(vk::CommandBuffer),
    ) -> Result<(), GpuError> {
        let cmd = self.allocate_command_buffer(name)?;
        let result = (|| {
            let begin = vk::CommandBufferBeginInfo::default()
                .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            // SAFETY: `cmd` was just allocated and is in the initial state.
            unsafe { self.device.begin_command_buffer(cmd, &begin) }
                .map_err(|e| GpuError::vulkan("vkBeginCommandBuffer", name, e))?;
            self.begin_label(cmd, name);
            record(cmd);
            self.end_label(cmd);
            // SAFETY: recording began above.
            unsafe { self.device.end_command_buffer(cmd) }
                .map_err(|e| GpuError::vulkan("vkEndCommandBuffer", name, e))?;
            self.submit_and_wait(cmd, name)
        })();
        self.free_command_buffer(cmd);
        result
    }

    pub(crate) fn allocate_command_buffer(
        &self,
        name: &str,
    ) -> Result<vk::CommandBuffer, GpuError> {
        let pool = self.command_pool.lock().unwrap_or_else(|p| p.into_inner());
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(*pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: the pool belongs to this device and is externally synchronised by the lock.
        let cmd = unsafe { self.device.allocate_command_buffers(&info) }
            .map_err(|e| GpuError::vulkan("vkAllocateCommandBuffers", name, e))?[0];
        self.set_name(cmd, name);
        Ok(cmd)
    }

    pub(crate) fn free_command_buffer(&self, cmd: vk::CommandBuffer) {
        let pool = self.command_pool.lock().unwrap_or_else(|p| p.into_inner());
        // SAFETY: callers only free after the buffer's submission completed (submit_and_wait).
        unsafe { self.device.free_command_buffers(*pool, &[cmd]) };
    }

    /// Submits one recorded command buffer with a fresh fence, which the caller waits on
    /// and destroys.
    pub(crate) fn submit(&self, cmd: vk::CommandBuffer, name: &str) -> Result<vk::Fence, GpuError> {
        // SAFETY: the fence is fresh; the queue is only used from the thread holding the
        // context (no concurrent submits).
        unsafe {
            let fence = self
                .device
                .create_fence(&vk::FenceCreateInfo::default(), None)
                .map_err(|e| GpuError::vulkan("vkCreateFence", name, e))?;
            self.set_name(fence, &format!("{name}.fence"));
            let cmds = [cmd];
            let submit = vk::SubmitInfo::default().command_buffers(&cmds);
            match self.device.queue_submit(self.queue, &[submit], fence) {
                Ok(()) => Ok(fence),
                Err(e) => {
                    self.device.destroy_fence(fence, None);
                    Err(GpuError::vulkan("vkQueueSubmit", name, e))
                }
            }
        }
    }

    /// Submits one recorded command buffer and blocks until the GPU has finished it.
    pub(crate) fn submit_and_wait(
        &self,
        cmd: vk::CommandBuffer,
        name: &str,
    ) -> Result<(), GpuError> {
        let fence = self.submit(cmd, name)?;
        // SAFETY: the fence was created by `submit`, is waited on and destroyed here.
        unsafe {
            let result = self
                .device
                .wait_for_fences(&[fence], true, u64::MAX)
                .map_err(|e| GpuError::vulkan("vkWaitForFences", name, e));
            self.device.destroy_fence(fence, None);
            result
        }
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        // SAFETY: all resources holding an Arc<Context> are gone (we are the last owner);
        // wait for the device, then destroy in reverse creation order.
        unsafe {
            let _ = self.device.device_wait_idle();
            let pool = *self
                .command_pool
                .get_mut()
                .unwrap_or_else(|p| p.into_inner());
            self.device.destroy_command_pool(pool, None);
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
            if let Some(di) = &self.debug_instance {
                di.destroy_debug_utils_messenger(self.messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// The layers and extensions the instance is created with; checks that the validation
/// layer (when asked for) and `desc.surface_extensions` are there.
struct InstanceNames {
    layers: Vec<*const c_char>,
    extensions: Vec<*const c_char>,
    /// VK_EXT_debug_utils is on (it is there, or validation is asked for).
    has_debug_utils: bool,
}

impl InstanceNames {
    fn new(entry: &ash::Entry, desc: &ContextDesc) -> Result<Self, GpuError> {
        // SAFETY: plain queries on a loaded entry.
        let layers = unsafe { entry.enumerate_instance_layer_properties() }
            .map_err(|e| GpuError::vulkan("vkEnumerateInstanceLayerProperties", "loader", e))?;
        let has_layer = |name: &CStr| {
            layers
                .iter()
                .any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == name))
        };
        if desc.validate && !has_layer(VALIDATION_LAYER) {
            return Err(GpuError::NoValidationLayer);
        }
        // SAFETY: as above.
        let extensions = unsafe { entry.enumerate_instance_extension_properties(None) }
            .map_err(|e| GpuError::vulkan("vkEnumerateInstanceExtensionProperties", "loader", e))?;
        let has_debug_utils = extensions.iter().any(|e| {
            e.extension_name_as_c_str()
                .is_ok_and(|n| n == ash::ext::debug_utils::NAME)
        }) || desc.validate;

        let layer_names: Vec<*const c_char> = if desc.validate {
            vec![VALIDATION_LAYER.as_ptr()]
        } else {
            vec![]
        };
        let mut ext_names: Vec<*const c_char> = if has_debug_utils {
            vec![ash::ext::debug_utils::NAME.as_ptr()]
        } else {
            vec![]
        };
        for wanted in &desc.surface_extensions {
            let present = extensions
                .iter()
                .any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == *wanted));
            if !present {
                return Err(GpuError::MissingFeature {
                    device: "the Vulkan loader".into(),
                    feature: format!("{} (needed to open a window)", wanted.to_string_lossy()),
                });
            }
            ext_names.push(wanted.as_ptr());
        }
        Ok(InstanceNames {
            layers: layer_names,
            extensions: ext_names,
            has_debug_utils,
        })
    }
}

/// The debug messenger's create-info: errors, warnings and infos of every type, counted
/// into `messages` by `debug::messenger_callback`.
fn messenger_create_info(
    messages: &std::sync::Arc<MessageCounts>,
) -> vk::DebugUtilsMessengerCreateInfoEXT<'static> {
    vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(
            vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                | vk::DebugUtilsMessageSeverityFlagsEXT::INFO,
        )
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(debug::messenger_callback))
        .user_data(std::sync::Arc::as_ptr(messages) as *mut c_void)
}

/// Creates the Vulkan 1.2 instance with `names`, chaining `messenger_info` where debug
/// utils are on.
fn create_instance(
    entry: &ash::Entry,
    names: &InstanceNames,
    messenger_info: &mut vk::DebugUtilsMessengerCreateInfoEXT<'_>,
) -> Result<ash::Instance, GpuError> {
    let app_name = c"shvis";
    let app_info = vk::ApplicationInfo::default()
        .application_name(app_name)
        .engine_name(app_name)
        .api_version(vk::API_VERSION_1_2);
    let mut instance_info = vk::InstanceCreateInfo::default()
        .application_info(&app_info)
        .enabled_layer_names(&names.layers)
        .enabled_extension_names(&names.extensions);
    if names.has_debug_utils {
        // Also catches messages from vkCreateInstance/vkDestroyInstance themselves.
        instance_info = instance_info.push_next(messenger_info);
    }
    // SAFETY: every pointer in the create-info borrows locals alive for the call.
    unsafe { entry.create_instance(&instance_info, None) }.map_err(|e| {
        if e == vk::Result::ERROR_INCOMPATIBLE_DRIVER {
            GpuError::NoDevice
        } else {
            GpuError::vulkan("vkCreateInstance", "shvis", e)
        }
    })
}

/// The debug-utils instance functions and the messenger, where debug utils are on (else
/// none and a null messenger); destroys `instance` on failure.
fn create_messenger(
    entry: &ash::Entry,
    instance: &ash::Instance,
    has_debug_utils: bool,
    messenger_info: &vk::DebugUtilsMessengerCreateInfoEXT<'_>,
) -> Result<
    (
        Option<ash::ext::debug_utils::Instance>,
        vk::DebugUtilsMessengerEXT,
    ),
    GpuError,
> {
    if !has_debug_utils {
        return Ok((None, vk::DebugUtilsMessengerEXT::null()));
    }
    let di = ash::ext::debug_utils::Instance::new(entry, instance);
    // SAFETY: the user-data box outlives the messenger (see Drop).
    let m = unsafe { di.create_debug_utils_messenger(messenger_info, None) };
    match m {
        Ok(m) => Ok((Some(di), m)),
        Err(e) => {
            // SAFETY: nothing was created from the instance yet.
            unsafe { instance.destroy_instance(None) };
            Err(GpuError::vulkan(
                "vkCreateDebugUtilsMessengerEXT",
                "shvis",
                e,
            ))
        }
    }
}

/// What `shvis devices` says of a Vulkan device: enough to name it in results and to judge
/// its timer (`gpu::frame_timing`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct DeviceSummary {
    pub name: String,
    /// "discrete GPU", "integrated GPU", "virtual GPU", "CPU" or "other".
    pub kind: &'static str,
    /// The driver's name and version string (VK_KHR_driver_properties, Vulkan 1.2).
    pub driver: String,
    /// Vulkan version the device supports, "major.minor.patch".
    pub api_version: String,
    /// ns per timestamp tick.
    pub timestamp_period_ns: f32,
    /// Valid bits of the graphics queue's timestamps (0: none).
    pub timestamp_valid_bits: u32,
    /// Lanes of a subgroup.
    pub subgroup_size: u32,
    /// Whether shvis picked it (the first discrete GPU, or the one `--device` names).
    pub in_use: bool,
}

impl DeviceSummary {
    fn query(instance: &ash::Instance, physical: vk::PhysicalDevice, in_use: bool) -> Self {
        let mut driver = vk::PhysicalDeviceDriverProperties::default();
        let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
        // SAFETY: `physical` came from this instance; Vulkan 1.2 core queries (the instance
        // asks for 1.2).
        let (props, families) = unsafe {
            let mut props2 = vk::PhysicalDeviceProperties2::default()
                .push_next(&mut driver)
                .push_next(&mut subgroup);
            instance.get_physical_device_properties2(physical, &mut props2);
            (
                props2.properties,
                instance.get_physical_device_queue_family_properties(physical),
            )
        };
        let text = |r: Result<&std::ffi::CStr, _>| {
            r.map(|c: &std::ffi::CStr| c.to_string_lossy().into_owned())
                .unwrap_or_default()
        };
        let v = props.api_version;
        DeviceSummary {
            name: text(props.device_name_as_c_str()),
            kind: match props.device_type {
                vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
                vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
                vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
                vk::PhysicalDeviceType::CPU => "CPU",
                _ => "other",
            },
            driver: format!(
                "{} {}",
                text(driver.driver_name_as_c_str()),
                text(driver.driver_info_as_c_str())
            )
            .trim()
            .to_string(),
            api_version: format!(
                "{}.{}.{}",
                vk::api_version_major(v),
                vk::api_version_minor(v),
                vk::api_version_patch(v)
            ),
            timestamp_period_ns: props.limits.timestamp_period,
            timestamp_valid_bits: families
                .iter()
                .find(|f| f.queue_flags.contains(vk::QueueFlags::GRAPHICS))
                .map_or(0, |f| f.timestamp_valid_bits),
            subgroup_size: subgroup.subgroup_size,
            in_use,
        }
    }
}

/// What the context keeps of the chosen physical device's properties.
struct PhysicalInfo {
    props: vk::PhysicalDeviceProperties,
    features: vk::PhysicalDeviceFeatures,
    families: Vec<vk::QueueFamilyProperties>,
    /// The subgroup operations fragment shaders may use (none where the fragment stage
    /// has no subgroups).
    fragment_subgroup_ops: vk::SubgroupFeatureFlags,
}

impl PhysicalInfo {
    fn query(instance: &ash::Instance, physical: vk::PhysicalDevice) -> Self {
        // SAFETY: `physical` came from this instance.
        let (props, features, families) = unsafe {
            (
                instance.get_physical_device_properties(physical),
                instance.get_physical_device_features(physical),
                instance.get_physical_device_queue_family_properties(physical),
            )
        };
        let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
        // SAFETY: as above; Vulkan 1.1 core, the instance asks for 1.2.
        unsafe {
            let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut subgroup);
            instance.get_physical_device_properties2(physical, &mut props2);
        }
        let fragment_subgroup_ops = if subgroup
            .supported_stages
            .contains(vk::ShaderStageFlags::FRAGMENT)
        {
            subgroup.supported_operations
        } else {
            vk::SubgroupFeatureFlags::empty()
        };
        PhysicalInfo {
            props,
            features,
            families,
            fragment_subgroup_ops,
        }
    }

    /// Whether `multiDrawIndirect` and `drawIndirectFirstInstance` are both there (the
    /// context enables them together).
    fn multi_draw_indirect(&self) -> bool {
        self.features.multi_draw_indirect != 0 && self.features.draw_indirect_first_instance != 0
    }
}

/// The instance-level debug objects a failure must destroy with the instance: the
/// debug-utils functions (where on) and the messenger.
type DebugObjects<'a> = (
    Option<&'a ash::ext::debug_utils::Instance>,
    vk::DebugUtilsMessengerEXT,
);

/// Creates the logical device of `physical` (its graphics queue family and name) with one
/// queue, the features the techniques use where the device has them, VK_KHR_maintenance4
/// where there, and VK_KHR_swapchain when the context presents; destroys the messenger
/// and the instance when it fails.
fn open_device(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
    queue_family: u32,
    device_name: &str,
    info: &PhysicalInfo,
    desc: &ContextDesc,
    (debug_instance, messenger): DebugObjects<'_>,
) -> Result<ash::Device, GpuError> {
    let priorities = [1.0f32];
    let queue_info = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(queue_family)
        .queue_priorities(&priorities)];
    let (features, multi_draw_indirect) = (&info.features, info.multi_draw_indirect());
    // Cube arrays (dx10 tables) and dynamically uniform indexing of sampler arrays (the
    // dx9 techniques' texture lists) where the device has them; techniques check.
    let enabled_features = vk::PhysicalDeviceFeatures::default()
        .image_cube_array(features.image_cube_array != 0)
        .shader_sampled_image_array_dynamic_indexing(
            features.shader_sampled_image_array_dynamic_indexing != 0,
        )
        // Normal-map generation draws one indirect command per low triangle.
        .multi_draw_indirect(multi_draw_indirect)
        .draw_indirect_first_instance(multi_draw_indirect)
        // BC formats: the dx11 path's per-texel data.
        .texture_compression_bc(features.texture_compression_bc != 0);
    // VK_KHR_maintenance4 relaxes vertex-output/fragment-input matching, so a pass may
    // read a subset of the shared mesh.vert outputs (the reference's G-buffer passes).
    // SAFETY: a plain query on this instance's physical device.
    let device_extensions =
        unsafe { instance.enumerate_device_extension_properties(physical) }.unwrap_or_default();
    let has_maintenance4 = device_extensions.iter().any(|e| {
        e.extension_name_as_c_str()
            .is_ok_and(|n| n == ash::khr::maintenance4::NAME)
    });
    let mut device_ext_names: Vec<*const c_char> = if has_maintenance4 {
        vec![ash::khr::maintenance4::NAME.as_ptr()]
    } else {
        vec![]
    };
    if !desc.surface_extensions.is_empty() {
        let has_swapchain = device_extensions.iter().any(|e| {
            e.extension_name_as_c_str()
                .is_ok_and(|n| n == ash::khr::swapchain::NAME)
        });
        if !has_swapchain {
            destroy_instance(instance, (debug_instance, messenger));
            return Err(GpuError::MissingFeature {
                device: device_name.to_string(),
                feature: "VK_KHR_swapchain (needed to present to a window)".into(),
            });
        }
        device_ext_names.push(ash::khr::swapchain::NAME.as_ptr());
    }
    let mut maintenance4 = vk::PhysicalDeviceMaintenance4Features::default().maintenance4(true);
    let mut device_info = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queue_info)
        .enabled_features(&enabled_features)
        .enabled_extension_names(&device_ext_names);
    if has_maintenance4 {
        device_info = device_info.push_next(&mut maintenance4);
    }
    // SAFETY: create-info borrows locals alive for the call.
    match unsafe { instance.create_device(physical, &device_info, None) } {
        Ok(d) => Ok(d),
        Err(e) => {
            destroy_instance(instance, (debug_instance, messenger));
            Err(GpuError::vulkan("vkCreateDevice", device_name, e))
        }
    }
}

/// Destroys the messenger and the instance of a context that failed to open.
fn destroy_instance(instance: &ash::Instance, (debug_instance, messenger): DebugObjects<'_>) {
    // SAFETY: the messenger and instance are the caller's, no device was created from the
    // instance (or it is destroyed already), and neither is used after this.
    unsafe {
        if let Some(di) = debug_instance {
            di.destroy_debug_utils_messenger(messenger, None);
        }
        instance.destroy_instance(None);
    }
}

/// The gpu-allocator and the command pool for one-shot work (on the graphics queue
/// family); destroys what exists, down to the instance, when either fails.
fn create_allocator_and_pool(
    instance: &ash::Instance,
    device: &ash::Device,
    physical: vk::PhysicalDevice,
    queue_family: u32,
    (debug_instance, messenger): DebugObjects<'_>,
) -> Result<(Allocator, vk::CommandPool), GpuError> {
    let allocator = Allocator::new(&AllocatorCreateDesc {
        instance: instance.clone(),
        device: device.clone(),
        physical_device: physical,
        debug_settings: Default::default(),
        buffer_device_address: false,
        allocation_sizes: Default::default(),
    });
    let pool_info = vk::CommandPoolCreateInfo::default()
        .queue_family_index(queue_family)
        .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
    // SAFETY: valid device and family.
    let pool = unsafe { device.create_command_pool(&pool_info, None) };
    match (allocator, pool) {
        (Ok(a), Ok(p)) => Ok((a, p)),
        (a, p) => {
            let pool_error = match p {
                // SAFETY: an unused pool of this device.
                Ok(p) => unsafe {
                    device.destroy_command_pool(p, None);
                    None
                },
                Err(e) => Some(GpuError::vulkan("vkCreateCommandPool", "shvis.pool", e)),
            };
            let error = match a {
                Ok(allocator) => {
                    drop(allocator); // frees its memory blocks before the device goes
                    pool_error.unwrap_or(GpuError::NoDevice)
                }
                Err(source) => GpuError::Alloc {
                    what: "allocator".into(),
                    source,
                },
            };
            // SAFETY: nothing created from the device is alive any more.
            unsafe { device.destroy_device(None) };
            destroy_instance(instance, (debug_instance, messenger));
            Err(error)
        }
    }
}

/// Picks the physical device and its graphics queue family; see the module doc.
fn pick_device(
    instance: &ash::Instance,
    wanted: Option<&str>,
) -> Result<(vk::PhysicalDevice, u32, String), GpuError> {
    // SAFETY: plain queries on a live instance.
    let devices = match unsafe { instance.enumerate_physical_devices() } {
        Ok(d) => d,
        Err(vk::Result::ERROR_INITIALIZATION_FAILED) => vec![],
        Err(e) => return Err(GpuError::vulkan("vkEnumeratePhysicalDevices", "shvis", e)),
    };
    let mut candidates = Vec::new();
    for pd in devices {
        // SAFETY: `pd` came from this instance.
        let (props, families) = unsafe {
            (
                instance.get_physical_device_properties(pd),
                instance.get_physical_device_queue_family_properties(pd),
            )
        };
        let name = props
            .device_name_as_c_str()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|_| "unnamed device".into());
        let Some(family) = families
            .iter()
            .position(|f| f.queue_flags.contains(vk::QueueFlags::GRAPHICS))
        else {
            continue;
        };
        let rank = match props.device_type {
            vk::PhysicalDeviceType::DISCRETE_GPU => 0,
            vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
            vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
            vk::PhysicalDeviceType::CPU => 3,
            _ => 4,
        };
        candidates.push((rank, pd, family as u32, name));
    }
    if candidates.is_empty() {
        return Err(GpuError::NoDevice);
    }
    if let Some(w) = wanted {
        let lw = w.to_lowercase();
        return candidates
            .iter()
            .find(|c| c.3.to_lowercase().contains(&lw))
            .map(|c| (c.1, c.2, c.3.clone()))
            .ok_or_else(|| GpuError::NoMatchingDevice {
                wanted: w.to_string(),
                available: candidates
                    .iter()
                    .map(|c| c.3.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
    }
    candidates.sort_by_key(|c| c.0);
    let c = &candidates[0];
    Ok((c.1, c.2, c.3.clone()))
}
