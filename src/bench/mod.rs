//! `brdfwave bench`: run time against error, every configuration in one run.
//!
//! Each configuration renders the scene progressively (passes of 1, 1, 2, 4, … samples per
//! pixel, the last one cut to its share of the time budget); after each pass the running image
//! is compared with a reference (RMSE, relMSE, FLIP) and the cumulative render time recorded.
//! The configurations take turns pass by pass, so a slow spell of a noisy machine hits them
//! all alike. The reference is rendered once by the CPU reference at many samples with its own
//! seed (its noise is independent of the runs) and cached, keyed by the scene file, the render
//! settings and this executable.
//!
//! Configurations: `wavefront` and `megakernel` on the Vulkan device (lavapipe by default),
//! each also with `-t1` / `-t2` (`LP_NUM_THREADS`, read by lavapipe when a Vulkan instance is
//! made), `cpu` (the CPU reference), each with brdfwave's default sampler (`multijitter`) or another
//! named last (`wavefront-independent`, `cpu-independent`); and, when the Python module
//! `mitsuba` is installed, `mitsuba-scalar`, `mitsuba-llvm` and `mitsuba-cuda` rendering the
//! same scene (triangle scenes of Lambert and rough-conductor materials) through
//! `scripts/mitsuba_peer.py`, embedded here, with Mitsuba's `independent` sampler or another
//! named last (`mitsuba-llvm-multijitter`, `-ldsampler`, `-stratified`, `-orthogonal`).
//!
//! Each system is measured at its best: with `sobol` and `independent`, brdfwave's passes
//! continue one sample sequence, so the running image after 2^k samples is exactly a
//! 2^k-sample render (its stratification included), and its time is the sum of the passes;
//! the `multijitter` pattern (brdfwave's default) is sized by the sample count, so each of its
//! points is a fresh render of all the samples so far, set up apart and timed alone, like
//! Mitsuba's; a fresh render of either system that takes under [`REPEAT_BELOW`] seconds is
//! timed twice and the faster time kept. Mitsuba's stratified samplers lose their
//! stratification when independent passes are averaged, so each Mitsuba point is a fresh,
//! warm render of all the samples so far, timed alone (its kernels, which for most of its
//! samplers depend on the sample count, are compiled by an untimed warm-up render of the same
//! count, reported apart), and the script also times one plain warm render at a fixed sample
//! count, reported beside the bench's figure and beside the bench's own render of that count
//! (the like-for-like check: the figure in the table is the last, largest render's, and
//! Mitsuba's samplers run at different speeds at different counts). (A Mitsuba
//! configuration's wall time is thus about four times the time of its last render; its budget
//! share counts the last render.)
//!
//! A scene with textured materials also gets a "Textures" section (`textures.rs`): its speed
//! against the same scene with each textured parameter its texture's mean, on both backends.

mod config;
mod mitsuba;
pub mod rays;
mod reference;
mod runner;
mod scaling;
mod tables;
mod textures;

pub use config::{Config, DEFAULT_CONFIGS, MITSUBA_SAMPLERS};
pub use scaling::add_sphere_mesh;
pub use tables::TABLE_SPP;
pub use textures::constant_parameters;

use crate::bvh::{self, Bvh};
use crate::imageio::Image;
use crate::metrics;
use crate::plot::{self, Series};
use crate::scene::{self, Scene};
use crate::vk::{Context, ContextOptions, ShaderCompiler};
use anyhow::{anyhow, bail, Context as _, Result};
use runner::Runner;
use std::fmt::Write as _;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// Render seconds under which a fresh render (a `multijitter` point of ours, every Mitsuba
/// point) is timed a second time and the faster of the two kept: a render of 0.1–0.6 s, which
/// the 16- and 64-spp columns come from, is what a spell of a busy host slows most, and each
/// system is to be measured at its best. Passes that continue a sequence (`sobol`,
/// `independent`, brdfwave's GPU configurations with them) are timed once.
pub(super) const REPEAT_BELOW: f64 = 1.0;

/// The CSV header of `bench.csv`, one row per pass.
pub const CSV_COLUMNS: &str = "config,pass,spp,seconds,paths_per_second,rmse,relmse,flip";

/// Passes every configuration makes, even past its share of the budget: a curve needs points.
const MIN_PASSES: u32 = 3;

