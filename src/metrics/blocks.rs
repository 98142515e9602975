//! The aggregate part of the two-sample test of means ([`super::z_test`]): the image cut into
//! square blocks at several scales, 4×4 pixels, 8×8, … up to the whole image, and in each block
//! and channel a two-sample test of the block means, with the variance of the block mean (the
//! pixels' variances of their means, added: pixels are independent, every sampler keys its
//! numbers on the pixel). A bias too small to show in one pixel's noise shows in a block's
//! mean, whose standard error falls with the square root of its pixels: a 2 % darker material
//! over a quarter of a 128×128 image is 0.2 standard errors in a pixel at 64 spp, and dozens in
//! the whole image.
//!
//! **Family-wise control.** Every scale is one member of the verdict's family and gets the
//! share α_m of the family-wise α (see [`super::ZTestOptions`]); within a scale of n blocks the
//! 3n block-channel tests share it equally (Bonferroni level α_m / 3n). Across all scales the
//! tests are combined by Holm's (1979) weighted step-down procedure: sorted by p_i / c_i (c_i
//! the test's Bonferroni level), the j-th is rejected while p_(j) <= c_(j) · C / R_j, C the sum of
//! all levels and R_j the sum of the levels not yet rejected. Its first step is the Bonferroni
//! test, so the family-wise error is at most Σ c_i = α_m × scales, whatever the dependence
//! between scales (a block's test is correlated with those of the blocks inside it); the later
//! steps only add rejections (which blocks are off), never a false verdict.
//!
//! **Statistic.** For a block and one channel, over its B pixels whose variance of the
//! difference of means V_i (before the floor) is estimated above 0: d = the mean of
//! (m_a − m_b), V = Σ V_i / B², the floor f = (rel · max(|M_a|, |M_b|))² + abs² of the block
//! means M (not divided by B: it stands for differences too small to matter, which do not
//! shrink by averaging), t = d / sqrt(V + f), and p = P(|T_ν| > |t|) with ν the
//! Welch–Satterthwaite degrees of freedom (V + f)² / Σ W_i / B⁴, W_i = Σ v² / ν over the
//! pixel's variance terms. A block with a non-finite input in that channel gets p = 0.
//!
//! Pixels with no variance on either side are left to the pixel rules: where both sides are
//! exact (an emitter seen directly, a black background) their means agree and add nothing,
//! and where they disagree the variance estimate failed, not the renderer, as often as not: at
//! a few samples per pixel, or two batches, all of a pixel's samples fall on one side of an
//! edge often enough (measured: a 1024x1024 pair at 4 spp in 2 batches put a 4x4 block at
//! t = −4000 from one such pixel). The outlier rule counts them, with its allowance.
//!
//! **Power.** For each scale, the smallest relative bias b of the test image (every pixel of a
//! block scaled by 1 + b) that some block-channel would have detected: |b| · |M_b| = c · s, with
//! s = sqrt(V + f) and c the critical |t| at the scale's Bonferroni level (detected with
//! probability about 1/2); with probability about 0.95 it takes (c + z_0.95) · s.

use super::dist::{normal_quantile, satterthwaite, t_critical, t_two_sided};

/// The side of the smallest blocks, in pixels.
pub const SMALLEST_BLOCK: u32 = 4;

/// One pixel-channel's part of the block sums.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PixelTerms {
    /// m_a − m_b.
    pub d: f64,
    /// The variance of the difference of the means, without the floor.
    pub v: f64,
    /// Σ v² / ν of the variance terms (0 when none is estimated).
    pub w: f64,
    pub ma: f64,
    pub mb: f64,
    /// Whether every input of the pixel-channel is finite.
    pub finite: bool,
}

/// The sums of one block and channel, over its pixel-channels with an estimated variance.
#[derive(Clone, Copy, Debug, Default)]
struct Sums {
    /// How many pixel-channels are summed.
    n: f64,
    d: f64,
    v: f64,
    w: f64,
    ma: f64,
    mb: f64,
    bad: u32,
}

impl Sums {
    fn add(&mut self, o: &Sums) {
        self.n += o.n;
        self.d += o.d;
        self.v += o.v;
        self.w += o.w;
        self.ma += o.ma;
        self.mb += o.mb;
        self.bad += o.bad;
    }
}

