//! `brdfwave` command line: render scenes on the GPU (Vulkan) or the CPU reference, compare
//! images, and measure the reflectance models.

use anyhow::{bail, Context as _, Result};
use brdfwave::{
    bvh,
    cpu::CpuRenderer,
    film::{self, Tile},
    gpu::GpuRenderer,
    imageio, metrics,
    outfile::{self, Output},
    scene, vk,
};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `eprintln!` that never panics: a warning that cannot be written (stderr full or closed) is
/// dropped and the work goes on (std's version panics). `out!` and `outln!` write the
/// command's data to stdout and return an error naming it when that fails: a full disk is an
/// error exit, never a panic, and never a silent success.
macro_rules! eprintln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}
macro_rules! out {
    ($($arg:tt)*) => {
        write_stdout(format_args!($($arg)*))
    };
}
macro_rules! outln {
    ($($arg:tt)*) => {
        write_stdout(format_args!("{}\n", format_args!($($arg)*)))
    };
}

fn write_stdout(args: std::fmt::Arguments<'_>) -> Result<()> {
    use std::io::Write as _;
    let mut o = std::io::stdout().lock();
    o.write_fmt(args)
        .and_then(|_| o.flush())
        .context("cannot write to standard output")
}

#[derive(Parser)]
#[command(
    name = "brdfwave",
    version,
    about = "Vulkan wavefront path tracer for the survey's surface models"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Backend {
    Gpu,
    Cpu,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum IntegratorArg {
    Wavefront,
    Megakernel,
}

impl IntegratorArg {
    fn gpu(self) -> brdfwave::gpu::Integrator {
        match self {
            IntegratorArg::Wavefront => brdfwave::gpu::Integrator::Wavefront,
            IntegratorArg::Megakernel => brdfwave::gpu::Integrator::Megakernel,
        }
    }
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene file to one or more images (.exr linear, .png sRGB).
    Render(RenderArgs),
    /// Merge partial films (.bwfilm outputs of `render`) into one image: the parts must come
    /// from the same scene, settings and program version and cover every pixel and sample once.
    Merge {
        /// The partial films (.bwfilm), in any order.
        #[arg(required = true)]
        parts: Vec<PathBuf>,
        /// Output images (.exr, .png or .pfm); may be given several times.
        #[arg(long = "out", required = true)]
        out: Vec<PathBuf>,
        /// The samples the parts must hold together, START..END: a set that holds fewer (a
        /// missing last part) is refused (default: any one range, without gaps or overlaps).
        #[arg(long, value_parser = brdfwave::film::parse_samples)]
        samples: Option<std::ops::Range<u32>>,
        /// Also write the per-pixel variance of one sample (EXR).
        #[arg(long)]
        variance_out: Option<PathBuf>,
        /// Print the summary as one JSON object on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Compare a test image with a reference: RMSE, relMSE (pbrt) and FLIP.
    Diff {
        /// The image to test (.exr, .png or .pfm).
        test: PathBuf,
        /// The reference image, the same size.
        reference: PathBuf,
        /// Write an error map image.
        #[arg(long)]
        error_map: Option<PathBuf>,
        /// Print the metrics as one JSON object on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Run time against error: every configuration renders the scene progressively, taking
    /// turns, compared with a reference after each pass; writes bench.csv, bench.png, bench.md.
    Bench {
        /// The scene file to benchmark.
        scene: PathBuf,
        /// Reference image (EXR); default: rendered once by the CPU reference and cached.
        #[arg(long)]
        reference: Option<PathBuf>,
        /// Render seconds, shared equally by the configurations.
        #[arg(long, default_value_t = 60.0)]
        budget: f64,
        /// Comma-separated: wavefront, megakernel (each optionally -t1, -t2, … for lavapipe's
        /// LP_NUM_THREADS), cpu, each optionally -independent or -sobol last (the sampler;
        /// default sobol); mitsuba-scalar, mitsuba-llvm, mitsuba-cuda, each optionally
        /// -stratified, -multijitter, -orthogonal or -ldsampler last (default independent).
        #[arg(long, default_value = brdfwave::bench::DEFAULT_CONFIGS)]
        configs: String,
        /// Output directory.
        #[arg(long, default_value = "out/bench")]
        out: PathBuf,
        /// Image size WxH (overrides the scene).
        #[arg(long, value_parser = parse_res)]
        res: Option<(u32, u32)>,
        /// Maximum path segments (overrides the scene).
        #[arg(long)]
        max_depth: Option<u32>,
        /// Samples per pixel of the rendered reference.
        #[arg(long, default_value_t = 1024)]
        reference_spp: u32,
        /// Every configuration renders at least this many samples per pixel, whatever the
        /// budget; the equal-spp table reads 16, 64 and 256.
        #[arg(long, default_value_t = 1)]
        min_spp: u32,
        /// Vulkan device: a case-insensitive part of its name (default: lavapipe if present).
        #[arg(long)]
        device: Option<String>,
        /// Also measure set-up and speed against scene size, with a generated mesh of this many
        /// triangles (e.g. 1048576) and the lineup scene.
        #[arg(long)]
        scaling: Option<u32>,
    },
    /// List the Vulkan devices.
    Devices,
    /// Evaluate, plot and measure reflectance models.
    Brdf {
        #[command(subcommand)]
        command: BrdfCommand,
    },
    /// Randomized numerical-stability checks within a time budget (see src/stress.rs).
    Stress {
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
    },
}

#[derive(Subcommand)]
enum BrdfCommand {
    /// Evaluate f and pdf for direction pairs from a CSV (header wi_x,wi_y,wi_z,wo_x,wo_y,wo_z).
    Eval {
        /// The material as an inline TOML table, e.g. 'model = "ward", kd = 0.1, ks = 0.8, alpha_x = 0.2, alpha_y = 0.1'.
        #[arg(long)]
        material: String,
        /// CSV of direction pairs, header wi_x,wi_y,wi_z,wo_x,wo_y,wo_z: unit vectors in the
        /// local frame (z = normal), both pointing away from the surface, wi toward the light.
        #[arg(long)]
        dirs: PathBuf,
        /// Where to evaluate: the Rust model or its GLSL twin on the Vulkan device.
        #[arg(long, value_enum, default_value = "cpu")]
        backend: Backend,
        /// Output CSV (default: stdout); missing directories are created.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Vulkan device for --backend gpu: a case-insensitive part of its name (default:
        /// lavapipe if present; `brdfwave devices` lists them).
        #[arg(long, value_parser = parse_device)]
        device: Option<String>,
    },
    /// Plot the lobe: polar plot of f·cosθo in the plane of incidence and a hemisphere image.
    Plot {
        /// The material as an inline TOML table, as for `brdf eval`.
        #[arg(long)]
        material: String,
        /// Angle of incidence in degrees, in [0, 90).
        #[arg(long, allow_hyphen_values = true)]
        theta_i: f32,
        /// Output image: .png (as drawn, sRGB), .exr or .pfm (the same colours, linear).
        #[arg(long)]
        out: PathBuf,
    },
    /// Measure every model at representative parameters: albedo, reciprocity, χ², cost, variance.
    Report {
        /// Directory for report.md, report.csv and lobe_*.png (created if missing).
        #[arg(long, default_value = "out/report")]
        out: PathBuf,
        /// Skip the GPU cost measurement.
        #[arg(long)]
        no_gpu: bool,
        /// Vulkan device for the GPU cost measurement: a case-insensitive part of its name
        /// (default: lavapipe if present; `brdfwave devices` lists them).
        #[arg(long, value_parser = parse_device)]
        device: Option<String>,
    },
}

fn parse_sampler(s: &str) -> std::result::Result<brdfwave::rng::Sampler, String> {
    brdfwave::rng::Sampler::parse(s).ok_or_else(|| {
        format!(
            "unknown sampler '{s}': expected one of {}",
            brdfwave::rng::Sampler::names()
        )
    })
}

fn parse_res(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}' is not WxH (e.g. 256x256)"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("bad width in '{s}'"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("bad height in '{s}'"))?;
    let max = brdfwave::scene::load::MAX_FILM_SIZE;
    if w == 0 || h == 0 || w > max || h > max {
        return Err(format!(
            "resolution '{s}' must be between 1x1 and {max}x{max}"
        ));
    }
    Ok((w, h))
}

fn parse_device(s: &str) -> std::result::Result<String, String> {
    if s.trim().is_empty() {
        return Err("the device name is empty; `brdfwave devices` lists the names".to_string());
    }
    Ok(s.to_string())
}

/// Warns about options given with the CPU backend, which ignores them.
fn warn_gpu_only(options: &[(&str, bool)]) {
    for (name, given) in options {
        if *given {
            eprintln!("warning: {name} applies to the GPU backend only; ignored");
        }
    }
}

fn main() {
    // Rust ignores SIGPIPE, so printing to a closed pipe (`brdfwave diff a b | head`) would
    // panic; restore the default action and end quietly, as other command-line tools do.
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    outfile::remove_temporaries_on_signal();
    // A negative number is a value, never an option: `--spp -1` gave clap's tip to write
    // `-- -1`, which does not work; now it is refused as an invalid value of --spp.
    let cli = {
        use clap::{CommandFactory, FromArgMatches};
        let cmd = Cli::command().mut_subcommands(|c| {
            c.allow_negative_numbers(true)
                .mut_subcommands(|c| c.allow_negative_numbers(true))
        });
        Cli::from_arg_matches(&cmd.get_matches()).unwrap_or_else(|e| e.exit())
    };
    let result = match cli.command {
        Command::Render(args) => render(args),
        Command::Merge {
            parts,
            out,
            samples,
            variance_out,
            json,
        } => merge(&parts, &out, samples, variance_out.as_deref(), json),
        Command::Diff {
            test,
            reference,
            error_map,
            json,
        } => diff(&test, &reference, error_map.as_deref(), json),
        Command::Brdf { command } => brdf_command(command),
        Command::Bench {
            scene,
            reference,
            budget,
            configs,
            out,
            res,
            max_depth,
            reference_spp,
            min_spp,
            device,
            scaling,
        } => (|| {
            let configs = configs
                .split(',')
                .map(|c| brdfwave::bench::Config::parse(c.trim()))
                .collect::<Result<Vec<_>>>()?;
            if reference_spp == 0 {
                bail!("--reference-spp must be at least 1");
            }
            if let Some(n) = scaling.filter(|&n| n == 0 || n > 1 << 24) {
                bail!("--scaling takes a triangle count from 1 to 16777216, got {n}");
            }
            let md = brdfwave::bench::run(&brdfwave::bench::BenchOptions {
                scene,
                reference,
                budget,
                configs,
                out: out.clone(),
                res,
                max_depth,
                reference_spp,
                min_spp,
                device,
                scaling,
            })?;
            out!("{md}")?;
            outln!(
                "wrote {0}/bench.csv, {0}/bench.png, {0}/bench.md",
                out.display()
            )?;
            Ok(())
        })(),
        Command::Stress {
            budget,
            seed,
            replay,
            failures,
            groups,
            device,
        } => brdfwave::stress::cli(budget, seed, replay, failures, groups, device),
        Command::Devices => vk::Context::list_devices().and_then(|d| {
            for name in d {
                outln!("{name}")?;
            }
            Ok(())
        }),
    };
    if let Err(e) = result {
        eprintln!("error: {}", brdfwave::errors::chain(&e));
        std::process::exit(1);
    }
}

/// The options of `brdfwave render`.
#[derive(clap::Args)]
struct RenderArgs {
    /// The scene file (TOML; scenes/README.md documents the format).
    scene: PathBuf,
    /// Renderer: the Vulkan wavefront path tracer or the CPU reference.
    #[arg(long, value_enum, default_value = "gpu")]
    backend: Backend,
    /// Samples per pixel (overrides the scene).
    #[arg(long)]
    spp: Option<u32>,
    /// Image size WxH (overrides the scene).
    #[arg(long, value_parser = parse_res)]
    res: Option<(u32, u32)>,
    /// Maximum path segments; the camera segment is one (overrides the scene).
    #[arg(long)]
    max_depth: Option<u32>,
    /// Seed of the random numbers, 0 to 4294967295 (overrides the scene); the same seed
    /// gives nearly the same image on both backends.
    #[arg(long)]
    seed: Option<u32>,
    /// Where the random numbers come from (overrides the scene): `sobol` (Owen-scrambled
    /// Sobol' points, the default) or `independent`.
    #[arg(long, value_parser = parse_sampler)]
    sampler: Option<brdfwave::rng::Sampler>,
    /// Output files (.exr, .png or .pfm images; .bwfilm, a partial film for `brdfwave
    /// merge`); may be given several times; missing directories are created. Default:
    /// out/<scene name>.png
    #[arg(long = "out")]
    out: Vec<PathBuf>,
    /// Render only these sample indices, START..END (END exclusive), e.g. 0..256, for a
    /// partial film: parts with consecutive ranges merge into the image of one render
    /// (default: 0..spp).
    #[arg(long, value_parser = brdfwave::film::parse_samples, conflicts_with = "spp")]
    samples: Option<std::ops::Range<u32>>,
    /// Render only the pixels of this tile, X,Y,W,H (from the top-left corner), for a
    /// partial film; images written are the tile's size (default: the whole image).
    #[arg(long, value_parser = brdfwave::film::Tile::parse)]
    tile: Option<Tile>,
    /// Also write the per-pixel variance of one sample (EXR), for statistical tests.
    #[arg(long)]
    variance_out: Option<PathBuf>,
    /// Vulkan device: a case-insensitive part of its name (default: lavapipe if present;
    /// `brdfwave devices` lists them). GPU backend only.
    #[arg(long, value_parser = parse_device)]
    device: Option<String>,
    /// Enable the Khronos validation layer; the run fails if it reports anything, or if the
    /// layer is not installed. GPU backend only.
    #[arg(long)]
    validation: bool,
    /// GPU: most paths in flight at a time, 64 to 1048576 (the default). The image does not
    /// depend on it.
    #[arg(long)]
    wave_paths: Option<u32>,
    /// GPU: how paths are followed: `wavefront` (the stages with queues, the default) or
    /// `megakernel` (one kernel per wave, the benchmark's baseline). Same image.
    #[arg(long, value_enum, default_value = "wavefront")]
    integrator: IntegratorArg,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

fn progress_bar(len: u64, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template(&format!(
            "{{spinner}} {what} [{{bar:40}}] {{pos}}/{{len}} {{elapsed}} eta {{eta}}"
        ))
        .expect("valid template")
        .progress_chars("=> "),
    );
    pb
}

/// What `render` reports: printed as text, or as one JSON object with `--json`.
#[derive(Serialize)]
struct RenderSummary {
    backend: &'static str,
    device: String,
    scene: String,
    width: u32,
    height: u32,
    /// The part of the image rendered, when not all of it (`--tile`).
    #[serde(skip_serializing_if = "Option::is_none")]
    tile: Option<Tile>,
    /// The sample indices rendered, START..END.
    samples: [u32; 2],
    spp: u32,
    max_depth: u32,
    seed: u32,
    sampler: &'static str,
    russian_roulette: bool,
    /// GPU only.
    #[serde(flatten)]
    gpu: Option<GpuSetup>,
    seconds_bvh: f64,
    bvh_nodes: usize,
    seconds_setup: f64,
    seconds_render: f64,
    paths_per_second: f64,
    rays_per_second: f64,
    extension_rays: u64,
    shadow_rays: u64,
    rays_by_segment: Vec<SegmentRays>,
    nonfinite_samples: u64,
    nonfinite_by_stage: Vec<StageCount>,
    mean_radiance: [f64; 3],
    stage_seconds: Vec<StageSeconds>,
    outputs: Vec<String>,
    variance_output: Option<String>,
}

#[derive(Serialize)]
struct GpuSetup {
    pipelines: Vec<String>,
    seconds_shader_compile: f64,
    seconds_pipeline_create: f64,
    wave_paths: u32,
    integrator: &'static str,
    subgroup_queues: bool,
}

#[derive(Serialize)]
struct SegmentRays {
    extension: u64,
    shadow: u64,
}

#[derive(Serialize)]
struct StageCount {
    stage: String,
    count: u64,
}

#[derive(Serialize)]
struct StageSeconds {
    stage: String,
    seconds: f64,
}

fn stage_counts(v: &[(String, u64)]) -> Vec<StageCount> {
    v.iter()
        .map(|(stage, count)| StageCount {
            stage: stage.clone(),
            count: *count,
        })
        .collect()
}

impl std::fmt::Display for RenderSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "backend        {} on {}", self.backend, self.device)?;
        let part = match (&self.tile, self.samples[0]) {
            (None, 0) => String::new(),
            (tile, _) => format!(
                " (samples {}..{}{})",
                self.samples[0],
                self.samples[1],
                tile.map(|t| format!(", tile {t}")).unwrap_or_default()
            ),
        };
        writeln!(
            f,
            "image          {}x{}, {} spp{part}, max depth {}, sampler {}",
            self.width, self.height, self.spp, self.max_depth, self.sampler
        )?;
        if let Some(g) = &self.gpu {
            writeln!(
                f,
                "pipelines      {} (compile {:.3} s, create {:.3} s)",
                g.pipelines.join(", "),
                g.seconds_shader_compile,
                g.seconds_pipeline_create
            )?;
            let sg = if g.subgroup_queues {
                ", subgroup-aggregated queue pushes"
            } else {
                ""
            };
            writeln!(f, "wave           {} paths in flight{sg}", g.wave_paths)?;
        }
        writeln!(
            f,
            "time           set-up {:.3} s (BVH {:.3} s), render {:.3} s",
            self.seconds_setup, self.seconds_bvh, self.seconds_render
        )?;
        writeln!(
            f,
            "throughput     {:.3} M paths/s, {:.3} M rays/s",
            self.paths_per_second / 1e6,
            self.rays_per_second / 1e6
        )?;
        write_nonfinite(f, self.nonfinite_samples, &self.nonfinite_by_stage)?;
        if !self.stage_seconds.is_empty() {
            let parts: Vec<String> = self
                .stage_seconds
                .iter()
                .map(|e| format!("{} {:.3}", e.stage, e.seconds))
                .collect();
            writeln!(f, "stages (s)     {}", parts.join(", "))?;
        }
        for o in self.outputs.iter().chain(&self.variance_output) {
            writeln!(f, "wrote          {o}")?;
        }
        Ok(())
    }
}

