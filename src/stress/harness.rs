//! The stress harness: the group table, what the groups share (a Vulkan device, the Cornell
//! box, rendering on either backend), and the driver: running the groups within a time
//! budget, recording failures, replaying them, and the report.

use super::degenerate::case_degenerate;
use super::geometry::case_geometry;
use super::gpu_math::case_gpu_math;
use super::limits::case_limits;
use super::models::case_models;
use super::radiance::case_radiance;
use super::rng::case_seed;
use super::scene_numbers::case_scene_numbers;
use super::self_shadow::case_self_shadow;
use crate::scene::Scene;
use crate::vk::{Context, ContextOptions, ShaderCompiler};
use anyhow::{bail, Context as _, Result};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The outcome of one case: the worst error measure seen (group-specific, documented in the
/// table's legend) and a failure message.
pub struct CaseResult {
    pub error: f64,
    pub failure: Option<String>,
}

impl CaseResult {
    pub(super) fn ok(error: f64) -> CaseResult {
        CaseResult {
            error,
            failure: None,
        }
    }
    pub(super) fn fail(error: f64, msg: String) -> CaseResult {
        CaseResult {
            error,
            failure: Some(msg),
        }
    }
}

/// What the groups share: a Vulkan device and shader compiler, made on first use.
pub struct Env {
    options: ContextOptions,
    gpu: Option<(Context, ShaderCompiler)>,
    cornell: Option<Scene>,
}

impl Env {
    pub fn new(options: ContextOptions) -> Env {
        Env {
            options,
            gpu: None,
            cornell: None,
        }
    }
    pub(super) fn gpu(&mut self) -> Result<&(Context, ShaderCompiler)> {
        if self.gpu.is_none() {
            let ctx = Context::new(&self.options).context("stress needs a Vulkan device")?;
            let compiler = ShaderCompiler::new()?;
            self.gpu = Some((ctx, compiler));
        }
        Ok(self.gpu.as_ref().expect("set above"))
    }
    pub(super) fn cornell(&mut self) -> Result<Scene> {
        if self.cornell.is_none() {
            let s = crate::scene::load_str(CORNELL, Path::new("cornell-box.toml"))
                .map_err(|e| anyhow::anyhow!("{e}"))?;
            self.cornell = Some(s);
        }
        Ok(self.cornell.clone().expect("set above"))
    }
}

const CORNELL: &str = include_str!("../../scenes/cornell-box.toml");

pub struct Group {
    pub name: &'static str,
    /// What the "worst error" column measures.
    pub measure: &'static str,
    pub run: fn(&mut Env, u64) -> Result<CaseResult>,
}

pub static GROUPS: &[Group] = &[
    Group {
        name: "models",
        measure: "GPU-CPU rel. diff",
        run: case_models,
    },
    Group {
        name: "limits",
        measure: "error / tolerance",
        run: case_limits,
    },
    Group {
        name: "gpu_math",
        measure: "rel. err / tol",
        run: case_gpu_math,
    },
    Group {
        name: "geometry",
        measure: "error / tolerance",
        run: case_geometry,
    },
    Group {
        name: "radiance",
        measure: "linearity rel. err",
        run: case_radiance,
    },
    Group {
        name: "scene_numbers",
        measure: "-",
        run: case_scene_numbers,
    },
    Group {
        name: "self_shadow",
        measure: "false occl. + leaks",
        run: case_self_shadow,
    },
    Group {
        name: "degenerate",
        measure: "non-finite",
        run: case_degenerate,
    },
];

pub(super) fn render_cpu(s: &Scene) -> crate::output::RenderOutput {
    let b = crate::bvh::build(s);
    crate::render::CpuBackend::render_all(s, std::sync::Arc::new(b))
}

pub(super) fn small(mut s: Scene, w: u32, spp: u32, seed: u32) -> Scene {
    s.width = w;
    s.height = w;
    s.integrator.spp = spp;
    s.integrator.max_depth = 5;
    s.integrator.seed = seed;
    s
}

/// Render `s` on the GPU (`gpu`) or the CPU reference.
pub(super) fn render_on(
    env: &mut Env,
    s: &Scene,
    gpu: bool,
) -> Result<crate::output::RenderOutput> {
    if !gpu {
        return Ok(render_cpu(s));
    }
    let (ctx, compiler) = env.gpu()?;
    crate::render::render_whole(crate::render::Backend::gpu(ctx, compiler), s)
}

pub(super) fn backend_name(gpu: bool) -> &'static str {
    if gpu {
        "GPU"
    } else {
        "CPU"
    }
}

