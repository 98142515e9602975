//! The command line as a user runs it: the `brdfwave` binary in a subprocess. Checks the
//! `--json` summary fields the issues require, and that the brdf tools, `bench` and `stress`
//! write what they say. The files written are checked in `tests/cli_outputs.rs`, the messages of
//! bad input (exit status 1, never a panic) in `tests/cli_messages.rs`.

mod common;

use common::cli::{bin, eval_args, s, Cli};

use std::path::Path;

const CLI: Cli = Cli {
    tag: "cli",
    own_cache: false,
    env_remove: &[],
};

/// `--version` names what the binary was built from: the package version, the commit of a
/// git checkout and, where the code had uncommitted changes, a hash of them; the same string the
/// render summary's `version` and the partial films carry.
#[test]
fn version_names_the_commit_and_uncommitted_changes() {
    let version = brdfwave::film::code_version();
    assert_eq!(CLI.ok(&["--version"]).trim(), format!("brdfwave {version}"));
    let commit = std::process::Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    if let Some(commit) = commit {
        // Built from this checkout (cargo test builds before it runs).
        assert!(
            version.contains(&commit),
            "{version} does not name {commit}"
        );
        let clean = std::process::Command::new("git")
            .args([
                "diff", "--quiet", "HEAD", "--", "src", "shaders", "build.rs",
            ])
            .args(["Cargo.toml", "Cargo.lock", ".cargo"])
            .status()
            .expect("git runs")
            .success();
        assert_eq!(version.contains(".modified-"), !clean, "{version}");
    }
}

#[test]
fn render_json_summary_on_both_backends() {
    let mut images = Vec::new();
    for backend in ["gpu", "cpu"] {
        let png = CLI.tmp(&format!("cornell-{backend}.png"));
        let exr = CLI.tmp(&format!("cornell-{backend}.exr"));
        let stdout = CLI.ok(&[
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
    let stdout = CLI.ok(&[
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
        let stdout = CLI.ok(&[
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
    let cpu = parse(&CLI.ok(&eval_args(material, s(&dirs), &["--backend", "cpu"])));
    let out = CLI.tmp("gpu-eval.csv");
    CLI.ok(&eval_args(
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
    CLI.ok(&[
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
    CLI.fails_naming(
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
    let configs = [
        "wavefront",
        "megakernel",
        "cpu",
        "wavefront-t1",
        "cpu-independent",
    ];
    common::run_ok(
        bin()
            .args(["bench", "scenes/cornell-box.toml", "--res", "16x12"])
            .args(["--budget", "3", "--reference-spp", "32", "--min-spp", "16"])
            .args(["--configs", &configs.join(","), "--out", s(&out)])
            .env("BRDFWAVE_CACHE_DIR", &reference)
            .current_dir(common::repo()),
    );
    let csv = std::fs::read_to_string(out.join("bench.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some(brdfwave::bench::CSV_COLUMNS));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    for config in configs {
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
    CLI.fails_naming(
        &[
            "bench",
            "scenes/cornell-box.toml",
            "--configs",
            "wavefront,pbrt",
        ],
        "unknown configuration 'pbrt'",
    );
    CLI.fails_naming(
        &["bench", "scenes/cornell-box.toml", "--scaling", "0"],
        "--scaling",
    );
    CLI.fails_naming(
        &["bench", "scenes/cornell-box.toml", "--budget", "0"],
        "--budget",
    );
}

/// `brdfwave stress` with a CI-sized budget: every group runs and passes, the table lists them;
/// `--replay` runs exactly the listed cases; bad arguments are errors, not panics.
#[test]
fn stress_runs_every_group_within_a_small_budget_and_replays_cases() {
    let failures = CLI.tmp("stress-failures.jsonl");
    let _ = std::fs::remove_file(&failures);
    let out = CLI.ok(&[
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
    let out = CLI.ok(&["stress", "--replay", s(&replay), "--failures", s(&failures)]);
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
    let e = CLI.fails(&["stress", "--replay", s(&replay)]);
    assert!(
        e.contains("stress-replay.jsonl:1") && e.contains("not a failure record"),
        "{e}"
    );
    CLI.fails_naming(
        &["stress", "--budget", "1", "--group", "nope"],
        "unknown group 'nope'",
    );
    CLI.fails_naming(&["stress", "--budget=-1"], "--budget");
}
