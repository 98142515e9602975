// Building blocks shared by the models, grouped by topic as in the Rust twin
// (src/brdf/common.rs): same names, same arithmetic.
#ifndef BRDF_COMMON_GLSL
#define BRDF_COMMON_GLSL
#include "brdf/../common.glsl"  // = shaders/common.glsl both for glslangValidator -I (a bare "common.glsl" finds this file first) and for vk::ShaderCompiler (root-relative, no "../" above the root)

// ---------------------------------------------------------------------------------------------
// Sampling the hemisphere
// ---------------------------------------------------------------------------------------------

// The least cos²θ of sample_cosine_hemisphere: 2^-23 (Rust: brdf::common::MIN_COS2).
const float MIN_COS2 = 1.0 / 8388608.0;

// Cosine-weighted hemisphere sample, concentric mapping (Shirley & Chiu 1997). pdf = cosθ/π.
vec3 sample_cosine_hemisphere(vec2 u) {
    vec2 a = 2.0 * u - vec2(1.0);
    vec2 d;
    if (a.x == 0.0 && a.y == 0.0) {
        d = vec2(0.0);
    } else if (abs(a.x) > abs(a.y)) {
        // phi = (PI/4)(a.y/a.x), in [-PI/4, PI/4].
        float phi = (PI / 4.0) * (a.y / a.x);
        d = a.x * vec2(cos(phi), sin(phi));
    } else {
        // phi = PI/2 - psi with psi = (PI/4)(a.x/a.y): cos phi = sin psi, sin phi = cos psi.
        float psi = (PI / 4.0) * (a.x / a.y);
        d = a.y * vec2(sin(psi), cos(psi));
    }
    // The rim (cosθ = 0, pdf 0) moves inwards to 1 - |d|² = MIN_COS2, as in the Rust twin.
    float z2 = 1.0 - dot(d, d);
    if (z2 < MIN_COS2) {
        d = d * (sqrt(1.0 - MIN_COS2) / length(d));
        return vec3(d, sqrt(MIN_COS2));
    }
    return vec3(d, sqrt(z2));
}

float cosine_hemisphere_pdf(float cos_theta) { return max(cos_theta, 0.0) * INV_PI; }

bool same_hemisphere_up(vec3 a, vec3 b) { return a.z > 0.0 && b.z > 0.0; }

// ---------------------------------------------------------------------------------------------
// Directions and frames
// ---------------------------------------------------------------------------------------------

vec3 reflect_z(vec3 w) { return vec3(-w.x, -w.y, w.z); }

// r = 2(w·h)h − w; false when w·h ≤ 0 (the sample is rejected), as reflect_about in common.rs.
bool reflect_about(vec3 w, vec3 h, out vec3 r) {
    float c = dot(w, h);
    if (c <= 0.0) return false;
    r = 2.0 * c * h - w;
    return true;
}

// Orthonormal basis completing n (Duff et al. 2017); t x b = n.
void orthonormal_basis(vec3 n, out vec3 t, out vec3 b) {
    float sgn = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sgn + n.z);
    float bb = n.x * n.y * a;
    t = vec3(1.0 + sgn * n.x * n.x * a, sgn * bb, -sgn * n.x);
    b = vec3(bb, sgn + n.y * n.y * a, -n.y);
}

vec3 rotate_z(vec3 w, float c, float s) { return vec3(c * w.x - s * w.y, s * w.x + c * w.y, w.z); }

// 1 - dot(a, b) for unit vectors, accurate when nearly parallel.
float one_minus_dot(vec3 a, vec3 b) {
    precise vec3 d = a - b;
    return 0.5 * dot(d, d);
}

float tan2_theta(vec3 w) { return (w.x * w.x + w.y * w.y) / (w.z * w.z); }

// ---------------------------------------------------------------------------------------------
// Special functions: accurate where GLSL has no library function
// ---------------------------------------------------------------------------------------------

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

// erfc with relative accuracy (Numerical Recipes erfcc form) where it is a normal float; 0
// from |x| = ERFC_ZERO on (brdf::common::erfc says why); |x| clamped to 10 in the formula.
const float ERFC_ZERO = 9.19;
float erfc(float x) {
    float z = min(abs(x), 10.0);
    float t = 1.0 / (1.0 + 0.5 * z);
    float p = -1.2655122
        + t * (1.0000237
        + t * (0.37409196
        + t * (0.09678418
        + t * (-0.18628806
        + t * (0.27886807
        + t * (-1.13520398
        + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277))))))));
    float r = z >= ERFC_ZERO ? 0.0 : t * exp(-z * z + p);
    return x >= 0.0 ? r : 2.0 - r;
}

