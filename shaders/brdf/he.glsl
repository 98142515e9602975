// He, Torrance, Sillion & Greenberg 1991, survey eqs. 10–15 (the paper's eqs. 24–25, 76–83 with
// its erratum's e^(−a²) in the shadowing).
// Rust twin: src/brdf/he.rs (parameter table, corrections to the survey's eq. 15, the series
// window (with its proof)/cap and its accuracy, sampling).
// Record: p[0].x σ₀, p[0].y τ, p[0].z 1 if σ₀ > 0, p[1].xyz ior, p[2].xyz κ,
// p[3].xyz wavelengths (µm), p[4].xyz diffuse.
// Define HE_SERIES to compile the directional-diffuse series (every material with σ₀ > 0
// requests it); without it f_dd is 0, exact for σ₀ = 0.
#include "brdf/common.glsl"

#define HE_MAX_TERMS 128
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
    float e = exp(-a * a) * (0.5 / sqrt(PI));
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

vec3 he_eval(Material m, vec3 wi, vec3 wo) {
    if (!same_hemisphere_up(wi, wo)) return vec3(0.0);
    vec3 ud = m.p[4].xyz * INV_PI;
    if (m.p[0].x <= 0.0) return ud;
#ifdef HE_SERIES
    float sigma = he_effective_sigma(m, wi, wo);
    vec3 h = normalize(wi + wo);
    vec3 f = fresnel_conductor(dot(wi, h), m.p[1].xyz, m.p[2].xyz);
    vec3 l = m.p[3].xyz;
    vec3 dd = vec3(he_dd_unit(m, l.x, sigma, wi, wo), he_dd_unit(m, l.y, sigma, wi, wo),
                   he_dd_unit(m, l.z, sigma, wi, wo));
    return ud + f * dd;
#else
    return ud;
#endif
}

// (P_delta, P_beckmann, P_cosine, m_s) for the known direction.
vec4 he_lobe_probabilities(Material m, vec3 given) {
    float sigma0 = m.p[0].x;
    float tau = m.p[0].y;
    vec3 f = fresnel_conductor(given.z, m.p[1].xyz, m.p[2].xyz);
    float sigma = he_effective_sigma(m, given, given);
    float s1 = he_shadow_s1(sigma0, tau, given);
    vec3 l = m.p[3].xyz;
    float spec = luminance(f * he_specular_exp(m, sigma, given) * (s1 * s1));
    float k = 4.0 * PI * sigma * given.z;
    vec3 a = vec3(k / l.x, k / l.y, k / l.z);
    vec3 gs = vec3(-expm1_f(-a.x * a.x), -expm1_f(-a.y * a.y),
                   -expm1_f(-a.z * a.z));
    float wdd = luminance(f * gs) * s1;
    float wb = 0.9 * wdd;
    float wc = luminance(m.p[4].xyz) + 0.1 * wdd;
    float total = spec + wb + wc;
    float lmax = max(max(l.x, l.y), l.z);
    float rough = 2.0 * sigma0 / tau;
    float diffr = lmax / (2.0 * PI * tau * max(given.z, 1e-6));
    float ms = clamp(sqrt(rough * rough + diffr * diffr), 1e-4, 1.0);
    if (total <= 0.0) return vec4(0.0, 0.0, 1.0, ms);
    return vec4(spec / total, wb / total, wc / total, ms);
}

float he_beckmann_lobe_pdf(float ms, vec3 given, vec3 sampled) {
    RETURN_REFLECTED_PDF(given, sampled, h, beckmann_d(h, ms) * h.z);
}

float he_pdf(Material m, vec3 given, vec3 sampled) {
    if (!same_hemisphere_up(given, sampled)) return 0.0;
    vec4 lp = he_lobe_probabilities(m, given);
    float p = lp.z * cosine_hemisphere_pdf(sampled.z);
    if (lp.y > 0.0) p += lp.y * he_beckmann_lobe_pdf(lp.w, given, sampled);
    return p;
}

bool he_sample(Material m, vec3 given, float u_lobe, vec2 u, out BrdfSample s) {
    if (!sample_begin(given, s)) return false;
    vec4 lp = he_lobe_probabilities(m, given);
    vec3 wi;
    if (u_lobe < lp.x) {
        return sample_mirror(given, he_specular_reflectance(m, given) / lp.x, s);
    } else if (u_lobe < lp.x + lp.y) {
        vec3 h = sample_beckmann_h(u, lp.w);
        if (!reflect_about(given, h, wi)) return false;
    } else {
        wi = sample_cosine_hemisphere(u);
    }
    RETURN_SCATTERED(wi, he_pdf(m, given, wi), he_eval(m, wi, given));
}

#ifdef SCENE_TEXTURES
// A textured material's record after its parameters' values are written (texture.glsl): the
// flag p[0].z (sigma0 > 0), which no shader reads (HE_SERIES decides). Rust twin:
// he::with_params.
void he_textured(inout Material m) { m.p[0].z = m.p[0].x > 0.0 ? 1.0 : 0.0; }
#endif
