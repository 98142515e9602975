//! Environment maps (`src/envmap.rs`, `shaders/envmap.glsl`): the furnace test (a constant map
//! around a white Lambert sphere gives 1 everywhere), one bright texel against a distant light
//! of the same solid angle and radiance, the χ² test of the map's sampler against its pdf, and
//! the refusal of bad map files, each with the file and the field named.

mod common;

use brdfwave::envmap::EnvMap;
use brdfwave::imageio::{self, Image};
use brdfwave::scene::{self, Scene};
use glam::{Mat3, Vec3};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// A scene of one sphere (material `material`) seen from -z, in `dir`, with `extra` appended.
fn sphere_scene(dir: &Path, material: &str, extra: &str, size: u32) -> PathBuf {
    let src = format!(
        "[camera]\nposition = [0.0, 0.0, -4.0]\ntarget = [0.0, 0.0, 0.0]\nfov_y = 36.0\n\
         [film]\nwidth = {size}\nheight = {size}\n\
         [materials.m]\n{material}\n\
         [[shapes]]\nmaterial = \"m\"\nsphere = {{ center = [0.0, 0.0, 0.0], radius = 1.0 }}\n{extra}"
    );
    let p = dir.join("s.toml");
    std::fs::write(&p, src).unwrap();
    p
}

fn write_map(dir: &Path, name: &str, img: &Image) -> PathBuf {
    let p = dir.join(name);
    imageio::write(&p, img).unwrap();
    p
}

/// Per pixel |mean − want| / standard error of the mean, the worst over the image.
fn worst_z(mean: &Image, var: &Image, spp: u32, want: f32) -> f64 {
    let mut worst = 0.0f64;
    for (m, v) in mean.data.iter().zip(&var.data) {
        for c in 0..3 {
            let se = (v[c].max(0.0) as f64 / spp as f64).sqrt().max(1e-7);
            worst = worst.max((m[c] - want).abs() as f64 / se);
        }
    }
    worst
}

/// A constant map of 1 (scaled and turned, so that both are exercised) around a sphere of
/// albedo 1: every pixel is 1, the sphere's too (it sees only the environment), within noise,
/// on both backends; the image's mean is 1 within 0.3 %.
#[test]
fn a_constant_map_of_one_around_a_white_lambert_sphere_gives_one_everywhere() {
    let dir = tempfile::tempdir().unwrap();
    write_map(dir.path(), "half.exr", &Image::filled(16, 9, [0.5; 3]));
    let p = sphere_scene(
        dir.path(),
        "model = \"lambert\"\nalbedo = 1.0",
        "[environment]\nmap = \"half.exr\"\nscale = 2.0\n\
         transform = { rotate = { axis = [1.0, 2.0, 0.5], angle_deg = 70.0 } }\n\
         [integrator]\nmax_depth = 16\nsampler = \"independent\"\n",
        24,
    );
    let mut s = scene::load(&p).unwrap();
    s.integrator.spp = 64;
    for (name, out) in common::render_both(&s) {
        assert_eq!(out.nonfinite_samples, 0, "{name}");
        let z = worst_z(&out.mean, &out.variance, out.spp, 1.0);
        let m = out.mean.mean();
        println!("{name}: mean {m:?}, worst |z| {z:.2}");
        // 24 × 24 × 3 pixel-channels at a family-wise rate of 1e-3: |z| < 4.8 (Bonferroni).
        assert!(z < 4.8, "{name}: worst |z| = {z:.2}");
        for c in m {
            assert!((c - 1.0).abs() < 3e-3, "{name}: mean {m:?}");
        }
        // The sphere covers the middle: its pixels have variance (they sample the map), the
        // background's none (a camera ray that misses sees exactly 1).
        let centre = out.variance.get(12, 12);
        assert!(centre[0] > 0.0, "{name}: the sphere is not in the picture");
    }
}

