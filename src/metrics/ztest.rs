//! The two-sample statistical test of means of two renders ([`z_test`], [`z_test_with`]): per
//! pixel (Mitsuba 3 `test_renders.py` style, made two-sample) and per block of pixels at several
//! scales (`blocks.rs`), under one family-wise α; the verdict rule is documented on
//! [`ZTestOptions`], where each side's variance comes from on [`SideVariance`].

use std::fmt;

use super::blocks::{self, BlockReport, Candidate, Detectable, PixelTerms, Rect};
use super::dist::{satterthwaite, t_two_sided};
use super::{check_pair, top_k, MetricsError, WORST_COUNT};
use crate::imageio::Image;

/// Where one side's variance of its pixel means comes from.
#[derive(Clone, Copy, Debug)]
pub enum SideVariance<'a> {
    /// The per-pixel variance of one sample and the samples per pixel n >= 1: the variance of
    /// the mean is v / n (n − 1 degrees of freedom). Right when a pixel's samples are
    /// independent (`--sampler independent`); a stratified or low-discrepancy render's samples
    /// are not, and v / n overstates its variance (the test is then valid but weak).
    OneSample { variance: &'a Image, spp: u64 },
    /// The variance of each pixel's mean estimated from `batches` >= 2 independent batch means
    /// (s² / K, K − 1 degrees of freedom; `render --batches K`): right for every sampler.
    BatchMeans { variance: &'a Image, batches: u32 },
}

impl SideVariance<'_> {
    fn image(&self) -> &Image {
        match self {
            SideVariance::OneSample { variance, .. }
            | SideVariance::BatchMeans { variance, .. } => variance,
        }
    }

    /// The variance of the pixel mean and its degrees of freedom, from the image's value `v`.
    fn of_mean(&self, v: f64) -> (f64, f64) {
        let v = v.max(0.0);
        match *self {
            SideVariance::OneSample { spp, .. } => (v / spp as f64, spp as f64 - 1.0),
            SideVariance::BatchMeans { batches, .. } => (v, batches as f64 - 1.0),
        }
    }

    fn source(&self) -> VarianceSource {
        match *self {
            SideVariance::OneSample { spp, .. } => VarianceSource::OneSample { spp },
            SideVariance::BatchMeans { batches, .. } => VarianceSource::BatchMeans { batches },
        }
    }
}

/// What one side's variance was, for the report.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VarianceSource {
    OneSample { spp: u64 },
    BatchMeans { batches: u32 },
}

impl VarianceSource {
    /// `one-sample` or `batches`, as the JSON names it.
    pub fn name(self) -> &'static str {
        match self {
            VarianceSource::OneSample { .. } => "one-sample",
            VarianceSource::BatchMeans { .. } => "batches",
        }
    }
}

impl fmt::Display for VarianceSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            VarianceSource::OneSample { spp } => {
                write!(f, "variance of one sample / {spp} spp")
            }
            VarianceSource::BatchMeans { batches } => {
                write!(f, "variance of the mean from {batches} batch means")
            }
        }
    }
}

/// One side of the test: its per-pixel means and where their variance comes from.
#[derive(Clone, Copy, Debug)]
pub struct ZSide<'a> {
    pub mean: &'a Image,
    pub variance: SideVariance<'a>,
}

/// How the variance of the difference of means is estimated in [`z_test`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VarianceModel {
    /// Welch: V_a + V_b, each side's variance of its mean (v/n for a one-sample variance), with
    /// the Welch–Satterthwaite degrees of freedom. Valid when the two sides have different
    /// per-sample variances (e.g. different sampling strategies), but anti-conservative per
    /// pixel for skewed samples with unequal n, because a low sample mean comes with a low
    /// sample variance: measured on exponential samples, n = 64 vs 256 rejects 2.1x the nominal
    /// rate at p < 0.0033 and 33x at p < 7e-6; 10%-firefly-like samples at n = 256 vs 1024
    /// reject 15x / 52x. The only model for batch-mean variances.
    Welch,
    /// Pooled (Student): v_p (1/n_a + 1/n_b) with v_p = ((n_a−1) v_a + (n_b−1) v_b) /
    /// (n_a + n_b − 2), n_a + n_b − 2 degrees of freedom. Assumes both sides draw from the same
    /// per-sample distribution, which is the null hypothesis of "two renderers implement the
    /// same estimator" (GPU vs CPU, or two seeds). Much better calibrated there: the same cases
    /// reject 1.15x / 7x and 1.5x / 8x. Not for an exact (zero-variance) reference: use Welch
    /// there. Applies when both sides give one-sample variances; otherwise Welch is used.
    Pooled,
}

