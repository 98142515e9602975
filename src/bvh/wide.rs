//! The CPU traversal's 8-wide tree: the binary tree collapsed (each wide node holds up to
//! [`WIDTH`] of a binary node's descendants), with the children's boxes stored axis by axis so
//! that one SIMD test checks them all (one 256-bit register per plane with AVX, two with SSE).
//! Eight children, as Embree's BVH8 has on AVX machines: against four, the CPU reference's
//! renders are 3–6 % faster with the same pixels (docs/bench-log.md); sixteen gained nothing
//! more. Its leaves are the binary tree's leaves, so it indexes the same
//! [`super::Bvh::prims`]. The GPU kernels walk the binary tree; both find the same hits
//! because the tie rule does not depend on the order in which primitives are met (the
//! [`crate::bvh`] module documentation).

use super::build::children;
use super::node::{link, GpuNode};
use super::MAX_DEPTH;

/// Children per wide node.
pub const WIDTH: usize = 8;

/// One value per child of a wide node.
pub type Lanes = [f32; WIDTH];

// The box test compares its lanes four at a time (`intersect::BoxRay::box_hit`).
const _: () = assert!(WIDTH % 4 == 0 && WIDTH <= 32);

/// Traversal stack entries for the wide tree: visiting a node at wide depth k leaves at most
/// `WIDTH - 1` entries per level above it and as many of its own, and a wide node is never
/// deeper than the binary node it was made from.
pub(super) const WIDE_STACK_SIZE: usize = (WIDTH - 1) * (MAX_DEPTH as usize + 1);

/// One node of the wide tree (256 bytes, four cache lines).
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WideNode {
    /// The children's lower box corners: x of all children, then y, then z.
    pub lo: [Lanes; 3],
    /// The children's upper box corners, likewise.
    pub hi: [Lanes; 3],
    /// Child links in the stack encoding ([`super::node::link`]) over wide nodes and
    /// `prims`; 0 for an absent child (the root, node 0, is nobody's child).
    pub child: [u32; WIDTH],
    /// Bit k set where child k is present (`child[k] != 0`).
    pub present: u32,
}

const _: () = assert!(std::mem::size_of::<WideNode>() == 256);

impl WideNode {
    const EMPTY: WideNode = WideNode {
        lo: [[0.0; WIDTH]; 3],
        hi: [[0.0; WIDTH]; 3],
        child: [0; WIDTH],
        present: 0,
    };
}

/// The wide tree of the binary tree `nodes` (root = node 0, which every built tree has),
/// appended to `out` (empty). Each wide node starts from a binary node's children and opens
/// the inner child with the largest box until it has four children or only leaves; the wide
/// children of a node are stored next to each other.
pub(super) fn collapse(nodes: &[GpuNode], out: &mut Vec<WideNode>) {
    debug_assert!(out.is_empty());
    if nodes.is_empty() {
        return;
    }
    out.push(WideNode::EMPTY);
    fill(nodes, 0, 0, out);
}

