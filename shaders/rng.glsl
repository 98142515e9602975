// Counter-based random numbers keyed on (seed, pixel, sample, depth, dimension).
// Rust twin: src/rng.rs (bit-identical; dimension numbers listed there in `dim`).
#ifndef RNG_GLSL
#define RNG_GLSL

uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

uint random_u32(uint seed, uint pixel, uint sample_index, uint depth, uint dim) {
    uint h = pcg_hash(seed ^ 0x9E3779B9u);
    h = pcg_hash(h ^ pixel);
    h = pcg_hash(h ^ sample_index);
    h = pcg_hash(h ^ (depth * 64u + dim));
    return h;
}

float random_f32(uint seed, uint pixel, uint sample_index, uint depth, uint dim) {
    return float(random_u32(seed, pixel, sample_index, depth, dim) >> 8u) * (1.0 / 16777216.0);
}

#define DIM_PIXEL_X 0u
#define DIM_PIXEL_Y 1u
#define DIM_LIGHT_SELECT 0u
#define DIM_LIGHT_U 1u
#define DIM_LIGHT_V 2u
#define DIM_BSDF_LOBE 3u
#define DIM_BSDF_U 4u
#define DIM_BSDF_V 5u
#define DIM_RR 6u

#endif
