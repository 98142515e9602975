//! `brdfwave rays`, the traversal benchmark: its table is complete and its counts are those of
//! the rays it makes; where the driver has ray queries, both traversals find the same hits, and
//! where it has none (Debian 12's Mesa 22.3.6), the command says what the device lacks.
//! `eval "$(bash scripts/mesa-backports.sh)"` before `cargo test --release --test rays` runs
//! the ray-query side on Mesa 25's lavapipe (docs/cli/rays.md).

mod common;

use common::cli::Cli;

const CLI: Cli = Cli {
    tag: "rays",
    own_cache: true,
    env_remove: &[],
};

/// The table's rows: (kind, count, brdfwave M rays/s, ray query M rays/s or None, same-hit
/// share in % or None, CPU M rays/s).
type Row = (String, usize, f64, Option<f64>, Option<f64>, f64);

fn rows(out: &str) -> Vec<Row> {
    out.lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| rays"))
        .map(|l| {
            let c: Vec<&str> = l.trim_matches('|').split('|').map(str::trim).collect();
            assert_eq!(c.len(), 7, "{l}");
            let num = |s: &str| s.parse::<f64>().ok();
            (
                c[0].to_string(),
                c[1].parse().unwrap(),
                num(c[2]).unwrap(),
                num(c[3]),
                num(c[5].trim_end_matches(" %")),
                num(c[6]).unwrap(),
            )
        })
        .collect()
}

#[test]
fn ours_only_traces_every_kind_of_ray() {
    let out = CLI.ok(&[
        "rays",
        "scenes/cornell-box.toml",
        "--res",
        "12x10",
        "--per-pixel",
        "2",
        "--repeats",
        "1",
        "--ours-only",
    ]);
    assert!(out.contains("Host: ") && out.contains("Device: "), "{out}");
    let r = rows(&out);
    let kinds: Vec<&str> = r.iter().map(|r| r.0.as_str()).collect();
    assert_eq!(kinds, ["camera", "bounce", "shadow"], "{out}");
    // Every camera ray of the closed box (its camera looks in through the open side at the
    // back wall) hits, so each makes one bounce ray and one shadow ray.
    assert_eq!(r[0].1, 12 * 10 * 2, "{out}");
    assert!(r[1].1 > 0 && r[1].1 <= r[0].1 && r[2].1 <= r[1].1, "{out}");
    for row in &r {
        assert!(row.2 > 0.0 && row.5 > 0.0, "{out}");
        assert!(row.3.is_none() && row.4.is_none(), "{out}");
    }
}

#[test]
fn ray_queries_agree_or_the_missing_extensions_are_named() {
    let args = [
        "rays",
        "scenes/cornell-box-glossy.toml",
        "--res",
        "24x24",
        "--repeats",
        "1",
    ];
    let out = CLI.run(&args);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    if out.status.success() {
        for row in rows(&stdout) {
            let same = row.4.expect("a same-hit share");
            assert!(row.3.unwrap() > 0.0, "{stdout}");
            assert!(
                same >= 99.9,
                "{}: only {same} % of the hits agree\n{stdout}",
                row.0
            );
        }
    } else {
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert!(
            stderr.contains("cannot trace ray queries") && stderr.contains("VK_KHR_ray_query"),
            "{stderr}"
        );
        println!("no ray queries on this driver: {stderr}");
    }
}

#[test]
fn bad_inputs_are_refused_with_a_reason() {
    CLI.fails_naming(
        &["rays", "scenes/furnace-sphere.toml", "--ours-only"],
        "sphere",
    );
    CLI.fails_naming(
        &["rays", "scenes/cornell-box.toml", "--per-pixel", "0"],
        "--per-pixel",
    );
    CLI.fails_naming(
        &["rays", "scenes/cornell-box.toml", "--repeats", "0"],
        "--repeats",
    );
    CLI.fails_naming(
        &["rays", "no/such/scene.toml", "--ours-only"],
        "no/such/scene.toml",
    );
}
