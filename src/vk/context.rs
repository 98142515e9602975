//! The Vulkan context: instance, validation messages, physical device choice, logical device,
//! one compute queue, the memory allocator and the objects the other files share (pipeline
//! cache, descriptor pools, timestamp query pool), plus an orderly teardown.
//!
//! Headless: no surface, no window-system extensions. Vulkan 1.2 or newer.

use super::commands::Timestamps;
use super::pipeline::{load_pipeline_cache, save_pipeline_cache, DescriptorPools};
use anyhow::{anyhow, bail, Context as _, Result};
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::collections::HashMap;
use std::ffi::{c_void, CStr, CString};
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::sync::Mutex;

/// How to set up a [`Context`].
#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// A case-insensitive substring of the device name (see `brdfwave devices`); `None` picks
    /// lavapipe when present, else the first discrete, then integrated GPU.
    pub device: Option<String>,
    /// Enable `VK_LAYER_KHRONOS_validation` (with synchronisation validation) when installed and
    /// collect its warnings and errors (see [`Context::validation_messages`]).
    pub validation: bool,
}

/// Optional device features, enabled when the device supports them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DeviceFeatures {
    /// `scalarBlockLayout` (GLSL `layout(scalar)`, GL_EXT_scalar_block_layout).
    pub scalar_block_layout: bool,
    /// `storageBuffer8BitAccess` (8-bit types in storage buffers).
    pub storage_buffer_8bit_access: bool,
    /// The compute queue writes timestamps (`timestampValidBits` > 0).
    pub timestamps: bool,
    /// Compute shaders have the basic and ballot subgroup operations (Vulkan 1.1 core
    /// properties; GL_KHR_shader_subgroup_ballot).
    pub subgroup_ballot: bool,
}

/// The package that provides lavapipe, named in every "no Vulkan" error.
const INSTALL_HINT: &str = "install the Vulkan loader and the lavapipe software driver: \
     `sudo apt-get install libvulkan1 mesa-vulkan-drivers` (see README, \"Requirements\")";
const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";
/// Timestamp queries available per command buffer.
pub const MAX_TIMESTAMPS: u32 = 4096;

/// Where validation messages go; the debug messenger gets a pointer to it (boxed, so it never
/// moves while the messenger lives). Keeps the first [`MessageSink::KEEP`] messages and counts
/// the rest, so a broken render cannot fill the memory with repeats.
#[derive(Default)]
pub(crate) struct MessageSink {
    messages: Mutex<(Vec<String>, usize)>,
}

impl MessageSink {
    const KEEP: usize = 1000;

    pub(crate) fn push(&self, msg: String) {
        let mut m = self.messages.lock().unwrap_or_else(|e| e.into_inner());
        if m.0.len() < Self::KEEP {
            m.0.push(msg);
        } else {
            m.1 += 1;
        }
    }

    fn snapshot(&self) -> Vec<String> {
        let m = self.messages.lock().unwrap_or_else(|e| e.into_inner());
        let mut out = m.0.clone();
        if m.1 > 0 {
            out.push(format!("... and {} more messages (not kept)", m.1));
        }
        out
    }
}

/// Vulkan objects created through the context and not yet destroyed, so that teardown can
/// report (and still destroy) anything the caller forgot.
#[derive(Default)]
pub(crate) struct Registry {
    pub(crate) buffers: HashMap<vk::Buffer, String>,
    pub(crate) pipelines:
        HashMap<vk::Pipeline, (vk::PipelineLayout, vk::DescriptorSetLayout, String)>,
}

/// One physical device as seen at start-up.
struct Candidate {
    pd: vk::PhysicalDevice,
    name: String,
    kind: vk::PhysicalDeviceType,
    driver_id: vk::DriverId,
    driver_name: String,
    api_version: u32,
    /// (family index, timestampValidBits) of the queue family used for compute.
    compute_family: Option<(u32, u32)>,
}

