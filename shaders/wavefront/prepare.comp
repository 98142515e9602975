#version 460
// One thread: turns queue counters into indirect dispatch arguments and resets the counters the
// next stage appends to. The push constant `phase` says for which stage (src/gpu/layout.rs
// `Prepare`): PREPARE_EXTEND before `extend`, PREPARE_SHADE after it (material queues),
// PREPARE_SHADOW after shading (shadow queue).
#extension GL_GOOGLE_include_directive : require
#include "wavefront/state.glsl"
layout(local_size_x = 1) in;

// Workgroups of LOCAL_SIZE invocations for n paths.
const uint GROUP = uint(LOCAL_SIZE);
uvec4 groups(uint n) { return uvec4((n + (GROUP - 1u)) / GROUP, 1u, 1u, 0u); }

// 64-bit running total in two words (for the rays/s figures).
void add_total(uint c, uint n) {
    uint lo = counters[c] + n;
    if (lo < n) counters[c + 1u] += 1u;
    counters[c] = lo;
}

void run_kernel() {
    if (pc.phase == PREPARE_EXTEND) {
        uint rays = counters[counter_ray_queue(ray_queue_in())];
        args[ARGS_RAY] = groups(rays);
        add_total(COUNTER_EXT_TOTAL, rays);
        add_total(counter_segment_extension(pc.depth), rays);
        counters[counter_ray_queue(ray_queue_out())] = 0u;
        counters[COUNTER_SHADOW] = 0u;
        for (uint k = 0u; k < g.num_queues; ++k) counters[counter_material_queue(k)] = 0u;
    } else if (pc.phase == PREPARE_SHADE) {
        for (uint k = 0u; k < g.num_queues; ++k) args[ARGS_MATERIAL + k] = groups(counters[counter_material_queue(k)]);
    } else {  // PREPARE_SHADOW
        args[ARGS_SHADOW] = groups(counters[COUNTER_SHADOW]);
        add_total(COUNTER_SHADOW_TOTAL, counters[COUNTER_SHADOW]);
        add_total(counter_segment_shadow(pc.depth), counters[COUNTER_SHADOW]);
    }
}

// The whole kernel, then the loop-budget check (state.glsl), which every return above reaches.
void main() {
    run_kernel();
    check_loops();
}
