//! The files the command line writes: missing directories are made, two outputs with one
//! path and unwritable outputs are refused before the work, a plot's format follows its
//! extension, and written files follow the umask.

mod common;

use common::cli::{eval_args, render_args, s, Cli};

use std::path::Path;
#[cfg(unix)]
use std::process::Command;

const CLI: Cli = Cli {
    tag: "cli-outputs",
    own_cache: false,
    env_remove: &[],
};

/// Writes a directions file with one pair at `dirs`; returns the `brdf eval` arguments that
/// evaluate a Lambertian on it into `csv`.
fn lambert_eval_args<'a>(dirs: &'a Path, csv: &'a Path) -> Vec<&'a str> {
    std::fs::write(dirs, "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n").unwrap();
    eval_args(r#"model = "lambert""#, s(dirs), &["--out", s(csv)])
}

/// The `brdf plot` arguments that plot a Lambertian at θi = 10° into `plot`.
fn lambert_plot_args(plot: &Path) -> [&str; 8] {
    [
        "brdf",
        "plot",
        "--material",
        r#"model = "lambert""#,
        "--theta-i",
        "10",
        "--out",
        s(plot),
    ]
}

#[test]
fn every_output_gets_its_missing_directories() {
    let d = CLI.fresh_dir("mkdirs");
    let png = d.join("a/b/img.png");
    let exr = d.join("c/img.exr");
    let var = d.join("d/var.exr");
    let stdout = CLI.ok(&render_args(&[
        "--out",
        s(&png),
        "--out",
        s(&exr),
        "--variance-out",
        s(&var),
    ]));
    assert!(png.is_file() && exr.is_file() && var.is_file());
    // The variance output is listed with the others.
    assert!(
        stdout.contains(&format!("wrote          {}", var.display())),
        "{stdout}"
    );
    let map = d.join("e/map.png");
    CLI.ok(&["diff", s(&exr), s(&exr), "--error-map", s(&map)]);
    assert!(map.is_file());
    // The error map may not overwrite an input.
    let before = std::fs::read(&png).unwrap();
    CLI.fails_naming(
        &["diff", s(&png), s(&exr), "--error-map", s(&png)],
        "TEST image",
    );
    assert_eq!(std::fs::read(&png).unwrap(), before);
    let dirs = d.join("dirs.csv");
    let csv = d.join("f/eval.csv");
    CLI.ok(&lambert_eval_args(&dirs, &csv));
    assert!(csv.is_file());
    let plot = d.join("g/plot.png");
    CLI.ok(&lambert_plot_args(&plot));
    assert!(plot.is_file());
}

#[test]
fn two_outputs_with_the_same_path_are_refused() {
    let d = CLI.fresh_dir("same");
    let same = d.join("same.exr");
    let also = d.join("sub/../same.exr");
    let args = render_args(&["--out", s(&same), "--variance-out", s(&also)]);
    CLI.fails_naming_all(&args, &["--out", "--variance-out", "same file"]);
    assert!(!same.exists(), "nothing is rendered or written");
    let a = d.join("x.png");
    CLI.fails_naming(
        &render_args(&["--out", s(&a), "--out", &format!("{}/./x.png", d.display())]),
        "same file",
    );
    #[cfg(unix)]
    {
        // A directory reached through a symbolic link is the same directory.
        std::os::unix::fs::symlink(&d, d.join("link")).unwrap();
        let link = d.join("link/x.png");
        let args = render_args(&["--out", s(&a), "--out", s(&link)]);
        CLI.fails_naming(&args, "same file");
    }
}

#[test]
fn unwritable_outputs_are_found_before_the_render() {
    let d = CLI.fresh_dir("unwritable");
    let good = d.join("good.png");
    // /sys refuses new files even to root; the good output listed first is not written
    // either, which shows that the check ran before the render, not after it.
    let args = render_args(&["--out", s(&good), "--out", "/sys/brdfwave-x.png"]);
    CLI.fails_naming_all(&args, &["/sys/brdfwave-x.png", "cannot"]);
    assert!(!good.exists());
    // An existing directory as output.
    let dir_png = d.join("dir.png");
    std::fs::create_dir(&dir_png).unwrap();
    let args = render_args(&["--out", s(&good), "--out", s(&dir_png)]);
    CLI.fails_naming_all(&args, &["dir.png", "is a directory"]);
    std::fs::remove_dir(&dir_png).unwrap();
    // A file where a directory must be created.
    std::fs::write(d.join("plain"), b"x").unwrap();
    let in_plain = d.join("plain/x.png");
    let args = render_args(&["--out", s(&in_plain)]);
    CLI.fails_naming_all(&args, &["plain", "cannot create the directory"]);
    // An unknown extension, before the render too.
    let jpg = d.join("x.jpg");
    let args = render_args(&["--out", s(&good), "--out", s(&jpg)]);
    CLI.fails_naming_all(&args, &["x.jpg", "extension"]);
    assert!(!good.exists());
    // No temporary files are left by the checks.
    let left: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left, vec![std::ffi::OsString::from("plain")], "{left:?}");
}

