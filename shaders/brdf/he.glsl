// He, Torrance, Sillion & Greenberg 1991, survey eqs. 10–15 (the paper's eqs. 24–25, 76–83 with
// its erratum's e^(−a²) in the shadowing).
// Rust twin: src/brdf/he/mod.rs (parameter table, corrections to the survey's eq. 15, sampling).
// The model's parts are in brdf/he/ as in the Rust twin: terms.glsl (directional-diffuse and
// coherent terms), shadowing.glsl (S₁ and σ), series.glsl (the series of f_dd).
// Record: p[0].x σ₀, p[0].y τ, p[0].z 1 if σ₀ > 0, p[1].xyz ior, p[2].xyz κ,
// p[3].xyz wavelengths (µm), p[4].xyz diffuse.
// Define HE_SERIES to compile the directional-diffuse series (every material with σ₀ > 0
// requests it); without it f_dd is 0, exact for σ₀ = 0.
#include "brdf/common.glsl"
#include "brdf/he/terms.glsl"

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