/// Settings of the two-sample test of means, and its verdict rule.
///
/// **Pixels.** For every pixel-channel the statistic is z = (m_a − m_b) / sqrt(V + f), with m
/// the per-pixel means, V the variance of the difference of the means (see [`VarianceModel`]
/// and [`SideVariance`]), and the floor f = (rel_floor · max(|m_a|, |m_b|))² + abs_floor². Its
/// two-sided p-value is Student's t with the degrees of freedom of V (Welch–Satterthwaite;
/// with the pooled model n_a + n_b − 2; the normal where V is the floor alone). Pixel-channels
/// where any input is NaN/inf get p = 0; negative variances count as 0.
///
/// The floor f handles zero-variance pixels: equal means (e.g. both black) give z = 0 and pass;
/// different means with zero variance fail unless the difference is within a few sqrt(f), i.e.
/// float rounding (1e-5 relative or 1e-6 absolute with the defaults). It is negligible wherever
/// the variance is not tiny. A reference known exactly (analytic) can be passed with a zero
/// variance image.
///
/// **Blocks.** With `blocks` (the default) the same test runs on the means of square blocks of
/// pixels, 4×4, 8×8, … up to the whole image (`blocks.rs`): a bias too small for one pixel's
/// noise shows in a block's mean, whose standard error falls with the square root of its
/// pixels.
///
/// **Verdict.** The family-wise false-alarm rate is `alpha`, shared equally by the members of
/// the verdict: the two pixel rules below and each block scale, α_m = α / members. Each member
/// fails with probability at most α_m under H0 (up to the normal approximation of the means),
/// so the verdict fails falsely with probability at most α (Bonferroni). Mitsuba 3's
/// `test_renders.py` Šidák-corrects α over the N pixel-channels, α_s = 1 − (1 − α)^(1/N), and
/// passes when at least 99.75% of pixel-channels have p ≥ α_s. The two do not fit together:
/// Šidák already makes P(any p < α_s) = α for independent Gaussian tests, so a correct
/// renderer has about α (≪ 1) such "outliers" and the 0.25% allowance only absorbs
/// non-Gaussian tails (fireflies, small n). Combined they see only gross errors: at 256x256, a
/// bias of 3 standard errors over 6% of the image puts 0.7% of those pixel-channels below α_s
/// (z > 5.45), 0.04% of the image, and passes. So the verdict fails when ANY member fails:
///
/// 1. **Outlier rule (Mitsuba's):** the number of pixel-channels with p < α_s (non-finite
///    included), α_s Šidák-corrected from α_m, must be at most
///    `floor(max_outlier_fraction · N)`. Catches strong local errors and any NaN/inf beyond
///    the allowance.
/// 2. **Excess rule** (if `excess_test`): a pixel is "rejected" when its smallest channel
///    p-value is below α/3 (Bonferroni over its 3 correlated channels, so under H0 with exact
///    p-values P(rejected) <= α whatever the channel correlation). Because the normal
///    approximation is anti-conservative for Monte Carlo samples (see [`VarianceModel`]), the
///    rule tolerates a rejection rate up to κ·α, κ = `excess_tolerance` (default 3), and fails
///    when the count K of rejected pixels among P is significant against that:
///    P(Binomial(P, κα) >= K) < α_m. Catches moderate bias over a region: a 3-SE shift rejects
///    ~90% of the shifted pixels, so it fails once the region exceeds a few percent of the
///    image.
/// 3. **Block scales** (if `blocks`): each scale's 3 × blocks tests share α_m (Bonferroni), and
///    Holm's step-down procedure runs over all scales' tests; any rejection fails. Catches a
///    small bias over a region or the whole image (a 2 % darker material).
///
/// Sample counts should be large enough for the normal approximation on both sides (n >= 64
/// with smooth integrands, more with fireflies); with Welch, also keep n_a and n_b similar or
/// use [`VarianceModel::Pooled`] when both sides run the same estimator. A block mean averages
/// 16 pixels or more, so its normal approximation is better than a pixel's.
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
    /// Whether the block scales (3) are part of the verdict. Default true.
    pub blocks: bool,
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
            blocks: true,
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

