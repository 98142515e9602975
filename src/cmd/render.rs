//! `brdfwave render`: one scene, one backend, one [`Renderer`] (`brdfwave::render`), written to
//! images or a partial film, and the summary of the render.

use super::summary::{stage_counts, write_nonfinite, StageCount};
use super::{parse_device, parse_res, parse_sampler, warn_gpu_only, Backend, IntegratorArg};
use anyhow::{bail, Context as _, Result};
use brdfwave::{
    bvh,
    film::{self, Tile},
    imageio,
    outfile::{self, Output},
    overrides::{self, Set},
    render::{
        self, Description, Overrides, Progress, ProgressUnit, RenderRequest, Rendered, Renderer,
    },
    scene::{self, Scene},
    vk,
};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The options of `brdfwave render`.
#[derive(clap::Args)]
pub struct RenderArgs {
    /// The scene file: TOML, or Mitsuba 3 XML when it ends in .xml (scenes/README.md
    /// documents both).
    scene: PathBuf,
    /// Set a parameter of a Mitsuba XML scene (overrides its `<default>`), like Mitsuba's -D.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = super::parse_define)]
    define: Vec<(String, String)>,
    /// Renderer: the Vulkan wavefront path tracer or the CPU reference.
    #[arg(long, value_enum, default_value = "gpu")]
    backend: Backend,
    /// Samples per pixel (overrides the scene).
    #[arg(value_name = "N", long)]
    spp: Option<u32>,
    /// Image size WxH (overrides the scene).
    #[arg(value_name = "WxH", long, value_parser = parse_res)]
    res: Option<(u32, u32)>,
    /// Maximum path segments; the camera segment is one (overrides the scene).
    #[arg(value_name = "D", long)]
    max_depth: Option<u32>,
    /// Seed of the random numbers, 0 to 4294967295 (overrides the scene); the same seed
    /// gives nearly the same image on both backends.
    #[arg(value_name = "S", long)]
    seed: Option<u32>,
    /// Where the random numbers come from (overrides the scene): `multijitter` (correlated
    /// multi-jittered points of the render's sample count, the default), `sobol`
    /// (Owen-scrambled Sobol' points, stratified at every power of two) or `independent`.
    #[arg(long, value_parser = parse_sampler)]
    sampler: Option<brdfwave::rng::Sampler>,
    /// Output files (.exr, .png or .pfm images; .bwfilm, a partial film for `brdfwave
    /// merge`); may be given several times; missing directories are created. Default:
    /// out/<scene name>.png
    #[arg(value_name = "FILE", long = "out")]
    out: Vec<PathBuf>,
    /// Render only these sample indices, START..END (END exclusive), e.g. 0..256, for a
    /// partial film: parts with consecutive ranges merge into the image of one render of spp
    /// samples (`--spp`, else the scene's), which the range must lie in (default: 0..spp).
    #[arg(value_name = "START..END", long, value_parser = brdfwave::film::parse_samples)]
    samples: Option<std::ops::Range<u32>>,
    /// Render only the pixels of this tile, X,Y,W,H (from the top-left corner), for a
    /// partial film; images written are the tile's size (default: the whole image).
    #[arg(value_name = "X,Y,W,H", long, value_parser = brdfwave::film::Tile::parse)]
    tile: Option<Tile>,
    /// Also write the per-pixel variance of one sample (EXR), for statistical tests.
    #[arg(value_name = "FILE.exr", long)]
    variance_out: Option<PathBuf>,
    /// Render in K independent batches of spp/K samples, 2 to 65536 (8 or more for the z-test
    /// of `diff`, whose approximations want K − 1 >= 7 degrees of freedom), and write beside the
    /// image (EXR layer `meanVariance`) the variance of each pixel's mean from the K batch
    /// means: right for every sampler, where the variance of one sample over the spp is right
    /// only for `independent`; the z-test of `diff` uses it. With `multijitter` each batch is its
    /// own pattern of spp/K points and with `sobol` its own scramble (for both, spp/K a power of
    /// two), so the image is not the unbatched one; with `independent` it is.
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(2..=65536))]
    batches: Option<u32>,
    /// Vulkan device: a case-insensitive part of its name (default: lavapipe if present;
    /// `brdfwave devices` lists them). GPU backend only.
    #[arg(value_name = "NAME", long, value_parser = parse_device)]
    device: Option<String>,
    /// Enable the Khronos validation layer; the run fails if it reports anything, or if the
    /// layer is not installed. GPU backend only.
    #[arg(long)]
    validation: bool,
    /// GPU: most paths in flight at a time, 64 to 1048576 (the default). The image does not
    /// depend on it.
    #[arg(value_name = "N", long)]
    wave_paths: Option<u32>,
    /// GPU: how paths are followed: `wavefront` (the stages with queues), `megakernel` (one
    /// kernel per wave, the benchmark's baseline) or `auto` (the default: the megakernel for
    /// waves of at most 2048 paths, where the wavefront's cost per segment dominates, else the
    /// wavefront). Same image; the summary names the one that ran.
    #[arg(long, value_enum)]
    integrator: Option<IntegratorArg>,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    json: bool,
    /// Override a field of the scene file before it is checked, KEY=VALUE, e.g.
    /// `integrator.spp=256`, `materials.gold.roughness=0.1`, `shapes[2].sphere.radius=1.5`;
    /// VALUE is a TOML value (a bare word is a string); may be given several times, later
    /// ones win. Checked like the file; an error names the override.
    #[arg(long = "set", value_name = "KEY=VALUE", value_parser = Set::parse)]
    set: Vec<Set>,
    /// Worker threads, 1 to 1024: the CPU backend's thread pool, or on the GPU backend
    /// lavapipe's (LP_NUM_THREADS, which other drivers ignore). Default: one per core.
    #[arg(value_name = "N", long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// No progress bar and no text summary (with --json, the JSON summary is still printed);
    /// warnings and errors still go to stderr.
    #[arg(long)]
    quiet: bool,
}

