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
//! `brdfwave merge` reads them back (`src/film.rs` [`write_part`], [`read_part`], [`merge`]).
//! The format, all integers little-endian:
//! * 8 bytes `BWFILM\0\n`, then a `u32` format version (2) and a `u32` header length `n`;
//! * `n` bytes of JSON, the [`PartHeader`]: scene and code identity, image size, tile, sample
//!   range, the blocks in order, the render's counts, and a checksum (FNV-1a 64) of each
//!   block's data, checked on reading;
//! * zero bytes up to a multiple of 8 from the file start;
//! * for each block in order, for each pixel of the tile in rows from the top, six `f64`: the
//!   sums of r, g, b and of r², g², b².

use crate::imageio::Image;
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::ops::Range;
use std::path::{Path, PathBuf};

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
    /// joins siblings. Panics on a gap or overlap: callers check ranges first ([`merge`] does).
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

// ---------------------------------------------------------------------------------------------
// Partial-film files.

const MAGIC: &[u8; 8] = b"BWFILM\0\n";
/// Version 2 added `block_checksums`.
const VERSION: u32 = 2;

/// The JSON header of a partial film (see the module documentation).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PartHeader {
    /// The scene file as given on the command line (for messages only).
    pub scene: String,
    /// [`scene_hash`] of the scene as rendered (command-line overrides applied).
    pub scene_hash: String,
    /// [`code_version`] of the program that rendered it.
    pub code_version: String,
    /// `cpu` or `gpu`, and the device.
    pub backend: String,
    pub device: String,
    /// The whole image.
    pub width: u32,
    pub height: u32,
    pub tile: Tile,
    pub samples: [u32; 2],
    /// The sample range of each data block, in order.
    pub blocks: Vec<[u32; 2]>,
    pub extension_rays: u64,
    pub shadow_rays: u64,
    /// Non-finite values dropped, by stage (as in a render's summary).
    pub nonfinite_by_stage: Vec<(String, u64)>,
    pub seconds_render: f64,
    /// FNV-1a 64 of each data block's bytes, in hex (set by [`write_part`], checked on reading):
    /// a flipped bit in the body changed a pixel silently.
    #[serde(default)]
    pub block_checksums: Vec<String>,
}

/// The program's version for partial films: parts from different versions are not merged. The
/// package version and, when built from a git checkout, the commit (uncommitted changes are not
/// seen).
pub fn code_version() -> String {
    let commit = env!("BRDFWAVE_COMMIT");
    if commit.is_empty() {
        env!("CARGO_PKG_VERSION").to_string()
    } else {
        format!("{}+{}", env!("CARGO_PKG_VERSION"), commit)
    }
}

/// A hash of everything in the scene that the image depends on: camera, image size, integrator
/// settings but the sample count, materials, emitters, geometry and environment; not the file's
/// path or names, so the same scene loaded on two machines hashes the same.
pub fn scene_hash(s: &crate::scene::Scene) -> String {
    use std::fmt::Write as _;
    let mut h = crate::hash::Fnv64::new();
    let it = &s.integrator;
    let _ = write!(
        h,
        "{:?}|{}x{}|{} {} {} {} {}|{:?}|{:?}|{:?}|{:?}|{:?}",
        s.camera,
        s.width,
        s.height,
        it.max_depth,
        it.seed,
        it.russian_roulette,
        it.rr_start_depth,
        it.sampler,
        s.materials,
        s.emitters,
        s.triangles,
        s.spheres,
        s.environment
    );
    format!("{:016x}", h.finish())
}

/// A partial film read from or written to a file.
pub struct Part {
    pub header: PartHeader,
    pub film: Film,
}

impl Part {
    /// The partial film of a render of `scene` (loaded from `scene_file`) whose film is `film`
    /// and whose counts are in `out`.
    pub fn of_render(
        scene_file: &str,
        scene: &crate::scene::Scene,
        film: Film,
        out: &crate::output::RenderOutput,
        backend: &str,
        device: &str,
        seconds_render: f64,
    ) -> Part {
        let samples = film.samples();
        Part {
            header: PartHeader {
                scene: scene_file.to_string(),
                scene_hash: scene_hash(scene),
                code_version: code_version(),
                backend: backend.to_string(),
                device: device.to_string(),
                width: scene.width,
                height: scene.height,
                tile: film.tile,
                samples: [samples.start, samples.end],
                blocks: film
                    .blocks
                    .iter()
                    .map(|b| [b.samples.start, b.samples.end])
                    .collect(),
                extension_rays: out.extension_rays,
                shadow_rays: out.shadow_rays,
                nonfinite_by_stage: out.nonfinite_by_stage.clone(),
                seconds_render,
                block_checksums: Vec::new(),
            },
            film,
        }
    }
}

