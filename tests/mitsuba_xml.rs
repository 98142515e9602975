//! Mitsuba 3 XML scenes: the XML twins of the shipped scenes (`scenes/xml/`) are what
//! `brdfwave convert` writes and render bit-identical images on both backends; the subset's
//! shapes, transforms, sensor and BSDF mapping load to hand-computed values; every error is
//! located (file, line, element).

mod common;

use brdfwave::scene::load::load_str_with;
use brdfwave::scene::mitsuba::write::{to_mitsuba, Options};
use brdfwave::scene::{load, load_str, Scene};
use common::{context, line_of, render_cpu, render_gpu, repo};
use glam::Vec3;
use std::path::{Path, PathBuf};

/// The shipped TOML scenes, each with its twin `scenes/xml/NAME.xml` (the material preview's
/// measured table written first).
fn shipped() -> Vec<String> {
    common::material_preview_table();
    let mut names: Vec<String> = std::fs::read_dir(repo().join("scenes"))
        .unwrap()
        .filter_map(|e| {
            let p = e.unwrap().path();
            let stem = p.file_stem()?.to_string_lossy().into_owned();
            (p.extension()? == "toml").then_some(stem)
        })
        .collect();
    names.sort();
    assert!(names.len() >= 7, "{names:?}");
    names
}

fn load_pair(name: &str) -> (Scene, Scene) {
    let toml = load(&repo().join(format!("scenes/{name}.toml"))).unwrap();
    let xml = load(&repo().join(format!("scenes/xml/{name}.xml")))
        .unwrap_or_else(|e| panic!("scenes/xml/{name}.xml: {e}"));
    (toml, xml)
}

/// Each twin is what `convert` writes today (regenerate: `brdfwave convert scenes/NAME.toml
/// --to mitsuba scenes/xml/NAME.xml`, with `--brdfwave-plugins` where a model Mitsuba lacks is
/// used).
#[test]
fn xml_twins_are_what_convert_writes() {
    for name in shipped() {
        let s = load(&repo().join(format!("scenes/{name}.toml"))).unwrap();
        let mesh_dir = format!("{name}-meshes");
        // Written into scenes/xml/, as the command writes it: files the scene names are
        // relative to there (the material preview's images and table).
        let xml_dir = Some(repo().join("scenes/xml"));
        let plain = Options {
            xml_dir: xml_dir.clone(),
            ..Options::default()
        };
        let c = match to_mitsuba(&s, &mesh_dir, plain) {
            Ok(c) => c,
            Err(_) => to_mitsuba(
                &s,
                &mesh_dir,
                Options {
                    brdfwave_plugins: true,
                    xml_dir,
                },
            )
            .unwrap(),
        };
        let on_disk = std::fs::read_to_string(repo().join(format!("scenes/xml/{name}.xml")))
            .unwrap_or_else(|e| panic!("scenes/xml/{name}.xml: {e}"));
        assert_eq!(
            c.xml, on_disk,
            "scenes/xml/{name}.xml is stale: regenerate it with `brdfwave convert \
             scenes/{name}.toml --to mitsuba scenes/xml/{name}.xml` (add --brdfwave-plugins \
             where a model Mitsuba lacks is used)"
        );
        for (file, text) in &c.meshes {
            let p = repo().join("scenes/xml").join(file);
            let on_disk = std::fs::read_to_string(&p).unwrap();
            assert_eq!(*text, on_disk, "{} is stale", p.display());
        }
    }
}

/// Loading a twin gives the same primitives, materials, camera and settings, bit for bit.
#[test]
fn xml_twins_load_to_the_same_scene() {
    for name in shipped() {
        let (t, x) = load_pair(&name);
        assert_eq!(t.triangles, x.triangles, "{name}: triangles");
        assert_eq!(t.spheres, x.spheres, "{name}: spheres");
        assert_eq!(t.emitters, x.emitters, "{name}: emitters");
        assert_eq!(t.camera, x.camera, "{name}: camera");
        assert_eq!((t.width, t.height), (x.width, x.height), "{name}: film");
        assert_eq!(t.environment, x.environment, "{name}: environment");
        assert_eq!(t.material_names, x.material_names, "{name}: material names");
        for (a, b) in t.materials.iter().zip(&x.materials) {
            assert_eq!(a.model, b.model, "{name}");
            assert_eq!(
                a.brdf.pack(),
                b.brdf.pack(),
                "{name}: {:?} vs {:?}",
                a.brdf,
                b.brdf
            );
        }
        let (ti, xi) = (&t.integrator, &x.integrator);
        assert_eq!(
            (
                ti.spp,
                ti.max_depth,
                ti.seed,
                ti.sampler,
                ti.russian_roulette
            ),
            (
                xi.spp,
                xi.max_depth,
                xi.seed,
                xi.sampler,
                xi.russian_roulette
            ),
            "{name}: integrator"
        );
        assert!(x.warnings.is_empty(), "{name}: {:?}", x.warnings);
    }
}

fn bits(o: &brdfwave::output::RenderOutput) -> Vec<u32> {
    o.mean
        .data
        .iter()
        .flat_map(|p| p.map(f32::to_bits))
        .collect()
}

fn small(mut s: Scene) -> Scene {
    s.width = 24;
    s.height = 16;
    s.integrator.spp = 2;
    s.integrator.max_depth = s.integrator.max_depth.min(4);
    s
}

/// Each shipped scene and its XML twin render bit-identical images on the CPU reference and
/// on the GPU.
#[test]
fn xml_twins_render_bit_identical_images_on_both_backends() {
    let ctx = context();
    for name in shipped() {
        let (t, x) = load_pair(&name);
        let (t, x) = (small(t), small(x));
        let (ct, cx) = (render_cpu(&t), render_cpu(&x));
        assert!(
            bits(&ct).iter().any(|b| *b != 0),
            "{name}: a black image proves nothing"
        );
        assert_eq!(bits(&ct), bits(&cx), "{name}: CPU images differ");
        let ((gt, _), (gx, _)) = (render_gpu(&ctx, &t), render_gpu(&ctx, &x));
        assert_eq!(bits(&gt), bits(&gx), "{name}: GPU images differ");
    }
}

// ---------------------------------------------------------------------------------------------
// The subset, against hand-computed values.

const SENSOR: &str = r#"<sensor type="perspective">
        <float name="fov" value="40"/>
        <string name="fov_axis" value="y"/>
        <transform name="to_world"><lookat origin="0, 0, -5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="16"/></film>
    </sensor>
    <emitter type="constant"><rgb name="radiance" value="1"/></emitter>"#;

fn xml(body: &str) -> String {
    format!("<scene version=\"3.0.0\">\n    {SENSOR}\n{body}\n</scene>\n")
}

fn load_xml(body: &str) -> Result<Scene, String> {
    load_str(&xml(body), Path::new("dir/s.xml")).map_err(|e| e.to_string())
}

/// The error of `body` starts with `dir/s.xml:LINE:` (the line of `needle`) and contains `what`.
fn expect_error(body: &str, needle: &str, what: &str) {
    let text = xml(body);
    let msg = load_str(&text, Path::new("dir/s.xml"))
        .expect_err("must fail")
        .to_string();
    common::assert_located(&msg, ("dir/s.xml", &text), needle, &[what]);
}

