// Cook–Torrance (1982), survey eqs. 6–9, plus kd/π. Rust twin: src/brdf/cook_torrance.rs
// (parameter table, defaults, the 4× note on the survey normalisation, sampling).
// Record: p[0].xyz kd, p[0].w roughness, p[1].xyz ks, p[1].w N (4 survey, 1 walter),
// p[2].xyz Fresnel A (ior / eta / f0), p[2].w distribution (CT_BECKMANN, CT_GGX),
// p[3].xyz k, p[3].w geometry (CT_V_CAVITY, CT_SMITH), p[4].x fresnel (CT_FRESNEL_DIELECTRIC,
// CT_FRESNEL_CONDUCTOR, CT_FRESNEL_SCHLICK), p[4].y half-vector sampler (CT_SAMPLE_NDF,
// CT_SAMPLE_VISIBLE; chosen per variant on the host); the codes are generated from
// cook_torrance::RECORD_CODES.
#include "brdf/common.glsl"

#define CT_MIRROR_ROUGHNESS 1e-3

vec3 ct_fresnel(Material m, float c) {
    float kind = m.p[4].x;
    if (kind == CT_FRESNEL_DIELECTRIC) return vec3(fresnel_dielectric(c, m.p[2].x));
    if (kind == CT_FRESNEL_CONDUCTOR) return fresnel_conductor(c, m.p[2].xyz, m.p[3].xyz);
    return fresnel_schlick(c, m.p[2].xyz);
}

float ct_ndf(Material m, vec3 h) {
    if (m.p[2].w == CT_BECKMANN) return beckmann_d(h, m.p[0].w);
    return ggx_d(h, m.p[0].w);
}

float ct_geometry(Material m, vec3 wi, vec3 wo, vec3 h) {
    float alpha = m.p[0].w;
    if (m.p[3].w == CT_V_CAVITY) {
        float c = dot(wo, h);
        if (c <= 0.0) return 0.0;
        float g_mask = 2.0 * h.z * wo.z / c;
        float g_shadow = 2.0 * h.z * wi.z / c;
        return min(min(g_mask, g_shadow), 1.0);
    }
    if (m.p[2].w == CT_BECKMANN) return smith_g1_beckmann_walter(wi, alpha) * smith_g1_beckmann_walter(wo, alpha);
    return smith_g1_ggx(wi, alpha) * smith_g1_ggx(wo, alpha);
}

vec3 cook_torrance_eval(Material m, vec3 wi, vec3 wo) {
    if (!same_hemisphere_up(wi, wo)) return vec3(0.0);
    vec3 diffuse = m.p[0].xyz * INV_PI;
    if (m.p[0].w < CT_MIRROR_ROUGHNESS) return diffuse;
    vec3 h = normalize(wi + wo);
    float c = dot(wi, h);
    float d = ct_ndf(m, h);
    float g = ct_geometry(m, wi, wo, h);
    float denom = max(4.0 * wi.z * wo.z, 1e-20);
    float s = d * g / denom * m.p[1].w;
    return diffuse + m.p[1].xyz * ct_fresnel(m, c) * s;
}

float ct_specular_probability(Material m, float cos_given) {
    // Without a diffuse lobe the answer is 1 whatever the Fresnel term: it is not evaluated.
    float wd = luminance(m.p[0].xyz);
    if (wd <= 0.0) return 1.0;
    float ws = luminance(m.p[1].xyz * ct_fresnel(m, cos_given)) * m.p[1].w;
    if (ws <= 0.0) return 0.0;
    return clamp(ws / (ws + wd), 0.1, 0.9);
}

// The exact Smith G1 of the distribution (the visible-normal sampler's density holds it).
float ct_exact_g1(Material m, vec3 w) {
    if (m.p[2].w == CT_BECKMANN) return smith_g1_beckmann(w, m.p[0].w);
    return smith_g1_ggx(w, m.p[0].w);
}

float ct_specular_pdf(Material m, vec3 given, vec3 sampled) {
    if (m.p[4].y == CT_SAMPLE_VISIBLE) {
        RETURN_VISIBLE_REFLECTED_PDF(given, sampled, ct_exact_g1(m, given), h, ct_ndf(m, h));
    }
    RETURN_REFLECTED_PDF(given, sampled, h, ct_ndf(m, h) * h.z);
}

float cook_torrance_pdf(Material m, vec3 given, vec3 sampled) {
    if (!same_hemisphere_up(given, sampled)) return 0.0;
    float ps = ct_specular_probability(m, given.z);
    float p = (1.0 - ps) * cosine_hemisphere_pdf(sampled.z);
    if (!(m.p[0].w < CT_MIRROR_ROUGHNESS) && ps > 0.0) p += ps * ct_specular_pdf(m, given, sampled);
    return p;
}

bool cook_torrance_sample(Material m, vec3 given, float u_lobe, vec2 u, out BrdfSample s) {
    if (!sample_begin(given, s)) return false;
    float ps = ct_specular_probability(m, given.z);
    vec3 wi;
    if (u_lobe < ps) {
        if (m.p[0].w < CT_MIRROR_ROUGHNESS) {
            return sample_mirror(given, m.p[1].xyz * ct_fresnel(m, given.z) * (m.p[1].w / ps), s);
        }
        float alpha = m.p[0].w;
        bool beckmann = m.p[2].w == CT_BECKMANN;
        vec3 h;
        if (m.p[4].y == CT_SAMPLE_VISIBLE) {
            h = beckmann ? sample_beckmann_vndf(given, u, alpha) : sample_ggx_vndf(given, u, alpha);
        } else {
            h = beckmann ? sample_beckmann_h(u, alpha) : sample_ggx_h(u, alpha);
        }
        if (!reflect_about(given, h, wi)) return false;
    } else {
        wi = sample_cosine_hemisphere(u);
    }
    RETURN_SCATTERED(wi, cook_torrance_pdf(m, given, wi), cook_torrance_eval(m, wi, given));
}

#ifdef SCENE_TEXTURES
// A textured material's record after its parameters' values are written (texture.glsl): cook_torrance
// derives nothing from them (Rust twin: cook_torrance::with_params).
void cook_torrance_textured(inout Material m) {}
#endif
