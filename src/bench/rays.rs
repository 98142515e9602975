//! `brdfwave rays`: the BVH traversal alone, against the platform's own. The same rays of a
//! scene are traced on the Vulkan device by brdfwave's traversal (`shaders/bvh.glsl`, with the
//! defines the renderer uses for this tree) and, where the device has `VK_KHR_ray_query`, by
//! a ray query on acceleration structures the driver builds ([`crate::vk::accel`]): Mesa's
//! lavapipe has them from Mesa 24.1. Both kernels read the rays from a buffer and write the
//! hit, so they differ in the traversal alone.
//!
//! Three kinds of rays, as a path tracer makes them: camera rays (one per pixel, coherent),
//! bounce rays (from each camera hit, cosine-distributed about the geometric normal,
//! incoherent) and shadow rays (from each camera hit to a uniform point on an emitting
//! triangle, any hit). Each kernel is timed warm (a first, untimed dispatch compiles it: on
//! lavapipe at the first dispatch), as the fastest of `repeats` dispatches, each submitted and
//! waited for alone. Agreement is the share of rays whose hit primitive (closest) or verdict
//! (any hit) is the same on both: watertightness and ties differ between the two, so it is
//! near 1, not 1.
//!
//! Scenes with analytic spheres are refused: the ray-query side would need procedural
//! geometry and its own intersection code, which would no longer be the platform's.

use crate::bvh::{self, Bvh};
use crate::camera::CameraBasis;
use crate::gpu::bvh_defines;
use crate::gpu::bvh_probe::{self, BvhTexels};
use crate::robust;
use crate::scene::Scene;
use crate::stress::Rng;
use crate::vk::{raw, Context, ContextOptions, MemoryLocation, Resource, ShaderCompiler};
use anyhow::{bail, Context as _, Result};
use glam::Vec3;
use std::time::Instant;

/// brdfwave's traversal: per ray two vec4 (o, tmax), (d, 0); out (prim or ~0, t bits, 0, 0),
/// or with `ANY_HIT` defined (1 if occluded, ...). Two kernels, not a branch on a uniform: up to
/// Mesa 24.2, lavapipe runs both sides of every `if`, and would run both traversals.
const OURS: &str = r#"#version 460
#extension GL_GOOGLE_include_directive : require
#include "bvh_probe/interface.glsl"
#include "bvh.glsl"
layout(local_size_x = 64) in;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    vec4 o = rays[2u * i];
    vec4 d = rays[2u * i + 1u];
    uvec4 r = uvec4(0xFFFFFFFFu, 0u, 0u, 0u);
#ifdef ANY_HIT
    r.x = trace_any(o.xyz, d.xyz, o.w) ? 1u : 0u;
#else
    Hit h;
    if (trace_closest(o.xyz, d.xyz, o.w, h)) {
        r.xy = uvec2(h.prim, floatBitsToUint(h.t));
    }
#endif
    outp[i] = r;
}
"#;