#[test]
fn rectangle_cube_and_disk_become_triangles_placed_by_to_world() {
    let s = load_xml(
        r#"<shape type="rectangle">
            <transform name="to_world"><scale value="2"/><rotate x="1" angle="90"/><translate y="3"/></transform>
        </shape>"#,
    )
    .unwrap();
    // (-1, -1, 0) → (-2, -2, 0) → rotated about +x by 90°: (x, y, z) → (x, -z, y) = (-2, 0, -2)
    // → (-2, 3, -2). The normal +z turns to -y.
    assert_eq!(s.triangles.len(), 2);
    assert!((s.triangles[0].v[0] - Vec3::new(-2.0, 3.0, -2.0)).length() < 1e-6);
    assert!((s.triangles[0].geometric_normal() - Vec3::NEG_Y).length() < 1e-6);

    let s = load_xml(r#"<shape type="cube"/>"#).unwrap();
    assert_eq!(s.triangles.len(), 12);
    for t in &s.triangles {
        // Every face faces out: its normal points the way its centroid lies.
        let c = (t.v[0] + t.v[1] + t.v[2]) / 3.0;
        assert!(t.geometric_normal().dot(c) > 0.0, "{t:?}");
    }
    let area: f64 = load_xml(r#"<shape type="disk"/>"#)
        .unwrap()
        .triangles
        .iter()
        .map(|t| t.area())
        .sum();
    assert!((area / std::f64::consts::PI - 1.0).abs() < 2e-4, "{area}");
}

/// Mitsuba's normals of its `rectangle`, `disk`, `cube` and `sphere` go through the inverse
/// transpose of `to_world`: a mirroring transform reverses the winding but not the side they
/// face, so the reader winds the triangles the other way (and turns a sphere inward, as Mitsuba
/// does); `flip_normals` turns them back. A mesh's triangles face their vertex normals.
#[test]
fn mirroring_transforms_keep_mitsubas_front_sides() {
    let mirror = r#"<transform name="to_world"><scale x="-1"/><translate y="1"/></transform>"#;
    let load_shape = |shape: &str, flip: bool| {
        let flip = if flip {
            r#"<boolean name="flip_normals" value="true"/>"#
        } else {
            ""
        };
        load_xml(&format!("<shape type=\"{shape}\">{flip}{mirror}</shape>")).unwrap()
    };
    for shape in ["rectangle", "disk"] {
        // scale(-1, 1, 1) keeps the normal +z: (M^-T)·z = z.
        for (flip, want) in [(false, 1.0), (true, -1.0)] {
            let s = load_shape(shape, flip);
            for t in &s.triangles {
                assert!(
                    t.geometric_normal().z * want > 0.999,
                    "{shape} {flip}: {t:?}"
                );
            }
            let mirrored = s.warnings.iter().any(|w| w.contains("mirrors"));
            assert!(!mirrored, "{shape}: nothing turns over: {:?}", s.warnings);
        }
    }
    let s = load_shape("cube", false);
    for t in &s.triangles {
        let c = (t.v[0] + t.v[1] + t.v[2]) / 3.0 - Vec3::Y;
        assert!(
            t.geometric_normal().dot(c) > 0.0,
            "a mirrored cube faces out: {t:?}"
        );
    }
    assert!(load_shape("sphere", false).spheres[0].inward);
    assert!(!load_shape("sphere", true).spheres[0].inward);

    // An OBJ with outward vertex normals under the mirror: the winding follows the normals.
    let d = tempfile::tempdir().unwrap();
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n";
    write(d.path(), "t.obj", obj);
    let main = write(
        d.path(),
        "s.xml",
        &xml(&format!(
            r#"<shape type="obj"><string name="filename" value="t.obj"/>{mirror}</shape>"#
        )),
    );
    let s = load(&main).unwrap();
    assert!(s.triangles[0].geometric_normal().z > 0.999);
    assert!(s
        .warnings
        .iter()
        .any(|w| w.contains("keeps the side they face")));
    // flip_normals turns a mesh over, winding and normals, with or without a mirror.
    for transform in ["", mirror] {
        let main = write(
            d.path(),
            "s.xml",
            &xml(&format!(
                r#"<shape type="obj"><string name="filename" value="t.obj"/><boolean name="flip_normals" value="true"/>{transform}</shape>"#
            )),
        );
        let s = load(&main).unwrap();
        assert!(s.triangles[0].geometric_normal().z < -0.999, "{transform}");
        let n = s.attributes_of(0).n.expect("the file's normals");
        assert!(n.iter().all(|n| n.z < -0.999), "{transform}: {n:?}");
    }
}

/// A mesh without normals gets Mitsuba's smooth normals at each vertex of the file: a cube whose
/// faces share their eight corners (even across `o` and `g` groups) is smooth, one whose faces
/// each have their own four vertices at the same corners is flat, in OBJ and in PLY;
/// `face_normals` keeps it flat, and a TOML scene, which does not smooth, too.
#[test]
fn meshes_without_normals_are_smoothed_per_vertex_of_the_file() {
    let corners =
        "v -1 -1 -1\nv 1 -1 -1\nv -1 1 -1\nv 1 1 -1\nv -1 -1 1\nv 1 -1 1\nv -1 1 1\nv 1 1 1\n";
    let quads = common::scene_file::CUBE_QUADS;
    let position = |i: usize| {
        let i = i - 1;
        Vec3::new(
            [-1.0, 1.0][i & 1],
            [-1.0, 1.0][(i >> 1) & 1],
            [-1.0, 1.0][(i >> 2) & 1],
        )
    };
    let welded: String = quads
        .iter()
        .map(|q| format!("f {} {} {} {}\n", q[0], q[1], q[2], q[3]))
        .collect();
    let grouped: String = quads
        .iter()
        .enumerate()
        .map(|(k, q)| {
            let kw = ["o", "g"][k % 2];
            format!("{kw} side{k}\nf {} {} {} {}\n", q[0], q[1], q[2], q[3])
        })
        .collect();
    let mut unwelded = String::new();
    for (k, q) in quads.iter().enumerate() {
        for &i in q {
            let p = position(i);
            unwelded += &format!("v {} {} {}\n", p.x, p.y, p.z);
        }
        let b = 4 * k;
        unwelded += &format!("f {} {} {} {}\n", b + 1, b + 2, b + 3, b + 4);
    }
    let ply = |vertices: &[Vec3], faces: &[[usize; 4]]| {
        let mut t = format!(
            "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
            vertices.len(),
            faces.len()
        );
        for v in vertices {
            t += &format!("{} {} {}\n", v.x, v.y, v.z);
        }
        for f in faces {
            t += &format!("4 {} {} {} {}\n", f[0], f[1], f[2], f[3]);
        }
        t
    };
    let eight: Vec<Vec3> = (1..=8).map(position).collect();
    let zero_based: Vec<[usize; 4]> = quads.iter().map(|q| q.map(|i| i - 1)).collect();
    let spread: Vec<Vec3> = quads.iter().flatten().map(|&i| position(i)).collect();
    let own: Vec<[usize; 4]> = (0..6)
        .map(|k| [4 * k, 4 * k + 1, 4 * k + 2, 4 * k + 3])
        .collect();

    let d = tempfile::tempdir().unwrap();
    write(d.path(), "welded.obj", &format!("{corners}{welded}"));
    write(d.path(), "grouped.obj", &format!("{corners}{grouped}"));
    write(d.path(), "unwelded.obj", &unwelded);
    write(d.path(), "welded.ply", &ply(&eight, &zero_based));
    write(d.path(), "unwelded.ply", &ply(&spread, &own));
    let shape = |file: &str, extra: &str| {
        let kind = &file[file.len() - 3..];
        let main = write(
            d.path(),
            "s.xml",
            &xml(&format!(
                r#"<shape type="{kind}"><string name="filename" value="{file}"/>{extra}</shape>"#
            )),
        );
        load(&main).unwrap()
    };
    for (file, smooth) in [
        ("welded.obj", true),
        ("grouped.obj", true),
        ("unwelded.obj", false),
        ("welded.ply", true),
        ("unwelded.ply", false),
    ] {
        let s = shape(file, "");
        assert_eq!(s.triangles.len(), 12, "{file}");
        for (k, t) in s.triangles.iter().enumerate() {
            let n = s.attributes_of(k).n.expect("smooth normals");
            let face = t.geometric_normal();
            for (v, n) in t.v.iter().zip(n) {
                let want = if smooth { *v / 3f32.sqrt() } else { face };
                assert!(
                    (n - want).length() < 1e-5,
                    "{file}: triangle {k}: {n} at {v}, want {want}"
                );
            }
        }
        let flat = shape(file, r#"<boolean name="face_normals" value="true"/>"#);
        assert!(
            (0..12).all(|k| flat.attributes_of(k).n.is_none()),
            "{file}: face_normals"
        );
    }
    // A TOML scene shades a mesh without normals flat.
    let main = write(
        d.path(),
        "s.toml",
        "[camera]\nposition = [0, 0, -5]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 40\n[film]\nwidth = 8\nheight = 8\n[materials.m]\nmodel = \"lambert\"\nalbedo = 0.5\n[[shapes]]\nobj = \"welded.obj\"\nmaterial = \"m\"\n",
    );
    let s = load(&main).unwrap();
    assert!((0..12).all(|k| s.attributes_of(k).n.is_none()));
}

/// A bitmap's `to_uv` is rows and columns 0, 1 and 3 of its 4×4 transform, as Mitsuba takes it:
/// a 3×3 `<matrix>` is the 4×4's linear part, so its third column moves nothing (with a
/// warning), and a `<translate>` after it does.
#[test]
fn bitmap_to_uv_is_the_2d_part_of_the_transform() {
    let d = tempfile::tempdir().unwrap();
    image::RgbImage::from_pixel(2, 2, image::Rgb([200, 100, 50]))
        .save(d.path().join("t.png"))
        .unwrap();
    let map = |steps: &str| {
        let main = write(
            d.path(),
            "s.xml",
            &xml(&format!(
                r#"<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="t.png"/><transform name="to_uv">{steps}</transform></texture></bsdf></shape>"#
            )),
        );
        let s = load(&main).unwrap();
        (s.materials[0].textures[0].texture.to_uv, s.warnings)
    };
    let m3 = r#"<matrix value="1.5 0.5 0.2 -0.3 1.2 0.1 0 0 1"/>"#;
    let (uv, warnings) = map(m3);
    assert_eq!(uv, [[1.5, 0.5, 0.0], [-0.3, 1.2, 0.0]]);
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("to_uv: the map's z column (0.2, 0.1) is dropped")),
        "{warnings:?}"
    );
    let (uv, _) = map(&format!(r#"{m3}<translate x="0.25" y="0.5"/>"#));
    assert_eq!(uv, [[1.5, 0.5, 0.25], [-0.3, 1.2, 0.5]]);
    let (uv, warnings) = map(r#"<scale x="2" y="3"/><translate x="0.25"/>"#);
    assert_eq!(uv, [[2.0, 0.0, 0.25], [0.0, 3.0, 0.0]]);
    assert!(
        !warnings.iter().any(|w| w.contains("to_uv")),
        "{warnings:?}"
    );
}

/// Emitters without their radiance, intensity or irradiance emit Mitsuba's default, 1 (grey).
#[test]
fn emitters_default_to_mitsubas_unit_radiance() {
    let s = load_str(
        &format!(
            "<scene version=\"3.0.0\">{}<emitter type=\"constant\"/><shape type=\"rectangle\"><emitter type=\"area\"/></shape><emitter type=\"point\"/></scene>",
            SENSOR.split("<emitter").next().unwrap()
        ),
        Path::new("dir/s.xml"),
    )
    .unwrap();
    assert_eq!(s.environment, Vec3::ONE);
    assert_eq!(s.emitters.len(), 1);
    assert_eq!(s.emitters[0].radiance, Vec3::ONE);
    assert!(matches!(
        s.lights[..],
        [brdfwave::scene::DeltaLight::Point { intensity, .. }] if intensity == Vec3::ONE
    ));
}

/// A conductor given η alone takes Mitsuba's default κ = 1, and one given κ alone is a mirror
/// (Mitsuba's default η = 0, a purely imaginary index, reflects everything); Mitsuba 3.9.1 gives
/// F = 0.7398 for η = 0.2 alone and for η = 0.2, κ = 1 at cos θ = 0.6, and 1 for κ alone.
#[test]
fn conductors_fill_in_mitsubas_default_eta_and_k() {
    let material = |bsdf: &str| {
        let s = load_xml(&format!("<shape type=\"sphere\">{bsdf}</shape>")).unwrap();
        s.materials[0].clone()
    };
    let (wi, wo) = (Vec3::new(0.8, 0.0, 0.6), Vec3::new(-0.8, 0.0, 0.6));
    let eval = |bsdf: &str| {
        let m = material(&format!(
            "<bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"0.2\"/>{bsdf}</bsdf>"
        ));
        m.brdf.eval(wi, wo)
    };
    let eta = "<float name=\"eta\" value=\"0.2\"/>";
    let k1 = "<float name=\"k\" value=\"1\"/>";
    assert_eq!(eval(eta), eval(&format!("{eta}{k1}")));
    let k3 = "<float name=\"k\" value=\"3\"/>";
    assert_eq!(
        eval(k3),
        eval(""),
        "κ alone is Mitsuba's mirror, as no η nor κ"
    );
    assert_ne!(eval(eta), eval(""));
    let both = format!("<string name=\"material\" value=\"Au\"/>{eta}");
    expect_error(
        &format!("<shape type=\"sphere\"><bsdf type=\"conductor\">{both}</bsdf></shape>"),
        "<float name=\"eta\"",
        "give either material, or eta and k, not both",
    );
}

/// Mitsuba's texture coordinates on its own shapes: the rectangle's ((x + 1)/2, (y + 1)/2)
/// with or without `flip_normals`, the disk's (r, φ/2π), and each cube face onto [0, 1]².
#[test]
fn generated_shapes_carry_mitsubas_texture_coordinates() {
    let textured = r#"<bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="t.exr"/></texture></bsdf>"#;
    let d = tempfile::tempdir().unwrap();
    let tex = d.path().join("t.exr");
    brdfwave::imageio::write(
        &tex,
        &brdfwave::imageio::Image::from_fn(2, 2, |_, _| [0.5; 3]),
    )
    .unwrap();
    // `shape` is the start tag's type and anything after it inside the tag.
    let load_shape = |shape: &str, inside: &str| {
        let body = format!("<shape type=\"{shape}\">{inside}{textured}</shape>");
        load(&write(d.path(), "s.xml", &xml(&body))).unwrap()
    };
    let uv_at = |s: &Scene, k: usize, i: usize| s.attributes_of(k).uv.expect("uv")[i];
    for flipped in [false, true] {
        let inside = match flipped {
            true => r#"<boolean name="flip_normals" value="true"/>"#,
            false => "",
        };
        let s = load_shape("rectangle", inside);
        assert_eq!(s.triangles.len(), 2);
        for (k, t) in s.triangles.iter().enumerate() {
            for (i, p) in t.v.iter().enumerate() {
                let want = glam::Vec2::new((p.x + 1.0) / 2.0, (p.y + 1.0) / 2.0);
                assert_eq!(uv_at(&s, k, i), want, "flip_normals {flipped}");
            }
            assert_eq!(t.geometric_normal().z > 0.0, !flipped);
        }
    }
    let s = load_shape("disk", "");
    for (k, t) in s.triangles.iter().enumerate() {
        for (i, p) in t.v.iter().enumerate().skip(1) {
            let uv = uv_at(&s, k, i);
            assert!((uv.x - p.truncate().length()).abs() < 1e-6);
            let phi = p.y.atan2(p.x).rem_euclid(std::f32::consts::TAU) / std::f32::consts::TAU;
            // The rim vertex at φ = 0 is v = 0 on one side of the seam and v = 1 on the other.
            assert!(
                (uv.y - phi).abs() < 1e-5 || (uv.y - 1.0).abs() < 1e-6,
                "{uv} {p}"
            );
        }
    }
    let s = load_shape("cube", "");
    assert_eq!(s.triangles.len(), 12);
    for face in 0..6 {
        let mut corners: Vec<(Vec3, glam::Vec2)> = Vec::new();
        for k in [2 * face, 2 * face + 1] {
            for i in 0..3 {
                corners.push((s.triangles[k].v[i], uv_at(&s, k, i)));
            }
        }
        // Four distinct corners of the face, each at a distinct corner of [0, 1]², and (u, v)
        // an affine function of the position (so that the two triangles agree).
        let mut uvs: Vec<[u32; 2]> = corners
            .iter()
            .map(|c| [c.1.x as u32, c.1.y as u32])
            .collect();
        uvs.sort();
        uvs.dedup();
        assert_eq!(uvs, [[0, 0], [0, 1], [1, 0], [1, 1]], "face {face}");
        for a in &corners {
            for b in &corners {
                if a.0 == b.0 {
                    assert_eq!(a.1, b.1, "face {face}: one corner, one (u, v)");
                }
            }
        }
    }
}

/// A sphere its transform turns, or mirrors, is written with that turn in `to_world` (its
/// texture coordinates turn with it in Mitsuba too) and reads back with the same frame,
/// centre, radius and front side.
#[test]
fn turned_spheres_convert_with_their_frames() {
    let toml = "[camera]\nposition = [0.0, 1.0, -5.0]\ntarget = [0.0, 0.0, 0.0]\nfov_y = 40.0\n\
        [film]\nwidth = 16\nheight = 16\n\
        [materials.m]\nmodel = \"lambert\"\n\
        [[shapes]]\nmaterial = \"m\"\nsphere = { center = [0.0, 0.0, 0.0], radius = 1.0 }\n\
        transform = { translate = [0.0, 0.5, 0.0], rotate = { axis = [1.0, 0.3, 0.0], angle_deg = -70.0 } }\n\
        [[shapes]]\nmaterial = \"m\"\nsphere = { center = [2.0, 0.0, 0.0], radius = 0.5, inward = true }\n\
        transform = { matrix = [[0.0, -1.0, 0.0, 0.0], [-1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]] }\n";
    let s = load_str(toml, Path::new("t.toml")).unwrap();
    let c = to_mitsuba(&s, "m", Options::default()).unwrap();
    let x = load_str(&c.xml, Path::new("t.xml")).unwrap_or_else(|e| panic!("{e}\n{}", c.xml));
    assert_eq!(s.spheres.len(), 2);
    for (a, b) in s.spheres.iter().zip(&x.spheres) {
        assert!((a.center - b.center).length() < 1e-6, "{a:?} {b:?}");
        assert!((a.radius - b.radius).abs() < 1e-6);
        assert_eq!(a.inward, b.inward);
        let (fa, fb) = (a.frame.expect("turned"), b.frame.expect("turned"));
        assert_eq!(fa.mirror, fb.mirror);
        for d in [Vec3::X, Vec3::Y, Vec3::Z] {
            assert!(
                (fa.to_local(d) - fb.to_local(d)).length() < 1e-5,
                "{fa:?} {fb:?}"
            );
        }
    }
    assert!(s.spheres[1].frame.unwrap().mirror);
}

#[test]
fn spheres_take_similarities_only() {
    let s = load_xml(
        r#"<shape type="sphere"><point name="center" x="1" y="0" z="0"/><float name="radius" value="0.5"/>
            <transform name="to_world"><rotate z="1" angle="90"/><scale value="2"/></transform>
        </shape>"#,
    )
    .unwrap();
    // Centre (1, 0, 0) → rotated (0, 1, 0) → scaled (0, 2, 0); radius 0.5 · 2.
    assert!((s.spheres[0].center - Vec3::new(0.0, 2.0, 0.0)).length() < 1e-6);
    assert!((s.spheres[0].radius - 1.0).abs() < 1e-6);
    expect_error(
        r#"<shape type="sphere">
            <transform name="to_world"><scale x="2"/></transform>
        </shape>"#,
        "<transform name=\"to_world\"><scale x",
        "similarity",
    );
}

/// Mitsuba's fov is horizontal by default: 90° across a 32 × 16 film is
/// 2·atan(tan(45°)·16/32) = 53.1301° vertically. A to_world matrix camera looks along its +z.
#[test]
fn sensor_fov_axis_and_matrix_camera() {
    let text = xml("<shape type=\"sphere\"/>").replace(
        "<float name=\"fov\" value=\"40\"/>\n        <string name=\"fov_axis\" value=\"y\"/>",
        "<float name=\"fov\" value=\"90\"/>",
    );
    let s = load_str(&text, Path::new("s.xml")).unwrap();
    assert!(
        (s.camera.fov_y_deg - 53.130_1).abs() < 1e-3,
        "{}",
        s.camera.fov_y_deg
    );
    let text = xml("<shape type=\"sphere\"/>").replace(
        "<lookat origin=\"0, 0, -5\" target=\"0, 0, 0\" up=\"0, 1, 0\"/>",
        "<rotate y=\"1\" angle=\"90\"/><translate x=\"-5\"/>",
    );
    let s = load_str(&text, Path::new("s.xml")).unwrap();
    // +z rotated 90° about +y is +x: the camera at (-5, 0, 0) looks toward +x.
    assert!((s.camera.position - Vec3::new(-5.0, 0.0, 0.0)).length() < 1e-6);
    assert!((s.camera.target - Vec3::new(-4.0, 0.0, 0.0)).length() < 1e-6);
    assert!((s.camera.up - Vec3::Y).length() < 1e-6);
}

/// Without a `fov`, the `focal_length` of a 35 mm camera (Mitsuba's default 50mm) gives the
/// diagonal's field of view. The horizontal fields of view Mitsuba 3.9.1 gives
/// (`mi.traverse(sensor)["x_fov"]`): 34.022057° (50mm, 64 × 64), 47.216316° (35mm, 64 × 64),
/// 42.311714° (50mm, 96 × 48).
#[test]
fn focal_length_as_mitsuba_reads_it() {
    let load_cam = |lens: &str, (w, h): (u32, u32)| {
        let text = xml("<shape type=\"sphere\"/>")
            .replace(
                "<float name=\"fov\" value=\"40\"/>\n        <string name=\"fov_axis\" value=\"y\"/>",
                lens,
            )
            .replace("value=\"32\"", &format!("value=\"{w}\""))
            .replace("value=\"16\"", &format!("value=\"{h}\""));
        load_str(&text, Path::new("s.xml"))
    };
    for (lens, size, x_fov) in [
        ("", (64, 64), 34.022_057),
        (
            r#"<string name="focal_length" value="35mm"/>"#,
            (64, 64),
            47.216_316,
        ),
        (
            r#"<string name="focal_length" value="50"/>"#,
            (96, 48),
            42.311_714,
        ),
    ] {
        let s = load_cam(lens, size).unwrap();
        let aspect = size.1 as f64 / size.0 as f64;
        let want = 2.0
            * ((x_fov / 2.0f64).to_radians().tan() * aspect)
                .atan()
                .to_degrees();
        let got = s.camera.fov_y_deg as f64;
        assert!((got - want).abs() < 1e-4, "{lens}: {got} against {want}");
    }
    let both = r#"<float name="fov" value="40"/><string name="focal_length" value="50mm"/>"#;
    let e = load_cam(both, (32, 16)).unwrap_err().to_string();
    assert!(e.contains("either a fov or a focal_length"), "{e}");
    let axis = r#"<string name="focal_length" value="50mm"/><string name="fov_axis" value="y"/>"#;
    let e = load_cam(axis, (32, 16)).unwrap_err().to_string();
    assert!(e.contains("fov_axis goes with a fov"), "{e}");
    let bad = r#"<string name="focal_length" value="-5mm"/>"#;
    let e = load_cam(bad, (32, 16)).unwrap_err().to_string();
    assert!(e.contains("focal_length '-5mm' is not a length"), "{e}");
}

/// A camera whose `to_world` mirrors (`<scale x="-1"/>` before its `lookat`) mirrors the image,
/// as Mitsuba renders it, and `convert` writes it back that way.
#[test]
fn a_mirroring_camera_mirrors_the_image() {
    let text = xml("<shape type=\"sphere\"/>")
        .replace("<lookat origin=", "<scale x=\"-1\"/><lookat origin=");
    let s = load_str(&text, Path::new("s.xml")).unwrap();
    assert!(s.camera.mirror);
    assert!((s.camera.position - Vec3::new(0.0, 0.0, -5.0)).length() < 1e-6);
    assert!((s.camera.up - Vec3::Y).length() < 1e-6);
    assert!(!load_xml("<shape type=\"sphere\"/>").unwrap().camera.mirror);
    let c = to_mitsuba(&s, "m", Options::default()).unwrap();
    assert!(c.xml.contains("<scale x=\"-1\"/><lookat"), "{}", c.xml);
    let back = load_str(&c.xml, Path::new("t.xml")).unwrap();
    assert!(back.camera.mirror);
    assert!((back.camera.position - s.camera.position).length() < 1e-6);
}

/// Mitsuba's `hide_emitters`: camera rays pass through the emitters they meet and do not see
/// the environment; the light of both still reaches the scene. An emitting square in front of
/// a diffuse wall lit by a constant sky: without it the square's pixels are its radiance, with
/// it they are the wall behind (dimmed a little where the square shades it), on both backends;
/// `convert` keeps the setting.
#[test]
fn hidden_emitters_let_camera_rays_through() {
    let scene = |hide: bool| {
        let text = format!(
            r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="3"/><boolean name="hide_emitters" value="{hide}"/></integrator>
<sensor type="perspective"><float name="fov" value="40"/>
<transform name="to_world"><lookat origin="0, 0, -5" target="0, 0, 0" up="0, 1, 0"/></transform>
<sampler type="independent"><integer name="sample_count" value="32"/></sampler>
<film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/><rfilter type="box"/></film></sensor>
<shape type="rectangle"><transform name="to_world"><scale value="5"/><rotate y="1" angle="180"/><translate z="2"/></transform>
<bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
<shape type="rectangle"><transform name="to_world"><scale value="0.6"/><rotate y="1" angle="180"/></transform>
<emitter type="area"><rgb name="radiance" value="5"/></emitter></shape>
<emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>"#
        );
        load_str(&text, Path::new("h.xml")).unwrap()
    };
    let (shown, hidden) = (scene(false), scene(true));
    assert!(hidden.integrator.hide_emitters && !shown.integrator.hide_emitters);
    let centre = |o: &brdfwave::output::RenderOutput| o.mean.get(8, 8)[1];
    assert_eq!(centre(&render_cpu(&shown)), 5.0, "the square seen directly");
    let ctx = context();
    let cpu = render_cpu(&hidden);
    let (gpu, _) = render_gpu(&ctx, &hidden);
    common::finish(ctx);
    // The wall: albedo 0.5 under a sky of 1, less what the square hides of the sky.
    let c = centre(&cpu);
    assert!(
        c > 0.35 && c < 0.5,
        "the wall behind the hidden square: {c}"
    );
    let rmse = brdfwave::metrics::rmse(&gpu.mean, &cpu.mean).unwrap();
    assert!(rmse < 1e-5, "GPU and CPU differ: RMSE {rmse:e}");
    let c = to_mitsuba(&hidden, "m", Options::default()).unwrap();
    assert!(c
        .xml
        .contains("<boolean name=\"hide_emitters\" value=\"true\"/>"));
}

/// The BSDF mapping: diffuse → lambert, roughconductor with a named metal → conductor Fresnel
/// with its table, roughplastic → dielectric Cook–Torrance with a diffuse part, and any survey
/// model by its own name and parameters.
#[test]
fn bsdfs_map_to_the_survey_models() {
    use brdfwave::brdf::cook_torrance::{CookTorrance, Distribution, Fresnel, Geometry};
    let s = load_xml(
        r#"<bsdf type="roughconductor" id="gold"><string name="material" value="Au"/>
              <float name="alpha" value="0.25"/><string name="distribution" value="ggx"/></bsdf>
           <bsdf type="roughplastic" id="plastic"><rgb name="diffuse_reflectance" value="0.2, 0.3, 0.4"/>
              <string name="int_ior" value="bk7"/><float name="ext_ior" value="1"/></bsdf>
           <bsdf type="ward" id="w"><float name="alpha_x" value="0.3"/><float name="alpha_y" value="0.1"/></bsdf>
           <shape type="sphere"><ref id="gold"/></shape>
           <shape type="sphere"><ref id="plastic"/></shape>
           <shape type="sphere"><ref id="w"/></shape>
           <shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="0.7"/></bsdf></shape>"#,
    )
    .unwrap();
    let ct = |i: usize| -> CookTorrance {
        s.materials[i]
            .brdf
            .as_any()
            .downcast_ref::<CookTorrance>()
            .unwrap()
            .clone()
    };
    let gold = ct(0);
    assert_eq!(gold.fresnel, Fresnel::Conductor);
    assert_eq!(gold.distribution, Distribution::Ggx);
    assert_eq!(gold.geometry, Geometry::Smith);
    assert_eq!(gold.roughness, 0.25);
    assert_eq!(gold.eta, Vec3::new(0.143_119, 0.374_957, 1.442_48));
    assert_eq!(gold.kd, Vec3::ZERO);
    let plastic = ct(1);
    assert_eq!(plastic.fresnel, Fresnel::Dielectric);
    assert_eq!(plastic.ior, 1.5046);
    assert_eq!(plastic.kd, Vec3::new(0.2, 0.3, 0.4));
    // Mitsuba's default roughplastic: Beckmann, alpha 0.1.
    assert_eq!(
        (plastic.distribution, plastic.roughness),
        (Distribution::Beckmann, 0.1)
    );
    assert_eq!(s.materials[2].model_name(), "ward");
    assert_eq!(s.materials[3].model_name(), "lambert");
    assert_eq!(s.material_names[3], "shape 3 bsdf");
}

/// `$name` takes the `<default>`, or the command line's `-D name=value` over it.
#[test]
fn defaults_and_command_line_parameters() {
    let body = r#"<default name="r" value="2"/>
        <shape type="sphere"><float name="radius" value="$r"/></shape>"#;
    assert_eq!(load_xml(body).unwrap().spheres[0].radius, 2.0);
    let defines = [("r".to_string(), "3.5".to_string())];
    let s = load_str_with(&xml(body), Path::new("s.xml"), &defines).unwrap();
    assert_eq!(s.spheres[0].radius, 3.5);
    assert!(
        !s.warnings.iter().any(|w| w.contains("-D")),
        "{:?}",
        s.warnings
    );
    // A -D the scene never substitutes is most likely misspelt: it is warned about.
    let typo = [("radius".to_string(), "3.5".to_string())];
    let s = load_str_with(&xml(body), Path::new("s.xml"), &typo).unwrap();
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("-D radius: the scene has no $radius")),
        "{:?}",
        s.warnings
    );
    // A TOML scene takes no parameters.
    let toml = std::fs::read_to_string(repo().join("scenes/white-furnace.toml")).unwrap();
    let e = load_str_with(&toml, Path::new("w.toml"), &defines).unwrap_err();
    assert!(e.to_string().contains("Mitsuba XML scenes only"), "{e}");
}

// ---------------------------------------------------------------------------------------------
// Every error is located.

#[test]
fn malformed_xml_names_its_line() {
    let text = "<scene version=\"3.0.0\">\n  <shape type=\"sphere\">\n</scene>\n";
    let e = load_str(text, Path::new("m.xml")).unwrap_err().to_string();
    assert!(e.starts_with("m.xml:3: malformed XML"), "{e}");
    let e = load_str("<scene version=\"2.1.0\"/>", Path::new("m.xml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("no <sensor"), "a Mitsuba 2 file is read: {e}");
    let e = load_str("<scene version=\"0.6.0\"/>", Path::new("m.xml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("m.xml:1: ") && e.contains("only Mitsuba 2 and 3"),
        "{e}"
    );
    // Nesting deep enough to exhaust a recursive reader is refused, located.
    let deep = format!(
        "<scene version=\"3.0.0\">\n{}{}</scene>",
        "<a>".repeat(100_000),
        "</a>".repeat(100_000)
    );
    let e = load_str(&deep, Path::new("m.xml")).unwrap_err().to_string();
    assert!(
        e.starts_with("m.xml:2: ") && e.contains("nest deeper"),
        "{e}"
    );
}

#[test]
fn unsupported_elements_are_refused_where_they_are() {
    expect_error(
        r#"<shape type="hair"/>"#,
        "hair",
        "<shape type=\"hair\"> is not supported (supported: obj",
    );
    expect_error(
        r#"<bsdf type="dielectric" id="glass"/>"#,
        "dielectric",
        "supported: diffuse, conductor, roughconductor, plastic, roughplastic, and the survey's models by name: lambert",
    );
    expect_error(r#"<emitter type="spot"/>"#, "spot", "is not supported");
    // The test scene has a constant environment already.
    expect_error(
        r#"<emitter type="envmap"/>"#,
        "envmap",
        "a second environment emitter (constant or envmap)",
    );
    expect_error(
        r#"<texture type="bitmap"/>"#,
        "bitmap",
        "not supported at the top level",
    );
    expect_error(
        r#"<shape type="sphere"><float name="radiu" value="1"/></shape>"#,
        "radiu",
        "does not take parameter float 'radiu' (supported: center, radius",
    );
    expect_error(
        r#"<bsdf type="roughconductor" id="a"><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.2"/></bsdf>"#,
        "alpha_v",
        "anisotropic roughness is not supported",
    );
    expect_error(
        r#"<bsdf type="conductor" id="a"><string name="material" value="Unobtainium"/></bsdf>"#,
        "Unobtainium",
        "unknown conductor material 'Unobtainium' (known: none, a-C, Ag",
    );
    // Our own models take their own parameter names, checked by the registry's parser.
    expect_error(
        r#"<bsdf type="ward" id="w"><float name="roughness" value="0.3"/></bsdf>
           <shape type="sphere"><ref id="w"/></shape>"#,
        "name=\"roughness\"",
        "roughness",
    );
    expect_error(
        r#"<shape type="sphere"><ref id="nope"/></shape>"#,
        "nope",
        "no top-level <bsdf id=\"nope\"> in the scene",
    );
    expect_error(
        r#"<shape type="sphere"><float name="radius" value="$rr"/></shape>"#,
        "$rr",
        "unknown parameter $rr",
    );
    expect_error(
        r#"<shape type="sphere"><float name="radius" value="-1"/></shape>"#,
        "value=\"-1\"",
        "the radius must be > 0",
    );
}

/// PLY meshes, point and directional emitters and `twosided` BSDFs load as their TOML forms:
/// `ply`, `[[lights]]` and `twosided = true`.
#[test]
fn ply_delta_lights_and_twosided_map_to_their_toml_forms() {
    use brdfwave::scene::DeltaLight;
    let d = tempfile::tempdir().unwrap();
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
               end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    write(d.path(), "t.ply", ply);
    let main = write(
        d.path(),
        "s.xml",
        &xml(
            r#"<bsdf type="twosided" id="two"><bsdf type="diffuse"><rgb name="reflectance" value="0.3"/></bsdf></bsdf>
<shape type="ply"><string name="filename" value="t.ply"/><ref id="two"/></shape>
<emitter type="point"><point name="position" x="1" y="2" z="3"/><rgb name="intensity" value="4, 5, 6"/></emitter>
<emitter type="directional"><vector name="direction" x="0" y="-2" z="0"/><float name="irradiance" value="2"/></emitter>
<emitter type="point"><transform name="to_world"><translate x="7"/></transform></emitter>"#,
        ),
    );
    let s = load(&main).unwrap();
    assert_eq!(s.triangles.len(), 1);
    assert_eq!(s.triangles[0].v, [Vec3::ZERO, Vec3::X, Vec3::Y]);
    let m = &s.materials[s.triangles[0].material as usize];
    assert!(m.twosided, "the twosided bsdf's material is two-sided");
    assert_eq!(
        s.lights,
        [
            DeltaLight::Point {
                position: Vec3::new(1.0, 2.0, 3.0),
                intensity: Vec3::new(4.0, 5.0, 6.0)
            },
            DeltaLight::Directional {
                direction: Vec3::new(0.0, -1.0, 0.0),
                irradiance: Vec3::splat(2.0)
            },
            DeltaLight::Point {
                position: Vec3::new(7.0, 0.0, 0.0),
                intensity: Vec3::ONE
            },
        ]
    );
    // What has no brdfwave form is refused where it is.
    expect_error(
        r#"<bsdf type="twosided" id="t"><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>"#,
        "twosided",
        "exactly one BSDF, nested or by <ref> (found 2 nested and 0 <ref>)",
    );
    expect_error(
        r#"<emitter type="point"><point name="position" x="1"/><transform name="to_world"><translate x="1"/></transform></emitter>"#,
        "type=\"point\"",
        "either position or to_world",
    );
    expect_error(
        r#"<shape type="sphere"><emitter type="point"/></shape>"#,
        "type=\"point\"",
        "belongs at the top level",
    );
}

/// What Mitsuba 3 does with files users write, which a reader of the documentation alone would
/// get wrong: a constant `<spectrum>` in an emitter is that multiple of D65 (in a BSDF, grey);
/// a twosided BSDF may name its BSDF by `<ref>`; a shape may name a BSDF defined after it.
#[test]
fn mitsuba_readings_of_spectra_refs_and_order() {
    let d65 = Vec3::new(1.204_793_9, 0.948_291, 0.908_916_06);
    let scene = |body: &str| {
        let text = format!(
            "<scene version=\"3.0.0\">\n{}\n{body}\n</scene>\n",
            SENSOR.lines().take(6).collect::<Vec<_>>().join("\n")
        );
        load_str(&text, Path::new("dir/s.xml")).unwrap_or_else(|e| panic!("{e}"))
    };
    let s = scene(
        r#"<emitter type="constant"><spectrum name="radiance" value="2"/></emitter>
<emitter type="point"><spectrum name="intensity" value="3"/></emitter>
<emitter type="directional"><float name="irradiance" value="4"/></emitter>
<shape type="sphere"><emitter type="area"><spectrum name="radiance" value="5"/></emitter></shape>
<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="0.5"/></bsdf></shape>"#,
    );
    let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() <= 1e-6 * b.max_element();
    assert!(close(s.environment, 2.0 * d65), "{}", s.environment);
    use brdfwave::scene::DeltaLight;
    let DeltaLight::Point { intensity, .. } = s.lights[0] else {
        panic!()
    };
    assert!(close(intensity, 3.0 * d65), "{intensity}");
    let DeltaLight::Directional { irradiance, .. } = s.lights[1] else {
        panic!()
    };
    assert_eq!(irradiance, Vec3::splat(4.0), "a <float> is grey");
    assert!(
        close(s.emitters[0].radiance, 5.0 * d65),
        "{}",
        s.emitters[0].radiance
    );
    let lambert = |i: usize| {
        let m = &s.materials[s.spheres[i].material as usize];
        m.brdf.eval(Vec3::Z, Vec3::Z) * std::f32::consts::PI
    };
    assert!(
        close(lambert(1), Vec3::splat(0.5)),
        "a <spectrum> in a BSDF is grey"
    );

    // A twosided BSDF by <ref>, the BSDF after the shapes that name it; the BSDF it wraps is
    // no material of its own unless a shape uses it too.
    let wrapped = r#"<shape type="sphere"><ref id="two"/></shape>
<bsdf type="diffuse" id="white"><rgb name="reflectance" value="0.3"/></bsdf>
<bsdf type="twosided" id="two"><ref id="white"/></bsdf>"#;
    let s = scene(wrapped);
    let m = &s.materials[s.spheres[0].material as usize];
    assert!(m.twosided);
    assert!(close(
        m.brdf.eval(Vec3::Z, Vec3::Z) * std::f32::consts::PI,
        Vec3::splat(0.3)
    ));
    assert_eq!(s.material_names, ["two"]);
    let s = scene(&format!(
        "{wrapped}\n<shape type=\"sphere\"><ref id=\"white\"/></shape>"
    ));
    let mut names = s.material_names.clone();
    names.sort();
    assert_eq!(names, ["two", "white"]);
    assert!(!s.materials[s.spheres[1].material as usize].twosided);
    // A twosided BSDF names one read before it; a name nothing defines is refused, located.
    expect_error(
        r#"<bsdf type="twosided" id="two"><ref id="later"/></bsdf>
<bsdf type="diffuse" id="later"/>"#,
        "<ref id=\"later\"",
        "a twosided BSDF names only one defined before it",
    );
    expect_error(
        r#"<shape type="sphere"><ref id="nowhere"/></shape>"#,
        "<ref id=\"nowhere\"",
        "no top-level <bsdf id=\"nowhere\"> in the scene (BSDFs with ids: none",
    );
}

/// Where brdfwave renders a file otherwise than Mitsuba would, or as Mitsuba does but not as
/// the file seems to mean, it says so: a film without a filter (Mitsuba's default is a
/// Gaussian), a `<rotate>` about an axis that is not a unit vector (taken as written).
#[test]
fn warnings_say_where_a_reading_is_surprising() {
    let warned = |s: &Scene, what: &str| s.warnings.iter().any(|w| w.contains(what));
    let s = load_xml(r#"<shape type="sphere"/>"#).unwrap();
    assert!(
        warned(&s, "no <rfilter>: Mitsuba's default is a Gaussian"),
        "{:?}",
        s.warnings
    );
    let boxed =
        xml("<shape type=\"sphere\"/>").replace("</film>", "<rfilter type=\"box\"/></film>");
    let s = load_str(&boxed, Path::new("dir/s.xml")).unwrap();
    assert!(!warned(&s, "rfilter"), "{:?}", s.warnings);
    let rotated = |axis: &str| {
        load_xml(&format!(
            r#"<shape type="rectangle"><transform name="to_world"><rotate value="{axis}" angle="30"/></transform></shape>"#
        ))
        .unwrap()
    };
    assert!(warned(&rotated("1, 1, 0"), "has length 1.414214, not 1"));
    assert!(!warned(&rotated("0.7071, 0.7071, 0"), "not 1"));
    assert!(!warned(&rotated("0, 0, 1"), "not 1"));
}

/// `convert` keeps delta lights and two-sided materials: the XML it writes loads back to the
/// same lights and the same flag.
#[test]
fn convert_keeps_delta_lights_and_twosided() {
    // The scene-file tests' small scene (a one-sided material "m" on an emitting sphere), with
    // a two-sided material on a quad and two delta lights added.
    let toml = format!(
        "{}{}",
        common::scene_file::BASE,
        r#"
[materials.back]
model = "lambert"
albedo = 0.25
twosided = true
[[shapes]]
material = "back"
quads = [[[-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [1.0, 0.0, 1.0], [-1.0, 0.0, 1.0]]]
[[lights]]
type = "point"
position = [0.0, 2.0, 0.0]
intensity = [1.0, 2.0, 3.0]
[[lights]]
type = "directional"
direction = [0.0, -1.0, 0.5]
irradiance = 0.5
"#
    );
    let s = load_str(&toml, Path::new("t.toml")).unwrap();
    let c = to_mitsuba(&s, "m", Options::default()).unwrap();
    assert!(
        c.xml.contains("<bsdf type=\"twosided\" id=\"back\">"),
        "{}",
        c.xml
    );
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir(d.path().join("m")).unwrap();
    for (file, text) in &c.meshes {
        write(d.path(), file, text);
    }
    let back = load(&write(d.path(), "t.xml", &c.xml)).unwrap();
    // The direction is normalised again on loading (in double precision, then rounded): equal
    // up to its last bits.
    use brdfwave::scene::DeltaLight::{Directional, Point};
    match (&back.lights[..], &s.lights[..]) {
        (
            [p @ Point { .. }, Directional {
                direction: a,
                irradiance: ea,
            }],
            [q @ Point { .. }, Directional {
                direction: b,
                irradiance: eb,
            }],
        ) => {
            assert_eq!(p, q);
            assert!((*a - *b).abs().max_element() < 3e-7, "{a} vs {b}");
            assert_eq!(ea, eb);
        }
        other => panic!("{other:?}"),
    }
    let twosided = |name: &str| {
        let k = back.material_names.iter().position(|n| n == name).unwrap();
        back.materials[k].twosided
    };
    assert!(twosided("back") && !twosided("m"));
    assert_eq!(back.triangles, s.triangles);
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Includes splice the included scene in place; an error inside one names that file and line;
/// a missing include and a cycle are refused at the `<include>`.
#[test]
fn includes_missing_and_cyclic() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    write(
        dir,
        "bsdfs.xml",
        "<scene version=\"3.0.0\">\n<bsdf type=\"diffuse\" id=\"grey\"/>\n</scene>\n",
    );
    let main = write(
        dir,
        "main.xml",
        &xml(
            "<include filename=\"bsdfs.xml\"/>\n<shape type=\"sphere\"><ref id=\"grey\"/></shape>",
        ),
    );
    let s = load(&main).unwrap();
    assert_eq!(s.material_names, ["grey"]);

    // An error in the included file: its name, its line.
    write(
        dir,
        "bad.xml",
        "<scene version=\"3.0.0\">\n\n<bsdf type=\"diffuse\" id=\"g\"><rgb name=\"reflectance\" value=\"2\"/></bsdf>\n</scene>\n",
    );
    let main = write(
        dir,
        "main2.xml",
        &xml("<include filename=\"bad.xml\"/>\n<shape type=\"sphere\"><ref id=\"g\"/></shape>"),
    );
    let e = load(&main).unwrap_err().to_string();
    let bad = dir.join("bad.xml").display().to_string();
    assert!(e.starts_with(&format!("{bad}:3: ")), "{e}");
    assert!(e.contains("albedo") && e.contains("out of range"), "{e}");

    let text = xml("<include filename=\"missing.xml\"/>");
    let main = write(dir, "main3.xml", &text);
    let e = load(&main).unwrap_err().to_string();
    let line = line_of(&text, "missing.xml");
    assert!(
        e.starts_with(&format!("{}:{line}: ", main.display())),
        "{e}"
    );
    assert!(e.contains("cannot read the included file"), "{e}");

    let a = write(
        dir,
        "a.xml",
        "<scene version=\"3.0.0\">\n<include filename=\"b.xml\"/>\n</scene>\n",
    );
    write(
        dir,
        "b.xml",
        "<scene version=\"3.0.0\">\n\n<include filename=\"a.xml\"/>\n</scene>\n",
    );
    let e = load(&a).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!("{}:3: ", dir.join("b.xml").display())),
        "{e}"
    );
    assert!(e.contains("cyclic include"), "{e}");
}

/// An OBJ shape's filename is relative to the file that names it, and the mesh keeps its
/// vertices as written without a to_world.
#[test]
fn obj_shapes_resolve_against_their_file() {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir(d.path().join("m")).unwrap();
    write(d.path(), "m/t.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let main = write(
        d.path(),
        "s.xml",
        &xml("<shape type=\"obj\"><string name=\"filename\" value=\"m/t.obj\"/></shape>"),
    );
    let s = load(&main).unwrap();
    assert_eq!(s.triangles[0].v, [Vec3::ZERO, Vec3::X, Vec3::Y]);
}

/// What a user wrote is what an error names: a film of width or height 0 (not the field of view
/// computed from it), a field of view out of range, `int_ior`/`ext_ior` (not the ior of their
/// ratio), the step where a `to_world` overflows (not "projective"), and a Latin-1 byte in an
/// `.xml` scene or include (its line and column, not "this looks like a Mitsuba scene").
#[test]
fn errors_name_what_the_file_says() {
    let sensor = |fov: &str, axis: &str, w: &str, h: &str| {
        format!(
            "<scene version=\"3.0.0\">\n<sensor type=\"perspective\">\n<float name=\"fov\" value=\"{fov}\"/>\n\
             <string name=\"fov_axis\" value=\"{axis}\"/>\n<film type=\"hdrfilm\">\n\
             <integer name=\"width\" value=\"{w}\"/>\n<integer name=\"height\" value=\"{h}\"/>\n\
             </film>\n</sensor>\n<shape type=\"sphere\"/>\n</scene>\n"
        )
    };
    for (fov, axis, w, h, needle, what) in [
        (
            "40",
            "x",
            "0",
            "8",
            "\"width\"",
            "width 0 is out of range: must be in [1, 16384]",
        ),
        (
            "40",
            "x",
            "8",
            "0",
            "\"height\"",
            "height 0 is out of range: must be in [1, 16384]",
        ),
        (
            "40",
            "diagonal",
            "0",
            "0",
            "\"width\"",
            "width 0 is out of range",
        ),
        (
            "40",
            "y",
            "16385",
            "8",
            "\"width\"",
            "width 16385 is out of range",
        ),
        (
            "40",
            "smaller",
            "8",
            "99999",
            "\"height\"",
            "height 99999 is out of range",
        ),
        (
            "0",
            "x",
            "8",
            "8",
            "\"fov\"",
            "fov 0 is out of range: must be in (0, 180) degrees",
        ),
        ("180", "y", "8", "8", "\"fov\"", "fov 180 is out of range"),
        (
            "-5",
            "larger",
            "8",
            "8",
            "\"fov\"",
            "fov -5 is out of range",
        ),
    ] {
        let text = sensor(fov, axis, w, h);
        let e = load_str(&text, Path::new("f.xml")).unwrap_err().to_string();
        common::assert_located(&e, ("f.xml", &text), needle, &[what]);
        assert!(!e.contains("fov_y"), "{e}");
    }
    for (bsdf, needle, what) in [
        (
            r#"<float name="ext_ior" value="0"/>"#,
            "ext_ior",
            "ext_ior 0 is out of range: an index of refraction is > 0",
        ),
        (
            r#"<float name="int_ior" value="0"/>"#,
            "int_ior",
            "int_ior 0 is out of range",
        ),
        (
            r#"<float name="int_ior" value="-1.5"/>"#,
            "int_ior",
            "int_ior -1.5 is out of range",
        ),
        (
            r#"<float name="int_ior" value="3e38"/><float name="ext_ior" value="1e-3"/>"#,
            "ext_ior",
            "int_ior / ext_ior = 3e38 / 0.001: 3e41 is out of the single-precision range",
        ),
    ] {
        let body = format!(
            "<bsdf type=\"roughplastic\" id=\"p\">{bsdf}</bsdf>\n<shape type=\"sphere\"><ref id=\"p\"/></shape>"
        );
        expect_error(&body, needle, what);
        let e = load_xml(&body).unwrap_err();
        assert!(!e.contains("field 'ior'") && !e.contains("inf"), "{e}");
    }
    for (steps, what) in [
        (
            r#"<scale value="1e38"/><scale value="1e38"/>"#,
            "<scale>: the transform overflows here: an entry of the matrix so far is 1e76",
        ),
        (
            r#"<scale value="1e30"/><scale value="1e30"/><scale value="1e30"/><scale value="1e30"/><scale value="1e30"/><scale value="1e30"/><scale value="1e30"/><scale value="1e30"/><scale value="1e30"/><scale value="1e30"/>"#,
            "<scale>: the transform overflows here",
        ),
        (
            r#"<matrix value="3e38 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"/><scale x="10"/>"#,
            "<scale>: the transform overflows here",
        ),
        (
            r#"<translate x="3e38"/><translate x="3e38"/>"#,
            "<translate>: the transform overflows here",
        ),
    ] {
        let body = format!(
            "<shape type=\"sphere\"><transform name=\"to_world\">{steps}</transform></shape>"
        );
        let e = load_xml(&body).unwrap_err();
        assert!(
            e.contains(what) && !e.contains("projective"),
            "{steps}: {e}"
        );
    }
    // A truly projective matrix is still called that.
    let e = load_xml(r#"<shape type="sphere"><transform name="to_world"><matrix value="1 0 0 0 0 1 0 0 0 0 1 0 0 0 1 1"/></transform></shape>"#).unwrap_err();
    assert!(e.contains("projective"), "{e}");

    let d = tempfile::tempdir().unwrap();
    let mut latin1 = xml("<shape type=\"sphere\"/>").into_bytes();
    latin1.extend_from_slice(b"<!-- caf\xe9 -->\n");
    let lines = 1 + latin1.iter().filter(|&&b| b == b'\n').count() - 1;
    std::fs::write(d.path().join("l.xml"), &latin1).unwrap();
    let e = load(&d.path().join("l.xml")).unwrap_err().to_string();
    assert!(
        e.contains(&format!("line {lines}, column 9")) && e.contains("0xe9"),
        "{e}"
    );
    assert!(!e.contains("looks like"), "{e}");
    let main = write(d.path(), "main.xml", &xml("<include filename=\"l.xml\"/>"));
    let e = load(&main).unwrap_err().to_string();
    assert!(
        e.contains("cannot read the included file")
            && e.contains(&format!("line {lines}, column 9")),
        "{e}"
    );
}

/// Nothing is silently dropped or replaced: a second `<integrator>`; two elements with one id
/// (shapes, a shape and a BSDF, a nested BSDF, an emitter); `value` beside `x`, `y` or `z`
/// (where one would win) on every element that takes both; an attribute an element does not
/// take.
#[test]
fn conflicting_definitions_are_refused() {
    expect_error(
        "<integrator type=\"path\"/>\n<integrator type=\"path\"><integer name=\"max_depth\" value=\"3\"/></integrator>",
        "max_depth",
        "a second <integrator>: brdfwave renders with one (the first is at dir/s.xml:",
    );
    for (body, needle) in [
        (
            r#"<shape type="sphere" id="a"/><shape type="rectangle" id="a"/>"#,
            "rectangle",
        ),
        (
            r#"<bsdf type="diffuse" id="a"/><shape type="sphere" id="a"><ref id="a"/></shape>"#,
            "sphere",
        ),
        (
            r#"<shape type="sphere" id="b"><bsdf type="diffuse" id="b"/></shape>"#,
            "diffuse",
        ),
        (
            r#"<bsdf type="diffuse" id="c"/><shape type="sphere"><bsdf type="conductor" id="c"/></shape>"#,
            "conductor",
        ),
        (
            r#"<emitter type="point" id="e"/><shape type="sphere" id="e"/>"#,
            "sphere",
        ),
    ] {
        expect_error(body, needle, "is given twice: to ");
        let e = load_xml(body).unwrap_err();
        assert!(e.contains("an id names one object"), "{e}");
    }
    // A ref refers, it does not define: two refs to one BSDF are fine.
    load_xml(r#"<bsdf type="diffuse" id="w"/><shape type="sphere"><ref id="w"/></shape><shape type="cube"><ref id="w"/></shape>"#).unwrap();
    for (el, tag) in [
        (r#"<point name="center" value="9 9 9" x="0"/>"#, "point"),
        (r#"<point name="center" value="1" z="2" y="1"/>"#, "point"),
        (
            r#"<transform name="to_world"><scale value="2" x="3"/></transform>"#,
            "scale",
        ),
        (
            r#"<transform name="to_world"><translate value="1 2 3" y="1"/></transform>"#,
            "translate",
        ),
        (
            r#"<transform name="to_world"><rotate value="0 1 0" x="1" angle="30"/></transform>"#,
            "rotate",
        ),
    ] {
        let body = format!("<shape type=\"sphere\">{el}</shape>");
        expect_error(
            &body,
            &format!("<{tag}"),
            &format!("<{tag}> has both value and"),
        );
    }
    let e = load_xml(r#"<emitter type="directional"><vector name="direction" value="0 0 1" x="1"/></emitter><shape type="sphere"/>"#).unwrap_err();
    assert!(e.contains("<vector> has both value and x"), "{e}");
    for (el, what) in [
        (
            r#"<float name="radius" value="1" foo="2"/>"#,
            "<float> does not take the attribute 'foo' (it takes name, value)",
        ),
        (
            r#"<point name="center" x="1" w="2"/>"#,
            "<point> does not take the attribute 'w'",
        ),
        (
            r#"<transform name="to_world"><lookat origin="0 0 0" target="0 0 1" dir="1"/></transform>"#,
            "<lookat> does not take the attribute 'dir'",
        ),
        (
            r#"<transform name="to_world"><scale vlaue="2"/></transform>"#,
            "<scale> does not take the attribute 'vlaue'",
        ),
    ] {
        let body = format!("<shape type=\"sphere\">{el}</shape>");
        let e = load_xml(&body).unwrap_err();
        assert!(e.contains(what), "{el}: {e}");
    }
    let e = load_xml(r#"<shape type="sphere" kind="x"/>"#).unwrap_err();
    assert!(
        e.contains("<shape> does not take the attribute 'kind'"),
        "{e}"
    );
}

/// The message of an unsupported shape lists every shape the reader reads, and each one listed
/// is read (the list and the reader cannot drift apart).
#[test]
fn the_supported_shapes_are_the_ones_read() {
    let e = load_xml(r#"<shape type="cylinder"/>"#).unwrap_err();
    let list = e
        .split("(supported: ")
        .nth(1)
        .and_then(|r| r.strip_suffix(')'))
        .unwrap_or_else(|| panic!("{e}"));
    let d = tempfile::tempdir().unwrap();
    std::fs::write(
        d.path().join("t.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        d.path().join("t.ply"),
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    )
    .unwrap();
    let kinds: Vec<&str> = list.split(", ").collect();
    assert!(kinds.contains(&"ply") && kinds.len() >= 6, "{list}");
    for kind in kinds {
        let file = match kind {
            "obj" | "ply" => format!("<string name=\"filename\" value=\"t.{kind}\"/>"),
            _ => String::new(),
        };
        let text = xml(&format!("<shape type=\"{kind}\">{file}</shape>"));
        let p = write(d.path(), "s.xml", &text);
        load(&p).unwrap_or_else(|e| panic!("{kind}: {e}"));
    }
}

/// A small file cannot make the reader do unbounded work: `<default>`s that double each other
/// (and `-D` values, and many substitutions of a long one) stop at the bounds with a short
/// message; includes that fan out stop at 1024 files read, and included text at 256 MiB.
#[test]
fn reading_an_xml_scene_is_bounded() {
    let mut doubling = String::from("<default name=\"a0\" value=\"xx\"/>\n");
    for i in 1..34 {
        doubling.push_str(&format!(
            "<default name=\"a{i}\" value=\"$a{}$a{}\"/>\n",
            i - 1,
            i - 1
        ));
    }
    let body =
        format!("{doubling}<shape type=\"sphere\"><float name=\"radius\" value=\"$a33\"/></shape>");
    let e = load_xml(&body).unwrap_err();
    assert!(
        e.contains("the value is longer than 65536 bytes") && e.len() < 1000,
        "{e}"
    );
    // A command-line value used twice.
    let big = "7".repeat(40_000);
    let text = xml(r#"<shape type="sphere"><float name="radius" value="$r$r"/></shape>"#);
    let e = load_str_with(&text, Path::new("s.xml"), &[("r".into(), big)])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("longer than 65536 bytes") && e.len() < 1000,
        "{e}"
    );
    // Many substitutions of a long value: 60 KB each, 1200 times.
    let long = "1".repeat(60_000);
    let mut many = format!("<default name=\"v\" value=\"{long}\"/>\n<shape type=\"sphere\">");
    for i in 0..1200 {
        many.push_str(&format!("<string name=\"s{i}\" value=\"$v\"/>"));
    }
    many.push_str("</shape>");
    let e = load_xml(&many).unwrap_err();
    assert!(
        e.contains("substitutions add up to more than 64 MiB") && e.len() < 1000,
        "{e}"
    );

    let d = tempfile::tempdir().unwrap();
    for i in 0..30 {
        let next = format!("<include filename=\"d{}.xml\"/>", i + 1);
        let body = if i < 29 {
            next.repeat(2)
        } else {
            String::new()
        };
        write(
            d.path(),
            &format!("d{i}.xml"),
            &format!("<scene version=\"3.0.0\">{body}</scene>\n"),
        );
    }
    let main = write(d.path(), "main.xml", &xml("<include filename=\"d0.xml\"/>"));
    let e = load(&main).unwrap_err().to_string();
    assert!(e.contains("the scene reads more than 1024 files"), "{e}");
    // Fewer files, each large: 300 reads of a 1 MB include pass 256 MiB.
    let pad = format!(
        "<scene version=\"3.0.0\"><!-- {} --></scene>\n",
        "x".repeat(1 << 20)
    );
    write(d.path(), "big.xml", &pad);
    let main = write(
        d.path(),
        "main2.xml",
        &xml(&"<include filename=\"big.xml\"/>".repeat(300)),
    );
    let e = load(&main).unwrap_err().to_string();
    assert!(
        e.contains("the included files add up to more than 256 MiB"),
        "{e}"
    );
    // A chain past 32 levels.
    for i in 0..40 {
        write(
            d.path(),
            &format!("c{i}.xml"),
            &format!(
                "<scene version=\"3.0.0\"><include filename=\"c{}.xml\"/></scene>\n",
                i + 1
            ),
        );
    }
    write(d.path(), "c40.xml", "<scene version=\"3.0.0\"/>\n");
    let e = load(&d.path().join("c0.xml")).unwrap_err().to_string();
    assert!(e.contains("includes nest deeper than 32 files"), "{e}");
}

/// `convert` writes what Mitsuba reads as brdfwave read the scene: an OBJ with normals mirrored
/// by a matrix (its normals then behind its winding's side) gets face normals, so that Mitsuba's front, where
/// the normals point, is brdfwave's, the winding's side, and the XML renders as the TOML does;
/// material names Mitsuba cannot take as ids (empty, or with a '$') get ids of their own; a
/// path with a '$' is refused; a textured roughness on the dielectric form (roughplastic, whose
/// alpha is a number) has no twin.
#[test]
fn convert_writes_what_mitsuba_reads_as_brdfwave_read_it() {
    let d = tempfile::tempdir().unwrap();
    // A quad facing +z with its normals, mirrored in x (the normals then face -z).
    write(
        d.path(),
        "q.obj",
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\n",
    );
    image::RgbImage::from_pixel(2, 2, image::Rgb([90, 90, 90]))
        .save(d.path().join("r.png"))
        .unwrap();
    let scene = |shape_extra: &str, names: [&str; 2], kd: &str| {
        format!(
            "[camera]\nposition = [0, 0, 4]\ntarget = [0, 0, 0]\nfov_y = 40\n[film]\nwidth = 16\nheight = 16\n\
             [integrator]\nspp = 4\nmax_depth = 3\n[environment]\nradiance = 1\n\
             [materials.\"{a}\"]\nmodel = \"lambert\"\nalbedo = 0.5\n\
             [materials.\"{b}\"]\nmodel = \"cook_torrance\"\nfresnel = \"dielectric\"\nnormalization = \"walter\"\n\
             geometry = \"smith\"\nkd = 0.4\nks = 0.3\nroughness = {kd}\n\
             [[shapes]]\nmaterial = \"{a}\"\nobj = \"q.obj\"\n{shape_extra}\n\
             [[shapes]]\nmaterial = \"{b}\"\nsphere = {{ center = [0, 0, -2], radius = 0.5 }}\n",
            a = names[0],
            b = names[1],
        )
    };
    let convert = |text: &str| {
        let p = write(d.path(), "s.toml", text);
        let s = load(&p).unwrap();
        to_mitsuba(&s, "s-meshes", Options::default()).map(|c| (s, c))
    };
    let (s, c) = convert(&scene(
        "transform = { matrix = [[-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]] }",
        ["", "a$b"],
        "0.3",
    ))
    .unwrap();
    assert!(
        c.xml.contains("id=\"material0\"") && c.xml.contains("id=\"material1\""),
        "{}",
        c.xml
    );
    assert!(!c.xml.contains('$'));
    let obj = &c.meshes[0].1;
    // The mirror winds the quad toward -z, and its normals stay +z: written as the face's.
    assert!(
        obj.contains("vn 0 0 -1\n") && !obj.contains("vn 0 0 1\n"),
        "{obj}"
    );
    std::fs::create_dir_all(d.path().join("s-meshes")).unwrap();
    for (file, text) in &c.meshes {
        write(d.path(), file, text);
    }
    let xml = write(d.path(), "s.xml", &c.xml);
    let x = load(&xml).unwrap();
    assert_eq!(
        bits(&render_cpu(&x)),
        bits(&render_cpu(&s)),
        "the XML renders as the TOML"
    );

    let Err(e) = convert(&scene("", ["m", "n"], "{ texture = \"r.png\" }")) else {
        panic!("a textured roughplastic alpha converted")
    };
    assert!(
        e.contains("material 'n'") && e.contains("not a texture"),
        "{e}"
    );
    std::fs::create_dir_all(d.path().join("a$b")).unwrap();
    image::RgbImage::from_pixel(2, 2, image::Rgb([90, 90, 90]))
        .save(d.path().join("a$b/r.png"))
        .unwrap();
    let text = scene("", ["m", "n"], "0.3")
        .replace("albedo = 0.5", "albedo = { texture = \"a$b/r.png\" }");
    let Err(e) = convert(&text) else {
        panic!("a path with a '$' converted")
    };
    assert!(e.contains("a$b/r.png") && e.contains("holds a '$'"), "{e}");
}

/// Mitsuba's other path tracers render as `path` without participating media, and take its
/// properties; other integrators are refused, and so is a `<spectrum>` of wavelength:value
/// pairs, each with a message that says what to write.
#[test]
fn volumetric_and_replay_path_tracers_read_as_path() {
    for kind in ["volpath", "volpathmis", "prb", "prbvolpath"] {
        let s = load_xml(&format!(
            r#"<integrator type="{kind}"><integer name="max_depth" value="3"/><integer name="rr_depth" value="2"/></integrator><shape type="sphere"/>"#
        ))
        .unwrap();
        assert_eq!(s.integrator.max_depth, 3, "{kind}");
        assert!(s.integrator.russian_roulette, "{kind}");
    }
    expect_error(
        r#"<integrator type="direct"/><shape type="sphere"/>"#,
        "integrator type",
        "volpath, volpathmis, prb and prbvolpath, which render as path",
    );
    expect_error(
        r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="400:0.1, 700:0.9"/></bsdf></shape>"#,
        "<spectrum",
        "wavelength:value pairs",
    );
}