#[derive(Default, Clone)]
pub struct GroupStats {
    pub cases: u64,
    pub failures: u64,
    pub worst: f64,
}

/// One failing case, as a line of the failure file.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
pub struct Failure {
    pub group: String,
    pub seed: u64,
    pub message: String,
}

pub struct Options {
    pub budget: Duration,
    pub seed: u64,
    pub replay: Option<PathBuf>,
    pub failures_out: PathBuf,
    /// Only these groups (all when empty).
    pub groups: Vec<String>,
    pub context: ContextOptions,
}

pub struct Report {
    pub stats: Vec<(&'static str, &'static str, GroupStats)>,
    pub failures: Vec<Failure>,
}

impl Report {
    pub fn table(&self) -> String {
        let mut s = format!(
            "{:<14} {:>8} {:>9} {:>12}  {}\n",
            "group", "cases", "failures", "worst error", "(measure)"
        );
        for (name, measure, st) in &self.stats {
            s += &format!(
                "{:<14} {:>8} {:>9} {:>12.3e}  ({measure})\n",
                name, st.cases, st.failures, st.worst
            );
        }
        s
    }
}

fn run_case(env: &mut Env, g: &Group, seed: u64) -> CaseResult {
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| (g.run)(env, seed)));
    match r {
        Ok(Ok(c)) => c,
        Ok(Err(e)) => CaseResult::fail(f64::NAN, format!("error: {e:#}")),
        Err(p) => {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            CaseResult::fail(f64::NAN, format!("panicked: {msg}"))
        }
    }
}

fn record(st: &mut GroupStats, failures: &mut Vec<Failure>, g: &Group, seed: u64, c: CaseResult) {
    st.cases += 1;
    if c.error.is_finite() {
        st.worst = st.worst.max(c.error);
    }
    if let Some(m) = c.failure {
        st.failures += 1;
        failures.push(Failure {
            group: g.name.to_string(),
            seed,
            message: m,
        });
    }
}

