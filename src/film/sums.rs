//! The sums: per-pixel sums of samples in aligned dyadic blocks, and the film that holds and
//! joins them (the module documentation of [`crate::film`] says why the grouping is fixed).

use super::Tile;
use crate::imageio::Image;
use std::ops::Range;

/// Six per-pixel sums: radiance r, g, b, then r², g², b².
pub type Sums = [f64; 6];

/// The sums of one sample of radiance `l` (finite).
pub fn sample_sums(l: [f32; 3]) -> Sums {
    let [r, g, b] = l.map(|c| c as f64);
    // f32 × f32 is exact in f64 (48 significant bits, exponents far within range).
    [r, g, b, r * r, g * g, b * b]
}

fn add(a: &Sums, b: &Sums) -> Sums {
    std::array::from_fn(|i| a[i] + b[i])
}

/// The fewest aligned dyadic blocks `[i·2^k, (i+1)·2^k)` that make up `range`, in order.
pub fn dyadic_blocks(range: Range<u32>) -> Vec<Range<u32>> {
    let (mut a, b) = (range.start as u64, range.end as u64);
    let mut out = Vec::new();
    while a < b {
        // The largest power of two dividing a (any, for a = 0), not overshooting b.
        let align = if a == 0 {
            1u64 << 32
        } else {
            1u64 << a.trailing_zeros()
        };
        let mut len = align;
        while a + len > b {
            len /= 2;
        }
        out.push(a as u32..(a + len) as u32);
        a += len;
    }
    out
}

/// Whether `r` is an aligned dyadic block that is the left half of its parent, and `s` the
/// right half.
fn siblings(r: &Range<u32>, s: &Range<u32>) -> bool {
    let len = r.end - r.start;
    len.is_power_of_two()
        && r.start % len == 0
        && (r.start / len) % 2 == 0
        && s.start == r.end
        && s.end - s.start == len
}

/// Sums one aligned dyadic block's samples, given in order, as the halves-first tree of
/// [`dyadic_blocks`]: a binary counter of partial sums, at most 33 deep.
pub struct PairwiseSum {
    stack: [(Sums, u64); 34],
    depth: usize,
}

impl Default for PairwiseSum {
    fn default() -> Self {
        PairwiseSum {
            stack: [([0.0; 6], 0); 34],
            depth: 0,
        }
    }
}

impl PairwiseSum {
    pub fn push(&mut self, v: Sums) {
        let (mut v, mut n) = (v, 1u64);
        while self.depth > 0 && self.stack[self.depth - 1].1 == n {
            self.depth -= 1;
            v = add(&self.stack[self.depth].0, &v);
            n *= 2;
        }
        self.stack[self.depth] = (v, n);
        self.depth += 1;
    }

    /// The block's sum: exactly one partial sum is left after a whole dyadic block.
    pub fn total(&self) -> Sums {
        debug_assert_eq!(self.depth, 1, "a PairwiseSum takes whole dyadic blocks");
        self.stack[0].0
    }
}

/// The per-pixel sums (over the tile's pixels, in rows) of one range of samples.
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    pub samples: Range<u32>,
    pub sums: Vec<Sums>,
}

/// Whether samples `asked` may be added to a film that holds samples `held` (empty when it
/// holds none): they must continue it, so that the sums stay those of one render; any start is
/// allowed while it is empty. Both renderers ask before they render.
pub fn check_continues(held: &Range<u32>, asked: &Range<u32>) -> anyhow::Result<()> {
    if !held.is_empty() && asked.start != held.end {
        anyhow::bail!(
            "samples from {} asked for, but the film holds samples {}..{}",
            asked.start,
            held.start,
            held.end
        );
    }
    Ok(())
}

/// Per-pixel sums of the samples `blocks` cover, for the pixels of `tile`.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub tile: Tile,
    /// In sample order, contiguous, siblings joined.
    pub blocks: Vec<Block>,
}

impl Film {
    pub fn new(tile: Tile) -> Film {
        Film {
            tile,
            blocks: Vec::new(),
        }
    }

    /// The samples the film holds (empty at `0..0` when it holds none).
    pub fn samples(&self) -> Range<u32> {
        match (self.blocks.first(), self.blocks.last()) {
            (Some(a), Some(b)) => a.samples.start..b.samples.end,
            _ => 0..0,
        }
    }

    /// Samples per pixel held.
    pub fn spp(&self) -> u32 {
        let r = self.samples();
        r.end - r.start
    }

    /// Adds blocks that continue the film's samples (any start when it is empty) in order, and
    /// joins siblings. Panics on a gap or overlap: callers check ranges first ([`merge`](super::merge) does).
    pub fn add_blocks(&mut self, blocks: Vec<Block>) {
        for b in blocks {
            assert!(
                self.blocks.is_empty() || b.samples.start == self.samples().end,
                "samples {:?} do not continue {:?}",
                b.samples,
                self.samples()
            );
            assert_eq!(
                b.sums.len(),
                self.tile.pixels(),
                "block of another tile size"
            );
            self.blocks.push(b);
            // Only the newest block can have gained a sibling; joining may cascade leftwards.
            while let [.., l, r] = &self.blocks[..] {
                if !siblings(&l.samples, &r.samples) {
                    break;
                }
                let r = self.blocks.pop().expect("two blocks");
                let l = self.blocks.last_mut().expect("two blocks");
                for (a, b) in l.sums.iter_mut().zip(&r.sums) {
                    *a = add(a, b);
                }
                l.samples.end = r.samples.end;
            }
        }
    }