#[test]
fn brdf_plot_honours_the_extension() {
    let d = CLI.fresh_dir("plot-ext");
    let material = r#"model = "phong", ks = 0.8, kd = 0, exponent = 20"#;
    let plot = |out: &Path| {
        CLI.run(&[
            "brdf",
            "plot",
            "--material",
            material,
            "--theta-i",
            "40",
            "--out",
            s(out),
        ])
    };
    let png = d.join("lobe.png");
    let exr = d.join("lobe.exr");
    assert!(plot(&png).status.success());
    assert!(plot(&exr).status.success());
    // The EXR is an OpenEXR file holding the PNG's colours, linear.
    let bytes = std::fs::read(&exr).unwrap();
    assert_eq!(
        &bytes[..4],
        &[0x76, 0x2f, 0x31, 0x01],
        "OpenEXR magic number"
    );
    let a = brdfwave::imageio::read(&png).unwrap();
    let b = brdfwave::imageio::read(&exr).unwrap();
    assert_eq!((b.width, b.height), (960, 600));
    let max_diff = a
        .data
        .iter()
        .zip(&b.data)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs()))
        .fold(0f32, f32::max);
    assert!(max_diff < 1e-6, "{max_diff}");
    let jpg = d.join("lobe.jpg");
    let out = plot(&jpg);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("lobe.jpg") && err.contains("extension"),
        "{err}"
    );
    assert!(!jpg.exists());
}

/// Runs brdfwave under `umask 027`.
#[cfg(unix)]
fn ok_with_umask(args: &[&str]) {
    common::run_ok(
        Command::new("sh")
            .arg("-c")
            .arg("umask 027 && exec \"$0\" \"$@\"")
            .arg(env!("CARGO_BIN_EXE_brdfwave"))
            .args(args)
            .current_dir(common::repo()),
    );
}

#[cfg(unix)]
#[test]
fn written_files_follow_the_umask() {
    use std::os::unix::fs::PermissionsExt;
    let d = CLI.fresh_dir("umask");
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    let (png, exr) = (d.join("r.png"), d.join("r.exr"));
    ok_with_umask(&render_args(&["--out", s(&png), "--out", s(&exr)]));
    let map = d.join("map.png");
    ok_with_umask(&["diff", s(&exr), s(&exr), "--error-map", s(&map)]);
    let dirs = d.join("dirs.csv");
    let csv = d.join("eval.csv");
    ok_with_umask(&lambert_eval_args(&dirs, &csv));
    let plot = d.join("plot.png");
    ok_with_umask(&lambert_plot_args(&plot));
    for p in [&png, &exr, &map, &csv, &plot] {
        assert_eq!(mode(p), 0o640, "{}: 0666 & !027 expected", p.display());
    }
}

/// A small TOML scene of one OBJ mesh `mesh` (relative to the scene), lit by the environment.
#[cfg(unix)]
fn obj_scene(d: &Path, mesh: &str) -> std::path::PathBuf {
    let p = d.join("conv.toml");
    std::fs::write(
        &p,
        format!(
            "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\nfov_y = 40\n[film]\nwidth = 8\n\
             height = 8\n[environment]\nradiance = 1\n[materials.m]\nmodel = \"lambert\"\n\
             [[shapes]]\nmaterial = \"m\"\nobj = \"{mesh}\"\n"
        ),
    )
    .unwrap();
    p
}

