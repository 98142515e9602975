//! The numbers of [`PathRng`] for a packet of up to [`PACKET`] consecutive samples of one pixel,
//! each pair computed once for the whole packet: the CPU reference traces a pixel's samples one
//! after another, and they draw the same (depth, pair) keys, so the first path to ask for a pair
//! computes it for all the packet's samples in one loop that the compiler puts in SIMD lanes
//! (the keys that depend on the pixel, depth and pair alone once, the per-sample hashes 16 at a
//! time), and the other paths read it. The numbers are [`PathRng::pair_u32`]'s, bit for bit:
//! only when they are computed changes.

use super::{to_unit_f32, PathRng, Sampler};

/// The most samples per packet: a packet of n samples (a power of two, at most 16) holds samples
/// `n·k .. n·k + n` of one pixel.
pub const PACKET: usize = 16;
/// Depths whose pairs the packet keeps (0 to 15); deeper vertices compute theirs one path at a
/// time.
const CACHED_DEPTHS: u32 = 16;
/// Pairs per depth the packet keeps: every pair of [`super::dim`].
const CACHED_PAIRS: u32 = 4;
const SLOTS: usize = (CACHED_DEPTHS * CACHED_PAIRS) as usize;
const _: () = assert!(SLOTS <= 64 && PACKET.is_power_of_two());

/// The pairs of one packet computed so far (8 KiB), reused packet after packet.
pub struct PacketRng {
    /// The numbers of the packet's first sample (`first`).
    rng: PathRng,
    /// Whether `rng` is a packet's yet (nothing is computed before the first [`Self::path`]).
    started: bool,
    /// Samples per packet, a power of two up to [`PACKET`].
    lanes: usize,
    /// Bit `depth·CACHED_PAIRS + pair` set once that slot of `x` and `y` holds the pair.
    valid: u64,
    x: [[u32; PACKET]; SLOTS],
    y: [[u32; PACKET]; SLOTS],
}

impl PacketRng {
    /// An empty packet for a render's sampler, seed and pattern bits ([`super::pattern_bits`]),
    /// which traces `samples` samples of each pixel: packets of that many, rounded up to a power
    /// of two, at most [`PACKET`] (a pair computed for samples the render does not trace is
    /// wasted: a 1-spp render draws each pair once).
    pub fn new(sampler: Sampler, seed: u32, bits: u32, samples: u32) -> PacketRng {
        PacketRng {
            rng: PathRng::with_bits(sampler, seed, bits, 0, 0),
            started: false,
            lanes: (samples.max(1) as usize).next_power_of_two().min(PACKET),
            valid: 0,
            x: [[0; PACKET]; SLOTS],
            y: [[0; PACKET]; SLOTS],
        }
    }

    /// Samples per packet, a power of two up to [`PACKET`].
    pub fn lanes(&self) -> usize {
        self.lanes
    }

    /// The numbers of the path (pixel, sample): those of `PathRng::with_bits(sampler, seed,
    /// bits, pixel, sample)`. The packet starts over when the path is not one of its own.
    #[inline]
    pub fn path(&mut self, pixel: u32, sample: u32) -> LaneRng<'_> {
        let first = sample & !(self.lanes as u32 - 1);
        if !(self.started && self.rng.pixel == pixel && self.rng.sample == first) {
            let r = &self.rng;
            self.rng = PathRng::with_bits(r.sampler, r.seed, r.pattern_bits, pixel, first);
            self.started = true;
            self.valid = 0;
        }
        LaneRng {
            lane: (sample - first) as usize,
            packet: self,
        }
    }

    /// Computes pair `pair` at `depth` for every sample of the packet into slot `slot`. The
    /// sampler, the pixel key, depth and pair are the same for all lanes, so the compiler
    /// hoists them and vectorises the per-sample part.
    #[inline(never)]
    fn fill(&mut self, slot: usize, depth: u32, pair: u32) {
        let lanes = self.lanes;
        let (xs, ys) = (&mut self.x[slot][..lanes], &mut self.y[slot][..lanes]);
        let first = self.rng.sample;
        for (k, (x, y)) in xs.iter_mut().zip(ys.iter_mut()).enumerate() {
            let sample = first.wrapping_add(k as u32);
            (*x, *y) = self.rng.with_sample(sample).pair_u32(depth, pair);
        }
        self.valid |= 1 << slot;
    }
}

/// One path's numbers, from its packet ([`PacketRng::path`]); the same API as [`PathRng`].
pub struct LaneRng<'a> {
    packet: &'a mut PacketRng,
    /// The path's sample minus the packet's first, below [`PACKET`].
    lane: usize,
}

impl LaneRng<'_> {
    /// [`PathRng::pair_u32`] of this path.
    #[inline(always)]
    fn pair(&mut self, depth: u32, pair: u32) -> (u32, u32) {
        let lane = self.lane & (PACKET - 1);
        if depth < CACHED_DEPTHS && pair < CACHED_PAIRS {
            let slot = (depth * CACHED_PAIRS + pair) as usize;
            let p = &mut *self.packet;
            if p.valid & (1 << slot) == 0 {
                p.fill(slot, depth, pair);
            }
            (p.x[slot][lane], p.y[slot][lane])
        } else {
            let p = &self.packet.rng;
            p.with_sample(p.sample + lane as u32).pair_u32(depth, pair)
        }
    }

    /// [`PathRng::get`]: the number of dimension `dim` at `depth`.
    #[inline(always)]
    pub fn get(&mut self, depth: u32, dim: u32) -> f32 {
        let (x, y) = self.pair(depth, dim >> 1);
        to_unit_f32(if dim & 1 == 0 { x } else { y })
    }

    /// [`PathRng::get2`]: the numbers of dimensions `dim` and `dim + 1` (`dim` even).
    #[inline(always)]
    pub fn get2(&mut self, depth: u32, dim: u32) -> glam::Vec2 {
        debug_assert!(dim & 1 == 0, "a pair starts at an even dimension");
        let (x, y) = self.pair(depth, dim >> 1);
        glam::Vec2::new(to_unit_f32(x), to_unit_f32(y))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every number a packet gives is the path's own, for every sampler, at cached and
    /// uncached depths and pairs, with paths visited out of order, packets started part-way
    /// (a sample range not aligned to the packet), and pixels revisited.
    #[test]
    fn packets_give_each_path_its_own_numbers() {
        for sampler in Sampler::ALL {
            for (bits, lanes) in [(0u32, 1u32), (3, 16), (4, 3), (7, 16), (7, 100)] {
                let seed = 0x1234_5678;
                let mut packet = PacketRng::new(sampler, seed, bits, lanes);
                let paths = [
                    (5u32, 3u32),
                    (5, 17),
                    (5, 16),
                    (9, 17),
                    (5, 31),
                    (5, 0),
                    (9, 40),
                ];
                for (pixel, sample) in paths {
                    let want = PathRng::with_bits(sampler, seed, bits, pixel, sample);
                    let mut got = packet.path(pixel, sample);
                    for depth in [0u32, 1, 7, 15, 16, 40] {
                        for dim in 0..10u32 {
                            assert_eq!(
                                got.get(depth, dim).to_bits(),
                                want.get(depth, dim).to_bits(),
                                "{sampler} bits {bits} lanes {lanes} pixel {pixel} sample {sample} depth {depth} dim {dim}"
                            );
                            if dim & 1 == 0 {
                                assert_eq!(got.get2(depth, dim), want.get2(depth, dim));
                            }
                        }
                    }
                }
            }
        }
    }
}
