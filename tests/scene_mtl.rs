//! OBJ shapes with `mtl = true`: the MTL materials of the faces become Lambert or normalised
//! Blinn–Phong materials (by `illum`) and emitters (`Ke`), equal to the same materials written
//! in TOML; bad MTL content is an error naming the MTL file, its line and the material;
//! without `mtl` nothing changes.

mod common;
use brdfwave::metrics;
use brdfwave::scene::{load, Scene};
use common::scene_file::assert_warned;
use common::*;
use glam::Vec3;
use std::path::Path;

const OBJ: &str = "mtllib lib.mtl\nv -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nv -0.3 1 0.3\nv 0.3 1 0.3\nv 0.3 1 -0.3\n\
    v -0.3 1 -0.3\nusemtl matte\nf 1 4 3\nusemtl shiny\nf 1 3 2\nusemtl lamp\nf 5 6 7 8\n";

const MTL: &str =
    "newmtl matte\nKd 0.7 0.6 0.5\nillum 1\n\nnewmtl shiny\nKa 0.1 0.1 0.1\nKd 0.4 0.4 0.3\n\
    Ks 0.3 0.3 0.3\nNs 40\nillum 2\nmap_Kd wood.png\n\nnewmtl lamp\nKd 0 0 0\nKe 5 4 3\n";

fn scene_with(files: &[(&str, &str)], shape: &str) -> Result<Scene, String> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("m")).unwrap();
    for (name, content) in files {
        std::fs::write(dir.path().join("m").join(name), content).unwrap();
    }
    let src = format!(
        "[camera]\nposition = [0, 3, 3]\ntarget = [0, 0, 0]\nfov_y = 50\n[film]\nwidth = 16\n\
         height = 16\n[integrator]\nspp = 4\nmax_depth = 3\n[materials.m]\nmodel = \"lambert\"\n\
         [[shapes]]\nmaterial = \"m\"\nobj = \"m/a.obj\"\n{shape}\n"
    );
    std::fs::write(dir.path().join("s.toml"), src).unwrap();
    load(&dir.path().join("s.toml")).map_err(|e| e.to_string())
}

/// The material written in TOML, parsed by the model.
fn toml_material(fields: &str) -> brdfwave::brdf::Material {
    let src = format!(
        "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\nfov_y = 30\n[film]\nwidth = 4\nheight = 4\n\
         [environment]\nradiance = 1\n[materials.x]\n{fields}\n[[shapes]]\nmaterial = \"x\"\n\
         sphere = {{ center = [0, 0, 0], radius = 1 }}\n"
    );
    let s = brdfwave::scene::load_str(&src, Path::new("x.toml")).unwrap();
    s.materials[0].clone()
}

#[test]
fn mtl_materials_become_models_and_emitters() {
    let s = scene_with(&[("a.obj", OBJ), ("lib.mtl", MTL)], "mtl = true").unwrap();
    assert_eq!(
        s.material_names,
        ["m", "m/a.obj:matte", "m/a.obj:shiny", "m/a.obj:lamp"]
    );
    // The shape's own material stays in use (for faces without usemtl): one warning only.
    scene_file::assert_one_warning(&s, "material 'm/a.obj:shiny': ignored: Ka, texture maps");
    let by_name = |n: &str| s.material_names.iter().position(|x| x == n).unwrap() as u32;
    let mats: Vec<u32> = s.triangles.iter().map(|t| t.material).collect();
    assert_eq!(
        mats,
        [
            by_name("m/a.obj:matte"),
            by_name("m/a.obj:shiny"),
            by_name("m/a.obj:lamp"),
            by_name("m/a.obj:lamp")
        ]
    );
    assert_eq!(s.emitters.len(), 1);
    assert_eq!(s.emitters[0].radiance, Vec3::new(5.0, 4.0, 3.0));
    assert!(s.triangles[..2].iter().all(|t| t.emitter.is_none()));
    assert!(s.triangles[2..].iter().all(|t| t.emitter == Some(0)));
    // The same materials written in TOML evaluate the same.
    let want = [
        ("m/a.obj:matte", "model = \"lambert\"\nalbedo = [0.7, 0.6, 0.5]"),
        ("m/a.obj:shiny", "model = \"blinn_phong\"\nform = \"normalized\"\nkd = [0.4, 0.4, 0.3]\nks = 0.3\nexponent = 40"),
        ("m/a.obj:lamp", "model = \"blinn_phong\"\nform = \"normalized\"\nkd = 0\nks = 0\nexponent = 0"),
    ];
    let (wi, wo) = (
        Vec3::new(0.3, 0.1, 0.9).normalize(),
        Vec3::new(-0.2, 0.3, 0.8).normalize(),
    );
    for (name, fields) in want {
        let got = &s.materials[by_name(name) as usize];
        let t = toml_material(fields);
        assert_eq!(got.model_name(), t.model_name(), "{name}");
        assert_eq!(got.brdf.eval(wi, wo), t.brdf.eval(wi, wo), "{name}");
    }
    // Both backends render it alike (the MTL materials get their shading pipelines).
    let ctx = context();
    let (gpu, _) = render_gpu(&ctx, &s);
    finish(ctx);
    let cpu = render_cpu(&s);
    let agree = metrics::fraction_within(&gpu.mean, &cpu.mean, 1e-3, 1e-4).unwrap();
    assert!(agree.channel_fraction >= 0.99, "{agree}");
    assert!(cpu.mean.mean().iter().all(|&c| c > 0.01), "a lit image");
}

