//! The wavefront path tracer on Vulkan compute.
//!
//! The work comes in waves of up to `MAX_CAPACITY` paths: a small image takes several
//! consecutive samples of every pixel per wave (so that a large GPU has enough paths in flight),
//! a large one one sample of one chunk of pixels per wave. One command buffer holds one sample
//! pass over every chunk, or one wave of several samples:
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
//! Only the models the scene's materials use get a queue and a shade pipeline; features a
//! scene does not use are compiled out through the models' `#define`s. The algorithm and its
//! conventions (depth, MIS, random-number keys) are those of the CPU reference (`crate::cpu`).

pub mod brdf_probe;
pub mod scene_buffers;

use crate::brdf::MODELS;
use crate::bvh::Bvh;
use crate::lights::LightTable;
use crate::output::{mean_and_variance, nonfinite_stages, RenderOutput};
use crate::scene::Scene;
use crate::vk::{Buffer, ComputePipeline, Context, ShaderCompiler};
use anyhow::{bail, Context as _, Result};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::collections::BTreeSet;
use std::time::Instant;

/// Bytes of push constants (`Push` in state.glsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    bounce: u32,
    sample_index: u32,
    chunk_offset: u32,
    chunk_size: u32,
    phase: u32,
    queue_slot: u32,
    chunk_pixels: u32,
}

const NUM_BINDINGS: u32 = 22;
const LOCAL_SIZE: u32 = 64;
/// Most path slots in a wave: bounded by the 65535-workgroup dispatch limit and lavapipe's
/// 128 MiB storage-buffer range (the queue buffer holds (3 + models) × capacity indices).
pub const MAX_CAPACITY: u32 = 1 << 20;

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

pub struct GpuRenderer<'a> {
    ctx: &'a Context,
    scene: &'a Scene,
    buffers: Vec<Buffer>,
    generate: Kernel,
    prepare: Kernel,
    extend: Kernel,
    shadow: Kernel,
    accumulate: Kernel,
    /// (queue slot, model index, kernel)
    shade: Vec<(u32, usize, Kernel)>,
    capacity: u32,
    pub setup: SetupStats,
}

/// Buffer indices = binding numbers (state.glsl).
mod b {
    pub const FILM: usize = 20;
    pub const FILM2: usize = 21;
    pub const COUNTERS: usize = 18;
    pub const ARGS: usize = 19;
}

impl<'a> GpuRenderer<'a> {
    /// A renderer with the largest wave ([`MAX_CAPACITY`] paths). Larger waves were faster on
    /// every device measured: on lavapipe (2 cores) 2^20 paths gave 0.315 M paths/s against
    /// 0.263 M with 2^16 (Cornell box 256², 64 spp; fewer dispatches and barriers), and an H200
    /// needs about 2^20 paths in flight to fill.
    pub fn new(
        ctx: &'a Context,
        scene: &'a Scene,
        bvh: &Bvh,
        compiler: &ShaderCompiler,
    ) -> Result<Self> {
        Self::with_wave_paths(ctx, scene, bvh, compiler, MAX_CAPACITY)
    }

