//! Compute pipelines: one descriptor set (storage buffers, uniform buffers, uniform and storage
//! texel buffers) plus push constants per pipeline, created through a pipeline cache that
//! persists on disk; descriptor sets from pools owned by the context; the workgroup size read
//! back from the SPIR-V.

use super::buffer::Buffer;
use super::cache::{default_cache_dir, write_atomic};
use super::context::Context;
use super::shader::SPIRV_MAGIC;
use anyhow::{anyhow, bail, Context as _, Result};
use ash::vk;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A compute pipeline and the layout objects it owns.
#[derive(Debug)]
pub struct ComputePipeline {
    pub name: String,
    pub pipeline: vk::Pipeline,
    pub layout: vk::PipelineLayout,
    pub set_layout: vk::DescriptorSetLayout,
    /// Workgroup size along x (`local_size_x`), read from the SPIR-V.
    pub local_size_x: u32,
    /// The whole workgroup size.
    pub local_size: [u32; 3],
    /// The descriptor type of each binding 0..n of set 0.
    pub bindings: Vec<vk::DescriptorType>,
    pub push_constant_bytes: u32,
}

/// What a descriptor set binds at one binding: a whole buffer (storage or uniform buffer), or a
/// texel view of one (uniform or storage texel buffer).
#[derive(Clone, Copy, Debug)]
pub enum Resource<'b> {
    Buffer(&'b Buffer),
    Texels(&'b Buffer, vk::BufferView),
    /// A top-level acceleration structure (a context made with
    /// [`super::ContextOptions::ray_query`]; [`super::accel`]).
    Accel(&'b super::accel::AccelStructure),
}

impl Resource<'_> {
    fn buffer(&self) -> &Buffer {
        match self {
            Resource::Buffer(b) | Resource::Texels(b, _) => b,
            Resource::Accel(a) => &a.buffer,
        }
    }
}

impl Context {
    /// A compute pipeline whose set 0 holds `num_storage_buffers` storage buffers at bindings
    /// 0..n and whose push-constant block has `push_constant_bytes` bytes (a multiple of 4, at
    /// most the device limit, 128 on lavapipe). The entry point is `main`.
    pub fn create_compute_pipeline(
        &self,
        name: &str,
        spirv: &[u32],
        num_storage_buffers: u32,
        push_constant_bytes: u32,
    ) -> Result<ComputePipeline> {
        let bindings = vec![vk::DescriptorType::STORAGE_BUFFER; num_storage_buffers as usize];
        self.create_compute_pipeline_with(name, spirv, &bindings, push_constant_bytes)
    }

    /// Refuses a pipeline the device cannot create: more descriptors of a type than its
    /// per-stage limit, or push constants that are too large or not a multiple of 4.
    fn check_pipeline_limits(
        &self,
        name: &str,
        bindings: &[vk::DescriptorType],
        push_constant_bytes: u32,
    ) -> Result<()> {
        let count = |t: vk::DescriptorType| bindings.iter().filter(|&&b| b == t).count() as u32;
        let l = &self.limits;
        for (t, max, what) in [
            (
                vk::DescriptorType::STORAGE_BUFFER,
                l.max_per_stage_descriptor_storage_buffers,
                "storage buffers",
            ),
            (
                vk::DescriptorType::UNIFORM_BUFFER,
                l.max_per_stage_descriptor_uniform_buffers,
                "uniform buffers",
            ),
            (
                vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
                l.max_per_stage_descriptor_sampled_images,
                "uniform texel buffers",
            ),
            (
                vk::DescriptorType::STORAGE_TEXEL_BUFFER,
                l.max_per_stage_descriptor_storage_images,
                "storage texel buffers",
            ),
        ] {
            if count(t) > max {
                bail!(
                    "pipeline \"{name}\": {} {what}, the device allows {max} per stage",
                    count(t)
                );
            }
        }
        let max_push = self.limits.max_push_constants_size;
        if push_constant_bytes > max_push || push_constant_bytes % 4 != 0 {
            bail!("pipeline \"{name}\": push constants of {push_constant_bytes} bytes; need a multiple of 4 and at most {max_push}");
        }
        Ok(())
    }

    /// A compute pipeline whose set 0 has the descriptor types `bindings` at bindings 0..n
    /// (storage buffers, uniform buffers, uniform or storage texel buffers); the device's limits are
    /// checked first ([`Self::check_pipeline_limits`]).
    pub fn create_compute_pipeline_with(
        &self,
        name: &str,
        spirv: &[u32],
        bindings: &[vk::DescriptorType],
        push_constant_bytes: u32,
    ) -> Result<ComputePipeline> {
        let local_size = reflect_local_size(spirv)
            .with_context(|| format!("pipeline \"{name}\": reading the SPIR-V"))?;
        self.check_pipeline_limits(name, bindings, push_constant_bytes)?;
        let d = &self.device;
        let kinds = bindings;
        let bindings: Vec<_> = kinds
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i as u32)
                    .descriptor_type(t)
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        let set_layout = unsafe {
            d.create_descriptor_set_layout(
                &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
                None,
            )
        }
        .with_context(|| format!("vkCreateDescriptorSetLayout for pipeline \"{name}\""))?;
        let ranges = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::COMPUTE)
            .offset(0)
            .size(push_constant_bytes)];
        let set_layouts = [set_layout];
        let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        if push_constant_bytes > 0 {
            layout_info = layout_info.push_constant_ranges(&ranges);
        }
        let layout = match unsafe { d.create_pipeline_layout(&layout_info, None) } {
            Ok(l) => l,
            Err(e) => {
                unsafe { d.destroy_descriptor_set_layout(set_layout, None) };
                return Err(anyhow!(
                    "vkCreatePipelineLayout for pipeline \"{name}\": {e}"
                ));
            }
        };
        let cleanup = || unsafe {
            d.destroy_pipeline_layout(layout, None);
            d.destroy_descriptor_set_layout(set_layout, None);
        };
        let module = match unsafe {
            d.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(spirv), None)
        } {
            Ok(m) => m,
            Err(e) => {
                cleanup();
                return Err(anyhow!("vkCreateShaderModule for pipeline \"{name}\": {e}"));
            }
        };
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main");
        let info = [vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(layout)];
        let created = unsafe { d.create_compute_pipelines(self.pipeline_cache, &info, None) };
        unsafe { d.destroy_shader_module(module, None) };
        let pipeline = match created {
            Ok(p) => p[0],
            Err((_, e)) => {
                cleanup();
                return Err(anyhow!(
                    "vkCreateComputePipelines for pipeline \"{name}\": {e}"
                ));
            }
        };
        self.set_name(pipeline, name);
        self.set_name(layout, name);
        self.set_name(set_layout, name);
        self.registry
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .pipelines
            .insert(pipeline, (layout, set_layout, name.to_string()));
        Ok(ComputePipeline {
            name: name.to_string(),
            pipeline,
            layout,
            set_layout,
            local_size_x: local_size[0],
            local_size,
            bindings: kinds.to_vec(),
            push_constant_bytes,
        })
    }

    /// A descriptor set for `pipeline` with `buffers[i]` at binding i (whole buffers; every
    /// binding a storage buffer). See [`create_descriptor_set_with`](Self::create_descriptor_set_with).
    pub fn create_descriptor_set(
        &self,
        pipeline: &ComputePipeline,
        buffers: &[&Buffer],
    ) -> Result<vk::DescriptorSet> {
        let resources: Vec<Resource> = buffers.iter().map(|b| Resource::Buffer(b)).collect();
        self.create_descriptor_set_with(pipeline, &resources)
    }

    /// A descriptor set for `pipeline` with `resources[i]` at binding i, from a pool owned by
    /// the context: a whole buffer for a storage or uniform buffer binding, a texel view for a
    /// texel-buffer binding. The set belongs to `pipeline`: it is freed when the pipeline is
    /// destroyed.
    pub fn create_descriptor_set_with(
        &self,
        pipeline: &ComputePipeline,
        resources: &[Resource],
    ) -> Result<vk::DescriptorSet> {
        if resources.len() != pipeline.bindings.len() {
            bail!(
                "descriptor set for pipeline \"{}\": {} buffers given, the pipeline has {} bindings",
                pipeline.name,
                resources.len(),
                pipeline.bindings.len()
            );
        }
        for (i, (r, &t)) in resources.iter().zip(&pipeline.bindings).enumerate() {
            let b = r.buffer();
            let is_accel = matches!(r, Resource::Accel(_));
            if is_accel != (t == vk::DescriptorType::ACCELERATION_STRUCTURE_KHR) {
                bail!(
                    "descriptor set for pipeline \"{}\": binding {i} is a {t:?}, and \"{}\" {}",
                    pipeline.name,
                    b.name,
                    if is_accel {
                        "is an acceleration structure"
                    } else {
                        "is not one"
                    }
                );
            }
            if is_accel {
                continue;
            }
            let (usage, max, limit) = match t {
                vk::DescriptorType::STORAGE_BUFFER => (
                    vk::BufferUsageFlags::STORAGE_BUFFER,
                    self.limits.max_storage_buffer_range as u64,
                    "maxStorageBufferRange",
                ),
                vk::DescriptorType::UNIFORM_BUFFER => (
                    vk::BufferUsageFlags::UNIFORM_BUFFER,
                    self.limits.max_uniform_buffer_range as u64,
                    "maxUniformBufferRange",
                ),
                vk::DescriptorType::UNIFORM_TEXEL_BUFFER => {
                    (vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER, u64::MAX, "")
                }
                _ => (vk::BufferUsageFlags::STORAGE_TEXEL_BUFFER, u64::MAX, ""),
            };
            let is_view = matches!(r, Resource::Texels(..));
            let wants_view = matches!(
                t,
                vk::DescriptorType::UNIFORM_TEXEL_BUFFER | vk::DescriptorType::STORAGE_TEXEL_BUFFER
            );
            if is_view != wants_view {
                bail!("descriptor set for pipeline \"{}\": binding {i} (buffer \"{}\") is a {t:?}, which takes {}", pipeline.name, b.name, if wants_view { "a texel view" } else { "a whole buffer" });
            }
            if !b.usage.contains(usage) {
                bail!("descriptor set for pipeline \"{}\": buffer \"{}\" (binding {i}) lacks {usage:?} usage", pipeline.name, b.name);
            }
            if b.vk_size > max {
                bail!(
                    "descriptor set for pipeline \"{}\": buffer \"{}\" (binding {i}) has {} bytes, more than the device's \
                     {limit} of {max} bytes; split it",
                    pipeline.name,
                    b.name,
                    b.vk_size
                );
            }
        }
        let set = self
            .descriptor_pools
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .allocate(
                &self.device,
                (pipeline.pipeline, pipeline.set_layout),
                pipeline.bindings.len() as u32,
                self.features.ray_query,
            )
            .with_context(|| {
                format!(
                    "allocating a descriptor set for pipeline \"{}\"",
                    pipeline.name
                )
            })?;
        let infos: Vec<[vk::DescriptorBufferInfo; 1]> = resources
            .iter()
            .map(|r| {
                [vk::DescriptorBufferInfo::default()
                    .buffer(r.buffer().raw)
                    .offset(0)
                    .range(vk::WHOLE_SIZE)]
            })
            .collect();
        let views: Vec<[vk::BufferView; 1]> = resources
            .iter()
            .map(|r| match r {
                Resource::Texels(_, v) => [*v],
                Resource::Buffer(_) | Resource::Accel(_) => [vk::BufferView::null()],
            })
            .collect();
        let accels: Vec<[vk::AccelerationStructureKHR; 1]> = resources
            .iter()
            .map(|r| match r {
                Resource::Accel(a) => [a.raw],
                _ => [vk::AccelerationStructureKHR::null()],
            })
            .collect();
        let mut accel_writes: Vec<vk::WriteDescriptorSetAccelerationStructureKHR> = accels
            .iter()
            .map(|a| {
                vk::WriteDescriptorSetAccelerationStructureKHR::default().acceleration_structures(a)
            })
            .collect();
        let writes: Vec<_> = resources
            .iter()
            .zip(accel_writes.iter_mut())
            .enumerate()
            .map(|(i, (r, aw))| {
                let w = vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(i as u32)
                    .descriptor_type(pipeline.bindings[i]);
                match r {
                    Resource::Buffer(_) => w.buffer_info(&infos[i]),
                    Resource::Texels(..) => w.texel_buffer_view(&views[i]),
                    Resource::Accel(_) => w.descriptor_count(1).push_next(aw),
                }
            })
            .collect();
        unsafe { self.device.update_descriptor_sets(&writes, &[]) };
        Ok(set)
    }

    /// Testing aid: the number of descriptor pools made so far.
    #[doc(hidden)]
    pub fn debug_descriptor_pool_count(&self) -> usize {
        self.descriptor_pools
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .pools
            .len()
    }

    /// Destroys the pipeline, its layouts and the descriptor sets made for it.
    pub fn destroy_pipeline(&self, p: ComputePipeline) {
        self.destroy_pipeline_ref(&p);
    }

    /// [`destroy_pipeline`](Self::destroy_pipeline) for a pipeline held by reference (e.g. in a
    /// `Drop` impl); destroying the same pipeline twice does nothing the second time.
    pub fn destroy_pipeline_ref(&self, p: &ComputePipeline) {
        let known = self
            .registry
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .pipelines
            .remove(&p.pipeline)
            .is_some();
        if known {
            self.descriptor_pools
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .free_owned(&self.device, p.pipeline);
            unsafe {
                self.device.destroy_pipeline(p.pipeline, None);
                self.device.destroy_pipeline_layout(p.layout, None);
                self.device
                    .destroy_descriptor_set_layout(p.set_layout, None);
            }
        }
    }
}

