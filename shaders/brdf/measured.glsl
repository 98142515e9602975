// A measured material: f_r looked up in a MERL table (Matusik et al. 2003) with the steps of
// src/measured/merl.rs, function by function (merl::half_diff, index_coords, clamped_axis,
// periodic_axis, MerlTable::lookup_angles), sampled through its fitted Ward lobe mixed with a
// cosine lobe. Parameters, sampling and sharing: src/brdf/measured.rs.
// Record: floatBitsToUint(p[0].x) = the table's first texel in measured_table; p[1..4] = the
// sampling lobe's Ward record (shaders/brdf/ward.glsl).
// The table: one RGBA32F texel per MERL cell (f_r red, green, blue; negative = missing), declared
// by the generated interface header under MEASURED_TABLE (or by a probe's generated header, which
// defines MEASURED_TABLE_DECLARED: src/gpu/interface.rs `probe_glsl`).
#ifndef BRDF_MEASURED_GLSL
#define BRDF_MEASURED_GLSL
#include "brdf/common.glsl"
#include "brdf/ward.glsl"
#ifndef MEASURED_TABLE_DECLARED
#include "wavefront/state.glsl"
#endif

#define MEASURED_THETA_H 90
#define MEASURED_THETA_D 90
#define MEASURED_PHI_D 180
#define MEASURED_P_COSINE 0.5

// atan2 with Rust's value at (0, 0), where GLSL's atan(y, x) is undefined.
float measured_atan2(float y, float x) {
    if (x == 0.0 && y == 0.0) return 0.0;
    return atan(y, x);
}

// Rusinkiewicz's (θh, θd, φd) of a pair, φd folded into [0, π); false when wi + wo ~ 0.
bool measured_half_diff(vec3 wi, vec3 wo, out vec3 angles) {
    angles = vec3(0.0);
    vec3 sum = wi + wo;
    float len2 = dot(sum, sum);
    if (len2 <= 1e-20) return false;
    vec3 h = sum / sqrt(len2);
    float theta_h = measured_atan2(length(h.xy), h.z);
    float phi_h = measured_atan2(h.y, h.x);
    float sp = sin(phi_h), cp = cos(phi_h);
    // wi rotated by -φh about the normal, then by -θh about the bitangent.
    vec3 t = vec3(wi.x * cp + wi.y * sp, wi.y * cp - wi.x * sp, wi.z);
    float st = sin(theta_h), ct = cos(theta_h);
    vec3 d = vec3(t.x * ct - t.z * st, t.y, t.z * ct + t.x * st);
    float theta_d = measured_atan2(length(d.xy), d.z);
    float phi_d = measured_atan2(d.y, d.x);
    if (phi_d < 0.0) phi_d += PI;
    angles = vec3(theta_h, theta_d, phi_d);
    return true;
}

// The continuous index coordinates (cell centres at whole numbers; √θh for θh).
vec3 measured_index_coords(vec3 a) {
    return vec3(sqrt(max(a.x, 0.0) / (0.5 * PI)) * float(MEASURED_THETA_H) - 0.5,
                a.y / (0.5 * PI) * float(MEASURED_THETA_D) - 0.5,
                a.z / PI * float(MEASURED_PHI_D) - 0.5);
}

// The first of the two cells along a clamped axis of n cells, and the second's weight.
uint measured_clamped_axis(float x, int n, out float f) {
    x = clamp(x, 0.0, float(n - 1));
    uint i = min(uint(floor(x)), uint(n - 2));
    f = x - float(i);
    return i;
}

// The first cell along the periodic φd axis (the second is the next, mod n), and its weight.
uint measured_periodic_axis(float x, int n, out float f) {
    float fl = floor(x);
    int i = int(fl);
    i = i - n * int(floor(float(i) / float(n)));
    f = clamp(x - fl, 0.0, 1.0);
    return uint(i);
}

vec4 measured_texel(uint i) { return imageLoad(measured_table, int(i)); }

// The interpolated value at (θh, θd, φd): missing corners left out, the others' weights
// renormalised per channel.
vec3 measured_lookup_angles(Material m, vec3 angles) {
    vec3 c = measured_index_coords(angles);
    float fh, fd, fp;
    uint ih = measured_clamped_axis(c.x, MEASURED_THETA_H, fh);
    uint id = measured_clamped_axis(c.y, MEASURED_THETA_D, fd);
    uint ip = measured_periodic_axis(c.z, MEASURED_PHI_D, fp);
    uint base = floatBitsToUint(m.p[0].x);
    vec3 sum = vec3(0.0), weight = vec3(0.0);
    for (uint a = 0u; a < 2u; ++a) {
        float wa = a == 0u ? 1.0 - fh : fh;
        for (uint b = 0u; b < 2u; ++b) {
            float wb = b == 0u ? 1.0 - fd : fd;
            for (uint p = 0u; p < 2u; ++p) {
                float wp = p == 0u ? 1.0 - fp : fp;
                float w = wa * wb * wp;
                uint pp = (ip + p) % uint(MEASURED_PHI_D);
                uint cell = pp + uint(MEASURED_PHI_D) * ((id + b) + uint(MEASURED_THETA_D) * (ih + a));
                vec3 v = measured_texel(base + cell).xyz;
                bvec3 ok = greaterThanEqual(v, vec3(0.0));
                sum += mix(vec3(0.0), w * v, ok);
                weight += mix(vec3(0.0), vec3(w), ok);
            }
        }
    }
    return mix(vec3(0.0), sum / max(weight, vec3(1e-30)), greaterThan(weight, vec3(1e-6)));
}

vec3 measured_lookup(Material m, vec3 wi, vec3 wo) {
    if (wi.z <= 0.0 || wo.z <= 0.0) return vec3(0.0);
    vec3 angles;
    if (!measured_half_diff(wi, wo, angles)) return vec3(0.0);
    return measured_lookup_angles(m, angles);
}

// The sampling lobe's Ward material: the record's p[1..4].
Material measured_lobe(Material m) {
    Material w;
    w.header = m.header;
    for (int k = 0; k < MATERIAL_PARAMS; ++k) w.p[k] = vec4(0.0);
    w.p[0] = m.p[1];
    w.p[1] = m.p[2];
    w.p[2] = m.p[3];
    return w;
}

vec3 measured_eval(Material m, vec3 wi, vec3 wo) { return measured_lookup(m, wi, wo); }

float measured_pdf(Material m, vec3 given, vec3 sampled) {
    if (!same_hemisphere_up(given, sampled)) return 0.0;
    float lobe = ward_pdf(measured_lobe(m), given, sampled);
    return diffuse_specular_pdf(1.0 - MEASURED_P_COSINE, lobe, sampled);
}

bool measured_sample(Material m, vec3 given, float u_lobe, vec2 u, out BrdfSample s) {
    if (!sample_begin(given, s)) return false;
    vec3 wi;
    if (u_lobe < MEASURED_P_COSINE) {
        wi = sample_cosine_hemisphere(u);
    } else {
        float u_ward = (u_lobe - MEASURED_P_COSINE) / (1.0 - MEASURED_P_COSINE);
        BrdfSample w;
        if (!ward_sample(measured_lobe(m), given, u_ward, u, w)) return false;
        wi = w.wi;
    }
    RETURN_SCATTERED(wi, measured_pdf(m, given, wi), measured_eval(m, wi, given));
}


#ifdef SCENE_TEXTURES
// A textured material's record after its parameters' values are written (texture.glsl): measured
// derives nothing from them (Rust twin: measured::with_params).
void measured_textured(inout Material m) {}
#endif

#endif
