// The series of He et al.'s directional-diffuse term (the D of survey eq. 12), summed over a
// window that provably holds all but e^(−20) of it: term by term from the largest one by the
// ratio of consecutive terms, or every s-th term in log space where the window is wide. Rust
// twin: src/brdf/he/series.rs (the window's proof, the caps and the accuracy).
#ifndef BRDF_HE_SERIES_GLSL
#define BRDF_HE_SERIES_GLSL
#include "brdf/common.glsl"

#define HE_MAX_TERMS 128
#define HE_STRIDED_TERMS 32

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
    float n = m + 1.0;
    return log(g) + log(m / (n * n)) + c / (m * n);
}
// t(m+1)/t(m) = g·m/(m+1)² e^(c/(m(m+1))), +inf where the exponential overflows (Rust:
// series_ratio).
float he_ratio(float g, float c, float m) {
    float n = m + 1.0;
    return g * m / (n * n) * exp(c / (m * n));
}
#define HE_WINDOW_DROP 20.0
#define HE_WINDOW_DROP_RATIO exp(-HE_WINDOW_DROP)
#define HE_BISECTION_STEPS 40

// Bisection of an integer bracket [A, B] (float variables) until B - A <= 1, at most
// HE_BISECTION_STEPS halvings: the midpoint MID replaces B where TO_B (an expression in MID)
// holds, A otherwise. A macro because GLSL has no closures; the three searches of
// he_series use it, as the Rust series_mode and series_ends use bisect.
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

// The smallest m >= 1 with ln ρ(m) < 0: the largest term (Rust: series_mode).
float he_mode(float g, float c) {
    if (he_log_ratio(g, c, 1.0) < 0.0) return 1.0;
    float a = 1.0;
    float b = ceil(max(2.0 * g, 2.0 * sqrt(c))) + 1.0;
    HE_BISECT(a, b, mid, he_log_ratio(g, c, mid) < 0.0)
    return b;
}
// Σ t(m)/t(mode) over the window, term by term outwards from the mode; a negative value when
// the window holds more than HE_MAX_TERMS terms (Rust: series_walk, where the end tests are
// explained).
float he_walk(float g, float c, float mode) {
    float sum = 1.0;
    int terms = 1;
    float m = mode;
    float t = 1.0;
    for (int j = 0; j < HE_MAX_TERMS; ++j) {
        float rho = he_ratio(g, c, m);
        if (rho < 1.0 && t * rho <= HE_WINDOW_DROP_RATIO * (1.0 - rho)) break;
        if (terms == HE_MAX_TERMS) return -1.0;
        t *= rho;
        m += 1.0;
        sum += t;
        terms += 1;
    }
    m = mode;
    t = 1.0;
    for (int j = 0; j < HE_MAX_TERMS && m > 1.0; ++j) {
        float rho = he_ratio(g, c, m - 1.0);
        if (rho > 1.0 && t <= HE_WINDOW_DROP_RATIO * (rho - 1.0)) break;
        if (terms == HE_MAX_TERMS) return -1.0;
        t /= rho;
        m -= 1.0;
        sum += t;
        terms += 1;
    }
    return sum;
}
// Σ_{m≥1} gᵐ e^(−g)/(m!·m) e^(−c/m) over the window of the Rust series_ends (mode by
// bisection on the term ratio, ends where the geometric bound on the rest is e^(−20) of it; the
// proof is there): he_walk times the largest term, or HE_STRIDED_TERMS strided terms in log
// space where the window looks wide or the walk gives up.
float he_series(float g, float c) {
    if (g <= 1e-30 || !(c >= 0.0)) return 0.0;
    float mode = he_mode(g, c);
    // The window's predicted width, 2√(2·HE_WINDOW_DROP)·√(mode³/(mode² + 2c)) terms, at most
    // 110: walk (Rust: series_looks_narrow).
    if (8.0 * HE_WINDOW_DROP * mode * mode * mode <= 12100.0 * (mode * mode + 2.0 * c)) {
        float relative = he_walk(g, c, mode);
        if (relative > 0.0) return exp(he_log_term(g, c, mode)) * relative;
    }
    float start = 2.0 * sqrt(c);
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
    float stride = max(ceil(count / float(HE_STRIDED_TERMS)), 1.0);
    float sum = 0.0;
    for (int j = 0; j < HE_STRIDED_TERMS; ++j) {
        float mm = lo + float(j) * stride;
        if (mm > hi) break;
        sum += exp(he_log_term(g, c, mm));
    }
    return sum * stride;
}
#endif
