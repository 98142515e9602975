//! A pixel's samples traced in lockstep: a packet of up to [`LANES`] paths (consecutive samples
//! of one pixel, the sampler's packet) a segment at a time, [`CpuRenderer::trace_path`]'s steps
//! for each, with two of them done for the whole packet in SIMD lanes:
//! - a triangle hit's surface (`surface_at`'s point, error bound, side and frame), for scenes
//!   whose triangles have no vertex normals or texture coordinates ([`HitLanes`]);
//! - the vertex of an untextured Lambert material under area lights made of triangles
//!   (`shade_vertex`'s light sample and cosine-weighted continuation, [`LambertLanes`]).
//!
//! Every other vertex and hit (spheres, other models, textures, delta lights, the environment)
//! goes through the scalar code, lane by lane, and every ray is traced one at a time. Each lane
//! kernel does the same f32 operations in the same order as the scalar functions it stands for
//! (named at each step), without fused multiply-adds, so the image and the counts are those of
//! one path at a time, bit for bit (`tests/render.rs`,
//! `lockstep_packets_give_the_image_of_one_path_at_a_time`; `BRDFWAVE_LANES=0` renders one
//! path at a time, for A/B timing). Issue 43, lever 3's first step: docs/bench-log.md, "A
//! pixel's samples in lockstep".

use super::surface::{surface_at, triangle_light_point, Frame, Surface};
use super::{CpuRenderer, PathStats};
use crate::brdf::common::{sin_cos_quarter, MIN_COS2};
use crate::brdf::lambert::Lambert;
use crate::bvh::SPHERE_BIT;
use crate::conventions::SEGMENTS_COUNTED;
use crate::lights::LightTable;
use crate::rng::{dim, PacketRng, PACKET};
use crate::robust::{gamma, step_off, ulp, SHADOW_EPSILON, SHIFT_ULPS};
use crate::scene::Scene;
use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

/// Paths per packet: one register of 16 f32 lanes.
pub(super) const LANES: usize = PACKET;

/// The smallest packet traced in lockstep: the kernels compute all [`LANES`] lanes (a loop of
/// fixed length, which the compiler turns into whole registers; a loop over the packet's own
/// count made full packets 1.28x slower), so a packet of 1 or 2 paths costs more than the
/// scalar path (1 spp: 1.32x slower), while one of 4 already gains (1.07x).
pub(super) const MIN_LANES: usize = 4;

type F = [f32; LANES];

/// Three coordinates of [`LANES`] vectors.
#[derive(Clone, Copy, Default)]
struct V3 {
    x: F,
    y: F,
    z: F,
}

impl V3 {
    #[inline(always)]
    fn set(&mut self, k: usize, v: Vec3) {
        (self.x[k], self.y[k], self.z[k]) = (v.x, v.y, v.z);
    }
    #[inline(always)]
    fn get(&self, k: usize) -> Vec3 {
        Vec3::new(self.x[k], self.y[k], self.z[k])
    }
}

/// [`crate::robust::offset_ray_origin`] in lane k.
#[inline(always)]
fn offset(p: &V3, err: &V3, n: &V3, k: usize) -> (f32, f32, f32) {
    let d = n.x[k].abs() * err.x[k] + n.y[k].abs() * err.y[k] + n.z[k].abs() * err.z[k];
    (
        step_off(p.x[k] + n.x[k] * d, n.x[k]),
        step_off(p.y[k] + n.y[k] * d, n.y[k]),
        step_off(p.z[k] + n.z[k] * d, n.z[k]),
    )
}

/// The state of a packet's paths (the locals of [`CpuRenderer::trace_path`], one per lane).
struct Paths {
    o: [Vec3; LANES],
    d: [Vec3; LANES],
    beta: [Vec3; LANES],
    l: [Vec3; LANES],
    prev_pdf: [f32; LANES],
    leaving: [u32; LANES],
    alive: [bool; LANES],
}

/// The vertices of the segment being shaded: whose they are, and those the Lambert lanes take.
struct Vertices {
    pixel: u32,
    first: u32,
    depth: u32,
    /// The segment's index in the counts by segment.
    seg: usize,
    lam: LambertLanes,
}