pub struct BenchOptions {
    pub scene: PathBuf,
    pub reference: Option<PathBuf>,
    /// Render seconds shared by all configurations.
    pub budget: f64,
    pub configs: Vec<Config>,
    pub out: PathBuf,
    pub res: Option<(u32, u32)>,
    pub max_depth: Option<u32>,
    /// Samples per pixel of a rendered reference.
    pub reference_spp: u32,
    /// Every configuration renders at least this many samples per pixel, whatever the
    /// budget (for the equal-spp table).
    pub min_spp: u32,
    pub device: Option<String>,
    /// Also measure set-up and speed against scene size (a generated mesh of this many
    /// triangles, and the lineup scene).
    pub scaling: Option<u32>,
}

/// One pass of one configuration.
#[derive(Clone, Debug)]
pub struct PassRecord {
    pub config: String,
    pub pass: u32,
    pub spp: u32,
    /// Cumulative render time of the configuration.
    pub seconds: f64,
    pub paths_per_second: f64,
    pub rmse: f64,
    pub relmse: f64,
    pub flip: f64,
}

/// What one configuration reports besides its passes.
#[derive(Clone, Debug, Default)]
struct Details {
    device: String,
    setup_seconds: f64,
    rays: u64,
    /// (extension, shadow) rays by path segment: the queue sizes per segment.
    rays_by_segment: Vec<(u64, u64)>,
    stage_seconds: Vec<(String, f64)>,
    pipelines_compile: f64,
    pipelines_create: f64,
    /// Mitsuba: the seconds its warm-up renders took beyond the warm ones (kernel
    /// compilation, one per sample count for most samplers), kept out of every timed render.
    peer_compile: Option<f64>,
    /// Mitsuba: one plain warm render, timed alone: (spp, seconds).
    peer_plain: Option<(u32, f64)>,
    /// The sampler, as its system names it.
    sampler: String,
}

/// The scene to benchmark, with the command-line overrides.
fn load_scene(o: &BenchOptions) -> Result<Scene> {
    let mut sc = scene::load(&o.scene)?;
    if let Some((w, h)) = o.res {
        sc.width = w;
        sc.height = h;
    }
    if let Some(d) = o.max_depth {
        crate::gpu::check_max_depth(d).context("--max-depth")?;
        sc.integrator.max_depth = d;
    }
    Ok(sc)
}

/// A configuration's name and its runner.
type Named<'a> = (String, Box<dyn Runner + 'a>);

/// Runs the benchmark; writes `bench.csv`, `bench.png` and `bench.md` under `o.out` and
/// returns the markdown summary.
pub fn run(o: &BenchOptions) -> Result<String> {
    check_options(o)?;
    let t = Instant::now();
    let sc = load_scene(o)?;
    let seconds_load = t.elapsed().as_secs_f64();
    for w in &sc.warnings {
        eprintln!("{w}");
    }
    let t = Instant::now();
    let bvh = Arc::new(bvh::build(&sc));
    let seconds_bvh = t.elapsed().as_secs_f64();
    let (reference, reference_err) = reference::reference(o, &sc, &bvh)?;
    let pixels = sc.width as f64 * sc.height as f64;

    // Vulkan contexts first (one per GPU configuration: lavapipe reads LP_NUM_THREADS when an
    // instance is made), then the runners that borrow them.
    let mut notes: Vec<String> = Vec::new();
    let contexts = contexts(o)?;
    let compiler = ShaderCompiler::new()?;
    let mitsuba_xml = o.out.join("mitsuba_scene.xml");
    let mitsuba_ok = mitsuba_setup(o, &sc, &mitsuba_xml);
    let scenes = config_scenes(o, &sc);
    let mut runners = runners(
        o,
        &contexts,
        &scenes,
        &bvh,
        &compiler,
        &mitsuba_ok,
        &mitsuba_xml,
        &mut notes,
    )?;

    let records = passes(o, &mut runners, &reference, pixels)?;
    let details = details(o, &mut runners);
    // The runners (and Mitsuba's processes) and the devices go before anything else is timed.
    drop(runners);
    drop(contexts);

    write_outputs(
        o,
        &sc,
        (seconds_load, seconds_bvh),
        reference_err,
        &records,
        &details,
        notes,
    )
}

