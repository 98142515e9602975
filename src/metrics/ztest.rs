//! The per-pixel two-sample statistical test of means ([`z_test_with`]): Mitsuba 3
//! `test_renders.py` style, made two-sample; the verdict rule is documented on
//! [`ZTestOptions`].

use std::fmt;

use super::{check_pair, top_k, MetricsError, WORST_COUNT};
use crate::imageio::Image;

/// How the variance of the difference of means is estimated in [`z_test_with`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VarianceModel {
    /// Welch: v_a/n_a + v_b/n_b. Valid when the two sides have different per-sample variances
    /// (e.g. different sampling strategies), but anti-conservative for skewed samples with
    /// unequal n, because a low sample mean comes with a low sample variance: measured on
    /// exponential samples, n = 64 vs 256 rejects 2.1x the nominal rate at p < 0.0033 and 33x
    /// at p < 7e-6; 10%-firefly-like samples at n = 256 vs 1024 reject 15x / 52x.
    Welch,
    /// Pooled (Student): v_p (1/n_a + 1/n_b) with v_p = ((n_a−1) v_a + (n_b−1) v_b) /
    /// (n_a + n_b − 2). Assumes both sides draw from the same per-sample distribution, which is
    /// the null hypothesis of "two renderers implement the same estimator" (GPU vs CPU, or two
    /// seeds). Much better calibrated there: the same cases reject 1.15x / 7x and 1.5x / 8x.
    /// Not for an exact (zero-variance) reference: use Welch there.
    Pooled,
}

/// Settings of the per-pixel two-sample test of means, and its verdict rule.
///
/// For every pixel-channel the statistic is z = (m_a − m_b) / sqrt(V + f), with m the per-pixel
/// means, V the variance of the difference of the means from the sample variances of ONE sample
/// v_a, v_b and the sample counts n_a, n_b (see [`VarianceModel`]; Welch by default:
/// V = v_a/n_a + v_b/n_b), and the floor f = (rel_floor · max(|m_a|, |m_b|))² + abs_floor².
/// Its two-sided p-value under the normal approximation is p = erfc(|z| / √2). Pixel-channels
/// where any input is NaN/inf get p = 0; negative variances count as 0.
///
/// The floor f handles zero-variance pixels: equal means (e.g. both black) give z = 0 and pass;
/// different means with zero variance fail unless the difference is within a few sqrt(f), i.e.
/// float rounding (1e-5 relative or 1e-6 absolute with the defaults). It is negligible wherever
/// the variance is not tiny. A reference known exactly (analytic) can be passed with a zero
/// variance image.
///
/// **Verdict.** Mitsuba 3's `test_renders.py` Šidák-corrects α over the N pixel-channels,
/// α_s = 1 − (1 − α)^(1/N), and passes when at least 99.75% of pixel-channels have p ≥ α_s.
/// The two do not fit together: Šidák already makes P(any p < α_s) = α for independent
/// Gaussian tests, so a correct renderer has about α (≪ 1) such "outliers" and the 0.25%
/// allowance only absorbs non-Gaussian tails (fireflies, small n). Combined they see only gross
/// errors: at 256x256, a bias of 3 standard errors over 6% of the image puts 0.7% of those
/// pixel-channels below α_s (z > 5.45), 0.04% of the image, and passes. So the verdict here
/// fails when EITHER of two rules fails:
///
/// 1. **Outlier rule (Mitsuba's):** the number of pixel-channels with p < α_s (non-finite
///    included) must be at most `floor(max_outlier_fraction · N)`. Catches strong local errors
///    and any NaN/inf beyond the allowance.
/// 2. **Excess rule** (if `excess_test`): a pixel is "rejected" when its smallest channel
///    p-value is below α/3 (Bonferroni over its 3 correlated channels, so under H0 with exact
///    p-values P(rejected) <= α whatever the channel correlation). Because the normal
///    approximation is anti-conservative for Monte Carlo samples (see [`VarianceModel`]), the
///    rule tolerates a rejection rate up to κ·α, κ = `excess_tolerance` (default 3), and fails
///    when the count K of rejected pixels among P is significant against that:
///    P(Binomial(P, κα) >= K) < α. Catches moderate bias over a region: a 3-SE shift rejects
///    ~90% of the shifted pixels, so it fails once the region exceeds a few percent of the image
///    (and a 1-SE bias over the whole image, ~6% of pixels rejected, fails too on large images).
///
/// Under H0 with Gaussian means the false-failure probability is at most about 2α. Sample
/// counts should be large enough for the normal approximation on both sides (n >= 64 with
/// smooth integrands, more with fireflies); with Welch, also keep n_a and n_b similar or use
/// [`VarianceModel::Pooled`] when both sides run the same estimator.
#[derive(Clone, Debug)]
pub struct ZTestOptions {
    /// Family-wise significance level, in (0, 1). Default 0.01 (Mitsuba).
    pub alpha: f64,
    /// Variance of the difference of means. Default [`VarianceModel::Welch`].
    pub variance: VarianceModel,
    /// Largest tolerated fraction of pixel-channels below the Šidák level. Default 0.0025
    /// (Mitsuba's 99.75% pass rule).
    pub max_outlier_fraction: f64,
    /// Whether the excess rule (2) is part of the verdict. Default true.
    pub excess_test: bool,
    /// κ of the excess rule, >= 1. Default 3.
    pub excess_tolerance: f64,
    /// Relative part of the variance floor. Default 1e-5.
    pub rel_floor: f64,
    /// Absolute part of the variance floor. Default 1e-6.
    pub abs_floor: f64,
}

