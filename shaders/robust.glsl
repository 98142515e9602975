// Robust geometry: overflow-safe vectors, hit points with rounding-error bounds, and ray origins
// offset off the surface they leave. Rust twin: src/robust.rs, the same functions under the same
// names; every step repeats the Rust arithmetic in the same order, with intermediate values
// `precise` so that the compiler cannot fuse multiply-adds. How every ray that leaves a surface
// is kept off it (origins here, the hit tests' error bounds in bvh.glsl) is stated once, in
// src/robust.rs, section "Every ray that leaves a surface".
//
// Include after `#version 460`.
#ifndef ROBUST_GLSL
#define ROBUST_GLSL
#include "common.glsl"

// Rust: gamma(n), triangle_point, SHIFT_ULPS, ulp, sphere_point (the same arithmetic; the bounds
// are derived there, after Pharr, Jakob & Humphreys 2016, sec. 3.9).
#define GAMMA2 uintBitsToFloat(0x34000001u)
#define GAMMA4 uintBitsToFloat(0x34800002u)
#define GAMMA5 uintBitsToFloat(0x34a00003u)
#define SHIFT_ULPS 4.0
// 2^-24 and 2^-50 (Rust: SPHERE_ROUND, SPHERE_F64).
#define SPHERE_ROUND uintBitsToFloat(0x33800000u)
#define SPHERE_F64 uintBitsToFloat(0x26800000u)
// The spacing of the floats at x >= 0 (2^(exponent - 23)).
float ulp(float x) {
    uint e = (floatBitsToUint(x) >> 23) & 0xffu;
    return e > 23u ? uintBitsToFloat((e - 23u) << 23) : uintBitsToFloat(1u);
}
// Rust: pull_inside. A hit's barycentrics moved a fraction t towards the centroid's
// (1/3, 1/3), by SHIFT_ULPS ulps of the coordinates' magnitude (at most half way), so that a
// point near an edge is not on or beyond the neighbouring face's plane.
vec2 pull_inside(vec3 v0, vec3 v1, vec3 v2, float b1, float b2) {
    precise vec3 e1 = v1 - v0;
    precise vec3 e2 = v2 - v0;
    const float third = 1.0 / 3.0;
    precise float d1 = third - b1;
    precise float d2 = third - b2;
    precise vec3 to_c = abs(e1 * d1 + e2 * d2);
    precise float dist = max(to_c.x, max(to_c.y, to_c.z));
    if (!(dist > 0.0 && is_finite_f(dist))) return vec2(b1, b2);
    vec3 a0 = abs(v0);
    precise float delta = ulp(max(a0.x, max(a0.y, a0.z)) + 3.0 * dist) * SHIFT_ULPS;
    precise float t = min(delta / dist, 0.5);
    return vec2(b1 + t * d1, b2 + t * d2);
}
// p = v0 + (b1 (v1 - v0) + b2 (v2 - v0)); err bounds its distance from the plane per coordinate.
void triangle_point(vec3 v0, vec3 v1, vec3 v2, float b1, float b2, out vec3 p, out vec3 err) {
    precise vec3 e1 = (v1 - v0) * b1;
    precise vec3 e2 = (v2 - v0) * b2;
    precise vec3 q = v0 + (e1 + e2);
    precise vec3 e = (abs(e1) + abs(e2)) * GAMMA4 + abs(q) * GAMMA2;
    p = q;
    err = e;
}
// Rust: sphere_point. The point of the sphere (c, r) in the direction `toward` from its centre,
// computed in double and rounded once; err bounds its distance from the sphere per coordinate
// (2^-24 |p| + 2^-50 (|c| + r)); n is the unit outward normal.
void sphere_point(vec3 c, float r, dvec3 toward, out vec3 p, out vec3 err, out vec3 n) {
    precise double len = sqrt(toward.x * toward.x + toward.y * toward.y + toward.z * toward.z);
    precise dvec3 u = toward / len;
    precise dvec3 q = dvec3(c) + u * double(r);
    vec3 pf = vec3(q);
    precise vec3 e = abs(pf) * SPHERE_ROUND + (abs(c) + vec3(abs(r))) * SPHERE_F64;
    p = pf;
    err = e;
    n = vec3(u);
}

// Rust: scale_to_unit_exponent and triangle_normal. A vector scaled by the power of two
// that brings its largest component into [0.5, 1) (exact), so that the cross product of huge or
// tiny edges neither overflows nor underflows; the same normal bit for bit otherwise.
vec3 scale_to_unit_exponent(vec3 e) {
    float m = max(abs(e.x), max(abs(e.y), abs(e.z)));
    if (!(m > 0.0) || !is_finite_f(m)) return e;
    int ex;
    frexp(m, ex);
    return ldexp(e, ivec3(-ex));
}
vec3 triangle_normal(vec3 v0, vec3 v1, vec3 v2) {
    return normalize(cross(scale_to_unit_exponent(v1 - v0), scale_to_unit_exponent(v2 - v0)));
}

// Shadow rays end this fraction of their length before the light point (Rust: SHADOW_EPSILON).
#define SHADOW_EPSILON uintBitsToFloat(0x38d1b717u)
// The least magnitude of a coordinate offset_ray_origin moves, 2^-100 (Rust: ORIGIN_MIN).
#define ORIGIN_MIN uintBitsToFloat(0x0d800000u)

// Rust: step_off / offset_ray_origin (the same arithmetic on the same bits).
// q one float further in the direction of the sign of n (next_float_up for n > 0,
// next_float_down for n < 0, -0 and +0 stepping away from 0 alike), a result below ORIGIN_MIN
// in magnitude replaced by +-ORIGIN_MIN on the side of n; q itself for n = 0 or NaN and for an
// infinite or NaN q. Selects on integer bits, not if-statements (as in Rust, which has no
// branches there).
float step_off(float q, float n) {
    uint b = floatBitsToUint(q);
    uint mag = b & 0x7fffffffu;
    bool down = n < 0.0;
    bool moves = (n > 0.0) || down;
    bool away = (((b >> 31) != 0u) == down) || mag == 0u;
    uint s = away ? b + 1u : b - 1u;
    uint least = floatBitsToUint(ORIGIN_MIN) | (down ? 0x80000000u : 0u);
    uint r = (s & 0x7fffffffu) < floatBitsToUint(ORIGIN_MIN) ? least : s;
    return uintBitsToFloat(moves && mag < 0x7f800000u ? r : b);
}

// Move p, within err (per coordinate) of the true surface point, off the surface to the side of
// the unit normal n: by |n|.err along n, then each coordinate one float further along n
// (Pharr, Jakob & Humphreys 2016, sec. 3.9.5).
// A coordinate left within ORIGIN_MIN of 0 is set to +-ORIGIN_MIN on the side of n: never a
// subnormal, which Intel cores (lavapipe's too) compute in microcode assists. The test
// is on the bits, so the subnormal is no operand of arithmetic (and an FTZ device agrees).
vec3 offset_ray_origin(vec3 p, vec3 err, vec3 n) {
    precise float d = abs(n.x) * err.x + abs(n.y) * err.y + abs(n.z) * err.z;
    precise vec3 q = p + n * d;
    return vec3(step_off(q.x, n.x), step_off(q.y, n.y), step_off(q.z, n.z));
}

#endif
