//! Evaluating and sampling one material's GLSL BRDF on the GPU (`shaders/brdf_probe.comp`), for
//! `brdfwave brdf eval --backend gpu` and the GPU-vs-CPU BRDF parity tests.

use crate::brdf::{BrdfSample, Material, MODELS};
use crate::gpu::scene_buffers;
use crate::vk::{Context, ShaderCompiler};
use anyhow::Result;
use ash::vk;
use glam::{Vec2, Vec3};
use gpu_allocator::MemoryLocation;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    count: u32,
    mode: u32,
}

/// Runs the probe kernel; returns the outputs and the kernel's GPU time in seconds (timestamps).
fn run(
    ctx: &Context,
    compiler: &ShaderCompiler,
    m: &Material,
    inputs: &[[f32; 4]],
    mode: u32,
) -> Result<(Vec<[f32; 4]>, f64)> {
    let name = MODELS[m.model].name;
    let mut defines: Vec<(String, String)> = m
        .brdf
        .defines()
        .into_iter()
        .map(|d| (d.to_string(), "1".to_string()))
        .collect();
    defines.push(("BRDF_EVAL".into(), format!("{name}_eval")));
    defines.push(("BRDF_PDF".into(), format!("{name}_pdf")));
    defines.push(("BRDF_SAMPLE".into(), format!("{name}_sample")));
    let overrides = vec![("brdf/model.glsl".to_string(), format!("brdf/{name}.glsl"))];
    let spirv = compiler.compile("brdf_probe.comp", &defines, &overrides)?;
    let pipeline = ctx.create_compute_pipeline(&format!("probe_{name}"), &spirv, 3, 8)?;
    let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
    let record = scene_buffers::material_records_of(std::slice::from_ref(m));
    let mat = ctx.create_buffer_with_data("probe_material", &record, storage)?;
    let inp = ctx.create_buffer_with_data("probe_inputs", inputs, storage)?;
    let out = ctx.create_buffer(
        "probe_outputs",
        (inputs.len() * 16) as u64,
        storage,
        MemoryLocation::GpuToCpu,
    )?;
    let set = ctx.create_descriptor_set(&pipeline, &[&mat, &inp, &out])?;
    let mut rec = ctx.begin()?;
    rec.bind(&pipeline, set);
    let count = (inputs.len() / 2) as u32;
    rec.push_constants(&pipeline, &Push { count, mode });
    rec.timestamp("begin");
    rec.dispatch(count.div_ceil(64), 1, 1);
    rec.timestamp("end");
    ctx.submit_and_wait(rec)?;
    let stamps = ctx.read_timestamps()?;
    let seconds =
        stamps.last().map(|s| s.1).unwrap_or(0.0) - stamps.first().map(|s| s.1).unwrap_or(0.0);
    let result: Vec<[f32; 4]> = ctx.download(&out)?;
    ctx.destroy_buffer(mat);
    ctx.destroy_buffer(inp);
    ctx.destroy_buffer(out);
    ctx.destroy_pipeline(pipeline);
    Ok((result, seconds))
}

/// f(wi, wo) and pdf(given = wi, sampled = wo) for each pair, on the GPU.
pub fn eval(
    ctx: &Context,
    compiler: &ShaderCompiler,
    m: &Material,
    pairs: &[(Vec3, Vec3)],
) -> Result<Vec<(Vec3, f32)>> {
    Ok(eval_timed(ctx, compiler, m, pairs)?.0)
}

/// [`eval`] plus the kernel's GPU time in seconds.
pub fn eval_timed(
    ctx: &Context,
    compiler: &ShaderCompiler,
    m: &Material,
    pairs: &[(Vec3, Vec3)],
) -> Result<(Vec<(Vec3, f32)>, f64)> {
    let mut inputs = Vec::with_capacity(pairs.len() * 2);
    for (wi, wo) in pairs {
        inputs.push([wi.x, wi.y, wi.z, 0.0]);
        inputs.push([wo.x, wo.y, wo.z, 0.0]);
    }
    let (out, seconds) = run(ctx, compiler, m, &inputs, 0)?;
    Ok((
        out.chunks(2)
            .map(|c| (Vec3::new(c[0][0], c[0][1], c[0][2]), c[0][3]))
            .collect(),
        seconds,
    ))
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
    let (out, _) = run(ctx, compiler, m, &raw, 1)?;
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