impl RenderArgs {
    fn overrides(&self) -> Overrides {
        Overrides {
            spp: self.spp,
            res: self.res,
            max_depth: self.max_depth,
            seed: self.seed,
            sampler: self.sampler,
            samples: self.samples.clone(),
            tile: self.tile,
        }
    }
}

/// The bar of a render's progress on stderr (drawn only on a terminal): rows of the tile on
/// the CPU, per cent of the samples on the GPU.
fn progress_bar(unit: ProgressUnit, total: f64, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let (len, template) = match unit {
        ProgressUnit::Rows => (
            total as u64,
            "{spinner} rows [{bar:40}] {pos}/{len} {elapsed} eta {eta}",
        ),
        // Per mille of a sample, so that a single wave shows progress by segment.
        ProgressUnit::Samples => (
            total as u64 * 1000,
            "{spinner} samples [{bar:40}] {percent}% {elapsed} eta {eta}",
        ),
    };
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template(template)
            .expect("valid template")
            .progress_chars("=> "),
    );
    pb
}

fn show(pb: &ProgressBar, p: Progress) {
    pb.set_position(match p.unit {
        ProgressUnit::Rows => p.done as u64,
        ProgressUnit::Samples => (p.done * 1000.0) as u64,
    });
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
    /// `--batches K`: the render in K independent batches (null without).
    batches: Option<u32>,
    max_depth: u32,
    seed: u32,
    sampler: &'static str,
    russian_roulette: bool,
    /// The CPU backend's thread pool, or the `--threads` given to lavapipe (else null).
    threads: Option<u32>,
    /// GPU only.
    #[serde(flatten)]
    gpu: Option<GpuSetup>,
    seconds_bvh: f64,
    /// Nodes of the tree the backend walks: binary on the GPU, 8-wide on the CPU.
    bvh_nodes: usize,
    seconds_setup: f64,
    seconds_render: f64,
    paths_per_second: f64,
    rays_per_second: f64,
    extension_rays: u64,
    shadow_rays: u64,
    /// Shadow rays that found an occluder.
    shadow_rays_occluded: u64,
    rays_by_segment: Vec<SegmentRays>,
    nonfinite_samples: u64,
    nonfinite_by_stage: Vec<StageCount>,
    mean_radiance: [f64; 3],
    stage_seconds: Vec<StageSeconds>,
    /// The distinct measured tables, each held once, and the memory each takes on this
    /// backend (GPU: an RGBA32F texel per cell; CPU: three f32 planes).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    measured_tables: Vec<MeasuredTable>,
    outputs: Vec<String>,
    variance_output: Option<String>,
}

