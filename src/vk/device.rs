//! Choosing the physical device: every device the instance sees, whether it is usable
//! (Vulkan 1.2, a compute queue), its one-line description (`brdfwave devices`) and the choice
//! by name or by kind (lavapipe first).

use super::instance::{driver_override_hint, lossy, version_string, INSTALL_HINT};
use super::DeviceFeatures;
use anyhow::{anyhow, bail, Context as _, Result};
use ash::vk;

/// One physical device as seen at start-up.
pub(super) struct Candidate {
    pub(super) pd: vk::PhysicalDevice,
    pub(super) name: String,
    pub(super) kind: vk::PhysicalDeviceType,
    pub(super) driver_id: vk::DriverId,
    pub(super) driver_name: String,
    pub(super) api_version: u32,
    /// (family index, timestampValidBits) of the queue family used for compute.
    pub(super) compute_family: Option<(u32, u32)>,
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

    pub(super) fn describe(&self) -> String {
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

pub(super) fn candidates(instance: &ash::Instance) -> Result<Vec<Candidate>> {
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
pub(super) fn choose(cands: &[Candidate], wanted: Option<&str>) -> Result<usize> {
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

/// The device extensions [`super::ContextOptions::ray_query`] enables.
const RAY_QUERY_EXTENSIONS: [&std::ffi::CStr; 3] = [
    ash::khr::acceleration_structure::NAME,
    ash::khr::ray_query::NAME,
    ash::khr::deferred_host_operations::NAME,
];

/// Why `cand` cannot trace ray queries, if it cannot: the extensions or features it lacks.
fn ray_query_missing(instance: &ash::Instance, cand: &Candidate) -> Result<Option<String>> {
    let pd = cand.pd;
    let have = unsafe { instance.enumerate_device_extension_properties(pd) }
        .context("vkEnumerateDeviceExtensionProperties")?;
    let mut missing: Vec<String> = RAY_QUERY_EXTENSIONS
        .iter()
        .filter(|&&want| {
            !have
                .iter()
                .any(|e| e.extension_name_as_c_str().ok() == Some(want))
        })
        .map(|e| e.to_string_lossy().into_owned())
        .collect();
    if missing.is_empty() {
        let mut rq = vk::PhysicalDeviceRayQueryFeaturesKHR::default();
        let mut accel = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default();
        let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut f2 = vk::PhysicalDeviceFeatures2::default()
            .push_next(&mut rq)
            .push_next(&mut accel)
            .push_next(&mut f12);
        unsafe { instance.get_physical_device_features2(pd, &mut f2) };
        for (name, on) in [
            ("rayQuery", rq.ray_query),
            ("accelerationStructure", accel.acceleration_structure),
            ("bufferDeviceAddress", f12.buffer_device_address),
        ] {
            if on != vk::TRUE {
                missing.push(format!("the {name} feature"));
            }
        }
    }
    Ok((!missing.is_empty()).then(|| missing.join(", ")))
}

/// Creates the logical device on `cand` with one queue of `queue_family`, enabling the
/// optional features it supports ([`DeviceFeatures`]) and nothing else; with `ray_query`, also
/// ray queries and acceleration structures, or an error that names what the device lacks.
pub(super) fn create_device(
    instance: &ash::Instance,
    cand: &Candidate,
    (queue_family, timestamp_valid_bits): (u32, u32),
    ray_query: bool,
) -> Result<(ash::Device, DeviceFeatures)> {
    let pd = cand.pd;
    if ray_query {
        if let Some(missing) = ray_query_missing(instance, cand)? {
            bail!(
                "{} ({}) cannot trace ray queries: it lacks {missing}. Mesa's lavapipe has them \
                 from Mesa 24.1 (Debian 12's bookworm-backports carries Mesa 25.0); point \
                 VK_ICD_FILENAMES at such a driver's lvp_icd.json",
                cand.name,
                cand.driver_name
            );
        }
    }
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
    let (scalar, int8, float64) = {
        let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f12);
        unsafe { instance.get_physical_device_features2(pd, &mut f2) };
        let float64 = f2.features.shader_float64 == vk::TRUE;
        (
            f12.scalar_block_layout == vk::TRUE,
            f12.storage_buffer8_bit_access == vk::TRUE,
            float64,
        )
    };
    let mut f12 = vk::PhysicalDeviceVulkan12Features::default()
        .scalar_block_layout(scalar)
        .storage_buffer8_bit_access(int8)
        .buffer_device_address(ray_query);
    let core = vk::PhysicalDeviceFeatures::default().shader_float64(float64);
    let mut rq = vk::PhysicalDeviceRayQueryFeaturesKHR::default().ray_query(true);
    let mut accel =
        vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default().acceleration_structure(true);
    let mut f2 = vk::PhysicalDeviceFeatures2::default()
        .features(core)
        .push_next(&mut f12);
    if ray_query {
        f2 = f2.push_next(&mut rq).push_next(&mut accel);
    }
    let priorities = [1.0f32];
    let queue_info = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(queue_family)
        .queue_priorities(&priorities)];
    let extensions: Vec<*const std::ffi::c_char> = match ray_query {
        true => RAY_QUERY_EXTENSIONS.iter().map(|e| e.as_ptr()).collect(),
        false => Vec::new(),
    };
    let device_info = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queue_info)
        .enabled_extension_names(&extensions)
        .push_next(&mut f2);
    let device = unsafe { instance.create_device(pd, &device_info, None) }
        .with_context(|| format!("vkCreateDevice on {}", cand.name))?;
    let features = DeviceFeatures {
        scalar_block_layout: scalar,
        storage_buffer_8bit_access: int8,
        timestamps: timestamp_valid_bits > 0,
        subgroup_ballot,
        shader_float64: float64,
        ray_query,
    };
    Ok((device, features))
}