impl Candidate {
    fn usable(&self) -> Result<(), String> {
        if self.api_version < vk::API_VERSION_1_2 {
            return Err(format!(
                "supports only Vulkan {}, 1.2 is needed",
                version_string(self.api_version)
            ));
        }
        if self.compute_family.is_none() {
            return Err("has no compute queue".into());
        }
        Ok(())
    }

    fn describe(&self) -> String {
        let kind = match self.kind {
            vk::PhysicalDeviceType::CPU => "cpu",
            vk::PhysicalDeviceType::DISCRETE_GPU => "discrete gpu",
            vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated gpu",
            vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual gpu",
            _ => "other",
        };
        let mut s = format!(
            "{} ({kind}, driver {}, Vulkan {})",
            self.name,
            self.driver_name,
            version_string(self.api_version)
        );
        if let Err(why) = self.usable() {
            s += &format!(" — unusable: {why}");
        }
        s
    }
}

fn version_string(v: u32) -> String {
    format!(
        "{}.{}.{}",
        vk::api_version_major(v),
        vk::api_version_minor(v),
        vk::api_version_patch(v)
    )
}

/// Owns every Vulkan object of the program. See the module documentation of [`crate::vk`].
pub struct Context {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    debug_utils: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    /// Device-level debug utils (object names); present when validation is on.
    pub(crate) debug_device: Option<ash::ext::debug_utils::Device>,
    sink: Box<MessageSink>,
    pub physical_device: vk::PhysicalDevice,
    pub device: ash::Device,
    /// The one queue used for everything (compute, transfer, timestamps).
    pub queue: vk::Queue,
    pub queue_family: u32,
    /// `vkQueueSubmit` needs the queue externally synchronised.
    pub(crate) queue_lock: Mutex<()>,
    /// Taken (dropped) in teardown, before the device is destroyed.
    allocator: Option<Mutex<Allocator>>,
    pub(crate) pipeline_cache: vk::PipelineCache,
    pipeline_cache_file: Option<PathBuf>,
    pub(crate) descriptor_pools: Mutex<DescriptorPools>,
    /// Null when the queue has no timestamps.
    pub(crate) query_pool: vk::QueryPool,
    pub(crate) timestamps: Mutex<Timestamps>,
    pub(crate) registry: Mutex<Registry>,
    /// See [`Context::debug_force_staging`].
    pub(crate) force_staging: AtomicBool,
    /// `VkPhysicalDeviceProperties::deviceName`, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
    pub device_name: String,
    pub device_type: vk::PhysicalDeviceType,
    pub driver_id: vk::DriverId,
    /// Driver name and version, e.g. "llvmpipe Mesa 22.3.6 (LLVM 15.0.6)".
    pub driver_info: String,
    pub api_version: u32,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period_ns: f32,
    pub(crate) timestamp_valid_bits: u32,
    pub limits: vk::PhysicalDeviceLimits,
    pub features: DeviceFeatures,
    validation: bool,
    torn_down: bool,
}

/// Collects WARNING and ERROR messages (the messenger is created for those severities only).
unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    if data.is_null() || user.is_null() {
        return vk::FALSE;
    }
    let sink = &*(user as *const MessageSink);
    let data = &*data;
    let id = lossy(data.message_id_name_as_c_str());
    let text = lossy(data.message_as_c_str());
    if is_harmless_loader_message(types, &id, &text) {
        return vk::FALSE;
    }
    let level = if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        "ERROR"
    } else {
        "WARNING"
    };
    let kind = if types.contains(vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION) {
        "validation"
    } else if types.contains(vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE) {
        "performance"
    } else {
        "general"
    };
    sink.push(format!("[{level} {kind}] {id}: {text}"));
    vk::FALSE
}

/// Messages of the Vulkan loader (not of the validation layer) that report that *other* ICDs
/// installed on the machine found no hardware, e.g. the Intel or Radeon drivers that ship in
/// `mesa-vulkan-drivers` next to lavapipe. They say nothing about our use of Vulkan. Everything
/// else, from the loader included, is kept.
fn is_harmless_loader_message(
    types: vk::DebugUtilsMessageTypeFlagsEXT,
    id: &str,
    text: &str,
) -> bool {
    if types != vk::DebugUtilsMessageTypeFlagsEXT::GENERAL || id != "Loader Message" {
        return false;
    }
    const ICD_SKIPPED: [&str; 3] = [
        "Failed to CreateInstance in ICD",
        "Skipping ICD",
        "failed to find a compatible driver",
    ];
    ICD_SKIPPED.iter().any(|p| text.contains(p)) && !text.contains("lvp_icd")
}