/// The Lambert vertices of one segment, compacted: entry j is path lane `lane[j]`.
#[derive(Default)]
struct LambertLanes {
    n: usize,
    lane: [usize; LANES],
    prim: [u32; LANES],
    p: V3,
    p_err: V3,
    ng: V3,
    t: V3,
    b: V3,
    sn: V3,
    d: V3,
    beta: V3,
    albedo: V3,
    // The light sample's triangle and emitter, gathered.
    lb1: F,
    lb2: F,
    lv0: V3,
    lv1: V3,
    lv2: V3,
    ln: V3,
    lrad: V3,
    ldens: F,
    ub: [glam::Vec2; LANES],
}

/// The triangle hits of one segment, compacted: entry j is path lane `lane[j]`; the surface
/// quantities of [`surface_at`] for a triangle without vertex normals or texture coordinates.
#[derive(Default)]
struct HitLanes {
    n: usize,
    lane: [usize; LANES],
    prim: [u32; LANES],
    t: F,
    b1: F,
    b2: F,
    d: V3,
    v0: V3,
    v1: V3,
    v2: V3,
    ng: V3,
    // Results.
    p: V3,
    p_err: V3,
    front: [bool; LANES],
    ft: V3,
    fb: V3,
}

impl HitLanes {
    #[inline(always)]
    fn push(
        &mut self,
        s: &crate::scene::Scene,
        normals: &[Vec3],
        k: usize,
        hit: &crate::bvh::Hit,
        d: Vec3,
    ) {
        let j = self.n;
        self.n += 1;
        self.lane[j] = k;
        self.prim[j] = hit.prim;
        self.t[j] = hit.t;
        (self.b1[j], self.b2[j]) = (hit.bary.x, hit.bary.y);
        self.d.set(j, d);
        let tri = &s.triangles[hit.prim as usize];
        self.v0.set(j, tri.v[0]);
        self.v1.set(j, tri.v[1]);
        self.v2.set(j, tri.v[2]);
        self.ng.set(j, normals[hit.prim as usize]);
    }

    /// [`surface_at`]'s point, its error bound, side and frame, for every entry: the same
    /// operations as `robust::pull_inside`, `robust::triangle_point`, `default_tangent` and
    /// `make_frame`, in the same order.
    fn surfaces(&mut self) {
        let (g4, g2) = (gamma(4), gamma(2));
        for k in 0..LANES {
            let (v0x, v0y, v0z) = (self.v0.x[k], self.v0.y[k], self.v0.z[k]);
            let (e1x, e1y, e1z) = (self.v1.x[k] - v0x, self.v1.y[k] - v0y, self.v1.z[k] - v0z);
            let (e2x, e2y, e2z) = (self.v2.x[k] - v0x, self.v2.y[k] - v0y, self.v2.z[k] - v0z);
            // pull_inside
            let (b1, b2) = (self.b1[k], self.b2[k]);
            let third = 1.0 / 3.0;
            let (d1, d2) = (third - b1, third - b2);
            let (cx, cy, cz) = (
                (e1x * d1 + e2x * d2).abs(),
                (e1y * d1 + e2y * d2).abs(),
                (e1z * d1 + e2z * d2).abs(),
            );
            let dist = cx.max(cy.max(cz));
            let m = v0x.abs().max(v0y.abs().max(v0z.abs()));
            let delta = ulp(m + 3.0 * dist) * SHIFT_ULPS;
            let tt = (delta / dist).min(0.5);
            let moved = dist > 0.0 && dist.is_finite();
            let pb1 = if moved { b1 + tt * d1 } else { b1 };
            let pb2 = if moved { b2 + tt * d2 } else { b2 };
            // triangle_point
            let (a1x, a1y, a1z) = (e1x * pb1, e1y * pb1, e1z * pb1);
            let (a2x, a2y, a2z) = (e2x * pb2, e2y * pb2, e2z * pb2);
            let (px, py, pz) = (v0x + (a1x + a2x), v0y + (a1y + a2y), v0z + (a1z + a2z));
            self.p.x[k] = px;
            self.p.y[k] = py;
            self.p.z[k] = pz;
            self.p_err.x[k] = (a1x.abs() + a2x.abs()) * g4 + px.abs() * g2;
            self.p_err.y[k] = (a1y.abs() + a2y.abs()) * g4 + py.abs() * g2;
            self.p_err.z[k] = (a1z.abs() + a2z.abs()) * g4 + pz.abs() * g2;
            let (nx, ny, nz) = (self.ng.x[k], self.ng.y[k], self.ng.z[k]);
            self.front[k] = self.d.x[k] * nx + self.d.y[k] * ny + self.d.z[k] * nz < 0.0;
            // default_tangent(n), then make_frame(n, that hint)
            let sign = if nz >= 0.0 { 1.0 } else { -1.0 };
            let a = -1.0 / (sign + nz);
            let bb = nx * ny * a;
            let (hx, hy, hz) = (1.0 + sign * nx * nx * a, sign * bb, -sign * nx);
            let dh = nx * hx + ny * hy + nz * hz;
            let (tx, ty, tz) = (hx - nx * dh, hy - ny * dh, hz - nz * dh);
            let len2 = tx * tx + ty * ty + tz * tz;
            let len = len2.sqrt();
            let (tx, ty, tz) = if len2 > 1e-12 {
                (tx / len, ty / len, tz / len)
            } else {
                (hx, hy, hz)
            };
            self.ft.x[k] = tx;
            self.ft.y[k] = ty;
            self.ft.z[k] = tz;
            self.fb.x[k] = ny * tz - ty * nz;
            self.fb.y[k] = nz * tx - tz * nx;
            self.fb.z[k] = nx * ty - tx * ny;
        }
    }
}

