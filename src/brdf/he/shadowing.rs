//! He et al. 1991's shadowing function S₁ (eq. 13, with the erratum's e^(−a²) in Λ, eqs.
//! 24–25 of the paper) and the effective roughness σ (eqs. 80–83 of the paper), which the
//! directional-diffuse and coherent terms ([`super::terms`]) evaluate. GLSL twin:
//! `shaders/brdf/he/shadowing.glsl`.

use super::He;
use crate::brdf::common::erfc;
use glam::Vec3;
use std::f32::consts::PI;

/// Newton steps of the effective-roughness equation.
pub const HE_NEWTON_STEPS: u32 = 6;

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
    // From a = 9, e < 2e-36 vanishes beside n = a in f32 (S₁ = 1 either way); not formed, as
    // e^(−a²) would be subnormal or underflow, which costs Intel cores microcode assists.
    let e = if a >= 9.0 {
        0.0
    } else {
        (-a * a).exp() * (0.5 / PI.sqrt())
    };
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
