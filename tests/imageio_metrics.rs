//! Image files (round trips, atomic writes, errors) and image metrics (relMSE, FLIP, agreement,
//! per-pixel z-test) on synthetic images with known answers.

use std::fs;
use std::path::Path;

use brdfwave::film;
use brdfwave::imageio::{self, linear_to_srgb8, srgb_to_linear, Image, ImageError};
use brdfwave::metrics::{self, MetricsError, VarianceModel, ZTestOptions};
use brdfwave::stress::Rng;

/// Draws for the synthetic data from the stress tests' SplitMix64 (independent of
/// `brdfwave::rng`).
trait Synthetic {
    /// Uniform in [0, 1).
    fn uniform(&mut self) -> f64;
    /// Standard normal (Box-Muller).
    fn normal(&mut self) -> f64;
}

impl Synthetic for Rng {
    fn uniform(&mut self) -> f64 {
        self.f64()
    }
    fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// Values that stress a float format: signs, zeros, denormals, huge, inf, NaN.
fn awkward_image() -> Image {
    let special = [
        0.0f32,
        -0.0,
        1.0,
        -1.5,
        1e-40,
        f32::MIN_POSITIVE,
        3.4e38,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        0.1,
        123.456,
    ];
    // 7x5, not square, so a transposition shows.
    Image::from_fn(7, 5, |x, y| {
        let i = (y * 7 + x) as usize;
        [
            special[i % special.len()],
            x as f32 + 0.25 * y as f32,
            special[(i * 5 + 3) % special.len()],
        ]
    })
}

fn assert_bit_exact(a: &Image, b: &Image) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    for (i, (p, q)) in a.data.iter().zip(&b.data).enumerate() {
        for c in 0..3 {
            if p[c].is_nan() {
                assert!(q[c].is_nan(), "pixel {i} channel {c}: NaN became {}", q[c]);
            } else {
                assert_eq!(
                    p[c].to_bits(),
                    q[c].to_bits(),
                    "pixel {i} channel {c}: {} became {}",
                    p[c],
                    q[c]
                );
            }
        }
    }
}

#[test]
fn exr_round_trip_is_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    let img = awkward_image();
    for name in ["a.exr", "b.EXR"] {
        let path = dir.path().join(name);
        imageio::write(&path, &img).unwrap();
        let back = imageio::read(&path).unwrap();
        assert_bit_exact(&img, &back);
    }
    // Orientation, checked with the exr crate directly: row 0 of the file is our row 0 (top).
    let path = dir.path().join("a.exr");
    let raw = exr::prelude::read_first_rgba_layer_from_file(
        &path,
        |res, _| vec![[0.0f32; 3]; res.width() * res.height() + 1],
        |px: &mut Vec<[f32; 3]>, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * 7 + pos.x()] = [r, g, b];
        },
    )
    .unwrap();
    let size = raw.layer_data.size;
    assert_eq!((size.width(), size.height()), (7, 5));
    assert_eq!(
        raw.layer_data.channel_data.pixels[7 * 2 + 3][1],
        img.get(3, 2)[1]
    );
}

#[test]
fn pfm_round_trip_and_foreign_files() {
    let dir = tempfile::tempdir().unwrap();
    let img = awkward_image();
    let path = dir.path().join("a.pfm");
    imageio::write(&path, &img).unwrap();
    assert_bit_exact(&img, &imageio::read(&path).unwrap());

    // A hand-made big-endian grey 2x2 file: rows bottom to top.
    let mut bytes = b"Pf\n2 2\n1.0\n".to_vec();
    for v in [1.0f32, 2.0, 3.0, 4.0] {
        bytes.extend_from_slice(&v.to_be_bytes());
    }
    let grey = dir.path().join("grey.pfm");
    fs::write(&grey, &bytes).unwrap();
    let g = imageio::read(&grey).unwrap();
    assert_eq!(g.get(0, 1), [1.0; 3], "first stored row is the bottom row");
    assert_eq!(g.get(1, 0), [4.0; 3]);

    // Truncated raster: a clear error naming the file.
    fs::write(&grey, &bytes[..bytes.len() - 1]).unwrap();
    let err = imageio::read(&grey).unwrap_err().to_string();
    assert!(
        err.contains("grey.pfm") && err.contains("needs 16 bytes"),
        "{err}"
    );
}