/// The options' own checks, and the output directory.
fn check_options(o: &BenchOptions) -> Result<()> {
    if !(o.budget > 0.0 && o.budget.is_finite()) {
        bail!(
            "--budget must be a positive number of seconds, got {}",
            o.budget
        );
    }
    if o.configs.is_empty() {
        bail!("--configs names no configuration");
    }
    std::fs::create_dir_all(&o.out).with_context(|| format!("creating {}", o.out.display()))?;
    Ok(())
}

/// One Vulkan context per GPU configuration, each made with its `LP_NUM_THREADS` (the user's
/// own setting restored afterwards); None for the others.
fn contexts(o: &BenchOptions) -> Result<Vec<Option<Context>>> {
    let user_threads = std::env::var_os("LP_NUM_THREADS");
    let mut contexts: Vec<Option<Context>> = Vec::new();
    for c in &o.configs {
        contexts.push(match c {
            Config::Gpu { threads, .. } => {
                match threads {
                    Some(t) => std::env::set_var("LP_NUM_THREADS", t.to_string()),
                    None => match &user_threads {
                        Some(v) => std::env::set_var("LP_NUM_THREADS", v),
                        None => std::env::remove_var("LP_NUM_THREADS"),
                    },
                }
                Some(Context::new(&ContextOptions {
                    device: o.device.clone(),
                    validation: false,
                    ray_query: false,
                })?)
            }
            _ => None,
        });
    }
    match &user_threads {
        Some(v) => std::env::set_var("LP_NUM_THREADS", v),
        None => std::env::remove_var("LP_NUM_THREADS"),
    }
    Ok(contexts)
}

/// Whether the Mitsuba configurations (if any) can run: Mitsuba installed and the scene
/// written to `mitsuba_xml` as `brdfwave convert --to mitsuba` writes it (the meshes beside it
/// in `mitsuba_scene-meshes/`), so the peer renders what a user's converted scene gives.
fn mitsuba_setup(o: &BenchOptions, sc: &Scene, mitsuba_xml: &Path) -> Result<()> {
    use crate::scene::mitsuba::write;
    match o.configs.iter().any(|c| matches!(c, Config::Mitsuba { .. })) {
        false => Ok(()),
        true if !mitsuba::mitsuba_installed() => Err(anyhow!(
            "python3 cannot import mitsuba (pip install mitsuba numpy; the llvm variant also needs libLLVM 16 or newer, e.g. Debian's libllvm19)"
        )),
        true => {
            let dir = mitsuba_xml.parent().unwrap_or(Path::new("."));
            let converted = write::to_mitsuba(sc, "mitsuba_scene-meshes", write::Options::default())
                .map_err(|e| anyhow!("the Mitsuba configurations need the scene as Mitsuba 3 XML: {e}"))?;
            std::fs::create_dir_all(dir.join("mitsuba_scene-meshes"))
                .with_context(|| format!("creating {}", dir.display()))?;
            for (name, text) in &converted.meshes {
                let path = dir.join(name);
                std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))?;
            }
            std::fs::write(mitsuba_xml, &converted.xml)
                .with_context(|| format!("writing {}", mitsuba_xml.display()))
        }
    }
}

/// The scene as each of our configurations renders it: with its sampler.
fn config_scenes(o: &BenchOptions, sc: &Scene) -> Vec<Scene> {
    o.configs
        .iter()
        .map(|c| {
            let mut s = sc.clone();
            if let Config::Gpu { sampler, .. } | Config::Cpu { sampler } = c {
                s.integrator.sampler = *sampler;
            }
            s
        })
        .collect()
}

/// The runners of all configurations; a Mitsuba one that cannot start is skipped with a note,
/// any other failure is fatal.
#[allow(clippy::too_many_arguments)]
fn runners<'a>(
    o: &BenchOptions,
    contexts: &'a [Option<Context>],
    scenes: &'a [Scene],
    bvh: &Arc<Bvh>,
    compiler: &'a ShaderCompiler,
    mitsuba_ok: &Result<()>,
    mitsuba_xml: &Path,
    notes: &mut Vec<String>,
) -> Result<Vec<Named<'a>>> {
    let mut runners: Vec<Named<'a>> = Vec::new();
    for ((c, ctx), sc) in o.configs.iter().zip(contexts).zip(scenes) {
        let name = c.name();
        let runner = runner::runner(
            c,
            ctx.as_ref(),
            sc,
            bvh,
            compiler,
            mitsuba_ok,
            mitsuba_xml,
            &o.out,
        );
        match runner {
            Ok(r) => runners.push((name, r)),
            Err(e) if matches!(c, Config::Mitsuba { .. }) => {
                notes.push(format!("{name}: skipped: {e:#}"));
                eprintln!("{name}: skipped: {e:#}");
            }
            Err(e) => return Err(e.context(format!("configuration {name}"))),
        }
    }
    if runners.is_empty() {
        bail!("no configuration could run:\n{}", notes.join("\n"));
    }
    Ok(runners)
}

