// Blinn–Phong 1977, survey eq. 5 (half vector) with Phong's eq. 4: `classic`; or Giesen's
// normalized lobe. Parameters, defaults, ranges, reciprocity/energy notes:
// src/brdf/blinn_phong.rs.
// Record: p[0].xyz = kd, p[0].w = exponent, p[1].xyz = ks, p[1].w = form (BLINN_PHONG_CLASSIC,
// BLINN_PHONG_NORMALIZED: generated from blinn_phong::RECORD_CODES), p[2].x = probability of sampling the specular lobe, p[2].y = k_n.
#ifndef BRDF_BLINN_PHONG_GLSL
#define BRDF_BLINN_PHONG_GLSL
#include "brdf/common.glsl"

#define BLINN_PHONG_COS_FLOOR 1e-6

// Unit half vector h of a and b and x = 1 - h.z; false when a + b ~ 0.
bool blinn_phong_half(vec3 a, vec3 b, out vec3 h, out float x) {
    vec3 hv = a + b;
    float len2 = dot(hv, hv);
    h = vec3(0.0, 0.0, 1.0);
    x = 0.0;
    if (len2 <= 1e-20) return false;
    h = hv / sqrt(len2);
    float sin2 = (hv.x * hv.x + hv.y * hv.y) / len2;
    x = sin2 / (1.0 + max(h.z, 0.0));
    return true;
}

float blinn_phong_sample_exponent(Material m) {
    return m.p[1].w == BLINN_PHONG_NORMALIZED ? m.p[0].w + 1.0 : m.p[0].w;
}

vec3 blinn_phong_eval(Material m, vec3 wi, vec3 wo) {
    if (!same_hemisphere_up(wi, wo)) return vec3(0.0);
    vec3 diffuse = m.p[0].xyz * INV_PI;
    vec3 h;
    float x;
    if (!blinn_phong_half(wi, wo, h, x)) return diffuse;
    float l = pow_one_minus(x, m.p[0].w);
    float spec = m.p[1].w == BLINN_PHONG_NORMALIZED ? l * m.p[2].y : l / max(wi.z, BLINN_PHONG_COS_FLOOR);
    return diffuse + m.p[1].xyz * spec;
}

float blinn_phong_pdf(Material m, vec3 given, vec3 sampled) {
    if (!same_hemisphere_up(given, sampled)) return 0.0;
    float ps = 0.0;
    vec3 h;
    float x;
    if (blinn_phong_half(given, sampled, h, x)) {
        float e = blinn_phong_sample_exponent(m);
        float pdf_h = (e + 1.0) * (0.5 * INV_PI) * pow_one_minus(x, e);
        ps = pdf_h / (4.0 * max(dot(given, h), 1e-10));
    }
    return diffuse_specular_pdf(m.p[2].x, ps, sampled);
}

bool blinn_phong_sample(Material m, vec3 given, float u_lobe, vec2 u, out BrdfSample s) {
    if (!sample_begin(given, s)) return false;
    vec3 wi;
    if (u_lobe < m.p[2].x) {
        // cos(theta_h) = u'^(1/(e+1)), u' = 1 - u.x in (0, 1].
        float l = log(1.0 - u.x) / (blinn_phong_sample_exponent(m) + 1.0);
        float cos_h = exp(l);
        float sin_h = sqrt(max(-expm1_f(2.0 * l), 0.0));
        float phi = 2.0 * PI * u.y;
        vec3 h = vec3(sin_h * cos(phi), sin_h * sin(phi), cos_h);
        if (!reflect_about(given, h, wi)) return false;
    } else {
        wi = sample_cosine_hemisphere(u);
    }
    RETURN_SCATTERED(wi, blinn_phong_pdf(m, given, wi), blinn_phong_eval(m, wi, given));
}


#ifdef SCENE_TEXTURES
// A textured material's record after its parameters' values are written (texture.glsl): the
// lobe-selection probability p[2].x and Giesen's k_n p[2].y recomputed as BlinnPhong::new does
// (Rust twin: blinn_phong::with_params).
void blinn_phong_textured(inout Material m) {
    float n = m.p[0].w;
    float es = m.p[1].w == BLINN_PHONG_NORMALIZED ? 1.0 : 8.0 * PI * (1.0 - exp2(-0.5 * (n + 2.0))) / (n + 2.0);
    m.p[2].x = specular_probability(luminance(m.p[0].xyz), luminance(m.p[1].xyz) * es);
    m.p[2].y = (n + 2.0) * (n + 4.0) / (8.0 * PI * (exp2(-0.5 * n) + n));
}
#endif

#endif
