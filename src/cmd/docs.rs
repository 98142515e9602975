//! `brdfwave docs` (hidden): the option reference of every command, rendered from the clap
//! definitions into the pages under `docs/cli/`, so that the pages cannot drift from the
//! program. Each command has a page `docs/cli/NAME.md`; in it the generated text of a command
//! lies between `<!-- begin options: PATH -->` and `<!-- end options: PATH -->` (PATH is the
//! command's words after `brdfwave`, e.g. `render` or `brdf fit`), and the prose around the
//! markers is written by hand. Without `--write` the command checks the pages and fails, naming
//! each stale or missing block; `tests/docs.rs` runs that check in the default test run.
//!
//! The text comes from clap's own introspection (`Command::get_arguments` and friends): the
//! synopsis, then for each argument its name, value, help text (the long help where there is
//! one), default and possible values. Improve an option's description in its `///` comment in
//! `src/cmd/`, which `--help` shows too, never in the page.

use anyhow::{bail, Context as _, Result};
use clap::{Arg, ArgAction, Command};
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct DocsArgs {
    /// Rewrite the generated blocks of the pages instead of checking them.
    #[arg(long)]
    write: bool,
    /// The repository's root directory (the pages are under ROOT/docs/cli/).
    #[arg(value_name = "DIR", long, default_value = ".")]
    root: PathBuf,
}

/// What to run to bring the pages up to date (the check's message names it).
const REGENERATE: &str = "`cargo run --release -- docs --write` (or `BRDFWAVE_WRITE_DOCS=1 cargo test --release --test docs`)";

pub fn run(a: DocsArgs, cli: Command) -> Result<()> {
    let mut stale = Vec::new();
    for (page, commands) in pages(&cli) {
        let path = a.root.join(&page);
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound && a.write => {
                format!("# `{}`\n\n", commands[0].0)
            }
            Err(e) => {
                stale.push(format!("{page}: cannot read it ({e})"));
                continue;
            }
        };
        let (want, problems) = update_page(&text, &commands);
        if !problems.is_empty() && !a.write {
            stale.extend(problems.iter().map(|p| format!("{page}: {p}")));
        }
        if want != text {
            if a.write {
                brdfwave::outfile::write(&path, want.as_bytes())
                    .with_context(|| format!("cannot write {}", path.display()))?;
                eprintln!("docs: wrote {page}");
            } else if problems.is_empty() {
                let (n, (got, want)) = text
                    .lines()
                    .chain(std::iter::repeat(""))
                    .zip(want.lines().chain(std::iter::repeat("")))
                    .enumerate()
                    .find(|(_, (a, b))| a != b)
                    .unwrap_or((0, ("", "")));
                stale.push(format!(
                    "{page} is stale: its generated options differ from the program's, first at \
                     line {}:\n    page:    {got}\n    program: {want}",
                    n + 1
                ));
            }
        }
    }
    if !stale.is_empty() {
        bail!(
            "the command-line reference under docs/cli/ does not match the program:\n  {}\nrun {REGENERATE}",
            stale.join("\n  ")
        );
    }
    Ok(())
}

/// The pages and the commands each documents: `docs/cli/NAME.md` for every visible top-level
/// command, holding the command itself and each of its visible subcommands (their paths and
/// generated text).
fn pages(cli: &Command) -> Vec<(String, Vec<(String, String)>)> {
    let mut out = Vec::new();
    for c in visible(cli) {
        let mut blocks = Vec::new();
        let subs: Vec<&Command> = visible(c).collect();
        if subs.is_empty() {
            blocks.push((c.get_name().to_string(), render_command(&[c.get_name()], c)));
        }
        for s in subs {
            blocks.push((
                format!("{} {}", c.get_name(), s.get_name()),
                render_command(&[c.get_name(), s.get_name()], s),
            ));
        }
        out.push((format!("docs/cli/{}.md", c.get_name()), blocks));
    }
    out
}

fn visible(c: &Command) -> impl Iterator<Item = &Command> {
    c.get_subcommands()
        .filter(|s| !s.is_hide_set() && s.get_name() != "help")
}

fn begin(path: &str) -> String {
    format!("<!-- begin options: {path} -->")
}

fn end(path: &str) -> String {
    format!("<!-- end options: {path} -->")
}

/// The page with every command's block replaced by its generated text, and what is wrong with
/// the page's markers (a block missing or unterminated, a block of no command). A missing block
/// is appended, so that `--write` makes it.
fn update_page(text: &str, commands: &[(String, String)]) -> (String, Vec<String>) {
    let mut problems = Vec::new();
    let mut out = String::new();
    let mut lines = text.split_inclusive('\n').peekable();
    let mut done = Vec::new();
    while let Some(line) = lines.next() {
        let t = line.trim_end();
        let Some(path) = t
            .strip_prefix("<!-- begin options: ")
            .and_then(|r| r.strip_suffix(" -->"))
        else {
            out.push_str(line);
            continue;
        };
        let Some((_, body)) = commands.iter().find(|(p, _)| p == path) else {
            problems.push(format!(
                "a block for `{path}`, which is no command of this page"
            ));
            out.push_str(line);
            continue;
        };
        // Skip the old body up to and including the end marker.
        let mut ended = false;
        for l in lines.by_ref() {
            if l.trim_end() == end(path) {
                ended = true;
                break;
            }
        }
        if !ended {
            problems.push(format!("no `{}` after `{}`", end(path), begin(path)));
        }
        out.push_str(&begin(path));
        out.push('\n');
        out.push_str(body);
        out.push_str(&end(path));
        out.push('\n');
        done.push(path.to_string());
    }
    for (path, body) in commands {
        if !done.contains(path) {
            problems.push(format!("no block `{}`", begin(path)));
            if !out.ends_with("\n\n") {
                out.push('\n');
            }
            let _ = write!(out, "{}\n{body}{}\n", begin(path), end(path));
        }
    }
    (out, problems)
}

