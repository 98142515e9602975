// He et al. 1991's shadowing S₁ (eq. 13 with the erratum's Λ) and effective roughness σ
// (the paper's eqs. 80–83). Rust twin: src/brdf/he/shadowing.rs (the derivations).
#ifndef BRDF_HE_SHADOWING_GLSL
#define BRDF_HE_SHADOWING_GLSL
#include "brdf/common.glsl"

#define HE_NEWTON_STEPS 6

float he_shadow_arg(float sigma0, float tau, vec3 w) {
    float s = sqrt(w.x * w.x + w.y * w.y);
    float den = 2.0 * sigma0 * s;
    if (den <= 1e-30 || tau * w.z >= 30.0 * den) return 30.0;
    return tau * max(w.z, 0.0) / den;
}

float he_shadow_s1(float sigma0, float tau, vec3 w) {
    if (w.z <= 0.0) return 0.0;
    float a = he_shadow_arg(sigma0, tau, w);
    float n = a * (1.0 - 0.5 * erfc(a));
    float e = a >= 9.0 ? 0.0 : exp(-a * a) * (0.5 / sqrt(PI));  // S1 = 1 either way from 9
    return n / (n + e);
}

float he_k_term(float sigma0, float tau, vec3 w) {
    float s = sqrt(w.x * w.x + w.y * w.y);
    if (s <= 0.0) return 0.0;
    float tn = s >= 1e6 * w.z ? 1e6 : s / w.z;
    return tn * erfc(he_shadow_arg(sigma0, tau, w));
}

float he_solve_z0(float f0) {
    if (f0 <= 1e-30) return 0.0;
    float l = log(f0);
    float x;
    if (f0 <= 1.0) x = f0;
    else if (l < 0.5) x = 1.0;
    else x = sqrt(2.0 * l);
    for (int i = 0; i < HE_NEWTON_STEPS; ++i) {
        precise float g = log(x) + 0.5 * x * x - l;
        x -= g / (1.0 / x + x);
        x = max(x, 1e-30);
    }
    return x;
}

float he_effective_sigma(Material m, vec3 wi, vec3 wo) {
    float sigma0 = m.p[0].x;
    float tau = m.p[0].y;
    if (sigma0 <= 0.0) return 0.0;
    float f0 = (he_k_term(sigma0, tau, wi) + he_k_term(sigma0, tau, wo)) / sqrt(8.0 * PI);
    float x = he_solve_z0(f0);
    return sigma0 / sqrt(1.0 + x * x);
}

#endif