fn load_entry() -> Result<ash::Entry> {
    unsafe { ash::Entry::load() }.map_err(|e| {
        let text = e.to_string();
        // With no file descriptor left the loader cannot be opened either, but installing it
        // again would not help: say what would.
        if text.contains("Too many open files") || out_of_file_descriptors() {
            anyhow!("cannot load the Vulkan loader (libvulkan.so.1): {e}; {FD_HINT}")
        } else {
            anyhow!("cannot load the Vulkan loader (libvulkan.so.1): {e}; {INSTALL_HINT}")
        }
    })
}

/// What to do when the process has run out of file descriptors (EMFILE/ENFILE).
const FD_HINT: &str = "the process has no file descriptor left (EMFILE): raise the limit \
     (`ulimit -n`, e.g. to 1024) or close files it inherited; the Vulkan installation is not the \
     problem";

/// Whether opening a file fails now for want of file descriptors (EMFILE: this process's
/// limit, ENFILE: the system's). The loader reports such a failure as "no driver", which would
/// point the user at reinstalling Vulkan.
fn out_of_file_descriptors() -> bool {
    match std::fs::File::open("/dev/null") {
        Ok(_) => false,
        Err(e) => matches!(e.raw_os_error(), Some(libc::EMFILE) | Some(libc::ENFILE)),
    }
}

fn instance_extensions(entry: &ash::Entry, layer: Option<&CStr>) -> Vec<CString> {
    unsafe { entry.enumerate_instance_extension_properties(layer) }
        .unwrap_or_default()
        .iter()
        .filter_map(|e| e.extension_name_as_c_str().ok().map(CStr::to_owned))
        .collect()
}

/// Creates a headless instance; with `validation` the layer and debug utils are enabled and the
/// messenger's create info is chained so that instance creation itself is validated.
fn create_instance(
    entry: &ash::Entry,
    validation: bool,
    sink: &MessageSink,
) -> Result<(ash::Instance, bool)> {
    let version = unsafe { entry.try_enumerate_instance_version() }
        .context("vkEnumerateInstanceVersion")?
        .unwrap_or(vk::API_VERSION_1_0);
    if version < vk::API_VERSION_1_2 {
        bail!(
            "the Vulkan loader supports only Vulkan {}, 1.2 is needed; {INSTALL_HINT}",
            version_string(version)
        );
    }
    let mut layers: Vec<&CStr> = Vec::new();
    let mut extensions: Vec<&CStr> = Vec::new();
    let available = instance_extensions(entry, None);
    let mut flags = vk::InstanceCreateFlags::empty();
    if available
        .iter()
        .any(|e| e.as_c_str() == ash::khr::portability_enumeration::NAME)
    {
        extensions.push(ash::khr::portability_enumeration::NAME);
        flags |= vk::InstanceCreateFlags::ENUMERATE_PORTABILITY_KHR;
    }
    let mut use_validation = false;
    let mut validation_features = false;
    if validation {
        match validation_support(entry, &available)? {
            Ok(features) => {
                use_validation = true;
                layers.push(VALIDATION_LAYER);
                extensions.push(ash::ext::debug_utils::NAME);
                if features {
                    validation_features = true;
                    extensions.push(ash::ext::validation_features::NAME);
                }
            }
            Err(why) => eprintln!("warning: {why}; running without validation"),
        }
    }
    let app = vk::ApplicationInfo::default()
        .application_name(c"brdfwave")
        .application_version(1)
        .engine_name(c"brdfwave")
        .api_version(vk::API_VERSION_1_2);
    let layer_ptrs: Vec<_> = layers.iter().map(|l| l.as_ptr()).collect();
    let ext_ptrs: Vec<_> = extensions.iter().map(|e| e.as_ptr()).collect();
    let mut messenger_info = messenger_create_info(sink);
    // Synchronisation validation catches missing barriers between dependent dispatches.
    let enables = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
    let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&enables);
    let mut info = vk::InstanceCreateInfo::default()
        .flags(flags)
        .application_info(&app)
        .enabled_layer_names(&layer_ptrs)
        .enabled_extension_names(&ext_ptrs);
    if use_validation {
        info = info.push_next(&mut messenger_info);
        if validation_features {
            info = info.push_next(&mut features);
        }
    }
    let instance = unsafe { entry.create_instance(&info, None) }.map_err(|e| {
        if out_of_file_descriptors() {
            return anyhow!("vkCreateInstance: {e}: {FD_HINT}");
        }
        // A driver manifest the loader cannot parse gives ERROR_OUT_OF_HOST_MEMORY (Vulkan
        // loader 1.3.239), so an override of the driver list explains that code too.
        match (e, driver_override_hint()) {
            (
                vk::Result::ERROR_INCOMPATIBLE_DRIVER
                | vk::Result::ERROR_INITIALIZATION_FAILED
                | vk::Result::ERROR_OUT_OF_HOST_MEMORY,
                Some(hint),
            ) => anyhow!("vkCreateInstance: {e}: {hint}"),
            (
                vk::Result::ERROR_INCOMPATIBLE_DRIVER | vk::Result::ERROR_INITIALIZATION_FAILED,
                None,
            ) => {
                anyhow!(
                    "vkCreateInstance: no Vulkan 1.2 driver could be loaded ({e}); {INSTALL_HINT}"
                )
            }
            (e, _) => anyhow!("vkCreateInstance: {e}"),
        }
    })?;
    Ok((instance, use_validation))
}