    /// A renderer that traces at most `wave_paths` paths at a time (64 ..= [`MAX_CAPACITY`]).
    /// The image does not depend on it: the random numbers are keyed on (pixel, sample, bounce,
    /// dimension) and the film adds each pixel's samples in sample order.
    pub fn with_wave_paths(
        ctx: &'a Context,
        scene: &'a Scene,
        bvh: &Bvh,
        compiler: &ShaderCompiler,
        wave_paths: u32,
    ) -> Result<Self> {
        check_wave_paths(wave_paths).context("wave size")?;
        let mut setup = SetupStats::default();
        let pixels = scene.width as u64 * scene.height as u64;
        // Path slots: all the samples that fit of the whole image, or one chunk of it.
        let spp = scene.integrator.spp.max(1) as u64;
        let wave = wave_paths as u64;
        let capacity = if pixels <= wave {
            (pixels * spp.min(wave / pixels.max(1))) as u32
        } else {
            wave_paths
        };
        setup.wave_paths = capacity;
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

        // Scene and state buffers, in binding order.
        let t_upload = Instant::now();
        let lights = LightTable::build(scene);
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let film_bytes = pixels * 16;
        let limit = ctx.limits.max_storage_buffer_range as u64;
        let queue_bytes = (3 + num_queues as u64) * capacity as u64 * 4;
        if film_bytes > limit || queue_bytes > limit {
            bail!(
                "image of {}x{} needs a {} MiB film buffer, over this device's storage-buffer range of {} MiB; render a smaller image",
                scene.width,
                scene.height,
                film_bytes >> 20,
                limit >> 20
            );
        }
        let cap = capacity as u64;
        let mut buffers = vec![
            ctx.create_buffer_with_data("bvh_nodes", scene_buffers::bvh_nodes(bvh), storage)?,
            ctx.create_buffer_with_data("bvh_prims", &bvh.prims, storage)?,
            ctx.create_buffer_with_data(
                "triangles",
                &scene_buffers::triangle_data(scene),
                storage,
            )?,
            ctx.create_buffer_with_data("spheres", &scene_buffers::sphere_data(scene), storage)?,
            ctx.create_buffer_with_data(
                "tri_attrs",
                &scene_buffers::triangle_attributes(scene),
                storage,
            )?,
            ctx.create_buffer_with_data(
                "materials",
                &scene_buffers::material_records(scene, &queue_slot),
                storage,
            )?,
            ctx.create_buffer_with_data("lights", &scene_buffers::light_data(&lights), storage)?,
            ctx.create_buffer_with_data(
                "emitters",
                &scene_buffers::emitter_data(scene, &lights),
                storage,
            )?,
            ctx.create_buffer_with_data(
                "globals",
                &scene_buffers::globals(scene, &lights, num_queues, capacity),
                storage,
            )?,
        ];
        let gpu = MemoryLocation::GpuOnly;
        for name in [
            "ray_o", "ray_d", "beta", "radiance", "hit_rec", "shadow_o", "shadow_d", "shadow_l",
        ] {
            buffers.push(ctx.create_buffer(name, cap * 16, storage, gpu)?);
        }
        buffers.push(ctx.create_buffer("queues", queue_bytes, storage, gpu)?);
        // Film and counters are read and written by every pass and read back once: device
        // memory, downloaded through a staging copy. (In host-visible memory, as first written,
        // each accumulate crossed PCIe on a discrete GPU: 71% of the render time at 1024² on an
        // H200; lavapipe cannot tell the difference.)
        buffers.push(ctx.create_buffer(
            "counters",
            (9 + 2 * num_queues as u64) * 4,
            storage | vk::BufferUsageFlags::TRANSFER_DST,
            gpu,
        )?);
        buffers.push(ctx.create_buffer(
            "args",
            (2 + num_queues as u64) * 16,
            storage | vk::BufferUsageFlags::INDIRECT_BUFFER,
            gpu,
        )?);
        for name in ["film", "film2"] {
            buffers.push(ctx.create_buffer(
                name,
                film_bytes,
                storage | vk::BufferUsageFlags::TRANSFER_DST,
                gpu,
            )?);
        }
        assert_eq!(buffers.len() as u32, NUM_BINDINGS);
        setup.seconds_upload = t_upload.elapsed().as_secs_f64();

        // Pipelines. On failure, everything made so far is destroyed before returning.
        let mut built: Vec<Kernel> = Vec::new();
        let result = Self::build_kernels(
            ctx, scene, &models, &buffers, compiler, &mut setup, &mut built,
        );
        if let Err(e) = result {
            for k in built {
                ctx.destroy_pipeline(k.pipeline);
            }
            for b in buffers {
                ctx.destroy_buffer(b);
            }
            return Err(e);
        }
        let mut it = built.into_iter();
        let mut next = || it.next().expect("five stage kernels");
        let (generate, prepare, extend, shadow, accumulate) =
            (next(), next(), next(), next(), next());
        let shade: Vec<(u32, usize, Kernel)> = it
            .enumerate()
            .map(|(slot, k)| (slot as u32, models[slot], k))
            .collect();

        Ok(GpuRenderer {
            ctx,
            scene,
            buffers,
            generate,
            prepare,
            extend,
            shadow,
            accumulate,
            shade,
            capacity,
            setup,
        })
    }

