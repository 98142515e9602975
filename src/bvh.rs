//! Host BVH: binned-SAH construction, the 64-byte GPU node layout and the CPU traversal.
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
//! # Traversal
//! Iterative, near child first, with a private stack of [`STACK_SIZE`] entries. A stack entry
//! is an inner node index, or a leaf encoded as `LEAF_FLAG | first << 3 | (count - 1)` (so at
//! most 2^28 primitives). Box tests follow Ize 2013 ("Robust BVH Ray Traversal", JCGT 2(2)):
//! the far distance is widened by [`BOX_WIDEN`] so rounding never rejects a box the ray
//! touches. Direction components with `|d| < ZERO_DIR` are treated as exactly parallel to the
//! slab: the inverse is a large finite number and the slab interval is padded by `ZERO_PAD`,
//! which makes a ray lying in a box's face plane count as inside the slab (no `0 * inf` NaN, no
//! lost hits for axis-aligned rays grazing box faces).
//!
//! **Ties.** The closest hit is replaced only by a strictly smaller `t`. Among primitives at
//! the same `t` the first one met wins; the order is: children in near-first order (left first
//! when both entry distances are equal), the far child after the whole near subtree, and the
//! primitives of a leaf in `prims` order. The GLSL traversal visits in exactly this order.
//!
//! # Intersections
//! * Triangles: Woop, Benthin & Wald 2013, "Watertight Ray/Triangle Intersection" (JCGT 2(1)),
//!   single precision without the double-precision fallback: an edge function that rounds to
//!   zero counts as inside on both triangles sharing the edge, so a ray through a shared edge
//!   or vertex hits at least one of them (it may hit both; the first found is kept).
//! * Spheres: the quadratic in the form of Haines et al. 2019, "Precision Improvements for
//!   Ray/Sphere Intersection" (Ray Tracing Gems ch. 7): the discriminant from the distance of
//!   the centre to the line, and the two roots as `c/q` and `q/a` without cancellation.
//! * Self-intersection: [`offset_ray_origin`] from the hit point's own rounding-error bound
//!   ([`triangle_point`], [`sphere_point`]), after Pharr, Jakob & Humphreys 2016
//!   ("Physically Based Rendering", 3rd ed., sec. 3.9).
//!
//! # Tests
//! `tests/bvh.rs` compares both traversals with brute force over all primitives (random soups,
//! closed meshes hit exactly at shared edges and vertices, spheres from inside and from their
//! surface, axis-aligned and grazing rays, degenerate input) and runs `shaders/bvh.glsl` on a
//! Vulkan device (lavapipe) against this file: the hits must be the same primitives, bit-exact
//! where division and sqrt are correctly rounded.

use crate::scene::Scene;
use glam::{Vec2, Vec3};

/// Primitive reference: triangle index, or sphere index with bit 31 set.
pub const SPHERE_BIT: u32 = 0x8000_0000;

/// Centroid bins per axis in the SAH sweep.
pub const BINS: usize = 16;
/// Most primitives in one leaf (the stack encoding keeps `count - 1` in 3 bits).
pub const MAX_LEAF: usize = 8;
/// SAH cost of visiting one inner node (two box tests).
pub const C_TRAV: f32 = 1.0;
/// SAH cost of one primitive test.
pub const C_INT: f32 = 1.0;
/// Traversal stack entries (Rust and GLSL).
pub const STACK_SIZE: usize = 64;
/// Deepest inner node (root = depth 0). Processing an inner node at depth k leaves at most
/// k + 1 entries on the stack, so `MAX_DEPTH < STACK_SIZE` means the stack never overflows.
pub const MAX_DEPTH: u32 = 60;
/// Marks a leaf in a traversal stack entry.
const LEAF_FLAG: u32 = 0x8000_0000;
/// Largest primitive count the leaf encoding of a stack entry can address.
pub const MAX_PRIMS: usize = 1 << 28;

/// Ize 2013: the far slab distance is multiplied by this (1 + 2^-20, exact in f32), more than
/// the 1 + 2·γ₃ the three roundings of `(b - o) · inv` need, to absorb the rounding of the
/// primitive tests' `t` as well.
pub const BOX_WIDEN: f32 = 1.0 + 1.0 / (1u32 << 20) as f32;
/// Direction components smaller than this (2^-80) are treated as zero in the box test.
const ZERO_DIR: f32 = 1.0 / (1u128 << 80) as f32;
/// Inverse used for zero direction components (2^120; finite, so `0 · ZERO_INV = 0`).
const ZERO_INV: f32 = (1u128 << 120) as f32;
/// Padding of the slab interval of a zero direction component (2^80): an origin inside the
/// slab, or on its faces, gets an interval wider than any `t` a scene can produce; one outside
/// by more than `ZERO_PAD / ZERO_INV = 2^-40` gets an empty one.
const ZERO_PAD: f32 = (1u128 << 80) as f32;

/// A ray origin closer to a sphere's surface than about `M · 2^-19`, M = max(|o|∞, r), counts
/// as on the surface (16 ulps of the largest coordinate, more than the rounding of a point
/// computed on the sphere): the root at t ≈ 0 is dropped so the ray finds the far side (see
/// [`intersect_sphere`]). `|f|² - r²` is compared with `r · M · SPHERE_ON_SURFACE`.
const SPHERE_ON_SURFACE: f32 = 1.0 / (1u32 << 18) as f32;

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
    pub nodes: Vec<GpuNode>,
    /// Primitive references (triangle index, or sphere index | `SPHERE_BIT`), leaf-contiguous.
    pub prims: Vec<u32>,
    /// The vertices of each triangle of `prims`, in the same order (zeros for spheres): the CPU
    /// traversal reads a leaf's triangles from consecutive memory instead of the scene's larger
    /// `Triangle` records.
    pub leaf_triangles: Vec<[Vec3; 3]>,
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
// Construction

