//! Point and directional lights: the analytic direct light on a Lambertian plane on the CPU
//! and both GPU integrators, same-seed parity with an area light in the same scene, and the
//! `[[lights]]` tables' errors.

mod common;
use brdfwave::camera::CameraBasis;
use brdfwave::gpu::{GpuOptions, GpuRenderer, Integrator};
use brdfwave::metrics;
use brdfwave::output::RenderOutput;
use brdfwave::scene::{load_str, Scene};
use common::*;
use glam::Vec3;
use std::f32::consts::PI;
use std::path::Path;

const ALBEDO: f32 = 0.6;

/// A Lambertian floor (y = 0, facing +y, larger than the view) seen from above, lit by `lights` (TOML), with
/// `extra` shapes; direct light only (two segments).
fn floor_scene(lights: &str, extra: &str) -> Scene {
    floor_scene_from(4.0, "", lights, extra)
}

/// [`floor_scene`] with the camera at height `y` and more fields of the floor's material.
fn floor_scene_from(y: f32, floor: &str, lights: &str, extra: &str) -> Scene {
    let src = format!(
        "[camera]\nposition = [0, {y}, 0]\ntarget = [0, 0, 0]\nup = [0, 0, 1]\nfov_y = 30\n\
         [film]\nwidth = 16\nheight = 12\n[integrator]\nspp = 16\nmax_depth = 2\nseed = 3\n\
         [materials.floor]\nmodel = \"lambert\"\nalbedo = {ALBEDO}\n{floor}\n\
         [[shapes]]\nmaterial = \"floor\"\n\
         quads = [[[-3, 0, -3], [-3, 0, 3], [3, 0, 3], [3, 0, -3]]]\n{extra}\n{lights}\n"
    );
    let s = load_str(&src, Path::new("lights.toml")).unwrap_or_else(|e| panic!("{e}"));
    // Without lights the loader warns of a black image (a test then adds emission).
    assert!(
        s.warnings.is_empty() || lights.is_empty(),
        "{:?}",
        s.warnings
    );
    s
}

/// The CPU render and both GPU integrators' renders.
fn renders(s: &Scene) -> Vec<(&'static str, RenderOutput)> {
    let ctx = context();
    let compiler = brdfwave::vk::ShaderCompiler::new().unwrap();
    let b = std::sync::Arc::new(brdfwave::bvh::build(s));
    let mut out = vec![("cpu", render_cpu(s))];
    for (name, integrator) in [
        ("wavefront", Integrator::Wavefront),
        ("megakernel", Integrator::Megakernel),
    ] {
        let options = GpuOptions {
            integrator,
            ..Default::default()
        };
        let mut r =
            GpuRenderer::with_options(&ctx, s, b.clone(), &compiler, options).expect("set-up");
        out.push((name, r.render(&|_| {}).expect("render")));
    }
    finish(ctx);
    out
}

/// The floor point seen through the centre of pixel (x, y).
fn floor_point(s: &Scene, x: u32, y: u32) -> Vec3 {
    let cam = CameraBasis::new(s);
    let d = cam.ray_direction(x as f32 + 0.5, y as f32 + 0.5, s.width, s.height);
    cam.origin + d * (-cam.origin.y / d.y)
}

/// Every pixel of every render within `tol` (relative) of `expected(floor point)`.
fn check(s: &Scene, tol: f32, expected: impl Fn(Vec3) -> Vec3) {
    for (name, r) in renders(s) {
        assert_eq!(r.nonfinite_samples, 0, "{name}");
        let mut worst = 0.0f32;
        for y in 0..s.height {
            for x in 0..s.width {
                let want = expected(floor_point(s, x, y));
                let want = want.max(Vec3::ZERO);
                let got = Vec3::from_array(r.mean.get(x, y));
                let err = ((got - want).abs() / want.max(Vec3::splat(1e-6))).max_element();
                worst = worst.max(err);
                assert!(
                    err <= tol,
                    "{name}: pixel ({x}, {y}): {got} vs analytic {want}"
                );
            }
        }
        println!("{name}: worst relative error {worst:.2e}");
    }
}

