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
//!     prepare(0)   args for `extend`; reset the queues this segment appends to
//!     extend       closest hit; emission (MIS); route to the material's queue
//!     prepare(1)   args for each material queue
//!     shade_<m>    one pipeline per model, indirect over its own queue: NEE → shadow queue,
//!                  BRDF sample → next ray queue
//!     prepare(2)   args for the shadow queue
//!     shadow       any hit; add the unoccluded light sample
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
//! Every buffer, counter and slot is named in [`layout`].

pub mod brdf_probe;
pub mod layout;
pub mod scene_buffers;

use crate::brdf::MODELS;
use crate::bvh::Bvh;
use crate::film::{Block, Film, Tile};
use crate::lights::LightTable;
use crate::output::{nonfinite_stages, RenderOutput};
use crate::scene::Scene;
use crate::vk::{Buffer, ComputePipeline, Context, Recorder, Resource, ShaderCompiler};
use anyhow::{bail, Context as _, Result};
use ash::vk;
use gpu_allocator::MemoryLocation;
use layout::{Binding, Counter, Counters, Kind};
use std::collections::BTreeSet;
use std::ops::Range;
use std::time::Instant;

/// Bytes of push constants (`Push` in state.glsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    depth: u32,
    sample_index: u32,
    chunk_offset: u32,
    wave_size: u32,
    phase: u32,
    queue_slot: u32,
    chunk_pixels: u32,
}

const LOCAL_SIZE: u32 = 64;
/// Most path slots in a wave: bounded by the 65535-workgroup dispatch limit and lavapipe's
/// 128 MiB storage-buffer range (the queue buffer holds (3 + models) × wave_paths indices).
pub const MAX_WAVE_PATHS: u32 = 1 << 20;
/// Segments recorded between two checks whether any path is left (deep renders only: a scene
/// with `max_depth` at most this never waits for the host within a wave).
const SEGMENTS_PER_CHECK: u32 = 16;
/// Most samples of one pixel in a wave. `accumulate` adds a pixel's samples of a wave in one
/// loop of two iterations per sample, which must stay within the 65,535 loop iterations that
/// Mesa 22.3's gallivm allows an invocation (docs/loops.md); the film's sums do not depend on it.
pub const MAX_SAMPLES_PER_WAVE: u32 = 8192;

/// How the GPU follows paths.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Integrator {
    /// The wavefront stages above: path state in buffers, one kernel per stage and per model.
    #[default]
    Wavefront,
    /// One kernel per wave that follows every path to its end and switches on the model: the
    /// baseline of `brdfwave bench`. The same random numbers, arithmetic and image.
    Megakernel,
}

impl Integrator {
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Wavefront => "wavefront",
            Integrator::Megakernel => "megakernel",
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

struct Kernel {
    pipeline: ComputePipeline,
    set: vk::DescriptorSet,
}

/// The Vulkan objects a renderer made, destroyed when it goes (also when set-up fails half way).
struct Owned<'a> {
    ctx: &'a Context,
    /// One buffer per [`Binding`], in binding order.
    buffers: Vec<Buffer>,
    /// Texel views, parallel to `buffers` (null for whole-buffer bindings).
    views: Vec<vk::BufferView>,
    kernels: Vec<Kernel>,
}

impl Owned<'_> {
    fn buffer(&self, b: Binding) -> &Buffer {
        &self.buffers[b.index() as usize]
    }
    fn resources(&self) -> Vec<Resource<'_>> {
        self.buffers
            .iter()
            .zip(&self.views)
            .map(|(b, &v)| match v == vk::BufferView::null() {
                true => Resource::Buffer(b),
                false => Resource::Texels(b, v),
            })
            .collect()
    }
}

