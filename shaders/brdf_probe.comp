#version 460
// Evaluates one material's BRDF on the GPU for lists of direction pairs and samples: the GPU
// side of `brdfwave brdf eval --backend gpu` and of the GPU-vs-CPU BRDF parity tests. The model
// is chosen like the shade pipelines: "brdf/model.glsl" and BRDF_EVAL / BRDF_PDF / BRDF_SAMPLE.
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
// The bindings (material, inputs, outputs, a measured material's table) and the push constants,
// generated from src/gpu/brdf_probe.rs `BINDINGS` and `Push`. Inputs hold 2 vec4 per item:
// (a.xyz, u_lobe), (b.xyz or (u.x, u.y, _), _). Outputs hold 2 vec4 per item. Mode 0 (eval):
// (f, pdf), (0). Mode 1 (sample): (wi, pdf), (weight, ok | delta << 1). Mode 2 (cost): (sum of
// f over the reps, 0), (0). Mode 3 (math helpers): (helper(x, y), 0, 0, 0), (0); op 4
// (he_series) needs a He material with the series.
#include "brdf_probe/interface.glsl"
#include "brdf/model.glsl"
layout(local_size_x = 64) in;

// Mode 2 turns wo about the normal by this angle between evaluations (cos, sin of 0.1 rad).
const float COST_C = 0.99500417, COST_S = 0.09983342;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    vec4 a = inputs[2u * i];
    vec4 b = inputs[2u * i + 1u];
    if (pc.mode == 0u) {
        // a = wi, b = wo; pdf of sampling wo given wi.
        vec3 f = BRDF_EVAL(material, a.xyz, b.xyz);
        float pdf = BRDF_PDF(material, a.xyz, b.xyz);
        outputs[2u * i] = vec4(f, pdf);
        outputs[2u * i + 1u] = vec4(0.0);
    } else if (pc.mode == 3u) {
        // GPU math helpers (brdfwave stress, group gpu_math): a = (x, y, op, _).
        float x = a.x, y = a.y, r = 0.0;
        uint op = uint(a.z);
        if (op == 0u) r = erfc(x);
        else if (op == 1u) r = expm1_f(x);
        else if (op == 2u) r = log1p_f(x);
        else if (op == 3u) r = pow_one_minus(x, y);
#ifdef HE_SERIES
        else if (op == 4u) r = he_series(x, y);
#endif
        outputs[2u * i] = vec4(r, 0.0, 0.0, 0.0);
        outputs[2u * i + 1u] = vec4(0.0);
    } else if (pc.mode == 2u) {
        // Evaluation cost: `reps` evaluations per invocation and one write, so that memory traffic
        // does not hide the arithmetic. wo turns about the normal between evaluations (4 FMAs),
        // so no evaluation can be hoisted out of the loop.
        vec3 wi = a.xyz, wo = b.xyz;
        vec3 sum = vec3(0.0);
        for (uint r = 0u; r < pc.reps; ++r) {
            sum += BRDF_EVAL(material, wi, wo);
            wo = vec3(COST_C * wo.x - COST_S * wo.y, COST_S * wo.x + COST_C * wo.y, wo.z);
        }
        outputs[2u * i] = vec4(sum, 0.0);
        outputs[2u * i + 1u] = vec4(0.0);
    } else {
        BrdfSample s;
        bool ok = BRDF_SAMPLE(material, a.xyz, a.w, b.xy, s);
        outputs[2u * i] = vec4(s.wi, s.pdf);
        outputs[2u * i + 1u] = vec4(s.weight, float((ok ? 1u : 0u) | (s.delta ? 2u : 0u)));
    }
}