/// The direction of (u, v) of a map in its own frame (src/envmap.rs).
fn direction(u: f64, v: f64) -> [f64; 3] {
    let (st, ct) = (PI * v).sin_cos();
    let (sp, cp) = (2.0 * PI * u).sin_cos();
    [sp * st, ct, -cp * st]
}

/// A map black but for one texel of radiance L lights a sphere as a directional light of
/// irradiance E = ∫ L dω (the bilinear tent of that texel integrated over the sphere of
/// directions), from the texel's direction, does: the two images agree within noise (the
/// whole image and each lit quarter, |z| < 4, and within 2 %), on both backends.
#[test]
fn one_bright_texel_equals_a_distant_light_of_the_same_solid_angle() {
    let (w, h, x0, y0, l) = (128u32, 65u32, 40u32, 20u32, 1000.0f32);
    let dir = tempfile::tempdir().unwrap();
    let mut img = Image::new(w, h);
    img.set(x0, y0, [l; 3]);
    write_map(dir.path(), "dot.pfm", &img);
    // ∫ tent · 2π² sin(πv) du dv over the tent's 2/W × 2/(H − 1) support, in f64.
    let (du, dv) = (1.0 / w as f64, 1.0 / (h - 1) as f64);
    let (u0, v0) = ((x0 as f64 + 0.5) * du, y0 as f64 * dv);
    let n = 400;
    let mut solid_angle = 0.0;
    for i in 0..n {
        for j in 0..n {
            let (a, b) = (
                -1.0 + 2.0 * (i as f64 + 0.5) / n as f64,
                -1.0 + 2.0 * (j as f64 + 0.5) / n as f64,
            );
            let tent = (1.0 - a.abs()) * (1.0 - b.abs());
            let v = v0 + b * dv;
            solid_angle += tent
                * 2.0
                * PI
                * PI
                * (PI * v).sin()
                * (2.0 * du / n as f64)
                * (2.0 * dv / n as f64);
        }
    }
    let e = l as f64 * solid_angle;
    let d = direction(u0, v0);
    let material = "model = \"lambert\"\nalbedo = 0.8";
    let settings = "[integrator]\nmax_depth = 2\nsampler = \"independent\"\n";
    let env = sphere_scene(
        dir.path(),
        material,
        &format!("[environment]\nmap = \"dot.pfm\"\n{settings}"),
        32,
    );
    let env = {
        let mut s = scene::load(&env).unwrap();
        s.integrator.spp = 512;
        s
    };
    let light = sphere_scene(
        dir.path(),
        material,
        &format!(
            "{settings}[[lights]]\ntype = \"directional\"\ndirection = [{}, {}, {}]\nirradiance = {e}\n",
            -d[0], -d[1], -d[2]
        ),
        32,
    );
    let light = {
        let mut s = scene::load(&light).unwrap();
        s.integrator.spp = 256;
        s
    };
    let reference = common::render_cpu(&light).mean;
    // Sums over a block of the image (grey light, grey material: the channels are equal):
    // the value, and the variance of the sum's estimate (variance of one sample / spp).
    let block = |out: &Image, var: Option<&Image>, spp: u32, x0: u32, y0: u32, size: u32| {
        let (mut s, mut v) = (0.0, 0.0);
        for y in y0..y0 + size {
            for x in x0..x0 + size {
                s += out.get(x, y)[1] as f64;
                v += var.map_or(0.0, |i| i.get(x, y)[1] as f64 / spp as f64);
            }
        }
        (s, v)
    };
    let (total, _) = block(&reference, None, 1, 0, 0, 32);
    assert!(total > 10.0, "the light does not reach the sphere: {total}");
    for (name, out) in common::render_both(&env) {
        assert_eq!(out.nonfinite_samples, 0, "{name}");
        // The whole image and each quarter the light reaches: within noise (|z| < 4) and
        // within 2 %.
        for (x0, y0, size) in [
            (0, 0, 32),
            (0, 0, 16),
            (16, 0, 16),
            (0, 16, 16),
            (16, 16, 16),
        ] {
            let (want, _) = block(&reference, None, 1, x0, y0, size);
            if want < 0.1 * total {
                continue;
            }
            let (got, var) = block(&out.mean, Some(&out.variance), out.spp, x0, y0, size);
            let z = (got - want) / var.sqrt();
            println!(
                "{name}: block ({x0}, {y0}) {size}²: map / light = {:.4}, z = {z:.2}",
                got / want
            );
            assert!(
                z.abs() < 4.0 && (got / want - 1.0).abs() < 0.02,
                "{name}: block ({x0}, {y0}): {got} against {want}, z = {z:.2}"
            );
        }
    }
    // The test can fail: the light's irradiance 3 % higher is caught.
    let mut brighter = light.clone();
    if let Some(brdfwave::scene::DeltaLight::Directional { irradiance, .. }) =
        brighter.lights.first_mut()
    {
        *irradiance *= 1.03;
    }
    let (want, _) = block(&common::render_cpu(&brighter).mean, None, 1, 0, 0, 32);
    let out = common::render_cpu(&env);
    let (got, var) = block(&out.mean, Some(&out.variance), out.spp, 0, 0, 32);
    assert!(
        ((got - want) / var.sqrt()).abs() > 4.0,
        "3 % too much light was not caught"
    );
}

