// The wavefront integrator's state, shared by every stage. The bindings' declarations, the push
// constants, the Globals block, the numbers (BINDING_*, COUNTER_*, ARGS_*, QUEUE_*, PREPARE_*,
// LOCAL_SIZE) and the counter positions (counter_*) come from the header wavefront/interface.glsl,
// generated at pipeline build time from one description in Rust (src/gpu/layout.rs and
// src/gpu/interface.rs); this file adds the accessors.
//
// Path state is structure-of-arrays, one entry per path slot of the current wave; queues hold
// path indices only (the state never moves). Counters and indirect-dispatch arguments live in
// small buffers written by the one-thread `prepare` kernel.
#ifndef STATE_GLSL
#define STATE_GLSL
#extension GL_EXT_scalar_block_layout : require
#ifdef SUBGROUP_QUEUES
#extension GL_KHR_shader_subgroup_ballot : require
#endif
#include "wavefront/interface.glsl"
#include "common.glsl"
#include "rng.glsl"

#include "bvh.glsl"

// Scene data (read-only storage texel buffers, raw 32-bit words).
vec4 tri_attr(uint i) { return uintBitsToFloat(imageLoad(tri_attrs, int(i))); }
uvec2 light_entry(uint i) { return imageLoad(light_table, int(i)).xy; }
vec4 emitter(uint i) { return uintBitsToFloat(imageLoad(emitter_data, int(i))); }
Material load_material(uint i) {
    Material m;
    m.header = imageLoad(material_words, int(MATERIAL_TEXELS * i));
    for (int k = 0; k < MATERIAL_PARAMS; ++k) m.p[k] = uintBitsToFloat(imageLoad(material_words, int(MATERIAL_TEXELS * i) + 1 + k));
    return m;
}

// Path state (SoA) in storage texel buffers (an image load is a vector gather on lavapipe;
// src/gpu/layout.rs), read and written through the accessors below. Queues: the regions of
// src/gpu/layout.rs `Queue`, g.wave_paths entries each: QUEUE_RAY and QUEUE_RAY_1 ping-pong,
// QUEUE_SHADOW, then QUEUE_MATERIAL + k for material queue k.
#define STATE_ACCESSORS(name, img, T) \
    T name(uint p) { return imageLoad(img, int(p)); } \
    void name##_set(uint p, T v) { imageStore(img, int(p), v); }
STATE_ACCESSORS(ray_o, ray_o_img, vec4)
STATE_ACCESSORS(ray_d, ray_d_img, vec4)
STATE_ACCESSORS(beta, beta_img, vec4)
STATE_ACCESSORS(radiance, radiance_img, vec4)
STATE_ACCESSORS(hit_rec, hit_rec_img, uvec4)
STATE_ACCESSORS(shadow_o, shadow_o_img, vec4)
STATE_ACCESSORS(shadow_d, shadow_d_img, vec4)
STATE_ACCESSORS(shadow_l, shadow_l_img, vec4)
uint queue_entry(uint i) { return imageLoad(queue_img, int(i)).x; }
void queue_entry_set(uint i, uint path) { imageStore(queue_img, int(i), uvec4(path)); }

// Path slot p holds pixel chunk_offset + p mod chunk_pixels of the tile (the film's index),
// sample sample_index + p / chunk_pixels.
uint path_film_pixel(uint path) { return pc.chunk_offset + path % pc.chunk_pixels; }
// The path's pixel in the whole image, which keys its random numbers and places its camera ray.
uint path_pixel(uint path) {
    uint p = path_film_pixel(path);
#ifdef TILED
    p = (g.tile_y + p / g.tile_width) * g.width + g.tile_x + p % g.tile_width;
#endif
    return p;
}
uint path_sample(uint path) { return pc.sample_index + path / pc.chunk_pixels; }

// Whether v is finite; if not, counts it at counter c (the caller then drops it). Reads the
// bits, which the compiler cannot assume away as it may isnan/isinf.
bool finite_or_count(vec3 v, uint c) {
    if (is_finite_v(v)) return true;
    atomicAdd(counters[c], 1u);
    return false;
}