/// What the kernel gives each entry.
#[derive(Default)]
struct LaneOut {
    origin: V3,
    shadow: [bool; LANES],
    sd: V3,
    stmax: F,
    sl: V3,
    next: [bool; LANES],
    nd: V3,
    nbeta: V3,
    npdf: F,
}

/// The albedo of each material of `s` whose vertices the lane kernel shades (untextured
/// Lambert), when every light of the scene (its table `lights`) is a triangle or a pair of
/// them; else none.
pub(super) fn lane_albedos(s: &Scene, lights: &LightTable) -> Vec<Option<Vec3>> {
    let lights_ok = s.environment_map.is_none()
        && s.lights.is_empty()
        && !lights.is_empty()
        && lights.prims.iter().all(|&p| p & SPHERE_BIT == 0);
    s.materials
        .iter()
        .map(|m| {
            let lambert = m.brdf.as_any().downcast_ref::<Lambert>();
            match lambert {
                Some(l) if lights_ok && m.textures.is_empty() => Some(l.albedo),
                _ => None,
            }
        })
        .collect()
}

impl CpuRenderer<'_> {
    /// The radiance of the `n` paths (pixel (x, y), samples `first..first + n`), traced in
    /// lockstep: [`Self::trace_path`]'s steps, lane by lane, with the triangle hits and the
    /// Lambert vertices of each segment computed together.
    pub(super) fn trace_packet(
        &self,
        (x, y, pixel): (u32, u32, u32),
        first: u32,
        n: usize,
        packet: &mut PacketRng,
        stats: &mut PathStats,
    ) -> [Vec3; LANES] {
        let s = self.scene;
        let mut paths = Paths {
            o: [Vec3::ZERO; LANES],
            d: [Vec3::ZERO; LANES],
            beta: [Vec3::ONE; LANES],
            l: [Vec3::ZERO; LANES],
            prev_pdf: [0.0; LANES],
            leaving: [u32::MAX; LANES],
            alive: [false; LANES],
        };
        let mut v = Vertices {
            pixel,
            first,
            depth: 0,
            seg: 0,
            // Reused from segment to segment: entries at and beyond `n` are stale, and the
            // kernels' results for them are not read.
            lam: LambertLanes::default(),
        };
        for k in 0..n {
            let mut rng = packet.path(pixel, first + k as u32);
            (paths.o[k], paths.d[k]) = self.camera_ray(x, y, &mut rng);
            paths.alive[k] = true;
        }
        let mut hits = HitLanes::default();
        let mut out = LaneOut::default();
        for depth in 1..=s.integrator.max_depth {
            v.depth = depth;
            v.seg = (depth.min(SEGMENTS_COUNTED) - 1) as usize;
            v.lam.n = 0;
            hits.n = 0;
            // The segment's rays, one at a time; triangle hits are turned into surfaces in
            // lanes (`HitLanes`), the rest as the scalar path does.
            for k in 0..n {
                if !paths.alive[k] {
                    continue;
                }
                stats.extension_rays += 1;
                stats.segment_extension[v.seg] += 1;
                let (o, d) = (paths.o[k], paths.d[k]);
                let at = (paths.prev_pdf[k], paths.beta[k], false);
                let end = if self.lane_surfaces && !(depth == 1 && s.integrator.hide_emitters) {
                    match self
                        .bvh
                        .closest_leaving(s, o, d, f32::MAX, paths.leaving[k])
                    {
                        None => self.segment_miss(d, at.0, at.1, false, stats),
                        Some(hit) if hit.prim & SPHERE_BIT == 0 => {
                            hits.push(s, &self.normals, k, &hit, d);
                            continue;
                        }
                        Some(hit) => {
                            let si = surface_at(s, &self.normals, &hit, o, d);
                            self.segment_surface(depth, d, hit.t, si, at, stats)
                        }
                    }
                } else {
                    self.segment_end(depth, (o, d, paths.leaving[k]), at.0, at.1, stats)
                };
                if let Some(e) = end.e {
                    paths.l[k] += e;
                }
                match end.surface {
                    Some(si) => self.vertex(&mut v, &mut paths, k, si, packet, stats),
                    None => paths.alive[k] = false,
                }
            }
            if hits.n > 0 {
                hits.surfaces();
                for j in 0..hits.n {
                    let k = hits.lane[j];
                    let prim = hits.prim[j];
                    let tri = &s.triangles[prim as usize];
                    let (ng, front) = (hits.ng.get(j), hits.front[j]);
                    let at = (paths.prev_pdf[k], paths.beta[k], false);
                    let hit = (front, ng, tri.material, tri.emitter);
                    let (e, goes_on) =
                        self.segment_light(depth, paths.d[k], hits.t[j], hit, at, stats);
                    if let Some(e) = e {
                        paths.l[k] += e;
                    }
                    if !goes_on {
                        paths.alive[k] = false;
                        continue;
                    }
                    match self.lane_albedo[tri.material as usize] {
                        Some(albedo) if front => {
                            let frame = (hits.ft.get(j), hits.fb.get(j), ng);
                            let at = (prim, hits.p.get(j), hits.p_err.get(j), ng, frame);
                            self.lambert_lane(&mut v, &paths, k, at, albedo, packet);
                        }
                        _ => {
                            let si = Surface {
                                p: hits.p.get(j),
                                p_err: hits.p_err.get(j),
                                ng,
                                front,
                                frame: Frame {
                                    t: hits.ft.get(j),
                                    b: hits.fb.get(j),
                                    n: ng,
                                },
                                material: tri.material,
                                emitter: tri.emitter,
                                prim,
                                uv: glam::Vec2::ZERO,
                            };
                            self.vertex(&mut v, &mut paths, k, si, packet, stats);
                        }
                    }
                }
            }
            if v.lam.n == 0 {
                continue;
            }
            let lam = &v.lam;
            self.shade_lambert_lanes(lam, &mut out, stats);
            for j in 0..lam.n {
                let k = lam.lane[j];
                let origin = out.origin.get(j);
                if out.shadow[j] {
                    let ray = (origin, out.sd.get(j), out.stmax[j], lam.prim[j]);
                    self.shadow_ray(v.seg, ray, out.sl.get(j), &mut paths.l[k], stats);
                }
                if !out.next[j] {
                    paths.alive[k] = false;
                    continue;
                }
                let (wi, pdf) = (out.nd.get(j), out.npdf[j]);
                let mut rng = packet.path(pixel, first + k as u32);
                let next = (wi, out.nbeta.get(j), pdf);
                let model = self.lambert_model;
                let Some(b) = self.continuation(&mut rng, depth, next, model, stats) else {
                    paths.alive[k] = false;
                    continue;
                };
                (paths.o[k], paths.d[k], paths.beta[k]) = (origin, wi, b);
                paths.prev_pdf[k] = pdf;
                paths.leaving[k] = lam.prim[j];
            }
        }
        paths.l
    }

    /// Path lane `k` goes on from surface `si`: into the Lambert lanes when they shade it, else
    /// shaded by [`Self::shade_vertex`] with its shadow ray traced and the path moved on.
    fn vertex(
        &self,
        v: &mut Vertices,
        paths: &mut Paths,
        k: usize,
        si: Surface,
        packet: &mut PacketRng,
        stats: &mut PathStats,
    ) {
        match self.lane_albedo[si.material as usize] {
            Some(albedo) if si.front => {
                let frame = (si.frame.t, si.frame.b, si.frame.n);
                let at = (si.prim, si.p, si.p_err, si.ng, frame);
                self.lambert_lane(v, paths, k, at, albedo, packet);
            }
            _ => {
                let mut rng = packet.path(v.pixel, v.first + k as u32);
                let (depth, d, beta) = (v.depth, paths.d[k], paths.beta[k]);
                let sc = self.shade_vertex(&mut rng, depth, &si, d, beta, stats);
                if let Some(sh) = sc.shadow {
                    let ray = (sh.o, sh.d, sh.tmax, si.prim);
                    self.shadow_ray(v.seg, ray, sh.l, &mut paths.l[k], stats);
                }
                match sc.next {
                    None => paths.alive[k] = false,
                    Some(next) => {
                        (paths.o[k], paths.d[k], paths.beta[k]) = (next.o, next.d, next.beta);
                        paths.prev_pdf[k] = next.pdf;
                        paths.leaving[k] = si.prim;
                    }
                }
            }
        }
    }

    /// A new Lambert entry for path lane `k` at the surface of primitive `prim` (point `p`, its
    /// error bound, geometric normal `ng`, shading frame (t, b, n)): with the ray's direction
    /// and throughput, the albedo, the random numbers and the light sample's triangle.
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    fn lambert_lane(
        &self,
        v: &mut Vertices,
        paths: &Paths,
        k: usize,
        (prim, p, p_err, ng, (t, b, n)): (u32, Vec3, Vec3, Vec3, (Vec3, Vec3, Vec3)),
        albedo: Vec3,
        packet: &mut PacketRng,
    ) {
        let lam = &mut v.lam;
        let j = lam.n;
        lam.n += 1;
        lam.lane[j] = k;
        lam.prim[j] = prim;
        lam.p.set(j, p);
        lam.p_err.set(j, p_err);
        lam.ng.set(j, ng);
        lam.t.set(j, t);
        lam.b.set(j, b);
        lam.sn.set(j, n);
        lam.d.set(j, paths.d[k]);
        lam.beta.set(j, paths.beta[k]);
        lam.albedo.set(j, albedo);
        let mut rng = packet.path(v.pixel, v.first + k as u32);
        let u_choice = rng.get2(v.depth, dim::LIGHT_SELECT);
        let u_light = rng.get2(v.depth, dim::LIGHT_U);
        lam.ub[j] = rng.get2(v.depth, dim::BSDF_U);
        self.gather_light(lam, j, u_choice.x, u_light);
    }

    /// A shadow ray of segment index `seg` leaving primitive `prim`: adds `contrib` to `l`
    /// when nothing occludes it.
    #[inline(always)]
    fn shadow_ray(
        &self,
        seg: usize,
        (o, d, tmax, prim): (Vec3, Vec3, f32, u32),
        contrib: Vec3,
        l: &mut Vec3,
        stats: &mut PathStats,
    ) {
        stats.shadow_rays += 1;
        stats.segment_shadow[seg] += 1;
        if !self.bvh.occluded_leaving(self.scene, o, d, tmax, prim) {
            *l += contrib;
        } else {
            stats.shadow_rays_occluded += 1;
        }
    }

    /// [`super::surface::sample_light`]'s choice of a triangle and its barycentrics, and the
    /// data of that triangle and its emitter, into entry j.
    #[inline(always)]
    fn gather_light(&self, lam: &mut LambertLanes, j: usize, u_sel: f32, u: glam::Vec2) {
        let s = self.scene;
        let prim = self.lights.prims[self.lights.select(u_sel)];
        let (index, b1, b2) = triangle_light_point(prim, u.x, u.y);
        let t = &s.triangles[index];
        let e = t.emitter.expect("light table holds emitters only") as usize;
        lam.lb1[j] = b1;
        lam.lb2[j] = b2;
        lam.lv0.set(j, t.v[0]);
        lam.lv1.set(j, t.v[1]);
        lam.lv2.set(j, t.v[2]);
        lam.ln.set(j, self.normals[index]);
        lam.lrad.set(j, s.emitters[e].radiance);
        lam.ldens[j] = self.lights.select_density[e];
    }

    /// [`Self::shade_vertex`] for Lambert vertices under area lights, in lanes: the light
    /// sample's contribution and the cosine-weighted continuation, before Russian roulette and
    /// the finiteness check of the continuation (the caller's, [`Self::continuation`]).
    fn shade_lambert_lanes(&self, lam: &LambertLanes, out: &mut LaneOut, stats: &mut PathStats) {
        let (g4, g2) = (gamma(4), gamma(2));
        let mut wo_up = [false; LANES];
        let mut bad = [false; LANES];
        // The light sample.
        for k in 0..LANES {
            // wo = to_local(-d); only its z matters to Lambert.
            let wo_z =
                -lam.d.x[k] * lam.sn.x[k] + -lam.d.y[k] * lam.sn.y[k] + -lam.d.z[k] * lam.sn.z[k];
            wo_up[k] = wo_z > 0.0;
            let (ox, oy, oz) = offset(&lam.p, &lam.p_err, &lam.ng, k);
            (out.origin.x[k], out.origin.y[k], out.origin.z[k]) = (ox, oy, oz);
            // triangle_point
            let (b1, b2) = (lam.lb1[k], lam.lb2[k]);
            let e1x = (lam.lv1.x[k] - lam.lv0.x[k]) * b1;
            let e1y = (lam.lv1.y[k] - lam.lv0.y[k]) * b1;
            let e1z = (lam.lv1.z[k] - lam.lv0.z[k]) * b1;
            let e2x = (lam.lv2.x[k] - lam.lv0.x[k]) * b2;
            let e2y = (lam.lv2.y[k] - lam.lv0.y[k]) * b2;
            let e2z = (lam.lv2.z[k] - lam.lv0.z[k]) * b2;
            let px = lam.lv0.x[k] + (e1x + e2x);
            let py = lam.lv0.y[k] + (e1y + e2y);
            let pz = lam.lv0.z[k] + (e1z + e2z);
            let ex = (e1x.abs() + e2x.abs()) * g4 + px.abs() * g2;
            let ey = (e1y.abs() + e2y.abs()) * g4 + py.abs() * g2;
            let ez = (e1z.abs() + e2z.abs()) * g4 + pz.abs() * g2;
            // offset_ray_origin(p, err, light normal)
            let (lnx, lny, lnz) = (lam.ln.x[k], lam.ln.y[k], lam.ln.z[k]);
            let dd = lnx.abs() * ex + lny.abs() * ey + lnz.abs() * ez;
            let tx = step_off(px + lnx * dd, lnx);
            let ty = step_off(py + lny * dd, lny);
            let tz = step_off(pz + lnz * dd, lnz);
            let (lx, ly, lz) = (tx - ox, ty - oy, tz - oz);
            let dist2 = lx * lx + ly * ly + lz * lz;
            let dist = dist2.sqrt();
            let (wx, wy, wz) = (lx / dist, ly / dist, lz / dist);
            let cos_light = -(wx * lnx + wy * lny + wz * lnz);
            let wl_z = wx * lam.sn.x[k] + wy * lam.sn.y[k] + wz * lam.sn.z[k];
            let ng_dot = wx * lam.ng.x[k] + wy * lam.ng.y[k] + wz * lam.ng.z[k];
            let geometry = dist2 > 0.0 && cos_light > 0.0 && ng_dot > 0.0 && wl_z > 0.0;
            let dens = lam.ldens[k];
            let pdf_l = if cos_light <= 0.0 || dens <= 0.0 {
                0.0
            } else {
                dens * dist2 / cos_light
            };
            let up = wl_z > 0.0 && wo_up[k];
            let (fx, fy, fz) = if up {
                (
                    lam.albedo.x[k] * FRAC_1_PI,
                    lam.albedo.y[k] * FRAC_1_PI,
                    lam.albedo.z[k] * FRAC_1_PI,
                )
            } else {
                (0.0, 0.0, 0.0)
            };
            let f_nonzero = fx != 0.0 || fy != 0.0 || fz != 0.0;
            let pdf_b = if up { wl_z.max(0.0) / PI } else { 0.0 };
            // power_heuristic(pdf_l, pdf_b)
            let r = (pdf_b / pdf_l).min(1e18);
            let w = if pdf_l <= 0.0 {
                0.0
            } else {
                1.0 / (1.0 + r * r)
            };
            let sc = wl_z * w / pdf_l;
            let cx = lam.beta.x[k] * fx * sc * lam.lrad.x[k];
            let cy = lam.beta.y[k] * fy * sc * lam.lrad.y[k];
            let cz = lam.beta.z[k] * fz * sc * lam.lrad.z[k];
            let taken = wo_up[k] && geometry && pdf_l > 0.0 && f_nonzero;
            let finite = cx.is_finite() && cy.is_finite() && cz.is_finite();
            bad[k] = taken && !finite;
            out.shadow[k] = taken && finite;
            (out.sd.x[k], out.sd.y[k], out.sd.z[k]) = (wx, wy, wz);
            out.stmax[k] = dist * (1.0 - SHADOW_EPSILON);
            (out.sl.x[k], out.sl.y[k], out.sl.z[k]) = (cx, cy, cz);
        }
        // The cosine-weighted sample (`sample_cosine_hemisphere`): the concentric map's angle
        // in [−π/4, π/4], its sine and cosine by `sin_cos_quarter`'s polynomials, then the
        // rest.
        let (rim, rim_z) = ((1.0 - MIN_COS2).sqrt(), MIN_COS2.sqrt());
        for (k, &up) in wo_up.iter().enumerate() {
            let ax = 2.0 * lam.ub[k].x - 1.0;
            let ay = 2.0 * lam.ub[k].y - 1.0;
            let zero = ax == 0.0 && ay == 0.0;
            let wide = ax.abs() > ay.abs();
            let psi = if wide {
                (PI / 4.0) * (ay / ax)
            } else {
                (PI / 4.0) * (ax / ay)
            };
            let (sin, cos) = sin_cos_quarter(psi);
            let (mut dx, mut dy) = if zero {
                (0.0, 0.0)
            } else if wide {
                (ax * cos, ax * sin)
            } else {
                (ay * sin, ay * cos)
            };
            let len2 = dx * dx + dy * dy;
            let z2 = 1.0 - len2;
            let z = if z2 < MIN_COS2 {
                let scale = rim / len2.sqrt();
                (dx, dy) = (dx * scale, dy * scale);
                rim_z
            } else {
                z2.sqrt()
            };
            let pdf = z.max(0.0) / PI;
            // to_world
            let wx = lam.t.x[k] * dx + lam.b.x[k] * dy + lam.sn.x[k] * z;
            let wy = lam.t.y[k] * dx + lam.b.y[k] * dy + lam.sn.y[k] * z;
            let wz = lam.t.z[k] * dx + lam.b.z[k] * dy + lam.sn.z[k] * z;
            let above = wx * lam.ng.x[k] + wy * lam.ng.y[k] + wz * lam.ng.z[k] > 0.0;
            out.next[k] = up && pdf > 0.0 && above;
            (out.nd.x[k], out.nd.y[k], out.nd.z[k]) = (wx, wy, wz);
            out.nbeta.x[k] = lam.beta.x[k] * lam.albedo.x[k];
            out.nbeta.y[k] = lam.beta.y[k] * lam.albedo.y[k];
            out.nbeta.z[k] = lam.beta.z[k] * lam.albedo.z[k];
            out.npdf[k] = pdf;
        }
        let nonfinite = bad[..lam.n].iter().filter(|&&b| b).count() as u64;
        stats.nonfinite_shade[self.lambert_model] += nonfinite;
    }
}
