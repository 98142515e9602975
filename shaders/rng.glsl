// Counter-based random numbers keyed on (seed, pixel, sample, depth, dimension): the
// integrator's three samplers. Rust twin: src/rng/ (bit-identical, same function names; the
// design, its references and the dimension table are documented in src/rng/mod.rs). The DIM_*
// numbers and the SAMPLER_* choice are defines generated from src/rng/mod.rs (`rng::defines`).
#ifndef RNG_GLSL
#define RNG_GLSL

uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

float to_unit_f32(uint x) {
    return float(x >> 8u) * (1.0 / 16777216.0);
}

// The `independent` sampler.
uint random_u32(uint seed, uint pixel, uint sample_index, uint depth, uint dim) {
    uint h = pcg_hash(seed ^ 0x9E3779B9u);
    h = pcg_hash(h ^ pixel);
    h = pcg_hash(h ^ sample_index);
    h = pcg_hash(h ^ (depth * 64u + dim));
    return h;
}

float random_f32(uint seed, uint pixel, uint sample_index, uint depth, uint dim) {
    return to_unit_f32(random_u32(seed, pixel, sample_index, depth, dim));
}

// Nested uniform scramble of x's bits from the least significant one (Burley 2020's
// Laine–Karras-style hash).
uint lk_permute(uint x, uint seed) {
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16u) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
}

// The second Sobol' dimension, bit-reversed: a superset sum over the bit positions (Pascal's
// triangle mod 2), five steps instead of a loop.
uint sobol1_reversed(uint i) {
    uint z = i;
    z ^= (z >> 1u) & 0x55555555u;
    z ^= (z >> 2u) & 0x33333333u;
    z ^= (z >> 4u) & 0x0f0f0f0fu;
    z ^= (z >> 8u) & 0x00ff00ffu;
    z ^= (z >> 16u) & 0x0000ffffu;
    return z;
}

uint sobol_pixel_key(uint seed, uint pixel) {
    return pcg_hash(pcg_hash(seed ^ 0x2545f491u) ^ pixel);
}

uint sobol_pair_key(uint pixel_key, uint depth, uint pair_index) {
    return pcg_hash(pixel_key ^ (depth * 64u + pair_index));
}

// The padding: an Owen scramble of the sample index's reversed bits.
uint sobol_shuffled_index(uint sample_index, uint pair_key) {
    return bitfieldReverse(lk_permute(bitfieldReverse(sample_index), pair_key));
}

// Component c of a pair at its shuffled index, Owen-scrambled with its own key.
uint sobol_component(uint index, uint pair_key, uint c) {
    uint reversed = c == 0u ? index : sobol1_reversed(index);
    return bitfieldReverse(lk_permute(reversed, pcg_hash(pair_key ^ (1u + c))));
}

// The key of one batch of 2^bits samples of a pair (bits = g.pattern_bits; 32: no batches).
uint sobol_batch_key(uint pair_key, uint sample_index, uint bits) {
    return bits >= 32u ? pair_key : pair_key ^ ((sample_index >> bits) * 0x9e3779b9u);
}

// The `sobol` sampler: component (dim & 1) of pair (dim >> 1), padded by an index shuffle.
uint sobol_u32(uint seed, uint bits, uint pixel, uint sample_index, uint depth, uint dim) {
    uint key = sobol_batch_key(sobol_pair_key(sobol_pixel_key(seed, pixel), depth, dim >> 1u), sample_index, bits);
    return sobol_component(sobol_shuffled_index(sample_index, key), key, dim & 1u);
}

float sobol_f32(uint seed, uint bits, uint pixel, uint sample_index, uint depth, uint dim) {
    return to_unit_f32(sobol_u32(seed, bits, pixel, sample_index, depth, dim));
}