/// Environment variables that replace the Vulkan loader's list of driver (ICD) manifests.
const DRIVER_OVERRIDES: [&str; 2] = ["VK_DRIVER_FILES", "VK_ICD_FILENAMES"];

/// When the driver list was overridden through the environment (a usual reason for a failing
/// `vkCreateInstance`): which manifests were tried, which of them exist, and how to fix it.
fn driver_override_hint() -> Option<String> {
    let (var, value) = DRIVER_OVERRIDES.iter().find_map(|v| {
        std::env::var(v)
            .ok()
            .filter(|x| !x.is_empty())
            .map(|x| (*v, x))
    })?;
    let tried: Vec<String> = std::env::split_paths(&value)
        .map(|p| {
            let state = if p.is_file() {
                manifest_state(&p)
            } else if p.exists() {
                "not a file".to_string()
            } else {
                "does not exist".to_string()
            };
            format!("{} ({state})", p.display())
        })
        .collect();
    Some(format!(
        "{var} restricts the Vulkan loader to the driver manifest(s) {}; none gave a usable \
         driver. Unset {var} to use the installed drivers, or set it to an existing manifest, \
         e.g. /usr/share/vulkan/icd.d/lvp_icd.{}.json for lavapipe",
        tried.join(", "),
        std::env::consts::ARCH
    ))
}

/// What is wrong with an existing driver manifest, as far as can be told without loading it: a
/// manifest is a JSON object whose `ICD.library_path` names the driver's shared library.
fn manifest_state(path: &std::path::Path) -> String {
    const MAX_MANIFEST: u64 = 1 << 20;
    let len = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    if len > MAX_MANIFEST {
        return format!("exists, but is {len} bytes: not a driver manifest");
    }
    let text = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) => return format!("exists, but cannot be read: {e}"),
    };
    let json: serde_json::Value = match serde_json::from_slice(&text) {
        Ok(v) => v,
        Err(e) => return format!("exists, but is not a JSON driver manifest: {e}"),
    };
    let Some(lib) = json
        .get("ICD")
        .and_then(|icd| icd.get("library_path"))
        .and_then(|l| l.as_str())
    else {
        return "exists, but has no ICD.library_path: not a driver manifest".to_string();
    };
    // A bare file name is looked up by the dynamic linker; a path is relative to the manifest.
    if lib.contains('/') {
        let dir = path.parent().unwrap_or(std::path::Path::new("."));
        let full = dir.join(lib);
        if !full.is_file() {
            return format!("exists, but its driver library {} does not", full.display());
        }
    }
    "exists".to_string()
}