#[test]
fn png_round_trip_within_8bit_quantisation() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ramp.png");
    // A ramp over [-0.1, 1.3] plus a NaN: values are clamped, then quantised.
    let img = Image::from_fn(37, 3, |x, y| {
        let v = -0.1 + 1.4 * x as f32 / 36.0;
        if (x, y) == (5, 2) {
            [f32::NAN, v, 0.5]
        } else {
            [v, v * v, 1.0 - v]
        }
    });
    imageio::write(&path, &img).unwrap();
    let back = imageio::read(&path).unwrap();
    assert_eq!((back.width, back.height), (37, 3));
    let mut max_lin_err = 0.0f32;
    for (p, q) in img.data.iter().zip(&back.data) {
        for c in 0..3 {
            let code = linear_to_srgb8(p[c]);
            // Decoding is the exact inverse of the 8-bit code...
            let expected = srgb_to_linear(code as f32 / 255.0);
            assert!(
                (q[c] - expected).abs() <= 1e-6,
                "{} -> {} expected {}",
                p[c],
                q[c],
                expected
            );
            // ...re-encoding is idempotent...
            assert_eq!(linear_to_srgb8(q[c]), code);
            // ...and the encoded value moved by at most half a code.
            let clamped = if p[c].is_nan() {
                0.0
            } else {
                p[c].clamp(0.0, 1.0)
            };
            let enc = |v: f32| imageio::linear_to_srgb(v) * 255.0;
            assert!((enc(q[c]) - enc(clamped)).abs() <= 0.5 + 1e-3);
            max_lin_err = max_lin_err.max((q[c] - clamped).abs());
        }
    }
    // The coarsest sRGB step in linear is near 1: (1 - decode(254/255)) ≈ 0.0089.
    assert!(max_lin_err < 0.005, "max linear error {max_lin_err}");
    // Orientation via the image crate directly: the file's top-left pixel is our (0, 0), which
    // is clamped black in red, 0.01 in green and clamped white in blue.
    let raw = image::open(&path).unwrap().into_rgb8();
    assert_eq!(raw.get_pixel(0, 0).0, [0, linear_to_srgb8(0.01), 255]);
    assert_eq!(raw.get_pixel(36, 0).0[0], 255);
    assert_eq!(raw.get_pixel(5, 2).0[0], 0, "NaN is written as 0");
}

fn only_entry(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn failed_writes_leave_existing_files_intact() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("keep.exr");
    let good = Image::from_fn(4, 3, |x, y| [x as f32, y as f32, 0.5]);
    imageio::write(&path, &good).unwrap();
    let before = fs::read(&path).unwrap();

    // Invalid image data (length mismatch): refused, file untouched.
    let bad = Image {
        width: 4,
        height: 3,
        data: vec![[1.0; 3]; 5],
    };
    let err = imageio::write(&path, &bad).unwrap_err();
    assert!(err.to_string().contains("keep.exr"), "{err}");
    assert_eq!(fs::read(&path).unwrap(), before);

    // Unknown extension: an error naming the path, nothing created.
    let txt = dir.path().join("keep.txt");
    let err = imageio::write(&txt, &good).unwrap_err();
    assert!(matches!(err, ImageError::UnknownExtension { .. }));
    assert!(err.to_string().contains("keep.txt"), "{err}");
    assert!(!txt.exists());

    // Missing directory: not created, the error names it.
    let nested = dir.path().join("no_such_dir").join("x.png");
    let err = imageio::write(&nested, &good).unwrap_err().to_string();
    assert!(
        err.contains("no_such_dir") && err.contains("does not exist"),
        "{err}"
    );
    assert!(!dir.path().join("no_such_dir").exists());

    // A failure after the temporary file was written: the destination is a non-empty directory,
    // so the final rename fails. The directory and its content survive, no temporary remains.
    let blocker = dir.path().join("blocked.png");
    fs::create_dir(&blocker).unwrap();
    fs::write(blocker.join("inside"), b"x").unwrap();
    let err = imageio::write(&blocker, &good).unwrap_err().to_string();
    assert!(err.contains("blocked.png"), "{err}");
    assert_eq!(fs::read(blocker.join("inside")).unwrap(), b"x");

    // A successful overwrite replaces the content and keeps the permissions; no temporary
    // files are left behind.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        fs::set_permissions(&path, fs::Permissions::from_mode(0o640)).unwrap();
    }
    let other = Image::filled(4, 3, [0.25; 3]);
    imageio::write(&path, &other).unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = fs::metadata(&path).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o640);
    }
    assert_eq!(imageio::read(&path).unwrap(), other);
    assert_eq!(only_entry(dir.path()), vec!["blocked.png", "keep.exr"]);
}

