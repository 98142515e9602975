// Schlick 1994, single and two-layer materials, survey eqs. 18–26. Rust twin:
// src/brdf/schlick.rs (parameter table, how each form is read from the survey, corrections).
// Record: p[0].xyz c, p[0].w r, p[1].xyz c2, p[1].w r2, p[2].x p, p[2].y p2,
// p[2].z form (SCHLICK_BASIC,
// SCHLICK_ATTENUATED, SCHLICK_CONTINUUM: generated from schlick::RECORD_CODES), p[2].w layered, p[3].x cos(rotation),
// p[3].y sin(rotation).
// SCHLICK_LAYERED compiles the second layer, SCHLICK_ANISOTROPIC the azimuth factor A
// (without it A ≡ 1, exact for p = 1).
#include "brdf/common.glsl"

#define SCHLICK_R_MIN 1e-4
#define SCHLICK_P_MIN 1e-3

vec3 schlick_spectral(vec3 c, float u) {
    precise float m = clamp(1.0 - clamp(u, 0.0, 1.0), 0.0, 1.0);
    float m2 = m * m;
    return c + (vec3(1.0) - c) * (m2 * m2 * m);
}

// (a, b, c) of eq. 26.
vec3 schlick_continuum_coeffs(float r) {
    float b = 4.0 * r * (1.0 - r);
    if (r < 0.5) return vec3(0.0, b, 1.0 - b);
    return vec3(1.0 - b, b, 0.0);
}

float schlick_zenith(float r, vec3 h) {
    r = max(r, SCHLICK_R_MIN);
    float d = h.x * h.x + h.y * h.y + r * h.z * h.z;
    if (d <= 0.0) return 0.0;
    return r / (d * d);
}

float schlick_azimuth2(float p, float cs, float sn, vec3 h) {
#ifdef SCHLICK_ANISOTROPIC
    p = max(p, SCHLICK_P_MIN);
    float s2 = h.x * h.x + h.y * h.y;
    if (s2 <= 1e-20) return 1.0;
    float hx = h.x * cs + h.y * sn;
    float hy = h.y * cs - h.x * sn;
    return p * s2 / (p * p * hy * hy + hx * hx);
#else
    return 1.0;
#endif
}

float schlick_q(float r, float v) {
    r = max(r, SCHLICK_R_MIN);
    return r + (1.0 - r) * v;
}

float schlick_shadow_g(float r, float v) { return v / schlick_q(r, v); }

float schlick_glossy(float r, float p, float cs, float sn, vec3 wi, vec3 wo, vec3 h) {
    return schlick_zenith(r, h) * sqrt(schlick_azimuth2(p, cs, sn, h))
        / (4.0 * PI * schlick_q(r, wi.z) * schlick_q(r, wo.z));
}

float schlick_layer_d(float form, float r, float p, float cs, float sn, vec3 wi, vec3 wo, vec3 h) {
    float vv = max(wi.z * wo.z, 1e-20);
    if (form == SCHLICK_BASIC) return schlick_zenith(r, h) * sqrt(schlick_azimuth2(p, cs, sn, h)) / (4.0 * PI * vv);
    if (form == SCHLICK_ATTENUATED) {
        float gg = schlick_shadow_g(r, wi.z) * schlick_shadow_g(r, wo.z);
        precise float re = max(1.0 - gg, 0.0);
        return schlick_glossy(r, p, cs, sn, wi, wo, h) + re / (4.0 * PI * vv);
    }
    vec3 abc = schlick_continuum_coeffs(r);
    float d = abc.x * INV_PI;
    if (abc.y > 0.0) d += abc.y * schlick_glossy(r, p, cs, sn, wi, wo, h);
    return d;
}

vec3 schlick_eval(Material m, vec3 wi, vec3 wo) {
    if (!same_hemisphere_up(wi, wo)) return vec3(0.0);
    float cs = m.p[3].x;
    float sn = m.p[3].y;
    float form = m.p[2].z;
    vec3 h = normalize(wi + wo);
    float u = dot(wi, h);
    vec3 s1 = schlick_spectral(m.p[0].xyz, u);
    vec3 f = s1 * schlick_layer_d(form, m.p[0].w, m.p[2].x, cs, sn, wi, wo, h);
#ifdef SCHLICK_LAYERED
    if (m.p[2].w > 0.5) {
        vec3 s2 = (vec3(1.0) - s1) * schlick_spectral(m.p[1].xyz, u);
        f += s2 * schlick_layer_d(form, m.p[1].w, m.p[2].y, cs, sn, wi, wo, h);
    }
#endif
    return f;
}

// (glossy, diffuse-like, delta) weights of one layer.
vec3 schlick_layer_weights(float form, float r, float s, float mu) {
    if (form == SCHLICK_BASIC) return vec3(s, 0.0, 0.0);
    if (form == SCHLICK_ATTENUATED) {
        float g = schlick_shadow_g(r, mu);
        return vec3(s * g, s * (1.0 - g), 0.0);
    }
    vec3 abc = schlick_continuum_coeffs(r);
    return vec3(s * abc.y, s * abc.x, s * abc.z);
}

