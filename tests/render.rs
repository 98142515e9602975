//! End-to-end renders on both backends (the GPU one on lavapipe in CI): same-seed parity,
//! independent-seed statistical agreement, scenes with known answers, the depth convention,
//! and "a scene builds only the pipelines it needs".

mod common;
use brdfwave::metrics;
use brdfwave::rng::Sampler;
use common::*;

/// Same seed, same random-number keys: the two renderers follow the same paths, so nearly every
/// pixel agrees to float precision; a few paths may diverge where a ray grazes an edge.
#[test]
fn cornell_box_gpu_matches_cpu_with_the_same_seed() {
    let s = scene("cornell-box.toml", 96, 96, 8, 8, 7);
    let [(_, cpu), (_, gpu)] = render_both(&s);
    assert_eq!(gpu.nonfinite_samples, 0);
    assert_eq!(cpu.nonfinite_samples, 0);
    let agree = metrics::fraction_within(&gpu.mean, &cpu.mean, 1e-3, 1e-4).unwrap();
    if agree.channel_fraction < 0.99 {
        let a = save("same-seed-gpu.exr", &gpu.mean);
        save("same-seed-cpu.exr", &cpu.mean);
        save(
            "same-seed-error.png",
            &metrics::error_map(&gpu.mean, &cpu.mean).unwrap(),
        );
        panic!(
            "need 99% of pixel-channels to agree: {agree}images in {}",
            a.parent().unwrap().display()
        );
    }
    // The two sides also traced the same number of rays, up to the few diverging paths.
    for (rays, g, c) in [
        ("extension rays", gpu.extension_rays, cpu.extension_rays),
        ("shadow rays", gpu.shadow_rays, cpu.shadow_rays),
    ] {
        let rel = (g as f64 - c as f64).abs() / c as f64;
        assert!(rel < 0.01, "{rays}: GPU {g} vs CPU {c}");
    }
}

/// The wave size changes how paths are batched, never the image: one sample of a 64-pixel chunk
/// per wave (the last chunk partial), two samples of the whole image per wave (the last wave
/// one), and all five at once give bit-identical films and the same ray counts.
#[test]
fn the_image_does_not_depend_on_the_wave_size() {
    let s = scene("cornell-box.toml", 24, 20, 5, 4, 3);
    let ctx = context();
    let (all, _) = render_gpu(&ctx, &s);
    assert_eq!(all.nonfinite_samples, 0);
    assert!(all.mean.mean().iter().all(|&c| c > 0.01), "a lit image");
    for wave in [64, 1000] {
        let (w, _) = render_gpu_wave(&ctx, &s, wave);
        assert!(
            w.mean.data == all.mean.data && w.variance.data == all.variance.data,
            "wave of {wave} paths: the film differs"
        );
        assert_eq!(w.extension_rays, all.extension_rays, "wave {wave}");
        assert_eq!(w.shadow_rays, all.shadow_rays, "wave {wave}");
    }
    finish(ctx);
}

/// Queue pushes aggregated over the subgroup (lavapipe and most GPUs have ballots) and one
/// atomic per push (the fallback) fill the queues in different orders but give the same film.
#[test]
fn subgroup_and_plain_queue_pushes_give_the_same_image() {
    let s = scene("cornell-box-glossy.toml", 24, 20, 3, 5, 9);
    let mut ctx = context();
    assert!(
        ctx.features.subgroup_ballot,
        "lavapipe has subgroup ballots in compute shaders"
    );
    let (sub, _) = render_gpu(&ctx, &s);
    ctx.features.subgroup_ballot = false;
    let (plain, _) = render_gpu(&ctx, &s);
    assert_eq!(sub.nonfinite_samples + plain.nonfinite_samples, 0);
    assert!(sub.mean.data == plain.mean.data, "the films differ");
    assert_eq!(sub.extension_rays, plain.extension_rays);
    assert_eq!(sub.shadow_rays, plain.shadow_rays);
    // One model: extend shades in place and counts its shadow rays per subgroup, or per
    // invocation without ballots.
    let one = scene("cornell-box.toml", 24, 20, 3, 5, 9);
    let (plain1, _) = render_gpu(&ctx, &one);
    ctx.features.subgroup_ballot = true;
    let (sub1, _) = render_gpu(&ctx, &one);
    assert!(sub1.mean.data == plain1.mean.data, "the films differ");
    assert_eq!(sub1.rays_by_segment, plain1.rays_by_segment);
    assert!(sub1.shadow_rays > 0);
    finish(ctx);
}

