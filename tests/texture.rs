//! Image textures on material parameters (`src/texture.rs`, `shaders/texture.glsl`,
//! `src/brdf/textured.rs`): every colour and number parameter of every model can be one; every
//! model's representative materials, each with all those parameters textured, render the same
//! image on both backends at the same seed (the CPU's `with_params` against the GPU's record
//! slots and `<model>_textured`); a texture of one value is the constant material; texels out
//! of a parameter's range are clamped with one warning; bad texture files and tables are
//! refused naming the field and the file.

mod common;

use brdfwave::brdf::{Kind, MODELS};
use brdfwave::imageio::{self, Image};
use brdfwave::scene::{self, Scene};
use std::path::{Path, PathBuf};

#[test]
fn every_colour_and_number_parameter_can_be_a_texture() {
    for m in MODELS.iter() {
        for p in m.params {
            let texturable = matches!(p.kind, Kind::Rgb(_) | Kind::Scalar(_));
            assert_eq!(
                p.slot.is_some(),
                texturable,
                "{}.{}: a colour or number parameter needs a record slot (`.at(word)`), no other kind may have one",
                m.name,
                p.name
            );
        }
    }
}

/// A scene of a sphere of material `material` (TOML fields, one per line) on a ground quad of
/// Lambert, under a gradient environment map, in `dir`.
fn scene_text(material: &str) -> String {
    format!(
        "[camera]\nposition = [0.0, 0.6, -3.0]\ntarget = [0.0, 0.0, 0.0]\nfov_y = 40.0\n\
         [film]\nwidth = 24\nheight = 24\n\
         [integrator]\nspp = 8\nmax_depth = 4\nseed = 3\n\
         [materials.m]\n{material}\n\
         [materials.ground]\nmodel = \"lambert\"\nalbedo = {{ texture = \"ground.png\" }}\n\
         [[shapes]]\nmaterial = \"m\"\nsphere = {{ center = [0.0, 0.0, 0.0], radius = 0.8 }}\n\
         [[shapes]]\nmaterial = \"ground\"\n\
         quads = [[[-3.0, -0.8, -3.0], [-3.0, -0.8, 3.0], [3.0, -0.8, 3.0], [3.0, -0.8, -3.0]]]\n\
         [environment]\nmap = \"sky.exr\"\n"
    )
}

/// The images every scene here reads: the sky and the ground.
fn write_common(dir: &Path) {
    let sky = Image::from_fn(16, 9, |x, y| {
        [
            0.3 + 0.1 * x as f32,
            1.2 - 0.1 * y as f32,
            0.5 + 0.05 * (x * y) as f32,
        ]
    });
    imageio::write(&dir.join("sky.exr"), &sky).unwrap();
    let ground = Image::from_fn(8, 8, |x, y| match (x + y) % 2 {
        0 => [0.8, 0.3, 0.2],
        _ => [0.2, 0.4, 0.7],
    });
    imageio::write(&dir.join("ground.png"), &ground).unwrap();
}

/// Four values of parameter `p` around `base`, within its range, for a 2 × 2 texture.
fn values_around(p: &brdfwave::brdf::Param, base: f32) -> [f32; 4] {
    let (lo, hi) = p.texture_range();
    if p.name == "rotation" {
        return [0.0, 20.0, 45.0, 90.0];
    }
    let v = if base > 0.0 {
        [0.6, 0.85, 1.0, 1.2].map(|k| base * k)
    } else {
        [0.05, 0.1, 0.15, 0.2].map(|k| lo.max(0.0) + k * (hi - lo.max(0.0)).min(1.0))
    };
    v.map(|x| x.clamp(lo, hi))
}