/// A rectangle of the image, in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Rect {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
}

/// One block-channel test.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct BlockTest {
    pub block: Rect,
    pub channel: usize,
    /// The block means of the two sides.
    pub mean_a: f64,
    pub mean_b: f64,
    /// The statistic, NaN where an input is not finite.
    pub t: f64,
    /// Degrees of freedom of the variance (infinite: a normal test).
    pub dof: f64,
    pub p: f64,
}

/// The smallest relative bias one scale would have detected (module docs), over its
/// block-channels whose variance is estimated (not the floor alone: a noise-free block, such as
/// one inside an emitter, would detect a bias of the floor's size, which says nothing of the
/// test's power on the noisy parts).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Detectable {
    /// Detected with probability about 1/2: the critical value of the test.
    pub bias: f64,
    /// Detected with probability about 0.95.
    pub bias_95: f64,
    /// The block (and channel) where it is smallest.
    pub block: Rect,
    pub channel: usize,
    /// The same (probability 1/2) for the block-channel of median σ/|M_b|: about half the
    /// blocks would detect a bias of this size on their own.
    pub typical_bias: f64,
}

/// One block-channel's candidacy for [`Detectable`]: σ/|M_b|, the degrees of freedom, where.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Candidate {
    pub ratio: f64,
    pub dof: f64,
    pub block: Rect,
    pub channel: usize,
}

/// The tests of one scale.
#[derive(Clone, Debug, PartialEq)]
pub struct ScaleReport {
    /// The block side in pixels; the last scale is the whole image, whatever its size.
    pub side: u32,
    pub whole_image: bool,
    pub blocks: usize,
    /// Block-channel tests, 3 × blocks.
    pub tests: usize,
    /// The Bonferroni level of each test: the scale's share of α over its tests.
    pub level: f64,
    /// Rejected by the Holm procedure over all scales.
    pub rejected: usize,
    /// The smallest p-value's test.
    pub worst: Option<BlockTest>,
    /// None when every block's reference mean is 0 (or not finite).
    pub detectable: Option<Detectable>,
}

/// The tests of every scale, with the Holm procedure over all of them.
#[derive(Clone, Debug, PartialEq)]
pub struct BlockReport {
    pub scales: Vec<ScaleReport>,
    /// All block-channel tests.
    pub tests: usize,
    /// Rejected by Holm's procedure.
    pub rejected: usize,
    /// The smallest family-wise α at which some block test would be rejected: the smallest
    /// p_i / u_i, u_i the test's level per unit α (≥ the observed α exactly when none is
    /// rejected).
    pub min_adjusted_p: f64,
    pub pass: bool,
}

/// The block sides of a `width` × `height` image: 4, 8, 16, … while smaller than the longer
/// side, then the whole image (marked by the side `max(width, height)`).
pub fn scales(width: u32, height: u32) -> Vec<u32> {
    let longest = width.max(height);
    let mut v = Vec::new();
    let mut s = SMALLEST_BLOCK;
    while s < longest {
        v.push(s);
        s *= 2;
    }
    v.push(longest);
    v
}