/// Pearson's χ² of the map's sampler against its own solid-angle pdf, in bins of equal solid
/// angle in world directions (so that the map's rotation, its (u, v) ↔ direction mapping and
/// the Jacobian 2π² sin θ are all tested), the expected counts by a fine midpoint quadrature of
/// `EnvMap::pdf`; and the pdf integrates to 1.
#[test]
fn the_map_sampler_follows_its_pdf() {
    let (w, h) = (48u32, 25u32);
    // Smooth blobs and a floor, with one very bright texel: a realistic, lumpy map.
    let px: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            let blob = (-((x - 12.0).powi(2) + (y - 8.0).powi(2)) / 18.0).exp();
            let band = (-((y - 18.0).powi(2)) / 4.0).exp();
            let spike = if i == 7 * w + 30 { 40.0 } else { 0.0 };
            [0.05 + 3.0 * blob + spike, 0.05 + band, 0.1 + 2.0 * blob]
        })
        .collect();
    let rot = Mat3::from_axis_angle(Vec3::new(0.3, 1.0, -0.2).normalize(), 0.7);
    let m = EnvMap::new("t.exr".into(), w, h, px.clone(), 1.0, rot).unwrap();
    let (nz, nphi, sub) = (24usize, 48usize, 24usize);
    let bin = |d: Vec3| -> usize {
        let z = ((d.z as f64 + 1.0) * 0.5 * nz as f64).clamp(0.0, nz as f64 - 1.0) as usize;
        let phi = (d.y as f64).atan2(d.x as f64) + PI;
        let p = (phi / (2.0 * PI) * nphi as f64).clamp(0.0, nphi as f64 - 1.0) as usize;
        z * nphi + p
    };
    // Expected probabilities: each bin (dz × dφ, solid angle dz·dφ) by sub × sub midpoints.
    let mut expected = vec![0.0f64; nz * nphi];
    let (dz, dphi) = (2.0 / nz as f64, 2.0 * PI / nphi as f64);
    for (k, e) in expected.iter_mut().enumerate() {
        let (iz, ip) = (k / nphi, k % nphi);
        for a in 0..sub {
            for b in 0..sub {
                let z = -1.0 + (iz as f64 + (a as f64 + 0.5) / sub as f64) * dz;
                let phi = -PI + (ip as f64 + (b as f64 + 0.5) / sub as f64) * dphi;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let d = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                *e += m.pdf(d) as f64;
            }
        }
        *e *= dz * dphi / (sub * sub) as f64;
    }
    let integral: f64 = expected.iter().sum();
    assert!((integral - 1.0).abs() < 2e-3, "∫ pdf dω = {integral}");
    let n = 500_000u32;
    let mut observed = vec![0.0f64; nz * nphi];
    let (mut rejected, mut mismatched) = (0, 0);
    for i in 0..n {
        let u1 = brdfwave::rng::random_f32(11, 0, i, 0, 0);
        let u2 = brdfwave::rng::random_f32(11, 0, i, 0, 1);
        match m.sample(u1, u2) {
            Some(s) => {
                // The pdf recomputed from the direction is the sample's own, but for a sample
                // within rounding of a cell's edge, which the direction may put in the next.
                mismatched += ((m.pdf(s.wi) / s.pdf - 1.0).abs() > 1e-3) as u32;
                observed[bin(s.wi)] += 1.0;
            }
            None => rejected += 1,
        }
    }
    println!("{mismatched} of {n} samples with another pdf from their direction");
    assert!(
        mismatched < n / 10_000,
        "{mismatched} samples with another pdf"
    );
    assert!(rejected < 5, "{rejected} samples at the poles");
    let mut cells: Vec<(f64, f64)> = expected
        .iter()
        .zip(&observed)
        .map(|(e, o)| (e * n as f64, *o))
        .collect();
    cells.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap());
    let (stat, k) = brdfwave::brdf::validate::pooled_statistic(cells, 5.0);
    let p = brdfwave::brdf::validate::chi2_survival((k - 1) as f64, stat);
    println!("χ² = {stat:.1} over {k} cells, p = {p:.3}");
    assert!(
        p > 1e-3,
        "the sampler does not follow its pdf: χ² = {stat:.1}, {k} cells, p = {p:e}"
    );
    // And the test can fail: the same samples against a map turned another way.
    let other = EnvMap::new("t.exr".into(), w, h, px.clone(), 1.0, Mat3::IDENTITY).unwrap();
    let mut wrong = vec![0.0f64; nz * nphi];
    for i in 0..n / 10 {
        let u1 = brdfwave::rng::random_f32(11, 0, i, 0, 0);
        let u2 = brdfwave::rng::random_f32(11, 0, i, 0, 1);
        if let Some(s) = other.sample(u1, u2) {
            wrong[bin(s.wi)] += 1.0;
        }
    }
    let mut cells: Vec<(f64, f64)> = expected
        .iter()
        .zip(&wrong)
        .map(|(e, o)| (e * (n / 10) as f64, *o))
        .collect();
    cells.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap());
    let (stat, k) = brdfwave::brdf::validate::pooled_statistic(cells, 5.0);
    let p = brdfwave::brdf::validate::chi2_survival((k - 1) as f64, stat);
    assert!(p < 1e-6, "a wrongly turned sampler passed: p = {p:e}");
}

