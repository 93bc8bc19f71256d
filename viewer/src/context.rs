//! The Vulkan context: loader, instance, validation messenger, device, queue and
//! command pool — everything the other modules borrow.
//!
//! Validation (`VK_LAYER_KHRONOS_validation` plus a `VK_EXT_debug_utils` messenger)
//! is on in debug builds and tests; the messenger counts errors so callers (the
//! tests, `mdg-view` at exit) can fail on any. When no loader or no device is found
//! the error says how to get one (`bash .ci/run` installs lavapipe).

use crate::Error;
use ash::vk;
use std::ffi::{c_void, CStr};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};

/// Whether to enable the validation layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Validation {
    /// Never.
    Off,
    /// When the layer is installed (debug builds of `mdg-view`).
    IfAvailable,
    /// Always; creating the context fails when the layer is missing (tests).
    Required,
}

impl Validation {
    /// The default for this build: `MDG_VALIDATION=0|1` overrides; otherwise on
    /// (if installed) in debug builds, off in release builds.
    pub fn from_env() -> Validation {
        match std::env::var("MDG_VALIDATION").as_deref() {
            Ok("0") => Validation::Off,
            Ok("1") => Validation::Required,
            _ if cfg!(debug_assertions) => Validation::IfAvailable,
            _ => Validation::Off,
        }
    }
}

/// What to ask of the context.
#[derive(Clone, Debug)]
pub struct ContextOptions {
    pub validation: Validation,
    /// Instance extensions a window surface needs (from `ash_window`); empty offscreen.
    pub surface_extensions: Vec<&'static CStr>,
    /// Receives each validation error and warning as it is reported (the viewer
    /// prints nothing itself); errors are also counted and kept in the log.
    pub on_message: Option<fn(&str)>,
}

/// Messages the validation layer reported, counted by severity; errors kept.
#[derive(Debug, Default)]
pub struct ValidationLog {
    errors: AtomicU32,
    warnings: AtomicU32,
    messages: Mutex<Vec<String>>,
    on_message: Option<fn(&str)>,
}

impl ValidationLog {
    /// Number of validation errors so far.
    pub fn errors(&self) -> u32 {
        self.errors.load(Ordering::SeqCst)
    }

    /// Number of validation warnings so far.
    pub fn warnings(&self) -> u32 {
        self.warnings.load(Ordering::SeqCst)
    }

    /// The text of the first error messages (at most 20 kept).
    pub fn error_messages(&self) -> Vec<String> {
        self.messages.lock().map(|m| m.clone()).unwrap_or_default()
    }
}

/// The instance, device and queue.
pub struct Context {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    /// Kept alive for the messenger's callback (which holds a raw pointer to it).
    log: Arc<ValidationLog>,
    pub physical: vk::PhysicalDevice,
    pub device: ash::Device,
    pub queue: vk::Queue,
    pub queue_family: u32,
    pub command_pool: vk::CommandPool,
    pub memory: vk::PhysicalDeviceMemoryProperties,
    pub limits: vk::PhysicalDeviceLimits,
    /// `fillModeNonSolid` (wireframe) was available and enabled.
    pub wireframe: bool,
    /// `largePoints` (point sizes other than 1, which the point-sprite stand-ins
    /// of small instances need: [`crate::points`]) was available and enabled.
    pub large_points: bool,
    /// The device's name, e.g. `llvmpipe (LLVM 15.0.6, 256 bits)`.
    pub device_name: String,
    /// A GPU or a CPU driver (lavapipe): pictures choose their samples by it.
    pub device_type: vk::PhysicalDeviceType,
    /// Whether validation is on.
    pub validation: bool,
}

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// How to get a Vulkan implementation here.
pub const INSTALL_HINT: &str =
    "install a Vulkan driver: your GPU vendor's, or the CPU one (Debian and Ubuntu: `sudo apt-get install mesa-vulkan-drivers libvulkan1`)";

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: `user` is the `Arc<ValidationLog>` pointer given at messenger creation;
    // the context keeps that Arc alive until after the messenger is destroyed.
    let log = unsafe { &*(user as *const ValidationLog) };
    // SAFETY: the layer passes a valid callback-data struct whose message is a
    // NUL-terminated string for the duration of this call (or null).
    let text = unsafe {
        match data.as_ref() {
            Some(d) if !d.p_message.is_null() => CStr::from_ptr(d.p_message).to_string_lossy().into_owned(),
            _ => String::from("(no message)"),
        }
    };
    if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        log.errors.fetch_add(1, Ordering::SeqCst);
        if let Some(f) = log.on_message {
            f(&format!("[vulkan validation error] {text}"));
        }
        if let Ok(mut m) = log.messages.lock() {
            if m.len() < 20 {
                m.push(text);
            }
        }
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING) {
        log.warnings.fetch_add(1, Ordering::SeqCst);
        if let Some(f) = log.on_message {
            f(&format!("[vulkan validation warning] {text}"));
        }
    }
    vk::FALSE
}