/// `convert --brdfwave-plugins` writes the MTL materials too (Blinn–Phong has no Mitsuba twin),
/// with the parameters they were made with: the XML reads back to the same materials.
#[test]
fn mtl_materials_convert_with_their_parameters() {
    use brdfwave::scene::mitsuba::write::{to_mitsuba, Options};
    let s = scene_with(&[("a.obj", OBJ), ("lib.mtl", MTL)], "mtl = true").unwrap();
    let Err(e) = to_mitsuba(&s, "x-meshes", Options::default()) else {
        panic!("Blinn–Phong converted without --brdfwave-plugins");
    };
    assert!(e.contains("--brdfwave-plugins"), "{e}");
    let opts = Options {
        brdfwave_plugins: true,
        ..Options::default()
    };
    let c = to_mitsuba(&s, "x-meshes", opts).unwrap();
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("x-meshes")).unwrap();
    for (file, text) in &c.meshes {
        std::fs::write(dir.path().join(file), text).unwrap();
    }
    std::fs::write(dir.path().join("x.xml"), &c.xml).unwrap();
    let back = load(&dir.path().join("x.xml")).unwrap();
    let (wi, wo) = (
        Vec3::new(0.3, 0.1, 0.9).normalize(),
        Vec3::new(-0.2, 0.3, 0.8).normalize(),
    );
    for name in ["m/a.obj:matte", "m/a.obj:shiny", "m/a.obj:lamp"] {
        let at = |sc: &Scene| sc.material_names.iter().position(|x| x == name);
        let (a, b) = (at(&s).unwrap(), at(&back).expect(name));
        let (a, b) = (&s.materials[a], &back.materials[b]);
        assert_eq!(a.model_name(), b.model_name(), "{name}");
        assert_eq!(a.brdf.eval(wi, wo), b.brdf.eval(wi, wo), "{name}");
    }
}

#[test]
fn without_mtl_the_faces_keep_the_shape_material() {
    let s = scene_with(&[("a.obj", OBJ), ("lib.mtl", MTL)], "").unwrap();
    assert_eq!(s.material_names, ["m"]);
    assert!(s
        .triangles
        .iter()
        .all(|t| t.material == 0 && t.emitter.is_none()));
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("MTL materials; they are ignored") && w.contains("mtl = true")),
        "{:?}",
        s.warnings
    );
}

/// OBJ statements as exporters write them read as the plain file reads: `usemtl` and `mtllib`
/// indented, after a tab, a library named after the first `usemtl`, CRLF lines; a vertex weight
/// `w` ignored (Mitsuba and Blender read x y z as written) with a warning naming its line; `vt`
/// of one number; vertex colours on only some vertices. A bare `usemtl` is an error naming its
/// line. Statements of the library that change the picture and are not read are named.
#[test]
fn obj_statements_as_exporters_write_them() {
    let plain = scene_with(&[("a.obj", OBJ), ("lib.mtl", MTL)], "mtl = true").unwrap();
    let awkward = "v -1 0 -1 1\r\nv 1 0 -1 2\r\nv 1 0 1 1 0 0\r\nv -1 0 1\r\nv -0.3 1 0.3\r\n\
        v 0.3 1 0.3\r\nv 0.3 1 -0.3\r\nv -0.3 1 -0.3\r\nvt 0.5\r\n  usemtl matte\r\nmtllib\tlib.mtl\r\n\
        f 1 4 3\r\nusemtl\tshiny\r\nf 1 3 2\r\n\tusemtl   lamp\r\nf 5 6 7 8\r\n";
    let s = scene_with(&[("a.obj", awkward), ("lib.mtl", MTL)], "mtl = true").unwrap();
    assert_eq!(s.material_names, plain.material_names);
    let mats = |s: &Scene| {
        s.triangles
            .iter()
            .map(|t| (t.material, t.emitter))
            .collect::<Vec<_>>()
    };
    assert_eq!(mats(&s), mats(&plain));
    let verts = |s: &Scene| s.triangles.iter().map(|t| t.v).collect::<Vec<_>>();
    assert_eq!(
        verts(&s),
        verts(&plain),
        "v 1 0 -1 2 is (1, 0, -1), not divided by w"
    );
    assert_warned(&s, "a.obj', line 2: the vertex weight w = 2 is ignored");
    assert!(
        !s.warnings.iter().any(|w| w.contains("line 1:")),
        "{:?}",
        s.warnings
    );

    let bare = OBJ.replace("usemtl shiny", "usemtl");
    let e = scene_with(&[("a.obj", &bare), ("lib.mtl", MTL)], "mtl = true").unwrap_err();
    assert!(
        e.contains("a.obj', line 12: usemtl needs a material name"),
        "{e}"
    );

    let mtl = MTL.replace(
        "illum 1\n",
        "illum 1\nTr 0.5\nmap_Ke glow.png\nnorm n.png\nPr 0.4\n",
    );
    let s = scene_with(&[("a.obj", OBJ), ("lib.mtl", &mtl)], "mtl = true").unwrap();
    assert_warned(
        &s,
        "material 'm/a.obj:matte': ignored: d/Tr (transparency), texture maps (map_Ke, norm), physically based statements (Pr)",
    );
}