// The loop budget. Mesa 22.3's gallivm (lavapipe) ends every loop of a shader invocation once the
// invocation has made 65,535 loop iterations in all (LP_MAX_TGSI_LOOP_ITERATIONS, never reset),
// without any sign: the code after the loop runs as if the loop had ended. loops_intact() runs a
// loop of two iterations that the compiler cannot unroll (x = 1 -> 3 -> 7 is no induction
// variable of a constant step, and x starts from a uniform, min(g.width, 1) = 1): it makes both
// iterations iff the budget was not used up before it, that is iff no loop of this invocation
// has been cut short so far. (A loop counted by a plain `k < 2` would be unrolled, and then
// tell nothing.) Other drivers have no such limit, and it always returns true.
bool loops_intact() {
    uint x = min(g.width, 1u);
    while (x < 7u) x = 2u * x + 1u;
    return x == 7u;
}

// Run at the end of every wavefront kernel (after all its loops, on every path through it):
// counts an invocation whose loops were cut short, which the host reports as an error. Every loop
// of these kernels has a bound well below the budget (docs/loops.md), BVH traversal aside, whose
// iterations grow with the nodes a ray visits: this is what catches a traversal cut short.
void check_loops() {
    if (!loops_intact()) atomicAdd(counters[COUNTER_CUT_SHORT], 1u);
}

// The ray queue of this segment's rays and of the next segment's: QUEUE_RAY + 0 or 1 (segment 1
// reads QUEUE_RAY); the counter of ray queue q is COUNTER_RAY + q - QUEUE_RAY.
uint ray_queue_in() { return QUEUE_RAY + ((pc.depth + 1u) & 1u); }
uint ray_queue_out() { return QUEUE_RAY + (pc.depth & 1u); }
uint counter_ray_queue(uint q) { return COUNTER_RAY + (q - QUEUE_RAY); }

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
            queue_entry_set(q * g.wave_paths + base + subgroupBallotExclusiveBitCount(mask), path);
            return;
        }
    }
#else
    uint slot = atomicAdd(counters[c], 1u);
    queue_entry_set(q * g.wave_paths + slot, path);
#endif
}

// Adds n to the 64-bit count in counters c (low word) and c + 1 (high word).
void add_total64(uint c, uint n) {
    if (n == 0u) return;
    uint old = atomicAdd(counters[c], n);
    if (old + n < old) atomicAdd(counters[c + 1u], 1u);
}

// Counts one ray for every invocation with `traced` in the 64-bit counts at `total` and
// `segment`: one atomic per subgroup where the device has ballots.
void count_rays(uint total, uint segment, bool traced) {
#ifdef SUBGROUP_QUEUES
    uint n = subgroupBallotBitCount(subgroupBallot(traced));
    if (subgroupElect()) {
        add_total64(total, n);
        add_total64(segment, n);
    }
#else
    if (traced) {
        add_total64(total, 1u);
        add_total64(segment, 1u);
    }
#endif
}

// Counts one for every invocation with `yes` in the 64-bit count at `total`: one atomic per
// subgroup where the device has ballots.
void count_total(uint total, bool yes) {
#ifdef SUBGROUP_QUEUES
    uint n = subgroupBallotBitCount(subgroupBallot(yes));
    if (subgroupElect()) add_total64(total, n);
#else
    if (yes) add_total64(total, 1u);
#endif
}

// The path's random number for one (depth, dimension) key (dimension table: src/rng/mod.rs).
float rand(uint path, uint depth, uint dim) {
#if defined(SAMPLER_INDEPENDENT)
    return random_f32(g.seed, path_pixel(path), path_sample(path), depth, dim);
#elif defined(SAMPLER_SOBOL)
    return sobol_f32(g.seed, g.pattern_bits, path_pixel(path), path_sample(path), depth, dim);
#elif defined(SAMPLER_MULTIJITTER)
    return multijitter_f32(g.seed, g.pattern_bits, path_pixel(path), path_sample(path), depth, dim);
#else
#error "no sampler defined (rng::defines)"
#endif
}

// The path's two numbers of the pair that starts at dimension dim (even): PathRng::get2.
vec2 rand2(uint path, uint depth, uint dim) {
#if defined(SAMPLER_INDEPENDENT)
    uint pixel = path_pixel(path), s = path_sample(path);
    return vec2(random_f32(g.seed, pixel, s, depth, dim), random_f32(g.seed, pixel, s, depth, dim + 1u));
#elif defined(SAMPLER_SOBOL)
    return sobol_pair_f32(g.seed, g.pattern_bits, path_pixel(path), path_sample(path), depth, dim);
#else
    return multijitter_pair_f32(g.seed, g.pattern_bits, path_pixel(path), path_sample(path), depth, dim);
#endif
}

#endif
