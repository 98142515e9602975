//! Scene loading: the shipped scenes load as documented, OBJ meshes and transforms load as
//! described, and equivalent spellings of a scene give the same scene. Bad input is
//! `tests/scene_errors.rs`.

mod common;

use brdfwave::scene::{load, load_str, Scene, Triangle};
use common::assert_located;
use common::scene_file::{
    assert_one_warning, assert_warned, error_of, expect_error, scene_with_obj, BASE, QUAD_OBJ,
};
use glam::{Quat, Vec3};
use std::path::{Path, PathBuf};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

fn load_ok(rel: &str) -> Scene {
    load(&repo(rel)).unwrap_or_else(|e| panic!("{rel} does not load: {e}"))
}

fn v3(j: &serde_json::Value) -> Vec3 {
    let a = j.as_array().expect("array");
    assert_eq!(a.len(), 3);
    Vec3::new(
        a[0].as_f64().unwrap() as f32,
        a[1].as_f64().unwrap() as f32,
        a[2].as_f64().unwrap() as f32,
    )
}

fn unit_normal(t: &Triangle) -> Vec3 {
    t.geometric_normal_unnormalized().normalize()
}

fn centroid(t: &Triangle) -> Vec3 {
    (t.v[0] + t.v[1] + t.v[2]) / 3.0
}

// ---------------------------------------------------------------------------------------------
// The Cornell box against the published data (a copy of the project's cornell_box.json).

/// The shapes of `scenes/cornell-box.toml` in file order.
const CORNELL_ORDER: [&str; 8] = [
    "floor",
    "ceiling",
    "back_wall",
    "red_wall",
    "green_wall",
    "short_block",
    "tall_block",
    "light",
];

#[test]
fn cornell_box_matches_the_published_data() {
    let s = load_ok("scenes/cornell-box.toml");
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(repo("tests/data/cornell_box.json")).unwrap(),
    )
    .unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);

    let cam = &json["camera"];
    assert_eq!(s.camera.position, v3(&cam["origin"]));
    assert_eq!(s.camera.target, v3(&cam["target"]));
    assert_eq!(s.camera.up, v3(&cam["up"]));
    assert_eq!(s.camera.fov_y_deg, cam["fov_deg"].as_f64().unwrap() as f32);
    assert_eq!(cam["fov_axis"], "y");
    assert_eq!(
        s.width as u64,
        cam["default_resolution"][0].as_u64().unwrap()
    );
    assert_eq!(
        s.height as u64,
        cam["default_resolution"][1].as_u64().unwrap()
    );
    assert_eq!(
        s.integrator.max_depth as u64,
        json["integrator"]["max_depth"].as_u64().unwrap()
    );
    assert!(!s.integrator.russian_roulette);
    assert_eq!(s.environment, Vec3::ZERO);

    // Materials: the four Lambert materials of the diffuse variant, in file order.
    assert_eq!(s.material_names, ["white", "red", "green", "light_surface"]);
    for (name, m) in s.material_names.iter().zip(&s.materials) {
        let j = &json["materials"][name];
        assert_eq!(m.model_name(), j["model"].as_str().unwrap());
        // Lambert packs its albedo in p[0].xyz.
        let p = m.brdf.pack().0;
        assert_eq!(
            Vec3::new(p[0], p[1], p[2]),
            v3(&j["albedo"]),
            "albedo of {name}"
        );
    }
    assert!(
        !s.materials[3].brdf.scatters(),
        "the light surface is black"
    );

    // Geometry: every quad as published, split (v0,v1,v2), (v0,v2,v3).
    let shapes = json["shapes"].as_object().unwrap();
    assert_eq!(shapes.len(), CORNELL_ORDER.len());
    let mut expected = Vec::new();
    for name in CORNELL_ORDER {
        let shape = &shapes[name];
        let material = s
            .material_names
            .iter()
            .position(|n| n == shape["material"].as_str().unwrap());
        let emitter = shape.get("emitter").map(|_| 0u32);
        for q in shape["quads"].as_array().unwrap() {
            let p: Vec<Vec3> = q.as_array().unwrap().iter().map(v3).collect();
            for t in [[p[0], p[1], p[2]], [p[0], p[2], p[3]]] {
                expected.push((name, t, material.unwrap() as u32, emitter));
            }
        }
    }
    // 5 walls × 1 quad + 2 blocks × 5 quads + 1 light quad = 16 quads = 32 triangles.
    assert_eq!(expected.len(), 32);
    assert_eq!(s.triangles.len(), 32);
    assert!(s.spheres.is_empty());
    for (t, (name, v, material, emitter)) in s.triangles.iter().zip(&expected) {
        assert_eq!(t.v, *v, "{name}");
        assert_eq!(t.material, *material, "{name}");
        assert_eq!(t.emitter, *emitter, "{name}");
    }
    // No triangle has normals or texture coordinates.
    assert!(s.attributes.is_empty());
    assert_eq!(s.emitters.len(), 1);
    assert_eq!(json["emitter"]["shape"], "light");
    assert_eq!(s.emitters[0].radiance, v3(&json["emitter"]["radiance"]));
}

