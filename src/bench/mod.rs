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
//! made), `cpu` (the CPU reference), each with brdfwave's default sampler (`sobol`) or another
//! named last (`wavefront-independent`, `cpu-independent`); and, when the Python module
//! `mitsuba` is installed, `mitsuba-scalar`, `mitsuba-llvm` and `mitsuba-cuda` rendering the
//! same scene (triangle scenes of Lambert and rough-conductor materials) through
//! `scripts/mitsuba_peer.py`, embedded here, with Mitsuba's `independent` sampler or another
//! named last (`mitsuba-llvm-multijitter`, `-ldsampler`, `-stratified`, `-orthogonal`).
//!
//! Each system is measured at its best: brdfwave's passes continue one sample sequence, so
//! the running image after 2^k samples is exactly a 2^k-sample render (its stratification
//! included), and its time is the sum of the passes; Mitsuba's stratified samplers lose their
//! stratification when independent passes are averaged, so each Mitsuba point is a fresh,
//! warm render of all the samples so far, timed alone (its kernels, which for most of its
//! samplers depend on the sample count, are compiled by an untimed warm-up render of the same
//! count, reported apart), and the script also times one plain warm render at a fixed sample
//! count, reported beside the bench's figure. (A Mitsuba configuration's wall time is thus
//! about four times the time of its last render; its budget share counts the last render.)

use crate::bvh::{self, Bvh};
use crate::film::Tile;
use crate::gpu::{GpuOptions, Integrator};
use crate::imageio::{self, Image};
use crate::metrics;
use crate::output::RenderOutput;
use crate::plot::{self, Series};
use crate::render::{self, RenderRequest, Renderer};
use crate::rng::Sampler;
use crate::scene::{self, Scene, Triangle};
use crate::vk::{self, Context, ContextOptions, ShaderCompiler};
use anyhow::{anyhow, bail, Context as _, Result};
use glam::Vec3;
use std::fmt::Write as _;
use std::io::{BufRead, BufReader, IsTerminal, Write as _};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::time::Instant;

/// The Mitsuba side of the peer configurations (see its docstring for the protocol).
const MITSUBA_SCRIPT: &str = include_str!("../../scripts/mitsuba_peer.py");

/// The CSV header of `bench.csv`, one row per pass.
pub const CSV_COLUMNS: &str = "config,pass,spp,seconds,paths_per_second,rmse,relmse,flip";

/// Passes every configuration makes, even past its share of the budget: a curve needs points.
const MIN_PASSES: u32 = 3;

/// One configuration of the benchmark.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Config {
    /// The GPU renderer with this integrator and lavapipe thread count (None: the default).
    Gpu {
        integrator: Integrator,
        threads: Option<u32>,
        sampler: Sampler,
    },
    /// The CPU reference renderer (all cores, rayon).
    Cpu { sampler: Sampler },
    /// Mitsuba 3 with this variant (`scalar_rgb`, `llvm_ad_rgb`, `cuda_ad_rgb`) and sampler
    /// plugin (one of [`MITSUBA_SAMPLERS`]).
    Mitsuba { variant: String, sampler: String },
}

/// Mitsuba 3's sampler plugins that a Mitsuba configuration may name; `independent` is the
/// default (and is not written in the configuration's name).
pub const MITSUBA_SAMPLERS: [&str; 5] = [
    "independent",
    "stratified",
    "multijitter",
    "orthogonal",
    "ldsampler",
];

impl Config {
    pub fn name(&self) -> String {
        let ours = |base: String, s: &Sampler| match s {
            Sampler::Sobol => base,
            s => format!("{base}-{s}"),
        };
        match self {
            Config::Gpu {
                integrator,
                threads,
                sampler,
            } => ours(
                match threads {
                    Some(t) => format!("{}-t{t}", integrator.name()),
                    None => integrator.name().to_string(),
                },
                sampler,
            ),
            Config::Cpu { sampler } => ours("cpu".into(), sampler),
            Config::Mitsuba { variant, sampler } => {
                let v = variant.trim_end_matches("_ad_rgb").trim_end_matches("_rgb");
                match sampler.as_str() {
                    "independent" => format!("mitsuba-{v}"),
                    s => format!("mitsuba-{v}-{s}"),
                }
            }
        }
    }

    /// The sampler this configuration uses, as its system names it.
    pub fn sampler_name(&self) -> String {
        match self {
            Config::Gpu { sampler, .. } | Config::Cpu { sampler } => sampler.name().into(),
            Config::Mitsuba { sampler, .. } => sampler.clone(),
        }
    }

