//! `render --set`, `--threads` and `--quiet` as a user runs them: an override renders what the
//! edited file renders and is refused naming its key when wrong; the thread count changes the
//! pool, not the image; quiet prints nothing but errors; `--spp` with `--samples` renders a
//! part of that render.

mod common;

use common::cli::{s, Cli};

use brdfwave::imageio;
use std::path::Path;

const CLI: Cli = Cli {
    tag: "options",
    own_cache: true,
    env_remove: &["LP_NUM_THREADS"],
};
const GLOSSY: &str = "scenes/cornell-box-glossy.toml";
const SMALL: [&str; 4] = ["--backend", "cpu", "--res", "12x10"];

fn render_json(scene: &str, out: &Path, extra: &[&str]) -> serde_json::Value {
    let args = [
        &["render", scene, "--out", s(out), "--json"][..],
        &SMALL,
        extra,
    ]
    .concat();
    let (o, _) = CLI.status(&args, 0);
    serde_json::from_str(o.trim()).unwrap()
}

#[test]
fn set_renders_what_the_edited_file_renders() {
    let text = std::fs::read_to_string(common::repo().join(GLOSSY)).unwrap();
    let (old_rough, old_spp) = ("roughness = 0.2", "spp = 16");
    assert_eq!(
        (
            text.matches(old_rough).count(),
            text.matches(old_spp).count()
        ),
        (1, 1)
    );
    let edited = CLI.tmp("edited.toml");
    std::fs::write(
        &edited,
        text.replace(old_rough, "roughness = 0.05")
            .replace(old_spp, "spp = 3"),
    )
    .unwrap();
    let (a, b, plain) = (
        CLI.tmp("set.exr"),
        CLI.tmp("edited.exr"),
        CLI.tmp("plain.exr"),
    );
    let sets = [
        "--set",
        "materials.gold_rough.roughness=0.05",
        "--set",
        "integrator.spp=3",
    ];
    let j = render_json(GLOSSY, &a, &sets);
    assert_eq!(j["spp"], 3);
    render_json(s(&edited), &b, &[]);
    render_json(GLOSSY, &plain, &["--spp", "3"]);
    let (ia, ib, ip) = [&a, &b, &plain].map(|p| imageio::read(p).unwrap()).into();
    assert_eq!(ia, ib, "--set and the edited file render the same image");
    assert_ne!(ia, ip, "the override changed the image");
    let p = imageio::read_layered(&a).unwrap().provenance;
    assert_eq!(
        p.overrides,
        ["materials.gold_rough.roughness=0.05", "integrator.spp=3"]
    );
    // A string, an array and a new key; later overrides win.
    let j = render_json(
        GLOSSY,
        &a,
        &[
            "--set",
            "integrator.sampler=sobol",
            "--set",
            "integrator.sampler=independent",
            "--set",
            "materials.white.albedo=[0.5, 0.5, 0.5]",
        ],
    );
    assert_eq!(j["sampler"], "independent");
}

#[test]
fn a_wrong_override_is_refused_naming_its_key() {
    let out = CLI.tmp("bad.exr");
    for (set, needle) in [
        (
            "materials.white.roughnes=0.1",
            "--set materials.white.roughnes=0.1: scenes/cornell-box-glossy.toml:",
        ),
        (
            "materials.white.roughnes=0.1",
            "field 'roughnes': unknown field",
        ),
        ("integrator.spp=abc", "--set integrator.spp=abc: "),
        (
            "integrator.spp=abc",
            "field 'integrator.spp': invalid type: string \"abc\"",
        ),
        ("integrator.spp=-1", "--set integrator.spp=-1: "),
        ("camera.fov_y=\"wide\"", "--set camera.fov_y=\"wide\": "),
        (
            "shapes[99].x=1",
            "--set shapes[99].x=1: index 99 is past the end: 'shapes' has",
        ),
        (
            "integrator.spp.x=1",
            "'integrator.spp' is integer, which has no field 'x'",
        ),
        // Errors that name no overridden field: the override that makes them is named.
        (
            "shapes[0].transform.translate=x",
            "--set shapes[0].transform.translate=x: ",
        ),
        ("foo.bar=1", "--set foo.bar=1: "),
        // A table of the schema is described, not named by its Rust type.
        (
            "shapes[0].transform=0",
            "expected a transform table (translate, rotate, scale, matrix)",
        ),
    ] {
        let (_, e) = CLI.status(
            &[
                &["render", GLOSSY, "--out", s(&out), "--set", set][..],
                &SMALL,
            ]
            .concat(),
            1,
        );
        assert!(e.contains(needle), "{set}: {e}");
    }
    // Syntax errors are the option's.
    for set in ["spp", "a..b=1", "x=[1"] {
        let (_, e) = CLI.status(&["render", GLOSSY, "--set", set], 2);
        assert!(e.contains("--set"), "{set}: {e}");
    }
    // Another format.
    let other = CLI.tmp("scene.xml");
    std::fs::write(&other, "<scene/>").unwrap();
    let (_, e) = CLI.status(&["render", s(&other), "--set", "integrator.spp=1"], 1);
    assert!(e.contains("--set edits TOML scene files"), "{e}");
    assert!(!out.exists());
}

