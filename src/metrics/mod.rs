//! Image comparison: MSE/RMSE, relMSE, FLIP, per-pixel agreement and a two-sample statistical
//! test of means, per pixel and per block.
//!
//! Conventions: images are linear RGB [`Image`]s; "test" is the image under scrutiny and
//! "reference" the one it is compared with. Every function checks that the two images are valid
//! and of the same size and returns [`MetricsError`] otherwise, never panicking. All sums are
//! accumulated in f64. Nothing here depends on the renderers.
//!
//! * [`mse`], [`rmse`], [`relmse`] follow pbrt-v4 `Image::MSE` / `Image::MRSE`: per pixel-channel
//!   (t − r)² resp. (t − r)² / (r + 0.01)²; a non-finite term is skipped (contributes 0) but the
//!   divisor stays the total number of pixel-channels, and the per-channel values are averaged
//!   over R, G, B (as `imgtool diff` reports them).
//! * [`flip_mean`] and [`error_map`] use NVIDIA's FLIP through the `nv-flip` crate. This is
//!   **LDR-FLIP**: both images are first tone-mapped by clamping to [0, 1] and sRGB-encoding to
//!   8 bits (exactly what [`crate::imageio::write`] stores in a PNG), at the default 67 pixels per
//!   degree. Radiance above 1 is therefore invisible to it; use relMSE/RMSE for HDR content.
//! * [`fraction_within`] is the same-seed agreement check (GPU vs CPU with shared random
//!   numbers).
//! * [`z_test`] (and [`z_test_with`] for one-sample variances) is the independent-seed
//!   statistical test of means, per pixel (Mitsuba 3 `test_renders.py` style, made two-sample)
//!   and per block at several scales (`blocks.rs`), under one family-wise α; its verdict rule
//!   is documented on [`ZTestOptions`], the distributions it needs are in `dist.rs`.

use std::fmt;

use crate::imageio::{linear_to_srgb8, srgb_to_linear, Image};

mod blocks;
mod dist;
mod verdict;
mod ztest;

pub use blocks::{scales as block_scales, BlockReport, BlockTest, Detectable, Rect, ScaleReport};
pub use dist::{normal_quantile, normal_two_sided, t_critical, t_two_sided};
pub use verdict::{Metric, Threshold, ThresholdError, Verdict};
pub use ztest::{
    binomial_upper_tail, z_test, z_test_with, SideVariance, VarianceModel, VarianceSource,
    ZOutlier, ZSide, ZTestOptions, ZTestReport,
};

/// The ε of relMSE, (t − r)² / (r + ε)², as in pbrt-v4 `Image::MRSE`.
pub const RELMSE_EPSILON: f64 = 0.01;

/// How many worst pixels the reports list.
pub const WORST_COUNT: usize = 10;

/// Errors of the comparison functions.
#[derive(Debug, thiserror::Error)]
pub enum MetricsError {
    #[error("image size mismatch: {a_name} is {}x{}, {b_name} is {}x{}", a.0, a.1, b.0, b.1)]
    SizeMismatch {
        a_name: &'static str,
        a: (u32, u32),
        b_name: &'static str,
        b: (u32, u32),
    },
    #[error("invalid {name} image: {reason}")]
    InvalidImage { name: &'static str, reason: String },
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        name: &'static str,
        value: f64,
        reason: &'static str,
    },
}

fn check(name: &'static str, img: &Image) -> Result<(), MetricsError> {
    img.validate().map_err(|e| MetricsError::InvalidImage {
        name,
        reason: match e {
            crate::imageio::ImageError::Invalid(r) => r,
            other => other.to_string(),
        },
    })
}

pub(crate) fn check_pair(
    a_name: &'static str,
    a: &Image,
    b_name: &'static str,
    b: &Image,
) -> Result<(), MetricsError> {
    check(a_name, a)?;
    check(b_name, b)?;
    if !a.same_size(b) {
        return Err(MetricsError::SizeMismatch {
            a_name,
            a: (a.width, a.height),
            b_name,
            b: (b.width, b.height),
        });
    }
    Ok(())
}

