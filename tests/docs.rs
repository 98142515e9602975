//! The documentation, run: every command shown in README.md, scenes/README.md and the pages under
//! docs/ is parsed from the Markdown and run (large renders made small, outputs in a temporary
//! directory), the option reference of docs/cli/ is compared with what the program generates
//! from its clap definitions, the scene and model tables with the files and models that exist,
//! and the example materials and scenes are loaded and must give no warning. A command the docs
//! gain that this file does not know how to run fails the test, so the docs cannot drift from
//! the program again.

mod common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_brdfwave"))
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(common::repo().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// Fenced code blocks: (info string, body).
fn code_blocks(md: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut current: Option<(String, String)> = None;
    for line in md.lines() {
        if let Some(info) = line.trim_start().strip_prefix("```") {
            match current.take() {
                Some(block) => out.push(block),
                None => current = Some((info.trim().to_string(), String::new())),
            }
        } else if let Some((_, body)) = current.as_mut() {
            body.push_str(line);
            body.push('\n');
        }
    }
    assert!(current.is_none(), "unterminated code block");
    out
}

/// Inline code spans outside fenced blocks.
fn inline_spans(md: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_block = false;
    for line in md.lines() {
        if line.trim_start().starts_with("```") {
            in_block = !in_block;
            continue;
        }
        if in_block {
            continue;
        }
        let parts: Vec<&str> = line.split('`').collect();
        for (i, p) in parts.iter().enumerate() {
            if i % 2 == 1 && i + 1 < parts.len() {
                out.push(p.to_string());
            }
        }
    }
    out
}

/// Splits a command line as the shell does for the forms the docs use: words, '…' and "…".
fn shell_words(line: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut cur = String::new();
    let mut in_word = false;
    let mut chars = line.chars();
    while let Some(c) = chars.next() {
        match c {
            '\'' | '"' => {
                in_word = true;
                for d in chars.by_ref() {
                    if d == c {
                        break;
                    }
                    cur.push(d);
                }
            }
            c if c.is_whitespace() => {
                if in_word {
                    words.push(std::mem::take(&mut cur));
                    in_word = false;
                }
            }
            c => {
                in_word = true;
                cur.push(c);
            }
        }
    }
    if in_word {
        words.push(cur);
    }
    words
}

fn run(args: &[String], dir: &Path) -> Output {
    let out = bin()
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run brdfwave");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "brdfwave {args:?} failed ({}):\n{stderr}",
        out.status
    );
    assert!(
        !stderr.contains("warning") && !stderr.contains("panicked"),
        "brdfwave {args:?} warned:\n{stderr}"
    );
    out
}

/// Every page whose commands this file runs: README.md, scenes/README.md and every Markdown
/// page under docs/, in that order (docs/ sorted by path), but the benchmarks' history
/// (docs/bench-log.md): a record of what was run at past commits, not examples.
fn pages() -> Vec<String> {
    let mut docs = Vec::new();
    let mut stack = vec![common::repo().join("docs")];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "md") && !p.ends_with("bench-log.md") {
                let rel = p.strip_prefix(common::repo()).unwrap();
                docs.push(rel.to_string_lossy().into_owned());
            }
        }
    }
    docs.sort();
    assert!(docs.len() >= 15, "docs/ has {} pages", docs.len());
    ["README.md".to_string(), "scenes/README.md".to_string()]
        .into_iter()
        .chain(docs)
        .collect()
}

/// The page without its generated option blocks (`brdfwave docs`): the commands in their help
/// texts are not examples.
fn without_generated(md: &str) -> String {
    let mut out = String::new();
    let mut skipping = false;
    for line in md.lines() {
        if line.starts_with("<!-- begin options: ") {
            skipping = true;
        } else if line.starts_with("<!-- end options: ") {
            skipping = false;
        } else if !skipping {
            out.push_str(line);
            out.push('\n');
        }
    }
    out
}