/// Run the suite: every selected group gets an equal share of the budget (each runs at least
/// one case), or, with `replay`, exactly the cases listed in that file.
pub fn run(opts: &Options) -> Result<Report> {
    for g in &opts.groups {
        if !GROUPS.iter().any(|x| x.name == g) {
            let names: Vec<&str> = GROUPS.iter().map(|g| g.name).collect();
            bail!("unknown group '{g}': the groups are {}", names.join(", "));
        }
    }
    let selected: Vec<&Group> = GROUPS
        .iter()
        .filter(|g| opts.groups.is_empty() || opts.groups.iter().any(|x| x == g.name))
        .collect();
    let mut env = Env::new(opts.context.clone());
    let mut stats: Vec<(&'static str, &'static str, GroupStats)> = selected
        .iter()
        .map(|g| (g.name, g.measure, GroupStats::default()))
        .collect();
    let mut failures = Vec::new();
    if let Some(path) = &opts.replay {
        let text = crate::infile::read_text(path, crate::infile::REPLAY)
            .with_context(|| format!("cannot read the replay file {}", path.display()))?;
        // The failures list of an earlier run, which this run rewrites (the default --failures).
        crate::infile::forget(path);
        for (i, line) in text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty())
        {
            let f: Failure = serde_json::from_str(line).with_context(|| {
                format!(
                    "{}:{}: not a failure record (JSON with group, seed, message)",
                    path.display(),
                    i + 1
                )
            })?;
            let Some(k) = selected.iter().position(|g| g.name == f.group) else {
                bail!("{}:{}: unknown group '{}'", path.display(), i + 1, f.group);
            };
            let c = run_case(&mut env, selected[k], f.seed);
            record(&mut stats[k].2, &mut failures, selected[k], f.seed, c);
        }
    } else {
        let share = opts.budget.div_f64(selected.len().max(1) as f64);
        for (k, g) in selected.iter().enumerate() {
            let group_index = GROUPS.iter().position(|x| x.name == g.name).unwrap_or(k);
            let start = Instant::now();
            let mut case = 0u64;
            while case == 0 || start.elapsed() < share {
                let seed = case_seed(opts.seed, group_index, case);
                let c = run_case(&mut env, g, seed);
                record(&mut stats[k].2, &mut failures, g, seed, c);
                case += 1;
            }
        }
    }
    if let Some((ctx, _)) = env.gpu.take() {
        let msgs = ctx.finish();
        if !msgs.is_empty() {
            failures.push(Failure {
                group: "models".into(),
                seed: 0,
                message: format!("validation layer: {}", msgs.join("; ")),
            });
        }
    }
    if !failures.is_empty() {
        // Through the atomic writer: a full disk leaves the old file, never half a record, and
        // a symbolic link there is replaced, not followed.
        let mut text = String::new();
        for x in &failures {
            text += &serde_json::to_string(x)?;
            text.push('\n');
        }
        crate::outfile::write(&opts.failures_out, text.as_bytes())
            .context("cannot write the failure file")?;
    }
    Ok(Report { stats, failures })
}

/// `brdfwave stress`: run, print the table, fail when any case failed.
pub fn cli(
    budget: f64,
    seed: u64,
    replay: Option<PathBuf>,
    failures_out: PathBuf,
    groups: Vec<String>,
    device: Option<String>,
) -> Result<()> {
    if !(budget.is_finite() && (0.0..=1e7).contains(&budget)) {
        bail!("--budget {budget} is out of range: seconds in [0, 1e7]");
    }
    // Before any case runs: an unwritable failure file, and a --device that names no device
    // (every case would "fail" for want of it, and those records would replace the file).
    crate::outfile::prepare(&[crate::outfile::Output {
        option: "--failures",
        path: &failures_out,
    }])?;
    if device.is_some() {
        Context::new(&ContextOptions {
            device: device.clone(),
            validation: false,
            ray_query: false,
        })
        .context("--device")?
        .finish();
    }
    let opts = Options {
        budget: Duration::from_secs_f64(budget),
        seed,
        replay,
        failures_out,
        groups,
        context: ContextOptions {
            device,
            validation: false,
            ray_query: false,
        },
    };
    let t = Instant::now();
    let report = run(&opts)?;
    let mut text = report.table();
    text += &format!("seed {seed}, {:.1} s\n", t.elapsed().as_secs_f64());
    for f in &report.failures {
        text += &format!("FAIL {} seed {}: {}\n", f.group, f.seed, f.message);
    }
    {
        // The report is the command's data: a failed write is an error, not a panic.
        let mut o = std::io::stdout().lock();
        o.write_all(text.as_bytes())
            .and_then(|_| o.flush())
            .context("cannot write to standard output")?;
    }
    if !report.failures.is_empty() {
        bail!(
            "{} failing case(s), written to {} (run them again with --replay {})",
            report.failures.len(),
            opts.failures_out.display(),
            opts.failures_out.display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn case_seeds_differ_by_group_and_case() {
        let mut seen = std::collections::HashSet::new();
        for g in 0..GROUPS.len() {
            for c in 0..1000 {
                assert!(seen.insert(case_seed(1, g, c)));
            }
        }
    }
}