    /// Each pixel's sums over all the film's samples: the blocks added from left to right.
    pub fn totals(&self) -> Vec<Sums> {
        let mut blocks = self.blocks.iter();
        let Some(first) = blocks.next() else {
            return vec![[0.0; 6]; self.tile.pixels()];
        };
        let mut t = first.sums.clone();
        for b in blocks {
            for (a, s) in t.iter_mut().zip(&b.sums) {
                *a = add(a, s);
            }
        }
        t
    }

    /// The tile's mean image and one-sample variance image.
    pub fn images(&self) -> (Image, Image) {
        let (w, h) = (self.tile.width, self.tile.height);
        let mut mean = Image::new(w, h);
        let mut variance = Image::new(w, h);
        let n = self.spp();
        for (i, s) in self.totals().iter().enumerate() {
            let (m, v) = mean_and_variance([s[0], s[1], s[2]], [s[3], s[4], s[5]], n);
            mean.data[i] = m;
            variance.data[i] = v;
        }
        (mean, variance)
    }
}

/// Mean and unbiased one-sample variance of `n` samples from their sums in f64. The mean of
/// finite f32 samples is a finite f32; the variance of samples beyond about 1.8e19 is not, and
/// is clamped to `f32::MAX` (the images are f32). Negative variances from rounding become 0.
pub fn mean_and_variance(sum: [f64; 3], sum2: [f64; 3], n: u32) -> ([f32; 3], [f32; 3]) {
    let n = n.max(1) as f64;
    let mut m = [0f32; 3];
    let mut v = [0f32; 3];
    for c in 0..3 {
        let mean = sum[c] / n;
        m[c] = mean as f32;
        v[c] = if n > 1.0 {
            ((sum2[c] - n * mean * mean) / (n - 1.0)).clamp(0.0, f32::MAX as f64) as f32
        } else {
            0.0
        };
    }
    (m, v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dyadic_blocks_are_aligned_and_cover_the_range() {
        assert_eq!(dyadic_blocks(0..8), vec![0..8]);
        assert_eq!(dyadic_blocks(0..7), vec![0..4, 4..6, 6..7]);
        assert_eq!(dyadic_blocks(3..9), vec![3..4, 4..8, 8..9]);
        assert_eq!(dyadic_blocks(5..6), vec![5..6]);
        assert_eq!(dyadic_blocks(0..u32::MAX), {
            let mut v = Vec::new();
            let mut a = 0u64;
            for k in (0..32).rev() {
                v.push(a as u32..(a + (1 << k)) as u32);
                a += 1 << k;
            }
            v
        });
        for a in 0..40u32 {
            for b in a + 1..80 {
                let v = dyadic_blocks(a..b);
                assert_eq!(v[0].start, a);
                assert_eq!(v.last().unwrap().end, b);
                for w in v.windows(2) {
                    assert_eq!(w[0].end, w[1].start);
                }
                for r in &v {
                    let len = r.end - r.start;
                    assert!(len.is_power_of_two() && r.start % len == 0, "{r:?}");
                }
            }
        }
    }

    /// Films of any split of 0..n, joined, hold the blocks and totals of one film of 0..n, bit
    /// for bit; values spread over many magnitudes make any other grouping differ.
    #[test]
    fn any_split_joins_to_the_same_sums() {
        let value = |s: u32| -> Sums {
            let x = (1.0 + (s as f64 * 0.618).fract()) * 10f64.powi((s % 7) as i32 * 3 - 9);
            [x, x * 0.5, x * 3.0, x * x, x * x * 0.25, x * x * 9.0]
        };
        let block = |r: Range<u32>| -> Block {
            let mut p = PairwiseSum::default();
            for s in r.clone() {
                p.push(value(s));
            }
            Block {
                samples: r,
                sums: vec![p.total()],
            }
        };
        let film_of = |ranges: &[Range<u32>]| {
            let mut f = Film::new(Tile::full(1, 1));
            for r in ranges {
                f.add_blocks(dyadic_blocks(r.clone()).into_iter().map(block).collect());
            }
            f
        };
        let n = 23;
        let whole = film_of(&dyadic_blocks(0..n));
        let in_order = (0..n).fold([0.0; 6], |a, s| add(&a, &value(s)));
        let mut seen_difference = false;
        for cut1 in 1..n {
            for cut2 in cut1..n {
                let ranges: Vec<_> = [0..cut1, cut1..cut2, cut2..n]
                    .into_iter()
                    .filter(|r| !r.is_empty())
                    .collect();
                let f = film_of(&ranges);
                assert_eq!(f.blocks, whole.blocks, "split at {cut1}, {cut2}");
                assert_eq!(f.totals(), whole.totals());
                // The naive grouping, for contrast: sums of the parts, added.
                let naive = ranges.iter().fold([0.0; 6], |a, r| {
                    add(&a, &r.clone().fold([0.0; 6], |b, s| add(&b, &value(s))))
                });
                seen_difference |= naive != in_order;
            }
        }
        assert!(
            seen_difference,
            "the test values must be sensitive to grouping"
        );
    }
}
