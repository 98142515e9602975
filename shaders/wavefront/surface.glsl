// Surface interactions and light sampling on the GPU. Rust twin (independent code, same
// conventions): src/cpu/surface.rs.
#ifndef SURFACE_GLSL
#define SURFACE_GLSL
#include "wavefront/state.glsl"
#include "robust.glsl"

#define SPHERE_BIT 0x80000000u
#define NO_EMITTER 0xFFFFFFFFu

struct Frame { vec3 t; vec3 b; vec3 n; };

vec3 to_local(Frame f, vec3 v) { return vec3(dot(v, f.t), dot(v, f.b), dot(v, f.n)); }
vec3 to_world(Frame f, vec3 v) { return f.t * v.x + f.b * v.y + f.n * v.z; }

// Duff et al. 2017 orthonormal basis; sign from n.z >= 0 (as the Rust side).
vec3 default_tangent(vec3 n) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float b = n.x * n.y * a;
    return vec3(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
}

Frame make_frame(vec3 n, vec3 hint) {
    vec3 t = hint - n * dot(n, hint);
    float len2 = dot(t, t);
    t = len2 > 1e-12 ? t / sqrt(len2) : default_tangent(n);
    Frame f;
    f.t = t;
    f.b = cross(n, t);
    f.n = n;
    return f;
}

struct Surface {
    vec3 p;
    vec3 p_err;    // absolute rounding-error bound of p, per coordinate (offset_ray_origin)
    vec3 ng;       // unit geometric normal, front side
    bool front;
    Frame frame;
    uint material;
    uint emitter;  // NO_EMITTER when not emissive
#ifdef SCENE_TEXTURES
    vec2 uv;       // texture coordinates (texture.glsl surface_uv), set by the caller of surface_at
#endif
};

Surface surface_sphere(uint i, float t, vec3 o, vec3 d) {
    Surface s;
    vec4 cr;
    uvec4 info;
    sphere_texels(i, cr, info);
    precise dvec3 toward = dvec3(o) + dvec3(d) * double(t) - dvec3(cr.xyz);
    vec3 outward;
    sphere_point(cr.xyz, cr.w, toward, s.p, s.p_err, outward);
    s.ng = info.z != 0u ? -outward : outward;
    s.front = dot(d, s.ng) < 0.0;
    s.frame = make_frame(s.ng, cross(vec3(0.0, 1.0, 0.0), outward));
    s.material = info.x;
    s.emitter = info.y;
    return s;
}

// Shading normals and texture coordinates (for the tangent) are read only when some triangle
// of the scene has them (defines SCENE_SHADING_NORMALS, SCENE_UVS).
Surface surface_triangle(uint prim, vec2 bary, vec3 d) {
    Surface s;
    vec4 a, b, c;
    triangle_texels(prim, a, b, c);
    float b1 = bary.x;
    float b2 = bary.y;
    float b0 = 1.0 - b1 - b2;
    vec2 pb = pull_inside(a.xyz, b.xyz, c.xyz, b1, b2);
    triangle_point(a.xyz, b.xyz, c.xyz, pb.x, pb.y, s.p, s.p_err);
    vec3 e1 = b.xyz - a.xyz;
    vec3 e2 = c.xyz - a.xyz;
    s.ng = triangle_normal(a.xyz, b.xyz, c.xyz);
    s.front = dot(d, s.ng) < 0.0;
    vec3 ns = s.ng;
#if defined(SCENE_SHADING_NORMALS) || defined(SCENE_UVS)
    vec4 n0 = tri_attr(4u * prim);
    vec4 n1 = tri_attr(4u * prim + 1u);
    vec4 n2 = tri_attr(4u * prim + 2u);
    vec4 vv = tri_attr(4u * prim + 3u);
    uint flags = floatBitsToUint(vv.w);
#endif
#ifdef SCENE_SHADING_NORMALS
    if ((flags & 1u) != 0u) {
        vec3 n = n0.xyz * b0 + n1.xyz * b1 + n2.xyz * b2;
        float len2 = dot(n, n);
        if (len2 > 1e-12) {
            n = n / sqrt(len2);
            if (dot(n, s.ng) > 0.0) ns = n;
        }
    }
#endif
    vec3 hint = default_tangent(ns);
#ifdef SCENE_UVS
    if ((flags & 2u) != 0u) {
        vec2 du1 = vec2(n1.w, vv.y) - vec2(n0.w, vv.x);
        vec2 du2 = vec2(n2.w, vv.z) - vec2(n0.w, vv.x);
        float det = du1.x * du2.y - du1.y * du2.x;
        if (abs(det) > 1e-12) hint = (e1 * du2.y - e2 * du1.y) / det;
    }
#endif
    s.frame = make_frame(ns, hint);
    s.material = floatBitsToUint(a.w);
    s.emitter = floatBitsToUint(b.w);
    return s;
}

