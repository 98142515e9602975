// The wavefront integrator's buffers, shared by every stage. Rust side: src/gpu/mod.rs
// (`Binding`), which binds the same buffers to every pipeline in this order.
//
// Path state is structure-of-arrays, one entry per path slot of the current chunk; queues hold
// path indices only (the state never moves). Counters and indirect-dispatch arguments live in
// small buffers written by the one-thread `prepare` kernel.
#ifndef STATE_GLSL
#define STATE_GLSL
#extension GL_EXT_scalar_block_layout : require
#ifdef SUBGROUP_QUEUES
#extension GL_KHR_shader_subgroup_ballot : require
#endif
#include "common.glsl"
#include "rng.glsl"

#define BVH_BINDING 0
#include "bvh.glsl"

layout(std430, set = 0, binding = 4) readonly buffer TriAttrs { vec4 tri_attr[]; };  // 4 vec4 per triangle: (n0, u0), (n1, u1), (n2, u2), (v0, v1, v2, flags)
layout(std430, set = 0, binding = 5) readonly buffer Materials { Material materials[]; };
layout(std430, set = 0, binding = 6) readonly buffer Lights { uvec2 lights[]; };      // (prim ref, floatBits(cdf))
layout(std430, set = 0, binding = 7) readonly buffer Emitters { vec4 emitters[]; };   // radiance, lum(Le)/W

// Scene-wide values.
layout(scalar, set = 0, binding = 8) readonly buffer Globals {
    vec3 cam_origin;
    vec3 cam_forward;
    vec3 cam_right;   // scaled by tan(fov/2)·aspect
    vec3 cam_up;      // scaled by tan(fov/2)
    vec3 environment;
    uint num_lights;
    uint width;
    uint height;
    uint max_depth;
    uint seed;
    uint rr_enabled;
    uint rr_start_depth;
    uint num_queues;  // material queues in use
    uint capacity;    // path slots per chunk
} g;

// Path state (SoA).
layout(std430, set = 0, binding = 9) buffer RayO { vec4 ray_o[]; };      // xyz origin
layout(std430, set = 0, binding = 10) buffer RayD { vec4 ray_d[]; };     // xyz direction, w = pdf of the BSDF sample (0: camera/delta)
layout(std430, set = 0, binding = 11) buffer Beta { vec4 beta[]; };      // path throughput
layout(std430, set = 0, binding = 12) buffer Radiance { vec4 radiance[]; };
layout(std430, set = 0, binding = 13) buffer HitRec { uvec4 hit_rec[]; }; // prim, bary.x, bary.y, t (float bits)
layout(std430, set = 0, binding = 14) buffer ShadowO { vec4 shadow_o[]; }; // xyz origin, w = tmax
layout(std430, set = 0, binding = 15) buffer ShadowD { vec4 shadow_d[]; };
layout(std430, set = 0, binding = 16) buffer ShadowL { vec4 shadow_l[]; }; // unoccluded contribution

// Queues: [0, cap) and [cap, 2cap) ping-pong ray queues; [2cap, 3cap) shadow queue;
// [(3 + k)cap, (4 + k)cap) material queue k.
layout(std430, set = 0, binding = 17) buffer Queues { uint queues[]; };
// counters: 0,1 ray queues; 2 shadow queue; 3 non-finite samples dropped by `accumulate`; 4,5
// extension rays traced (low, high word); 6,7 shadow rays traced; 8 + k material queue k;
// 8 + num_queues non-finite values dropped by `extend`; 9 + num_queues + k by the shade kernel
// of material queue k.
layout(std430, set = 0, binding = 18) buffer Counters { uint counters[]; };
// Indirect dispatch arguments, 4 uints each (x, y, z, pad): 0 ray, 1 shadow, 2 + k material k.
layout(std430, set = 0, binding = 19) buffer Args { uvec4 args[]; };
// Film: running sums of radiance and radiance² per pixel.
layout(std430, set = 0, binding = 20) buffer Film { vec4 film[]; };
layout(std430, set = 0, binding = 21) buffer Film2 { vec4 film2[]; };

#define NUM_BINDINGS 22

#define COUNTER_RAY 0u
#define COUNTER_SHADOW 2u
#define COUNTER_NONFINITE 3u
#define COUNTER_EXT_TOTAL 4u
#define COUNTER_SHADOW_TOTAL 6u
#define COUNTER_MATERIAL 8u
#define ARGS_RAY 0u
#define ARGS_SHADOW 1u
#define ARGS_MATERIAL 2u
#define QUEUE_SHADOW 2u
#define QUEUE_MATERIAL 3u

// A wave traces chunk_size = chunk_pixels × k paths: k consecutive samples of the pixels
// [chunk_offset, chunk_offset + chunk_pixels). Small images take several samples per wave, so
// that a large GPU has enough paths in flight; large images take one sample of one chunk.
layout(push_constant) uniform Push {
    uint bounce;        // segment index d of the rays being traced / the vertex being shaded
    uint sample_index;  // sample of the wave's first path
    uint chunk_offset;  // first pixel of this chunk
    uint chunk_size;    // paths in this wave
    uint phase;         // prepare kernel: which arguments to write
    uint queue_slot;    // shade kernels: which material queue
    uint chunk_pixels;  // pixels in this chunk (chunk_size is a multiple)
} pc;

// Path slot p holds pixel chunk_offset + p mod chunk_pixels, sample sample_index + p / chunk_pixels.
uint path_pixel(uint path) { return pc.chunk_offset + path % pc.chunk_pixels; }
uint path_sample(uint path) { return pc.sample_index + path / pc.chunk_pixels; }

uint counter_nonfinite_extend() { return COUNTER_MATERIAL + g.num_queues; }
uint counter_nonfinite_shade(uint slot) { return COUNTER_MATERIAL + g.num_queues + 1u + slot; }

// Whether v is finite; if not, counts it at counter c (the caller then drops it). Reads the
// bits, which the compiler cannot assume away as it may isnan/isinf.
bool finite_or_count(vec3 v, uint c) {
    if (is_finite_v(v)) return true;
    atomicAdd(counters[c], 1u);
    return false;
}

uint ray_queue_in() { return (pc.bounce + 1u) & 1u; }  // segment 1 reads queue 0
uint ray_queue_out() { return pc.bounce & 1u; }

// Append a path index to queue q (counter c). With SUBGROUP_QUEUES (set where the device has
// subgroup ballots), the invocations of a subgroup that push to the same queue take their slots
// with one atomic between them: each round, those whose counter equals the first active
// invocation's get consecutive slots. Without it, one atomic per push. The image does not depend
// on queue order (random numbers are keyed on the path, not the slot).
void queue_push(uint q, uint c, uint path) {
#ifdef SUBGROUP_QUEUES
    for (;;) {
        if (c == subgroupBroadcastFirst(c)) {
            uvec4 mask = subgroupBallot(true);
            uint base = 0u;
            if (subgroupElect()) base = atomicAdd(counters[c], subgroupBallotBitCount(mask));
            base = subgroupBroadcastFirst(base);
            queues[q * g.capacity + base + subgroupBallotExclusiveBitCount(mask)] = path;
            return;
        }
    }
#else
    uint slot = atomicAdd(counters[c], 1u);
    queues[q * g.capacity + slot] = path;
#endif
}

float rand(uint path, uint bounce, uint dim) {
    return random_f32(g.seed, path_pixel(path), path_sample(path), bounce, dim);
}

#endif
