//! The CPU traversal: the 8-wide tree ([`super::wide`]), near children first, with a private
//! stack. Its GLSL twin, `bvh_traverse` in `shaders/bvh.glsl`, walks the binary tree the wide
//! one was collapsed from, with the same box and primitive tests; the two meet the primitives
//! in different orders and find the same hit, because the tie rule (the [`crate::bvh`] module
//! documentation) does not depend on the order.

use super::intersect::{sphere, Ray};
use super::node::LEAF_FLAG;
use super::wide::{WIDE_STACK_SIZE, WIDTH};
use super::{Bvh, Hit, SPHERE_BIT};
use crate::scene::Scene;
use glam::{Vec2, Vec3};

/// No primitive to leave out.
const NONE: u32 = u32::MAX;

impl Bvh {
    /// Closest hit with t in (0, tmax); ties are resolved as the module documentation says.
    /// `scene` must be the scene the BVH was built from. A zero, infinite or NaN direction
    /// hits nothing. Panics on a tree built for the GPU alone ([`super::Traversal::GpuOnly`]).
    pub fn closest(&self, scene: &Scene, o: Vec3, d: Vec3, tmax: f32) -> Option<Hit> {
        self.traverse::<false>(scene, o, d, tmax, NONE)
    }

    /// Whether anything is hit with t in (0, tmax) (shadow rays).
    pub fn occluded(&self, scene: &Scene, o: Vec3, d: Vec3, tmax: f32) -> bool {
        self.traverse::<true>(scene, o, d, tmax, NONE).is_some()
    }

    /// [`closest`](Self::closest) for a ray that leaves the triangle `leaving` (a primitive
    /// reference, [`Hit::prim`]; a sphere's is ignored), which the traversal then does not
    /// test. The CPU reference's rays leave a surface from an origin offset off the triangle's
    /// plane to the side they go to (`crate::robust::offset_ray_origin`), and a plane is
    /// crossed at most once, so they cannot meet that triangle again: `closest` would test it,
    /// find `t` within its error bound of 0, redo the test in f64 and miss it. Skipping it
    /// gives the same hit without the two tests (`tests/bvh.rs` checks the same bits on rays
    /// leaving surfaces at many scales); only a direction within rounding of the plane itself
    /// could be told apart. GLSL twin: `trace_closest_leaving` (`shaders/bvh.glsl`), whose
    /// path state carries the primitive as `bvh_leaving_code`.
    // This and `occluded_leaving` are the CPU path loop's rays, each called from one place:
    // inlined there, as the profile-guided build and a build with fat LTO inline them (a
    // public function of the library is not one that LLVM sees used once, so the plain build
    // called them; docs/bench-log.md, "The path loop's two traversals inlined").
    #[inline(always)]
    pub fn closest_leaving(
        &self,
        scene: &Scene,
        o: Vec3,
        d: Vec3,
        tmax: f32,
        leaving: u32,
    ) -> Option<Hit> {
        self.traverse::<false>(scene, o, d, tmax, leaving)
    }

    /// [`occluded`](Self::occluded) for a ray that leaves the triangle `leaving`.
    #[inline(always)]
    pub fn occluded_leaving(
        &self,
        scene: &Scene,
        o: Vec3,
        d: Vec3,
        tmax: f32,
        leaving: u32,
    ) -> bool {
        self.traverse::<true>(scene, o, d, tmax, leaving).is_some()
    }

    // Inlined as the profile-guided build inlines it (docs/bench-log.md, "Hot functions inlined
    // by hand").
    #[inline(always)]
    fn traverse<const ANY: bool>(
        &self,
        scene: &Scene,
        o: Vec3,
        d: Vec3,
        tmax: f32,
        leaving: u32,
    ) -> Option<Hit> {
        assert!(
            !self.wide.is_empty(),
            "the CPU traversal of a BVH built for the GPU alone (bvh::Traversal::GpuOnly)"
        );
        let ray = Ray::new(o, d)?;
        let box_ray = ray.box_ray();
        let mut best = Hit {
            t: tmax,
            prim: u32::MAX,
            bary: Vec2::ZERO,
        };
        let mut found = false;
        // Not zeroed: zeroing its entries (183 for the 4-wide tree) for every ray made renders
        // 3–5 % slower (docs/bench-log.md), and only entries below `sp`, each written before,
        // are read.
        let mut stack = [std::mem::MaybeUninit::<u32>::uninit(); WIDE_STACK_SIZE];
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
                        sphere(o, d, s.center, s.radius, best.t).map(|t| (t, Vec2::ZERO))
                    } else if r == leaving {
                        None
                    } else {
                        ray.triangle(&self.leaf_triangles[i as usize], best.t)
                    };
                    if let Some((t, bary)) = h {
                        // The tie rule: a smaller t, or the same t and a smaller reference.
                        // Before the first hit, best.t is tmax and only t < tmax counts.
                        if t < best.t || (found && r < best.prim) {
                            best = Hit { t, prim: r, bary };
                            found = true;
                            if ANY {
                                return Some(best);
                            }
                        }
                    }
                }
            } else {
                let n = &self.wide[cur as usize];
                let (hits, tn) = box_ray.box_hit(&n.lo, &n.hi, best.t);
                let mut hits = hits & n.present;
                match hits.count_ones() {
                    0 => {}
                    1 => {
                        cur = n.child[hits.trailing_zeros() as usize];
                        continue;
                    }
                    k => {
                        // Near first: the hit children by entry distance (equal distances in
                        // child order), the nearest next and the others pushed far to near.
                        let mut order = [0usize; WIDTH];
                        for slot in order.iter_mut().take(k as usize) {
                            *slot = hits.trailing_zeros() as usize;
                            hits &= hits - 1;
                        }
                        let order = &mut order[..k as usize];
                        for i in 1..order.len() {
                            let mut j = i;
                            while j > 0 && tn[order[j]] < tn[order[j - 1]] {
                                order.swap(j, j - 1);
                                j -= 1;
                            }
                        }
                        for &c in order[1..].iter().rev() {
                            debug_assert!(sp < WIDE_STACK_SIZE, "BVH deeper than the stack");
                            if sp < WIDE_STACK_SIZE {
                                stack[sp].write(n.child[c]);
                                sp += 1;
                            }
                        }
                        cur = n.child[order[0]];
                        continue;
                    }
                }
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            // SAFETY: entry sp < the number pushed, and every push writes its entry.
            cur = unsafe { stack[sp].assume_init() };
        }
        found.then_some(best)
    }
}
