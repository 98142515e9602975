//! The Vulkan context: it owns the instance (`instance.rs`) and the chosen device
//! (`device.rs`), the one compute queue, the memory allocator and the objects the other files
//! share (pipeline cache, descriptor pools, timestamp query pool), and tears them down in order.
//!
//! Headless: no surface, no window-system extensions. Vulkan 1.2 or newer.

use super::commands::Timestamps;
use super::device::{candidates, choose, create_device, Candidate};
use super::instance::{create_instance, load_entry, messenger_create_info, MessageSink};
use super::pipeline::{load_pipeline_cache, save_pipeline_cache, DescriptorPools};
use anyhow::{anyhow, Context as _, Result};
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::collections::HashMap;
use std::ffi::CString;
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
    /// Enable ray queries on acceleration structures the driver builds (`VK_KHR_ray_query`,
    /// `VK_KHR_acceleration_structure`; [`crate::vk::accel`]); an error where the device lacks
    /// them. Only the traversal benchmark (`brdfwave rays`) asks for them.
    pub ray_query: bool,
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
    /// `shaderFloat64`: the sphere test and sphere points compute in double
    /// (`shaders/bvh.glsl`, `shaders/robust.glsl`), so scenes with spheres need it.
    pub shader_float64: bool,
    /// Ray queries and acceleration structures, with buffer device addresses (asked for with
    /// [`ContextOptions::ray_query`]).
    pub ray_query: bool,
}

/// Timestamp queries available per command buffer.
pub const MAX_TIMESTAMPS: u32 = 4096;

/// Vulkan objects created through the context and not yet destroyed, so that teardown can
/// report (and still destroy) anything the caller forgot.
#[derive(Default)]
pub(crate) struct Registry {
    pub(crate) buffers: HashMap<vk::Buffer, String>,
    pub(crate) pipelines:
        HashMap<vk::Pipeline, (vk::PipelineLayout, vk::DescriptorSetLayout, String)>,
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

        let (device, features) = create_device(
            &instance,
            cand,
            (queue_family, timestamp_valid_bits),
            opts.ray_query,
        )?;
        partial.device = Some(device.clone());
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: pd,
            debug_settings: Default::default(),
            buffer_device_address: features.ray_query,
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
            features,
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