/// The Cornell box at 24×24, max depth 8, with this sampler, spp and seed.
fn cornell_box(sampler: Sampler, spp: u32, seed: u32) -> brdfwave::scene::Scene {
    let mut s = scene("cornell-box.toml", 24, 24, spp, 8, seed);
    s.integrator.sampler = sampler;
    s
}

/// Independent seeds: per-pixel two-sample test of the means (Mitsuba-style, Šidák-corrected).
/// With the `independent` sampler: the pooled variance is the calibrated choice only when a
/// pixel's samples are independent (a `sobol` render's per-sample variance overstates the
/// variance of its mean, which would make this test conservative and weaker).
#[test]
fn cornell_box_gpu_and_cpu_agree_statistically_with_independent_seeds() {
    let ctx = context();
    let (gpu, _) = render_gpu(&ctx, &cornell_box(Sampler::Independent, 128, 1));
    let cpu = render_cpu(&cornell_box(Sampler::Independent, 128, 2));
    let r = common::pooled_z_test(&gpu, &cpu);
    if !r.pass {
        save("z-gpu.exr", &gpu.mean);
        save("z-cpu.exr", &cpu.mean);
        save("z-pvalues.exr", &r.p_map);
    }
    assert!(r.pass, "{r}");
    finish(ctx);
}

/// The stratified samplers (`multijitter`, `sobol`) are unbiased: each one's Cornell box agrees
/// with an `independent` render within noise, per pixel. The z-test takes each render's
/// per-sample variance as if its samples were independent: for a stratified render that
/// overstates the variance of its mean (its samples are negatively correlated), so the test is
/// conservative; it still catches a biased sampler (a shifted or clumped dimension moves whole
/// regions of the image). Also: at equal spp each one's image is closer to a converged reference
/// than the `independent` one (the point of the samplers), checked on the mean squared error.
#[test]
fn stratified_samplers_agree_with_independent_and_have_less_error() {
    let indep = render_cpu(&cornell_box(Sampler::Independent, 128, 2));
    // Error against a 4096-spp independent reference, at 32 spp (three seeds each).
    let reference = render_cpu(&cornell_box(Sampler::Independent, 4096, 99)).mean;
    let mse = |sampler| {
        (10..13)
            .map(|seed| {
                let img = render_cpu(&cornell_box(sampler, 32, seed)).mean;
                metrics::diff(&img, &reference).unwrap().mse
            })
            .sum::<f64>()
    };
    let i = mse(Sampler::Independent);
    for sampler in [Sampler::Multijitter, Sampler::Sobol] {
        let r = common::pooled_z_test(&render_cpu(&cornell_box(sampler, 128, 1)), &indep);
        assert!(r.pass, "{sampler}: {r}");
        let s = mse(sampler);
        assert!(
            s * 2.0 < i,
            "MSE at 32 spp: {sampler} {s:e}, independent {i:e}"
        );
    }
}

/// The image mean is the exact value within 5 standard errors and 1e-5. The standard error
/// comes from the per-sample variance as if the samples were independent; with the default
/// `multijitter` sampler that overstates it (stratified samples vary less in their mean), so the
/// bound is conservative; a bias of more than a few standard errors still fails it. In the
/// closed sphere below the estimator's exact variance is zero (from a point on the sphere, the
/// light sample's solid-angle density, dist²/(A cos) = cosθ/π, is the cosine sample's: equal
/// MIS weights, and every path sums to the same value), so what variance there is is rounding's,
/// possibly none at all, and the 1e-5 governs.
fn analytic_furnace(out: &brdfwave::output::RenderOutput, expected: f64) {
    let n = out.mean.data.len() as f64 * out.spp as f64;
    for c in 0..3 {
        let mean: f64 =
            out.mean.data.iter().map(|p| p[c] as f64).sum::<f64>() / out.mean.data.len() as f64;
        let var: f64 = out.variance.data.iter().map(|p| p[c] as f64).sum::<f64>()
            / out.variance.data.len() as f64;
        let se = (var / n).sqrt();
        assert!(var >= 0.0 && var.is_finite(), "channel {c}: variance {var}");
        assert!(
            (mean - expected).abs() < 5.0 * se + 1e-5,
            "channel {c}: mean {mean} vs exact {expected} (standard error {se})"
        );
    }
}