/// The block tests of one image pair, from its pixel terms (`terms[i][c]`, pixel i in rows of
/// `width`), at the family-wise `alpha` shared by `members` (each scale's share is
/// alpha / members); `floor` maps the two block means to the floor of the variance.
pub(crate) fn block_tests(
    width: u32,
    height: u32,
    terms: &[[PixelTerms; 3]],
    alpha: f64,
    members: usize,
    floor: &dyn Fn(f64, f64) -> f64,
) -> BlockReport {
    let alpha_member = alpha / members as f64;
    let base = base_grid(width, height, terms);
    let (gw, gh) = (
        width.div_ceil(SMALLEST_BLOCK),
        height.div_ceil(SMALLEST_BLOCK),
    );
    let sides = scales(width, height);
    // (p, the test's level in units of α_m, scale)
    let mut all: Vec<(f64, f64, usize)> = Vec::new();
    let mut reports = Vec::with_capacity(sides.len());
    for (si, &side) in sides.iter().enumerate() {
        let whole = si + 1 == sides.len();
        // Base cells per block along each axis.
        let cells = if whole {
            gw.max(gh)
        } else {
            side / SMALLEST_BLOCK
        };
        let (bw, bh) = (gw.div_ceil(cells), gh.div_ceil(cells));
        let blocks = (bw * bh) as usize;
        let tests = 3 * blocks;
        let level = alpha_member / tests as f64;
        let mut worst: Option<BlockTest> = None;
        let mut candidates: Vec<Candidate> = Vec::new();
        for by in 0..bh {
            for bx in 0..bw {
                let mut s = [Sums::default(); 3];
                for cy in by * cells..((by + 1) * cells).min(gh) {
                    for cx in bx * cells..((bx + 1) * cells).min(gw) {
                        let cell = &base[(cy * gw + cx) as usize];
                        for c in 0..3 {
                            s[c].add(&cell[c]);
                        }
                    }
                }
                let rect = block_rect(bx, by, cells, width, height);
                for (c, s) in s.iter().enumerate() {
                    let test = block_test(rect, c, s, floor);
                    let n = s.n;
                    all.push((test.p, 1.0 / tests as f64, si));
                    if worst.map_or(true, |w| {
                        test.p < w.p || (test.p == w.p && test.t.abs() > w.t.abs())
                    }) {
                        worst = Some(test);
                    }
                    if s.bad == 0 && s.v > 0.0 && test.mean_b != 0.0 && test.mean_b.is_finite() {
                        let sd = (s.v / (n * n) + floor(test.mean_a, test.mean_b)).sqrt();
                        if sd.is_finite() {
                            candidates.push(Candidate {
                                ratio: sd / test.mean_b.abs(),
                                dof: test.dof,
                                block: rect,
                                channel: c,
                            });
                        }
                    }
                }
            }
        }
        reports.push(ScaleReport {
            side,
            whole_image: whole,
            blocks,
            tests,
            level,
            rejected: 0,
            worst,
            detectable: detectable(candidates, level),
        });
    }
    let (rejected_by_scale, min_ratio) = holm(&all, alpha_member);
    for (r, k) in reports.iter_mut().zip(rejected_by_scale) {
        r.rejected = k;
    }
    let rejected = reports.iter().map(|r| r.rejected).sum();
    BlockReport {
        tests: all.len(),
        rejected,
        min_adjusted_p: (min_ratio * members as f64).min(1.0),
        pass: rejected == 0,
        scales: reports,
    }
}

/// Sums over the 4×4 cells of the image (partial at the right and bottom edges).
fn base_grid(width: u32, height: u32, terms: &[[PixelTerms; 3]]) -> Vec<[Sums; 3]> {
    let (gw, gh) = (
        width.div_ceil(SMALLEST_BLOCK),
        height.div_ceil(SMALLEST_BLOCK),
    );
    let mut base = vec![[Sums::default(); 3]; (gw * gh) as usize];
    for y in 0..height {
        for x in 0..width {
            let cell = &mut base[((y / SMALLEST_BLOCK) * gw + x / SMALLEST_BLOCK) as usize];
            for (c, t) in terms[(y * width + x) as usize].iter().enumerate() {
                if !t.finite {
                    cell[c].bad += 1;
                } else if t.v > 0.0 {
                    cell[c].add(&Sums {
                        n: 1.0,
                        d: t.d,
                        v: t.v,
                        w: t.w,
                        ma: t.ma,
                        mb: t.mb,
                        bad: 0,
                    });
                }
            }
        }
    }
    base
}

/// The pixels of block (bx, by) of `cells` base cells a side, clipped to the image.
fn block_rect(bx: u32, by: u32, cells: u32, width: u32, height: u32) -> Rect {
    let side = cells.saturating_mul(SMALLEST_BLOCK);
    let (x, y) = (bx.saturating_mul(side), by.saturating_mul(side));
    Rect {
        x,
        y,
        width: side.min(width - x),
        height: side.min(height - y),
    }
}