/// L = ρ/π · I cos θ / r² for a point light of intensity I.
#[test]
fn a_point_light_gives_the_inverse_square_irradiance() {
    let (pos, intensity) = (Vec3::new(0.7, 1.5, -0.4), Vec3::new(10.0, 5.0, 2.0));
    let s = floor_scene(
        "[[lights]]\ntype = \"point\"\nposition = [0.7, 1.5, -0.4]\nintensity = [10, 5, 2]\n",
        "",
    );
    // The pixel-filter jitter averages the radiance over each pixel (about 0.07 units wide):
    // the centre value is off by the curvature term, well below 1%.
    check(&s, 0.01, |p| {
        let to = pos - p;
        let r2 = to.length_squared();
        let cos = to.y / r2.sqrt();
        ALBEDO / PI * intensity * cos / r2
    });
}

/// L = ρ/π · E cos θ for a directional light of irradiance E (normal incidence): the same in
/// every pixel, and every sample gives it exactly (no noise).
#[test]
fn a_directional_light_gives_the_cosine_irradiance() {
    let s = floor_scene(
        "[[lights]]\ntype = \"directional\"\ndirection = [0.3, -1, 0.2]\nirradiance = [2, 3, 4]\n",
        "",
    );
    let cos = 1.0 / Vec3::new(0.3, -1.0, 0.2).length();
    check(&s, 1e-4, |_| ALBEDO / PI * Vec3::new(2.0, 3.0, 4.0) * cos);
    // From below the floor, the light is behind the surface: black.
    let s = floor_scene(
        "[[lights]]\ntype = \"directional\"\ndirection = [0, 1, 0]\nirradiance = 1\n",
        "",
    );
    check(&s, 0.0, |_| Vec3::ZERO);
}

/// Point, directional and area lights together: with the same seed both backends choose the
/// same light for each sample (one table, one selection rule), and the image is their sum.
#[test]
fn delta_and_area_lights_mix_with_the_same_choices_on_both_backends() {
    let lights = "[[lights]]\ntype = \"point\"\nposition = [0.7, 1.5, -0.4]\nintensity = 4\n\
                  [[lights]]\ntype = \"directional\"\ndirection = [0.3, -1, 0.2]\nirradiance = 0.5\n";
    // A black, downward-facing lamp panel (it also shades the floor from the other lights).
    let lamp = |e: f32| {
        format!(
            "[materials.lamp]\nmodel = \"lambert\"\nalbedo = 0\n[[shapes]]\nmaterial = \"lamp\"\n\
             emission = {e}\nquads = [[[-0.5, 2, -0.5], [0.5, 2, -0.5], [0.5, 2, 0.5], [-0.5, 2, 0.5]]]\n"
        )
    };
    let mut s = floor_scene(lights, &lamp(3.0));
    s.integrator.spp = 64;
    let out = renders(&s);
    let cpu = &out[0].1;
    for (name, gpu) in &out[1..] {
        let agree = metrics::fraction_within(&gpu.mean, &cpu.mean, 1e-3, 1e-4).unwrap();
        assert!(agree.channel_fraction >= 0.99, "{name}: {agree}");
        assert_eq!(gpu.shadow_rays, cpu.shadow_rays, "{name}");
    }
    // The sum of the three lights, each rendered alone (independent noise: a loose check of
    // the mean over the image).
    let alone = |l: &str, e: f32| {
        let mut s = floor_scene(l, &lamp(e));
        s.integrator.spp = 64;
        render_cpu(&s).mean.mean()
    };
    let (p, d) = lights.split_at(lights.find("[[lights]]\ntype = \"directional").unwrap());
    let parts = [alone(p, 0.0), alone(d, 0.0), alone("", 3.0)];
    let all = cpu.mean.mean();
    for c in 0..3 {
        let sum: f64 = parts.iter().map(|m| m[c]).sum();
        assert!(
            (all[c] - sum).abs() <= 0.03 * sum,
            "channel {c}: {} vs {sum}",
            all[c]
        );
    }
}

