//! Image files: an in-memory linear-RGB [`Image`] and atomic reading/writing of OpenEXR, PNG and
//! PFM files.
//!
//! * `.exr` — linear RGB, 32-bit float per channel, lossless ZIP compression (crate `exr`).
//!   Round trips are bit-exact, including negative, infinite and NaN values.
//! * `.png` — 8-bit sRGB: linear values are clamped to [0, 1] (NaN becomes 0), then encoded with
//!   the sRGB transfer curve (IEC 61966-2-1) and rounded to the nearest 8-bit code. Reading
//!   applies the inverse curve, so a PNG round trip is exact up to this 8-bit quantisation.
//!   Alpha is ignored on reading, grey images are replicated to RGB, 16-bit PNGs are read at full
//!   precision.
//! * `.pfm` — Portable Float Map, linear 32-bit float, little-endian, rows stored bottom to top
//!   as the format requires. Reading accepts both byte orders and grey (`Pf`) files; the
//!   magnitude of the scale field is ignored.
//!
//! The format is chosen by the file extension (case-insensitive). Every write is atomic
//! ([`crate::outfile::write_with`]): the encoded image goes to a temporary file in the
//! destination directory, which is then renamed over the destination, so an interrupted or
//! failed write never destroys an existing file (a new file gets `0666 & !umask`, a replaced
//! file keeps its permissions; a symbolic link at the destination is replaced, not followed).
//! Missing directories are not created here: writing into one is an error naming the path (the
//! command line creates them up front, see [`crate::outfile::prepare`]).
//!
//! Scene inputs (environment maps, textures) are read by `stored.rs` ([`read_stored`]): EXR,
//! Radiance HDR, PFM and PNG, their values as stored, with whether they are sRGB codes.
//!
//! Renderers that estimate per-pixel variance produce two plain [`Image`]s (mean and sample
//! variance), from the sums of their film (`crate::film::mean_and_variance`); in an EXR file
//! both go together with what produced them ([`write_layered`], [`read_layered`],
//! [`Provenance`]; the file layout is described in `openexr.rs`).

mod openexr;
mod stored;

pub use openexr::{
    BatchVariance, Extras, Layered, Provenance, MEAN_VARIANCE_LAYER, VARIANCE_LAYER,
};
pub use stored::{read_stored, write_hdr, Stored, STORED_EXTENSIONS};

use std::fmt;
use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

/// Errors of image construction, reading and writing. Each names the file involved.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    #[error("{}: unsupported image file extension (expected .exr, .png or .pfm)", crate::errors::shown_path(.path))]
    UnknownExtension { path: PathBuf },
    #[error("{}: cannot write, the directory {} does not exist", crate::errors::shown_path(.path), crate::errors::shown_path(.dir))]
    MissingDirectory { path: PathBuf, dir: PathBuf },
    #[error("{}: {what}: {source}", crate::errors::shown_path(.path))]
    Io {
        path: PathBuf,
        what: &'static str,
        #[source]
        source: std::io::Error,
    },
    #[error(
        "{}: OpenEXR error: {source} (brdfwave reads the first layer with R, G and B channels)",
        crate::errors::shown_path(.path)
    )]
    Exr {
        path: PathBuf,
        #[source]
        source: exr::error::Error,
    },
    /// Writing: the reading hint of [`ImageError::Exr`] does not apply.
    #[error("{}: cannot write the OpenEXR file: {source}", crate::errors::shown_path(.path))]
    ExrWrite {
        path: PathBuf,
        #[source]
        source: exr::error::Error,
    },
    #[error("{}: PNG error: {source}", crate::errors::shown_path(.path))]
    Png {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    #[error("{}: malformed PFM file: {reason}", crate::errors::shown_path(.path))]
    Pfm { path: PathBuf, reason: String },
    #[error("{}: invalid image: {reason}", crate::errors::shown_path(.path))]
    InvalidImage { path: PathBuf, reason: String },
    #[error("invalid image: {0}")]
    Invalid(String),
}

impl ImageError {
    /// The message without the "invalid image: " of [`ImageError::Invalid`], for an error
    /// that says it already.
    pub(super) fn reason(&self) -> String {
        match self {
            ImageError::Invalid(r) => r.clone(),
            other => other.to_string(),
        }
    }
}

