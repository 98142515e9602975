//! Counter-based random numbers shared by both renderers.
//!
//! Every random number is a pure function of (seed, pixel, sample index, depth, dimension), so
//! the result does not depend on the order in which queues are processed, and the CPU reference
//! follows exactly the sample paths of the GPU renderer. The GLSL twin is `shaders/rng.glsl`;
//! both must stay bit-identical (tested in `tests/rng_parity.rs`).
//!
//! Dimensions per depth are listed in [`dim`].

/// PCG output permutation used as a 32-bit integer hash (Jarzynski & Olano 2020, "Hash
/// Functions for GPU Rendering", JCGT 9(3): `pcg`).
#[inline]
pub fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28).wrapping_add(4))) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The 32-bit random integer for one (seed, pixel, sample, depth, dimension) key.
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
    (random_u32(seed, pixel, sample, depth, dim) >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Dimension numbers within one depth. Depth 0 is the camera vertex; depth k >= 1 is the
/// vertex at the end of path segment k.
pub mod dim {
    /// Depth 0: sub-pixel position (box filter, one pixel wide).
    pub const PIXEL_X: u32 = 0;
    pub const PIXEL_Y: u32 = 1;
    /// Next-event estimation: which emitter, then a point on it.
    pub const LIGHT_SELECT: u32 = 0;
    pub const LIGHT_U: u32 = 1;
    pub const LIGHT_V: u32 = 2;
    /// BSDF sampling: lobe choice, then the 2-D direction sample.
    pub const BSDF_LOBE: u32 = 3;
    pub const BSDF_U: u32 = 4;
    pub const BSDF_V: u32 = 5;
    /// Russian roulette.
    pub const RR: u32 = 6;
}

/// Random numbers for one (pixel, sample) path; a convenience over [`random_f32`].
#[derive(Clone, Copy, Debug)]
pub struct PathRng {
    pub seed: u32,
    pub pixel: u32,
    pub sample: u32,
}

impl PathRng {
    #[inline]
    pub fn get(&self, depth: u32, dim: u32) -> f32 {
        random_f32(self.seed, self.pixel, self.sample, depth, dim)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_are_in_unit_interval_and_well_spread() {
        let n = 100_000;
        let mut sum = 0.0f64;
        let mut buckets = [0u32; 10];
        for i in 0..n {
            let u = random_f32(7, i, 3, 1, 4);
            assert!((0.0..1.0).contains(&u));
            sum += u as f64;
            buckets[(u * 10.0) as usize] += 1;
        }
        let mean = sum / n as f64;
        assert!((mean - 0.5).abs() < 0.005, "mean {mean}");
        for b in buckets {
            assert!((b as f64 - n as f64 / 10.0).abs() < 500.0, "{buckets:?}");
        }
    }

    #[test]
    fn every_key_component_changes_the_stream() {
        let base = random_u32(1, 2, 3, 4, 5);
        assert_ne!(base, random_u32(9, 2, 3, 4, 5));
        assert_ne!(base, random_u32(1, 9, 3, 4, 5));
        assert_ne!(base, random_u32(1, 2, 9, 4, 5));
        assert_ne!(base, random_u32(1, 2, 3, 9, 5));
        assert_ne!(base, random_u32(1, 2, 3, 4, 9));
    }
}