/// pbrt's analytic scene: the camera inside a closed Lambertian sphere (ρ = 0.5) that also emits
/// Le = 0.5. With at most D segments the exact radiance is Le·Σ_{k<D} ρᵏ everywhere.
#[test]
fn closed_sphere_lit_from_within_renders_the_exact_radiance_on_both_backends() {
    let depth = 6;
    let expected = 0.5 * (1.0 - 0.5f64.powi(depth as i32)) / (1.0 - 0.5);
    let s = scene("furnace-sphere.toml", 16, 16, 64, depth, 3);
    analytic_furnace(&render_cpu(&s), expected);
    let ctx = context();
    analytic_furnace(&render_gpu(&ctx, &s).0, expected);
    // A sample count that is not a power of two (the default `multijitter` draws 23 of the
    // points of a 32-point pattern, every one uniform): still the exact value.
    let odd = scene("furnace-sphere.toml", 16, 16, 23, depth, 4);
    analytic_furnace(&render_cpu(&odd), expected);
    analytic_furnace(&render_gpu(&ctx, &odd).0, expected);
    finish(ctx);
}

/// White furnace: a convex Lambertian sphere (ρ = 0.8) under a constant environment of
/// radiance 1. Every path that sees the sphere reflects once and escapes, so the sphere is
/// exactly 0.8 (zero variance) and the background exactly 1.
#[test]
fn white_furnace_sphere_is_exact_on_both_backends() {
    let s = scene("white-furnace.toml", 33, 33, 16, 8, 5);
    for (name, out) in render_both(&s) {
        let centre = out.mean.data[16 * 33 + 16];
        let corner = out.mean.data[0];
        for c in 0..3 {
            assert!((centre[c] - 0.8).abs() < 1e-5, "{name}: centre {centre:?}");
            assert!((corner[c] - 1.0).abs() < 1e-6, "{name}: corner {corner:?}");
        }
        for p in &out.mean.data {
            assert!(
                p.iter().all(|&v| (0.8 - 1e-5..=1.0 + 1e-6).contains(&v)),
                "{name}: pixel {p:?}"
            );
        }
    }
}

/// max_depth counts segments: with one segment only directly visible emitters show.
#[test]
fn depth_one_shows_only_the_light_on_both_backends() {
    let s = scene("cornell-box.toml", 32, 32, 4, 1, 0);
    for (name, out) in render_both(&s) {
        let lit = out.mean.data.iter().filter(|p| p[0] > 0.0).count();
        assert!(lit > 0, "{name}: the light is visible from the camera");
        for p in &out.mean.data {
            // A pixel sees the light fully, partly (at its edge) or not at all.
            assert!(
                p[0] <= 17.0 + 1e-4 && (p[0] == 0.0) == (p[1] == 0.0),
                "{name}: {p:?}"
            );
            if p[0] > 0.0 {
                assert!(
                    (p[1] / p[0] - 12.0 / 17.0).abs() < 1e-4,
                    "{name}: not the light's colour: {p:?}"
                );
            }
        }
    }
    // Two segments add direct illumination: the walls light up.
    let s2 = scene("cornell-box.toml", 32, 32, 4, 2, 0);
    let out = render_cpu(&s2);
    assert!(out.mean.data.iter().filter(|p| p[0] > 0.0).count() > 32 * 32 / 2);
}