/// The platform's traversal: the same rays through a ray query (opaque triangles, t in
/// [0, tmax]), the same output; likewise two kernels.
const RAY_QUERY: &str = r#"#version 460
#extension GL_EXT_ray_query : require
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Rays { vec4 rays[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Out { uvec4 outp[]; };
layout(set = 0, binding = 2) uniform accelerationStructureEXT tlas;
layout(push_constant) uniform Push { uint count; } pc;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    vec4 o = rays[2u * i];
    vec4 d = rays[2u * i + 1u];
#ifdef ANY_HIT
    uint flags = gl_RayFlagsOpaqueEXT | gl_RayFlagsTerminateOnFirstHitEXT;
#else
    uint flags = gl_RayFlagsOpaqueEXT;
#endif
    rayQueryEXT q;
    rayQueryInitializeEXT(q, tlas, flags, 0xFFu, o.xyz, 0.0, d.xyz, o.w);
    while (rayQueryProceedEXT(q)) {}
    uvec4 r = uvec4(0xFFFFFFFFu, 0u, 0u, 0u);
    bool hit = rayQueryGetIntersectionTypeEXT(q, true) == gl_RayQueryCommittedIntersectionTriangleEXT;
#ifdef ANY_HIT
    r.x = hit ? 1u : 0u;
#else
    if (hit) {
        r.xy = uvec2(uint(rayQueryGetIntersectionPrimitiveIndexEXT(q, true)),
                     floatBitsToUint(rayQueryGetIntersectionTEXT(q, true)));
    }
#endif
    outp[i] = r;
}
"#;

/// The most rays of one kind: one dispatch of the most workgroups of 64 that every Vulkan
/// device takes (maxComputeWorkGroupCount[0] ≥ 65535).
pub const MAX_RAYS: u64 = 65535 * 64;

/// What to measure.
pub struct RaysOptions {
    /// Camera rays per pixel of the scene's image (and so bounce and shadow rays per pixel).
    pub per_pixel: u32,
    pub seed: u64,
    /// Timed dispatches per kernel and kind; the fastest counts.
    pub repeats: u32,
    /// A case-insensitive part of the device name.
    pub device: Option<String>,
    /// Trace with brdfwave's traversal only (a device without ray queries).
    pub ours_only: bool,
}

/// One kind of ray, traced both ways.
pub struct RaysRow {
    pub kind: &'static str,
    pub rays: usize,
    /// Million rays per second, brdfwave's traversal.
    pub ours_mrays: f64,
    /// The same through a ray query; `None` with `ours_only`.
    pub query_mrays: Option<f64>,
    /// The share of rays with the same hit primitive or verdict.
    pub agreement: Option<f64>,
    /// The same rays through the CPU reference's traversal ([`Bvh::closest`],
    /// [`Bvh::occluded`]) on all the host's threads, for scale.
    pub cpu_mrays: f64,
}

pub struct RaysReport {
    pub device: String,
    pub driver: String,
    pub rows: Vec<RaysRow>,
}

/// The rays of each kind: (name, any hit, rays as (o, tmax), (d, 0)).
type RaySet = (&'static str, bool, Vec<[f32; 4]>);

/// Camera, bounce and shadow rays of `scene` (its image size × `per_pixel` camera rays).
fn make_rays(scene: &Scene, b: &Bvh, per_pixel: u32, seed: u64) -> Vec<RaySet> {
    let mut rng = Rng::new(seed);
    let cam = CameraBasis::new(scene);
    let (w, h) = (scene.width, scene.height);
    let emitters: Vec<&crate::scene::Triangle> = scene
        .triangles
        .iter()
        .filter(|t| t.emitter.is_some())
        .collect();
    let push = |v: &mut Vec<[f32; 4]>, o: Vec3, d: Vec3, tmax: f32| {
        v.push([o.x, o.y, o.z, tmax]);
        v.push([d.x, d.y, d.z, 0.0]);
    };
    let (mut camera, mut bounce, mut shadow) = (Vec::new(), Vec::new(), Vec::new());
    for y in 0..h {
        for x in 0..w {
            for _ in 0..per_pixel {
                let (fx, fy) = (x as f32 + rng.f(), y as f32 + rng.f());
                let (o, d) = if cam.thin_lens() {
                    let u = glam::Vec2::new(rng.f(), rng.f());
                    cam.lens_ray(fx, fy, w, h, u)
                } else {
                    (cam.origin, cam.ray_direction(fx, fy, w, h))
                };
                push(&mut camera, o, d, f32::MAX);
                let Some(hit) = b.closest(scene, o, d, f32::MAX) else {
                    continue;
                };
                let v = scene.triangles[hit.prim as usize].v;
                let (p, err) = robust::triangle_point(&v, hit.bary.x, hit.bary.y);
                let mut n = robust::triangle_normal(&v);
                if n.dot(d) > 0.0 {
                    n = -n;
                }
                let origin = robust::offset_ray_origin(p, err, n);
                // Cosine-distributed about n (Malley's method).
                let (r, phi) = (rng.f().sqrt(), std::f32::consts::TAU * rng.f());
                let (t, s) = n.any_orthonormal_pair();
                let local = Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - r * r).max(0.0).sqrt());
                push(
                    &mut bounce,
                    origin,
                    t * local.x + s * local.y + n * local.z,
                    f32::MAX,
                );
                if !emitters.is_empty() {
                    let e = rng.pick(&emitters).v;
                    let (mut b1, mut b2) = (rng.f(), rng.f());
                    if b1 + b2 > 1.0 {
                        (b1, b2) = (1.0 - b1, 1.0 - b2);
                    }
                    let (q, q_err) = robust::triangle_point(&e, b1, b2);
                    let mut en = robust::triangle_normal(&e);
                    if en.dot(origin - q) < 0.0 {
                        en = -en;
                    }
                    let to = robust::offset_ray_origin(q, q_err, en) - origin;
                    let dist = to.length();
                    if dist > 0.0 {
                        let tmax = dist * (1.0 - robust::SHADOW_EPSILON);
                        push(&mut shadow, origin, to / dist, tmax);
                    }
                }
            }
        }
    }
    let mut sets = vec![("camera", false, camera), ("bounce", false, bounce)];
    if !shadow.is_empty() {
        sets.push(("shadow", true, shadow));
    }
    sets
}

