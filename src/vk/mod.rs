//! The Vulkan backend layer (ash 0.38, gpu-allocator 0.28, shaderc 0.10), in the style of
//! kajiya-backend: a headless [`Context`] (instance, validation, device, queue, allocator),
//! [`Buffer`]s, run-time GLSL compilation with an on-disk SPIR-V cache ([`ShaderCompiler`]),
//! [`ComputePipeline`]s with one descriptor set of storage buffers plus push constants, and a
//! [`Recorder`] for command buffers with barriers, indirect dispatch and timestamps.
//!
//! One Vulkan object family per file: `instance.rs` (loader, instance, validation messages, why
//! Vulkan could not start), `device.rs` (the physical device choice), `context.rs` (the logical
//! device, queue, allocator, shared objects and teardown), `buffer.rs`,
//! `shader.rs` (GLSL → SPIR-V), `pipeline.rs` (pipelines, descriptor sets, pipeline cache),
//! `commands.rs` (recording, submission, timestamps), `cache.rs` (on-disk cache helpers),
//! `accel.rs` (the driver's own acceleration structures, for the traversal benchmark).
//!
//! A typical kernel launch:
//! ```no_run
//! # use brdfwave::vk::*;
//! # fn main() -> anyhow::Result<()> {
//! let ctx = Context::new(&ContextOptions { device: None, validation: true, ray_query: false })?;
//! let spirv = ShaderCompiler::new()?.compile("wavefront/generate.comp", &[], &[])?;
//! let pipeline = ctx.create_compute_pipeline("generate", &spirv, 1, 16)?;
//! let buf = ctx.create_buffer_with_data("data", &[0u32; 256], ash::vk::BufferUsageFlags::STORAGE_BUFFER)?;
//! let set = ctx.create_descriptor_set(&pipeline, &[&buf])?;
//! let mut rec = ctx.begin()?;
//! rec.bind(&pipeline, set);
//! rec.push_constants(&pipeline, &[0u32; 4]);
//! rec.dispatch(256u32.div_ceil(pipeline.local_size_x), 1, 1);
//! ctx.submit_and_wait(rec)?;
//! let data: Vec<u32> = ctx.download(&buf)?;
//! # ctx.destroy_buffer(buf); ctx.destroy_pipeline(pipeline); Ok(()) }
//! ```

pub mod accel;
mod buffer;
pub mod cache;
mod commands;
mod context;
mod device;
mod instance;
mod pipeline;
mod shader;

pub use buffer::Buffer;
pub use commands::Recorder;
pub use context::{Context, ContextOptions, DeviceFeatures, MAX_TIMESTAMPS};
pub use instance::require_validation;
pub use pipeline::{reflect_local_size, ComputePipeline, Resource};
pub use shader::{CompileStats, CompiledShader, ShaderCompiler, EMBEDDED_SHADERS, SHADER_DIR_ENV};

/// Re-exported so that users of this module name the same versions.
pub use ash::vk as raw;
pub use gpu_allocator::MemoryLocation;
