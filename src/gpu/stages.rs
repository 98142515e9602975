//! The wavefront stages and the order they run in, after the wavefront integrator of pbrt-v4
//! (Pharr, Jakob and Humphreys 2023, `src/pbrt/wavefront/integrator.cpp`): a wave is
//! `generate`, then per path segment `extend`, `shade` and `shadow`, each a kernel over its
//! own queue, and `accumulate`. The kernels are a table ([`Stage`]); which of them a render
//! runs is its [`Schedule`]; the recording below routes a segment by naming its stages in
//! order ([`Segment`]), and the queue, argument and phase numbers come from
//! [`super::layout`], which gives the shaders the same numbers.

use super::interface::Push;
use super::kernels::KernelId;
use super::layout::{Args, Binding, Counter, MegakernelPhase, Prepare, Queue, LOCAL_SIZE};
use super::{GpuRenderer, Integrator, SEGMENTS_PER_CHECK};
use crate::vk::Recorder;
use anyhow::{bail, Result};

/// The kernels, one shader each under `shaders/`; a per-model stage is compiled once per
/// shaded model, as pipeline `<name>_<model>`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Stage {
    /// Camera rays of the wave → ray queue 0.
    Generate,
    /// One thread: indirect arguments from the queue lengths ([`Prepare`] says which).
    Prepare,
    /// Closest hit; emission (MIS); route to the material's queue.
    Extend,
    /// Per model, over its material queue: NEE → shadow queue, BRDF sample → next ray queue.
    Shade,
    /// Per model, for a scene that shades one: `extend`, `shade` and `shadow` in one kernel.
    ExtendShade,
    /// Any hit of the shadow queue; adds the unoccluded light sample.
    Shadow,
    /// Film += the wave's samples, in sample order (one writer per pixel).
    Accumulate,
    /// Everything between `generate` and `accumulate`, one path per invocation.
    Megakernel,
}

impl Stage {
    /// Every stage (the table's tests go through them).
    #[cfg(test)]
    pub const ALL: [Stage; 8] = [
        Stage::Generate,
        Stage::Prepare,
        Stage::Extend,
        Stage::Shade,
        Stage::ExtendShade,
        Stage::Shadow,
        Stage::Accumulate,
        Stage::Megakernel,
    ];

    /// The pipeline's name (with `_<model>` for a per-model stage), and the label of its
    /// timestamps.
    pub fn name(self) -> &'static str {
        self.row().0
    }
    /// Its workgroup size (`local_size_x`), checked against the pipeline's.
    pub fn local_size(self) -> u32 {
        match self {
            Stage::Prepare => 1,
            _ => LOCAL_SIZE,
        }
    }
    /// Its shader, relative to `shaders/`.
    pub fn file(self) -> &'static str {
        self.row().1
    }
    fn row(self) -> (&'static str, &'static str) {
        match self {
            Stage::Generate => ("generate", "wavefront/generate.comp"),
            Stage::Prepare => ("prepare", "wavefront/prepare.comp"),
            Stage::Extend => ("extend", "wavefront/extend.comp"),
            Stage::Shade => ("shade", "wavefront/shade.comp"),
            Stage::ExtendShade => ("extend_shade", "wavefront/extend_shade.comp"),
            Stage::Shadow => ("shadow", "wavefront/shadow.comp"),
            Stage::Accumulate => ("accumulate", "wavefront/accumulate.comp"),
            Stage::Megakernel => ("megakernel", "wavefront/megakernel.comp"),
        }
    }
}

/// A material queue and the model its paths are shaded with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct ModelQueue {
    /// The material queue (`layout::Queue::material`), and the model's position among the
    /// scene's shaded models.
    pub slot: u32,
    /// Index into `brdf::MODELS`.
    pub model: usize,
}

/// The shade kernel of one model.
#[derive(Clone, Copy, Debug)]
pub(super) struct ShadeKernel {
    pub queue: ModelQueue,
    pub kernel: KernelId,
}

/// The kernels every wavefront schedule starts a wave and a segment with.
#[derive(Clone, Copy, Debug)]
pub(super) struct WaveKernels {
    pub generate: KernelId,
    pub prepare: KernelId,
}

