// Lambert: the ideal diffuse reflector. Survey eq. 3, f_r = ρ/π.
// Parameters, defaults and ranges: see src/brdf/lambert.rs (the Rust twin).
// Record: p[0].xyz = albedo.
#include "brdf/common.glsl"

vec3 lambert_eval(Material m, vec3 wi, vec3 wo) {
    if (!same_hemisphere_up(wi, wo)) return vec3(0.0);
    return m.p[0].xyz * INV_PI;
}

float lambert_pdf(Material m, vec3 given, vec3 sampled) {
    if (!same_hemisphere_up(given, sampled)) return 0.0;
    return cosine_hemisphere_pdf(sampled.z);
}

bool lambert_sample(Material m, vec3 given, float u_lobe, vec2 u, out BrdfSample s) {
    if (!sample_begin(given, s)) return false;
    s.wi = sample_cosine_hemisphere(u);
    s.pdf = cosine_hemisphere_pdf(s.wi.z);
    if (s.pdf <= 0.0) return false;
    // f·cos/pdf = ρ exactly.
    s.weight = m.p[0].xyz;
    return true;
}