    pub fn parse(name: &str) -> Result<Config> {
        if let Some(rest) = name.strip_prefix("mitsuba-") {
            let (v, sampler) = match rest.split_once('-') {
                Some((v, s)) => (v, s),
                None => (rest, "independent"),
            };
            if !MITSUBA_SAMPLERS.contains(&sampler) {
                bail!(
                    "configuration '{name}': unknown Mitsuba sampler '{sampler}' (use one of {})",
                    MITSUBA_SAMPLERS.join(", ")
                );
            }
            let variant = match v {
                "scalar" => "scalar_rgb",
                "llvm" => "llvm_ad_rgb",
                "cuda" => "cuda_ad_rgb",
                _ => bail!("configuration '{name}': unknown Mitsuba variant '{v}' (use scalar, llvm or cuda)"),
            };
            return Ok(Config::Mitsuba {
                variant: variant.into(),
                sampler: sampler.into(),
            });
        }
        // Ours: BASE[-tN][-SAMPLER].
        let (name, sampler) = match Sampler::ALL
            .iter()
            .find_map(|s| name.strip_suffix(&format!("-{s}")).map(|n| (n, *s)))
        {
            Some((n, s)) => (n, s),
            None => (name, Sampler::default()),
        };
        let gpu = |integrator, rest: &str| -> Result<Config> {
            let threads = match rest {
                "" => None,
                t => Some(
                    t.strip_prefix("-t")
                        .and_then(|n| n.parse::<u32>().ok())
                        .filter(|&n| (1..=256).contains(&n))
                        .ok_or_else(|| anyhow!("configuration '{name}': a thread count is written -tN, N from 1 to 256"))?,
                ),
            };
            Ok(Config::Gpu {
                integrator,
                threads,
                sampler,
            })
        };
        if name == "cpu" {
            Ok(Config::Cpu { sampler })
        } else if let Some(rest) = name.strip_prefix("wavefront") {
            gpu(Integrator::Wavefront, rest)
        } else if let Some(rest) = name.strip_prefix("megakernel") {
            gpu(Integrator::Megakernel, rest)
        } else {
            bail!(
                "unknown configuration '{name}': use wavefront, megakernel (each optionally -t1, -t2, …), cpu, each optionally -{} last; or mitsuba-scalar, mitsuba-llvm, mitsuba-cuda, each optionally -SAMPLER last ({})",
                Sampler::ALL.map(|s| s.name()).join(" or -"),
                MITSUBA_SAMPLERS.join(", ")
            )
        }
    }
}

/// The default configurations: everything that runs here (Mitsuba's are skipped with a note
/// when the module is missing).
pub const DEFAULT_CONFIGS: &str = "wavefront,wavefront-independent,megakernel,cpu,cpu-independent,wavefront-t1,wavefront-t2,mitsuba-scalar,mitsuba-llvm,mitsuba-llvm-multijitter,mitsuba-llvm-ldsampler";

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

trait Runner {
    /// Renders `n` more samples per pixel; returns the samples per pixel of the image now (a
    /// sampler may round a count up) and the render seconds that image took.
    fn pass(&mut self, n: u32) -> Result<(u32, f64)>;
    /// The running mean of all passes so far.
    fn image(&mut self) -> Result<Image>;
    fn details(&mut self) -> Details;
}

/// brdfwave's own configurations, on either backend, through [`crate::render`]: each pass
/// continues the renderer's sample sequence.
struct RendererRunner<'a> {
    renderer: Box<dyn Renderer + 'a>,
    setup_seconds: f64,
    done: u32,
    seconds: f64,
    /// The image after the last pass, and its counts.
    last: Option<RenderOutput>,
}

impl Runner for RendererRunner<'_> {
    fn pass(&mut self, n: u32) -> Result<(u32, f64)> {
        let request = RenderRequest::samples(self.done..self.done + n);
        let r = self.renderer.render(&request, &|_| {})?;
        self.done += n;
        self.seconds += r.seconds_samples;
        self.last = Some(r.output);
        Ok((self.done, self.seconds))
    }
    fn image(&mut self) -> Result<Image> {
        let out = self.last.as_ref().ok_or_else(|| anyhow!("no pass yet"))?;
        Ok(out.mean.clone())
    }
    fn details(&mut self) -> Details {
        let d = self.renderer.describe();
        let setup = d.gpu.map(|g| g.setup).unwrap_or_default();
        let out = self.last.as_ref();
        Details {
            device: d.device,
            setup_seconds: self.setup_seconds,
            rays: out.map(|o| o.extension_rays + o.shadow_rays).unwrap_or(0),
            rays_by_segment: out.map(|o| o.rays_by_segment.clone()).unwrap_or_default(),
            stage_seconds: out.map(|o| o.stage_seconds.clone()).unwrap_or_default(),
            pipelines_compile: setup.seconds_shader_compile,
            pipelines_create: setup.seconds_pipeline_create,
            ..Default::default()
        }
    }
}