fn write_nonfinite(
    f: &mut std::fmt::Formatter<'_>,
    total: u64,
    by_stage: &[StageCount],
) -> std::fmt::Result {
    let by_stage: Vec<String> = by_stage
        .iter()
        .map(|e| format!("{} {}", e.stage, e.count))
        .collect();
    writeln!(
        f,
        "non-finite     {total} values dropped ({})",
        by_stage.join(", ")
    )
}

/// Where a render's outputs go: images get the mean (or, for `--variance-out`, the variance);
/// `.bwfilm` files get the partial film.
fn is_partial_film(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("bwfilm"))
}

fn render(a: RenderArgs) -> Result<()> {
    let t0 = Instant::now();
    let mut sc = scene::load(&a.scene)?;
    for w in &sc.warnings {
        eprintln!("{w}");
    }
    if let Some(spp) = a.spp {
        if spp == 0 {
            bail!("--spp must be at least 1");
        }
        sc.integrator.spp = spp;
    }
    if let Some((w, h)) = a.res {
        sc.width = w;
        sc.height = h;
    }
    if let Some(d) = a.max_depth {
        if d == 0 {
            bail!("--max-depth must be at least 1 (the camera segment)");
        }
        if d > brdfwave::gpu::MAX_DEPTH {
            bail!(
                "--max-depth {d} is over the largest supported depth, {} segments",
                brdfwave::gpu::MAX_DEPTH
            );
        }
        sc.integrator.max_depth = d;
    }
    if let Some(s) = a.seed {
        sc.integrator.seed = s;
    }
    if let Some(s) = a.sampler {
        sc.integrator.sampler = s;
    }
    // The samples and pixels to render: all of them unless a part is asked for.
    let samples = a.samples.clone().unwrap_or(0..sc.integrator.spp);
    sc.integrator.spp = samples.end - samples.start;
    let full = Tile::full(sc.width, sc.height);
    let tile = a.tile.unwrap_or(full);
    tile.check_within(sc.width, sc.height)
        .map_err(anyhow::Error::msg)
        .context("--tile")?;
    if let Some(w) = a.wave_paths {
        brdfwave::gpu::check_wave_paths(w).context("--wave-paths")?;
    }
    if a.backend == Backend::Cpu {
        warn_gpu_only(&[
            ("--device", a.device.is_some()),
            ("--validation", a.validation),
            ("--wave-paths", a.wave_paths.is_some()),
        ]);
    } else if a.validation {
        vk::require_validation().context("--validation")?;
    }
    let (outs, out_option) = if a.out.is_empty() {
        let stem = a
            .scene
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("render");
        (
            vec![PathBuf::from(format!("out/{stem}.png"))],
            "the default output",
        )
    } else {
        (a.out.clone(), "--out")
    };
    let mut planned: Vec<Output> = outs
        .iter()
        .map(|p| Output {
            option: out_option,
            path: p,
        })
        .collect();
    if let Some(v) = &a.variance_out {
        planned.push(Output {
            option: "--variance-out",
            path: v,
        });
    }
    for (i, o) in planned.iter().enumerate() {
        if i < outs.len() && is_partial_film(o.path) {
            continue;
        }
        imageio::Format::from_path(o.path).with_context(|| {
            if i < outs.len() {
                format!("{} (a partial film ends in .bwfilm)", o.option)
            } else {
                o.option.to_string()
            }
        })?;
    }
    outfile::refuse_inputs(&planned, &[("scene file", &a.scene)])?;
    outfile::prepare(&planned)?;
    let wants_film = outs.iter().any(|p| is_partial_film(p));
    let t_bvh = Instant::now();
    let bvh = bvh::build(&sc);
    let seconds_bvh = t_bvh.elapsed().as_secs_f64();

    let (output, film, device, gpu, seconds_setup, seconds_render);
    match a.backend {
        Backend::Gpu => {
            let ctx = vk::Context::new(&vk::ContextOptions {
                device: a.device.clone(),
                validation: a.validation,
            })?;
            let compiler = vk::ShaderCompiler::new()?;
            let wave = a.wave_paths.unwrap_or(brdfwave::gpu::MAX_WAVE_PATHS);
            let mut r = GpuRenderer::with_options(
                &ctx,
                &sc,
                &bvh,
                &compiler,
                brdfwave::gpu::GpuOptions {
                    wave_paths: wave,
                    integrator: a.integrator.gpu(),
                    tile: Some(tile),
                },
            )?;
            seconds_setup = t0.elapsed().as_secs_f64();
            // Per mille of a sample, so that a single wave shows progress by segment.
            let pb = progress_bar(sc.integrator.spp as u64 * 1000, "samples");
            pb.set_style(
                ProgressStyle::with_template(
                    "{spinner} samples [{bar:40}] {percent}% {elapsed} eta {eta}",
                )
                .expect("valid template")
                .progress_chars("=> "),
            );
            let t = Instant::now();
            r.render_samples(samples.clone(), &|n| pb.set_position((n * 1000.0) as u64))?;
            output = r.output()?;
            seconds_render = t.elapsed().as_secs_f64();
            // Downloaded again only for a partial film (output() keeps only the images).
            film = wants_film.then(|| r.film()).transpose()?;
            pb.finish_and_clear();
            device = ctx.device_name.clone();
            gpu = Some(GpuSetup {
                pipelines: r.setup.pipelines.clone(),
                seconds_shader_compile: r.setup.seconds_shader_compile,
                seconds_pipeline_create: r.setup.seconds_pipeline_create,
                wave_paths: r.setup.wave_paths,
                integrator: a.integrator.gpu().name(),
                subgroup_queues: r.setup.subgroup_queues,
            });
            drop(r);
            // Tear down now so that messages raised at device destruction (leaks) count too.
            let msgs = ctx.finish();
            if !msgs.is_empty() {
                bail!(
                    "the validation layer reported {} message(s):\n{}",
                    msgs.len(),
                    msgs.join("\n")
                );
            }
        }
        Backend::Cpu => {
            // The film (6 f64 sums per pixel and block), the mean and variance images, and the
            // encoded output (a partial film is the sums again): an allocation that fails
            // aborts, so ask first.
            let blocks = film::dyadic_blocks(samples.clone()).len() as u64;
            let per_pixel = 48 * blocks + 24 + if wants_film { 48 * blocks } else { 12 };
            brdfwave::memory::check(
                tile.pixels() as u64 * per_pixel,
                &format!("a CPU render of {}x{} pixels", tile.width, tile.height),
                "render a smaller image or split it into tiles (--tile)",
            )?;
            seconds_setup = t0.elapsed().as_secs_f64();
            let r = CpuRenderer::new(&sc, &bvh);
            let pb = progress_bar(tile.height as u64, "rows");
            let t = Instant::now();
            let mut f = r.film_of(tile);
            r.render_samples(&mut f, samples.clone(), &|n| pb.set_position(n as u64));
            output = r.output(&f);
            seconds_render = t.elapsed().as_secs_f64();
            film = wants_film.then_some(f.film);
            pb.finish_and_clear();
            device = format!("CPU reference ({} threads)", rayon::current_num_threads());
            gpu = None;
        }
    }
    let backend = match a.backend {
        Backend::Gpu => "gpu",
        Backend::Cpu => "cpu",
    };
    let part = film.map(|film| {
        film::Part::of_render(
            &a.scene.display().to_string(),
            &sc,
            film,
            &output,
            backend,
            &device,
            seconds_render,
        )
    });
    // Every output that can be written is, even when one fails; then the failures are reported.
    let paths: Vec<&Path> = planned.iter().map(|o| o.path).collect();
    outfile::write_each(&paths, |i, p| {
        if i < outs.len() && is_partial_film(p) {
            film::write_part(
                p,
                part.as_ref().expect("a film is kept for .bwfilm outputs"),
            )?;
        } else {
            let img = if i < outs.len() {
                &output.mean
            } else {
                &output.variance
            };
            imageio::write(p, img)?;
        }
        Ok(())
    })?;
    let paths = tile.pixels() as f64 * output.spp as f64;
    let rays = (output.extension_rays + output.shadow_rays) as f64;
    let summary = RenderSummary {
        backend,
        device,
        scene: a.scene.display().to_string(),
        width: sc.width,
        height: sc.height,
        tile: (tile != full).then_some(tile),
        samples: [samples.start, samples.end],
        spp: output.spp,
        max_depth: sc.integrator.max_depth,
        seed: sc.integrator.seed,
        sampler: sc.integrator.sampler.name(),
        russian_roulette: sc.integrator.russian_roulette,
        gpu,
        seconds_bvh,
        bvh_nodes: bvh.nodes.len(),
        seconds_setup,
        seconds_render,
        paths_per_second: paths / seconds_render.max(1e-9),
        rays_per_second: rays / seconds_render.max(1e-9),
        extension_rays: output.extension_rays,
        shadow_rays: output.shadow_rays,
        rays_by_segment: output
            .rays_by_segment
            .iter()
            .map(|&(extension, shadow)| SegmentRays { extension, shadow })
            .collect(),
        nonfinite_samples: output.nonfinite_samples,
        nonfinite_by_stage: stage_counts(&output.nonfinite_by_stage),
        mean_radiance: output.mean.mean(),
        stage_seconds: output
            .stage_seconds
            .iter()
            .map(|(stage, seconds)| StageSeconds {
                stage: stage.clone(),
                seconds: *seconds,
            })
            .collect(),
        outputs: outs.iter().map(|o| o.display().to_string()).collect(),
        variance_output: a.variance_out.as_ref().map(|v| v.display().to_string()),
    };
    if a.json {
        outln!("{}", serde_json::to_string(&summary)?)?;
    } else {
        out!("{summary}")?;
    }
    if output.nonfinite_samples > 0 {
        eprintln!(
            "warning: {} non-finite values were dropped (see the stages above)",
            output.nonfinite_samples
        );
    }
    Ok(())
}

