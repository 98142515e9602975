#version 460
// Stage 3: one pipeline per reflectance model, dispatched indirectly over that model's queue.
// The model is chosen when the pipeline is built: the virtual include "brdf/model.glsl" is the
// model's file and BRDF_EVAL / BRDF_PDF / BRDF_SAMPLE name its functions. For each path
// (wavefront/scatter.glsl `shade_vertex`): one light sample, written as a shadow ray with its
// unoccluded contribution, and one BRDF sample, the next extension ray. Non-finite light
// contributions and path continuations are counted and dropped.
#extension GL_GOOGLE_include_directive : require
#include "brdf/model.glsl"
#include "wavefront/scatter.glsl"
layout(local_size_x = LOCAL_SIZE) in;

void run_kernel() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= counters[counter_material_queue(pc.queue_slot)]) return;
    uint path = queue_entry((QUEUE_MATERIAL + pc.queue_slot) * g.wave_paths + i);
    uvec4 h = hit_rec(path);
    Hit hit;
    hit.prim = h.x;
    hit.bary = vec2(uintBitsToFloat(h.y), uintBitsToFloat(h.z));
    hit.t = uintBitsToFloat(h.w);
    vec3 d = ray_d(path).xyz;
    Surface s = surface_at(hit.prim, hit.bary, hit.t, ray_o(path).xyz, d);
#ifdef SCENE_TEXTURES
    s.uv = surface_uv(hit.prim, hit.bary, s.p);
#endif
    Scatter sc = shade_vertex(path, pc.depth, s, d, beta(path).xyz, counter_nonfinite_shade(pc.queue_slot));
    if (sc.shadow) {
        shadow_o_set(path, vec4(sc.shadow_o, sc.shadow_tmax));
        shadow_d_set(path, vec4(sc.shadow_d, bvh_leaving_code(hit.prim)));
        shadow_l_set(path, vec4(sc.shadow_l, 0.0));
        queue_push(QUEUE_SHADOW, COUNTER_SHADOW, path);
    }
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