#[test]
fn cornell_box_normals_follow_the_conventions() {
    let s = load_ok("scenes/cornell-box.toml");
    let tris = |name: &str| -> &[Triangle] {
        let mut start = 0;
        for n in CORNELL_ORDER {
            let count = if n.ends_with("_block") { 10 } else { 2 };
            if n == name {
                return &s.triangles[start..start + count];
            }
            start += count;
        }
        unreachable!()
    };
    // Walls, floor and ceiling face into the box, along their axis.
    let inside = Vec3::new(278.0, 274.4, 279.6);
    for (name, axis) in [
        ("floor", Vec3::Y),
        ("ceiling", -Vec3::Y),
        ("back_wall", -Vec3::Z),
        ("red_wall", -Vec3::X),
        ("green_wall", Vec3::X),
    ] {
        for t in tris(name) {
            let n = unit_normal(t);
            assert!(n.dot(inside - centroid(t)) > 0.0, "{name} faces out: {n}");
            assert!(
                n.dot(axis) > 0.999,
                "{name}: normal {n}, expected about {axis}"
            );
        }
    }
    // The blocks face outward: away from their own centre; the sides are vertical.
    for name in ["short_block", "tall_block"] {
        let ts = tris(name);
        let centre = ts.iter().map(centroid).sum::<Vec3>() / ts.len() as f32;
        for (k, t) in ts.iter().enumerate() {
            let n = unit_normal(t);
            assert!(
                n.dot(centroid(t) - centre) > 0.0,
                "{name} triangle {k} faces in: {n}"
            );
            if k < 2 {
                assert!(n.dot(Vec3::Y) > 0.9999, "{name} top: {n}");
            } else {
                assert!(n.y.abs() < 1e-6, "{name} side {k}: {n}");
            }
        }
    }
    // The light faces down.
    for t in tris("light") {
        assert!((unit_normal(t) - -Vec3::Y).length() < 1e-6);
        assert_eq!(t.emitter, Some(0));
        assert!(t.v.iter().all(|v| v.y == 548.7));
    }
}

// ---------------------------------------------------------------------------------------------
// The analytic scenes and the OBJ example.

#[test]
fn furnace_sphere_puts_the_camera_inside_an_emitting_inward_sphere() {
    let s = load_ok("scenes/furnace-sphere.toml");
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert!(s.triangles.is_empty());
    assert_eq!(s.spheres.len(), 1);
    let sp = &s.spheres[0];
    assert!(sp.inward);
    assert_eq!((sp.center, sp.radius), (Vec3::ZERO, 1.0));
    assert!((s.camera.position - sp.center).length() < sp.radius);
    assert_eq!(sp.emitter, Some(0));
    assert_eq!(s.emitters[0].radiance, Vec3::splat(0.5));
    assert_eq!(
        s.materials[sp.material as usize].brdf.pack().0[..3],
        [0.5; 3]
    );
    assert_eq!((s.width, s.height), (32, 32));
    assert_eq!(s.environment, Vec3::ZERO);
    assert!(!s.integrator.russian_roulette);
}

#[test]
fn white_furnace_is_a_grey_sphere_in_a_white_environment() {
    let s = load_ok("scenes/white-furnace.toml");
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.environment, Vec3::ONE);
    assert_eq!(s.spheres.len(), 1);
    let sp = &s.spheres[0];
    assert!(!sp.inward);
    assert!((s.camera.position - sp.center).length() > sp.radius);
    assert_eq!(sp.emitter, None);
    assert!(s.emitters.is_empty());
    assert_eq!(
        s.materials[sp.material as usize].brdf.pack().0[..3],
        [0.8; 3]
    );
}

