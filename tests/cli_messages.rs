//! The messages of the command line: bad input gives an error naming the file and the field
//! or line (exit status 1, never a panic), once and in plain words; bad driver manifests and
//! GPU options are named with what is wrong.

mod common;

use common::cli::{bin, eval_args, render_args, s, Cli};

use std::path::{Path, PathBuf};

const CLI: Cli = Cli {
    tag: "cli-messages",
    own_cache: false,
    env_remove: &[],
};

#[test]
fn bad_inputs_name_the_file_and_field() {
    // Scene with a bad field value.
    let scene = CLI.tmp("bad.toml");
    let text = std::fs::read_to_string(common::repo().join("scenes/cornell-box.toml")).unwrap();
    let bad = text.replacen("[camera]", "[camera]\nfov_y_bogus = 3", 1);
    std::fs::write(&scene, bad).unwrap();
    let err = CLI.fails_naming(
        &["render", s(&scene), "--backend", "cpu", "--spp", "1"],
        "bad.toml",
    );
    assert!(err.contains("fov_y_bogus"), "{err}");

    // Missing scene file.
    CLI.fails_naming(
        &["render", "scenes/does-not-exist.toml"],
        "does-not-exist.toml",
    );

    // Bad command-line values are refused before any work.
    CLI.fails_naming(
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
    CLI.fails_naming(
        &["render", "scenes/cornell-box.toml", "--wave-paths", "10"],
        "--wave-paths",
    );
    let out = CLI.run(&["render", "scenes/cornell-box.toml", "--res", "12by12"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("12by12"));

    // Inline materials: unknown model and negative roughness.
    let dirs = CLI.tmp("dirs-ok.csv");
    std::fs::write(&dirs, "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n").unwrap();
    CLI.fails_naming(&eval_args(r#"model = "wardd""#, s(&dirs), &[]), "wardd");
    CLI.fails_naming(
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
    let err = CLI.fails_naming(
        &eval_args(r#"model = "lambert""#, s(&bad_csv), &[]),
        "dirs-bad.csv",
    );
    assert!(err.contains('3'), "line number missing: {err}");

    // diff of a missing image.
    CLI.fails_naming(&["diff", "nope-a.exr", "nope-b.exr"], "nope-a.exr");
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
    let d = CLI.fresh_dir("messages");
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
    let render = ["render", s(&sc), "--backend", "cpu"];
    let err = CLI.fails_naming_all(&render, &["lines.obj", "no triangles"]);
    assert!(!err.contains("add a [[shapes]] table"), "{err}");

    // A malformed OBJ position: the line is named.
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 x 0\nf 1 2 3\n").unwrap();
    CLI.fails_naming_all(&render, &["line 3", "'x'"]);

    // OS errors once, not repeated by the error chain.
    let err = CLI.fails(&["diff", "nope-a.exr", "nope-b.exr"]);
    assert_eq!(err.matches("No such file").count(), 1, "{err}");

    // No Rust type names; huge numbers in scientific notation.
    let p = scene("types.toml", &|t| {
        t.replacen("fov_y = ", "fov_y = \"wide\" #", 1)
    });
    let err = CLI.fails(&["render", s(&p), "--backend", "cpu"]);
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
    let err = CLI.fails(&["render", s(&p), "--backend", "cpu"]);
    assert!(
        !err.contains("u32") && err.contains("whole number"),
        "{err}"
    );
    let p = scene("radius.toml", &|t| {
        t.replacen("radius = 1.0", "radius = -1e30", 1)
    });
    let err = CLI.fails(&["render", s(&p), "--backend", "cpu"]);
    assert!(err.contains("-1e30") && !err.contains("000000"), "{err}");

    // One range for Ward's alpha, whatever the bad value.
    let dirs = d.join("dirs.csv");
    std::fs::write(&dirs, "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n").unwrap();
    for a in ["-0.2", "0", "1.5"] {
        let m = format!(r#"model = "ward", alpha_x = {a}"#);
        let err = CLI.fails(&eval_args(&m, s(&dirs), &[]));
        assert!(err.contains("[0.001, 1]"), "alpha_x = {a}: {err}");
    }

    // brdf report --out naming a file.
    let file = d.join("report-file");
    std::fs::write(&file, b"x").unwrap();
    let err = CLI.fails_naming(
        &["brdf", "report", "--no-gpu", "--out", s(&file)],
        "is a file",
    );
    assert!(!err.contains("os error"), "{err}");
}

/// A driver list that points nowhere, a manifest that exists but is garbage (the loader says
/// "host memory allocation has failed") and one whose library is missing: each manifest tried
/// is named with what is wrong with it, and how to fix it.
#[test]
fn bad_driver_manifests_are_named_with_what_is_wrong() {
    let d = CLI.fresh_dir("manifests");
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
    let d = CLI.fresh_dir("gpu-options");
    let png = d.join("x.png");
    for extra in [
        vec!["--device", "llvmpipe"],
        vec!["--validation"],
        vec!["--wave-paths", "4096"],
        // Ignored whatever the value: a GPU range is not checked for the CPU.
        vec!["--wave-paths", "0"],
        vec!["--wave-paths", "4294967295"],
        vec!["--integrator", "megakernel"],
    ] {
        let mut args = extra.clone();
        args.extend(["--out", s(&png)]);
        let (_, err) = CLI.status(&render_args(&args), 0);
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
    let eval = eval_args(r#"model = "lambert""#, s(&dirs), &["--device", "llvmpipe"]);
    let (_, err) = CLI.status(&eval, 0);
    assert!(
        err.contains("warning: --device applies to the GPU backend only; ignored"),
        "{err}"
    );
    // --validation without the layer installed (the loader's explicit-layer search path
    // pointed at an empty directory) fails before any work, as its help says.
    let empty = CLI.fresh_dir("no-layers");
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
    common::assert_mentions(&err, &["--validation", "vulkan-validationlayers"]);
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

/// A name or value a user gave cannot reach the terminal as control characters: an escape
/// sequence or a newline in the scene's name, an output's name, a part's name and a value is
/// shown escaped, on every path a message takes (an error, a warning, the summary).
#[test]
fn control_characters_in_names_are_shown_escaped() {
    let d = CLI.fresh_dir("escapes");
    let text = std::fs::read_to_string(common::repo().join("scenes/cornell-box.toml")).unwrap();
    let evil = d.join("a\x1b[31mred\nscene.toml");
    std::fs::write(&evil, text.replace("spp = 16", "spp = 0")).unwrap();
    let out_name = d.join("o\x1b]0;title\x07.png");
    let part = d.join("p\x1b[2J.bwfilm");
    let runs: Vec<Vec<&str>> = vec![
        vec!["render", s(&evil), "--backend", "cpu"],
        vec![
            "render",
            "scenes/cornell-box.toml",
            "--backend",
            "cpu",
            "--spp",
            "1",
            "--res",
            "8x8",
            "--out",
            s(&out_name),
        ],
        vec!["merge", s(&part), "--out", s(&out_name)],
        vec!["diff", s(&out_name), "nope\x1b[5m.exr"],
        vec![
            "render",
            "scenes/xml/cornell-box.xml",
            "-D",
            "x=\x1b[1m",
            "--backend",
            "cpu",
            "--res",
            "8x8",
            "--spp",
            "1",
            "--out",
            s(&part),
        ],
    ];
    for args in runs {
        let o = CLI.run(&args);
        for (stream, bytes) in [("stdout", &o.stdout), ("stderr", &o.stderr)] {
            assert!(
                !bytes.contains(&0x1b) && !bytes.contains(&0x07),
                "{args:?}: a control character on {stream}: {:?}",
                String::from_utf8_lossy(bytes)
            );
        }
        let all = format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(
            all.contains("\\x1b"),
            "{args:?}: the escape is shown: {all}"
        );
    }
    // The newline in the scene's name does not split the error.
    let e = CLI.fails(&["render", s(&evil), "--backend", "cpu"]);
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(
        e.contains("red\\nscene.toml") && e.contains("integrator.spp"),
        "{e}"
    );
}

/// Messages that list what is accepted list all of it: `--error-map` takes figures (.svg,
/// .png) and images (.exr, .pfm).
#[test]
fn lists_of_what_is_accepted_are_complete() {
    let d = CLI.fresh_dir("lists");
    let a = d.join("a.pfm");
    brdfwave::imageio::write(&a, &brdfwave::imageio::Image::filled(4, 4, [0.5; 3])).unwrap();
    let e = CLI.fails(&["diff", s(&a), s(&a), "--error-map", s(&d.join("map.jpg"))]);
    for ext in [".svg", ".png", ".exr", ".pfm"] {
        assert!(e.contains(ext), "{ext}: {e}");
    }
    for ext in ["svg", "png", "exr", "pfm"] {
        CLI.ok(&[
            "diff",
            s(&a),
            s(&a),
            "--error-map",
            s(&d.join(format!("map.{ext}"))),
        ]);
    }
}

/// `merge` without `--samples` needs all the samples of the render the parts record: a lone
/// part of samples 8..16 of a 16-spp render is refused (it merged with exit 0 before), as are
/// parts of renders of different sample counts; `--samples 8..16` merges it, and the whole set
/// merges without it.
#[test]
fn merge_needs_every_sample_of_the_render() {
    let d = CLI.fresh_dir("merge-all");
    let part = |name: &str, spp: &str, samples: &str| {
        let p = d.join(name);
        CLI.ok(&[
            "render",
            "scenes/cornell-box.toml",
            "--backend",
            "cpu",
            "--res",
            "8x8",
            "--spp",
            spp,
            "--samples",
            samples,
            "--quiet",
            "--out",
            s(&p),
        ]);
        p
    };
    let late = part("late.bwfilm", "16", "8..16");
    let early = part("early.bwfilm", "16", "0..8");
    let other = part("other.bwfilm", "32", "0..8");
    let out = d.join("m.exr");
    let e = CLI.fails(&["merge", s(&late), "--out", s(&out)]);
    assert!(
        e.contains(
            "the parts hold samples 8..16, not the samples 0..16 of the whole 16-spp render"
        ),
        "{e}"
    );
    let e = CLI.fails(&["merge", s(&early), "--out", s(&out)]);
    assert!(
        e.contains("hold samples 0..8, not the samples 0..16"),
        "{e}"
    );
    assert!(!out.exists());
    let e = CLI.fails(&["merge", s(&late), s(&other), "--out", s(&out)]);
    // (With the default sampler the pattern differs too, so the scene hash already differs.)
    assert!(e.contains("come from different"), "{e}");
    CLI.ok(&["merge", s(&late), "--samples", "8..16", "--out", s(&out)]);
    CLI.fails_naming(
        &["merge", s(&late), "--samples", "0..16", "--out", s(&out)],
        "not the samples 0..16 asked for",
    );
    CLI.ok(&["merge", s(&late), s(&early), "--out", s(&out)]);
}

/// A measured table whose values overflow single precision once scaled is an error of every
/// command that reads it (it printed NaN with exit 0 before).
#[test]
fn measured_tables_that_overflow_are_refused() {
    let d = CLI.fresh_dir("merl-overflow");
    let cells = 90 * 90 * 180;
    let mut bytes: Vec<u8> = [90i32, 90, 180]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    for i in 0..3 * cells {
        let v: f64 = if i == cells + 1000 { 6e41 } else { 0.5 };
        bytes.extend(v.to_le_bytes());
    }
    let table = d.join("big.binary");
    std::fs::write(&table, bytes).unwrap();
    let dirs = d.join("dirs.csv");
    std::fs::write(&dirs, "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n").unwrap();
    let material = format!("model = \"measured\", file = \"{}\"", s(&table));
    for args in [
        eval_args(&material, s(&dirs), &["--backend", "cpu"]),
        vec![
            "brdf",
            "plot",
            "--material",
            &material,
            "--out",
            s(&d.join("p.svg")),
        ],
        vec![
            "brdf",
            "fit",
            "--measured",
            s(&table),
            "--out",
            s(&d.join("fit")),
        ],
    ] {
        let e = CLI.fails(&args);
        assert!(
            e.contains("6e41 scaled by MERL's 1.15/1500") && e.contains("green plane"),
            "{args:?}: {e}"
        );
    }
}