// The surface at a hit: only the primitive kinds the scene has are compiled in (BVH_SPHERES,
// BVH_TRIANGLES; see bvh.glsl).
Surface surface_at(uint prim, vec2 bary, float t, vec3 o, vec3 d) {
#if defined(BVH_SPHERES) && defined(BVH_TRIANGLES)
    if ((prim & SPHERE_BIT) != 0u) return surface_sphere(prim & ~SPHERE_BIT, t, o, d);
    return surface_triangle(prim, bary, d);
#elif defined(BVH_SPHERES)
    return surface_sphere(prim & ~SPHERE_BIT, t, o, d);
#else
    return surface_triangle(prim, bary, d);
#endif
}

// First light whose CDF exceeds u (the same binary search as LightTable::select).
uint select_light(float u) {
    uint lo = 0u;
    uint hi = g.num_lights - 1u;
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        if (uintBitsToFloat(light_entry(mid).y) > u) hi = mid; else lo = mid + 1u;
    }
    return lo;
}

// density: the emitter's light-selection density per unit area, lum(Le)/W (host-computed).
struct LightSample { vec3 p; vec3 p_err; vec3 n; vec3 radiance; float density; };

LightSample sample_sphere_light(uint i, float u1, float u2) {
    LightSample ls;
    vec4 cr;
    uvec4 info;
    sphere_texels(i, cr, info);
    float z = 1.0 - 2.0 * u1;
    float r = sqrt(max(1.0 - z * z, 0.0));
    float phi = 2.0 * PI * u2;
    vec3 dir = vec3(r * cos(phi), r * sin(phi), z);
    sphere_point(cr.xyz, cr.w, dvec3(dir), ls.p, ls.p_err, dir);
    ls.n = info.z != 0u ? -dir : dir;
    ls.radiance = emitter(info.y).xyz;
    ls.density = emitter(info.y).w;
    return ls;
}

// A point at barycentric weights (b1, b2) of emissive triangle `prim`.
LightSample triangle_light_at(uint prim, float b1, float b2) {
    LightSample ls;
    vec4 a, b, c;
    triangle_texels(prim, a, b, c);
    triangle_point(a.xyz, b.xyz, c.xyz, b1, b2, ls.p, ls.p_err);
    ls.n = triangle_normal(a.xyz, b.xyz, c.xyz);
    ls.radiance = emitter(floatBitsToUint(b.w)).xyz;
    ls.density = emitter(floatBitsToUint(b.w)).w;
    return ls;
}

LightSample sample_triangle_light(uint prim, float u1, float u2) {
    float su = sqrt(u1);
    float b0 = 1.0 - su;
    float b1 = u2 * su;
    return triangle_light_at(prim, b1, 1.0 - b0 - b1);
}

// A pair of triangles (v0, v1, v2), (v0, v2, v3) sampled as one light by one 2-D sample
// (src/lights.rs): the half of the unit square below the diagonal (u2 <= u1) maps to the first
// triangle, (b1, b2) = (u1 - u2, u2), the half above to the second, (u1, u2 - u1). Rust twin:
// lights::pair_barycentrics.
#define PAIR_BIT 0x40000000u