/// Which kernels a render runs between a wave's start and `accumulate`.
#[derive(Clone, Debug)]
pub(super) enum Schedule {
    /// The separate stages, with a material queue per model and a shadow queue between them.
    Wavefront {
        base: WaveKernels,
        extend: KernelId,
        shade: Vec<ShadeKernel>,
        shadow: KernelId,
    },
    /// A scene that shades one model: `extend_shade` hits, shades and traces the shadow ray
    /// (no material or shadow queue: with one model they only cost). Several models behind
    /// `brdf/any.glsl`'s switch in one such kernel measured no faster than the stages
    /// (docs/bench-log.md).
    Fused {
        base: WaveKernels,
        extend_shade: ShadeKernel,
    },
    /// One kernel per wave that follows each path to its end (`brdfwave bench`'s baseline).
    Megakernel {
        kernel: KernelId,
        /// The queue slots it counts each model's non-finite values at, as the shade stages.
        models: Vec<ModelQueue>,
    },
}

/// Whether a render with `integrator` (resolved) of a scene that shades `models` models runs
/// the separate stages ([`Schedule::Wavefront`]): the only schedule that passes hit records and
/// shadow rays between kernels through buffers ([`Binding::is_stage_record`]). With one model
/// the wavefront is [`Schedule::Fused`]. `kernels::build_kernels` chooses by it, and
/// `kernels::create_buffers` sizes those buffers by it.
pub(super) fn separate_stages(integrator: Integrator, models: usize) -> bool {
    integrator != Integrator::Megakernel && models != 1
}

impl Schedule {
    /// The models shaded and their queues (the non-finite counters read per model).
    pub fn models(&self) -> Vec<ModelQueue> {
        match self {
            Schedule::Wavefront { shade, .. } => shade.iter().map(|k| k.queue).collect(),
            Schedule::Fused { extend_shade, .. } => vec![extend_shade.queue],
            Schedule::Megakernel { models, .. } => models.clone(),
        }
    }
}

#[derive(Clone, Copy, Debug)]
pub(super) enum Dispatch {
    Groups(u32),
    /// Indirect, from this slot of the `args` buffer.
    Indirect(Args),
    /// Indirect, from the slot of this material queue.
    IndirectMaterial(u32),
}

/// One dispatch: a kernel, how many invocations, and the push constants that select what it
/// does (the `prepare` phase, the material queue of a shade kernel).
#[derive(Clone, Copy, Debug)]
struct Step {
    kernel: KernelId,
    how: Dispatch,
    phase: u32,
    queue_slot: u32,
}

/// The dispatches of one segment, in order, each added by the method of its stage.
struct Segment {
    prepare: KernelId,
    steps: Vec<Step>,
}

impl Segment {
    fn new(base: WaveKernels) -> Self {
        Segment {
            prepare: base.prepare,
            steps: Vec::new(),
        }
    }
    fn step(&mut self, kernel: KernelId, how: Dispatch, phase: u32, queue_slot: u32) {
        self.steps.push(Step {
            kernel,
            how,
            phase,
            queue_slot,
        });
    }
    /// `prepare`, writing the arguments of the stage that comes next.
    fn prepare(&mut self, phase: Prepare) {
        self.step(self.prepare, Dispatch::Groups(1), phase.index(), 0);
    }
    /// The closest hits of the segment's rays (`extend`, or `extend_shade`).
    fn extend(&mut self, kernel: KernelId) {
        self.prepare(Prepare::Extend);
        self.step(kernel, Dispatch::Indirect(Args::Ray), 0, 0);
    }
    /// Each model's shade kernel over its material queue.
    fn shade(&mut self, shade: &[ShadeKernel]) {
        self.prepare(Prepare::Shade);
        for k in shade {
            let slot = k.queue.slot;
            self.step(k.kernel, Dispatch::IndirectMaterial(slot), 0, slot);
        }
    }
    /// The any-hit tests of the shadow queue.
    fn shadow(&mut self, kernel: KernelId) {
        self.prepare(Prepare::Shadow);
        self.step(kernel, Dispatch::Indirect(Args::Shadow), 0, 0);
    }
}

impl<'a> GpuRenderer<'a> {
    /// The dispatches of a segment; the last one (`max_depth`) ends every path at its hit.
    fn segment(&self, last: bool) -> Segment {
        match &self.schedule {
            Schedule::Wavefront {
                base,
                extend,
                shade,
                shadow,
            } => {
                let mut s = Segment::new(*base);
                s.extend(*extend);
                if !last {
                    s.shade(shade);
                    s.shadow(*shadow);
                }
                s
            }
            Schedule::Fused { base, extend_shade } => {
                let mut s = Segment::new(*base);
                s.extend(extend_shade.kernel);
                s
            }
            Schedule::Megakernel { .. } => unreachable!("the megakernel has no segments"),
        }
    }

