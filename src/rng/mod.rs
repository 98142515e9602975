//! Counter-based random numbers shared by both renderers: the integrator's samplers.
//!
//! Every random number is a pure function of (seed, pixel, sample index, depth, dimension), so
//! the result does not depend on the order in which queues are processed, a render split by
//! sample ranges merges exactly, and the CPU reference follows exactly the sample paths of the
//! GPU renderer. The GLSL twin is `shaders/rng.glsl`; both must stay bit-identical (tested in
//! `tests/rng_parity.rs`). The dimension table is [`dim`]; the GLSL side gets it from
//! [`defines`], so it is written down once.
//!
//! This file holds the stream keys, the `independent` sampler and the public API (re-exporting
//! the rest); the two low-discrepancy samplers are `sobol.rs` and `multijitter.rs`. The CPU
//! reference draws a pixel's numbers 16 samples at a time (`packet.rs`, [`PacketRng`]): the
//! same numbers, each pair computed in SIMD lanes for the packet's samples.
//!
//! Three samplers ([`Sampler`]), chosen by the scene's `[integrator] sampler` or `--sampler`:
//!
//! * `multijitter` (the default): correlated multi-jittered points (Kensler 2013,
//!   "Correlated Multi-Jittered Sampling", Pixar technical memo 13-01), the construction of
//!   Mitsuba 3's `multijitter`. Dimensions come in pairs (see [`dim`]); a render of N samples
//!   per pixel gives each (pixel, depth, pair) its own pattern of 2^⌈log2 N⌉ points: a grid of
//!   m×n cells (m = 2^⌈b/2⌉ columns, n = 2^⌊b/2⌋ rows) with one point each, whose 2^b x and y
//!   coordinates also fall in 2^b distinct strata each ("n-rooks"), jittered within them. The
//!   sample index is first permuted per pattern (the padding that keeps pairs independent),
//!   and the rows' and columns' substrata get one permutation each; every permutation is one
//!   short hash over a power-of-two range ([`hashed_permute`]), a bijection without cycle
//!   walking, so neither backend loops, and both jitters come from one hash
//!   ([`multijitter_pair`]). A non-power-of-two N draws N of
//!   the pattern's points (each cell at most once), and every number is uniform, so any N is
//!   unbiased. The pattern depends on N, so the parts of a split render keep the whole
//!   render's N (`Integrator::pattern_spp`), and the bench measures each sample count as a
//!   fresh render. A render in K batches (`render --batches`, `Integrator::batch_spp`) sizes
//!   the pattern by the batch, N/K, so that each batch is an independent pattern. Measured on the two Cornell boxes (BENCHMARKS.md): at 16, 64 and 256 spp
//!   these points have 3–7 % less error than the padded Sobol' nets below, because for the
//!   discontinuous and the smooth 2-D integrands a path tracer meets, a jittered grid with
//!   n-rooks strata has less variance than a scrambled (0,2)-net at these counts.
//! * `sobol`: Owen-scrambled Sobol' points, padded per pair of dimensions.
//!   Dimensions come in pairs (see [`dim`]); within one (pixel, depth, pair) the sample index
//!   `i` is first shuffled by a nested uniform (Owen) scramble of its bits taken in reverse
//!   order, keyed on a hash of (seed, pixel, depth, pair) — the index shuffle that pads one pair
//!   against the others (Burley 2020, "Practical Hash-based Owen Scrambling", JCGT 9(4)).
//!   The pair is then the first two dimensions of the Sobol' sequence at the shuffled index,
//!   each Owen-scrambled with its own key (same paper, with its improved Laine–Karras hash).
//!   The first two Sobol' dimensions form a (0,2)-sequence (Sobol' 1967; Niederreiter 1992),
//!   and both the shuffle and the scramble keep that: for any `m`, the samples `0..2^m`
//!   of a pair are a (0,m,2)-net (each of the 2^m elementary intervals of area 2^-m holds
//!   exactly one point), and each aligned block `k·2^m..(k+1)·2^m` is one too, so progressive
//!   passes and sample ranges of power-of-two sizes are stratified as one render. Every single
//!   number is uniform on [0, 1) (the scramble is random), so any sample count, power of two or
//!   not, is unbiased. Pixels, depths and pairs get independent scrambles: errors of pixels are
//!   independent (white noise) and pairs do not correlate. A render in batches of 2^m samples
//!   (`render --batches`) keys each batch's shuffle and scrambles on the batch too
//!   ([`sobol_batch_key`]): each batch an independently randomized net.
//! * `independent`: each number is its own hash of the key (PCG, Jarzynski & Olano 2020) — the
//!   first sampler, kept for comparison and for the tests whose statistics need independent
//!   samples (the per-sample variance of a stratified render overstates the variance of its
//!   mean, which makes a z-test on it conservative).
//!
//! All three output 24-bit floats: exactly representable in f32, never 1.

