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
        vec3 l = radiance[path].xyz;
        if (!is_finite_v(l)) {
            atomicAdd(counters[COUNTER_NONFINITE], 1u);
            continue;
        }
        sum += l;
        sum2 += l * l;
    }
    film[pixel].xyz = sum;
    film2[pixel].xyz = sum2;
}