/// Result of [`z_test`]; see [`ZTestOptions`] for the rule.
#[derive(Clone, Debug)]
pub struct ZTestReport {
    pub width: u32,
    pub height: u32,
    /// Where each side's variance came from (a, b).
    pub variance_sources: [VarianceSource; 2],
    /// The model used: Pooled only when asked and both sides give one-sample variances.
    pub variance: VarianceModel,
    /// Number of pixel-channels tested, N = 3 · pixels.
    pub tests: usize,
    pub alpha: f64,
    /// Members of the verdict sharing α: the pixel rules and the block scales.
    pub members: usize,
    /// α_m = α / members.
    pub alpha_member: f64,
    /// Šidák-corrected per-test level 1 − (1 − α_m)^(1/N).
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
    pub outlier_rule_pass: bool,
    pub excess_rule_pass: bool,
    /// The smallest relative bias of one pixel-channel that the Šidák level would detect (the
    /// typical one too), over the pixel-channels whose variance is estimated.
    pub pixel_detectable: Option<Detectable>,
    /// The block scales (None when `blocks` is off).
    pub blocks: Option<BlockReport>,
    /// Overall verdict.
    pub pass: bool,
    /// Per pixel-channel p-values.
    pub p_map: Image,
    /// Per pixel-channel signed z (NaN where an input is not finite).
    pub z_map: Image,
    /// The [`WORST_COUNT`] pixel-channels with the smallest p-values (largest |z|).
    pub worst: Vec<ZOutlier>,
}

fn word(pass: bool) -> &'static str {
    if pass {
        "pass"
    } else {
        "FAIL"
    }
}

/// A detectable relative bias in per cent, e.g. `2.31 % (95 % power: 3.05 %; typical block
/// 5.2 %)`.
fn percent(d: &Option<Detectable>) -> String {
    match d {
        Some(d) => format!(
            "{:.3} % (95 % power {:.3} %) at {},{} ch {}; typical {:.3} %",
            100.0 * d.bias,
            100.0 * d.bias_95,
            d.block.x,
            d.block.y,
            d.channel,
            100.0 * d.typical_bias
        ),
        None => "- (no noisy block with a mean)".into(),
    }
}

impl fmt::Display for ZTestReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "z-test {}: {}x{}, alpha {} over {} members (alpha_m {:.3e}), {} variance",
            if self.pass { "PASS" } else { "FAIL" },
            self.width,
            self.height,
            self.alpha,
            self.members,
            self.alpha_member,
            match self.variance {
                VarianceModel::Welch => "welch",
                VarianceModel::Pooled => "pooled",
            }
        )?;
        writeln!(
            f,
            "  variance   test: {}; reference: {}",
            self.variance_sources[0], self.variance_sources[1]
        )?;
        writeln!(
            f,
            "  outlier rule {}: {} of {} pixel-channels below Sidak level {:.3e} (allowed {}), {:.4}% pass, {} non-finite, min p {:.3e}",
            word(self.outlier_rule_pass),
            self.outliers,
            self.tests,
            self.alpha_sidak,
            self.max_outliers,
            100.0 * self.pass_fraction,
            self.nonfinite,
            self.min_p
        )?;
        writeln!(
            f,
            "  excess rule {}: {} pixels rejected at alpha/3 per channel (H0 bound {:.1}), tail p {:.3e} (tolerance x{})",
            word(self.excess_rule_pass),
            self.rejected_pixels,
            self.expected_rejected_pixels,
            self.excess_p,
            self.excess_tolerance
        )?;
        writeln!(
            f,
            "  pixel      detectable bias {}",
            percent(&self.pixel_detectable)
        )?;
        if let Some(b) = &self.blocks {
            writeln!(
                f,
                "  blocks {}: {} tests, {} rejected (Holm), smallest alpha that rejects {:.3e}",
                word(b.pass),
                b.tests,
                b.rejected,
                b.min_adjusted_p
            )?;
            for s in &b.scales {
                let name = if s.whole_image {
                    format!("{}x{} (whole)", self.width, self.height)
                } else {
                    format!("{0}x{0}", s.side)
                };
                let worst = s
                    .worst
                    .map(|w| {
                        format!(
                            "min p {:.3e} (t {:+.2}) at {},{} ch {}",
                            w.p, w.t, w.block.x, w.block.y, w.channel
                        )
                    })
                    .unwrap_or_default();
                writeln!(
                    f,
                    "  {name:<10} {} blocks, level {:.2e}, {} rejected, {worst}, detectable bias {}",
                    s.blocks,
                    s.level,
                    s.rejected,
                    percent(&s.detectable)
                )?;
            }
        }
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