// ---------------------------------------------------------------------------------------------
// Fresnel reflectance
// ---------------------------------------------------------------------------------------------

// Survey eq. 7, unpolarised dielectric Fresnel (see the Rust twin for the guards).
float fresnel_dielectric(float c, float n) {
    c = clamp(c, 0.0, 1.0);
    if (n == 1.0) return 0.0;
    precise float g2 = n * n + c * c - 1.0;
    if (g2 <= 0.0) return 1.0;
    float g = sqrt(g2);
    precise float a = (g - c) / (g + c);
    precise float num = c * (g + c) - 1.0;
    precise float den = c * (g - c) + 1.0;
    float b = num / den;
    return clamp(0.5 * a * a * (1.0 + b * b), 0.0, 1.0);
}

// Exact conductor Fresnel, one channel (real-arithmetic form; see the Rust twin).
float fresnel_conductor1(float c, float eta, float k) {
    c = clamp(c, 0.0, 1.0);
    float c2 = c * c;
    precise float s2 = max(1.0 - c2, 0.0);
    precise float x = eta * eta - k * k - s2;
    float ek = eta * k;
    float t = sqrt(x * x + 4.0 * ek * ek);
    float a2;
    float b2;
    if (x >= 0.0) {
        a2 = 0.5 * (t + x);
        b2 = a2 > 0.0 ? ek * ek / a2 : 0.0;
    } else {
        b2 = 0.5 * (t - x);
        a2 = b2 > 0.0 ? ek * ek / b2 : 0.0;
    }
    float a = sqrt(a2);
    float ab2 = a2 + b2;
    precise float rs_num = ab2 - 2.0 * a * c + c2;
    float rs_den = ab2 + 2.0 * a * c + c2;
    float rs = rs_den > 0.0 ? rs_num / rs_den : 1.0;
    precise float p_num = c2 * ab2 - 2.0 * a * c * s2 + s2 * s2;
    float p_den = c2 * ab2 + 2.0 * a * c * s2 + s2 * s2;
    float rp = p_den > 0.0 ? rs * p_num / p_den : rs;
    return clamp(0.5 * (rs + rp), 0.0, 1.0);
}

vec3 fresnel_conductor(float c, vec3 eta, vec3 k) {
    return vec3(fresnel_conductor1(c, eta.x, k.x), fresnel_conductor1(c, eta.y, k.y),
                fresnel_conductor1(c, eta.z, k.z));
}

// Schlick's approximation (survey eq. 18), fifth power by multiplications.
vec3 fresnel_schlick(float c, vec3 f0) {
    precise float m = clamp(1.0 - clamp(c, 0.0, 1.0), 0.0, 1.0);
    float m2 = m * m;
    float m5 = m2 * m2 * m;
    return f0 + (vec3(1.0) - f0) * m5;
}

// ---------------------------------------------------------------------------------------------
// Microfacet distributions (Beckmann, GGX): normal distributions, Smith masking, sampling
// ---------------------------------------------------------------------------------------------

// Normalised isotropic Beckmann NDF (survey eq. 6 / π).
float beckmann_d(vec3 h, float alpha) {
    if (h.z <= 0.0) return 0.0;
    float a2 = alpha * alpha;
    float c2 = h.z * h.z;
    float e = exp(-tan2_theta(h) / a2);
    return e / (PI * a2 * c2 * c2);
}

// Normalised isotropic GGX NDF.
float ggx_d(vec3 h, float alpha) {
    if (h.z <= 0.0) return 0.0;
    float a2 = alpha * alpha;
    float d = h.z * h.z * a2 + h.x * h.x + h.y * h.y;
    if (d <= 0.0) return 0.0;
    return a2 / (PI * d * d);
}

// Smith G1 for Beckmann, Walter et al. 2007's rational approximation.
float smith_g1_beckmann_walter(vec3 w, float alpha) {
    if (w.z <= 0.0) return 0.0;
    float s = sqrt(w.x * w.x + w.y * w.y);
    if (w.z >= 1.6 * alpha * s) return 1.0;
    float a = w.z / (alpha * s);
    return (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a);
}