/// The material `inline` (`model = "…", a = 1, …`) with every colour and number parameter
/// its record holds (Cook–Torrance's Fresnel parameters only for its Fresnel term) textured by
/// a 2 × 2 EXR written into `dir` (values around the material's own or the default), as TOML
/// lines.
fn textured(dir: &Path, inline: &str) -> String {
    let text = inline.replace(", ", "\n");
    let (plain, _) = brdfwave::brdf::validate::material_from_toml("inline", &text).unwrap();
    let table: toml::Table = toml::from_str(&text).unwrap();
    let model = MODELS
        .iter()
        .find(|m| Some(m.name) == table["model"].as_str())
        .unwrap();
    let mut lines = vec![format!("model = \"{}\"", model.name)];
    for (k, v) in &table {
        let textured = |p: &&brdfwave::brdf::Param| plain.brdf.record_slot(p).is_some();
        if k != "model" && !model.params.iter().filter(textured).any(|p| p.name == k) {
            lines.push(format!("{k} = {v}"));
        }
    }
    for p in model
        .params
        .iter()
        .filter(|p| plain.brdf.record_slot(p).is_some())
    {
        let given = table.get(p.name).and_then(|v| match v {
            toml::Value::Float(f) => Some(*f as f32),
            toml::Value::Integer(i) => Some(*i as f32),
            toml::Value::Array(a) => a.first().and_then(|x| x.as_float()).map(|f| f as f32),
            _ => None,
        });
        let base = given.unwrap_or(match p.kind {
            Kind::Rgb(c) => c[0],
            Kind::Scalar(x) => x,
            _ => unreachable!(),
        });
        let v = values_around(p, base);
        let file = format!("{}-{}.exr", model.name, p.name);
        let img = Image::from_fn(2, 2, |x, y| {
            let a = v[(2 * y + x) as usize];
            match p.kind {
                // A colour's channels differ, each in range.
                Kind::Rgb(_) => [a, v[(2 * y + x + 1) as usize % 4], a],
                _ => [a; 3],
            }
        });
        imageio::write(&dir.join(&file), &img).unwrap();
        lines.push(format!("{} = {{ texture = \"{file}\" }}", p.name));
    }
    lines.join("\n")
}

