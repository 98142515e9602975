//! Bad scene files: every kind of bad input gives an error naming the file, the line and the
//! field, never a panic.

mod common;

use brdfwave::scene::{load, load_str};
use common::scene_file::{error_of, expect_error, scene_with_obj, with, BASE, QUAD_OBJ};
use common::{assert_located, line_of};
use glam::Vec3;
use std::path::Path;

#[test]
fn unknown_fields_are_errors_everywhere() {
    let top = format!("samples = 4\n{BASE}");
    expect_error(&top, "samples", "samples", "unknown field");
    expect_error(
        &with("fov_y", "fov = 40.0\nfov_y"),
        "fov =",
        "camera.fov",
        "unknown field",
    );
    expect_error(
        &with("height = 8", "height = 8\ndepth = 1"),
        "depth",
        "film.depth",
        "unknown field",
    );
    let i = format!("{BASE}[integrator]\nspp = 4\nbounces = 3\n");
    expect_error(&i, "bounces", "integrator.bounces", "unknown field");
    let e = format!("{BASE}[environment]\nradiance = 1.0\ncolor = 2.0\n");
    expect_error(&e, "color", "environment.color", "unknown field");
    expect_error(
        &with("emission", "colour = 1\nemission"),
        "colour",
        "shapes[0].colour",
        "unknown field",
    );
    expect_error(
        &with("radius = 1.0", "radius = 1.0, radiuss = 2.0"),
        "radiuss",
        "shapes[0].sphere.radiuss",
        "unknown field",
    );
    // Sub-tables written with dotted keys are found too.
    let dotted = with(
        "sphere = { center = [0.0, 0.0, 0.0], radius = 1.0 }",
        "sphere.center = [0.0, 0.0, 0.0]\nsphere.radius = 1.0\nsphere.inwards = true",
    );
    expect_error(
        &dotted,
        "sphere.inwards",
        "shapes[0].sphere.inwards",
        "unknown field",
    );
    // A material parameter the model does not take (the brdf module's message).
    let msg = error_of(&with(
        "model = \"lambert\"",
        "model = \"lambert\"\nalbedoo = 0.5",
    ));
    let line = line_of(
        &with("model = \"lambert\"", "model = \"lambert\"\nalbedoo = 0.5"),
        "albedoo",
    );
    assert!(
        msg.starts_with(&format!(
            "dir/bad.toml:{line}: material 'm', field 'albedoo'"
        )),
        "{msg}"
    );
}

#[test]
fn transform_fields_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("mesh.obj"), QUAD_OBJ).unwrap();
    let path = dir.path().join("s.toml");
    let scene = |t: &str| {
        format!("{BASE}\n[[shapes]]\nmaterial = \"m\"\nobj = \"mesh.obj\"\ntransform = {t}\n")
    };
    let file = path.display().to_string();
    let check = |src: String, field: &str, what: &str| {
        let msg = load_str(&src, &path).expect_err("must fail").to_string();
        let field = format!("field '{field}'");
        assert_located(&msg, (&file, &src), "transform", &[&field, what]);
    };
    check(
        scene("{ rotate_x_deg = 3.0 }"),
        "shapes[1].transform.rotate_x_deg",
        "unknown field",
    );
    check(
        scene("{ scale = 0.0 }"),
        "shapes[1].transform.scale",
        "must be > 0",
    );
    check(
        scene("{ scale = [1.0, -1.0, 1.0] }"),
        "shapes[1].transform.scale",
        "must be > 0",
    );
    check(
        scene("{ translate = [1.0, nan, 1.0] }"),
        "shapes[1].transform.translate",
        "not a finite number",
    );
    check(
        scene("{ rotate_y_deg = inf }"),
        "shapes[1].transform.rotate_y_deg",
        "not a finite number",
    );
    let ok = load_str(
        &scene("{ scale = 2.0, rotate_y_deg = 90.0, translate = [0.0, 0.0, 5.0] }"),
        &path,
    )
    .unwrap();
    // (1, 0, 0) → scaled (2, 0, 0) → rotated (0, 0, -2) → translated (0, 0, 3).
    assert!(
        (ok.triangles[0].v[1] - Vec3::new(0.0, 0.0, 3.0)).length() < 1e-5,
        "{}",
        ok.triangles[0].v[1]
    );
    // A sphere takes a similarity: scale 2 doubles its radius; a non-uniform scale would make
    // an ellipsoid.
    let src = with(
        "radius = 1.0 }",
        "radius = 1.0 }\ntransform = { scale = 2.0 }",
    );
    let s = load_str(&src, &path).unwrap();
    assert!((s.spheres[0].radius - 2.0).abs() < 1e-6);
    let src = with(
        "radius = 1.0 }",
        "radius = 1.0 }\ntransform = { scale = [2.0, 1.0, 1.0] }",
    );
    expect_error(&src, "transform", "shapes[0].transform", "similarity");
}

