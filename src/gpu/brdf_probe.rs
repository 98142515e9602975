//! Evaluating and sampling one material's GLSL BRDF on the GPU (`shaders/brdf_probe.comp`), for
//! `brdfwave brdf eval --backend gpu` and the GPU-vs-CPU BRDF parity tests.

use crate::brdf::{BrdfSample, Material, MODELS};
use crate::gpu::interface::{self, glsl_block, Field, GlslType, ProbeBinding};
use crate::gpu::layout::Binding;
use crate::gpu::scene_buffers;
use crate::vk::{Buffer, Context, Resource, ShaderCompiler};
use anyhow::Result;
use ash::vk;
use glam::{Vec2, Vec3};
use gpu_allocator::MemoryLocation;

glsl_block! {
    /// The probe's push constants (GLSL `pc`).
    pub struct Push {
        /// items in the inputs
        pub count: u32,
        /// MODE_*
        pub mode: u32,
        /// mode 2: evaluations per invocation
        pub reps: u32,
    }
}

/// The probe's bindings, in slot order; the shader's declarations are generated from this list
/// ([`interface::probe_glsl`]) and the pipeline's descriptor types read from it. The measured
/// table is bound (and declared) only for a measured material.
const BINDINGS: [ProbeBinding; 4] = [
    ProbeBinding::Storage {
        block: "Mat",
        member: "Material material",
        access: "readonly",
        about: "the material's record",
    },
    ProbeBinding::Storage {
        block: "Inputs",
        member: "vec4 inputs[]",
        access: "readonly",
        about: "2 vec4 per item",
    },
    ProbeBinding::Storage {
        block: "Outputs",
        member: "vec4 outputs[]",
        access: "writeonly",
        about: "2 vec4 per item",
    },
    ProbeBinding::Layout(Binding::MeasuredTable),
];

/// The generated header's name among the shader sources.
const HEADER: &str = "brdf_probe/interface.glsl";

const MODE_EVAL: u32 = 0;
const MODE_SAMPLE: u32 = 1;
const MODE_COST: u32 = 2;
const MODE_MATH: u32 = 3;
/// Evaluations per invocation in the cost mode (He's at most 849 loop iterations each keep the
/// invocation within lavapipe's 65,535: docs/loops.md).
const COST_REPS: u32 = 64;

/// The probe kernel compiled for one material's model.
struct Probe<'a> {
    ctx: &'a Context,
    pipeline: Option<crate::vk::ComputePipeline>,
    material: &'a Material,
}

impl<'a> Probe<'a> {
    fn new(ctx: &'a Context, compiler: &ShaderCompiler, m: &'a Material) -> Result<Self> {
        let name = MODELS[m.model].name;
        let (defines, overrides) = crate::gpu::model_shader_inputs(m.model, m.brdf.defines());
        let header = interface::probe_glsl("BRDF_PROBE_INTERFACE", &BINDINGS, Push::FIELDS);
        let generated = [(HEADER.to_string(), header)];
        let spirv = compiler
            .compile_generated("brdf_probe.comp", &defines, &overrides, &generated)?
            .spirv;
        let bound = if m.brdf.measured().is_some() { 4 } else { 3 };
        let kinds: Vec<_> = BINDINGS[..bound]
            .iter()
            .map(|b| b.descriptor_type())
            .collect();
        let push_bytes = std::mem::size_of::<Push>() as u32;
        let pipeline =
            ctx.create_compute_pipeline_with(&format!("probe_{name}"), &spirv, &kinds, push_bytes)?;
        Ok(Probe {
            ctx,
            pipeline: Some(pipeline),
            material: m,
        })
    }

    /// Runs the kernel over `inputs`; returns the outputs and the kernel's GPU time in seconds
    /// (timestamps).
    fn run(&self, inputs: &[[f32; 4]], mode: u32, reps: u32) -> Result<(Vec<[f32; 4]>, f64)> {
        let mut buffers = Vec::new();
        let result = self.run_with(&mut buffers, inputs, mode, reps);
        for b in buffers {
            self.ctx.destroy_buffer(b);
        }
        result
    }