    /// Compile and create the stage pipelines (generate, prepare, extend, shadow, accumulate, in
    /// that order) and one shade pipeline per model in `models`, pushing each onto `built`.
    fn build_kernels(
        ctx: &Context,
        scene: &Scene,
        models: &[usize],
        buffers: &[Buffer],
        compiler: &ShaderCompiler,
        setup: &mut SetupStats,
        built: &mut Vec<Kernel>,
    ) -> Result<()> {
        // Device-wide defines, added to every stage: subgroup-aggregated queue pushes where the
        // device has subgroup ballots (see `queue_push` in state.glsl).
        let device_defines: Vec<(String, String)> = if ctx.features.subgroup_ballot {
            vec![("SUBGROUP_QUEUES".into(), "1".into())]
        } else {
            Vec::new()
        };
        let mut build = |name: &str,
                         file: &str,
                         mut defines: Vec<(String, String)>,
                         overrides: Vec<(String, String)>|
         -> Result<()> {
            defines.extend(device_defines.iter().cloned());
            let t = Instant::now();
            let spirv = compiler
                .compile(file, &defines, &overrides)
                .with_context(|| format!("compiling {file} for pipeline {name}"))?;
            setup.seconds_shader_compile += t.elapsed().as_secs_f64();
            let t = Instant::now();
            let pipeline = ctx.create_compute_pipeline(
                name,
                &spirv,
                NUM_BINDINGS,
                std::mem::size_of::<Push>() as u32,
            )?;
            setup.seconds_pipeline_create += t.elapsed().as_secs_f64();
            let refs: Vec<&Buffer> = buffers.iter().collect();
            let set = match ctx.create_descriptor_set(&pipeline, &refs) {
                Ok(set) => set,
                Err(e) => {
                    ctx.destroy_pipeline(pipeline);
                    return Err(e);
                }
            };
            setup.pipelines.push(name.to_string());
            built.push(Kernel { pipeline, set });
            Ok(())
        };
        build("generate", "wavefront/generate.comp", vec![], vec![])?;
        build("prepare", "wavefront/prepare.comp", vec![], vec![])?;
        build("extend", "wavefront/extend.comp", vec![], vec![])?;
        build("shadow", "wavefront/shadow.comp", vec![], vec![])?;
        build("accumulate", "wavefront/accumulate.comp", vec![], vec![])?;
        for &model in models {
            let name = MODELS[model].name;
            let mut defines: BTreeSet<&'static str> = BTreeSet::new();
            for m in scene
                .materials
                .iter()
                .filter(|m| m.model == model && m.brdf.scatters())
            {
                defines.extend(m.brdf.defines());
            }
            let (defs, overrides) = model_shader_inputs(model, defines);
            build(
                &format!("shade_{name}"),
                "wavefront/shade.comp",
                defs,
                overrides,
            )?;
        }
        Ok(())
    }