impl Default for ZTestOptions {
    fn default() -> Self {
        ZTestOptions {
            alpha: 0.01,
            variance: VarianceModel::Welch,
            max_outlier_fraction: 0.0025,
            excess_test: true,
            excess_tolerance: 3.0,
            rel_floor: 1e-5,
            abs_floor: 1e-6,
        }
    }
}

/// One entry of the most significant pixel-channels of a [`ZTestReport`].
#[derive(Clone, Debug, PartialEq)]
pub struct ZOutlier {
    pub x: u32,
    pub y: u32,
    pub channel: usize,
    pub mean_a: f32,
    pub mean_b: f32,
    pub z: f64,
    pub p: f64,
}

/// Result of [`z_test_with`]; see [`ZTestOptions`] for the rule.
#[derive(Clone, Debug)]
pub struct ZTestReport {
    pub width: u32,
    pub height: u32,
    /// Number of pixel-channels tested, N = 3 · pixels.
    pub tests: usize,
    pub alpha: f64,
    /// Šidák-corrected per-test level 1 − (1 − α)^(1/N).
    pub alpha_sidak: f64,
    /// Pixel-channels with p < α_s (non-finite included).
    pub outliers: usize,
    /// Largest tolerated number of outliers.
    pub max_outliers: usize,
    /// Fraction of pixel-channels with p >= α_s.
    pub pass_fraction: f64,
    /// Pixel-channels with a NaN/inf mean or variance.
    pub nonfinite: usize,
    /// Smallest p-value.
    pub min_p: f64,
    /// Mean of the finite z values (a global bias shows as a mean far from 0; under H0 with
    /// Gaussian means its standard error is at most sqrt(3/N); right-skewed samples with Welch
    /// variances bias it negative when side a has fewer samples than side b).
    pub mean_z: f64,
    /// Pixels whose smallest channel p-value is below α/3, and the H0 expectation bound α·P.
    pub rejected_pixels: usize,
    pub expected_rejected_pixels: f64,
    /// P(Binomial(P, κα) >= rejected_pixels), κ = `excess_tolerance`.
    pub excess_p: f64,
    pub excess_tolerance: f64,
    pub variance: VarianceModel,
    pub outlier_rule_pass: bool,
    pub excess_rule_pass: bool,
    /// Overall verdict.
    pub pass: bool,
    /// Per pixel-channel p-values.
    pub p_map: Image,
    /// Per pixel-channel signed z (NaN where an input is not finite).
    pub z_map: Image,
    /// The [`WORST_COUNT`] pixel-channels with the smallest p-values (largest |z|).
    pub worst: Vec<ZOutlier>,
}

