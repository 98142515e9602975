//! The GLSL twin of the BVH traversal (`shaders/bvh.glsl`): it compiles for Vulkan, and on a
//! Vulkan device (lavapipe in CI) it finds the same hits as the CPU traversal.
//!
//! Run `cargo test --test bvh_glsl -- --nocapture` to see the hit counts of every scene.

mod common;

use brdfwave::bvh::{self, Bvh, SPHERE_BIT};
use brdfwave::gpu::bvh_probe;
use brdfwave::robust;
use brdfwave::scene::Scene;
use brdfwave::stress::Rng;
use brdfwave::vk::{raw, Context, ContextOptions, Resource, ShaderCompiler};
use common::bvh::{grid_cube, mixed_scene, random_spheres, scene, targets, tmax_of, RayRng};
use glam::{Vec2, Vec3};

/// The probe kernel: per ray two vec4 in (o, tmax), (d, the triangle the ray leaves as
/// `bvh_leaving_code`, 0 for none); out two uvec4:
/// (closest prim or ~0, t, b1, b2) and (any hit, offset_ray_origin(o, |o|·4e-7, d)). Its
/// bindings and push constant are declared by the header `gpu::bvh_probe::interface_glsl` generates.
const PROBE: &str = r#"#version 460
#extension GL_GOOGLE_include_directive : require
#include "bvh_probe/interface.glsl"
#include "bvh.glsl"
#include "robust.glsl"
layout(local_size_x = 64) in;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    vec4 o = rays[2u * i];
    vec4 d = rays[2u * i + 1u];
    Hit h;
    uint leaving = bvh_leaving_prim(d.w);
    bool c = trace_closest_leaving(o.xyz, d.xyz, o.w, leaving, h);
    bool a = trace_any_leaving(o.xyz, d.xyz, o.w, leaving);
    vec3 q = offset_ray_origin(o.xyz, abs(o.xyz) * 4.0e-7, d.xyz);
    outp[2u * i] = uvec4(c ? h.prim : 0xFFFFFFFFu, floatBitsToUint(h.t), floatBitsToUint(h.bary.x), floatBitsToUint(h.bary.y));
    outp[2u * i + 1u] = uvec4(a ? 1u : 0u, floatBitsToUint(q.x), floatBitsToUint(q.y), floatBitsToUint(q.z));
}
"#;

/// The probe compiled by the product's shader compiler (shaders as embedded in the build), with
/// `defines` (the renderer's [`brdfwave::gpu::bvh_defines`] for a tree, or none: the array
/// stack).
fn compile_probe(defines: &[(String, String)]) -> Vec<u32> {
    let generated = [(
        bvh_probe::INTERFACE_PATH.to_string(),
        bvh_probe::interface_glsl(),
    )];
    ShaderCompiler::new()
        .and_then(|c| c.with_source("bvh_probe.comp", PROBE))
        .and_then(|c| c.compile_generated("bvh_probe.comp", defines, &[], &generated))
        .map(|c| c.spirv)
        .unwrap_or_else(|e| panic!("shaders/bvh.glsl does not compile:\n{e:#}"))
}

#[test]
fn glsl_twin_compiles_for_vulkan() {
    assert!(compile_probe(&[]).len() > 100);
    let regs = [("BVH_STACK_REGS".to_string(), "8".to_string())];
    assert!(compile_probe(&regs).len() > 100);
}

/// A probe ray: origin, direction, tmax, and the primitive it leaves ([`NONE`] for none).
type ProbeRay = (Vec3, Vec3, f32, u32);

/// No primitive left.
const NONE: u32 = u32::MAX;

/// `bvh_leaving_code` of `shaders/bvh.glsl`: a triangle reference as reference + 1 below 2^24,
/// else 0 (none).
fn leaving_code(prim: u32) -> f32 {
    if prim < 1 << 24 {
        (prim + 1) as f32
    } else {
        0.0
    }
}