#[derive(Clone, Copy)]
struct Aabb {
    min: Vec3,
    max: Vec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };
    fn grow(&mut self, b: &Aabb) {
        self.min = self.min.min(b.min);
        self.max = self.max.max(b.max);
    }
    fn grow_point(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    /// Half the surface area (f64: no overflow for huge boxes); 0 for empty or flat boxes.
    fn half_area(&self) -> f64 {
        let e = (self.max - self.min).max(Vec3::ZERO).as_dvec3();
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

/// Box of one primitive. Sphere boxes are widened by a relative 2^-16 of the radius (plus the
/// rounding of `center ± radius`) so that they contain every point the sphere test can return.
fn prim_box(scene: &Scene, r: u32) -> Aabb {
    if r & SPHERE_BIT != 0 {
        let s = &scene.spheres[(r & !SPHERE_BIT) as usize];
        let rad = s.radius.abs() * (1.0 + 1.0 / 65536.0);
        let lo = s.center - Vec3::splat(rad);
        let hi = s.center + Vec3::splat(rad);
        // One more ulp outward, so rounding of the sums cannot cut into the sphere.
        Aabb {
            min: lo - lo.abs() * f32::EPSILON,
            max: hi + hi.abs() * f32::EPSILON,
        }
    } else {
        let v = &scene.triangles[r as usize].v;
        Aabb {
            min: v[0].min(v[1]).min(v[2]),
            max: v[0].max(v[1]).max(v[2]),
        }
    }
}

/// Inner levels a median-split subtree over `n` primitives needs below a node's parent.
fn levels_needed(n: usize) -> u32 {
    if n <= MAX_LEAF {
        0
    } else {
        1 + levels_needed(n.div_ceil(2))
    }
}

/// A child link under construction.
#[derive(Clone, Copy)]
struct Link {
    bounds: Aabb,
    index: u32,
    count: u32,
}

const ABSENT: Link = Link {
    bounds: Aabb {
        min: Vec3::ZERO,
        max: Vec3::ZERO,
    },
    index: 0,
    count: 0,
};

/// Builds one subtree: `order` is the part `base..base + order.len()` of the permutation of
/// primitive slots (leaves index contiguous ranges of it, by absolute position); `nodes` are
/// this builder's, numbered from 0 (a parent rebases them when it appends them).
struct Builder<'a> {
    boxes: &'a [Aabb],
    centroids: &'a [Vec3],
    order: &'a mut [u32],
    base: usize,
    /// Subtrees over at least this many primitives are built in parallel.
    parallel_prims: usize,
    nodes: Vec<GpuNode>,
    stats: BvhStats,
    /// Σ A(inner)·C_TRAV + Σ A(leaf)·n·C_INT, normalised at the end.
    sah_sum: f64,
}

enum Decision {
    Leaf,
    Split(usize),
}

/// Subtrees over at least this many primitives are built on two threads (rayon::join); the
/// tree is the same as a serial build's, node for node.
const PARALLEL_PRIMS: usize = 16 * 1024;

/// Adds `offset` to the internal-node links of `nodes` (appended at `offset` in a parent).
fn rebase(nodes: &mut [GpuNode], offset: u32) {
    for n in nodes {
        if n.left_count == 0 {
            n.left += offset;
        }
        if n.right_count == 0 {
            n.right += offset;
        }
    }
}

impl<'a> Builder<'a> {
    fn range(&self, start: usize, end: usize) -> &[u32] {
        &self.order[start - self.base..end - self.base]
    }

    fn range_bounds(&self, start: usize, end: usize) -> (Aabb, Aabb) {
        let mut b = Aabb::EMPTY;
        let mut c = Aabb::EMPTY;
        for &i in self.range(start, end) {
            b.grow(&self.boxes[i as usize]);
            c.grow_point(self.centroids[i as usize]);
        }
        (b, c)
    }

    /// Best binned SAH split: (axis, bin boundary, cost), or None when no axis has extent.
    fn best_split(
        &self,
        start: usize,
        end: usize,
        bounds: &Aabb,
        cb: &Aabb,
    ) -> Option<(usize, usize, f64)> {
        let parent_area = bounds.half_area();
        let mut best: Option<(usize, usize, f64)> = None;
        for axis in 0..3 {
            let lo = cb.min[axis];
            let extent = cb.max[axis] - lo;
            // Also false for NaN or infinite extents.
            if !(extent > 0.0 && extent < f32::INFINITY) {
                continue;
            }
            let scale = BINS as f32 / extent;
            let mut bin_box = [Aabb::EMPTY; BINS];
            let mut bin_n = [0usize; BINS];
            for &i in self.range(start, end) {
                let b = bin_of(self.centroids[i as usize][axis], lo, scale);
                bin_n[b] += 1;
                bin_box[b].grow(&self.boxes[i as usize]);
            }
            // Sweep from the right: area·count of bins k.. for every k.
            let mut right_cost = [0.0f64; BINS];
            let mut acc = Aabb::EMPTY;
            let mut n = 0;
            for k in (1..BINS).rev() {
                acc.grow(&bin_box[k]);
                n += bin_n[k];
                right_cost[k] = if n > 0 {
                    acc.half_area() * n as f64
                } else {
                    f64::INFINITY
                };
            }
            let mut acc = Aabb::EMPTY;
            let mut n = 0;
            for k in 1..BINS {
                acc.grow(&bin_box[k - 1]);
                n += bin_n[k - 1];
                if n == 0 || right_cost[k] == f64::INFINITY {
                    continue;
                }
                let areas = acc.half_area() * n as f64 + right_cost[k];
                let cost = if parent_area > 0.0 && parent_area < f64::INFINITY {
                    C_TRAV as f64 + C_INT as f64 * areas / parent_area
                } else {
                    // Degenerate (point-like) node: every split costs the same.
                    C_TRAV as f64 + C_INT as f64 * 0.5 * (end - start) as f64
                };
                if best.map_or(true, |(_, _, c)| cost < c) {
                    best = Some((axis, k, cost));
                }
            }
        }
        best
    }

    /// Reorder `order[start..end]` so the primitives whose centroid falls in bins `< k` come
    /// first; returns the boundary.
    fn partition(&mut self, start: usize, end: usize, axis: usize, k: usize, cb: &Aabb) -> usize {
        let lo = cb.min[axis];
        let scale = BINS as f32 / (cb.max[axis] - lo);
        let mut i = start - self.base;
        let mut j = end - self.base;
        while i < j {
            if bin_of(self.centroids[self.order[i] as usize][axis], lo, scale) < k {
                i += 1;
            } else {
                j -= 1;
                self.order.swap(i, j);
            }
        }
        i + self.base
    }

    /// Object-median split along the axis of largest centroid extent.
    fn median(&mut self, start: usize, end: usize, cb: &Aabb) -> usize {
        let e = cb.max - cb.min;
        let axis = if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        };
        let mid = start + (end - start) / 2;
        let c = self.centroids;
        self.order[start - self.base..end - self.base]
            .select_nth_unstable_by(mid - start, |&a, &b| {
                c[a as usize][axis].total_cmp(&c[b as usize][axis])
            });
        self.stats.median_splits += 1;
        mid
    }

    fn decide(
        &mut self,
        start: usize,
        end: usize,
        depth: u32,
        bounds: &Aabb,
        cb: &Aabb,
    ) -> Decision {
        let n = end - start;
        if n <= 1 || (n <= MAX_LEAF && depth >= MAX_DEPTH) {
            return Decision::Leaf;
        }
        let split = self.best_split(start, end, bounds, cb);
        if n <= MAX_LEAF {
            match split {
                Some((_, _, cost)) if cost < n as f64 * C_INT as f64 => {}
                _ => return Decision::Leaf,
            }
        }
        if let Some((axis, k, _)) = split {
            let mid = self.partition(start, end, axis, k, cb);
            let largest = (mid - start).max(end - mid);
            if mid > start && mid < end && depth + levels_needed(largest) <= MAX_DEPTH {
                return Decision::Split(mid);
            }
        }
        Decision::Split(self.median(start, end, cb))
    }

    fn leaf(&mut self, start: usize, end: usize, depth: u32, bounds: Aabb) -> Link {
        let n = end - start;
        self.stats.leaves += 1;
        self.stats.max_leaf_size = self.stats.max_leaf_size.max(n);
        self.stats.max_leaf_depth = self.stats.max_leaf_depth.max(depth);
        self.sah_sum += bounds.half_area() * n as f64 * C_INT as f64;
        Link {
            bounds,
            index: start as u32,
            count: n as u32,
        }
    }

    /// Build the subtree over `order[start..end]` whose root sits at `depth` (as an inner node).
    fn build(&mut self, start: usize, end: usize, depth: u32, is_root: bool) -> Link {
        let (bounds, cb) = self.range_bounds(start, end);
        if end == start {
            // Only the root of an empty scene.
            self.nodes.push(GpuNode::default());
            self.stats.inner_nodes += 1;
            return Link {
                bounds,
                index: 0,
                count: 0,
            };
        }
        match self.decide(start, end, depth, &bounds, &cb) {
            Decision::Leaf if !is_root => self.leaf(start, end, depth, bounds),
            Decision::Leaf => {
                self.nodes.push(GpuNode::default());
                self.stats.inner_nodes += 1;
                self.sah_sum += bounds.half_area() * C_TRAV as f64;
                let l = self.leaf(start, end, depth + 1, bounds);
                self.nodes[0] = make_node(&l, &ABSENT);
                Link {
                    bounds,
                    index: 0,
                    count: 0,
                }
            }
            Decision::Split(mid) => {
                let index = self.nodes.len();
                self.nodes.push(GpuNode::default());
                self.stats.inner_nodes += 1;
                self.stats.max_depth = self.stats.max_depth.max(depth);
                self.sah_sum += bounds.half_area() * C_TRAV as f64;
                let (l, r) = if end - start >= self.parallel_prims {
                    self.build_children_in_parallel(start, mid, end, depth + 1)
                } else {
                    let l = self.build(start, mid, depth + 1, false);
                    (l, self.build(mid, end, depth + 1, false))
                };
                self.nodes[index] = make_node(&l, &r);
                Link {
                    bounds,
                    index: index as u32,
                    count: 0,
                }
            }
        }
    }
}