impl Drop for Owned<'_> {
    fn drop(&mut self) {
        for k in self.kernels.drain(..) {
            self.ctx.destroy_pipeline(k.pipeline);
        }
        for v in self.views.drain(..) {
            if v != vk::BufferView::null() {
                self.ctx.destroy_buffer_view(v);
            }
        }
        for b in self.buffers.drain(..) {
            self.ctx.destroy_buffer(b);
        }
    }
}

/// A shade pipeline: (queue slot, model index, index into `Owned::kernels`).
type ShadeKernel = (u32, usize, usize);

/// Indices into `Owned::kernels`.
#[derive(Clone, Copy)]
struct Stages {
    generate: usize,
    prepare: usize,
    extend: usize,
    shadow: usize,
    accumulate: usize,
    megakernel: usize,
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
    stages: Stages,
    shade: Vec<ShadeKernel>,
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
    /// paths). Larger waves were faster on every device measured (BENCHMARKS.md).
    pub fn new(
        ctx: &'a Context,
        scene: &'a Scene,
        bvh: &Bvh,
        compiler: &ShaderCompiler,
    ) -> Result<Self> {
        Self::with_options(ctx, scene, bvh, compiler, GpuOptions::default())
    }

    /// A wavefront renderer that traces at most `wave_paths` paths at a time.
    pub fn with_wave_paths(
        ctx: &'a Context,
        scene: &'a Scene,
        bvh: &Bvh,
        compiler: &ShaderCompiler,
        wave_paths: u32,
    ) -> Result<Self> {
        let options = GpuOptions {
            wave_paths,
            ..GpuOptions::default()
        };
        Self::with_options(ctx, scene, bvh, compiler, options)
    }

