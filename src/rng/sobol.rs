//! The `sobol` sampler: Owen-scrambled Sobol' points (Burley 2020), padded per dimension pair by
//! an Owen scramble of the sample index; described with the other samplers in the [`super`]
//! module docs. Its GLSL twin is the `sobol` part of `shaders/rng.glsl`.

use super::{pcg_hash, sobol_pair_key, sobol_pixel_key, to_unit_f32};

/// A nested uniform scramble of `x`'s bits read from the least significant one, keyed on
/// `seed`: the Laine–Karras-style hash with Burley's (2020) constants. Output bit `k` is
/// input bit `k` flipped by a function of the seed and the bits below `k` only, which is what
/// makes it an Owen scramble of the number whose bits are `x`'s in reverse order.
#[inline]
pub fn lk_permute(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x
}

/// The second Sobol' dimension at index `i`, bit-reversed. Its generator matrix is Pascal's
/// triangle mod 2: bit `m` of the reversed value is the XOR of the index bits `j` with
/// `m ⊆ j` (Lucas' theorem), a superset sum over the 5 bits of a bit position, done in five
/// shift-and-XOR steps instead of a loop over the index bits.
#[inline]
pub fn sobol1_reversed(i: u32) -> u32 {
    let mut z = i;
    z ^= (z >> 1) & 0x5555_5555;
    z ^= (z >> 2) & 0x3333_3333;
    z ^= (z >> 4) & 0x0f0f_0f0f;
    z ^= (z >> 8) & 0x00ff_00ff;
    z ^= (z >> 16) & 0x0000_ffff;
    z
}

/// The shuffled sample index of a pair (the padding): an Owen scramble of the index's
/// reversed bits, a permutation of every aligned block of 2^m indices.
#[inline]
pub fn sobol_shuffled_index(sample: u32, pair_key: u32) -> u32 {
    lk_permute(sample.reverse_bits(), pair_key).reverse_bits()
}

/// Component `c` (0 or 1) of a pair at its shuffled index: the reversed Sobol' value (for
/// dimension 0, the van der Corput radical inverse, whose reversal is the index itself),
/// Owen-scrambled with the component's own key.
#[inline]
pub fn sobol_component(index: u32, pair_key: u32, c: u32) -> u32 {
    let reversed = if c == 0 {
        index
    } else {
        sobol1_reversed(index)
    };
    lk_permute(reversed, pcg_hash(pair_key ^ (1 + c))).reverse_bits()
}

/// The `sobol` batches' bits of a render that has none: every sample draws from one sequence.
pub const SOBOL_UNBATCHED: u32 = 32;

/// The key of one batch of a pair (a render in batches of 2^bits samples, `render --batches`):
/// the pair key, and which batch the sample is in, so that every batch has its own index
/// shuffle and scrambles (independent randomizations of one aligned block of the sequence, a
/// (0,m,2)-net). Without batches (`bits` = [`SOBOL_UNBATCHED`]) and in the first batch, the pair
/// key itself.
#[inline]
pub fn sobol_batch_key(pair_key: u32, sample: u32, bits: u32) -> u32 {
    match sample.checked_shr(bits) {
        Some(batch) if bits < 32 => pair_key ^ batch.wrapping_mul(0x9e37_79b9),
        _ => pair_key,
    }
}

/// The `sobol` sampler's 32-bit value for one key of a render in batches of 2^bits samples
/// ([`SOBOL_UNBATCHED`] for none): dimension `dim` is component `dim & 1` of pair `dim >> 1`
/// (see [`dim`](super::dim)).
#[inline]
pub fn sobol_u32(seed: u32, bits: u32, pixel: u32, sample: u32, depth: u32, dim: u32) -> u32 {
    let pair = sobol_pair_key(sobol_pixel_key(seed, pixel), depth, dim >> 1);
    let key = sobol_batch_key(pair, sample, bits);
    sobol_component(sobol_shuffled_index(sample, key), key, dim & 1)
}

