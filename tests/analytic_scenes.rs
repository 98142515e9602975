//! Scenes with an exact answer, built the ways a user builds them: every flat and convex shape
//! that a reader makes (Mitsuba XML `rectangle`, `disk`, `cube`, `sphere`, `obj`, `ply`; TOML
//! `quads`, `triangles`, `sphere`, `obj`, `ply`), alone under a uniform sky of radiance 1,
//! direct light only. A flat or convex Lambert surface sees the whole sky above it, and with
//! cosine-weighted sampling every sample that hits it is worth exactly albedo × radiance, so
//! every pixel whose samples all hit the shape must be exactly 0.6, with no noise, on both
//! backends. The shapes are placed where rays leaving them are hardest to keep off them:
//! through the origin and tilted by a rounding error (a rotated rectangle's corners are at
//! y = ±2.4e-16), tilted by 1e-30 and 1e-3, fans of thin triangles, a sphere of radius 1e6
//! and 1e7 under a camera one unit above it.
//!
//! Which pixels are fully covered is read off a `max_depth` 1 render of the same camera rays:
//! there the sky seen directly is 1 and the shape 0.

mod common;

use brdfwave::output::RenderOutput;
use brdfwave::scene::{self, Scene};
use std::path::Path;

const ALBEDO: f32 = 0.6;

/// A Mitsuba scene of the issue's layout (camera at (0, 2, -5) looking at (0, 0.5, 0)) with
/// `shape` and a constant sky.
fn xml(shape: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="2"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="35"/>
        <transform name="to_world"><lookat origin="0, 2, -5" target="0, 0.5, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="8"/></sampler>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/>
            <rfilter type="box"/></film>
    </sensor>
    {shape}
    <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
</scene>
"#
    )
}

const DIFFUSE: &str =
    r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.6, 0.6"/></bsdf>"#;

/// A TOML scene with `camera` (position, target), a constant sky and `shape`.
fn toml(camera: ([f32; 3], [f32; 3]), shape: &str) -> String {
    let (p, t) = camera;
    format!(
        "[camera]\nposition = {p:?}\ntarget = {t:?}\nfov_y = 25.0\n\
         [film]\nwidth = 32\nheight = 32\n\
         [integrator]\nspp = 8\nmax_depth = 2\nsampler = \"independent\"\n\
         [environment]\nradiance = [1.0, 1.0, 1.0]\n\
         [materials.m]\nmodel = \"lambert\"\nalbedo = {ALBEDO}\n\
         [[shapes]]\nmaterial = \"m\"\n{shape}\n"
    )
}

/// An OBJ file of the quad with corners (±1, y0, -1) and (±1, y1, +1), facing up.
fn floor_obj(y0: f32, y1: f32) -> String {
    format!("v -1 {y0:e} -1\nv 1 {y0:e} -1\nv 1 {y1:e} 1\nv -1 {y1:e} 1\nf 1 3 2\nf 1 4 3\n")
}

/// The same quad as an ASCII PLY file.
fn floor_ply(y0: f32, y1: f32) -> String {
    format!(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
         property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
         -1 {y0:e} -1\n1 {y0:e} -1\n1 {y1:e} 1\n-1 {y1:e} 1\n4 0 3 2 1\n"
    )
}

/// A closed cube [-1, 1]³ as an OBJ file, faces outwards.
fn cube_obj() -> String {
    let mut s = String::new();
    for i in 0..8 {
        let c = |b: usize| if i & b != 0 { 1 } else { -1 };
        s += &format!("v {} {} {}\n", c(1), c(2), c(4));
    }
    for q in common::scene_file::CUBE_QUADS {
        s += &format!("f {} {} {} {}\n", q[0], q[1], q[2], q[3]);
    }
    s
}

/// A fan of `n` triangles over the unit disk in the plane y = 0, facing up, as TOML triangles.
fn fan(n: usize) -> String {
    let p = |k: usize| {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        format!("[{:e}, 0.0, {:e}]", a.cos(), -a.sin())
    };
    let tris: Vec<String> = (0..n)
        .map(|k| format!("[[0.0, 0.0, 0.0], {}, {}]", p(k), p(k + 1)))
        .collect();
    format!("triangles = [{}]", tris.join(", "))
}