#[test]
fn read_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.exr");
    let err = imageio::read(&missing).unwrap_err().to_string();
    assert!(err.contains("missing.exr"), "{err}");
    for name in ["junk.exr", "junk.png", "junk.pfm"] {
        let p = dir.path().join(name);
        fs::write(&p, b"this is not an image").unwrap();
        let err = imageio::read(&p).unwrap_err().to_string();
        assert!(err.contains(name), "{err}");
    }
    let err = imageio::read(&dir.path().join("x.jpg"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("x.jpg") && err.contains("extension"), "{err}");
}

/// The film's mean and one-sample variance from sums (`film::mean_and_variance`, the one
/// implementation both renderers and merge use) match a two-pass computation in f64.
#[test]
fn mean_and_variance_from_sums_match_two_passes() {
    let n = 37u32;
    let mut rng = Rng::new(7);
    for pixel in 0..20 {
        let xs: Vec<[f32; 3]> = (0..n)
            .map(|_| [0, 1, 2].map(|c| (pixel as f64 + c as f64 + rng.normal()) as f32))
            .collect();
        let mut sums = [0.0f64; 6];
        for x in &xs {
            for (s, v) in sums.iter_mut().zip(film::sample_sums(*x)) {
                *s += v;
            }
        }
        let (m, v) =
            film::mean_and_variance([sums[0], sums[1], sums[2]], [sums[3], sums[4], sums[5]], n);
        for c in 0..3 {
            let mean = xs.iter().map(|x| x[c] as f64).sum::<f64>() / n as f64;
            let var = xs.iter().map(|x| (x[c] as f64 - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
            assert!((m[c] as f64 - mean).abs() < 1e-6 * mean.abs().max(1.0));
            assert!(
                (v[c] as f64 - var).abs() < 1e-4 * var.max(1.0),
                "{} vs {var}",
                v[c]
            );
        }
    }
    // One sample: variance 0; no samples: mean 0.
    assert_eq!(
        film::mean_and_variance([2.0; 3], [4.0; 3], 1),
        ([2.0; 3], [0.0; 3])
    );
    assert_eq!(film::mean_and_variance([0.0; 3], [0.0; 3], 0).0, [0.0; 3]);
}

#[test]
fn mse_and_relmse_closed_forms() {
    let (w, h) = (16, 8);
    let reference = Image::filled(w, h, [0.5, 2.0, 0.0]);
    let test = reference.map(|p| p.map(|v| v + 0.25));
    let d2 = 0.0625f64;
    let expected_rel = (d2 / 0.51f64.powi(2) + d2 / 2.01f64.powi(2) + d2 / 0.01f64.powi(2)) / 3.0;
    assert!((metrics::mse(&test, &reference).unwrap() - d2).abs() < 1e-15);
    assert!((metrics::rmse(&test, &reference).unwrap() - 0.25).abs() < 1e-15);
    let rel = metrics::relmse(&test, &reference).unwrap();
    assert!(
        (rel - expected_rel).abs() < 1e-9 * expected_rel,
        "{rel} vs {expected_rel}"
    );

    // A non-finite pixel-channel is skipped but still counted in the divisor (pbrt-v4).
    let mut with_nan = test.clone();
    with_nan.data[3][0] = f32::NAN;
    let n = (3 * w * h) as f64;
    let expected = expected_rel - d2 / 0.51f64.powi(2) / n;
    let rel = metrics::relmse(&with_nan, &reference).unwrap();
    assert!(
        (rel - expected).abs() < 1e-9 * expected,
        "{rel} vs {expected}"
    );

    let report = metrics::diff(&with_nan, &reference).unwrap();
    assert_eq!(report.nonfinite_test, 1);
    assert_eq!((report.worst_pixels[0].x, report.worst_pixels[0].y), (3, 0));
    assert!((report.max_abs - 0.25).abs() < 1e-12);
    assert!((report.mean_test[1] - 2.25).abs() < 1e-12);

    let small = Image::new(4, 4);
    let err = metrics::diff(&small, &reference).unwrap_err();
    assert!(matches!(err, MetricsError::SizeMismatch { .. }));
    assert!(
        err.to_string().contains("4x4") && err.to_string().contains("16x8"),
        "{err}"
    );
}

#[test]
fn flip_is_zero_for_identical_images_and_grows_with_noise() {
    let (w, h) = (96, 64);
    let base = Image::from_fn(w, h, |x, y| {
        let v = 0.05 + 0.6 * (x as f32 / w as f32) * (0.5 + 0.5 * (y as f32 / h as f32));
        [v, 0.8 * v, 0.3]
    });
    assert_eq!(metrics::flip_mean(&base, &base).unwrap(), 0.0);
    let map = metrics::error_map(&base, &base).unwrap();
    assert_eq!((map.width, map.height), (w, h));
    assert!(
        map.data.iter().all(|p| *p == map.data[0]),
        "uniform map for zero error"
    );

    let mut rng = Rng::new(11);
    let mut flips = Vec::new();
    for sigma in [0.01f32, 0.05, 0.2] {
        let noisy = base.map(|p| p.map(|v| v + sigma * rng.normal() as f32));
        let report = metrics::diff(&noisy, &base).unwrap();
        let text = report.to_string();
        assert!(text.contains("FLIP") && text.contains("relMSE"));
        flips.push(report.flip_mean);
    }
    assert!(
        flips[0] > 0.0 && flips[0] < flips[1] && flips[1] < flips[2],
        "{flips:?}"
    );
    assert!(flips[2] < 1.0);
    // The error map brightens where the error is.
    let mut half = base.clone();
    for y in 0..h {
        for x in 0..w / 2 {
            half.set(x, y, [1.0, 0.0, 1.0]);
        }
    }
    let map = metrics::error_map(&half, &base).unwrap();
    let lum = |p: [f32; 3]| p[0] + p[1] + p[2];
    assert!(lum(map.get(10, 30)) > lum(map.get(80, 30)) + 0.1);
    // Tiny images work too.
    let t = Image::filled(2, 1, [0.5; 3]);
    assert!(metrics::flip_mean(&t, &Image::filled(2, 1, [0.0; 3])).unwrap() > 0.0);
}

#[test]
fn fraction_within_counts_and_ranks_disagreements() {
    let reference = Image::from_fn(10, 10, |x, y| [x as f32 + 1.0, y as f32, 0.0]);
    let mut test = reference.clone();
    // Within tolerance: 0.5% relative on the value 6 of pixel (5, 0).
    test.data[5][0] = 6.0 * 1.005;
    // Outside: 5% relative, and 10x the tolerance.
    test.set(2, 3, [3.0 * 1.05, 3.0, 0.0]);
    test.set(7, 7, [8.0 * 1.10, 7.0, 0.0]);
    // NaN never agrees; zero vs small value within the absolute floor agrees.
    test.set(9, 9, [10.0, f32::NAN, 0.0]);
    test.set(0, 0, [1.0, 0.0, 5e-4]);
    let a = metrics::fraction_within(&test, &reference, 0.01, 1e-3).unwrap();
    assert_eq!(a.disagreeing_channels, 3);
    assert!((a.channel_fraction - (1.0 - 3.0 / 300.0)).abs() < 1e-12);
    assert!((a.pixel_fraction - 0.97).abs() < 1e-12);
    let order: Vec<(u32, u32)> = a.worst.iter().take(3).map(|p| (p.x, p.y)).collect();
    assert_eq!(order, vec![(9, 9), (7, 7), (2, 3)]);
    assert!(a.worst[3].score <= 1.0);
    assert!(metrics::fraction_within(&test, &reference, -1.0, 0.0).is_err());
    assert!(metrics::fraction_within(&test, &Image::new(3, 3), 0.01, 0.0).is_err());
}

/// Per-pixel mean and sample variance of `n` exponential samples with mean mu(x, y) + shift
/// (shift only inside `region`), from per-pixel sums as a film keeps them. Exponential: skewed
/// like Monte Carlo radiance.
fn exponential_render(
    seed: u64,
    w: u32,
    h: u32,
    n: u64,
    mu: impl Fn(u32, u32) -> f64,
    shift: impl Fn(u32, u32) -> f64,
) -> (Image, Image) {
    let mut rng = Rng::new(seed);
    let mut sums = vec![[0.0f64; 6]; (w * h) as usize];
    for _ in 0..n {
        for y in 0..h {
            for x in 0..w {
                let l = [0, 1, 2].map(|c| {
                    let mean = mu(x, y) * (1.0 + 0.3 * c as f64);
                    (-mean * (1.0 - rng.uniform()).ln() + shift(x, y) * (1.0 + 0.3 * c as f64))
                        as f32
                });
                let s = &mut sums[(y * w + x) as usize];
                for (a, v) in s.iter_mut().zip(film::sample_sums(l)) {
                    *a += v;
                }
            }
        }
    }
    let mut mean = Image::new(w, h);
    let mut variance = Image::new(w, h);
    for (i, s) in sums.iter().enumerate() {
        let (m, v) = film::mean_and_variance([s[0], s[1], s[2]], [s[3], s[4], s[5]], n as u32);
        mean.data[i] = m;
        variance.data[i] = v;
    }
    (mean, variance)
}

#[test]
fn z_test_accepts_equal_means_and_rejects_shifted_regions() {
    let (w, h, na, nb) = (40u32, 32u32, 64u64, 256u64);
    let mu = |x: u32, y: u32| 0.2 + 0.05 * x as f64 + 0.02 * y as f64;
    let none = |_: u32, _: u32| 0.0;

    // H0: independent renders of the same means pass for the large majority of fixed seeds,
    // with either variance model.
    let pooled = ZTestOptions {
        variance: VarianceModel::Pooled,
        ..ZTestOptions::default()
    };
    let (mut welch_passes, mut pooled_passes) = (0, 0);
    let mut min_pass_fraction: f64 = 1.0;
    for seed in 0..8u64 {
        let (ma, va) = exponential_render(2 * seed + 1, w, h, na, mu, none);
        let (mb, vb) = exponential_render(2 * seed + 2, w, h, nb, mu, none);
        let r = metrics::z_test_with(&ma, &va, na, &mb, &vb, nb, &ZTestOptions::at_alpha(0.01))
            .unwrap();
        println!("seed {seed} Welch: {r}");
        welch_passes += r.pass as usize;
        min_pass_fraction = min_pass_fraction.min(r.pass_fraction);
        let r = metrics::z_test_with(&ma, &va, na, &mb, &vb, nb, &pooled).unwrap();
        println!("seed {seed} pooled: {r}");
        pooled_passes += r.pass as usize;
        // Pooled variances keep the mean of z near 0 (Welch is skewed negative here, see
        // `VarianceModel`); the bound is ~5 standard errors sqrt(1/N).
        assert!(r.mean_z.abs() < 0.08, "seed {seed}: {r}");
    }
    assert!(
        welch_passes >= 7,
        "only {welch_passes}/8 seeds pass (Welch)"
    );
    assert!(
        pooled_passes >= 7,
        "only {pooled_passes}/8 seeds pass (pooled)"
    );
    assert!(min_pass_fraction > 0.997);

    // A region (8x8 of 40x32, 5% of the image) shifted by 3 standard errors of the difference.
    let (ma0, va0) = exponential_render(101, w, h, na, mu, none);
    let (mb, vb) = exponential_render(102, w, h, nb, mu, none);
    let region = |x: u32, y: u32| (10..18).contains(&x) && (4..12).contains(&y);
    let se = |x: u32, y: u32| mu(x, y) * (1.0 / na as f64 + 1.0 / nb as f64).sqrt();
    let shift3 = |x: u32, y: u32| if region(x, y) { 3.0 * se(x, y) } else { 0.0 };
    let (ma, va) = exponential_render(101, w, h, na, mu, shift3);
    let r = metrics::z_test_with(&ma, &va, na, &mb, &vb, nb, &pooled).unwrap();
    assert!(!r.pass && !r.excess_rule_pass, "3-SE shift, pooled:\n{r}");
    let r =
        metrics::z_test_with(&ma, &va, na, &mb, &vb, nb, &ZTestOptions::at_alpha(0.01)).unwrap();
    println!("3-SE shift, Welch: {r}");
    assert!(!r.pass, "3-SE shift over a region must fail:\n{r}");
    assert!(!r.excess_rule_pass);
    assert!(
        r.rejected_pixels as f64 > 3.0 * r.expected_rejected_pixels,
        "{r}"
    );
    // The worst pixel-channels lie in the shifted region.
    assert!(r.worst.iter().all(|o| region(o.x, o.y)), "{r}");
    // The same seeds without the shift pass.
    let r0 =
        metrics::z_test_with(&ma0, &va0, na, &mb, &vb, nb, &ZTestOptions::at_alpha(0.01)).unwrap();
    assert!(r0.pass, "{r0}");

    // A gross local error (8 SE on 8x8) fails Mitsuba's outlier rule as well.
    let shift8 = |x: u32, y: u32| if region(x, y) { 8.0 * se(x, y) } else { 0.0 };
    let (ma, va) = exponential_render(101, w, h, na, mu, shift8);
    let r =
        metrics::z_test_with(&ma, &va, na, &mb, &vb, nb, &ZTestOptions::at_alpha(0.01)).unwrap();
    println!("8-SE shift, Welch: {r}");
    assert!(!r.outlier_rule_pass && !r.pass, "{r}");
    assert!(r.min_p < r.alpha_sidak);
    // With the excess rule disabled the verdict is Mitsuba's alone.
    let opts = ZTestOptions {
        excess_test: false,
        ..ZTestOptions::default()
    };
    let r = metrics::z_test_with(&ma0, &va0, na, &mb, &vb, nb, &opts).unwrap();
    assert!(r.pass && r.excess_rule_pass);

    // The p-value map is in [0, 1] and has the image size.
    assert_eq!((r.p_map.width, r.p_map.height), (w, h));
    assert!(r
        .p_map
        .data
        .iter()
        .flatten()
        .all(|p| (0.0..=1.0).contains(p)));
}

#[test]
fn z_test_zero_variance_and_bad_inputs() {
    let (w, h) = (8, 8);
    let zero = Image::new(w, h);
    let a = Image::filled(w, h, [0.5, 0.0, 2.0]);
    // Identical, zero variance: pass with p = 1 everywhere.
    let r =
        metrics::z_test_with(&a, &zero, 16, &a, &zero, 16, &ZTestOptions::at_alpha(0.01)).unwrap();
    assert!(r.pass && r.min_p == 1.0, "{r}");
    // Zero variance, a difference at float rounding level: pass.
    let b = a.map(|p| p.map(|v| v * (1.0 + 2e-7)));
    assert!(
        metrics::z_test_with(&a, &zero, 16, &b, &zero, 16, &ZTestOptions::at_alpha(0.01))
            .unwrap()
            .pass
    );
    // Zero variance, a real difference in one pixel: fail.
    let mut c = a.clone();
    c.set(3, 4, [0.5, 0.001, 2.0]);
    let r =
        metrics::z_test_with(&a, &zero, 16, &c, &zero, 16, &ZTestOptions::at_alpha(0.01)).unwrap();
    assert!(!r.pass && r.outliers == 1, "{r}");
    assert_eq!((r.worst[0].x, r.worst[0].y, r.worst[0].channel), (3, 4, 1));
    // A NaN mean fails.
    let mut d = a.clone();
    d.data[0][2] = f32::NAN;
    let r =
        metrics::z_test_with(&a, &zero, 16, &d, &zero, 16, &ZTestOptions::at_alpha(0.01)).unwrap();
    assert!(!r.pass && r.nonfinite == 1);
    // Bad inputs are errors, not panics.
    assert!(
        metrics::z_test_with(&a, &zero, 0, &a, &zero, 16, &ZTestOptions::at_alpha(0.01)).is_err()
    );
    assert!(
        metrics::z_test_with(&a, &zero, 16, &a, &zero, 16, &ZTestOptions::at_alpha(1.5)).is_err()
    );
    let err = metrics::z_test_with(
        &a,
        &Image::new(4, 4),
        16,
        &a,
        &zero,
        16,
        &ZTestOptions::at_alpha(0.01),
    )
    .unwrap_err();
    assert!(err.to_string().contains("var_a"), "{err}");
}

#[test]
fn binomial_tail_matches_direct_sum() {
    fn direct(n: u64, q: f64, k: u64) -> f64 {
        // Exact pmf by the multiplicative recurrence from j = 0.
        let mut pmf = (1.0 - q).powi(n as i32);
        let mut tail = 0.0;
        for j in 0..=n {
            if j >= k {
                tail += pmf;
            }
            pmf *= (n - j) as f64 / (j + 1) as f64 * q / (1.0 - q);
        }
        tail
    }
    for (n, q, k) in [
        (50, 0.01, 0),
        (50, 0.01, 1),
        (50, 0.01, 3),
        (200, 0.05, 10),
        (200, 0.05, 25),
        (300, 0.1, 2),
    ] {
        let a = metrics::binomial_upper_tail(n, q, k);
        let b = direct(n, q, k);
        assert!(
            (a - b).abs() <= 1e-10 + 1e-9 * b,
            "n {n} q {q} k {k}: {a} vs {b}"
        );
    }
    assert!(metrics::binomial_upper_tail(100_000, 0.01, 2_000) < 1e-100);
}

/// A synthetic stratified render: each pixel's value is the mean of `k` batches, each a
/// jittered pattern of `p` samples of f(u) = mu · (1 + bias) · 2u (mean mu · (1 + bias)), so
/// that, as with a path tracer's stratified sampler, the variance of one sample (mu² / 3)
/// vastly overstates the variance of the pixel's estimate (mu² / (3 p³ k)). Returns the mean,
/// the one-sample variance of all k·p samples, and the variance of the mean from the k batch
/// means.
fn stratified_render(
    seed: u64,
    w: u32,
    h: u32,
    (k, p): (u32, u32),
    mu: impl Fn(u32, u32) -> f64,
    bias: f64,
) -> (Image, Image, Image) {
    let mut rng = Rng::new(seed);
    let (mut mean, mut one, mut of_mean) = (Image::new(w, h), Image::new(w, h), Image::new(w, h));
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            for c in 0..3 {
                let m = mu(x, y) * (1.0 + 0.3 * c as f64) * (1.0 + bias);
                let mut sums = [0.0f64; 6];
                let mut batch_means = Vec::with_capacity(k as usize);
                for _ in 0..k {
                    let mut s = 0.0;
                    for j in 0..p {
                        let u = (j as f64 + rng.uniform()) / p as f64;
                        let v = m * 2.0 * u;
                        s += v;
                        let add = film::sample_sums([v as f32, 0.0, 0.0]);
                        sums[0] += add[0];
                        sums[3] += add[3];
                    }
                    batch_means.push(s / p as f64);
                }
                let n = k * p;
                let (mm, vv) = film::mean_and_variance([sums[0], 0.0, 0.0], [sums[3], 0.0, 0.0], n);
                mean.data[i][c] = mm[0];
                one.data[i][c] = vv[0];
                let bm = batch_means.iter().sum::<f64>() / k as f64;
                let s2 = batch_means.iter().map(|b| (b - bm).powi(2)).sum::<f64>() / (k - 1) as f64;
                of_mean.data[i][c] = (s2 / k as f64) as f32;
            }
        }
    }
    (mean, one, of_mean)
}

