#version 460
// Stage 2: closest hit for every queued ray of segment `depth`. Adds emission seen at the end
// of the segment (MIS-weighted against next-event estimation), adds the environment on a miss,
// and routes each path that goes on to the queue of its material's reflectance model
// (wavefront/path.glsl `segment_end`). A non-finite emitted contribution is counted and dropped.
#extension GL_GOOGLE_include_directive : require
#include "wavefront/path.glsl"
layout(local_size_x = LOCAL_SIZE) in;

void run_kernel() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= counters[counter_ray_queue(ray_queue_in())]) return;
    uint path = queue_entry(ray_queue_in() * g.wave_paths + i);
    vec4 dd = ray_d(path);
    vec3 o = ray_o(path).xyz;
    vec3 e;
    Hit hit;
    Surface s;
    vec4 b = beta(path);
    uint slot = segment_end(pc.depth, o, dd.xyz, bvh_leaving_prim(b.w), dd.w, b.xyz, e, hit, s);
    if (e.x != 0.0 || e.y != 0.0 || e.z != 0.0) radiance_set(path, radiance(path) + vec4(e, 0.0));
    if (slot == NO_QUEUE) return;
    hit_rec_set(path, uvec4(hit.prim, floatBitsToUint(hit.bary.x), floatBitsToUint(hit.bary.y), floatBitsToUint(hit.t)));
    queue_push(QUEUE_MATERIAL + slot, counter_material_queue(slot), path);
}

// The whole kernel, then the loop-budget check (state.glsl), which every return above reaches.
void main() {
    run_kernel();
    check_loops();
}
