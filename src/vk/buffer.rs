//! Buffers: creation through gpu-allocator, upload and download (a mapped copy when the memory
//! is host-visible, a staging buffer and a copy command otherwise), destruction.

use super::context::Context;
use anyhow::{anyhow, bail, Context as _, Result};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;
use std::sync::atomic::Ordering;

/// A buffer and its memory. Destroy it with [`Context::destroy_buffer`]; a buffer dropped
/// without that is reported as a leak when the context goes.
#[derive(Debug)]
pub struct Buffer {
    pub raw: vk::Buffer,
    /// The size asked for, in bytes (upload and download work on this many bytes).
    pub size: u64,
    pub name: String,
    /// The usage given plus TRANSFER_SRC | TRANSFER_DST, which every buffer gets.
    pub usage: vk::BufferUsageFlags,
    pub location: MemoryLocation,
    /// The size of the Vulkan buffer: `size`, or 16 when `size` is 0 (Vulkan needs nonzero).
    pub(crate) vk_size: u64,
    allocation: Option<Allocation>,
}

impl Context {
    /// A buffer of `size` bytes. Every buffer also gets TRANSFER_SRC and TRANSFER_DST usage, so
    /// that [`upload`](Self::upload), [`download`](Self::download) and `fill_buffer` always work.
    pub fn create_buffer(
        &self,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Result<Buffer> {
        let vk_size = if size == 0 { 16 } else { size };
        let usage = usage | vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST;
        let info = vk::BufferCreateInfo::default()
            .size(vk_size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        let raw = unsafe { self.device.create_buffer(&info, None) }
            .with_context(|| format!("vkCreateBuffer \"{name}\" ({size} bytes)"))?;
        let requirements = unsafe { self.device.get_buffer_memory_requirements(raw) };
        let allocation = self.allocator().allocate(&AllocationCreateDesc {
            name,
            requirements,
            location,
            linear: true,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        });
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                unsafe { self.device.destroy_buffer(raw, None) };
                bail!("allocating {size} bytes ({location:?}) for buffer \"{name}\": {e}");
            }
        };
        if let Err(e) = unsafe {
            self.device
                .bind_buffer_memory(raw, allocation.memory(), allocation.offset())
        } {
            unsafe { self.device.destroy_buffer(raw, None) };
            let _ = self.allocator().free(allocation);
            bail!("vkBindBufferMemory \"{name}\": {e}");
        }
        self.set_name(raw, name);
        self.registry
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .buffers
            .insert(raw, name.to_string());
        Ok(Buffer {
            raw,
            size,
            name: name.to_string(),
            usage,
            location,
            vk_size,
            allocation: Some(allocation),
        })
    }

    /// A device-local buffer holding `data`.
    pub fn create_buffer_with_data<T: bytemuck::Pod>(
        &self,
        name: &str,
        data: &[T],
        usage: vk::BufferUsageFlags,
    ) -> Result<Buffer> {
        let buf = self.create_buffer(
            name,
            std::mem::size_of_val(data) as u64,
            usage,
            MemoryLocation::GpuOnly,
        )?;
        if let Err(e) = self.upload(&buf, data) {
            self.destroy_buffer(buf);
            return Err(e);
        }
        Ok(buf)
    }

    /// A device-local buffer of `len` elements, written by `fill`: straight into the buffer's
    /// memory when it is mapped (host-visible, as all of lavapipe's memory is), so that the data
    /// never has a second, host-side copy (the triangle buffer of a million triangles is 48 MB);
    /// otherwise into a host vector that is [`upload`](Self::upload)ed. `fill` is given
    /// zeroed elements.
    pub fn create_buffer_filled<T: bytemuck::Pod>(
        &self,
        name: &str,
        len: usize,
        usage: vk::BufferUsageFlags,
        fill: impl FnOnce(&mut [T]),
    ) -> Result<Buffer> {
        let bytes = len
            .checked_mul(std::mem::size_of::<T>())
            .ok_or_else(|| anyhow!("buffer \"{name}\": {len} elements overflow its size"))?;
        let buf = self.create_buffer(name, bytes as u64, usage, MemoryLocation::GpuOnly)?;
        let alloc = buf.allocation.as_ref().expect("live buffer has memory");
        let direct = bytes > 0
            && alloc.mapped_ptr().is_some()
            && !self.force_staging.load(Ordering::Relaxed);
        let result = match direct {
            true => Self::mapping(alloc, bytes).and_then(|dst| {
                if dst as usize % std::mem::align_of::<T>() != 0 {
                    bail!("the mapping is not aligned for its elements");
                }
                // SAFETY: the mapping holds `bytes` bytes (checked), aligned for T (checked);
                // zeroing them first makes every element a valid T (T is Pod); no GPU work uses
                // a buffer just made.
                let elements = unsafe {
                    std::ptr::write_bytes(dst, 0, bytes);
                    std::slice::from_raw_parts_mut(dst.cast::<T>(), len)
                };
                fill(elements);
                if let Some(range) = self.non_coherent_range(alloc) {
                    unsafe { self.device.flush_mapped_memory_ranges(&[range]) }
                        .context("vkFlushMappedMemoryRanges")?;
                }
                Ok(())
            }),
            false => {
                let mut data = vec![T::zeroed(); len];
                fill(&mut data);
                self.upload(&buf, &data)
            }
        };
        if let Err(e) = result {
            self.destroy_buffer(buf);
            return Err(e.context(format!("filling buffer \"{name}\"")));
        }
        Ok(buf)
    }