/// One command's generated Markdown: its description, synopsis and arguments.
fn render_command(path: &[&str], c: &Command) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "*Generated from the program's own definition of `{}` (`brdfwave docs --write`); its \
         `--help` prints the same.*\n",
        path.join(" ")
    );
    if let Some(about) = c.get_long_about().or(c.get_about()) {
        let about = one_paragraph(&about.to_string());
        let stop = if about.ends_with(['.', ')']) { "" } else { "." };
        let _ = writeln!(s, "{about}{stop}\n");
    }
    let _ = writeln!(s, "```text\n{}\n```\n", synopsis(path, c));
    let args: Vec<&Arg> = documented(c).collect();
    if args.is_empty() {
        let _ = writeln!(s, "No options.");
    }
    for a in args {
        let _ = write!(s, "- `{}`", arg_name(a));
        let notes: Vec<&str> = [
            (a.is_required_set(), "required"),
            (matches!(a.get_action(), ArgAction::Append), "repeatable"),
        ]
        .into_iter()
        .filter_map(|(on, note)| on.then_some(note))
        .collect();
        if !notes.is_empty() {
            let _ = write!(s, " ({})", notes.join(", "));
        }
        let help = a
            .get_long_help()
            .or(a.get_help())
            .map(|h| one_paragraph(&h.to_string()))
            .unwrap_or_default();
        let _ = write!(s, ": {}", help.trim_end_matches('.'));
        s.push('.');
        let defaults: Vec<String> = a
            .get_default_values()
            .iter()
            .map(|v| v.to_string_lossy().into_owned())
            .collect();
        let takes_value = a.get_action().takes_values();
        if !defaults.is_empty() && takes_value {
            let _ = write!(s, " Default: `{}`.", defaults.join(" "));
        }
        let values = possible_values(a);
        if !values.is_empty() {
            let _ = write!(
                s,
                " Values: {}.",
                values
                    .iter()
                    .map(|v| format!("`{v}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        s.push('\n');
    }
    s
}

/// The arguments a page lists: all but hidden ones and clap's own --help/--version.
fn documented(c: &Command) -> impl Iterator<Item = &Arg> {
    c.get_arguments().filter(|a| {
        !a.is_hide_set() && !matches!(a.get_action(), ArgAction::Help | ArgAction::Version)
    })
}

fn possible_values(a: &Arg) -> Vec<String> {
    if !a.get_action().takes_values() {
        return Vec::new();
    }
    a.get_possible_values()
        .iter()
        .filter(|v| !v.is_hide_set())
        .map(|v| v.get_name().to_string())
        .collect()
}

/// `--spp N`, `-D NAME=VALUE`, `SCENE`, `--json`: how the argument is written.
fn arg_name(a: &Arg) -> String {
    let value = value_name(a);
    if a.is_positional() {
        let dots = if matches!(a.get_action(), ArgAction::Append) {
            "..."
        } else {
            ""
        };
        return format!("{value}{dots}");
    }
    let flag = match (a.get_long(), a.get_short()) {
        (Some(l), _) => format!("--{l}"),
        (None, Some(c)) => format!("-{c}"),
        (None, None) => a.get_id().to_string(),
    };
    if a.get_action().takes_values() {
        format!("{flag} {value}")
    } else {
        flag
    }
}

fn value_name(a: &Arg) -> String {
    match a.get_value_names() {
        Some(names) if !names.is_empty() => names
            .iter()
            .map(|n| n.to_string())
            .collect::<Vec<_>>()
            .join(" "),
        _ => a.get_id().to_string().to_uppercase().replace('-', "_"),
    }
}

/// The command in one line, wrapped at 100 columns: `brdfwave render SCENE [--spp SPP] ...`,
/// with the possible values in place of the value's name where there are a few.
fn synopsis(path: &[&str], c: &Command) -> String {
    let head = format!("brdfwave {}", path.join(" "));
    let mut words: Vec<String> = Vec::new();
    if c.get_subcommands().any(|s| !s.is_hide_set()) {
        words.push("COMMAND".into());
    }
    let args: Vec<&Arg> = documented(c).collect();
    // Positional arguments first, as the usage line has them.
    for a in args.iter().filter(|a| a.is_positional()) {
        let n = arg_name(a);
        words.push(if a.is_required_set() {
            n
        } else {
            format!("[{n}]")
        });
    }
    for a in args.iter().filter(|a| !a.is_positional()) {
        let values = possible_values(a);
        let mut n = arg_name(a);
        if !values.is_empty() && values.len() <= 4 {
            let flag = n.split(' ').next().unwrap_or_default().to_string();
            n = format!("{flag} {}", values.join("|"));
        }
        let dots = if matches!(a.get_action(), ArgAction::Append) {
            "..."
        } else {
            ""
        };
        words.push(if a.is_required_set() {
            format!("{n}{dots}")
        } else {
            format!("[{n}]{dots}")
        });
    }
    let indent = " ".repeat(head.chars().count() + 1);
    let mut out = head.clone();
    let mut width = out.chars().count();
    for w in words {
        let wl = w.chars().count();
        if width + 1 + wl > 100 && width > indent.len() {
            out.push('\n');
            out.push_str(&indent);
            out.push_str(&w);
            width = indent.len() + wl;
        } else {
            out.push(' ');
            out.push_str(&w);
            width += 1 + wl;
        }
    }
    out
}

/// Help text as one Markdown paragraph (a list item holds one): clap's lines joined.
fn one_paragraph(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}