// [glossy layer 1, glossy layer 2, diffuse-like, delta].
vec4 schlick_lobe_probabilities(Material m, vec3 given) {
    float form = m.p[2].z;
    vec3 s1 = schlick_spectral(m.p[0].xyz, given.z);
    vec3 w1 = schlick_layer_weights(form, m.p[0].w, luminance(s1), given.z);
    vec3 w2 = vec3(0.0);
#ifdef SCHLICK_LAYERED
    if (m.p[2].w > 0.5) {
        vec3 s2 = (vec3(1.0) - s1) * schlick_spectral(m.p[1].xyz, given.z);
        w2 = schlick_layer_weights(form, m.p[1].w, luminance(s2), given.z);
    }
#endif
    float total = w1.x + w2.x + w1.y + w2.y + w1.z + w2.z;
    if (total <= 0.0) return vec4(1.0, 0.0, 0.0, 0.0);
    return vec4(w1.x / total, w2.x / total, (w1.y + w2.y) / total, (w1.z + w2.z) / total);
}

vec3 schlick_mirror_reflectance(Material m, vec3 given) {
    if (m.p[2].z != SCHLICK_CONTINUUM) return vec3(0.0);
    vec3 s1 = schlick_spectral(m.p[0].xyz, given.z);
    vec3 f = s1 * schlick_continuum_coeffs(m.p[0].w).z;
#ifdef SCHLICK_LAYERED
    if (m.p[2].w > 0.5)
        f += (vec3(1.0) - s1) * schlick_spectral(m.p[1].xyz, given.z) * schlick_continuum_coeffs(m.p[1].w).z;
#endif
    return f;
}

vec3 schlick_sample_glossy_h(float r, float p, float cs, float sn, vec2 u) {
    r = max(r, SCHLICK_R_MIN);
    p = max(p, SCHLICK_P_MIN);
    float tan2 = r * u.x / max(1.0 - u.x, 1e-30);
    float cos_t = 1.0 / sqrt(1.0 + tan2);
    float sin_t = sqrt(tan2) * cos_t;
    float v = 4.0 * u.y;
    float quadrant = min(floor(v), 3.0);
    float uq = v - quadrant;
    float a = uq * (0.5 * PI);
    float phi0 = atan(sin(a), p * cos(a));
    float phi;
    if (quadrant < 0.5) phi = phi0;
    else if (quadrant < 1.5) phi = PI - phi0;
    else if (quadrant < 2.5) phi = PI + phi0;
    else phi = 2.0 * PI - phi0;
    float sp = sin(phi);
    float cp = cos(phi);
    float x = cp * cs - sp * sn;
    float y = sp * cs + cp * sn;
    return vec3(sin_t * x, sin_t * y, cos_t);
}

float schlick_glossy_pdf(float r, float p, float cs, float sn, vec3 given, vec3 sampled) {
    RETURN_REFLECTED_PDF(given, sampled, h,
                         schlick_zenith(r, h) * h.z * schlick_azimuth2(p, cs, sn, h) * INV_PI);
}

vec3 schlick_sample_uniform_hemisphere(vec2 u) {
    float z = 1.0 - u.x;
    float s = sqrt(max(1.0 - z * z, 0.0));
    float phi = 2.0 * PI * u.y;
    return vec3(s * cos(phi), s * sin(phi), z);
}

float schlick_pdf(Material m, vec3 given, vec3 sampled) {
    if (!same_hemisphere_up(given, sampled)) return 0.0;
    float cs = m.p[3].x;
    float sn = m.p[3].y;
    vec4 pr = schlick_lobe_probabilities(m, given);
    float p = 0.0;
    if (pr.x > 0.0) p += pr.x * schlick_glossy_pdf(m.p[0].w, m.p[2].x, cs, sn, given, sampled);
    if (pr.y > 0.0) p += pr.y * schlick_glossy_pdf(m.p[1].w, m.p[2].y, cs, sn, given, sampled);
    if (pr.z > 0.0) {
        float pd = m.p[2].z == SCHLICK_ATTENUATED ? 0.5 * INV_PI : cosine_hemisphere_pdf(sampled.z);
        p += pr.z * pd;
    }
    return p;
}

bool schlick_sample(Material m, vec3 given, float u_lobe, vec2 u, out BrdfSample s) {
    if (!sample_begin(given, s)) return false;
    float cs = m.p[3].x;
    float sn = m.p[3].y;
    vec4 pr = schlick_lobe_probabilities(m, given);
    vec3 wi;
    if (u_lobe < pr.w) {
        return sample_mirror(given, schlick_mirror_reflectance(m, given) / pr.w, s);
    } else if (u_lobe < pr.w + pr.x + pr.y) {
        vec3 h;
        if (u_lobe < pr.w + pr.x) h = schlick_sample_glossy_h(m.p[0].w, m.p[2].x, cs, sn, u);
        else h = schlick_sample_glossy_h(m.p[1].w, m.p[2].y, cs, sn, u);
        if (!reflect_about(given, h, wi)) return false;
    } else if (m.p[2].z == SCHLICK_ATTENUATED) {
        wi = schlick_sample_uniform_hemisphere(u);
    } else {
        wi = sample_cosine_hemisphere(u);
    }
    RETURN_SCATTERED(wi, schlick_pdf(m, given, wi), schlick_eval(m, wi, given));
}

#ifdef SCENE_TEXTURES
// A textured material's record after its parameters' values are written (texture.glsl): schlick
// derives nothing from them (Rust twin: schlick::with_params).
void schlick_textured(inout Material m) {}
#endif
