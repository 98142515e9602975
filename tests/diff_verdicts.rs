//! `brdfwave diff` as a CI check: thresholds on the metrics (`--max`) and the statistical test
//! of two renders (`--z-test`) give exit status 1 and a FAIL line on a regression, 0 otherwise;
//! and the EXR metadata and variance layer that `render` and `merge` write and `--z-test` reads.

mod common;

use common::cli::{s, Cli};

use brdfwave::imageio::{self, Image};
use std::path::{Path, PathBuf};

const CLI: Cli = Cli {
    tag: "diff",
    own_cache: true,
    env_remove: &[],
};
/// A reference of 0.5 everywhere and a test 0.1 brighter in the left quarter of the columns:
/// RMSE 0.05, max |t-r| 0.1, a quarter of the pixels over a tolerance below 0.1.
fn pair() -> (PathBuf, PathBuf) {
    let (t, r) = (CLI.tmp("test.exr"), CLI.tmp("reference.exr"));
    imageio::write(&r, &Image::filled(16, 16, [0.5; 3])).unwrap();
    let test = Image::from_fn(16, 16, |x, _| [if x < 4 { 0.6 } else { 0.5 }; 3]);
    imageio::write(&t, &test).unwrap();
    (t, r)
}

#[test]
fn thresholds_pass_below_and_fail_above_naming_the_metric() {
    let (t, r) = pair();
    let (t, r) = (s(&t), s(&r));
    let (o, _) = CLI.status(
        &["diff", t, r, "--max", "rmse=0.06", "--max", "max_abs=0.11"],
        0,
    );
    assert!(o.contains("PASS rmse 5.000e-2 <= 0.06"), "{o}");
    assert!(o.contains("PASS max_abs"), "{o}");
    let (o, e) = CLI.status(
        &[
            "diff",
            t,
            r,
            "--max",
            "rmse=0.04",
            "--max",
            "max_abs=0.11",
            "--max",
            "relmse=1e-3",
        ],
        1,
    );
    assert!(o.contains("FAIL rmse 5.000e-2 > 0.04"), "{o}");
    assert!(o.contains("FAIL relmse"), "{o}");
    assert!(o.contains("PASS max_abs"), "{o}");
    assert!(e.contains("FAIL rmse 5.000e-2 > 0.04; FAIL relmse"), "{e}");
    // A quarter of the pixels are over a tolerance of 0.05, none over 0.2.
    let over = ["diff", t, r, "--max", "over=0.2", "--tolerance"];
    let (o, _) = CLI.status(&[&over[..], &["0.05"]].concat(), 1);
    assert!(o.contains("FAIL over 2.500e-1 > 0.2"), "{o}");
    CLI.status(&[&over[..], &["0.2"]].concat(), 0);
    // The relative tolerance: 0.1 <= 0.2 * 0.6.
    CLI.status(&[&over[..], &["0", "--rel-tolerance", "0.2"]].concat(), 0);
    // JSON carries the verdicts and the overall one.
    let (o, _) = CLI.status(&["diff", t, r, "--json", "--max", "flip=1e-9"], 1);
    let j: serde_json::Value = serde_json::from_str(o.trim()).unwrap();
    assert_eq!(j["pass"], false);
    assert_eq!(j["verdicts"][0]["metric"], "flip");
    assert_eq!(j["verdicts"][0]["pass"], false);
    // The same image passes every threshold at 0.
    let zero: Vec<&str> = ["rmse", "mse", "relmse", "flip", "max_abs", "over"]
        .iter()
        .flat_map(|m| ["--max", Box::leak(format!("{m}=0").into_boxed_str())])
        .collect();
    CLI.status(&[&["diff", r, r][..], &zero].concat(), 0);
}

#[test]
fn bad_thresholds_are_refused_with_the_reason() {
    let (t, r) = pair();
    let (t, r) = (s(&t), s(&r));
    for (arg, needle) in [
        ("psnr=30", "unknown metric 'psnr'"),
        ("relmse", "is not METRIC=VALUE"),
        ("relmse=abc", "not a number"),
        ("rmse=-1", "must be finite and >= 0"),
        ("over=2", "at most 1"),
    ] {
        let (_, e) = CLI.status(&["diff", t, r, "--max", arg], 2);
        assert!(e.contains(needle) && e.contains("--max"), "{arg}: {e}");
    }
    let (_, e) = CLI.status(&["diff", t, r, "--tolerance", "0.1"], 1);
    assert!(e.contains("--max over"), "{e}");
    let (_, e) = CLI.status(&["diff", t, r, "--z-test"], 1);
    assert!(e.contains("--test-variance"), "{e}");
}

