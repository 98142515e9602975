// Lambert: the ideal diffuse reflector. Survey eq. 3, f_r = ρ/π.
// Parameters, defaults and ranges: see src/brdf/lambert.rs (the Rust twin).
// Record: p[0].xyz = albedo.
#include "brdf/common.glsl"

vec3 lambert_eval(Material m, vec3 wi, vec3 wo) {
    if (!same_hemisphere_up(wi, wo)) return vec3(0.0);
    return m.p[0].xyz * INV_PI;
}

float lambert_pdf(Material m, vec3 given, vec3 sampled) {
    return diffuse_pdf(given, sampled);
}

bool lambert_sample(Material m, vec3 given, float u_lobe, vec2 u, out BrdfSample s) {
    if (!sample_diffuse(given, u, s)) return false;
    // f·cos/pdf = ρ exactly.
    s.weight = m.p[0].xyz;
    return true;
}

#ifdef SCENE_TEXTURES
// A textured material's record after its parameters' values are written (texture.glsl): lambert
// derives nothing from them (Rust twin: lambert::with_params).
void lambert_textured(inout Material m) {}
#endif
