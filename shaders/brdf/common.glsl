// Building blocks shared by the models. Rust twin: src/brdf/common.rs.
#ifndef BRDF_COMMON_GLSL
#define BRDF_COMMON_GLSL
#include "brdf/../common.glsl"  // = shaders/common.glsl both for glslangValidator -I (a bare "common.glsl" finds this file first) and for vk::ShaderCompiler (root-relative, no "../" above the root)

// Cosine-weighted hemisphere sample, concentric mapping (Shirley & Chiu 1997). pdf = cosθ/π.
vec3 sample_cosine_hemisphere(vec2 u) {
    vec2 a = 2.0 * u - vec2(1.0);
    vec2 d;
    if (a.x == 0.0 && a.y == 0.0) {
        d = vec2(0.0);
    } else if (abs(a.x) > abs(a.y)) {
        float r = a.x;
        float phi = (PI / 4.0) * (a.y / a.x);
        d = vec2(r * cos(phi), r * sin(phi));
    } else {
        float r = a.y;
        float phi = PI / 2.0 - (PI / 4.0) * (a.x / a.y);
        d = vec2(r * cos(phi), r * sin(phi));
    }
    float z = sqrt(max(1.0 - dot(d, d), 0.0));
    return vec3(d, z);
}

float cosine_hemisphere_pdf(float cos_theta) { return max(cos_theta, 0.0) * INV_PI; }

bool same_hemisphere_up(vec3 a, vec3 b) { return a.z > 0.0 && b.z > 0.0; }

// ---------------------------------------------------------------------------------------------
// Helpers added by models-a (Oren–Nayar, Phong, Blinn–Phong, Ward). Rust twins under the same
// marker in src/brdf/common.rs, same names and the same arithmetic.
// ---------------------------------------------------------------------------------------------

float luminance(vec3 c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

vec3 reflect_z(vec3 w) { return vec3(-w.x, -w.y, w.z); }

vec3 reflect_about(vec3 w, vec3 h) { return 2.0 * dot(w, h) * h - w; }

// Orthonormal basis completing n (Duff et al. 2017); t x b = n.
void orthonormal_basis(vec3 n, out vec3 t, out vec3 b) {
    float sgn = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sgn + n.z);
    float bb = n.x * n.y * a;
    t = vec3(1.0 + sgn * n.x * n.x * a, sgn * bb, -sgn * n.x);
    b = vec3(bb, sgn + n.y * n.y * a, -n.y);
}

vec3 rotate_z(vec3 w, float c, float s) { return vec3(c * w.x - s * w.y, s * w.x + c * w.y, w.z); }

// e^x - 1, relative accuracy near 0: series to x^6 for |x| < 0.1.
float expm1_f(float x) {
    if (abs(x) < 0.1) {
        return x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0 + x * (1.0 / 120.0 + x * (1.0 / 720.0))))));
    }
    precise float e = exp(x) - 1.0;
    return e;
}

// ln(1 + x), relative accuracy near 0: series to x^8 for |x| < 0.1. x > -1.
float log1p_f(float x) {
    if (abs(x) < 0.1) {
        return x * (1.0 + x * (-0.5 + x * (1.0 / 3.0 + x * (-0.25 + x * (0.2 + x * (-1.0 / 6.0 + x * (1.0 / 7.0 + x * -0.125)))))));
    }
    return log(1.0 + x);
}

// c^n for c = 1 - x with x supplied accurately; 0 for c <= 0, 1 for n = 0.
float pow_one_minus(float x, float n) {
    if (x >= 1.0) return 0.0;
    if (n <= 0.0) return 1.0;
    return exp(n * log1p_f(-max(x, 0.0)));
}

// 1 - dot(a, b) for unit vectors, accurate when nearly parallel.
float one_minus_dot(vec3 a, vec3 b) {
    precise vec3 d = a - b;
    return 0.5 * dot(d, d);
}

#endif