/// One descriptor pool and what is left in it.
struct Pool {
    pool: vk::DescriptorPool,
    sets_left: u32,
    descriptors_left: u32,
}

/// Descriptor pools of the context (FREE_DESCRIPTOR_SET). Capacity is
/// tracked here, so a pool with room is chosen before allocating; sets are freed when their
/// pipeline is destroyed and their room is reused.
#[derive(Default)]
pub(crate) struct DescriptorPools {
    pools: Vec<Pool>,
    /// The sets of each pipeline: (pool index, set, descriptors).
    owned: HashMap<vk::Pipeline, Vec<(usize, vk::DescriptorSet, u32)>>,
}

impl DescriptorPools {
    const SETS_PER_POOL: u32 = 64;
    const DESCRIPTORS_PER_POOL: u32 = 64 * 24;

    fn allocate(
        &mut self,
        device: &ash::Device,
        (owner, layout): (vk::Pipeline, vk::DescriptorSetLayout),
        descriptors: u32,
        ray_query: bool,
    ) -> Result<vk::DescriptorSet> {
        let layouts = [layout];
        let fits = |p: &Pool| p.sets_left > 0 && p.descriptors_left >= descriptors;
        let mut index = self.pools.iter().position(fits);
        loop {
            let i = match index {
                Some(i) => i,
                None => {
                    let count = Self::DESCRIPTORS_PER_POOL.max(descriptors);
                    // Room for `count` descriptors of each type a pipeline may bind.
                    // Acceleration structures only on a device that has them.
                    let types = [
                        vk::DescriptorType::STORAGE_BUFFER,
                        vk::DescriptorType::UNIFORM_BUFFER,
                        vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
                        vk::DescriptorType::STORAGE_TEXEL_BUFFER,
                        vk::DescriptorType::ACCELERATION_STRUCTURE_KHR,
                    ];
                    let sizes: Vec<_> = types[..if ray_query { 5 } else { 4 }]
                        .iter()
                        .map(|&t| {
                            vk::DescriptorPoolSize::default()
                                .ty(t)
                                .descriptor_count(count)
                        })
                        .collect();
                    let info = vk::DescriptorPoolCreateInfo::default()
                        .flags(vk::DescriptorPoolCreateFlags::FREE_DESCRIPTOR_SET)
                        .max_sets(Self::SETS_PER_POOL)
                        .pool_sizes(&sizes);
                    let pool = unsafe { device.create_descriptor_pool(&info, None) }
                        .context("vkCreateDescriptorPool")?;
                    self.pools.push(Pool {
                        pool,
                        sets_left: Self::SETS_PER_POOL,
                        descriptors_left: count,
                    });
                    self.pools.len() - 1
                }
            };
            let info = vk::DescriptorSetAllocateInfo::default()
                .descriptor_pool(self.pools[i].pool)
                .set_layouts(&layouts);
            match unsafe { device.allocate_descriptor_sets(&info) } {
                Ok(sets) => {
                    let p = &mut self.pools[i];
                    p.sets_left -= 1;
                    p.descriptors_left -= descriptors;
                    self.owned
                        .entry(owner)
                        .or_default()
                        .push((i, sets[0], descriptors));
                    return Ok(sets[0]);
                }
                // Fragmented after frees: treat the pool as full and use a fresh one.
                Err(vk::Result::ERROR_FRAGMENTED_POOL | vk::Result::ERROR_OUT_OF_POOL_MEMORY)
                    if index.is_some() =>
                {
                    self.pools[i].sets_left = 0;
                    index = None;
                }
                Err(e) => return Err(anyhow!("vkAllocateDescriptorSets: {e}")),
            }
        }
    }