/// A two-sided floor seen and lit from below shades like its front: the same inverse-square
/// radiance as from above; a one-sided floor is black from below. An emitter stays one-sided:
/// a two-sided emitting floor seen from below reflects the light but emits nothing there.
#[test]
fn a_two_sided_floor_shades_its_back_like_its_front() {
    let (pos, intensity) = (Vec3::new(0.7, -1.5, -0.4), Vec3::new(10.0, 5.0, 2.0));
    let light =
        "[[lights]]\ntype = \"point\"\nposition = [0.7, -1.5, -0.4]\nintensity = [10, 5, 2]\n";
    let analytic = |p: Vec3| {
        let to = pos - p;
        let r2 = to.length_squared();
        ALBEDO / PI * intensity * (-to.y / r2.sqrt()) / r2
    };
    let s = floor_scene_from(-4.0, "twosided = true", light, "");
    check(&s, 0.01, analytic);
    let s = floor_scene_from(-4.0, "twosided = false", light, "");
    check(&s, 0.0, |_| Vec3::ZERO);
    // Emission only from the front (+y), two-sided or not: black from below, 7 from above.
    for (y, want) in [(-4.0, 0.0), (4.0, 7.0)] {
        let mut s = floor_scene_from(y, "twosided = true", "", "");
        s.emitters.push(brdfwave::scene::Emitter {
            radiance: Vec3::splat(7.0),
        });
        for t in &mut s.triangles {
            t.emitter = Some(0);
        }
        check(&s, 1e-6, |_| Vec3::splat(want));
    }
    let e = light_error("[materials.t]\nmodel = \"lambert\"\ntwosided = 1\n");
    assert!(
        e.contains("field 'materials.t.twosided': expected true or false, found 1"),
        "{e}"
    );
}

