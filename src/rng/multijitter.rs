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

/// A hashed permutation of [0, 2^bits), keyed on `p`, for every permutation of a pattern:
/// the padding of the sample index (bits ≤ 24) and the per-row and per-column substrata σ_x
/// and σ_y (bits ≤ 12). A keyed xor, a multiply by a keyed odd number, a masked xorshift by
/// half the width, a second keyed xor and odd multiply, a masked xorshift by one, a keyed
/// offset: every step is a bijection of the low `bits` bits that does not carry higher bits
/// down, so the whole is one for a power-of-two length without the cycle walking a general
/// length needs (no loop on either backend). It replaces Kensler's (2013) hash, with two
/// multiplies where that has seven: over 20,000 keys it reaches more of the small permutations
/// (all 24 of 4 elements, against Kensler's 8) with flatter pair statistics, decorrelates the
/// paddings of two pairs as well, and renders have the same error (docs/bench-log.md, the
/// sampler-cost step).
#[inline]
pub fn hashed_permute(i: u32, bits: u32, p: u32) -> u32 {
    if bits == 0 {
        return 0;
    }
    let w = u32::MAX >> (32 - bits);
    let half = (bits + 1) >> 1;
    let mut i = i ^ p;
    i = i.wrapping_mul((p >> 8) | 1);
    i ^= (i & w) >> half;
    i ^= p >> 16;
    i = i.wrapping_mul((p >> 20) | 1);
    i ^= (i & w) >> 1;
    i.wrapping_add(p >> 12) & w
}

/// The y jitter from the x jitter's hash: a bijective mix (one multiply, xorshifts both
/// sides), so that every bit of the result depends on every bit of `h` and the pair has no
/// structure a render could see, at half the cost of a second hash.
#[inline]
pub fn remix(h: u32) -> u32 {
    let mut h = h ^ (h >> 16);
    h = h.wrapping_mul(0x7feb_352d);
    h ^ (h >> 15)
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
// Inlined as the profile-guided build inlines it (docs/bench-log.md, "Hot functions inlined
// by hand").
#[inline(always)]
pub fn multijitter_pair(sample: u32, p: u32, bits: u32) -> (u32, u32) {
    let kx = bits.div_ceil(2);
    let ky = bits - kx;
    let low = |b: u32| if b == 0 { 0 } else { u32::MAX >> (32 - b) };
    let s = hashed_permute(sample & low(bits), bits, p.wrapping_mul(0x5163_3e2d));
    let (c, r) = (s & low(kx), s >> kx);
    let sigma_x = hashed_permute(c, kx, p.wrapping_mul(0xa511_e9b3));
    let sigma_y = hashed_permute(r, ky, p.wrapping_mul(0x63d8_3595));
    let xi = pcg_hash(s ^ p.wrapping_mul(0xa399_d265));
    let eta = remix(xi);
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

    /// The hashed permutation is a bijection of [0, 2^bits) for every seed, at every width a
    /// pattern uses up to 2^16 (the rows and columns span at most 2^12).
    #[test]
    fn hashed_permute_is_a_bijection_of_power_of_two_ranges() {
        for p in [0u32, 1, 0x5163_3e2d, 0xa511_e9b3, 0xdead_beef, u32::MAX] {
            for bits in 0..=16u32 {
                let n = 1usize << bits;
                let mut seen = vec![false; n];
                for i in 0..n as u32 {
                    let j = hashed_permute(i, bits, p) as usize;
                    assert!(j < n && !seen[j], "p {p:#x} bits {bits}: not a bijection");
                    seen[j] = true;
                }
            }
        }
    }

    /// The y jitter's mix is a bijection (a multiply by an odd number between xorshifts): no
    /// two x jitters share a y jitter. Checked on every 16-bit high half with a few low halves.
    #[test]
    fn remix_is_injective_on_a_sample() {
        let mut seen = std::collections::HashSet::new();
        for hi in 0..1u32 << 16 {
            for lo in [0u32, 1, 0x8001, 0xffff] {
                assert!(
                    seen.insert(remix(hi << 16 | lo)),
                    "remix collides at {hi:#x}:{lo:#x}"
                );
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
