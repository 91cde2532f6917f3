//! VK_EXT_debug_utils: messages routed to `log` and counted (tests fail on any error or
//! warning), object names and command-buffer labels.

use std::ffi::{CStr, c_void};
use std::sync::atomic::{AtomicU32, Ordering};

use ash::vk;

/// Counts of debug-utils messages by severity since the context was created.
#[derive(Debug, Default)]
pub struct MessageCounts {
    pub errors: AtomicU32,
    pub warnings: AtomicU32,
}

impl MessageCounts {
    /// (errors, warnings) so far.
    pub fn get(&self) -> (u32, u32) {
        (
            self.errors.load(Ordering::SeqCst),
            self.warnings.load(Ordering::SeqCst),
        )
    }
}

/// The messenger callback; `user_data` points at the context's boxed `MessageCounts`.
pub(crate) unsafe extern "system" fn messenger_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    kind: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: the loader passes valid callback data for the duration of the call; the
    // message is a NUL-terminated string when non-null.
    let message = unsafe {
        data.as_ref()
            .and_then(|d| (!d.p_message.is_null()).then(|| CStr::from_ptr(d.p_message)))
            .map(|m| m.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    // SAFETY: `user_data` is the address of the context's `Arc<MessageCounts>`, which
    // outlives the messenger (destroyed in `Context::drop` before the Arc is released).
    let counts = unsafe { (user_data as *const MessageCounts).as_ref() };
    // Loader chatter (GENERAL) is for debugging set-up: a missing driver already becomes
    // one clear error, so it is not repeated at error level. Validation and performance
    // messages are counted — tests require none.
    if !kind.intersects(
        vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
            | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
    ) {
        log::debug!(target: "vulkan", "[{kind:?}] {message}");
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        if let Some(c) = counts {
            c.errors.fetch_add(1, Ordering::SeqCst);
        }
        log::error!(target: "vulkan", "[{kind:?}] {message}");
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING) {
        if let Some(c) = counts {
            c.warnings.fetch_add(1, Ordering::SeqCst);
        }
        log::warn!(target: "vulkan", "[{kind:?}] {message}");
    } else {
        log::debug!(target: "vulkan", "[{kind:?}] {message}");
    }
    vk::FALSE
}
