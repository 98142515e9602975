//! Images read as scene inputs (environment maps and textures, `crate::texture`): the values as
//! the file stores them, with whether they are codes of the sRGB curve, so that the scene
//! decides what they mean (a colour decodes the curve unless `raw`; a scalar parameter takes
//! the codes as they are).
//!
//! | extension | format | values |
//! |---|---|---|
//! | `.exr` | OpenEXR, the first layer with R, G, B | linear |
//! | `.hdr` | Radiance RGBE (`#?RADIANCE`, `#?RGBE`), flat or run-length encoded | linear |
//! | `.pfm` | Portable Float Map, RGB or grey | linear |
//! | `.png` | PNG, 8 or 16 bits, grey or RGB (alpha ignored) | sRGB codes in [0, 1] |
//!
//! Every reader checks the declared size against [`super::check_size`] before it allocates
//! (a file of a few bytes can declare 10^10 pixels), and every error names the file.

use super::{check_size, open, read_png_codes, Image, ImageError};
use std::io::BufReader;
use std::path::Path;

/// An image as stored in its file.
#[derive(Clone, Debug)]
pub struct Stored {
    /// The values, row 0 at the top: linear, or sRGB codes in [0, 1] when `srgb`.
    pub image: Image,
    /// The values are codes of the sRGB curve (PNG).
    pub srgb: bool,
}

/// The extensions [`read_stored`] reads, for messages.
pub const STORED_EXTENSIONS: &str = ".exr, .hdr, .pfm or .png";

/// Reads an image file for use as a texture or an environment map (module docs).
pub fn read_stored(path: &Path) -> Result<Stored, ImageError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let (image, srgb) = match ext.as_deref() {
        Some("exr") => (super::openexr::read_exr(path)?, false),
        Some("pfm") => (super::read_pfm(path)?, false),
        Some("hdr") => (read_hdr(path)?, false),
        Some("png") => (read_png_codes(path)?, true),
        _ => {
            return Err(ImageError::InvalidImage {
                path: path.to_path_buf(),
                reason: format!("unsupported image format (expected {STORED_EXTENSIONS})"),
            })
        }
    };
    image.validate().map_err(|e| ImageError::InvalidImage {
        path: path.to_path_buf(),
        reason: e.reason(),
    })?;
    Ok(Stored { image, srgb })
}

/// A Radiance RGBE file through the `image` crate's decoder, its size checked first.
fn read_hdr(path: &Path) -> Result<Image, ImageError> {
    use image::ImageDecoder;
    let hdr_error = |source: image::ImageError| ImageError::InvalidImage {
        path: path.to_path_buf(),
        reason: format!("Radiance HDR error: {source}"),
    };
    // A Radiance file opens with "#?" and the name of the program that wrote it: "#?RADIANCE",
    // "#?RGBE" (Mitsuba and others). The decoder's strict mode knows only the first; checked
    // here, and the line then read as a comment.
    let mut reader = BufReader::new(open(path)?);
    let head = std::io::BufRead::fill_buf(&mut reader).map_err(|source| ImageError::Io {
        path: path.to_path_buf(),
        what: "cannot read",
        source,
    })?;
    if !head.starts_with(b"#?") {
        return Err(ImageError::InvalidImage {
            path: path.to_path_buf(),
            reason: "not a Radiance HDR file: it does not begin with '#?' (as in #?RADIANCE)"
                .into(),
        });
    }
    let decoder =
        image::codecs::hdr::HdrDecoder::with_strictness(reader, false).map_err(hdr_error)?;
    let (w, h) = decoder.dimensions();
    check_size(path, w as u64, h as u64)?;
    let rgb = image::DynamicImage::from_decoder(decoder)
        .map_err(hdr_error)?
        .into_rgb32f();
    let (width, height) = rgb.dimensions();
    let data = rgb.pixels().map(|p| p.0).collect();
    Image::from_data(width, height, data).map_err(|e| ImageError::InvalidImage {
        path: path.to_path_buf(),
        reason: e.reason(),
    })
}

/// Writes a Radiance RGBE file (flat scanlines, no run-length encoding): for tests and the
/// scripts that make inputs. Values are clamped to ≥ 0 (RGBE has no sign).
pub fn write_hdr(path: &Path, img: &Image) -> Result<(), ImageError> {
    let mut bytes = format!(
        "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {} +X {}\n",
        img.height, img.width
    )
    .into_bytes();
    for p in &img.data {
        let m = p.iter().fold(0.0f32, |a, &c| a.max(c.max(0.0)));
        if !m.is_finite() || m < 1e-32 {
            bytes.extend([0, 0, 0, 0]);
            continue;
        }
        // m = f · 2^e with f in [0.5, 1): the mantissas c / 2^e · 256.
        let e = m.log2().floor() as i32 + 1;
        let scale = 256.0 / 2f32.powi(e);
        for c in p {
            bytes.push((c.max(0.0) * scale).min(255.0) as u8);
        }
        bytes.push((e + 128) as u8);
    }
    crate::outfile::write_with(path, |f| {
        use std::io::Write;
        f.write_all(&bytes).map_err(|source| ImageError::Io {
            path: path.to_path_buf(),
            what: "cannot write the Radiance HDR data",
            source,
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hdr_round_trip_within_rgbe_precision() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.hdr");
        let img = Image::from_fn(5, 3, |x, y| [x as f32 * 0.37 + 0.01, y as f32 * 2.0, 100.0]);
        write_hdr(&p, &img).unwrap();
        let s = read_stored(&p).unwrap();
        assert!(!s.srgb);
        assert_eq!((s.image.width, s.image.height), (5, 3));
        for (a, b) in img.data.iter().zip(&s.image.data) {
            for c in 0..3 {
                // RGBE keeps 8 bits of the largest channel's mantissa.
                assert!(
                    (a[c] - b[c]).abs() <= 0.01 * a[0].max(a[1]).max(a[2]),
                    "{a:?} {b:?}"
                );
            }
        }
    }

    #[test]
    fn unknown_extensions_are_named() {
        let e = read_stored(Path::new("x.jpg")).unwrap_err().to_string();
        assert!(e.contains("x.jpg") && e.contains(".hdr"), "{e}");
    }
}
