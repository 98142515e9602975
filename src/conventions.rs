//! Conventions both renderers keep, so that their outputs compare: the CPU reference
//! (`crate::cpu`) and the GPU integrators (`crate::gpu`) read them from here, and the GPU's
//! shaders get them through the generated interface (`crate::gpu::layout`).

/// Path segments counted one by one in the per-segment ray counts
/// ([`crate::output::RenderOutput::rays_by_segment`]); deeper segments add to the last one.
pub const SEGMENTS_COUNTED: u32 = 32;