/// Runs the probe over `rays` ((o, tmax), (d, 0) per ray) against the scene as the renderer
/// uploads it (`gpu::bvh_probe::BvhTexels`).
fn run_probe(ctx: &Context, spirv: &[u32], s: &Scene, b: &Bvh, rays: &[[f32; 4]]) -> Vec<[u32; 4]> {
    let storage = raw::BufferUsageFlags::STORAGE_BUFFER;
    let n = rays.len() / 2;
    let inp = ctx.create_buffer_with_data("rays", rays, storage).unwrap();
    let out = ctx
        .create_buffer(
            "out",
            (n * 32) as u64,
            storage,
            brdfwave::vk::MemoryLocation::GpuOnly,
        )
        .unwrap();
    let texels = bvh_probe::BvhTexels::upload(ctx, s, b).unwrap();
    let kinds = bvh_probe::descriptor_types();
    let p = ctx
        .create_compute_pipeline_with("bvh_probe", spirv, &kinds, 4)
        .unwrap();
    let mut res = vec![Resource::Buffer(&inp), Resource::Buffer(&out)];
    res.extend(texels.resources());
    let set = ctx.create_descriptor_set_with(&p, &res).unwrap();
    let mut rec = ctx.begin().unwrap();
    rec.bind(&p, set);
    rec.push_constants(&p, &(n as u32));
    rec.dispatch((n as u32).div_ceil(64), 1, 1);
    ctx.submit_and_wait(rec).unwrap();
    let result: Vec<[u32; 4]> = ctx.download(&out).unwrap();
    ctx.destroy_pipeline(p);
    texels.destroy(ctx);
    ctx.destroy_buffer(inp);
    ctx.destroy_buffer(out);
    result
}

/// The probe's rays for scene `s`: random rays (half aimed at primitives), secondary rays from
/// surface points as the renderer makes them, and axis-aligned rays from grid points.
fn probe_rays(s: &Scene, b: &Bvh, rng: &mut Rng) -> Vec<ProbeRay> {
    let tg = targets(s, rng);
    let mut rays: Vec<ProbeRay> = Vec::new();
    for k in 0..20_000 {
        let o = rng.vec(-8.0, 8.0);
        let d = if k % 2 == 0 || tg.is_empty() {
            rng.dir()
        } else {
            tg[(rng.next_u64() % tg.len() as u64) as usize] - o
        };
        rays.push((o, d, tmax_of(rng, 10.0), NONE));
    }
    // Secondary rays as the renderer makes them: from surface points (offset along the
    // normal, and raw) in random directions, spheres included.
    for k in 0..4000 {
        let (o, d, tmax, _) = rays[k];
        let Some(h) = b.closest(s, o, d, tmax) else {
            continue;
        };
        let (p, err, n) = if h.prim & SPHERE_BIT != 0 {
            let sph = &s.spheres[(h.prim & !SPHERE_BIT) as usize];
            let toward = o.as_dvec3() + d.as_dvec3() * h.t as f64 - sph.center.as_dvec3();
            robust::sphere_point(sph.center, sph.radius, toward)
        } else {
            let v = s.triangles[h.prim as usize].v;
            let (p, err) = robust::triangle_point(&v, h.bary.x, h.bary.y);
            (p, err, brdfwave::robust::triangle_normal(&v))
        };
        let n = if k % 2 == 0 { n } else { -n };
        let mut dir = rng.dir();
        if dir.dot(n) < 0.0 {
            dir -= 2.0 * dir.dot(n) * n;
        }
        let origin = robust::offset_ray_origin(p, err, n);
        // Told the primitive it leaves (a sphere's is not skipped), and not told.
        rays.push((origin, dir, f32::MAX, h.prim));
        rays.push((origin, dir, f32::MAX, NONE));
        rays.push((p, dir, f32::MAX, NONE));
    }
    // Axis-aligned rays from grid points (zero direction components, box-face origins).
    for k in 0..3000 {
        let o = Vec3::new(
            (rng.next_u64() % 9) as f32 * 0.25 - 1.0,
            (rng.next_u64() % 9) as f32 * 0.25 - 1.0,
            rng.range(-0.9, 0.9),
        );
        let mut d = [0.0f32; 3];
        d[k % 3] = if k % 2 == 0 { 1.0 } else { -1.0 };
        let o = match k % 3 {
            0 => Vec3::new(o.z, o.x, o.y),
            1 => Vec3::new(o.y, o.z, o.x),
            _ => o,
        };
        rays.push((o, Vec3::from(d), f32::MAX, NONE));
    }
    rays
}

