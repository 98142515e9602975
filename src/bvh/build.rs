//! Binned-SAH construction (Wald 2007; see the [`crate::bvh`] module documentation): the
//! centroid-binned sweep, the object-median fallback that bounds the depth, and the parallel
//! build of large subtrees, which gives the serial build's tree node for node.

use super::node::{GpuNode, MAX_PRIMS, STACK_SIZE};
use super::{Bvh, BvhStats, SPHERE_BIT};
use crate::memory::huge_page_vec;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;

/// Centroid bins per axis in the SAH sweep.
pub const BINS: usize = 16;
/// Most primitives in one leaf (the stack encoding keeps `count - 1` in 3 bits).
pub const MAX_LEAF: usize = 8;
/// SAH cost of visiting one inner node (two box tests).
pub const C_TRAV: f32 = 1.0;
/// SAH cost of one primitive test.
pub const C_INT: f32 = 1.0;
/// Deepest inner node (root = depth 0). Processing an inner node at depth k leaves at most
/// k + 1 entries on the stack, so `MAX_DEPTH <` [`STACK_SIZE`] means the stack never overflows.
pub const MAX_DEPTH: u32 = 60;
const _: () = assert!((MAX_DEPTH as usize) < STACK_SIZE);

#[derive(Clone, Copy)]
pub(super) struct Aabb {
    pub(super) min: Vec3,
    pub(super) max: Vec3,
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
    /// [`Aabb::grow`] for the boxes that only the SAH costs read (the bins): plain compares,
    /// cheaper than `f32::min`'s NaN handling. The boxes hold no NaN, so only the sign of a
    /// zero bound can differ, which changes no extent and so no cost.
    fn grow_bin(&mut self, b: &Aabb) {
        let lo = |a: f32, b: f32| if b < a { b } else { a };
        let hi = |a: f32, b: f32| if b > a { b } else { a };
        let (m, n) = (self.min, self.max);
        self.min = Vec3::new(lo(m.x, b.min.x), lo(m.y, b.min.y), lo(m.z, b.min.z));
        self.max = Vec3::new(hi(n.x, b.max.x), hi(n.y, b.max.y), hi(n.z, b.max.z));
    }
    /// Half the surface area (f64: no overflow for huge boxes); 0 for empty or flat boxes.
    pub(super) fn half_area(&self) -> f64 {
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

/// A child link: under construction, or read back from a node ([`children`]).
#[derive(Clone, Copy)]
pub(super) struct Link {
    pub(super) bounds: Aabb,
    /// Node index if `count == 0`, else first index into `prims` (the [`GpuNode`] fields).
    pub(super) index: u32,
    pub(super) count: u32,
}

impl Link {
    pub(super) fn is_inner(&self) -> bool {
        self.count == 0
    }
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
/// this builder's, numbered from 0, and `later` those its parallel subtrees made, which follow
/// them (a parent rebases them when it assembles them).
struct Builder<'a> {
    boxes: &'a [Aabb],
    centroids: &'a [Vec3],
    order: &'a mut [u32],
    base: usize,
    /// Subtrees over at least this many primitives are built in parallel.
    parallel_prims: usize,
    nodes: Vec<GpuNode>,
    /// The nodes of subtrees built by other builders, in order after `nodes`, each run with
    /// the offset its inner links still need. Kept as runs and joined once at the end: each
    /// parallel level appending its children's nodes copied the upper subtrees' nodes once per
    /// level (about 6 copies of 34 MB on the 1M-triangle scene).
    later: Vec<(u32, Vec<GpuNode>)>,
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

/// An empty vector with room for `n` values, for one of the arrays the traversals read at
/// random (primitive references, leaf triangles, wide nodes): on huge pages where the CPU
/// traversal reads it ([`huge_page_vec`], fewer TLB misses). Arrays that only the GPU reads
/// (uploaded, then freed), and the binary nodes (which the CPU traversal no longer reads), get
/// plain vectors: memory in huge pages that is freed back to the heap is returned to the system
/// only in whole 2 MiB blocks (lavapipe's peak on the 1M-triangle scene rose by 60 MB with
/// them).
fn array_for<T>(cpu_reads_it: bool, n: usize) -> Vec<T> {
    if cpu_reads_it {
        huge_page_vec(n)
    } else {
        Vec::with_capacity(n)
    }
}

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
    /// Nodes made so far, `later` included.
    fn len(&self) -> usize {
        self.nodes.len() + self.later.iter().map(|(_, v)| v.len()).sum::<usize>()
    }

    /// All nodes in one vector: `nodes`, then the runs of `later` rebased, each run freed once
    /// copied.
    fn join(nodes: Vec<GpuNode>, later: Vec<(u32, Vec<GpuNode>)>) -> Vec<GpuNode> {
        let total = nodes.len() + later.iter().map(|(_, v)| v.len()).sum::<usize>();
        let mut all = array_for(false, total);
        all.extend_from_slice(&nodes);
        drop(nodes);
        for (offset, mut run) in later {
            rebase(&mut run, offset);
            all.extend_from_slice(&run);
        }
        all
    }

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
        // The axes with extent (also false for NaN or infinite extents), and their bin scales.
        let scale: [Option<f32>; 3] = std::array::from_fn(|axis| {
            let extent = cb.max[axis] - cb.min[axis];
            (extent > 0.0 && extent < f32::INFINITY).then(|| BINS as f32 / extent)
        });
        // All three axes binned in one pass over the primitives: each primitive's box and
        // centroid are fetched once, not once per axis (the same bins, so the same tree).
        let mut bin_box = [[Aabb::EMPTY; BINS]; 3];
        let mut bin_n = [[0u32; BINS]; 3];
        for &i in self.range(start, end) {
            let (c, bx) = (self.centroids[i as usize], &self.boxes[i as usize]);
            for axis in 0..3 {
                if let Some(scale) = scale[axis] {
                    let b = bin_of(c[axis], cb.min[axis], scale);
                    bin_n[axis][b] += 1;
                    bin_box[axis][b].grow_bin(bx);
                }
            }
        }
        for axis in 0..3 {
            if scale[axis].is_none() {
                continue;
            }
            let (bin_box, bin_n) = (&bin_box[axis], &bin_n[axis]);
            // Sweep from the right: area·count of bins k.. for every k (infinite while empty).
            // An empty bin changes neither box nor count: its entry repeats the one after it.
            let mut right_cost = [f64::INFINITY; BINS + 1];
            let mut acc = Aabb::EMPTY;
            let mut n = 0;
            for k in (1..BINS).rev() {
                right_cost[k] = right_cost[k + 1];
                if bin_n[k] > 0 {
                    acc.grow_bin(&bin_box[k]);
                    n += bin_n[k];
                    right_cost[k] = acc.half_area() * n as f64;
                }
            }
            let mut acc = Aabb::EMPTY;
            let mut n = 0;
            for k in 1..BINS {
                // After an empty bin k - 1 the split at k is the split at k - 1 again, which
                // costs the same and so never wins (only a strictly lower cost does).
                if bin_n[k - 1] == 0 {
                    continue;
                }
                acc.grow_bin(&bin_box[k - 1]);
                n += bin_n[k - 1];
                if right_cost[k] == f64::INFINITY {
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
                // Nodes come only before a builder's parallel subtrees: `nodes` is its first run.
                debug_assert!(self.later.is_empty());
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
            later: Vec::new(),
            stats: BvhStats::default(),
            sah_sum: 0.0,
        };
        let ((mut l, lb), (mut r, rb)) = rayon::join(
            || {
                let mut b = sub(lo, start);
                let link = b.build(start, mid, depth, false);
                (link, (b.nodes, b.later, b.stats, b.sah_sum))
            },
            || {
                let mut b = sub(hi, mid);
                let link = b.build(mid, end, depth, false);
                (link, (b.nodes, b.later, b.stats, b.sah_sum))
            },
        );
        self.order = order;
        for (link, (nodes, later, t, sah)) in [(&mut l, lb), (&mut r, rb)] {
            let offset = self.len() as u32;
            if link.count == 0 {
                link.index += offset;
            }
            self.later.push((offset, nodes));
            let runs = later.into_iter().map(|(o, run)| (o + offset, run));
            self.later.extend(runs);
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

/// The present children of node `n`, left first: [`make_node`] read back.
pub(super) fn children(n: &GpuNode) -> impl Iterator<Item = Link> {
    let link = |min: [f32; 3], max: [f32; 3], index, count| Link {
        bounds: Aabb {
            min: Vec3::from_array(min),
            max: Vec3::from_array(max),
        },
        index,
        count,
    };
    let l = link(n.lmin, n.lmax, n.left, n.left_count);
    let r = link(n.rmin, n.rmax, n.right, n.right_count);
    [l, r].into_iter().filter(|c| c.count != 0 || c.index != 0)
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
    build_with(scene, PARALLEL_PRIMS, Traversal::Both)
}

/// Which traversals a tree is for. The GPU kernels walk the binary [`Bvh::nodes`] and read the
/// scene's own triangle buffer; the CPU traversal walks the 8-wide [`Bvh::wide`], collapsed
/// from them, and reads each leaf's triangles from a copy in leaf order
/// ([`Bvh::leaf_triangles`], 36 bytes a triangle). A tree for one renderer leaves out what only
/// the other reads (for a million triangles 36 MB of triangles, or the binary nodes once the
/// wide tree is made: the renderers' peak memory, docs/bench-log.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Traversal {
    /// Both: everything [`Bvh`] holds ([`build`]; the tests compare the two traversals).
    Both,
    /// The CPU traversal only: `nodes` is empty (freed once collapsed into `wide`).
    CpuOnly,
    /// The GPU kernels only: no [`Bvh::leaf_triangles`] and no [`Bvh::wide`];
    /// [`Bvh::closest`] and [`Bvh::occluded`] panic on such a tree.
    GpuOnly,
}

impl Traversal {
    fn cpu(self) -> bool {
        self != Traversal::GpuOnly
    }
}

/// [`build`] for the renderer `traversal` says: the same nodes and primitives either way.
pub fn build_for(scene: &Scene, traversal: Traversal) -> Bvh {
    build_with(scene, PARALLEL_PRIMS, traversal)
}

/// [`build_for`], with subtrees of at least `parallel_prims` primitives built on two threads.
pub(super) fn build_with(scene: &Scene, parallel_prims: usize, traversal: Traversal) -> Bvh {
    let n = scene.triangles.len() + scene.spheres.len();
    assert!(
        n <= MAX_PRIMS,
        "the BVH supports at most {MAX_PRIMS} primitives, the scene has {n}"
    );
    let refs: Vec<u32> = (0..scene.triangles.len() as u32)
        .chain((0..scene.spheres.len() as u32).map(|i| i | SPHERE_BIT))
        .collect();
    let boxes: Vec<Aabb> = refs.par_iter().map(|&r| prim_box(scene, r)).collect();
    let centroids: Vec<Vec3> = boxes.par_iter().map(|b| (b.min + b.max) * 0.5).collect();
    let mut order: Vec<u32> = (0..n as u32).into_par_iter().collect();
    let mut b = Builder {
        boxes: &boxes,
        centroids: &centroids,
        order: &mut order,
        base: 0,
        parallel_prims,
        nodes: Vec::new(),
        later: Vec::new(),
        stats: BvhStats {
            primitives: n,
            ..Default::default()
        },
        sah_sum: 0.0,
    };
    let root = b.build(0, n, 0, true);
    let (sah_sum, mut stats, first, later) = (b.sah_sum, b.stats, b.nodes, b.later);
    // The boxes and centroids are the build's alone: freed before the nodes are joined and the
    // leaves' triangles gathered, they no longer add to the set-up's peak memory (37 MB for a
    // million triangles; docs/bench-log.md).
    drop((boxes, centroids));
    let mut nodes = Builder::join(first, later);
    // The wide tree straight after the nodes, so that a tree for the CPU alone frees them
    // before the primitive arrays are made.
    let wide = if traversal.cpu() {
        let mut w = array_for(true, nodes.len());
        super::wide::collapse(&nodes, &mut w);
        w
    } else {
        Vec::new()
    };
    if traversal == Traversal::CpuOnly {
        nodes = Vec::new();
    }
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
    let mut prims: Vec<u32> = array_for(traversal.cpu(), order.len());
    prims.par_extend(order.par_iter().map(|&i| refs[i as usize]));
    drop((refs, order));
    let leaf_triangles = if traversal.cpu() {
        let mut v = array_for(true, prims.len());
        v.par_extend(prims.par_iter().map(|&r| match r & SPHERE_BIT {
            0 => scene.triangles[r as usize].v,
            _ => [Vec3::ZERO; 3],
        }));
        v
    } else {
        Vec::new()
    };
    let (bounds_min, bounds_max) = if n > 0 {
        (root.bounds.min, root.bounds.max)
    } else {
        (Vec3::ZERO, Vec3::ZERO)
    };
    Bvh {
        nodes,
        prims,
        leaf_triangles,
        wide,
        bounds_min,
        bounds_max,
        stats,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Building subtrees in parallel gives the serial build's tree, node for node.
    #[test]
    fn parallel_build_equals_serial_build() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
        let mut s = crate::scene::load(&path).unwrap();
        crate::bench::add_sphere_mesh(&mut s, 40_000);
        let serial = build_with(&s, usize::MAX, Traversal::Both);
        let parallel = build_with(&s, 1000, Traversal::Both);
        assert!(serial.nodes.len() > 1000);
        assert!(serial.nodes == parallel.nodes, "nodes differ");
        assert_eq!(serial.prims, parallel.prims);
        assert_eq!(serial.stats.leaves, parallel.stats.leaves);
        assert_eq!(serial.stats.inner_nodes, parallel.stats.inner_nodes);
        assert_eq!(serial.stats.max_depth, parallel.stats.max_depth);
        assert_eq!(serial.leaf_triangles, parallel.leaf_triangles);
    }

    /// A tree for one renderer is the tree for both without what only the other reads: the
    /// GPU's without the leaves' triangles and the wide tree, the CPU's without the binary
    /// nodes.
    #[test]
    fn single_renderer_builds_are_the_same_tree_without_the_other_half() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
        let mut s = crate::scene::load(&path).unwrap();
        crate::bench::add_sphere_mesh(&mut s, 4_000);
        let both = build_for(&s, Traversal::Both);
        let gpu = build_for(&s, Traversal::GpuOnly);
        let cpu = build_for(&s, Traversal::CpuOnly);
        assert!(both.nodes == gpu.nodes, "nodes differ");
        assert_eq!(both.prims, gpu.prims);
        assert_eq!(both.leaf_triangles.len(), both.prims.len());
        assert!(gpu.leaf_triangles.is_empty() && gpu.wide.is_empty());
        assert!(cpu.nodes.is_empty());
        assert!(cpu.wide == both.wide, "wide nodes differ");
        assert_eq!(cpu.prims, both.prims);
        assert_eq!(cpu.leaf_triangles, both.leaf_triangles);
        assert_eq!(cpu.stats, both.stats);
    }

    #[test]
    fn levels_needed_halves() {
        assert_eq!(levels_needed(MAX_LEAF), 0);
        assert_eq!(levels_needed(MAX_LEAF + 1), 1);
        assert_eq!(levels_needed(4 * MAX_LEAF), 2);
        assert_eq!(levels_needed(4 * MAX_LEAF + 1), 3);
    }
}
