//! Host BVH: binned-SAH construction, the 64-byte GPU node layout and the CPU traversal.
//!
//! One job per file: `build.rs` the construction, `node.rs` the node layout and the stack's
//! link encoding, `wide.rs` the CPU's 8-wide tree collapsed from the binary one,
//! `intersect.rs` the ray set-up and the box and primitive tests, `traverse.rs` the CPU
//! traversal; this file the public types. The robust-geometry helpers the renderers apply
//! to a hit (error bounds, ray-origin offsets) are [`crate::robust`]'s.
//!
//! The GLSL twin of the traversal and of every intersection routine is `shaders/bvh.glsl`; it
//! repeats the arithmetic below operation by operation (no fused multiply-adds: the GLSL marks
//! the intermediate values `precise`) so that both renderers find the same hits.
//!
//! # Construction
//! Binned SAH after Wald 2007 ("On fast Construction of SAH-based Bounding Volume
//! Hierarchies"): [`BINS`] centroid bins per axis, traversal and intersection costs
//! [`C_TRAV`] and [`C_INT`], leaves of at most [`MAX_LEAF`] primitives. A node becomes a leaf
//! when it holds at most `MAX_LEAF` primitives and the leaf is not more expensive than the best
//! split. When all centroids coincide, or a split would let the tree grow deeper than
//! [`MAX_DEPTH`], the range is split at its object median instead, which bounds the depth (and
//! so the traversal stack) for every input.
//!
//! # Node layout (Aila & Laine 2009)
//! A [`GpuNode`] holds the boxes of *both* children, so one 64-byte fetch decides which
//! children the ray enters and in which order. A child link is
//! * an inner node: `count == 0`, `index` = node index (never 0, the root is nobody's child);
//! * a leaf: `count` in `1..=MAX_LEAF`, `index` = first entry of [`Bvh::prims`];
//! * absent: `count == 0` and `index == 0`. Traversal ignores an absent child whatever its box.
//!
//! The root (node 0) is always an inner node: a scene that fits in one leaf gets a root whose
//! left child is that leaf and whose right child is absent; an empty scene gets a root with two
//! absent children (and `prims` is empty).
//!
//! # The CPU's wide tree
//! The CPU traversal walks [`Bvh::wide`]: the binary tree collapsed into [`WideNode`]s of up
//! to [`WIDTH`] children (each starts from a binary node's two children and opens the inner
//! child with the largest box until it has eight), whose boxes are tested all at once in
//! SIMD registers. Its leaves are the binary tree's, so it indexes the same `prims`. The CPU
//! reference ran about 10 % faster on a 4-wide tree than on the binary one, and 3–6 % faster
//! again on the 8-wide one (docs/bench-log.md).
//!
//! # Traversal
//! Iterative, near child first, with a private stack: on the GPU over the binary tree, with
//! [`STACK_SIZE`] entries (for a tree at most 15 deep, [`register_stack_size`] entries held in
//! registers instead: the same entries in the same order, so the same nodes are visited); on
//! the CPU over the wide tree, its hit children in the order of their entry distances. A stack
//! entry is an inner node index, or a leaf encoded as `LEAF_FLAG | first << 3 | (count - 1)`
//! (so at most 2^28 primitives). Box tests follow Ize 2013 ("Robust BVH Ray Traversal", JCGT 2(2)):
//! the far distance is widened by [`BOX_WIDEN`] so rounding never rejects a box the ray
//! touches. Direction components with `|d| < ZERO_DIR` are treated as exactly parallel to the
//! slab: the inverse is a large finite number and the slab interval is padded by `ZERO_PAD`,
//! which makes a ray lying in a box's face plane count as inside the slab (no `0 * inf` NaN, no
//! lost hits for axis-aligned rays grazing box faces).
//!
//! **Ties.** Among the primitives hit at the smallest `t` the one with the smallest primitive
//! reference wins (so triangles before spheres). The primitive tests return a `t` equal to the
//! current best one, and a hit replaces the best if its `t` is smaller, or equal with a smaller
//! reference. The result does not depend on the order in which primitives are met, so the
//! GPU's binary traversal and the CPU's wide one find the same hit, and on the rays of
//! `tests/bvh.rs` that of a brute-force loop over all primitives. (Before the triangle test
//! had its `t` error bound, a ray leaving a plane from a hair behind it could get a false hit
//! at t ≈ 1e-7 that the box tests culled and a loop over the primitives did not; the bound
//! removes such hits from both.)
//!
//! # Intersections
//! * Triangles: Woop, Benthin & Wald 2013, "Watertight Ray/Triangle Intersection" (JCGT 2(1)),
//!   single precision without the double-precision fallback: an edge function that rounds to
//!   zero counts as inside on both triangles sharing the edge, so a ray through a shared edge
//!   or vertex hits at least one of them (it may hit both; the tie rule picks one). A hit
//!   counts only where `t` exceeds the bound on its own rounding error (Pharr, Jakob &
//!   Humphreys 2016, sec. 3.9.6).
//! * Spheres: in f64 from the f32 inputs, the quadratic in the form of Haines et al. 2019,
//!   "Precision Improvements for Ray/Sphere Intersection" (Ray Tracing Gems ch. 7): the
//!   discriminant from the distance of the centre to the line, the two roots as `c/q` and
//!   `q/a` without cancellation, and `c = |o − center|² − r²` summed from exact products
//!   without loss ([`sphere_c`]).
//! * Self-intersection: [`crate::robust`]'s section "Every ray that leaves a surface" (GLSL
//!   `shaders/robust.glsl`) says how both halves, the ray's origin and these tests, keep a ray
//!   off the surface it leaves.
//!
//! # Tests
//! `tests/bvh.rs` compares both traversals with brute force over all primitives (random soups,
//! closed meshes hit exactly at shared edges and vertices, spheres from inside and from their
//! surface, axis-aligned and grazing rays, degenerate input); `tests/bvh_glsl.rs` runs
//! `shaders/bvh.glsl` on a Vulkan device (lavapipe) against this module: the hits must be the
//! same primitives, bit-exact where division and sqrt are correctly rounded.

