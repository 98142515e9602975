//! The documentation, run: every command shown in README.md and scenes/README.md is parsed from
//! the Markdown and run (renders with a tiny --res and --spp, outputs under a temporary
//! directory), the command-line synopsis is compared with the binary's --help, the scene and
//! model tables with the files and models that exist, and the example materials and scenes are
//! loaded and must give no warning. A command the docs gain that this file does not know how to
//! run fails the test, so the docs cannot drift from the program again.

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

/// Runs `brdfwave ARGS` as the docs show it, made small: `--res` becomes 16x16, `--spp` 2, and
/// every `--out`/`--variance-out`/`--error-map` path is moved under `tmp` (keeping its
/// relative directories, which do not exist there yet). Returns the output paths.
fn run_small(args: &[String], tmp: &Path) -> Vec<PathBuf> {
    let mut a = args.to_vec();
    let mut outs = Vec::new();
    for i in 0..a.len().saturating_sub(1) {
        match a[i].as_str() {
            "--res" => a[i + 1] = "16x16".into(),
            "--spp" => a[i + 1] = "2".into(),
            "--out" | "--variance-out" | "--error-map" => {
                let p = tmp.join(&a[i + 1]);
                a[i + 1] = p.display().to_string();
                outs.push(p);
            }
            _ => {}
        }
    }
    run(&a, &common::repo());
    for p in &outs {
        assert!(
            p.is_file(),
            "brdfwave {args:?} did not write {}",
            p.display()
        );
    }
    outs
}

/// The shell commands of README.md's `sh` blocks, one per line (`&&` chains kept whole).
fn readme_command_lines() -> Vec<String> {
    code_blocks(&read("README.md"))
        .into_iter()
        .filter(|(info, _)| info == "sh")
        .flat_map(|(_, body)| {
            body.replace("\\\n", " ")
                .lines()
                .map(str::trim)
                .filter(|l| !l.is_empty() && !l.starts_with('#'))
                .map(String::from)
                .collect::<Vec<_>>()
        })
        .collect()
}

#[test]
fn readme_commands_run_and_are_what_ci_runs() {
    let ci = read(".ci/run");
    let setup = read("scripts/setup.sh");
    let tmp = tempfile::tempdir().unwrap();
    let lines = readme_command_lines();
    let mut rendered = false;
    let mut tested = false;
    for line in &lines {
        for cmd in line.split("&&").map(str::trim) {
            let w = shell_words(cmd);
            let w: Vec<&str> = w.iter().map(String::as_str).collect();
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
                            "README installs {p}, scripts/setup.sh does not"
                        );
                    }
                }
                ["cargo", "test", "--release"] => {
                    assert!(
                        ci.lines().any(|l| l.trim() == line),
                        ".ci/run does not run the README's command verbatim: {line}"
                    );
                    tested = true;
                }
                ["cargo", "run", "--release", "--", args @ ..] => {
                    assert!(
                        ci.lines().any(|l| l.trim() == line),
                        ".ci/run does not run the README's command verbatim: {line}"
                    );
                    let args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
                    run_small(&args, tmp.path());
                    rendered |= args.first().map(String::as_str) == Some("render");
                }
                other => panic!("README.md shows a command tests/docs.rs cannot run: {other:?}"),
            }
        }
    }
    assert!(
        rendered && tested,
        "README.md lost its render or test command"
    );
}

/// `brdfwave …` commands in inline code (e.g. `brdfwave devices`) of both READMEs run.
#[test]
fn inline_commands_run() {
    let tmp = tempfile::tempdir().unwrap();
    let mut n = 0;
    for doc in ["README.md", "scenes/README.md"] {
        for span in inline_spans(&read(doc)) {
            let Some(rest) = span.strip_prefix("brdfwave ") else {
                continue;
            };
            let words = shell_words(rest);
            // Skip `brdfwave diff a b | head`-style pipelines; there are none today.
            assert!(!rest.contains('|'), "{doc}: cannot run `{span}`");
            run_small(&words, tmp.path());
            n += 1;
        }
    }
    assert!(n >= 1, "no inline brdfwave command found");
}

