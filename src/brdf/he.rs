//! He, Torrance, Sillion & Greenberg 1991: physical-optics reflection from a rough surface with
//! Gaussian height statistics. Survey eqs. 10–15: f_r = f_sp + f_dd + f_ud, evaluated per RGB
//! channel at one wavelength each. Formulas follow He et al. 1991 (eqs. 24–25 shadowing with the
//! e^(−a²) factor of the paper's erratum, eqs. 76–83), as re-derived by Pacanowski & Holzschuch
//! ("Demystifying the He, Torrance, Sillion and Greenberg BRDF") and checked against the
//! Torrance–Sparrow rough limit (tests/brdf_he.rs); they correct the survey's transcription in
//! three places.
//!
//! | parameter | unit | default | range | meaning | texture: GPU record |
//! |---|---|---|---|---|---|
//! | `sigma0` | µm | `0.18` | [0, 50] | rms surface height σ₀ (survey fig. 9: 0.18–0.38 µm) | `p[0].x` |
//! | `tau` | µm | `3` | (0, 1000] | autocorrelation length τ (survey fig. 9: 3.0 µm) | `p[0].y` |
//! | `ior` | RGB | `[1.37, 0.96, 0.62]` | (0, 100] | real part n(λ) of the complex index | `p[1].xyz` |
//! | `k` | RGB | `[7.62, 6.69, 5.47]` | [0, 100] | imaginary part κ(λ) (defaults: approximate aluminium, the survey's fig. 9 material) | `p[2].xyz` |
//! | `wavelengths` | µm per channel | `[0.65, 0.55, 0.45]` | [0.2, 5] | λ at which each channel is evaluated | `p[3].xyz` |
//! | `diffuse` | RGB albedo | `[0, 0, 0]` | [0, 1] | uniform-diffuse a(λ) as an albedo: f_ud = `diffuse`/π (survey eq. 15) | `p[4].xyz` |
//!
//! **Terms** (v = wi + wo, v_z = cosθi + cosθo, v_xy² = v_x² + v_y², k = 2π/λ):
//! * f_dd = F(wi·h)·G·S·D / (π cosθi cosθo) (eq. 15), G = (v·v/v_z)² (unpolarised form of He's
//!   geometric factor), D = (π²τ²/(4λ²)) Σ_{m≥1} gᵐe^(−g)/(m!·m) · exp(−k² v_xy² τ²/(4m)),
//!   g = (k σ v_z)² (eq. 12). The survey prints eq. 15 with τ²/(16π) in place of π²τ²/(4λ²)·G/π,
//!   which is off by k² = (2π/λ)² and lacks G (it is not even dimensionless); with v = k(k_r − k_i)
//!   a wave vector, the k² belongs in the exponent, and only this form tends to Torrance–Sparrow
//!   with Beckmann m = 2σ₀/τ for g ≫ 1 (tested to 0.05 %).
//! * S = S₁(θi)·S₁(θo) (eq. 13), S₁ = [1 − ½ erfc(a)]/[1 + Λ(a)], a = τ cotθ/(2σ₀), with the
//!   erratum Λ(a) = ½[e^(−a²)/(a√π) − erfc(a)] (the survey and the 1991 paper lack e^(−a²)).
//!   Evaluated as S₁ = N/(N + e^(−a²)/(2√π)), N = a(1 − ½ erfc a): no 1/a, no cancellation.
//! * σ is He's effective roughness: x = z₀/σ₀ solves x·e^(x²/2) = (K(θi) + K(θo))/√(8π),
//!   K(θ) = tanθ·erfc(τ/(2σ₀ tanθ)), σ = σ₀/√(1 + x²); solved by [`HE_NEWTON_STEPS`] Newton steps
//!   on ln x + x²/2 = ln f₀ from a start that converges monotonically (see [`solve_z0`]).
//! * f_sp (eq. 11) is a delta lobe in the mirror direction with reflectance
//!   F(cosθi)·e^(−g_s)·S₁(θi)², g_s = (4πσ cosθi/λ)², σ at θo = θi.
//! * f_ud = `diffuse`/π: He's a(λ) is a free constant (not derived, not coupled to the other
//!   terms), exposed as a Lambertian albedo. The model is therefore not energy conserving by
//!   construction (only first-surface terms are physically derived; f_dd + f_sp alone stay
//!   ≤ F up to the Kirchhoff approximation). It is reciprocal: every factor is symmetric.
//! * F is the exact unpolarised Fresnel reflectance of the complex index n + iκ.
//!
//! **The series** is summed in log space, term by term
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
//! **Compiled out**: the directional-diffuse series is compiled only under `HE_SERIES`, which
//! every material with σ₀ > 0 requests; with σ₀ = 0 g is 0 and f_dd vanishes identically, so
//! a material without it is exact without the series (mirror × Fresnel plus uniform diffuse).
//!
//! **Sampling**: a mixture chosen from the known direction (cos μ):
//! * the delta lobe with probability ∝ luminance(F(μ)·e^(−g_s)·S₁(μ)²);
//! * Beckmann half-vector sampling (Walter et al. 2007, Beckmann sampling) with slope
//!   m_s = √((2σ₀/τ)² + (λ_max/(2πτμ))²), clamped to [1e-4, 1]: the rough-limit slope 2σ₀/τ
//!   widened to the first-order diffraction width λ/(πτ v_z) of the m = 1 term, so that smooth
//!   surfaces (g ≲ 1) are covered too; weight ∝ 0.9·luminance(F(μ)(1 − e^(−g_s)))·S₁(μ);
//! * cosine sampling with weight ∝ luminance(diffuse) + 0.1·(the directional-diffuse weight).
//!
//! pdf = P_b·D_B(h; m_s) cosθh/(4 given·h) + P_c·cosθ/π, P_b + P_c = 1 − P_delta.
//!
//! GPU record: p[0] σ₀, p[1] τ, p[2] 1 if σ₀ > 0, p[3] unused, p[4..7] ior, p[8..11] κ,
//! p[12..15] wavelengths, p[16..19] diffuse.

