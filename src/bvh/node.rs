//! The 64-byte GPU node layout (Aila & Laine 2009) and the traversal stack's link encoding;
//! see the [`crate::bvh`] module documentation. GLSL twin: `bvh_node`, `bvh_link` and the
//! `BVH_*` defines in `shaders/bvh.glsl`.

/// Traversal stack entries (Rust and GLSL).
pub const STACK_SIZE: usize = 64;
/// Marks a leaf in a traversal stack entry.
pub(super) const LEAF_FLAG: u32 = 0x8000_0000;
/// The most traversal-stack entries the GLSL traversal keeps in registers (`BVH_STACK_REGS` in
/// `shaders/bvh.glsl`); a deeper tree gets the array stack of [`STACK_SIZE`] entries. Measured
/// on lavapipe (docs/bench-log.md): 8 and 16 registers pay on the Cornell box (depth 5); 24 and 32
/// gain nothing there, nor on a 1M-triangle mesh (depth 23), since every push and pop shifts
/// them all.
pub const REGISTER_STACK_MAX: u32 = 16;
/// Register stacks come in multiples of this many entries, so that trees of about the same
/// depth share one compiled kernel.
const REGISTER_STACK_STEP: u32 = 8;

/// The register stack for a tree whose deepest inner node is at depth `max_depth` (root = 0):
/// enough entries for every traversal (an inner node at depth k leaves at most k + 1 entries
/// on the stack, `build::MAX_DEPTH`), rounded up to a multiple of 8; `None` beyond
/// [`REGISTER_STACK_MAX`]. On lavapipe a stack in registers is a few selects per step, where
/// an array indexed by the stack pointer is a per-lane loop of branches and loads
/// (docs/bench-log.md, optimisation log).
pub fn register_stack_size(max_depth: u32) -> Option<u32> {
    let size = (max_depth + 1).div_ceil(REGISTER_STACK_STEP) * REGISTER_STACK_STEP;
    (size <= REGISTER_STACK_MAX).then_some(size)
}

/// Largest primitive count the leaf encoding of a stack entry can address.
pub const MAX_PRIMS: usize = 1 << 28;

/// One node, Aila–Laine layout: both children's boxes in the parent (64 bytes, 4 × vec4 on the
/// GPU with the u32 fields in `.w`). See the module documentation for the link encoding.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuNode {
    pub lmin: [f32; 3],
    /// Node index if `left_count == 0`, else first index into `prims`.
    pub left: u32,
    pub lmax: [f32; 3],
    pub right: u32,
    pub rmin: [f32; 3],
    /// 0 = inner node (or absent when `left == 0`), else a leaf with that many prims.
    pub left_count: u32,
    pub rmax: [f32; 3],
    pub right_count: u32,
}

const _: () = assert!(std::mem::size_of::<GpuNode>() == 64);

/// Stack entry of a child link.
#[inline]
pub(super) fn link(index: u32, count: u32) -> u32 {
    if count == 0 {
        index
    } else {
        LEAF_FLAG | (index << 3) | (count - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn register_stack_holds_the_deepest_traversal() {
        assert_eq!(register_stack_size(0), Some(8));
        assert_eq!(register_stack_size(7), Some(8));
        assert_eq!(register_stack_size(8), Some(16));
        assert_eq!(register_stack_size(15), Some(16));
        assert_eq!(register_stack_size(16), None);
        for depth in 0..40 {
            if let Some(n) = register_stack_size(depth) {
                assert!(n > depth && n <= REGISTER_STACK_MAX && n % REGISTER_STACK_STEP == 0);
            }
        }
    }

    #[test]
    fn node_is_64_bytes_in_vec4_order() {
        let n = GpuNode {
            left: 1,
            right: 2,
            left_count: 3,
            right_count: 4,
            ..Default::default()
        };
        let w: &[u32; 16] = bytemuck::cast_ref(&n);
        assert_eq!((w[3], w[7], w[11], w[15]), (1, 2, 3, 4));
    }
}