/// Checks the GPU probe's answers `out` for `rays` against the CPU traversal; returns the hits,
/// and how many of them are bit-exact and how many only within 1e-5 in t.
fn compare_probe(
    name: &str,
    s: &Scene,
    b: &Bvh,
    rays: &[ProbeRay],
    out: &[[u32; 4]],
) -> (usize, usize, usize) {
    let (mut hits, mut exact, mut inexact) = (0, 0, 0);
    for (i, &(o, d, tmax, leaving)) in rays.iter().enumerate() {
        let [prim, t, b1, b2] = out[2 * i];
        let [any, qx, qy, qz] = out[2 * i + 1];
        let cpu = b.closest_leaving(s, o, d, tmax, leaving);
        let q = robust::offset_ray_origin(o, o.abs() * 4.0e-7, d);
        assert_eq!(
            [qx, qy, qz],
            [q.x.to_bits(), q.y.to_bits(), q.z.to_bits()],
            "{name}: offset_ray_origin({o}, |o|·4e-7, {d})"
        );
        assert_eq!(
            any == 1,
            b.occluded_leaving(s, o, d, tmax, leaving),
            "{name}: any-hit differs for o={o} d={d} tmax={tmax}"
        );
        match cpu {
            None => assert_eq!(
                prim,
                u32::MAX,
                "{name}: GPU hit {prim:#x} t={}, CPU none: o={o} d={d}",
                f32::from_bits(t)
            ),
            Some(h) => {
                assert_ne!(prim, u32::MAX, "{name}: GPU missed, CPU {h:?}: o={o} d={d}");
                hits += 1;
                let gt = f32::from_bits(t);
                let gb = Vec2::new(f32::from_bits(b1), f32::from_bits(b2));
                // The tie rule (among equal t the smallest reference) does not depend on
                // the traversal order: the GPU's binary tree and the CPU's wide tree keep the
                // same primitive.
                assert_eq!(
                    prim, h.prim,
                    "{name}: GPU hit {prim:#x} at {gt}, CPU {h:?}: o={o} d={d}"
                );
                if t == h.t.to_bits() && gb == h.bary {
                    exact += 1;
                } else {
                    // Tolerated on devices whose division or sqrt is not correctly rounded.
                    let rel = (gt - h.t).abs() / h.t.max(1e-30);
                    assert!(
                        rel < 1e-5,
                        "{name}: t differs: GPU {gt}, CPU {h:?}: o={o} d={d}"
                    );
                    inexact += 1;
                }
            }
        }
    }
    (hits, exact, inexact)
}

/// `n` parallel triangles at z from -0.95 to 0.95, each covering the square [-2, 2]² in x and y.
fn stacked_layers(n: usize) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|i| {
            let z = -0.95 + 1.9 * i as f32 / (n - 1) as f32;
            [
                Vec3::new(-5.0, -3.0, z),
                Vec3::new(5.0, -3.0, z),
                Vec3::new(0.0, 7.0, z),
            ]
        })
        .collect()
}

#[test]
fn glsl_traversal_matches_cpu_on_a_vulkan_device() {
    let ctx = Context::new(&ContextOptions::default()).expect("a Vulkan device (lavapipe)");
    let mut rng = Rng::new(15);
    let scenes = [
        ("mixed", mixed_scene(&mut rng, 800, 80)),
        (
            "grid cube (no spheres)",
            scene(grid_cube(8, -1.0, 1.0), vec![]),
        ),
        (
            "spheres only",
            scene(vec![], random_spheres(&mut rng, 200, 5.0)),
        ),
        ("empty", scene(vec![], vec![])),
        // Parallel triangles across z: a ray along z enters both children of every node on
        // its way, so its stack fills to the tree's depth.
        ("stacked layers", scene(stacked_layers(300), vec![])),
    ];
    // Each tree with the stack the renderer gives it (in registers: every tree here is shallow
    // enough) and with the array stack of deeper trees.
    let mut register_stacks = 0;
    for (name, s) in &scenes {
        let b = bvh::build(s);
        let rays = probe_rays(s, &b, &mut rng);
        let ray_data: Vec<[f32; 4]> = rays
            .iter()
            .flat_map(|&(o, d, t, l)| [[o.x, o.y, o.z, t], [d.x, d.y, d.z, leaving_code(l)]])
            .collect();
        let n = rays.len();
        let defines = brdfwave::gpu::bvh_defines(&b);
        register_stacks += defines.len();
        // ... and with the fewest registers that hold its deepest traversal.
        let tight = vec![(
            "BVH_STACK_REGS".to_string(),
            (b.stats.max_depth + 1).to_string(),
        )];
        for defines in [defines, tight, vec![]] {
            let stack = match defines.first() {
                Some((_, n)) => format!("{n} stack registers"),
                None => "array stack".to_string(),
            };
            let out = run_probe(&ctx, &compile_probe(&defines), s, &b, &ray_data);
            let name = &format!("{name}, {stack} (depth {})", b.stats.max_depth);
            let (hits, exact, inexact) = compare_probe(name, s, &b, &rays, &out);
            println!("{name} on {}: {n} rays, {hits} hits, {exact} bit-exact, {inexact} t/bary off in the last bits", ctx.device_name);
            // lavapipe's float division and sqrt are IEEE: everything must be bit-exact there.
            if ctx.device_name.contains("llvmpipe") {
                assert_eq!(
                    inexact, 0,
                    "{name}: results are not bit-exact on {}",
                    ctx.device_name
                );
            }
        }
    }
    assert_eq!(
        register_stacks,
        scenes.len(),
        "every tree here fits a register stack"
    );
}
