//! Acceleration structures the driver builds (`VK_KHR_acceleration_structure`), for ray
//! queries (`VK_KHR_ray_query`) in compute shaders: one bottom level over a triangle soup and
//! one top level holding it once with the identity transform. brdfwave traces its own BVH
//! (`shaders/bvh.glsl`); these exist so that the traversal benchmark (`brdfwave rays`) can
//! trace the same rays through the platform's own structures and compare. A context made
//! with [`super::ContextOptions::ray_query`] is needed.

use super::{Buffer, Context};
use anyhow::{bail, Context as _, Result};
use ash::vk;
use gpu_allocator::MemoryLocation;

/// An acceleration structure and the buffer that holds it.
#[derive(Debug)]
pub struct AccelStructure {
    pub raw: vk::AccelerationStructureKHR,
    pub buffer: Buffer,
}

/// A top-level structure with the bottom level it instances (kept alive together).
pub struct TriangleAccel {
    pub top: AccelStructure,
    bottom: AccelStructure,
}

impl Context {
    fn accel_loader(&self) -> Result<ash::khr::acceleration_structure::Device> {
        if !self.features.ray_query {
            bail!("acceleration structures need a context made with ContextOptions::ray_query");
        }
        Ok(ash::khr::acceleration_structure::Device::new(
            &self.instance,
            &self.device,
        ))
    }

    fn buffer_address(&self, b: &Buffer) -> vk::DeviceAddress {
        let info = vk::BufferDeviceAddressInfo::default().buffer(b.raw);
        unsafe { self.device.get_buffer_device_address(&info) }
    }