#[derive(Serialize)]
struct MeasuredTable {
    file: String,
    bytes: u64,
}

/// The scene's distinct measured tables with their memory on the backend.
fn measured_tables(sc: &Scene, gpu: bool) -> Vec<MeasuredTable> {
    let t = brdfwave::gpu::scene_buffers::MeasuredTables::of(&sc.materials);
    let per_table = match gpu {
        true => t.gpu_bytes() / t.tables.len().max(1) as u64,
        false => t
            .tables
            .first()
            .map_or(0, |s| s.table.memory_bytes() as u64),
    };
    t.tables
        .iter()
        .map(|s| MeasuredTable {
            file: s.path.display().to_string(),
            bytes: per_table,
        })
        .collect()
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
struct StageSeconds {
    stage: String,
    seconds: f64,
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
        let batches = self
            .batches
            .map(|k| format!(" in {k} batches"))
            .unwrap_or_default();
        writeln!(
            f,
            "image          {}x{}, {} spp{batches}{part}, max depth {}, sampler {}",
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
            writeln!(
                f,
                "wave           {} paths in flight, {} integrator{sg}",
                g.wave_paths, g.integrator
            )?;
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
        if !self.measured_tables.is_empty() {
            let bytes: u64 = self.measured_tables.iter().map(|t| t.bytes).sum();
            let files: Vec<&str> = self
                .measured_tables
                .iter()
                .map(|t| t.file.as_str())
                .collect();
            writeln!(
                f,
                "measured       {} table(s) held once each, {:.1} MiB: {}",
                files.len(),
                bytes as f64 / (1 << 20) as f64,
                files.join(", ")
            )?;
        }
        for o in self.outputs.iter().chain(&self.variance_output) {
            writeln!(f, "wrote          {o}")?;
        }
        Ok(())
    }
}

/// Where a render's outputs go: images get the mean (or, for `--variance-out`, the variance);
/// `.bwfilm` files get the partial film.
fn is_partial_film(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("bwfilm"))
}

/// The outputs of a render: the images and partial films asked for (`--out`, else the
/// default), then `--variance-out`.
struct Outputs {
    outs: Vec<PathBuf>,
    variance_out: Option<PathBuf>,
    option: &'static str,
}

impl Outputs {
    fn of(a: &RenderArgs) -> Self {
        let (outs, option) = if a.out.is_empty() {
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
        Outputs {
            outs,
            variance_out: a.variance_out.clone(),
            option,
        }
    }

    fn planned(&self) -> Vec<Output<'_>> {
        let mut planned: Vec<Output> = self
            .outs
            .iter()
            .map(|p| Output {
                option: self.option,
                path: p,
            })
            .collect();
        if let Some(v) = &self.variance_out {
            planned.push(Output {
                option: "--variance-out",
                path: v,
            });
        }
        planned
    }

    /// Refuses an output of an unknown format or that is the scene file, and makes the
    /// directories, before anything is rendered.
    fn prepare(&self, scene: &Path) -> Result<()> {
        let planned = self.planned();
        for (i, o) in planned.iter().enumerate() {
            if i < self.outs.len() && is_partial_film(o.path) {
                continue;
            }
            imageio::Format::from_path(o.path).with_context(|| {
                if i < self.outs.len() {
                    format!("{} (a partial film ends in .bwfilm)", o.option)
                } else {
                    o.option.to_string()
                }
            })?;
        }
        outfile::refuse_inputs(&planned, &[("scene file", scene)])?;
        outfile::prepare(&planned)
    }

    fn wants_film(&self) -> bool {
        self.outs.iter().any(|p| is_partial_film(p))
    }