#[test]
fn material_references_are_checked() {
    expect_error(
        &with("material = \"m\"", "material = \"nope\""),
        "material = \"nope\"",
        "shapes[0].material",
        "unknown material 'nope' (defined materials: m)",
    );
    expect_error(
        &with("material = \"m\"\n", ""),
        "[[shapes]]",
        "shapes[0].material",
        "missing",
    );
    let dup = with(
        "[[shapes]]",
        "[materials.m]\nmodel = \"lambert\"\n\n[[shapes]]",
    );
    let msg = error_of(&dup);
    let second = line_of(&dup, "[[shapes]]") - 3;
    assert!(
        msg.starts_with(&format!("dir/bad.toml:{second}: ")),
        "{msg}"
    );
    assert!(msg.contains("duplicate key `m`"), "{msg}");
    // A material without a model, and an unknown model.
    let msg = error_of(&with("model = \"lambert\"", "albedo = 0.5"));
    assert!(
        msg.starts_with("dir/bad.toml:10: material 'm', field 'model': missing"),
        "{msg}"
    );
    let msg = error_of(&with("model = \"lambert\"", "model = \"torrance_sparrow\""));
    assert!(
        msg.starts_with(
            "dir/bad.toml:11: material 'm', field 'model': unknown value \"torrance_sparrow\""
        ),
        "{msg}"
    );
    // Unused materials are a warning.
    let s = load_str(
        &with(
            "[[shapes]]",
            "[materials.spare]\nmodel = \"lambert\"\n\n[[shapes]]",
        ),
        Path::new("w.toml"),
    )
    .unwrap();
    assert_eq!(s.warnings.len(), 1);
    assert!(
        s.warnings[0].starts_with("warning: w.toml:13: field 'materials.spare'"),
        "{:?}",
        s.warnings
    );
}

