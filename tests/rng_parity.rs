//! The counter-based random numbers of every sampler (`multijitter`, `sobol`, `independent`) are
//! bit-identical in GLSL (`shaders/rng.glsl`) and Rust (`src/rng/`): the premise of the
//! same-seed GPU-vs-CPU image comparison.

mod common;
use ash::vk;
use brdfwave::rng;
use brdfwave::vk::ShaderCompiler;
use gpu_allocator::MemoryLocation;

const KERNEL: &str = r#"#version 460
#extension GL_GOOGLE_include_directive : require
#include "rng.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Keys { uvec4 keys[]; };   // seed, pixel, sample, (sobol unbatched << 24) | (pattern bits << 16) | (bounce << 8) | dim
layout(std430, set = 0, binding = 1) writeonly buffer Out { uint outs[]; };
layout(push_constant) uniform Push { uint count; } pc;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    uvec4 k = keys[i];
    uint bounce = (k.w >> 8u) & 255u;
    uint dim = k.w & 255u;
    uint bits = (k.w >> 16u) & 255u;
    uint sobol_bits = (k.w >> 24u) != 0u ? 32u : bits;
    outs[8u * i] = random_u32(k.x, k.y, k.z, bounce, dim);
    outs[8u * i + 1u] = floatBitsToUint(random_f32(k.x, k.y, k.z, bounce, dim));
    outs[8u * i + 2u] = sobol_u32(k.x, sobol_bits, k.y, k.z, bounce, dim);
    outs[8u * i + 3u] = floatBitsToUint(sobol_f32(k.x, sobol_bits, k.y, k.z, bounce, dim));
    vec2 pair = sobol_pair_f32(k.x, sobol_bits, k.y, k.z, bounce, dim & ~1u);
    outs[8u * i + 4u] = floatBitsToUint(pair.x);
    outs[8u * i + 5u] = floatBitsToUint(pair.y);
    outs[8u * i + 6u] = multijitter_u32(k.x, bits, k.y, k.z, bounce, dim);
    vec2 mj = multijitter_pair_f32(k.x, bits, k.y, k.z, bounce, dim & ~1u);
    outs[8u * i + 7u] = floatBitsToUint((dim & 1u) == 0u ? mj.x : mj.y);
}
"#;

#[test]
fn random_numbers_are_bit_identical_on_gpu_and_cpu() {
    let ctx = common::context();
    let compiler = ShaderCompiler::new()
        .unwrap()
        .with_source("test/rng_probe.comp", KERNEL)
        .unwrap();
    let spirv = compiler.compile("test/rng_probe.comp", &[], &[]).unwrap();
    let pipeline = ctx
        .create_compute_pipeline("rng_probe", &spirv, 2, 4)
        .unwrap();
    let keys: Vec<[u32; 4]> = (0..20_000u32)
        .map(|i| {
            let h = rng::pcg_hash(i);
            // Small sample indices, and every 5th one anywhere in 32 bits.
            let sample = if i % 5 == 0 {
                h.rotate_left(13)
            } else {
                i % 1031
            };
            // Pattern sizes 2^0 .. 2^24 (a sample past the pattern draws from a later one); the
            // same as sobol batches, and every third key sobol without batches.
            let bits = i % (rng::MULTIJITTER_MAX_BITS + 1);
            let unbatched = u32::from(i % 3 == 0);
            [
                h % 7,
                h.rotate_left(7),
                sample,
                (unbatched << 24) | (bits << 16) | ((i % 17) << 8) | (i % 7),
            ]
        })
        .collect();
    let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
    let kb = ctx.create_buffer_with_data("keys", &keys, storage).unwrap();
    let ob = ctx
        .create_buffer(
            "outs",
            keys.len() as u64 * 32,
            storage,
            MemoryLocation::GpuToCpu,
        )
        .unwrap();
    let set = ctx.create_descriptor_set(&pipeline, &[&kb, &ob]).unwrap();
    let mut rec = ctx.begin().unwrap();
    rec.bind(&pipeline, set);
    rec.push_constants(&pipeline, &(keys.len() as u32));
    rec.dispatch((keys.len() as u32).div_ceil(64), 1, 1);
    ctx.submit_and_wait(rec).unwrap();
    let outs: Vec<[u32; 8]> = ctx.download(&ob).unwrap();
    for (k, o) in keys.iter().zip(&outs) {
        let (b, d, bits) = ((k[3] >> 8) & 255, k[3] & 255, (k[3] >> 16) & 255);
        let sobol_bits = if k[3] >> 24 != 0 {
            rng::SOBOL_UNBATCHED
        } else {
            bits
        };
        assert_eq!(o[0], rng::random_u32(k[0], k[1], k[2], b, d), "key {k:?}");
        assert_eq!(
            o[1],
            rng::random_f32(k[0], k[1], k[2], b, d).to_bits(),
            "key {k:?}"
        );
        assert_eq!(
            o[2],
            rng::sobol_u32(k[0], sobol_bits, k[1], k[2], b, d),
            "sobol, key {k:?}"
        );
        assert_eq!(
            o[3],
            rng::sobol_f32(k[0], sobol_bits, k[1], k[2], b, d).to_bits(),
            "sobol, key {k:?}"
        );
        // A pair drawn together (rand2 / PathRng::get2) is the same two numbers.
        let pair = rng::PathRng::with_bits(rng::Sampler::Sobol, k[0], sobol_bits, k[1], k[2])
            .get2(b, d & !1);
        assert_eq!(
            [o[4], o[5]],
            [pair.x.to_bits(), pair.y.to_bits()],
            "pair, key {k:?}"
        );
        assert_eq!(
            o[6],
            rng::multijitter_u32(k[0], bits, k[1], k[2], b, d),
            "multijitter, key {k:?}"
        );
        // A render whose pattern has 2^bits points draws the same numbers, alone and in pairs.
        let path = rng::PathRng::new(rng::Sampler::Multijitter, k[0], 1 << bits, k[1], k[2]);
        assert_eq!(o[7], path.get(b, d).to_bits(), "multijitter, key {k:?}");
        let v = path.get2(b, d & !1);
        assert_eq!(
            o[7],
            if d & 1 == 0 { v.x } else { v.y }.to_bits(),
            "multijitter pair, key {k:?}"
        );
    }
    ctx.destroy_buffer(kb);
    ctx.destroy_buffer(ob);
    ctx.destroy_pipeline(pipeline);
    common::finish(ctx);
}