/// A linear-RGB floating-point image. Pixels are stored row by row, row 0 at the top, so pixel
/// (x, y) is `data[y * width + x]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub data: Vec<[f32; 3]>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Image {
        Image::filled(width, height, [0.0; 3])
    }

    /// An image with every pixel set to `rgb`.
    pub fn filled(width: u32, height: u32, rgb: [f32; 3]) -> Image {
        Image {
            width,
            height,
            data: vec![rgb; width as usize * height as usize],
        }
    }

    /// An image whose pixel (x, y) is `f(x, y)`.
    pub fn from_fn(width: u32, height: u32, mut f: impl FnMut(u32, u32) -> [f32; 3]) -> Image {
        let mut data = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                data.push(f(x, y));
            }
        }
        Image {
            width,
            height,
            data,
        }
    }

    /// Wraps pixel data, checking that it holds exactly `width * height` pixels.
    pub fn from_data(width: u32, height: u32, data: Vec<[f32; 3]>) -> Result<Image, ImageError> {
        let img = Image {
            width,
            height,
            data,
        };
        img.validate()?;
        Ok(img)
    }

    /// Checks the invariants the public fields cannot enforce: a non-empty size and
    /// `data.len() == width * height`.
    pub fn validate(&self) -> Result<(), ImageError> {
        if self.width == 0 || self.height == 0 {
            return Err(ImageError::Invalid(format!(
                "size {}x{} is empty",
                self.width, self.height
            )));
        }
        let expected = self.width as u64 * self.height as u64;
        if self.data.len() as u64 != expected {
            return Err(ImageError::Invalid(format!(
                "{}x{} image holds {} pixels, expected {}",
                self.width,
                self.height,
                self.data.len(),
                expected
            )));
        }
        Ok(())
    }

    /// Number of pixels, `width * height`.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Index of pixel (x, y) in `data`.
    #[inline]
    pub fn index(&self, x: u32, y: u32) -> usize {
        debug_assert!(x < self.width && y < self.height);
        y as usize * self.width as usize + x as usize
    }

    /// Pixel (x, y). Panics when out of bounds, like slice indexing.
    #[inline]
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside {}x{}",
            self.width,
            self.height
        );
        self.data[self.index(x, y)]
    }

    /// Sets pixel (x, y). Panics when out of bounds, like slice indexing.
    #[inline]
    pub fn set(&mut self, x: u32, y: u32, rgb: [f32; 3]) {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside {}x{}",
            self.width,
            self.height
        );
        let i = self.index(x, y);
        self.data[i] = rgb;
    }

    /// (x, y) of the pixel at `data[index]`.
    #[inline]
    pub fn coords(&self, index: usize) -> (u32, u32) {
        let w = self.width.max(1) as usize;
        ((index % w) as u32, (index / w) as u32)
    }

    /// Whether both images have the same width and height.
    pub fn same_size(&self, other: &Image) -> bool {
        self.width == other.width && self.height == other.height
    }

    /// A new image with `f` applied to every pixel.
    pub fn map(&self, mut f: impl FnMut([f32; 3]) -> [f32; 3]) -> Image {
        Image {
            width: self.width,
            height: self.height,
            data: self.data.iter().map(|&p| f(p)).collect(),
        }
    }

    /// Decodes sRGB codes to linear values in place ([`srgb_to_linear`]; no copy of a large
    /// image).
    pub fn decode_srgb(&mut self) {
        for p in &mut self.data {
            *p = p.map(srgb_to_linear);
        }
    }

    /// Per-channel mean over all pixels, in f64. Non-finite values propagate (see
    /// [`Image::count_nonfinite`]); use [`Image::mean_finite`] to skip them.
    pub fn mean(&self) -> [f64; 3] {
        let mut s = [0.0f64; 3];
        for p in &self.data {
            for c in 0..3 {
                s[c] += p[c] as f64;
            }
        }
        let n = self.data.len().max(1) as f64;
        s.map(|v| v / n)
    }

    /// Per-channel mean over the finite values only (each channel divides by its own count of
    /// finite values; 0 when there are none).
    pub fn mean_finite(&self) -> [f64; 3] {
        let mut s = [0.0f64; 3];
        let mut n = [0u64; 3];
        for p in &self.data {
            for c in 0..3 {
                if p[c].is_finite() {
                    s[c] += p[c] as f64;
                    n[c] += 1;
                }
            }
        }
        [0, 1, 2].map(|c| if n[c] > 0 { s[c] / n[c] as f64 } else { 0.0 })
    }

    /// Mean luminance (Rec. 709 / sRGB primaries: 0.2126 R + 0.7152 G + 0.0722 B).
    pub fn mean_luminance(&self) -> f64 {
        let m = self.mean();
        0.2126 * m[0] + 0.7152 * m[1] + 0.0722 * m[2]
    }

    /// Number of pixel-channels that are NaN or infinite.
    pub fn count_nonfinite(&self) -> usize {
        self.data
            .iter()
            .flat_map(|p| p.iter())
            .filter(|v| !v.is_finite())
            .count()
    }

    /// Smallest and largest finite channel values, or `None` if there are none.
    pub fn finite_range(&self) -> Option<(f32, f32)> {
        let mut r: Option<(f32, f32)> = None;
        for &v in self.data.iter().flat_map(|p| p.iter()) {
            if v.is_finite() {
                r = Some(match r {
                    None => (v, v),
                    Some((lo, hi)) => (lo.min(v), hi.max(v)),
                });
            }
        }
        r
    }

    /// The image tone-mapped for display: each channel clamped to [0, 1] (NaN to 0), sRGB
    /// encoded and rounded to 8 bits; tightly packed RGB, row 0 first.
    pub fn to_srgb8(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.data.len() * 3);
        for p in &self.data {
            for &v in p {
                out.push(linear_to_srgb8(v));
            }
        }
        out
    }

    /// Builds an image from tightly packed 8-bit sRGB data, decoding to linear.
    pub fn from_srgb8(width: u32, height: u32, bytes: &[u8]) -> Result<Image, ImageError> {
        let n = width as usize * height as usize;
        if bytes.len() != n * 3 {
            return Err(ImageError::Invalid(format!(
                "{width}x{height} sRGB8 data holds {} bytes, expected {}",
                bytes.len(),
                n * 3
            )));
        }
        let data = bytes
            .chunks_exact(3)
            .map(|c| [0, 1, 2].map(|i| srgb_to_linear(c[i] as f32 / 255.0)))
            .collect();
        Image::from_data(width, height, data)
    }
}

