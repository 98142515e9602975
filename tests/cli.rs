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
            // The Cornell box is all Lambert: one shade pipeline, named after its model.
            let pipes: Vec<&str> = j["pipelines"]
                .as_array()
                .expect("pipelines list")
                .iter()
                .map(|p| p.as_str().unwrap())
                .collect();
            assert!(pipes.contains(&"shade_lambert"), "{pipes:?}");
            assert!(
                !pipes
                    .iter()
                    .any(|p| p.starts_with("shade_") && *p != "shade_lambert"),
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

/// `brdfwave stress` with a CI-sized budget: every group runs and passes, the table lists them;
/// `--replay` runs exactly the listed cases; bad arguments are errors, not panics.
#[test]
fn stress_runs_every_group_within_a_small_budget_and_replays_cases() {
    let failures = tmp("stress-failures.jsonl");
    let _ = std::fs::remove_file(&failures);
    let out = ok(&[
        "stress",
        "--budget",
        "6",
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
    let replay = tmp("stress-replay.jsonl");
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
    let e = fails(&["stress", "--budget", "1", "--group", "nope"]);
    assert!(e.contains("unknown group 'nope'"), "{e}");
    let e = fails(&["stress", "--budget=-1"]);
    assert!(e.contains("--budget"), "{e}");
}
