// The integrator's steps along one path, written once and used by both GPU integrators: the
// wavefront stages (generate, extend, shade, shadow: one step per kernel, the path state in
// buffers between them) and the megakernel (every step of a path in one invocation). Rust twin
// (independent code, same conventions and random-number keys): camera_ray and segment_end in
// src/cpu/path.rs, and the loop that calls them, trace_path in src/cpu/mod.rs.
//
// Shading a vertex is in wavefront/scatter.glsl, which needs the BRDF interface.
#ifndef PATH_GLSL
#define PATH_GLSL
#include "wavefront/surface.glsl"
#include "envmap.glsl"
#include "texture.glsl"

#ifdef CAMERA_THIN_LENS
// Shirley & Chiu's (1997) concentric map of the unit square onto the unit disc. Rust twin:
// camera::concentric_disk.
vec2 concentric_disk(vec2 u) {
    float a = 2.0 * u.x - 1.0;
    float b = 2.0 * u.y - 1.0;
    if (a == 0.0 && b == 0.0) return vec2(0.0);
    // phi in turns, its sine and cosine by basic operations (common.glsl sincos_turns).
    float r;
    precise float turns;
    if (abs(a) > abs(b)) {
        r = a;
        turns = 0.125 * (b / a);
    } else {
        r = b;
        turns = 0.25 - 0.125 * (a / b);
    }
    vec2 sc = sincos_turns(turns);
    return vec2(r * sc.y, r * sc.x);
}
#endif

// Camera ray of path slot `path`: box pixel filter, uniform position in the pixel; with
// CAMERA_THIN_LENS from a point of the lens, through the pinhole ray's point on the plane in
// focus (src/camera.rs).
void camera_ray(uint path, out vec3 o, out vec3 d) {
    uint pixel = path_pixel(path);
    uint x = pixel % g.width;
    uint y = pixel / g.width;
    vec2 sub_pixel = rand2(path, 0u, DIM_PIXEL_X);
    float fx = float(x) + sub_pixel.x;
    float fy = float(y) + sub_pixel.y;
    float sx = 2.0 * fx / float(g.width) - 1.0;
    float sy = 1.0 - 2.0 * fy / float(g.height);
#ifdef CAMERA_THIN_LENS
    vec3 dd = g.cam_forward + sx * g.cam_right + sy * g.cam_up;
    vec2 lens = concentric_disk(rand2(path, 0u, DIM_LENS_U));
    vec3 offset = lens.x * g.lens_right + lens.y * g.lens_up;
    o = g.cam_origin + offset;
    d = normalize(dd * g.focus_distance - offset);
#else
    o = g.cam_origin;
    d = normalize(g.cam_forward + sx * g.cam_right + sy * g.cam_up);
#endif
}

// The most emitters a camera ray passes through with hidden emitters (Rust: HIDE_PASSES).
#define HIDE_PASSES 16u

// The end of path segment `depth` (ray o + t d leaving the triangle `leaving` or BVH_NO_PRIM,
// throughput b, pdf of the BSDF sample that chose d or 0): the emitted light seen there, MIS-weighted against next-event estimation, or the
// environment on a miss, goes to `e` (zero when none; a non-finite value is counted at the
// extend counter and dropped). Returns the material queue slot when the path goes on from a
// surface (whose interaction is `s`, for shading), NO_QUEUE when it ends (miss, back face unless
// two-sided, the depth limit, a black surface).
uint segment_end(uint depth, vec3 o, vec3 d, uint leaving, float prev_pdf, vec3 b, out vec3 e, out Hit hit, out Surface s) {
    e = vec3(0.0);
    bool found = trace_closest_leaving(o, d, 3.402823e38, leaving, hit);
#ifdef HIDE_EMITTERS
    // Mitsuba's hidden emitters: the camera ray passes through the emitters it meets, on from
    // just beyond each, at most HIDE_PASSES of them (Rust: segment_end).
    for (uint k = 0u; depth == 1u && found && k < HIDE_PASSES; ++k) {
        Surface h = surface_at(hit.prim, hit.bary, hit.t, o, d);
        if (h.emitter == NO_EMITTER) break;
        o = offset_ray_origin(h.p, h.p_err, h.front ? -h.ng : h.ng);
        found = trace_closest(o, d, 3.402823e38, hit);
    }
#endif
    if (!found) {
#ifdef SCENE_ENV_MAP
        vec3 env = b * env_radiance(d) * env_weight(d, prev_pdf);
#else
        vec3 env = b * g.environment;
#endif
        if (finite_or_count(env, counter_nonfinite_extend())) e = env;
#ifdef HIDE_EMITTERS
        // The camera ray does not see the environment (Rust: segment_end).
        if (depth == 1u) e = vec3(0.0);
#endif
        return NO_QUEUE;
    }
    s = surface_at(hit.prim, hit.bary, hit.t, o, d);
#ifdef SCENE_TEXTURES
    s.uv = surface_uv(hit.prim, hit.bary, s.p);
#endif
    if (!s.front) {
#ifdef SCENE_TWOSIDED
        // The back of a two-sided material scatters (shade_vertex turns it to the front) but
        // emits nothing.
        uvec4 h = imageLoad(material_words, int(MATERIAL_TEXELS * s.material));
        if (h.z != 0u && depth < g.max_depth) return h.y;
#endif
        return NO_QUEUE;
    }
    if (s.emitter != NO_EMITTER) {
        vec3 le = emitter(s.emitter).xyz;
        float w = 1.0;
        if (prev_pdf > 0.0) {
            float cos_light = -dot(d, s.ng);
            w = power_heuristic(prev_pdf, light_pdf(emitter(s.emitter).w, hit.t * hit.t, cos_light));
        }
        vec3 em = b * le * w;
        if (finite_or_count(em, counter_nonfinite_extend())) e = em;
#ifdef HIDE_EMITTERS
        // Nor an emitter it could not pass (HIDE_PASSES).
        if (depth == 1u) e = vec3(0.0);
#endif
    }
    if (depth >= g.max_depth) return NO_QUEUE;
    return imageLoad(material_words, int(MATERIAL_TEXELS * s.material)).y;
}

#endif