/// Over many seeds of unbiased pairs the whole verdict (pixel rules and blocks) fails at most
/// about alpha of the time, with independent samples and the one-sample variance (exponential
/// samples: skewed, as radiance is) and with stratified samples and the batch-means variance;
/// and the stratified estimator's one-sample variance is so much larger than its real error
/// that the test hardly ever fails (valid, but blind).
#[test]
fn z_test_false_alarms_stay_under_alpha_over_many_seeds() {
    let (w, h, alpha, pairs) = (24u32, 24u32, 0.05, 120u64);
    let mu = |x: u32, y: u32| 0.2 + 0.05 * x as f64 + 0.02 * y as f64;
    let none = |_: u32, _: u32| 0.0;
    let opts = ZTestOptions {
        variance: VarianceModel::Pooled,
        ..ZTestOptions::at_alpha(alpha)
    };
    let (mut independent, mut batches, mut batch_min_adjusted) = (0, 0, Vec::new());
    for seed in 0..pairs {
        let (ma, va) = exponential_render(1000 + 2 * seed, w, h, 64, mu, none);
        let (mb, vb) = exponential_render(1001 + 2 * seed, w, h, 64, mu, none);
        let r = metrics::z_test_with(&ma, &va, 64, &mb, &vb, 64, &opts).unwrap();
        independent += !r.pass as usize;
        let (ma, _, wa) = stratified_render(5000 + 2 * seed, w, h, (8, 8), mu, 0.0);
        let (mb, _, wb) = stratified_render(5001 + 2 * seed, w, h, (8, 8), mu, 0.0);
        let side = |mean, variance| metrics::ZSide {
            mean,
            variance: metrics::SideVariance::BatchMeans {
                variance,
                batches: 8,
            },
        };
        let r = metrics::z_test(&side(&ma, &wa), &side(&mb, &wb), &opts).unwrap();
        batches += !r.pass as usize;
        batch_min_adjusted.push(r.blocks.unwrap().min_adjusted_p);
    }
    // P(Binomial(120, 0.05) >= 13) = 2.1 %: a calibrated test passes this nearly always; one
    // that alarms at twice alpha fails it nearly always.
    println!("false alarms in {pairs} pairs: independent {independent}, stratified with batches {batches}");
    assert!(independent <= 12, "{independent} of {pairs}");
    assert!(batches <= 12, "{batches} of {pairs}");
    // The block family's smallest adjusted p is a p-value of its own: about uniform, not
    // piled up near 0 (fewer than 10 % of pairs below 0.1, with slack).
    let low = batch_min_adjusted.iter().filter(|&&p| p < 0.1).count();
    assert!(low <= 20, "{low} of {pairs} below 0.1");
}

