//! The Vulkan instance: loading the loader, the headless instance with (optionally) the
//! validation layer, the debug messenger and its message sink, and the messages that say why
//! Vulkan could not start (no loader, no driver, a broken driver manifest, no file
//! descriptor left).

use anyhow::{anyhow, bail, Context as _, Result};
use ash::vk;
use std::ffi::{c_void, CStr, CString};
use std::sync::Mutex;

/// The package that provides lavapipe, named in every "no Vulkan" error.
pub(super) const INSTALL_HINT: &str =
    "install the Vulkan loader and the lavapipe software driver: \
     `sudo apt-get install libvulkan1 mesa-vulkan-drivers` (see docs/install.md)";
const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

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

    pub(super) fn snapshot(&self) -> Vec<String> {
        let m = self.messages.lock().unwrap_or_else(|e| e.into_inner());
        let mut out = m.0.clone();
        if m.1 > 0 {
            out.push(format!("... and {} more messages (not kept)", m.1));
        }
        out
    }
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

pub(super) fn load_entry() -> Result<ash::Entry> {
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
pub(super) fn create_instance(
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
pub(super) fn driver_override_hint() -> Option<String> {
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
    // A regular file of at most 1 MiB (a device or a FIFO is named, not read).
    let text = match crate::infile::read(path, crate::infile::MANIFEST) {
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

pub(super) fn messenger_create_info(
    sink: &MessageSink,
) -> vk::DebugUtilsMessengerCreateInfoEXT<'static> {
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

/// A string the driver or the loader gave, as text: invalid UTF-8 replaced, empty when absent
/// or not terminated.
pub(super) fn lossy(s: Option<&CStr>) -> String {
    s.map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

pub(super) fn version_string(v: u32) -> String {
    format!(
        "{}.{}.{}",
        vk::api_version_major(v),
        vk::api_version_minor(v),
        vk::api_version_patch(v)
    )
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
