//! Surface interactions and light samples for the CPU reference renderer.
//! GLSL twin: `shaders/wavefront/surface.glsl` (surfaces and light sampling).

use crate::bvh::{Hit, SPHERE_BIT};
use crate::lights::{pair_barycentrics, DeltaEntry, LightTable, PAIR_BIT};
use crate::robust::{pull_inside, sphere_point, triangle_point};
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Local shading frame: z = shading normal, x = tangent, y = bitangent.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub t: Vec3,
    pub b: Vec3,
    pub n: Vec3,
}

impl Frame {
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

/// A tangent for `n` when the surface gives none (Duff et al. 2017, "Building an Orthonormal
/// Basis, Revisited", JCGT 6(1)); the sign uses `n.z >= 0` so both sides agree at -0.
pub fn default_tangent(n: Vec3) -> Vec3 {
    let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x)
}

/// Orthonormal frame from a shading normal and a tangent hint (Gram–Schmidt).
pub fn make_frame(n: Vec3, tangent_hint: Vec3) -> Frame {
    let mut t = tangent_hint - n * n.dot(tangent_hint);
    let len2 = t.length_squared();
    t = if len2 > 1e-12 {
        t / len2.sqrt()
    } else {
        default_tangent(n)
    };
    Frame {
        t,
        b: n.cross(t),
        n,
    }
}

pub struct Surface {
    pub p: Vec3,
    /// Absolute rounding-error bound of `p`, per coordinate (for `robust::offset_ray_origin`).
    pub p_err: Vec3,
    /// Unit geometric normal on the front side.
    pub ng: Vec3,
    /// The ray arrived at the front side.
    pub front: bool,
    pub frame: Frame,
    pub material: u32,
    pub emitter: Option<u32>,
    /// The primitive reference of the hit ([`Hit::prim`]).
    pub prim: u32,
    /// Texture coordinates (`crate::texture::hit_uv`), set only in a scene with textures.
    pub uv: Vec2,
}

impl Surface {
    /// The same surface seen as a front from behind: both normals reversed (the tangent kept,
    /// the frame right-handed), for two-sided materials.
    pub fn turned(&self) -> Surface {
        Surface {
            ng: -self.ng,
            frame: Frame {
                t: self.frame.t,
                b: -self.frame.b,
                n: -self.frame.n,
            },
            ..*self
        }
    }
}

/// Reconstruct the hit surface from the BVH hit record (position from barycentrics, not o + t·d).
/// `normals` holds each triangle's geometric normal ([`crate::scene::Triangle::geometric_normal`]).
// Inlined as the profile-guided build inlines it (docs/bench-log.md, "Hot functions inlined
// by hand").
#[inline(always)]
pub fn surface_at(scene: &Scene, normals: &[Vec3], hit: &Hit, o: Vec3, d: Vec3) -> Surface {
    if hit.prim & SPHERE_BIT != 0 {
        let s = &scene.spheres[(hit.prim & !SPHERE_BIT) as usize];
        let toward = o.as_dvec3() + d.as_dvec3() * hit.t as f64 - s.center.as_dvec3();
        let (p, p_err, out) = sphere_point(s.center, s.radius, toward);
        let ng = if s.inward { -out } else { out };
        let front = d.dot(ng) < 0.0;
        // Tangent along lines of latitude around the world y axis.
        let hint = Vec3::Y.cross(out);
        Surface {
            p,
            p_err,
            ng,
            front,
            frame: make_frame(ng, hint),
            material: s.material,
            emitter: s.emitter,
            prim: hit.prim,
            uv: Vec2::ZERO,
        }
    } else {
        let tri = &scene.triangles[hit.prim as usize];
        let (b1, b2) = (hit.bary.x, hit.bary.y);
        let b0 = 1.0 - b1 - b2;
        let [v0, v1, v2] = tri.v;
        let (pb1, pb2) = pull_inside(&tri.v, b1, b2);
        let (p, p_err) = triangle_point(&tri.v, pb1, pb2);
        let e1 = v1 - v0;
        let e2 = v2 - v0;
        let ng = normals[hit.prim as usize];
        let front = d.dot(ng) < 0.0;
        let mut ns = ng;
        let attributes = scene.attributes_of(hit.prim as usize);
        if let Some([n0, n1, n2]) = attributes.n {
            let n = n0 * b0 + n1 * b1 + n2 * b2;
            let len2 = n.length_squared();
            if len2 > 1e-12 {
                let n = n / len2.sqrt();
                if n.dot(ng) > 0.0 {
                    ns = n;
                }
            }
        }
        let mut hint = default_tangent(ns);
        if let Some([uv0, uv1, uv2]) = attributes.uv {
            let du1: Vec2 = uv1 - uv0;
            let du2: Vec2 = uv2 - uv0;
            let det = du1.x * du2.y - du1.y * du2.x;
            if det.abs() > 1e-12 {
                hint = (e1 * du2.y - e2 * du1.y) / det;
            }
        }
        Surface {
            p,
            p_err,
            ng,
            front,
            frame: make_frame(ns, hint),
            material: tri.material,
            emitter: tri.emitter,
            prim: hit.prim,
            uv: Vec2::ZERO,
        }
    }
}