fn load(dir: &Path, text: &str) -> Scene {
    let p = dir.join("s.toml");
    std::fs::write(&p, text).unwrap();
    scene::load(&p).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// Every representative material of every model but `measured` (a table has no parameter to
/// texture), all its colour and number parameters textured: the GPU (record slots and
/// `<model>_textured`) renders what the CPU (`with_params`) renders, at the same seed.
#[test]
fn textured_materials_render_alike_on_both_backends() {
    let dir = tempfile::tempdir().unwrap();
    write_common(dir.path());
    let ctx = common::context();
    for model in MODELS.iter().filter(|m| m.name != "measured") {
        for (label, inline) in model.report_materials() {
            let s = load(dir.path(), &scene_text(&textured(dir.path(), &inline)));
            assert!(!s.materials[0].textures.is_empty(), "{label}");
            let (gpu, pipelines) = common::render_gpu(&ctx, &s);
            let cpu = common::render_cpu(&s);
            assert_eq!(gpu.nonfinite_samples + cpu.nonfinite_samples, 0, "{label}");
            let rmse = brdfwave::metrics::rmse(&gpu.mean, &cpu.mean).unwrap();
            let mean = cpu.mean.mean_luminance();
            println!("{label}: RMSE {rmse:.2e} (mean {mean:.3}), {pipelines:?}");
            assert!(mean > 0.01, "{label}: a black image proves nothing");
            if rmse > 1e-4 * mean.max(1.0) {
                common::save(&format!("texture-{label}-gpu.exr"), &gpu.mean);
                common::save(&format!("texture-{label}-cpu.exr"), &cpu.mean);
                panic!("{label}: GPU and CPU differ, RMSE {rmse:e}");
            }
        }
    }
    common::finish(ctx);
}

/// A sphere's texture turns with the sphere, as Mitsuba's does: the frame its transform gives
/// takes a turned direction back to the one it came from (a mirror too), the GPU renders what
/// the CPU renders, and the image is not the unturned sphere's.
#[test]
fn a_turned_sphere_turns_its_texture() {
    use glam::Vec3;
    let dir = tempfile::tempdir().unwrap();
    write_common(dir.path());
    let with = |transform: &str| {
        let text = scene_text("model = \"lambert\"\nalbedo = { texture = \"ground.png\" }")
            .replace(
                "sphere = { center = [0.0, 0.0, 0.0], radius = 0.8 }\n",
                &format!("sphere = {{ center = [0.0, 0.0, 0.0], radius = 0.8 }}\n{transform}"),
            );
        load(dir.path(), &text)
    };
    let plain = with("");
    assert_eq!(plain.spheres[0].frame, None);
    // (About z by a quarter turn the checkered texture would look the same.)
    let turned = with("transform = { rotate = { axis = [1.0, 0.0, 0.0], angle_deg = 90.0 } }\n");
    let f = turned.spheres[0]
        .frame
        .expect("a turned sphere has a frame");
    // 90° about x takes y to z: the frame takes z back to y.
    assert!((f.to_local(Vec3::Z) - Vec3::Y).length() < 1e-6);
    let mirrored = with(
        "transform = { matrix = [[-1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]] }\n",
    );
    let f = mirrored.spheres[0]
        .frame
        .expect("a mirrored sphere has a frame");
    for d in [
        Vec3::X,
        Vec3::Y,
        Vec3::Z,
        Vec3::new(0.3, -0.5, 0.8).normalize(),
    ] {
        let back = f.to_local(Vec3::new(-d.x, d.y, d.z));
        assert!((back - d).length() < 1e-6, "{d} -> {back}");
    }
    let ctx = common::context();
    let plain_image = common::render_cpu(&plain).mean;
    for (label, s) in [("turned", &turned), ("mirrored", &mirrored)] {
        let (gpu, _) = common::render_gpu(&ctx, s);
        let cpu = common::render_cpu(s);
        let rmse = brdfwave::metrics::rmse(&gpu.mean, &cpu.mean).unwrap();
        assert!(rmse < 1e-5, "{label}: GPU and CPU differ, RMSE {rmse:e}");
        let moved = brdfwave::metrics::rmse(&plain_image, &cpu.mean).unwrap();
        assert!(
            moved > 1e-2,
            "{label}: the texture did not turn (RMSE {moved:e})"
        );
    }
    common::finish(ctx);
}

/// A texture whose texels all equal the material's constant gives the constant material's
/// image: on the CPU bit for bit, on the GPU within rounding (its record's derived words are
/// recomputed in GLSL).
#[test]
fn a_texture_of_one_value_is_the_constant_material() {
    let dir = tempfile::tempdir().unwrap();
    write_common(dir.path());
    imageio::write(
        &dir.path().join("kd.exr"),
        &Image::filled(3, 2, [0.25, 0.5, 0.125]),
    )
    .unwrap();
    let constant = "model = \"ward\"\nkd = [0.25, 0.5, 0.125]\nks = 0.3\nalpha_x = 0.15";
    let tex = "model = \"ward\"\nkd = { texture = \"kd.exr\" }\nks = 0.3\nalpha_x = 0.15";
    let a = load(dir.path(), &scene_text(constant));
    let b = load(dir.path(), &scene_text(tex));
    let bits = |i: &Image| -> Vec<u32> { i.data.iter().flatten().map(|x| x.to_bits()).collect() };
    assert_eq!(
        bits(&common::render_cpu(&a).mean),
        bits(&common::render_cpu(&b).mean)
    );
    let ctx = common::context();
    let (ga, _) = common::render_gpu(&ctx, &a);
    let (gb, _) = common::render_gpu(&ctx, &b);
    common::finish(ctx);
    let rmse = brdfwave::metrics::rmse(&ga.mean, &gb.mean).unwrap();
    assert!(rmse < 1e-6, "GPU: RMSE {rmse:e}");
}

/// Texels outside the parameter's range (here −1, 2 and NaN for `kd` in [0, 1]) are clamped
/// (NaN to the lower end) and counted in one warning naming the field and the file; the
/// material still loads. A scalar parameter with its own range (Ward's α in [0.001, 1]) is
/// clamped into that.
#[test]
fn texels_out_of_range_are_clamped_with_one_warning() {
    let dir = tempfile::tempdir().unwrap();
    write_common(dir.path());
    let mut img = Image::filled(2, 2, [0.5; 3]);
    img.set(0, 0, [-1.0, 0.5, 0.5]);
    img.set(1, 0, [0.5, 2.0, 0.5]);
    img.set(1, 1, [0.5, 0.5, f32::NAN]);
    imageio::write(&dir.path().join("bad.exr"), &img).unwrap();
    imageio::write(&dir.path().join("zero.exr"), &Image::filled(2, 1, [0.0; 3])).unwrap();
    let s = load(
        dir.path(),
        &scene_text("model = \"ward\"\nkd = { texture = \"bad.exr\" }\nks = 0.3\nalpha_x = { texture = \"zero.exr\" }"),
    );
    let warnings: Vec<&String> = s
        .warnings
        .iter()
        .filter(|w| w.contains("clamped"))
        .collect();
    assert_eq!(warnings.len(), 2, "{:?}", s.warnings);
    // In the order of the material's fields (sorted).
    common::assert_mentions(
        warnings[0],
        &[
            "materials.m.alpha_x",
            "zero.exr",
            "2 of the 2x1",
            "[0.001, 1]",
        ],
    );
    common::assert_mentions(
        warnings[1],
        &["materials.m.kd", "bad.exr", "3 of the 2x2 texels", "[0, 1]"],
    );
    let t = &s.materials[0].textures[1].texture;
    assert!(t.path.ends_with("bad.exr"));
    assert_eq!(t.texels[0], [0.0, 0.5, 0.5]);
    assert_eq!(t.texels[1], [0.5, 1.0, 0.5]);
    assert_eq!(t.texels[3], [0.5, 0.5, 0.0]);
    // alpha_y, not given, follows alpha_x's texture.
    let names: Vec<&str> = s.materials[0]
        .textures
        .iter()
        .map(|t| t.param.name)
        .collect();
    assert_eq!(names, ["alpha_x", "kd", "alpha_y"]);
}

/// The error of the scene with `kd = { texture = "<name>", … }` (`extra` inside the table), the
/// file written by `make`.
fn texture_error(name: &str, extra: &str, make: impl FnOnce(&Path)) -> String {
    let dir = tempfile::tempdir().unwrap();
    write_common(dir.path());
    make(&dir.path().join(name));
    let text = scene_text(&format!(
        "model = \"ward\"\nkd = {{ texture = \"{name}\"{extra} }}"
    ));
    let p = dir.path().join("s.toml");
    std::fs::write(&p, text).unwrap();
    match scene::load(&p) {
        Ok(_) => panic!("{name} {extra}: loaded"),
        Err(e) => e.to_string(),
    }
}

/// Missing, truncated, not an image, empty or huge texture files, and bad texture tables: each
/// refused while the scene loads, naming the field (`materials.m.kd`) and the file.
#[test]
fn bad_textures_are_refused_before_rendering() {
    let field = "field 'materials.m.kd'";
    let good = Image::from_fn(4, 4, |x, y| [x as f32 / 4.0, y as f32 / 4.0, 0.5]);
    let e = texture_error("none.png", "", |_| {});
    common::assert_mentions(&e, &["s.toml:", field, "none.png", "No such file"]);
    for ext in ["png", "exr", "pfm", "hdr"] {
        let name = format!("cut.{ext}");
        let e = texture_error(&name, "", |p| {
            match ext {
                "hdr" => imageio::write_hdr(p, &good).unwrap(),
                _ => imageio::write(p, &good).unwrap(),
            }
            let bytes = std::fs::read(p).unwrap();
            std::fs::write(p, &bytes[..bytes.len() / 2]).unwrap();
        });
        common::assert_mentions(&e, &[field, &name]);
    }
    let e = texture_error("notes.png", "", |p| std::fs::write(p, "hello").unwrap());
    common::assert_mentions(&e, &[field, "notes.png", "PNG"]);
    let e = texture_error("empty.pfm", "", |p| {
        std::fs::write(p, "PF\n0 0\n-1\n").unwrap()
    });
    common::assert_mentions(&e, &[field, "empty.pfm", "not a positive integer"]);
    let e = texture_error("huge.pfm", "", |p| {
        std::fs::write(p, "PF\n100000 100000\n-1\n\0\0\0\0").unwrap()
    });
    common::assert_mentions(&e, &[field, "huge.pfm", "100000x100000", "over the limit"]);
    let ok = |p: &Path| imageio::write(p, &good).unwrap();
    let cases = [
        (
            ", wrap = \"tile\"",
            "'wrap' is one of repeat, mirror, clamp",
        ),
        (", filter = 3", "'filter' is one of bilinear, nearest"),
        (", raw = \"yes\"", "'raw' is true or false"),
        (", scale = 2.0", "unknown field 'scale' in a texture"),
        (
            ", to_uv = { scale = [1.0, 2.0, 3.0] }",
            "to_uv: expected an array of 2 numbers",
        ),
        (
            ", to_uv = { matrix = [[1.0, 0.0, 0.0]] }",
            "to_uv: matrix has 2 rows",
        ),
    ];
    for (extra, what) in cases {
        let e = texture_error("t.png", extra, ok);
        common::assert_mentions(&e, &[field, what]);
    }
    // Only colour and number parameters can be textures.
    let dir = tempfile::tempdir().unwrap();
    write_common(dir.path());
    ok(&dir.path().join("t.png"));
    let p = dir.path().join("s.toml");
    std::fs::write(
        &p,
        scene_text("model = \"ward\"\nvariant = { texture = \"t.png\" }"),
    )
    .unwrap();
    let e = scene::load(&p).map(|_| ()).unwrap_err().to_string();
    common::assert_mentions(&e, &["materials.m.variant", "cannot be a texture"]);
}

/// OBJ texture coordinates are flipped to the image's top-down v (as Mitsuba reads OBJ), and
/// `convert` writes them back so that the XML twin reads the same bits.
#[test]
fn obj_texture_coordinates_run_down_the_image() {
    let dir = tempfile::tempdir().unwrap();
    write_common(dir.path());
    let obj: PathBuf = dir.path().join("t.obj");
    std::fs::write(
        &obj,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25 0.125\nvt 0.75 0.125\nvt 0.25 1.0\nf 1/1 2/2 3/3\n",
    )
    .unwrap();
    let text = "[camera]\nposition = [0.3, 0.3, 2.0]\ntarget = [0.3, 0.3, 0.0]\nfov_y = 30.0\n\
        [film]\nwidth = 8\nheight = 8\n[materials.m]\nmodel = \"lambert\"\n\
        albedo = { texture = \"ground.png\" }\n[[shapes]]\nmaterial = \"m\"\nobj = \"t.obj\"\n\
        [environment]\nradiance = 1.0\n";
    let s = load(dir.path(), text);
    let uv = s.attributes_of(0).uv.unwrap();
    assert_eq!(
        uv.map(|t| t.to_array()),
        [[0.25, 0.875], [0.75, 0.875], [0.25, 0.0]]
    );
}

/// A PNG on a number parameter is read as stored (a roughness map's numbers) unless
/// `raw = false`, which decodes the sRGB curve as a colour parameter does by default; a Mitsuba
/// scene's bitmap decodes unless `raw = true` on either kind, as Mitsuba does.
#[test]
fn png_numbers_are_as_stored_unless_raw_is_false() {
    let dir = tempfile::tempdir().unwrap();
    write_common(dir.path());
    image::GrayImage::from_raw(2, 1, vec![128, 64])
        .unwrap()
        .save(dir.path().join("rough.png"))
        .unwrap();
    let stored = [128.0 / 255.0, 64.0 / 255.0];
    let decoded = stored.map(imageio::srgb_to_linear);
    let first_texture = |s: &Scene| {
        let t = &s.materials[0].textures[0].texture;
        [t.texels[0][0], t.texels[1][0]]
    };
    for (raw, want) in [
        ("", stored),
        (", raw = true", stored),
        (", raw = false", decoded),
    ] {
        let m = format!(
            "model = \"ward\"\nkd = 0.5\nks = 0.3\nalpha_x = {{ texture = \"rough.png\"{raw} }}"
        );
        let s = load(dir.path(), &scene_text(&m));
        let got = first_texture(&s);
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-6, "TOML{raw}: {got:?}, want {want:?}");
        }
    }
    for (raw, want) in [
        ("", decoded),
        ("<boolean name=\"raw\" value=\"true\"/>", stored),
    ] {
        let xml = format!(
            "<scene version=\"3.0.0\"><sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/><integer name=\"height\" value=\"8\"/></film></sensor>\
             <emitter type=\"constant\"/><shape type=\"sphere\"><bsdf type=\"roughconductor\"><texture type=\"bitmap\" name=\"alpha\">\
             <string name=\"filename\" value=\"rough.png\"/>{raw}</texture></bsdf></shape></scene>"
        );
        let path = dir.path().join("s.xml");
        std::fs::write(&path, xml).unwrap();
        let s = scene::load(&path).unwrap();
        let got = first_texture(&s);
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-6, "XML {raw}: {got:?}, want {want:?}");
        }
    }
}

