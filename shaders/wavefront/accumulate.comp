#version 460
// Stage 5: adds each path's radiance to its pixel (one writer per pixel: deterministic), and
// counts non-finite samples, which are dropped. The finiteness test reads the bits, which the
// compiler cannot assume away the way it may assume isnan/isinf false.
#extension GL_GOOGLE_include_directive : require
#include "wavefront/state.glsl"
layout(local_size_x = 64) in;

void main() {
    // One invocation per pixel adds its samples in sample order, so the film holds the same f32
    // sums whatever the number of samples per wave.
    uint p = gl_GlobalInvocationID.x;
    if (p >= pc.chunk_pixels) return;
    uint pixel = pc.chunk_offset + p;
    vec3 sum = film[pixel].xyz;
    vec3 sum2 = film2[pixel].xyz;
    for (uint path = p; path < pc.chunk_size; path += pc.chunk_pixels) {
        vec3 l = radiance(path).xyz;
        // A non-finite sample, or one whose square (beyond about 1.8e19) or running sum
        // overflows f32, is dropped and counted.
        vec3 s1 = sum + l, s2 = sum2 + l * l;
        if (!(is_finite_v(l) && is_finite_v(s1) && is_finite_v(s2))) {
            atomicAdd(counters[COUNTER_NONFINITE], 1u);
            continue;
        }
        sum = s1;
        sum2 = s2;
    }
    film[pixel].xyz = sum;
    film2[pixel].xyz = sum2;
}