    /// [`Probe::run`] with the buffers it creates pushed to `buffers` (the caller destroys
    /// them): the material record, the inputs, the outputs, and a measured material's table.
    fn run_with(
        &self,
        buffers: &mut Vec<Buffer>,
        inputs: &[[f32; 4]],
        mode: u32,
        reps: u32,
    ) -> Result<(Vec<[f32; 4]>, f64)> {
        let ctx = self.ctx;
        let pipeline = self.pipeline.as_ref().expect("live probe");
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let materials = std::slice::from_ref(self.material);
        let record = scene_buffers::material_records_of(materials);
        buffers.push(ctx.create_buffer_with_data("probe_material", &record, storage)?);
        buffers.push(ctx.create_buffer_with_data("probe_inputs", inputs, storage)?);
        // Device memory, read back through a staging copy: written to host memory, the kernel
        // would time PCIe writes on a discrete GPU rather than the BRDF.
        let bytes = (inputs.len() * 16) as u64;
        let gpu = MemoryLocation::GpuOnly;
        buffers.push(ctx.create_buffer("probe_outputs", bytes, storage, gpu)?);
        let measured = self.material.brdf.measured().is_some();
        let view = if measured {
            let texels = scene_buffers::MeasuredTables::of(materials).texels();
            let usage = vk::BufferUsageFlags::STORAGE_TEXEL_BUFFER;
            buffers.push(ctx.create_buffer_with_data("probe_table", &texels, usage)?);
            Some(ctx.create_buffer_view(&buffers[3], vk::Format::R32G32B32A32_SFLOAT)?)
        } else {
            None
        };
        let result = (|| {
            let mut resources: Vec<Resource> = buffers[..3].iter().map(Resource::Buffer).collect();
            if let Some(v) = view {
                resources.push(Resource::Texels(&buffers[3], v));
            }
            let set = ctx.create_descriptor_set_with(pipeline, &resources)?;
            let mut rec = ctx.begin()?;
            rec.bind(pipeline, set);
            let count = (inputs.len() / 2) as u32;
            rec.push_constants(pipeline, &Push { count, mode, reps });
            rec.timestamp("begin");
            rec.dispatch(count.div_ceil(pipeline.local_size_x), 1, 1);
            rec.timestamp("end");
            ctx.submit_and_wait(rec)?;
            let stamps = ctx.read_timestamps()?;
            let seconds = stamps.last().map(|s| s.1).unwrap_or(0.0)
                - stamps.first().map(|s| s.1).unwrap_or(0.0);
            Ok((ctx.download(&buffers[2])?, seconds))
        })();
        if let Some(v) = view {
            ctx.destroy_buffer_view(v);
        }
        result
    }
}

impl Drop for Probe<'_> {
    fn drop(&mut self) {
        if let Some(p) = self.pipeline.take() {
            self.ctx.destroy_pipeline(p);
        }
    }
}

fn run(
    ctx: &Context,
    compiler: &ShaderCompiler,
    m: &Material,
    inputs: &[[f32; 4]],
    mode: u32,
    reps: u32,
) -> Result<(Vec<[f32; 4]>, f64)> {
    Probe::new(ctx, compiler, m)?.run(inputs, mode, reps)
}

/// f(wi, wo) and pdf(given = wi, sampled = wo) for each pair, on the GPU.
pub fn eval(
    ctx: &Context,
    compiler: &ShaderCompiler,
    m: &Material,
    pairs: &[(Vec3, Vec3)],
) -> Result<Vec<(Vec3, f32)>> {
    let mut inputs = Vec::with_capacity(pairs.len() * 2);
    for (wi, wo) in pairs {
        inputs.push([wi.x, wi.y, wi.z, 0.0]);
        inputs.push([wo.x, wo.y, wo.z, 0.0]);
    }
    let (out, _) = run(ctx, compiler, m, &inputs, MODE_EVAL, 0)?;
    Ok(out
        .chunks(2)
        .map(|c| (Vec3::new(c[0][0], c[0][1], c[0][2]), c[0][3]))
        .collect())
}

