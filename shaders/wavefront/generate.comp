#version 460
// Stage 1: camera rays for the wave's samples of one chunk of pixels (box filter, uniform
// position in the pixel). Every path slot enters ray queue 0.
#extension GL_GOOGLE_include_directive : require
#include "wavefront/path.glsl"
layout(local_size_x = LOCAL_SIZE) in;

void run_kernel() {
    uint path = gl_GlobalInvocationID.x;
    if (path == 0u) counters[counter_ray_queue(QUEUE_RAY)] = pc.wave_size;
    if (path >= pc.wave_size) return;
    vec3 o;
    vec3 d;
    camera_ray(path, o, d);
    ray_o_set(path, vec4(o, 0.0));
    ray_d_set(path, vec4(d, 0.0));
    // w: the camera ray leaves no triangle (bvh_leaving_code).
    beta_set(path, vec4(vec3(1.0), 0.0));
    radiance_set(path, vec4(0.0));
    queue_entry_set(QUEUE_RAY * g.wave_paths + path, path);
}

// The whole kernel, then the loop-budget check (state.glsl), which every return above reaches.
void main() {
    run_kernel();
    check_loops();
}
