#version 460
// Stages 2, 3 and 4 in one kernel, for a scene with one shaded model: the closest hit of every
// queued ray of segment `depth` (wavefront/path.glsl `segment_end`, as extend.comp), then,
// where the path goes on, the shading of that vertex on the spot (wavefront/scatter.glsl
// `shade_vertex`, as shade.comp) and its shadow ray, without a trip through the hit record, a
// material queue and the shadow queue. The material queues keep the SIMD lanes of a shade
// kernel on one model; with one model they only cost. The shadow rays are counted here (as
// `prepare` counts the shadow queue otherwise), and added in the same order as the separate
// stages add them, so the image is the same.
#extension GL_GOOGLE_include_directive : require
#include "brdf/model.glsl"
#include "wavefront/scatter.glsl"
layout(local_size_x = LOCAL_SIZE) in;

void run_kernel() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= counters[counter_ray_queue(ray_queue_in())]) return;
    uint path = queue_entry(ray_queue_in() * g.wave_paths + i);
    vec4 dd = ray_d(path);
    vec3 o = ray_o(path).xyz;
    vec4 bl = beta(path);
    vec3 b = bl.xyz;
    vec3 e;
    Hit hit;
    Surface s;
    uint slot = segment_end(pc.depth, o, dd.xyz, bvh_leaving_prim(bl.w), dd.w, b, e, hit, s);
    if (e.x != 0.0 || e.y != 0.0 || e.z != 0.0) radiance_set(path, radiance(path) + vec4(e, 0.0));
    if (slot == NO_QUEUE) return;
    // Counted as the material queue's length, as extend would, for the ray totals.
    Scatter sc = shade_vertex(path, pc.depth, s, dd.xyz, b, counter_nonfinite_shade(slot));
    bool occluded = sc.shadow && trace_any_leaving(sc.shadow_o, sc.shadow_d, sc.shadow_tmax, hit.prim);
    if (sc.shadow && !occluded) {
        radiance_set(path, radiance(path) + vec4(sc.shadow_l, 0.0));
    }
    count_rays(COUNTER_SHADOW_TOTAL, counter_segment_shadow(pc.depth), sc.shadow);
    count_total(COUNTER_OCCLUDED_TOTAL, occluded);
    if (!sc.next) return;
    beta_set(path, vec4(sc.beta, bvh_leaving_code(hit.prim)));
    ray_o_set(path, vec4(sc.o, 0.0));
    ray_d_set(path, vec4(sc.d, sc.pdf));
    queue_push(ray_queue_out(), counter_ray_queue(ray_queue_out()), path);
}

// The whole kernel, then the loop-budget check (state.glsl), which every return above reaches.
void main() {
    run_kernel();
    check_loops();
}