#[test]
fn obj_example_loads_the_mesh_with_its_normals_and_transforms() {
    let s = load_ok("scenes/obj-example.toml");
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // floor quad, two 80-triangle icospheres, lamp quad.
    assert_eq!(s.triangles.len(), 2 + 80 + 80 + 2);
    let (floor, rest) = s.triangles.split_at(2);
    let (ball, rest) = rest.split_at(80);
    let (egg, lamp) = rest.split_at(80);
    assert!(floor
        .iter()
        .all(|t| (unit_normal(t) - Vec3::Y).length() < 1e-6));
    assert!(lamp
        .iter()
        .all(|t| (unit_normal(t) + Vec3::Y).length() < 1e-6 && t.emitter == Some(0)));

    // Ball: the unit icosphere moved to (-1.2, 1, 0); its normals are the radial directions.
    let c = Vec3::new(-1.2, 1.0, 0.0);
    for (i, t) in ball.iter().enumerate() {
        let a = s.attributes_of(2 + i);
        let n = a.n.expect("the icosphere has vertex normals");
        for (v, n) in t.v.iter().zip(n) {
            assert!(((*v - c).length() - 1.0).abs() < 1e-5);
            assert!((n - (*v - c).normalize()).length() < 1e-4, "{n} vs {v}");
        }
        assert!(unit_normal(t).dot(t.v[0] - c) > 0.0, "outward winding");
        assert_eq!(a.uv, None);
        assert_eq!(t.emitter, None);
        assert_eq!(s.material_names[t.material as usize], "clay");
    }

    // Egg: scale (0.6, 1, 0.6), then 30° about +y, then translate. Undo it with glam's
    // rotation to get the unit-sphere point p; the ellipsoid's normal is R·(p / scale).
    let scale = Vec3::new(0.6, 1.0, 0.6);
    let rot = Quat::from_rotation_y(30f32.to_radians());
    let translate = Vec3::new(1.2, 1.0, 0.5);
    for (i, t) in egg.iter().enumerate() {
        let n = s
            .attributes_of(82 + i)
            .n
            .expect("normals survive the transform");
        for (v, n) in t.v.iter().zip(n) {
            let p = rot.inverse() * (*v - translate) / scale;
            assert!(
                (p.length() - 1.0).abs() < 1e-5,
                "vertex {v} is not on the ellipsoid"
            );
            let expected = (rot * (p / scale)).normalize();
            assert!((n - expected).length() < 1e-4, "{n} vs {expected}");
            assert!(n.dot(unit_normal(t)) > 0.0);
        }
    }
}