struct MitsubaRunner {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
    last: Option<PathBuf>,
    variant: String,
    sampler: String,
    setup_seconds: f64,
    compile_seconds: f64,
    plain: (u32, f64),
    spp: u32,
}

impl MitsubaRunner {
    fn start(variant: &str, sampler: &str, scene_json: &Path, dir: &Path) -> Result<MitsubaRunner> {
        let script = dir.join("mitsuba_peer.py");
        std::fs::write(&script, MITSUBA_SCRIPT)
            .with_context(|| format!("writing {}", script.display()))?;
        let mut cmd = Command::new("python3");
        cmd.arg(&script)
            .arg(variant)
            .arg(sampler)
            .arg(scene_json)
            .arg(dir)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null());
        // Dr.Jit's LLVM backend needs LLVM 16 or newer; LLVM 15 (lavapipe's) crashes it.
        if std::env::var_os("DRJIT_LIBLLVM_PATH").is_none() {
            if let Some(p) = newest_libllvm() {
                cmd.env("DRJIT_LIBLLVM_PATH", p);
            }
        }
        let t = Instant::now();
        let mut child = cmd.spawn().context("starting python3")?;
        let stdin = child.stdin.take().expect("piped");
        let mut stdout = BufReader::new(child.stdout.take().expect("piped"));
        let line = protocol_line(&mut stdout)?;
        let line = line.trim();
        if let Some(msg) = line.strip_prefix("error ") {
            let _ = child.kill();
            let _ = child.wait();
            bail!("{msg}");
        }
        // `ready COMPILE_SECONDS PLAIN_SPP PLAIN_SECONDS`.
        let w: Vec<&str> = line.split_whitespace().collect();
        let ready = match w[..] {
            ["ready", c, n, s] => c
                .parse::<f64>()
                .ok()
                .zip(n.parse::<u32>().ok().zip(s.parse::<f64>().ok())),
            _ => None,
        };
        let Some((compile_seconds, plain)) = ready else {
            let _ = child.kill();
            let _ = child.wait();
            bail!("the Mitsuba script ended without a word (is python3 with mitsuba installed?)");
        };
        Ok(MitsubaRunner {
            child,
            stdin,
            stdout,
            last: None,
            variant: variant.to_string(),
            sampler: sampler.to_string(),
            setup_seconds: t.elapsed().as_secs_f64(),
            compile_seconds,
            plain,
            spp: 0,
        })
    }
}

impl Runner for MitsubaRunner {
    fn pass(&mut self, n: u32) -> Result<(u32, f64)> {
        // A fresh render of all the samples so far (see the module docs).
        writeln!(self.stdin, "render {}", self.spp + n)?;
        self.stdin.flush()?;
        let line = protocol_line(&mut self.stdout)?;
        let mut w = line.split_whitespace();
        match (w.next(), w.next(), w.next(), w.next(), w.next()) {
            (Some("done"), Some(secs), Some(spp), Some(compile), Some(path)) => {
                self.last = Some(PathBuf::from(path));
                self.spp = spp.parse()?;
                self.compile_seconds += compile.parse::<f64>()?;
                Ok((self.spp, secs.parse()?))
            }
            _ => bail!(
                "Mitsuba ({}, {}) answered '{}'",
                self.variant,
                self.sampler,
                line.trim()
            ),
        }
    }
    fn image(&mut self) -> Result<Image> {
        let p = self.last.as_ref().ok_or_else(|| anyhow!("no pass yet"))?;
        Ok(imageio::read(p)?)
    }
    fn details(&mut self) -> Details {
        Details {
            device: format!("Mitsuba 3 {}", self.variant),
            setup_seconds: self.setup_seconds,
            peer_compile: Some(self.compile_seconds),
            peer_plain: Some(self.plain),
            ..Default::default()
        }
    }
}

impl Drop for MitsubaRunner {
    fn drop(&mut self) {
        let _ = writeln!(self.stdin, "quit");
        let _ = self.stdin.flush();
        let _ = self.child.wait();
    }
}

/// The next line of the Mitsuba script's protocol (`ready`, `done` or `error`), skipping any
/// other output (a log line the script did not silence); "" at the end of its output.
fn protocol_line(r: &mut impl BufRead) -> Result<String> {
    for _ in 0..10_000 {
        let mut line = String::new();
        if r.read_line(&mut line)? == 0 {
            return Ok(line);
        }
        if ["ready", "done", "error"]
            .iter()
            .any(|w| line.split_whitespace().next() == Some(*w))
        {
            return Ok(line);
        }
    }
    bail!("the Mitsuba script wrote 10000 lines that are not its protocol")
}