/// A 1 % bias of every pixel of a stratified render is far under one pixel's noise; the blocks
/// see it when each side gives the variance of its batch means, and do not when the variance
/// of one sample stands in (it overstates the error of a stratified mean by p²: here 64×).
#[test]
fn z_test_blocks_see_a_small_bias_of_a_stratified_render_with_batch_variances() {
    let (w, h) = (24u32, 24u32);
    let mu = |x: u32, y: u32| 0.2 + 0.05 * x as f64 + 0.02 * y as f64;
    let (ma, oa, wa) = stratified_render(77, w, h, (8, 8), mu, 0.01);
    let (mb, ob, wb) = stratified_render(78, w, h, (8, 8), mu, 0.0);
    let batches = |mean, variance| metrics::ZSide {
        mean,
        variance: metrics::SideVariance::BatchMeans {
            variance,
            batches: 8,
        },
    };
    let r = metrics::z_test(
        &batches(&ma, &wa),
        &batches(&mb, &wb),
        &ZTestOptions::at_alpha(0.01),
    )
    .unwrap();
    println!("{r}");
    let b = r.blocks.as_ref().unwrap();
    assert!(!r.pass && !b.pass, "{r}");
    assert!(
        r.outlier_rule_pass && r.excess_rule_pass,
        "the pixels alone: {r}"
    );
    // The whole image: detected, darker-or-brighter right, and the report says it could.
    let whole = b.scales.last().unwrap();
    assert!(whole.whole_image && whole.rejected > 0, "{r}");
    assert!(whole.worst.unwrap().t > 0.0);
    assert!(whole.detectable.unwrap().bias < 0.01, "{r}");
    let r =
        metrics::z_test_with(&ma, &oa, 64, &mb, &ob, 64, &ZTestOptions::at_alpha(0.01)).unwrap();
    println!("{r}");
    assert!(r.pass, "one-sample variances: {r}");
    assert!(
        r.blocks
            .unwrap()
            .scales
            .last()
            .unwrap()
            .detectable
            .unwrap()
            .bias
            > 0.01,
        "the one-sample variance cannot see 1 %"
    );
}