/// What `merge` reports.
#[derive(Serialize)]
struct MergeSummary {
    scene: String,
    parts: usize,
    tiles: usize,
    width: u32,
    height: u32,
    samples: [u32; 2],
    spp: u32,
    backends: Vec<String>,
    extension_rays: u64,
    shadow_rays: u64,
    nonfinite_samples: u64,
    nonfinite_by_stage: Vec<StageCount>,
    /// The parts' render times added: the compute time of the whole job.
    seconds_render: f64,
    mean_radiance: [f64; 3],
    outputs: Vec<String>,
    variance_output: Option<String>,
}

impl std::fmt::Display for MergeSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "merged         {} parts ({} tile{}) of {}",
            self.parts,
            self.tiles,
            if self.tiles == 1 { "" } else { "s" },
            self.scene
        )?;
        writeln!(
            f,
            "image          {}x{}, {} spp (samples {}..{})",
            self.width, self.height, self.spp, self.samples[0], self.samples[1]
        )?;
        writeln!(f, "rendered on    {}", self.backends.join("; "))?;
        writeln!(
            f,
            "work           {:.3} s of rendering, {} extension and {} shadow rays",
            self.seconds_render, self.extension_rays, self.shadow_rays
        )?;
        write_nonfinite(f, self.nonfinite_samples, &self.nonfinite_by_stage)?;
        for o in self.outputs.iter().chain(&self.variance_output) {
            writeln!(f, "wrote          {o}")?;
        }
        Ok(())
    }
}

