// Phong 1975, survey eq. 4 (+ eq. 3 diffuse) or the normalized Lafortune–Willems form.
// Parameters, defaults, ranges, reciprocity/energy notes: src/brdf/phong.rs.
// Record: p[0].xyz = kd, p[0].w = exponent, p[1].xyz = ks, p[1].w = form (PHONG_SURVEY,
// PHONG_NORMALIZED: generated from phong::RECORD_CODES), p[2].x = probability of sampling the specular lobe.
#ifndef BRDF_PHONG_GLSL
#define BRDF_PHONG_GLSL
#include "brdf/common.glsl"

#define PHONG_COS_FLOOR 1e-6

// max(0, refl(wi).wo)^n, accurate for large n.
float phong_lobe(float n, vec3 wi, vec3 wo) {
    return pow_one_minus(one_minus_dot(reflect_z(wi), wo), n);
}

vec3 phong_eval(Material m, vec3 wi, vec3 wo) {
    if (!same_hemisphere_up(wi, wo)) return vec3(0.0);
    float n = m.p[0].w;
    float l = phong_lobe(n, wi, wo);
    float spec = m.p[1].w == PHONG_NORMALIZED ? l * (n + 2.0) * (0.5 * INV_PI)
                                : l / max(wi.z, PHONG_COS_FLOOR);
    return m.p[0].xyz * INV_PI + m.p[1].xyz * spec;
}

float phong_pdf(Material m, vec3 given, vec3 sampled) {
    if (!same_hemisphere_up(given, sampled)) return 0.0;
    float n = m.p[0].w;
    float ps = (n + 1.0) * (0.5 * INV_PI) * phong_lobe(n, given, sampled);
    return diffuse_specular_pdf(m.p[2].x, ps, sampled);
}

bool phong_sample(Material m, vec3 given, float u_lobe, vec2 u, out BrdfSample s) {
    if (!sample_begin(given, s)) return false;
    vec3 wi;
    if (u_lobe < m.p[2].x) {
        vec3 r = reflect_z(given);
        vec3 t, b;
        orthonormal_basis(r, t, b);
        // cos(alpha) = u'^(1/(n+1)), u' = 1 - u.x in (0, 1].
        float l = log(1.0 - u.x) / (m.p[0].w + 1.0);
        float cos_a = exp(l);
        float sin_a = sqrt(max(-expm1_f(2.0 * l), 0.0));
        float phi = 2.0 * PI * u.y;
        wi = t * (sin_a * cos(phi)) + b * (sin_a * sin(phi)) + r * cos_a;
    } else {
        wi = sample_cosine_hemisphere(u);
    }
    RETURN_SCATTERED(wi, phong_pdf(m, given, wi), phong_eval(m, wi, given));
}


#ifdef SCENE_TEXTURES
// A textured material's record after its parameters' values are written (texture.glsl): the
// lobe-selection probability p[2].x recomputed as Phong::new does (Rust twin:
// phong::with_params): the specular lobe's albedo estimate 2π/(n + 1) (survey) or 1.
void phong_textured(inout Material m) {
    float n = m.p[0].w;
    float es = m.p[1].w == PHONG_NORMALIZED ? 1.0 : 2.0 * PI / (n + 1.0);
    m.p[2].x = specular_probability(luminance(m.p[0].xyz), luminance(m.p[1].xyz) * es);
}
#endif

#endif