/// Whether the validation layer and its debug-utils extension can be enabled: `Ok(Ok(has
/// VK_EXT_validation_features))`, or `Ok(Err(why not))`.
fn validation_support(
    entry: &ash::Entry,
    available: &[CString],
) -> Result<std::result::Result<bool, String>> {
    let layer_present = unsafe { entry.enumerate_instance_layer_properties() }
        .context("vkEnumerateInstanceLayerProperties")?
        .iter()
        .any(|l| l.layer_name_as_c_str().ok() == Some(VALIDATION_LAYER));
    if !layer_present {
        return Ok(Err(
            "the Khronos validation layer (VK_LAYER_KHRONOS_validation) is not installed: \
             `sudo apt-get install vulkan-validationlayers`"
                .to_string(),
        ));
    }
    let layer_exts = instance_extensions(entry, Some(VALIDATION_LAYER));
    let has = |name: &CStr| {
        available
            .iter()
            .chain(layer_exts.iter())
            .any(|e| e.as_c_str() == name)
    };
    if !has(ash::ext::debug_utils::NAME) {
        return Ok(Err(
            "the validation layer is installed but VK_EXT_debug_utils, which reports its \
             messages, is unavailable"
                .to_string(),
        ));
    }
    Ok(Ok(has(ash::ext::validation_features::NAME)))
}

/// Checks that the validation layer can be enabled, for callers that must not run without it
/// (`brdfwave render --validation`); the error says why not and how to install it.
/// [`Context::new`] itself only warns and runs without validation.
pub fn require_validation() -> Result<()> {
    let entry = load_entry()?;
    let available = instance_extensions(&entry, None);
    validation_support(&entry, &available)?.map_err(|why| anyhow!("{why}"))?;
    Ok(())
}

fn messenger_create_info(sink: &MessageSink) -> vk::DebugUtilsMessengerCreateInfoEXT<'static> {
    vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(
            vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
        )
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(debug_callback))
        .user_data(sink as *const MessageSink as *mut c_void)
}

fn candidates(instance: &ash::Instance) -> Result<Vec<Candidate>> {
    let pds =
        unsafe { instance.enumerate_physical_devices() }.map_err(
            |e| match driver_override_hint() {
                Some(hint) => anyhow!("vkEnumeratePhysicalDevices: {e}: {hint}"),
                None => anyhow!("vkEnumeratePhysicalDevices: {e}; {INSTALL_HINT}"),
            },
        )?;
    let mut out = Vec::new();
    for pd in pds {
        let props = unsafe { instance.get_physical_device_properties(pd) };
        let name = lossy(props.device_name_as_c_str().ok());
        let (driver_id, driver_name) = if props.api_version >= vk::API_VERSION_1_2 {
            let mut driver = vk::PhysicalDeviceDriverProperties::default();
            let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver);
            unsafe { instance.get_physical_device_properties2(pd, &mut p2) };
            let n = lossy(driver.driver_name_as_c_str().ok());
            let i = lossy(driver.driver_info_as_c_str().ok());
            (driver.driver_id, format!("{n} {i}").trim().to_string())
        } else {
            (vk::DriverId::default(), String::from("?"))
        };
        let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        // Prefer a compute family with timestamps; among those the first.
        let compute_family = families
            .iter()
            .enumerate()
            .filter(|(_, f)| f.queue_flags.contains(vk::QueueFlags::COMPUTE) && f.queue_count > 0)
            .max_by_key(|(i, f)| (f.timestamp_valid_bits > 0, std::cmp::Reverse(*i)))
            .map(|(i, f)| (i as u32, f.timestamp_valid_bits));
        out.push(Candidate {
            pd,
            name,
            kind: props.device_type,
            driver_id,
            driver_name,
            api_version: props.api_version,
            compute_family,
        });
    }
    Ok(out)
}