fn merge(
    parts: &[PathBuf],
    out: &[PathBuf],
    samples: Option<std::ops::Range<u32>>,
    variance_out: Option<&Path>,
    json: bool,
) -> Result<()> {
    let mut planned: Vec<Output> = out
        .iter()
        .map(|p| Output {
            option: "--out",
            path: p,
        })
        .collect();
    if let Some(v) = variance_out {
        planned.push(Output {
            option: "--variance-out",
            path: v,
        });
    }
    for o in &planned {
        imageio::Format::from_path(o.path).with_context(|| o.option.to_string())?;
        if let Some(p) = parts
            .iter()
            .find(|p| outfile::resolve(p) == outfile::resolve(o.path))
        {
            bail!(
                "{} {} is also a part to merge: it would be overwritten",
                o.option,
                p.display()
            );
        }
    }
    outfile::prepare(&planned)?;
    let m = film::merge(parts)?;
    if let Some(want) = samples.filter(|w| *w != m.samples) {
        bail!(
            "the parts hold samples {}..{}, not the {}..{} asked for (--samples): a part is missing or left over",
            m.samples.start,
            m.samples.end,
            want.start,
            want.end
        );
    }
    let paths: Vec<&Path> = planned.iter().map(|o| o.path).collect();
    outfile::write_each(&paths, |i, p| {
        imageio::write(p, if i < out.len() { &m.mean } else { &m.variance })?;
        Ok(())
    })?;
    let nonfinite_samples = m.nonfinite_by_stage.iter().map(|s| s.1).sum();
    let summary = MergeSummary {
        scene: m.scene.clone(),
        parts: parts.len(),
        tiles: m.tiles,
        width: m.mean.width,
        height: m.mean.height,
        samples: [m.samples.start, m.samples.end],
        spp: m.samples.end - m.samples.start,
        backends: m.backends.clone(),
        extension_rays: m.extension_rays,
        shadow_rays: m.shadow_rays,
        nonfinite_samples,
        nonfinite_by_stage: stage_counts(&m.nonfinite_by_stage),
        seconds_render: m.seconds_render,
        mean_radiance: m.mean.mean(),
        outputs: out.iter().map(|o| o.display().to_string()).collect(),
        variance_output: variance_out.map(|v| v.display().to_string()),
    };
    if json {
        outln!("{}", serde_json::to_string(&summary)?)?;
    } else {
        out!("{summary}")?;
    }
    if nonfinite_samples > 0 {
        eprintln!("warning: the parts dropped {nonfinite_samples} non-finite values");
    }
    Ok(())
}