struct Case {
    name: &'static str,
    /// The scene file's name (its extension picks the reader) and text, and extra files.
    scene: (&'static str, String),
    files: Vec<(&'static str, String)>,
}

fn cases() -> Vec<Case> {
    let c = |name, scene, files| Case { name, scene, files };
    let above = ([0.0, 2.0, -5.0], [0.0, 0.5, 0.0]);
    vec![
        c(
            "xml rectangle rotated to the floor",
            ("s.xml", xml(&format!(r#"<shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/></transform>{DIFFUSE}</shape>"#))),
            vec![],
        ),
        c(
            "xml rectangle, any rotation, scaled and moved",
            ("s.xml", xml(&format!(r#"<shape type="rectangle"><transform name="to_world"><scale value="1.5"/><rotate x="1" angle="-80"/><rotate y="1" angle="25"/><translate x="0.01" y="-0.2" z="0"/></transform>{DIFFUSE}</shape>"#))),
            vec![],
        ),
        c(
            "xml disk rotated to the floor",
            ("s.xml", xml(&format!(r#"<shape type="disk"><transform name="to_world"><scale value="1.6"/><rotate x="1" angle="-90"/></transform>{DIFFUSE}</shape>"#))),
            vec![],
        ),
        c(
            "xml disk rotated about two axes",
            ("s.xml", xml(&format!(r#"<shape type="disk"><transform name="to_world"><scale value="2.5"/><rotate x="1" angle="-70"/><rotate y="1" angle="30"/></transform>{DIFFUSE}</shape>"#))),
            vec![],
        ),
        c(
            "xml disk facing the camera",
            ("s.xml", xml(&format!(r#"<shape type="disk"><transform name="to_world"><rotate y="1" angle="180"/><rotate x="1" angle="-16.7"/><translate y="0.5"/></transform>{DIFFUSE}</shape>"#))),
            vec![],
        ),
        c(
            "xml cube rotated and moved",
            ("s.xml", xml(&format!(r#"<shape type="cube"><transform name="to_world"><scale value="0.8"/><rotate x="1" y="2" z="3" angle="40"/><translate x="0.1" y="0.4" z="0.2"/></transform>{DIFFUSE}</shape>"#))),
            vec![],
        ),
        c(
            "xml sphere",
            ("s.xml", xml(&format!(r#"<shape type="sphere"><point name="center" value="0, 0.5, 0"/><float name="radius" value="1"/>{DIFFUSE}</shape>"#))),
            vec![],
        ),
        c(
            "xml obj floor tilted by 2.4e-16 through the origin",
            ("s.xml", xml(&format!(r#"<shape type="obj"><string name="filename" value="floor.obj"/>{DIFFUSE}</shape>"#))),
            vec![("floor.obj", floor_obj(2.4e-16, -2.4e-16))],
        ),
        c(
            "xml ply floor tilted by 1e-3 through the origin",
            ("s.xml", xml(&format!(r#"<shape type="ply"><string name="filename" value="floor.ply"/>{DIFFUSE}</shape>"#))),
            vec![("floor.ply", floor_ply(1e-3, -1e-3))],
        ),
        c(
            "toml quad tilted by 1e-30 through the origin",
            ("s.toml", toml(above, "quads = [[[-1.0, 1e-30, -1.0], [-1.0, -1e-30, 1.0], [1.0, -1e-30, 1.0], [1.0, 1e-30, -1.0]]]")),
            vec![],
        ),
        c(
            "toml fan of 64 triangles, rotated through the origin",
            ("s.toml", toml(above, &format!("{}\ntransform = {{ rotate = {{ axis = [1.0, 0.2, 0.3], angle_deg = 10.0 }} }}", fan(64)))),
            vec![],
        ),
        c(
            "toml obj floor tilted by 2.4e-16, moved by a transform",
            ("s.toml", toml(above, "obj = \"floor.obj\"\ntransform = { translate = [0.0, 1e-7, 0.0], rotate_y_deg = 33.0 }")),
            vec![("floor.obj", floor_obj(2.4e-16, -2.4e-16))],
        ),
        c(
            "toml ply floor tilted by 1e-3",
            ("s.toml", toml(above, "ply = \"floor.ply\"")),
            vec![("floor.ply", floor_ply(1e-3, -1e-3))],
        ),
        c(
            "toml obj cube, rotated",
            ("s.toml", toml(above, "obj = \"cube.obj\"\ntransform = { rotate = { axis = [0.3, 1.0, 0.1], angle_deg = 29.0 }, scale = 0.7, translate = [0.0, 0.6, 0.0] }")),
            vec![("cube.obj", cube_obj())],
        ),
        c(
            "toml sphere placed by a transform",
            ("s.toml", toml(above, "sphere = { center = [0.0, 0.0, 0.0], radius = 1.0 }\ntransform = { rotate = { axis = [1.0, 1.0, 0.0], angle_deg = 50.0 }, scale = 0.9, translate = [0.0, 0.5, 0.0] }")),
            vec![],
        ),
        c(
            "toml ground sphere of radius 1e6, camera 1 above",
            ("s.toml", toml(([0.0, 1.0, 0.0], [0.0, 0.0, 5.0]), "sphere = { center = [0.0, -1e6, 0.0], radius = 1e6 }")),
            vec![],
        ),
        c(
            "toml ground sphere of radius 1e7, camera 1 above",
            ("s.toml", toml(([0.0, 1.0, 0.0], [0.0, 0.0, 5.0]), "sphere = { center = [0.0, -1e7, 0.0], radius = 1e7 }")),
            vec![],
        ),
    ]
}

/// Loads the case with `max_depth`.
fn load(dir: &Path, case: &Case, max_depth: u32) -> Scene {
    for (name, text) in &case.files {
        std::fs::write(dir.join(name), text).unwrap();
    }
    let path = dir.join(case.scene.0);
    std::fs::write(&path, &case.scene.1).unwrap();
    let mut s = scene::load(&path).unwrap_or_else(|e| panic!("{}: {e}", case.name));
    s.integrator.max_depth = max_depth;
    s
}

/// The pixels whose samples all hit the shape (0 in the camera-only render), and of those the
/// ones not exactly albedo × radiance: (covered, wrong, the worst value).
fn check(direct: &RenderOutput, seen: &RenderOutput) -> (usize, usize, f32) {
    let (mut covered, mut wrong, mut worst) = (0, 0, ALBEDO);
    for (a, b) in direct.mean.data.iter().zip(&seen.mean.data) {
        if b[0] != 0.0 {
            continue;
        }
        covered += 1;
        if (0..3).any(|c| (a[c] - ALBEDO).abs() > 1e-5) {
            wrong += 1;
            if (a[0] - ALBEDO).abs() > (worst - ALBEDO).abs() {
                worst = a[0];
            }
        }
    }
    (covered, wrong, worst)
}

#[test]
fn lone_shapes_under_a_sky_render_albedo_times_radiance_in_every_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let ctx = common::context();
    let mut failures = Vec::new();
    for case in cases() {
        let direct = load(dir.path(), &case, 2);
        let seen = load(dir.path(), &case, 1);
        let outputs = [
            (
                "gpu",
                common::render_gpu(&ctx, &direct).0,
                common::render_gpu(&ctx, &seen).0,
            ),
            (
                "cpu",
                common::render_cpu(&direct),
                common::render_cpu(&seen),
            ),
        ];
        for (backend, d, s) in outputs {
            let (covered, wrong, worst) = check(&d, &s);
            let pixels = (d.mean.width * d.mean.height) as usize;
            // Each shape covers a good part of the image, so the check is not empty.
            assert!(
                covered * 20 >= pixels,
                "{}: only {covered} of {pixels} pixels covered by the shape",
                case.name
            );
            if wrong > 0 || d.nonfinite_samples > 0 {
                failures.push(format!(
                    "{} ({backend}): {wrong} of {covered} covered pixels are not {ALBEDO} \
                     (worst {worst}), {} non-finite samples",
                    case.name, d.nonfinite_samples
                ));
            }
        }
    }
    common::finish(ctx);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
