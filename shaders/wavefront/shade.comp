#version 460
// Stage 3: one pipeline per reflectance model, dispatched indirectly over that model's queue.
// The model is chosen when the pipeline is built: the virtual include "brdf/model.glsl" is the
// model's file and BRDF_EVAL / BRDF_PDF / BRDF_SAMPLE name its functions. For each path: one
// light sample (written as a shadow ray with its unoccluded contribution) and one BRDF sample
// (the next extension ray). Non-finite light contributions and path continuations are
// counted and dropped.
#extension GL_GOOGLE_include_directive : require
#include "wavefront/surface.glsl"
#include "brdf/model.glsl"
layout(local_size_x = 64) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= counters[COUNTER_MATERIAL + pc.queue_slot]) return;
    uint path = queues[(QUEUE_MATERIAL + pc.queue_slot) * g.capacity + i];
    uint depth = pc.bounce;
    uvec4 h = hit_rec[path];
    vec3 o = ray_o[path].xyz;
    vec3 d = ray_d[path].xyz;
    Surface s = surface_at(h.x, vec2(uintBitsToFloat(h.y), uintBitsToFloat(h.z)), uintBitsToFloat(h.w), o, d);
    Material m = materials[s.material];
    vec3 b = beta[path].xyz;
    vec3 wo = to_local(s.frame, -d);
    if (wo.z <= 0.0) return;
    vec3 origin = offset_ray_origin(s.p, s.p_err, s.ng);

    // Next-event estimation.
    if (g.num_lights > 0u) {
        LightSample ls = sample_light(rand(path, depth, DIM_LIGHT_SELECT), rand(path, depth, DIM_LIGHT_U),
                                      rand(path, depth, DIM_LIGHT_V));
        vec3 target = offset_ray_origin(ls.p, ls.p_err, ls.n);
        vec3 to_light = target - origin;
        float dist2 = dot(to_light, to_light);
        if (dist2 > 0.0) {
            float dist = sqrt(dist2);
            vec3 wi = to_light / dist;
            float cos_light = -dot(wi, ls.n);
            vec3 wi_local = to_local(s.frame, wi);
            if (cos_light > 0.0 && dot(wi, s.ng) > 0.0 && wi_local.z > 0.0) {
                float pdf_l = light_pdf(ls.density, dist2, cos_light);
                vec3 f = BRDF_EVAL(m, wi_local, wo);
                if (pdf_l > 0.0 && (f.x != 0.0 || f.y != 0.0 || f.z != 0.0)) {
                    float pdf_b = BRDF_PDF(m, wo, wi_local);
                    float w = power_heuristic(pdf_l, pdf_b);
                    vec3 contrib = b * f * (wi_local.z * w / pdf_l) * ls.radiance;
                    if (finite_or_count(contrib, counter_nonfinite_shade(pc.queue_slot))) {
                        // Shortened by SHADOW_EPSILON (Rust: bvh::SHADOW_EPSILON).
                        shadow_o[path] = vec4(origin, dist * (1.0 - SHADOW_EPSILON));
                        shadow_d[path] = vec4(wi, 0.0);
                        shadow_l[path] = vec4(contrib, 0.0);
                        queue_push(QUEUE_SHADOW, COUNTER_SHADOW, path);
                    }
                }
            }
        }
    }

    // BRDF sampling for the next segment.
    BrdfSample bs;
    vec2 u = vec2(rand(path, depth, DIM_BSDF_U), rand(path, depth, DIM_BSDF_V));
    if (!BRDF_SAMPLE(m, wo, rand(path, depth, DIM_BSDF_LOBE), u, bs)) return;
    vec3 wi = to_world(s.frame, bs.wi);
    if (dot(wi, s.ng) <= 0.0) return;
    b *= bs.weight;
    float prev_pdf = bs.delta ? 0.0 : bs.pdf;
    if (g.rr_enabled != 0u && depth >= g.rr_start_depth) {
        float q = min(max(b.x, max(b.y, b.z)), 1.0);
        if (rand(path, depth, DIM_RR) >= q) return;
        b /= q;
    }
    // A non-finite throughput, direction or pdf ends the path, counted.
    if (!(is_finite_v(b) && is_finite_v(wi) && is_finite_f(prev_pdf))) {
        atomicAdd(counters[counter_nonfinite_shade(pc.queue_slot)], 1u);
        return;
    }
    if (b.x == 0.0 && b.y == 0.0 && b.z == 0.0) return;
    beta[path] = vec4(b, 0.0);
    ray_o[path] = vec4(origin, 0.0);
    ray_d[path] = vec4(wi, prev_pdf);
    queue_push(ray_queue_out(), COUNTER_RAY + ray_queue_out(), path);
}
