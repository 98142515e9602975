//! `brdfwave bench`: run time against error (`brdfwave::bench`).

use super::parse_res;
use anyhow::{bail, Result};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct BenchArgs {
    /// The scene file to benchmark.
    scene: PathBuf,
    /// Reference image (EXR); default: rendered once by the CPU reference and cached.
    #[arg(value_name = "FILE.exr", long)]
    reference: Option<PathBuf>,
    /// Render seconds, shared equally by the configurations.
    #[arg(value_name = "SECONDS", long, default_value_t = 60.0)]
    budget: f64,
    /// Comma-separated: wavefront, megakernel (each optionally -t1, -t2, … for lavapipe's
    /// LP_NUM_THREADS), cpu, each optionally -sobol or -independent last (the sampler;
    /// default multijitter); mitsuba-scalar, mitsuba-llvm, mitsuba-cuda, each optionally
    /// -stratified, -multijitter, -orthogonal or -ldsampler last (default independent).
    #[arg(value_name = "LIST", long, default_value = brdfwave::bench::DEFAULT_CONFIGS)]
    configs: String,
    /// Output directory.
    #[arg(value_name = "DIR", long, default_value = "out/bench")]
    out: PathBuf,
    /// Image size WxH (overrides the scene).
    #[arg(value_name = "WxH", long, value_parser = parse_res)]
    res: Option<(u32, u32)>,
    /// Maximum path segments (overrides the scene).
    #[arg(value_name = "D", long)]
    max_depth: Option<u32>,
    /// Samples per pixel of the rendered reference.
    #[arg(value_name = "N", long, default_value_t = 1024)]
    reference_spp: u32,
    /// Every configuration renders at least this many samples per pixel, whatever the
    /// budget; the equal-spp table reads 16, 64 and 256.
    #[arg(value_name = "N", long, default_value_t = 1)]
    min_spp: u32,
    /// Vulkan device: a case-insensitive part of its name (default: lavapipe if present).
    #[arg(value_name = "NAME", long)]
    device: Option<String>,
    /// Also measure set-up and speed against scene size, with a generated mesh of this many
    /// triangles (e.g. 1048576) and the lineup scene.
    #[arg(value_name = "TRIANGLES", long)]
    scaling: Option<u32>,
}

pub fn run(a: BenchArgs) -> Result<()> {
    let configs = a
        .configs
        .split(',')
        .map(|c| brdfwave::bench::Config::parse(c.trim()))
        .collect::<Result<Vec<_>>>()?;
    if a.reference_spp == 0 {
        bail!("--reference-spp must be at least 1");
    }
    if let Some(n) = a.scaling.filter(|&n| n == 0 || n > 1 << 24) {
        bail!("--scaling takes a triangle count from 1 to 16777216, got {n}");
    }
    let md = brdfwave::bench::run(&brdfwave::bench::BenchOptions {
        scene: a.scene,
        reference: a.reference,
        budget: a.budget,
        configs,
        out: a.out.clone(),
        res: a.res,
        max_depth: a.max_depth,
        reference_spp: a.reference_spp,
        min_spp: a.min_spp,
        device: a.device,
        scaling: a.scaling,
    })?;
    out!("{md}")?;
    outln!(
        "wrote {0}/bench.csv, {0}/bench.png, {0}/bench.md",
        a.out.display()
    )?;
    Ok(())
}
