//! Command recording and submission, barriers and GPU timestamps.
//!
//! A [`Recorder`] wraps one primary command buffer from its own transient command pool (so
//! recorders on different threads never share a pool). Misuse found while recording (push
//! constants larger than the pipeline's block, a dispatch with no pipeline bound, an indirect
//! buffer without INDIRECT_BUFFER usage, too many timestamps) is remembered and returned by
//! [`Context::submit_and_wait`], which then submits nothing.
//!
//! Memory dependencies, all global memory barriers:
//! * at the start of every command buffer: earlier submissions' shader and transfer writes →
//!   this buffer's shader, transfer and indirect-command accesses;
//! * [`Recorder::barrier`]: compute-shader writes → compute-shader reads/writes and
//!   indirect-command reads (the wavefront pattern counter → args → `dispatch_indirect`);
//! * [`Recorder::fill_buffer`]: a barrier before (earlier shader/transfer accesses → the fill)
//!   and after (the fill → shader, transfer and indirect-command accesses), so it needs no
//!   extra `barrier()` on either side;
//! * at the end of every command buffer: all writes → host reads, so mapped downloads after
//!   `submit_and_wait` see the results.

use super::buffer::Buffer;
use super::context::{Context, MAX_TIMESTAMPS};
use super::pipeline::ComputePipeline;
use anyhow::{anyhow, bail, Context as _, Result};
use ash::vk;

/// Timestamp state shared by the context and the recorder that owns the query pool.
#[derive(Default)]
pub(crate) struct Timestamps {
    labels: Vec<String>,
    /// Incremented by every public `begin()`; a recorder only writes while it holds the latest.
    generation: u64,
    /// The recorder holding `generation` was submitted and waited for.
    complete: bool,
}

/// A primary command buffer being recorded; submit it with [`Context::submit_and_wait`].
pub struct Recorder<'a> {
    ctx: &'a Context,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    /// The timestamp generation this recorder owns (None: internal recorder, no timestamps).
    timestamp_generation: Option<u64>,
    bound: Option<String>,
    error: Option<anyhow::Error>,
    /// Submitted and not (successfully) waited for: drop must wait before freeing.
    in_flight: bool,
}

const SHADER_RW: vk::AccessFlags = vk::AccessFlags::from_raw(
    vk::AccessFlags::SHADER_READ.as_raw() | vk::AccessFlags::SHADER_WRITE.as_raw(),
);
const TRANSFER_RW: vk::AccessFlags = vk::AccessFlags::from_raw(
    vk::AccessFlags::TRANSFER_READ.as_raw() | vk::AccessFlags::TRANSFER_WRITE.as_raw(),
);
const WRITES: vk::AccessFlags = vk::AccessFlags::from_raw(
    vk::AccessFlags::SHADER_WRITE.as_raw() | vk::AccessFlags::TRANSFER_WRITE.as_raw(),
);
const COMPUTE_TRANSFER: vk::PipelineStageFlags = vk::PipelineStageFlags::from_raw(
    vk::PipelineStageFlags::COMPUTE_SHADER.as_raw() | vk::PipelineStageFlags::TRANSFER.as_raw(),
);
const ALL_USES: vk::PipelineStageFlags = vk::PipelineStageFlags::from_raw(
    vk::PipelineStageFlags::COMPUTE_SHADER.as_raw()
        | vk::PipelineStageFlags::TRANSFER.as_raw()
        | vk::PipelineStageFlags::DRAW_INDIRECT.as_raw(),
);