/// Mean over pixel-channels of `term(t, r)`, skipping non-finite terms but dividing by the total
/// count (pbrt-v4 convention).
fn mean_term(test: &Image, reference: &Image, term: impl Fn(f64, f64) -> f64) -> f64 {
    let mut sum = 0.0f64;
    for (t, r) in test.data.iter().zip(&reference.data) {
        for c in 0..3 {
            let v = term(t[c] as f64, r[c] as f64);
            if v.is_finite() {
                sum += v;
            }
        }
    }
    sum / (3 * test.data.len()) as f64
}

/// Mean squared error over all pixel-channels (pbrt-v4 `Image::MSE`, averaged over channels).
pub fn mse(test: &Image, reference: &Image) -> Result<f64, MetricsError> {
    check_pair("test", test, "reference", reference)?;
    Ok(mean_term(test, reference, |t, r| (t - r) * (t - r)))
}

/// Root of [`mse`].
pub fn rmse(test: &Image, reference: &Image) -> Result<f64, MetricsError> {
    mse(test, reference).map(f64::sqrt)
}

/// Relative MSE exactly as pbrt-v4 `Image::MRSE` averaged over channels:
/// mean over pixel-channels of (t − r)² / (r + 0.01)², non-finite terms skipped (but counted in
/// the divisor).
pub fn relmse(test: &Image, reference: &Image) -> Result<f64, MetricsError> {
    check_pair("test", test, "reference", reference)?;
    Ok(mean_term(test, reference, relmse_term))
}

#[inline]
fn relmse_term(t: f64, r: f64) -> f64 {
    let d = r + RELMSE_EPSILON;
    (t - r) * (t - r) / (d * d)
}

/// Per pixel-channel relative squared error (t − r)² / (r + 0.01)² as an image (for EXR output);
/// non-finite terms are stored as they are.
pub fn relative_error_map(test: &Image, reference: &Image) -> Result<Image, MetricsError> {
    check_pair("test", test, "reference", reference)?;
    let data = test
        .data
        .iter()
        .zip(&reference.data)
        .map(|(t, r)| [0, 1, 2].map(|c| relmse_term(t[c] as f64, r[c] as f64) as f32))
        .collect();
    Ok(Image {
        width: test.width,
        height: test.height,
        data,
    })
}

/// The per-pixel LDR-FLIP error in [0, 1], row 0 first (see the module documentation for the
/// tone mapping). Computed in bands of rows ([`FLIP_BAND_PIXELS`]), each with
/// [`FLIP_CONTEXT`] rows of the images around it, so that FLIP's working images (about 80
/// bytes a pixel) are a band's, not the whole image's: the same values as one pass over the
/// whole image, since no FLIP filter reaches past the context.
pub fn flip_map(test: &Image, reference: &Image) -> Result<Vec<f32>, MetricsError> {
    check_pair("test", test, "reference", reference)?;
    let rows = (FLIP_BAND_PIXELS / test.width as usize).max(64);
    Ok(flip_map_in_bands(
        test,
        reference,
        rows.min(u32::MAX as usize) as u32,
    ))
}

/// Pixels of a band of [`flip_map`] (at least 64 rows).
pub const FLIP_BAND_PIXELS: usize = 1 << 22;

/// Rows of the images above and below a band of [`flip_map`]: more than the reach of FLIP's
/// filters at its default 67.02 pixels per degree (Andersson et al. 2020: the spatial filters
/// of the colour pipeline reach 3 standard deviations of their widest Gaussian, 10 pixels; the
/// edge and point detectors 3 standard deviations of 0.041°, 9 pixels). A test compares bands
/// of 5 rows with the whole image.
pub const FLIP_CONTEXT: u32 = 24;