use std::fmt;

mod multijitter;
mod packet;
mod sobol;

pub use multijitter::{
    hashed_permute, multijitter_bits, multijitter_pair, multijitter_pattern_key, multijitter_u32,
    remix, MULTIJITTER_MAX_BITS,
};
pub use packet::{LaneRng, PacketRng, PACKET};
pub use sobol::{
    lk_permute, sobol1_reversed, sobol_batch_key, sobol_component, sobol_f32, sobol_shuffled_index,
    sobol_u32, SOBOL_UNBATCHED,
};

/// PCG output permutation used as a 32-bit integer hash (Jarzynski & Olano 2020, "Hash
/// Functions for GPU Rendering", JCGT 9(3): `pcg`).
#[inline]
pub fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28).wrapping_add(4))) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The integrator's sampler: where its random numbers come from (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Sampler {
    /// Correlated multi-jittered points of the render's sample count, padded per dimension
    /// pair by a permutation of the sample index.
    #[default]
    Multijitter,
    /// Owen-scrambled Sobol' points, padded per dimension pair by an index shuffle.
    Sobol,
    /// Independent uniform numbers, one hash per key.
    Independent,
}

impl Sampler {
    pub const ALL: [Sampler; 3] = [Sampler::Multijitter, Sampler::Sobol, Sampler::Independent];

    /// The name in scene files, on the command line and in summaries.
    pub fn name(self) -> &'static str {
        match self {
            Sampler::Multijitter => "multijitter",
            Sampler::Sobol => "sobol",
            Sampler::Independent => "independent",
        }
    }

    pub fn parse(name: &str) -> Option<Sampler> {
        Sampler::ALL.into_iter().find(|s| s.name() == name)
    }

    /// The names, for messages: `multijitter, sobol, independent`.
    pub fn names() -> String {
        Sampler::ALL.map(|s| s.name()).join(", ")
    }

    /// The GLSL define that selects this sampler in `rand()` (`shaders/wavefront/state.glsl`).
    pub fn define(self) -> &'static str {
        match self {
            Sampler::Multijitter => "SAMPLER_MULTIJITTER",
            Sampler::Sobol => "SAMPLER_SOBOL",
            Sampler::Independent => "SAMPLER_INDEPENDENT",
        }
    }

    /// The uniform number in [0, 1) for one key of a render of `spp` samples per pixel (the
    /// `multijitter` pattern's size; the other samplers do not depend on it), not in batches
    /// ([`PathRng`] takes a render's batches).
    #[inline]
    pub fn get(self, seed: u32, spp: u32, pixel: u32, sample: u32, depth: u32, dim: u32) -> f32 {
        match self {
            Sampler::Multijitter => to_unit_f32(multijitter_u32(
                seed,
                multijitter_bits(spp),
                pixel,
                sample,
                depth,
                dim,
            )),
            Sampler::Sobol => sobol_f32(seed, SOBOL_UNBATCHED, pixel, sample, depth, dim),
            Sampler::Independent => random_f32(seed, pixel, sample, depth, dim),
        }
    }
}