impl Context {
    /// Starts recording. Resets the timestamp query pool: timestamps written by this recorder
    /// replace the previous ones (read them with [`read_timestamps`](Self::read_timestamps)
    /// after [`submit_and_wait`](Self::submit_and_wait)).
    pub fn begin(&self) -> Result<Recorder<'_>> {
        let mut rec = self.begin_raw()?;
        if self.query_pool != vk::QueryPool::null() {
            let mut ts = self.timestamps.lock().unwrap_or_else(|e| e.into_inner());
            ts.labels.clear();
            ts.generation += 1;
            ts.complete = false;
            rec.timestamp_generation = Some(ts.generation);
            unsafe {
                self.device
                    .cmd_reset_query_pool(rec.cmd, self.query_pool, 0, MAX_TIMESTAMPS)
            };
        }
        Ok(rec)
    }

    /// A recorder for internal transfers (staging copies): leaves the timestamps alone.
    pub(crate) fn begin_internal(&self) -> Result<Recorder<'_>> {
        self.begin_raw()
    }

    fn begin_raw(&self) -> Result<Recorder<'_>> {
        let d = &self.device;
        let info = vk::CommandPoolCreateInfo::default()
            .flags(vk::CommandPoolCreateFlags::TRANSIENT)
            .queue_family_index(self.queue_family);
        let pool = unsafe { d.create_command_pool(&info, None) }.context("vkCreateCommandPool")?;
        // From here on the recorder's Drop destroys the pool.
        let mut rec = Recorder {
            ctx: self,
            pool,
            cmd: vk::CommandBuffer::null(),
            timestamp_generation: None,
            bound: None,
            error: None,
            in_flight: false,
        };
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        rec.cmd =
            unsafe { d.allocate_command_buffers(&alloc) }.context("vkAllocateCommandBuffers")?[0];
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        unsafe { d.begin_command_buffer(rec.cmd, &begin) }.context("vkBeginCommandBuffer")?;
        rec.memory_barrier(
            COMPUTE_TRANSFER,
            WRITES,
            ALL_USES,
            SHADER_RW | TRANSFER_RW | vk::AccessFlags::INDIRECT_COMMAND_READ,
        );
        Ok(rec)
    }

    /// Ends the recording, submits it to the queue and waits for it to finish. Returns the first
    /// recording error instead, without submitting.
    pub fn submit_and_wait(&self, mut rec: Recorder) -> Result<()> {
        if !std::ptr::eq(rec.ctx, self) {
            bail!("submit_and_wait: the recorder belongs to another context");
        }
        if let Some(e) = rec.error.take() {
            return Err(e.context("recording the command buffer (nothing was submitted)"));
        }
        let d = &self.device;
        rec.memory_barrier(
            vk::PipelineStageFlags::ALL_COMMANDS,
            WRITES,
            vk::PipelineStageFlags::HOST,
            vk::AccessFlags::HOST_READ,
        );
        unsafe { d.end_command_buffer(rec.cmd) }.context("vkEndCommandBuffer")?;
        let fence = unsafe { d.create_fence(&vk::FenceCreateInfo::default(), None) }
            .context("vkCreateFence")?;
        let cmds = [rec.cmd];
        let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
        let submitted = {
            let _queue = self.queue_lock.lock().unwrap_or_else(|e| e.into_inner());
            unsafe { d.queue_submit(self.queue, &submit, fence) }
        };
        if let Err(e) = submitted {
            unsafe { d.destroy_fence(fence, None) };
            return Err(anyhow!("vkQueueSubmit: {e}"));
        }
        rec.in_flight = true;
        let waited = unsafe { d.wait_for_fences(&[fence], true, u64::MAX) };
        unsafe { d.destroy_fence(fence, None) };
        waited.context("vkWaitForFences (GPU work failed or the device was lost)")?;
        rec.in_flight = false;
        if let Some(g) = rec.timestamp_generation {
            let mut ts = self.timestamps.lock().unwrap_or_else(|e| e.into_inner());
            if ts.generation == g {
                ts.complete = true;
            }
        }
        Ok(())
    }

    /// The timestamps of the last recorder started with [`begin`](Self::begin), after
    /// [`submit_and_wait`](Self::submit_and_wait): `(label, seconds since the first timestamp)`
    /// in recording order. Empty when nothing was stamped or the queue has no timestamps.
    pub fn read_timestamps(&self) -> Result<Vec<(String, f64)>> {
        let ts = self.timestamps.lock().unwrap_or_else(|e| e.into_inner());
        if ts.labels.is_empty() {
            return Ok(Vec::new());
        }
        if !ts.complete {
            bail!("read_timestamps: the command buffer holding these timestamps was not submitted and waited for (call submit_and_wait first)");
        }
        let mut ticks = vec![0u64; ts.labels.len()];
        unsafe {
            self.device.get_query_pool_results(
                self.query_pool,
                0,
                &mut ticks,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .context("vkGetQueryPoolResults (timestamps)")?;
        let mask = if self.timestamp_valid_bits >= 64 {
            u64::MAX
        } else {
            (1u64 << self.timestamp_valid_bits) - 1
        };
        let t0 = ticks[0] & mask;
        let period = self.timestamp_period_ns as f64 * 1e-9;
        Ok(ts
            .labels
            .iter()
            .zip(&ticks)
            .map(|(l, &t)| {
                (
                    l.clone(),
                    ((t & mask).wrapping_sub(t0) & mask) as f64 * period,
                )
            })
            .collect())
    }
}

impl Recorder<'_> {
    /// The raw command buffer, for commands this wrapper does not offer.
    pub fn raw(&self) -> vk::CommandBuffer {
        self.cmd
    }

    fn fail(&mut self, e: anyhow::Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
    }

    fn memory_barrier(
        &mut self,
        src: vk::PipelineStageFlags,
        src_access: vk::AccessFlags,
        dst: vk::PipelineStageFlags,
        dst_access: vk::AccessFlags,
    ) {
        let b = [vk::MemoryBarrier::default()
            .src_access_mask(src_access)
            .dst_access_mask(dst_access)];
        unsafe {
            self.ctx.device.cmd_pipeline_barrier(
                self.cmd,
                src,
                dst,
                vk::DependencyFlags::empty(),
                &b,
                &[],
                &[],
            )
        };
    }

    /// Binds the pipeline and its descriptor set (set 0).
    pub fn bind(&mut self, p: &ComputePipeline, set: vk::DescriptorSet) {
        let d = &self.ctx.device;
        unsafe {
            d.cmd_bind_pipeline(self.cmd, vk::PipelineBindPoint::COMPUTE, p.pipeline);
            if set != vk::DescriptorSet::null() {
                d.cmd_bind_descriptor_sets(
                    self.cmd,
                    vk::PipelineBindPoint::COMPUTE,
                    p.layout,
                    0,
                    &[set],
                    &[],
                );
            }
        }
        self.bound = Some(p.name.clone());
    }

    /// Sets the push constants of `p` (offset 0) from `value`, whose size must be a multiple of
    /// 4 and at most the pipeline's push-constant block.
    pub fn push_constants<T: bytemuck::Pod>(&mut self, p: &ComputePipeline, value: &T) {
        let bytes = bytemuck::bytes_of(value);
        if bytes.len() as u32 > p.push_constant_bytes || bytes.len() % 4 != 0 || bytes.is_empty() {
            let n = bytes.len();
            return self.fail(anyhow!(
                "push_constants for pipeline \"{}\": {n} bytes, but its block has {} (and the size must be a nonzero multiple of 4)",
                p.name,
                p.push_constant_bytes
            ));
        }
        unsafe {
            self.ctx.device.cmd_push_constants(
                self.cmd,
                p.layout,
                vk::ShaderStageFlags::COMPUTE,
                0,
                bytes,
            )
        };
    }

    fn check_bound(&mut self, what: &str) -> bool {
        if self.bound.is_none() {
            self.fail(anyhow!("{what} with no pipeline bound (call bind first)"));
            return false;
        }
        true
    }

    /// Dispatches `groups_x × groups_y × groups_z` workgroups of the bound pipeline.
    pub fn dispatch(&mut self, groups_x: u32, groups_y: u32, groups_z: u32) {
        if !self.check_bound("dispatch") {
            return;
        }
        let max = self.ctx.limits.max_compute_work_group_count;
        if groups_x > max[0] || groups_y > max[1] || groups_z > max[2] {
            let name = self.bound.clone().unwrap_or_default();
            return self.fail(anyhow!("dispatch of \"{name}\": {groups_x}×{groups_y}×{groups_z} workgroups exceed the device limit {max:?}"));
        }
        unsafe {
            self.ctx
                .device
                .cmd_dispatch(self.cmd, groups_x, groups_y, groups_z)
        };
    }

    /// Dispatches with the workgroup counts in `args` at `offset` (a `VkDispatchIndirectCommand`:
    /// three u32). `args` needs INDIRECT_BUFFER usage; a compute shader writing it earlier in the
    /// same command buffer needs a [`barrier`](Self::barrier) in between.
    pub fn dispatch_indirect(&mut self, args: &Buffer, offset: u64) {
        if !self.check_bound("dispatch_indirect") {
            return;
        }
        if !args.usage.contains(vk::BufferUsageFlags::INDIRECT_BUFFER) {
            return self.fail(anyhow!(
                "dispatch_indirect: buffer \"{}\" lacks INDIRECT_BUFFER usage",
                args.name
            ));
        }
        if offset % 4 != 0 || offset + 12 > args.vk_size {
            return self.fail(anyhow!(
                "dispatch_indirect: offset {offset} in buffer \"{}\" ({} bytes) is not 4-aligned or leaves no room for 12 bytes",
                args.name,
                args.vk_size
            ));
        }
        unsafe {
            self.ctx
                .device
                .cmd_dispatch_indirect(self.cmd, args.raw, offset)
        };
    }

    /// Global memory barrier: compute-shader writes before it are visible to compute-shader
    /// reads and writes and to indirect-command reads after it.
    pub fn barrier(&mut self) {
        self.memory_barrier(
            vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::AccessFlags::SHADER_WRITE,
            vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::DRAW_INDIRECT,
            SHADER_RW | vk::AccessFlags::INDIRECT_COMMAND_READ,
        );
    }

    /// Fills the whole buffer with the 32-bit `value` (`vkCmdFillBuffer`). Ordered after earlier
    /// shader and transfer accesses and before later shader, transfer and indirect-command
    /// accesses by its own barriers; no `barrier()` needed around it.
    pub fn fill_buffer(&mut self, buf: &Buffer, value: u32) {
        self.memory_barrier(
            COMPUTE_TRANSFER,
            WRITES,
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::TRANSFER_WRITE,
        );
        unsafe {
            self.ctx
                .device
                .cmd_fill_buffer(self.cmd, buf.raw, 0, vk::WHOLE_SIZE, value)
        };
        self.memory_barrier(
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::TRANSFER_WRITE,
            ALL_USES,
            SHADER_RW | TRANSFER_RW | vk::AccessFlags::INDIRECT_COMMAND_READ,
        );
    }

    /// Copies `size` bytes from the start of `src` to the start of `dst`, with barriers like
    /// [`fill_buffer`](Self::fill_buffer).
    pub fn copy_buffer(&mut self, src: &Buffer, dst: &Buffer, size: u64) {
        if size > src.vk_size || size > dst.vk_size {
            return self.fail(anyhow!(
                "copy of {size} bytes from \"{}\" to \"{}\": larger than a buffer",
                src.name,
                dst.name
            ));
        }
        if size == 0 {
            return;
        }
        self.memory_barrier(
            COMPUTE_TRANSFER,
            WRITES,
            vk::PipelineStageFlags::TRANSFER,
            TRANSFER_RW,
        );
        let region = [vk::BufferCopy::default().size(size)];
        unsafe {
            self.ctx
                .device
                .cmd_copy_buffer(self.cmd, src.raw, dst.raw, &region)
        };
        self.memory_barrier(
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::TRANSFER_WRITE,
            ALL_USES,
            SHADER_RW | TRANSFER_RW | vk::AccessFlags::INDIRECT_COMMAND_READ,
        );
    }

    /// How many more [`timestamp`](Self::timestamp)s this command buffer can take
    /// ([`MAX_TIMESTAMPS`] in all; unlimited, as `u32::MAX`, where the device has none).
    pub fn timestamps_left(&self) -> u32 {
        if self.ctx.query_pool == vk::QueryPool::null() || self.timestamp_generation.is_none() {
            return u32::MAX;
        }
        let ts = self
            .ctx
            .timestamps
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        MAX_TIMESTAMPS.saturating_sub(ts.labels.len() as u32)
    }

    /// Writes a timestamp once all earlier commands have completed, under `label` (labels are
    /// kept in order and need not be unique). A no-op on queues without timestamps.
    pub fn timestamp(&mut self, label: &str) {
        let ctx = self.ctx;
        if ctx.query_pool == vk::QueryPool::null() {
            return;
        }
        let Some(generation) = self.timestamp_generation else {
            return self.fail(anyhow!("timestamp(\"{label}\") on an internal recorder"));
        };
        let mut ts = ctx.timestamps.lock().unwrap_or_else(|e| e.into_inner());
        if ts.generation != generation {
            drop(ts);
            return self.fail(anyhow!(
                "timestamp(\"{label}\"): a newer begin() took over the timestamp queries"
            ));
        }
        let index = ts.labels.len() as u32;
        if index >= MAX_TIMESTAMPS {
            drop(ts);
            return self.fail(anyhow!("timestamp(\"{label}\"): more than {MAX_TIMESTAMPS} timestamps in one command buffer"));
        }
        ts.labels.push(label.to_string());
        drop(ts);
        unsafe {
            ctx.device.cmd_write_timestamp(
                self.cmd,
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                ctx.query_pool,
                index,
            )
        };
    }
}

impl Drop for Recorder<'_> {
    fn drop(&mut self) {
        let d = &self.ctx.device;
        unsafe {
            if self.in_flight {
                // Submitted but the wait failed: do not free what the GPU may still use.
                let _ = d.device_wait_idle();
            }
            // Frees the command buffer with the pool.
            d.destroy_command_pool(self.pool, None);
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn timestamp_mask_wraps() {
        // The subtraction used by read_timestamps, for a 36-bit counter that wrapped.
        let bits = 36u32;
        let mask = (1u64 << bits) - 1;
        let (t0, t1) = (mask - 5, 10u64);
        assert_eq!(t1.wrapping_sub(t0) & mask, 16);
    }
}