    /// Records one wave of the wavefront integrator: `generate`, then the segments. With
    /// `report`, each segment is submitted on its own and `report` gets the fraction of the
    /// wave's segments done.
    pub(super) fn record_wave<'r>(
        &mut self,
        mut rec: Recorder<'r>,
        mut push: Push,
        report: Option<&dyn Fn(f64)>,
    ) -> Result<Recorder<'r>>
    where
        'a: 'r,
    {
        let max_depth = self.scene.integrator.max_depth;
        let generate = match &self.schedule {
            Schedule::Wavefront { base, .. } | Schedule::Fused { base, .. } => base.generate,
            Schedule::Megakernel { .. } => unreachable!("a wavefront wave of the megakernel"),
        };
        rec = self.ensure_timestamps(rec, 1)?;
        let groups = push.wave_size.div_ceil(LOCAL_SIZE);
        self.dispatch(&mut rec, generate, &push, Dispatch::Groups(groups));
        let mut check = CheckSchedule::new();
        let mut progress = ProgressSchedule::new();
        for depth in 1..=max_depth {
            // A deep render stops once every path has ended: the host looks at the queue of the
            // next segment after SEGMENTS_PER_CHECK segments, then at doubling intervals.
            if max_depth > SEGMENTS_PER_CHECK && check.due(depth) {
                rec = self.resubmit(rec)?;
                let counters: Vec<u32> = self.ctx.download(self.owned.buffer(Binding::Counters))?;
                if counters[self.counters.ray_queue(Queue::ray_in(depth))] == 0 {
                    break;
                }
            }
            push.depth = depth;
            let segment = self.segment(depth == max_depth);
            rec = self.ensure_timestamps(rec, segment.steps.len() as u32)?;
            for step in segment.steps {
                push.phase = step.phase;
                push.queue_slot = step.queue_slot;
                self.dispatch(&mut rec, step.kernel, &push, step.how);
            }
            if let Some(report) = report.filter(|_| depth < max_depth) {
                if progress.due() {
                    rec = self.resubmit(rec)?;
                    progress.submitted();
                    report(depth as f64 / max_depth as f64);
                }
            }
        }
        Ok(rec)
    }

    /// Records one wave of the megakernel: every path from the camera to its end. A path the
    /// driver's loop budget stops is saved and resumed by another dispatch (megakernel.comp):
    /// in a deep render (`max_depth` over [`SEGMENTS_PER_CHECK`]) the host waits after each
    /// dispatch and dispatches again while any path is left; in a shallow one, where that would
    /// take a segment of thousands of loop iterations, [`Self::check_loops`] reports it.
    pub(super) fn record_megakernel_wave<'r>(
        &mut self,
        mut rec: Recorder<'r>,
        mut push: Push,
    ) -> Result<Recorder<'r>>
    where
        'a: 'r,
    {
        let Schedule::Megakernel { kernel, .. } = self.schedule else {
            unreachable!("a megakernel wave of the wavefront schedule")
        };
        let groups = push.wave_size.div_ceil(LOCAL_SIZE);
        let c = self.counters;
        let mut segments = None;
        push.phase = MegakernelPhase::Start.index();
        loop {
            rec = self.ensure_timestamps(rec, 1)?;
            self.dispatch(&mut rec, kernel, &push, Dispatch::Groups(groups));
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
            push.phase = MegakernelPhase::Resume.index();
        }
    }

    /// Records `accumulate` for one wave.
    pub(super) fn record_accumulate<'r>(
        &mut self,
        rec: Recorder<'r>,
        push: &Push,
    ) -> Result<Recorder<'r>>
    where
        'a: 'r,
    {
        let mut rec = self.ensure_timestamps(rec, 1)?;
        let groups = push.chunk_pixels.div_ceil(LOCAL_SIZE);
        self.dispatch(&mut rec, self.accumulate, push, Dispatch::Groups(groups));
        Ok(rec)
    }

    /// Bind, push constants, dispatch, barrier, timestamp (labelled with the pipeline's name):
    /// every stage goes through here.
    fn dispatch(&self, rec: &mut Recorder<'_>, kernel: KernelId, push: &Push, how: Dispatch) {
        let k = self.owned.kernel(kernel);
        rec.bind(&k.pipeline, k.set);
        rec.push_constants(&k.pipeline, push);
        let args = self.owned.buffer(Binding::Args);
        match how {
            Dispatch::Groups(n) => rec.dispatch(n, 1, 1),
            Dispatch::Indirect(slot) => rec.dispatch_indirect(args, slot.index() as u64 * 16),
            Dispatch::IndirectMaterial(k) => {
                rec.dispatch_indirect(args, Args::material(k) as u64 * 16)
            }
        }
        rec.barrier();
        rec.timestamp(&k.pipeline.name);
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
}