    /// Frees the sets made for `owner` and returns their room to the pools.
    fn free_owned(&mut self, device: &ash::Device, owner: vk::Pipeline) {
        for (i, set, descriptors) in self.owned.remove(&owner).unwrap_or_default() {
            let p = &mut self.pools[i];
            if unsafe { device.free_descriptor_sets(p.pool, &[set]) }.is_ok() {
                p.sets_left += 1;
                p.descriptors_left += descriptors;
            }
        }
    }

    pub(crate) fn destroy(self, device: &ash::Device) {
        for p in self.pools {
            unsafe { device.destroy_descriptor_pool(p.pool, None) };
        }
    }
}

/// The on-disk pipeline cache of this device: `<cache>/pipeline-<vendor>-<device>-<uuid>.bin`.
fn pipeline_cache_path(props: &vk::PhysicalDeviceProperties) -> Option<PathBuf> {
    let uuid: String = props
        .pipeline_cache_uuid
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    default_cache_dir().map(|d| {
        d.join(format!(
            "pipeline-{:04x}-{:04x}-{uuid}.bin",
            props.vendor_id, props.device_id
        ))
    })
}

/// Whether `data` starts with a pipeline-cache header (version one) for this exact device and
/// driver build; anything else is not handed to the driver.
fn pipeline_cache_header_matches(data: &[u8], props: &vk::PhysicalDeviceProperties) -> bool {
    if data.len() < 32 {
        return false;
    }
    let word = |i: usize| u32::from_le_bytes(data[i..i + 4].try_into().unwrap());
    let header_len = word(0);
    header_len >= 32
        && header_len as usize <= data.len()
        && word(4) == vk::PipelineCacheHeaderVersion::ONE.as_raw() as u32
        && word(8) == props.vendor_id
        && word(12) == props.device_id
        && data[16..32] == props.pipeline_cache_uuid
}