/// Bad MTL content is an error naming the MTL file and its line (not the scene's line, not
/// tobj's "material parse error"), numbers as written (never `inf`); a library that is not one,
/// or not a regular file, is refused; a `usemtl` of a material no library defines, and an
/// unknown statement, are warned about.
#[test]
fn bad_mtl_content_is_located() {
    let lib_line =
        |mtl: &str, needle: &str| 1 + mtl[..mtl.find(needle).unwrap()].matches('\n').count();
    // The model's range check: at the MTL file and the line of its Kd.
    let bad = MTL.replace("Kd 0.7 0.6 0.5", "Kd 1.5 0.6 0.5");
    let e = scene_with(&[("a.obj", OBJ), ("lib.mtl", &bad)], "mtl = true").unwrap_err();
    let at = format!(
        "lib.mtl:{}: material 'm/a.obj:matte', field 'albedo'",
        lib_line(&bad, "Kd 1.5")
    );
    assert!(e.contains(&at) && e.contains("out of range"), "{e}");
    let bad = MTL.replace("Ks 0.3 0.3 0.3", "Ks 0.3 2 0.3");
    let e = scene_with(&[("a.obj", OBJ), ("lib.mtl", &bad)], "mtl = true").unwrap_err();
    let at = format!(
        "lib.mtl:{}: material 'm/a.obj:shiny', field 'ks'",
        lib_line(&bad, "Ks 0.3 2")
    );
    assert!(e.contains(&at), "{e}");
    // The line checks: file, line, the statement and the number as written.
    for (from, to, what) in [
        (
            "Ke 5 4 3",
            "Ke 1e39 4 3",
            "Ke: '1e39' is out of the single-precision range",
        ),
        (
            "Ke 5 4 3",
            "Ke 5 -4e40 3",
            "Ke: '-4e40' is out of the single-precision range",
        ),
        (
            "Ns 40",
            "Ns 1e300",
            "Ns: '1e300' is out of the single-precision range",
        ),
        ("Ke 5 4 3", "Ke nan 4 3", "Ke: 'nan' is not a finite number"),
        (
            "Kd 0.7 0.6 0.5",
            "Kd 0.7",
            "Kd needs 3 numbers (r g b), found 1",
        ),
        (
            "Kd 0.7 0.6 0.5",
            "Kd 0.7 0.6 0.5 0.4",
            "Kd needs 3 numbers (r g b), found 4",
        ),
        (
            "Kd 0.7 0.6 0.5",
            "Kd spectral wood.spd",
            "Kd spectral: only RGB colours",
        ),
        ("Kd 0.7 0.6 0.5", "Kd 0.7 x 0.5", "Kd: 'x' is not a number"),
        (
            "illum 2",
            "illum 99",
            "illum needs a whole number from 0 to 10, found '99'",
        ),
        ("Ns 40", "Ns", "Ns needs 1 number, found 0"),
    ] {
        let bad = MTL.replace(from, to);
        let e = scene_with(&[("a.obj", OBJ), ("lib.mtl", &bad)], "mtl = true").unwrap_err();
        let at = "lib.mtl' (mtllib of OBJ file '";
        let line = format!("line {}: {what}", lib_line(&bad, to));
        assert!(
            e.contains("field 'shapes[0].obj'") && e.contains(at) && e.contains(&line),
            "{to}: {e}"
        );
        assert!(!e.contains("inf") || to.contains("nan"), "{to}: {e}");
    }
    let neg = MTL.replace("Ke 5 4 3", "Ke 5 -4 3");
    let e = scene_with(&[("a.obj", OBJ), ("lib.mtl", &neg)], "mtl = true").unwrap_err();
    let at = format!(
        "lib.mtl', line {}: material 'm/a.obj:lamp': Ke [5, -4, 3] must be >= 0",
        lib_line(&neg, "Ke 5 -4")
    );
    assert!(e.contains(&at), "{e}");
    // A library that cannot be read, is not a regular file, is not text or is not MTL at all.
    let e = scene_with(&[("a.obj", OBJ)], "mtl = true").unwrap_err();
    assert!(
        e.contains("field 'shapes[0].obj'")
            && e.contains("OBJ file")
            && e.contains("line 1: cannot read the MTL library")
            && e.contains("lib.mtl"),
        "{e}"
    );
    for (lib, what) in [
        ("/dev/zero", "is a character device, not a regular file"),
        ("/", "is a directory, not a regular file"),
    ] {
        let obj = OBJ.replace("mtllib lib.mtl", &format!("mtllib {lib}"));
        let e = scene_with(&[("a.obj", &obj)], "mtl = true").unwrap_err();
        assert!(
            e.contains("line 1: cannot read the MTL library") && e.contains(what),
            "{e}"
        );
    }
    let passwd = "root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1::/usr/sbin:/usr/sbin/nologin\n";
    let e = scene_with(&[("a.obj", OBJ), ("lib.mtl", passwd)], "mtl = true").unwrap_err();
    assert!(
        e.contains("line 1: no material (newmtl): this is not an MTL library")
            && e.contains("'root:x:0:0"),
        "{e}"
    );
    let e = scene_with(
        &[("a.obj", OBJ), ("lib.mtl", "# only a comment\n")],
        "mtl = true",
    )
    .unwrap_err();
    assert!(e.contains("this is not an MTL library"), "{e}");
    let latin1 = String::from_utf8_lossy(b"newmtl matte\nKd 0.7 0.6 0.5\n").into_owned();
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("m")).unwrap();
    let mut bytes = latin1.into_bytes();
    bytes.extend_from_slice(b"# caf\xe9\n");
    std::fs::write(dir.path().join("m/lib.mtl"), bytes).unwrap();
    let e = scene_with_files_in(&dir, &[("a.obj", OBJ)], "mtl = true").unwrap_err();
    assert!(e.contains("line 3, column 6") && e.contains("0xe9"), "{e}");
    // Warnings: a usemtl no library defines (its faces keep the shape's material), and an
    // unknown statement, each with its line.
    let obj = OBJ.replace("usemtl shiny", "usemtl glossy");
    let s = scene_with(&[("a.obj", &obj), ("lib.mtl", MTL)], "mtl = true").unwrap();
    let line = lib_line(&obj, "usemtl glossy");
    assert_warned(
        &s,
        &format!("line {line}: usemtl 'glossy': no library defines it"),
    );
    assert!(s.triangles.iter().any(|t| t.material == 0));
    let obj = OBJ.replace("mtllib lib.mtl\n", "");
    let s = scene_with(&[("a.obj", &obj)], "mtl = true").unwrap();
    assert_warned(&s, "usemtl 'matte': the file names no MTL library");
    let odd = MTL.replace("illum 1\n", "illum 1\nfrobnicate 3\n");
    let s = scene_with(&[("a.obj", OBJ), ("lib.mtl", &odd)], "mtl = true").unwrap();
    assert_warned(
        &s,
        &format!(
            "line {}: unknown statement 'frobnicate'",
            lib_line(&odd, "frob")
        ),
    );
    let e = scene_with(&[("a.obj", OBJ)], "mtl = 1").unwrap_err();
    assert!(e.contains("shapes[0].mtl"), "{e}");
}

/// [`scene_with`] in the folder `dir` (whose `m/` may hold files already).
fn scene_with_files_in(
    dir: &tempfile::TempDir,
    files: &[(&str, &str)],
    shape: &str,
) -> Result<Scene, String> {
    for (name, content) in files {
        std::fs::write(dir.path().join("m").join(name), content).unwrap();
    }
    let src = format!(
        "[camera]\nposition = [0, 3, 3]\ntarget = [0, 0, 0]\nfov_y = 50\n[film]\nwidth = 16\n\
         height = 16\n[materials.m]\nmodel = \"lambert\"\n[[shapes]]\nmaterial = \"m\"\n\
         obj = \"m/a.obj\"\n{shape}\n"
    );
    std::fs::write(dir.path().join("s.toml"), src).unwrap();
    load(&dir.path().join("s.toml")).map_err(|e| e.to_string())
}
