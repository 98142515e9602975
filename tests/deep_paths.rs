//! Loops that a driver may cut short. Mesa 22.3's gallivm (lavapipe) ends every loop of a shader
//! invocation once the invocation has made 65,535 loop iterations in all, without any sign
//! (docs/loops.md). Before the renderer knew, the megakernel stopped every path at about 5,462
//! segments, `accumulate` kept only the first 32,767 samples of a pixel in a wave, and a ray
//! whose BVH traversal was that long silently missed. These tests fail on such a driver if any
//! of it comes back.

mod common;

use brdfwave::gpu::{GpuOptions, GpuRenderer, Integrator};
use brdfwave::output::RenderOutput;
use brdfwave::scene::Scene;
use brdfwave::vk::{Context, ShaderCompiler};
use common::*;
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    scratch("deep").join(name)
}

/// `scenes/furnace-sphere.toml` with albedo 1: every segment of every path adds exactly 0.5
/// (emission plus light sample, MIS-weighted), so D segments give 0.5 × D.
fn white_furnace(w: u32, h: u32, spp: u32, max_depth: u32) -> Scene {
    let text = std::fs::read_to_string(repo().join("scenes/furnace-sphere.toml")).unwrap();
    assert!(text.contains("albedo = 0.5"));
    let p = tmp("white-furnace-sphere.toml");
    std::fs::write(&p, text.replace("albedo = 0.5", "albedo = 1.0")).unwrap();
    let mut s = brdfwave::scene::load(&p).expect("scene loads");
    s.width = w;
    s.height = h;
    s.integrator.spp = spp;
    s.integrator.max_depth = max_depth;
    s
}

/// A context without the validation layer: it checks every dispatch, and these renders make
/// 10^4 to 10^5 of them (the API use is the same as in the other tests, which validate it).
fn context() -> Context {
    Context::new(&brdfwave::vk::ContextOptions {
        device: None,
        validation: false,
        ray_query: false,
    })
    .expect("a Vulkan device (install mesa-vulkan-drivers)")
}

fn gpu(ctx: &Context, s: &Scene, integrator: Integrator) -> anyhow::Result<RenderOutput> {
    let b = brdfwave::bvh::build(s);
    let compiler = ShaderCompiler::new()?;
    let mut r = GpuRenderer::with_options(
        ctx,
        s,
        b.into(),
        &compiler,
        GpuOptions {
            integrator,
            ..Default::default()
        },
    )?;
    r.render(&|_| {})
}

fn assert_mean(name: &str, out: &RenderOutput, expected: f64) {
    for (c, m) in out.mean.mean().iter().enumerate() {
        assert!(
            (m - expected).abs() <= 1e-5 * expected,
            "{name}: channel {c}: mean {m}, expected {expected}"
        );
    }
}

fn furnace_at(depths: &[u32], integrators: &[Integrator], cpu: bool) {
    let ctx = context();
    for &d in depths {
        let s = white_furnace(2, 2, 1, d);
        let expected = 0.5 * d as f64;
        for &i in integrators {
            let out = gpu(&ctx, &s, i).expect("GPU render");
            assert_eq!(out.extension_rays, 4 * d as u64, "{} at D = {d}", i.name());
            assert_mean(&format!("{} at D = {d}", i.name()), &out, expected);
        }
        if cpu {
            assert_mean(&format!("cpu at D = {d}"), &render_cpu(&s), expected);
        }
    }
    finish(ctx);
}

/// The furnace at 1,000, 10,000 and 100,000 segments gives 0.5 × D in both integrators and on
/// the CPU (the megakernel gave 2730.75 for every D ≥ 5,500). The wavefront at 100,000 takes
/// half a minute on lavapipe (a dispatch per stage and segment): `deep_wavefront_furnace`.
#[test]
fn the_white_furnace_gives_half_the_depth_everywhere() {
    furnace_at(&[1_000, 10_000], &[Integrator::Wavefront], false);
    furnace_at(&[1_000, 10_000, 100_000], &[Integrator::Megakernel], true);
}

