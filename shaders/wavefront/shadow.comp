#version 460
// Stage 4: any-hit test of every queued shadow ray; an unoccluded ray adds its contribution.
// Each path has at most one shadow ray per segment, so each radiance entry has one writer.
#extension GL_GOOGLE_include_directive : require
#include "wavefront/state.glsl"
layout(local_size_x = LOCAL_SIZE) in;

void run_kernel() {
    uint i = gl_GlobalInvocationID.x;
    bool queued = i < counters[COUNTER_SHADOW];
    bool occluded = false;
    if (queued) {
        uint path = queue_entry(QUEUE_SHADOW * g.wave_paths + i);
        vec4 o = shadow_o(path);
        vec4 d = shadow_d(path);
        occluded = trace_any_leaving(o.xyz, d.xyz, o.w, bvh_leaving_prim(d.w));
        if (!occluded) radiance_set(path, radiance(path) + vec4(shadow_l(path).xyz, 0.0));
    }
    count_total(COUNTER_OCCLUDED_TOTAL, occluded);
}

// The whole kernel, then the loop-budget check (state.glsl), which every return above reaches.
void main() {
    run_kernel();
    check_loops();
}