/// Only the models a scene uses get a shade pipeline; with one model, extend shades in place
/// (no material queue, no separate shade kernel), with the same image as separate kernels.
#[test]
fn a_lambert_only_scene_builds_only_the_lambert_shade_pipeline() {
    let s = scene("cornell-box.toml", 8, 8, 1, 2, 0);
    let ctx = context();
    let (_, pipelines) = render_gpu(&ctx, &s);
    let shade: Vec<&String> = pipelines.iter().filter(|p| p.contains("shade_")).collect();
    assert_eq!(
        shade,
        vec!["extend_shade_lambert"],
        "all pipelines: {pipelines:?}"
    );
    assert!(
        !pipelines.iter().any(|p| p == "extend" || p == "shadow"),
        "{pipelines:?}"
    );
    // The same scene with a second (black-free) model forces separate extend and shade kernels
    // and a material queue per model: the Lambert paths render as before.
    let one = scene("cornell-box.toml", 24, 20, 3, 6, 1);
    let (fused, _) = render_gpu(&ctx, &one);
    let mut two = one.clone();
    let ward = brdfwave::brdf::inline::parse_inline(
        "model = \"ward\", kd = [0.2, 0.2, 0.2], ks = [0.1, 0.1, 0.1], alpha_x = 0.3, alpha_y = 0.3",
    )
    .unwrap();
    two.materials.push(ward);
    two.material_names.push("unused ward".into());
    let (split, pipes) = render_gpu(&ctx, &two);
    assert!(
        pipes.iter().any(|p| p == "extend") && pipes.iter().any(|p| p == "shade_lambert"),
        "{pipes:?}"
    );
    assert!(
        fused.mean.data == split.mean.data,
        "fused and separate kernels differ"
    );
    assert_eq!(fused.rays_by_segment, split.rays_by_segment);
    finish(ctx);
}