    /// Writes every output that can be written, even when one fails; then reports the failures.
    /// EXR images carry `provenance`, and the image outputs the variance as a layer.
    fn write(
        &self,
        r: &Rendered,
        batch_variance: Option<&imageio::BatchVariance>,
        part: Option<&film::Part>,
        provenance: &imageio::Provenance,
    ) -> Result<()> {
        let planned = self.planned();
        let paths: Vec<&Path> = planned.iter().map(|o| o.path).collect();
        outfile::write_each(&paths, |i, p| {
            if i < self.outs.len() && is_partial_film(p) {
                film::write_part(p, part.expect("a film is kept for .bwfilm outputs"))?;
            } else {
                let (img, variance, batch_variance) = if i < self.outs.len() {
                    (&r.output.mean, Some(&r.output.variance), batch_variance)
                } else {
                    (&r.output.variance, None, None)
                };
                let extras = imageio::Extras {
                    variance,
                    batch_variance,
                    provenance: Some(provenance),
                };
                imageio::write_layered(p, img, &extras)?;
            }
            Ok(())
        })?;
        Ok(())
    }
}

pub fn run(a: RenderArgs) -> Result<()> {
    let t0 = Instant::now();
    set_threads(a.backend, a.threads)?;
    let (mut sc, scene_bytes) = load_scene(&a.scene, &a.set, &a.define)?;
    for w in &sc.warnings {
        eprintln!("{w}");
    }
    let part = a.overrides().apply(&mut sc)?;
    // Batches are cut from the whole render's samples (a part keeps its spp as the pattern's).
    let batches = a
        .batches
        .map(|k| {
            let it = &sc.integrator;
            render::Batches::plan(k, it.pattern_spp(), &part.samples, it.sampler)
        })
        .transpose()?;
    if let Some(b) = &batches {
        b.apply(&mut sc);
    }
    check_backend_options(&a)?;
    let outputs = Outputs::of(&a);
    outputs.prepare(&a.scene)?;
    brdfwave::memory::release_free_heap();
    let t_bvh = Instant::now();
    let bvh = bvh::build_for(
        &sc,
        match a.backend {
            Backend::Gpu => bvh::Traversal::GpuOnly,
            Backend::Cpu => bvh::Traversal::CpuOnly,
        },
    );
    let seconds_bvh = t_bvh.elapsed().as_secs_f64();
    // The nodes of the tree the backend walks: binary on the GPU, 8-wide on the CPU.
    let bvh_nodes = match a.backend {
        Backend::Gpu => bvh.nodes.len(),
        Backend::Cpu => bvh.wide.len(),
    };
    brdfwave::memory::release_free_heap();
    let gpu = match a.backend {
        Backend::Gpu => Some((
            vk::Context::new(&vk::ContextOptions {
                device: a.device.clone(),
                validation: a.validation,
                ray_query: false,
            })?,
            vk::ShaderCompiler::new()?,
        )),
        Backend::Cpu => None,
    };
    let backend = match &gpu {
        Some((ctx, compiler)) => render::Backend::Gpu {
            ctx,
            compiler,
            options: brdfwave::gpu::GpuOptions {
                wave_paths: a.wave_paths.unwrap_or(brdfwave::gpu::MAX_WAVE_PATHS),
                integrator: a.integrator.unwrap_or(IntegratorArg::Auto).gpu(),
                tile: None,
            },
        },
        None => render::Backend::Cpu,
    };
    let request = RenderRequest {
        samples: part.samples.clone(),
        take_film: outputs.wants_film(),
    };
    // The only reference: the GPU path frees the host's tree once it is uploaded.
    let r = render::open(backend, &sc, std::sync::Arc::new(bvh), part.tile)?;
    let (mut rendered, batch_variance, description, seconds_setup, seconds_render) =
        render_with_progress(r, &request, batches, part.tile, t0, a.quiet)?;
    if a.backend == Backend::Gpu && a.threads.is_some() && !description.device.contains("llvmpipe")
    {
        eprintln!(
            "warning: --threads sets LP_NUM_THREADS, which only lavapipe reads; {} ignores it",
            description.device
        );
    }
    // Tear down now so that messages raised at device destruction (leaks) count too.
    teardown(gpu)?;
    let part_film = rendered.film.take().map(|film| {
        film::Part::of_render(
            &a.scene.display().to_string(),
            &sc,
            film,
            &rendered.output,
            description.backend,
            &description.device,
            seconds_render,
        )
    });
    let provenance = provenance(
        &a,
        &sc,
        &part.samples,
        &rendered,
        &description,
        seconds_render,
        &scene_bytes,
    );
    outputs.write(
        &rendered,
        batch_variance.as_ref(),
        part_film.as_ref(),
        &provenance,
    )?;
    let times = Times {
        bvh: seconds_bvh,
        setup: seconds_setup,
        render: seconds_render,
    };
    let summary = summary(
        &a,
        &sc,
        bvh_nodes,
        &part,
        &description,
        &rendered,
        times,
        &outputs,
    );
    if a.json {
        outln!("{}", serde_json::to_string(&summary)?)?;
    } else if !a.quiet {
        out!("{summary}")?;
    }
    if rendered.output.nonfinite_samples > 0 {
        eprintln!(
            "warning: {} non-finite values were dropped (see the stages above)",
            rendered.output.nonfinite_samples
        );
    }
    Ok(())
}