/// Renders `scene` small on the CPU with the independent sampler (whose per-sample variance is
/// what the z-test assumes) to `name`.exr and its variance to `name`-var.exr.
fn render(scene: &Path, seed: &str, name: &str) -> (PathBuf, PathBuf) {
    let (out, var) = (
        CLI.tmp(&format!("{name}.exr")),
        CLI.tmp(&format!("{name}-var.exr")),
    );
    let args = [
        "render",
        s(scene),
        "--backend",
        "cpu",
        "--res",
        "32x32",
        "--spp",
        "256",
        "--sampler",
        "independent",
        "--seed",
        seed,
        "--out",
        s(&out),
        "--variance-out",
        s(&var),
    ];
    CLI.status(&args, 0);
    (out, var)
}

fn z_diff(a: &(PathBuf, PathBuf), b: &(PathBuf, PathBuf), code: i32, extra: &[&str]) -> String {
    let args = [
        "diff",
        s(&a.0),
        s(&b.0),
        "--z-test",
        "--test-variance",
        s(&a.1),
        "--test-spp",
        "256",
        "--reference-variance",
        s(&b.1),
        "--reference-spp",
        "256",
    ];
    CLI.status(&[&args[..], extra].concat(), code).0
}

#[test]
fn z_test_passes_on_two_seeds_and_fails_on_a_changed_wall() {
    let scene = common::repo().join("scenes/cornell-box.toml");
    let text = std::fs::read_to_string(&scene).unwrap();
    // The red wall 10% brighter.
    let red = "albedo = [0.63, 0.065, 0.05]";
    assert_eq!(text.matches(red).count(), 1);
    let changed = CLI.tmp("changed.toml");
    std::fs::write(
        &changed,
        text.replace(red, "albedo = [0.693, 0.0715, 0.055]"),
    )
    .unwrap();
    let a = render(&scene, "1", "seed1");
    let b = render(&scene, "2", "seed2");
    let c = render(&changed, "2", "changed");
    let p_map = CLI.tmp("p.exr");
    let o = z_diff(&a, &b, 0, &["--p-map", s(&p_map)]);
    assert!(o.contains("z-test PASS"), "{o}");
    let p = imageio::read(&p_map).unwrap();
    assert_eq!((p.width, p.height), (32, 32));
    assert!(p.data.iter().flatten().all(|&v| (0.0..=1.0).contains(&v)));
    let o = z_diff(&c, &a, 1, &[]);
    assert!(
        o.contains("z-test FAIL") && o.contains("excess rule FAIL"),
        "{o}"
    );
    // The worst pixels are on the red wall, the left of the image.
    let j: serde_json::Value = serde_json::from_str(z_diff(&c, &a, 1, &["--json"]).trim()).unwrap();
    assert_eq!(j["pass"], false);
    assert_eq!(j["z_test"]["pass"], false);
    assert!(j["z_test"]["worst"][0]["x"].as_u64().unwrap() < 8, "{j}");
    let j: serde_json::Value = serde_json::from_str(z_diff(&a, &b, 0, &["--json"]).trim()).unwrap();
    assert_eq!(
        (j["pass"].clone(), j["z_test"]["variance_model"].clone()),
        (true.into(), "pooled".into())
    );
    // The same verdicts from the EXRs' variance layers and spp attributes alone.
    let layers = |x: &PathBuf, y: &PathBuf, code| {
        let (o, _) = CLI.status(&["diff", s(x), s(y), "--z-test", "--json"], code);
        let j: serde_json::Value = serde_json::from_str(o.trim()).unwrap();
        j["z_test"].clone()
    };
    assert_eq!(layers(&a.0, &b.0, 0), j["z_test"]);
    assert_eq!(layers(&c.0, &a.0, 1)["pass"], false);
}