// Exact Smith G1 for GGX.
float smith_g1_ggx(vec3 w, float alpha) {
    if (w.z <= 0.0) return 0.0;
    float s2 = w.x * w.x + w.y * w.y;
    float r = sqrt(w.z * w.z + alpha * alpha * s2);
    return 2.0 * w.z / (w.z + r);
}

vec3 half_vector_from_tan2(float tan2, float u) {
    float cos_t = 1.0 / sqrt(1.0 + tan2);
    float sin_t = sqrt(tan2) * cos_t;
    float phi = 2.0 * PI * u;
    return vec3(sin_t * cos(phi), sin_t * sin(phi), cos_t);
}

vec3 sample_beckmann_h(vec2 u, float alpha) {
    float tan2 = -alpha * alpha * log(max(1.0 - u.x, 1e-30));
    return half_vector_from_tan2(max(tan2, 0.0), u.y);
}

vec3 sample_ggx_h(vec2 u, float alpha) {
    float tan2 = alpha * alpha * u.x / max(1.0 - u.x, 1e-30);
    return half_vector_from_tan2(tan2, u.y);
}

// Exact Smith G1 for Beckmann (Heitz 2014, eqs. 25, 43), 2a/(a(2 - erfc a) + e^(-a²)/√π),
// a = cosθ/(α sinθ); 1 from a >= 10. As smith_g1_beckmann in common.rs.
const float FRAC_1_SQRT_PI = 0.5641896;
float smith_g1_beckmann(vec3 w, float alpha) {
    if (w.z <= 0.0) return 0.0;
    float s = sqrt(w.x * w.x + w.y * w.y);
    if (w.z >= 9.0 * alpha * s) return 1.0;
    float a = w.z / (alpha * s);
    float den = a * (2.0 - erfc(a)) + exp(-a * a) * FRAC_1_SQRT_PI;
    return min(2.0 * a / den, 1.0);
}

// Inverse error function, single precision (Giles 2010); x clamped to ±(1 - 2^-24).
const float ERFINV_MAX = 1.0 - 1.0 / 16777216.0;
float erfinv_f(float x) {
    x = clamp(x, -ERFINV_MAX, ERFINV_MAX);
    precise float one_minus = 1.0 - x;
    precise float one_plus = 1.0 + x;
    float w = -log(one_minus * one_plus);
    float p;
    if (w < 5.0) {
        w -= 2.5;
        p = 2.8102264e-8;
        p = 3.4327394e-7 + p * w;
        p = -3.5233877e-6 + p * w;
        p = -4.3915065e-6 + p * w;
        p = 0.00021858087 + p * w;
        p = -0.001253725 + p * w;
        p = -0.0041776816 + p * w;
        p = 0.24664073 + p * w;
        p = 1.5014094 + p * w;
    } else {
        w = sqrt(w) - 3.0;
        p = -0.00020021426;
        p = 0.00010095056 + p * w;
        p = 0.0013493432 + p * w;
        p = -0.0036734284 + p * w;
        p = 0.0057395077 + p * w;
        p = -0.0076224613 + p * w;
        p = 0.0094388705 + p * w;
        p = 1.001674 + p * w;
        p = 2.8329768 + p * w;
    }
    return p * x;
}

// Visible-normal sampling of GGX (Heitz 2018, JCGT 7(4)); as sample_ggx_vndf in common.rs.
vec3 sample_ggx_vndf(vec3 wo, vec2 u, float alpha) {
    vec3 v = normalize(vec3(alpha * wo.x, alpha * wo.y, wo.z));
    float len2 = v.x * v.x + v.y * v.y;
    vec3 t1 = len2 > 0.0 ? vec3(-v.y, v.x, 0.0) / sqrt(len2) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(v, t1);
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    float p1 = r * cos(phi);
    float s = 0.5 * (1.0 + v.z);
    float p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * (r * sin(phi));
    vec3 n = p1 * t1 + p2 * t2 + sqrt(max(1.0 - p1 * p1 - p2 * p2, 0.0)) * v;
    return normalize(vec3(alpha * n.x, alpha * n.y, max(n.z, 0.0)));
}