impl<'a> Builder<'a> {
    /// The subtrees over `start..mid` and `mid..end` on two threads, appended to `nodes` in the
    /// order a serial build makes them (left subtree, then right).
    fn build_children_in_parallel(
        &mut self,
        start: usize,
        mid: usize,
        end: usize,
        depth: u32,
    ) -> (Link, Link) {
        let order = std::mem::take(&mut self.order);
        let (_, rest) = order.split_at_mut(start - self.base);
        let (lo, rest) = rest.split_at_mut(mid - start);
        let (hi, _) = rest.split_at_mut(end - mid);
        let (boxes, centroids, parallel_prims) = (self.boxes, self.centroids, self.parallel_prims);
        let sub = |order, base| Builder {
            boxes,
            centroids,
            order,
            base,
            parallel_prims,
            nodes: Vec::new(),
            stats: BvhStats::default(),
            sah_sum: 0.0,
        };
        let ((mut l, lb), (mut r, rb)) = rayon::join(
            || {
                let mut b = sub(lo, start);
                let link = b.build(start, mid, depth, false);
                (link, (b.nodes, b.stats, b.sah_sum))
            },
            || {
                let mut b = sub(hi, mid);
                let link = b.build(mid, end, depth, false);
                (link, (b.nodes, b.stats, b.sah_sum))
            },
        );
        self.order = order;
        for (link, (mut nodes, t, sah)) in [(&mut l, lb), (&mut r, rb)] {
            let offset = self.nodes.len() as u32;
            rebase(&mut nodes, offset);
            if link.count == 0 {
                link.index += offset;
            }
            self.nodes.append(&mut nodes);
            let s = &mut self.stats;
            s.inner_nodes += t.inner_nodes;
            s.leaves += t.leaves;
            s.median_splits += t.median_splits;
            s.max_depth = s.max_depth.max(t.max_depth);
            s.max_leaf_depth = s.max_leaf_depth.max(t.max_leaf_depth);
            s.max_leaf_size = s.max_leaf_size.max(t.max_leaf_size);
            self.sah_sum += sah;
        }
        (l, r)
    }
}