pub struct LightSample {
    pub p: Vec3,
    /// Absolute rounding-error bound of `p`, per coordinate.
    pub p_err: Vec3,
    /// Unit normal on the emitting side.
    pub n: Vec3,
    pub radiance: Vec3,
    /// The emitter's light-selection density per unit area, lum(Le)/W.
    pub density: f32,
}

/// Choose an emissive primitive by power and a point uniformly by area on it (a pair of
/// triangles by one 2-D sample over both, [`pair_barycentrics`]). `normals` as for
/// [`surface_at`].
// Inlined as the profile-guided build inlines it (docs/bench-log.md, "Hot functions inlined
// by hand").
#[inline(always)]
pub fn sample_light(
    scene: &Scene,
    normals: &[Vec3],
    lights: &LightTable,
    u_sel: f32,
    u1: f32,
    u2: f32,
) -> LightSample {
    let prim = lights.prims[lights.select(u_sel)];
    if prim & SPHERE_BIT != 0 {
        let s = &scene.spheres[(prim & !SPHERE_BIT) as usize];
        let z = 1.0 - 2.0 * u1;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * PI * u2;
        let dir = Vec3::new(r * phi.cos(), r * phi.sin(), z);
        let e = s.emitter.expect("light table holds emitters only");
        let (p, p_err, dir) = sphere_point(s.center, s.radius, dir.as_dvec3());
        LightSample {
            p,
            p_err,
            n: if s.inward { -dir } else { dir },
            radiance: scene.emitters[e as usize].radiance,
            density: lights.select_density[e as usize],
        }
    } else {
        let (index, b1, b2) = triangle_light_point(prim, u1, u2);
        let t = &scene.triangles[index];
        let e = t.emitter.expect("light table holds emitters only");
        let (p, p_err) = triangle_point(&t.v, b1, b2);
        LightSample {
            p,
            p_err,
            n: normals[index],
            radiance: scene.emitters[e as usize].radiance,
            density: lights.select_density[e as usize],
        }
    }
}

/// The triangle and the barycentrics (b1, b2) of a point uniform by area on the light-table
/// entry `prim` (a triangle, or a pair of them by one 2-D sample over both,
/// [`pair_barycentrics`]), from the 2-D sample (u1, u2).
#[inline(always)]
pub fn triangle_light_point(prim: u32, u1: f32, u2: f32) -> (usize, f32, f32) {
    if prim & PAIR_BIT != 0 {
        let (second, b1, b2) = pair_barycentrics(u1, u2);
        ((prim & !PAIR_BIT) as usize + second as usize, b1, b2)
    } else {
        let su = u1.sqrt();
        let b0 = 1.0 - su;
        let b1 = u2 * su;
        (prim as usize, b1, 1.0 - b0 - b1)
    }
}

/// Next-event estimation towards a delta light from `origin`: the direction to it, the length
/// of the shadow ray and the incident radiance divided by the light's selection probability
/// and the (Dirac) density, `I / (r² p_sel)` for a point light and `E / p_sel` for a
/// directional one. `None` when the origin is at the point light.
pub struct DeltaSample {
    pub wi: Vec3,
    pub tmax: f32,
    pub li: Vec3,
}

pub fn sample_delta_light(l: &DeltaEntry, origin: Vec3) -> Option<DeltaSample> {
    if l.select_prob <= 0.0 {
        return None;
    }
    if l.directional {
        return Some(DeltaSample {
            wi: l.v,
            tmax: f32::MAX,
            li: l.value / l.select_prob,
        });
    }
    let to_light = l.v - origin;
    let dist2 = to_light.length_squared();
    if dist2.is_nan() || dist2 <= 0.0 {
        return None;
    }
    let dist = dist2.sqrt();
    Some(DeltaSample {
        wi: to_light / dist,
        tmax: dist * (1.0 - crate::robust::SHADOW_EPSILON),
        li: l.value / (dist2 * l.select_prob),
    })
}

/// Solid-angle density of NEE choosing a point of an emitter with selection density `density`
/// (lum(Le)/W, [`LightTable::select_density`]) at distance² `dist2` whose emitting side makes
/// cosine `cos_light` with the direction back to the shading point.
pub fn light_pdf(density: f32, dist2: f32, cos_light: f32) -> f32 {
    if cos_light <= 0.0 || density <= 0.0 {
        return 0.0;
    }
    density * dist2 / cos_light
}

/// Power heuristic (β = 2) weight of a strategy with density `a` against one with `b`,
/// written so that huge densities cannot overflow into inf/inf.
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    if a <= 0.0 {
        return 0.0;
    }
    let r = (b / a).min(1e18);
    1.0 / (1.0 + r * r)
}
