//! The CPU traversal: near child first, with a private stack (GLSL twin: `bvh_traverse` in
//! `shaders/bvh.glsl`, the same nodes and primitives in the same order); the tie rule is the
//! [`crate::bvh`] module documentation's.

use super::intersect::{intersect_sphere, Ray};
use super::node::{link, LEAF_FLAG, STACK_SIZE};
use super::{Bvh, Hit, SPHERE_BIT};
use crate::scene::Scene;
use glam::{Vec2, Vec3};

impl Bvh {
    /// Closest hit with t in (0, tmax); ties are resolved as the module documentation says.
    /// `scene` must be the scene the BVH was built from. A zero, infinite or NaN direction
    /// hits nothing. Panics on a tree built for the GPU alone ([`super::Traversal::GpuOnly`]).
    pub fn closest(&self, scene: &Scene, o: Vec3, d: Vec3, tmax: f32) -> Option<Hit> {
        self.traverse::<false>(scene, o, d, tmax)
    }

    /// Whether anything is hit with t in (0, tmax) (shadow rays).
    pub fn occluded(&self, scene: &Scene, o: Vec3, d: Vec3, tmax: f32) -> bool {
        self.traverse::<true>(scene, o, d, tmax).is_some()
    }

    fn traverse<const ANY: bool>(&self, scene: &Scene, o: Vec3, d: Vec3, tmax: f32) -> Option<Hit> {
        assert!(
            self.leaf_triangles.len() == self.prims.len(),
            "the CPU traversal of a BVH built for the GPU alone (bvh::Traversal::GpuOnly)"
        );
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
                let [lmin, lmax, rmin, rmax] = n.corners();
                let (hl, tl) = ray.box_hit(lmin, lmax, best.t);
                let (hr, tr) = ray.box_hit(rmin, rmax, best.t);
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
