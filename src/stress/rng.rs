//! The stress groups' random numbers: a seedable SplitMix64 generator and the seed of each
//! case, so that a case is reproduced from its group and case seed alone.

/// SplitMix64 (Steele, Lea & Flood 2014): small, seedable, good enough for test inputs.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1), 53 bits.
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [0, 1).
    pub fn f(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    pub fn range(&mut self, a: f32, b: f32) -> f32 {
        a + (b - a) * self.f()
    }
    /// Log-uniform in [a, b] (a, b > 0).
    pub fn log_range(&mut self, a: f32, b: f32) -> f32 {
        let (la, lb) = ((a as f64).ln(), (b as f64).ln());
        ((la + (lb - la) * self.f() as f64).exp() as f32).clamp(a, b)
    }
    pub fn pick<'a, T>(&mut self, v: &'a [T]) -> &'a T {
        &v[(self.next_u64() % v.len() as u64) as usize]
    }
    /// A value in [a, b]: an end exactly, near an end (log scale), or uniform.
    pub fn extreme(&mut self, a: f32, b: f32, floor: f32) -> f32 {
        match self.next_u64() % 5 {
            0 => a.max(floor),
            1 => b,
            2 => self.log_range(floor.max(a).max(1e-30), b),
            _ => self.range(a.max(floor), b),
        }
    }
}

/// The seed of case `case` of group `group` in a run with seed `seed`.
pub fn case_seed(seed: u64, group: usize, case: u64) -> u64 {
    let mut r = Rng::new(seed ^ (group as u64).wrapping_mul(0xA076_1D64_78BD_642F));
    for _ in 0..2 {
        r.next_u64();
    }
    r.0 ^= case.wrapping_mul(0xE703_7ED1_A0B4_28DB);
    r.next_u64()
}
