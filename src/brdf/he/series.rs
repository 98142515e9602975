//! The series of the directional-diffuse term (the D of survey eq. 12),
//! Σ_{m≥1} gᵐe^(−g)/(m!·m) · exp(−c/m), is summed in log space, term by term
//! exp(−m·φ(g/m − 1) − ½ln(2πm) − r(m) − ln m − c/m), φ(ε) = ε − ln(1 + ε) (a series in
//! z = ε/(2+ε) near 0, so no cancellation), r(m) = ln m! − (m ln m − m + ½ ln 2πm) the Stirling
//! remainder (table for m ≤ 3, three-term series above), over the window of
//! [`series_window`]: around the largest term m̂ (found by bisection on the ratio of
//! consecutive terms, which decreases with m), out to where the terms are e^(−40) below it and
//! fall geometrically; proved there to omit at most 2e^(−40) ≈ 8.5e-18 of the sum for every g
//! and every c. (A window fixed around g, such as m ∈ [g − 8√g, g + 8√g + 10], would miss that
//! e^(−c/m) moves the largest terms to m ≫ g when c ≫ g²: rough surfaces far from the specular
//! direction would be 2 % off where the value is below 1e-20.) The loop is capped at
//! [`HE_MAX_TERMS`] = 128 evaluations (the GPU needs a bound): when the window is wider the sum
//! takes every s-th term times s. The terms are a smooth bell of width w ≈ 1/√(−d²ln t/dm²)
//! and the window spans about ±9w, so s ≈ 18w/128 and by Poisson summation the relative error
//! of the strided sum is ~exp(−2π²w²/s²) ≈ e^(−990): the cap costs no accuracy. The total
//! error is f32 rounding: measured against an f64 sum of every term (tests/brdf_he.rs). The
//! cost is ≤ 128 exp/log pairs plus three bisections of ≤ 40 log evaluations per channel.
//!
//! GLSL twin: `shaders/brdf/he/series.glsl`.

use crate::brdf::common::expm1_f;
use std::f32::consts::PI;

/// Cap on the number of series terms evaluated (the GPU loop bound).
pub const HE_MAX_TERMS: u32 = 128;

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

/// ln of the ratio of consecutive series terms, ln(t(m+1)/t(m)) = ln g + ln(m/(m+1))
/// − ln(m+1) + c/(m(m+1)). The ratio decreases with m (see [`series_window`]).
pub fn series_log_ratio(g: f32, c: f32, m: f32) -> f32 {
    g.ln() + (m / (m + 1.0)).ln() - (m + 1.0).ln() + c / (m * (m + 1.0))
}

/// How far below its largest term a window end must be: e^(−40) ≈ 4e-18.
pub const HE_WINDOW_DROP: f32 = 40.0;
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

/// The summation window [lo, hi] of [`series`] and its mode m̂ (largest term).
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
///   e^(−40)·t(m̂) (in logs: ln t(hi) − ln(1/ρ(hi) − 1) ≤ ln t(m̂) − 40). Since ρ decreases,
///   t(hi + j) ≤ t(hi)·ρ(hi)^j, so Σ_{m>hi} t(m) ≤ t(hi)·ρ(hi)/(1 − ρ(hi)) ≤ e^(−40)·t(m̂).
///   The left side decreases with m after m̂ (t falls, ρ falls), so once true the condition
///   stays true and a bisection finds hi; its upper bracket H = ⌈max(4g, 2√c)⌉ + 60 satisfies
///   it (from max(4g, 2√c) on, ln ρ < ln(g/(m+1)) + ¼ < −ln 2, and then ≥ 58 halvings).
/// * Lower end: lo = 1 when no m ≤ m̂ qualifies; otherwise the largest m ≤ m̂ with
///   ρ(m−1) > 1 and t(m)/(ρ(m−1) − 1) ≤ e^(−40)·t(m̂). Below lo the terms fall at least by
///   1/ρ(lo−1) per step (ρ is larger further down), so Σ_{m<lo} t(m) ≤ t(lo)/(ρ(lo−1) − 1).
///
/// With t(m̂) ≤ Σ t, the window omits at most 2e^(−40) ≈ 8.5e-18 of the sum, for every g > 0
/// and c ≥ 0, up to the f32 rounding of the tests themselves (ln t has absolute error
/// ~1e-7·|ln t|, a few units at most, which the 40 absorbs many times over). For c = 0 and
/// large g the window is about g ± 9.4√g, like the old g ± 8√g.
pub fn series_window(g: f32, c: f32) -> (f32, f32, f32) {
    let start = 2.0 * c.sqrt();
    // Mode: smallest m with ln ρ(m) < 0, in [1, m_up].
    let m_up = (2.0 * g).max(start).ceil() + 1.0;
    let mode = if series_log_ratio(g, c, 1.0) < 0.0 {
        1.0
    } else {
        bisect(1.0, m_up, |m| series_log_ratio(g, c, m) < 0.0).1
    };
    let peak = series_log_term(g, c, mode) - HE_WINDOW_DROP;
    // Upper end: smallest m in [mode, h_up] with ln ρ(m) < 0 and
    // ln t(m) − ln(1/ρ(m) − 1) ≤ ln t(m̂) − 40.
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
    (lo, mode, hi)
}

/// Σ_{m≥1} gᵐ e^(−g)/(m!·m) · e^(−c/m), in log space over the window of [`series_window`]
/// (which accounts for e^(−c/m)) with at most [`HE_MAX_TERMS`] evaluations (stride s, each
/// term weighted s; see the module header for the accuracy).
pub fn series(g: f32, c: f32) -> f32 {
    if g <= 1e-30 || c.is_nan() || c < 0.0 {
        return 0.0;
    }
    let (lo, _, hi) = series_window(g, c);
    let count = hi - lo + 1.0;
    let stride = (count / HE_MAX_TERMS as f32).ceil().max(1.0);
    let mut sum = 0.0f32;
    for j in 0..HE_MAX_TERMS {
        let mm = lo + j as f32 * stride;
        if mm > hi {
            break;
        }
        sum += series_log_term(g, c, mm).exp();
    }
    sum * stride
}
