#version 460
// Stage 2: closest hit for every queued ray of segment `bounce`. Adds emission seen at the end
// of the segment (MIS-weighted against next-event estimation), adds the environment on a miss,
// and routes each path that goes on to the queue of its material's reflectance model. A
// non-finite emitted contribution is counted and dropped.
#extension GL_GOOGLE_include_directive : require
#include "wavefront/surface.glsl"
layout(local_size_x = 64) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= counters[COUNTER_RAY + ray_queue_in()]) return;
    uint path = queues[ray_queue_in() * g.capacity + i];
    vec3 o = ray_o[path].xyz;
    vec4 dd = ray_d[path];
    vec3 d = dd.xyz;
    float prev_pdf = dd.w;
    vec3 b = beta[path].xyz;
    Hit hit;
    if (!trace_closest(o, d, 3.402823e38, hit)) {
        vec3 e = b * g.environment;
        if (finite_or_count(e, counter_nonfinite_extend())) radiance[path].xyz += e;
        return;
    }
    Surface s = surface_at(hit.prim, hit.bary, hit.t, o, d);
    if (!s.front) return;
    if (s.emitter != NO_EMITTER) {
        vec3 le = emitters[s.emitter].xyz;
        float w = 1.0;
        if (prev_pdf > 0.0) {
            float cos_light = -dot(d, s.ng);
            w = power_heuristic(prev_pdf, light_pdf(emitters[s.emitter].w, hit.t * hit.t, cos_light));
        }
        vec3 e = b * le * w;
        if (finite_or_count(e, counter_nonfinite_extend())) radiance[path].xyz += e;
    }
    if (pc.bounce >= g.max_depth) return;
    Material m = materials[s.material];
    uint slot = m.header.y;
    if (slot == 0xFFFFFFFFu) return;  // a surface that does not scatter (black)
    hit_rec[path] = uvec4(hit.prim, floatBitsToUint(hit.bary.x), floatBitsToUint(hit.bary.y), floatBitsToUint(hit.t));
    queue_push(QUEUE_MATERIAL + slot, COUNTER_MATERIAL + slot, path);
}