/// The GPU-only options: checked for the GPU backend (the wave size's range, the validation
/// layer present), and warned about as ignored on the CPU backend.
/// On the CPU backend every GPU-only option is ignored with the same warning, whatever its
/// value (its range is the GPU's to check).
fn check_backend_options(a: &RenderArgs) -> Result<()> {
    if a.backend == Backend::Cpu {
        warn_gpu_only(&[
            ("--device", a.device.is_some()),
            ("--validation", a.validation),
            ("--wave-paths", a.wave_paths.is_some()),
            ("--integrator", a.integrator.is_some()),
        ]);
        return Ok(());
    }
    if let Some(w) = a.wave_paths {
        brdfwave::gpu::check_wave_paths(w).context("--wave-paths")?;
    }
    if a.validation {
        vk::require_validation().context("--validation")?;
    }
    Ok(())
}

/// Drops the GPU context and compiler, and fails on the validation layer's messages (raised
/// up to the device's destruction: leaks count too).
fn teardown(gpu: Option<(vk::Context, vk::ShaderCompiler)>) -> Result<()> {
    let Some((ctx, compiler)) = gpu else {
        return Ok(());
    };
    drop(compiler);
    let msgs = ctx.finish();
    if !msgs.is_empty() {
        bail!(
            "the validation layer reported {} message(s):\n{}",
            msgs.len(),
            msgs.join("\n")
        );
    }
    Ok(())
}

/// The metadata that EXR outputs carry.
fn provenance(
    a: &RenderArgs,
    sc: &Scene,
    samples: &std::ops::Range<u32>,
    rendered: &Rendered,
    description: &Description,
    seconds_render: f64,
    scene_bytes: &[u8],
) -> imageio::Provenance {
    imageio::Provenance {
        spp: Some(rendered.output.spp),
        samples: Some(samples.clone()),
        seed: Some(sc.integrator.seed),
        sampler: Some(sc.integrator.sampler.name().to_string()),
        max_depth: Some(sc.integrator.max_depth),
        render_seconds: Some(seconds_render),
        scene: Some(a.scene.display().to_string()),
        scene_file_hash: Some(format!("{:016x}", brdfwave::hash::fnv1a64(scene_bytes))),
        scene_hash: Some(film::scene_hash(sc)),
        overrides: a.set.iter().map(|s| s.text.clone()).collect(),
        version: Some(film::code_version()),
        backend: Some(description.backend.to_string()),
        device: Some(description.device.clone()),
    }
}

/// `--threads`: the size of the CPU backend's thread pool, made now, before anything else uses
/// it; or `LP_NUM_THREADS` for lavapipe, which reads it when the Vulkan instance is made (as
/// the bench's `-tN` configurations do).
fn set_threads(backend: Backend, threads: Option<u32>) -> Result<()> {
    let Some(n) = threads else { return Ok(()) };
    match backend {
        Backend::Cpu => rayon::ThreadPoolBuilder::new()
            .num_threads(n as usize)
            .build_global()
            .context("--threads: cannot make the thread pool")?,
        Backend::Gpu => std::env::set_var("LP_NUM_THREADS", n.to_string()),
    }
    Ok(())
}

/// The scene and its file's bytes (hashed into the images' metadata), with the `--set`
/// overrides applied to the document before its checks (`brdfwave::overrides`).
fn load_scene(path: &Path, sets: &[Set], defines: &[(String, String)]) -> Result<(Scene, Vec<u8>)> {
    if sets.is_empty() {
        return Ok(scene::load_read(path, defines)?);
    }
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    if !ext.eq_ignore_ascii_case("toml") {
        bail!(
            "--set edits TOML scene files, and {} is not one (.toml){}",
            path.display(),
            if scene::load::is_xml(path) {
                ": a Mitsuba XML scene takes -D NAME=VALUE for its $NAME parameters"
            } else {
                ""
            }
        );
    }
    if let Some((name, _)) = defines.first() {
        bail!("-D {name}=…: parameters apply to Mitsuba XML scenes only (this is a TOML scene; --set edits it)");
    }
    overrides::load_toml(path, sets)
}

