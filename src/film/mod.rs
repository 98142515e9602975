//! The film: per-pixel sums of a render's samples, kept so that a render split by sample range
//! and by tile, on several machines, merges into exactly the image of one render.
//!
//! ## Exact merging
//! Floating-point addition is not associative: the sum of samples 0..N plus the sum of N..M
//! differs in its last bits from the sum of 0..M added one by one. So the grouping of the
//! additions is fixed by the sample indices alone, never by how a range was split:
//! * the samples of a pixel are summed in aligned dyadic blocks `[i·2^k, (i+1)·2^k)`; a block
//!   of one sample is that sample, a longer block is the sum of its two halves (pairwise
//!   summation, which also loses less than adding in order);
//! * a range `[a, b)` is held as the fewest such blocks: from `a`, the largest aligned block
//!   that starts there and fits ([`dyadic_blocks`]);
//! * blocks from parts are joined with their sibling (the other half of their parent) until no
//!   two siblings are left ([`Film::add_blocks`]), which gives the same blocks as one render of
//!   the whole range; the total is those blocks added from left to right ([`Film::totals`]).
//!
//! The CPU reference fills its blocks this way, so CPU parts merge into its single-run image bit
//! for bit, in any split. The GPU film holds one f32 sum per pixel for the range it rendered
//! (scaled against overflow, `shaders/wavefront/accumulate.comp`), which becomes one block:
//! GPU parts, and parts from both backends, merge within rounding.
//!
//! Each block keeps six f64 sums per pixel: radiance (r, g, b) and radiance squared, from which
//! [`mean_and_variance`] gives the image and the one-sample variance. A non-finite sample counts
//! as a sample of value 0 (and is counted by the stage that made it).
//!
//! ## Partial-film files (`.bwfilm`)
//! `brdfwave render --samples A..B --tile X,Y,W,H --out part.bwfilm` writes a film to a file and
//! `brdfwave merge` reads them back ([`write_part`], [`read_part`] in `part.rs`, [`merge`] in
//! `merge.rs`).
//! The format, all integers little-endian:
//! * 8 bytes `BWFILM\0\n`, then a `u32` format version (3) and a `u32` header length `n`;
//! * `n` bytes of JSON, the [`PartHeader`]: scene and code identity, image size, tile, sample
//!   range, the whole render's samples per pixel (`spp`: [`merge`] needs a set of parts to hold
//!   all of 0..spp, unless it is given another range), the blocks in order, the render's counts, and a checksum (FNV-1a 64) of each
//!   block's data, checked on reading;
//! * zero bytes up to a multiple of 8 from the file start;
//! * for each block in order, for each pixel of the tile in rows from the top, six `f64`: the
//!   sums of r, g, b and of r², g², b².
//!
//! ## Files
//! `sums.rs` the sums and the film, `part.rs` the `.bwfilm` format, `merge.rs` the merge; this
//! file the tile and sample range a render covers.

mod merge;
mod part;
mod sums;

pub use merge::{merge, merge_samples, Merged};
pub use part::{code_version, read_header, read_part, scene_hash, write_part, Part, PartHeader};
pub use sums::{
    check_continues, dyadic_blocks, mean_and_variance, sample_sums, Block, Film, PairwiseSum, Sums,
};

use serde::{Deserialize, Serialize};
use std::ops::Range;

/// A rectangle of the image, in pixels: columns `x .. x + width`, rows `y .. y + height`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Tile {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
}

impl Tile {
    /// The whole of a `width` × `height` image.
    pub fn full(width: u32, height: u32) -> Tile {
        Tile {
            x: 0,
            y: 0,
            width,
            height,
        }
    }

    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Whether the tile is a non-empty part of a `width` × `height` image; else why not.
    pub fn check_within(&self, width: u32, height: u32) -> std::result::Result<(), String> {
        if self.width == 0 || self.height == 0 {
            return Err(format!("tile {self} is empty"));
        }
        if self.x as u64 + self.width as u64 > width as u64
            || self.y as u64 + self.height as u64 > height as u64
        {
            return Err(format!(
                "tile {self} reaches outside the {width}x{height} image"
            ));
        }
        Ok(())
    }

    fn contains(&self, x: u32, y: u32) -> bool {
        (self.x..self.x + self.width).contains(&x) && (self.y..self.y + self.height).contains(&y)
    }

    /// Parses `X,Y,W,H`.
    pub fn parse(s: &str) -> std::result::Result<Tile, String> {
        let v: Vec<&str> = s.split(',').map(str::trim).collect();
        let [x, y, w, h] = v[..] else {
            return Err(format!("'{s}' is not X,Y,W,H (e.g. 0,0,512,512)"));
        };
        let num = |t: &str, what: &str| {
            t.parse::<u32>()
                .map_err(|_| format!("{what} '{t}' in '{s}' is not a whole number"))
        };
        Ok(Tile {
            x: num(x, "X")?,
            y: num(y, "Y")?,
            width: num(w, "W")?,
            height: num(h, "H")?,
        })
    }
}

impl std::fmt::Display for Tile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{},{},{},{}", self.x, self.y, self.width, self.height)
    }
}

/// Parses a sample range `START..END` (END exclusive, START < END).
pub fn parse_samples(s: &str) -> std::result::Result<Range<u32>, String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("'{s}' is not START..END (e.g. 0..64)"))?;
    let num = |t: &str, what: &str| {
        t.trim()
            .parse::<u32>()
            .map_err(|_| format!("{what} '{t}' in '{s}' is not a whole number up to 4294967295"))
    };
    let (a, b) = (num(a, "START")?, num(b, "END")?);
    if a >= b {
        return Err(format!(
            "'{s}' holds no samples: START must be less than END"
        ));
    }
    Ok(a..b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_samples_and_tiles() {
        assert_eq!(parse_samples("3..9"), Ok(3..9));
        assert!(parse_samples("9..9").unwrap_err().contains("no samples"));
        assert!(parse_samples("9-10").unwrap_err().contains("START..END"));
        assert!(parse_samples("0..x").unwrap_err().contains("END 'x'"));
        assert_eq!(
            Tile::parse("1, 2,3,4"),
            Ok(Tile {
                x: 1,
                y: 2,
                width: 3,
                height: 4
            })
        );
        assert!(Tile::parse("1,2,3").is_err());
        let t = Tile::parse("10,0,10,10").unwrap();
        assert!(t.check_within(20, 10).is_ok());
        assert!(t.check_within(19, 10).unwrap_err().contains("outside"));
        assert!(Tile::parse("0,0,0,1").unwrap().check_within(5, 5).is_err());
    }
}