LightSample sample_triangle_pair_light(uint first, float u1, float u2) {
    bool second = u2 > u1;
    float b1 = second ? u1 : u1 - u2;
    float b2 = second ? u2 - u1 : u2;
    return triangle_light_at(first + (second ? 1u : 0u), b1, b2);
}

// A point on an emitter: only the kinds of emitters the scene has are compiled in
// (LIGHT_SPHERES, LIGHT_TRIANGLES, LIGHT_TRIANGLE_PAIRS; all three when none is defined).
// Delta-light entries never reach it (scatter.glsl tests DELTA_TAG first).
#if !defined(LIGHT_SPHERES) && !defined(LIGHT_TRIANGLES) && !defined(LIGHT_TRIANGLE_PAIRS)
#define LIGHT_SPHERES
#define LIGHT_TRIANGLES
#define LIGHT_TRIANGLE_PAIRS
#endif
LightSample sample_light(float u_sel, float u1, float u2) {
    uint prim = light_entry(select_light(u_sel)).x;
#if defined(LIGHT_SPHERES) && (defined(LIGHT_TRIANGLES) || defined(LIGHT_TRIANGLE_PAIRS))
    if ((prim & SPHERE_BIT) != 0u) return sample_sphere_light(prim & ~SPHERE_BIT, u1, u2);
#elif defined(LIGHT_SPHERES)
    return sample_sphere_light(prim & ~SPHERE_BIT, u1, u2);
#endif
#if defined(LIGHT_TRIANGLE_PAIRS) && defined(LIGHT_TRIANGLES)
    if ((prim & PAIR_BIT) != 0u) return sample_triangle_pair_light(prim & ~PAIR_BIT, u1, u2);
    return sample_triangle_light(prim, u1, u2);
#elif defined(LIGHT_TRIANGLE_PAIRS)
    return sample_triangle_pair_light(prim & ~PAIR_BIT, u1, u2);
#elif defined(LIGHT_TRIANGLES)
    return sample_triangle_light(prim, u1, u2);
#endif
}

#ifdef SCENE_DELTA_LIGHTS
// Point and directional lights (src/lights.rs): a light-table entry DELTA_TAG | k, whose
// emitter texels are k = (position, or the unit direction towards the light; 1 when
// directional, else 0) and k + 1 = (intensity or irradiance, selection probability).
#define DELTA_TAG 0xC0000000u

// The direction to a delta light, the shadow-ray length and the incident radiance divided by
// the selection probability: I / (r² p_sel) (point) or E / p_sel (directional). False when the
// origin is at the point light. Rust twin: sample_delta_light in src/cpu/surface.rs.
struct DeltaSample { vec3 wi; float tmax; vec3 li; };

bool sample_delta_light(uint prim, vec3 origin, out DeltaSample ds) {
    uint k = prim & ~DELTA_TAG;
    vec4 a = emitter(k);
    vec4 v = emitter(k + 1u);
    ds.wi = vec3(0.0);
    ds.tmax = 0.0;
    ds.li = vec3(0.0);
    if (v.w <= 0.0) return false;
    if (a.w != 0.0) {
        ds.wi = a.xyz;
        ds.tmax = 3.402823e38;
        ds.li = v.xyz / v.w;
        return true;
    }
    vec3 to_light = a.xyz - origin;
    float dist2 = dot(to_light, to_light);
    if (!(dist2 > 0.0)) return false;
    float dist = sqrt(dist2);
    ds.wi = to_light / dist;
    ds.tmax = dist * (1.0 - SHADOW_EPSILON);
    ds.li = v.xyz / (dist2 * v.w);
    return true;
}
#endif

// Solid-angle density of next-event estimation choosing this point (src/lights.rs). The
// density lum(Le)/W comes from the host: lum(Le)·(1/W) here flushed to 0 on an NVIDIA GPU when
// 1/W was a denormal.
float light_pdf(float density, float dist2, float cos_light) {
    if (cos_light <= 0.0 || density <= 0.0) return 0.0;
    return density * dist2 / cos_light;
}

float power_heuristic(float a, float b) {
    if (a <= 0.0) return 0.0;
    float r = min(b / a, 1e18);
    return 1.0 / (1.0 + r * r);
}

#endif
