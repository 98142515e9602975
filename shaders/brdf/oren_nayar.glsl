// Oren–Nayar 1994, survey §2.1.2 (no equation in the survey; the paper's full and qualitative
// models). Parameters, defaults, ranges, reciprocity/energy notes: src/brdf/oren_nayar.rs.
// Record: p[0].xyz = albedo, p[0].w = sigma (radians), p[1].x = variant (OREN_NAYAR_FULL,
// OREN_NAYAR_QUALITATIVE: generated from oren_nayar::RECORD_CODES).
#ifndef BRDF_OREN_NAYAR_GLSL
#define BRDF_OREN_NAYAR_GLSL
#include "brdf/common.glsl"

// Rust: oren_nayar::forward_c2_over_cos. (sin(alpha) - (2 beta/pi)^3) / cos(beta) without the
// cancellation near the horizon: with db = pi/2 - beta, da = pi/2 - alpha, x = 2 db/pi,
// sin(alpha) - (2 beta/pi)^3 = x (3 - 3x + x^2) - 2 sin^2(da/2), and db/cos(beta) -> 1/sin(beta).
float forward_c2_over_cos(float sin_alpha, float cos_alpha, float sin_beta, float cos_beta) {
    float cb = max(cos_beta, 1e-30);
    float d_beta = atan(cb, sin_beta);
    float d_alpha = atan(max(cos_alpha, 0.0), sin_alpha);
    float x = 2.0 * d_beta / PI;
    float h = sin(0.5 * d_alpha);
    return (2.0 / PI) * (d_beta / cb) * (3.0 - 3.0 * x + x * x) - 2.0 * h * h / cb;
}

vec3 oren_nayar_eval(Material m, vec3 wi, vec3 wo) {
    if (!same_hemisphere_up(wi, wo)) return vec3(0.0);
    vec3 albedo = m.p[0].xyz;
    float s2 = m.p[0].w * m.p[0].w;
    float a = 1.0 - 0.5 * s2 / (s2 + 0.33);
    float b = 0.45 * s2 / (s2 + 0.09);
    float sin_i = length(wi.xy);
    float sin_o = length(wo.xy);
    float sxy = wi.x * wo.x + wi.y * wo.y;  // sin(theta_i) sin(theta_o) cos(dphi)
    float cos_beta = max(max(wi.z, wo.z), 1e-6);
    if (m.p[1].x == OREN_NAYAR_QUALITATIVE) {
        return albedo * (INV_PI * (a + b * max(sxy, 0.0) / cos_beta));
    }
    float cos_dphi = (sin_i < 1e-4 || sin_o < 1e-4) ? 0.0 : clamp(sxy / (sin_i * sin_o), -1.0, 1.0);
    float theta_i = atan(sin_i, wi.z);
    float theta_o = atan(sin_o, wo.z);
    float alpha = max(theta_i, theta_o);
    float beta = min(theta_i, theta_o);
    float sin_alpha = max(sin_i, sin_o);
    float sin_beta = min(sin_i, sin_o);
    float tan_half = (sin_alpha + sin_beta) / max(wi.z + wo.z, 1e-6);  // tan((alpha+beta)/2)
    float two_beta_pi = 2.0 * beta / PI;
    float c2_tan_beta = cos_dphi >= 0.0
        ? b * sin_alpha * sin_beta / cos_beta
        : b * sin_beta * forward_c2_over_cos(sin_alpha, min(wi.z, wo.z), sin_beta, max(wi.z, wo.z));
    float t = 4.0 * alpha * beta / (PI * PI);
    float c3 = 0.125 * s2 / (s2 + 0.09) * t * t;
    float l1 = max(a + cos_dphi * c2_tan_beta + (1.0 - abs(cos_dphi)) * c3 * tan_half, 0.0);
    float l2 = 0.17 * s2 / (s2 + 0.13) * (1.0 - cos_dphi * two_beta_pi * two_beta_pi);
    return (albedo * l1 + albedo * albedo * l2) * INV_PI;
}

float oren_nayar_pdf(Material m, vec3 given, vec3 sampled) {
    return diffuse_pdf(given, sampled);
}

bool oren_nayar_sample(Material m, vec3 given, float u_lobe, vec2 u, out BrdfSample s) {
    if (!sample_diffuse(given, u, s)) return false;
    s.weight = oren_nayar_eval(m, s.wi, given) * PI;  // f cos / (cos/pi)
    return true;
}


#ifdef SCENE_TEXTURES
// A textured material's record after its parameters' values are written (texture.glsl): oren_nayar
// derives nothing from them (Rust twin: oren_nayar::with_params).
void oren_nayar_textured(inout Material m) {}
#endif

#endif