/// Writes `part` to `path` atomically.
pub fn write_part(path: &Path, part: &Part) -> Result<()> {
    let block_bytes: Vec<Vec<u8>> = part
        .film
        .blocks
        .iter()
        .map(|b| {
            b.sums
                .iter()
                .flatten()
                .flat_map(|v| v.to_le_bytes())
                .collect()
        })
        .collect();
    let mut header = part.header.clone();
    header.block_checksums = block_bytes.iter().map(|b| checksum(b)).collect();
    let json = serde_json::to_vec(&header)?;
    let mut bytes = Vec::with_capacity(
        16 + json.len() + 8 + part.film.blocks.len() * part.film.tile.pixels() * 48,
    );
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&VERSION.to_le_bytes());
    bytes.extend_from_slice(&(json.len() as u32).to_le_bytes());
    bytes.extend_from_slice(&json);
    while bytes.len() % 8 != 0 {
        bytes.push(0);
    }
    for b in &block_bytes {
        bytes.extend_from_slice(b);
    }
    crate::outfile::write(path, &bytes)?;
    Ok(())
}

/// The checksum of a data block's bytes in a partial film.
fn checksum(bytes: &[u8]) -> String {
    format!("{:016x}", crate::hash::Fnv64::new().bytes(bytes).finish())
}

/// Reads a partial film, checking that it is one and that its parts agree with each other.
pub fn read_part(path: &Path) -> Result<Part> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    parse_part(&bytes).with_context(|| format!("{}", path.display()))
}

/// Reads only the header of a partial film (checked as [`read_part`] checks it, the length of
/// the data included), not its sums.
pub fn read_header(path: &Path) -> Result<PartHeader> {
    use std::io::Read as _;
    let at = || format!("{}", path.display());
    let mut f = std::fs::File::open(path).with_context(|| format!("{}: cannot read", at()))?;
    let len = f
        .metadata()
        .with_context(|| format!("{}: cannot read", at()))?
        .len();
    let mut head = vec![0u8; 16.min(len as usize)];
    f.read_exact(&mut head).with_context(at)?;
    if head.len() == 16 && &head[..8] == MAGIC {
        let n = u32::from_le_bytes(head[12..16].try_into().expect("4 bytes")) as u64;
        let mut rest = vec![0u8; n.min(len.saturating_sub(16)) as usize];
        f.read_exact(&mut rest).with_context(at)?;
        head.extend(rest);
    }
    Ok(parse_header(&head, len).with_context(at)?.0)
}

/// The header of a partial film from the file's first bytes (at least up to the end of the
/// header) and its length; and where the data starts.
fn parse_header(bytes: &[u8], file_len: u64) -> Result<(PartHeader, usize)> {
    if bytes.len() < 16 || &bytes[..8] != MAGIC {
        bail!("not a brdfwave partial film (it does not start with the BWFILM mark)");
    }
    let word = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
    let version = word(8);
    if version != VERSION {
        bail!("partial-film format version {version}; this program reads version {VERSION}");
    }
    let n = word(12) as usize;
    let json = bytes
        .get(16..16 + n)
        .context("the file ends inside its header")?;
    let header: PartHeader =
        serde_json::from_slice(json).context("the header is not a valid partial-film header")?;
    let h = &header;
    // Header text is printed to the terminal (merge's summary and messages): no control
    // characters, which could move the cursor or recolour it.
    for (field, text) in [
        ("scene", &h.scene),
        ("scene_hash", &h.scene_hash),
        ("code_version", &h.code_version),
        ("backend", &h.backend),
        ("device", &h.device),
    ] {
        if text.chars().any(|c| c.is_control()) {
            bail!("header field '{field}': {text:?} holds control characters");
        }
    }
    let max = crate::scene::load::MAX_FILM_SIZE;
    if h.width == 0 || h.height == 0 || h.width > max || h.height > max {
        bail!(
            "header fields 'width' and 'height': {}x{} is not an image size (1 to {max} per side)",
            h.width,
            h.height
        );
    }
    h.tile
        .check_within(h.width, h.height)
        .map_err(anyhow::Error::msg)
        .context("header field 'tile'")?;
    let [s0, s1] = h.samples;
    if s0 >= s1 {
        bail!("header field 'samples': {s0}..{s1} holds no samples");
    }
    let mut next = s0;
    for (i, b) in h.blocks.iter().enumerate() {
        if b[0] != next || b[1] <= b[0] {
            bail!(
                "header field 'blocks': block {i} is {}..{}, but should start at {next} and be non-empty",
                b[0],
                b[1]
            );
        }
        next = b[1];
    }
    if next != s1 {
        bail!(
            "header field 'blocks': the blocks end at {next}, not at the end of 'samples' ({s1})"
        );
    }
    if h.block_checksums.len() != h.blocks.len() {
        bail!(
            "header field 'block_checksums': {} checksum(s) for {} block(s)",
            h.block_checksums.len(),
            h.blocks.len()
        );
    }
    let start = (16 + n).div_ceil(8) * 8;
    let expected = h.blocks.len() as u64 * h.tile.pixels() as u64 * 48;
    let found = file_len.saturating_sub(start as u64);
    if found != expected {
        bail!(
            "the data holds {found} bytes, but {} block(s) of a {}x{} tile need {expected}",
            h.blocks.len(),
            h.tile.width,
            h.tile.height
        );
    }
    Ok((header, start))
}