/// Creates the pipeline cache, seeded from disk when a matching file exists.
pub(crate) fn load_pipeline_cache(
    device: &ash::Device,
    props: &vk::PhysicalDeviceProperties,
) -> Result<(vk::PipelineCache, Option<PathBuf>)> {
    let path = pipeline_cache_path(props);
    let data = path
        .as_ref()
        .and_then(|p| std::fs::read(p).ok())
        .filter(|d| pipeline_cache_header_matches(d, props));
    let create = |initial: &[u8]| unsafe {
        device.create_pipeline_cache(
            &vk::PipelineCacheCreateInfo::default().initial_data(initial),
            None,
        )
    };
    let cache = match data.as_deref().map(create) {
        Some(Ok(c)) => c,
        // A rejected file (driver update, damage): start empty.
        _ => create(&[]).context("vkCreatePipelineCache")?,
    };
    Ok((cache, path))
}

/// Writes the pipeline cache to disk (atomically); failures are reported on stderr only, since
/// this runs during teardown.
pub(crate) fn save_pipeline_cache(device: &ash::Device, cache: vk::PipelineCache, path: &Path) {
    match unsafe { device.get_pipeline_cache_data(cache) } {
        Ok(data) if !data.is_empty() => {
            if let Err(e) = write_atomic(path, &data) {
                eprintln!(
                    "warning: could not save the pipeline cache: {}",
                    crate::errors::chain(&e)
                );
            }
        }
        Ok(_) => {}
        Err(e) => eprintln!("warning: vkGetPipelineCacheData: {e}"),
    }
}