fn make_node(l: &Link, r: &Link) -> GpuNode {
    GpuNode {
        lmin: l.bounds.min.to_array(),
        left: l.index,
        lmax: l.bounds.max.to_array(),
        right: r.index,
        rmin: r.bounds.min.to_array(),
        left_count: l.count,
        rmax: r.bounds.max.to_array(),
        right_count: r.count,
    }
}

/// Bin of a centroid coordinate; clamped, and 0 for NaN (the cast saturates).
fn bin_of(c: f32, lo: f32, scale: f32) -> usize {
    (((c - lo) * scale) as usize).min(BINS - 1)
}

/// Build the BVH over all triangles and spheres of `scene` (binned SAH, root = node 0).
///
/// # Panics
/// If the scene has more than [`MAX_PRIMS`] (2^28) primitives, the limit of the traversal's
/// leaf encoding.
pub fn build(scene: &Scene) -> Bvh {
    build_with(scene, PARALLEL_PRIMS)
}

/// [`build`], with subtrees of at least `parallel_prims` primitives built on two threads.
fn build_with(scene: &Scene, parallel_prims: usize) -> Bvh {
    let n = scene.triangles.len() + scene.spheres.len();
    assert!(
        n <= MAX_PRIMS,
        "the BVH supports at most {MAX_PRIMS} primitives, the scene has {n}"
    );
    let refs: Vec<u32> = (0..scene.triangles.len() as u32)
        .chain((0..scene.spheres.len() as u32).map(|i| i | SPHERE_BIT))
        .collect();
    let boxes: Vec<Aabb> = refs.iter().map(|&r| prim_box(scene, r)).collect();
    let centroids: Vec<Vec3> = boxes.iter().map(|b| (b.min + b.max) * 0.5).collect();
    let mut order: Vec<u32> = (0..n as u32).collect();
    let mut b = Builder {
        boxes: &boxes,
        centroids: &centroids,
        order: &mut order,
        base: 0,
        parallel_prims,
        nodes: Vec::with_capacity(n.max(1)),
        stats: BvhStats {
            primitives: n,
            ..Default::default()
        },
        sah_sum: 0.0,
    };
    let root = b.build(0, n, 0, true);
    let (nodes, sah_sum, mut stats) = (b.nodes, b.sah_sum, b.stats);
    let root_area = root.bounds.half_area();
    stats.sah_cost = if root_area > 0.0 {
        (sah_sum / root_area) as f32
    } else {
        0.0
    };
    stats.mean_leaf_size = if stats.leaves > 0 {
        n as f32 / stats.leaves as f32
    } else {
        0.0
    };
    let prims: Vec<u32> = order.iter().map(|&i| refs[i as usize]).collect();
    let leaf_triangles = prims
        .iter()
        .map(|&r| match r & SPHERE_BIT {
            0 => scene.triangles[r as usize].v,
            _ => [Vec3::ZERO; 3],
        })
        .collect();
    let (bounds_min, bounds_max) = if n > 0 {
        (root.bounds.min, root.bounds.max)
    } else {
        (Vec3::ZERO, Vec3::ZERO)
    };
    Bvh {
        nodes,
        prims,
        leaf_triangles,
        bounds_min,
        bounds_max,
        stats,
    }
}

// ---------------------------------------------------------------------------------------------
// Ray set-up and intersection routines (twins in shaders/bvh.glsl)

/// Per-ray constants of the box and triangle tests.
#[derive(Clone, Copy, Debug)]
struct Ray {
    o: Vec3,
    /// Safe inverse direction (box test).
    inv: Vec3,
    /// ZERO_PAD on zero components, else 0.
    pad: Vec3,
    /// Woop et al.: axes of the shear, kz = largest |d| component.
    kx: usize,
    ky: usize,
    kz: usize,
    /// Shear constants (Sx, Sy, Sz).
    s: Vec3,
}

#[inline]
fn dot3(a: Vec3, b: Vec3) -> f32 {
    a.x * b.x + a.y * b.y + a.z * b.z
}

#[inline]
fn safe_inv(d: f32) -> (f32, f32) {
    if d.abs() < ZERO_DIR {
        (ZERO_INV, ZERO_PAD)
    } else {
        (1.0 / d, 0.0)
    }
}

