#version 460
// The megakernel baseline: the same integrator as the wavefront stages, with every step of a
// path in one invocation: camera ray, then per segment the closest hit (wavefront/path.glsl
// `segment_end`), the shading of every model behind one switch (brdf/any.glsl), and the shadow
// ray traced on the spot. The same random-number keys, arithmetic and order of additions as the
// wavefront stages, so the same image; it writes each path's radiance for `accumulate`.
// A path that the driver's loop budget stops (Mesa 22.3's gallivm: 65,535 loop iterations per
// invocation, state.glsl `loops_intact`) is saved in the path state and resumed by the next
// dispatch (push constant `phase` MEGAKERNEL_RESUME), which the host repeats until no path is left.
// Here for the benchmark (`brdfwave bench`, `render --integrator megakernel`): it keeps no
// path state in memory and needs no queues, at the price of SIMD lanes that wait for the
// slowest path of their subgroup and for every model's code in one pipeline.
#extension GL_GOOGLE_include_directive : require
#include "brdf/any.glsl"
#include "wavefront/scatter.glsl"
layout(local_size_x = LOCAL_SIZE) in;

// Rays traced by the workgroup, in all and by segment, added to the 64-bit counts once per
// workgroup.
shared uint wg_extension;
shared uint wg_shadow;
shared uint wg_occluded;
shared uint wg_segment_extension[SEGMENTS_COUNTED];
shared uint wg_segment_shadow[SEGMENTS_COUNTED];


void main() {
    if (gl_LocalInvocationIndex == 0u) {
        wg_extension = 0u;
        wg_shadow = 0u;
        wg_occluded = 0u;
    }
    if (gl_LocalInvocationIndex < SEGMENTS_COUNTED) {
        wg_segment_extension[gl_LocalInvocationIndex] = 0u;
        wg_segment_shadow[gl_LocalInvocationIndex] = 0u;
    }
    barrier();
    uint path = gl_GlobalInvocationID.x;
    if (path < pc.wave_size) {
        vec3 o;
        vec3 d;
        vec3 b;
        vec3 l;
        float prev_pdf;
        uint depth;
        // The triangle the ray leaves (bvh_leaving_code), saved in beta.w.
        float leaving;
        if (pc.phase == MEGAKERNEL_START) {
            camera_ray(path, o, d);
            b = vec3(1.0);
            l = vec3(0.0);
            prev_pdf = 0.0;
            leaving = 0.0;
            depth = 1u;
            radiance_set(path, vec4(0.0));
            ray_o_set(path, vec4(o, 1.0));
            ray_d_set(path, vec4(d, 0.0));
            beta_set(path, vec4(b, 0.0));
        } else {
            // Resumed: the state saved below; depth 0 marks a path that has ended.
            vec4 ro = ray_o(path);
            vec4 rd = ray_d(path);
            o = ro.xyz;
            depth = uint(ro.w);
            d = rd.xyz;
            prev_pdf = rd.w;
            vec4 bl = beta(path);
            b = bl.xyz;
            leaving = bl.w;
            l = radiance(path).xyz;
        }
        // One segment per iteration, kept only if no loop was cut short in it (loops_intact,
        // state.glsl): otherwise the path stops where the segment began and the host resumes it
        // with a fresh loop budget. A redone segment draws the same random numbers (keyed on
        // path and depth) and adds to l in the same order, so the image does not depend on where
        // a path was stopped. Each kept segment is saved to the path state at once: the budget
        // may also run out at this loop's own back edge, and the variables seen after a loop
        // left that way are not reliable, while memory is. Ending at max_depth is segment_end's
        // (NO_QUEUE).
        bool ended = depth == 0u;
        while (!ended) {
            vec3 e;
            Hit hit;
            Surface s;
            uint slot = segment_end(depth, o, d, bvh_leaving_prim(leaving), prev_pdf, b, e, hit, s);
            Scatter sc;
            sc.shadow = false;
            sc.next = false;
            bool lit = false;
            if (slot != NO_QUEUE) {
                sc = shade_vertex(path, depth, s, d, b, counter_nonfinite_shade(slot));
                if (sc.shadow) lit = !trace_any_leaving(sc.shadow_o, sc.shadow_d, sc.shadow_tmax, hit.prim);
            }
            if (!loops_intact()) break;
            atomicAdd(wg_extension, 1u);
            atomicAdd(wg_segment_extension[min(depth, SEGMENTS_COUNTED) - 1u], 1u);
            l += e;
            if (sc.shadow) {
                atomicAdd(wg_shadow, 1u);
                atomicAdd(wg_segment_shadow[min(depth, SEGMENTS_COUNTED) - 1u], 1u);
                if (lit) l += sc.shadow_l;
                else atomicAdd(wg_occluded, 1u);
            }
            radiance_set(path, vec4(l, 0.0));
            if (!sc.next) {
                ray_o_set(path, vec4(0.0));
                ended = true;
                break;
            }
            o = sc.o;
            d = sc.d;
            b = sc.beta;
            prev_pdf = sc.pdf;
            leaving = bvh_leaving_code(hit.prim);
            depth += 1u;
            ray_o_set(path, vec4(o, float(depth)));
            ray_d_set(path, vec4(d, prev_pdf));
            beta_set(path, vec4(b, leaving));
        }
        // Read back from memory, not from the loop's variables (see above).
        if (ray_o(path).w != 0.0) atomicAdd(counters[COUNTER_RESUMED], 1u);
    }
    barrier();
    if (gl_LocalInvocationIndex == 0u) {
        add_total64(COUNTER_EXT_TOTAL, wg_extension);
        add_total64(COUNTER_SHADOW_TOTAL, wg_shadow);
        add_total64(COUNTER_OCCLUDED_TOTAL, wg_occluded);
    }
    if (gl_LocalInvocationIndex < SEGMENTS_COUNTED) {
        uint d = gl_LocalInvocationIndex + 1u;
        add_total64(counter_segment_extension(d), wg_segment_extension[d - 1u]);
        add_total64(counter_segment_shadow(d), wg_segment_shadow[d - 1u]);
    }
}