impl fmt::Display for ZTestReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "z-test {}: {}x{}, {} pixel-channels, alpha {}, Sidak level {:.3e}",
            if self.pass { "PASS" } else { "FAIL" },
            self.width,
            self.height,
            self.tests,
            self.alpha,
            self.alpha_sidak
        )?;
        writeln!(
            f,
            "  outlier rule {}: {} below Sidak level (allowed {}), {:.4}% pass, {} non-finite, min p {:.3e}",
            if self.outlier_rule_pass { "pass" } else { "FAIL" },
            self.outliers,
            self.max_outliers,
            100.0 * self.pass_fraction,
            self.nonfinite,
            self.min_p
        )?;
        writeln!(
            f,
            "  excess rule {}: {} pixels rejected at alpha/3 per channel (H0 bound {:.1}), tail p {:.3e} (tolerance x{})",
            if self.excess_rule_pass { "pass" } else { "FAIL" },
            self.rejected_pixels,
            self.expected_rejected_pixels,
            self.excess_p,
            self.excess_tolerance
        )?;
        writeln!(f, "  mean z {:+.4}", self.mean_z)?;
        for o in &self.worst {
            writeln!(
                f,
                "  ({}, {}) ch {}: a {:.6} b {:.6} z {:+.3} p {:.3e}",
                o.x, o.y, o.channel, o.mean_a, o.mean_b, o.z, o.p
            )?;
        }
        Ok(())
    }
}

/// Per-pixel two-sample test of means: `var_*` are per-pixel sample variances of one sample,
/// `n_*` the samples per pixel ([`ZTestOptions::at_alpha`] for the default options at one
/// significance).
pub fn z_test_with(
    mean_a: &Image,
    var_a: &Image,
    n_a: u64,
    mean_b: &Image,
    var_b: &Image,
    n_b: u64,
    opts: &ZTestOptions,
) -> Result<ZTestReport, MetricsError> {
    check_pair("mean_a", mean_a, "var_a", var_a)?;
    check_pair("mean_a", mean_a, "mean_b", mean_b)?;
    check_pair("mean_b", mean_b, "var_b", var_b)?;
    for (name, n) in [("n_a", n_a), ("n_b", n_b)] {
        if n == 0 {
            return Err(MetricsError::InvalidParameter {
                name,
                value: 0.0,
                reason: "the sample count must be at least 1",
            });
        }
    }
    opts.validate()?;

    let pixels = mean_a.data.len();
    let tests = 3 * pixels;
    let alpha = opts.alpha;
    // 1 − (1 − α)^(1/N), computed without cancellation.
    let alpha_sidak = -libm::expm1(libm::log1p(-alpha) / tests as f64);
    let model = ChannelTest::new(opts, n_a, n_b);
    let mut acc = Tally::default();
    let mut p_map = Vec::with_capacity(pixels);
    let mut z_map = Vec::with_capacity(pixels);
    for i in 0..pixels {
        let (ma, va, mb, vb) = (mean_a.data[i], var_a.data[i], mean_b.data[i], var_b.data[i]);
        let mut pp = [1.0f32; 3];
        let mut zz = [0.0f32; 3];
        let mut pixel_min_p = 1.0f64;
        for c in 0..3 {
            let (z, p) = model.z_and_p(ma[c] as f64, va[c] as f64, mb[c] as f64, vb[c] as f64);
            acc.add(z, p, alpha_sidak);
            pixel_min_p = pixel_min_p.min(p);
            pp[c] = p as f32;
            zz[c] = z as f32;
        }
        if pixel_min_p < alpha / 3.0 {
            acc.rejected_pixels += 1;
        }
        p_map.push(pp);
        z_map.push(zz);
    }

    let max_outliers = (opts.max_outlier_fraction * tests as f64).floor() as usize;
    let outlier_rule_pass = acc.outliers <= max_outliers;
    let excess_p = binomial_upper_tail(
        pixels as u64,
        (opts.excess_tolerance * alpha).min(1.0),
        acc.rejected_pixels as u64,
    );
    let excess_rule_pass = !opts.excess_test || excess_p >= alpha;
    let (w, h) = (mean_a.width, mean_a.height);
    let image = |data| Image {
        width: w,
        height: h,
        data,
    };
    let worst = worst_outliers(mean_a, mean_b, &z_map, &p_map);
    Ok(ZTestReport {
        width: w,
        height: h,
        tests,
        alpha,
        alpha_sidak,
        outliers: acc.outliers,
        max_outliers,
        pass_fraction: 1.0 - acc.outliers as f64 / tests as f64,
        nonfinite: acc.nonfinite,
        min_p: acc.min_p,
        mean_z: if acc.z_count > 0 {
            acc.z_sum / acc.z_count as f64
        } else {
            0.0
        },
        rejected_pixels: acc.rejected_pixels,
        expected_rejected_pixels: alpha * pixels as f64,
        excess_p,
        excess_tolerance: opts.excess_tolerance,
        variance: opts.variance,
        outlier_rule_pass,
        excess_rule_pass,
        pass: outlier_rule_pass && excess_rule_pass,
        p_map: image(p_map),
        z_map: image(z_map),
        worst,
    })
}