/// Radiance files open with "#?" and their writer's name: `#?RGBE` (Mitsuba's) reads as
/// `#?RADIANCE` does; a file without the "#?" is refused. An EXR of one luminance channel `Y`
/// is a grey image.
#[test]
fn radiance_files_of_every_writer_and_grey_exrs_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let img = Image::from_fn(3, 2, |x, y| {
        [0.25 * (x + 1) as f32, 0.5 * (y + 1) as f32, 0.125]
    });
    let radiance = dir.path().join("radiance.hdr");
    imageio::write_hdr(&radiance, &img).unwrap();
    let bytes = std::fs::read(&radiance).unwrap();
    assert!(bytes.starts_with(b"#?RADIANCE\n"));
    let rgbe = dir.path().join("rgbe.hdr");
    std::fs::write(&rgbe, [b"#?RGBE\n", &bytes[11..]].concat()).unwrap();
    let a = imageio::read_stored(&radiance).unwrap().image;
    let b = imageio::read_stored(&rgbe).unwrap().image;
    assert_eq!(a.data, b.data);
    assert_eq!(a.data, img.data, "exact in RGBE");
    let bare = dir.path().join("bare.hdr");
    std::fs::write(&bare, &bytes[11..]).unwrap();
    let e = imageio::read_stored(&bare).unwrap_err().to_string();
    assert!(
        e.contains("bare.hdr") && e.contains("does not begin with '#?'"),
        "{e}"
    );

    let grey = dir.path().join("grey.exr");
    let xz = dir.path().join("xz.exr");
    {
        use exr::prelude::{SpecificChannels, Vec2, WritableImage};
        let channels = SpecificChannels::build()
            .with_channel("Y")
            .with_pixel_fn(|p: Vec2<usize>| (0.25 * (p.x() + 2 * p.y()) as f32,));
        exr::prelude::Image::from_channels((2, 2), channels)
            .write()
            .to_file(&grey)
            .unwrap();
        let channels = SpecificChannels::build()
            .with_channel("X")
            .with_channel("Z")
            .with_pixel_fn(|_: Vec2<usize>| (1.0f32, 2.0f32));
        exr::prelude::Image::from_channels((2, 2), channels)
            .write()
            .to_file(&xz)
            .unwrap();
    }
    let g = imageio::read_stored(&grey).unwrap().image;
    assert_eq!(g.data, [[0.0; 3], [0.25; 3], [0.5; 3], [0.75; 3]]);
    let e = imageio::read_stored(&xz).unwrap_err().to_string();
    assert!(
        e.contains("no R, G, B channels and no Y") && e.contains("X, Z"),
        "{e}"
    );
}