/// The test of one block-channel: a non-finite pixel fails it; with no pixel-channel to test
/// (none has an estimated variance) it passes.
fn block_test(block: Rect, channel: usize, s: &Sums, floor: &dyn Fn(f64, f64) -> f64) -> BlockTest {
    let n = s.n.max(1.0);
    let (ma, mb) = (s.ma / n, s.mb / n);
    if s.bad > 0 {
        return BlockTest {
            block,
            channel,
            mean_a: ma,
            mean_b: mb,
            t: f64::NAN,
            dof: f64::NAN,
            p: 0.0,
        };
    }
    if s.n == 0.0 {
        return BlockTest {
            block,
            channel,
            mean_a: 0.0,
            mean_b: 0.0,
            t: 0.0,
            dof: f64::INFINITY,
            p: 1.0,
        };
    }
    let d = s.d / n;
    let var = s.v / (n * n) + floor(ma, mb);
    let dof = satterthwaite(var, s.w / (n * n * n * n));
    let t = if d == 0.0 {
        0.0
    } else if var > 0.0 {
        d / var.sqrt()
    } else {
        f64::INFINITY.copysign(d)
    };
    BlockTest {
        block,
        channel,
        mean_a: ma,
        mean_b: mb,
        t,
        dof,
        p: t_two_sided(t, dof),
    }
}

/// The smallest detectable relative bias over `candidates` at the two-sided level `level`,
/// and the typical one: the critical value grows as ν falls, so the candidates are visited by
/// σ/|M_b| and the search stops when even the normal critical value cannot do better.
pub(crate) fn detectable(mut candidates: Vec<Candidate>, level: f64) -> Option<Detectable> {
    if candidates.is_empty() || level <= 0.0 {
        return None;
    }
    candidates.sort_by(|a, b| a.ratio.total_cmp(&b.ratio));
    let median = candidates[candidates.len() / 2];
    let typical_bias = t_critical(level, median.dof) * median.ratio;
    let z_inf = t_critical(level, f64::INFINITY);
    let z95 = normal_quantile(0.95);
    let mut best: Option<Detectable> = None;
    for Candidate {
        ratio,
        dof,
        block,
        channel,
    } in candidates
    {
        if best.is_some_and(|b| ratio * z_inf >= b.bias) {
            break;
        }
        let c = t_critical(level, dof);
        if best.map_or(true, |b| c * ratio < b.bias) {
            best = Some(Detectable {
                bias: c * ratio,
                bias_95: (c + z95) * ratio,
                block,
                channel,
                typical_bias,
            });
        }
    }
    best
}

