//! The `multijitter` sampler: Kensler's (2013) correlated multi-jittered points, one pattern of
//! the render's sample count per (pixel, depth, pair), padded by a permutation of the sample
//! index; described with the other samplers in the [`super`] module docs. Its GLSL twin is the
//! `multijitter` part of `shaders/rng.glsl`.

use super::{pcg_hash, sobol_pair_key, sobol_pixel_key};

/// The `multijitter` pattern of a render of `spp` samples per pixel has 2^bits points: the
/// smallest power of two that holds them, at most 2^[`MULTIJITTER_MAX_BITS`].
pub fn multijitter_bits(spp: u32) -> u32 {
    let bits = 32 - spp.max(1).wrapping_sub(1).leading_zeros();
    bits.min(MULTIJITTER_MAX_BITS)
}

/// The largest `multijitter` pattern, 2^24 points (the numbers' resolution); samples past it
/// draw from further, independent patterns of that size.
pub const MULTIJITTER_MAX_BITS: u32 = 24;

/// Kensler's (2013) hashed permutation of [0, 2^bits): every step is invertible on the low
/// `bits` bits and does not carry higher bits down, so for a power-of-two length it is a
/// bijection without the cycle walking a general length needs (no loop on either backend).
#[inline]
pub fn kensler_permute(i: u32, bits: u32, p: u32) -> u32 {
    if bits == 0 {
        return 0;
    }
    let w = u32::MAX >> (32 - bits);
    let mut i = i;
    i ^= p;
    i = i.wrapping_mul(0xe170_893d);
    i ^= p >> 16;
    i ^= (i & w) >> 4;
    i ^= p >> 8;
    i = i.wrapping_mul(0x0929_eb3f);
    i ^= p >> 23;
    i ^= (i & w) >> 1;
    i = i.wrapping_mul(1 | (p >> 27));
    i = i.wrapping_mul(0x6935_fa69);
    i ^= (i & w) >> 11;
    i = i.wrapping_mul(0x74dc_b303);
    i ^= (i & w) >> 2;
    i = i.wrapping_mul(0x9e50_1cc3);
    i ^= (i & w) >> 2;
    i = i.wrapping_mul(0xc860_a3df);
    i &= w;
    i ^= i >> 5;
    i.wrapping_add(p) & w
}

/// The key of one pattern of a pair: the pair key (a hash), and which 2^bits block of sample
/// indices the sample is in (0 for every sample of a render that fits one pattern).
#[inline]
pub fn multijitter_pattern_key(pair_key: u32, sample: u32, bits: u32) -> u32 {
    pair_key ^ (sample >> bits).wrapping_mul(0x9e37_79b9)
}

/// One pair of the `multijitter` sampler as 32-bit fixed-point values: Kensler's (2013)
/// correlated multi-jittered point of sample `sample` in a pattern of N = 2^bits points keyed
/// on `p`, a grid of m = 2^ceil(bits/2) columns by n = 2^floor(bits/2) rows. The sample index is
/// first permuted (the padding between pairs); point s = (column c, row r) of the permuted index
/// lies in cell c of the m columns and r of the n rows, at x-substratum σ_y(r) of its column
/// and y-substratum σ_x(c) of its row (one permutation of each for the whole pattern), jittered
/// within it: x = (c·n + σ_y(r) + ξ)/N, y = (r·m + σ_x(c) + η)/N. Every N-point pattern is
/// then stratified in the m×n grid and in each coordinate's N strata ("n-rooks"). Integer
/// arithmetic throughout, so both backends compute the same bits.
#[inline]
pub fn multijitter_pair(sample: u32, p: u32, bits: u32) -> (u32, u32) {
    let kx = bits.div_ceil(2);
    let ky = bits - kx;
    let low = |b: u32| if b == 0 { 0 } else { u32::MAX >> (32 - b) };
    let s = kensler_permute(sample & low(bits), bits, p.wrapping_mul(0x5163_3e2d));
    let (c, r) = (s & low(kx), s >> kx);
    let sigma_x = kensler_permute(c, kx, p.wrapping_mul(0xa511_e9b3));
    let sigma_y = kensler_permute(r, ky, p.wrapping_mul(0x63d8_3595));
    let xi = pcg_hash(s ^ p.wrapping_mul(0xa399_d265));
    let eta = pcg_hash(s ^ p.wrapping_mul(0x711a_d6a5));
    if bits == 0 {
        return (xi, eta);
    }
    let cell_x = (c << ky) | sigma_y;
    let cell_y = (r << kx) | sigma_x;
    (
        (cell_x << (32 - bits)) | (xi >> bits),
        (cell_y << (32 - bits)) | (eta >> bits),
    )
}