/// The device to use (see [`ContextOptions::device`]).
fn choose(cands: &[Candidate], wanted: Option<&str>) -> Result<usize> {
    if cands.is_empty() {
        if let Some(hint) = driver_override_hint() {
            bail!("no Vulkan device found: {hint}");
        }
        bail!("no Vulkan device found; {INSTALL_HINT}");
    }
    let list = || {
        cands
            .iter()
            .map(|c| format!("  {}", c.describe()))
            .collect::<Vec<_>>()
            .join("\n")
    };
    if let Some(w) = wanted {
        if w.trim().is_empty() {
            bail!("the device name to look for is empty; `brdfwave devices` lists the names");
        }
        let w_lower = w.to_lowercase();
        let matching: Vec<usize> = (0..cands.len())
            .filter(|&i| cands[i].name.to_lowercase().contains(&w_lower))
            .collect();
        if matching.is_empty() {
            bail!(
                "no Vulkan device name contains \"{w}\"; available devices:\n{}",
                list()
            );
        }
        return matching
            .iter()
            .copied()
            .find(|&i| cands[i].usable().is_ok())
            .ok_or_else(|| {
                anyhow!(
                    "the devices matching \"{w}\" cannot be used; available devices:\n{}",
                    list()
                )
            });
    }
    let usable: Vec<usize> = (0..cands.len())
        .filter(|&i| cands[i].usable().is_ok())
        .collect();
    let pick = usable
        .iter()
        .copied()
        .find(|&i| cands[i].driver_id == vk::DriverId::MESA_LLVMPIPE)
        .or_else(|| {
            usable
                .iter()
                .copied()
                .find(|&i| cands[i].kind == vk::PhysicalDeviceType::DISCRETE_GPU)
        })
        .or_else(|| {
            usable
                .iter()
                .copied()
                .find(|&i| cands[i].kind == vk::PhysicalDeviceType::INTEGRATED_GPU)
        })
        .or_else(|| usable.first().copied());
    pick.ok_or_else(|| anyhow!("no usable Vulkan device (Vulkan 1.2 with a compute queue); available devices:\n{}\n{INSTALL_HINT}", list()))
}

impl Context {
    /// Descriptions of the Vulkan devices on this machine, one line each ("name (type, driver,
    /// Vulkan version)"); `ContextOptions::device` matches a substring of the name.
    pub fn list_devices() -> Result<Vec<String>> {
        let entry = load_entry()?;
        let sink = MessageSink::default();
        let (instance, _) = create_instance(&entry, false, &sink)?;
        let result = candidates(&instance).map(|c| c.iter().map(Candidate::describe).collect());
        unsafe { instance.destroy_instance(None) };
        result
    }

