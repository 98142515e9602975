#version 460
// Stage 5: adds each path's radiance to its pixel (one writer per pixel: deterministic), and
// counts non-finite samples, which are dropped. The finiteness test reads the bits, which the
// compiler cannot assume away the way it may assume isnan/isinf false.
//
// The film holds per pixel the sums of l·2^-k and of (l·2^-k)², with k (a multiple of
// FILM_SCALE_STEP, kept in film[pixel].w) raised whenever a sum or a square would overflow f32:
// both sums are then scaled down by the same exact power of two. k stays 0 unless a sample's
// square exceeds f32 (beyond about 1.8e19), so ordinary images are the plain f32 sums, bit for
// bit; radiance up to the f32 limit accumulates without loss instead of being dropped. The host
// (src/gpu/mod.rs) multiplies the sums by 2^k and 2^2k in f64.
#extension GL_GOOGLE_include_directive : require
#include "wavefront/state.glsl"
layout(local_size_x = LOCAL_SIZE) in;

#define FILM_SCALE_STEP 32
// 2^128 > FLT_MAX, so l·2^-160 < 2^-32 and its square < 2^-64: no sum of fewer than 2^64
// such terms can overflow. The loop below never needs to go beyond it.
#define FILM_SCALE_MAX 160

void run_kernel() {
    // One invocation per pixel adds its samples in sample order, so the film holds the same f32
    // sums whatever the number of samples per wave.
    uint p = gl_GlobalInvocationID.x;
    if (p >= pc.chunk_pixels) return;
    uint pixel = pc.chunk_offset + p;
    vec4 f = film[pixel];
    vec3 sum = f.xyz;
    int k = int(f.w);
    vec3 sum2 = film2[pixel].xyz;
    for (uint path = p; path < pc.wave_size; path += pc.chunk_pixels) {
        vec3 l = radiance(path).xyz;
        if (!is_finite_v(l)) {
            atomicAdd(counters[COUNTER_NONFINITE], 1u);
            continue;
        }
        vec3 ls = ldexp(l, ivec3(-k));
        vec3 s1 = sum + ls, s2 = sum2 + ls * ls;
        while (!(is_finite_v(s1) && is_finite_v(s2)) && k < FILM_SCALE_MAX) {
            k += FILM_SCALE_STEP;
            sum = ldexp(sum, ivec3(-FILM_SCALE_STEP));
            sum2 = ldexp(sum2, ivec3(-2 * FILM_SCALE_STEP));
            ls = ldexp(l, ivec3(-k));
            s1 = sum + ls;
            s2 = sum2 + ls * ls;
        }
        sum = s1;
        sum2 = s2;
    }
    film[pixel] = vec4(sum, float(k));
    film2[pixel].xyz = sum2;
}

// The whole kernel, then the loop-budget check (state.glsl), which every return above reaches.
void main() {
    run_kernel();
    check_loops();
}