const OP_ENTRY_POINT: u32 = 15;
const OP_EXECUTION_MODE: u32 = 16;
const OP_CONSTANT: u32 = 43;
const OP_CONSTANT_COMPOSITE: u32 = 44;
const OP_SPEC_CONSTANT: u32 = 50;
const OP_SPEC_CONSTANT_COMPOSITE: u32 = 51;
const OP_DECORATE: u32 = 71;
const OP_EXECUTION_MODE_ID: u32 = 331;
const EXECUTION_MODEL_GLCOMPUTE: u32 = 5;
const EXECUTION_MODE_LOCAL_SIZE: u32 = 17;
const EXECUTION_MODE_LOCAL_SIZE_ID: u32 = 38;
const DECORATION_BUILTIN: u32 = 11;
const BUILTIN_WORKGROUP_SIZE: u32 = 25;

/// The workgroup size of the GLCompute entry point `main`, from the module's words: the
/// `WorkgroupSize` built-in constant when present (it overrides the execution mode), else
/// `OpExecutionMode LocalSize`, else `OpExecutionModeId LocalSizeId`. Spec constants give their
/// default values.
pub fn reflect_local_size(spirv: &[u32]) -> Result<[u32; 3]> {
    if spirv.len() < 5 || spirv[0] != SPIRV_MAGIC {
        bail!("not a SPIR-V module (no magic number)");
    }
    let mut entry: Option<u32> = None;
    let mut local_size: HashMap<u32, [u32; 3]> = HashMap::new();
    let mut local_size_id: HashMap<u32, [u32; 3]> = HashMap::new();
    let mut constants: HashMap<u32, u32> = HashMap::new();
    let mut composites: HashMap<u32, Vec<u32>> = HashMap::new();
    let mut workgroup_builtin: Option<u32> = None;
    let mut i = 5;
    while i < spirv.len() {
        let count = (spirv[i] >> 16) as usize;
        let op = spirv[i] & 0xffff;
        if count == 0 || i + count > spirv.len() {
            bail!("malformed SPIR-V: instruction at word {i} has length {count}");
        }
        let w = &spirv[i..i + count];
        match op {
            OP_ENTRY_POINT if count >= 4 && w[1] == EXECUTION_MODEL_GLCOMPUTE => {
                let name_bytes: Vec<u8> = w[3..]
                    .iter()
                    .flat_map(|x| x.to_le_bytes())
                    .take_while(|&b| b != 0)
                    .collect();
                if name_bytes == b"main" {
                    entry = Some(w[2]);
                }
            }
            OP_EXECUTION_MODE if count >= 6 && w[2] == EXECUTION_MODE_LOCAL_SIZE => {
                local_size.insert(w[1], [w[3], w[4], w[5]]);
            }
            OP_EXECUTION_MODE_ID if count >= 6 && w[2] == EXECUTION_MODE_LOCAL_SIZE_ID => {
                local_size_id.insert(w[1], [w[3], w[4], w[5]]);
            }
            OP_DECORATE
                if count >= 4 && w[2] == DECORATION_BUILTIN && w[3] == BUILTIN_WORKGROUP_SIZE =>
            {
                workgroup_builtin = Some(w[1]);
            }
            OP_CONSTANT | OP_SPEC_CONSTANT if count >= 4 => {
                constants.insert(w[2], w[3]);
            }
            OP_CONSTANT_COMPOSITE | OP_SPEC_CONSTANT_COMPOSITE if count >= 3 => {
                composites.insert(w[2], w[3..].to_vec());
            }
            _ => {}
        }
        i += count;
    }
    let entry = entry.ok_or_else(|| anyhow!("no GLCompute entry point named \"main\""))?;
    let constant = |id: u32| {
        constants.get(&id).copied().ok_or_else(|| {
            anyhow!("workgroup size refers to id {id}, which is not a scalar constant")
        })
    };
    let size = if let Some(id) = workgroup_builtin {
        let parts = composites
            .get(&id)
            .ok_or_else(|| anyhow!("WorkgroupSize built-in {id} is not a constant composite"))?;
        if parts.len() != 3 {
            bail!("WorkgroupSize built-in has {} components", parts.len());
        }
        [
            constant(parts[0])?,
            constant(parts[1])?,
            constant(parts[2])?,
        ]
    } else if let Some(s) = local_size.get(&entry) {
        *s
    } else if let Some(ids) = local_size_id.get(&entry) {
        [constant(ids[0])?, constant(ids[1])?, constant(ids[2])?]
    } else {
        bail!("the entry point declares no workgroup size (LocalSize)");
    };
    if size.contains(&0) {
        bail!("workgroup size {size:?} has a zero component");
    }
    Ok(size)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-assembled module: header, OpEntryPoint GLCompute %4 "main", LocalSize 64 2 1.
    fn module(extra: &[u32]) -> Vec<u32> {
        let name = u32::from_le_bytes(*b"main");
        let mut m = vec![SPIRV_MAGIC, 0x0001_0500, 0, 100, 0];
        m.extend_from_slice(&[
            (5 << 16) | OP_ENTRY_POINT,
            EXECUTION_MODEL_GLCOMPUTE,
            4,
            name,
            0,
        ]);
        m.extend_from_slice(&[
            (6 << 16) | OP_EXECUTION_MODE,
            4,
            EXECUTION_MODE_LOCAL_SIZE,
            64,
            2,
            1,
        ]);
        m.extend_from_slice(extra);
        m
    }

    #[test]
    fn local_size_from_execution_mode() {
        assert_eq!(reflect_local_size(&module(&[])).unwrap(), [64, 2, 1]);
    }

    #[test]
    fn workgroup_size_builtin_overrides() {
        let extra = [
            (4 << 16) | OP_DECORATE,
            20,
            DECORATION_BUILTIN,
            BUILTIN_WORKGROUP_SIZE,
            (4 << 16) | OP_SPEC_CONSTANT,
            1,
            10,
            128,
            (4 << 16) | OP_CONSTANT,
            1,
            11,
            1,
            (6 << 16) | OP_SPEC_CONSTANT_COMPOSITE,
            2,
            20,
            10,
            11,
            11,
        ];
        assert_eq!(reflect_local_size(&module(&extra)).unwrap(), [128, 1, 1]);
    }

    #[test]
    fn malformed_modules_are_rejected() {
        assert!(reflect_local_size(&[1, 2, 3]).is_err());
        let mut m = module(&[]);
        m[5] = OP_ENTRY_POINT; // zero length
        assert!(reflect_local_size(&m).is_err());
        let mut m = module(&[]);
        m.truncate(10); // cut inside the execution mode
        assert!(reflect_local_size(&m).is_err());
    }
}