    /// A renderer with `options` (see [`GpuOptions`]).
    pub fn with_options(
        ctx: &'a Context,
        scene: &'a Scene,
        bvh: &Bvh,
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
        let pixels = tile.pixels() as u64;
        // Path slots: all the samples of the tile that fit in `wave_paths`, or one chunk of it.
        let spp = scene.integrator.spp.max(1) as u64;
        let most = wave_paths as u64;
        let wave_paths = if pixels <= most {
            (pixels
                * spp
                    .min(most / pixels.max(1))
                    .min(MAX_SAMPLES_PER_WAVE as u64)) as u32
        } else {
            wave_paths
        };
        setup.wave_paths = wave_paths;
        setup.subgroup_queues = ctx.features.subgroup_ballot;

        // Which models need a queue: those of materials that scatter.
        let models = scene.shaded_models();
        let queue_slot: Vec<u32> = scene
            .materials
            .iter()
            .map(|m| match m.brdf.scatters() {
                true => models.iter().position(|&x| x == m.model).unwrap() as u32,
                false => scene_buffers::NO_QUEUE,
            })
            .collect();
        let num_queues = models.len() as u32;
        let counters = Counters { queues: num_queues };

        let t_upload = Instant::now();
        let lights = LightTable::build(scene);
        let film_bytes = pixels * 16;
        let limit = ctx.limits.max_storage_buffer_range as u64;
        let queue_bytes =
            (layout::QUEUE_MATERIAL as u64 + num_queues as u64) * wave_paths as u64 * 4;
        if film_bytes > limit || queue_bytes > limit {
            bail!(
                "{}: its film needs {} MiB, over this device's storage-buffer range of {} MiB; render a smaller image or split it into tiles (--tile)",
                if tile == Tile::full(scene.width, scene.height) {
                    format!("an image of {}x{}", scene.width, scene.height)
                } else {
                    format!("a tile of {}x{}", tile.width, tile.height)
                },
                film_bytes >> 20,
                limit >> 20
            );
        }
        let mut owned = Owned {
            ctx,
            buffers: Vec::new(),
            views: Vec::new(),
            kernels: Vec::new(),
        };
        let cap = wave_paths as u64;
        let gpu = MemoryLocation::GpuOnly;
        for b in Binding::ALL {
            let name = b.name();
            let usage = b.usage();
            let buffer = match b {
                Binding::BvhNodes => {
                    ctx.create_buffer_with_data(name, scene_buffers::bvh_nodes(bvh), usage)?
                }
                Binding::BvhPrims => ctx.create_buffer_with_data(name, &bvh.prims, usage)?,
                Binding::Triangles => {
                    ctx.create_buffer_with_data(name, &scene_buffers::triangle_data(scene), usage)?
                }
                Binding::Spheres => {
                    ctx.create_buffer_with_data(name, &scene_buffers::sphere_data(scene), usage)?
                }
                Binding::TriAttrs => ctx.create_buffer_with_data(
                    name,
                    &scene_buffers::triangle_attributes(scene),
                    usage,
                )?,
                Binding::Materials => ctx.create_buffer_with_data(
                    name,
                    &scene_buffers::material_records(scene, &queue_slot),
                    usage,
                )?,
                Binding::Lights => {
                    ctx.create_buffer_with_data(name, &scene_buffers::light_data(&lights), usage)?
                }
                Binding::Emitters => ctx.create_buffer_with_data(
                    name,
                    &scene_buffers::emitter_data(scene, &lights),
                    usage,
                )?,
                Binding::Globals => ctx.create_buffer_with_data(
                    name,
                    &scene_buffers::globals(scene, &lights, num_queues, wave_paths, tile),
                    usage,
                )?,
                Binding::RayO
                | Binding::RayD
                | Binding::Beta
                | Binding::Radiance
                | Binding::HitRec
                | Binding::ShadowO
                | Binding::ShadowD
                | Binding::ShadowL => ctx.create_buffer(name, cap * 16, usage, gpu)?,
                Binding::Queues => ctx.create_buffer(name, queue_bytes, usage, gpu)?,
                // Film and counters are read and written by every pass and read back once:
                // device memory, downloaded through a staging copy (in host-visible memory every
                // accumulate would cross PCIe on a discrete GPU).
                Binding::Counters => {
                    ctx.create_buffer(name, counters.len() as u64 * 4, usage, gpu)?
                }
                Binding::Args => ctx.create_buffer(
                    name,
                    (layout::ARGS_MATERIAL as u64 + num_queues as u64) * 16,
                    usage | vk::BufferUsageFlags::INDIRECT_BUFFER,
                    gpu,
                )?,
                Binding::Film | Binding::Film2 => {
                    ctx.create_buffer(name, film_bytes, usage, gpu)?
                }
            };
            owned.buffers.push(buffer);
            let view = match b.kind() {
                Kind::Texels(format) | Kind::Image(format) => {
                    ctx.create_buffer_view(owned.buffers.last().unwrap(), format)?
                }
                Kind::Uniform | Kind::Storage => vk::BufferView::null(),
            };
            owned.views.push(view);
        }
        setup.seconds_upload = t_upload.elapsed().as_secs_f64();

        let tiled = tile != Tile::full(scene.width, scene.height);
        let (stages, shade) = build_kernels(
            ctx, scene, &mut owned, compiler, &mut setup, integrator, tiled,
        )?;
        let mut r = GpuRenderer {
            ctx,
            scene,
            owned,
            stages,
            shade,
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
        if self.film_samples.is_empty() {
            self.film_samples = samples.start..samples.start;
        } else if samples.start != self.film_samples.end {
            bail!(
                "samples from {} asked for, but the film holds samples {}..{}",
                samples.start,
                self.film_samples.start,
                self.film_samples.end
            );
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
                rec = match self.integrator {
                    Integrator::Wavefront => {
                        self.record_wave(rec, push, split.then_some(&report))?
                    }
                    Integrator::Megakernel => self.record_megakernel_wave(rec, push)?,
                };
                rec = self.ensure_timestamps(rec, 1)?;
                self.dispatch(
                    &mut rec,
                    self.stages.accumulate,
                    &push,
                    Dispatch::Groups(w.pixels.div_ceil(LOCAL_SIZE)),
                    "accumulate",
                );
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
            self.shade
                .iter()
                .map(|&(slot, model, _)| (model, counters[c.nonfinite_shade(slot)] as u64)),
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
            rays_by_segment: (1..=scene.integrator.max_depth.min(crate::conventions::SEGMENTS_COUNTED))
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

    /// Records one wave of the wavefront integrator. With `report`, each segment is submitted on
    /// its own and `report` gets the fraction of the wave's segments done.
    fn record_wave<'r>(
        &mut self,
        mut rec: Recorder<'r>,
        mut push: Push,
        report: Option<&dyn Fn(f64)>,
    ) -> Result<Recorder<'r>>
    where
        'a: 'r,
    {
        let st = self.stages;
        let max_depth = self.scene.integrator.max_depth;
        let per_segment = 4 + self.shade.len() as u32;
        rec = self.ensure_timestamps(rec, 2 + per_segment)?;
        self.dispatch(
            &mut rec,
            st.generate,
            &push,
            Dispatch::Groups(push.wave_size.div_ceil(LOCAL_SIZE)),
            "generate",
        );
        for depth in 1..=max_depth {
            // A deep render stops once every path has ended: the host looks at the queue of the
            // next segment every SEGMENTS_PER_CHECK segments.
            if depth > 1 && max_depth > SEGMENTS_PER_CHECK && (depth - 1) % SEGMENTS_PER_CHECK == 0
            {
                rec = self.resubmit(rec)?;
                let counters: Vec<u32> = self.ctx.download(self.owned.buffer(Binding::Counters))?;
                if counters[ray_queue_in(depth) as usize] == 0 {
                    break;
                }
            }
            rec = self.ensure_timestamps(rec, 1 + per_segment)?;
            push.depth = depth;
            self.prepare(&mut rec, &mut push, 0);
            let label = self.owned.kernels[st.extend].pipeline.name.clone();
            self.dispatch(
                &mut rec,
                st.extend,
                &push,
                Dispatch::Indirect(layout::ARGS_RAY),
                &label,
            );
            if depth == max_depth {
                break;
            }
            let fused = self.shade.len() == 1 && self.shade[0].2 == st.extend;
            if !fused {
                self.prepare(&mut rec, &mut push, 1);
            }
            for i in (0..self.shade.len()).filter(|_| !fused) {
                let (slot, _, kernel) = self.shade[i];
                push.queue_slot = slot;
                let name = self.owned.kernels[kernel].pipeline.name.clone();
                self.dispatch(
                    &mut rec,
                    kernel,
                    &push,
                    Dispatch::Indirect(layout::ARGS_MATERIAL + slot),
                    &name,
                );
            }
            if !fused {
                self.prepare(&mut rec, &mut push, 2);
                self.dispatch(
                    &mut rec,
                    st.shadow,
                    &push,
                    Dispatch::Indirect(layout::ARGS_SHADOW),
                    "shadow",
                );
            }
            if let Some(report) = report {
                rec = self.resubmit(rec)?;
                report(depth as f64 / max_depth as f64);
            }
        }
        Ok(rec)
    }

    /// Records one wave of the megakernel: every path from the camera to its end. A path the
    /// driver's loop budget stops is saved and resumed by another dispatch (megakernel.comp):
    /// in a deep render (`max_depth` over [`SEGMENTS_PER_CHECK`]) the host waits after each
    /// dispatch and dispatches again while any path is left; in a shallow one, where that would
    /// take a segment of thousands of loop iterations, [`Self::check_loops`] reports it.
    fn record_megakernel_wave<'r>(
        &mut self,
        mut rec: Recorder<'r>,
        mut push: Push,
    ) -> Result<Recorder<'r>>
    where
        'a: 'r,
    {
        let groups = push.wave_size.div_ceil(LOCAL_SIZE);
        let c = self.counters;
        let mut segments = None;
        loop {
            rec = self.ensure_timestamps(rec, 1)?;
            self.dispatch(
                &mut rec,
                self.stages.megakernel,
                &push,
                Dispatch::Groups(groups),
                "megakernel",
            );
            if self.scene.integrator.max_depth <= SEGMENTS_PER_CHECK {
                return Ok(rec);
            }
            rec = self.resubmit(rec)?;
            let counters: Vec<u32> = self.ctx.download(self.owned.buffer(Binding::Counters))?;
            let resumed = counters[c.fixed(Counter::MegakernelResumed)];
            let left = resumed.wrapping_sub(self.resumed_seen);
            self.resumed_seen = resumed;
            if left == 0 {
                return Ok(rec);
            }
            // Every segment adds an extension ray: none since the last dispatch means that one
            // segment needs more loop iterations than the driver allows an invocation.
            let done = c.total(&counters, Counter::ExtensionRaysLo);
            if segments == Some(done) {
                bail!(
                    "the megakernel cannot complete a path segment within the Vulkan driver's loop limit \
                     (Mesa 22.3's lavapipe allows 65,535 loop iterations per invocation); \
                     render with --integrator wavefront"
                );
            }
            segments = Some(done);
            push.phase = 1;
        }
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

    /// Bind, push constants, dispatch, barrier, timestamp: every stage goes through here.
    fn dispatch(
        &self,
        rec: &mut Recorder<'_>,
        kernel: usize,
        push: &Push,
        how: Dispatch,
        label: &str,
    ) {
        let k = &self.owned.kernels[kernel];
        rec.bind(&k.pipeline, k.set);
        rec.push_constants(&k.pipeline, push);
        match how {
            Dispatch::Groups(n) => rec.dispatch(n, 1, 1),
            Dispatch::Indirect(slot) => {
                rec.dispatch_indirect(self.owned.buffer(Binding::Args), slot as u64 * 16)
            }
        }
        rec.barrier();
        rec.timestamp(label);
    }

    fn prepare(&self, rec: &mut Recorder<'_>, push: &mut Push, phase: u32) {
        push.phase = phase;
        self.dispatch(
            rec,
            self.stages.prepare,
            push,
            Dispatch::Groups(1),
            "prepare",
        );
    }

    /// `rec`, or a new command buffer when fewer than `n` timestamps are left in it.
    fn ensure_timestamps<'r>(&mut self, rec: Recorder<'r>, n: u32) -> Result<Recorder<'r>>
    where
        'a: 'r,
    {
        if rec.timestamps_left() < n {
            self.resubmit(rec)
        } else {
            Ok(rec)
        }
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

#[derive(Clone, Copy)]
enum Dispatch {
    Groups(u32),
    /// Indirect, from this slot of the `args` buffer.
    Indirect(u32),
}

/// The ray queue that holds the rays of segment `depth` (segment 1 reads queue 0).
fn ray_queue_in(depth: u32) -> u32 {
    (depth + 1) & 1
}

/// Compiles and creates the pipelines `integrator` needs (each stage, or the megakernel, and
/// `accumulate`) and one shade pipeline per model of the scene (`Scene::shaded_models`) for the
/// wavefront.
fn build_kernels(
    ctx: &Context,
    scene: &Scene,
    owned: &mut Owned,
    compiler: &ShaderCompiler,
    setup: &mut SetupStats,
    integrator: Integrator,
    tiled: bool,
) -> Result<(Stages, Vec<ShadeKernel>)> {
    let models = &scene.shaded_models()[..];
    // Defines added to every stage: the layout's numbers, the sampler and its dimension
    // table, and subgroup-aggregated queue pushes
    // where the device has subgroup ballots (see `queue_push` in state.glsl).
    let mut common = layout::defines();
    common.extend(crate::rng::defines(scene.integrator.sampler));
    common.push(("NO_QUEUE".into(), format!("{}u", scene_buffers::NO_QUEUE)));
    if ctx.features.subgroup_ballot {
        common.push(("SUBGROUP_QUEUES".into(), "1".into()));
    }
    // A render of one tile maps its pixels to the image's (see `path_pixel` in state.glsl).
    if tiled {
        common.push(("TILED".into(), "1".into()));
    }
    common.extend(
        scene_features(scene)
            .into_iter()
            .map(|f| (f.to_string(), "1".to_string())),
    );
    let kinds: Vec<vk::DescriptorType> = Binding::ALL.iter().map(|b| b.descriptor_type()).collect();
    let mut build = |name: &str,
                     file: &str,
                     mut defines: Vec<(String, String)>,
                     overrides: Vec<(String, String)>|
     -> Result<usize> {
        defines.extend(common.iter().cloned());
        let t = Instant::now();
        let spirv = compiler
            .compile(file, &defines, &overrides)
            .with_context(|| format!("compiling {file} for pipeline {name}"))?;
        setup.seconds_shader_compile += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let pipeline = ctx.create_compute_pipeline_with(
            name,
            &spirv,
            &kinds,
            std::mem::size_of::<Push>() as u32,
        )?;
        setup.seconds_pipeline_create += t.elapsed().as_secs_f64();
        let set = match ctx.create_descriptor_set_with(&pipeline, &owned.resources()) {
            Ok(set) => set,
            Err(e) => {
                ctx.destroy_pipeline(pipeline);
                return Err(e);
            }
        };
        setup.pipelines.push(name.to_string());
        owned.kernels.push(Kernel { pipeline, set });
        Ok(owned.kernels.len() - 1)
    };
    // The features (defines) each model needs for the scene's materials.
    let features = |model: usize| -> BTreeSet<&'static str> {
        let mut f = BTreeSet::new();
        for m in scene
            .materials
            .iter()
            .filter(|m| m.model == model && m.brdf.scatters())
        {
            f.extend(m.brdf.defines());
        }
        f
    };
    let none = usize::MAX;
    let mut stages = Stages {
        generate: none,
        prepare: none,
        extend: none,
        shadow: none,
        accumulate: none,
        megakernel: none,
    };
    let mut shade = Vec::new();
    match integrator {
        Integrator::Wavefront => {
            stages.generate = build("generate", "wavefront/generate.comp", vec![], vec![])?;
            stages.prepare = build("prepare", "wavefront/prepare.comp", vec![], vec![])?;
            stages.shadow = build("shadow", "wavefront/shadow.comp", vec![], vec![])?;
            if let [model] = models {
                // One shaded model: extend shades in place (extend_shade.comp); the material
                // queue would only cost.
                let (defs, overrides) = model_shader_inputs(*model, features(*model));
                stages.extend = build(
                    &format!("extend_shade_{}", MODELS[*model].name),
                    "wavefront/extend_shade.comp",
                    defs,
                    overrides,
                )?;
                shade.push((0, *model, stages.extend));
            } else {
                stages.extend = build("extend", "wavefront/extend.comp", vec![], vec![])?;
                for (slot, &model) in models.iter().enumerate() {
                    let (defs, overrides) = model_shader_inputs(model, features(model));
                    let k = build(
                        &format!("shade_{}", MODELS[model].name),
                        "wavefront/shade.comp",
                        defs,
                        overrides,
                    )?;
                    shade.push((slot as u32, model, k));
                }
            }
        }
        Integrator::Megakernel => {
            let mut defs: Vec<(String, String)> = Vec::new();
            for &model in models {
                defs.push((
                    format!("MODEL_{}", MODELS[model].name.to_uppercase()),
                    format!("{model}u"),
                ));
                defs.extend(
                    features(model)
                        .into_iter()
                        .map(|f| (f.to_string(), "1".to_string())),
                );
            }
            stages.megakernel = build("megakernel", "wavefront/megakernel.comp", defs, vec![])?;
            // The shade stages' non-finite counters are read per model: the megakernel counts
            // at the same slots.
            for (slot, &model) in models.iter().enumerate() {
                shade.push((slot as u32, model, none));
            }
        }
    }
    stages.accumulate = build("accumulate", "wavefront/accumulate.comp", vec![], vec![])?;
    Ok((stages, shade))
}

/// The `#define`s that compile in only what the scene has: the primitive kinds (BVH_TRIANGLES,
/// BVH_SPHERES), the emitter kinds (LIGHT_TRIANGLES, LIGHT_SPHERES), per-vertex shading normals
/// and texture coordinates (SCENE_SHADING_NORMALS, SCENE_UVS), Russian roulette
/// (RUSSIAN_ROULETTE). On lavapipe both sides of every
/// branch run for all lanes, so code for something the scene lacks is not free.
pub fn scene_features(scene: &Scene) -> Vec<&'static str> {
    let mut f = Vec::new();
    if !scene.triangles.is_empty() || scene.spheres.is_empty() {
        f.push("BVH_TRIANGLES");
    }
    if !scene.spheres.is_empty() {
        f.push("BVH_SPHERES");
    }
    let lit_tris = scene.triangles.iter().any(|t| t.emitter.is_some());
    let lit_spheres = scene.spheres.iter().any(|s| s.emitter.is_some());
    if lit_tris || !lit_spheres {
        f.push("LIGHT_TRIANGLES");
    }
    if lit_spheres {
        f.push("LIGHT_SPHERES");
    }
    if scene.triangles.iter().any(|t| t.n.is_some()) {
        f.push("SCENE_SHADING_NORMALS");
    }
    if scene.triangles.iter().any(|t| t.uv.is_some()) {
        f.push("SCENE_UVS");
    }
    if scene.integrator.russian_roulette {
        f.push("RUSSIAN_ROULETTE");
    }
    f
}

/// Largest `max_depth` accepted (segments per path): the random-number key holds depth × 64 +
/// dimension in 32 bits, and a deeper path would reuse another depth's numbers long before.
pub const MAX_DEPTH: u32 = 1 << 20;

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

/// (name, value) pairs: `#define`s, or include overrides (virtual name, file).
pub(crate) type Defines = Vec<(String, String)>;

/// How a shader is compiled for one model (the shade pipelines and the BRDF probe): the virtual
/// include "brdf/model.glsl" is the model's file, BRDF_EVAL / BRDF_PDF / BRDF_SAMPLE name its
/// functions, and `features` (the materials' `defines`) are defined as 1. Returns the defines
/// and the include overrides.
pub(crate) fn model_shader_inputs<'f>(
    model: usize,
    features: impl IntoIterator<Item = &'f str>,
) -> (Defines, Defines) {
    let name = MODELS[model].name;
    let mut defines: Vec<(String, String)> = features
        .into_iter()
        .map(|d| (d.to_string(), "1".to_string()))
        .collect();
    defines.push(("BRDF_EVAL".into(), format!("{name}_eval")));
    defines.push(("BRDF_PDF".into(), format!("{name}_pdf")));
    defines.push(("BRDF_SAMPLE".into(), format!("{name}_sample")));
    let overrides = vec![("brdf/model.glsl".to_string(), format!("brdf/{name}.glsl"))];
    (defines, overrides)
}