fn parse_part(bytes: &[u8]) -> Result<Part> {
    let (header, start) = parse_header(bytes, bytes.len() as u64)?;
    let h = &header;
    let pixels = h.tile.pixels();
    let mut values = bytes[start..]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")));
    let mut blocks = Vec::with_capacity(h.blocks.len());
    for (i, b) in h.blocks.iter().enumerate() {
        // n samples of finite f32 radiance add up to at most n·f32::MAX, their squares to
        // n·f32::MAX²: a larger sum (1e300 passed as "finite") made an infinite pixel.
        let n = (b[1] - b[0]) as f64;
        let max = f32::MAX as f64;
        let bounds = [n * max, n * max * max];
        let mut sums = Vec::with_capacity(pixels);
        for p in 0..pixels {
            let s: Sums = std::array::from_fn(|_| values.next().expect("length checked"));
            if !s.iter().all(|v| v.is_finite() && *v >= 0.0) {
                bail!(
                    "block {i}, pixel {p} of the tile: sums {s:?} are not finite and non-negative"
                );
            }
            if (0..6).any(|c| s[c] > bounds[c / 3]) {
                bail!(
                    "block {i}, pixel {p} of the tile: sums {s:?} are larger than {} samples of finite radiance can add up to",
                    b[1] - b[0]
                );
            }
            sums.push(s);
        }
        let from = start + i * pixels * 48;
        if checksum(&bytes[from..from + pixels * 48]) != h.block_checksums[i] {
            bail!("block {i}: its data does not match its checksum: the file is damaged");
        }
        blocks.push(Block {
            samples: b[0]..b[1],
            sums,
        });
    }
    Ok(Part {
        film: Film {
            tile: header.tile,
            blocks,
        },
        header,
    })
}

/// The image merged from partial films, and what the parts rendered together.
pub struct Merged {
    pub mean: Image,
    pub variance: Image,
    pub samples: Range<u32>,
    pub tiles: usize,
    pub extension_rays: u64,
    pub shadow_rays: u64,
    pub nonfinite_by_stage: Vec<(String, u64)>,
    /// Render seconds of all parts added (CPU time of the whole job, not its wall time).
    pub seconds_render: f64,
    pub scene: String,
    pub backends: Vec<String>,
}

