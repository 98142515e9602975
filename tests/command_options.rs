//! No two options of `diff` or `merge` refuse each other needlessly (as `render --spp` and
//! `--samples` once did; `tests/render_options.rs` checks `render`'s pairs): every pair of the
//! options their `--help` lists runs, each with what it needs (`--alpha` needs `--z-test`,
//! `--tolerance` a `--max over=…`). The tables must give every option of `--help` a value, so a
//! new option fails here until it is checked too.

mod common;

use common::cli::{help_options, render_args_spp, s, Cli};

const CLI: Cli = Cli {
    tag: "cmdopts",
    own_cache: true,
    env_remove: &["LP_NUM_THREADS"],
};

/// An option with its value and what it needs beside it.
struct Opt<'a> {
    name: &'a str,
    args: Vec<&'a str>,
    needs: Vec<&'a str>,
}

fn opt<'a>(name: &'a str, args: &[&'a str], needs: &[&'a str]) -> Opt<'a> {
    Opt {
        name,
        args: args.to_vec(),
        needs: needs.to_vec(),
    }
}

/// Runs `base` with every pair of `table`'s options (and what each needs, once); a pair passes
/// when the command runs to its end: exit status 0, or 1 for a verdict that failed (diff), never
/// a refusal (an `error:` line or clap's usage error, status 2).
fn every_pair_runs(command: &str, base: &[&str], table: &[Opt]) {
    let listed = help_options(command);
    assert!(listed.len() >= 4, "{command} --help lists {listed:?}");
    for o in &listed {
        assert!(
            table.iter().any(|t| t.name == o),
            "{o} of `brdfwave {command} --help` has no value in this test"
        );
    }
    for (i, a) in table.iter().enumerate() {
        for b in &table[i + 1..] {
            let mut args: Vec<&str> = base.to_vec();
            args.extend(&a.args);
            args.extend(&b.args);
            // What each needs, unless the command line already has it (the same words).
            for needs in [&a.needs, &b.needs] {
                if !needs.is_empty() && !args.windows(needs.len()).any(|w| w == &needs[..]) {
                    args.extend(needs.iter());
                }
            }
            let o = CLI.run(&args);
            let stderr = String::from_utf8_lossy(&o.stderr);
            let code = o.status.code();
            assert!(
                matches!(code, Some(0) | Some(1)) && !stderr.contains("error:"),
                "{} with {} is refused (status {code:?}): {args:?}\n{stderr}",
                a.name,
                b.name
            );
        }
    }
}

#[test]
fn every_pair_of_diff_options_runs() {
    let d = CLI.fresh_dir("diff");
    let (test, reference) = (d.join("test.exr"), d.join("ref.exr"));
    let (test_var, ref_var) = (d.join("test-var.exr"), d.join("ref-var.exr"));
    for (seed, out, var) in [("1", &test, &test_var), ("2", &reference, &ref_var)] {
        let extra = [
            "--batches",
            "2",
            "--seed",
            seed,
            "--quiet",
            "--out",
            s(out),
            "--variance-out",
            s(var),
        ];
        CLI.status(&render_args_spp("8", &extra), 0);
    }
    let (map, trip, pmap) = (d.join("e.png"), d.join("t.png"), d.join("p.exr"));
    let z = ["--z-test"];
    let over = ["--max", "over=1"];
    let table = [
        opt("--error-map", &["--error-map", s(&map)], &[]),
        opt("--triptych", &["--triptych", s(&trip)], &[]),
        opt("--json", &["--json"], &[]),
        opt("--max", &["--max", "relmse=100"], &[]),
        opt("--tolerance", &["--tolerance", "0.1"], &over),
        opt("--rel-tolerance", &["--rel-tolerance", "0.1"], &over),
        opt("--z-test", &["--z-test"], &[]),
        opt("--variance-source", &["--variance-source", "auto"], &z),
        opt("--test-variance", &["--test-variance", s(&test_var)], &z),
        opt("--test-spp", &["--test-spp", "8"], &z),
        opt(
            "--reference-variance",
            &["--reference-variance", s(&ref_var)],
            &z,
        ),
        opt("--reference-spp", &["--reference-spp", "8"], &z),
        opt("--alpha", &["--alpha", "0.05"], &z),
        opt("--variance-model", &["--variance-model", "welch"], &z),
        opt("--p-map", &["--p-map", s(&pmap)], &z),
    ];
    every_pair_runs("diff", &["diff", s(&test), s(&reference)], &table);
}

#[test]
fn every_pair_of_merge_options_runs() {
    let d = CLI.fresh_dir("merge");
    let parts: Vec<_> = (0..2).map(|i| d.join(format!("part-{i}.bwfilm"))).collect();
    for (i, range) in ["0..2", "2..4"].iter().enumerate() {
        CLI.status(
            &render_args_spp("4", &["--samples", range, "--quiet", "--out", s(&parts[i])]),
            0,
        );
    }
    let (out, var) = (d.join("merged.exr"), d.join("var.exr"));
    let table = [
        opt("--out", &["--out", s(&out)], &[]),
        opt("--samples", &["--samples", "0..4"], &["--out", s(&out)]),
        opt(
            "--variance-out",
            &["--variance-out", s(&var)],
            &["--out", s(&out)],
        ),
        opt("--json", &["--json"], &["--out", s(&out)]),
    ];
    every_pair_runs("merge", &["merge", s(&parts[0]), s(&parts[1])], &table);
}