#[cfg(test)]
mod tests {
    use super::Stage;

    /// Every stage has its own name and an embedded shader that says its local size.
    #[test]
    fn the_stage_table_names_each_kernel_once_and_its_shader_exists() {
        let c = crate::vk::ShaderCompiler::new()
            .unwrap()
            .with_embedded_shaders();
        for (i, s) in Stage::ALL.iter().enumerate() {
            assert!(Stage::ALL[..i]
                .iter()
                .all(|t| t.name() != s.name() && t.file() != s.file()));
            let text = c.read_source(s.file()).unwrap();
            let size = match s.local_size() {
                1 => "layout(local_size_x = 1) in;",
                _ => "layout(local_size_x = LOCAL_SIZE) in;",
            };
            assert!(text.contains(size), "{} does not declare {size}", s.file());
        }
    }
}

/// Most segments between two looks at the queues in a deep render ([`CheckSchedule`]).
const MAX_SEGMENTS_PER_CHECK: u32 = 1024;

/// When a deep wave looks whether any path is left: before segment `SEGMENTS_PER_CHECK + 1`,
/// then after twice as many segments each time, up to [`MAX_SEGMENTS_PER_CHECK`]. Every look is
/// a submission and a download the host waits for; a look every 16 segments made a path of 2^20
/// segments wait 65,536 times. Segments recorded after the
/// last path ended have empty queues and change nothing; doubling keeps them fewer than the
/// segments before the look that found the queue empty.
struct CheckSchedule {
    next: u32,
    interval: u32,
}

impl CheckSchedule {
    fn new() -> Self {
        CheckSchedule {
            next: SEGMENTS_PER_CHECK + 1,
            interval: SEGMENTS_PER_CHECK,
        }
    }

    /// Whether to look before recording segment `depth` (called for every depth in order).
    fn due(&mut self, depth: u32) -> bool {
        if depth != self.next {
            return false;
        }
        self.interval = (self.interval * 2).min(MAX_SEGMENTS_PER_CHECK);
        self.next = depth.saturating_add(self.interval);
        true
    }
}

/// Most segments per submission while a single wave reports progress ([`ProgressSchedule`]).
const MAX_SEGMENTS_PER_REPORT: u32 = 1024;

/// How often a single-wave render (a slow device, or a deep path) submits to report progress:
/// after one segment, then after twice as many segments while a submission took under
/// [`super::BATCH_SECONDS`] (as the batches of waves grow), so that progress moves several
/// times a second without a wait for every segment of a deep path.
struct ProgressSchedule {
    per_report: u32,
    pending: u32,
    since: std::time::Instant,
}

impl ProgressSchedule {
    fn new() -> Self {
        ProgressSchedule {
            per_report: 1,
            pending: 0,
            since: std::time::Instant::now(),
        }
    }

    /// Called after each segment: whether to submit and report now.
    fn due(&mut self) -> bool {
        self.pending += 1;
        self.pending >= self.per_report
    }

    /// Called after the submission: the next interval.
    fn submitted(&mut self) {
        if self.since.elapsed().as_secs_f64() < super::BATCH_SECONDS {
            self.per_report = (self.per_report * 2).min(MAX_SEGMENTS_PER_REPORT);
        }
        self.pending = 0;
        self.since = std::time::Instant::now();
    }
}

#[cfg(test)]
mod schedule_tests {
    use super::*;

    #[test]
    fn checks_start_after_the_first_segments_and_double_up_to_the_cap() {
        let mut c = CheckSchedule::new();
        let looks: Vec<u32> = (1..=5000).filter(|&d| c.due(d)).collect();
        assert_eq!(&looks[..5], &[17, 49, 113, 241, 497]);
        assert!(looks
            .windows(2)
            .all(|w| w[1] - w[0] <= MAX_SEGMENTS_PER_CHECK));
        assert_eq!(
            looks[looks.len() - 1] - looks[looks.len() - 2],
            MAX_SEGMENTS_PER_CHECK
        );
        // 2^20 segments: a few hundred looks, not 65,536.
        let mut c = CheckSchedule::new();
        let n = (1..=1u32 << 20).filter(|&d| c.due(d)).count();
        assert!(n < 1100, "{n} looks");
    }
}