/// Holm's weighted step-down procedure over `tests` (p, level u in units of α_m, scale): the
/// number rejected in each scale, and the smallest p / u (the smallest α_m at which the first
/// test is rejected). With U = Σ u (the number of scales), the family's block level is α_m · U
/// and the j-th test in the order of p / u is rejected while p_(j) <= α_m · u_(j) · U / R_j, R_j
/// the sum of u over the tests not yet rejected.
fn holm(tests: &[(f64, f64, usize)], alpha_member: f64) -> (Vec<usize>, f64) {
    let scales = tests.iter().map(|t| t.2 + 1).max().unwrap_or(0);
    let mut rejected = vec![0; scales];
    let ratio = |i: usize| tests[i].0 / tests[i].1;
    let mut order: Vec<usize> = (0..tests.len()).collect();
    order.sort_by(|&a, &b| ratio(a).total_cmp(&ratio(b)));
    let Some(&first) = order.first() else {
        return (rejected, f64::INFINITY);
    };
    let total: f64 = tests.iter().map(|t| t.1).sum();
    let mut remaining = total;
    for &i in &order {
        let (p, u, s) = tests[i];
        if p <= alpha_member * u * total / remaining {
            rejected[s] += 1;
            remaining -= u;
        } else {
            break;
        }
    }
    (rejected, ratio(first))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn terms(w: u32, h: u32, f: impl Fn(u32, u32) -> (f64, f64)) -> Vec<[PixelTerms; 3]> {
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| {
                let (d, v) = f(x, y);
                [PixelTerms {
                    d,
                    v,
                    w: 0.0,
                    ma: 1.0 + d,
                    mb: 1.0,
                    finite: true,
                }; 3]
            })
            .collect()
    }

    #[test]
    fn scales_run_from_four_pixels_to_the_whole_image() {
        assert_eq!(scales(128, 128), vec![4, 8, 16, 32, 64, 128]);
        assert_eq!(scales(40, 32), vec![4, 8, 16, 32, 40]);
        assert_eq!(scales(3, 2), vec![3]);
        assert_eq!(scales(4, 1), vec![4]);
        assert_eq!(scales(5, 1), vec![4, 5]);
    }

    /// A bias of 0.2 standard errors per pixel everywhere: invisible per pixel, a t of 0.2 × 32
    /// = 6.4 over the 32×32 image, which the whole-image test rejects; blocks partial at the
    /// edges cover every pixel once.
    #[test]
    fn a_small_bias_everywhere_is_seen_by_the_largest_blocks() {
        let (w, h) = (32, 32);
        let t = terms(w, h, |_, _| (0.2, 1.0));
        let r = block_tests(w, h, &t, 0.01, 7, &|_, _| 0.0);
        assert_eq!(r.scales.len(), 4);
        let whole = r.scales.last().unwrap();
        assert!(whole.whole_image && whole.blocks == 1);
        let worst = whole.worst.unwrap();
        assert!((worst.t - 6.4).abs() < 1e-9, "{worst:?}");
        assert!(whole.rejected == 3 && !r.pass, "{r:?}");
        // 4×4 blocks: t = 0.8 each, none rejected.
        assert_eq!(r.scales[0].rejected, 0);
        assert_eq!(r.scales[0].blocks, 64);
        // Holm rejects more than the three whole-image channels once they are out: the 16×16
        // blocks have t = 3.2 at level 0.01/7/12: not enough, so exactly the whole image.
        assert_eq!(r.rejected, 3);
        // The detectable bias of the whole image: c · 1/32 relative (mean 1, sd 1/32).
        let det = whole.detectable.unwrap();
        let c = t_critical(whole.level, f64::INFINITY);
        assert!((det.bias - c / 32.0).abs() < 1e-12, "{det:?}");
        assert!(det.bias_95 > det.bias);
        // Partial blocks: a 10×6 image has 4×4 blocks of 4×4, 2×4, 4×2 and 2×2 pixels.
        let t = terms(10, 6, |_, _| (0.0, 1.0));
        let r = block_tests(10, 6, &t, 0.01, 3, &|_, _| 0.0);
        assert_eq!(r.scales[0].blocks, 6);
        assert!(r.pass && r.min_adjusted_p >= 1.0 - 1e-12, "{r:?}");
    }

    /// A pixel-channel without variance on either side is the pixel rules' business: its
    /// difference, however large, does not enter the blocks; a block of such pixels alone
    /// passes.
    #[test]
    fn pixels_without_variance_are_left_out_of_the_blocks() {
        let (w, h) = (8, 8);
        let mut t = terms(w, h, |x, _| (0.0, if x < 4 { 1.0 } else { 0.0 }));
        t[7][0].d = 50.0;
        t[7][0].ma = 51.0;
        let r = block_tests(w, h, &t, 0.01, 4, &|_, _| 1e-12);
        assert!(r.pass, "{r:?}");
        // Every block holds only pixels of equal means, or none: p = 1 everywhere.
        assert!(r.scales.iter().all(|s| s.worst.unwrap().p == 1.0), "{r:?}");
        // The same difference with a variance is seen.
        t[7][0].v = 1.0;
        assert!(!block_tests(w, h, &t, 0.01, 4, &|_, _| 1e-12).pass);
    }

    /// A non-finite pixel fails its blocks at every scale; no bias passes.
    #[test]
    fn nonfinite_pixels_fail_their_blocks() {
        let (w, h) = (16, 16);
        let mut t = terms(w, h, |_, _| (0.0, 1.0));
        t[17][1].finite = false;
        let r = block_tests(w, h, &t, 0.01, 6, &|_, _| 0.0);
        assert!(!r.pass);
        for s in &r.scales {
            assert_eq!(s.rejected, 1, "{s:?}");
            let worst = s.worst.unwrap();
            assert_eq!((worst.channel, worst.p), (1, 0.0));
        }
    }
}