/// Traces every kind of `scene`'s rays both ways on one device.
pub fn run(scene: &Scene, o: &RaysOptions) -> Result<RaysReport> {
    if !scene.spheres.is_empty() {
        bail!(
            "the scene has {} analytic sphere(s): the ray-query side traces triangles only \
             (a sphere would need procedural geometry and brdfwave's own intersection code); \
             use a scene of triangles",
            scene.spheres.len()
        );
    }
    if scene.triangles.is_empty() {
        bail!("the scene has no triangles to trace");
    }
    let camera_rays = scene.width as u64 * scene.height as u64 * o.per_pixel.max(1) as u64;
    if camera_rays > MAX_RAYS {
        bail!(
            "{}x{} pixels × {} rays per pixel are {camera_rays} camera rays; at most {MAX_RAYS} \
             (one dispatch of 65535 workgroups of 64, Vulkan's guaranteed limit): use a smaller \
             --res or --per-pixel",
            scene.width,
            scene.height,
            o.per_pixel
        );
    }
    let b = bvh::build(scene);
    let sets = make_rays(scene, &b, o.per_pixel.max(1), o.seed);
    let ctx = Context::new(&ContextOptions {
        device: o.device.clone(),
        validation: false,
        ray_query: !o.ours_only,
    })?;
    let result = run_on(&ctx, scene, &b, &sets, o);
    for m in ctx.finish() {
        eprintln!("vulkan: {m}");
    }
    result
}

