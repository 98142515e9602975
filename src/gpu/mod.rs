//! The wavefront path tracer on Vulkan compute.
//!
//! The work comes in waves of up to `MAX_WAVE_PATHS` paths: a small image takes several
//! consecutive samples of every pixel per wave (so that a large GPU has enough paths in flight),
//! a large one one sample of one chunk of pixels per wave. One command buffer holds one or more
//! waves:
//!
//! ```text
//! generate                                   camera rays → ray queue 0
//! for segment d = 1 ..= max_depth:
//!     prepare(Extend)  args for `extend`; reset the queues this segment appends to
//!     extend           closest hit; emission (MIS); route to the material's queue
//!     prepare(Shade)   args for each material queue
//!     shade_<m>        one pipeline per model, indirect over its own queue: NEE → shadow
//!                      queue, BRDF sample → next ray queue
//!     prepare(Shadow)  args for the shadow queue
//!     shadow           any hit; add the unoccluded light sample
//! accumulate                                 film += the wave's samples, in sample order
//!                                            (one writer per pixel)
//! ```
//!
//! With a single shaded model, `extend` shades in place and traces the shadow ray
//! (`extend_shade_<model>`: no material queue, no separate shade and shadow kernels; the
//! material queues only keep the lanes of a kernel on one model). [`Integrator::Megakernel`] replaces everything between `generate` and
//! `accumulate` by one kernel that follows each path to its end (the benchmark's baseline; the
//! same image).
//!
//! Only the models the scene's materials use get a queue and a shade pipeline; features a
//! scene does not use are compiled out through the models' `#define`s. The algorithm and its
//! conventions (depth, MIS, random-number keys) are those of the CPU reference (`crate::cpu`).
//! Every buffer, counter, queue, argument slot and `prepare` phase is named in [`layout`].
//!
//! Files: `stages.rs` (the stage table, the [`Integrator`]'s schedule of kernels and the
//! recording of a wave, segment by segment), `kernels.rs` (buffers and pipelines),
//! `waves.rs` (the cutting of a render into waves), `layout.rs` and `interface.rs` (the
//! Rust–GLSL interface, described once and emitted as the header `wavefront/interface.glsl`),
//! `scene_buffers.rs` (the scene as the kernels read it).
//!
//! A new stage is its kernel (a `.comp` file and a `stages::Stage` row), its routing (a
//! `stages::Schedule` field, built in `kernels::build_kernels`, and a `Segment` method that
//! the recording calls in order), and, if it has a queue of its own, one row each in the
//! queue, argument and `prepare` tables of [`layout`]: every number follows from those.

pub mod brdf_probe;
pub mod bvh_probe;
pub mod interface;
mod kernels;
pub mod layout;
pub mod scene_buffers;
mod stages;
mod waves;

use crate::bvh::Bvh;
use crate::film::{Block, Film, Tile};
use crate::output::{nonfinite_stages, RenderOutput};
use crate::scene::Scene;
use crate::vk::{Context, Recorder, ShaderCompiler};
use anyhow::{bail, Context as _, Result};
use interface::Push;
pub(crate) use kernels::model_shader_inputs;
pub use kernels::{bvh_defines, scene_features};
use kernels::{KernelId, Owned};
use layout::{Binding, Counter, Counters, LOCAL_SIZE};
use stages::Schedule;
use std::ops::Range;
use std::sync::Arc;
use std::time::Instant;
use waves::waves;

/// Most path slots in a wave: bounded by the 65535-workgroup dispatch limit and lavapipe's
/// 128 MiB storage-buffer range (the queue buffer holds (3 + models) × wave_paths indices).
pub const MAX_WAVE_PATHS: u32 = 1 << 20;
/// Segments recorded between two checks whether any path is left (deep renders only: a scene
/// with `max_depth` at most this never waits for the host within a wave).
pub(crate) const SEGMENTS_PER_CHECK: u32 = 16;
/// Most samples of one pixel in a wave. `accumulate` adds a pixel's samples of a wave in one
/// loop of two iterations per sample, which must stay within the 65,535 loop iterations that
/// Mesa 22.3's gallivm allows an invocation (docs/loops.md); the film's sums do not depend on it.
pub const MAX_SAMPLES_PER_WAVE: u32 = 8192;

/// How the GPU follows paths. Every choice gives the same image, bit for bit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Integrator {
    /// The wavefront stages above: path state in buffers, one kernel per stage and per model.
    #[default]
    Wavefront,
    /// One kernel per wave that follows every path to its end and switches on the model: the
    /// baseline of `brdfwave bench`. The same random numbers, arithmetic and image.
    Megakernel,
    /// Whichever of the two is faster for the render's wave size ([`Integrator::resolve`]):
    /// the command line's default.
    Auto,
}

