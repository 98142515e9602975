//! `brdfwave stress`: randomized numerical-stability checks (`brdfwave::stress`).

use anyhow::Result;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct StressArgs {
    /// Seconds to spend, shared equally by the groups (each runs at least one case).
    #[arg(value_name = "SECONDS", long, default_value_t = 60.0)]
    budget: f64,
    /// Seed of the randomized cases (each case gets its own seed from it, written with a
    /// failure for --replay).
    #[arg(value_name = "S", long, default_value_t = 1)]
    seed: u64,
    /// Run again exactly the failing cases listed in this file.
    #[arg(value_name = "FILE", long)]
    replay: Option<PathBuf>,
    /// Where failing cases are written (JSON lines), for --replay.
    #[arg(value_name = "FILE", long, default_value = "stress-failures.jsonl")]
    failures: PathBuf,
    /// Only this group (may be given several times): `models`, `limits`, `gpu_math`,
    /// `geometry`, `radiance`, `scene_numbers`, `self_shadow` or `degenerate` (default: all).
    #[arg(value_name = "GROUP", long = "group")]
    groups: Vec<String>,
    /// Vulkan device for the GPU checks: a case-insensitive part of its name (default:
    /// lavapipe if present).
    #[arg(value_name = "NAME", long)]
    device: Option<String>,
}

pub fn run(a: StressArgs) -> Result<()> {
    brdfwave::stress::cli(a.budget, a.seed, a.replay, a.failures, a.groups, a.device)
}