    /// Builds the structures over `triangles` (three vertices each; a triangle's primitive
    /// index in a ray query is its index here), opaque, for fast tracing.
    pub fn build_triangle_accel(&self, triangles: &[[[f32; 3]; 3]]) -> Result<TriangleAccel> {
        let ext = self.accel_loader()?;
        if triangles.is_empty() {
            bail!("no triangles to build an acceleration structure over");
        }
        let input = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        let vertices = self.create_buffer_with_data("accel vertices", triangles, input)?;
        let tri = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
            .vertex_format(vk::Format::R32G32B32_SFLOAT)
            .vertex_data(vk::DeviceOrHostAddressConstKHR {
                device_address: self.buffer_address(&vertices),
            })
            .vertex_stride(12)
            .max_vertex(triangles.len() as u32 * 3 - 1)
            .index_type(vk::IndexType::NONE_KHR);
        let geometry = [vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
            .geometry(vk::AccelerationStructureGeometryDataKHR { triangles: tri })
            .flags(vk::GeometryFlagsKHR::OPAQUE)];
        let bottom = self.build_level(
            &ext,
            vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
            &geometry,
            triangles.len() as u32,
            "accel bottom",
        );
        self.destroy_buffer(vertices);
        let bottom = bottom?;

        let reference = unsafe {
            ext.get_acceleration_structure_device_address(
                &vk::AccelerationStructureDeviceAddressInfoKHR::default()
                    .acceleration_structure(bottom.raw),
            )
        };
        let instance = vk::AccelerationStructureInstanceKHR {
            transform: vk::TransformMatrixKHR {
                matrix: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            },
            instance_custom_index_and_mask: vk::Packed24_8::new(0, 0xFF),
            instance_shader_binding_table_record_offset_and_flags: vk::Packed24_8::new(
                0,
                vk::GeometryInstanceFlagsKHR::FORCE_OPAQUE.as_raw() as u8,
            ),
            acceleration_structure_reference: vk::AccelerationStructureReferenceKHR {
                device_handle: reference,
            },
        };
        // SAFETY: the instance record is plain data laid out as Vulkan specifies (64 bytes).
        let bytes: &[u8] = unsafe {
            std::slice::from_raw_parts(
                (&instance as *const vk::AccelerationStructureInstanceKHR).cast(),
                std::mem::size_of::<vk::AccelerationStructureInstanceKHR>(),
            )
        };
        let instances = match self.create_buffer_with_data("accel instances", bytes, input) {
            Ok(b) => b,
            Err(e) => {
                self.destroy_accel(&ext, bottom);
                return Err(e);
            }
        };
        let inst = vk::AccelerationStructureGeometryInstancesDataKHR::default().data(
            vk::DeviceOrHostAddressConstKHR {
                device_address: self.buffer_address(&instances),
            },
        );
        let geometry = [vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::INSTANCES)
            .geometry(vk::AccelerationStructureGeometryDataKHR { instances: inst })];
        let top = self.build_level(
            &ext,
            vk::AccelerationStructureTypeKHR::TOP_LEVEL,
            &geometry,
            1,
            "accel top",
        );
        self.destroy_buffer(instances);
        match top {
            Ok(top) => Ok(TriangleAccel { top, bottom }),
            Err(e) => {
                self.destroy_accel(&ext, bottom);
                Err(e)
            }
        }
    }

    /// Sizes, creates and builds one level (on the device, waiting for it).
    fn build_level(
        &self,
        ext: &ash::khr::acceleration_structure::Device,
        ty: vk::AccelerationStructureTypeKHR,
        geometry: &[vk::AccelerationStructureGeometryKHR],
        primitives: u32,
        name: &str,
    ) -> Result<AccelStructure> {
        let mut build = vk::AccelerationStructureBuildGeometryInfoKHR::default()
            .ty(ty)
            .flags(vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE)
            .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
            .geometries(geometry);
        let mut sizes = vk::AccelerationStructureBuildSizesInfoKHR::default();
        unsafe {
            ext.get_acceleration_structure_build_sizes(
                vk::AccelerationStructureBuildTypeKHR::DEVICE,
                &build,
                &[primitives],
                &mut sizes,
            )
        };
        let storage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        let buffer = self.create_buffer(
            name,
            sizes.acceleration_structure_size,
            storage,
            MemoryLocation::GpuOnly,
        )?;
        let info = vk::AccelerationStructureCreateInfoKHR::default()
            .buffer(buffer.raw)
            .size(sizes.acceleration_structure_size)
            .ty(ty);
        let raw = match unsafe { ext.create_acceleration_structure(&info, None) } {
            Ok(raw) => raw,
            Err(e) => {
                self.destroy_buffer(buffer);
                bail!("vkCreateAccelerationStructureKHR ({name}): {e}");
            }
        };
        let accel = AccelStructure { raw, buffer };
        // The scratch memory, its address rounded up to the device's alignment.
        let align = {
            let mut p = vk::PhysicalDeviceAccelerationStructurePropertiesKHR::default();
            let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut p);
            unsafe {
                self.instance
                    .get_physical_device_properties2(self.physical_device, &mut p2)
            };
            (p.min_acceleration_structure_scratch_offset_alignment as u64).max(1)
        };
        let scratch = match self.create_buffer(
            &format!("{name} scratch"),
            sizes.build_scratch_size + align,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            MemoryLocation::GpuOnly,
        ) {
            Ok(b) => b,
            Err(e) => {
                self.destroy_accel(ext, accel);
                return Err(e);
            }
        };
        let scratch_address = self.buffer_address(&scratch).next_multiple_of(align);
        build =
            build
                .dst_acceleration_structure(accel.raw)
                .scratch_data(vk::DeviceOrHostAddressKHR {
                    device_address: scratch_address,
                });
        let range =
            [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(primitives)];
        let result = self.begin().and_then(|rec| {
            // The inputs (uploads, the bottom level) are written before the build reads them,
            // and the build is done before a shader reads the structure.
            let before = vk::MemoryBarrier::default()
                .src_access_mask(
                    vk::AccessFlags::TRANSFER_WRITE
                        | vk::AccessFlags::ACCELERATION_STRUCTURE_WRITE_KHR,
                )
                .dst_access_mask(
                    vk::AccessFlags::ACCELERATION_STRUCTURE_READ_KHR
                        | vk::AccessFlags::ACCELERATION_STRUCTURE_WRITE_KHR,
                );
            let after = vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::ACCELERATION_STRUCTURE_WRITE_KHR)
                .dst_access_mask(vk::AccessFlags::ACCELERATION_STRUCTURE_READ_KHR);
            let build_stage = vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR;
            unsafe {
                self.device.cmd_pipeline_barrier(
                    rec.raw(),
                    vk::PipelineStageFlags::TRANSFER | build_stage,
                    build_stage,
                    vk::DependencyFlags::empty(),
                    &[before],
                    &[],
                    &[],
                );
                ext.cmd_build_acceleration_structures(rec.raw(), &[build], &[&range]);
                self.device.cmd_pipeline_barrier(
                    rec.raw(),
                    build_stage,
                    build_stage | vk::PipelineStageFlags::COMPUTE_SHADER,
                    vk::DependencyFlags::empty(),
                    &[after],
                    &[],
                    &[],
                );
            }
            self.submit_and_wait(rec)
        });
        self.destroy_buffer(scratch);
        match result.with_context(|| format!("building the {name} acceleration structure")) {
            Ok(()) => Ok(accel),
            Err(e) => {
                self.destroy_accel(ext, accel);
                Err(e)
            }
        }
    }

    fn destroy_accel(&self, ext: &ash::khr::acceleration_structure::Device, a: AccelStructure) {
        unsafe { ext.destroy_acceleration_structure(a.raw, None) };
        self.destroy_buffer(a.buffer);
    }

    /// Destroys both levels and their buffers.
    pub fn destroy_triangle_accel(&self, a: TriangleAccel) {
        if let Ok(ext) = self.accel_loader() {
            self.destroy_accel(&ext, a.top);
            self.destroy_accel(&ext, a.bottom);
        }
    }
}