/// A GLSL helper for each `(x, y)` on the GPU, compiled with material `m`'s model: `op` 0
/// `erfc(x)`, 1 `expm1_f(x)`, 2 `log1p_f(x)`, 3 `pow_one_minus(x, y)`, 4 `he_series(x, y)`
/// (a He material with σ₀ > 0 only; 0 otherwise). For `brdfwave stress`.
pub fn math(
    ctx: &Context,
    compiler: &ShaderCompiler,
    m: &Material,
    op: u32,
    inputs: &[(f32, f32)],
) -> Result<Vec<f32>> {
    let raw: Vec<[f32; 4]> = inputs
        .iter()
        .flat_map(|&(x, y)| [[x, y, op as f32, 0.0], [0.0; 4]])
        .collect();
    let (out, _) = run(ctx, compiler, m, &raw, MODE_MATH, 0)?;
    Ok(out.chunks(2).map(|c| c[0][0]).collect())
}

/// `sample(given, u_lobe, u)` for each input, on the GPU.
pub fn sample(
    ctx: &Context,
    compiler: &ShaderCompiler,
    m: &Material,
    inputs: &[(Vec3, f32, Vec2)],
) -> Result<Vec<Option<BrdfSample>>> {
    let mut raw = Vec::with_capacity(inputs.len() * 2);
    for (g, ul, u) in inputs {
        raw.push([g.x, g.y, g.z, *ul]);
        raw.push([u.x, u.y, 0.0, 0.0]);
    }
    let (out, _) = run(ctx, compiler, m, &raw, MODE_SAMPLE, 0)?;
    Ok(out
        .chunks(2)
        .map(|c| {
            let flags = c[1][3] as u32;
            (flags & 1 != 0).then(|| BrdfSample {
                wi: Vec3::new(c[0][0], c[0][1], c[0][2]),
                pdf: c[0][3],
                weight: Vec3::new(c[1][0], c[1][1], c[1][2]),
                delta: flags & 2 != 0,
            })
        })
        .collect())
}

/// Nanoseconds per evaluation of f on the GPU, from GPU timestamps around the probe kernel in
/// its cost mode ([`COST_REPS`] evaluations per invocation over cosine-distributed random
/// direction pairs, one write each; uploads and pipeline creation excluded). A first small
/// dispatch warms the pipeline up (lavapipe compiles a shader to machine code at its first
/// dispatch, which its timestamps would otherwise include); then the number of invocations
/// grows until the kernel runs for at least 20 ms, so that the figure means the same on
/// lavapipe and on a large GPU.
pub fn eval_cost(ctx: &Context, compiler: &ShaderCompiler, m: &Material) -> Result<f64> {
    let probe = Probe::new(ctx, compiler, m)?;
    let inputs = |n: u32| -> Vec<[f32; 4]> {
        let mut v = Vec::with_capacity(2 * n as usize);
        for i in 0..n {
            let u = |d| crate::rng::random_f32(9, i, 0, 0, d);
            let s = crate::brdf::common::sample_cosine_hemisphere;
            let (a, b) = (s(Vec2::new(u(0), u(1))), s(Vec2::new(u(2), u(3))));
            v.push([a.x, a.y, a.z, 0.0]);
            v.push([b.x, b.y, b.z, 0.0]);
        }
        v
    };
    probe.run(&inputs(64), MODE_COST, COST_REPS)?;
    let mut n = 1u32 << 12;
    loop {
        let (_, seconds) = probe.run(&inputs(n), MODE_COST, COST_REPS)?;
        if seconds >= 0.02 || n >= 1 << 22 {
            return Ok(seconds * 1e9 / (n as f64 * COST_REPS as f64));
        }
        // Aim at 40 ms, at most 16 times more work per step.
        let grow = (0.04 / seconds.max(1e-7)).clamp(2.0, 16.0);
        n = ((n as f64 * grow) as u64).min(1 << 22) as u32;
    }
}