impl fmt::Display for Image {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = self.mean();
        write!(
            f,
            "{}x{} image, mean ({:.6}, {:.6}, {:.6})",
            self.width, self.height, m[0], m[1], m[2]
        )
    }
}

/// The sRGB transfer curve (IEC 61966-2-1), linear to encoded, for `c` in [0, 1].
#[inline]
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// The inverse sRGB transfer curve, encoded to linear, for `c` in [0, 1].
#[inline]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Clamps a linear value to [0, 1] (NaN to 0, +inf to 1), sRGB-encodes it and rounds to the
/// nearest 8-bit code.
#[inline]
pub fn linear_to_srgb8(v: f32) -> u8 {
    let c = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    (linear_to_srgb(c) * 255.0 + 0.5).floor().clamp(0.0, 255.0) as u8
}

/// Image file formats, chosen by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Exr,
    Png,
    Pfm,
}

impl Format {
    /// The format for `path`'s extension (case-insensitive), or an error naming the path.
    pub fn from_path(path: &Path) -> Result<Format, ImageError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("exr") => Ok(Format::Exr),
            Some("png") => Ok(Format::Png),
            Some("pfm") => Ok(Format::Pfm),
            _ => Err(ImageError::UnknownExtension {
                path: path.to_path_buf(),
            }),
        }
    }
}

/// Writes `img` to `path` atomically, in the format given by the extension (see the module
/// documentation). The parent directory must exist.
pub fn write(path: &Path, img: &Image) -> Result<(), ImageError> {
    write_layered(path, img, &Extras::default())
}

/// [`write`], and in an EXR file the variance layer and the attributes of `extras` too (see
/// `openexr`'s documentation: plain RGB readers still read `img`); PNG and PFM files get the
/// image only.
pub fn write_layered(path: &Path, img: &Image, extras: &Extras) -> Result<(), ImageError> {
    let format = Format::from_path(path)?;
    img.validate().map_err(|e| ImageError::InvalidImage {
        path: path.to_path_buf(),
        reason: match e {
            ImageError::Invalid(r) => r,
            other => other.to_string(),
        },
    })?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(ImageError::MissingDirectory {
            path: path.to_path_buf(),
            dir,
        });
    }
    crate::outfile::write_with(path, |file| match format {
        Format::Exr => openexr::write_exr(file, path, img, extras),
        Format::Png => write_png(file, path, img),
        Format::Pfm => write_pfm(file, path, img),
    })
}

impl From<crate::outfile::WriteError> for ImageError {
    fn from(e: crate::outfile::WriteError) -> Self {
        ImageError::Io {
            path: e.path,
            what: e.what,
            source: e.source,
        }
    }
}

fn write_png(file: &mut File, path: &Path, img: &Image) -> Result<(), ImageError> {
    use image::ImageEncoder;
    let bytes = img.to_srgb8();
    let mut out = BufWriter::new(file);
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(
            &bytes,
            img.width,
            img.height,
            image::ExtendedColorType::Rgb8,
        )
        .map_err(|source| ImageError::Png {
            path: path.to_path_buf(),
            source,
        })?;
    out.flush().map_err(|source| ImageError::Io {
        path: path.to_path_buf(),
        what: "cannot write the PNG data",
        source,
    })
}