/// Non-finite values are counted where they arise, at the same stages on both backends, and
/// none reaches the image. The scene is built to overflow f32: the camera sits between a floor
/// and a light of radiance 3e38 a hair above it, looking down. The floor is a Cook–Torrance
/// survey-form surface with F = 1, whose sampled throughput exceeds 1, so emission reached by
/// BSDF sampling overflows (`extend`). Finite samples near 3e38, whose squares overflow f32,
/// are accumulated, not dropped: `accumulate` counts only the paths whose own sum of finite
/// contributions overflowed (0 or 1 of these 2,304 paths, depending on the random numbers),
/// the same paths on both backends, where a GPU film that dropped every sample whose square
/// overflows would count hundreds. Next-event
/// contributions stay finite (the MIS weight bounds them by f·cosθ/(2·pdf_bsdf)); the shade
/// stages' counters are tested by injection below.
#[test]
fn nonfinite_values_are_counted_by_stage_on_both_backends() {
    let text = r#"
[camera]
position = [0.0, 0.0005, 0.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
fov_y = 90.0

[film]
width = 24
height = 24

[integrator]
spp = 4
max_depth = 3
seed = 5

[materials.floor]
model = "cook_torrance"
kd = 0.0
ks = 1.0
roughness = 0.4
fresnel = "schlick"
f0 = 1.0

[materials.black]
model = "lambert"
albedo = 0.0

[[shapes]]
name = "floor"
material = "floor"
quads = [[[-2.0, 0.0, -2.0], [-2.0, 0.0, 2.0], [2.0, 0.0, 2.0], [2.0, 0.0, -2.0]]]

[[shapes]]
name = "light"
material = "black"
emission = [3.0e38, 3.0e38, 3.0e38]
quads = [[[-0.5, 0.001, -0.5], [0.5, 0.001, -0.5], [0.5, 0.001, 0.5], [-0.5, 0.001, 0.5]]]
"#;
    let path = std::env::temp_dir().join(format!("brdfwave-overflow-{}.toml", std::process::id()));
    std::fs::write(&path, text).unwrap();
    let s = brdfwave::scene::load(&path).expect("overflow scene loads");
    let _ = std::fs::remove_file(&path);
    let ctx = context();
    let (gpu, _) = render_gpu(&ctx, &s);
    let cpu = render_cpu(&s);
    eprintln!(
        "GPU {:?}\nCPU {:?}",
        gpu.nonfinite_by_stage, cpu.nonfinite_by_stage
    );
    let names = |o: &brdfwave::output::RenderOutput| -> Vec<String> {
        o.nonfinite_by_stage.iter().map(|x| x.0.clone()).collect()
    };
    assert_eq!(
        names(&gpu),
        ["extend", "shade_cook_torrance", "accumulate"],
        "stage names"
    );
    assert_eq!(names(&gpu), names(&cpu));
    for ((stage, g), (_, c)) in gpu.nonfinite_by_stage.iter().zip(&cpu.nonfinite_by_stage) {
        // The same paths on both sides; a value that overflows on one side only is rare.
        let tol = 2 + c / 50;
        assert!(g.abs_diff(*c) <= tol, "{stage}: GPU {g}, CPU {c}");
    }
    assert!(gpu.nonfinite_by_stage[0].1 > 0, "extend counted nothing");
    // The CPU film sums in f64 and drops a sample only when the path's own value is not
    // finite: the GPU's accumulate count must not exceed it (the float-order tolerance aside).
    let (gpu_acc, cpu_acc) = (gpu.nonfinite_by_stage[2].1, cpu.nonfinite_by_stage[2].1);
    assert!(
        gpu_acc <= cpu_acc + 2 && cpu_acc <= 4,
        "finite samples were dropped at accumulate: GPU {gpu_acc}, CPU {cpu_acc}"
    );
    let total: u64 = gpu.nonfinite_by_stage.iter().map(|x| x.1).sum();
    assert_eq!(gpu.nonfinite_samples, total);
    for img in [&gpu.mean, &gpu.variance, &cpu.mean, &cpu.variance] {
        assert!(
            img.data.iter().flatten().all(|v| v.is_finite()),
            "a non-finite pixel"
        );
    }
    finish(ctx);
}

/// A model that returns a NaN sample weight (for u.x > 0.5) on both sides: the GPU from a copy
/// of the shaders with `lambert_sample` changed, the CPU from Lambert with its samples changed
/// by this function to do the same. The NaN is counted at `shade_lambert` on both backends, the
/// paths end there, and the image stays finite.
fn nan_weight(s: &mut brdfwave::brdf::BrdfSample, u: glam::Vec2) {
    if u.x > 0.5 {
        s.weight = glam::Vec3::NAN;
    }
}

#[test]
fn a_nan_from_a_model_is_counted_at_its_shade_stage_on_both_backends() {
    let mut s = scene("cornell-box.toml", 24, 24, 4, 5, 2);
    for m in &mut s.materials {
        if m.model_name() == "lambert" && m.brdf.scatters() {
            m.brdf = std::sync::Arc::new(common::brdf::Tampered {
                inner: m.brdf.clone(),
                pdf: None,
                sample: Some(nan_weight),
            });
        }
    }
    // The GPU side: the same change in a copy of the shaders.
    let dir = std::env::temp_dir().join(format!("brdfwave-nan-shaders-{}", std::process::id()));
    copy_dir(&repo().join("shaders"), &dir);
    let lambert = dir.join("brdf/lambert.glsl");
    let src = std::fs::read_to_string(&lambert).unwrap();
    let patched = src.replace(
        "    s.weight = m.p[0].xyz;\n",
        "    s.weight = u.x > 0.5 ? vec3(uintBitsToFloat(0x7fc00000u)) : m.p[0].xyz;\n",
    );
    assert_ne!(
        patched, src,
        "lambert_sample changed since this test was written"
    );
    std::fs::write(&lambert, patched).unwrap();
    let ctx = context();
    let compiler = brdfwave::vk::ShaderCompiler::new()
        .unwrap()
        .with_shader_dir(&dir);
    let b = brdfwave::bvh::build(&s);
    let gpu = {
        let mut r = brdfwave::gpu::GpuRenderer::new(&ctx, &s, b.into(), &compiler).unwrap();
        r.render(&|_| {}).unwrap()
    };
    let _ = std::fs::remove_dir_all(&dir);
    let cpu = render_cpu(&s);
    eprintln!(
        "GPU {:?}\nCPU {:?}",
        gpu.nonfinite_by_stage, cpu.nonfinite_by_stage
    );
    assert_eq!(gpu.nonfinite_by_stage, cpu.nonfinite_by_stage);
    let shade = &gpu.nonfinite_by_stage[1];
    assert_eq!(shade.0, "shade_lambert");
    // About half of the shaded vertices draw u.x > 0.5.
    assert!(shade.1 > 1000, "{shade:?}");
    assert_eq!(gpu.nonfinite_samples, shade.1);
    for img in [&gpu.mean, &cpu.mean] {
        assert!(img.data.iter().flatten().all(|v| v.is_finite()));
    }
    finish(ctx);
}

fn copy_dir(from: &std::path::Path, to: &std::path::Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).unwrap();
        }
    }
}

