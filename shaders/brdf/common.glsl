// Building blocks shared by the models. Rust twin: src/brdf/common.rs.
#ifndef BRDF_COMMON_GLSL
#define BRDF_COMMON_GLSL
#include "../common.glsl"

// Cosine-weighted hemisphere sample, concentric mapping (Shirley & Chiu 1997). pdf = cosθ/π.
vec3 sample_cosine_hemisphere(vec2 u) {
    vec2 a = 2.0 * u - vec2(1.0);
    vec2 d;
    if (a.x == 0.0 && a.y == 0.0) {
        d = vec2(0.0);
    } else if (abs(a.x) > abs(a.y)) {
        float r = a.x;
        float phi = (PI / 4.0) * (a.y / a.x);
        d = vec2(r * cos(phi), r * sin(phi));
    } else {
        float r = a.y;
        float phi = PI / 2.0 - (PI / 4.0) * (a.x / a.y);
        d = vec2(r * cos(phi), r * sin(phi));
    }
    float z = sqrt(max(1.0 - dot(d, d), 0.0));
    return vec3(d, z);
}

float cosine_hemisphere_pdf(float cos_theta) { return max(cos_theta, 0.0) * INV_PI; }

bool same_hemisphere_up(vec3 a, vec3 b) { return a.z > 0.0 && b.z > 0.0; }

#endif
