// Shading one path vertex: a light sample and a BRDF sample. Used by the wavefront shade
// kernels and by the megakernel. The includer defines BRDF_EVAL / BRDF_PDF / BRDF_SAMPLE first
// (shade.comp: one model's functions; megakernel.comp: brdf/any.glsl, a switch over the
// scene's models). Rust twin: shade_vertex in src/cpu/scatter.rs.
#ifndef SCATTER_GLSL
#define SCATTER_GLSL
#include "wavefront/path.glsl"

// What shading one surface vertex produces: at most one shadow ray with the contribution it
// adds when unoccluded, and the next segment of the path.
struct Scatter {
    bool shadow;          // a shadow ray was made
    vec3 shadow_o;
    vec3 shadow_d;
    float shadow_tmax;
    vec3 shadow_l;        // its unoccluded contribution
    bool next;            // the path goes on
    vec3 o;               // next segment: origin, direction, throughput, pdf (0: delta)
    vec3 d;
    vec3 beta;
    float pdf;
};

#ifdef SCENE_DELTA_LIGHTS
// Next-event estimation towards the delta light of light-table entry `prim` from `origin` on s
// (view direction wo, local): no MIS, since BSDF sampling can never find it. Writes r's shadow
// ray. Rust twin: delta_light_ray in src/cpu/scatter.rs.
void delta_light_ray(uint prim, Surface s, Material m, vec3 origin, vec3 wo, vec3 b, uint c, inout Scatter r) {
    DeltaSample ds;
    if (!sample_delta_light(prim, origin, ds)) return;
    vec3 wi_local = to_local(s.frame, ds.wi);
    if (!(dot(ds.wi, s.ng) > 0.0 && wi_local.z > 0.0)) return;
    vec3 f = BRDF_EVAL(m, wi_local, wo);
    if (f.x == 0.0 && f.y == 0.0 && f.z == 0.0) return;
    vec3 contrib = b * f * wi_local.z * ds.li;
    if (!finite_or_count(contrib, c)) return;
    r.shadow = true;
    r.shadow_o = origin;
    r.shadow_d = ds.wi;
    r.shadow_tmax = ds.tmax;
    r.shadow_l = contrib;
}
#endif

#ifdef SCENE_ENV_MAP
// Next-event estimation towards the environment map, its direction drawn by the path's light
// pair, MIS-weighted against BSDF sampling. Writes r's shadow ray. Rust twin: env_light_ray in
// src/cpu/scatter.rs.
void env_light_ray(uint path, uint depth, Surface s, Material m, vec3 origin, vec3 wo, vec3 b, uint c, inout Scatter r) {
    vec2 u = rand2(path, depth, DIM_LIGHT_U);
    vec3 wi;
    float pdf;
    vec3 radiance;
    if (!env_sample(u.x, u.y, wi, pdf, radiance)) return;
    vec3 wi_local = to_local(s.frame, wi);
    if (!(dot(wi, s.ng) > 0.0 && wi_local.z > 0.0)) return;
    float pdf_l = g.env_select * pdf;
    vec3 f = BRDF_EVAL(m, wi_local, wo);
    if (!(pdf_l > 0.0) || (f.x == 0.0 && f.y == 0.0 && f.z == 0.0)) return;
    float w = power_heuristic(pdf_l, BRDF_PDF(m, wo, wi_local));
    vec3 contrib = b * f * (wi_local.z * w / pdf_l) * radiance;
    if (!finite_or_count(contrib, c)) return;
    r.shadow = true;
    r.shadow_o = origin;
    r.shadow_d = wi;
    r.shadow_tmax = 3.402823e38;
    r.shadow_l = contrib;
}
#endif