#[test]
fn threads_size_the_pool_and_leave_the_image_alone() {
    let (one, all) = (CLI.tmp("t1.exr"), CLI.tmp("tall.exr"));
    let j = render_json(GLOSSY, &one, &["--threads", "1", "--spp", "2"]);
    assert_eq!(j["threads"], 1);
    assert!(j["device"].as_str().unwrap().contains("(1 threads)"), "{j}");
    let j = render_json(GLOSSY, &all, &["--threads", "3", "--spp", "2"]);
    assert_eq!(j["threads"], 3);
    assert_eq!(imageio::read(&one).unwrap(), imageio::read(&all).unwrap());
    // lavapipe: LP_NUM_THREADS, the same image as without.
    let (g1, g) = (CLI.tmp("g1.exr"), CLI.tmp("g.exr"));
    let gpu = |out: &Path, extra: &[&str]| {
        let args = [
            &[
                "render",
                GLOSSY,
                "--res",
                "12x10",
                "--spp",
                "2",
                "--json",
                "--out",
                s(out),
            ][..],
            extra,
        ]
        .concat();
        let (o, e) = CLI.status(&args, 0);
        assert!(!e.contains("warning"), "{e}");
        serde_json::from_str::<serde_json::Value>(o.trim()).unwrap()
    };
    assert_eq!(gpu(&g1, &["--threads", "1"])["threads"], 1);
    assert_eq!(gpu(&g, &[])["threads"], serde_json::Value::Null);
    assert_eq!(imageio::read(&g1).unwrap(), imageio::read(&g).unwrap());
    for bad in ["0", "-2", "many", "5000"] {
        let (_, e) = CLI.status(&["render", GLOSSY, "--threads", bad], 2);
        assert!(e.contains("--threads"), "{bad}: {e}");
    }
}

#[test]
fn quiet_prints_nothing_but_errors() {
    let out = CLI.tmp("quiet.exr");
    let (o, e) = CLI.status(
        &[
            &["render", GLOSSY, "--spp", "1", "--quiet", "--out", s(&out)][..],
            &SMALL,
        ]
        .concat(),
        0,
    );
    assert_eq!((o.as_str(), e.as_str()), ("", ""));
    assert!(out.is_file());
    let (o, e) = CLI.status(
        &[
            &["render", GLOSSY, "--spp", "1", "--out", s(&out)][..],
            &SMALL,
        ]
        .concat(),
        0,
    );
    assert!(o.contains("wrote") && e.is_empty(), "{o}");
    let (o, e) = CLI.status(&["render", "scenes/none.toml", "--quiet"], 1);
    assert!(o.is_empty() && e.contains("scenes/none.toml"), "{e}");
    // With --json: the JSON summary alone, no bar, nothing on stderr.
    let (o, e) = CLI.status(
        &[
            &["render", GLOSSY, "--spp", "1", "--quiet", "--json"][..],
            &["--out", s(&out)],
            &SMALL,
        ]
        .concat(),
        0,
    );
    let j: serde_json::Value = serde_json::from_str(o.trim()).unwrap();
    assert_eq!((j["spp"].as_u64(), e.as_str()), (Some(1), ""), "{o}");
}