/// The `multijitter` sampler's 32-bit value for one key of a render whose pattern has 2^bits
/// points ([`multijitter_bits`]): component `dim & 1` of pair `dim >> 1`.
#[inline]
pub fn multijitter_u32(seed: u32, bits: u32, pixel: u32, sample: u32, depth: u32, dim: u32) -> u32 {
    let key = sobol_pair_key(sobol_pixel_key(seed, pixel), depth, dim >> 1);
    let (x, y) = multijitter_pair(sample, multijitter_pattern_key(key, sample, bits), bits);
    if dim & 1 == 0 {
        x
    } else {
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Kensler's permutation is a bijection of [0, 2^bits) for every seed.
    #[test]
    fn kensler_permute_is_a_bijection_of_power_of_two_ranges() {
        for p in [0u32, 1, 0x5163_3e2d, 0xdead_beef, u32::MAX] {
            for bits in 0..=12u32 {
                let n = 1usize << bits;
                let mut seen = vec![false; n];
                for i in 0..n as u32 {
                    let j = kensler_permute(i, bits, p) as usize;
                    assert!(j < n && !seen[j], "p {p:#x} bits {bits}: not a bijection");
                    seen[j] = true;
                }
            }
        }
    }

    /// Every `multijitter` pattern (the first one of a render, and later ones) is stratified
    /// in its m×n grid and in each coordinate's N strata; with a non-power-of-two sample count
    /// the samples are distinct points of the larger pattern (each cell at most once).
    #[test]
    fn multijitter_patterns_are_multi_jittered() {
        for (pixel, depth, pair) in [(0u32, 0u32, 0u32), (17, 1, 1), (40_000, 3, 2)] {
            for spp in (1..=10u32).map(|b| 1 << b).chain([3, 100]) {
                let bits = multijitter_bits(spp);
                let n = 1u32 << bits;
                let (kx, ky) = (bits.div_ceil(2), bits / 2);
                for block in [0u32, 3] {
                    let mut cells = vec![false; n as usize];
                    let mut xs = vec![false; n as usize];
                    let mut ys = vec![false; n as usize];
                    for i in block * n..block * n + spp {
                        let key = |d| multijitter_u32(9, bits, pixel, i, depth, 2 * pair + d);
                        let (x, y) = (key(0), key(1));
                        let top = |v: u32, b: u32| v.checked_shr(32 - b).unwrap_or(0);
                        let cell = ((top(x, kx) << ky) | top(y, ky)) as usize;
                        for (seen, what, at) in [
                            (&mut cells, "cell", cell),
                            (&mut xs, "x stratum", top(x, bits) as usize),
                            (&mut ys, "y stratum", top(y, bits) as usize),
                        ] {
                            assert!(
                                !seen[at],
                                "pixel {pixel} depth {depth} pair {pair} spp {spp} block \
                                 {block}: two points in one {what}"
                            );
                            seen[at] = true;
                        }
                    }
                }
            }
        }
        assert_eq!(multijitter_bits(0), 0);
        assert_eq!(multijitter_bits(1), 0);
        assert_eq!(multijitter_bits(64), 6);
        assert_eq!(multijitter_bits(65), 7);
        assert_eq!(multijitter_bits(u32::MAX), MULTIJITTER_MAX_BITS);
    }
}
