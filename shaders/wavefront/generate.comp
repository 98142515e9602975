#version 460
// Stage 1: camera rays for the wave's samples of one chunk of pixels (box filter, uniform
// position in the pixel). Every path slot enters ray queue 0.
#extension GL_GOOGLE_include_directive : require
#include "wavefront/state.glsl"
layout(local_size_x = 64) in;

void main() {
    uint path = gl_GlobalInvocationID.x;
    if (path == 0u) counters[COUNTER_RAY] = pc.chunk_size;
    if (path >= pc.chunk_size) return;
    uint pixel = path_pixel(path);
    uint x = pixel % g.width;
    uint y = pixel / g.width;
    float fx = float(x) + rand(path, 0u, DIM_PIXEL_X);
    float fy = float(y) + rand(path, 0u, DIM_PIXEL_Y);
    float sx = 2.0 * fx / float(g.width) - 1.0;
    float sy = 1.0 - 2.0 * fy / float(g.height);
    vec3 d = normalize(g.cam_forward + sx * g.cam_right + sy * g.cam_up);
    ray_o[path] = vec4(g.cam_origin, 0.0);
    ray_d[path] = vec4(d, 0.0);
    beta[path] = vec4(1.0);
    radiance[path] = vec4(0.0);
    queues[path] = path;
}