/// Merges the partial films `paths`: they must come from the same scene and code, and every
/// pixel must lie in parts that cover the same sample range, each sample once (tiles may differ
/// between sample ranges: e.g. samples 0..64 of the whole image and 64..128 in two halves).
///
/// The headers are read and checked first; then the parts' sums are read one part at a time,
/// in sample order, and joined into the films of the cells the tiles cut the image into, so
/// memory holds one part and a few blocks per cell (parts of aligned power-of-two ranges join
/// as they arrive), not every part.
pub fn merge(paths: &[PathBuf]) -> Result<Merged> {
    if paths.is_empty() {
        bail!("no partial films to merge");
    }
    let headers = paths
        .iter()
        .map(|p| read_header(p))
        .collect::<Result<Vec<_>>>()?;
    let name = |i: usize| paths[i].display().to_string();
    let first = &headers[0];
    for (i, h) in headers.iter().enumerate().skip(1) {
        let differs = |what: &str, a: &dyn std::fmt::Display, b: &dyn std::fmt::Display| {
            anyhow::anyhow!(
                "{} and {} come from different {what} ({a} and {b}): parts of different renders cannot be merged",
                name(0),
                name(i)
            )
        };
        if h.scene_hash != first.scene_hash {
            return Err(differs(
                "scenes or settings",
                &format!("{} #{}", first.scene, first.scene_hash),
                &format!("{} #{}", h.scene, h.scene_hash),
            ));
        }
        if h.code_version != first.code_version {
            return Err(differs(
                "program versions",
                &first.code_version,
                &h.code_version,
            ));
        }
        if (h.width, h.height) != (first.width, first.height) {
            return Err(differs(
                "image sizes",
                &format!("{}x{}", first.width, first.height),
                &format!("{}x{}", h.width, h.height),
            ));
        }
    }
    let (width, height) = (first.width, first.height);
    let samples_of = |i: usize| headers[i].samples[0]..headers[i].samples[1];

    // The grid the tiles' edges cut the image into: each cell lies in the same parts' tiles
    // throughout, which must cover the same samples, each sample once.
    let cuts = |edges: &mut dyn Iterator<Item = u32>, size: u32| {
        let mut v: Vec<u32> = edges.chain([0, size]).collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let xs = cuts(
        &mut headers
            .iter()
            .flat_map(|h| [h.tile.x, h.tile.x + h.tile.width]),
        width,
    );
    let ys = cuts(
        &mut headers
            .iter()
            .flat_map(|h| [h.tile.y, h.tile.y + h.tile.height]),
        height,
    );
    let mut cells: Vec<(Film, Vec<usize>)> = Vec::new();
    let mut range: Option<(Range<u32>, Tile)> = None;
    for y in ys.windows(2) {
        for x in xs.windows(2) {
            let cell = Tile {
                x: x[0],
                y: y[0],
                width: x[1] - x[0],
                height: y[1] - y[0],
            };
            let mut members: Vec<usize> = (0..headers.len())
                .filter(|&i| headers[i].tile.contains(cell.x, cell.y))
                .collect();
            if members.is_empty() {
                bail!(
                    "pixel ({}, {}) of the {width}x{height} image is in no part's tile: a part is missing",
                    cell.x,
                    cell.y
                );
            }
            members.sort_by_key(|&i| (samples_of(i).start, samples_of(i).end));
            let at = format!("pixel ({}, {})", cell.x, cell.y);
            for w in members.windows(2) {
                let (a, b) = (samples_of(w[0]), samples_of(w[1]));
                if b.start > a.end {
                    bail!(
                        "samples {}..{} of {at} are in no part (between {} with {}..{} and {} with {}..{}): a part is missing",
                        a.end, b.start, name(w[0]), a.start, a.end, name(w[1]), b.start, b.end
                    );
                }
                if b.start < a.end {
                    bail!(
                        "samples {}..{} of {at} are in two parts, {} ({}..{}) and {} ({}..{}): each sample must be in one",
                        b.start, a.end.min(b.end), name(w[0]), a.start, a.end, name(w[1]), b.start, b.end
                    );
                }
            }
            let r =
                samples_of(members[0]).start..samples_of(*members.last().expect("not empty")).end;
            match &range {
                None => range = Some((r.clone(), cell)),
                Some((r0, c0)) if *r0 != r => bail!(
                    "pixel ({}, {}) has samples {}..{} but pixel ({}, {}) has {}..{}: every pixel needs the same samples",
                    c0.x, c0.y, r0.start, r0.end, cell.x, cell.y, r.start, r.end
                ),
                _ => {}
            }
            cells.push((Film::new(cell), members));
        }
    }

    // The sums, one part at a time in sample order: each cell gets its parts' blocks, cut to
    // the cell, in order.
    let mut order: Vec<usize> = (0..headers.len()).collect();
    order.sort_by_key(|&i| (samples_of(i).start, samples_of(i).end));
    for i in order {
        let part = read_part(&paths[i])?;
        if part.header != headers[i] {
            bail!("{} changed while it was being merged", name(i));
        }
        let t = part.film.tile;
        for (film, _) in cells.iter_mut().filter(|(_, m)| m.contains(&i)) {
            let cell = film.tile;
            let blocks = part
                .film
                .blocks
                .iter()
                .map(|b| Block {
                    samples: b.samples.clone(),
                    sums: (cell.y..cell.y + cell.height)
                        .flat_map(|py| {
                            let row = ((py - t.y) * t.width + (cell.x - t.x)) as usize;
                            b.sums[row..row + cell.width as usize].iter().copied()
                        })
                        .collect(),
                })
                .collect();
            film.add_blocks(blocks);
        }
    }
    let mut mean = Image::new(width, height);
    let mut variance = Image::new(width, height);
    for (film, _) in &cells {
        let cell = film.tile;
        let (m, v) = film.images();
        for py in 0..cell.height {
            for px in 0..cell.width {
                let src = (py * cell.width + px) as usize;
                mean.set(cell.x + px, cell.y + py, m.data[src]);
                variance.set(cell.x + px, cell.y + py, v.data[src]);
            }
        }
    }
    let tiles = {
        let mut t: Vec<Tile> = headers.iter().map(|h| h.tile).collect();
        t.sort_by_key(|t| (t.y, t.x, t.height, t.width));
        t.dedup();
        t.len()
    };
    let mut nonfinite_by_stage: Vec<(String, u64)> = Vec::new();
    let mut backends: Vec<String> = Vec::new();
    let overflow = |what: &str| anyhow::anyhow!("the parts' {what} add up to more than 2^64");
    for h in &headers {
        for (stage, n) in &h.nonfinite_by_stage {
            match nonfinite_by_stage.iter_mut().find(|(s, _)| s == stage) {
                Some((_, t)) => {
                    *t = t
                        .checked_add(*n)
                        .ok_or_else(|| overflow("non-finite counts"))?
                }
                None => nonfinite_by_stage.push((stage.clone(), *n)),
            }
        }
        let b = format!("{} on {}", h.backend, h.device);
        if !backends.contains(&b) {
            backends.push(b);
        }
    }
    Ok(Merged {
        mean,
        variance,
        samples: range.expect("at least one cell").0,
        tiles,
        extension_rays: headers
            .iter()
            .try_fold(0u64, |t, h| t.checked_add(h.extension_rays))
            .ok_or_else(|| overflow("extension-ray counts"))?,
        shadow_rays: headers
            .iter()
            .try_fold(0u64, |t, h| t.checked_add(h.shadow_rays))
            .ok_or_else(|| overflow("shadow-ray counts"))?,
        nonfinite_by_stage,
        seconds_render: headers.iter().map(|h| h.seconds_render).sum(),
        scene: first.scene.clone(),
        backends,
    })
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

    #[test]
    fn a_part_survives_the_file_format_and_damage_is_refused() {
        let header = PartHeader {
            scene: "s.toml".into(),
            scene_hash: "00".into(),
            code_version: code_version(),
            backend: "cpu".into(),
            device: "test".into(),
            width: 4,
            height: 3,
            tile: Tile {
                x: 1,
                y: 1,
                width: 2,
                height: 2,
            },
            samples: [2, 5],
            blocks: vec![[2, 4], [4, 5]],
            extension_rays: 7,
            shadow_rays: 3,
            nonfinite_by_stage: vec![("extend".into(), 0)],
            seconds_render: 0.5,
            block_checksums: Vec::new(),
        };
        let film = Film {
            tile: header.tile,
            blocks: vec![
                Block {
                    samples: 2..4,
                    sums: (0..4).map(|i| [i as f64 + 0.1; 6]).collect(),
                },
                Block {
                    samples: 4..5,
                    sums: (0..4).map(|i| [i as f64 * 1e38; 6]).collect(),
                },
            ],
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.bwfilm");
        write_part(
            &path,
            &Part {
                header,
                film: film.clone(),
            },
        )
        .unwrap();
        let back = read_part(&path).unwrap();
        assert_eq!(back.film, film);
        assert_eq!(back.header.block_checksums.len(), 2);
        let bytes = std::fs::read(&path).unwrap();
        let err = |b: &[u8]| format!("{:#}", parse_part(b).err().expect("refused"));
        assert!(err(&bytes[..bytes.len() - 8]).contains("data holds"));
        assert!(err(&bytes[..20]).contains("header"));
        assert!(err(b"P6\n4 4\n255\n........").contains("not a brdfwave partial film"));
        let mut bad = bytes.clone();
        let last = bad.len() - 8;
        bad[last..].copy_from_slice(&f64::NAN.to_le_bytes());
        assert!(err(&bad).contains("not finite"));
        // A sum no finite f32 samples can make (one sample: at most f32::MAX).
        bad[last..].copy_from_slice(&1e300f64.to_le_bytes());
        assert!(err(&bad).contains("larger than 1 samples"), "{}", err(&bad));
        // One flipped bit of a plausible value: only the checksum sees it.
        let mut flipped = bytes.clone();
        flipped[last] ^= 1;
        assert!(err(&flipped).contains("checksum"), "{}", err(&flipped));
    }
}