    /// Copies `data` to the start of `buf` (at most `buf.size` bytes). Call it while no
    /// submitted work uses the buffer (every submission here is waited for, so: not between
    /// `begin` and `submit_and_wait` of a recording that uses it).
    pub fn upload<T: bytemuck::Pod>(&self, buf: &Buffer, data: &[T]) -> Result<()> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        if bytes.len() as u64 > buf.size {
            bail!(
                "upload to buffer \"{}\": {} bytes do not fit in its {} bytes",
                buf.name,
                bytes.len(),
                buf.size
            );
        }
        if bytes.is_empty() {
            return Ok(());
        }
        let alloc = buf.allocation.as_ref().expect("live buffer has memory");
        if alloc.mapped_ptr().is_some() && !self.force_staging.load(Ordering::Relaxed) {
            return self
                .write_mapped(alloc, bytes)
                .with_context(|| format!("upload to buffer \"{}\"", buf.name));
        }
        let staging = self.create_buffer(
            &format!("{} (staging)", buf.name),
            bytes.len() as u64,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::CpuToGpu,
        )?;
        let result = (|| {
            let salloc = staging.allocation.as_ref().expect("live buffer has memory");
            if salloc.mapped_ptr().is_none() {
                bail!("the staging memory is not host-visible");
            }
            self.write_mapped(salloc, bytes)?;
            let mut rec = self.begin_internal()?;
            rec.copy_buffer(&staging, buf, bytes.len() as u64);
            self.submit_and_wait(rec)
        })();
        self.destroy_buffer(staging);
        result
            .with_context(|| format!("upload to buffer \"{}\" through a staging buffer", buf.name))
    }

    /// The contents of `buf` (`buf.size` bytes, which must be a multiple of `size_of::<T>()`).
    /// Call it after the work writing the buffer was submitted and waited for.
    pub fn download<T: bytemuck::Pod>(&self, buf: &Buffer) -> Result<Vec<T>> {
        let elem = std::mem::size_of::<T>() as u64;
        if elem == 0 || buf.size % elem != 0 {
            bail!("download of buffer \"{}\": its {} bytes are not a whole number of {elem}-byte elements", buf.name, buf.size);
        }
        let mut out: Vec<T> = vec![T::zeroed(); (buf.size / elem) as usize];
        let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut out);
        if bytes.is_empty() {
            return Ok(out);
        }
        let alloc = buf.allocation.as_ref().expect("live buffer has memory");
        if alloc.mapped_ptr().is_some() && !self.force_staging.load(Ordering::Relaxed) {
            self.read_mapped(alloc, bytes)
                .with_context(|| format!("download of buffer \"{}\"", buf.name))?;
            return Ok(out);
        }
        let staging = self.create_buffer(
            &format!("{} (readback)", buf.name),
            buf.size,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuToCpu,
        )?;
        let result = (|| {
            let mut rec = self.begin_internal()?;
            rec.copy_buffer(buf, &staging, buf.size);
            self.submit_and_wait(rec)?;
            let salloc = staging.allocation.as_ref().expect("live buffer has memory");
            if salloc.mapped_ptr().is_none() {
                bail!("the readback memory is not host-visible");
            }
            self.read_mapped(salloc, bytes)
        })();
        self.destroy_buffer(staging);
        result.with_context(|| {
            format!(
                "download of buffer \"{}\" through a staging buffer",
                buf.name
            )
        })?;
        Ok(out)
    }

    /// Testing aid: send every upload and download through a staging buffer and a copy
    /// command, as on a GPU whose device-local memory is not host-visible (lavapipe maps all
    /// its memory, so the staging path is otherwise never taken there).
    #[doc(hidden)]
    pub fn debug_force_staging(&self, on: bool) {
        self.force_staging.store(on, Ordering::Relaxed);
    }

    /// Frees the buffer and its memory. The buffer must not be in use by unfinished work.
    pub fn destroy_buffer(&self, mut buf: Buffer) {
        self.registry
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .buffers
            .remove(&buf.raw);
        unsafe { self.device.destroy_buffer(buf.raw, None) };
        if let Some(a) = buf.allocation.take() {
            if let Err(e) = self.allocator().free(a) {
                eprintln!(
                    "warning: freeing the memory of buffer \"{}\": {e}",
                    buf.name
                );
            }
        }
    }

    /// A texel view of the whole of `buf` in `format`, for a uniform or storage texel-buffer
    /// binding (the buffer needs the matching usage). Destroy it with
    /// [`destroy_buffer_view`](Self::destroy_buffer_view) before the buffer.
    pub fn create_buffer_view(&self, buf: &Buffer, format: vk::Format) -> Result<vk::BufferView> {
        let texel = match format {
            vk::Format::R32_UINT | vk::Format::R32_SFLOAT => 4,
            vk::Format::R32G32_UINT | vk::Format::R32G32_SFLOAT => 8,
            vk::Format::R32G32B32A32_UINT | vk::Format::R32G32B32A32_SFLOAT => 16,
            _ => bail!(
                "buffer view of \"{}\": format {format:?} is not supported",
                buf.name
            ),
        };
        let texels = buf.vk_size / texel;
        let max = self.limits.max_texel_buffer_elements as u64;
        if texels > max {
            bail!(
                "buffer \"{}\" holds {texels} texels, more than the device's maxTexelBufferElements of {max}",
                buf.name
            );
        }
        let info = vk::BufferViewCreateInfo::default()
            .buffer(buf.raw)
            .format(format)
            .offset(0)
            .range(texels * texel);
        let view = unsafe { self.device.create_buffer_view(&info, None) }
            .with_context(|| format!("vkCreateBufferView \"{}\" ({format:?})", buf.name))?;
        self.set_name(view, &buf.name);
        Ok(view)
    }

    /// Destroys a view made by [`create_buffer_view`](Self::create_buffer_view).
    pub fn destroy_buffer_view(&self, view: vk::BufferView) {
        unsafe { self.device.destroy_buffer_view(view, None) };
    }

    /// Memory range covering an allocation, aligned to `nonCoherentAtomSize` for flush and
    /// invalidate (WHOLE_SIZE from the aligned-down offset stays inside the mapping); None for
    /// host-coherent memory, which needs neither.
    fn non_coherent_range(&self, alloc: &Allocation) -> Option<vk::MappedMemoryRange<'static>> {
        if alloc
            .memory_properties()
            .contains(vk::MemoryPropertyFlags::HOST_COHERENT)
        {
            return None;
        }
        let atom = self.limits.non_coherent_atom_size.max(1);
        Some(
            vk::MappedMemoryRange::default()
                .memory(unsafe { alloc.memory() })
                .offset(alloc.offset() / atom * atom)
                .size(vk::WHOLE_SIZE),
        )
    }

    /// The start of the mapping of `alloc`, checked to hold `len` bytes.
    fn mapping(alloc: &Allocation, len: usize) -> Result<*mut u8> {
        let ptr = alloc
            .mapped_ptr()
            .ok_or_else(|| anyhow!("memory is not mapped"))?;
        if len as u64 > alloc.size() {
            bail!(
                "{} bytes exceed the allocation of {} bytes",
                len,
                alloc.size()
            );
        }
        Ok(ptr.as_ptr().cast::<u8>())
    }

    fn write_mapped(&self, alloc: &Allocation, bytes: &[u8]) -> Result<()> {
        let dst = Self::mapping(alloc, bytes.len())?;
        // SAFETY: the mapping covers `alloc.size()` bytes; no GPU work uses it (caller contract).
        unsafe { std::ptr::copy_nonoverlapping(bytes.as_ptr(), dst, bytes.len()) };
        if let Some(range) = self.non_coherent_range(alloc) {
            unsafe { self.device.flush_mapped_memory_ranges(&[range]) }
                .context("vkFlushMappedMemoryRanges")?;
        }
        Ok(())
    }

    fn read_mapped(&self, alloc: &Allocation, bytes: &mut [u8]) -> Result<()> {
        let src = Self::mapping(alloc, bytes.len())?;
        if let Some(range) = self.non_coherent_range(alloc) {
            unsafe { self.device.invalidate_mapped_memory_ranges(&[range]) }
                .context("vkInvalidateMappedMemoryRanges")?;
        }
        // SAFETY: as in write_mapped; the GPU work writing it has completed (fence waited).
        unsafe { std::ptr::copy_nonoverlapping(src, bytes.as_mut_ptr(), bytes.len()) };
        Ok(())
    }
}