// Both numbers of the pair that starts at dimension dim (even): one key, one shuffled index.
vec2 sobol_pair_f32(uint seed, uint bits, uint pixel, uint sample_index, uint depth, uint dim) {
    uint key = sobol_batch_key(sobol_pair_key(sobol_pixel_key(seed, pixel), depth, dim >> 1u), sample_index, bits);
    uint index = sobol_shuffled_index(sample_index, key);
    return vec2(to_unit_f32(sobol_component(index, key, 0u)), to_unit_f32(sobol_component(index, key, 1u)));
}

// The `multijitter` sampler (src/rng/multijitter.rs, function by function): Kensler's (2013) correlated
// multi-jittered points of a 2^bits-point pattern (bits = g.pattern_bits), padded per pair by a
// permutation of the sample index. Integer arithmetic only, so both backends agree bit for bit.

// The hashed permutation of [0, 2^bits): a bijection without cycle walking.
uint hashed_permute(uint i, uint bits, uint p) {
    if (bits == 0u) return 0u;
    uint w = 0xffffffffu >> (32u - bits);
    uint half_bits = (bits + 1u) >> 1u;
    i ^= p;
    i *= (p >> 8u) | 1u;
    i ^= (i & w) >> half_bits;
    i ^= p >> 16u;
    i *= (p >> 20u) | 1u;
    i ^= (i & w) >> 1u;
    return (i + (p >> 12u)) & w;
}

// The y jitter from the x jitter's hash: a bijective mix.
uint remix(uint h) {
    h ^= h >> 16u;
    h *= 0x7feb352du;
    return h ^ (h >> 15u);
}

uint multijitter_pattern_key(uint pair_key, uint sample_index, uint bits) {
    return pair_key ^ ((sample_index >> bits) * 0x9e3779b9u);
}

// One pair of the pattern keyed on p, as 32-bit fixed-point values.
uvec2 multijitter_pair(uint sample_index, uint p, uint bits) {
    uint kx = (bits + 1u) >> 1u;
    uint ky = bits - kx;
    uint low = bits == 0u ? 0u : 0xffffffffu >> (32u - bits);
    uint s = hashed_permute(sample_index & low, bits, p * 0x51633e2du);
    uint c = kx == 0u ? 0u : s & (0xffffffffu >> (32u - kx));
    uint r = s >> kx;
    uint sigma_x = hashed_permute(c, kx, p * 0xa511e9b3u);
    uint sigma_y = hashed_permute(r, ky, p * 0x63d83595u);
    uint xi = pcg_hash(s ^ (p * 0xa399d265u));
    uint eta = remix(xi);
    if (bits == 0u) return uvec2(xi, eta);
    uint cell_x = (c << ky) | sigma_y;
    uint cell_y = (r << kx) | sigma_x;
    return uvec2((cell_x << (32u - bits)) | (xi >> bits), (cell_y << (32u - bits)) | (eta >> bits));
}

uvec2 multijitter_pair_u32(uint seed, uint bits, uint pixel, uint sample_index, uint depth, uint dim) {
    uint key = sobol_pair_key(sobol_pixel_key(seed, pixel), depth, dim >> 1u);
    return multijitter_pair(sample_index, multijitter_pattern_key(key, sample_index, bits), bits);
}

uint multijitter_u32(uint seed, uint bits, uint pixel, uint sample_index, uint depth, uint dim) {
    uvec2 v = multijitter_pair_u32(seed, bits, pixel, sample_index, depth, dim);
    return (dim & 1u) == 0u ? v.x : v.y;
}

float multijitter_f32(uint seed, uint bits, uint pixel, uint sample_index, uint depth, uint dim) {
    return to_unit_f32(multijitter_u32(seed, bits, pixel, sample_index, depth, dim));
}

// Both numbers of the pair that starts at dimension dim (even).
vec2 multijitter_pair_f32(uint seed, uint bits, uint pixel, uint sample_index, uint depth, uint dim) {
    uvec2 v = multijitter_pair_u32(seed, bits, pixel, sample_index, depth, dim);
    return vec2(to_unit_f32(v.x), to_unit_f32(v.y));
}

#endif