/// The error of loading the sphere scene with `[environment] map = "<name>"` (the file written
/// by `make`, if any) in a fresh directory.
fn map_error(name: &str, make: impl FnOnce(&Path)) -> String {
    let dir = tempfile::tempdir().unwrap();
    make(&dir.path().join(name));
    let p = sphere_scene(
        dir.path(),
        "model = \"lambert\"",
        &format!("[environment]\nmap = \"{name}\"\n"),
        8,
    );
    match scene::load(&p) {
        Ok(_) => panic!("{name}: loaded"),
        Err(e) => e.to_string(),
    }
}

#[track_caller]
fn assert_names(msg: &str, file: &str, what: &str) {
    common::assert_mentions(msg, &["s.toml:", "field 'environment.map'", file, what]);
}

/// Missing, truncated, not an image, empty, huge, of an unknown format, with a NaN or a
/// negative texel: each refused while the scene loads, naming the scene file, the field and
/// the image file.
#[test]
fn bad_maps_are_refused_before_rendering() {
    let good = Image::from_fn(8, 4, |x, y| [x as f32, y as f32, 1.0]);
    let e = map_error("none.exr", |_| {});
    assert_names(&e, "none.exr", "No such file");
    for ext in ["exr", "png", "pfm", "hdr"] {
        let name = format!("cut.{ext}");
        let e = map_error(&name, |p| {
            match ext {
                "hdr" => imageio::write_hdr(p, &good).unwrap(),
                _ => imageio::write(p, &good).unwrap(),
            }
            let bytes = std::fs::read(p).unwrap();
            std::fs::write(p, &bytes[..bytes.len() * 2 / 3]).unwrap();
        });
        assert_names(&e, &name, "");
        println!("{e}");
    }
    let e = map_error("text.png", |p| std::fs::write(p, "not an image\n").unwrap());
    assert_names(&e, "text.png", "PNG");
    let e = map_error("zero.pfm", |p| std::fs::write(p, "PF\n0 0\n-1\n").unwrap());
    assert_names(&e, "zero.pfm", "not a positive integer");
    let e = map_error("huge.pfm", |p| {
        std::fs::write(p, "PF\n100000 100000\n-1\n\0\0\0\0").unwrap()
    });
    assert_names(&e, "huge.pfm", "100000x100000");
    let e = map_error("huge.hdr", |p| {
        std::fs::write(
            p,
            "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n",
        )
        .unwrap()
    });
    assert_names(&e, "huge.hdr", "100000x100000");
    let e = map_error("map.jpg", |p| {
        std::fs::write(p, [0xff, 0xd8, 0xff]).unwrap()
    });
    assert_names(&e, "map.jpg", "unsupported image format");
    let e = map_error("thin.pfm", |p| {
        imageio::write(p, &Image::filled(8, 1, [1.0; 3])).unwrap()
    });
    assert_names(&e, "thin.pfm", "at least 2x2");
    for (name, bad) in [
        ("nan.pfm", f32::NAN),
        ("neg.exr", -0.5),
        ("inf.pfm", f32::INFINITY),
    ] {
        let e = map_error(name, |p| {
            let mut img = good.clone();
            img.set(3, 2, [0.5, bad, 0.5]);
            imageio::write(p, &img).unwrap()
        });
        assert_names(&e, name, "texel (3, 2)");
    }
}