/// `--spp N --samples A..B` renders samples A..B of an N-spp render, as `--set
/// integrator.spp=N` does: the parts merge into the whole render bit for bit (CPU), with every
/// sampler (the multijitter pattern is sized by N); a range beyond N is refused naming both.
#[test]
fn spp_and_samples_together_render_a_part_of_that_render() {
    for sampler in ["multijitter", "sobol", "independent"] {
        let whole = CLI.tmp(&format!("whole-{sampler}.exr"));
        let common = ["--spp", "6", "--sampler", sampler, "--seed", "3"];
        render_json(GLOSSY, &whole, &common);
        let parts: Vec<_> = ["0..2", "2..5", "5..6"]
            .iter()
            .enumerate()
            .map(|(i, range)| {
                let p = CLI.tmp(&format!("part{i}-{sampler}.bwfilm"));
                let j = render_json(GLOSSY, &p, &[&common[..], &["--samples", range]].concat());
                assert_eq!(
                    j["samples"].to_string(),
                    format!("[{}]", range.replace("..", ","))
                );
                p
            })
            .collect();
        // The same part through --set, for the same render.
        let via_set = CLI.tmp(&format!("set-{sampler}.bwfilm"));
        render_json(
            GLOSSY,
            &via_set,
            &[
                "--set",
                "integrator.spp=6",
                "--sampler",
                sampler,
                "--seed",
                "3",
                "--samples",
                "2..5",
            ],
        );
        assert_eq!(
            std::fs::read(&via_set).unwrap().len(),
            std::fs::read(&parts[1]).unwrap().len()
        );
        let merged = CLI.tmp(&format!("merged-{sampler}.exr"));
        CLI.status(
            &[
                "merge",
                s(&parts[0]),
                s(&parts[2]),
                s(&via_set),
                "--out",
                s(&merged),
            ],
            0,
        );
        let (a, b) = (
            imageio::read(&whole).unwrap(),
            imageio::read(&merged).unwrap(),
        );
        assert!(
            a.data == b.data,
            "{sampler}: merged parts differ from the whole render"
        );
    }
    for (spp, samples) in [("6", "4..7"), ("1", "1..2"), ("6", "6..7")] {
        let e = CLI.fails(
            &[
                &["render", GLOSSY, "--spp", spp, "--samples", samples][..],
                &["--out", s(&CLI.tmp("no.bwfilm"))],
                &SMALL,
            ]
            .concat(),
        );
        assert!(
            e.contains(&format!("--samples {samples}")) && e.contains(&format!("--spp {spp}")),
            "{e}"
        );
    }
}

/// No two options of `render` refuse each other (as `--spp` and `--samples` did): every pair of
/// the options of `render --help` (which docs/cli/render.md lists, generated from it) renders. The table below must give every option there a
/// value (a new option fails this test until it is added, and so is checked too). GPU-only
/// options are given on the CPU backend, where they are ignored with a warning.
#[test]
fn every_pair_of_render_options_is_accepted() {
    let d = CLI.fresh_dir("pairs");
    let (exr, var, part) = (d.join("a.exr"), d.join("v.exr"), d.join("p.bwfilm"));
    let options: Vec<(&str, Vec<&str>)> = vec![
        ("-D", vec!["-D", "unused=1"]),
        ("--backend", vec!["--backend", "cpu"]),
        ("--spp", vec!["--spp", "4"]),
        ("--res", vec!["--res", "8x6"]),
        ("--max-depth", vec!["--max-depth", "3"]),
        ("--seed", vec!["--seed", "2"]),
        ("--sampler", vec!["--sampler", "sobol"]),
        ("--out", vec!["--out", s(&exr)]),
        ("--variance-out", vec!["--variance-out", s(&var)]),
        ("--device", vec!["--device", "llvmpipe"]),
        ("--validation", vec!["--validation"]),
        ("--wave-paths", vec!["--wave-paths", "128"]),
        ("--integrator", vec!["--integrator", "megakernel"]),
        ("--json", vec!["--json"]),
        ("--samples", vec!["--samples", "0..2"]),
        ("--tile", vec!["--tile", "0,0,4,4"]),
        ("--set", vec!["--set", "integrator.seed=3"]),
        ("--threads", vec!["--threads", "1"]),
        ("--batches", vec!["--batches", "2"]),
        ("--quiet", vec!["--quiet"]),
        ("--out .bwfilm", vec!["--out", s(&part)]),
    ];
    // The options of `render --help`: clap's own list, so that a new option fails here until
    // the table above gives it a value.
    let named = common::cli::help_options("render");
    assert!(named.len() > 15, "{named:?}");
    for o in &named {
        assert!(
            options.iter().any(|(name, _)| name == o),
            "{o} of `brdfwave render --help` has no value in this test"
        );
    }
    // -D applies to XML scenes: pairs with it render the XML twin.
    for (i, (a, va)) in options.iter().enumerate() {
        for (b, vb) in &options[i + 1..] {
            let xml = *a == "-D" || *b == "-D";
            let scene = match xml {
                true => "scenes/xml/cornell-box.xml",
                false => "scenes/cornell-box.toml",
            };
            if xml && (*a == "--set" || *b == "--set") {
                continue; // --set edits TOML scenes and -D sets XML parameters: no scene takes both.
            }
            let mut args = vec!["render", scene];
            args.extend(va);
            args.extend(vb);
            for (name, default) in [
                ("--backend", ["--backend", "cpu"]),
                ("--res", ["--res", "8x8"]),
                ("--spp", ["--spp", "2"]),
            ] {
                if !args.contains(&name) {
                    args.extend(default);
                }
            }
            if !args.contains(&"--out") {
                args.extend(["--out", s(&exr)]);
            }
            let o = CLI.run(&args);
            assert!(
                o.status.success(),
                "{a} with {b} is refused: {args:?}\n{}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
    }
}