impl Ray {
    /// None for a zero, infinite or NaN direction: such a ray hits nothing.
    #[inline]
    fn new(o: Vec3, d: Vec3) -> Option<Ray> {
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        if !(a[kz] > 0.0 && a[kz] <= f32::MAX) {
            return None;
        }
        let mut kx = if kz == 2 { 0 } else { kz + 1 };
        let mut ky = if kx == 2 { 0 } else { kx + 1 };
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let s = Vec3::new(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
        let (ix, px) = safe_inv(d.x);
        let (iy, py) = safe_inv(d.y);
        let (iz, pz) = safe_inv(d.z);
        Some(Ray {
            o,
            inv: Vec3::new(ix, iy, iz),
            pad: Vec3::new(px, py, pz),
            kx,
            ky,
            kz,
            s,
        })
    }

    /// Conservative slab test: (hit, entry distance clamped to 0).
    #[inline]
    fn box_hit(&self, bmin: Vec3, bmax: Vec3, tmax: f32) -> (bool, f32) {
        let t0 = (bmin - self.o) * self.inv;
        let t1 = (bmax - self.o) * self.inv;
        let tn = t0.min(t1) - self.pad;
        let tf = t0.max(t1) + self.pad;
        let tnear = tn.x.max(tn.y).max(tn.z.max(0.0));
        let tfar = tf.x.min(tf.y).min(tf.z.min(tmax)) * BOX_WIDEN;
        (tnear <= tfar, tnear)
    }

    /// Woop–Benthin–Wald watertight test; (t, (b1, b2)) with t in (0, tmax).
    #[inline]
    fn triangle(&self, v: &[Vec3; 3], tmax: f32) -> Option<(f32, Vec2)> {
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let a = v[0] - self.o;
        let b = v[1] - self.o;
        let c = v[2] - self.o;
        let ax = a[kx] - self.s.x * a[kz];
        let ay = a[ky] - self.s.y * a[kz];
        let bx = b[kx] - self.s.x * b[kz];
        let by = b[ky] - self.s.y * b[kz];
        let cx = c[kx] - self.s.x * c[kz];
        let cy = c[ky] - self.s.y * c[kz];
        let u = cx * by - cy * bx;
        let v_ = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v_ < 0.0 || w < 0.0) && (u > 0.0 || v_ > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v_ + w;
        if det == 0.0 {
            return None;
        }
        let az = self.s.z * a[kz];
        let bz = self.s.z * b[kz];
        let cz = self.s.z * c[kz];
        let tt = u * az + v_ * bz + w * cz;
        // t > 0 needs T and det of the same sign (and T != 0).
        if (det < 0.0 && tt >= 0.0) || (det > 0.0 && tt <= 0.0) {
            return None;
        }
        let rcp = 1.0 / det;
        let t = tt * rcp;
        if !(t > 0.0 && t < tmax) {
            return None;
        }
        Some((t, Vec2::new(v_ * rcp, w * rcp)))
    }
}

/// Watertight ray/triangle intersection (Woop, Benthin & Wald 2013): the hit distance `t` in
/// (0, tmax) and the barycentrics (b1, b2) of v1 and v2. None for a zero direction.
pub fn intersect_triangle(o: Vec3, d: Vec3, v: &[Vec3; 3], tmax: f32) -> Option<(f32, Vec2)> {
    Ray::new(o, d)?.triangle(v, tmax)
}

/// Ray/sphere intersection (Ray Tracing Gems ch. 7): the smallest root in (0, tmax), so a ray
/// starting inside finds the far side. An origin within about 16 ulps of its largest
/// coordinate (or of the radius) from the surface counts as on it: the root at t ≈ 0 is dropped, so a ray leaving the surface inwards finds
/// the far side and one leaving outwards finds nothing. `d` need not be normalised.
pub fn intersect_sphere(o: Vec3, d: Vec3, center: Vec3, radius: f32, tmax: f32) -> Option<f32> {
    let f = o - center;
    let a = dot3(d, d);
    // Also rejects NaN (GLSL: `!(a > 0.0)`).
    if a.is_nan() || a <= 0.0 {
        return None;
    }
    let b = dot3(f, d);
    let r2 = radius * radius;
    let c = dot3(f, f) - r2;
    // Discriminant / a from the squared distance of the centre to the line.
    let k = b / a;
    let l = f - d * k;
    let disc = a * (r2 - dot3(l, l));
    if disc < 0.0 {
        return None;
    }
    let sq = disc.sqrt();
    let q = if b >= 0.0 { -b - sq } else { -b + sq };
    if q == 0.0 {
        return None;
    }
    let m = o.x.abs().max(o.y.abs()).max(o.z.abs().max(radius.abs()));
    let on_surface = c.abs() <= radius.abs() * m * SPHERE_ON_SURFACE;
    let t0 = if on_surface { 0.0 } else { c / q };
    let t1 = q / a;
    let (lo, hi) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
    if lo > 0.0 && lo < tmax {
        Some(lo)
    } else if hi > 0.0 && hi < tmax {
        Some(hi)
    } else {
        None
    }
}

/// `gamma(n) = n·u / (1 - n·u)` with `u = 2^-24` the unit roundoff of f32: a bound on the
/// relative error of `n` successive roundings (Higham 2002, "Accuracy and Stability of Numerical
/// Algorithms", lemma 3.1; used this way by Pharr, Jakob & Humphreys 2016, "Physically Based
/// Rendering" 3rd ed., sec. 3.9).
pub const fn gamma(n: u32) -> f32 {
    let nu = n as f32 * (f32::EPSILON * 0.5);
    nu / (1.0 - nu)
}

/// The barycentrics (b1, b2) of a hit on the triangle `v`, moved a little towards the centroid
/// (1/3, 1/3), for the point a new ray leaves from.
///
/// Within the plane, the error of a hit point (the intersection's barycentrics and the rounding
/// of the coordinates, a few ulps) can put a point near an edge on, or just beyond, the plane of
/// the neighbouring face. A ray leaving from there, offset only along this face's normal, starts
/// on that plane and passes through the face unseen (a closed box seen from inside showed the
/// environment through its corners). Moving the barycentrics a fraction t towards (1/3, 1/3)
/// moves the point by t·(c − p), c − p = (1/3 − b1)·e1 + (1/3 − b2)·e2: by [`SHIFT_ULPS`] ulps
/// of the coordinates' magnitude (estimated as |v0| + 3·|c − p|, max-norm; at most half way),
/// so the point is a few roundings inside every edge, and no further: the move is a bias (30
/// ulps darkened a Cornell box moved 1e6 away by 0.26 %). Sampled light points need no move
/// (they are interior with probability 1, and a shadow ray ends before its target).
pub fn pull_inside(v: &[Vec3; 3], b1: f32, b2: f32) -> (f32, f32) {
    let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
    let third = 1.0 / 3.0;
    let (d1, d2) = (third - b1, third - b2);
    let dist = (e1 * d1 + e2 * d2).abs().max_element();
    if !(dist > 0.0 && dist.is_finite()) {
        return (b1, b2);
    }
    let delta = ulp(v[0].abs().max_element() + 3.0 * dist) * SHIFT_ULPS;
    let t = (delta / dist).min(0.5);
    (b1 + t * d1, b2 + t * d2)
}

/// The point with barycentrics (b1, b2) of the triangle `v`, computed as
/// `v0 + (b1·(v1 − v0) + b2·(v2 − v0))`, and the absolute error bound of its distance from the
/// triangle's plane, per coordinate: `gamma(4)·(|b1·e1| + |b2·e2|) + gamma(2)·|p|`.
///
/// Any b1, b2 give a point of the plane in exact arithmetic, so the barycentrics' own error
/// moves the point within the plane only (see [`pull_inside`] for what that needs); what moves
/// it off the plane is the rounding of the edges, the products and the two sums (Higham 2002,
/// lemma 3.1; Pharr, Jakob & Humphreys 2016, sec. 3.9.4, which bounds the form Σ bᵢ·vᵢ by
/// gamma(7)·Σ|bᵢ·vᵢ|). For a scene far from the origin this is about 2 ulps of the
/// coordinates, not 7.
pub fn triangle_point(v: &[Vec3; 3], b1: f32, b2: f32) -> (Vec3, Vec3) {
    let e1 = (v[1] - v[0]) * b1;
    let e2 = (v[2] - v[0]) * b2;
    let p = v[0] + (e1 + e2);
    let err = (e1.abs() + e2.abs()) * gamma(4) + p.abs() * gamma(2);
    (p, err)
}

/// How far [`pull_inside`] moves a hit point towards the centroid, in ulps of the largest vertex
/// coordinate.
pub const SHIFT_ULPS: f32 = 4.0;

/// The spacing of the floats at `x` (non-negative): 2^(exponent − 23), or the smallest
/// subnormal below 2^-126.
pub fn ulp(x: f32) -> f32 {
    let e = (x.to_bits() >> 23) & 0xff;
    if e > 23 {
        f32::from_bits((e - 23) << 23)
    } else {
        f32::from_bits(1)
    }
}

/// The sphere point `center + u·radius` for a unit vector `u` (up to `|1 - u·u|`: a normalised
/// vector, or one made from sines and cosines), and its absolute error bound per coordinate:
/// `gamma(5)·|u·radius| + gamma(2)·|p|` for the roundings of `u` and of the product and sum,
/// plus `|1 - u·u|·|radius|` for a `u` that is not exactly unit (Pharr et al. 2016, sec. 3.9.4,
/// the sphere's reprojected point).
pub fn sphere_point(center: Vec3, u: Vec3, radius: f32) -> (Vec3, Vec3) {
    let ur = u * radius;
    let p = center + ur;
    let radial = (1.0 - dot3(u, u)).abs() * radius.abs();
    let err = ur.abs() * gamma(5) + p.abs() * gamma(2) + Vec3::splat(radial);
    (p, err)
}

/// Shadow rays end this fraction of their length before the point on the light (Pharr, Jakob &
/// Humphreys 2016, sec. 3.9.5, `ShadowEpsilon`): the light point is offset off its surface by
/// its own error bound, but the ray's hit distance with that surface carries the rounding of
/// the whole ray (origin, direction and intersection), which can be larger where the light's
/// plane coordinate is small and the others are not (a Cornell box moved so that its ceiling
/// is near y = 0 lost 15 % of its direct light to shadow rays blocked by the light itself).
pub const SHADOW_EPSILON: f32 = 1e-4;

/// The next f32 above `x` (towards +inf); +0 for -0. Infinities and NaN are returned as they are.
#[inline]
pub fn next_float_up(x: f32) -> f32 {
    if !x.is_finite() {
        return x;
    }
    let x = if x == 0.0 { 0.0 } else { x };
    let bits = x.to_bits();
    f32::from_bits(if x >= 0.0 { bits + 1 } else { bits - 1 })
}

/// The next f32 below `x` (towards -inf); -0 for +0. Infinities and NaN are returned as they are.
#[inline]
pub fn next_float_down(x: f32) -> f32 {
    if !x.is_finite() {
        return x;
    }
    let x = if x == 0.0 { -0.0 } else { x };
    let bits = x.to_bits();
    f32::from_bits(if x <= 0.0 { bits + 1 } else { bits - 1 })
}

/// Move the surface point `p`, whose coordinates are within `err` of the true surface point,
/// off the surface to the side of the unit normal `n` the new ray leaves from, far enough that
/// the new ray cannot hit the surface it starts on (Pharr et al. 2016, sec. 3.9.5, and the
/// pbrt-v4 sources' `OffsetRayOrigin`): along `n` by `d = |n|·err`, the distance from the plane
/// of the box `p ± err`, then each coordinate one float further along `n`, so that
/// the rounding of `p + d·n` cannot bring the point back inside that box. The offset scales
/// with the error of `p` itself, so it is the same fraction of the scene at every scale and
/// translation (fixed offsets are not: Wächter & Binder 2019's 256 ulps and `n/65536` near zero
/// moved origins by a visible part of a scene scaled by 1e-6 or moved 1e6 away).
pub fn offset_ray_origin(p: Vec3, err: Vec3, n: Vec3) -> Vec3 {
    let d = dot3(n.abs(), err);
    let q = p + n * d;
    // By the sign of n, not of the offset: a point with a zero error bound (a vertex at the
    // origin) still moves one float.
    let one = |q: f32, n: f32| -> f32 {
        if n > 0.0 {
            next_float_up(q)
        } else if n < 0.0 {
            next_float_down(q)
        } else {
            q
        }
    };
    Vec3::new(one(q.x, n.x), one(q.y, n.y), one(q.z, n.z))
}

// ---------------------------------------------------------------------------------------------
// Traversal

impl Bvh {
    /// Closest hit with t in (0, tmax); ties are resolved as the module documentation says.
    /// `scene` must be the scene the BVH was built from. A zero, infinite or NaN direction
    /// hits nothing.
    pub fn closest(&self, scene: &Scene, o: Vec3, d: Vec3, tmax: f32) -> Option<Hit> {
        self.traverse::<false>(scene, o, d, tmax)
    }