/// Largest wave for which [`Integrator::Auto`] takes the megakernel. A wavefront segment
/// costs a few dispatches whatever the number of paths in it (on lavapipe about 0.2 ms per
/// segment, mostly waking and joining its threads), while the megakernel costs that once per
/// wave but keeps a lane busy until the longest path of its subgroup ends (0.63× the
/// wavefront's paths/s on the 256×256 Cornell box). Measured on 2 cores, 1 spp, one wave
/// (seconds of rendering, wavefront / megakernel): Cornell box max depth 8 at 64×64 (4096
/// paths) 0.030–0.037 / 0.031–0.050, at 256×256 0.18 / 0.20; white furnace 4×4 (16 paths) at
/// depth 1024 0.216 / 0.020, at 64×64 0.81 / 0.59; 16 paths of 65,536 segments 12.5 / 0.6.
/// Below about 2,000 paths the per-segment cost dominates every scene measured.
pub const AUTO_MEGAKERNEL_MAX_WAVE_PATHS: u32 = 2048;

impl Integrator {
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Wavefront => "wavefront",
            Integrator::Megakernel => "megakernel",
            Integrator::Auto => "auto",
        }
    }

    /// The integrator that renders waves of `wave_paths` paths: `Auto` becomes the megakernel
    /// for waves of at most [`AUTO_MEGAKERNEL_MAX_WAVE_PATHS`] paths, else the wavefront; the
    /// others stay as they are.
    pub fn resolve(self, wave_paths: u32) -> Integrator {
        match self {
            Integrator::Auto if wave_paths <= AUTO_MEGAKERNEL_MAX_WAVE_PATHS => {
                Integrator::Megakernel
            }
            Integrator::Auto => Integrator::Wavefront,
            fixed => fixed,
        }
    }
}

/// Timing and bookkeeping of the set-up, for the summary.
#[derive(Clone, Debug, Default)]
pub struct SetupStats {
    /// Names of the pipelines built (shade pipelines are `shade_<model>`).
    pub pipelines: Vec<String>,
    pub seconds_shader_compile: f64,
    pub seconds_pipeline_create: f64,
    pub seconds_upload: f64,
    pub shader_cache_hits: u32,
    /// Path slots of a wave (all samples that fit of the whole image, or one chunk of it).
    pub wave_paths: u32,
    /// Queue pushes are aggregated over the subgroup (the device has subgroup ballots).
    pub subgroup_queues: bool,
}

/// How a [`GpuRenderer`] renders; none of it changes the image.
#[derive(Clone, Copy, Debug)]
pub struct GpuOptions {
    /// Most paths in flight at a time, 64 ..= [`MAX_WAVE_PATHS`] (the default). The random
    /// numbers are keyed on (pixel, sample, depth, dimension) and the film adds each pixel's
    /// samples in sample order, so the waves do not show in the image.
    pub wave_paths: u32,
    /// The stages with queues (default), or the megakernel.
    pub integrator: Integrator,
    /// Only the pixels of this tile (which must lie within the image; default: all of it). The
    /// film is the tile's size, and each pixel gets the samples it gets in a render of the
    /// whole image (the random numbers are keyed on the image's pixel).
    pub tile: Option<Tile>,
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions {
            wave_paths: MAX_WAVE_PATHS,
            integrator: Integrator::Wavefront,
            tile: None,
        }
    }
}

pub struct GpuRenderer<'a> {
    ctx: &'a Context,
    scene: &'a Scene,
    owned: Owned<'a>,
    /// The kernels between a wave's start and `accumulate`, and their order.
    schedule: Schedule,
    accumulate: KernelId,
    /// The integrator that renders (never `Auto`: resolved for the wave size).
    integrator: Integrator,
    counters: Counters,
    wave_paths: u32,
    /// The part of the image rendered (the whole image unless split into tiles).
    tile: Tile,
    /// The samples in the film: `film_samples.start` is the first one rendered since the last
    /// reset, `film_samples.end` the next to render.
    film_samples: Range<u32>,
    stage_seconds: Vec<(String, f64)>,
    /// The megakernel's count of resumed paths (`Counter::MegakernelResumed`) as last seen.
    resumed_seen: u32,
    pub setup: SetupStats,
}

