// Shared definitions for every kernel. Rust twin: src/brdf/mod.rs (record layout).
#ifndef COMMON_GLSL
#define COMMON_GLSL

#define PI 3.14159265358979323846
#define INV_PI 0.31830988618379067154

// GPU material record, 32 words (brdf::RECORD_WORDS): header = (model index, queue slot,
// flags, reserved); p[] = the model's parameters as its Rust `pack` writes them. The size and
// the models' record codes are generated (src/brdf/glsl.rs, record_glsl).
#include "brdf/record.glsl"
struct Material {
    uvec4 header;
    vec4 p[MATERIAL_PARAMS];
};

// The result of sampling a BRDF (Rust: brdf::BrdfSample).
struct BrdfSample {
    vec3 wi;      // sampled direction
    vec3 weight;  // f·cos/pdf (non-delta), or reflectance / selection probability (delta)
    float pdf;    // solid-angle pdf; 0 for delta
    bool delta;
};

// Rec. 709 luminance (Rust: lights::luminance).
float luminance(vec3 c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

// A float is finite iff its exponent bits are not all ones. Bit tests cannot be optimised away
// the way isnan/isinf can under Vulkan's default float controls.
bool is_finite_f(float x) { return (floatBitsToUint(x) & 0x7f800000u) != 0x7f800000u; }
bool is_finite_v(vec3 v) { return is_finite_f(v.x) && is_finite_f(v.y) && is_finite_f(v.z); }

#if defined(SCENE_ENV_MAP) || defined(SCENE_TEXTURES)
// atan2(y, x) by basic operations only, `precise` so that no multiply-add is fused: the same
// bits as the Rust twin envmap::atan2_f32, which explains the reduction and the series (the
// library atan differs from Rust's by about 1e-5 rad on lavapipe). Environment maps and the
// texture coordinates of spheres use it. 0 at (0, 0).
float atan2_f32(float y, float x) {
    float ax = abs(x);
    float ay = abs(y);
    float hi = max(ax, ay);
    float lo = min(ax, ay);
    if (!(hi > 0.0)) return 0.0;
    precise float a = lo / hi;
    bool big = a > 0.41421357;
    precise float t = big ? (a - 1.0) / (a + 1.0) : a;
    precise float s = t * t;
    precise float p = -1.0 / 15.0;
    p = p * s + 1.0 / 13.0;
    p = p * s - 1.0 / 11.0;
    p = p * s + 1.0 / 9.0;
    p = p * s - 1.0 / 7.0;
    p = p * s + 1.0 / 5.0;
    p = p * s - 1.0 / 3.0;
    precise float r = t + t * (s * p);
    if (big) r += 0.78539819;
    if (ay > ax) r = 1.5707964 - r;
    if (x < 0.0) r = 3.1415927 - r;
    return y < 0.0 ? -r : r;
}
#endif


#if defined(SCENE_ENV_MAP) || defined(CAMERA_THIN_LENS)
// (sin 2 pi t, cos 2 pi t) by basic operations only, `precise`: the same bits as the Rust twin
// envmap::sincos_turns, which explains the reduction and the series.
vec2 sincos_turns(float t) {
    precise float q = floor(t * 4.0 + 0.5);
    precise float x = (t - q * 0.25) * 6.2831855;
    precise float s2 = x * x;
    precise float sp = 1.0 / 6227020800.0;
    sp = sp * s2 - 1.0 / 39916800.0;
    sp = sp * s2 + 1.0 / 362880.0;
    sp = sp * s2 - 1.0 / 5040.0;
    sp = sp * s2 + 1.0 / 120.0;
    sp = sp * s2 - 1.0 / 6.0;
    precise float s = x + x * (s2 * sp);
    precise float cp = 1.0 / 87178291200.0;
    cp = cp * s2 - 1.0 / 479001600.0;
    cp = cp * s2 + 1.0 / 3628800.0;
    cp = cp * s2 - 1.0 / 40320.0;
    cp = cp * s2 + 1.0 / 720.0;
    cp = cp * s2 - 1.0 / 24.0;
    cp = cp * s2 + 0.5;
    precise float c = 1.0 - s2 * cp;
    int k = int(q) & 3;
    if (k == 0) return vec2(s, c);
    if (k == 1) return vec2(c, -s);
    if (k == 2) return vec2(-s, -c);
    return vec2(-c, s);
}
#endif

#endif