#[test]
fn obj_problems_name_the_obj_file_and_the_scene_line() {
    // Missing file.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.toml");
    let src = format!("{BASE}\n[[shapes]]\nmaterial = \"m\"\nobj = \"meshes/none.obj\"\n");
    let msg = load_str(&src, &path).err().unwrap().to_string();
    let line = line_of(&src, "meshes/none.obj");
    assert!(
        msg.starts_with(&format!(
            "{}:{line}: field 'shapes[1].obj': cannot read OBJ file",
            path.display()
        )),
        "{msg}"
    );
    assert!(
        msg.contains(&dir.path().join("meshes/none.obj").display().to_string()),
        "{msg}"
    );

    // Index out of range: the OBJ line is named.
    let (_d, path) = scene_with_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "");
    let msg = load(&path).err().unwrap().to_string();
    assert!(
        msg.contains("scene.toml:20: field 'shapes[1].obj'") && msg.contains("mesh.obj', line 4"),
        "{msg}"
    );
    assert!(msg.contains("vertex index 4 does not exist"), "{msg}");
    // A relative texture index before any texture coordinate.
    let (_d, path) = scene_with_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/-100 2 3\n", "");
    let msg = load(&path).err().unwrap().to_string();
    assert!(
        msg.contains("line 4") && msg.contains("texture coordinate index -100"),
        "{msg}"
    );
    // Malformed numbers, which tobj reports without a line: found first, with the line.
    let (_d, path) = scene_with_obj("v 0 zero 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "");
    let msg = load(&path).err().unwrap().to_string();
    assert!(
        msg.contains("scene.toml:20: field 'shapes[1].obj': OBJ file")
            && msg.contains("mesh.obj', line 1: vertex position: 'zero' is not a number"),
        "{msg}"
    );
    let (_d, path) = scene_with_obj("v 0 0 0\nv 1 0 0\nvn 0 1\nv 0 1 0\nf 1 2 3\n", "");
    let msg = load(&path).err().unwrap().to_string();
    assert!(
        msg.contains("line 3: a normal needs 3 numbers, found 2"),
        "{msg}"
    );
    // Non-finite vertices.
    let (_d, path) = scene_with_obj("v 0 nan 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "");
    let msg = load(&path).err().unwrap().to_string();
    assert!(
        msg.contains("scene.toml:20:") && msg.contains("not finite"),
        "{msg}"
    );
}

/// A number that is finite as written but beyond single precision is refused as written, with
/// its place, in every reader: TOML fields, OBJ positions, normals and texture coordinates (in
/// a plain file, which the parallel reader declines, and in a general one), XML values; never
/// reported (or rendered) as `inf`.
#[test]
fn numbers_beyond_single_precision_are_named_as_written() {
    for (obj, line, what) in [
        (
            "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n",
            2,
            "vertex position: '1e39' is out of the single-precision range",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 -3.5e38 0\nf 1 2 3\n",
            3,
            "vertex position: '-3.5e38' is out of",
        ),
        (
            "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1e40\nf 1//1 2//1 3//1\n",
            5,
            "normal: '1e40' is out of",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 5e38 0\nf 1/1 2/1 3/1\n",
            4,
            "texture coordinate: '5e38' is out of",
        ),
    ] {
        let (_d, path) = scene_with_obj(obj, "");
        let msg = load(&path).err().unwrap().to_string();
        assert!(
            msg.contains("scene.toml:20: field 'shapes[1].obj'")
                && msg.contains(&format!("mesh.obj', line {line}: {what}"))
                && !msg.contains("inf"),
            "{obj:?}: {msg}"
        );
    }
    for (from, to, field) in [
        ("radius = 1.0", "radius = 5e38", "shapes[0].sphere.radius"),
        ("fov_y = 40.0", "fov_y = -1e300", "camera.fov_y"),
        (
            "emission = [1.0, 1.0, 1.0]",
            "emission = [1.0, 4e38, 1.0]",
            "shapes[0].emission",
        ),
    ] {
        let e = error_of(&with(from, to));
        assert!(
            e.contains(&format!("field '{field}'"))
                && e.contains("is out of the single-precision range")
                && !e.contains("inf"),
            "{to}: {e}"
        );
    }
    let xml = "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><float name=\"fov\" value=\"1e39\"/></sensor>\n</scene>\n";
    let e = load_str(xml, Path::new("s.xml")).unwrap_err().to_string();
    assert!(
        e.contains("s.xml:2:") && e.contains("'1e39' is out of the single-precision range"),
        "{e}"
    );
}

#[test]
fn degenerate_triangles_are_errors_naming_shape_and_index() {
    let quads = with(
        "sphere = { center = [0.0, 0.0, 0.0], radius = 1.0 }",
        "name = \"wall\"\nquads = [\n  [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]],\n  [[0, 0, 0], [1, 0, 0], [1, 1, 0], [1, 1, 0]],\n]",
    );
    expect_error(
        &quads,
        "[1, 1, 0], [1, 1, 0]",
        "shapes[0].quads[1]",
        "shape 'wall', quad 1: its second triangle (v0, v2, v3) has zero area",
    );
    let tris = with(
        "sphere = { center = [0.0, 0.0, 0.0], radius = 1.0 }",
        "triangles = [[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0, 0], [1, 1, 1], [2, 2, 2]]]",
    );
    expect_error(
        &tris,
        "triangles",
        "shapes[0].triangles[1]",
        "triangle 1 has zero area",
    );
}

#[test]
fn non_finite_numbers_are_errors() {
    expect_error(
        &with("fov_y = 40.0", "fov_y = nan"),
        "fov_y",
        "camera.fov_y",
        "not a finite number",
    );
    expect_error(
        &with("position = [0.0, 0.0, -4.0]", "position = [0.0, inf, -4.0]"),
        "position",
        "camera.position",
        "not a finite number",
    );
    expect_error(
        &with(
            "position = [0.0, 0.0, -4.0]",
            "position = [0.0, 1e39, -4.0]",
        ),
        "position",
        "camera.position",
        "single-precision range",
    );
    expect_error(
        &with("emission = [1.0, 1.0, 1.0]", "emission = [1.0, -nan, 1.0]"),
        "emission",
        "shapes[0].emission",
        "not a finite number",
    );
    expect_error(
        &with("center = [0.0, 0.0, 0.0]", "center = [0.0, 0.0, -inf]"),
        "center",
        "shapes[0].sphere.center",
        "not a finite number",
    );
    expect_error(
        &with("radius = 1.0", "radius = inf"),
        "radius",
        "shapes[0].sphere.radius",
        "not a finite number",
    );
    let q = with(
        "sphere = { center = [0.0, 0.0, 0.0], radius = 1.0 }",
        "quads = [[[0, 0, 0], [1, 0, 0], [1, nan, 0], [0, 1, 0]]]",
    );
    expect_error(&q, "quads", "shapes[0].quads[0]", "not a finite number");
}

#[test]
fn out_of_range_values_are_errors() {
    expect_error(
        &with("radius = 1.0", "radius = -1.0"),
        "radius",
        "shapes[0].sphere.radius",
        "must be > 0",
    );
    expect_error(
        &with("radius = 1.0", "radius = 0"),
        "radius",
        "shapes[0].sphere.radius",
        "must be > 0",
    );
    expect_error(
        &with("width = 8", "width = 0"),
        "width",
        "film.width",
        "must be in [1, 16384]",
    );
    expect_error(
        &with("height = 8", "height = 16385"),
        "height",
        "film.height",
        "must be in [1, 16384]",
    );
    expect_error(
        &with("width = 8", "width = -8"),
        "width",
        "film.width",
        "expected a whole number from 0 to 4294967295",
    );
    expect_error(
        &with("width = 8", "width = \"8\""),
        "width",
        "film.width",
        "invalid type",
    );
    for fov in ["0.0", "180.0", "-30", "200"] {
        expect_error(
            &with("fov_y = 40.0", &format!("fov_y = {fov}")),
            "fov_y",
            "camera.fov_y",
            "must be in (0, 180)",
        );
    }
    expect_error(
        &with("target = [0.0, 0.0, 0.0]", "target = [0.0, 0.0, -4.0]"),
        "target",
        "camera.target",
        "equals the position",
    );
    expect_error(
        &with("fov_y", "up = [0.0, 0.0, -3.0]\nfov_y"),
        "up =",
        "camera.up",
        "parallel to the viewing direction",
    );
    expect_error(
        &with("fov_y", "up = [0.0, 0.0, 0.0]\nfov_y"),
        "up =",
        "camera.up",
        "zero length",
    );
    expect_error(
        &with("position = [0.0, 0.0, -4.0]", "position = [0.0, -4.0]"),
        "position",
        "camera.position",
        "invalid length 2",
    );
    expect_error(
        &with("emission = [1.0, 1.0, 1.0]", "emission = [1.0, -0.5, 1.0]"),
        "emission",
        "shapes[0].emission",
        "negative",
    );
    let env = format!("{BASE}[environment]\nradiance = -1\n");
    expect_error(&env, "radiance", "environment.radiance", "negative");
    for field in ["spp", "max_depth", "rr_start_depth"] {
        let src = format!("{BASE}[integrator]\n{field} = 0\n");
        expect_error(
            &src,
            &format!("{field} ="),
            &format!("integrator.{field}"),
            "must be >= 1",
        );
    }
    let src = format!("{BASE}[integrator]\nspp = 1.5\n");
    expect_error(&src, "spp", "integrator.spp", "invalid type");
}

#[test]
fn geometry_kinds_are_exactly_one_per_shape() {
    let two = with("radius = 1.0 }", "radius = 1.0 }\nobj = \"x.obj\"");
    expect_error(&two, "obj =", "shapes[0].obj", "has both sphere and obj");
    let none = with("sphere = { center = [0.0, 0.0, 0.0], radius = 1.0 }\n", "");
    expect_error(&none, "[[shapes]]", "shapes[0]", "has no geometry");
    let empty = with(
        "sphere = { center = [0.0, 0.0, 0.0], radius = 1.0 }",
        "quads = []",
    );
    expect_error(&empty, "quads", "shapes[0].quads", "empty");
    let short = with(
        "sphere = { center = [0.0, 0.0, 0.0], radius = 1.0 }",
        "quads = [[[0, 0, 0], [1, 0, 0], [1, 1, 0]]]",
    );
    expect_error(&short, "quads", "shapes[0].quads[0]", "invalid length 3");
}

#[test]
fn missing_parts_are_errors() {
    // No shapes at all: no line to name.
    let src = BASE.split("[[shapes]]").next().unwrap();
    let msg = error_of(src);
    assert!(
        msg.starts_with("dir/bad.toml: field 'shapes': the scene has no primitives"),
        "{msg}"
    );
    // Missing required tables and fields.
    let msg = error_of(&with("[film]\nwidth = 8\nheight = 8\n", ""));
    assert!(
        msg.starts_with("dir/bad.toml: field 'film': missing"),
        "{msg}"
    );
    expect_error(
        &with("fov_y = 40.0\n", ""),
        "[camera]",
        "camera.fov_y",
        "missing",
    );
    expect_error(
        &with(", radius = 1.0", ""),
        "sphere",
        "shapes[0].sphere.radius",
        "missing",
    );
    // Syntax errors name the line.
    let msg = error_of(&with("[film]", "[film"));
    assert!(msg.starts_with("dir/bad.toml:6: "), "{msg}");
    // An unreadable scene file names it.
    let msg = load(Path::new("no/such/scene.toml"))
        .err()
        .unwrap()
        .to_string();
    assert!(
        msg.starts_with("no/such/scene.toml: cannot read the scene file"),
        "{msg}"
    );
}

/// Every prefix of the Cornell box file is either a scene or an error: never a panic.
#[test]
fn truncated_input_never_panics() {
    let src = std::fs::read_to_string(common::repo().join("scenes/cornell-box.toml")).unwrap();
    let mut errors = 0;
    for end in (0..src.len())
        .step_by(5)
        .filter(|&e| src.is_char_boundary(e))
    {
        match load_str(&src[..end], Path::new("cut.toml")) {
            Ok(_) => {}
            Err(e) => {
                assert!(e.to_string().starts_with("cut.toml"), "{e}");
                errors += 1;
            }
        }
    }
    assert!(errors > 100);
}

#[test]
fn missing_field_of_the_only_table_names_table_and_line() {
    let msg = error_of("[camera]\nposition = [0.0, 0.0, -4.0]\n");
    assert!(
        msg.starts_with("dir/bad.toml:1: field 'camera.target': missing"),
        "{msg}"
    );
}

/// Fixed-length vectors refuse extra elements, located like every other error (they loaded
/// silently: serde's `[f64; 3]` reads three elements and TOML ignored the rest).
#[test]
fn fixed_length_vectors_refuse_extra_elements() {
    let cases: [(&str, &str, &str, &str); 5] = [
        (
            "position = [0.0, 0.0, -4.0]",
            "position = [0.0, 0.0, -4.0, \"junk\"]",
            "camera.position",
            "invalid length 4, expected an array of 3 elements",
        ),
        (
            "fov_y = 40.0",
            "fov_y = 40.0\nup = [0, 1, 0, 7, 8]",
            "camera.up",
            "invalid length 5",
        ),
        (
            "center = [0.0, 0.0, 0.0]",
            "center = [0.0, 0.0, 0.0, 1.0]",
            "shapes[0].sphere.center",
            "invalid length 4",
        ),
        (
            "sphere = { center = [0.0, 0.0, 0.0], radius = 1.0 }",
            "triangles = [[[0, 0, 0, 5], [1, 0, 0], [0, 1, 0]]]",
            "shapes[0].triangles[0][0]",
            "invalid length 4",
        ),
        (
            "sphere = { center = [0.0, 0.0, 0.0], radius = 1.0 }",
            "quads = [[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 2, 0]]]",
            "shapes[0].quads[0]",
            "invalid length 5, expected an array of 4 elements",
        ),
    ];
    for (from, to, field, what) in cases {
        let src = with(from, to);
        let at = to.lines().last().unwrap();
        expect_error(&src, at, field, what);
    }
    // Too few is refused as before, and the exact length still loads.
    expect_error(
        &with("center = [0.0, 0.0, 0.0]", "center = [0.0, 0.0]"),
        "center = [0.0, 0.0]",
        "shapes[0].sphere.center",
        "invalid length 2",
    );
    let t = with(
        "sphere = { center = [0.0, 0.0, 0.0], radius = 1.0 }",
        "quads = [[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]]",
    );
    assert_eq!(
        load_str(&t, Path::new("q.toml")).unwrap().triangles.len(),
        2
    );
}

/// The scene's max_depth is held to the renderers' limit, as `--max-depth` is (2^20 + 1 loaded
/// and failed only on the GPU, without a line).
#[test]
fn max_depth_over_the_limit_is_an_error() {
    let src = with(
        "[materials.m]",
        "[integrator]\nmax_depth = 1048577\n\n[materials.m]",
    );
    expect_error(
        &src,
        "max_depth = 1048577",
        "integrator.max_depth",
        "must be in [1, 1048576]",
    );
    let ok = with(
        "[materials.m]",
        "[integrator]\nmax_depth = 1048576\n\n[materials.m]",
    );
    assert_eq!(
        load_str(&ok, Path::new("d.toml"))
            .unwrap()
            .integrator
            .max_depth,
        1 << 20
    );
}