/// 16 CPU paths of 2^20 segments each: every path reaches its last segment. A cosine sample on
/// the concentric disk's rim (a random number exactly 0, once in 2^24) used to be a tangent
/// direction of pdf 0, which ended the path: 0.9 % to 8 % of these segments were lost,
/// depending on the sampler.
#[test]
fn a_million_segment_furnace_loses_no_path_on_the_cpu() {
    let d = 1u32 << 20;
    let s = white_furnace(4, 4, 1, d);
    let out = render_cpu(&s);
    assert_eq!(out.extension_rays, 16 * d as u64, "segments traced");
    assert_mean("cpu at D = 2^20", &out, 0.5 * d as f64);
}

#[test]
#[ignore = "about 30 s on lavapipe: run with --ignored"]
fn deep_wavefront_furnace() {
    furnace_at(&[100_000], &[Integrator::Wavefront], false);
}

/// A 1×1 image at 70,000 samples puts every sample in one wave; `accumulate` adds a pixel's
/// samples of a wave in one loop. Each sample of `furnace-sphere.toml` at depth 1 is 0.5.
#[test]
fn every_sample_of_a_many_sample_pixel_reaches_the_film() {
    let ctx = context();
    let s = scene("furnace-sphere.toml", 1, 1, 70_000, 1, 3);
    for i in [Integrator::Wavefront, Integrator::Megakernel] {
        let out = gpu(&ctx, &s, i).expect("GPU render");
        assert_eq!(out.spp, 70_000);
        assert_mean(i.name(), &out, 0.5);
    }
    finish(ctx);
}

/// A ray that must visit every node of a large BVH: 70,000 triangles stacked along the camera
/// ray, each with a bounding box around the ray but missing it, and behind them one that it
/// hits (black: the pixel is 0, against the environment's 1 on a miss). The traversal takes
/// more loop iterations than an invocation gets on lavapipe: the render fails and says why,
/// instead of returning the miss of a ray that stopped half way (which it did). The CPU renders
/// it. (On a driver without the limit, the GPU renders it too, and matches the CPU.)
#[test]
fn a_traversal_cut_short_by_the_driver_is_an_error() {
    let n = 70_000;
    let mut obj = String::new();
    for i in 0..n {
        let z = 1.0 + i as f64 * 1e-4;
        obj += &format!("v -1 -1 {z}\nv 1 -1 {z}\nv 1 0.9 {z}\n");
    }
    let z = 1.1 + n as f64 * 1e-4;
    obj += &format!("v -1 -1 {z}\nv 1 -1 {z}\nv 0 1 {z}\n");
    for i in 0..=n {
        obj += &format!("f {} {} {}\n", 3 * i + 1, 3 * i + 2, 3 * i + 3);
    }
    std::fs::write(tmp("stack.obj"), obj).unwrap();
    let toml = "[camera]\nposition = [0.0, 0.0, 0.0]\ntarget = [0.0, 0.0, 1.0]\nfov_y = 0.001\n\
                [film]\nwidth = 1\nheight = 1\n[integrator]\nspp = 1\nmax_depth = 1\n\
                [environment]\nradiance = 1.0\n\
                [materials.grey]\nmodel = \"lambert\"\nalbedo = 0.5\n\
                [[shapes]]\nmaterial = \"grey\"\nobj = \"stack.obj\"\n";
    std::fs::write(tmp("stack.toml"), toml).unwrap();
    let s = brdfwave::scene::load(&tmp("stack.toml")).expect("scene loads");
    let cpu = render_cpu(&s);
    assert_eq!(cpu.mean.data[0], [0.0; 3], "the ray hits the last triangle");
    let ctx = context();
    for i in [Integrator::Wavefront, Integrator::Megakernel] {
        match gpu(&ctx, &s, i) {
            Ok(out) => assert_eq!(out.mean.data[0], [0.0; 3], "{}", i.name()),
            Err(e) => {
                let msg = format!("{e:#}");
                assert!(
                    msg.contains("loop") && msg.contains("65,535"),
                    "{}: {msg}",
                    i.name()
                );
            }
        }
    }
    finish(ctx);
}