/// The megakernel follows the same paths with the same arithmetic as the wavefront stages: the
/// same film, ray counts and non-finite counts, on a scene with every model (one switch).
#[test]
fn the_megakernel_renders_the_wavefront_image() {
    use brdfwave::gpu::{GpuRenderer, Integrator};
    let ctx = context();
    let compiler = brdfwave::vk::ShaderCompiler::new().unwrap();
    for (name, w, h) in [("lineup.toml", 40, 16), ("cornell-box-glossy.toml", 24, 20)] {
        let s = scene(name, w, h, 3, 6, 5);
        let b = std::sync::Arc::new(brdfwave::bvh::build(&s));
        let mut outs = Vec::new();
        let mut pipelines = Vec::new();
        for integrator in [Integrator::Wavefront, Integrator::Megakernel] {
            let mut r = GpuRenderer::with_options(
                &ctx,
                &s,
                b.clone(),
                &compiler,
                brdfwave::gpu::GpuOptions {
                    integrator,
                    ..Default::default()
                },
            )
            .expect("set-up");
            outs.push(r.render(&|_| {}).expect("render"));
            pipelines.push(r.setup.pipelines.clone());
        }
        assert_eq!(pipelines[1], ["megakernel", "accumulate"], "{name}");
        let (wf, mk) = (&outs[0], &outs[1]);
        assert_eq!(wf.extension_rays, mk.extension_rays, "{name}");
        assert_eq!(wf.shadow_rays, mk.shadow_rays, "{name}");
        assert_eq!(wf.rays_by_segment, mk.rays_by_segment, "{name}");
        assert_eq!(wf.nonfinite_by_stage, mk.nonfinite_by_stage, "{name}");
        // The CPU reference takes the same paths; a light sample whose f is zero or
        // non-finite on one side only (glossy lobes, float differences) may differ.
        let cpu = render_cpu(&s);
        for (d, (c, g)) in cpu
            .rays_by_segment
            .iter()
            .zip(&wf.rays_by_segment)
            .enumerate()
        {
            assert_eq!(c.0, g.0, "{name}: extension rays of segment {}", d + 1);
            assert!(
                c.1.abs_diff(g.1) * 100 <= g.1.max(1),
                "{name}: shadow rays of segment {}: CPU {} GPU {}",
                d + 1,
                c.1,
                g.1
            );
        }
        assert_eq!(wf.rays_by_segment.len(), 6);
        let total: u64 = wf.rays_by_segment.iter().map(|r| r.0).sum();
        assert_eq!(total, wf.extension_rays);
        assert_eq!(
            wf.rays_by_segment[0].0,
            (w * h * 3) as u64,
            "{name}: one camera ray per path"
        );
        let d = metrics::diff(&mk.mean, &wf.mean).unwrap();
        // Bit-identical on lavapipe; a compiler may contract the two kernels' arithmetic
        // differently elsewhere, hence the tolerance.
        assert!(
            d.max_abs <= 1e-5 * (1.0 + d.mean_reference.iter().cloned().fold(0.0, f64::max)),
            "{name}: {d}"
        );
        println!(
            "{name}: megakernel vs wavefront max |diff| {:.3e}",
            d.max_abs
        );
    }
    finish(ctx);
}

/// Rendering in passes (the benchmark's progressive mode) gives the film of one render, on
/// both backends: each pixel's samples are added in sample order whatever the passes.
#[test]
fn passes_add_up_to_one_render_on_both_backends() {
    use brdfwave::cpu::CpuRenderer;
    use brdfwave::gpu::GpuRenderer;
    let s = scene("cornell-box.toml", 20, 16, 7, 5, 2);
    let b = brdfwave::bvh::build(&s);
    let b = std::sync::Arc::new(b);
    let cpu = CpuRenderer::new(&s, b.clone());
    let whole = cpu.render(&|_| {});
    let mut film = cpu.film();
    for r in [0..1, 1..3, 3..7] {
        cpu.render_samples(&mut film, r, &|_| {});
    }
    let parts = cpu.output(&film);
    assert!(parts.mean.data == whole.mean.data && parts.variance.data == whole.variance.data);
    assert_eq!(parts.extension_rays, whole.extension_rays);

    let ctx = context();
    let compiler = brdfwave::vk::ShaderCompiler::new().unwrap();
    let mut r = GpuRenderer::new(&ctx, &s, b, &compiler).unwrap();
    let whole = r.render(&|_| {}).unwrap();
    r.reset().unwrap();
    for range in [0..2, 2..3, 3..7] {
        r.render_samples(range, &|_| {}).unwrap();
    }
    let parts = r.output().unwrap();
    assert!(parts.mean.data == whole.mean.data && parts.variance.data == whole.variance.data);
    assert_eq!(parts.spp, 7);
    assert_eq!(parts.extension_rays, whole.extension_rays);
    assert!(
        r.render_samples(9..10, &|_| {}).is_err(),
        "a gap in the samples is refused"
    );
    drop(r);
    finish(ctx);
}