/// No output replaces a file the command read, whichever reader read it and however the
/// output names it: `convert` over the scene's own OBJ mesh and over a file the scene includes,
/// `brdf merl` over the table its material reads, `diff --error-map` through a link to its TEST
/// image, `render --out` over the scene through a link. Each input is left as it was.
#[cfg(unix)]
#[test]
fn no_output_replaces_a_file_the_command_read() {
    let d = CLI.fresh_dir("inputs");
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    std::fs::create_dir(d.join("conv-meshes")).unwrap();
    let mesh = d.join("conv-meshes/mesh-0.obj");
    std::fs::write(&mesh, tri).unwrap();
    let scene = obj_scene(&d, "conv-meshes/mesh-0.obj");
    let xml = d.join("conv.xml");
    CLI.fails_naming_all(
        &["convert", s(&scene), "--to", "mitsuba", s(&xml)],
        &[
            "mesh-0.obj",
            "is also an input of this command (read as the OBJ mesh)",
        ],
    );
    assert_eq!(std::fs::read_to_string(&mesh).unwrap(), tri);
    assert!(!xml.exists());

    let inc = d.join("inc.xml");
    let inc_text = "<scene version=\"3.0.0\"><bsdf type=\"diffuse\" id=\"w\"/></scene>\n";
    std::fs::write(&inc, inc_text).unwrap();
    let main = d.join("main.xml");
    std::fs::write(
        &main,
        "<scene version=\"3.0.0\">\n<include filename=\"inc.xml\"/>\n<sensor type=\"perspective\">\
         <float name=\"fov\" value=\"40\"/></sensor>\n<shape type=\"sphere\"><ref id=\"w\"/></shape>\n</scene>\n",
    )
    .unwrap();
    CLI.fails_naming_all(
        &["convert", s(&main), "--to", "mitsuba", s(&inc)],
        &["inc.xml", "read as the included scene file"],
    );
    assert_eq!(std::fs::read_to_string(&inc).unwrap(), inc_text);

    let table = d.join("t.binary");
    CLI.ok(&[
        "brdf",
        "merl",
        "--material",
        r#"model = "lambert""#,
        "--out",
        s(&table),
    ]);
    let before = std::fs::read(&table).unwrap();
    let material = format!("model = \"measured\", file = \"{}\"", s(&table));
    CLI.fails_naming_all(
        &["brdf", "merl", "--material", &material, "--out", s(&table)],
        &["t.binary", "read as the measured table"],
    );
    assert_eq!(std::fs::read(&table).unwrap(), before);

    let test = d.join("test.pfm");
    let reference = d.join("ref.pfm");
    for (p, seed) in [(&test, "1"), (&reference, "2")] {
        CLI.ok(&[
            "render",
            s(&scene),
            "--backend",
            "cpu",
            "--spp",
            "1",
            "--seed",
            seed,
            "--quiet",
            "--out",
            s(p),
        ]);
    }
    let before = std::fs::read(&test).unwrap();
    let link = d.join("map.pfm");
    std::os::unix::fs::symlink(&test, &link).unwrap();
    CLI.fails_naming_all(
        &["diff", s(&test), s(&reference), "--error-map", s(&link)],
        &["map.pfm"],
    );
    assert_eq!(
        std::fs::read(&test).unwrap(),
        before,
        "the TEST image was replaced"
    );

    let scene_link = d.join("scene.pfm");
    std::os::unix::fs::symlink(&scene, &scene_link).unwrap();
    let scene_text = std::fs::read(&scene).unwrap();
    CLI.fails_naming_all(
        &[
            "render",
            s(&scene),
            "--backend",
            "cpu",
            "--out",
            s(&scene_link),
        ],
        &["scene.pfm"],
    );
    assert_eq!(std::fs::read(&scene).unwrap(), scene_text);
}

/// An output that is a symbolic link is written through it: the file it names gets the image
/// and the link stays a link (before, the link was replaced and its target left stale); two
/// outputs that name one file through a link are one output, refused.
#[cfg(unix)]
#[test]
fn links_at_outputs_are_written_through() {
    let d = CLI.fresh_dir("links");
    std::fs::create_dir(d.join("store")).unwrap();
    let target = d.join("store/t.pfm");
    std::fs::write(&target, b"stale").unwrap();
    let link = d.join("link.pfm");
    std::os::unix::fs::symlink("store/t.pfm", &link).unwrap();
    CLI.ok(&render_args(&["--out", s(&link)]));
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    let img = brdfwave::imageio::read(&target).unwrap();
    assert!(img.width > 0);
    // No temporary file was left beside the link or the target.
    assert_eq!(std::fs::read_dir(&d).unwrap().count(), 2);
    assert_eq!(std::fs::read_dir(d.join("store")).unwrap().count(), 1);
    for (a, b) in [(&target, &link), (&link, &target)] {
        CLI.fails_naming_all(
            &render_args(&["--out", s(a), "--out", s(b)]),
            &["same file", "t.pfm"],
        );
    }
    // A chain of links, and a variance output through one.
    let link2 = d.join("link2.exr");
    std::os::unix::fs::symlink(&link, &link2).unwrap();
    CLI.fails_naming(
        &render_args(&["--out", s(&target), "--variance-out", s(&link2)]),
        "same file",
    );
}