// Slopes of the α = 1 Beckmann visible normals seen from (sin, 0, cos) by Jakob 2014's routine
// (root-finding steps on b = erf(x) inside a bisection bracket, from Jakob's fitted guess) with
// Halley's steps; as beckmann_visible_slopes, which starts from a table of the roots instead
// (here a constant table indexed per invocation made lavapipe's glossy box 1.28x slower; both
// stop at the same tolerance, so the two agree to it, not bit for bit).
#define BECKMANN_VNDF_STEPS 10
#define BECKMANN_VNDF_TOLERANCE 1e-6
const float HALF_SQRT_PI = 0.88622695;
vec2 beckmann_visible_slopes(float cos_t, float sin_t, vec2 u) {
    float tan_t = sin_t / cos_t;
    float cot_t = sin_t * 9.0 >= cos_t ? cos_t / sin_t : 9.0;  // changes no value; no subnormal
    float b_max = 1.0 - erfc(cot_t);
    float k = tan_t * FRAC_1_SQRT_PI;
    float norm = 1.0 / (1.0 + b_max + k * exp(-cot_t * cot_t));
    float theta = acos(clamp(cos_t, -1.0, 1.0));
    float q = 1.0 + theta * (-0.876 + theta * (0.4265 - 0.0594 * theta));
    float b = b_max - (1.0 + b_max) * pow(1.0 - u.x, q);
    float lo = -1.0;
    float hi = b_max;
    // erfinv(b) of the b that met the tolerance, which the loop has just computed, as in Rust.
    bool converged = false;
    float x_converged = 0.0;
    for (int i = 0; i < BECKMANN_VNDF_STEPS; i++) {
        if (!(b >= lo && b <= hi)) b = 0.5 * (lo + hi);
        float x = erfinv_f(b);
        float e = exp(-x * x);
        float value = norm * (1.0 + b + k * e) - u.x;
        if (abs(value) < BECKMANN_VNDF_TOLERANCE) {
            converged = true;
            x_converged = x;
            break;
        }
        if (value > 0.0) {
            hi = b;
        } else {
            lo = b;
        }
        float slope = norm * (1.0 - x * tan_t);
        float curve = -norm * tan_t * HALF_SQRT_PI / e;
        float den = 2.0 * slope * slope - value * curve;
        b = slope > 1e-20 && den > 0.0 ? b - 2.0 * value * slope / den
            : slope > 1e-20 ? b - value / slope : 0.5 * (lo + hi);
    }
    return vec2(converged ? x_converged : erfinv_f(b), erfinv_f(2.0 * u.y - 1.0));
}

// Visible-normal sampling of Beckmann (Heitz & d'Eon 2014); as sample_beckmann_vndf.
vec3 sample_beckmann_vndf(vec3 wo, vec2 u, float alpha) {
    vec3 v = normalize(vec3(alpha * wo.x, alpha * wo.y, wo.z));
    float sin_t = sqrt(v.x * v.x + v.y * v.y);
    vec2 slope = beckmann_visible_slopes(v.z, sin_t, u);
    float c = 1.0;
    float s = 0.0;
    if (sin_t > 0.0) {
        c = v.x / sin_t;
        s = v.y / sin_t;
    }
    float sx = alpha * (c * slope.x - s * slope.y);
    float sy = alpha * (s * slope.x + c * slope.y);
    return normalize(vec3(-sx, -sy, 1.0));
}

// The density at SAMPLED of a visible-normal half-vector sampler reflecting GIVEN:
// G1 · D(H) / (4 cosθ_GIVEN), with G1 the exact Smith G1 of GIVEN and PDF_D = D(H) an
// expression in H = normalize(GIVEN + SAMPLED); 0 when GIVEN·H <= 0 or GIVEN.z <= 0. Returns
// from the function, as RETURN_REFLECTED_PDF. Rust: visible_reflected_pdf.
#define RETURN_VISIBLE_REFLECTED_PDF(GIVEN, SAMPLED, G1, H, PDF_D) \
    { \
        vec3 H = normalize((GIVEN) + (SAMPLED)); \
        if (dot(GIVEN, H) <= 0.0 || (GIVEN).z <= 0.0) return 0.0; \
        return (G1) * (PDF_D) / (4.0 * (GIVEN).z); \
    }