/// A depth far beyond where every path ends: the GPU stops once its queues are empty (the
/// white furnace's paths leave after a few bounces) and gives the CPU's image and ray counts.
#[test]
fn a_huge_max_depth_stops_when_every_path_has_ended() {
    let s = scene("white-furnace.toml", 16, 16, 1, 100_000, 4);
    let [(_, cpu), (_, gpu)] = render_both(&s);
    assert_eq!(gpu.extension_rays, cpu.extension_rays);
    assert_eq!(gpu.shadow_rays, cpu.shadow_rays);
    // 32 segments counted, the last holding the deeper ones.
    assert_eq!(gpu.rays_by_segment.len(), 32);
    assert_eq!(gpu.rays_by_segment, cpu.rays_by_segment);
    let d = metrics::diff(&gpu.mean, &cpu.mean).unwrap();
    assert!(d.rmse < 1e-4, "{d}");
}

/// The CPU reference traces a pixel's samples in lockstep packets, with Lambert vertices and
/// triangle hits in SIMD lanes (`src/cpu/lanes.rs`), or one path at a time: the same image and
/// counts, bit for bit, on scenes with and without what the lanes take (triangle lights,
/// spheres, glossy models, textures and an environment map, vertex normals, hidden emitters,
/// Russian roulette, sample ranges that start and end inside a packet).
#[test]
fn lockstep_packets_give_the_image_of_one_path_at_a_time() {
    use brdfwave::cpu::CpuRenderer;
    // (scene, max depth, integrator switch turned on)
    let cases = [
        ("cornell-box.toml", 8, ""),
        ("cornell-box.toml", 40, "russian_roulette"),
        ("cornell-box.toml", 3, "hide_emitters"),
        ("cornell-box-glossy.toml", 8, ""),
        ("furnace-sphere.toml", 8, ""),
        ("material-preview.toml", 8, ""),
        ("obj-example.toml", 8, ""),
    ];
    for (name, depth, flag) in cases {
        let mut s = scene(name, 12, 10, 24, depth, 3);
        match flag {
            "russian_roulette" => s.integrator.russian_roulette = true,
            "hide_emitters" => s.integrator.hide_emitters = true,
            _ => {}
        }
        let b = std::sync::Arc::new(brdfwave::bvh::build(&s));
        let mut images = Vec::new();
        for lanes in [true, false] {
            let cpu = CpuRenderer::new(&s, b.clone()).with_lanes(lanes);
            let mut film = cpu.film();
            // Ranges that split the sampler's packets of 16 (the render's 24 samples round up
            // to 32: packets of 16).
            for r in [0..5, 5..21, 21..24] {
                cpu.render_samples(&mut film, r, &|_| {});
            }
            images.push(cpu.output(&film));
        }
        let (a, b) = (&images[0], &images[1]);
        assert!(
            a.mean.data == b.mean.data && a.variance.data == b.variance.data,
            "{name} depth {depth} {flag}: the lanes' image differs"
        );
        assert_eq!(
            (a.extension_rays, a.shadow_rays, a.shadow_rays_occluded),
            (b.extension_rays, b.shadow_rays, b.shadow_rays_occluded),
            "{name} {flag}"
        );
        assert_eq!(a.rays_by_segment, b.rays_by_segment, "{name} {flag}");
        assert_eq!(a.nonfinite_by_stage, b.nonfinite_by_stage, "{name} {flag}");
        assert!(a.extension_rays > 0);
    }
}
