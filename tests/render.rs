//! End-to-end renders on both backends (the GPU one on lavapipe in CI): same-seed parity,
//! independent-seed statistical agreement, scenes with known answers, the depth convention,
//! and "a scene builds only the pipelines it needs".

mod common;
use brdfwave::metrics;
use common::*;

/// Same seed, same random-number keys: the two renderers follow the same paths, so nearly every
/// pixel agrees to float precision; a few paths may diverge where a ray grazes an edge.
#[test]
fn cornell_box_gpu_matches_cpu_with_the_same_seed() {
    let s = scene("cornell-box.toml", 96, 96, 8, 8, 7);
    let ctx = context();
    let (gpu, _) = render_gpu(&ctx, &s);
    let cpu = render_cpu(&s);
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
    let rel = |a: u64, b: u64| (a as f64 - b as f64).abs() / b as f64;
    assert!(
        rel(gpu.extension_rays, cpu.extension_rays) < 0.01,
        "{} vs {}",
        gpu.extension_rays,
        cpu.extension_rays
    );
    assert!(
        rel(gpu.shadow_rays, cpu.shadow_rays) < 0.01,
        "{} vs {}",
        gpu.shadow_rays,
        cpu.shadow_rays
    );
    finish(ctx);
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
    finish(ctx);
}

/// Independent seeds: per-pixel two-sample test of the means (Mitsuba-style, Šidák-corrected).
#[test]
fn cornell_box_gpu_and_cpu_agree_statistically_with_independent_seeds() {
    let ctx = context();
    let (gpu, _) = render_gpu(&ctx, &scene("cornell-box.toml", 24, 24, 128, 8, 1));
    let cpu = render_cpu(&scene("cornell-box.toml", 24, 24, 128, 8, 2));
    // Both sides run the same estimator, so the pooled (Student) variance is the calibrated
    // choice (Welch is anti-conservative for skewed per-sample distributions).
    let opts = metrics::ZTestOptions {
        alpha: 0.01,
        variance: metrics::VarianceModel::Pooled,
        ..Default::default()
    };
    let r = metrics::z_test_with(
        &gpu.mean,
        &gpu.variance,
        gpu.spp as u64,
        &cpu.mean,
        &cpu.variance,
        cpu.spp as u64,
        &opts,
    )
    .unwrap();
    if !r.pass {
        save("z-gpu.exr", &gpu.mean);
        save("z-cpu.exr", &cpu.mean);
        save("z-pvalues.exr", &r.p_map);
    }
    assert!(r.pass, "{r}");
    finish(ctx);
}

fn analytic_furnace(out: &brdfwave::output::RenderOutput, expected: f64) {
    let n = out.mean.data.len() as f64 * out.spp as f64;
    for c in 0..3 {
        let mean: f64 =
            out.mean.data.iter().map(|p| p[c] as f64).sum::<f64>() / out.mean.data.len() as f64;
        let var: f64 = out.variance.data.iter().map(|p| p[c] as f64).sum::<f64>()
            / out.variance.data.len() as f64;
        let se = (var / n).sqrt();
        assert!(var > 0.0, "the estimator should have some variance");
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
    finish(ctx);
}

/// White furnace: a convex Lambertian sphere (ρ = 0.8) under a constant environment of
/// radiance 1. Every path that sees the sphere reflects once and escapes, so the sphere is
/// exactly 0.8 (zero variance) and the background exactly 1.
#[test]
fn white_furnace_sphere_is_exact_on_both_backends() {
    let s = scene("white-furnace.toml", 33, 33, 16, 8, 5);
    let ctx = context();
    for (name, out) in [("cpu", render_cpu(&s)), ("gpu", render_gpu(&ctx, &s).0)] {
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
    finish(ctx);
}

/// max_depth counts segments: with one segment only directly visible emitters show.
#[test]
fn depth_one_shows_only_the_light_on_both_backends() {
    let s = scene("cornell-box.toml", 32, 32, 4, 1, 0);
    let ctx = context();
    for (name, out) in [("cpu", render_cpu(&s)), ("gpu", render_gpu(&ctx, &s).0)] {
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
    finish(ctx);
}

/// Only the models a scene uses get a shade pipeline.
#[test]
fn a_lambert_only_scene_builds_only_the_lambert_shade_pipeline() {
    let s = scene("cornell-box.toml", 8, 8, 1, 2, 0);
    let ctx = context();
    let (_, pipelines) = render_gpu(&ctx, &s);
    let shade: Vec<&String> = pipelines
        .iter()
        .filter(|p| p.starts_with("shade_"))
        .collect();
    assert_eq!(shade, vec!["shade_lambert"], "all pipelines: {pipelines:?}");
    finish(ctx);
}