fn run_on(
    ctx: &Context,
    scene: &Scene,
    b: &Bvh,
    sets: &[RaySet],
    o: &RaysOptions,
) -> Result<RaysReport> {
    let storage = raw::BufferUsageFlags::STORAGE_BUFFER;
    // brdfwave's kernel and the scene as the renderer uploads it (texel views).
    let generated = [(
        bvh_probe::INTERFACE_PATH.to_string(),
        bvh_probe::interface_glsl(),
    )];
    let kinds = bvh_probe::descriptor_types();
    let mut ours = Vec::new();
    for any in [false, true] {
        let mut defines = bvh_defines(b);
        if any {
            defines.push(("ANY_HIT".into(), "1".into()));
        }
        let spirv = ShaderCompiler::new()?
            .with_source("rays_probe.comp", OURS)?
            .compile_generated("rays_probe.comp", &defines, &[], &generated)?
            .spirv;
        ours.push(ctx.create_compute_pipeline_with("rays ours", &spirv, &kinds, 4)?);
    }
    let texels = BvhTexels::upload(ctx, scene, b)?;
    // The platform's: the scene's triangles in their own order (a hit's primitive index is
    // then the triangle index, as brdfwave's `prim` is).
    let query = if o.ours_only {
        None
    } else {
        let kinds = [
            raw::DescriptorType::STORAGE_BUFFER,
            raw::DescriptorType::STORAGE_BUFFER,
            raw::DescriptorType::ACCELERATION_STRUCTURE_KHR,
        ];
        let mut p = Vec::new();
        for any in [false, true] {
            let defines = match any {
                true => vec![("ANY_HIT".to_string(), "1".to_string())],
                false => Vec::new(),
            };
            let spirv = ShaderCompiler::new()?
                .with_source("rays_query.comp", RAY_QUERY)?
                .compile_generated("rays_query.comp", &defines, &[], &[])?
                .spirv;
            p.push(ctx.create_compute_pipeline_with("rays query", &spirv, &kinds, 4)?);
        }
        let tris: Vec<[[f32; 3]; 3]> = scene
            .triangles
            .iter()
            .map(|t| t.v.map(|v| v.to_array()))
            .collect();
        let t0 = Instant::now();
        let accel = ctx.build_triangle_accel(&tris)?;
        eprintln!(
            "rays: the driver built its acceleration structures over {} triangles in {:.3} s",
            tris.len(),
            t0.elapsed().as_secs_f64()
        );
        Some((p, accel))
    };

    let mut rows = Vec::new();
    for (kind, any, rays) in sets {
        let n = rays.len() / 2;
        if n == 0 {
            continue;
        }
        let inp = ctx.create_buffer_with_data("rays", rays, storage)?;
        let out = ctx.create_buffer("hits", (n * 16) as u64, storage, MemoryLocation::GpuOnly)?;
        let count = n as u32;
        let mut res = vec![Resource::Buffer(&inp), Resource::Buffer(&out)];
        res.extend(texels.resources());
        let ours_p = &ours[*any as usize];
        let set = ctx.create_descriptor_set_with(ours_p, &res)?;
        let (ours_s, ours_hits) = time(ctx, ours_p, set, count, &out, o.repeats)?;
        let (query_s, agreement) = match &query {
            None => (None, None),
            Some((p, accel)) => {
                let res = [
                    Resource::Buffer(&inp),
                    Resource::Buffer(&out),
                    Resource::Accel(&accel.top),
                ];
                let p = &p[*any as usize];
                let set = ctx.create_descriptor_set_with(p, &res)?;
                let (s, hits) = time(ctx, p, set, count, &out, o.repeats)?;
                let same = ours_hits
                    .iter()
                    .zip(&hits)
                    .filter(|(a, b)| a[0] == b[0])
                    .count();
                (Some(s), Some(same as f64 / n as f64))
            }
        };
        ctx.destroy_buffer(inp);
        ctx.destroy_buffer(out);
        let cpu_s = time_cpu(scene, b, rays, *any, o.repeats);
        rows.push(RaysRow {
            cpu_mrays: n as f64 / cpu_s / 1e6,
            kind,
            rays: n,
            ours_mrays: n as f64 / ours_s / 1e6,
            query_mrays: query_s.map(|s| n as f64 / s / 1e6),
            agreement,
        });
    }
    for p in ours {
        ctx.destroy_pipeline(p);
    }
    texels.destroy(ctx);
    if let Some((ps, accel)) = query {
        for p in ps {
            ctx.destroy_pipeline(p);
        }
        ctx.destroy_triangle_accel(accel);
    }
    Ok(RaysReport {
        device: ctx.device_name.clone(),
        driver: ctx.driver_info.clone(),
        rows,
    })
}

/// The CPU traversal of `rays` on all threads: the fastest of `repeats` passes (seconds).
fn time_cpu(scene: &Scene, b: &Bvh, rays: &[[f32; 4]], any: bool, repeats: u32) -> f64 {
    use rayon::prelude::*;
    let mut best = f64::INFINITY;
    for _ in 0..=repeats.max(1) {
        let t0 = Instant::now();
        let hits = rays
            .par_chunks(2 * 1024)
            .map(|chunk| {
                chunk
                    .chunks(2)
                    .filter(|r| {
                        let (o, d) = (Vec3::from_slice(&r[0]), Vec3::from_slice(&r[1]));
                        match any {
                            true => b.occluded(scene, o, d, r[0][3]),
                            false => b.closest(scene, o, d, r[0][3]).is_some(),
                        }
                    })
                    .count()
            })
            .sum::<usize>();
        std::hint::black_box(hits);
        best = best.min(t0.elapsed().as_secs_f64());
    }
    best
}

/// One untimed dispatch, then the fastest of `repeats` timed ones (seconds), and the hits.
fn time(
    ctx: &Context,
    p: &crate::vk::ComputePipeline,
    set: raw::DescriptorSet,
    count: u32,
    out: &crate::vk::Buffer,
    repeats: u32,
) -> Result<(f64, Vec<[u32; 4]>)> {
    let mut best = f64::INFINITY;
    for k in 0..=repeats.max(1) {
        let mut rec = ctx.begin()?;
        rec.bind(p, set);
        rec.push_constants(p, &count);
        rec.dispatch(count.div_ceil(64), 1, 1);
        let t0 = Instant::now();
        ctx.submit_and_wait(rec)
            .with_context(|| format!("tracing with pipeline {}", p.name))?;
        if k > 0 {
            best = best.min(t0.elapsed().as_secs_f64());
        }
    }
    Ok((best, ctx.download(out)?))
}