use super::common::{
    beckmann_d, cosine_hemisphere_pdf, erfc, expm1_f, fresnel_conductor, luminance, reflect_about,
    reflected_pdf, same_hemisphere_up, sample_beckmann_h, sample_cosine_hemisphere,
};
use super::{flag, Brdf, BrdfSample, Param, ParamError, ParamReader, Params, Representative};
use glam::{Vec2, Vec3, Vec4};
use std::f32::consts::{FRAC_1_PI, PI};
use std::sync::Arc;

/// Cap on the number of series terms evaluated (the GPU loop bound).
pub const HE_MAX_TERMS: u32 = 128;
/// Newton steps of the effective-roughness equation.
pub const HE_NEWTON_STEPS: u32 = 6;

#[derive(Clone, Debug, PartialEq)]
pub struct He {
    pub sigma0: f32,
    pub tau: f32,
    pub ior: Vec3,
    pub k: Vec3,
    pub wavelengths: Vec3,
    pub diffuse: Vec3,
}

impl Default for He {
    fn default() -> Self {
        He {
            sigma0: 0.18,
            tau: 3.0,
            ior: Vec3::new(1.37, 0.96, 0.62),
            k: Vec3::new(7.62, 6.69, 5.47),
            wavelengths: Vec3::new(0.65, 0.55, 0.45),
            diffuse: Vec3::ZERO,
        }
    }
}