/// The number of waves per command buffer doubles while a submission takes less than this.
const BATCH_SECONDS: f64 = 0.05;
/// Most waves per command buffer.
const MAX_BATCH: usize = 64;

/// One wave: `samples` consecutive samples, from `sample`, of the pixels
/// `offset .. offset + pixels`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Wave {
    sample: u32,
    samples: u32,
    offset: u32,
    pixels: u32,
    /// Samples per pixel complete once this wave is done.
    samples_done: u32,
}

/// The waves that render the sample indices `samples` over `pixels` pixels with `wave_paths`
/// path slots, in order (an iterator: a long render at a high sample count holds no list of
/// them).
fn waves(pixels: u32, samples: Range<u32>, wave_paths: u32) -> impl Iterator<Item = Wave> {
    let spp = samples.end;
    let (mut sample, mut offset) = (samples.start, 0u32);
    std::iter::from_fn(move || {
        if sample >= spp {
            return None;
        }
        if pixels <= wave_paths {
            let k = (wave_paths / pixels).min(spp - sample);
            let w = Wave {
                sample,
                samples: k,
                offset: 0,
                pixels,
                samples_done: sample + k,
            };
            sample += k;
            Some(w)
        } else {
            let n = (pixels - offset).min(wave_paths);
            let w = Wave {
                sample,
                samples: 1,
                offset,
                pixels: n,
                samples_done: if offset + n == pixels {
                    sample + 1
                } else {
                    sample
                },
            };
            offset += n;
            if offset == pixels {
                offset = 0;
                sample += 1;
            }
            Some(w)
        }
    })
}

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