    /// Render `scene.integrator.spp` samples per pixel; `progress` gets the number of samples per
    /// pixel done after each wave.
    pub fn render(&mut self, progress: &dyn Fn(u32)) -> Result<RenderOutput> {
        let scene = self.scene;
        let pixels = scene.width * scene.height;
        let spp = scene.integrator.spp;
        let ctx = self.ctx;
        let mut rec = ctx.begin()?;
        rec.fill_buffer(&self.buffers[b::FILM], 0);
        rec.fill_buffer(&self.buffers[b::FILM2], 0);
        rec.fill_buffer(&self.buffers[b::COUNTERS], 0);
        ctx.submit_and_wait(rec)?;

        // The waves, in order: k samples of the whole image when it fits in a wave, else one
        // sample of one chunk of pixels. Consecutive waves share a command buffer (a batch) whose
        // size doubles while a submission takes under BATCH_SECONDS, so a fast GPU is not held
        // up by a wait per wave and a slow device still reports progress. A command buffer is
        // also split, between two segments, before its timestamp queries run out.
        let mut waves = waves(pixels, spp, self.capacity).peekable();
        let stamps_per_segment = 4 + self.shade.len() as u32;
        let mut stage_seconds: Vec<(String, f64)> = Vec::new();
        let mut batch = 1usize;
        while waves.peek().is_some() {
            let t_batch = Instant::now();
            let mut rec = ctx.begin()?;
            rec.timestamp("start");
            let mut samples_done = 0;
            for w in waves.by_ref().take(batch) {
                samples_done = w.samples_done;
                let mut push = Push {
                    sample_index: w.sample,
                    chunk_offset: w.offset,
                    chunk_size: w.pixels * w.samples,
                    chunk_pixels: w.pixels,
                    ..Default::default()
                };
                if rec.timestamps_left() < 2 + stamps_per_segment {
                    rec = self.resubmit(rec, &mut stage_seconds)?;
                }
                rec.bind(&self.generate.pipeline, self.generate.set);
                rec.push_constants(&self.generate.pipeline, &push);
                rec.dispatch(push.chunk_size.div_ceil(LOCAL_SIZE), 1, 1);
                rec.barrier();
                rec.timestamp("generate");
                for depth in 1..=scene.integrator.max_depth {
                    if rec.timestamps_left() < 1 + stamps_per_segment {
                        rec = self.resubmit(rec, &mut stage_seconds)?;
                    }
                    push.bounce = depth;
                    let args = &self.buffers[b::ARGS];
                    self.run_prepare(&mut rec, &mut push, 0);
                    rec.bind(&self.extend.pipeline, self.extend.set);
                    rec.push_constants(&self.extend.pipeline, &push);
                    rec.dispatch_indirect(args, 0);
                    rec.barrier();
                    rec.timestamp("extend");
                    if depth == scene.integrator.max_depth {
                        break;
                    }
                    self.run_prepare(&mut rec, &mut push, 1);
                    for (slot, _, kernel) in &self.shade {
                        push.queue_slot = *slot;
                        rec.bind(&kernel.pipeline, kernel.set);
                        rec.push_constants(&kernel.pipeline, &push);
                        rec.dispatch_indirect(args, (2 + *slot as u64) * 16);
                        rec.barrier();
                        rec.timestamp(&kernel.pipeline.name);
                    }
                    self.run_prepare(&mut rec, &mut push, 2);
                    rec.bind(&self.shadow.pipeline, self.shadow.set);
                    rec.push_constants(&self.shadow.pipeline, &push);
                    rec.dispatch_indirect(args, 16);
                    rec.barrier();
                    rec.timestamp("shadow");
                }
                if rec.timestamps_left() < 1 {
                    rec = self.resubmit(rec, &mut stage_seconds)?;
                }
                rec.bind(&self.accumulate.pipeline, self.accumulate.set);
                rec.push_constants(&self.accumulate.pipeline, &push);
                rec.dispatch(w.pixels.div_ceil(LOCAL_SIZE), 1, 1);
                rec.barrier();
                rec.timestamp("accumulate");
            }
            ctx.submit_and_wait(rec)?;
            add_stage_times(ctx.read_timestamps()?, &mut stage_seconds);
            progress(samples_done);
            if t_batch.elapsed().as_secs_f64() < BATCH_SECONDS {
                batch = (batch * 2).min(MAX_BATCH);
            }
        }

        let counters: Vec<u32> = ctx.download(&self.buffers[b::COUNTERS])?;
        let film: Vec<[f32; 4]> = ctx.download(&self.buffers[b::FILM])?;
        let film2: Vec<[f32; 4]> = ctx.download(&self.buffers[b::FILM2])?;
        let mut mean = crate::imageio::Image::new(scene.width, scene.height);
        let mut variance = crate::imageio::Image::new(scene.width, scene.height);
        for i in 0..pixels as usize {
            // The film holds sums of l·2^-k and (l·2^-k)², k in .w (accumulate.comp).
            let k = film[i][3] as i32;
            let (sc, sc2) = (2f64.powi(k), 2f64.powi(2 * k));
            let s = [0, 1, 2].map(|c| film[i][c] as f64 * sc);
            let s2 = [0, 1, 2].map(|c| film2[i][c] as f64 * sc2);
            let (m, v) = mean_and_variance(s, s2, spp);
            mean.data[i] = m;
            variance.data[i] = v;
        }
        // Running totals kept by the prepare kernel from the queue sizes.
        let extension_rays = counters[4] as u64 | (counters[5] as u64) << 32;
        let shadow_rays = counters[6] as u64 | (counters[7] as u64) << 32;
        // Non-finite values dropped where they arose (state.glsl lists the counters).
        let nq = self.shade.len();
        let nonfinite_by_stage = nonfinite_stages(
            counters[8 + nq] as u64,
            self.shade
                .iter()
                .map(|(slot, model, _)| (*model, counters[9 + nq + *slot as usize] as u64)),
            counters[3] as u64,
        );
        Ok(RenderOutput {
            mean,
            variance,
            spp,
            nonfinite_samples: nonfinite_by_stage.iter().map(|s| s.1).sum(),
            nonfinite_by_stage,
            extension_rays,
            shadow_rays,
            stage_seconds,
        })
    }