impl fmt::Display for Sampler {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The 32-bit random integer for one (seed, pixel, sample, depth, dimension) key: the
/// `independent` sampler.
#[inline]
pub fn random_u32(seed: u32, pixel: u32, sample: u32, depth: u32, dim: u32) -> u32 {
    let mut h = pcg_hash(seed ^ 0x9E37_79B9);
    h = pcg_hash(h ^ pixel);
    h = pcg_hash(h ^ sample);
    h = pcg_hash(h ^ (depth.wrapping_mul(64).wrapping_add(dim)));
    h
}

/// A uniform float in [0, 1), with 24 bits: exactly representable in f32, never 1.
#[inline]
pub fn random_f32(seed: u32, pixel: u32, sample: u32, depth: u32, dim: u32) -> f32 {
    to_unit_f32(random_u32(seed, pixel, sample, depth, dim))
}

/// The top 24 bits of `x` as a float in [0, 1).
#[inline]
pub fn to_unit_f32(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// The part of a `sobol` key that depends on (seed, pixel) only: the same for all of a path's
/// numbers, so a path computes it once ([`PathRng`]).
#[inline]
pub fn sobol_pixel_key(seed: u32, pixel: u32) -> u32 {
    pcg_hash(pcg_hash(seed ^ 0x2545_f491) ^ pixel)
}

/// The hash of (seed, pixel, depth, pair) that keys a dimension pair's index shuffle; each
/// component's scramble key is derived from it.
#[inline]
pub fn sobol_pair_key(pixel_key: u32, depth: u32, pair: u32) -> u32 {
    pcg_hash(pixel_key ^ depth.wrapping_mul(64).wrapping_add(pair))
}

/// Dimension numbers within one depth: every random number the integrator draws. Depth 0 is
/// the camera vertex; depth k >= 1 is the vertex at the end of path segment k, where the path
/// chooses its light sample, its BSDF sample and whether it survives. Dimensions `2p` and
/// `2p + 1` are pair `p`, whose numbers the `sobol` sampler stratifies jointly (a 2-D net);
/// different pairs and depths are padded against each other. A one-dimensional use takes one
/// component of a pair.
///
/// | depth | dim | name | what it decides | pair |
/// |---|---|---|---|---|
/// | 0 | 0 | `PIXEL_X` | sub-pixel x (box filter, one pixel wide) | 0 |
/// | 0 | 1 | `PIXEL_Y` | sub-pixel y | 0 |
/// | 0 | 2 | `LENS_U` | point on the thin lens, first coordinate (`crate::camera`) | 1 |
/// | 0 | 3 | `LENS_V` | point on the thin lens, second coordinate | 1 |
/// | k >= 1 | 0 | `LIGHT_SELECT` | which emitter (next-event estimation) | 0 |
/// | k >= 1 | 1 | `BSDF_LOBE` | which lobe of the BSDF | 0 |
/// | k >= 1 | 2 | `LIGHT_U` | point on the emitter (or direction of the environment map), first coordinate | 1 |
/// | k >= 1 | 3 | `LIGHT_V` | point on the emitter (or direction of the environment map), second coordinate | 1 |
/// | k >= 1 | 4 | `BSDF_U` | BSDF direction, first coordinate | 2 |
/// | k >= 1 | 5 | `BSDF_V` | BSDF direction, second coordinate | 2 |
/// | k >= 1 | 6 | `RR` | Russian roulette | 3 |
pub mod dim {
    pub const PIXEL_X: u32 = 0;
    pub const PIXEL_Y: u32 = 1;
    pub const LENS_U: u32 = 2;
    pub const LENS_V: u32 = 3;
    pub const LIGHT_SELECT: u32 = 0;
    pub const BSDF_LOBE: u32 = 1;
    pub const LIGHT_U: u32 = 2;
    pub const LIGHT_V: u32 = 3;
    pub const BSDF_U: u32 = 4;
    pub const BSDF_V: u32 = 5;
    pub const RR: u32 = 6;
    /// Every dimension with its name, for the GLSL defines (`DIM_<name>`).
    pub const ALL: [(&str, u32); 11] = [
        ("PIXEL_X", PIXEL_X),
        ("PIXEL_Y", PIXEL_Y),
        ("LENS_U", LENS_U),
        ("LENS_V", LENS_V),
        ("LIGHT_SELECT", LIGHT_SELECT),
        ("BSDF_LOBE", BSDF_LOBE),
        ("LIGHT_U", LIGHT_U),
        ("LIGHT_V", LIGHT_V),
        ("BSDF_U", BSDF_U),
        ("BSDF_V", BSDF_V),
        ("RR", RR),
    ];
}

/// The dimension table and the sampler as GLSL defines (`DIM_PIXEL_X 0u`, …, and
/// `SAMPLER_SOBOL` or `SAMPLER_INDEPENDENT`), added to every wavefront stage.
pub fn defines(sampler: Sampler) -> Vec<(String, String)> {
    let mut d: Vec<(String, String)> = dim::ALL
        .iter()
        .map(|(n, v)| (format!("DIM_{n}"), format!("{v}u")))
        .collect();
    d.push((sampler.define().to_string(), "1".to_string()));
    d
}

/// Random numbers for one (pixel, sample) path: the numbers of [`Sampler::get`], with the
/// hashes that depend on the path alone computed once, and a pair's two numbers drawn
/// together ([`PathRng::get2`]: one pair key and one shuffled index for both).
#[derive(Clone, Copy, Debug)]
pub struct PathRng {
    sampler: Sampler,
    seed: u32,
    pixel: u32,
    sample: u32,
    /// [`sobol_pixel_key`] of (seed, pixel).
    pixel_key: u32,
    /// [`pattern_bits`] of the render.
    pattern_bits: u32,
}

/// The bits of a render's patterns, as both backends take them (the GPU's `pattern_bits`): for
/// `multijitter` its pattern has 2^bits points, sized by `batch_spp` when the render is in
/// batches (`render --batches`, each batch its own pattern), else by `pattern_spp` (the whole
/// render's sample count); for `sobol`, each batch of 2^bits samples has its own scramble
/// ([`sobol_batch_key`]), [`SOBOL_UNBATCHED`] without batches; `independent` has none (0).
pub fn pattern_bits(sampler: Sampler, pattern_spp: u32, batch_spp: Option<u32>) -> u32 {
    match sampler {
        Sampler::Multijitter => multijitter_bits(batch_spp.unwrap_or(pattern_spp)),
        Sampler::Sobol => batch_spp.map_or(SOBOL_UNBATCHED, multijitter_bits),
        Sampler::Independent => 0,
    }
}

impl PathRng {
    /// The numbers of one path of a render of `spp` samples per pixel, not in batches.
    pub fn new(sampler: Sampler, seed: u32, spp: u32, pixel: u32, sample: u32) -> PathRng {
        PathRng::with_bits(
            sampler,
            seed,
            pattern_bits(sampler, spp, None),
            pixel,
            sample,
        )
    }

    /// The numbers of one path of a render whose patterns have `bits` ([`pattern_bits`]).
    pub fn with_bits(sampler: Sampler, seed: u32, bits: u32, pixel: u32, sample: u32) -> PathRng {
        PathRng {
            sampler,
            seed,
            pixel,
            sample,
            pixel_key: sobol_pixel_key(seed, pixel),
            pattern_bits: bits,
        }
    }

    /// The key of a `sobol` pair, of the path's batch.
    #[inline]
    fn sobol_key(&self, depth: u32, dim: u32) -> u32 {
        let pair = sobol_pair_key(self.pixel_key, depth, dim >> 1);
        sobol_batch_key(pair, self.sample, self.pattern_bits)
    }

    /// The `multijitter` pair (as 32-bit values) of dimensions `dim & !1` and `dim | 1`.
    #[inline]
    fn multijitter(&self, depth: u32, dim: u32) -> (u32, u32) {
        let key = sobol_pair_key(self.pixel_key, depth, dim >> 1);
        let bits = self.pattern_bits;
        multijitter_pair(
            self.sample,
            multijitter_pattern_key(key, self.sample, bits),
            bits,
        )
    }

    /// Pair `pair` (dimensions `2·pair` and `2·pair + 1`) at `depth` as 32-bit values, whose
    /// [`to_unit_f32`] are the numbers [`get2`](Self::get2) and [`get`](Self::get) return.
    #[inline(always)]
    pub fn pair_u32(&self, depth: u32, pair: u32) -> (u32, u32) {
        let dim = 2 * pair;
        match self.sampler {
            Sampler::Multijitter => self.multijitter(depth, dim),
            Sampler::Sobol => {
                let key = self.sobol_key(depth, dim);
                let index = sobol_shuffled_index(self.sample, key);
                (
                    sobol_component(index, key, 0),
                    sobol_component(index, key, 1),
                )
            }
            Sampler::Independent => (
                random_u32(self.seed, self.pixel, self.sample, depth, dim),
                random_u32(self.seed, self.pixel, self.sample, depth, dim + 1),
            ),
        }
    }

    /// The same numbers for sample `sample` of the same pixel and render.
    #[inline]
    pub fn with_sample(&self, sample: u32) -> PathRng {
        PathRng { sample, ..*self }
    }

    /// The number of dimension `dim` at `depth`.
    #[inline]
    pub fn get(&self, depth: u32, dim: u32) -> f32 {
        match self.sampler {
            Sampler::Multijitter => {
                let (x, y) = self.multijitter(depth, dim);
                to_unit_f32(if dim & 1 == 0 { x } else { y })
            }
            Sampler::Sobol => {
                let key = self.sobol_key(depth, dim);
                to_unit_f32(sobol_component(
                    sobol_shuffled_index(self.sample, key),
                    key,
                    dim & 1,
                ))
            }
            Sampler::Independent => random_f32(self.seed, self.pixel, self.sample, depth, dim),
        }
    }

    /// The numbers of dimensions `dim` and `dim + 1` (one pair; `dim` even) at `depth`.
    // Inlined as the profile-guided build inlines it (docs/bench-log.md, "Hot functions inlined
    // by hand").
    #[inline(always)]
    pub fn get2(&self, depth: u32, dim: u32) -> glam::Vec2 {
        debug_assert!(dim & 1 == 0, "a pair starts at an even dimension");
        match self.sampler {
            Sampler::Multijitter => {
                let (x, y) = self.multijitter(depth, dim);
                glam::Vec2::new(to_unit_f32(x), to_unit_f32(y))
            }
            Sampler::Sobol => {
                let key = self.sobol_key(depth, dim);
                let index = sobol_shuffled_index(self.sample, key);
                glam::Vec2::new(
                    to_unit_f32(sobol_component(index, key, 0)),
                    to_unit_f32(sobol_component(index, key, 1)),
                )
            }
            Sampler::Independent => glam::Vec2::new(
                random_f32(self.seed, self.pixel, self.sample, depth, dim),
                random_f32(self.seed, self.pixel, self.sample, depth, dim + 1),
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_are_in_unit_interval_and_well_spread() {
        for sampler in Sampler::ALL {
            let n = 100_000;
            let mut sum = 0.0f64;
            let mut buckets = [0u32; 10];
            for i in 0..n {
                // Across pixels (independent scrambles) and across samples of one pixel.
                for u in [
                    sampler.get(7, 64, i, 3, 1, 4),
                    sampler.get(7, n, 3, i, 1, 5),
                ] {
                    assert!((0.0..1.0).contains(&u));
                    sum += u as f64;
                    buckets[(u * 10.0) as usize] += 1;
                }
            }
            let mean = sum / (2 * n) as f64;
            assert!((mean - 0.5).abs() < 0.005, "{sampler}: mean {mean}");
            for b in buckets {
                assert!(
                    (b as f64 - 2.0 * n as f64 / 10.0).abs() < 1000.0,
                    "{sampler}: {buckets:?}"
                );
            }
        }
    }

    /// A sampler's 32-bit value as a function of (seed, pixel, sample, depth, dim).
    type KeyedU32 = fn(u32, u32, u32, u32, u32) -> u32;

    #[test]
    fn every_key_component_changes_the_stream() {
        let mj =
            |seed, pixel, sample, depth, dim| multijitter_u32(seed, 6, pixel, sample, depth, dim);
        let sobol = |seed, pixel, sample, depth, dim| {
            sobol_u32(seed, SOBOL_UNBATCHED, pixel, sample, depth, dim)
        };
        let fs: [KeyedU32; 3] = [random_u32, sobol, mj];
        for f in fs {
            let base = f(1, 2, 3, 4, 5);
            assert_ne!(base, f(9, 2, 3, 4, 5));
            assert_ne!(base, f(1, 9, 3, 4, 5));
            assert_ne!(base, f(1, 2, 9, 4, 5));
            assert_ne!(base, f(1, 2, 3, 9, 5));
            assert_ne!(base, f(1, 2, 3, 4, 4));
        }
    }

    /// Padding: two different pairs at one depth, and one pair at two depths, are not
    /// correlated (sample correlation of 4096 points near 0, where a shared, unshuffled
    /// sequence would give 1).
    #[test]
    fn pairs_and_depths_are_decorrelated() {
        let n = 4096u32;
        let corr = |a: &dyn Fn(u32) -> f32, b: &dyn Fn(u32) -> f32| {
            let (mut sa, mut sb, mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for i in 0..n {
                let (x, y) = (a(i) as f64, b(i) as f64);
                sa += x;
                sb += y;
                sab += x * y;
                saa += x * x;
                sbb += y * y;
            }
            let nf = n as f64;
            (sab / nf - sa * sb / nf / nf)
                / ((saa / nf - (sa / nf).powi(2)) * (sbb / nf - (sb / nf).powi(2))).sqrt()
        };
        for sampler in [Sampler::Sobol, Sampler::Multijitter] {
            let s = move |depth: u32, d: u32| move |i: u32| sampler.get(3, n, 77, i, depth, d);
            for (a, b) in [
                ((1, 2), (1, 4)),
                ((1, 4), (2, 4)),
                ((1, 0), (1, 6)),
                ((0, 0), (1, 2)),
            ] {
                let r = corr(&s(a.0, a.1), &s(b.0, b.1));
                assert!(
                    r.abs() < 0.08,
                    "{sampler} depth/dim {a:?} vs {b:?}: correlation {r}"
                );
            }
        }
    }

    /// What the sampler is for: a smooth 2-D integral estimated with 64 points per pixel has a
    /// far lower mean squared error with `sobol` than with `independent` (about 1/N^1.5 against
    /// 1/N for Owen-scrambled nets), and both are unbiased.
    #[test]
    fn sobol_integrates_a_smooth_function_with_less_error() {
        let f = |x: f32, y: f32| {
            let (x, y) = (x as f64, y as f64);
            (x * 3.0).sin() * y + x * x * (y * 2.0).cos()
        };
        // ∫∫ sin(3x) y + x² cos(2y) dx dy over the unit square.
        let exact = (1.0 - 3f64.cos()) / 3.0 * 0.5 + (1.0 / 3.0) * (2f64.sin() / 2.0);
        let (pixels, n) = (2000u32, 64u32);
        let mut mse = [0.0f64; 3];
        let mut bias = [0.0f64; 3];
        for (k, sampler) in Sampler::ALL.into_iter().enumerate() {
            for p in 0..pixels {
                let est = (0..n)
                    .map(|i| {
                        f(
                            sampler.get(1, n, p, i, 2, dim::BSDF_U),
                            sampler.get(1, n, p, i, 2, dim::BSDF_V),
                        )
                    })
                    .sum::<f64>()
                    / n as f64;
                mse[k] += (est - exact).powi(2) / pixels as f64;
                bias[k] += (est - exact) / pixels as f64;
            }
        }
        let [multijitter, sobol, independent] = mse;
        for (name, m) in [("multijitter", multijitter), ("sobol", sobol)] {
            assert!(
                m * 10.0 < independent,
                "MSE {name} {m:e} vs independent {independent:e}"
            );
        }
        for (k, b) in bias.iter().enumerate() {
            // Standard error of the mean over pixels.
            let se = (mse[k] / pixels as f64).sqrt();
            assert!(b.abs() < 4.0 * se, "sampler {k}: bias {b:e} (se {se:e})");
        }
    }

    /// Non-power-of-two sample counts are unbiased too: the mean of the first 3, 5 and 100
    /// samples over many pixels is 1/2 within its standard error (for `multijitter`, renders of
    /// that many samples, which draw them from patterns of 4, 8 and 128 points).
    #[test]
    fn any_sample_count_is_unbiased() {
        for (n, sampler) in [3u32, 5, 100]
            .into_iter()
            .flat_map(|n| [(n, Sampler::Sobol), (n, Sampler::Multijitter)])
        {
            let pixels = 20_000u32;
            let means: Vec<f64> = (0..pixels)
                .map(|p| {
                    (0..n)
                        .map(|i| sampler.get(4, n, p, i, 1, 3) as f64)
                        .sum::<f64>()
                        / n as f64
                })
                .collect();
            let m = means.iter().sum::<f64>() / pixels as f64;
            let var = means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (pixels - 1) as f64;
            let se = (var / pixels as f64).sqrt();
            assert!(
                (m - 0.5).abs() < 4.0 * se,
                "{sampler} n {n}: mean {m} (se {se})"
            );
        }
    }

    /// A path's draws, one at a time and in pairs, are the sampler's numbers for their keys.
    #[test]
    fn path_draws_are_the_samplers_numbers() {
        for sampler in Sampler::ALL {
            for (pixel, sample) in [(0u32, 0u32), (77, 5), (123_456, 1 << 20)] {
                let r = PathRng::new(sampler, 9, 64, pixel, sample);
                for depth in 0..4 {
                    for d in 0..7 {
                        assert_eq!(r.get(depth, d), sampler.get(9, 64, pixel, sample, depth, d));
                    }
                    for d in [0, 2, 4] {
                        let v = r.get2(depth, d);
                        assert_eq!(v.x, sampler.get(9, 64, pixel, sample, depth, d));
                        assert_eq!(v.y, sampler.get(9, 64, pixel, sample, depth, d + 1));
                    }
                }
            }
        }
    }

    #[test]
    fn sampler_names_round_trip_and_dimensions_are_distinct_per_depth() {
        for s in Sampler::ALL {
            assert_eq!(Sampler::parse(s.name()), Some(s));
        }
        assert_eq!(Sampler::parse("halton"), None);
        assert_eq!(Sampler::default(), Sampler::Multijitter);
        let camera: Vec<u32> = dim::ALL[..4].iter().map(|d| d.1).collect();
        assert_eq!(
            camera,
            [0, 1, 2, 3],
            "depth 0: the pixel pair, then the lens pair"
        );
        let later: Vec<u32> = dim::ALL[4..].iter().map(|d| d.1).collect();
        for (i, a) in later.iter().enumerate() {
            assert!(*a < 64, "the independent key has 64 dimensions per depth");
            assert!(later[i + 1..].iter().all(|b| b != a), "{later:?}");
        }
        assert_ne!(dim::PIXEL_X, dim::PIXEL_Y);
        assert_eq!(
            dim::PIXEL_X >> 1,
            dim::PIXEL_Y >> 1,
            "the pixel offsets are one pair"
        );
        assert_eq!(
            dim::LIGHT_U >> 1,
            dim::LIGHT_V >> 1,
            "the light point is one pair"
        );
        assert_eq!(
            dim::BSDF_U >> 1,
            dim::BSDF_V >> 1,
            "the BSDF direction is one pair"
        );
    }
}
