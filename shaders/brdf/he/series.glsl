// The series of He et al.'s directional-diffuse term (the D of survey eq. 12), summed in log
// space over a window that provably holds all but e^(−40) of it. Rust twin:
// src/brdf/he/series.rs (the window's proof, the cap and the accuracy).
#ifndef BRDF_HE_SERIES_GLSL
#define BRDF_HE_SERIES_GLSL
#include "brdf/common.glsl"

#define HE_MAX_TERMS 128

// φ(ε) = ε − ln(1 + ε) without cancellation near 0 (series in z = ε/(2+ε)).
float he_phi_ln(float eps) {
    float z = eps / (2.0 + eps);
    if (abs(z) > 1.0 / 3.0) {
        precise float d = eps - log(1.0 + eps);
        return d;
    }
    float z2 = z * z;
    float s = 1.0 / 3.0
        + z2 * (1.0 / 5.0
        + z2 * (1.0 / 7.0
        + z2 * (1.0 / 9.0 + z2 * (1.0 / 11.0 + z2 * (1.0 / 13.0 + z2 * (1.0 / 15.0))))));
    precise float r = 2.0 * z2 / (1.0 - z) - 2.0 * z * z2 * s;
    return r;
}

float he_stirling_remainder(float m) {
    if (m < 1.5) return 0.08106147;
    if (m < 2.5) return 0.0413407;
    if (m < 3.5) return 0.027677926;
    float i = 1.0 / m;
    float i2 = i * i;
    return i * (1.0 / 12.0 - i2 * (1.0 / 360.0 - i2 * (1.0 / 1260.0)));
}

// ln t(m), t(m) = gᵐ e^(−g)/(m!·m) e^(−c/m) (Rust: series_log_term).
float he_log_term(float g, float c, float m) {
    float ln_m = log(m);
    float r = g / m;
    float lead = (r >= 0.5 && r <= 2.0) ? -m * he_phi_ln(r - 1.0) : m * (log(g) - ln_m) + m - g;
    return lead - 0.5 * log(2.0 * PI) - 0.5 * ln_m - he_stirling_remainder(m) - ln_m - c / m;
}
// ln(t(m+1)/t(m)), decreasing in m (Rust: series_log_ratio).
float he_log_ratio(float g, float c, float m) {
    return log(g) + log(m / (m + 1.0)) - log(m + 1.0) + c / (m * (m + 1.0));
}
#define HE_WINDOW_DROP 40.0
#define HE_BISECTION_STEPS 40

// Bisection of an integer bracket [A, B] (float variables) until B - A <= 1, at most
// HE_BISECTION_STEPS halvings: the midpoint MID replaces B where TO_B (an expression in MID)
// holds, A otherwise. A macro because GLSL has no closures; the three searches of
// he_series use it, as the Rust series_window uses bisect.
#define HE_BISECT(A, B, MID, TO_B) \
    for (int i_bisect = 0; i_bisect < HE_BISECTION_STEPS; ++i_bisect) { \
        if (B - A <= 1.0) break; \
        float MID = floor(0.5 * (A + B)); \
        if (TO_B) B = MID; else A = MID; \
    }

bool he_up_ok(float g, float c, float m, float peak) {
    float lr = he_log_ratio(g, c, m);
    return lr < 0.0 && he_log_term(g, c, m) - log(expm1_f(-lr)) <= peak;
}
bool he_lo_ok(float g, float c, float m, float peak) {
    if (m <= 1.0) return true;
    float lr = he_log_ratio(g, c, m - 1.0);
    return lr > 0.0 && he_log_term(g, c, m) - log(expm1_f(lr)) <= peak;
}

// Σ_{m≥1} gᵐ e^(−g)/(m!·m) e^(−c/m): log space over the window of the Rust series_window (mode
// by bisection on the term ratio, ends where the geometric bound on the rest is e^(−40) of it;
// the proof is there), at most HE_MAX_TERMS strided terms.
float he_series(float g, float c) {
    if (g <= 1e-30 || !(c >= 0.0)) return 0.0;
    float start = 2.0 * sqrt(c);
    float mode = 1.0;
    if (!(he_log_ratio(g, c, 1.0) < 0.0)) {
        float a = 1.0;
        float b = ceil(max(2.0 * g, start)) + 1.0;
        HE_BISECT(a, b, mid, he_log_ratio(g, c, mid) < 0.0)  // smallest m with ln ρ(m) < 0
        mode = b;
    }
    float peak = he_log_term(g, c, mode) - HE_WINDOW_DROP;
    float a = mode;
    float b = ceil(max(4.0 * g, start)) + 60.0;
    if (he_up_ok(g, c, a, peak)) b = a;
    HE_BISECT(a, b, mid, he_up_ok(g, c, mid, peak))  // smallest m >= mode with he_up_ok
    float hi = b;
    a = 1.0;
    b = mode;
    if (he_lo_ok(g, c, b, peak)) a = b;
    HE_BISECT(a, b, mid, !he_lo_ok(g, c, mid, peak))  // largest m <= mode with he_lo_ok
    float lo = a;
    float count = hi - lo + 1.0;
    float stride = max(ceil(count / float(HE_MAX_TERMS)), 1.0);
    float sum = 0.0;
    for (int j = 0; j < HE_MAX_TERMS; ++j) {
        float mm = lo + float(j) * stride;
        if (mm > hi) break;
        sum += exp(he_log_term(g, c, mm));
    }
    return sum * stride;
}

#endif
