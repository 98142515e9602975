//! The command line as a user runs it: the `brdfwave` binary in a subprocess. Checks the
//! `--json` summary fields the issues require, that bad input gives an error naming the file and
//! the field or line (exit status 1, never a panic), and that the brdf tools write what they say.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_brdfwave"))
}

fn run(args: &[&str]) -> Output {
    let out = bin()
        .args(args)
        .current_dir(common::repo())
        .output()
        .expect("run brdfwave");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !stderr.contains("panicked"),
        "brdfwave {args:?} panicked:\n{stderr}"
    );
    out
}

fn ok(args: &[&str]) -> String {
    let out = run(args);
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
    let out = run(args);
    assert_eq!(
        out.status.code(),
        Some(1),
        "brdfwave {args:?} should fail with status 1; stdout:\n{}\nstderr:\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("brdfwave-cli-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn render_json_summary_on_both_backends() {
    let mut images = Vec::new();
    for backend in ["gpu", "cpu"] {
        let png = tmp(&format!("cornell-{backend}.png"));
        let exr = tmp(&format!("cornell-{backend}.exr"));
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
    let map = tmp("cornell-error.png");
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

#[test]
fn bad_inputs_name_the_file_and_field() {
    // Scene with a bad field value.
    let scene = tmp("bad.toml");
    let text = std::fs::read_to_string(common::repo().join("scenes/cornell-box.toml")).unwrap();
    let bad = text.replacen("[camera]", "[camera]\nfov_y_bogus = 3", 1);
    std::fs::write(&scene, bad).unwrap();
    let err = fails(&["render", s(&scene), "--backend", "cpu", "--spp", "1"]);
    assert!(err.contains("bad.toml"), "{err}");
    assert!(err.contains("fov_y_bogus"), "{err}");

    // Missing scene file.
    let err = fails(&["render", "scenes/does-not-exist.toml"]);
    assert!(err.contains("does-not-exist.toml"), "{err}");

    // Bad command-line values are refused before any work.
    let err = fails(&[
        "render",
        "scenes/cornell-box.toml",
        "--spp",
        "0",
        "--backend",
        "cpu",
    ]);
    assert!(err.contains("--spp"), "{err}");
    let err = fails(&["render", "scenes/cornell-box.toml", "--wave-paths", "10"]);
    assert!(err.contains("--wave-paths"), "{err}");
    let out = run(&["render", "scenes/cornell-box.toml", "--res", "12by12"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("12by12"));

    // Inline materials: unknown model and negative roughness.
    let dirs = tmp("dirs-ok.csv");
    std::fs::write(&dirs, "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n").unwrap();
    let err = fails(&[
        "brdf",
        "eval",
        "--material",
        r#"model = "wardd""#,
        "--dirs",
        s(&dirs),
    ]);
    assert!(err.contains("wardd"), "{err}");
    let err = fails(&[
        "brdf",
        "eval",
        "--material",
        r#"model = "cook_torrance", roughness = -0.1"#,
        "--dirs",
        s(&dirs),
    ]);
    assert!(err.contains("roughness"), "{err}");

    // A direction CSV with a bad value names the file and line.
    let bad_csv = tmp("dirs-bad.csv");
    std::fs::write(
        &bad_csv,
        "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n0,0,1,0,zero,1\n",
    )
    .unwrap();
    let err = fails(&[
        "brdf",
        "eval",
        "--material",
        r#"model = "lambert""#,
        "--dirs",
        s(&bad_csv),
    ]);
    assert!(err.contains("dirs-bad.csv"), "{err}");
    assert!(err.contains('3'), "line number missing: {err}");

    // diff of a missing image.
    let err = fails(&["diff", "nope-a.exr", "nope-b.exr"]);
    assert!(err.contains("nope-a.exr"), "{err}");
}

#[test]
fn brdf_eval_agrees_between_backends_and_keeps_the_columns() {
    let dirs = tmp("dirs.csv");
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
    let cpu = parse(&ok(&[
        "brdf",
        "eval",
        "--material",
        material,
        "--dirs",
        s(&dirs),
        "--backend",
        "cpu",
    ]));
    let out = tmp("gpu-eval.csv");
    ok(&[
        "brdf",
        "eval",
        "--material",
        material,
        "--dirs",
        s(&dirs),
        "--backend",
        "gpu",
        "--out",
        s(&out),
    ]);
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
    let out = tmp("lobe.png");
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
    assert_eq!(img.dimensions(), (1024, 512));
    // The polar lobe of Phong at θi = 40° peaks around the mirror direction, on the left half
    // of the polar panel (local −x, since +x is drawn to the right and the light is there).
    let red = |x0: u32, x1: u32| {
        let mut n = 0;
        for y in 0..512 {
            for x in x0..x1 {
                let p = img.get_pixel(x, y);
                if p[0] == 200 && p[1] == 30 && p[2] == 30 {
                    n += 1;
                }
            }
        }
        n
    };
    assert!(
        red(0, 256) > 4 * red(256, 512),
        "lobe on the wrong side: left {} right {}",
        red(0, 256),
        red(256, 512)
    );
    let err = fails(&[
        "brdf",
        "plot",
        "--material",
        r#"model = "lambert""#,
        "--theta-i",
        "95",
        "--out",
        s(&out),
    ]);
    assert!(err.contains("--theta-i"), "{err}");
}

/// `bench` at a tiny budget (the CI smoke test; no timing is asserted): every configuration
/// asked for gets rows with the documented columns, errors that fall as samples grow, a plot
/// and a summary; a bad configuration name is refused.
#[test]
fn bench_writes_its_csv_plot_and_summary() {
    let out = tmp("bench");
    let reference = tmp("bench-cache");
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
            "wavefront,megakernel,cpu,wavefront-t1",
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
    for config in ["wavefront", "megakernel", "cpu", "wavefront-t1"] {
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
    // The reference was cached.
    let cached: Vec<_> = std::fs::read_dir(reference.join("reference"))
        .unwrap()
        .collect();
    assert_eq!(cached.len(), 1);
    let e = fails(&[
        "bench",
        "scenes/cornell-box.toml",
        "--configs",
        "wavefront,pbrt",
    ]);
    assert!(e.contains("unknown configuration 'pbrt'"), "{e}");
}