impl<'a> GpuRenderer<'a> {
    /// A wavefront renderer of the whole image with the largest wave ([`MAX_WAVE_PATHS`]
    /// paths). Larger waves were faster on every device measured (docs/bench-log.md).
    pub fn new(
        ctx: &'a Context,
        scene: &'a Scene,
        bvh: Arc<Bvh>,
        compiler: &ShaderCompiler,
    ) -> Result<Self> {
        Self::with_options(ctx, scene, bvh, compiler, GpuOptions::default())
    }

    /// A wavefront renderer that traces at most `wave_paths` paths at a time.
    pub fn with_wave_paths(
        ctx: &'a Context,
        scene: &'a Scene,
        bvh: Arc<Bvh>,
        compiler: &ShaderCompiler,
        wave_paths: u32,
    ) -> Result<Self> {
        let options = GpuOptions {
            wave_paths,
            ..GpuOptions::default()
        };
        Self::with_options(ctx, scene, bvh, compiler, options)
    }

    /// A renderer with `options` (see [`GpuOptions`]). It lets go of `bvh` once the tree is
    /// uploaded, before the other buffers are made: given the only reference, the host's copy
    /// is freed there (docs/bench-log.md, the scene's memory).
    pub fn with_options(
        ctx: &'a Context,
        scene: &'a Scene,
        bvh: Arc<Bvh>,
        compiler: &ShaderCompiler,
        options: GpuOptions,
    ) -> Result<Self> {
        let GpuOptions {
            wave_paths,
            integrator,
            tile,
        } = options;
        let tile = tile.unwrap_or(Tile::full(scene.width, scene.height));
        check_wave_paths(wave_paths).context("wave size")?;
        check_max_depth(scene.integrator.max_depth)?;
        tile.check_within(scene.width, scene.height)
            .map_err(anyhow::Error::msg)?;
        let mut setup = SetupStats::default();
        // Path slots: all the samples of the tile that fit in `wave_paths`, or one chunk of it.
        let spp = scene.integrator.spp;
        let wave_paths =
            waves::wave_slots(tile.pixels() as u64, spp, wave_paths, MAX_SAMPLES_PER_WAVE);
        setup.wave_paths = wave_paths;
        let integrator = integrator.resolve(wave_paths);
        setup.subgroup_queues = ctx.features.subgroup_ballot;
        if !scene.spheres.is_empty() && !ctx.features.shader_float64 {
            bail!(
                "the scene has spheres, and this device ({}) cannot run double-precision \
                 shaders (shaderFloat64), which the sphere test needs; render it with \
                 --backend cpu, or on another device (brdfwave devices)",
                ctx.device_name
            );
        }
        // One material queue per model of the scene's materials that scatter.
        let counters = Counters {
            queues: scene.shaded_models().len() as u32,
        };
        // Read from the tree before create_buffers lets go of it.
        let tiled = tile != Tile::full(scene.width, scene.height);
        let common = kernels::common_defines(ctx, scene, &bvh, tiled);
        let t_upload = Instant::now();
        let sizes = kernels::Sizes {
            wave_paths,
            counters,
            tile,
            separate_stages: stages::separate_stages(integrator, counters.queues as usize),
        };
        let mut owned = kernels::create_buffers(ctx, scene, bvh, &sizes)?;
        setup.seconds_upload = t_upload.elapsed().as_secs_f64();

        let (schedule, accumulate) = kernels::build_kernels(
            ctx, scene, &mut owned, compiler, &mut setup, integrator, common,
        )?;
        let mut r = GpuRenderer {
            ctx,
            scene,
            owned,
            schedule,
            accumulate,
            integrator,
            counters,
            wave_paths,
            tile,
            film_samples: 0..0,
            stage_seconds: Vec::new(),
            resumed_seen: 0,
            setup,
        };
        // Device memory starts undefined: an empty film, so that `render_samples` may follow.
        r.reset()?;
        Ok(r)
    }

    /// Render `scene.integrator.spp` samples per pixel from an empty film; `progress` gets the
    /// samples per pixel done so far (fractional within a wave).
    pub fn render(&mut self, progress: &dyn Fn(f64)) -> Result<RenderOutput> {
        self.reset()?;
        self.render_samples(0..self.scene.integrator.spp, progress)?;
        self.output()
    }

    /// Empties the film and the counters.
    pub fn reset(&mut self) -> Result<()> {
        let mut rec = self.ctx.begin()?;
        rec.fill_buffer(self.owned.buffer(Binding::Film), 0);
        rec.fill_buffer(self.owned.buffer(Binding::Film2), 0);
        rec.fill_buffer(self.owned.buffer(Binding::Counters), 0);
        self.ctx.submit_and_wait(rec)?;
        self.film_samples = 0..0;
        self.stage_seconds.clear();
        self.resumed_seen = 0;
        Ok(())
    }