/// The synopsis in README.md ("Command line") names exactly the options each subcommand's
/// --help lists, and every option and argument has help text.
#[test]
fn synopsis_matches_help_and_every_option_is_explained() {
    let text = code_blocks(&read("README.md"))
        .into_iter()
        .find(|(info, b)| info == "text" && b.contains("brdfwave render"))
        .expect("README.md has a text block with the command-line synopsis")
        .1;
    // Join continuation lines (indented) to their command.
    let mut commands: Vec<String> = Vec::new();
    for line in text.lines() {
        if line.starts_with("brdfwave ") {
            commands.push(line.to_string());
        } else if !line.trim().is_empty() {
            commands.last_mut().expect("continuation").push_str(line);
        }
    }
    assert!(commands.len() >= 6, "{commands:?}");
    let options = |s: &str| -> BTreeSet<String> {
        s.split(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
            .filter(|w| w.starts_with("--") && w.len() > 2)
            .filter(|w| *w != "--help" && *w != "--version")
            .map(String::from)
            .collect()
    };
    let mut seen = BTreeSet::new();
    for c in &commands {
        let words: Vec<&str> = c.split_whitespace().skip(1).collect();
        let sub: Vec<&str> = words
            .iter()
            .take_while(|w| w.chars().all(|ch| ch.is_ascii_lowercase()))
            .copied()
            .collect();
        assert!(!sub.is_empty(), "{c}");
        seen.insert(sub.join(" "));
        let mut args: Vec<&str> = sub.clone();
        args.push("--help");
        let help = String::from_utf8(
            run(
                &args.iter().map(|s| s.to_string()).collect::<Vec<_>>(),
                &common::repo(),
            )
            .stdout,
        )
        .unwrap();
        assert_eq!(
            options(c),
            options(&help),
            "README synopsis vs `brdfwave {} --help`",
            sub.join(" ")
        );
        // Every option and positional argument has a description on its line.
        let mut section = "";
        for line in help.lines() {
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
                        sub.join(" ")
                    );
                }
            }
        }
    }
    // Every subcommand is in the synopsis.
    let top = String::from_utf8(run(&["--help".to_string()], &common::repo()).stdout).unwrap();
    let mut in_commands = false;
    for line in top.lines() {
        if line == "Commands:" {
            in_commands = true;
            continue;
        }
        if in_commands {
            let Some(name) = line.split_whitespace().next() else {
                break;
            };
            if name == "help" {
                continue;
            }
            assert!(
                seen.iter()
                    .any(|s| s == name || s.starts_with(&format!("{name} "))),
                "the README synopsis lacks `brdfwave {name}`"
            );
        }
    }
}

/// The example materials (README's inline `'model = …'`, scenes/README's `[materials.…]`
/// blocks) and the example scene load without a warning.
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
    for span in inline_spans(&read("README.md")) {
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

/// Both scene tables list exactly the shipped scenes; scenes/README.md documents every model
/// (and README.md's model table lists them all).
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
    assert_eq!(table_entries("README.md", "scenes/"), shipped, "README.md");
    assert_eq!(
        table_entries("scenes/README.md", ""),
        shipped,
        "scenes/README.md"
    );
}

/// Every model's parameter documentation is the text generated from its declared parameters
/// (`brdf::docs`): the table at the top of `src/brdf/<model>.rs`, its row of README.md's model
/// table and its row of scenes/README.md's table. `BRDFWAVE_WRITE_DOCS=1` rewrites them instead.
#[test]
fn model_parameter_tables_are_generated_from_the_declarations() {
    use brdfwave::brdf::{docs, ModelInfo, MODELS};
    let write = std::env::var_os("BRDFWAVE_WRITE_DOCS").is_some();
    let mut failures = Vec::new();
    let mut unwritable = Vec::new();
    type Row = fn(&ModelInfo) -> String;
    let rows: [(&str, Row); 2] = [
        ("README.md", docs::readme_row),
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