impl ZTestOptions {
    /// The default options with significance `alpha`.
    pub fn at_alpha(alpha: f64) -> Self {
        ZTestOptions {
            alpha,
            ..ZTestOptions::default()
        }
    }
    /// Refuses options outside their documented ranges, naming the field.
    fn validate(&self) -> Result<(), MetricsError> {
        let params = [
            (
                "alpha",
                self.alpha,
                self.alpha > 0.0 && self.alpha < 1.0,
                "must be in (0, 1)",
            ),
            (
                "max_outlier_fraction",
                self.max_outlier_fraction,
                (0.0..=1.0).contains(&self.max_outlier_fraction),
                "must be in [0, 1]",
            ),
            (
                "rel_floor",
                self.rel_floor,
                self.rel_floor.is_finite() && self.rel_floor >= 0.0,
                "must be finite and >= 0",
            ),
            (
                "abs_floor",
                self.abs_floor,
                self.abs_floor.is_finite() && self.abs_floor >= 0.0,
                "must be finite and >= 0",
            ),
            (
                "excess_tolerance",
                self.excess_tolerance,
                self.excess_tolerance.is_finite() && self.excess_tolerance >= 1.0,
                "must be finite and >= 1",
            ),
        ];
        for (name, value, ok, reason) in params {
            if !ok {
                return Err(MetricsError::InvalidParameter {
                    name,
                    value,
                    reason,
                });
            }
        }
        Ok(())
    }
}

/// The statistic of one pixel-channel: the variance model, the sample counts and the floor.
struct ChannelTest {
    variance: VarianceModel,
    na: f64,
    nb: f64,
    /// (1/n_a + 1/n_b) / (n_a + n_b − 2); 0 with one sample per side, where there is no
    /// variance estimate.
    pooled_weight: f64,
    rel_floor: f64,
    abs_floor: f64,
}

impl ChannelTest {
    fn new(opts: &ZTestOptions, n_a: u64, n_b: u64) -> Self {
        let (na, nb) = (n_a as f64, n_b as f64);
        ChannelTest {
            variance: opts.variance,
            na,
            nb,
            pooled_weight: if n_a + n_b > 2 {
                (1.0 / na + 1.0 / nb) / (na + nb - 2.0)
            } else {
                0.0
            },
            rel_floor: opts.rel_floor,
            abs_floor: opts.abs_floor,
        }
    }