/// The vertex attributes stay with their triangles when meshes with them and shapes without
/// them alternate, and when a skipped zero-area face closes a gap in a mesh; the list stops at
/// the last triangle that has any.
#[test]
fn vertex_attributes_stay_with_their_triangles() {
    // The quad, then a zero-area face (skipped), then the quad's first triangle again.
    let obj = format!("{QUAD_OBJ}f 1/1 2/2 1/1\nf 1/1 2/2 3/3\n");
    let plain_quad =
        "[[shapes]]\nmaterial = \"m\"\nquads = [[[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]]]\n";
    let again = "[[shapes]]\nmaterial = \"m\"\nobj = \"mesh.obj\"\n";
    let (_dir, path) = scene_with_obj(&obj, &format!("{plain_quad}{again}{plain_quad}"));
    let s = load(&path).unwrap();
    assert_eq!(s.triangles.len(), 3 + 2 + 3 + 2);
    let uv = |i: usize| s.attributes_of(i).uv;
    // The file's vt, v flipped (a texture's v runs down the image).
    let first = [glam::Vec2::Y, glam::Vec2::ONE, glam::Vec2::X];
    let second = [glam::Vec2::Y, glam::Vec2::X, glam::Vec2::ZERO];
    for mesh in [0, 5] {
        assert_eq!(uv(mesh), Some(first), "mesh at {mesh}");
        assert_eq!(uv(mesh + 1), Some(second), "mesh at {mesh}");
        assert_eq!(
            uv(mesh + 2),
            Some(first),
            "mesh at {mesh}, after the skipped face"
        );
        assert_eq!(s.triangles[mesh + 2].v, s.triangles[mesh].v);
    }
    for quad in [3, 4, 8, 9] {
        assert_eq!(
            s.attributes_of(quad),
            Default::default(),
            "quad triangle {quad}"
        );
    }
    assert_eq!(s.attributes.len(), 8, "the list ends at the last mesh");
    assert!(
        s.warnings.iter().any(|w| w.contains("zero-area")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn obj_texture_coordinates_are_kept() {
    let (_dir, path) = scene_with_obj(QUAD_OBJ, "");
    let s = load(&path).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let quad = &s.triangles[..];
    assert_eq!(quad.len(), 2);
    // The file's vt (0 0, 1 0, 1 1, 0 1), v flipped: a texture's v runs down the image.
    assert_eq!(
        s.attributes_of(0).uv,
        Some([glam::Vec2::Y, glam::Vec2::ONE, glam::Vec2::X])
    );
    assert_eq!(
        s.attributes_of(1).uv,
        Some([glam::Vec2::Y, glam::Vec2::X, glam::Vec2::ZERO])
    );
    assert_eq!(s.attributes_of(0).n, None);
    // Counter-clockwise seen from +z: the front side is +z.
    assert!((unit_normal(&quad[0]) - Vec3::Z).length() < 1e-6);
}

#[test]
fn obj_mtl_materials_are_ignored_with_a_warning() {
    let obj = format!("mtllib nothere.mtl\nusemtl gold\n{QUAD_OBJ}");
    let (_dir, path) = scene_with_obj(&obj, "");
    let s = load(&path).unwrap();
    assert_eq!(s.triangles.len(), 2);
    assert!(s
        .triangles
        .iter()
        .all(|t| s.material_names[t.material as usize] == "m"));
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    let w = &s.warnings[0];
    assert!(
        w.starts_with("warning: ") && w.contains("scene.toml:20:") && w.contains("MTL"),
        "{w}"
    );
}

#[test]
fn obj_zero_area_triangles_are_skipped_with_a_warning() {
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n";
    let (_dir, path) = scene_with_obj(obj, "");
    let s = load(&path).unwrap();
    assert_eq!(s.triangles.len(), 1);
    assert_warned(&s, "skipped 1 zero-area");
}

/// OBJ points and polylines are not faces: `l 1 2 3` gave the image of `f 1 2 3`, and a file
/// of lines only loaded. They are dropped and counted in one warning.
#[test]
fn obj_points_and_lines_are_ignored_and_counted() {
    let obj = format!("{QUAD_OBJ}l 1 2 3\nl 1 2 3 4\nl 1 2\np 1 2 3\n");
    let (_dir, path) = scene_with_obj(&obj, "");
    let s = load(&path).unwrap();
    assert_eq!(s.triangles.len(), 2, "the quad only");
    assert_one_warning(&s, "1 point and 3 line element(s)");
    // Lines only: no triangles (BASE's sphere keeps the scene valid), and a warning that says so.
    let (_dir, path) = scene_with_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n", "");
    let s = load(&path).unwrap();
    assert!(s.triangles.is_empty());
    assert_warned(&s, "no usable triangles");
}

// ---------------------------------------------------------------------------------------------
// Transforms.

/// The general transforms: a row-major 4×4 `matrix` and `rotate` about any axis, on every
/// geometry kind, against hand-computed values; each bad one refused with its field.
#[test]
fn general_transforms() {
    let tri = |t: &str| {
        format!(
            "{BASE}\n[[shapes]]\nmaterial = \"m\"\ntriangles = [[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]]\ntransform = {t}\n"
        )
    };
    let path = Path::new("dir/t.toml");
    let v = |t: &str| load_str(&tri(t), path).unwrap().triangles[0].v;
    // Rotation by 90° about +z: x → y, y → -x, z stays; then translated by (0, 0, 5).
    let r = v(
        "{ rotate = { axis = [0.0, 0.0, 2.0], angle_deg = 90.0 }, translate = [0.0, 0.0, 5.0] }",
    );
    for (got, want) in r.iter().zip([
        Vec3::new(0.0, 1.0, 5.0),
        Vec3::new(-1.0, 0.0, 5.0),
        Vec3::new(0.0, 0.0, 6.0),
    ]) {
        assert!((*got - want).length() < 1e-6, "{got} vs {want}");
    }
    // 120° about (1, 1, 1) permutes the axes x → y → z → x.
    let r = v("{ rotate = { axis = [1.0, 1.0, 1.0], angle_deg = 120.0 } }");
    assert!((r[0] - Vec3::Y).length() < 1e-6 && (r[1] - Vec3::Z).length() < 1e-6);
    // A matrix, row by row: x' = 2x + 7, y' = -z + 8, z' = y + 9.
    let m = v("{ matrix = [[2.0, 0.0, 0.0, 7.0], [0.0, 0.0, -1.0, 8.0], [0.0, 1.0, 0.0, 9.0], [0.0, 0.0, 0.0, 1.0]] }");
    assert_eq!(
        m,
        [
            Vec3::new(9.0, 8.0, 9.0),
            Vec3::new(7.0, 8.0, 10.0),
            Vec3::new(7.0, 7.0, 9.0)
        ]
    );

    let check = |t: &str, field: &str, what: &str| {
        let src = tri(t);
        let msg = load_str(&src, path).expect_err("must fail").to_string();
        let field = format!("field '{field}'");
        assert_located(&msg, ("dir/t.toml", &src), "transform", &[&field, what]);
    };
    let f = "shapes[1].transform";
    check(
        "{ matrix = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 1.0, 1.0]] }",
        &format!("{f}.matrix"),
        "projective",
    );
    check(
        "{ matrix = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]] }",
        &format!("{f}.matrix"),
        "singular",
    );
    check(
        "{ matrix = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]] }",
        &format!("{f}.matrix"),
        "array of 4 elements",
    );
    check(
        "{ matrix = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]], scale = 2.0 }",
        &format!("{f}.matrix"),
        "matrix stands alone",
    );
    check(
        "{ rotate = { axis = [0.0, 0.0, 0.0], angle_deg = 3.0 } }",
        &format!("{f}.rotate.axis"),
        "zero length",
    );
    check(
        "{ rotate = { axis = [0.0, 1.0, 0.0], angle_deg = 3.0 }, rotate_y_deg = 3.0 }",
        &format!("{f}.rotate_y_deg"),
        "not both",
    );
    // A mirror is legal with a warning: the winding, and so the front side, turns over.
    let s = load_str(
        &tri("{ matrix = [[-1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]] }"),
        path,
    )
    .unwrap();
    assert_warned(&s, "mirrors");
}

// ---------------------------------------------------------------------------------------------
// The small valid scene and other spellings of it.

#[test]
fn the_base_scene_is_valid() {
    let s = load_str(BASE, Path::new("dir/base.toml")).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.spheres.len(), 1);
    assert_eq!(s.integrator, brdfwave::scene::Integrator::default());
}

#[test]
fn dotted_keys_and_inline_tables_are_equivalent_to_headers() {
    let src = r#"camera = { position = [0.0, 0.0, -4.0], target = [0.0, 0.0, 0.0], fov_y = 40.0 }
film.width = 8
film.height = 8
materials.m.model = "lambert"
materials.m.albedo = 0.25
shapes = [{ material = "m", sphere = { center = [0.0, 0.0, 0.0], radius = 1.0 } }]
environment.radiance = 1
"#;
    let s = load_str(src, Path::new("inline.toml")).unwrap();
    assert_eq!((s.width, s.height), (8, 8));
    assert_eq!(s.spheres.len(), 1);
    assert_eq!(s.materials[0].brdf.pack().0[..3], [0.25; 3]);
    // Errors inside them are located as well.
    let bad = src.replace("albedo = 0.25", "albedo = 2.5");
    let msg = error_of(&bad);
    assert!(
        msg.starts_with("dir/bad.toml:5: material 'm', field 'albedo'"),
        "{msg}"
    );
    let bad = src.replace("radius = 1.0", "radius = -1.0");
    expect_error(&bad, "radius", "shapes[0].sphere.radius", "must be > 0");
}

/// The minimal scene printed in scenes/README.md loads as described.
#[test]
fn readme_example_loads() {
    let readme = std::fs::read_to_string(repo("scenes/README.md")).unwrap();
    // The toml block that is a whole scene (the others are material examples).
    let example = readme
        .split("```toml\n")
        .skip(1)
        .map(|b| &b[..b.find("```").unwrap()])
        .find(|b| b.contains("[camera]"))
        .expect("README has a toml scene example");
    let s = load_str(example, Path::new("README.md")).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!((s.width, s.height, s.spheres.len()), (320, 240, 1));
    assert_eq!(s.camera.up, Vec3::Y);
    assert_eq!(s.environment, Vec3::ONE);
}