    /// Adds the samples `samples` (sample indices; the next ones after those already in the
    /// film, or any after a reset) of every pixel of the tile to the film. `progress` gets the samples per pixel done so far: after
    /// each batch of waves, and, while a batch holds a single wave (a slow device), after each
    /// segment, as a fraction of the wave by segments.
    pub fn render_samples(&mut self, samples: Range<u32>, progress: &dyn Fn(f64)) -> Result<()> {
        crate::film::check_continues(&self.film_samples, &samples)?;
        if self.film_samples.is_empty() {
            self.film_samples = samples.start..samples.start;
        }
        let pixels = self.tile.width * self.tile.height;
        let ctx = self.ctx;
        // The waves, in order: k samples of the whole image when it fits in a wave, else one
        // sample of one chunk of pixels. Consecutive waves share a command buffer (a batch) whose
        // size doubles while a submission takes under BATCH_SECONDS, so a fast GPU is not held
        // up by a wait per wave and a slow device still reports progress. A command buffer is
        // also split before its timestamp queries run out, and, in a deep render, every
        // SEGMENTS_PER_CHECK segments to stop once no path is left.
        let mut waves = waves(pixels, samples.clone(), self.wave_paths).peekable();
        let mut batch = 1usize;
        while waves.peek().is_some() {
            let t_batch = Instant::now();
            let mut rec = ctx.begin()?;
            rec.timestamp("start");
            let mut samples_done = self.film_samples.end;
            for w in waves.by_ref().take(batch) {
                samples_done = w.samples_done;
                let push = Push {
                    sample_index: w.sample,
                    chunk_offset: w.offset,
                    wave_size: w.pixels * w.samples,
                    chunk_pixels: w.pixels,
                    ..Default::default()
                };
                // The part of a sample per pixel this wave is, for progress.
                let start =
                    (w.sample - self.film_samples.start) as f64 + w.offset as f64 / pixels as f64;
                let end = start + w.samples as f64 * w.pixels as f64 / pixels as f64;
                let report = |fraction: f64| progress(start + (end - start) * fraction);
                let split = batch == 1;
                rec = match self.schedule {
                    Schedule::Megakernel { .. } => self.record_megakernel_wave(rec, push)?,
                    _ => self.record_wave(rec, push, split.then_some(&report))?,
                };
                rec = self.record_accumulate(rec, &push)?;
            }
            ctx.submit_and_wait(rec)?;
            add_stage_times(ctx.read_timestamps()?, &mut self.stage_seconds);
            self.check_loops()?;
            self.film_samples.end = samples_done;
            progress((samples_done - self.film_samples.start) as f64);
            if t_batch.elapsed().as_secs_f64() < BATCH_SECONDS {
                batch = (batch * 2).min(MAX_BATCH);
            }
        }
        Ok(())
    }

    /// The film so far: one block of per-pixel sums over the samples rendered since the last
    /// reset, in f64 (the GPU's sums are f32, in sample order per pixel).
    /// The integrator that renders: the one asked for, or what `Auto` chose for the wave size.
    pub fn integrator(&self) -> Integrator {
        self.integrator
    }

    pub fn film(&self) -> Result<Film> {
        let film: Vec<[f32; 4]> = self.ctx.download(self.owned.buffer(Binding::Film))?;
        let film2: Vec<[f32; 4]> = self.ctx.download(self.owned.buffer(Binding::Film2))?;
        let mut f = Film::new(self.tile);
        if self.film_samples.is_empty() {
            return Ok(f);
        }
        // The film holds sums of l·2^-k and (l·2^-k)², k in .w (accumulate.comp).
        let sums = film
            .iter()
            .zip(&film2)
            .map(|(s, s2)| {
                let k = s[3] as i32;
                let (sc, sc2) = (2f64.powi(k), 2f64.powi(2 * k));
                std::array::from_fn(|i| match i {
                    0..=2 => s[i] as f64 * sc,
                    _ => s2[i - 3] as f64 * sc2,
                })
            })
            .collect();
        f.add_blocks(vec![Block {
            samples: self.film_samples.clone(),
            sums,
        }]);
        Ok(f)
    }