fn flip_map_in_bands(test: &Image, reference: &Image, band: u32) -> Vec<f32> {
    let (w, h) = (test.width, test.height);
    let srgb8 = |img: &Image, rows: std::ops::Range<u32>| -> Vec<u8> {
        let px = &img.data[(rows.start * w) as usize..(rows.end * w) as usize];
        px.iter().flat_map(|p| p.map(linear_to_srgb8)).collect()
    };
    let mut out = Vec::with_capacity(test.data.len());
    let mut y0 = 0;
    while y0 < h {
        let y1 = y0.saturating_add(band).min(h);
        let ctx = y0.saturating_sub(FLIP_CONTEXT)..y1.saturating_add(FLIP_CONTEXT).min(h);
        let n = ctx.end - ctx.start;
        let r = nv_flip::FlipImageRgb8::with_data(w, n, &srgb8(reference, ctx.clone()));
        let t = nv_flip::FlipImageRgb8::with_data(w, n, &srgb8(test, ctx.clone()));
        let map = nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE).to_vec();
        let skip = ((y0 - ctx.start) * w) as usize;
        out.extend_from_slice(&map[skip..skip + ((y1 - y0) * w) as usize]);
        y0 = y1;
    }
    out
}

/// Mean LDR-FLIP error (`FlipPool` mean), 0 for identical tone-mapped images.
pub fn flip_mean(test: &Image, reference: &Image) -> Result<f64, MetricsError> {
    let map = flip_map(test, reference)?;
    Ok(flip_pool_mean(&map, test.width, test.height))
}

fn flip_pool_mean(map: &[f32], w: u32, h: u32) -> f64 {
    let img = nv_flip::FlipImageFloat::with_data(w, h, map);
    nv_flip::FlipPool::from_image(&img).mean() as f64
}

/// The error map for viewing: the per-pixel LDR-FLIP error coloured with FLIP's magma colour
/// map (black = no visible difference, through purple and orange, to pale yellow = 1).
/// The colours are stored linear, so writing the result as PNG reproduces magma exactly.
pub fn error_map(test: &Image, reference: &Image) -> Result<Image, MetricsError> {
    let map = flip_map(test, reference)?;
    Ok(colour_map(&map, test.width, test.height))
}

fn colour_map(values: &[f32], width: u32, height: u32) -> Image {
    let lut_bytes = nv_flip::magma_lut().to_vec();
    let lut: Vec<[f32; 3]> = lut_bytes
        .chunks_exact(3)
        .map(|c| [0, 1, 2].map(|i| srgb_to_linear(c[i] as f32 / 255.0)))
        .collect();
    let last = lut.len() - 1;
    let data = values
        .iter()
        .map(|&v| {
            let v = if v.is_nan() { 1.0 } else { v.clamp(0.0, 1.0) };
            lut[((v * last as f32).round() as usize).min(last)]
        })
        .collect();
    Image {
        width,
        height,
        data,
    }
}

/// One pixel of a "worst pixels" list.
#[derive(Clone, Debug, PartialEq)]
pub struct PixelDiff {
    pub x: u32,
    pub y: u32,
    pub test: [f32; 3],
    pub reference: [f32; 3],
    /// What the list is sorted by (largest first); its meaning is given by the producing
    /// function. Non-finite values rank as +inf.
    pub score: f64,
}

impl fmt::Display for PixelDiff {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "({}, {}): test ({:.6}, {:.6}, {:.6}) reference ({:.6}, {:.6}, {:.6}) score {:.4e}",
            self.x,
            self.y,
            self.test[0],
            self.test[1],
            self.test[2],
            self.reference[0],
            self.reference[1],
            self.reference[2],
            self.score
        )
    }
}

/// The `k` largest scores as (score, index), largest first; NaN scores rank as +inf.
pub(crate) fn top_k(scores: impl Iterator<Item = f64>, k: usize) -> Vec<(f64, usize)> {
    let mut v: Vec<(f64, usize)> = scores
        .enumerate()
        .map(|(i, s)| (if s.is_nan() { f64::INFINITY } else { s }, i))
        .collect();
    let by_score_desc =
        |a: &(f64, usize), b: &(f64, usize)| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1));
    if v.len() > k && k > 0 {
        v.select_nth_unstable_by(k - 1, by_score_desc);
        v.truncate(k);
    }
    v.truncate(k);
    v.sort_by(by_score_desc);
    v
}

fn worst_list(
    test: &Image,
    reference: &Image,
    scores: impl Iterator<Item = f64>,
) -> Vec<PixelDiff> {
    top_k(scores, WORST_COUNT)
        .into_iter()
        .map(|(score, i)| {
            let (x, y) = test.coords(i);
            PixelDiff {
                x,
                y,
                test: test.data[i],
                reference: reference.data[i],
                score,
            }
        })
        .collect()
}