fn fill(nodes: &[GpuNode], binary: usize, wide: usize, out: &mut Vec<WideNode>) {
    let mut kids: Vec<_> = children(&nodes[binary]).collect();
    while kids.len() < WIDTH {
        let area = |i: usize| kids[i].bounds.half_area();
        let widest = (0..kids.len())
            .filter(|&i| kids[i].is_inner())
            .max_by(|&a, &b| area(a).total_cmp(&area(b)));
        let Some(i) = widest else { break };
        let opened = kids.remove(i);
        for (k, c) in children(&nodes[opened.index as usize]).enumerate() {
            kids.insert(i + k, c);
        }
    }
    // The wide nodes of the inner children, next to each other: first, first + 1, ...
    let first = out.len();
    let mut below = Vec::new();
    let mut node = WideNode::EMPTY;
    for (k, c) in kids.iter().enumerate() {
        for a in 0..3 {
            node.lo[a][k] = c.bounds.min[a];
            node.hi[a][k] = c.bounds.max[a];
        }
        node.child[k] = if c.is_inner() {
            let w = first + below.len();
            below.push((c.index as usize, w));
            link(w as u32, 0)
        } else {
            link(c.index, c.count)
        };
        node.present |= 1 << k;
    }
    out.resize(first + below.len(), WideNode::EMPTY);
    out[wide] = node;
    for (b, w) in below {
        fill(nodes, b, w, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::node::LEAF_FLAG;

    type Leaf = (u32, [f32; 3], [f32; 3]);

    /// The leaves under binary node `n` (as stack links, with their boxes), left to right.
    fn binary_leaves(nodes: &[GpuNode], n: usize, out: &mut Vec<Leaf>) {
        for c in children(&nodes[n]) {
            if c.is_inner() {
                binary_leaves(nodes, c.index as usize, out);
            } else {
                let (lo, hi) = (c.bounds.min.to_array(), c.bounds.max.to_array());
                out.push((link(c.index, c.count), lo, hi));
            }
        }
    }

    /// The leaves under wide node `n`, likewise; checks that every node is reached once.
    fn wide_leaves(wide: &[WideNode], n: usize, seen: &mut [bool], out: &mut Vec<Leaf>) {
        assert!(!seen[n], "wide node {n} reached twice");
        seen[n] = true;
        let w = &wide[n];
        for k in 0..WIDTH {
            let c = w.child[k];
            if c & LEAF_FLAG != 0 {
                let lo = [0, 1, 2].map(|a| w.lo[a][k]);
                let hi = [0, 1, 2].map(|a| w.hi[a][k]);
                out.push((c, lo, hi));
            } else if c != 0 {
                wide_leaves(wide, c as usize, seen, out);
            }
        }
    }

    /// The wide tree of a real build holds the binary tree's leaves with their boxes, each
    /// once and in the same left-to-right order, in fewer nodes, each one full unless all its
    /// children are leaves.
    #[test]
    fn collapse_keeps_every_leaf_once_in_order() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
        let mut s = crate::scene::load(&path).unwrap();
        crate::bench::add_sphere_mesh(&mut s, 20_000);
        let b = crate::bvh::build(&s);
        let mut want = Vec::new();
        binary_leaves(&b.nodes, 0, &mut want);
        let mut got = Vec::new();
        let mut seen = vec![false; b.wide.len()];
        wide_leaves(&b.wide, 0, &mut seen, &mut got);
        assert_eq!(got.len(), b.stats.leaves);
        assert!(
            got == want,
            "the wide tree's leaves differ from the binary tree's"
        );
        assert!(seen.iter().all(|&s| s), "unreachable wide nodes");
        let (w, n) = (b.wide.len(), b.nodes.len());
        assert!(w * 2 < n, "{w} wide nodes for {n} binary ones");
        // A node with room left has only leaves: there was no inner child to open. Its
        // `present` bits are its links that are not 0.
        for (i, n) in b.wide.iter().enumerate() {
            let links = n.child.iter().enumerate();
            let mask = links.fold(0, |m, (k, &c)| m | u32::from(c != 0) << k);
            assert_eq!(n.present, mask, "node {i}");
            let present = n.child.iter().filter(|&&c| c != 0).count();
            let inner = n
                .child
                .iter()
                .filter(|&&c| c != 0 && c & LEAF_FLAG == 0)
                .count();
            assert!(present == WIDTH || inner == 0, "node {i}: {:?}", n.child);
        }
    }

    /// A one-leaf scene: the root's left child is the leaf, the right one absent.
    #[test]
    fn collapse_of_a_single_leaf_and_of_an_empty_tree() {
        let leaf = GpuNode {
            lmax: [1.0; 3],
            left: 0,
            left_count: 3,
            ..Default::default()
        };
        let mut w = Vec::new();
        collapse(&[leaf], &mut w);
        assert_eq!(w.len(), 1);
        let mut want = [0; WIDTH];
        want[0] = link(0, 3);
        assert_eq!(w[0].child, want);
        let mut w = Vec::new();
        collapse(&[GpuNode::default()], &mut w);
        assert_eq!(w.len(), 1);
        assert_eq!(w[0].child, [0; WIDTH]);
    }
}
