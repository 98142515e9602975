//! Shading one path vertex: a light sample and a BRDF sample. GLSL twin (independent code, same
//! conventions and random-number keys): `shade_vertex` in `shaders/wavefront/scatter.glsl`.

use super::surface::{light_pdf, power_heuristic, sample_delta_light, sample_light, Surface};
use super::{CpuRenderer, PathStats};
use crate::brdf::Brdf;
use crate::envmap::EnvMap;
use crate::lights::{DeltaEntry, ENV_ENTRY};
use crate::rng::{dim, LaneRng};
use crate::robust;
use glam::Vec3;

/// A shadow ray towards a light sample and the contribution it adds when unoccluded.
pub(super) struct ShadowRay {
    pub o: Vec3,
    pub d: Vec3,
    pub tmax: f32,
    /// Its unoccluded contribution.
    pub l: Vec3,
}

/// The next segment of a path: origin, direction, throughput, and the solid-angle pdf of the
/// BSDF sample that chose the direction (0 after a delta lobe).
pub(super) struct NextSegment {
    pub o: Vec3,
    pub d: Vec3,
    pub beta: Vec3,
    pub pdf: f32,
}

/// What shading one surface vertex produces (the GLSL `struct Scatter`).
#[derive(Default)]
pub(super) struct Scatter {
    pub shadow: Option<ShadowRay>,
    pub next: Option<NextSegment>,
}

