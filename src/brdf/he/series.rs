//! The series of the directional-diffuse term (the D of survey eq. 12),
//! Σ_{m≥1} gᵐe^(−g)/(m!·m) · exp(−c/m), summed over the window of [`series_ends`]: around
//! the largest term m̂ (found by bisection on the ratio of consecutive terms, which decreases
//! with m), out to where the terms are e^(−20) below it and fall geometrically; proved there to
//! omit at most 2e^(−20) ≈ 4.1e-9 of the sum for every g and every c, 15 times below f32's
//! rounding. (A window fixed around g, such as m ∈ [g − 8√g, g + 8√g + 10], would miss that
//! e^(−c/m) moves the largest terms to m ≫ g when c ≫ g²: rough surfaces far from the specular
//! direction would be 2 % off where the value is below 1e-20.)
//!
//! Two ways over the window, one per width (the GPU needs a bound on each):
//! * **Narrow** (most surfaces; g up to about 75 at c = 0): [`series_walk`] starts at m̂ and
//!   walks outwards term by term, each term the previous one times the ratio
//!   ρ(m) = g·m/(m+1)² · e^(c/(m(m+1))), one `exp` a term, relative to t(m̂); it stops at
//!   the window's ends by the same tests [`series_ends`] bisects on, and gives up past
//!   [`HE_MAX_TERMS`] = 128 terms. One `exp` and `ln` give t(m̂) itself,
//!   ln t(m̂) = −m̂·φ(g/m̂ − 1) − ½ln(2πm̂) − r(m̂) − ln m̂ − c/m̂ with φ(ε) = ε − ln(1 + ε)
//!   (a series in z = ε/(2+ε) near 0, so no cancellation) and
//!   r(m) = ln m! − (m ln m − m + ½ ln 2πm) the Stirling remainder (table for m ≤ 3,
//!   three-term series above). Each step rounds a few times, so a term k steps from m̂ is off
//!   by about 4k·2⁻²⁴ of itself; the terms that matter lie within a few widths of m̂.
//! * **Wide** (a predicted width over 110 terms, or a walk that gave up): every s-th term of the
//!   window in log space, times s, [`HE_STRIDED_TERMS`] = 32 of them. The terms are a smooth
//!   bell of width w ≈ 1/√(−d²ln t/dm²) and the window spans about ±6.5w, so s ≈ 13w/32 and
//!   by Poisson summation the relative error of the strided sum is ~exp(−2π²w²/s²) ≈ e^(−120),
//!   far below f32's rounding. Measured: on a grid of 3,581 wide windows (g from 1e-3 to 1e4,
//!   c up to 1e7·g) the stride was at most 0.50 of the predicted width and the worst error
//!   3.6e-6; 16 terms gave the same worst error as 128 on the random arguments of
//!   tests/brdf_he.rs (with the wider window of e^(−40)).
//!
//! The total error is f32 rounding: measured against an f64 sum of every term
//! (tests/brdf_he.rs). The narrow sum costs one bisection of ≤ 40 log evaluations and an `exp`
//! a term; the wide one three bisections and 32 exp/log pairs. Before, every window was summed
//! in log space (an `exp` and one or two `ln`s a term, after three bisections), the wide ones
//! over 128 terms: the CPU reference renders a Cornell box with He's walls (σ₀ = 0.18 µm) 2.0x
//! faster since (docs/bench-log.md, "He's series walked from its largest term").
//!
//! GLSL twin: `shaders/brdf/he/series.glsl`.

use crate::brdf::common::expm1_f;
use std::f32::consts::PI;

/// Cap on the number of series terms evaluated (the GPU loop bound).
pub const HE_MAX_TERMS: u32 = 128;
/// Terms of the strided sum over a wide window (every s-th term, s = ⌈window / 32⌉).
pub const HE_STRIDED_TERMS: u32 = 32;

/// φ(ε) = ε − ln(1 + ε) ≥ 0 for ε > −1, without cancellation near 0: with z = ε/(2 + ε),
/// φ = 2z²/(1 − z) − 2(z³/3 + z⁵/5 + …) for |z| ≤ 1/3, the direct form otherwise.
pub fn phi_ln(eps: f32) -> f32 {
    let z = eps / (2.0 + eps);
    if z.abs() > 1.0 / 3.0 {
        return eps - (1.0 + eps).ln();
    }
    let z2 = z * z;
    // z³(1/3 + z²/5 + z⁴/7 + … + z¹²/15): Horner.
    let s = 1.0 / 3.0
        + z2 * (1.0 / 5.0
            + z2 * (1.0 / 7.0
                + z2 * (1.0 / 9.0 + z2 * (1.0 / 11.0 + z2 * (1.0 / 13.0 + z2 * (1.0 / 15.0))))));
    2.0 * z2 / (1.0 - z) - 2.0 * z * z2 * s
}