/// Passes, taking turns; each configuration gets an equal share of the budget. After each
/// pass the running image is compared with `reference`.
fn passes(
    o: &BenchOptions,
    runners: &mut [Named<'_>],
    reference: &Image,
    pixels: f64,
) -> Result<Vec<PassRecord>> {
    let share = o.budget / runners.len() as f64;
    let mut records: Vec<PassRecord> = Vec::new();
    let mut state: Vec<(u32, f64, bool)> = vec![(0, 0.0, false); runners.len()]; // spp, seconds, done
    let mut passes = vec![0u32; runners.len()];
    let mut pass = 0u32;
    let tty = std::io::stderr().is_terminal();
    while state.iter().any(|s| !s.2) {
        pass += 1;
        for (i, (name, r)) in runners.iter_mut().enumerate() {
            let (spp, secs, done) = state[i];
            if done {
                continue;
            }
            // Double the samples so far, or as many as the rest of the share allows; a last
            // pass of under a quarter of that is not worth its overhead. Up to `min_spp`,
            // always double, whatever the budget.
            let n = if spp == 0 {
                1
            } else if spp < o.min_spp {
                // The next power of two: the equal-spp table reads 16, 64, 256 (a sampler
                // that rounded a count up, e.g. to a square, gets back on the powers).
                (spp + 1).next_power_of_two() - spp
            } else {
                let per_spp = secs / spp as f64;
                let fit = ((share - secs) / per_spp.max(1e-9)).floor();
                let n = (spp as f64).min(fit).min((u32::MAX / 2 - spp) as f64);
                if n < (spp as f64 / 4.0).max(1.0) && passes[i] >= MIN_PASSES {
                    state[i].2 = true;
                    continue;
                }
                n.max(1.0) as u32
            };
            if tty {
                eprint!("\r{name}: pass {pass}, {} spp          ", spp + n);
            }
            let (spp, secs) = r
                .pass(n)
                .with_context(|| format!("configuration {name}, pass {pass}"))?;
            let img = r.image()?;
            let d = metrics::diff(&img, reference)?;
            records.push(PassRecord {
                config: name.clone(),
                pass,
                spp,
                seconds: secs,
                paths_per_second: pixels * spp as f64 / secs.max(1e-9),
                rmse: d.rmse,
                relmse: d.relmse,
                flip: d.flip_mean,
            });
            passes[i] += 1;
            state[i] = (
                spp,
                secs,
                (secs >= share && passes[i] >= MIN_PASSES && spp >= o.min_spp) || spp >= 1 << 24,
            );
        }
    }
    if tty {
        eprintln!();
    }
    Ok(records)
}

/// What each runner reports besides its passes, with its configuration's sampler.
fn details(o: &BenchOptions, runners: &mut [Named<'_>]) -> Vec<(String, Details)> {
    runners
        .iter_mut()
        .map(|(n, r)| {
            let mut d = r.details();
            d.sampler = o
                .configs
                .iter()
                .find(|c| &c.name() == n)
                .map(|c| c.sampler_name())
                .unwrap_or_default();
            (n.clone(), d)
        })
        .collect()
}

/// Writes `bench.csv`, `bench.png` and `bench.md` (with the scaling table if asked for);
/// returns the markdown.
fn write_outputs(
    o: &BenchOptions,
    sc: &Scene,
    seconds_setup: (f64, f64),
    reference_err: Option<f64>,
    records: &[PassRecord],
    details: &[(String, Details)],
    mut notes: Vec<String>,
) -> Result<String> {
    write_csv(o, records)?;
    write_plot(o, sc, records, details)?;

    let reference_note = match (&o.reference, reference_err) {
        (Some(p), _) => format!("the reference is {}", p.display()),
        (None, Some(e)) => format!(
            "the reference: {} spp of the CPU reference ({} sampler, its own seed); its own expected relMSE is at most {e:.2e}",
            o.reference_spp, sc.integrator.sampler
        ),
        (None, None) => format!("the reference: {} spp of the CPU reference", o.reference_spp),
    };
    notes.push(reference_note);
    let md = tables::summary(o, sc, seconds_setup, records, details, &notes);
    let md = match o.scaling {
        Some(n) => format!("{md}\n{}", scaling::scaling(o, n)?),
        None => md,
    };
    // A scene with textures: what they cost against constant parameters.
    let md = match textures::texture_cost(o)? {
        Some(t) => format!("{md}\n## Textures\n\nThe scene against the same scene with each textured parameter its texture's mean (4 spp, the faster of 3 passes each):\n\n{t}"),
        None => md,
    };
    crate::outfile::write(&o.out.join("bench.md"), md.as_bytes())?;
    Ok(md)
}

/// `bench.csv`: [`CSV_COLUMNS`], one row per pass.
fn write_csv(o: &BenchOptions, records: &[PassRecord]) -> Result<()> {
    let mut csv = String::from(CSV_COLUMNS);
    csv.push('\n');
    for r in records {
        let _ = writeln!(
            csv,
            "{},{},{},{:.6},{:.1},{:.6e},{:.6e},{:.6e}",
            r.config, r.pass, r.spp, r.seconds, r.paths_per_second, r.rmse, r.relmse, r.flip
        );
    }
    crate::outfile::write(&o.out.join("bench.csv"), csv.as_bytes())?;
    Ok(())
}

/// The machine, in words: the CPU's model name, its family, model and stepping numbers and
/// widest vector instructions (a name like "Intel(R) Xeon(R) Processor" alone does not tell
/// one host from another, and lavapipe's speed depends on which it is), and its hardware
/// threads.
pub fn machine() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let field = |key: &str| {
        info.lines()
            .find(|l| l.split(':').next().is_some_and(|k| k.trim() == key))
            .and_then(|l| l.split_once(':'))
            .map(|(_, v)| v.trim().to_string())
    };
    let model = field("model name").unwrap_or_else(|| std::env::consts::ARCH.to_string());
    let numbers = match (field("cpu family"), field("model"), field("stepping")) {
        (Some(f), Some(m), Some(s)) => format!(" (family {f} model {m} stepping {s}"),
        _ => String::new(),
    };
    let flags = field("flags").unwrap_or_default();
    let has = |f: &str| flags.split_whitespace().any(|x| x == f);
    let isa = if has("avx512f") {
        ", AVX-512"
    } else if has("avx2") {
        ", AVX2"
    } else {
        ""
    };
    let close = if numbers.is_empty() { "" } else { ")" };
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("{model}{numbers}{isa}{close}, {threads} threads")
}

/// `bench.png`: relMSE against render time, log-log, one curve per configuration, titled with
/// the machine and the Vulkan device.
fn write_plot(
    o: &BenchOptions,
    sc: &Scene,
    records: &[PassRecord],
    details: &[(String, Details)],
) -> Result<()> {
    let series: Vec<Series> = details
        .iter()
        .map(|(name, _)| Series {
            label: name.clone(),
            points: records
                .iter()
                .filter(|r| &r.config == name)
                .map(|r| (r.seconds, r.relmse))
                .collect(),
        })
        .collect();
    // The machine and the Vulkan device (for lavapipe its LLVM version) the times were taken on.
    let devices: Vec<&str> = details
        .iter()
        .map(|(_, d)| d.device.as_str())
        .filter(|d| !d.is_empty())
        .fold(Vec::new(), |mut v, d| {
            if !v.contains(&d) {
                v.push(d);
            }
            v
        });
    let title = format!(
        "{} {}x{}, max depth {}: relMSE against time; {}; {}",
        o.scene.file_name().and_then(|s| s.to_str()).unwrap_or(""),
        sc.width,
        sc.height,
        sc.integrator.max_depth,
        machine(),
        devices.join(", ")
    );
    let chart = plot::LineChart {
        title,
        x_label: "render time (s)".into(),
        y_label: "relMSE".into(),
        x_scale: plot::Scale::Log,
        y_scale: plot::Scale::Log,
        x_range: None,
        series,
    };
    // Its data is bench.csv, beside it (every pass's seconds and relMSE, written above).
    plot::write_figure(
        &o.out.join("bench.png"),
        "bench.png",
        &plot::Figure::Lines(chart),
    )?;
    Ok(())
}