// Shades the vertex at the end of segment `depth` (surface s, reached along direction d with
// throughput b): one light sample (next-event estimation) and one BRDF sample, keyed on (path,
// depth). Non-finite light contributions and continuations are counted at counter c and dropped.
Scatter shade_vertex(uint path, uint depth, Surface s, vec3 d, vec3 b, uint c) {
    Scatter r;
    r.shadow = false;
    r.next = false;
    r.shadow_o = vec3(0.0);
    r.shadow_d = vec3(0.0);
    r.shadow_tmax = 0.0;
    r.shadow_l = vec3(0.0);
    r.o = vec3(0.0);
    r.d = vec3(0.0);
    r.beta = vec3(0.0);
    r.pdf = 0.0;
    Material m = load_material(s.material);
#ifdef SCENE_TEXTURES
    // A textured material: its parameters' values at this point written into the record, and
    // what the model derives from them (brdf/textured.rs).
    if (m.header.w != 0u) {
        apply_textures(m, s.uv);
        BRDF_TEXTURED(m);
    }
#endif
#ifdef SCENE_TWOSIDED
    // A two-sided material seen from behind: its back is shaded as a front, the geometric and
    // shading normals turned to the side the ray came from (header.z: src/gpu/scene_buffers.rs).
    if (m.header.z != 0u && !s.front) {
        s.ng = -s.ng;
        s.frame.n = -s.frame.n;
        s.frame.b = -s.frame.b;
    }
#endif
    vec3 wo = to_local(s.frame, -d);
    if (wo.z <= 0.0) return r;
    // Every ray from here leaves from this origin (src/robust.rs, "Every ray that leaves a
    // surface").
    vec3 origin = offset_ray_origin(s.p, s.p_err, s.ng);
    // The light choice and the lobe choice are one pair (DIM_LIGHT_SELECT, DIM_BSDF_LOBE).
    vec2 u_choice = rand2(path, depth, DIM_LIGHT_SELECT);

    // Next-event estimation.
#if defined(SCENE_DELTA_LIGHTS) || defined(SCENE_ENV_MAP)
    uint light_prim = g.num_lights > 0u ? light_entry(select_light(u_choice.x)).x : 0u;
#endif
#ifdef SCENE_ENV_MAP
    if (g.num_lights > 0u && light_prim == ENV_ENTRY) {
        env_light_ray(path, depth, s, m, origin, wo, b, c, r);
    } else
#endif
#ifdef SCENE_DELTA_LIGHTS
    if (g.num_lights > 0u && (light_prim & DELTA_TAG) == DELTA_TAG) {
        delta_light_ray(light_prim, s, m, origin, wo, b, c, r);
    } else
#endif
    if (g.num_lights > 0u) {
        vec2 u_light = rand2(path, depth, DIM_LIGHT_U);
        LightSample ls = sample_light(u_choice.x, u_light.x, u_light.y);
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
                    if (finite_or_count(contrib, c)) {
                        r.shadow = true;
                        r.shadow_o = origin;
                        r.shadow_d = wi;
                        // Shortened by SHADOW_EPSILON (Rust: robust::SHADOW_EPSILON).
                        r.shadow_tmax = dist * (1.0 - SHADOW_EPSILON);
                        r.shadow_l = contrib;
                    }
                }
            }
        }
    }

    // BRDF sampling for the next segment.
    BrdfSample bs;
    vec2 u = rand2(path, depth, DIM_BSDF_U);
    if (!BRDF_SAMPLE(m, wo, u_choice.y, u, bs)) return r;
    vec3 wi = to_world(s.frame, bs.wi);
    if (dot(wi, s.ng) <= 0.0) return r;
    b *= bs.weight;
    float prev_pdf = bs.delta ? 0.0 : bs.pdf;
#ifdef RUSSIAN_ROULETTE
    if (g.rr_enabled != 0u && depth >= g.rr_start_depth) {
        float q = min(max(b.x, max(b.y, b.z)), 1.0);
        if (rand(path, depth, DIM_RR) >= q) return r;
        b /= q;
    }
#endif
    // A non-finite throughput, direction or pdf ends the path, counted.
    if (!(is_finite_v(b) && is_finite_v(wi) && is_finite_f(prev_pdf))) {
        atomicAdd(counters[c], 1u);
        return r;
    }
    if (b.x == 0.0 && b.y == 0.0 && b.z == 0.0) return r;
    r.next = true;
    r.o = origin;
    r.d = wi;
    r.beta = b;
    r.pdf = prev_pdf;
    return r;
}

#endif