    /// Submits `rec` and waits, adds its stage times, and begins the next command buffer.
    fn resubmit<'c>(
        &self,
        rec: crate::vk::Recorder<'c>,
        stage_seconds: &mut Vec<(String, f64)>,
    ) -> Result<crate::vk::Recorder<'c>>
    where
        'a: 'c,
    {
        self.ctx.submit_and_wait(rec)?;
        add_stage_times(self.ctx.read_timestamps()?, stage_seconds);
        let mut rec = self.ctx.begin()?;
        rec.timestamp("start");
        Ok(rec)
    }

    fn run_prepare(&self, rec: &mut crate::vk::Recorder<'_>, push: &mut Push, phase: u32) {
        push.phase = phase;
        rec.bind(&self.prepare.pipeline, self.prepare.set);
        rec.push_constants(&self.prepare.pipeline, push);
        rec.dispatch(1, 1, 1);
        rec.barrier();
        rec.timestamp("prepare");
    }
}

impl Drop for GpuRenderer<'_> {
    fn drop(&mut self) {
        let ctx = self.ctx;
        for k in [
            &self.generate,
            &self.prepare,
            &self.extend,
            &self.shadow,
            &self.accumulate,
        ] {
            ctx.destroy_pipeline_ref(&k.pipeline);
        }
        for (_, _, k) in &self.shade {
            ctx.destroy_pipeline_ref(&k.pipeline);
        }
        for b in self.buffers.drain(..) {
            ctx.destroy_buffer(b);
        }
    }
}

/// A wave size [`GpuRenderer::with_wave_paths`] accepts: 64 ..= [`MAX_CAPACITY`] paths.
pub fn check_wave_paths(wave_paths: u32) -> Result<()> {
    if !(LOCAL_SIZE..=MAX_CAPACITY).contains(&wave_paths) {
        bail!("must be between {LOCAL_SIZE} and {MAX_CAPACITY} paths, got {wave_paths}");
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

/// The waves of a render of `spp` samples over `pixels` pixels with `capacity` path slots, in
/// order (an iterator: a long render at a high sample count holds no list of them).
fn waves(pixels: u32, spp: u32, capacity: u32) -> impl Iterator<Item = Wave> {
    let (mut sample, mut offset) = (0u32, 0u32);
    std::iter::from_fn(move || {
        if sample >= spp {
            return None;
        }
        if pixels <= capacity {
            let k = (capacity / pixels).min(spp - sample);
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
            let n = (pixels - offset).min(capacity);
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
    use super::{waves, Wave};

    /// Every (pixel, sample) pair lies in exactly one wave, in sample order per pixel, and no
    /// wave is larger than the capacity.
    fn check(pixels: u32, spp: u32, capacity: u32) -> Vec<Wave> {
        let w: Vec<Wave> = waves(pixels, spp, capacity).collect();
        let mut seen = vec![0u32; (pixels * spp) as usize];
        let mut next_sample = vec![0u32; pixels as usize];
        let mut done = 0;
        for x in &w {
            assert!(x.pixels * x.samples <= capacity, "{x:?}");
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
            "{pixels} px × {spp} spp, capacity {capacity}"
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
        // Exactly one wave; one pixel; capacity equal to the image.
        assert_eq!(check(100, 4, 1 << 20).len(), 1);
        check(1, 7, 64);
        check(640, 2, 640);
    }
}