    /// Whether anything is hit with t in (0, tmax) (shadow rays).
    pub fn occluded(&self, scene: &Scene, o: Vec3, d: Vec3, tmax: f32) -> bool {
        self.traverse::<true>(scene, o, d, tmax).is_some()
    }

    fn traverse<const ANY: bool>(&self, scene: &Scene, o: Vec3, d: Vec3, tmax: f32) -> Option<Hit> {
        let ray = Ray::new(o, d)?;
        let mut best = Hit {
            t: tmax,
            prim: u32::MAX,
            bary: Vec2::ZERO,
        };
        let mut found = false;
        let mut stack = [0u32; STACK_SIZE];
        let mut sp = 0usize;
        let mut cur = 0u32;
        loop {
            if cur & LEAF_FLAG != 0 {
                let first = (cur >> 3) & 0x0FFF_FFFF;
                let end = first + (cur & 7) + 1;
                for i in first..end {
                    let r = self.prims[i as usize];
                    let h = if r & SPHERE_BIT != 0 {
                        let s = &scene.spheres[(r & !SPHERE_BIT) as usize];
                        intersect_sphere(o, d, s.center, s.radius, best.t).map(|t| (t, Vec2::ZERO))
                    } else {
                        ray.triangle(&self.leaf_triangles[i as usize], best.t)
                    };
                    if let Some((t, bary)) = h {
                        best = Hit { t, prim: r, bary };
                        found = true;
                        if ANY {
                            return Some(best);
                        }
                    }
                }
            } else {
                let n = &self.nodes[cur as usize];
                let (hl, tl) = ray.box_hit(Vec3::from(n.lmin), Vec3::from(n.lmax), best.t);
                let (hr, tr) = ray.box_hit(Vec3::from(n.rmin), Vec3::from(n.rmax), best.t);
                let hl = hl && (n.left_count != 0 || n.left != 0);
                let hr = hr && (n.right_count != 0 || n.right != 0);
                let cl = link(n.left, n.left_count);
                let cr = link(n.right, n.right_count);
                if hl && hr {
                    let (near, far) = if tr < tl { (cr, cl) } else { (cl, cr) };
                    debug_assert!(sp < STACK_SIZE, "BVH deeper than the traversal stack");
                    if sp < STACK_SIZE {
                        stack[sp] = far;
                        sp += 1;
                    }
                    cur = near;
                    continue;
                }
                if hl {
                    cur = cl;
                    continue;
                }
                if hr {
                    cur = cr;
                    continue;
                }
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            cur = stack[sp];
        }
        found.then_some(best)
    }
}

/// Stack entry of a child link.
#[inline]
fn link(index: u32, count: u32) -> u32 {
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

    #[test]
    fn triangle_hit_values() {
        let v = [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ];
        let (t, b) = intersect_triangle(Vec3::new(0.25, 0.5, 0.0), Vec3::Z, &v, f32::MAX).unwrap();
        assert_eq!(t, 1.0);
        assert!((b - Vec2::new(0.25, 0.5)).abs().max_element() < 1e-6, "{b}");
        // From behind and with a reversed direction: both sides hit (no culling).
        let (t, _) =
            intersect_triangle(Vec3::new(0.25, 0.5, 3.0), -Vec3::Z * 2.0, &v, f32::MAX).unwrap();
        assert!((t - 1.0).abs() < 1e-6);
        // Behind the origin, beyond tmax, outside, zero direction.
        assert!(intersect_triangle(Vec3::new(0.25, 0.5, 2.0), Vec3::Z, &v, f32::MAX).is_none());
        assert!(intersect_triangle(Vec3::new(0.25, 0.5, 0.0), Vec3::Z, &v, 1.0).is_none());
        assert!(intersect_triangle(Vec3::new(0.75, 0.5, 0.0), Vec3::Z, &v, f32::MAX).is_none());
        assert!(intersect_triangle(Vec3::new(0.25, 0.5, 0.0), Vec3::ZERO, &v, f32::MAX).is_none());
        // A ray lying in the triangle's plane misses (det = 0).
        assert!(intersect_triangle(Vec3::new(-1.0, 0.2, 1.0), Vec3::X, &v, f32::MAX).is_none());
    }

    #[test]
    fn sphere_roots_outside_inside_and_on_surface() {
        let c = Vec3::new(1.0, 2.0, 3.0);
        let t = intersect_sphere(c - Vec3::X * 5.0, Vec3::X, c, 2.0, f32::MAX).unwrap();
        assert!((t - 3.0).abs() < 1e-6);
        // Unnormalised direction: t in units of d.
        let t = intersect_sphere(c - Vec3::X * 5.0, Vec3::X * 2.0, c, 2.0, f32::MAX).unwrap();
        assert!((t - 1.5).abs() < 1e-6);
        // From inside: the far side.
        let t = intersect_sphere(c, Vec3::Y, c, 2.0, f32::MAX).unwrap();
        assert!((t - 2.0).abs() < 1e-6);
        // From exactly on the surface: inwards finds the far side, outwards nothing.
        let p = c + Vec3::new(0.0, 0.0, 2.0);
        let t = intersect_sphere(p, -Vec3::Z, c, 2.0, f32::MAX).unwrap();
        assert!((t - 4.0).abs() < 1e-5);
        assert!(intersect_sphere(p, Vec3::Z, c, 2.0, f32::MAX).is_none());
        // Miss, behind, tmax.
        assert!(
            intersect_sphere(c + Vec3::new(0.0, 3.0, -5.0), Vec3::Z, c, 2.0, f32::MAX).is_none()
        );
        assert!(intersect_sphere(c + Vec3::X * 5.0, Vec3::X, c, 2.0, f32::MAX).is_none());
        assert!(intersect_sphere(c - Vec3::X * 5.0, Vec3::X, c, 2.0, 3.0).is_none());
    }

    #[test]
    fn sphere_far_away_is_precise() {
        // Small sphere at distance 1e4: the naive quadratic loses the discriminant.
        let c = Vec3::new(0.0, 0.0, 1.0e4);
        let t = intersect_sphere(Vec3::new(0.0, 0.0099, 0.0), Vec3::Z, c, 0.01, f32::MAX).unwrap();
        let exact = 1.0e4 - (0.01f64 * 0.01 - 0.0099f64 * 0.0099).sqrt();
        assert!((t as f64 - exact).abs() < 2e-3, "{t} vs {exact}");
    }

    #[test]
    fn offset_moves_to_the_normal_side_at_all_scales() {
        for &s in &[
            1e-30f32, 1e-6, 1e-3, 0.02, 1.0, 100.0, 1.0e4, -1.0e4, 1.0e6, 1.0e30,
        ] {
            let v = [
                Vec3::new(s, -0.7 * s, 0.3 * s),
                Vec3::new(1.3 * s, -0.2 * s, 0.1 * s),
                Vec3::new(0.9 * s, 0.4 * s, -0.5 * s),
            ];
            let n = crate::robust::triangle_normal(&v);
            let (p, err) = triangle_point(&v, 0.3, 0.45);
            let q = offset_ray_origin(p, err, n);
            // In f64: the offset point is off the plane by at least the error bound and by
            // at most a few times it (a tiny fraction of the triangle).
            let to64 = |a: Vec3| [a.x as f64, a.y as f64, a.z as f64];
            let (v0, v1, v2, q64) = (to64(v[0]), to64(v[1]), to64(v[2]), to64(q));
            let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
            let (e1, e2) = (sub(v1, v0), sub(v2, v0));
            let nn = [
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            ];
            let len = (nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]).sqrt();
            let w = sub(q64, v0);
            let dist = (w[0] * nn[0] + w[1] * nn[1] + w[2] * nn[2]) / len;
            assert!(
                dist > 0.0,
                "scale {s}: {p} -> {q} is not on the normal side"
            );
            let bound = (n.abs().dot(err)) as f64;
            assert!(
                dist >= 0.9 * bound && dist < 4.0 * bound + 2.0 * (s.abs() as f64) * 1e-7,
                "scale {s}: moved {dist}, error bound {bound}"
            );
            let q = offset_ray_origin(p, err, -n);
            assert!((q - p).dot(n) < 0.0, "scale {s}: not moved to the back");
        }
        // Coordinates at zero still move (to the smallest subnormal at least).
        let q = offset_ray_origin(Vec3::ZERO, Vec3::ZERO, Vec3::Z);
        assert!(q.z > 0.0 && q.x == 0.0 && q.y == 0.0);
        let q = offset_ray_origin(Vec3::splat(-0.0), Vec3::ZERO, -Vec3::Z);
        assert!(q.z < 0.0);
    }