impl CpuRenderer<'_> {
    /// Next-event estimation towards the delta light `l` from `origin` on `si` (view direction
    /// `wo`, local): no MIS, since BSDF sampling can never find it. GLSL twin:
    /// `delta_light_ray` in `shaders/wavefront/scatter.glsl`.
    #[allow(clippy::too_many_arguments)]
    fn delta_light_ray(
        &self,
        (l, brdf): (&DeltaEntry, &dyn Brdf),
        si: &Surface,
        origin: Vec3,
        wo: Vec3,
        beta: Vec3,
        model: usize,
        stats: &mut PathStats,
    ) -> Option<ShadowRay> {
        let ds = sample_delta_light(l, origin)?;
        let wi_local = si.frame.to_local(ds.wi);
        if !(ds.wi.dot(si.ng) > 0.0 && wi_local.z > 0.0) {
            return None;
        }
        let f = brdf.eval(wi_local, wo);
        if f == Vec3::ZERO {
            return None;
        }
        let contrib = beta * f * wi_local.z * ds.li;
        if !contrib.is_finite() {
            stats.nonfinite_shade[model] += 1;
            return None;
        }
        Some(ShadowRay {
            o: origin,
            d: ds.wi,
            tmax: ds.tmax,
            l: contrib,
        })
    }

    /// Next-event estimation towards the environment map `m`, its direction drawn by the 2-D
    /// sample `u`, from `origin` on `si` (view direction `wo`, local), MIS-weighted against
    /// BSDF sampling. GLSL twin: `env_light_ray` in `shaders/wavefront/scatter.glsl`.
    #[allow(clippy::too_many_arguments)]
    fn env_light_ray(
        &self,
        (m, u, brdf): (&EnvMap, glam::Vec2, &dyn Brdf),
        si: &Surface,
        origin: Vec3,
        wo: Vec3,
        beta: Vec3,
        model: usize,
        stats: &mut PathStats,
    ) -> Option<ShadowRay> {
        let es = m.sample(u.x, u.y)?;
        let wi_local = si.frame.to_local(es.wi);
        if !(es.wi.dot(si.ng) > 0.0 && wi_local.z > 0.0) {
            return None;
        }
        let pdf_l = self.lights.env_select * es.pdf;
        let (f, pdf_b) = brdf.eval_pdf(wi_local, wo);
        if pdf_l.is_nan() || pdf_l <= 0.0 || f == Vec3::ZERO {
            return None;
        }
        let w = power_heuristic(pdf_l, pdf_b);
        let contrib = beta * f * (wi_local.z * w / pdf_l) * es.radiance;
        if !contrib.is_finite() {
            stats.nonfinite_shade[model] += 1;
            return None;
        }
        Some(ShadowRay {
            o: origin,
            d: es.wi,
            tmax: f32::MAX,
            l: contrib,
        })
    }

    /// Shades the vertex at the end of segment `depth` (surface `si`, reached along direction
    /// `d` with throughput `beta`): one light sample (next-event estimation) and one BRDF
    /// sample, keyed on (path, depth). Non-finite light contributions and continuations are
    /// counted by model (the GPU's `shade_<model>`) and dropped.
    // Out of line for the lanes' scalar fall-back; `trace_path` inlines `shade_vertex_inline`
    // (as for `segment_end`).
    #[inline(never)]
    pub(super) fn shade_vertex(
        &self,
        rng: &mut LaneRng,
        depth: u32,
        si: &Surface,
        d: Vec3,
        beta: Vec3,
        stats: &mut PathStats,
    ) -> Scatter {
        self.shade_vertex_inline(rng, depth, si, d, beta, stats)
    }

    /// [`Self::shade_vertex`], inlined.
    #[inline(always)]
    pub(super) fn shade_vertex_inline(
        &self,
        rng: &mut LaneRng,
        depth: u32,
        si: &Surface,
        d: Vec3,
        beta: Vec3,
        stats: &mut PathStats,
    ) -> Scatter {
        let s = self.scene;
        let mut r = Scatter::default();
        let material = &s.materials[si.material as usize];
        // A textured material: the model with its parameters' values at this point.
        let at;
        let brdf: &dyn Brdf = match material.textures.is_empty() {
            true => material.brdf.as_ref(),
            false => {
                at = material.at(si.uv);
                at.as_ref()
            }
        };
        // A two-sided material seen from behind: its back is shaded as a front, the geometric
        // and shading normals turned to the side the ray came from.
        let back;
        let si = if material.twosided && !si.front {
            back = si.turned();
            &back
        } else {
            si
        };
        let wo = si.frame.to_local(-d);
        if wo.z <= 0.0 {
            return r;
        }
        // Every ray from here leaves from this origin (the `robust` module documentation,
        // "Every ray that leaves a surface").
        let origin = robust::offset_ray_origin(si.p, si.p_err, si.ng);
        // The light choice and the lobe choice are one pair (LIGHT_SELECT, BSDF_LOBE).
        let u_choice = rng.get2(depth, dim::LIGHT_SELECT);

        // Next-event estimation.
        let delta = (!s.lights.is_empty() && !self.lights.is_empty())
            .then(|| {
                self.lights
                    .delta_at(self.lights.prims[self.lights.select(u_choice.x)])
            })
            .flatten();
        let env = s.environment_map.as_deref().filter(|_| {
            !self.lights.is_empty()
                && self.lights.prims[self.lights.select(u_choice.x)] == ENV_ENTRY
        });
        if let Some(m) = env {
            let u_light = rng.get2(depth, dim::LIGHT_U);
            let light = (m, u_light, brdf);
            r.shadow = self.env_light_ray(light, si, origin, wo, beta, material.model, stats);
        } else if let Some(l) = delta {
            let light = (l, brdf);
            r.shadow = self.delta_light_ray(light, si, origin, wo, beta, material.model, stats);
        } else if !self.lights.is_empty() {
            let u_light = rng.get2(depth, dim::LIGHT_U);
            let ls = sample_light(
                s,
                &self.normals,
                &self.lights,
                u_choice.x,
                u_light.x,
                u_light.y,
            );
            let target = robust::offset_ray_origin(ls.p, ls.p_err, ls.n);
            let to_light = target - origin;
            let dist2 = to_light.length_squared();
            if dist2 > 0.0 {
                let dist = dist2.sqrt();
                let wi = to_light / dist;
                let cos_light = -wi.dot(ls.n);
                let wi_local = si.frame.to_local(wi);
                if cos_light > 0.0 && wi.dot(si.ng) > 0.0 && wi_local.z > 0.0 {
                    let pdf_l = light_pdf(ls.density, dist2, cos_light);
                    let (f, pdf_b) = brdf.eval_pdf(wi_local, wo);
                    if pdf_l > 0.0 && f != Vec3::ZERO {
                        let w = power_heuristic(pdf_l, pdf_b);
                        let contrib = beta * f * (wi_local.z * w / pdf_l) * ls.radiance;
                        if !contrib.is_finite() {
                            stats.nonfinite_shade[material.model] += 1;
                        } else {
                            r.shadow = Some(ShadowRay {
                                o: origin,
                                d: wi,
                                tmax: dist * (1.0 - robust::SHADOW_EPSILON),
                                l: contrib,
                            });
                        }
                    }
                }
            }
        }

        // BSDF sampling for the next segment.
        let u = rng.get2(depth, dim::BSDF_U);
        let Some(bs) = brdf.sample(wo, u_choice.y, u) else {
            return r;
        };
        let wi = si.frame.to_world(bs.wi);
        if wi.dot(si.ng) <= 0.0 {
            return r;
        }
        let prev_pdf = if bs.delta { 0.0 } else { bs.pdf };
        let next = (wi, beta * bs.weight, prev_pdf);
        let Some(beta) = self.continuation(rng, depth, next, material.model, stats) else {
            return r;
        };
        r.next = Some(NextSegment {
            o: origin,
            d: wi,
            beta,
            pdf: prev_pdf,
        });
        r
    }

    /// The throughput with which a path goes on along `wi` (BSDF pdf `pdf`) from the vertex at
    /// the end of segment `depth`, given its throughput `beta` times the sample's weight: after
    /// Russian roulette, when it is on; `None` when the path ends there, or when the throughput,
    /// direction or pdf is not finite (counted for `model`) or the throughput is zero. Both the
    /// scalar vertex and the Lambert lanes (`lanes.rs`) end with it.
    #[inline(always)]
    pub(super) fn continuation(
        &self,
        rng: &mut LaneRng,
        depth: u32,
        (wi, beta, pdf): (Vec3, Vec3, f32),
        model: usize,
        stats: &mut PathStats,
    ) -> Option<Vec3> {
        let s = self.scene;
        let mut beta = beta;
        if s.integrator.russian_roulette && depth >= s.integrator.rr_start_depth {
            let q = beta.max_element().min(1.0);
            if rng.get(depth, dim::RR) >= q {
                return None;
            }
            beta /= q;
        }
        // A non-finite throughput, direction or pdf ends the path, counted.
        if !(beta.is_finite() && wi.is_finite() && pdf.is_finite()) {
            stats.nonfinite_shade[model] += 1;
            return None;
        }
        (beta != Vec3::ZERO).then_some(beta)
    }
}