fn light_error(lights: &str) -> String {
    let src = format!(
        "[camera]\nposition = [0, 4, 0]\ntarget = [0, 0, 0]\nup = [0, 0, 1]\nfov_y = 30\n\
         [film]\nwidth = 4\nheight = 4\n[materials.m]\nmodel = \"lambert\"\n\
         [[shapes]]\nmaterial = \"m\"\nsphere = {{ center = [0, 0, 0], radius = 1 }}\n{lights}"
    );
    match load_str(&src, Path::new("l.toml")) {
        Ok(_) => panic!("loaded: {lights}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn light_tables_are_checked() {
    for (lights, want) in [
        ("[[lights]]\ntype = \"spot\"\n", "l.toml:15: field 'lights[0].type': unknown light type \"spot\""),
        ("[[lights]]\ntype = \"point\"\nintensity = 1\n", "field 'lights[0].position': a point light needs 'position'"),
        ("[[lights]]\ntype = \"point\"\nposition = [0, 2, 0]\n", "field 'lights[0].intensity': a point light needs 'intensity'"),
        ("[[lights]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = 1\nirradiance = 1\n", "field 'lights[0].irradiance': a point light has no 'irradiance' (it takes position and intensity)"),
        ("[[lights]]\ntype = \"directional\"\ndirection = [0, 0, 0]\nirradiance = 1\n", "l.toml:16: field 'lights[0].direction': [0, 0, 0] has zero length"),
        ("[[lights]]\ntype = \"directional\"\ndirection = [0, -1, 0]\nirradiance = [1, -1, 1]\n", "field 'lights[0].irradiance': [1, -1, 1] has a negative channel"),
        ("[[lights]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = 1\ncolor = 2\n", "l.toml:18: field 'lights[0].color': unknown field"),
        ("[[lights]]\nposition = [0, 2, 0]\nintensity = 1\n", "l.toml:14: field 'lights[0].type': missing: this field is required"),
    ] {
        let e = light_error(lights);
        assert!(e.contains(want), "{lights:?}\n  gave: {e}\n  want: {want}");
    }
}

/// The form factor from a point to the rectangle [0, a] × [0, b] in a parallel plane at height
/// h, one corner above the point (Howell's catalogue, configuration B-3; e.g. Siegel & Howell,
/// "Thermal Radiation Heat Transfer"), signed by the quadrant of (a, b).
fn corner_form_factor(a: f64, b: f64, h: f64) -> f64 {
    let (x, y) = (a.abs() / h, b.abs() / h);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    let f = (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI);
    a.signum() * b.signum() * f
}

/// A square lamp (one quad: two triangles sampled as one light, `lights::PAIR_BIT`) facing
/// down over the floor, out of the camera's view: every floor pixel has L = ρ · Le · F, F the
/// point-to-rectangle form factor. Checks that the pair's one 2-D sample covers the quad
/// uniformly (a wrong split or density would be off by far more than the tolerance), on the CPU
/// and both GPU integrators.
#[test]
fn a_quad_lamp_gives_the_form_factor_irradiance() {
    let (x0, x1, z0, z1, h) = (1.6f64, 2.6f64, -0.5f64, 0.5f64, 1.0f64);
    let lamp = format!(
        "[materials.lamp]\nmodel = \"lambert\"\nalbedo = 0\n\
         [[shapes]]\nmaterial = \"lamp\"\nemission = [3, 2, 1]\n\
         quads = [[[{x0}, {h}, {z0}], [{x1}, {h}, {z0}], [{x1}, {h}, {z1}], [{x0}, {h}, {z1}]]]\n"
    );
    let mut s = floor_scene("", &lamp);
    s.integrator.spp = 1024;
    let lights = brdfwave::lights::LightTable::build(&s);
    assert_eq!(lights.prims.len(), 1, "the quad is one light");
    assert_ne!(lights.prims[0] & brdfwave::lights::PAIR_BIT, 0);
    check(&s, 0.01, |p| {
        let (px, pz) = (p.x as f64, p.z as f64);
        let g = |x: f64, z: f64| corner_form_factor(x - px, z - pz, h);
        let f = g(x1, z1) - g(x0, z1) - g(x1, z0) + g(x0, z0);
        ALBEDO * Vec3::new(3.0, 2.0, 1.0) * f as f32
    });
}

/// One bounce, checked against a numerical integration written here, independent of both
/// renderers: a white quad stands on a white floor with its face turned away from the lamp, so
/// it is lit only by the floor (max depth 3: camera → quad → floor → lamp). For the pixels
/// whose centre ray meets the quad away from its edges, the mean radiance of the CPU and both
/// GPU integrators is within 1.5 % of ρ · ρ/π · E(y) averaged over cosine-distributed floor
/// points y, E by uniform points on the lamp with the quad's shadow. (Mitsuba 3.9.1 agrees
/// with it too, except with its `ldsampler`, which renders this quad 1.7–3.7 % dark at any
/// sample count: see tests/mitsuba_peer.rs.)
#[test]
fn a_quad_lit_only_by_the_floor_matches_a_numerical_integration() {
    // The quad's corners, in order around it.
    let quad: [[f32; 3]; 4] = [
        [130.0, 0.0, 65.0],
        [130.0, 165.0, 65.0],
        [290.0, 165.0, 114.0],
        [290.0, 0.0, 114.0],
    ];
    let src = format!(
        "[camera]\nposition = [278, 273, -800]\ntarget = [278, 273, 0]\nup = [0, 1, 0]\n\
         fov_y = 39.3077\n[film]\nwidth = 128\nheight = 128\n\
         [integrator]\nspp = 256\nmax_depth = 3\nseed = 5\n\
         [materials.white]\nmodel = \"lambert\"\nalbedo = 0.7\n\
         [materials.lamp]\nmodel = \"lambert\"\nalbedo = 0\n\
         [[shapes]]\nmaterial = \"white\"\n\
         quads = [[[552.8, 0, 0], [0, 0, 0], [0, 0, 559.2], [549.6, 0, 559.2]]]\n\
         [[shapes]]\nmaterial = \"white\"\nquads = [[{}]]\n\
         [[shapes]]\nmaterial = \"lamp\"\nemission = 12\n\
         quads = [[[343, 548.7, 227], [343, 548.7, 332], [213, 548.7, 332], [213, 548.7, 227]]]\n",
        quad.map(|c| format!("{c:?}")).join(", ")
    );
    let [v0, v1, _, v3] = quad.map(Vec3::from_array);
    let s = load_str(&src, Path::new("one-bounce.toml")).unwrap_or_else(|e| panic!("{e}"));
    let (rho, le) = (0.7f64, 12.0f64);
    let (eu, ev) = ((v3 - v0).as_dvec3(), (v1 - v0).as_dvec3());
    // The face's normal, towards the camera (−z).
    let n = eu.cross(ev).normalize();
    let n = if n.z < 0.0 { n } else { -n };
    let o0 = v0.as_dvec3();
    // (s, t) of the point where the line o + τd meets the quad's plane, and τ.
    let on_quad = |o: glam::DVec3, d: glam::DVec3| -> Option<(f64, f64, f64)> {
        let den = d.dot(n);
        if den.abs() < 1e-12 {
            return None;
        }
        let tau = (o0 - o).dot(n) / den;
        let q = o + d * tau - o0;
        let g = glam::DMat2::from_cols_array(&[eu.dot(eu), eu.dot(ev), eu.dot(ev), ev.dot(ev)]);
        let st = g.inverse() * glam::DVec2::new(q.dot(eu), q.dot(ev));
        Some((st.x, st.y, tau))
    };
    // The integration's own numbers (the stress tests' SplitMix64), independent of the
    // renderers' generator.
    let mut rng = brdfwave::stress::Rng::new(0x9E37_79B9_7F4A_7C15);
    let mut rnd = move || rng.f64();
    let t1 = n.cross(glam::DVec3::Y).normalize();
    let t2 = n.cross(t1);
    let cam = CameraBasis::new(&s);
    let (mut pixels, mut reference) = (Vec::new(), 0.0f64);
    for y in 0..s.height {
        for x in 0..s.width {
            let d = cam.ray_direction(x as f32 + 0.5, y as f32 + 0.5, s.width, s.height);
            let o = cam.origin.as_dvec3();
            let Some((su, tv, tau)) = on_quad(o, d.as_dvec3()) else {
                continue;
            };
            if tau <= 0.0 || !(0.15..0.85).contains(&su) || !(0.15..0.85).contains(&tv) {
                continue;
            }
            let p = o + d.as_dvec3() * tau;
            let k = 4000;
            let mut sum = 0.0;
            for _ in 0..k {
                let (u1, u2) = (rnd(), rnd());
                let (r, phi) = (u1.sqrt(), 2.0 * std::f64::consts::PI * u2);
                let w = t1 * (r * phi.cos()) + t2 * (r * phi.sin()) + n * (1.0 - u1).sqrt();
                if w.y >= 0.0 {
                    continue;
                }
                let f = p + w * (-p.y / w.y);
                let on_floor = f.x >= 0.0 && f.z >= 0.0 && f.z <= 559.2;
                if !on_floor || f.x > 552.8 - 3.2 * f.z / 559.2 {
                    continue;
                }
                let l = glam::DVec3::new(213.0 + 130.0 * rnd(), 548.7, 227.0 + 105.0 * rnd());
                let to = l - f;
                let dist = to.length();
                let wl = to / dist;
                let shadowed = on_quad(f, wl).is_some_and(|(a, b, t)| {
                    t > 1e-6 && t < dist && (0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b)
                });
                if !shadowed {
                    // E(f) = Le cosθ_f cosθ_l / r² · area (one uniform lamp point); the floor's
                    // radiance ρ/π · E; cosine sampling at p weighs it by ρ.
                    let e = le * wl.y * wl.y / (dist * dist) * 130.0 * 105.0;
                    sum += rho * rho / std::f64::consts::PI * e;
                }
            }
            reference += sum / k as f64;
            pixels.push((x, y));
        }
    }
    reference /= pixels.len() as f64;
    assert!(pixels.len() > 100, "{} pixels on the quad", pixels.len());
    for (name, r) in renders(&s) {
        assert_eq!(r.nonfinite_samples, 0, "{name}");
        let mean = pixels
            .iter()
            .map(|&(x, y)| r.mean.get(x, y)[1] as f64)
            .sum::<f64>()
            / pixels.len() as f64;
        let err = mean / reference - 1.0;
        println!(
            "{name}: {mean:.6e} against {reference:.6e} ({:+.2} %)",
            100.0 * err
        );
        assert!(
            err.abs() < 0.015,
            "{name}: {mean} against the integration's {reference}"
        );
    }
}