    #[test]
    fn next_float_steps_one_ulp() {
        assert_eq!(next_float_up(1.0), 1.0 + f32::EPSILON);
        assert_eq!(next_float_down(1.0), 1.0 - f32::EPSILON / 2.0);
        assert_eq!(next_float_up(-1.0), -1.0 + f32::EPSILON / 2.0);
        assert_eq!(next_float_up(-0.0), f32::from_bits(1));
        assert_eq!(next_float_down(0.0), -f32::from_bits(1));
        assert_eq!(next_float_up(f32::MAX), f32::INFINITY);
        assert_eq!(next_float_up(f32::INFINITY), f32::INFINITY);
        assert!(next_float_down(f32::NAN).is_nan());
    }

    /// Building subtrees in parallel gives the serial build's tree, node for node.
    #[test]
    fn parallel_build_equals_serial_build() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
        let mut s = crate::scene::load(&path).unwrap();
        crate::bench::add_sphere_mesh(&mut s, 40_000);
        let serial = build_with(&s, usize::MAX);
        let parallel = build_with(&s, 1000);
        assert!(serial.nodes.len() > 1000);
        assert!(serial.nodes == parallel.nodes, "nodes differ");
        assert_eq!(serial.prims, parallel.prims);
        assert_eq!(serial.stats.leaves, parallel.stats.leaves);
        assert_eq!(serial.stats.inner_nodes, parallel.stats.inner_nodes);
        assert_eq!(serial.stats.max_depth, parallel.stats.max_depth);
    }

    /// The GLSL twin's constants are the Rust ones, bit for bit.
    #[test]
    fn glsl_constants_match() {
        let glsl = include_str!("../shaders/bvh.glsl");
        let define = |name: &str| -> &str {
            let key = format!("#define {name} ");
            let line = glsl
                .lines()
                .find(|l| l.starts_with(&key))
                .unwrap_or_else(|| panic!("{name} not in bvh.glsl"));
            line[key.len()..].trim()
        };
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
        assert_eq!(bits("BVH_SPHERE_ON_SURFACE"), SPHERE_ON_SURFACE.to_bits());
        assert_eq!(bits("BVH_FLT_MAX"), f32::MAX.to_bits());
        assert_eq!(bits("SHADOW_EPSILON"), SHADOW_EPSILON.to_bits());
    }

    #[test]
    fn levels_needed_halves() {
        assert_eq!(levels_needed(MAX_LEAF), 0);
        assert_eq!(levels_needed(MAX_LEAF + 1), 1);
        assert_eq!(levels_needed(4 * MAX_LEAF), 2);
        assert_eq!(levels_needed(4 * MAX_LEAF + 1), 3);
    }
}