declare_model! {
    survey: "eqs. 10–15";
    params: {
        SIGMA0 = scalar("sigma0", "µm", 0.18, (0.0, 50.0), "rms surface height σ₀ (survey fig. 9: 0.18–0.38 µm)").at(0);
        // τ > 0 is checked in `parse`.
        TAU = scalar("tau", "µm", 3.0, (f32::NEG_INFINITY, 1000.0), "autocorrelation length τ (survey fig. 9: 3.0 µm)").range_text("(0, 1000]").at(1).texels_in(f32::MIN_POSITIVE, 1000.0);
        // n > 0 is checked in `parse`.
        IOR = rgb("ior", "RGB", [1.37, 0.96, 0.62], (f32::NEG_INFINITY, 100.0), "real part n(λ) of the complex index").range_text("(0, 100]").at(4).texels_in(f32::MIN_POSITIVE, 100.0);
        K = rgb("k", "RGB", [7.62, 6.69, 5.47], (0.0, 100.0), "imaginary part κ(λ) (defaults: approximate aluminium, the survey's fig. 9 material)").at(8);
        WAVELENGTHS = rgb("wavelengths", "µm per channel", [0.65, 0.55, 0.45], (0.2, 5.0), "λ at which each channel is evaluated").at(12);
        DIFFUSE = rgb("diffuse", "RGB albedo", [0.0; 3], (0.0, 1.0), "uniform-diffuse a(λ) as an albedo: f_ud = `diffuse`/π (survey eq. 15)").at(16);
    }
    representative: Representative::One(r#"model = "he", sigma0 = 0.4, tau = 4.0"#);
    record_codes: [];
}

pub fn parse(r: &mut ParamReader) -> Result<Arc<dyn Brdf>, ParamError> {
    let sigma0 = r.scalar_of(&SIGMA0)?;
    // Ranges open at 0: checked here in one message (the range check's "[0, 1000]" said 0 was
    // valid, and then 0 was refused).
    let tau = r.scalar_of(&TAU)?;
    if tau <= 0.0 {
        return Err(r.error(
            "tau",
            "must be > 0 and at most 1000 (the autocorrelation length, µm)",
        ));
    }
    let ior = r.rgb_of(&IOR)?;
    if ior.min_element() <= 0.0 {
        return Err(r.error("ior", "must be > 0 and at most 100 in every channel"));
    }
    let k = r.rgb_of(&K)?;
    let wavelengths = r.rgb_of(&WAVELENGTHS)?;
    let diffuse = r.rgb_of(&DIFFUSE)?;
    let m = He {
        sigma0,
        tau,
        ior,
        k,
        wavelengths,
        diffuse,
    };
    if sigma0 > 0.25 * tau {
        r.warn(
            "sigma0",
            format!(
                "rms slope 2σ₀/τ = {:.2} > 0.5: He et al.'s Kirchhoff/shadowing approximations \
                 assume a gently sloped surface",
                2.0 * sigma0 / tau
            ),
        );
    }
    Ok(Arc::new(m))
}

/// a = τ cotθ/(2σ₀) for a direction (cosθ = w.z), capped at 30 (beyond, erfc and e^(−a²) are
/// 0 in f32); a huge value when σ₀ sinθ is 0 (smooth surface or normal incidence).
fn shadow_arg(sigma0: f32, tau: f32, w: Vec3) -> f32 {
    let s = (w.x * w.x + w.y * w.y).sqrt();
    let den = 2.0 * sigma0 * s;
    if den <= 1e-30 || tau * w.z >= 30.0 * den {
        return 30.0;
    }
    tau * w.z.max(0.0) / den
}

/// He's shadowing S₁(θ) (eq. 13 with the erratum Λ), = N/(N + e^(−a²)/(2√π)),
/// N = a(1 − ½erfc a). 1 at normal incidence or for σ₀ = 0, → 0 at grazing.
pub fn shadow_s1(sigma0: f32, tau: f32, w: Vec3) -> f32 {
    if w.z <= 0.0 {
        return 0.0;
    }
    let a = shadow_arg(sigma0, tau, w);
    let n = a * (1.0 - 0.5 * erfc(a));
    let e = (-a * a).exp() * (0.5 / PI.sqrt());
    n / (n + e)
}

/// K(θ) = tanθ·erfc(τ/(2σ₀ tanθ)) = tanθ·erfc(a), tanθ capped at 1e6.
fn k_term(sigma0: f32, tau: f32, w: Vec3) -> f32 {
    let s = (w.x * w.x + w.y * w.y).sqrt();
    if s <= 0.0 {
        return 0.0;
    }
    let tan = if s >= 1e6 * w.z { 1e6 } else { s / w.z };
    tan * erfc(shadow_arg(sigma0, tau, w))
}

/// The root x ≥ 0 of x·e^(x²/2) = f₀ (He's z₀/σ₀). Newton on g(x) = ln x + x²/2 − ln f₀, which
/// is concave for x < 1 and convex for x > 1; starting at f₀ (f₀ ≤ 1), 1 (ln f₀ < ½) or
/// √(2 ln f₀) makes every step stay positive and converge monotonically after the first.
pub fn solve_z0(f0: f32) -> f32 {
    if f0 <= 1e-30 {
        return 0.0;
    }
    let l = f0.ln();
    let mut x = if f0 <= 1.0 {
        f0
    } else if l < 0.5 {
        1.0
    } else {
        (2.0 * l).sqrt()
    };
    for _ in 0..HE_NEWTON_STEPS {
        let g = x.ln() + 0.5 * x * x - l;
        x -= g / (1.0 / x + x);
        x = x.max(1e-30);
    }
    x
}

/// He's effective roughness σ = σ₀/√(1 + x²) (eqs. 80–83 of the paper) for the pair.
pub fn effective_sigma(m: &He, wi: Vec3, wo: Vec3) -> f32 {
    if m.sigma0 <= 0.0 {
        return 0.0;
    }
    let f0 = (k_term(m.sigma0, m.tau, wi) + k_term(m.sigma0, m.tau, wo)) / (8.0 * PI).sqrt();
    let x = solve_z0(f0);
    m.sigma0 / (1.0 + x * x).sqrt()
}

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

/// The directional-diffuse term without Fresnel, G·S·D/(π cosθi cosθo), for one wavelength
/// λ and effective roughness σ (tests compare it with the rough-limit table of §8).
pub fn dd_unit(m: &He, lambda: f32, sigma: f32, wi: Vec3, wo: Vec3) -> f32 {
    let v = wi + wo;
    let vz = wi.z + wo.z;
    if vz <= 1e-6 {
        return 0.0;
    }
    let vxy2 = v.x * v.x + v.y * v.y;
    let gg = v.dot(v) / vz;
    let geo = gg * gg;
    let s = shadow_s1(m.sigma0, m.tau, wi) * shadow_s1(m.sigma0, m.tau, wo);
    let kw = 2.0 * PI / lambda;
    let ks = kw * sigma * vz;
    let g = ks * ks;
    let c = 0.25 * kw * kw * vxy2 * m.tau * m.tau;
    // D/π = (π τ²/(4λ²)) Σ.
    let d_over_pi = PI * m.tau * m.tau / (4.0 * lambda * lambda) * series(g, c);
    geo * s * d_over_pi / (wi.z * wo.z).max(1e-30)
}

/// e^(−g_s)·S₁(θ)², the specular lobe's attenuation at incidence cosθ = w.z for wavelength λ
/// (σ evaluated at θo = θi).
pub fn specular_attenuation(m: &He, lambda: f32, w: Vec3) -> f32 {
    let sigma = effective_sigma(m, w, w);
    let s1 = shadow_s1(m.sigma0, m.tau, w);
    let a = 4.0 * PI * sigma * w.z / lambda;
    (-a * a).exp() * s1 * s1
}

/// e^(−g_s) per channel for the effective roughness σ at incidence cosθ = w.z.
fn specular_exp(m: &He, sigma: f32, w: Vec3) -> Vec3 {
    let l = m.wavelengths;
    let k = 4.0 * PI * sigma * w.z;
    let a = Vec3::new(k / l.x, k / l.y, k / l.z);
    Vec3::new((-a.x * a.x).exp(), (-a.y * a.y).exp(), (-a.z * a.z).exp())
}

/// The delta lobe's reflectance F(cosθ)·e^(−g_s)·S₁² per channel.
pub fn specular_reflectance(m: &He, w: Vec3) -> Vec3 {
    let f = fresnel_conductor(w.z, m.ior, m.k);
    let sigma = effective_sigma(m, w, w);
    let s1 = shadow_s1(m.sigma0, m.tau, w);
    f * specular_exp(m, sigma, w) * (s1 * s1)
}

/// f_dd + f_ud (eqs. 10, 15); the specular delta is not seen.
pub fn eval(m: &He, wi: Vec3, wo: Vec3) -> Vec3 {
    if !same_hemisphere_up(wi, wo) {
        return Vec3::ZERO;
    }
    let ud = m.diffuse * FRAC_1_PI;
    if m.sigma0 <= 0.0 {
        return ud;
    }
    let sigma = effective_sigma(m, wi, wo);
    let h = (wi + wo).normalize();
    let f = fresnel_conductor(wi.dot(h), m.ior, m.k);
    let l = m.wavelengths;
    let dd = Vec3::new(
        dd_unit(m, l.x, sigma, wi, wo),
        dd_unit(m, l.y, sigma, wi, wo),
        dd_unit(m, l.z, sigma, wi, wo),
    );
    ud + f * dd
}

/// Lobe selection for a known direction: (P_delta, P_beckmann, P_cosine) and the Beckmann
/// slope m_s.
pub fn lobe_probabilities(m: &He, given: Vec3) -> (f32, f32, f32, f32) {
    let f = fresnel_conductor(given.z, m.ior, m.k);
    let sigma = effective_sigma(m, given, given);
    let s1 = shadow_s1(m.sigma0, m.tau, given);
    let l = m.wavelengths;
    let spec = luminance(f * specular_exp(m, sigma, given) * (s1 * s1));
    let k = 4.0 * PI * sigma * given.z;
    let a = Vec3::new(k / l.x, k / l.y, k / l.z);
    let gs = Vec3::new(
        -expm1_f(-a.x * a.x),
        -expm1_f(-a.y * a.y),
        -expm1_f(-a.z * a.z),
    );
    let wdd = luminance(f * gs) * s1;
    let wb = 0.9 * wdd;
    let wc = luminance(m.diffuse) + 0.1 * wdd;
    let total = spec + wb + wc;
    let lmax = l.max_element();
    let rough = 2.0 * m.sigma0 / m.tau;
    let diffr = lmax / (2.0 * PI * m.tau * given.z.max(1e-6));
    let ms = (rough * rough + diffr * diffr).sqrt().clamp(1e-4, 1.0);
    if total <= 0.0 {
        return (0.0, 0.0, 1.0, ms);
    }
    (spec / total, wb / total, wc / total, ms)
}

fn beckmann_lobe_pdf(ms: f32, given: Vec3, sampled: Vec3) -> f32 {
    reflected_pdf(given, sampled, |h| beckmann_d(h, ms) * h.z)
}

pub fn pdf(m: &He, given: Vec3, sampled: Vec3) -> f32 {
    if !same_hemisphere_up(given, sampled) {
        return 0.0;
    }
    let (_, pb, pc, ms) = lobe_probabilities(m, given);
    let mut p = pc * cosine_hemisphere_pdf(sampled.z);
    if pb > 0.0 {
        p += pb * beckmann_lobe_pdf(ms, given, sampled);
    }
    p
}

pub fn sample(m: &He, given: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
    if given.z <= 0.0 {
        return None;
    }
    let (pd, pb, _, ms) = lobe_probabilities(m, given);
    let wi = if u_lobe < pd {
        let weight = specular_reflectance(m, given) / pd;
        return Some(BrdfSample::mirror(given, weight));
    } else if u_lobe < pd + pb {
        let h = sample_beckmann_h(u, ms);
        reflect_about(given, h)?
    } else {
        sample_cosine_hemisphere(u)
    };
    BrdfSample::scattered(wi, |wi| pdf(m, given, wi), |wi| eval(m, wi, given))
}

impl_brdf!(He {
    fn with_params(&self, v: &super::textured::ParamValues) -> Arc<dyn Brdf> {
        Arc::new(He {
            sigma0: v.scalar(&SIGMA0, self.sigma0),
            tau: v.scalar(&TAU, self.tau),
            ior: v.rgb(&IOR, self.ior),
            k: v.rgb(&K, self.k),
            wavelengths: v.rgb(&WAVELENGTHS, self.wavelengths),
            diffuse: v.rgb(&DIFFUSE, self.diffuse),
        })
    }
    /// A textured σ₀ may be positive anywhere: the series is compiled in.
    fn textured_defines(&self, textured: &[&str]) -> Vec<&'static str> {
        match textured.contains(&"sigma0") {
            true => vec!["HE_SERIES"],
            false => self.defines(),
        }
    }
    fn pack(&self) -> Params {
        Params::from_vec4s([
            Vec4::new(self.sigma0, self.tau, flag(self.sigma0 > 0.0), 0.0),
            self.ior.extend(0.0),
            self.k.extend(0.0),
            self.wavelengths.extend(0.0),
            self.diffuse.extend(0.0),
        ])
    }
    fn defines(&self) -> Vec<&'static str> {
        if self.sigma0 > 0.0 {
            vec!["HE_SERIES"]
        } else {
            Vec::new()
        }
    }
});

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brdf::validate::{assert_finite_on_sample_grid, dir_from_theta_deg as dir};

    #[test]
    fn phi_ln_matches_f64() {
        for i in 0..2000 {
            let eps = -0.999 + i as f32 * 0.005;
            let e = eps as f64;
            let want = e - (1.0 + e).ln();
            let got = phi_ln(eps) as f64;
            assert!(
                (got - want).abs() <= 2e-6 * want + 1e-12,
                "{eps}: {got} vs {want}"
            );
        }
    }

    #[test]
    fn newton_solves_the_effective_roughness_equation() {
        for f0 in [
            1e-20f32, 1e-6, 0.01, 0.3, 1.0, 1.2, 1.7, 3.0, 100.0, 1e10, 1e30,
        ] {
            let x = solve_z0(f0) as f64;
            let lhs = x.ln() + 0.5 * x * x;
            assert!(
                (lhs - (f0 as f64).ln()).abs() < 2e-6 * (1.0 + (f0 as f64).ln().abs()),
                "{f0}: {x}"
            );
        }
        assert_eq!(solve_z0(0.0), 0.0);
    }

    #[test]
    fn finite_everywhere() {
        // (σ₀, τ, uniform diffuse): the defaults, a mirror with diffuse, and rough extremes.
        let ms = [(0.18, 3.0, 0.0), (0.0, 3.0, 0.3), (0.01, 10.0, 0.0), (5.0, 10.0, 0.1), (40.0, 100.0, 0.0)]
            .map(|(sigma0, tau, diffuse)| He {
                sigma0,
                tau,
                diffuse: Vec3::splat(diffuse),
                ..Default::default()
            });
        for m in &ms {
            assert_finite_on_sample_grid(m, &[0.0, 0.3, 0.7, 0.99], &format!("{m:?}"));
        }
    }

    #[test]
    fn smooth_surface_is_a_fresnel_mirror() {
        let m = He {
            sigma0: 0.0,
            ..Default::default()
        };
        let w = dir(40.0, 10.0);
        let s = sample(&m, w, 0.0, Vec2::splat(0.5)).unwrap();
        assert!(s.delta);
        let f = fresnel_conductor(w.z, m.ior, m.k);
        assert!((s.weight - f).abs().max_element() < 1e-6, "{s:?} {f}");
        assert!(m.defines().is_empty());
        assert_eq!(He::default().defines(), vec!["HE_SERIES"]);
    }
}
