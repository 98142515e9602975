// Environment maps: radiance by direction from an equirectangular image, bilinear between texel
// centres, and its importance sampling by luminance x sin(theta) for next-event estimation.
// Rust twin (independent code, the same conventions and numbers; the mapping, the texel grid and
// the distribution are documented there): src/envmap.rs. Compiled in under SCENE_ENV_MAP only.
// Data: the map's texels at the start of binding `images`, its CDFs and cell densities in
// `env_dist_data` (src/gpu/scene_buffers.rs), its size, rotation and light-selection
// probability in Globals.
#ifndef ENVMAP_GLSL
#define ENVMAP_GLSL
#ifdef SCENE_ENV_MAP

// The map's entry in the light table (Rust: lights::ENV_ENTRY).
#define ENV_ENTRY 0xFFFFFFFFu

vec3 env_texel(uint x, uint y) { return imageLoad(image_texels, int(y * g.env_width + x)).xyz; }
float env_dist(uint i) { return imageLoad(env_dist_data, int(i)).x; }

// Written out and `precise`, as the Rust twin sums them: (x + y) + z, no fused multiply-add.
float env_dot(vec3 a, vec3 b) {
    precise float r = a.x * b.x + a.y * b.y + a.z * b.z;
    return r;
}
vec3 env_to_local(vec3 d) { return vec3(env_dot(g.env_x, d), env_dot(g.env_y, d), env_dot(g.env_z, d)); }
vec3 env_to_world(vec3 l) { return g.env_x * l.x + g.env_y * l.y + g.env_z * l.z; }

// (u, v) of a direction in the map's frame, u in [0, 1).
vec2 env_uv(vec3 l) {
    precise float u = atan2_f32(l.x, -l.z) * 0.15915494;
    if (u < 0.0) u += 1.0;
    if (u >= 1.0) u = 0.0;
    precise float sin_theta = sqrt(l.x * l.x + l.z * l.z);
    precise float v = atan2_f32(sin_theta, l.y) * 0.31830987;
    return vec2(u, min(v, 1.0));
}

// The bilinear patch of (u, v): its top-left texel and the weights of the texels to its right
// and below. Column x at u = (x + 1/2)/W, row y at v = y/(H - 1).
void env_cell(vec2 uv, out uint x0, out uint y0, out vec2 f) {
    float w = float(g.env_width);
    float h = float(g.env_height);
    precise float s = uv.x * w - 0.5;
    if (s < 0.0) s += w;
    precise float t = uv.y * (h - 1.0);
    x0 = min(uint(max(s, 0.0)), g.env_width - 1u);
    y0 = min(uint(max(t, 0.0)), g.env_height - 2u);
    f = vec2(clamp(s - float(x0), 0.0, 1.0), clamp(t - float(y0), 0.0, 1.0));
}

vec3 env_lookup(vec2 uv) {
    uint x0, y0;
    vec2 f;
    env_cell(uv, x0, y0, f);
    uint x1 = x0 + 1u == g.env_width ? 0u : x0 + 1u;
    vec3 a = env_texel(x0, y0) * (1.0 - f.x) + env_texel(x1, y0) * f.x;
    vec3 b = env_texel(x0, y0 + 1u) * (1.0 - f.x) + env_texel(x1, y0 + 1u) * f.x;
    return a * (1.0 - f.y) + b * f.y;
}

// The radiance arriving from world direction d (unit).
vec3 env_radiance(vec3 d) { return env_lookup(env_uv(env_to_local(d))); }

// Where the cells' densities start in env_dist_data: after the marginal CDF (H values) and the
// conditional CDFs ((H - 1) x (W + 1)).
uint env_pdf_base() { return g.env_height + (g.env_height - 1u) * (g.env_width + 1u); }

// The solid-angle density with which env_sample chooses world direction d.
float env_pdf(vec3 d) {
    vec3 l = env_to_local(d);
    float sin_theta = sqrt(l.x * l.x + l.z * l.z);
    if (!(sin_theta > 0.0)) return 0.0;
    uint x, y;
    vec2 f;
    env_cell(env_uv(l), x, y, f);
    return env_dist(env_pdf_base() + y * g.env_width + x) / (2.0 * PI * PI * sin_theta);
}

// Inverts the CDF of n + 1 values at env_dist_data[base ..]: the interval i with
// cdf[i] <= u < cdf[i + 1], and u's offset in it. Rust twin: envmap::sample_cdf.
uint env_sample_cdf(uint base, uint n, float u, out float d) {
    uint lo = 0u;
    uint hi = n - 1u;
    while (lo < hi) {
        uint mid = (lo + hi + 1u) / 2u;
        if (env_dist(base + mid) <= u) lo = mid; else hi = mid - 1u;
    }
    float c0 = env_dist(base + lo);
    float width = env_dist(base + lo + 1u) - c0;
    d = width > 0.0 ? clamp((u - c0) / width, 0.0, 0.99999994) : 0.0;
    return lo;
}

// A world direction drawn by (u1, u2), its solid-angle density and the radiance from it; false
// at a pole (sin theta = 0). Rust twin: EnvMap::sample.
bool env_sample(float u1, float u2, out vec3 wi, out float pdf, out vec3 radiance) {
    uint w = g.env_width;
    uint h = g.env_height;
    wi = vec3(0.0);
    pdf = 0.0;
    radiance = vec3(0.0);
    float dv;
    float du;
    uint y = env_sample_cdf(0u, h - 1u, u2, dv);
    uint x = env_sample_cdf(h + y * (w + 1u), w, u1, du);
    float u = (float(x) + 0.5 + du) / float(w);
    if (u >= 1.0) u -= 1.0;
    float v = (float(y) + dv) / float(h - 1u);
    vec2 theta = sincos_turns(0.5 * v);
    vec2 phi = sincos_turns(u);
    float sin_t = theta.x;
    float cos_t = theta.y;
    float sin_p = phi.x;
    float cos_p = phi.y;
    if (!(sin_t > 0.0)) return false;
    pdf = env_dist(env_pdf_base() + y * w + x) / (2.0 * PI * PI * sin_t);
    if (!(pdf > 0.0)) return false;
    wi = env_to_world(vec3(sin_p * sin_t, cos_t, -cos_p * sin_t));
    radiance = env_lookup(vec2(u, v));
    return true;
}

// The MIS weight of the map's light seen along d by a BSDF sample of solid-angle pdf prev_pdf
// (1 after the camera and delta lobes). Rust twin: CpuRenderer::env_weight (src/cpu/path.rs).
float env_weight(vec3 d, float prev_pdf) {
    if (prev_pdf > 0.0) return power_heuristic(prev_pdf, g.env_select * env_pdf(d));
    return 1.0;
}

#endif
#endif