/// Stirling remainder r(m) = ln m! − (m ln m − m + ½ ln 2πm) for integer m ≥ 1: exact table
/// for m ≤ 3, 1/(12m) − 1/(360m³) + 1/(1260m⁵) above (error < 4e-8).
pub fn stirling_remainder(m: f32) -> f32 {
    if m < 1.5 {
        return 0.081_061_47;
    }
    if m < 2.5 {
        return 0.041_340_7;
    }
    if m < 3.5 {
        return 0.027_677_926;
    }
    let i = 1.0 / m;
    let i2 = i * i;
    i * (1.0 / 12.0 - i2 * (1.0 / 360.0 - i2 * (1.0 / 1260.0)))
}

/// ln t(m) of the series term t(m) = gᵐ e^(−g)/(m!·m) · e^(−c/m), for integer m ≥ 1, as
/// L − ½ln(2πm) − r(m) − ln m − c/m with L = m ln(g/m) + m − g = −m·φ(g/m − 1): by the series
/// of [`phi_ln`] for g/m in [½, 2] (where the direct form cancels), and as m(ln g − ln m) + m − g
/// outside (where φ(g/m − 1) would lose the digits of g in 1 + (g/m − 1): 1.3 % at g = 1e-6).
///
/// Never inlined, as the plain release build already leaves it: the profile-guided build
/// (`scripts/pgo-build.sh`) inlined it into [`series`], and renders of He's model, whose time
/// is mostly this function's `ln`s and the caller's `exp`, became 4 % slower
/// (docs/bench-log.md, "A build guided by a profile").
#[inline(never)]
pub fn series_log_term(g: f32, c: f32, m: f32) -> f32 {
    let ln_m = m.ln();
    let r = g / m;
    let lead = if (0.5..=2.0).contains(&r) {
        -m * phi_ln(r - 1.0)
    } else {
        m * (g.ln() - ln_m) + m - g
    };
    lead - 0.5 * (2.0 * PI).ln() - 0.5 * ln_m - stirling_remainder(m) - ln_m - c / m
}

/// ln of the ratio of consecutive series terms, ln(t(m+1)/t(m)) = ln g + ln(m/(m+1)²)
/// + c/(m(m+1)). The ratio decreases with m (see [`series_ends`]).
pub fn series_log_ratio(g: f32, c: f32, m: f32) -> f32 {
    let n = m + 1.0;
    g.ln() + (m / (n * n)).ln() + c / (m * n)
}

/// The ratio itself, ρ(m) = t(m+1)/t(m) = g·m/(m+1)² · e^(c/(m(m+1))): +∞ where the exponential
/// overflows (far below the mode, where c ≫ m²), never NaN for g > 0, c ≥ 0, m ≥ 1.
pub fn series_ratio(g: f32, c: f32, m: f32) -> f32 {
    let n = m + 1.0;
    g * m / (n * n) * (c / (m * n)).exp()
}

/// How far below its largest term a window end must be: e^(−20) ≈ 2.1e-9, so that the window
/// omits less than f32's rounding of the sum (it was e^(−40) until the walk of
/// [`series_walk`]; half the drop makes the window about 0.7 as wide).
pub const HE_WINDOW_DROP: f32 = 20.0;
/// Bisection steps for each of the mode and the two window ends (enough for 2^40 > any m).
pub const HE_BISECTION_STEPS: u32 = 40;

/// [`HE_BISECTION_STEPS`] halvings of the integer bracket [a, b]: the midpoint replaces `b` where
/// `to_b` holds there, `a` otherwise; returns the last bracket (GLSL: the `HE_BISECT` macro).
fn bisect(mut a: f32, mut b: f32, to_b: impl Fn(f32) -> bool) -> (f32, f32) {
    for _ in 0..HE_BISECTION_STEPS {
        if b - a <= 1.0 {
            break;
        }
        let mid = (0.5 * (a + b)).floor();
        if to_b(mid) {
            b = mid;
        } else {
            a = mid;
        }
    }
    (a, b)
}