#[test]
fn render_and_merge_outputs_carry_what_produced_them() {
    let scene = common::repo().join("scenes/cornell-box.toml");
    let fixed = [
        "--backend",
        "cpu",
        "--res",
        "8x8",
        "--seed",
        "7",
        "--max-depth",
        "3",
    ];
    let out = CLI.tmp("whole.exr");
    CLI.status(
        &[
            &["render", s(&scene), "--spp", "4", "--out", s(&out)][..],
            &fixed,
        ]
        .concat(),
        0,
    );
    let l = imageio::read_layered(&out).unwrap();
    let p = &l.provenance;
    assert_eq!(
        (p.spp, p.samples.clone(), p.seed, p.max_depth),
        (Some(4), Some(0..4), Some(7), Some(3))
    );
    assert_eq!(
        (p.sampler.as_deref(), p.backend.as_deref()),
        (Some("multijitter"), Some("cpu"))
    );
    let bytes = std::fs::read(&scene).unwrap();
    let file_hash = format!("{:016x}", brdfwave::hash::fnv1a64(&bytes));
    assert_eq!(p.scene_file_hash.as_deref(), Some(file_hash.as_str()));
    assert_eq!(p.version, Some(brdfwave::film::code_version()));
    assert!(p.device.as_deref().unwrap().contains("CPU") && p.render_seconds.unwrap() >= 0.0);
    assert!(p.scene_hash.is_some());
    let image = l.image.clone();
    let variance = l.variance.expect("a variance layer");
    assert_eq!(imageio::read(&out).unwrap(), image);
    // --variance-out still writes the variance alone.
    let var_out = CLI.tmp("whole-var.exr");
    CLI.status(
        &[
            &[
                "render",
                s(&scene),
                "--spp",
                "4",
                "--variance-out",
                s(&var_out),
                "--out",
                s(&out),
            ][..],
            &fixed,
        ]
        .concat(),
        0,
    );
    assert_eq!(imageio::read(&var_out).unwrap(), variance);
    // Two parts merged: the union of their samples, their seconds added, the same image. The
    // parts are ranges of the scene's render, so its spp is set to the whole render's (it sizes
    // the default multijitter pattern).
    let parts: Vec<PathBuf> = ["0..2", "2..4"]
        .iter()
        .enumerate()
        .map(|(i, range)| {
            let part = CLI.tmp(&format!("part{i}.bwfilm"));
            CLI.status(
                &[
                    &[
                        "render",
                        s(&scene),
                        "--set",
                        "integrator.spp=4",
                        "--samples",
                        range,
                        "--out",
                        s(&part),
                    ][..],
                    &fixed,
                ]
                .concat(),
                0,
            );
            part
        })
        .collect();
    let merged = CLI.tmp("merged.exr");
    CLI.status(
        &["merge", s(&parts[0]), s(&parts[1]), "--out", s(&merged)],
        0,
    );
    let m = imageio::read_layered(&merged).unwrap();
    let mp = &m.provenance;
    assert_eq!((mp.spp, mp.samples.clone()), (Some(4), Some(0..4)));
    assert_eq!(
        (mp.scene_hash.clone(), mp.version.clone()),
        (p.scene_hash.clone(), p.version.clone())
    );
    assert_eq!(mp.backend.as_deref(), Some("cpu"));
    assert!(mp.render_seconds.is_some() && m.variance.is_some());
    assert_eq!(m.image, image);
}

/// The aggregate test sees what the pixels cannot: the Cornell box's white material (floor,
/// ceiling, back wall, blocks) 2 % darker, at 32x32 and 256 spp, is well within one pixel's
/// noise (both pixel rules pass) but not within a block's. Two seeds of the true scene pass.
/// For the default stratified sampler with the variance of its batch means (`--batches`), for
/// the same sampler with the variance of one sample (valid there, but an overstatement), and
/// for the independent sampler; the JSON says which variance each side had.
#[test]
fn blocks_see_a_darker_material_that_pixels_cannot_for_every_sampler() {
    let scene = common::repo().join("scenes/cornell-box.toml");
    let darker = "materials.white.albedo=[0.7105, 0.6958, 0.6664]"; // 0.98 x [0.725, 0.71, 0.68]
    for (name, sampler, batches, source) in [
        ("mj-batches", "multijitter", Some("8"), "batches"),
        ("mj", "multijitter", None, "one-sample"),
        ("indep", "independent", None, "one-sample"),
    ] {
        let render = |tag: &str, seed: &str, set: Option<&str>| {
            let out = CLI.tmp(&format!("{name}-{tag}.exr"));
            let mut args = vec![
                "render",
                s(&scene),
                "--backend",
                "cpu",
                "--res",
                "32x32",
                "--spp",
                "256",
                "--sampler",
                sampler,
                "--seed",
                seed,
                "--quiet",
                "--out",
                s(&out),
            ];
            if let Some(k) = batches {
                args.extend(["--batches", k]);
            }
            if let Some(set) = set {
                args.extend(["--set", set]);
            }
            CLI.status(&args, 0);
            out
        };
        let (a, b, dark) = (
            render("a", "11", None),
            render("b", "12", None),
            render("dark", "13", Some(darker)),
        );
        let verdict = |t: &PathBuf, r: &PathBuf, code| {
            let (o, _) = CLI.status(&["diff", s(t), s(r), "--z-test", "--json"], code);
            let j: serde_json::Value = serde_json::from_str(o.trim()).unwrap();
            println!("{name}: {}", j["z_test"]["blocks"]);
            j["z_test"].clone()
        };
        let z = verdict(&a, &b, 0);
        assert_eq!(z["variance"]["test"]["source"], source, "{name}");
        assert_eq!(z["variance"]["reference"]["source"], source, "{name}");
        assert_eq!(z["blocks"]["rejected"], 0, "{name}");
        // 1 + excess + 4 scales (4, 8, 16, whole) share alpha.
        assert_eq!(z["members"], 6, "{name}");
        let z = verdict(&dark, &a, 1);
        assert_eq!(
            (
                z["outlier_rule_pass"].clone(),
                z["excess_rule_pass"].clone()
            ),
            (true.into(), true.into()),
            "{name}: the pixels alone do not see 2 %"
        );
        assert_eq!(z["blocks"]["pass"], false, "{name}");
        let scales = z["blocks"]["scales"].as_array().unwrap();
        // The 16x16 blocks see it, darker (t < 0), and were able to: their detectable bias is
        // under the 2 % that is there.
        let s16 = &scales[2];
        assert_eq!(s16["side"], 16);
        assert!(s16["rejected"].as_u64().unwrap() > 0, "{name}: {s16}");
        assert!(s16["worst"]["t"].as_f64().unwrap() < 0.0, "{name}: {s16}");
        assert!(
            s16["detectable"]["bias"].as_f64().unwrap() < 0.02,
            "{name}: {s16}"
        );
    }
}

