// Every model a scene uses, behind one switch on the material's model index: the BRDF
// interface of the megakernel (wavefront/megakernel.comp), which shades every model in one
// pipeline. The Rust side defines MODEL_<NAME> as the model's index (brdf::MODELS) for each
// model the scene uses, and the models' feature defines; a model left out costs nothing.
#ifndef BRDF_ANY_GLSL
#define BRDF_ANY_GLSL
#include "brdf/common.glsl"
#ifdef MODEL_LAMBERT
#include "brdf/lambert.glsl"
#endif
#ifdef MODEL_OREN_NAYAR
#include "brdf/oren_nayar.glsl"
#endif
#ifdef MODEL_PHONG
#include "brdf/phong.glsl"
#endif
#ifdef MODEL_BLINN_PHONG
#include "brdf/blinn_phong.glsl"
#endif
#ifdef MODEL_COOK_TORRANCE
#include "brdf/cook_torrance.glsl"
#endif
#ifdef MODEL_HE
#include "brdf/he.glsl"
#endif
#ifdef MODEL_WARD
#include "brdf/ward.glsl"
#endif
#ifdef MODEL_SCHLICK
#include "brdf/schlick.glsl"
#endif

vec3 any_eval(Material m, vec3 wi, vec3 wo) {
    switch (m.header.x) {
#ifdef MODEL_LAMBERT
    case MODEL_LAMBERT: return lambert_eval(m, wi, wo);
#endif
#ifdef MODEL_OREN_NAYAR
    case MODEL_OREN_NAYAR: return oren_nayar_eval(m, wi, wo);
#endif
#ifdef MODEL_PHONG
    case MODEL_PHONG: return phong_eval(m, wi, wo);
#endif
#ifdef MODEL_BLINN_PHONG
    case MODEL_BLINN_PHONG: return blinn_phong_eval(m, wi, wo);
#endif
#ifdef MODEL_COOK_TORRANCE
    case MODEL_COOK_TORRANCE: return cook_torrance_eval(m, wi, wo);
#endif
#ifdef MODEL_HE
    case MODEL_HE: return he_eval(m, wi, wo);
#endif
#ifdef MODEL_WARD
    case MODEL_WARD: return ward_eval(m, wi, wo);
#endif
#ifdef MODEL_SCHLICK
    case MODEL_SCHLICK: return schlick_eval(m, wi, wo);
#endif
    default: return vec3(0.0);
    }
}

float any_pdf(Material m, vec3 given, vec3 sampled) {
    switch (m.header.x) {
#ifdef MODEL_LAMBERT
    case MODEL_LAMBERT: return lambert_pdf(m, given, sampled);
#endif
#ifdef MODEL_OREN_NAYAR
    case MODEL_OREN_NAYAR: return oren_nayar_pdf(m, given, sampled);
#endif
#ifdef MODEL_PHONG
    case MODEL_PHONG: return phong_pdf(m, given, sampled);
#endif
#ifdef MODEL_BLINN_PHONG
    case MODEL_BLINN_PHONG: return blinn_phong_pdf(m, given, sampled);
#endif
#ifdef MODEL_COOK_TORRANCE
    case MODEL_COOK_TORRANCE: return cook_torrance_pdf(m, given, sampled);
#endif
#ifdef MODEL_HE
    case MODEL_HE: return he_pdf(m, given, sampled);
#endif
#ifdef MODEL_WARD
    case MODEL_WARD: return ward_pdf(m, given, sampled);
#endif
#ifdef MODEL_SCHLICK
    case MODEL_SCHLICK: return schlick_pdf(m, given, sampled);
#endif
    default: return 0.0;
    }
}

bool any_sample(Material m, vec3 given, float u_lobe, vec2 u, out BrdfSample s) {
    s.wi = vec3(0.0, 0.0, 1.0);
    s.weight = vec3(0.0);
    s.pdf = 0.0;
    s.delta = false;
    switch (m.header.x) {
#ifdef MODEL_LAMBERT
    case MODEL_LAMBERT: return lambert_sample(m, given, u_lobe, u, s);
#endif
#ifdef MODEL_OREN_NAYAR
    case MODEL_OREN_NAYAR: return oren_nayar_sample(m, given, u_lobe, u, s);
#endif
#ifdef MODEL_PHONG
    case MODEL_PHONG: return phong_sample(m, given, u_lobe, u, s);
#endif
#ifdef MODEL_BLINN_PHONG
    case MODEL_BLINN_PHONG: return blinn_phong_sample(m, given, u_lobe, u, s);
#endif
#ifdef MODEL_COOK_TORRANCE
    case MODEL_COOK_TORRANCE: return cook_torrance_sample(m, given, u_lobe, u, s);
#endif
#ifdef MODEL_HE
    case MODEL_HE: return he_sample(m, given, u_lobe, u, s);
#endif
#ifdef MODEL_WARD
    case MODEL_WARD: return ward_sample(m, given, u_lobe, u, s);
#endif
#ifdef MODEL_SCHLICK
    case MODEL_SCHLICK: return schlick_sample(m, given, u_lobe, u, s);
#endif
    default: return false;
    }
}

#define BRDF_EVAL any_eval
#define BRDF_PDF any_pdf
#define BRDF_SAMPLE any_sample

#endif