/// The newest libLLVM of version 16 or later on the system, for Dr.Jit.
fn newest_libllvm() -> Option<PathBuf> {
    let dir = Path::new("/usr/lib/x86_64-linux-gnu");
    (16..=30)
        .rev()
        .flat_map(|v| [format!("libLLVM.so.{v}.1"), format!("libLLVM-{v}.so")])
        .map(|n| dir.join(n))
        .find(|p| p.exists())
}

/// A material as a Mitsuba 3 BSDF (`mitsuba_peer.py` builds the plugin), or why it has none:
/// Lambert is `diffuse`; Cook–Torrance with Walter et al.'s normalisation, a Beckmann or GGX
/// distribution, Smith shadowing, conductor Fresnel, no diffuse part and a white specular
/// scale is `roughconductor` (Mitsuba's Smith G1 for Beckmann is exact where ours is Walter et
/// al. 2007's rational approximation, within 0.35 %). Anything else has no Mitsuba twin.
fn mitsuba_bsdf(m: &crate::brdf::Material) -> Result<serde_json::Value> {
    use crate::brdf::cook_torrance::{
        CookTorrance, Distribution, Fresnel, Geometry, Normalization,
    };
    use crate::brdf::lambert::Lambert;
    let any = m.brdf.as_any();
    if let Some(l) = any.downcast_ref::<Lambert>() {
        return Ok(serde_json::json!({"type": "diffuse", "albedo": l.albedo.to_array()}));
    }
    if let Some(c) = any.downcast_ref::<CookTorrance>() {
        if c.kd == Vec3::ZERO
            && c.ks == Vec3::ONE
            && c.normalization == Normalization::Walter
            && c.geometry == Geometry::Smith
            && c.fresnel == Fresnel::Conductor
            && c.roughness > 0.0
        {
            let distribution = match c.distribution {
                Distribution::Beckmann => "beckmann",
                Distribution::Ggx => "ggx",
            };
            return Ok(serde_json::json!({
                "type": "roughconductor",
                "distribution": distribution,
                "alpha": c.roughness,
                "eta": c.eta.to_array(),
                "k": c.k.to_array(),
            }));
        }
        bail!("the Mitsuba configurations take Cook–Torrance only as a rough conductor (Walter normalisation, Smith G, conductor Fresnel, kd = 0, ks = 1)");
    }
    bail!(
        "the Mitsuba configurations take Lambert and rough-conductor materials only (this scene has {})",
        m.model_name()
    )
}

/// The scene as `mitsuba_peer.py` reads it, or why it cannot be: meshes of triangles grouped
/// by (material, emitter), each with its BSDF ([`mitsuba_bsdf`]), the camera, the image size,
/// the depth.
fn mitsuba_scene_json(s: &Scene) -> Result<String> {
    if !s.spheres.is_empty() {
        bail!("the Mitsuba configurations take triangle scenes only (this one has spheres)");
    }
    let bsdfs = s
        .materials
        .iter()
        .map(mitsuba_bsdf)
        .collect::<Result<Vec<_>>>()?;
    // (material, emitter) and the triangles that have them.
    type Group<'t> = ((u32, Option<u32>), Vec<&'t Triangle>);
    let mut groups: Vec<Group> = Vec::new();
    for t in &s.triangles {
        let key = (t.material, t.emitter);
        match groups.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) => v.push(t),
            None => groups.push((key, vec![t])),
        }
    }
    let meshes: Vec<serde_json::Value> = groups
        .iter()
        .map(|((mat, em), tris)| {
            serde_json::json!({
                "bsdf": bsdfs[*mat as usize],
                "radiance": em.map(|e| s.emitters[e as usize].radiance.to_array()),
                "vertices": tris.iter().flat_map(|t| t.v.iter().map(|v| v.to_array())).collect::<Vec<_>>(),
            })
        })
        .collect();
    let c = &s.camera;
    Ok(serde_json::json!({
        "width": s.width,
        "height": s.height,
        "max_depth": s.integrator.max_depth,
        "camera": {
            "position": c.position.to_array(),
            "target": c.target.to_array(),
            "up": c.up.to_array(),
            "fov_y": c.fov_y_deg,
        },
        "environment": s.environment.to_array(),
        "meshes": meshes,
    })
    .to_string())
}