    /// The image of the samples in the film so far (of the tile), and the counters.
    pub fn output(&self) -> Result<RenderOutput> {
        let scene = self.scene;
        let counters: Vec<u32> = self.ctx.download(self.owned.buffer(Binding::Counters))?;
        let film = self.film()?;
        let (mean, variance) = film.images();
        let spp = film.spp();
        let c = self.counters;
        let nonfinite_by_stage = nonfinite_stages(
            counters[c.nonfinite_extend()] as u64,
            self.schedule
                .models()
                .iter()
                .map(|q| (q.model, counters[c.nonfinite_shade(q.slot)] as u64)),
            counters[c.fixed(Counter::NonfiniteAccumulate)] as u64,
        );
        Ok(RenderOutput {
            mean,
            variance,
            spp,
            nonfinite_samples: nonfinite_by_stage.iter().map(|s| s.1).sum(),
            nonfinite_by_stage,
            // Running totals kept by the prepare kernel from the queue sizes (the megakernel
            // counts its rays itself).
            extension_rays: c.total(&counters, Counter::ExtensionRaysLo),
            shadow_rays: c.total(&counters, Counter::ShadowRaysLo),
            shadow_rays_occluded: c.total(&counters, Counter::OccludedLo),
            rays_by_segment: (1..=scene
                .integrator
                .max_depth
                .min(crate::conventions::SEGMENTS_COUNTED))
                .map(|d| {
                    (
                        c.total_at(&counters, c.segment_extension(d)),
                        c.total_at(&counters, c.segment_shadow(d)),
                    )
                })
                .collect(),
            stage_seconds: self.stage_seconds.clone(),
        })
    }

    /// Fails if the driver cut short any loop of a kernel since the last reset (the image would
    /// be silently wrong; state.glsl `check_loops`), or left a megakernel path unfinished.
    fn check_loops(&self) -> Result<()> {
        let counters: Vec<u32> = self.ctx.download(self.owned.buffer(Binding::Counters))?;
        let c = self.counters;
        let cut = counters[c.fixed(Counter::CutShort)];
        if cut > 0 {
            bail!(
                "the Vulkan driver cut short the loops of {cut} kernel invocation(s), which would give a wrong image \
                 (Mesa 22.3's lavapipe stops every loop of an invocation after 65,535 iterations in all; \
                 a BVH traversal of a very large scene can take that many): render on the CPU (--backend cpu) \
                 or with another Vulkan driver"
            );
        }
        if counters[c.fixed(Counter::MegakernelResumed)] != self.resumed_seen {
            bail!(
                "the megakernel could not finish its paths within the Vulkan driver's loop limit \
                 (Mesa 22.3's lavapipe allows 65,535 loop iterations per invocation); \
                 render with --integrator wavefront"
            );
        }
        Ok(())
    }

    /// Submits `rec` and waits, adds its stage times, and begins the next command buffer.
    fn resubmit<'r>(&mut self, rec: Recorder<'r>) -> Result<Recorder<'r>>
    where
        'a: 'r,
    {
        self.ctx.submit_and_wait(rec)?;
        add_stage_times(self.ctx.read_timestamps()?, &mut self.stage_seconds);
        let mut rec = self.ctx.begin()?;
        rec.timestamp("start");
        Ok(rec)
    }
}

/// Largest `max_depth` accepted (segments per path): [`crate::conventions::MAX_DEPTH`].
pub use crate::conventions::MAX_DEPTH;

/// A `max_depth` the GPU renderer accepts: 1 ..= [`MAX_DEPTH`].
pub fn check_max_depth(max_depth: u32) -> Result<()> {
    if !(1..=MAX_DEPTH).contains(&max_depth) {
        bail!("max depth must be between 1 and {MAX_DEPTH} segments, got {max_depth}");
    }
    Ok(())
}

/// A wave size [`GpuRenderer::with_wave_paths`] accepts: 64 ..= [`MAX_WAVE_PATHS`] paths.
pub fn check_wave_paths(wave_paths: u32) -> Result<()> {
    if !(LOCAL_SIZE..=MAX_WAVE_PATHS).contains(&wave_paths) {
        bail!("must be between {LOCAL_SIZE} and {MAX_WAVE_PATHS} paths, got {wave_paths}");
    }
    Ok(())
}

/// The number of waves per command buffer doubles while a submission takes less than this.
pub(crate) const BATCH_SECONDS: f64 = 0.05;
/// Most waves per command buffer.
const MAX_BATCH: usize = 64;

/// Adds the intervals between consecutive timestamps to the stage they end.
fn add_stage_times(stamps: Vec<(String, f64)>, stage_seconds: &mut Vec<(String, f64)>) {
    for w in stamps.windows(2) {
        let (label, dt) = (&w[1].0, w[1].1 - w[0].1);
        match stage_seconds.iter_mut().find(|(l, _)| l == label) {
            Some((_, t)) => *t += dt,
            None => stage_seconds.push((label.clone(), dt)),
        }
    }
}