    /// (z, p) of one pixel-channel; (NaN, 0) when an input is not finite.
    fn z_and_p(&self, ma: f64, va: f64, mb: f64, vb: f64) -> (f64, f64) {
        if !(ma.is_finite() && mb.is_finite() && va.is_finite() && vb.is_finite()) {
            return (f64::NAN, 0.0);
        }
        let floor = (self.rel_floor * ma.abs().max(mb.abs())).powi(2) + self.abs_floor.powi(2);
        let (va, vb) = (va.max(0.0), vb.max(0.0));
        let (na, nb) = (self.na, self.nb);
        let var = match self.variance {
            VarianceModel::Welch => va / na + vb / nb,
            VarianceModel::Pooled => self.pooled_weight * ((na - 1.0) * va + (nb - 1.0) * vb),
        } + floor;
        let d = ma - mb;
        let z = if d == 0.0 {
            0.0
        } else if var > 0.0 {
            d / var.sqrt()
        } else {
            f64::INFINITY.copysign(d)
        };
        (z, libm::erfc(z.abs() / std::f64::consts::SQRT_2))
    }
}

/// The counts the verdict is made of, summed over the pixel-channels.
struct Tally {
    outliers: usize,
    nonfinite: usize,
    rejected_pixels: usize,
    min_p: f64,
    z_sum: f64,
    z_count: usize,
}

impl Default for Tally {
    fn default() -> Self {
        Tally {
            outliers: 0,
            nonfinite: 0,
            rejected_pixels: 0,
            min_p: 1.0,
            z_sum: 0.0,
            z_count: 0,
        }
    }
}

impl Tally {
    fn add(&mut self, z: f64, p: f64, alpha_sidak: f64) {
        if z.is_nan() {
            self.nonfinite += 1;
        } else if z.is_finite() {
            self.z_sum += z;
            self.z_count += 1;
        }
        if p < alpha_sidak {
            self.outliers += 1;
        }
        self.min_p = self.min_p.min(p);
    }
}

/// The [`WORST_COUNT`] pixel-channels with the largest |z| (NaN first).
fn worst_outliers(
    mean_a: &Image,
    mean_b: &Image,
    z_map: &[[f32; 3]],
    p_map: &[[f32; 3]],
) -> Vec<ZOutlier> {
    top_k(
        z_map
            .iter()
            .flat_map(|z| z.iter())
            .map(|&z| (z as f64).abs()),
        WORST_COUNT,
    )
    .into_iter()
    .map(|(_, k)| {
        let (i, c) = (k / 3, k % 3);
        let (x, y) = mean_a.coords(i);
        ZOutlier {
            x,
            y,
            channel: c,
            mean_a: mean_a.data[i][c],
            mean_b: mean_b.data[i][c],
            z: z_map[i][c] as f64,
            p: p_map[i][c] as f64,
        }
    })
    .collect()
}

/// P(X >= k) for X ~ Binomial(n, q), 0 < q < 1, summing the pmf from k upwards in log space.
pub fn binomial_upper_tail(n: u64, q: f64, k: u64) -> f64 {
    if k == 0 {
        return 1.0;
    }
    if k > n || q <= 0.0 {
        return 0.0;
    }
    if q >= 1.0 {
        return 1.0;
    }
    let (nf, kf) = (n as f64, k as f64);
    let log_pmf = |j: f64| {
        libm::lgamma(nf + 1.0) - libm::lgamma(j + 1.0) - libm::lgamma(nf - j + 1.0)
            + j * q.ln()
            + (nf - j) * libm::log1p(-q)
    };
    let odds = q / (1.0 - q);
    let mean = nf * q;
    if kf <= mean {
        // The tail is large: 1 − P(X <= k − 1), summing the pmf downwards from k − 1, where
        // the terms decrease.
        let mut j = k - 1;
        let mut term = log_pmf(j as f64).exp();
        let mut sum = term;
        while j > 0 {
            term *= j as f64 / ((nf - j as f64 + 1.0) * odds);
            j -= 1;
            sum += term;
            if term <= sum * 1e-17 {
                break;
            }
        }
        return (1.0 - sum).clamp(0.0, 1.0);
    }
    // Above the mean the terms decrease from k upwards.
    let mut term = log_pmf(kf).exp();
    let mut sum = term;
    let mut j = k;
    while j < n && term > sum * 1e-17 {
        term *= (nf - j as f64) / (j as f64 + 1.0) * odds;
        j += 1;
        sum += term;
    }
    sum.min(1.0)
}
