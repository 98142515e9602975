#version 460
// Stage 5: adds each path's radiance to its pixel (one writer per pixel: deterministic), and
// counts non-finite samples, which are dropped. The finiteness test reads the bits, which the
// compiler cannot assume away the way it may assume isnan/isinf false.
#extension GL_GOOGLE_include_directive : require
#include "wavefront/state.glsl"
layout(local_size_x = 64) in;

void main() {
    uint path = gl_GlobalInvocationID.x;
    if (path >= pc.chunk_size) return;
    vec3 l = radiance[path].xyz;
    if (!is_finite_v(l)) {
        atomicAdd(counters[COUNTER_NONFINITE], 1u);
        return;
    }
    uint pixel = pc.chunk_offset + path;
    film[pixel].xyz += l;
    film2[pixel].xyz += l * l;
}