/// Everything `brdfwave diff` reports about a test image against a reference.
#[derive(Clone, Debug)]
pub struct DiffReport {
    pub width: u32,
    pub height: u32,
    pub mse: f64,
    pub rmse: f64,
    /// pbrt-v4 MRSE, see [`relmse`].
    pub relmse: f64,
    /// Mean LDR-FLIP error in [0, 1] (see the module documentation).
    pub flip_mean: f64,
    /// Largest finite |t − r| over pixel-channels.
    pub max_abs: f64,
    /// Per-channel means over finite values.
    pub mean_test: [f64; 3],
    pub mean_reference: [f64; 3],
    /// Number of NaN or infinite pixel-channels in each image.
    pub nonfinite_test: usize,
    pub nonfinite_reference: usize,
    /// The [`WORST_COUNT`] pixels with the largest max-over-channels |t − r| (score), pixels
    /// with non-finite values first.
    pub worst_pixels: Vec<PixelDiff>,
}

/// Compares `test` with `reference`: RMSE, relMSE, LDR-FLIP, max abs error, means, non-finite
/// counts and the worst pixels. Errors if the sizes differ.
pub fn diff(test: &Image, reference: &Image) -> Result<DiffReport, MetricsError> {
    check_pair("test", test, "reference", reference)?;
    let mse_v = mean_term(test, reference, |t, r| (t - r) * (t - r));
    let relmse_v = mean_term(test, reference, relmse_term);
    let flip = flip_mean(test, reference)?;
    let mut max_abs = 0.0f64;
    for (t, r) in test.data.iter().zip(&reference.data) {
        for c in 0..3 {
            let d = (t[c] as f64 - r[c] as f64).abs();
            if d.is_finite() {
                max_abs = max_abs.max(d);
            }
        }
    }
    let scores = test.data.iter().zip(&reference.data).map(|(t, r)| {
        (0..3)
            .map(|c| (t[c] as f64 - r[c] as f64).abs())
            .fold(0.0f64, |m, d| {
                if d.is_finite() {
                    m.max(d)
                } else {
                    f64::INFINITY
                }
            })
    });
    Ok(DiffReport {
        width: test.width,
        height: test.height,
        mse: mse_v,
        rmse: mse_v.sqrt(),
        relmse: relmse_v,
        flip_mean: flip,
        max_abs,
        mean_test: test.mean_finite(),
        mean_reference: reference.mean_finite(),
        nonfinite_test: test.count_nonfinite(),
        nonfinite_reference: reference.count_nonfinite(),
        worst_pixels: worst_list(test, reference, scores),
    })
}

impl fmt::Display for DiffReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "size        {}x{}", self.width, self.height)?;
        writeln!(f, "RMSE        {:.6e}", self.rmse)?;
        writeln!(f, "MSE         {:.6e}", self.mse)?;
        writeln!(f, "relMSE      {:.6e}", self.relmse)?;
        writeln!(f, "FLIP (LDR)  {:.6}", self.flip_mean)?;
        writeln!(f, "max |t-r|   {:.6e}", self.max_abs)?;
        let m = |v: [f64; 3]| format!("({:.6}, {:.6}, {:.6})", v[0], v[1], v[2]);
        writeln!(f, "mean test   {}", m(self.mean_test))?;
        writeln!(f, "mean ref    {}", m(self.mean_reference))?;
        writeln!(
            f,
            "non-finite  test {}, reference {}",
            self.nonfinite_test, self.nonfinite_reference
        )?;
        writeln!(f, "worst pixels (score = max channel |t-r|):")?;
        for p in &self.worst_pixels {
            writeln!(f, "  {p}")?;
        }
        Ok(())
    }
}

/// Result of [`fraction_within`].
#[derive(Clone, Debug)]
pub struct Agreement {
    /// Fraction of pixel-channels that agree.
    pub channel_fraction: f64,
    /// Fraction of pixels whose three channels all agree.
    pub pixel_fraction: f64,
    /// Number of pixel-channels that disagree.
    pub disagreeing_channels: usize,
    /// The [`WORST_COUNT`] pixels with the largest max-over-channels ratio
    /// |t − r| / (rel_tol · max(|t|, |r|) + abs_floor) (score; > 1 means disagreement).
    pub worst: Vec<PixelDiff>,
}