/// The mode m̂ of the series' terms (its largest term): the smallest m ≥ 1 with ln ρ(m) < 0,
/// by bisection in [1, ⌈max(2g, 2√c)⌉ + 1] (why it lies there: [`series_ends`]).
pub fn series_mode(g: f32, c: f32) -> f32 {
    if series_log_ratio(g, c, 1.0) < 0.0 {
        return 1.0;
    }
    let m_up = (2.0 * g).max(2.0 * c.sqrt()).ceil() + 1.0;
    bisect(1.0, m_up, |m| series_log_ratio(g, c, m) < 0.0).1
}

/// The summation window [lo, hi] of [`series`] around the mode m̂ = [`series_mode`] (largest
/// term), by two bisections.
///
/// **Why it is enough** (proof). The ratio of consecutive terms is
/// ρ(m) = t(m+1)/t(m) = g·m/(m+1)² · e^(c/(m(m+1))), a product of two positive factors that
/// both decrease for m ≥ 1 (d/dm m/(m+1)² = (1−m)/(m+1)³ ≤ 0; c ≥ 0). So t rises while
/// ρ ≥ 1 and falls after: the mode m̂ is the smallest m with ρ(m) < 1, and a bisection on the
/// sign of ln ρ finds it. ρ(m) < 1 for m ≥ max(2g, 2√c): there ln(g/(m+1)) < −ln 2 and
/// c/(m(m+1)) < ¼, so m̂ ≤ ⌈max(2g, 2√c)⌉ + 1. This is where c enters: e^(−c/m) moves the mode
/// from g up to about √(c / ln(m̂/g)) when c ≫ g², far outside the old window g ± 8√g.
///
/// * Upper end: hi is the smallest m ≥ m̂ with ρ(hi) < 1 and t(hi)·ρ(hi)/(1 − ρ(hi)) ≤
///   e^(−20)·t(m̂) (in logs: ln t(hi) − ln(1/ρ(hi) − 1) ≤ ln t(m̂) − 20). Since ρ decreases,
///   t(hi + j) ≤ t(hi)·ρ(hi)^j, so Σ_{m>hi} t(m) ≤ t(hi)·ρ(hi)/(1 − ρ(hi)) ≤ e^(−20)·t(m̂).
///   The left side decreases with m after m̂ (t falls, ρ falls), so once true the condition
///   stays true and a bisection finds hi; its upper bracket H = ⌈max(4g, 2√c)⌉ + 60 satisfies
///   it (from max(4g, 2√c) on, ln ρ < ln(g/(m+1)) + ¼ < −ln 2, and then ≥ 58 halvings).
/// * Lower end: lo = 1 when no m ≤ m̂ qualifies; otherwise the largest m ≤ m̂ with
///   ρ(m−1) > 1 and t(m)/(ρ(m−1) − 1) ≤ e^(−20)·t(m̂). Below lo the terms fall at least by
///   1/ρ(lo−1) per step (ρ is larger further down), so Σ_{m<lo} t(m) ≤ t(lo)/(ρ(lo−1) − 1).
///
/// With t(m̂) ≤ Σ t, the window omits at most 2e^(−20) ≈ 4.1e-9 of the sum, for every g > 0
/// and c ≥ 0, up to the f32 rounding of the tests themselves (ln t has absolute error
/// ~1e-7·|ln t|: where that is a few units, the omitted part can reach e^(−17) ≈ 4e-8, still
/// under f32's rounding of the sum). For c = 0 and large g the window is about g ± 6.5√g.
pub fn series_ends(g: f32, c: f32, mode: f32) -> (f32, f32) {
    let start = 2.0 * c.sqrt();
    let peak = series_log_term(g, c, mode) - HE_WINDOW_DROP;
    // Upper end: smallest m in [mode, h_up] with ln ρ(m) < 0 and
    // ln t(m) − ln(1/ρ(m) − 1) ≤ ln t(m̂) − 20.
    let h_up = (4.0 * g).max(start).ceil() + 60.0;
    let up_ok = |m: f32| {
        let lr = series_log_ratio(g, c, m);
        lr < 0.0 && series_log_term(g, c, m) - expm1_f(-lr).ln() <= peak
    };
    let hi = if up_ok(mode) {
        mode
    } else {
        bisect(mode, h_up, up_ok).1
    };
    // Lower end: largest m in [1, mode] with both conditions, or 1.
    let lo_ok = |m: f32| {
        if m <= 1.0 {
            return true;
        }
        let lr = series_log_ratio(g, c, m - 1.0);
        lr > 0.0 && series_log_term(g, c, m) - expm1_f(lr).ln() <= peak
    };
    let lo = if lo_ok(mode) {
        mode
    } else {
        bisect(1.0, mode, |m| !lo_ok(m)).0
    };
    (lo, hi)
}