/// Renders the request with a progress bar, in batches when asked (with the variance of the
/// means they give); returns what was rendered, the renderer's description, and the seconds of
/// set-up (since `t0`) and of the render.
#[allow(clippy::type_complexity)]
fn render_with_progress(
    mut r: Box<dyn Renderer + '_>,
    request: &RenderRequest,
    batches: Option<render::Batches>,
    tile: Tile,
    t0: Instant,
    quiet: bool,
) -> Result<(
    Rendered,
    Option<imageio::BatchVariance>,
    Description,
    f64,
    f64,
)> {
    let seconds_setup = t0.elapsed().as_secs_f64();
    let description = r.describe();
    let unit = description.progress;
    let pb = progress_bar(unit, unit.total(tile, &request.samples), quiet);
    let t = Instant::now();
    let (rendered, batch_variance) = match batches {
        None => (r.render(request, &|p| show(&pb, p))?, None),
        Some(b) => {
            let (rendered, v) = render::render_batches(
                r.as_mut(),
                request.samples.clone(),
                b.size,
                tile,
                request.take_film,
                &|p| show(&pb, p),
            )?;
            (rendered, Some(v))
        }
    };
    let seconds_render = t.elapsed().as_secs_f64();
    pb.finish_and_clear();
    Ok((
        rendered,
        batch_variance,
        description,
        seconds_setup,
        seconds_render,
    ))
}

/// The seconds of a render's phases.
#[derive(Clone, Copy)]
struct Times {
    bvh: f64,
    setup: f64,
    render: f64,
}

#[allow(clippy::too_many_arguments)]
fn summary(
    a: &RenderArgs,
    sc: &Scene,
    bvh_nodes: usize,
    part: &render::Resolved,
    d: &Description,
    r: &Rendered,
    times: Times,
    outputs: &Outputs,
) -> RenderSummary {
    let output = &r.output;
    let tile = part.tile;
    let paths = tile.pixels() as f64 * output.spp as f64;
    let rays = (output.extension_rays + output.shadow_rays) as f64;
    RenderSummary {
        backend: d.backend,
        device: d.device.clone(),
        scene: a.scene.display().to_string(),
        width: sc.width,
        height: sc.height,
        tile: (tile != Tile::full(sc.width, sc.height)).then_some(tile),
        samples: [part.samples.start, part.samples.end],
        spp: output.spp,
        batches: a.batches,
        max_depth: sc.integrator.max_depth,
        seed: sc.integrator.seed,
        sampler: sc.integrator.sampler.name(),
        russian_roulette: sc.integrator.russian_roulette,
        threads: match d.gpu {
            None => Some(rayon::current_num_threads() as u32),
            Some(_) => a.threads,
        },
        gpu: d.gpu.as_ref().map(|g| GpuSetup {
            pipelines: g.setup.pipelines.clone(),
            seconds_shader_compile: g.setup.seconds_shader_compile,
            seconds_pipeline_create: g.setup.seconds_pipeline_create,
            wave_paths: g.setup.wave_paths,
            integrator: g.integrator.name(),
            subgroup_queues: g.setup.subgroup_queues,
        }),
        seconds_bvh: times.bvh,
        bvh_nodes,
        seconds_setup: times.setup,
        seconds_render: times.render,
        paths_per_second: paths / times.render.max(1e-9),
        rays_per_second: rays / times.render.max(1e-9),
        extension_rays: output.extension_rays,
        shadow_rays: output.shadow_rays,
        shadow_rays_occluded: output.shadow_rays_occluded,
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
        measured_tables: measured_tables(sc, d.gpu.is_some()),
        outputs: outputs
            .outs
            .iter()
            .map(|o| o.display().to_string())
            .collect(),
        variance_output: outputs
            .variance_out
            .as_ref()
            .map(|v| v.display().to_string()),
    }
}