#[cfg(test)]
mod tests {
    use super::{scene_features, waves, Wave};

    /// Only what a scene has is compiled in: the Cornell box has lit triangles and nothing
    /// else; the lineup adds spheres; the OBJ example has per-vertex normals.
    #[test]
    fn scene_features_follow_the_scene() {
        let load = |name: &str| {
            crate::scene::load(
                &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("scenes")
                    .join(name),
            )
            .unwrap()
        };
        assert_eq!(
            scene_features(&load("cornell-box.toml")),
            ["BVH_TRIANGLES", "LIGHT_TRIANGLES"]
        );
        let lineup = scene_features(&load("lineup.toml"));
        assert!(lineup.contains(&"BVH_SPHERES"), "{lineup:?}");
        let mut rr = load("cornell-box.toml");
        rr.integrator.russian_roulette = true;
        assert!(scene_features(&rr).contains(&"RUSSIAN_ROULETTE"));
        let mut none = load("cornell-box.toml");
        none.triangles.clear();
        assert!(
            scene_features(&none).contains(&"BVH_TRIANGLES"),
            "an empty scene still compiles"
        );
    }

    /// Every (pixel, sample) pair lies in exactly one wave, in sample order per pixel, and no
    /// wave is larger than `wave_paths`.
    fn check(pixels: u32, spp: u32, wave_paths: u32) -> Vec<Wave> {
        let w: Vec<Wave> = waves(pixels, 0..spp, wave_paths).collect();
        let mut seen = vec![0u32; (pixels * spp) as usize];
        let mut next_sample = vec![0u32; pixels as usize];
        let mut done = 0;
        for x in &w {
            assert!(x.pixels * x.samples <= wave_paths, "{x:?}");
            assert!(x.samples_done >= done, "progress goes back: {x:?}");
            done = x.samples_done;
            for s in x.sample..x.sample + x.samples {
                for p in x.offset..x.offset + x.pixels {
                    seen[(s * pixels + p) as usize] += 1;
                    assert_eq!(next_sample[p as usize], s, "pixel {p} out of order");
                    next_sample[p as usize] += 1;
                }
            }
        }
        assert!(
            seen.iter().all(|&c| c == 1),
            "{pixels} px × {spp} spp, wave_paths {wave_paths}"
        );
        assert_eq!(done, spp);
        w
    }

    #[test]
    fn waves_cover_every_pixel_sample_once() {
        // Whole image, several samples per wave, last wave shorter.
        assert_eq!(check(480, 5, 960).len(), 3);
        // Chunks of the image, the last one partial.
        assert_eq!(check(480, 3, 64).len(), 3 * 8);
        // Exactly one wave; one pixel; wave_paths equal to the image.
        assert_eq!(check(100, 4, 1 << 20).len(), 1);
        check(1, 7, 64);
        check(640, 2, 640);
    }
}
