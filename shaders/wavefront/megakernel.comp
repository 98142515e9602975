#version 460
// The megakernel baseline: the same integrator as the wavefront stages, with every step of a
// path in one invocation: camera ray, then per segment the closest hit (wavefront/path.glsl
// `segment_end`), the shading of every model behind one switch (brdf/any.glsl), and the shadow
// ray traced on the spot. The same random-number keys, arithmetic and order of additions as the
// wavefront stages, so the same image; it writes each path's radiance for `accumulate`.
// Here for the benchmark (`brdfwave bench`, `render --integrator megakernel`): it keeps no
// path state in memory and needs no queues, at the price of SIMD lanes that wait for the
// slowest path of their subgroup and for every model's code in one pipeline.
#extension GL_GOOGLE_include_directive : require
#include "brdf/any.glsl"
#include "wavefront/scatter.glsl"
layout(local_size_x = 64) in;

// Rays traced by the workgroup, in all and by segment, added to the 64-bit counts once per
// workgroup.
shared uint wg_extension;
shared uint wg_shadow;
shared uint wg_segment_extension[SEGMENTS_COUNTED];
shared uint wg_segment_shadow[SEGMENTS_COUNTED];


void main() {
    if (gl_LocalInvocationIndex == 0u) {
        wg_extension = 0u;
        wg_shadow = 0u;
    }
    if (gl_LocalInvocationIndex < SEGMENTS_COUNTED) {
        wg_segment_extension[gl_LocalInvocationIndex] = 0u;
        wg_segment_shadow[gl_LocalInvocationIndex] = 0u;
    }
    barrier();
    uint path = gl_GlobalInvocationID.x;
    if (path < pc.wave_size) {
        uint n_extension = 0u;
        uint n_shadow = 0u;
        vec3 o;
        vec3 d;
        camera_ray(path, o, d);
        vec3 b = vec3(1.0);
        vec3 l = vec3(0.0);
        float prev_pdf = 0.0;
        for (uint depth = 1u; depth <= g.max_depth; ++depth) {
            vec3 e;
            Hit hit;
            n_extension += 1u;
            atomicAdd(wg_segment_extension[min(depth, SEGMENTS_COUNTED) - 1u], 1u);
            Surface s;
            uint slot = segment_end(depth, o, d, prev_pdf, b, e, hit, s);
            l += e;
            if (slot == NO_QUEUE) break;
            Scatter sc = shade_vertex(path, depth, s, d, b, counter_nonfinite_shade(slot));
            if (sc.shadow) {
                n_shadow += 1u;
                atomicAdd(wg_segment_shadow[min(depth, SEGMENTS_COUNTED) - 1u], 1u);
                if (!trace_any(sc.shadow_o, sc.shadow_d, sc.shadow_tmax)) l += sc.shadow_l;
            }
            if (!sc.next) break;
            o = sc.o;
            d = sc.d;
            b = sc.beta;
            prev_pdf = sc.pdf;
        }
        radiance_set(path, vec4(l, 0.0));
        atomicAdd(wg_extension, n_extension);
        atomicAdd(wg_shadow, n_shadow);
    }
    barrier();
    if (gl_LocalInvocationIndex == 0u) {
        add_total64(COUNTER_EXT_TOTAL, wg_extension);
        add_total64(COUNTER_SHADOW_TOTAL, wg_shadow);
    }
    if (gl_LocalInvocationIndex < SEGMENTS_COUNTED) {
        uint d = gl_LocalInvocationIndex + 1u;
        add_total64(counter_segment_extension(d), wg_segment_extension[d - 1u]);
        add_total64(counter_segment_shadow(d), wg_segment_shadow[d - 1u]);
    }
}
