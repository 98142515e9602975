//! `bench.md`'s summary: the per-configuration table, the equal-spp and equal-time tables,
//! the notes.

use super::{BenchOptions, Details, PassRecord};
use crate::scene::Scene;
use std::fmt::Write as _;

/// The sample counts of the equal-spp table.
pub const TABLE_SPP: [u32; 3] = [16, 64, 256];

/// The equal-spp table (relMSE of every configuration at 16, 64 and 256 spp) and the
/// equal-time table: relMSE × render seconds at those counts (lower is better; the product
/// is constant in the spp for an estimator whose error falls as 1/N) and its ratio to the
/// best Mitsuba configuration's.
fn equal_spp_tables(md: &mut String, records: &[PassRecord], details: &[(String, Details)]) {
    let at = |name: &str, spp: u32| records.iter().find(|r| r.config == name && r.spp == spp);
    let names: Vec<&str> = details
        .iter()
        .map(|(n, _)| n.as_str())
        .filter(|n| TABLE_SPP.iter().any(|&s| at(n, s).is_some()))
        .collect();
    if names.is_empty() {
        return;
    }
    let head: Vec<String> = TABLE_SPP.iter().map(|s| format!("{s} spp")).collect();
    let _ = writeln!(md, "relMSE at equal samples per pixel:\n");
    let _ = writeln!(md, "| config | {} |", head.join(" | "));
    let _ = writeln!(md, "|---|{}", "---|".repeat(TABLE_SPP.len()));
    for n in &names {
        let cells: Vec<String> = TABLE_SPP
            .iter()
            .map(|&s| at(n, s).map_or("–".into(), |r| format!("{:.3e}", r.relmse)))
            .collect();
        let _ = writeln!(md, "| {n} | {} |", cells.join(" | "));
    }
    let eff = |name: &str, spp: u32| at(name, spp).map(|r| r.relmse * r.seconds);
    let best_peer = |spp: u32| {
        names
            .iter()
            .filter(|n| n.starts_with("mitsuba-"))
            .filter_map(|n| eff(n, spp).map(|e| (*n, e)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    };
    let _ = writeln!(
        md,
        "\nEqual-time error, relMSE × render seconds (lower is better), and its ratio to the best Mitsuba configuration at the same spp:\n"
    );
    let _ = writeln!(md, "| config | {} |", head.join(" | "));
    let _ = writeln!(md, "|---|{}", "---|".repeat(TABLE_SPP.len()));
    for n in &names {
        let cells: Vec<String> = TABLE_SPP
            .iter()
            .map(|&s| match (eff(n, s), best_peer(s)) {
                (Some(e), Some((p, pe))) if !n.starts_with("mitsuba-") => {
                    format!("{e:.3e} ({:.2}x {p})", e / pe)
                }
                (Some(e), _) => format!("{e:.3e}"),
                _ => "–".into(),
            })
            .collect();
        let _ = writeln!(md, "| {n} | {} |", cells.join(" | "));
    }
    let _ = writeln!(md);
}

/// relMSE of `config` at `t` seconds, interpolated log-log between its passes (None before its
/// first pass or after its last).
fn relmse_at(records: &[PassRecord], config: &str, t: f64) -> Option<f64> {
    let pts: Vec<(f64, f64)> = records
        .iter()
        .filter(|r| r.config == config && r.relmse > 0.0)
        .map(|r| (r.seconds, r.relmse))
        .collect();
    for w in pts.windows(2) {
        let ((t0, e0), (t1, e1)) = (w[0], w[1]);
        if t0 <= t && t <= t1 {
            if t1 <= t0 {
                return Some(e1);
            }
            let a = (t.ln() - t0.ln()) / (t1.ln() - t0.ln());
            return Some((e0.ln() + a * (e1.ln() - e0.ln())).exp());
        }
    }
    pts.last().filter(|p| p.0 == t).map(|p| p.1)
}

pub(super) fn summary(
    o: &BenchOptions,
    sc: &Scene,
    (seconds_load, seconds_bvh): (f64, f64),
    records: &[PassRecord],
    details: &[(String, Details)],
    notes: &[String],
) -> String {
    let mut md = String::new();
    // Every figure below was taken on this host, and lavapipe's with the LLVM its device name
    // gives ("llvmpipe (LLVM 15.0.6, 256 bits)").
    let _ = writeln!(md, "Host: {}.\n", super::machine());
    let _ = writeln!(
        md,
        "Scene `{}`, {}x{}, max depth {}, Russian roulette {}; budget {:.0} s shared by {} configurations, taking turns pass by pass; scene load {:.3} s and BVH build {:.3} s (ours, once for all our configurations; a Mitsuba configuration's set-up is its own scene load).\n",
        o.scene.display(),
        sc.width,
        sc.height,
        sc.integrator.max_depth,
        if sc.integrator.russian_roulette { "on" } else { "off" },
        o.budget,
        details.len(),
        seconds_load,
        seconds_bvh
    );
    // Equal-time error: every configuration at the time the shortest one reached.
    let t_eq = details
        .iter()
        .filter_map(|(n, _)| records.iter().rfind(|r| &r.config == n).map(|r| r.seconds))
        .fold(f64::INFINITY, f64::min);
    let _ = writeln!(
        md,
        "| config | device | sampler | set-up s | spp | render s | paths/s | rays/s | relMSE | relMSE at {:.2} s | FLIP |",
        t_eq
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|---|");
    for (name, d) in details {
        let Some(last) = records.iter().rfind(|r| &r.config == name) else {
            continue;
        };
        let rays = match d.rays {
            0 => "–".to_string(),
            n => format!("{:.3} M", n as f64 / last.seconds / 1e6),
        };
        let eq = relmse_at(records, name, t_eq)
            .map(|e| format!("{e:.3e}"))
            .unwrap_or_else(|| "–".into());
        let _ = writeln!(
            md,
            "| {name} | {} | {} | {:.3} | {} | {:.2} | {:.3} M | {rays} | {:.3e} | {eq} | {:.4} |",
            d.device,
            d.sampler,
            d.setup_seconds,
            last.spp,
            last.seconds,
            last.paths_per_second / 1e6,
            last.relmse,
            last.flip
        );
    }
    let _ = writeln!(md);
    equal_spp_tables(&mut md, records, details);
    detail_notes(&mut md, sc, records, details);
    for n in notes {
        let _ = writeln!(md, "- {n}");
    }
    md
}

/// The smallest sample count whose Mitsuba render counts in the spread of its speeds (smaller
/// renders are dominated by fixed costs).
const PEER_SPREAD_MIN_SPP: u32 = 16;

/// The notes on each configuration's details: the Mitsuba peer's kernel compile and plain warm
/// render, the GPU time by stage, the queue sizes per segment.
fn detail_notes(
    md: &mut String,
    sc: &Scene,
    records: &[PassRecord],
    details: &[(String, Details)],
) {
    let pixels = sc.width as f64 * sc.height as f64;
    for (name, d) in details {
        if let (Some(c), Some((spp, s))) = (d.peer_compile, d.peer_plain) {
            let plain = pixels * spp as f64 / s.max(1e-9);
            let last = records.iter().rfind(|r| &r.config == name);
            // Every Mitsuba point is a fresh render timed alone, so each has its own speed;
            // Mitsuba's samplers run at different speeds at different sample counts (BENCHMARKS.md).
            let speeds: Vec<f64> = records
                .iter()
                .filter(|r| &r.config == name && r.spp >= PEER_SPREAD_MIN_SPP)
                .map(|r| r.paths_per_second / 1e6)
                .collect();
            let spread = match (
                speeds.iter().copied().reduce(f64::min),
                speeds.iter().copied().reduce(f64::max),
            ) {
                (Some(lo), Some(hi)) if speeds.len() > 1 => format!(
                    "; its {} timed renders of {PEER_SPREAD_MIN_SPP} spp or more ran at {lo:.3}–{hi:.3} M paths/s by sample count",
                    speeds.len()
                ),
                _ => String::new(),
            };
            // The like-for-like check: the bench's own timed render of the plain count (a
            // fresh warm render inside the interleaved run) beside the plain one.
            let same_count = records
                .iter()
                .find(|r| &r.config == name && r.spp == spp)
                .map(|r| {
                    format!(
                        "; its timed render of {spp} spp in the run: {:.3} M paths/s ({:+.1} % from the plain one)",
                        r.paths_per_second / 1e6,
                        100.0 * (r.paths_per_second / plain - 1.0)
                    )
                })
                .unwrap_or_default();
            let _ = writeln!(
                md,
                "- `{name}`: kernel compile {c:.2} s in all (kept out of every timed render); the faster of two plain warm renders of {spp} spp took {s:.2} s, {:.3} M paths/s{}{same_count}{spread}",
                plain / 1e6,
                last.map(|r| format!(" (the bench's own figure: {:.3} M)", r.paths_per_second / 1e6))
                    .unwrap_or_default()
            );
        }
    }
    for (name, d) in details {
        if d.stage_seconds.is_empty() {
            continue;
        }
        let total: f64 = d.stage_seconds.iter().map(|s| s.1).sum();
        let parts: Vec<String> = d
            .stage_seconds
            .iter()
            .map(|(s, t)| format!("{s} {:.0}%", 100.0 * t / total.max(1e-12)))
            .collect();
        let _ = writeln!(
            md,
            "- `{name}` GPU time by stage: {} (pipelines: compile {:.3} s, create {:.3} s)",
            parts.join(", "),
            d.pipelines_compile,
            d.pipelines_create
        );
    }
    if let Some((name, d)) = details.iter().find(|(_, d)| !d.rays_by_segment.is_empty()) {
        let spp = records
            .iter()
            .rfind(|r| &r.config == name)
            .map_or(1, |r| r.spp);
        let per = |n: u64| n as f64 / (sc.width as f64 * sc.height as f64 * spp as f64);
        let parts: Vec<String> = d
            .rays_by_segment
            .iter()
            .enumerate()
            .map(|(i, &(e, s))| format!("{}: {:.2}/{:.2}", i + 1, per(e), per(s)))
            .collect();
        let _ = writeln!(
            md,
            "- Queue sizes per segment (`{name}`), extension/shadow rays per camera path by segment: {}",
            parts.join(", ")
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relmse_is_interpolated_log_log() {
        let r = |s: f64, e: f64| PassRecord {
            config: "a".into(),
            pass: 0,
            spp: 1,
            seconds: s,
            paths_per_second: 0.0,
            rmse: 0.0,
            relmse: e,
            flip: 0.0,
        };
        let recs = vec![r(1.0, 1.0), r(100.0, 0.01)];
        let e = relmse_at(&recs, "a", 10.0).unwrap();
        assert!((e - 0.1).abs() < 1e-12, "{e}");
        assert_eq!(relmse_at(&recs, "a", 0.5), None);
        assert!((relmse_at(&recs, "a", 100.0).unwrap() - 0.01).abs() < 1e-12);
    }
}
