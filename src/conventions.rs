//! Conventions and limits that several layers share, so that no layer takes them from another
//! (the scene loader, the image readers, the partial films and both renderers read them from
//! here; `scene` does not depend on `gpu`, nor `imageio` on `scene`). The CPU reference
//! (`crate::cpu`) and the GPU integrators (`crate::gpu`) keep them alike so that their outputs
//! compare, and the GPU's shaders get them through the generated interface
//! (`crate::gpu::layout`).

/// Path segments counted one by one in the per-segment ray counts
/// ([`crate::output::RenderOutput::rays_by_segment`]); deeper segments add to the last one.
pub const SEGMENTS_COUNTED: u32 = 32;

/// Largest `max_depth` accepted (segments per path), by both renderers, the scene files and
/// `--max-depth`: the random-number key holds depth × 64 + dimension in 32 bits, and a deeper
/// path would reuse another depth's numbers long before.
pub const MAX_DEPTH: u32 = 1 << 20;

/// Largest film width or height in pixels: of a scene (`film.width`, `--res`), and of an image
/// or partial film read back (checked before anything of that size is allocated).
pub const MAX_FILM_SIZE: u32 = 16384;
