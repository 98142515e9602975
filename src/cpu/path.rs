//! The integrator's steps along one path that come before shading: the camera ray and the end
//! of a path segment. GLSL twin (independent code, same conventions and random-number keys):
//! `camera_ray` and `segment_end` in `shaders/wavefront/path.glsl`; shading a vertex is
//! [`super::scatter`].

use super::surface::{light_pdf, power_heuristic, surface_at, Surface};
use super::{CpuRenderer, PathStats};
use crate::rng::{dim, LaneRng};
use glam::Vec3;

/// The most emitters a camera ray passes through with hidden emitters (`hide_emitters`);
/// GLSL twin: `HIDE_PASSES` in path.glsl.
pub(super) const HIDE_PASSES: u32 = 16;

/// What the end of a path segment gives (the GLSL `segment_end`'s `e` and return value).
#[derive(Default)]
pub(super) struct SegmentEnd {
    /// The emitted light seen there, MIS-weighted against next-event estimation, or the
    /// environment on a miss; `None` when there is none or it was not finite (counted).
    pub e: Option<Vec3>,
    /// The surface the path goes on from, for shading; `None` when the path ends there.
    pub surface: Option<Surface>,
}

impl CpuRenderer<'_> {
    /// The MIS weight of the environment map's light seen along `d` by a BSDF sample of
    /// solid-angle pdf `prev_pdf` (1 after the camera and after delta lobes), against
    /// next-event estimation choosing the map and then `d`. GLSL twin: `env_weight`
    /// (envmap.glsl).
    pub(super) fn env_weight(&self, m: &crate::envmap::EnvMap, d: Vec3, prev_pdf: f32) -> f32 {
        if prev_pdf > 0.0 {
            power_heuristic(prev_pdf, self.lights.env_select * m.pdf(d))
        } else {
            1.0
        }
    }

    /// Camera ray through pixel (x, y): box pixel filter, uniform position in the pixel; from
    /// a point of the lens when the camera has one (`crate::camera`).
    pub(super) fn camera_ray(&self, x: u32, y: u32, rng: &mut LaneRng) -> (Vec3, Vec3) {
        let s = self.scene;
        let sub_pixel = rng.get2(0, dim::PIXEL_X);
        let fx = x as f32 + sub_pixel.x;
        let fy = y as f32 + sub_pixel.y;
        if self.camera.thin_lens() {
            let u = rng.get2(0, dim::LENS_U);
            return self.camera.lens_ray(fx, fy, s.width, s.height, u);
        }
        let o = self.camera.origin;
        let d = self.camera.ray_direction(fx, fy, s.width, s.height);
        (o, d)
    }

    /// The end of path segment `depth` (ray o + t d, throughput `beta`, `prev_pdf` the
    /// solid-angle pdf of the BSDF sample that chose d, or 0): the light seen there, and the
    /// surface when the path goes on from it; it ends on a miss, a back face, at the depth
    /// limit and on a black surface. A non-finite light is counted (the GPU's `extend`) and
    /// dropped.
    // Out of line for the lanes' scalar fall-back; `trace_path` inlines `segment_end_inline`
    // (with one body for both callers LLVM kept it out of line: one path at a time 8 % slower;
    // inlined into both, the lanes 3-5 % slower).
    #[inline(never)]
    pub(super) fn segment_end(
        &self,
        depth: u32,
        ray: (Vec3, Vec3, u32),
        prev_pdf: f32,
        beta: Vec3,
        stats: &mut PathStats,
    ) -> SegmentEnd {
        self.segment_end_inline(depth, ray, prev_pdf, beta, stats)
    }

    /// [`Self::segment_end`], inlined.
    #[inline(always)]
    pub(super) fn segment_end_inline(
        &self,
        depth: u32,
        (o, d, leaving): (Vec3, Vec3, u32),
        prev_pdf: f32,
        beta: Vec3,
        stats: &mut PathStats,
    ) -> SegmentEnd {
        let s = self.scene;
        let mut o = o;
        let mut found = self.bvh.closest_leaving(s, o, d, f32::MAX, leaving);
        let hidden = s.integrator.hide_emitters && depth == 1;
        if hidden {
            // Mitsuba's hidden emitters: the camera ray passes through the emitters it meets,
            // on from just beyond each (at most HIDE_PASSES of them; GLSL twin: segment_end).
            for _ in 0..HIDE_PASSES {
                let Some(hit) = &found else { break };
                let si = surface_at(s, &self.normals, hit, o, d);
                if si.emitter.is_none() {
                    break;
                }
                let beyond = if si.front { -si.ng } else { si.ng };
                o = crate::robust::offset_ray_origin(si.p, si.p_err, beyond);
                found = self.bvh.closest(s, o, d, f32::MAX);
            }
        }
        let Some(hit) = found else {
            return self.segment_miss(d, prev_pdf, beta, hidden, stats);
        };
        let mut si = surface_at(s, &self.normals, &hit, o, d);
        if self.textured {
            si.uv = crate::texture::hit_uv(s, &hit, si.p);
        }
        self.segment_surface(depth, d, hit.t, si, (prev_pdf, beta, hidden), stats)
    }

    /// [`Self::segment_end`] where the ray met nothing: the environment's light.
    pub(super) fn segment_miss(
        &self,
        d: Vec3,
        prev_pdf: f32,
        beta: Vec3,
        hidden: bool,
        stats: &mut PathStats,
    ) -> SegmentEnd {
        let s = self.scene;
        let mut end = SegmentEnd::default();
        let e = match &s.environment_map {
            None => beta * s.environment,
            Some(m) => beta * m.radiance(d) * self.env_weight(m, d, prev_pdf),
        };
        if !e.is_finite() {
            stats.nonfinite_extend += 1;
        } else if !hidden {
            // (Hidden emitters: the camera ray does not see the environment.)
            end.e = Some(e);
        }
        end
    }

    /// [`Self::segment_end`] at surface `si`, met at distance `t` along `d`: the light it
    /// emits, and the surface when the path goes on from it.
    pub(super) fn segment_surface(
        &self,
        depth: u32,
        d: Vec3,
        t: f32,
        si: Surface,
        at: (f32, Vec3, bool),
        stats: &mut PathStats,
    ) -> SegmentEnd {
        let hit = (si.front, si.ng, si.material, si.emitter);
        let (e, goes_on) = self.segment_light(depth, d, t, hit, at, stats);
        SegmentEnd {
            e,
            surface: goes_on.then_some(si),
        }
    }

    /// The light that a surface met at distance `t` along `d` emits toward the ray (front side
    /// `front`, geometric normal `ng`, its material and emitter), MIS-weighted against
    /// next-event estimation, and whether the path goes on from it.
    pub(super) fn segment_light(
        &self,
        depth: u32,
        d: Vec3,
        t: f32,
        (front, ng, material, emitter): (bool, Vec3, u32, Option<u32>),
        (prev_pdf, beta, hidden): (f32, Vec3, bool),
        stats: &mut PathStats,
    ) -> (Option<Vec3>, bool) {
        let s = self.scene;
        let scatters = self.scatters[material as usize];
        if !front {
            // The back of a two-sided material scatters (shade_vertex turns it to the front)
            // but emits nothing.
            let twosided = s.materials[material as usize].twosided;
            return (None, twosided && depth < s.integrator.max_depth && scatters);
        }
        let mut light = None;
        if let Some(e) = emitter {
            let le = s.emitters[e as usize].radiance;
            let w = if prev_pdf > 0.0 {
                let cos_light = -d.dot(ng);
                power_heuristic(
                    prev_pdf,
                    light_pdf(self.lights.select_density[e as usize], t * t, cos_light),
                )
            } else {
                1.0
            };
            let e = beta * le * w;
            if !e.is_finite() {
                stats.nonfinite_extend += 1;
            } else if !hidden {
                // (Nor an emitter it could not pass: HIDE_PASSES.)
                light = Some(e);
            }
        }
        (light, depth < s.integrator.max_depth && scatters)
    }
}

#[cfg(test)]
mod tests {
    /// The GLSL twin of the pass-through bound is the Rust one.
    #[test]
    fn glsl_hide_passes_matches() {
        let glsl = include_str!("../../shaders/wavefront/path.glsl");
        let passes = crate::robust::glsl_define(glsl, "wavefront/path.glsl", "HIDE_PASSES");
        assert_eq!(passes, format!("{}u", super::HIDE_PASSES));
    }
}