fn write_pfm(file: &mut File, path: &Path, img: &Image) -> Result<(), ImageError> {
    let mut out = BufWriter::new(file);
    let mut bytes = Vec::with_capacity(32 + img.data.len() * 12);
    bytes.extend_from_slice(format!("PF\n{} {}\n-1.0\n", img.width, img.height).as_bytes());
    let w = img.width as usize;
    for row in img.data.chunks_exact(w).rev() {
        for p in row {
            for v in p {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    out.write_all(&bytes)
        .and_then(|_| out.flush())
        .map_err(|source| ImageError::Io {
            path: path.to_path_buf(),
            what: "cannot write the PFM data",
            source,
        })
}

/// Reads an image, in the format given by the extension (see the module documentation), as
/// linear RGB.
pub fn read(path: &Path) -> Result<Image, ImageError> {
    let format = Format::from_path(path)?;
    let img = match format {
        Format::Exr => openexr::read_exr(path)?,
        Format::Png => read_png(path)?,
        Format::Pfm => read_pfm(path)?,
    };
    img.validate().map_err(|e| ImageError::InvalidImage {
        path: path.to_path_buf(),
        reason: e.reason(),
    })?;
    Ok(img)
}

/// [`read`], with the variance layer and the attributes an EXR file written by
/// [`write_layered`] carries (none for PNG and PFM files).
pub fn read_layered(path: &Path) -> Result<Layered, ImageError> {
    if Format::from_path(path)? != Format::Exr {
        return Ok(Layered {
            image: read(path)?,
            variance: None,
            batch_variance: None,
            provenance: Provenance::default(),
        });
    }
    let l = openexr::read_exr_layers(path)?;
    let batch = l.batch_variance.as_ref().map(|b| &b.variance);
    for img in std::iter::once(&l.image).chain(&l.variance).chain(batch) {
        img.validate().map_err(|e| ImageError::InvalidImage {
            path: path.to_path_buf(),
            reason: e.reason(),
        })?;
    }
    Ok(l)
}

pub(crate) fn open(path: &Path) -> Result<File, ImageError> {
    // A regular file within the limit of an image ([`crate::infile`]).
    crate::infile::open(path, crate::infile::IMAGE)
        .map(|(f, _)| f)
        .map_err(|source| ImageError::Io {
            path: path.to_path_buf(),
            what: "cannot open",
            source,
        })
}

/// Refuses an image of `width` × `height` read from `path` when either side is over the film
/// limit ([`crate::conventions::MAX_FILM_SIZE`]), before anything of that size is allocated: a
/// file of a few bytes can declare 10^10 pixels.
pub(crate) fn check_size(path: &Path, width: u64, height: u64) -> Result<(), ImageError> {
    let max = crate::conventions::MAX_FILM_SIZE as u64;
    if width > max || height > max {
        return Err(ImageError::InvalidImage {
            path: path.to_path_buf(),
            reason: format!(
                "its header declares {width}x{height} pixels, over the limit of {max} per side"
            ),
        });
    }
    Ok(())
}

fn read_png(path: &Path) -> Result<Image, ImageError> {
    let mut img = read_png_codes(path)?;
    img.decode_srgb();
    Ok(img)
}

/// A PNG's values as codes in [0, 1] (c / 255 or c / 65535, as the `image` crate converts
/// them), grey replicated to RGB, alpha ignored. Decoded straight into the image's pixels: the
/// file's samples (1 to 8 bytes a pixel) and the 12 bytes a pixel of the result are all it
/// holds at once, for a file of a few hundred kilobytes can declare 16384² pixels of one colour.
pub(crate) fn read_png_codes(path: &Path) -> Result<Image, ImageError> {
    use image::{ColorType, ImageDecoder};
    let png_error = |source| ImageError::Png {
        path: path.to_path_buf(),
        source,
    };
    // The size from the header first: a small file of a flat colour can expand to gigabytes.
    let decoder = image::codecs::png::PngDecoder::with_limits(
        BufReader::new(open(path)?),
        image::Limits::default(),
    )
    .map_err(png_error)?;
    let (w, h) = decoder.dimensions();
    check_size(path, w as u64, h as u64)?;
    let color = decoder.color_type();
    let mut bytes = vec![0u8; decoder.total_bytes() as usize];
    decoder.read_image(&mut bytes).map_err(png_error)?;
    let channels = color.channel_count() as usize;
    let code8 = |c: u8| (c as f32 / u8::MAX as f32).clamp(0.0, 1.0);
    let code16 =
        |c: &[u8]| (u16::from_ne_bytes([c[0], c[1]]) as f32 / u16::MAX as f32).clamp(0.0, 1.0);
    let data: Vec<[f32; 3]> = match color {
        ColorType::L8 | ColorType::La8 => bytes
            .chunks_exact(channels)
            .map(|p| [code8(p[0]); 3])
            .collect(),
        ColorType::Rgb8 | ColorType::Rgba8 => bytes
            .chunks_exact(channels)
            .map(|p| [code8(p[0]), code8(p[1]), code8(p[2])])
            .collect(),
        ColorType::L16 | ColorType::La16 => bytes
            .chunks_exact(2 * channels)
            .map(|p| [code16(&p[0..2]); 3])
            .collect(),
        ColorType::Rgb16 | ColorType::Rgba16 => bytes
            .chunks_exact(2 * channels)
            .map(|p| [code16(&p[0..2]), code16(&p[2..4]), code16(&p[4..6])])
            .collect(),
        other => {
            return Err(ImageError::InvalidImage {
                path: path.to_path_buf(),
                reason: format!("unsupported PNG colour type {other:?}"),
            })
        }
    };
    drop(bytes);
    Image::from_data(w, h, data).map_err(|e| ImageError::InvalidImage {
        path: path.to_path_buf(),
        reason: e.reason(),
    })
}

fn read_pfm(path: &Path) -> Result<Image, ImageError> {
    let bad = |reason: String| ImageError::Pfm {
        path: path.to_path_buf(),
        reason,
    };
    let mut bytes = Vec::new();
    open(path)?
        .read_to_end(&mut bytes)
        .map_err(|source| ImageError::Io {
            path: path.to_path_buf(),
            what: "cannot read",
            source,
        })?;
    // Header: four whitespace-separated tokens (magic, width, height, scale), then exactly one
    // whitespace byte before the raster.
    let mut pos = 0usize;
    let mut tokens: Vec<String> = Vec::with_capacity(4);
    while tokens.len() < 4 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() && pos - start < 64 {
            pos += 1;
        }
        if start == pos {
            return Err(bad(format!(
                "header ends after {} of its 4 fields (magic, width, height, scale)",
                tokens.len()
            )));
        }
        tokens.push(String::from_utf8_lossy(&bytes[start..pos]).into_owned());
    }
    if pos >= bytes.len() || !bytes[pos].is_ascii_whitespace() {
        return Err(bad("no whitespace byte after the scale field".into()));
    }
    pos += 1;
    let channels = match tokens[0].as_str() {
        "PF" => 3usize,
        "Pf" => 1usize,
        m => {
            return Err(bad(format!(
                "magic is {m:?}, expected \"PF\" (RGB) or \"Pf\" (grey)"
            )))
        }
    };
    let parse_dim = |s: &str, name: &str| -> Result<u32, ImageError> {
        s.parse::<u32>()
            .ok()
            .filter(|&v| v > 0)
            .ok_or_else(|| bad(format!("{name} {s:?} is not a positive integer")))
    };
    let width = parse_dim(&tokens[1], "width")?;
    let height = parse_dim(&tokens[2], "height")?;
    check_size(path, width as u64, height as u64)?;
    let scale: f32 = tokens[3]
        .parse()
        .ok()
        .filter(|s: &f32| s.is_finite() && *s != 0.0)
        .ok_or_else(|| bad(format!("scale {:?} is not a non-zero number", tokens[3])))?;
    let little_endian = scale < 0.0;
    let expected = width as u64 * height as u64 * channels as u64 * 4;
    let available = (bytes.len() - pos) as u64;
    if available < expected {
        return Err(bad(format!(
            "{width}x{height} raster needs {expected} bytes, the file has {available}"
        )));
    }
    let raster = &bytes[pos..pos + expected as usize];
    let mut floats = raster.chunks_exact(4).map(|b| {
        let b = [b[0], b[1], b[2], b[3]];
        if little_endian {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        }
    });
    let (w, h) = (width as usize, height as usize);
    let mut data = vec![[0.0f32; 3]; w * h];
    // Rows are stored bottom to top.
    for y in (0..h).rev() {
        for x in 0..w {
            let px = &mut data[y * w + x];
            if channels == 3 {
                for c in px.iter_mut() {
                    *c = floats.next().unwrap_or(0.0);
                }
            } else {
                *px = [floats.next().unwrap_or(0.0); 3];
            }
        }
    }
    Ok(Image {
        width,
        height,
        data,
    })
}