/// Whether `python3 -c "import mitsuba"` works.
fn mitsuba_installed() -> bool {
    Command::new("python3")
        .args(["-c", "import mitsuba"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .map(|s| s.success())
        .unwrap_or(false)
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

/// The reference's own expected relMSE, from its per-sample variance: the mean over
/// pixel-channels of var / (N (r + 0.01)²), the expected relMSE of an N-sample mean of
/// independent samples (an upper bound for a `sobol` reference, whose mean varies less).
fn reference_error(mean: &Image, variance: &Image, n: u32) -> f64 {
    let mut sum = 0.0;
    for (m, v) in mean.data.iter().zip(&variance.data) {
        for c in 0..3 {
            let r = m[c] as f64 + 0.01;
            sum += v[c] as f64 / n as f64 / (r * r);
        }
    }
    sum / (3 * mean.data.len()).max(1) as f64
}

/// The reference image: the given file, or one rendered by the CPU reference at
/// `reference_spp` with a seed of its own and cached; and, for a rendered one, its own
/// expected relMSE ([`reference_error`]).
fn reference(o: &BenchOptions, sc: &Scene, bvh: &Bvh) -> Result<(Image, Option<f64>)> {
    if let Some(p) = &o.reference {
        let img =
            imageio::read(p).with_context(|| format!("reading --reference {}", p.display()))?;
        if img.count_nonfinite() > 0 {
            bail!(
                "--reference {} holds {} non-finite values: a reference must be finite (relMSE would leave them out)",
                p.display(),
                img.count_nonfinite()
            );
        }
        if img.width != sc.width || img.height != sc.height {
            bail!(
                "--reference {} is {}x{}, the benchmark renders {}x{}",
                p.display(),
                img.width,
                img.height,
                sc.width,
                sc.height
            );
        }
        return Ok((img, None));
    }
    let mut key = crate::hash::Fnv64::new();
    key.bytes(&std::fs::read(&o.scene).with_context(|| format!("reading {}", o.scene.display()))?);
    for v in [
        sc.width,
        sc.height,
        sc.integrator.max_depth,
        sc.integrator.seed,
        o.reference_spp,
    ] {
        key.u64(v as u64);
    }
    key.u64(sc.integrator.russian_roulette as u64);
    key.bytes(sc.integrator.sampler.name().as_bytes());
    if let Ok(exe) = std::env::current_exe().and_then(std::fs::read) {
        key.bytes(&exe);
    }
    let cache = vk::cache::default_cache_dir().map(|d| {
        d.join("reference")
            .join(format!("{:016x}.exr", key.finish()))
    });
    let error_file = cache.as_ref().map(|p| p.with_extension("relmse"));
    if let Some(p) = cache.as_ref().filter(|p| p.exists()) {
        // A cache entry that does not read back as a finite image of the right size is
        // discarded and rendered again, never fatal.
        match imageio::read(p) {
            Ok(img) if img.width == sc.width && img.height == sc.height && img.count_nonfinite() == 0 => {
                eprintln!("reference: {} (cached)", p.display());
                let err = error_file
                    .as_ref()
                    .and_then(|f| std::fs::read_to_string(f).ok())
                    .and_then(|s| s.trim().parse().ok());
                return Ok((img, err));
            }
            Ok(img) => eprintln!(
                "warning: discarding the cached reference {} ({}x{}, {} non-finite values); rendering it again",
                p.display(),
                img.width,
                img.height,
                img.count_nonfinite()
            ),
            Err(e) => eprintln!("warning: discarding the cached reference: {e}; rendering it again"),
        }
    }
    let mut rs = sc.clone();
    rs.integrator.seed ^= 0x5EED_5EED;
    rs.integrator.spp = o.reference_spp;
    eprintln!(
        "reference: rendering {} spp on the CPU reference (once; cached)",
        o.reference_spp
    );
    let t = Instant::now();
    let out = render::render_all(render::Backend::Cpu, &rs, bvh)?;
    let err = reference_error(&out.mean, &out.variance, o.reference_spp);
    let img = out.mean;
    eprintln!("reference: {:.1} s", t.elapsed().as_secs_f64());
    if let Some(p) = &cache {
        if let Some(dir) = p.parent() {
            let _ = std::fs::create_dir_all(dir);
        }
        if let Err(e) = imageio::write(p, &img) {
            eprintln!(
                "warning: could not cache the reference at {}: {e}",
                p.display()
            );
        } else if let Some(f) = &error_file {
            let _ = crate::outfile::write(f, format!("{err:e}\n").as_bytes());
        }
    }
    Ok((img, Some(err)))
}

/// The runner of configuration `c`: ours through [`crate::render`] on the scene `sc` as the
/// configuration renders it (a GPU configuration has its context `ctx`), or the Mitsuba peer
/// when it could be set up (`mitsuba_ok`).
#[allow(clippy::too_many_arguments)]
fn runner<'a>(
    c: &Config,
    ctx: Option<&'a Context>,
    sc: &'a Scene,
    bvh: &'a Bvh,
    compiler: &'a ShaderCompiler,
    mitsuba_ok: &Result<()>,
    mitsuba_json: &Path,
    out: &Path,
) -> Result<Box<dyn Runner + 'a>> {
    match (c, ctx) {
        (Config::Gpu { .. } | Config::Cpu { .. }, ctx) => {
            let backend = match (c, ctx) {
                (Config::Gpu { integrator, .. }, Some(ctx)) => render::Backend::Gpu {
                    ctx,
                    compiler,
                    options: GpuOptions {
                        integrator: *integrator,
                        ..GpuOptions::default()
                    },
                },
                (Config::Gpu { .. }, None) => unreachable!("a GPU configuration has a context"),
                _ => render::Backend::Cpu,
            };
            let t = Instant::now();
            render::open(backend, sc, bvh, Tile::full(sc.width, sc.height)).map(|r| {
                Box::new(RendererRunner {
                    renderer: r,
                    setup_seconds: t.elapsed().as_secs_f64(),
                    done: 0,
                    seconds: 0.0,
                    last: None,
                }) as Box<dyn Runner>
            })
        }
        (Config::Mitsuba { variant, sampler }, _) => match mitsuba_ok {
            Ok(()) => MitsubaRunner::start(variant, sampler, mitsuba_json, out)
                .map(|r| Box::new(r) as Box<dyn Runner>),
            Err(e) => Err(anyhow!("{e}")),
        },
    }
}

/// Runs the benchmark; writes `bench.csv`, `bench.png` and `bench.md` under `o.out` and
/// returns the markdown summary.
pub fn run(o: &BenchOptions) -> Result<String> {
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
    let sc = load_scene(o)?;
    for w in &sc.warnings {
        eprintln!("{w}");
    }
    let t = Instant::now();
    let bvh = bvh::build(&sc);
    let seconds_bvh = t.elapsed().as_secs_f64();
    let (reference, reference_err) = reference(o, &sc, &bvh)?;
    let pixels = sc.width as f64 * sc.height as f64;

    // Vulkan contexts first (one per GPU configuration: lavapipe reads LP_NUM_THREADS when an
    // instance is made), then the runners that borrow them.
    let mut notes: Vec<String> = Vec::new();
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
                })?)
            }
            _ => None,
        });
    }
    match &user_threads {
        Some(v) => std::env::set_var("LP_NUM_THREADS", v),
        None => std::env::remove_var("LP_NUM_THREADS"),
    }
    let compiler = ShaderCompiler::new()?;
    let mitsuba_json = o.out.join("mitsuba_scene.json");
    let mitsuba_ok = match o.configs.iter().any(|c| matches!(c, Config::Mitsuba { .. })) {
        false => Ok(()),
        true if !mitsuba_installed() => Err(anyhow!(
            "python3 cannot import mitsuba (pip install mitsuba numpy; the llvm variant also needs libLLVM 16 or newer, e.g. Debian's libllvm19)"
        )),
        true => mitsuba_scene_json(&sc).and_then(|j| {
            std::fs::write(&mitsuba_json, j)
                .with_context(|| format!("writing {}", mitsuba_json.display()))
        }),
    };
    // The scene as each of our configurations renders it: with its sampler.
    let scenes: Vec<Scene> = o
        .configs
        .iter()
        .map(|c| {
            let mut s = sc.clone();
            if let Config::Gpu { sampler, .. } | Config::Cpu { sampler } = c {
                s.integrator.sampler = *sampler;
            }
            s
        })
        .collect();
    let mut runners: Vec<(String, Box<dyn Runner + '_>)> = Vec::new();
    for ((c, ctx), sc) in o.configs.iter().zip(&contexts).zip(&scenes) {
        let name = c.name();
        let runner = runner(
            c,
            ctx.as_ref(),
            sc,
            &bvh,
            &compiler,
            &mitsuba_ok,
            &mitsuba_json,
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

    // Passes, taking turns; each configuration gets an equal share of the budget.
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
            let d = metrics::diff(&img, &reference)?;
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

    let details: Vec<(String, Details)> = runners
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
        .collect();
    // The runners (and Mitsuba's processes) and the devices go before anything else is timed.
    drop(runners);
    drop(contexts);

    // Outputs.
    let mut csv = String::from(CSV_COLUMNS);
    csv.push('\n');
    for r in &records {
        let _ = writeln!(
            csv,
            "{},{},{},{:.6},{:.1},{:.6e},{:.6e},{:.6e}",
            r.config, r.pass, r.spp, r.seconds, r.paths_per_second, r.rmse, r.relmse, r.flip
        );
    }
    crate::outfile::write(&o.out.join("bench.csv"), csv.as_bytes())?;
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
    let title = format!(
        "{} {}x{}, max depth {}: relMSE against render time",
        o.scene.file_name().and_then(|s| s.to_str()).unwrap_or(""),
        sc.width,
        sc.height,
        sc.integrator.max_depth
    );
    let img = plot::log_log(&title, "seconds", "relMSE", &series);
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
    crate::outfile::write(&o.out.join("bench.png"), &png)?;

    let reference_note = match (&o.reference, reference_err) {
        (Some(p), _) => format!("the reference is {}", p.display()),
        (None, Some(e)) => format!(
            "the reference: {} spp of the CPU reference ({} sampler, its own seed); its own expected relMSE is at most {e:.2e}",
            o.reference_spp, sc.integrator.sampler
        ),
        (None, None) => format!("the reference: {} spp of the CPU reference", o.reference_spp),
    };
    notes.push(reference_note);
    let md = summary(o, &sc, seconds_bvh, &records, &details, &notes);
    let md = match o.scaling {
        Some(n) => format!("{md}\n{}", scaling(o, n)?),
        None => md,
    };
    crate::outfile::write(&o.out.join("bench.md"), md.as_bytes())?;
    Ok(md)
}

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

fn summary(
    o: &BenchOptions,
    sc: &Scene,
    seconds_bvh: f64,
    records: &[PassRecord],
    details: &[(String, Details)],
    notes: &[String],
) -> String {
    let mut md = String::new();
    let pixels = sc.width as f64 * sc.height as f64;
    let _ = writeln!(
        md,
        "Scene `{}`, {}x{}, max depth {}, Russian roulette {}; budget {:.0} s shared by {} configurations, taking turns pass by pass; BVH build {:.3} s.\n",
        o.scene.display(),
        sc.width,
        sc.height,
        sc.integrator.max_depth,
        if sc.integrator.russian_roulette { "on" } else { "off" },
        o.budget,
        details.len(),
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
    for (name, d) in details {
        if let (Some(c), Some((spp, s))) = (d.peer_compile, d.peer_plain) {
            let last = records.iter().rfind(|r| &r.config == name);
            let _ = writeln!(
                md,
                "- `{name}`: kernel compile {c:.2} s in all (kept out of every timed render); a plain warm render of {spp} spp took {s:.2} s, {:.3} M paths/s{}",
                pixels * spp as f64 / s.max(1e-9) / 1e6,
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
    for n in notes {
        let _ = writeln!(md, "- {n}");
    }
    md
}

/// Set-up and speed against scene size: the bench scene, the Cornell box with a tessellated
/// sphere of about `mesh_triangles` triangles added, and the lineup scene beside the bench
/// scene if there is one. Each: BVH build, shader compile cold (empty cache) and warm, pipeline
/// creation, and a short wavefront and CPU render.
fn scaling(o: &BenchOptions, mesh_triangles: u32) -> Result<String> {
    let base = load_scene(o)?;
    let mut scenes: Vec<(String, Scene)> = vec![(o.scene.display().to_string(), base.clone())];
    let mut big = base.clone();
    add_sphere_mesh(&mut big, mesh_triangles);
    scenes.push((format!("{} + sphere mesh", o.scene.display()), big));
    if let Some(lineup) = o
        .scene
        .parent()
        .map(|d| d.join("lineup.toml"))
        .filter(|p| p.exists() && *p != o.scene)
    {
        let mut s = scene::load(&lineup)?;
        s.width = base.width;
        s.height = base.height;
        scenes.push((lineup.display().to_string(), s));
    }
    let ctx = Context::new(&ContextOptions {
        device: o.device.clone(),
        validation: false,
    })?;
    let mut md = String::from("| scene | triangles | BVH nodes | BVH build s | compile cold s | compile warm s | pipelines s | wavefront paths/s | rays/s | CPU paths/s |\n|---|---|---|---|---|---|---|---|---|---|\n");
    for (name, mut s) in scenes {
        eprintln!("scaling: {name}");
        s.integrator.spp = 4;
        let t = Instant::now();
        let bvh = bvh::build(&s);
        let t_bvh = t.elapsed().as_secs_f64();
        let cold_dir = tempfile::tempdir()?;
        let cold = ShaderCompiler::new()?.with_cache_dir(cold_dir.path());
        let full = Tile::full(s.width, s.height);
        let setup = |r: &dyn Renderer| r.describe().gpu.map(|g| g.setup).unwrap_or_default();
        let r = render::open(render::Backend::gpu(&ctx, &cold), &s, &bvh, full)?;
        let compile_cold = setup(r.as_ref()).seconds_shader_compile;
        drop(r);
        let mut r = render::open(render::Backend::gpu(&ctx, &cold), &s, &bvh, full)?;
        let warm = setup(r.as_ref());
        let (compile_warm, create) = (warm.seconds_shader_compile, warm.seconds_pipeline_create);
        let t = Instant::now();
        let out = r
            .render(&RenderRequest::samples(0..s.integrator.spp), &|_| {})?
            .output;
        let dt = t.elapsed().as_secs_f64();
        let paths = s.width as f64 * s.height as f64 * s.integrator.spp as f64;
        drop(r);
        let t = Instant::now();
        render::render_all(render::Backend::Cpu, &s, &bvh)?;
        let dt_cpu = t.elapsed().as_secs_f64();
        let _ = writeln!(
            md,
            "| {name} | {} | {} | {t_bvh:.3} | {compile_cold:.3} | {compile_warm:.3} | {create:.3} | {:.3} M | {:.3} M | {:.3} M |",
            s.triangles.len(),
            bvh.nodes.len(),
            paths / dt / 1e6,
            (out.extension_rays + out.shadow_rays) as f64 / dt / 1e6,
            paths / dt_cpu / 1e6
        );
    }
    Ok(md)
}

/// Adds a UV sphere of about `n` triangles (white Lambert, the scene's first material) in the
/// middle of the scene's bounds, a third of their smallest extent across.
pub fn add_sphere_mesh(s: &mut Scene, n: u32) {
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for t in &s.triangles {
        for v in t.v {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    if lo.x > hi.x {
        (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(1.0));
    }
    let center = 0.5 * (lo + hi);
    let radius = (hi - lo).min_element() / 6.0;
    // rings × segments × 2 triangles ≈ n, with segments = 2 rings.
    let rings = ((n as f64 / 4.0).sqrt().ceil() as u32).max(2);
    let segs = 2 * rings;
    let p = |i: u32, j: u32| -> Vec3 {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        let phi = 2.0 * std::f32::consts::PI * j as f32 / segs as f32;
        center
            + radius
                * Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                )
    };
    let material = 0;
    for i in 0..rings {
        for j in 0..segs {
            let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            // Outward winding: cross(b - a, c - a) points away from the centre.
            for v in [[a, d, c], [a, c, b]] {
                let t = Triangle {
                    v,
                    n: None,
                    uv: None,
                    material,
                    emitter: None,
                };
                if t.area() > 0.0 {
                    s.triangles.push(t);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_names_round_trip() {
        for n in DEFAULT_CONFIGS.split(',').chain([
            "megakernel-t1",
            "mitsuba-cuda",
            "megakernel-t2-independent",
            "mitsuba-scalar-orthogonal",
        ]) {
            assert_eq!(Config::parse(n).unwrap().name(), n);
        }
        // The default sampler is not written in the name.
        assert_eq!(Config::parse("cpu-sobol").unwrap().name(), "cpu");
        assert_eq!(
            Config::parse("wavefront-t1-independent").unwrap(),
            Config::Gpu {
                integrator: Integrator::Wavefront,
                threads: Some(1),
                sampler: Sampler::Independent
            }
        );
        assert_eq!(
            Config::parse("mitsuba-llvm").unwrap().sampler_name(),
            "independent"
        );
        assert!(Config::parse("wavefront-t0").is_err());
        assert!(Config::parse("pbrt").is_err());
        assert!(Config::parse("mitsuba-llvm-halton").is_err());
        assert!(Config::parse("mitsuba-vulkan").is_err());
        assert!(Config::parse("cpu-t2").is_err());
    }

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

    #[test]
    fn sphere_mesh_has_about_n_outward_triangles() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
        let mut s = scene::load(&path).unwrap();
        let before = s.triangles.len();
        let (lo, hi) = s.triangles.iter().flat_map(|t| t.v).fold(
            (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
            |(lo, hi), v| (lo.min(v), hi.max(v)),
        );
        add_sphere_mesh(&mut s, 10_000);
        let n = s.triangles.len() - before;
        assert!((9_000..=11_000).contains(&n), "{n}");
        let c = 0.5 * (lo + hi);
        for t in &s.triangles[before..] {
            let mid = (t.v[0] + t.v[1] + t.v[2]) / 3.0;
            assert!(t.geometric_normal_unnormalized().dot(mid - c) > 0.0);
        }
    }
}
