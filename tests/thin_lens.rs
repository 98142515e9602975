//! The thin-lens camera (`src/camera.rs`, `camera_ray` in `shaders/wavefront/path.glsl`): an
//! aperture of 0 is the pinhole bit for bit, a point on the plane in focus stays sharp while
//! one off it blurs, both backends draw the same rays, and bad lens values are refused naming
//! the field. (Mitsuba 3's `thinlens` agreement is in tests/mitsuba_materials.rs.)

mod common;

use brdfwave::scene::{load_str, Scene};
use std::path::Path;

/// Two small emitting spheres on a black background, one at distance 4 and one at 8, seen by
/// a camera with `lens` (TOML lines of `[camera]`).
fn scene(lens: &str) -> Scene {
    let src = format!(
        "[camera]\nposition = [0.0, 0.0, -4.0]\ntarget = [0.0, 0.0, 0.0]\nfov_y = 20.0\n{lens}\n\
         [film]\nwidth = 64\nheight = 32\n\
         [integrator]\nspp = 64\nmax_depth = 1\n\
         [materials.m]\nmodel = \"lambert\"\nalbedo = 0.0\n\
         [[shapes]]\nmaterial = \"m\"\nemission = 1.0\nsphere = {{ center = [-0.35, 0.0, 0.0], radius = 0.12 }}\n\
         [[shapes]]\nmaterial = \"m\"\nemission = 1.0\nsphere = {{ center = [0.7, 0.0, 4.0], radius = 0.24 }}\n"
    );
    load_str(&src, Path::new("lens.toml")).unwrap()
}

/// How many pixels of a half of the image are lit at all: a blurred sphere covers more.
fn lit(img: &brdfwave::imageio::Image, right: bool) -> usize {
    (0..img.height)
        .flat_map(|y| (0..img.width / 2).map(move |x| (x, y)))
        .filter(|&(x, y)| img.get(if right { x + img.width / 2 } else { x }, y)[0] > 1e-3)
        .count()
}

#[test]
fn a_closed_aperture_is_the_pinhole() {
    let bits = |s: &Scene| -> Vec<u32> {
        common::render_cpu(s)
            .mean
            .data
            .iter()
            .flatten()
            .map(|x| x.to_bits())
            .collect()
    };
    assert_eq!(
        bits(&scene("")),
        bits(&scene("aperture_radius = 0.0\nfocus_distance = 2.0"))
    );
}

/// Focused on the near sphere, it keeps its size (within a pixel's rim) and the far one
/// spreads; focused on the far one, the other way round; the GPU draws the same image.
#[test]
fn the_plane_in_focus_is_sharp() {
    let pinhole = common::render_cpu(&scene("")).mean;
    let near = scene("aperture_radius = 0.25\nfocus_distance = 4.0");
    let far = scene("aperture_radius = 0.25\nfocus_distance = 8.0");
    // The camera's right is -x: the near sphere (x < 0) is in the right half of the image.
    let (pn, pf) = (lit(&pinhole, true), lit(&pinhole, false));
    for (name, s, sharp_right) in [("near", &near, true), ("far", &far, false)] {
        let [(_, cpu), (_, gpu)] = common::render_both(s);
        let rmse = brdfwave::metrics::rmse(&cpu.mean, &gpu.mean).unwrap();
        assert!(rmse < 1e-5, "{name}: GPU and CPU differ, RMSE {rmse:e}");
        let (r, l) = (lit(&cpu.mean, true), lit(&cpu.mean, false));
        println!("{name}: lit pixels right {r} (pinhole {pn}), left {l} (pinhole {pf})");
        let (sharp, sharp0, blurred, blurred0) = match sharp_right {
            true => (r, pn, l, pf),
            false => (l, pf, r, pn),
        };
        assert!(
            sharp <= sharp0 + sharp0 / 2,
            "{name}: the sphere in focus spread: {sharp} > {sharp0}"
        );
        assert!(
            blurred > 2 * blurred0,
            "{name}: the sphere out of focus did not blur: {blurred} vs {blurred0}"
        );
    }
}

#[test]
fn bad_lens_values_are_refused() {
    let base = "[camera]\nposition = [0.0, 0.0, -4.0]\ntarget = [0.0, 0.0, 0.0]\nfov_y = 20.0\nLENS\n\
        [film]\nwidth = 8\nheight = 8\n[materials.m]\nmodel = \"lambert\"\n\
        [[shapes]]\nmaterial = \"m\"\nemission = 1.0\nsphere = { center = [0.0, 0.0, 0.0], radius = 1.0 }\n";
    for (lens, at, field, what) in [
        (
            "aperture_radius = -0.1",
            "aperture_radius",
            "camera.aperture_radius",
            "must be >= 0",
        ),
        (
            "aperture_radius = 0.1\nfocus_distance = 0.0",
            "focus_distance",
            "camera.focus_distance",
            "must be > 0",
        ),
        (
            "aperture_radius = 0.1\nfocus_distance = -3.0",
            "focus_distance",
            "camera.focus_distance",
            "must be > 0",
        ),
        (
            "focus_distance = 3.0",
            "focus_distance",
            "camera.focus_distance",
            "give aperture_radius too",
        ),
        (
            "aperture_radius = nan",
            "aperture_radius",
            "camera.aperture_radius",
            "not a finite number",
        ),
    ] {
        let src = base.replace("LENS", lens);
        let e = load_str(&src, Path::new("dir/bad.toml"))
            .map(|_| ())
            .unwrap_err()
            .to_string();
        common::assert_located(
            &e,
            ("dir/bad.toml", &src),
            at,
            &[&format!("field '{field}'"), what],
        );
    }
}