/// `radiance` and `map` together, `scale` or `transform` without a map, a negative scale and a
/// transform that is not a rotation are refused, naming the field.
#[test]
fn the_environment_table_is_checked() {
    let dir = tempfile::tempdir().unwrap();
    write_map(dir.path(), "m.exr", &Image::filled(4, 2, [1.0; 3]));
    let cases = [
        (
            "radiance = 1.0\nmap = \"m.exr\"",
            "environment.radiance",
            "not both",
        ),
        (
            "radiance = 1.0\nscale = 2.0",
            "environment.scale",
            "only to an environment map",
        ),
        (
            "map = \"m.exr\"\nscale = -1.0",
            "environment.scale",
            "must be >= 0",
        ),
        (
            "map = \"m.exr\"\ntransform = { scale = 2.0 }",
            "environment.transform",
            "must be a rotation",
        ),
    ];
    for (body, field, what) in cases {
        let p = sphere_scene(
            dir.path(),
            "model = \"lambert\"",
            &format!("[environment]\n{body}\n"),
            8,
        );
        let e = scene::load(&p).map(|_| ()).unwrap_err().to_string();
        common::assert_mentions(&e, &[&format!("field '{field}'"), what]);
    }
    // A rotation with a translation is fine (a map at infinity does not move).
    let p = sphere_scene(
        dir.path(),
        "model = \"lambert\"",
        "[environment]\nmap = \"m.exr\"\ntransform = { rotate_y_deg = 30.0, translate = [1.0, 2.0, 3.0] }\n",
        8,
    );
    let s: Scene = scene::load(&p).unwrap();
    let m = s.environment_map.as_ref().unwrap();
    assert!((m.to_world.y_axis - Vec3::Y).length() < 1e-6);
}
