//! The command line as a user runs it: the `brdfwave` binary in a subprocess. Checks the
//! `--json` summary fields the issues require, that bad input gives an error naming the file and
//! the field or line (exit status 1, never a panic), and that the brdf tools write what they say.

mod common;

use common::cli::{s, Cli};

use std::path::{Path, PathBuf};
use std::process::Command;

const CLI: Cli = Cli {
    tag: "cli",
    own_cache: false,
    env_remove: &[],
};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_brdfwave"))
}
fn ok(args: &[&str]) -> String {
    let out = CLI.run(args);
    assert!(
        out.status.success(),
        "brdfwave {args:?} failed ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("utf-8 stdout")
}

/// Runs a command that must fail; returns its stderr.
fn fails(args: &[&str]) -> String {
    let out = CLI.run(args);
    assert_eq!(
        out.status.code(),
        Some(1),
        "brdfwave {args:?} should fail with status 1; stdout:\n{}\nstderr:\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Runs a command that must fail with a message naming `needle`; returns its stderr.
#[track_caller]
fn fails_naming(args: &[&str], needle: &str) -> String {
    let err = fails(args);
    assert!(err.contains(needle), "{err}");
    err
}

/// `brdf eval` of `material` on the directions file `dirs`, then `extra`.
fn eval_args<'a>(material: &'a str, dirs: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec!["brdf", "eval", "--material", material, "--dirs", dirs];
    a.extend_from_slice(extra);
    a
}

#[test]
fn render_json_summary_on_both_backends() {
    let mut images = Vec::new();
    for backend in ["gpu", "cpu"] {
        let png = CLI.tmp(&format!("cornell-{backend}.png"));
        let exr = CLI.tmp(&format!("cornell-{backend}.exr"));
        let stdout = ok(&[
            "render",
            "scenes/cornell-box.toml",
            "--backend",
            backend,
            "--res",
            "32x32",
            "--spp",
            "4",
            "--max-depth",
            "5",
            "--seed",
            "3",
            "--out",
            s(&png),
            "--out",
            s(&exr),
            "--validation",
            "--json",
        ]);
        let j: serde_json::Value = serde_json::from_str(stdout.trim())
            .unwrap_or_else(|e| panic!("--json prints one JSON object ({e}):\n{stdout}"));
        for field in [
            "backend",
            "device",
            "width",
            "height",
            "spp",
            "max_depth",
            "seconds_setup",
            "seconds_render",
            "paths_per_second",
            "rays_per_second",
            "nonfinite_samples",
        ] {
            assert!(j.get(field).is_some(), "{backend}: no field {field} in {j}");
        }
        assert_eq!(j["backend"], backend);
        assert_eq!(j["width"], 32);
        assert_eq!(j["height"], 32);
        assert_eq!(j["spp"], 4);
        assert_eq!(j["max_depth"], 5);
        assert_eq!(j["nonfinite_samples"], 0);
        let stages: Vec<&str> = j["nonfinite_by_stage"]
            .as_array()
            .expect("nonfinite_by_stage")
            .iter()
            .map(|e| e["stage"].as_str().unwrap())
            .collect();
        assert_eq!(
            stages,
            ["extend", "shade_lambert", "accumulate"],
            "{backend}"
        );
        assert!(j["paths_per_second"].as_f64().unwrap() > 0.0);
        assert!(j["rays_per_second"].as_f64().unwrap() > j["paths_per_second"].as_f64().unwrap());
        if backend == "gpu" {
            // The Cornell box is all Lambert: extend shades in place with the Lambert model, and
            // there is no other shading pipeline.
            let pipes: Vec<&str> = j["pipelines"]
                .as_array()
                .expect("pipelines list")
                .iter()
                .map(|p| p.as_str().unwrap())
                .collect();
            assert!(pipes.contains(&"extend_shade_lambert"), "{pipes:?}");
            assert!(
                !pipes
                    .iter()
                    .any(|p| p.contains("shade_") && *p != "extend_shade_lambert"),
                "{pipes:?}"
            );
            assert!(j["seconds_shader_compile"].as_f64().is_some());
            // 32×32 pixels × 4 samples fit in one wave.
            assert_eq!(j["wave_paths"], 4096);
            assert!(j["seconds_pipeline_create"].as_f64().is_some());
        }
        assert!(png.exists() && exr.exists());
        images.push(exr);
    }
    // Same seed on both backends: `diff` reports a small error and writes the error map.
    let map = CLI.tmp("cornell-error.png");
    let stdout = ok(&[
        "diff",
        s(&images[0]),
        s(&images[1]),
        "--error-map",
        s(&map),
        "--json",
    ]);
    let j: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    let relmse = j["relmse"].as_f64().unwrap();
    assert!(relmse < 1e-4, "GPU vs CPU same seed relMSE {relmse}");
    assert!(j["flip_mean"].as_f64().unwrap() < 1e-2, "{j}");
    assert!(map.exists());
}

/// `--integrator auto` (the default) takes the megakernel for a wave of at most 2048 paths and
/// the wavefront above; whichever it takes, the image is the explicit integrator's, bit for bit.
#[test]
fn auto_integrator_takes_the_megakernel_for_small_waves_only() {
    let render = |res: &str, spp: &str, integrator: &str, out: &Path| -> serde_json::Value {
        let stdout = ok(&[
            "render",
            "scenes/cornell-box-glossy.toml",
            "--res",
            res,
            "--spp",
            spp,
            "--integrator",
            integrator,
            "--out",
            s(out),
            "--json",
        ]);
        serde_json::from_str(stdout.trim()).unwrap()
    };
    // 16×16 pixels × 8 samples = 2048 paths in one wave; 32×32 × 2 = 2048 too; 2049+ is
    // the wavefront's.
    for (res, spp, wave, chosen) in [
        ("16x16", "8", 2048, "megakernel"),
        ("33x32", "2", 2112, "wavefront"),
    ] {
        let auto = CLI.tmp(&format!("auto-{res}.exr"));
        let fixed = CLI.tmp(&format!("fixed-{res}.exr"));
        let j = render(res, spp, "auto", &auto);
        assert_eq!(j["wave_paths"], wave, "{j}");
        assert_eq!(j["integrator"], chosen, "{j}");
        let pipes = j["pipelines"].to_string();
        assert_eq!(
            pipes.contains("\"megakernel\""),
            chosen == "megakernel",
            "{pipes}"
        );
        let k = render(res, spp, chosen, &fixed);
        assert_eq!(k["integrator"], chosen);
        // The pixels and the variance layer (the files differ in their render seconds).
        let layers = |p: &Path| {
            let l = brdfwave::imageio::read_layered(p).unwrap();
            (l.image, l.variance)
        };
        assert_eq!(
            layers(&auto),
            layers(&fixed),
            "{res}: auto and --integrator {chosen} differ"
        );
    }
}

#[test]
fn bad_inputs_name_the_file_and_field() {
    // Scene with a bad field value.
    let scene = CLI.tmp("bad.toml");
    let text = std::fs::read_to_string(common::repo().join("scenes/cornell-box.toml")).unwrap();
    let bad = text.replacen("[camera]", "[camera]\nfov_y_bogus = 3", 1);
    std::fs::write(&scene, bad).unwrap();
    let err = fails_naming(
        &["render", s(&scene), "--backend", "cpu", "--spp", "1"],
        "bad.toml",
    );
    assert!(err.contains("fov_y_bogus"), "{err}");

    // Missing scene file.
    fails_naming(
        &["render", "scenes/does-not-exist.toml"],
        "does-not-exist.toml",
    );

    // Bad command-line values are refused before any work.
    fails_naming(
        &[
            "render",
            "scenes/cornell-box.toml",
            "--spp",
            "0",
            "--backend",
            "cpu",
        ],
        "--spp",
    );
    fails_naming(
        &["render", "scenes/cornell-box.toml", "--wave-paths", "10"],
        "--wave-paths",
    );
    let out = CLI.run(&["render", "scenes/cornell-box.toml", "--res", "12by12"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("12by12"));

    // Inline materials: unknown model and negative roughness.
    let dirs = CLI.tmp("dirs-ok.csv");
    std::fs::write(&dirs, "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n").unwrap();
    fails_naming(&eval_args(r#"model = "wardd""#, s(&dirs), &[]), "wardd");
    fails_naming(
        &eval_args(
            r#"model = "cook_torrance", roughness = -0.1"#,
            s(&dirs),
            &[],
        ),
        "roughness",
    );

    // A direction CSV with a bad value names the file and line.
    let bad_csv = CLI.tmp("dirs-bad.csv");
    std::fs::write(
        &bad_csv,
        "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n0,0,1,0,zero,1\n",
    )
    .unwrap();
    let err = fails_naming(
        &eval_args(r#"model = "lambert""#, s(&bad_csv), &[]),
        "dirs-bad.csv",
    );
    assert!(err.contains('3'), "line number missing: {err}");

    // diff of a missing image.
    fails_naming(&["diff", "nope-a.exr", "nope-b.exr"], "nope-a.exr");
}

#[test]
fn brdf_eval_agrees_between_backends_and_keeps_the_columns() {
    let dirs = CLI.tmp("dirs.csv");
    let mut text = String::from("wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n");
    for (ti, to, phi) in [
        (0.0f32, 0.0f32, 0.0f32),
        (30.0, 30.0, 180.0),
        (45.0, 60.0, 90.0),
    ] {
        let (ti, to, phi) = (ti.to_radians(), to.to_radians(), phi.to_radians());
        text += &format!(
            "{},{},{},{},{},{}\n",
            ti.sin(),
            0.0,
            ti.cos(),
            to.sin() * phi.cos(),
            to.sin() * phi.sin(),
            to.cos()
        );
    }
    std::fs::write(&dirs, text).unwrap();
    let material = r#"model = "ward", ks = [1,1,1], alpha_x = 0.2, alpha_y = 0.1"#;
    let parse = |csv: &str| -> Vec<Vec<f64>> {
        let mut lines = csv.lines();
        assert_eq!(
            lines.next().unwrap(),
            "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,f_r,f_g,f_b,pdf"
        );
        lines
            .map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap()).collect())
            .collect()
    };
    let cpu = parse(&ok(&eval_args(material, s(&dirs), &["--backend", "cpu"])));
    let out = CLI.tmp("gpu-eval.csv");
    ok(&eval_args(
        material,
        s(&dirs),
        &["--backend", "gpu", "--out", s(&out)],
    ));
    let gpu = parse(&std::fs::read_to_string(&out).unwrap());
    assert_eq!(cpu.len(), 3);
    assert_eq!(gpu.len(), 3);
    for (c, g) in cpu.iter().zip(&gpu) {
        assert_eq!(c.len(), 10);
        for k in 0..10 {
            let tol = 1e-4 * c[k].abs().max(1.0);
            assert!(
                (c[k] - g[k]).abs() <= tol,
                "column {k}: cpu {c:?} gpu {g:?}"
            );
        }
        // f > 0 and a positive pdf in the lobe.
        assert!(c[6] > 0.0 && c[9] > 0.0, "{c:?}");
    }
}

#[test]
fn brdf_plot_writes_a_png_and_refuses_bad_angles() {
    let out = CLI.tmp("lobe.png");
    ok(&[
        "brdf",
        "plot",
        "--material",
        r#"model = "phong", ks = 0.8, kd = 0, exponent = 20"#,
        "--theta-i",
        "40",
        "--out",
        s(&out),
    ]);
    let img = image::open(&out).expect("a PNG").to_rgb8();
    assert_eq!(img.dimensions(), (960, 600));
    // The polar lobe of Phong at θi = 40° peaks around the mirror direction, on the left half
    // of the polar plot (local −x, since +x is drawn to the right and the light is there); the
    // first material's curve is drawn in the first colour of the palette.
    let red = |x0: u32, x1: u32| {
        let mut n = 0;
        for y in 0..600 {
            for x in x0..x1 {
                let p = img.get_pixel(x, y);
                if p[0] == 31 && p[1] == 119 && p[2] == 180 {
                    n += 1;
                }
            }
        }
        n
    };
    assert!(
        red(0, 480) > 4 * red(480, 960),
        "lobe on the wrong side: left {} right {}",
        red(0, 480),
        red(480, 960)
    );
    fails_naming(
        &[
            "brdf",
            "plot",
            "--material",
            r#"model = "lambert""#,
            "--theta-i",
            "95",
            "--out",
            s(&out),
        ],
        "--theta-i",
    );
}

/// `bench` at a tiny budget (the CI smoke test; no timing is asserted): every configuration
/// asked for gets rows with the documented columns, errors that fall as samples grow, a plot
/// and a summary; a bad configuration name is refused.
#[test]
fn bench_writes_its_csv_plot_and_summary() {
    let out = CLI.tmp("bench");
    let reference = CLI.tmp("bench-cache");
    let o = bin()
        .args([
            "bench",
            "scenes/cornell-box.toml",
            "--res",
            "16x12",
            "--budget",
            "3",
            "--reference-spp",
            "32",
            "--configs",
            "wavefront,megakernel,cpu,wavefront-t1,cpu-independent",
            "--min-spp",
            "16",
            "--out",
            s(&out),
        ])
        .env("BRDFWAVE_CACHE_DIR", &reference)
        .current_dir(common::repo())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("bench.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some(brdfwave::bench::CSV_COLUMNS));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    for config in [
        "wavefront",
        "megakernel",
        "cpu",
        "wavefront-t1",
        "cpu-independent",
    ] {
        let mine: Vec<&Vec<&str>> = rows.iter().filter(|r| r[0] == config).collect();
        assert!(mine.len() >= 2, "{config}: {} passes", mine.len());
        let spp: Vec<u32> = mine.iter().map(|r| r[2].parse().unwrap()).collect();
        assert!(spp.windows(2).all(|w| w[1] > w[0]), "{config}: spp {spp:?}");
        let relmse: Vec<f64> = mine.iter().map(|r| r[6].parse().unwrap()).collect();
        assert!(
            relmse.iter().all(|e| e.is_finite() && *e > 0.0),
            "{config}: {relmse:?}"
        );
        assert!(
            relmse.last() < relmse.first(),
            "{config}: error does not fall: {relmse:?}"
        );
    }
    let png = image::open(out.join("bench.png")).expect("bench.png decodes");
    assert!(png.width() > 400 && png.height() > 300);
    let md = std::fs::read_to_string(out.join("bench.md")).unwrap();
    assert!(
        md.contains("| megakernel |") && md.contains("GPU time by stage"),
        "{md}"
    );
    // --min-spp 16: every configuration reached 16 spp, whatever the budget, so the
    // equal-spp table has that column filled; the sampler is named per configuration.
    for row in ["| cpu | ", "| cpu-independent | "] {
        let line = md
            .lines()
            .filter(|l| l.starts_with(row))
            .nth(1)
            .unwrap_or_else(|| panic!("no equal-spp row {row} in {md}"));
        assert!(
            line.split('|')
                .nth(2)
                .unwrap()
                .trim()
                .parse::<f64>()
                .is_ok(),
            "{line}"
        );
    }
    let main_row = |config: &str| {
        md.lines()
            .find(|l| l.starts_with(&format!("| {config} | ")))
            .unwrap_or_else(|| panic!("no row for {config} in {md}"))
            .to_string()
    };
    assert!(main_row("cpu-independent").contains(" | independent | "));
    assert!(main_row("cpu").contains(" | multijitter | "));
    assert!(md.contains("its own expected relMSE is at most"), "{md}");
    // The reference was cached, with its own error beside it.
    let cached: Vec<_> = std::fs::read_dir(reference.join("reference"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(cached.len(), 2, "{cached:?}");
    assert!(cached.iter().any(|p| p.extension().unwrap() == "relmse"));
    fails_naming(
        &[
            "bench",
            "scenes/cornell-box.toml",
            "--configs",
            "wavefront,pbrt",
        ],
        "unknown configuration 'pbrt'",
    );
    fails_naming(
        &["bench", "scenes/cornell-box.toml", "--scaling", "0"],
        "--scaling",
    );
    fails_naming(
        &["bench", "scenes/cornell-box.toml", "--budget", "0"],
        "--budget",
    );
}

/// A fresh, empty directory for one test.
fn fresh_dir(name: &str) -> PathBuf {
    let d = CLI.tmp(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A quick render on the CPU with the given extra arguments.
fn render_args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec!["render", "scenes/cornell-box.toml"];
    a.extend_from_slice(&common::QUICK_RENDER);
    a.extend_from_slice(extra);
    a
}

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
    let d = fresh_dir("mkdirs");
    let png = d.join("a/b/img.png");
    let exr = d.join("c/img.exr");
    let var = d.join("d/var.exr");
    let stdout = ok(&render_args(&[
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
    ok(&["diff", s(&exr), s(&exr), "--error-map", s(&map)]);
    assert!(map.is_file());
    // The error map may not overwrite an input.
    let before = std::fs::read(&png).unwrap();
    fails_naming(
        &["diff", s(&png), s(&exr), "--error-map", s(&png)],
        "TEST image",
    );
    assert_eq!(std::fs::read(&png).unwrap(), before);
    let dirs = d.join("dirs.csv");
    let csv = d.join("f/eval.csv");
    ok(&lambert_eval_args(&dirs, &csv));
    assert!(csv.is_file());
    let plot = d.join("g/plot.png");
    ok(&lambert_plot_args(&plot));
    assert!(plot.is_file());
}

#[test]
fn two_outputs_with_the_same_path_are_refused() {
    let d = fresh_dir("same");
    let same = d.join("same.exr");
    let also = d.join("sub/../same.exr");
    let err = fails(&render_args(&[
        "--out",
        s(&same),
        "--variance-out",
        s(&also),
    ]));
    assert!(
        err.contains("--out") && err.contains("--variance-out") && err.contains("same file"),
        "{err}"
    );
    assert!(!same.exists(), "nothing is rendered or written");
    let a = d.join("x.png");
    fails_naming(
        &render_args(&["--out", s(&a), "--out", &format!("{}/./x.png", d.display())]),
        "same file",
    );
    #[cfg(unix)]
    {
        // A directory reached through a symbolic link is the same directory.
        std::os::unix::fs::symlink(&d, d.join("link")).unwrap();
        let err = fails(&render_args(&[
            "--out",
            s(&a),
            "--out",
            s(&d.join("link/x.png")),
        ]));
        assert!(err.contains("same file"), "{err}");
    }
}

#[test]
fn unwritable_outputs_are_found_before_the_render() {
    let d = fresh_dir("unwritable");
    let good = d.join("good.png");
    // /sys refuses new files even to root; the good output listed first is not written
    // either, which shows that the check ran before the render, not after it.
    let err = fails(&render_args(&[
        "--out",
        s(&good),
        "--out",
        "/sys/brdfwave-x.png",
    ]));
    assert!(
        err.contains("/sys/brdfwave-x.png") && err.contains("cannot"),
        "{err}"
    );
    assert!(!good.exists());
    // An existing directory as output.
    let dir_png = d.join("dir.png");
    std::fs::create_dir(&dir_png).unwrap();
    let err = fails(&render_args(&["--out", s(&good), "--out", s(&dir_png)]));
    assert!(
        err.contains("dir.png") && err.contains("is a directory"),
        "{err}"
    );
    std::fs::remove_dir(&dir_png).unwrap();
    // A file where a directory must be created.
    std::fs::write(d.join("plain"), b"x").unwrap();
    let err = fails(&render_args(&["--out", s(&d.join("plain/x.png"))]));
    assert!(
        err.contains("plain") && err.contains("cannot create the directory"),
        "{err}"
    );
    // An unknown extension, before the render too.
    let err = fails(&render_args(&[
        "--out",
        s(&good),
        "--out",
        s(&d.join("x.jpg")),
    ]));
    assert!(err.contains("x.jpg") && err.contains("extension"), "{err}");
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
    let d = fresh_dir("plot-ext");
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
    let d = fresh_dir("umask");
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

/// `d/obj-only.toml`: the white furnace without its shapes and with one OBJ shape, `obj`.
fn obj_only_scene(d: &Path, obj: &str) -> PathBuf {
    let text = std::fs::read_to_string(common::repo().join("scenes/white-furnace.toml")).unwrap();
    let mut kept = String::new();
    let mut in_shape = false;
    for line in text.lines() {
        if line.starts_with("[[shapes]]") {
            in_shape = true;
            continue;
        }
        if in_shape && line.starts_with('[') {
            in_shape = false;
        }
        if !in_shape {
            kept += line;
            kept += "\n";
        }
    }
    let material = text
        .lines()
        .find_map(|l| {
            l.strip_prefix("[materials.")
                .and_then(|r| r.strip_suffix(']'))
        })
        .expect("a material")
        .to_string();
    kept += &format!("\n[[shapes]]\nmaterial = \"{material}\"\nobj = \"{obj}\"\n");
    let sc = d.join("obj-only.toml");
    std::fs::write(&sc, &kept).unwrap();
    sc
}

#[test]
fn messages_name_the_cause_once_and_in_plain_words() {
    let d = fresh_dir("messages");
    let scene = |name: &str, edit: &dyn Fn(String) -> String| {
        let text =
            std::fs::read_to_string(common::repo().join("scenes/white-furnace.toml")).unwrap();
        let p = d.join(name);
        std::fs::write(&p, edit(text)).unwrap();
        p
    };
    // A scene whose only geometry is an OBJ without faces: the error says why.
    let obj = d.join("lines.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\n").unwrap();
    let sc = obj_only_scene(&d, "lines.obj");
    let err = fails(&["render", s(&sc), "--backend", "cpu"]);
    assert!(!err.contains("add a [[shapes]] table"), "{err}");
    assert!(
        err.contains("lines.obj") && err.contains("no triangles"),
        "{err}"
    );

    // A malformed OBJ position: the line is named.
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 x 0\nf 1 2 3\n").unwrap();
    let err = fails(&["render", s(&sc), "--backend", "cpu"]);
    assert!(err.contains("line 3") && err.contains("'x'"), "{err}");

    // OS errors once, not repeated by the error chain.
    let err = fails(&["diff", "nope-a.exr", "nope-b.exr"]);
    assert_eq!(err.matches("No such file").count(), 1, "{err}");

    // No Rust type names; huge numbers in scientific notation.
    let p = scene("types.toml", &|t| {
        t.replacen("fov_y = ", "fov_y = \"wide\" #", 1)
    });
    let err = fails(&["render", s(&p), "--backend", "cpu"]);
    assert!(!err.contains("f64") && err.contains("a number"), "{err}");
    let p = scene("width.toml", &|t| {
        t.lines()
            .map(|l| {
                if l.starts_with("width") {
                    "width = -4"
                } else {
                    l
                }
            })
            .collect::<Vec<_>>()
            .join("\n")
    });
    let err = fails(&["render", s(&p), "--backend", "cpu"]);
    assert!(
        !err.contains("u32") && err.contains("whole number"),
        "{err}"
    );
    let p = scene("radius.toml", &|t| {
        t.replacen("radius = 1.0", "radius = -1e30", 1)
    });
    let err = fails(&["render", s(&p), "--backend", "cpu"]);
    assert!(err.contains("-1e30") && !err.contains("000000"), "{err}");

    // One range for Ward's alpha, whatever the bad value.
    let dirs = d.join("dirs.csv");
    std::fs::write(&dirs, "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n").unwrap();
    for a in ["-0.2", "0", "1.5"] {
        let m = format!(r#"model = "ward", alpha_x = {a}"#);
        let err = fails(&eval_args(&m, s(&dirs), &[]));
        assert!(err.contains("[0.001, 1]"), "alpha_x = {a}: {err}");
    }

    // brdf report --out naming a file.
    let file = d.join("report-file");
    std::fs::write(&file, b"x").unwrap();
    let err = fails(&["brdf", "report", "--no-gpu", "--out", s(&file)]);
    assert!(
        err.contains("is a file") && !err.contains("os error"),
        "{err}"
    );
}

/// A driver list that points nowhere, a manifest that exists but is garbage (the loader says
/// "host memory allocation has failed") and one whose library is missing: each manifest tried
/// is named with what is wrong with it, and how to fix it.
#[test]
fn bad_driver_manifests_are_named_with_what_is_wrong() {
    let d = fresh_dir("manifests");
    let nowhere = std::path::PathBuf::from("/nonexistent/brdfwave_icd.json");
    let garbage = d.join("garbage_icd.json");
    std::fs::write(&garbage, b"garbage\n").unwrap();
    let no_lib = d.join("nolib_icd.json");
    std::fs::write(
        &no_lib,
        br#"{"file_format_version": "1.0.0", "ICD": {"library_path": "./missing_lvp.so", "api_version": "1.3.230"}}"#,
    )
    .unwrap();
    for (manifest, expect) in [
        (&nowhere, "/nonexistent/brdfwave_icd.json (does not exist)"),
        (&garbage, "not a JSON driver manifest"),
        (&no_lib, "missing_lvp.so does not"),
    ] {
        let out = bin()
            .arg("devices")
            .env("VK_ICD_FILENAMES", manifest)
            .env_remove("VK_DRIVER_FILES")
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains(expect) && err.contains("Unset VK_ICD_FILENAMES"),
            "{}: {err}",
            manifest.display()
        );
    }
}

#[test]
fn gpu_options_are_refused_or_warned_about_consistently() {
    let d = fresh_dir("gpu-options");
    let png = d.join("x.png");
    for extra in [
        vec!["--device", "llvmpipe"],
        vec!["--validation"],
        vec!["--wave-paths", "4096"],
    ] {
        let mut args = extra.clone();
        args.extend(["--out", s(&png)]);
        let out = CLI.run(&render_args(&args));
        assert!(out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains(&format!(
                "warning: {} applies to the GPU backend only; ignored",
                extra[0]
            )),
            "{extra:?}: {err}"
        );
    }
    // The same for brdf eval on the CPU.
    let dirs = d.join("dirs.csv");
    std::fs::write(&dirs, "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n").unwrap();
    let out = CLI.run(&eval_args(
        r#"model = "lambert""#,
        s(&dirs),
        &["--device", "llvmpipe"],
    ));
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("warning: --device applies to the GPU backend only; ignored"),
        "{err}"
    );
    // --validation without the layer installed (the loader's explicit-layer search path
    // pointed at an empty directory) fails before any work, as its help says.
    let empty = fresh_dir("no-layers");
    let out = bin()
        .args([
            "render",
            "scenes/cornell-box.toml",
            "--res",
            "8x8",
            "--spp",
            "1",
        ])
        .args(["--validation", "--out", s(&png)])
        .env("VK_LAYER_PATH", &empty)
        .current_dir(common::repo())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("--validation") && err.contains("vulkan-validationlayers"),
        "{err}"
    );
    // An empty device name is refused by the argument parser (status 2, as for any bad
    // option value), before any work.
    for args in [
        &["render", "scenes/cornell-box.toml", "--device", ""][..],
        &["brdf", "report", "--device", " "][..],
    ] {
        let out = CLI.run(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("empty"), "{err}");
    }
}

/// `brdfwave stress` with a CI-sized budget: every group runs and passes, the table lists them;
/// `--replay` runs exactly the listed cases; bad arguments are errors, not panics.
#[test]
fn stress_runs_every_group_within_a_small_budget_and_replays_cases() {
    let failures = CLI.tmp("stress-failures.jsonl");
    let _ = std::fs::remove_file(&failures);
    let out = ok(&[
        "stress",
        "--budget",
        "14",
        "--seed",
        "7",
        "--failures",
        s(&failures),
    ]);
    eprintln!("{out}");
    for group in [
        "models",
        "limits",
        "gpu_math",
        "geometry",
        "radiance",
        "scene_numbers",
        "degenerate",
    ] {
        let line = out
            .lines()
            .find(|l| l.split_whitespace().next() == Some(group))
            .unwrap_or_else(|| panic!("no row for {group}:\n{out}"));
        let cols: Vec<&str> = line.split_whitespace().collect();
        let cases: u64 = cols[1].parse().unwrap();
        assert!(cases >= 1, "{line}");
        assert_eq!(cols[2], "0", "{line}");
    }
    assert!(!failures.exists(), "a passing run wrote a failure file");

    // Replay: a file naming two cases runs those two and nothing else.
    let replay = CLI.tmp("stress-replay.jsonl");
    std::fs::write(
        &replay,
        "{\"group\":\"models\",\"seed\":12345,\"message\":\"\"}\n\
         {\"group\":\"scene_numbers\",\"seed\":99,\"message\":\"\"}\n",
    )
    .unwrap();
    let out = ok(&["stress", "--replay", s(&replay), "--failures", s(&failures)]);
    let cases = |group: &str| -> String {
        let line = out
            .lines()
            .find(|l| l.split_whitespace().next() == Some(group))
            .unwrap();
        line.split_whitespace().nth(1).unwrap().to_string()
    };
    assert_eq!(cases("models"), "1", "{out}");
    assert_eq!(cases("scene_numbers"), "1", "{out}");
    assert_eq!(cases("geometry"), "0", "{out}");

    std::fs::write(&replay, "not json\n").unwrap();
    let e = fails(&["stress", "--replay", s(&replay)]);
    assert!(
        e.contains("stress-replay.jsonl:1") && e.contains("not a failure record"),
        "{e}"
    );
    fails_naming(
        &["stress", "--budget", "1", "--group", "nope"],
        "unknown group 'nope'",
    );
    fails_naming(&["stress", "--budget=-1"], "--budget");
}
