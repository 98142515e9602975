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
