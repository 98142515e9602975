//! `brdfwave stress`: randomized numerical-stability checks (`brdfwave::stress`).

use anyhow::Result;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct StressArgs {
    /// Seconds to spend, shared equally by the groups (each runs at least one case).
    #[arg(long, default_value_t = 60.0)]
    budget: f64,
    /// Seed of the randomized cases (each case gets its own seed from it, written with a
    /// failure for --replay).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Run again exactly the failing cases listed in this file.
    #[arg(long)]
    replay: Option<PathBuf>,
    /// Where failing cases are written (JSON lines), for --replay.
    #[arg(long, default_value = "stress-failures.jsonl")]
    failures: PathBuf,
    /// Only this group (may be given several times).
    #[arg(long = "group")]
    groups: Vec<String>,
    /// Vulkan device for the GPU checks: a case-insensitive part of its name (default:
    /// lavapipe if present).
    #[arg(long)]
    device: Option<String>,
}

pub fn run(a: StressArgs) -> Result<()> {
    brdfwave::stress::cli(a.budget, a.seed, a.replay, a.failures, a.groups, a.device)
}