mod build;
mod intersect;
mod node;
mod traverse;
mod wide;

/// The robust-geometry helpers (hit points with error bounds, ray-origin offsets) are
/// [`crate::robust`]'s; re-exported for callers that name them `bvh::…`.
pub use crate::robust::{
    gamma, next_float_down, next_float_up, offset_ray_origin, pull_inside, sphere_point,
    triangle_point, ulp, SHADOW_EPSILON, SHIFT_ULPS,
};
pub use build::{build, build_for, Traversal, BINS, C_INT, C_TRAV, MAX_DEPTH, MAX_LEAF};
pub use intersect::{intersect_sphere, intersect_triangle, sphere_c, BOX_WIDEN};
pub use node::{register_stack_size, GpuNode, MAX_PRIMS, REGISTER_STACK_MAX, STACK_SIZE};
pub use wide::{WideNode, WIDTH};

use glam::{Vec2, Vec3};

/// Primitive reference: triangle index, or sphere index with bit 31 set.
pub const SPHERE_BIT: u32 = 0x8000_0000;

/// Quality figures of a built BVH.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BvhStats {
    /// Triangles plus spheres.
    pub primitives: usize,
    pub inner_nodes: usize,
    pub leaves: usize,
    /// Deepest inner node (root = 0).
    pub max_depth: u32,
    /// Deepest leaf (a child of the root has depth 1).
    pub max_leaf_depth: u32,
    pub mean_leaf_size: f32,
    pub max_leaf_size: usize,
    /// SAH cost `(Σ_inner A·C_TRAV + Σ_leaf A·n·C_INT) / A_root`, areas of the node boxes.
    pub sah_cost: f32,
    /// Splits made at the object median (coincident centroids or the depth limit).
    pub median_splits: usize,
}

impl std::fmt::Display for BvhStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} prims, {} inner nodes, {} leaves (mean {:.2}, max {} prims), depth {} (leaves {}), \
             SAH cost {:.3}, {} median splits",
            self.primitives,
            self.inner_nodes,
            self.leaves,
            self.mean_leaf_size,
            self.max_leaf_size,
            self.max_depth,
            self.max_leaf_depth,
            self.sah_cost,
            self.median_splits
        )
    }
}