impl Context {
    /// Loads Vulkan and creates an instance and a device with one graphics queue.
    pub fn new(opts: &ContextOptions) -> Result<Context, Error> {
        // SAFETY: loading the system Vulkan loader runs its initialisation code; we
        // trust the installed loader like any linked system library.
        let entry = unsafe { ash::Entry::load() }
            .map_err(|e| Error::NoVulkan(format!("cannot load the Vulkan loader (libvulkan.so.1): {e}")))?;
        // SAFETY: a plain query on a loaded entry.
        let layers = unsafe { entry.enumerate_instance_layer_properties() }.map_err(vkerr("enumerate layers"))?;
        let have_layer = layers.iter().any(|l| l.layer_name_as_c_str().ok() == Some(VALIDATION_LAYER));
        let validation = match opts.validation {
            Validation::Off => false,
            Validation::IfAvailable => have_layer,
            Validation::Required => {
                if !have_layer {
                    return Err(Error::NoVulkan(format!(
                        "the Vulkan validation layer ({}) is not installed",
                        VALIDATION_LAYER.to_string_lossy()
                    )));
                }
                true
            }
        };
        let app = vk::ApplicationInfo::default()
            .application_name(c"mdg-view")
            .engine_name(c"mdg")
            .api_version(vk::API_VERSION_1_0);
        let mut extensions: Vec<*const std::ffi::c_char> = opts.surface_extensions.iter().map(|e| e.as_ptr()).collect();
        if validation {
            extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        let layer_ptrs = [VALIDATION_LAYER.as_ptr()];
        let mut info = vk::InstanceCreateInfo::default().application_info(&app).enabled_extension_names(&extensions);
        if validation {
            info = info.enabled_layer_names(&layer_ptrs);
        }
        // SAFETY: the create info and everything it points to live until the call returns.
        let instance = unsafe { entry.create_instance(&info, None) }.map_err(|e| match e {
            vk::Result::ERROR_INCOMPATIBLE_DRIVER => Error::NoVulkan("no Vulkan driver (ICD) is installed".into()),
            e => Error::Vulkan(format!("vkCreateInstance: {e}")),
        })?;
        let log = Arc::new(ValidationLog { on_message: opts.on_message, ..ValidationLog::default() });
        let debug = if validation {
            let du = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::ERROR | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
                )
                // Performance hints (e.g. a vertex attribute a custom shader does
                // not read) are not errors and would only add noise.
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::GENERAL | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION,
                )
                .pfn_user_callback(Some(debug_callback))
                .user_data(Arc::as_ptr(&log) as *mut c_void);
            // SAFETY: the instance was created with VK_EXT_debug_utils; the user data
            // points into `log`, which the context owns and drops after the messenger.
            match unsafe { du.create_debug_utils_messenger(&info, None) } {
                Ok(m) => Some((du, m)),
                Err(e) => {
                    // SAFETY: nothing else was created from the instance yet.
                    unsafe { instance.destroy_instance(None) };
                    return Err(Error::Vulkan(format!("create debug messenger: {e}")));
                }
            }
        } else {
            None
        };
        // From here on, a failure must destroy what was made: build the rest in a
        // helper and clean up on error.
        match Self::device_part(&instance, !opts.surface_extensions.is_empty()) {
            Ok((physical, device, queue_family, wireframe, device_name)) => {
                // SAFETY: the device was just created with a queue of this family.
                let queue = unsafe { device.get_device_queue(queue_family, 0) };
                let pool_info = vk::CommandPoolCreateInfo::default()
                    .queue_family_index(queue_family)
                    .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
                // SAFETY: valid device and create info.
                let command_pool = match unsafe { device.create_command_pool(&pool_info, None) } {
                    Ok(p) => p,
                    Err(e) => {
                        // SAFETY: destroy in reverse creation order; nothing uses them.
                        unsafe {
                            device.destroy_device(None);
                            if let Some((du, m)) = &debug {
                                du.destroy_debug_utils_messenger(*m, None);
                            }
                            instance.destroy_instance(None);
                        }
                        return Err(Error::Vulkan(format!("create command pool: {e}")));
                    }
                };
                // SAFETY: plain queries on a valid physical device.
                let (memory, props, features) = unsafe {
                    (
                        instance.get_physical_device_memory_properties(physical),
                        instance.get_physical_device_properties(physical),
                        instance.get_physical_device_features(physical),
                    )
                };
                Ok(Context {
                    entry,
                    instance,
                    debug,
                    log,
                    physical,
                    device,
                    queue,
                    queue_family,
                    command_pool,
                    memory,
                    limits: props.limits,
                    device_type: props.device_type,
                    wireframe,
                    // Enabled by `device_part` whenever the device has it.
                    large_points: features.large_points == vk::TRUE,
                    device_name,
                    validation,
                })
            }
            Err(e) => {
                // SAFETY: nothing but the messenger was created from the instance.
                unsafe {
                    if let Some((du, m)) = &debug {
                        du.destroy_debug_utils_messenger(*m, None);
                    }
                    instance.destroy_instance(None);
                }
                Err(e)
            }
        }
    }

    /// Picks a device with a graphics queue (discrete GPU first, then integrated,
    /// then anything, e.g. lavapipe) and creates it.
    fn device_part(
        instance: &ash::Instance,
        present: bool,
    ) -> Result<(vk::PhysicalDevice, ash::Device, u32, bool, String), Error> {
        // SAFETY: plain query on a valid instance.
        let devices = unsafe { instance.enumerate_physical_devices() }.map_err(vkerr("enumerate devices"))?;
        let mut best: Option<(u32, vk::PhysicalDevice, u32)> = None;
        for pd in devices {
            // SAFETY: plain queries on a device enumerated from this instance.
            let (props, families) = unsafe {
                (instance.get_physical_device_properties(pd), instance.get_physical_device_queue_family_properties(pd))
            };
            let Some(family) = families.iter().position(|f| f.queue_flags.contains(vk::QueueFlags::GRAPHICS)) else {
                continue;
            };
            let rank = match props.device_type {
                vk::PhysicalDeviceType::DISCRETE_GPU => 4,
                vk::PhysicalDeviceType::INTEGRATED_GPU => 3,
                vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
                _ => 1,
            };
            if best.is_none_or(|(r, _, _)| rank > r) {
                best = Some((rank, pd, family as u32));
            }
        }
        let Some((_, physical, family)) = best else {
            return Err(Error::NoVulkan("no Vulkan device with a graphics queue was found".into()));
        };
        // SAFETY: plain queries on a valid physical device.
        let (features, props) = unsafe {
            (instance.get_physical_device_features(physical), instance.get_physical_device_properties(physical))
        };
        let device_name = props.device_name_as_c_str().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let wireframe = features.fill_mode_non_solid == vk::TRUE;
        let enabled = vk::PhysicalDeviceFeatures::default()
            .fill_mode_non_solid(wireframe)
            .large_points(features.large_points == vk::TRUE);
        let priorities = [1.0f32];
        let queue_info =
            [vk::DeviceQueueCreateInfo::default().queue_family_index(family).queue_priorities(&priorities)];
        // The swapchain extension is enabled for a window (it needs the instance's
        // surface extensions); offscreen rendering does not use it.
        // SAFETY: `physical` was enumerated from `instance`, which is alive; the query
        // only reads the device's extension list.
        let exts =
            unsafe { instance.enumerate_device_extension_properties(physical) }.map_err(vkerr("device extensions"))?;
        let has_swapchain =
            present && exts.iter().any(|e| e.extension_name_as_c_str().ok() == Some(ash::khr::swapchain::NAME));
        let ext_names: Vec<*const std::ffi::c_char> =
            if has_swapchain { vec![ash::khr::swapchain::NAME.as_ptr()] } else { vec![] };
        let info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_extension_names(&ext_names)
            .enabled_features(&enabled);
        // SAFETY: the create info and its pointers live until the call returns.
        let device = unsafe { instance.create_device(physical, &info, None) }.map_err(vkerr("vkCreateDevice"))?;
        Ok((physical, device, family, wireframe, device_name))
    }

    /// The validation messages so far.
    pub fn validation_log(&self) -> &ValidationLog {
        &self.log
    }

    /// A memory type index with `props` among those allowed by `type_bits`.
    pub fn memory_type(&self, type_bits: u32, props: vk::MemoryPropertyFlags) -> Option<u32> {
        (0..self.memory.memory_type_count)
            .find(|&i| type_bits & (1 << i) != 0 && self.memory.memory_types[i as usize].property_flags.contains(props))
    }

    /// Records commands with `record` into a one-time command buffer, submits it
    /// and waits for it to finish.
    pub fn one_time(&self, record: impl FnOnce(vk::CommandBuffer)) -> Result<(), Error> {
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(self.command_pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: valid pool from this device; the buffer is freed below.
        let cmd = unsafe { self.device.allocate_command_buffers(&info) }.map_err(vkerr("allocate command buffer"))?[0];
        let result = (|| {
            let begin = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            // SAFETY: a freshly allocated command buffer, recorded on this thread only.
            unsafe { self.device.begin_command_buffer(cmd, &begin) }.map_err(vkerr("begin command buffer"))?;
            record(cmd);
            // SAFETY: `cmd` is in the recording state (begun above on this thread) and
            // `record` only appended commands to it.
            unsafe { self.device.end_command_buffer(cmd) }.map_err(vkerr("end command buffer"))?;
            // SAFETY: valid device; the fence is destroyed below.
            let fence = unsafe { self.device.create_fence(&vk::FenceCreateInfo::default(), None) }
                .map_err(vkerr("create fence"))?;
            let cmds = [cmd];
            let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
            // SAFETY: the command buffer is fully recorded; the fence is unsignalled.
            let submitted =
                unsafe { self.device.queue_submit(self.queue, &submit, fence) }.map_err(vkerr("queue submit"));
            let waited = submitted.and_then(|()| {
                // SAFETY: waiting on our own fence; it is destroyed only after the wait.
                unsafe { self.device.wait_for_fences(&[fence], true, u64::MAX) }.map_err(vkerr("wait for fence"))
            });
            if waited.is_err() {
                self.wait_idle();
            }
            // SAFETY: the submission finished (or never started), so the fence is idle.
            unsafe { self.device.destroy_fence(fence, None) };
            waited
        })();
        // SAFETY: the submission finished (or was never made), so the buffer is idle.
        unsafe { self.device.free_command_buffers(self.command_pool, &[cmd]) };
        result
    }

    /// Waits until the device is idle (before destroying resources it may use).
    pub fn wait_idle(&self) {
        // SAFETY: valid device; a failure (device lost) leaves nothing better to do.
        let _ = unsafe { self.device.device_wait_idle() };
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        // SAFETY: every resource created from this device is owned by a value that
        // borrows the context, so all were dropped before it; destroy in reverse
        // creation order.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_command_pool(self.command_pool, None);
            self.device.destroy_device(None);
            if let Some((du, m)) = self.debug.take() {
                du.destroy_debug_utils_messenger(m, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// Maps a `vk::Result` error to [`Error::Vulkan`] naming the call.
pub fn vkerr(what: &'static str) -> impl Fn(vk::Result) -> Error {
    move |e| Error::Vulkan(format!("{what}: {e}"))
}