fn diff(test: &Path, reference: &Path, error_map: Option<&Path>, json_out: bool) -> Result<()> {
    if let Some(p) = error_map {
        imageio::Format::from_path(p).context("--error-map")?;
        for (name, input) in [("TEST", test), ("REFERENCE", reference)] {
            if outfile::resolve(p) == outfile::resolve(input) {
                bail!(
                    "--error-map {} is the {name} image: it would be overwritten; give the error \
                     map its own path",
                    p.display()
                );
            }
        }
        outfile::prepare(&[Output {
            option: "--error-map",
            path: p,
        }])?;
    }
    let a = imageio::read(test)?;
    let b = imageio::read(reference)?;
    let report = metrics::diff(&a, &b)?;
    if let Some(p) = error_map {
        imageio::write(p, &metrics::error_map(&a, &b)?)?;
    }
    if json_out {
        let j = json!({
            "width": report.width,
            "height": report.height,
            "mse": report.mse,
            "rmse": report.rmse,
            "relmse": report.relmse,
            "flip_mean": report.flip_mean,
            "max_abs": report.max_abs,
            "mean_test": report.mean_test,
            "mean_reference": report.mean_reference,
            "nonfinite_test": report.nonfinite_test,
            "nonfinite_reference": report.nonfinite_reference,
        });
        outln!("{j}")?;
    } else {
        out!("{report}")?;
    }
    // The metrics leave non-finite values out (two all-NaN images scored RMSE 0, FLIP 0): such
    // images do not compare, whatever the numbers above say.
    if report.nonfinite_test + report.nonfinite_reference > 0 {
        bail!(
            "the images hold non-finite values ({} in {}, {} in {}), which the metrics leave out: they do not compare",
            report.nonfinite_test,
            test.display(),
            report.nonfinite_reference,
            reference.display()
        );
    }
    Ok(())
}