/// The built hierarchy: nodes (root = 0) and the primitive references the leaves index.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    /// The binary tree the GPU kernels walk. Empty in a tree built for the CPU alone
    /// ([`Traversal::CpuOnly`]).
    pub nodes: Vec<GpuNode>,
    /// Primitive references (triangle index, or sphere index | `SPHERE_BIT`), leaf-contiguous.
    pub prims: Vec<u32>,
    /// The vertices of each triangle of `prims`, in the same order (zeros for spheres): the CPU
    /// traversal reads a leaf's triangles from consecutive memory instead of the scene's larger
    /// `Triangle` records. Empty in a tree built for the GPU alone ([`Traversal::GpuOnly`]).
    pub leaf_triangles: Vec<[Vec3; 3]>,
    /// The CPU traversal's 8-wide tree, collapsed from `nodes` (root = 0; the same leaves).
    /// Empty in a tree built for the GPU alone.
    pub wide: Vec<WideNode>,
    /// Box of the whole scene (empty scene: both zero).
    pub bounds_min: Vec3,
    pub bounds_max: Vec3,
    pub stats: BvhStats,
}

/// A ray hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Primitive reference (see [`SPHERE_BIT`]).
    pub prim: u32,
    /// (b1, b2) for triangles: p = (1-b1-b2) v0 + b1 v1 + b2 v2; zero for spheres.
    pub bary: Vec2,
}

// ---------------------------------------------------------------------------------------------

#[cfg(test)]
mod tests {
    use super::intersect::{gamma64, SPHERE_C_ERROR, ZERO_DIR, ZERO_INV, ZERO_PAD};
    use super::node::LEAF_FLAG;
    use super::*;

    /// The GLSL twin's constants are the Rust ones, bit for bit.
    #[test]
    fn glsl_constants_match() {
        let glsl = include_str!("../../shaders/bvh.glsl");
        let define = |name: &str| crate::robust::glsl_define(glsl, "bvh.glsl", name);
        let bits = |name: &str| -> u32 {
            let v = define(name);
            let hex = v
                .strip_prefix("uintBitsToFloat(0x")
                .and_then(|v| v.strip_suffix("u)"))
                .expect(v);
            u32::from_str_radix(hex, 16).unwrap()
        };
        assert_eq!(define("BVH_STACK_SIZE"), STACK_SIZE.to_string());
        assert_eq!(
            define("SPHERE_TEXELS"),
            format!("{}u", crate::gpu::scene_buffers::SPHERE_TEXELS)
        );
        assert_eq!(
            define("BVH_SPHERE_BIT"),
            format!("{SPHERE_BIT:#010X}u").replace("0X", "0x")
        );
        assert_eq!(
            define("BVH_LEAF_FLAG"),
            format!("{LEAF_FLAG:#010X}u").replace("0X", "0x")
        );
        assert_eq!(bits("BVH_BOX_WIDEN"), BOX_WIDEN.to_bits());
        assert_eq!(bits("BVH_ZERO_DIR"), ZERO_DIR.to_bits());
        assert_eq!(bits("BVH_ZERO_INV"), ZERO_INV.to_bits());
        assert_eq!(bits("BVH_ZERO_PAD"), ZERO_PAD.to_bits());
        let dbits = |name: &str| {
            let v = define(name);
            let hex = v
                .strip_prefix("packDouble2x32(uvec2(0x")
                .and_then(|v| v.strip_suffix("u))"))
                .expect(v);
            let (lo, hi) = hex.split_once("u, 0x").expect(v);
            u64::from_str_radix(lo, 16).unwrap() | u64::from_str_radix(hi, 16).unwrap() << 32
        };
        assert_eq!(dbits("BVH_SPHERE_C_ERROR"), SPHERE_C_ERROR.to_bits());
        for n in [2, 3, 5] {
            assert_eq!(dbits(&format!("BVH_GAMMA64_{n}")), gamma64(n).to_bits());
        }
        assert_eq!(bits("BVH_FLT_MAX"), f32::MAX.to_bits());
        for n in [2, 3, 5] {
            assert_eq!(bits(&format!("BVH_GAMMA{n}")), gamma(n).to_bits());
        }
    }
}
