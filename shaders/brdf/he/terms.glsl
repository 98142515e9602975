// He et al.'s terms (survey eqs. 11 and 15): the directional-diffuse term without Fresnel and
// the coherent (specular) lobe's attenuation and reflectance. Rust twin: src/brdf/he/terms.rs.
#ifndef BRDF_HE_TERMS_GLSL
#define BRDF_HE_TERMS_GLSL
#include "brdf/he/series.glsl"
#include "brdf/he/shadowing.glsl"

float he_dd_unit(Material m, float lambda, float sigma, vec3 wi, vec3 wo) {
    float sigma0 = m.p[0].x;
    float tau = m.p[0].y;
    vec3 v = wi + wo;
    float vz = wi.z + wo.z;
    if (vz <= 1e-6) return 0.0;
    float vxy2 = v.x * v.x + v.y * v.y;
    float gg = dot(v, v) / vz;
    float geo = gg * gg;
    float s = he_shadow_s1(sigma0, tau, wi) * he_shadow_s1(sigma0, tau, wo);
    float kw = 2.0 * PI / lambda;
    float ks = kw * sigma * vz;
    float g = ks * ks;
    float c = 0.25 * kw * kw * vxy2 * tau * tau;
    float d_over_pi = PI * tau * tau / (4.0 * lambda * lambda) * he_series(g, c);
    return geo * s * d_over_pi / max(wi.z * wo.z, 1e-30);
}

float he_specular_attenuation(Material m, float lambda, vec3 w) {
    float sigma = he_effective_sigma(m, w, w);
    float s1 = he_shadow_s1(m.p[0].x, m.p[0].y, w);
    float a = 4.0 * PI * sigma * w.z / lambda;
    return exp(-a * a) * s1 * s1;
}

vec3 he_specular_exp(Material m, float sigma, vec3 w) {
    vec3 l = m.p[3].xyz;
    float k = 4.0 * PI * sigma * w.z;
    vec3 a = vec3(k / l.x, k / l.y, k / l.z);
    return vec3(exp(-a.x * a.x), exp(-a.y * a.y), exp(-a.z * a.z));
}

vec3 he_specular_reflectance(Material m, vec3 w) {
    vec3 f = fresnel_conductor(w.z, m.p[1].xyz, m.p[2].xyz);
    float sigma = he_effective_sigma(m, w, w);
    float s1 = he_shadow_s1(m.p[0].x, m.p[0].y, w);
    return f * he_specular_exp(m, sigma, w) * (s1 * s1);
}

#endif