/// The two-sample test with one-sample variances: `var_*` are per-pixel sample variances of
/// one sample, `n_*` the samples per pixel ([`ZTestOptions::at_alpha`] for the default options
/// at one significance).
pub fn z_test_with(
    mean_a: &Image,
    var_a: &Image,
    n_a: u64,
    mean_b: &Image,
    var_b: &Image,
    n_b: u64,
    opts: &ZTestOptions,
) -> Result<ZTestReport, MetricsError> {
    for (name, n) in [("n_a", n_a), ("n_b", n_b)] {
        if n == 0 {
            return Err(MetricsError::InvalidParameter {
                name,
                value: 0.0,
                reason: "the sample count must be at least 1",
            });
        }
    }
    let side = |mean, variance, spp| ZSide {
        mean,
        variance: SideVariance::OneSample { variance, spp },
    };
    z_test(&side(mean_a, var_a, n_a), &side(mean_b, var_b, n_b), opts)
}

/// The two-sample test of means of sides `a` (the test image) and `b` (the reference); the
/// relative biases it reports are relative to `b`.
pub fn z_test(a: &ZSide, b: &ZSide, opts: &ZTestOptions) -> Result<ZTestReport, MetricsError> {
    check_pair("mean_a", a.mean, "var_a", a.variance.image())?;
    check_pair("mean_a", a.mean, "mean_b", b.mean)?;
    check_pair("mean_b", b.mean, "var_b", b.variance.image())?;
    for (name, v) in [("a", &a.variance), ("b", &b.variance)] {
        match *v {
            SideVariance::OneSample { spp: 0, .. } => {
                return Err(MetricsError::InvalidParameter {
                    name: if name == "a" { "n_a" } else { "n_b" },
                    value: 0.0,
                    reason: "the sample count must be at least 1",
                })
            }
            SideVariance::BatchMeans { batches, .. } if batches < 2 => {
                return Err(MetricsError::InvalidParameter {
                    name: if name == "a" {
                        "batches_a"
                    } else {
                        "batches_b"
                    },
                    value: batches as f64,
                    reason: "a variance from batch means needs at least 2 batches",
                })
            }
            _ => {}
        }
    }
    opts.validate()?;

    let (w, h) = (a.mean.width, a.mean.height);
    let pixels = a.mean.data.len();
    let tests = 3 * pixels;
    let alpha = opts.alpha;
    let scales = if opts.blocks {
        blocks::scales(w, h).len()
    } else {
        0
    };
    let members = 1 + opts.excess_test as usize + scales;
    let alpha_member = alpha / members as f64;
    // 1 − (1 − α_m)^(1/N), computed without cancellation.
    let alpha_sidak = -libm::expm1(libm::log1p(-alpha_member) / tests as f64);
    let model = ChannelTest::new(opts, &a.variance, &b.variance);
    let mut acc = Tally::default();
    let mut p_map = Vec::with_capacity(pixels);
    let mut z_map = Vec::with_capacity(pixels);
    let mut terms = Vec::with_capacity(if opts.blocks { pixels } else { 0 });
    let mut pixel_candidates = Vec::new();
    for i in 0..pixels {
        let (ma, va) = (a.mean.data[i], a.variance.image().data[i]);
        let (mb, vb) = (b.mean.data[i], b.variance.image().data[i]);
        let mut pp = [1.0f32; 3];
        let mut zz = [0.0f32; 3];
        let mut tt = [PixelTerms::default(); 3];
        let mut pixel_min_p = 1.0f64;
        for c in 0..3 {
            let t = model.terms(ma[c] as f64, va[c] as f64, mb[c] as f64, vb[c] as f64);
            let (z, p, sd, dof) = model.z_and_p(&t);
            acc.add(z, p, alpha_sidak);
            pixel_min_p = pixel_min_p.min(p);
            pp[c] = p as f32;
            zz[c] = z as f32;
            tt[c] = t;
            if t.finite && t.v > 0.0 && t.mb != 0.0 && sd.is_finite() {
                let (x, y) = a.mean.coords(i);
                pixel_candidates.push(Candidate {
                    ratio: sd / t.mb.abs(),
                    dof,
                    block: Rect {
                        x,
                        y,
                        width: 1,
                        height: 1,
                    },
                    channel: c,
                });
            }
        }
        if pixel_min_p < alpha / 3.0 {
            acc.rejected_pixels += 1;
        }
        p_map.push(pp);
        z_map.push(zz);
        if opts.blocks {
            terms.push(tt);
        }
    }

    let max_outliers = (opts.max_outlier_fraction * tests as f64).floor() as usize;
    let outlier_rule_pass = acc.outliers <= max_outliers;
    let excess_p = binomial_upper_tail(
        pixels as u64,
        (opts.excess_tolerance * alpha).min(1.0),
        acc.rejected_pixels as u64,
    );
    let excess_rule_pass = !opts.excess_test || excess_p >= alpha_member;
    let blocks = opts.blocks.then(|| {
        let floor = |ma: f64, mb: f64| model.floor(ma, mb);
        blocks::block_tests(w, h, &terms, alpha, members, &floor)
    });
    let blocks_pass = blocks.as_ref().map_or(true, |b| b.pass);
    let image = |data| Image {
        width: w,
        height: h,
        data,
    };
    let worst = worst_outliers(a.mean, b.mean, &z_map, &p_map);
    Ok(ZTestReport {
        width: w,
        height: h,
        variance_sources: [a.variance.source(), b.variance.source()],
        variance: model.variance,
        tests,
        alpha,
        members,
        alpha_member,
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
        outlier_rule_pass,
        excess_rule_pass,
        pixel_detectable: blocks::detectable(pixel_candidates, alpha_sidak),
        pass: outlier_rule_pass && excess_rule_pass && blocks_pass,
        blocks,
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

/// The statistic of one pixel-channel: the variance model, the two sides' variances and the
/// floor.
struct ChannelTest<'a> {
    variance: VarianceModel,
    a: SideVariance<'a>,
    b: SideVariance<'a>,
    /// Pooled: (1/n_a + 1/n_b) / (n_a + n_b − 2), and n_a − 1, n_b − 1, n_a + n_b − 2; the
    /// weight is 0 with one sample per side, where there is no variance estimate.
    pooled: Option<(f64, f64, f64, f64)>,
    rel_floor: f64,
    abs_floor: f64,
}

impl<'a> ChannelTest<'a> {
    fn new(opts: &ZTestOptions, a: &SideVariance<'a>, b: &SideVariance<'a>) -> Self {
        let pooled = match (opts.variance, a, b) {
            (
                VarianceModel::Pooled,
                SideVariance::OneSample { spp: n_a, .. },
                SideVariance::OneSample { spp: n_b, .. },
            ) => {
                let (na, nb) = (*n_a as f64, *n_b as f64);
                let weight = if n_a + n_b > 2 {
                    (1.0 / na + 1.0 / nb) / (na + nb - 2.0)
                } else {
                    0.0
                };
                Some((weight, na - 1.0, nb - 1.0, na + nb - 2.0))
            }
            _ => None,
        };
        ChannelTest {
            variance: if pooled.is_some() {
                VarianceModel::Pooled
            } else {
                VarianceModel::Welch
            },
            a: *a,
            b: *b,
            pooled,
            rel_floor: opts.rel_floor,
            abs_floor: opts.abs_floor,
        }
    }

    fn floor(&self, ma: f64, mb: f64) -> f64 {
        (self.rel_floor * ma.abs().max(mb.abs())).powi(2) + self.abs_floor.powi(2)
    }

    /// The terms of one pixel-channel: its difference, its variance (without the floor) and
    /// the Satterthwaite denominator.
    fn terms(&self, ma: f64, va: f64, mb: f64, vb: f64) -> PixelTerms {
        let finite = ma.is_finite() && mb.is_finite() && va.is_finite() && vb.is_finite();
        if !finite {
            return PixelTerms {
                ma,
                mb,
                ..PixelTerms::default()
            };
        }
        let (v, w) = match self.pooled {
            Some((weight, dfa, dfb, df)) => {
                let v = weight * (dfa * va.max(0.0) + dfb * vb.max(0.0));
                (v, if df > 0.0 { v * v / df } else { 0.0 })
            }
            None => {
                let (a, dfa) = self.a.of_mean(va);
                let (b, dfb) = self.b.of_mean(vb);
                let part = |v: f64, df: f64| if df > 0.0 { v * v / df } else { 0.0 };
                (a + b, part(a, dfa) + part(b, dfb))
            }
        };
        PixelTerms {
            d: ma - mb,
            v,
            w,
            ma,
            mb,
            finite,
        }
    }

    /// (z, p, standard deviation of the difference, degrees of freedom) of one pixel-channel;
    /// (NaN, 0, NaN, NaN) when an input is not finite.
    fn z_and_p(&self, t: &PixelTerms) -> (f64, f64, f64, f64) {
        if !t.finite {
            return (f64::NAN, 0.0, f64::NAN, f64::NAN);
        }
        let var = t.v + self.floor(t.ma, t.mb);
        let dof = satterthwaite(var, t.w);
        let z = if t.d == 0.0 {
            0.0
        } else if var > 0.0 {
            t.d / var.sqrt()
        } else {
            f64::INFINITY.copysign(t.d)
        };
        (z, t_two_sided(z, dof), var.sqrt(), dof)
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