/// The directory the docs' commands run in: the repository's inputs (scenes, docs, tests,
/// scripts, assets) linked in, and a fresh `out/` for what the commands write.
struct Sandbox {
    dir: tempfile::TempDir,
}

impl Sandbox {
    const LINKED: [&'static str; 5] = ["scenes", "docs", "tests", "scripts", "assets"];

    fn new() -> Sandbox {
        let dir = tempfile::tempdir().unwrap();
        for name in Self::LINKED {
            std::os::unix::fs::symlink(common::repo().join(name), dir.path().join(name)).unwrap();
        }
        Sandbox { dir }
    }

    fn path(&self) -> &Path {
        self.dir.path()
    }
}

/// The options whose value is a file or directory a command writes.
const OUTPUT_OPTIONS: [&str; 6] = [
    "--out",
    "--variance-out",
    "--error-map",
    "--triptych",
    "--p-map",
    "--failures",
];

/// The samples of a render above which a docs example is made smaller here (about a second on
/// lavapipe): `--res` becomes 32x32 and then `--spp` 256.
const MAX_SAMPLES: u64 = 1 << 20;

/// Runs `brdfwave ARGS` as the docs show it in the sandbox, made small where it is large: a
/// render of more than [`MAX_SAMPLES`] samples gets `--res 32x32` (and `--spp 256` if that is not
/// enough), a render without `--res` or `--spp` gets 32x32 and 4 (its scene's size may be
/// large), `--budget` is at most 2 s, and `brdf fit` compares 1000 cells. Everything it writes
/// must be a relative path outside the repository's linked directories, and must exist after.
/// `> FILE` sends stdout to FILE.
fn run_small(args: &[String], sandbox: &Path, page: &str) {
    let (args, stdout_to) = match args.iter().position(|a| a == ">") {
        Some(i) => (&args[..i], args.get(i + 1).cloned()),
        None => (args, None),
    };
    let mut a = args.to_vec();
    let value = |a: &[String], name: &str| {
        a.iter()
            .position(|x| x == name)
            .and_then(|i| a.get(i + 1).cloned())
    };
    let render = a.first().map(String::as_str) == Some("render");
    if render {
        let spp: u64 = value(&a, "--spp").map_or(64, |s| s.parse().unwrap());
        let res = value(&a, "--res").map(|r| {
            let (w, h) = r.split_once('x').unwrap();
            w.parse::<u64>().unwrap() * h.parse::<u64>().unwrap()
        });
        let partial = value(&a, "--samples").is_some();
        for i in 0..a.len().saturating_sub(1) {
            match a[i].as_str() {
                "--res" if res.unwrap() * spp > MAX_SAMPLES => a[i + 1] = "32x32".into(),
                "--spp" if !partial && 1024 * spp > MAX_SAMPLES => a[i + 1] = "256".into(),
                _ => {}
            }
        }
        if res.is_none() {
            a.extend(["--res".into(), "32x32".into()]);
        }
        if value(&a, "--spp").is_none() && !partial {
            a.extend(["--spp".into(), "4".into()]);
        }
    }
    for i in 0..a.len().saturating_sub(1) {
        if a[i] == "--budget" {
            let b: f64 = a[i + 1].parse().unwrap();
            a[i + 1] = b.min(2.0).to_string();
        }
    }
    // The traversal benchmark made small, and on brdfwave's side alone where the driver has
    // no ray queries (Debian 12's Mesa; tests/rays.rs checks both sides where it has them).
    if a.first().map(String::as_str) == Some("rays") {
        if value(&a, "--res").is_none() {
            a.extend(["--res".into(), "16x16".into()]);
        }
        if value(&a, "--repeats").is_none() {
            a.extend(["--repeats".into(), "1".into()]);
        }
        if !a.contains(&"--ours-only".to_string()) {
            a.push("--ours-only".into());
        }
    }
    if a.starts_with(&["brdf".into(), "fit".into()]) && value(&a, "--samples").is_none() {
        a.extend(["--samples".into(), "1000".into()]);
    }
    let mut outs: Vec<PathBuf> = Vec::new();
    for i in 0..a.len().saturating_sub(1) {
        if OUTPUT_OPTIONS.contains(&a[i].as_str()) {
            outs.push(PathBuf::from(&a[i + 1]));
        }
    }
    outs.extend(stdout_to.iter().map(PathBuf::from));
    for o in &outs {
        let first = o.components().next().unwrap().as_os_str().to_string_lossy();
        assert!(
            o.is_relative() && !Sandbox::LINKED.contains(&first.as_ref()),
            "{page}: `brdfwave {}` writes {}: examples write under out/, not into the repository",
            args.join(" "),
            o.display()
        );
    }
    let t = std::time::Instant::now();
    let out = run(&a, sandbox);
    println!(
        "{page}: {:.1} s: brdfwave {}",
        t.elapsed().as_secs_f64(),
        a.join(" ")
    );
    if let Some(f) = &stdout_to {
        std::fs::write(sandbox.join(f), &out.stdout).unwrap();
    }
    for o in &outs {
        assert!(
            sandbox.join(o).exists(),
            "{page}: `brdfwave {}` did not write {}",
            args.join(" "),
            o.display()
        );
    }
}

/// A fenced block's lines, continuation lines (`\` at the end) joined, comments and blank lines
/// left out.
fn block_lines(body: &str) -> Vec<String> {
    body.replace("\\\n", " ")
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(String::from)
        .collect()
}

/// The first words of a line in a `text` block that make it a command to run.
const COMMAND_WORDS: [&str; 6] = [
    "brdfwave",
    "target/release/brdfwave",
    "nice",
    "bash",
    "cargo",
    "sudo",
];

/// `brdfwave ARGS`, `target/release/brdfwave ARGS` and either after `nice -n N`: the ARGS.
fn brdfwave_args(words: &[&str]) -> Option<Vec<String>> {
    let w = match words {
        ["nice", "-n", _, rest @ ..] => rest,
        w => w,
    };
    match w {
        ["brdfwave" | "target/release/brdfwave", args @ ..] => {
            Some(args.iter().map(|s| s.to_string()).collect())
        }
        _ => None,
    }
}

/// What the pages show, run: the README's two commands (which must be `.ci/run`'s, verbatim),
/// and every command of every page's `sh` and `text` blocks, of the CI example's `run:` steps and
/// of its inline code, in the page's order and in one sandbox (a command may read what an
/// earlier one wrote; a command shown twice runs once). A line this test does not know how to
/// run fails it. Not run, but checked: `bash` blocks (the Slurm and Kubernetes lines, which
/// `scripts/scheduler-check.sh` runs, opt-in) and the opt-in `cargo test … -- --ignored` lines,
/// whose tests must exist and be marked `#[ignore]`.
#[test]
fn every_command_of_every_page_runs() {
    let ci = read(".ci/run");
    let setup = read("scripts/setup.sh");
    let sandbox = Sandbox::new();
    let sb = sandbox.path();
    let mut done: BTreeSet<String> = BTreeSet::new();
    let (mut rendered, mut tested, mut ran) = (false, false, 0);
    for page in pages() {
        let md = without_generated(&read(&page));
        let readme = page == "README.md";
        let mut lines: Vec<(String, bool)> = Vec::new(); // (line, from the CI example)
        for (info, body) in code_blocks(&md) {
            match info.as_str() {
                "sh" => lines.extend(block_lines(&body).into_iter().map(|l| (l, false))),
                // Text blocks also hold file fragments and output: their lines that start
                // like a command are commands.
                "text" => lines.extend(
                    block_lines(&body)
                        .into_iter()
                        .filter(|l| {
                            let first = l.split_whitespace().next().unwrap_or_default();
                            COMMAND_WORDS.contains(&first)
                        })
                        .map(|l| (l, false)),
                ),
                "yaml" => lines.extend(
                    body.lines()
                        .filter_map(|l| l.trim().strip_prefix("$B "))
                        .map(|l| (format!("brdfwave {l}"), true)),
                ),
                "bash" => assert!(
                    block_lines(&body).iter().all(|l| [
                        "sbatch",
                        "scontrol",
                        "scancel",
                        "kubectl",
                        "export ",
                        "task=",
                        "bash scripts/scheduler-check.sh"
                    ]
                    .iter()
                    .any(|k| l.contains(k))),
                    "{page}: a `bash` block is for cluster commands that only the opt-in \
                     scripts/scheduler-check.sh runs; show other commands in `sh` blocks:\n{body}"
                ),
                "rust" | "toml" | "json" | "xml" | "" => {}
                other => panic!(
                    "{page}: a code block of kind `{other}`, which tests/docs.rs does not know"
                ),
            }
        }
        // Headings name commands (`# \`brdfwave render\``); the text shows them.
        let text: String = md
            .lines()
            .filter(|l| !l.starts_with('#'))
            .map(|l| format!("{l}\n"))
            .collect();
        for span in inline_spans(&text) {
            if span.starts_with("brdfwave ") {
                assert!(!span.contains('|'), "{page}: cannot run `{span}`");
                lines.push((span, false));
            }
        }
        for (line, _) in &lines {
            for cmd in line.split("&&").map(str::trim) {
                let words = shell_words(cmd);
                let w: Vec<&str> = words.iter().map(String::as_str).collect();
                if let Some(args) = brdfwave_args(&w) {
                    if done.insert(args.join("\u{1f}")) {
                        run_small(&args, sb, &page);
                        ran += 1;
                    }
                    continue;
                }
                match w.as_slice() {
                    ["bash", "scripts/setup.sh"] => {
                        assert!(common::repo().join("scripts/setup.sh").is_file())
                    }
                    ["sudo", "apt-get", "install", pkgs @ ..] => {
                        for p in pkgs {
                            assert!(
                                setup
                                    .split(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
                                    .any(|x| x == *p),
                                "{page} installs {p}, scripts/setup.sh does not"
                            );
                        }
                    }
                    ["cargo", "test", "--release"] if readme => {
                        assert!(
                            ci.lines().any(|l| l.trim() == line),
                            ".ci/run does not run the README's command verbatim: {line}"
                        );
                        tested = true;
                    }
                    ["cargo", "run", "--release", "--", args @ ..] if readme => {
                        assert!(
                            ci.lines().any(|l| l.trim() == line),
                            ".ci/run does not run the README's command verbatim: {line}"
                        );
                        let args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
                        run_small(&args, sb, &page);
                        rendered |= args.first().map(String::as_str) == Some("render");
                    }
                    ["cargo", "test", "--release", "--test", name, "--", "--ignored", "--nocapture"] =>
                    {
                        let t = read(&format!("tests/{name}.rs"));
                        assert!(
                            t.contains("#[ignore"),
                            "{page}: tests/{name}.rs is shown as opt-in but has no #[ignore]d test"
                        );
                    }
                    ["bash", "scripts/material-preview.sh"] => common::material_preview_table(),
                    // Minutes of work (two full builds; Mitsuba 3 for the Embree rays): shown,
                    // not run; the script must exist and parse.
                    ["bash", script @ ("scripts/embree-rays.sh" | "scripts/pgo-build.sh"), ..] => {
                        let ok = Command::new("bash")
                            .args(["-n", script])
                            .current_dir(common::repo())
                            .status()
                            .is_ok_and(|s| s.success());
                        assert!(ok, "{page}: {script} is missing or does not parse");
                    }
                    ["bash", "scripts/render-parts.sh", args @ ..] => {
                        let mut a: Vec<String> = args.iter().map(|s| s.to_string()).collect();
                        // SCENE SPP PARTS JOBS OUT [render options]: the render made small.
                        for i in 5..a.len().saturating_sub(1) {
                            if a[i] == "--res" {
                                a[i + 1] = "32x32".into();
                            }
                        }
                        let o = Command::new("bash")
                            .arg("scripts/render-parts.sh")
                            .args(&a)
                            .env("BRDFWAVE", env!("CARGO_BIN_EXE_brdfwave"))
                            .current_dir(sb)
                            .output()
                            .unwrap();
                        assert!(
                            o.status.success() && sb.join(&a[4]).is_file(),
                            "{page}: {cmd}:\n{}",
                            String::from_utf8_lossy(&o.stderr)
                        );
                        ran += 1;
                    }
                    other => panic!("{page} shows a command tests/docs.rs cannot run: {other:?}"),
                }
            }
        }
    }
    assert!(
        rendered && tested,
        "README.md lost its render or test command"
    );
    assert!(ran >= 30, "only {ran} commands ran");
}

/// The option reference in docs/cli/*.md is what `brdfwave docs` generates from the clap
/// definitions now (`BRDFWAVE_WRITE_DOCS=1` rewrites it instead of failing).
#[test]
fn generated_option_reference_is_current() {
    let mut args = vec!["docs".to_string(), "--root".to_string()];
    args.push(common::repo().display().to_string());
    if std::env::var_os("BRDFWAVE_WRITE_DOCS").is_some() {
        args.push("--write".into());
    }
    let out = bin().args(&args).output().expect("run brdfwave docs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Every visible command and subcommand (from the binary's own --help) has a page under
/// docs/cli/ that shows it, and every option and argument of its --help has help text.
#[test]
fn every_command_has_a_page_and_every_option_is_explained() {
    let help = |args: &[&str]| -> String {
        let mut a: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        a.push("--help".into());
        String::from_utf8(run(&a, &common::repo()).stdout).unwrap()
    };
    let commands_of = |text: &str| -> Vec<String> {
        text.lines()
            .skip_while(|l| *l != "Commands:")
            .skip(1)
            .take_while(|l| l.starts_with("  "))
            .filter_map(|l| l.split_whitespace().next())
            .filter(|n| *n != "help")
            .map(String::from)
            .collect()
    };
    let top = commands_of(&help(&[]));
    assert!(top.len() >= 8, "{top:?}");
    let mut checked = 0;
    for c in &top {
        let page = read(&format!("docs/cli/{c}.md"));
        let subs = commands_of(&help(&[c]));
        let paths: Vec<Vec<&str>> = if subs.is_empty() {
            vec![vec![c.as_str()]]
        } else {
            subs.iter().map(|s| vec![c.as_str(), s.as_str()]).collect()
        };
        for path in paths {
            assert!(
                page.contains(&format!("<!-- begin options: {} -->", path.join(" "))),
                "docs/cli/{c}.md does not document `brdfwave {}`",
                path.join(" ")
            );
            let text = help(&path);
            let mut section = "";
            for line in text.lines() {
                if line.ends_with(':') && !line.starts_with(' ') {
                    section = line;
                    continue;
                }
                if (section == "Options:" || section == "Arguments:") && !line.trim().is_empty() {
                    let t = line.trim_start();
                    if t.starts_with('-') || t.starts_with('<') || t.starts_with('[') {
                        // The text after the option (clap's own "[default: …]" does not count).
                        let described = t
                            .split("  ")
                            .skip(1)
                            .map(str::trim)
                            .any(|part| !part.is_empty() && !part.starts_with('['));
                        assert!(
                            described,
                            "`brdfwave {} --help`: no help text for: {t}",
                            path.join(" ")
                        );
                        checked += 1;
                    }
                }
            }
        }
    }
    assert!(checked > 60, "{checked} options");
}

/// The example materials (the inline `'model = …'` of every page, scenes/README's
/// `[materials.…]` blocks) and the example scene load without a warning.
#[test]
fn example_materials_and_scenes_load_without_warnings() {
    let tmp = tempfile::tempdir().unwrap();
    let dirs = tmp.path().join("dirs.csv");
    std::fs::write(&dirs, "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n").unwrap();
    let eval = |material: &str| {
        let args = [
            "brdf",
            "eval",
            "--material",
            material,
            "--dirs",
            dirs.to_str().unwrap(),
        ]
        .map(String::from);
        run(&args, &common::repo());
    };
    let mut materials = 0;
    for span in pages()
        .iter()
        .flat_map(|p| inline_spans(&without_generated(&read(p))))
    {
        if let Some(m) = span.strip_prefix('\'').and_then(|s| s.strip_suffix('\'')) {
            if m.starts_with("model = ") {
                eval(m);
                materials += 1;
            }
        }
    }
    let mut scenes = 0;
    for (info, body) in code_blocks(&read("scenes/README.md")) {
        if info != "toml" {
            continue;
        }
        if body.contains("[camera]") {
            let p = tmp.path().join(format!("example-{scenes}.toml"));
            std::fs::write(&p, &body).unwrap();
            let out = tmp.path().join("example.png");
            let args: Vec<String> = ["render", p.to_str().unwrap()]
                .into_iter()
                .chain(common::QUICK_RENDER)
                .chain(["--out", out.to_str().unwrap()])
                .map(String::from)
                .collect();
            run(&args, &common::repo());
            scenes += 1;
        } else if body.starts_with("[[lights]]") {
            // Lights: added to a small lit-by-nothing-else scene, which must then load cleanly.
            let src = format!(
                "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\nfov_y = 30\n[film]\nwidth = 4\n\
                 height = 4\n[materials.m]\nmodel = \"lambert\"\n[[shapes]]\nmaterial = \"m\"\n\
                 sphere = {{ center = [0, 0, 0], radius = 1 }}\n{body}"
            );
            let s = brdfwave::scene::load_str(&src, Path::new("lights-example.toml"))
                .unwrap_or_else(|e| panic!("scenes/README.md: the lights example: {e}"));
            assert!(
                s.warnings.is_empty() && !s.lights.is_empty(),
                "{:?}",
                s.warnings
            );
        } else {
            let mut lines = body.lines();
            let header = lines.next().unwrap_or_default();
            assert!(
                header.starts_with("[materials."),
                "scenes/README.md: a toml block that is neither a scene nor a material:\n{body}"
            );
            eval(&lines.collect::<Vec<_>>().join("\n"));
            materials += 1;
        }
    }
    assert!(
        materials >= 2 && scenes >= 1,
        "{materials} materials, {scenes} scenes"
    );
}

/// Both scene tables (docs/scenes.md, scenes/README.md) list exactly the shipped scenes.
#[test]
fn scene_and_model_tables_are_complete() {
    let shipped: BTreeSet<String> = std::fs::read_dir(common::repo().join("scenes"))
        .unwrap()
        .filter_map(|e| {
            let n = e.unwrap().file_name().to_string_lossy().into_owned();
            n.ends_with(".toml").then_some(n)
        })
        .collect();
    assert!(shipped.len() >= 7);
    let table_entries = |doc: &str, prefix: &str| -> BTreeSet<String> {
        read(doc)
            .lines()
            .filter_map(|l| l.strip_prefix(&format!("| `{prefix}")))
            .filter_map(|l| l.split('`').next())
            .filter(|n| n.ends_with(".toml"))
            .map(String::from)
            .collect()
    };
    assert_eq!(
        table_entries("docs/scenes.md", "scenes/"),
        shipped,
        "docs/scenes.md"
    );
    assert_eq!(
        table_entries("scenes/README.md", ""),
        shipped,
        "scenes/README.md"
    );
}

/// Every model's parameter documentation is the text generated from its declared parameters
/// (`brdf::docs`): the table at the top of `src/brdf/<model>.rs`, its row of docs/models.md's
/// model table and its row of scenes/README.md's table. `BRDFWAVE_WRITE_DOCS=1` rewrites them instead.
#[test]
fn model_parameter_tables_are_generated_from_the_declarations() {
    use brdfwave::brdf::{docs, ModelInfo, MODELS};
    let write = std::env::var_os("BRDFWAVE_WRITE_DOCS").is_some();
    let mut failures = Vec::new();
    let mut unwritable = Vec::new();
    type Row = fn(&ModelInfo) -> String;
    let rows: [(&str, Row); 2] = [
        ("docs/models.md", docs::models_page_row),
        ("scenes/README.md", docs::scenes_readme_row),
    ];
    for (doc, row) in rows {
        let text = read(doc);
        let (want, missing) = docs::update_rows(&text, &MODELS, row);
        for m in missing {
            failures.push(format!("{doc}: no table row for the model {m}"));
            // A row that writing cannot add (no row of the model before it to follow).
            if !want.lines().any(|l| docs::is_row_of(l, m)) {
                unwritable.push(format!("{doc}: no place for the row of the model {m}"));
            }
        }
        if want != text {
            if write {
                std::fs::write(common::repo().join(doc), &want).unwrap();
            }
            for (got, want) in text.lines().zip(want.lines()).filter(|(a, b)| a != b) {
                failures.push(format!("{doc}: row\n  {got}\nshould be\n  {want}"));
            }
        }
    }
    for m in MODELS.iter() {
        let file = [
            format!("src/brdf/{}.rs", m.name),
            format!("src/brdf/{}/mod.rs", m.name),
        ]
        .into_iter()
        .find(|f| common::repo().join(f).is_file())
        .unwrap_or_else(|| format!("src/brdf/{}.rs", m.name));
        let text = read(&file);
        let Some(want) = docs::update_model_file(&text, m) else {
            failures.push(format!(
                "{file}: no parameter table (lines starting `//! |`)"
            ));
            continue;
        };
        if want != text {
            if write {
                std::fs::write(common::repo().join(&file), &want).unwrap();
            }
            failures.push(format!(
                "{file}: the parameter table should be\n{}",
                docs::model_file_table(m)
            ));
        }
    }
    // The table of a texture's fields, generated from their declaration.
    let table = docs::texture_fields_table();
    if !read("scenes/README.md").contains(&table) {
        failures.push(format!(
            "scenes/README.md: the texture fields' table should be\n{table}"
        ));
    }
    assert!(unwritable.is_empty(), "{}", unwritable.join("\n"));
    assert!(
        failures.is_empty() || write,
        "{}\n(BRDFWAVE_WRITE_DOCS=1 cargo test --release --test docs rewrites them)",
        failures.join("\n")
    );
}

/// Nothing in the repository cites notes that are not part of it: comments
/// cite the papers, and what the code needs is in the repository's own docs.
#[test]
fn no_citations_of_files_outside_the_repository() {
    // Built at run time so that this file does not match itself.
    let banned = [
        format!("brdf-{}.md", "models"),
        format!("{}-anchors", "renderer"),
        format!("../{}/", "shared"),
        format!("{}/data/", "shared"),
        format!("{}/reference/", "shared"),
    ];
    let mut stack = vec![common::repo()];
    let mut checked = 0;
    while let Some(p) = stack.pop() {
        let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
        if p.is_dir() {
            if matches!(name.as_deref(), Some("target" | ".git")) {
                continue;
            }
            for e in std::fs::read_dir(&p).unwrap() {
                stack.push(e.unwrap().path());
            }
            continue;
        }
        let Ok(text) = std::fs::read_to_string(&p) else {
            continue; // binary
        };
        checked += 1;
        for b in &banned {
            assert!(!text.contains(b.as_str()), "{} cites {b}", p.display());
        }
    }
    assert!(checked > 50, "{checked} files");
}

/// The layers import downwards only, so that no import circle crosses them: the scene loader
/// knows nothing of the renderers and the image files nothing of scenes or films (limits that
/// several layers share live in `src/conventions.rs`). Comments and test modules are not
/// imports.
#[test]
fn layers_do_not_import_the_layers_above_them() {
    let rules: [(&str, &[&str]); 3] = [
        (
            "src/scene",
            &[
                "crate::gpu",
                "crate::vk",
                "crate::render",
                "crate::output",
                "crate::cpu",
            ],
        ),
        (
            "src/imageio",
            &[
                "crate::scene",
                "crate::film",
                "crate::gpu",
                "crate::output",
                "crate::render",
            ],
        ),
        ("src/conventions.rs", &["use crate::"]),
    ];
    let mut bad = Vec::new();
    let mut checked = 0;
    for (root, banned) in rules {
        let mut stack = vec![common::repo().join(root)];
        while let Some(p) = stack.pop() {
            if p.is_dir() {
                stack.extend(std::fs::read_dir(&p).unwrap().map(|e| e.unwrap().path()));
                continue;
            }
            checked += 1;
            let text = std::fs::read_to_string(&p).unwrap();
            for (n, line) in text.lines().enumerate() {
                if line.starts_with("#[cfg(test)]") {
                    break;
                }
                let code = line.split("//").next().unwrap_or("");
                for b in banned.iter().filter(|b| code.contains(*b)) {
                    bad.push(format!("{}:{}: {b}: {}", p.display(), n + 1, line.trim()));
                }
            }
        }
    }
    assert!(checked > 20, "{checked} files");
    assert!(
        bad.is_empty(),
        "imports against the layering:\n{}",
        bad.join("\n")
    );
}

/// GitHub's anchor of a heading: lower case, punctuation dropped (but `-` and `_`), spaces to `-`.
fn anchor(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || matches!(c, ' ' | '-' | '_'))
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// Every relative link of every page (README.md, BENCHMARKS.md, scenes/README.md, docs/ with
/// its history) names a file or directory that exists, and a `#part` of a Markdown file one of
/// its headings: the pages link to each other and must not break when one moves.
#[test]
fn links_between_pages_resolve() {
    let mut all = pages();
    all.extend(["BENCHMARKS.md".to_string(), "docs/bench-log.md".to_string()]);
    let mut bad = Vec::new();
    let mut checked = 0;
    for page in &all {
        let md = read(page);
        let dir = Path::new(page).parent().unwrap().to_path_buf();
        let mut in_block = false;
        for line in md.lines() {
            if line.trim_start().starts_with("```") {
                in_block = !in_block;
            }
            if in_block {
                continue;
            }
            for part in line.split("](").skip(1) {
                let Some(target) = part.split(')').next() else {
                    continue;
                };
                if target.contains("://") || target.starts_with("mailto:") || target.is_empty() {
                    continue;
                }
                let (file, frag) = target.split_once('#').unwrap_or((target, ""));
                let path = if file.is_empty() {
                    PathBuf::from(page)
                } else {
                    dir.join(file)
                };
                checked += 1;
                let full = common::repo().join(&path);
                if !full.exists() {
                    bad.push(format!("{page}: ({target}): no {}", path.display()));
                    continue;
                }
                if !frag.is_empty() && full.extension().is_some_and(|e| e == "md") {
                    let text = std::fs::read_to_string(&full).unwrap();
                    let found = text
                        .lines()
                        .filter_map(|l| l.strip_prefix('#'))
                        .map(|h| h.trim_start_matches('#'))
                        .any(|h| anchor(h) == frag);
                    if !found {
                        bad.push(format!("{page}: ({target}): no heading #{frag}"));
                    }
                }
            }
        }
    }
    assert!(checked > 60, "{checked} links");
    assert!(bad.is_empty(), "broken links:\n{}", bad.join("\n"));
}