fn brdf_command(cmd: BrdfCommand) -> Result<()> {
    use brdfwave::brdf::inline::parse_inline;
    use brdfwave::brdf_tools as tools;
    match cmd {
        BrdfCommand::Eval {
            material,
            dirs,
            backend,
            out,
            device,
        } => {
            if backend == Backend::Cpu {
                warn_gpu_only(&[("--device", device.is_some())]);
            }
            if let Some(p) = &out {
                let o = [Output {
                    option: "--out",
                    path: p,
                }];
                outfile::refuse_inputs(&o, &[("--dirs file", &dirs)])?;
                outfile::prepare(&o)?;
            }
            let m = parse_inline(&material)?;
            let pairs = tools::read_direction_csv(&dirs)?;
            // Below the horizon every model is 0 by definition: say so rather than print zeros
            // without a word.
            let below = pairs
                .iter()
                .filter(|(wi, wo)| wi.z <= 0.0 || wo.z <= 0.0)
                .count();
            if below > 0 {
                eprintln!(
                    "warning: {}: {below} of {} direction pairs have wi or wo at or below the horizon (z <= 0), where f and pdf are 0",
                    dirs.display(),
                    pairs.len()
                );
            }
            let values = match backend {
                Backend::Cpu => tools::eval_cpu(&m, &pairs),
                Backend::Gpu => {
                    let ctx = vk::Context::new(&vk::ContextOptions {
                        device,
                        validation: false,
                    })?;
                    let compiler = vk::ShaderCompiler::new()?;
                    brdfwave::gpu::brdf_probe::eval(&ctx, &compiler, &m, &pairs)?
                }
            };
            let csv = tools::format_eval_csv(&pairs, &values);
            match out {
                Some(p) => outfile::write(&p, csv.as_bytes())?,
                None => out!("{csv}")?,
            }
        }
        BrdfCommand::Plot {
            material,
            theta_i,
            out,
        } => {
            if !(0.0..90.0).contains(&theta_i) {
                bail!("--theta-i must be in [0, 90) degrees, got {theta_i}");
            }
            imageio::Format::from_path(&out).context("--out")?;
            outfile::prepare(&[Output {
                option: "--out",
                path: &out,
            }])?;
            let m = parse_inline(&material)?;
            tools::write_plot(&out, &tools::plot_lobe(m.brdf.as_ref(), theta_i))?;
            outln!("wrote {}", out.display())?;
        }
        BrdfCommand::Report {
            out,
            no_gpu,
            device,
        } => {
            if no_gpu {
                warn_gpu_only(&[("--device", device.is_some())]);
            }
            tools::prepare_report_dir(&out)?;
            let gpu = if no_gpu {
                None
            } else {
                let ctx = vk::Context::new(&vk::ContextOptions {
                    device,
                    validation: false,
                })?;
                let compiler = vk::ShaderCompiler::new()?;
                Some((ctx, compiler))
            };
            let mut rows = Vec::new();
            for (label, src) in tools::representative() {
                eprintln!("measuring {label}");
                let (mut row, m) = tools::report_row(label, src)?;
                if let Some((ctx, compiler)) = &gpu {
                    row.ns_per_eval_gpu =
                        Some(brdfwave::gpu::brdf_probe::eval_cost(ctx, compiler, &m)?);
                }
                tools::write_plot(
                    &out.join(format!("lobe_{}.png", tools::slug(label))),
                    &tools::plot_lobe(m.brdf.as_ref(), 45.0),
                )?;
                rows.push(row);
            }
            let device_name = gpu.as_ref().map(|(c, _)| c.device_name.clone());
            let md = tools::report_markdown(&rows, device_name.as_deref());
            outfile::write(&out.join("report.md"), md.as_bytes())?;
            outfile::write(&out.join("report.csv"), tools::report_csv(&rows).as_bytes())?;
            out!("{md}")?;
            outln!(
                "\nwrote {}/report.md, report.csv and lobe_*.png",
                out.display()
            )?;
        }
    }
    Ok(())
}