/// The series' sum relative to its largest term, Σ t(m)/t(m̂) over the window of
/// [`series_ends`], term by term outwards from the mode m̂, each term the previous one times
/// [`series_ratio`] (or divided by it, going down). The walk up stops at the first m with
/// ρ(m) < 1 and t(m)·ρ(m)/(1 − ρ(m)) ≤ e^(−20)·t(m̂), the walk down at m = 1 or the first m
/// with ρ(m−1) > 1 and t(m)/(ρ(m−1) − 1) ≤ e^(−20)·t(m̂): the ends [`series_ends`] bisects
/// for (the tests are monotone, so the first m met is the one it finds). `None` when the window
/// holds more than [`HE_MAX_TERMS`] terms: [`series`] then sums every s-th term.
pub fn series_walk(g: f32, c: f32, mode: f32) -> Option<f32> {
    // e^(−HE_WINDOW_DROP): a window end's tail bound relative to the largest term.
    let drop = (-HE_WINDOW_DROP).exp();
    let mut sum = 1.0f32;
    let mut terms = 1;
    // Up: ρ(m) < 1 from the mode on, so the products stay below 1.
    let (mut m, mut t) = (mode, 1.0f32);
    loop {
        let rho = series_ratio(g, c, m);
        if rho < 1.0 && t * rho <= drop * (1.0 - rho) {
            break;
        }
        if terms == HE_MAX_TERMS {
            return None;
        }
        t *= rho;
        m += 1.0;
        sum += t;
        terms += 1;
    }
    // Down: ρ(m − 1) ≥ 1 below the mode; +∞ (overflow far below it) ends the walk at once.
    let (mut m, mut t) = (mode, 1.0f32);
    while m > 1.0 {
        let rho = series_ratio(g, c, m - 1.0);
        if rho > 1.0 && t <= drop * (rho - 1.0) {
            break;
        }
        if terms == HE_MAX_TERMS {
            return None;
        }
        t /= rho;
        m -= 1.0;
        sum += t;
        terms += 1;
    }
    Some(sum)
}

/// Whether the window looks narrow enough for [`series_walk`], so that a wide one does not
/// spend 128 terms on a walk that gives up. ln t(m) ≈ m ln g − ln m! − c/m has curvature
/// −1/m − 2c/m³ at the mode, so the bell's width is w ≈ √(m̂³/(m̂² + 2c)) and the window, out
/// to e^(−D) (D = [`HE_WINDOW_DROP`] = 20), about 2√(2D)·w terms; the walk is tried where
/// that is at most 110. Only a choice
/// of method (both are exact): on a grid of 24,000 (g, c), g from 1e-3 to 1e4 and c up to
/// 1e7·g, no walk tried under this bound gave up.
pub fn series_looks_narrow(c: f32, mode: f32) -> bool {
    // 8D·w² ≤ 110², without the division (GLSL twin: the same expression).
    8.0 * HE_WINDOW_DROP * mode * mode * mode <= 12100.0 * (mode * mode + 2.0 * c)
}

/// Σ_{m≥1} gᵐ e^(−g)/(m!·m) · e^(−c/m) over the window of [`series_ends`] (which accounts
/// for e^(−c/m)): by [`series_walk`] times the largest term, or, where the window looks wide
/// ([`series_looks_narrow`]) or the walk gives up, [`HE_STRIDED_TERMS`] terms in log space,
/// every s-th one weighted s (see the module header for the accuracy of both).
pub fn series(g: f32, c: f32) -> f32 {
    if g <= 1e-30 || c.is_nan() || c < 0.0 {
        return 0.0;
    }
    let mode = series_mode(g, c);
    if series_looks_narrow(c, mode) {
        if let Some(relative) = series_walk(g, c, mode) {
            return series_log_term(g, c, mode).exp() * relative;
        }
    }
    let (lo, hi) = series_ends(g, c, mode);
    let count = hi - lo + 1.0;
    let stride = (count / HE_STRIDED_TERMS as f32).ceil().max(1.0);
    let mut sum = 0.0f32;
    for j in 0..HE_STRIDED_TERMS {
        let mm = lo + j as f32 * stride;
        if mm > hi {
            break;
        }
        sum += series_log_term(g, c, mm).exp();
    }
    sum * stride
}