// The solid-angle density at SAMPLED of a lobe that samples a half vector and reflects GIVEN
// about it: PDF_H / (4 GIVEN·H), with PDF_H the half vector's density (cosθh included), an
// expression in H = normalize(GIVEN + SAMPLED); 4 GIVEN·H is the Jacobian of the reflection
// (Walter et al. 2007). 0 when GIVEN·H <= 0, where reflect_about rejects the sample. A macro,
// as RETURN_SCATTERED, because GLSL has no closures: H names the half vector for PDF_H. Returns
// from the function; every model whose lobe samples h and reflects (Cook–Torrance, He, Schlick)
// uses it. Rust: reflected_pdf.
#define RETURN_REFLECTED_PDF(GIVEN, SAMPLED, H, PDF_H) \
    { \
        vec3 H = normalize((GIVEN) + (SAMPLED)); \
        float c_reflected = dot(GIVEN, H); \
        if (c_reflected <= 0.0) return 0.0; \
        return (PDF_H) / (4.0 * c_reflected); \
    }

// ---------------------------------------------------------------------------------------------
// The start and the end of every <model>_sample
// ---------------------------------------------------------------------------------------------

// Clears `s` to "no sample" (an out parameter is written on every path) and says whether
// sampling may go on: not for a `given` direction below the horizon. Every <model>_sample
// (Ward's in ward_sample_local) starts with `if (!sample_begin(given, s)) return false;`.
bool sample_begin(vec3 given, out BrdfSample s) {
    s.wi = vec3(0.0, 0.0, 1.0);
    s.weight = vec3(0.0);
    s.pdf = 0.0;
    s.delta = false;
    return !(given.z <= 0.0);
}

// The pdf of the diffuse models (Lambert, Oren–Nayar): cosθ/π over the upper hemisphere, 0
// unless both directions are above the surface.
float diffuse_pdf(vec3 given, vec3 sampled) {
    if (!same_hemisphere_up(given, sampled)) return 0.0;
    return cosine_hemisphere_pdf(sampled.z);
}

// The pdf of the models with one specular lobe beside a Lambertian one (Phong, Blinn–Phong,
// Ward): the specular lobe, of density `ps` at `sampled`, is sampled with probability p_spec
// (u_lobe < p_spec in their samplers), the cosine-weighted diffuse lobe otherwise. For
// directions both above the surface (the caller checks). Rust: diffuse_specular_pdf.
// The probability of the specular lobe from the lobes' albedo estimates d and s (Rust:
// brdf::common::specular_probability).
float specular_probability(float d, float s) { return d + s > 0.0 ? s / (d + s) : 0.0; }

float diffuse_specular_pdf(float p_spec, float ps, vec3 sampled) {
    return (1.0 - p_spec) * cosine_hemisphere_pdf(sampled.z) + p_spec * ps;
}

// The sample of the diffuse models (Lambert, Oren–Nayar): a cosine-weighted direction s.wi and
// its pdf; false when `given` is not above the surface or the pdf is 0. The model then sets
// s.weight = f·cosθ/pdf, written out (no 0/0 at the horizon).
bool sample_diffuse(vec3 given, vec2 u, out BrdfSample s) {
    if (!sample_begin(given, s)) return false;
    s.wi = sample_cosine_hemisphere(u);
    s.pdf = cosine_hemisphere_pdf(s.wi.z);
    return !(s.pdf <= 0.0);
}

// The sample of a delta mirror lobe (Cook–Torrance below its mirror roughness, He's specular
// lobe, Schlick's mirror): wi = reflect_z(given), no pdf, and `weight` the lobe's reflectance
// divided by the probability of choosing it. Returns true: a sampler ends with
// `return sample_mirror(given, weight, s);`. Rust: BrdfSample::mirror.
bool sample_mirror(vec3 given, vec3 weight, out BrdfSample s) {
    s.wi = reflect_z(given);
    s.weight = weight;
    s.pdf = 0.0;
    s.delta = true;
    return true;
}

// The end of sampling a non-delta lobe, as Rust's BrdfSample::scattered ends it: refuse a
// direction WI below the horizon or with zero density, otherwise weight = f·cosθ/pdf with PDF
// the density of the whole mixture at WI and F the BRDF there. A macro, because GLSL has no
// closures: PDF and F are evaluated only when needed. Writes `s` and returns from the sampler.
#define RETURN_SCATTERED(WI, PDF, F) \
    { \
        if (WI.z <= 0.0) return false; \
        float p_scattered = PDF; \
        if (p_scattered <= 0.0) return false; \
        s.wi = WI; \
        s.pdf = p_scattered; \
        s.weight = (F) * (WI.z / p_scattered); \
        return true; \
    }

#endif