/// `render --batches K` writes the variance of the means from K batches beside the one-sample
/// variance, and refuses batches that cannot be cut; `diff --variance-source`
/// picks one or the other and names it in its text.
#[test]
fn batches_in_the_exr_and_the_variance_source_of_diff() {
    let scene = common::repo().join("scenes/cornell-box.toml");
    let base = [
        "render",
        s(&scene),
        "--backend",
        "cpu",
        "--res",
        "8x8",
        "--spp",
        "16",
        "--max-depth",
        "3",
        "--quiet",
    ];
    let out = CLI.tmp("batched.exr");
    CLI.status(
        &[&base[..], &["--batches", "4", "--out", s(&out)]].concat(),
        0,
    );
    let l = imageio::read_layered(&out).unwrap();
    let b = l.batch_variance.expect("a batch variance layer");
    assert_eq!(b.batches, 4);
    assert!(l.variance.is_some());
    assert!(b
        .variance
        .data
        .iter()
        .flatten()
        .all(|v| v.is_finite() && *v >= 0.0));
    // Refused by the render (status 1) or by the option's parser (status 2).
    for (extra, code, needle) in [
        (&["--batches", "3"][..], 1, "do not divide"),
        (&["--batches", "1"][..], 2, "--batches"),
    ] {
        let (_, e) = CLI.status(&[&base[..], extra, &["--out", s(&out)]].concat(), code);
        assert!(e.contains(needle), "{extra:?}: {e}");
    }
    // Sobol in batches: each its own scramble.
    let sobol = CLI.tmp("sobol.exr");
    let args = ["--batches", "4", "--sampler", "sobol", "--out", s(&sobol)];
    CLI.status(&[&base[..], &args].concat(), 0);
    let l = imageio::read_layered(&sobol).unwrap();
    assert_eq!(l.batch_variance.unwrap().batches, 4);
    // A part must hold whole batches of the whole render's.
    let mut part = base.to_vec();
    part.splice(6..8, ["--set", "integrator.spp=16", "--samples", "2..10"]);
    let (_, e) = CLI.status(
        &[&part[..], &["--batches", "4", "--out", s(&out)]].concat(),
        1,
    );
    assert!(e.contains("not at least two whole batches of 4"), "{e}");
    let plain = CLI.tmp("plain.exr");
    CLI.status(&[&base[..], &["--out", s(&plain)]].concat(), 0);
    let (o, _) = CLI.status(&["diff", s(&out), s(&out), "--z-test"], 0);
    assert!(o.contains("variance of the mean from 4 batch means"), "{o}");
    let (o, _) = CLI.status(
        &[
            "diff",
            s(&out),
            s(&out),
            "--z-test",
            "--variance-source",
            "one-sample",
        ],
        0,
    );
    assert!(o.contains("variance of one sample / 16 spp"), "{o}");
    // One side batched, the other not: each its own, and Welch.
    let (o, _) = CLI.status(&["diff", s(&out), s(&plain), "--z-test", "--json"], 0);
    let j: serde_json::Value = serde_json::from_str(o.trim()).unwrap();
    assert_eq!(j["z_test"]["variance"]["test"]["batches"], 4);
    assert_eq!(j["z_test"]["variance"]["reference"]["spp"], 16);
    assert_eq!(j["z_test"]["variance_model"], "welch");
    let (_, e) = CLI.status(
        &[
            "diff",
            s(&out),
            s(&plain),
            "--z-test",
            "--variance-source",
            "batches",
        ],
        1,
    );
    assert!(
        e.contains("has no meanVariance layer") && e.contains("--batches"),
        "{e}"
    );
}