/// The `sobol` sampler's float in [0, 1), with 24 bits.
#[inline]
pub fn sobol_f32(seed: u32, bits: u32, pixel: u32, sample: u32, depth: u32, dim: u32) -> f32 {
    to_unit_f32(sobol_u32(seed, bits, pixel, sample, depth, dim))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reversed second Sobol' dimension equals the direction-number construction
    /// (v_0 = 2^31, v_{j+1} = v_j ^ (v_j >> 1), x = XOR of v_j over the index's bits j).
    #[test]
    fn sobol1_matches_its_direction_numbers() {
        let direct = |mut i: u32| {
            let (mut v, mut x) = (1u32 << 31, 0u32);
            while i != 0 {
                if i & 1 == 1 {
                    x ^= v;
                }
                i >>= 1;
                v ^= v >> 1;
            }
            x
        };
        for i in (0..5000u32).chain([u32::MAX, 0x8000_0000, 0x1234_5678, 0xdead_beef]) {
            assert_eq!(sobol1_reversed(i).reverse_bits(), direct(i), "index {i}");
        }
    }

    /// The scramble keeps bit k a function of bits <= k only: two inputs that agree on their
    /// low k bits agree on the output's low k bits.
    #[test]
    fn lk_permute_is_nested_and_bijective_on_low_bits() {
        for seed in [0u32, 1, 0xdead_beef, 0x8000_0001] {
            for k in 1..12u32 {
                let mask = (1u32 << k) - 1;
                let mut seen = vec![false; 1 << k];
                for x in 0..(1u32 << k) {
                    let y = lk_permute(x, seed) & mask;
                    assert_eq!(y, lk_permute(x | (0x5a5a_5a5a << k), seed) & mask);
                    assert!(!seen[y as usize], "seed {seed} k {k}: not a bijection");
                    seen[y as usize] = true;
                }
            }
        }
    }

    /// Each pair's first 2^m samples, and any aligned block of 2^m, are a (0,m,2)-net: every
    /// elementary interval of area 2^-m (2^a by 2^(m-a) cells) holds one point; so is every
    /// batch of a render in batches of 2^m, each with its own scramble.
    #[test]
    fn sobol_pairs_are_0m2_nets_in_every_aligned_block() {
        for (pixel, depth, pair) in [(0u32, 0u32, 0u32), (17, 1, 1), (40_000, 3, 2), (5, 7, 3)] {
            for m in 0..=8u32 {
                for bits in [SOBOL_UNBATCHED, m] {
                    for block in [0u32, 1, 5] {
                        let n = 1u32 << m;
                        let pts: Vec<(u32, u32)> = (block * n..(block + 1) * n)
                            .map(|i| {
                                (
                                    sobol_u32(9, bits, pixel, i, depth, 2 * pair),
                                    sobol_u32(9, bits, pixel, i, depth, 2 * pair + 1),
                                )
                            })
                            .collect();
                        for a in 0..=m {
                            let mut seen = vec![false; n as usize];
                            for &(x, y) in &pts {
                                let (cx, cy) = (
                                    x.checked_shr(32 - a).unwrap_or(0),
                                    y.checked_shr(32 - (m - a)).unwrap_or(0),
                                );
                                let cell = ((cx << (m - a)) | cy) as usize;
                                assert!(
                                    !seen[cell],
                                    "pixel {pixel} depth {depth} pair {pair} m {m} bits {bits} \
                                     block {block} {a}x{}: two points in one cell",
                                    m - a
                                );
                                seen[cell] = true;
                            }
                        }
                    }
                }
            }
        }
    }

    /// A render in batches draws batch 0 as the unbatched render does, and every later batch
    /// from its own scramble: not the unbatched sequence's points.
    #[test]
    fn sobol_batches_are_scrambled_apart() {
        let bits = 3;
        for i in 0..8u32 {
            assert_eq!(
                sobol_u32(4, bits, 11, i, 1, 2),
                sobol_u32(4, SOBOL_UNBATCHED, 11, i, 1, 2)
            );
        }
        let same = (8..64u32)
            .filter(|&i| {
                sobol_u32(4, bits, 11, i, 1, 2) == sobol_u32(4, SOBOL_UNBATCHED, 11, i, 1, 2)
            })
            .count();
        assert!(
            same <= 1,
            "{same} of 56 numbers of later batches are the sequence's"
        );
        assert_eq!(sobol_batch_key(7, 1 << 31, SOBOL_UNBATCHED), 7);
        assert_ne!(sobol_batch_key(7, 8, 3), 7);
    }
}