impl fmt::Display for Agreement {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "agreeing pixel-channels {:.4}%, pixels {:.4}% ({} pixel-channels disagree)",
            100.0 * self.channel_fraction,
            100.0 * self.pixel_fraction,
            self.disagreeing_channels
        )?;
        writeln!(f, "worst pixels (score = |t-r| / tolerance):")?;
        for p in &self.worst {
            writeln!(f, "  {p}")?;
        }
        Ok(())
    }
}

/// Per-pixel agreement for the same-seed GPU-vs-CPU test: a pixel-channel agrees when
/// |t − r| <= rel_tol · max(|t|, |r|) + abs_floor. Non-finite values never agree.
pub fn fraction_within(
    test: &Image,
    reference: &Image,
    rel_tol: f64,
    abs_floor: f64,
) -> Result<Agreement, MetricsError> {
    check_pair("test", test, "reference", reference)?;
    for (name, value) in [("rel_tol", rel_tol), ("abs_floor", abs_floor)] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(MetricsError::InvalidParameter {
                name,
                value,
                reason: "must be finite and >= 0",
            });
        }
    }
    // Score: |t − r| / tolerance (0 for exact equality, +inf for non-finite values or a
    // difference with zero tolerance); the agreement test itself is done without division.
    let ratio = |t: f64, r: f64, tol: f64| -> f64 {
        let d = (t - r).abs();
        if !(t.is_finite() && r.is_finite()) {
            f64::INFINITY
        } else if d == 0.0 {
            0.0
        } else if tol > 0.0 {
            d / tol
        } else {
            f64::INFINITY
        }
    };
    let mut disagree = 0usize;
    let mut pixels_ok = 0usize;
    let mut scores = Vec::with_capacity(test.data.len());
    for (t, r) in test.data.iter().zip(&reference.data) {
        let mut worst = 0.0f64;
        let mut ok = true;
        for c in 0..3 {
            let (tc, rc) = (t[c] as f64, r[c] as f64);
            let tol = rel_tol * tc.abs().max(rc.abs()) + abs_floor;
            let agrees = tc.is_finite() && rc.is_finite() && (tc - rc).abs() <= tol;
            if !agrees {
                disagree += 1;
                ok = false;
            }
            worst = worst.max(ratio(tc, rc, tol));
        }
        pixels_ok += ok as usize;
        scores.push(worst);
    }
    let n = test.data.len();
    Ok(Agreement {
        channel_fraction: 1.0 - disagree as f64 / (3 * n) as f64,
        pixel_fraction: pixels_ok as f64 / n as f64,
        disagreeing_channels: disagree,
        worst: worst_list(test, reference, scores.into_iter()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// FLIP in bands of a few rows gives the values of one pass over the whole image, bit for
    /// bit: no filter reaches past the context rows. On noise with edges (where FLIP's feature
    /// detectors respond) and a smooth gradient.
    #[test]
    fn flip_in_bands_is_flip_of_the_whole_image() {
        let (w, h) = (37, 211);
        let rnd = |x: u32, y: u32| crate::rng::random_f32(7, y * w + x, 0, 0, 0);
        let reference = Image::from_fn(w, h, |x, y| {
            let edge = if (x / 5 + y / 7) % 2 == 0 { 0.8 } else { 0.1 };
            [edge, x as f32 / w as f32, y as f32 / h as f32]
        });
        let test = Image::from_fn(w, h, |x, y| {
            let n = 0.3 * (rnd(x, y) - 0.5);
            reference.get(x, y).map(|c| (c + n).max(0.0))
        });
        let whole = flip_map_in_bands(&test, &reference, h);
        assert!(whole.iter().any(|&v| v > 0.05), "the images differ visibly");
        for band in [1, 5, 64, 100] {
            let banded = flip_map_in_bands(&test, &reference, band);
            assert!(banded == whole, "bands of {band} rows");
        }
    }
}