    /// Creates the instance, picks the device and creates everything the backend shares.
    pub fn new(opts: &ContextOptions) -> Result<Context> {
        let entry = load_entry()?;
        let sink = Box::<MessageSink>::default();
        let (instance, validation) = create_instance(&entry, opts.validation, &sink)?;
        // Until the context exists, `partial` destroys what was created if a step fails.
        let mut partial = Partial {
            instance: Some(instance),
            debug_utils: None,
            device: None,
        };
        let instance = partial.instance.clone().unwrap();
        if validation {
            let du = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = messenger_create_info(&sink);
            let m = unsafe { du.create_debug_utils_messenger(&info, None) }
                .context("vkCreateDebugUtilsMessengerEXT")?;
            partial.debug_utils = Some((du, m));
        }
        let cands = candidates(&instance)?;
        let cand = &cands[choose(&cands, opts.device.as_deref())?];
        let pd = cand.pd;
        let (queue_family, timestamp_valid_bits) = cand
            .compute_family
            .expect("usable device has a compute family");
        let props = unsafe { instance.get_physical_device_properties(pd) };

        let subgroup_ballot = {
            let mut sg = vk::PhysicalDeviceSubgroupProperties::default();
            let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut sg);
            unsafe { instance.get_physical_device_properties2(pd, &mut p2) };
            sg.supported_stages.contains(vk::ShaderStageFlags::COMPUTE)
                && sg
                    .supported_operations
                    .contains(vk::SubgroupFeatureFlags::BASIC | vk::SubgroupFeatureFlags::BALLOT)
        };
        // Optional features: enable what is supported, nothing else.
        let (scalar, int8) = {
            let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
            let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f12);
            unsafe { instance.get_physical_device_features2(pd, &mut f2) };
            (
                f12.scalar_block_layout == vk::TRUE,
                f12.storage_buffer8_bit_access == vk::TRUE,
            )
        };
        let mut f12 = vk::PhysicalDeviceVulkan12Features::default()
            .scalar_block_layout(scalar)
            .storage_buffer8_bit_access(int8);
        let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f12);
        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let device_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .push_next(&mut f2);
        let device = unsafe { instance.create_device(pd, &device_info, None) }
            .with_context(|| format!("vkCreateDevice on {}", cand.name))?;
        partial.device = Some(device.clone());
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: pd,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })
        .map_err(|e| anyhow!("creating the gpu-allocator allocator: {e}"))?;

        // From here on the context itself cleans up (its teardown skips null handles).
        let debug_utils = partial.debug_utils.take();
        partial.device = None;
        partial.instance = None;
        let mut ctx = Context {
            debug_device: validation
                .then(|| ash::ext::debug_utils::Device::new(&instance, &device)),
            entry,
            instance,
            debug_utils,
            sink,
            physical_device: pd,
            device,
            queue,
            queue_family,
            queue_lock: Mutex::new(()),
            allocator: Some(Mutex::new(allocator)),
            pipeline_cache: vk::PipelineCache::null(),
            pipeline_cache_file: None,
            descriptor_pools: Mutex::new(DescriptorPools::default()),
            query_pool: vk::QueryPool::null(),
            timestamps: Mutex::new(Timestamps::default()),
            registry: Mutex::new(Registry::default()),
            force_staging: AtomicBool::new(false),
            device_name: cand.name.clone(),
            device_type: cand.kind,
            driver_id: cand.driver_id,
            driver_info: cand.driver_name.clone(),
            api_version: cand.api_version,
            timestamp_period_ns: props.limits.timestamp_period,
            timestamp_valid_bits,
            limits: props.limits,
            features: DeviceFeatures {
                scalar_block_layout: scalar,
                storage_buffer_8bit_access: int8,
                timestamps: timestamp_valid_bits > 0,
                subgroup_ballot,
            },
            validation,
            torn_down: false,
        };
        let (cache, file) = load_pipeline_cache(&ctx.device, &props)?;
        ctx.pipeline_cache = cache;
        ctx.pipeline_cache_file = file;
        if timestamp_valid_bits > 0 {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(MAX_TIMESTAMPS);
            ctx.query_pool = unsafe { ctx.device.create_query_pool(&info, None) }
                .context("vkCreateQueryPool (timestamps)")?;
        }
        Ok(ctx)
    }

    /// The memory allocator (alive until teardown).
    pub(crate) fn allocator(&self) -> std::sync::MutexGuard<'_, Allocator> {
        self.allocator
            .as_ref()
            .expect("allocator alive until teardown")
            .lock()
            .unwrap_or_else(|e| e.into_inner())
    }

    /// Whether `VK_LAYER_KHRONOS_validation` is active.
    pub fn validation_enabled(&self) -> bool {
        self.validation
    }

    /// The validation layer's warnings and errors so far, plus reports of objects left alive at
    /// teardown (see [`finish`](Self::finish)). Empty when validation is off.
    pub fn validation_messages(&self) -> Vec<String> {
        self.sink.snapshot()
    }

    /// Tears the context down now and returns every validation message, including those raised
    /// while destroying the device (leaks) and the context's own reports of buffers and
    /// pipelines that were never destroyed.
    pub fn finish(mut self) -> Vec<String> {
        self.teardown();
        self.sink.snapshot()
    }

    /// Gives a Vulkan object a name that validation messages quote (no-op without validation).
    pub(crate) fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        if let (Some(du), Ok(cname)) = (&self.debug_device, CString::new(name)) {
            let info = vk::DebugUtilsObjectNameInfoEXT::default()
                .object_handle(handle)
                .object_name(&cname);
            let _ = unsafe { du.set_debug_utils_object_name(&info) };
        }
    }

    /// Destroys everything in dependency order. Idempotent.
    fn teardown(&mut self) {
        if self.torn_down {
            return;
        }
        self.torn_down = true;
        unsafe {
            let _ = self.device.device_wait_idle();
            // Objects the caller forgot: report, then destroy so the device goes down cleanly.
            let leaked =
                std::mem::take(&mut *self.registry.lock().unwrap_or_else(|e| e.into_inner()));
            for (p, (layout, set_layout, name)) in leaked.pipelines {
                self.sink.push(format!(
                    "[ERROR brdfwave] leak: compute pipeline \"{name}\" was never destroyed"
                ));
                self.device.destroy_pipeline(p, None);
                self.device.destroy_pipeline_layout(layout, None);
                self.device.destroy_descriptor_set_layout(set_layout, None);
            }
            for (b, name) in leaked.buffers {
                self.sink.push(format!(
                    "[ERROR brdfwave] leak: buffer \"{name}\" was never destroyed"
                ));
                self.device.destroy_buffer(b, None);
            }
            if self.pipeline_cache != vk::PipelineCache::null() {
                if let Some(file) = &self.pipeline_cache_file {
                    save_pipeline_cache(&self.device, self.pipeline_cache, file);
                }
                self.device
                    .destroy_pipeline_cache(self.pipeline_cache, None);
            }
            let pools = std::mem::take(
                &mut *self
                    .descriptor_pools
                    .lock()
                    .unwrap_or_else(|e| e.into_inner()),
            );
            pools.destroy(&self.device);
            if self.query_pool != vk::QueryPool::null() {
                self.device.destroy_query_pool(self.query_pool, None);
            }
            // The allocator frees its memory blocks through the device: before the device.
            drop(self.allocator.take());
            self.device.destroy_device(None);
            if let Some((du, m)) = self.debug_utils.take() {
                du.destroy_debug_utils_messenger(m, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// What exists while [`Context::new`] runs; destroyed in order if a step fails.
struct Partial {
    instance: Option<ash::Instance>,
    debug_utils: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    device: Option<ash::Device>,
}

impl Drop for Partial {
    fn drop(&mut self) {
        unsafe {
            if let Some(d) = self.device.take() {
                d.destroy_device(None);
            }
            if let Some((du, m)) = self.debug_utils.take() {
                du.destroy_debug_utils_messenger(m, None);
            }
            if let Some(i) = self.instance.take() {
                i.destroy_instance(None);
            }
        }
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        if self.torn_down {
            return;
        }
        let before = self.sink.snapshot().len();
        self.teardown();
        let after = self.sink.snapshot();
        for m in &after[before..] {
            eprintln!("vulkan teardown: {m}");
        }
    }
}

/// A string the driver or the loader gave, as text: invalid UTF-8 replaced, empty when absent
/// or not terminated.
fn lossy(s: Option<&CStr>) -> String {
    s.map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loader_filter_keeps_validation_messages() {
        let general = vk::DebugUtilsMessageTypeFlagsEXT::GENERAL;
        let validation = vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION;
        assert!(is_harmless_loader_message(
            general,
            "Loader Message",
            "terminator_CreateInstance: Failed to CreateInstance in ICD 1.  Skipping ICD."
        ));
        assert!(!is_harmless_loader_message(
            validation,
            "Loader Message",
            "Skipping ICD"
        ));
        assert!(!is_harmless_loader_message(
            general,
            "VUID-x",
            "Skipping ICD"
        ));
        assert!(!is_harmless_loader_message(
            general,
            "Loader Message",
            "something else"
        ));
    }
}
