//! Oren–Nayar (1994): rough diffuse surfaces of V-cavity facets, each Lambertian. Survey
//! §2.1.2 (the survey describes the model in words and cites [Oren and Nayar 1994]; it gives no
//! equation, so the formulas are the paper's: Oren & Nayar 1994, the full model with its
//! interreflection term, and the paper's qualitative model for `qualitative`).
//!
//! | parameter | unit | default | range | meaning | texture: GPU record |
//! |---|---|---|---|---|---|
//! | `albedo` | RGB, unitless | `[0.5, 0.5, 0.5]` | [0, 1] | facet albedo ρ | `p[0].xyz` |
//! | `sigma` | radians | `0.3` | [0, π/2] | std-dev σ of the facet slope angle (σ = 0 is Lambert) | `p[0].w` |
//! | `variant` | — | `"full"` | `full`, `qualitative` | the paper's full model or its qualitative simplification | — |
//!
//! **Default `full`.** The survey presents Oren–Nayar only as "a generalization of the Lambert
//! model" by reference to the 1994 paper; the model of that paper is the full one (C1, C2, C3
//! and the interreflection term L2). The paper itself offers the qualitative model as a cheaper
//! approximation, so a user who names only the model gets the full one.
//!
//! Full model (α = max(θi, θo), β = min(θi, θo), Δφ = φo − φi, s = σ²):
//! * C1 = 1 − 0.5 s/(s + 0.33);
//! * C2 = 0.45 s/(s + 0.09)·sinα if cosΔφ ≥ 0, else 0.45 s/(s + 0.09)·(sinα − (2β/π)³);
//! * C3 = 0.125 s/(s + 0.09)·(4αβ/π²)²;
//! * L1 = ρ/π·[C1 + cosΔφ·C2·tanβ + (1 − |cosΔφ|)·C3·tan((α + β)/2)];
//! * L2 = 0.17 ρ²/π · s/(s + 0.13) · [1 − cosΔφ·(2β/π)²];  f = max(L1, 0) + L2.
//!
//! Qualitative model: f = ρ/π·[A + B·max(0, cosΔφ)·sinα·tanβ], A = C1, B = 0.45 s/(s + 0.09),
//! evaluated trig-free as ρ/π·[A + B·max(0, s_xy)/max(cosθi, cosθo)] with
//! s_xy = wi.x·wo.x + wi.y·wo.y = sinθi sinθo cosΔφ.
//!
//! **Reciprocity and energy.** Both variants are reciprocal (symmetric in θi, θo and Δφ).
//! Neither conserves energy exactly: the qualitative model drops the interreflections, so its
//! albedo at normal incidence is ρ·A (0.920 at σ = 0.25, 0.785 at σ = 0.5, 0.624 at σ = 1 for
//! ρ = 1), and both exceed 1 near grazing when ρ ≈ 1 (at σ = 0.25, 85°: qualitative 1.007,
//! full 1.030; Fujii: the full model breaks conservation for ρ > 0.97, so `albedo` > 0.97 gives a
//! warning). For large σ at grazing back-scatter the full L1 can go negative (the C2 term with
//! cosΔφ < 0); it is clamped to 0 — the only departure from the paper.
//!
//! Numerics: sinθ from the xy components (no 1 − cos² cancellation), θ by atan2, tanβ and
//! tan((α+β)/2) as sine ratios (half-angle identity) with denominators floored at 1e-6, cosΔφ = 0
//! when either direction is within 1e-4 of the pole (pbrt).
//!
//! Sampling: cosine-weighted (pdf = cosθ/π), weight = π·f.
//!
//! GPU record: `p[0].xyz` = albedo, `p[0].w` = σ, `p[1].x` = variant (0 full, 1 qualitative).

use super::common::{diffuse_pdf, same_hemisphere_up, sample_diffuse};
use super::{Brdf, BrdfSample, Param, ParamError, ParamReader, Params, Representative};
use glam::{Vec2, Vec3, Vec4};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, PI};
use std::sync::Arc;

#[derive(Clone, Debug, PartialEq)]
pub struct OrenNayar {
    pub albedo: Vec3,
    pub sigma: f32,
    pub variant: Variant,
}

choice_enum! {
    pub enum Variant {
        Full = "full" => "OREN_NAYAR_FULL",
        Qualitative = "qualitative" => "OREN_NAYAR_QUALITATIVE",
    }
}

declare_model! {
    survey: "§2.1.2 (Oren & Nayar 1994)";
    params: {
        ALBEDO = rgb("albedo", "RGB, unitless", [0.5; 3], (0.0, 1.0), "facet albedo ρ").at(0);
        // The upper end, π/2, is checked in `parse` with a message about degrees.
        SIGMA = scalar("sigma", "radians", 0.3, (0.0, f32::INFINITY), "std-dev σ of the facet slope angle (σ = 0 is Lambert)").range_text("[0, π/2]").at(3).texels_in(0.0, std::f32::consts::FRAC_PI_2);
        VARIANT = choice("variant", Variant::NAMES, Variant::Full.name(), "the paper's full model or its qualitative simplification");
    }
    representative: Representative::One(r#"model = "oren_nayar", albedo = 0.8, sigma = 0.3"#);
    record_codes: [Variant];
}

pub fn parse(r: &mut ParamReader) -> Result<Arc<dyn Brdf>, ParamError> {
    let albedo = r.rgb_of(&ALBEDO)?;
    let sigma = r.scalar_of(&SIGMA)?;
    if sigma > FRAC_PI_2 {
        return Err(r.error(
            "sigma",
            format!(
                "{sigma} is out of range: must be in [0, π/2] radians (σ is the slope-angle \
                 std-dev in radians; {sigma}° would be {:.4})",
                sigma.to_radians()
            ),
        ));
    }
    let variant = r.choice_of(&VARIANT)?;
    if albedo.max_element() > 0.97 {
        r.warn(
            "albedo",
            "Oren–Nayar reflects more than it receives near grazing incidence for albedo > 0.97 \
             (albedo 1.03 at 85° for σ = 0.25, full model)",
        );
    }
    Ok(Arc::new(OrenNayar {
        albedo,
        sigma,
        variant,
    }))
}

/// f_r of Oren & Nayar 1994 (survey §2.1.2), without the cosine.
pub fn eval(m: &OrenNayar, wi: Vec3, wo: Vec3) -> Vec3 {
    if !same_hemisphere_up(wi, wo) {
        return Vec3::ZERO;
    }
    let s2 = m.sigma * m.sigma;
    let a = 1.0 - 0.5 * s2 / (s2 + 0.33);
    let b = 0.45 * s2 / (s2 + 0.09);
    let sin_i = Vec2::new(wi.x, wi.y).length();
    let sin_o = Vec2::new(wo.x, wo.y).length();
    // sinθi sinθo cosΔφ, exactly.
    let sxy = wi.x * wo.x + wi.y * wo.y;
    let cos_beta = wi.z.max(wo.z).max(1e-6);
    if m.variant == Variant::Qualitative {
        return m.albedo * (FRAC_1_PI * (a + b * sxy.max(0.0) / cos_beta));
    }
    let cos_dphi = if sin_i < 1e-4 || sin_o < 1e-4 {
        0.0
    } else {
        (sxy / (sin_i * sin_o)).clamp(-1.0, 1.0)
    };
    let theta_i = sin_i.atan2(wi.z);
    let theta_o = sin_o.atan2(wo.z);
    let alpha = theta_i.max(theta_o);
    let beta = theta_i.min(theta_o);
    let sin_alpha = sin_i.max(sin_o);
    let sin_beta = sin_i.min(sin_o);
    // tan((α + β)/2) = (sinα + sinβ)/(cosα + cosβ).
    let tan_half = (sin_alpha + sin_beta) / (wi.z + wo.z).max(1e-6);
    let two_beta_pi = 2.0 * beta / PI;
    let c2_tan_beta = if cos_dphi >= 0.0 {
        // The back-scatter peak grows like tanβ towards the horizon (the model's own
        // singularity), bounded by cosβ ≥ 1e-6.
        b * sin_alpha * sin_beta / cos_beta
    } else {
        b * sin_beta * forward_c2_over_cos(sin_alpha, wi.z.min(wo.z), sin_beta, wi.z.max(wo.z))
    };
    let t = 4.0 * alpha * beta / (PI * PI);
    let c3 = 0.125 * s2 / (s2 + 0.09) * t * t;
    let l1 = (a + cos_dphi * c2_tan_beta + (1.0 - cos_dphi.abs()) * c3 * tan_half).max(0.0);
    let l2 = 0.17 * s2 / (s2 + 0.13) * (1.0 - cos_dphi * two_beta_pi * two_beta_pi);
    (m.albedo * l1 + m.albedo * m.albedo * l2) * FRAC_1_PI
}

/// (sinα − (2β/π)³)/cosβ, the forward-scatter C2 over cosβ, from the sines and cosines of α ≥ β.
/// Towards the horizon both terms of the difference tend to 1 and cosβ to 0 (in f32 the
/// difference was all rounding, and the GPU and CPU differed by 12 % at cosθ = 1e-7, stress
/// suite). Written with δβ = π/2 − β = atan2(cosβ, sinβ) and δα = π/2 − α:
/// sinα − (2β/π)³ = x(3 − 3x + x²) − 2 sin²(δα/2), x = 2δβ/π, each term accurate, and δβ/cosβ
/// tends to 1/sinβ: finite at the horizon, as the model's limit is.
fn forward_c2_over_cos(sin_alpha: f32, cos_alpha: f32, sin_beta: f32, cos_beta: f32) -> f32 {
    let cos_beta = cos_beta.max(1e-30);
    let d_beta = cos_beta.atan2(sin_beta);
    let d_alpha = cos_alpha.max(0.0).atan2(sin_alpha);
    let x = 2.0 * d_beta / PI;
    let h = (0.5 * d_alpha).sin();
    (2.0 / PI) * (d_beta / cos_beta) * (3.0 - 3.0 * x + x * x) - 2.0 * h * h / cos_beta
}

pub fn pdf(_m: &OrenNayar, given: Vec3, sampled: Vec3) -> f32 {
    diffuse_pdf(given, sampled)
}

pub fn sample(m: &OrenNayar, given: Vec3, _u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
    // f·cosθ/(cosθ/π) = π·f, without the 0/0 at the horizon.
    sample_diffuse(given, u, |wi| eval(m, wi, given) * PI)
}

impl_brdf!(OrenNayar {
    fn with_params(&self, v: &super::textured::ParamValues) -> Arc<dyn Brdf> {
        Arc::new(OrenNayar {
            albedo: v.rgb(&ALBEDO, self.albedo),
            sigma: v.scalar(&SIGMA, self.sigma),
            variant: self.variant,
        })
    }
    fn pack(&self) -> Params {
        Params::from_vec4s([
            self.albedo.extend(self.sigma),
            Vec4::new(self.variant.code(), 0.0, 0.0, 0.0),
        ])
    }
    fn scatters(&self) -> bool {
        self.albedo != Vec3::ZERO
    }
});

#[cfg(test)]
mod tests {
    use super::*;

    /// Forward scattering at the horizon (opposite azimuths, cosθ = 1.4e-7 on both sides): the
    /// C2 term is a difference of two numbers near 1 times tanβ near 7e6; it must match the
    /// model evaluated in f64 (it was 8 % off in f32 on the CPU, 2 % on the GPU, stress suite).
    #[test]
    fn forward_scatter_at_the_horizon_matches_f64() {
        let f64_eval = |sigma: f64, wi: [f64; 3], wo: [f64; 3]| -> f64 {
            let s2 = sigma * sigma;
            let (a, b) = (1.0 - 0.5 * s2 / (s2 + 0.33), 0.45 * s2 / (s2 + 0.09));
            let (si, so) = (wi[0].hypot(wi[1]), wo[0].hypot(wo[1]));
            let cd = ((wi[0] * wo[0] + wi[1] * wo[1]) / (si * so)).clamp(-1.0, 1.0);
            let (ti, to) = (si.atan2(wi[2]), so.atan2(wo[2]));
            let (al, be) = (ti.max(to), ti.min(to));
            let c2 = b * (al.sin() - (2.0 * be / std::f64::consts::PI).powi(3));
            let t = 4.0 * al * be / (std::f64::consts::PI * std::f64::consts::PI);
            let c3 = 0.125 * s2 / (s2 + 0.09) * t * t;
            let l1 = a + cd * c2 * be.tan() + (1.0 - cd.abs()) * c3 * ((al + be) / 2.0).tan();
            let l2 =
                0.17 * s2 / (s2 + 0.13) * (1.0 - cd * (2.0 * be / std::f64::consts::PI).powi(2));
            (l1.max(0.0) + l2) / std::f64::consts::PI
        };
        for (sigma, z) in [
            (0.372_274_73f32, 1.357_249_5e-7f32),
            (1.0, 1e-5),
            (0.3, 3e-4),
        ] {
            let m = on(sigma, Variant::Full);
            let r = (1.0 - (z as f64) * (z as f64)).sqrt() as f32;
            let (wi, wo) = (Vec3::new(0.0, r, z), Vec3::new(0.0, -r, z));
            let got = eval(&m, wi, wo).x as f64;
            let want = f64_eval(
                sigma as f64,
                [0.0, r as f64, z as f64],
                [0.0, -r as f64, z as f64],
            );
            assert!(
                (got / want - 1.0).abs() < 1e-4,
                "sigma {sigma}, cos {z}: {got} vs {want}"
            );
        }
    }
    use crate::brdf::validate::dir_from_theta_deg;

    fn on(sigma: f32, variant: Variant) -> OrenNayar {
        OrenNayar {
            albedo: Vec3::ONE,
            sigma,
            variant,
        }
    }

    #[test]
    fn sigma_zero_is_lambert() {
        for v in [Variant::Full, Variant::Qualitative] {
            let m = on(0.0, v);
            for (a, b) in [(0.0, 0.0), (30.0, 70.0), (89.9, 10.0), (60.0, 60.0)] {
                let f = eval(&m, dir_from_theta_deg(a, 0.0), dir_from_theta_deg(b, 120.0));
                assert!(
                    (f - Vec3::splat(FRAC_1_PI)).abs().max_element() < 1e-6,
                    "{f}"
                );
            }
        }
    }

    #[test]
    fn finite_at_edges() {
        let dirs = [
            Vec3::Z,
            dir_from_theta_deg(89.999, 0.0),
            dir_from_theta_deg(89.999, 180.0),
            Vec3::new(1.0, 0.0, 1e-30),
            Vec3::new(-1.0, 0.0, 1e-30),
            Vec3::new(0.0, 1.0, f32::MIN_POSITIVE),
            dir_from_theta_deg(1e-3, 90.0),
            dir_from_theta_deg(45.0, 45.0),
        ];
        for sigma in [0.0, 0.25, 1.0, FRAC_PI_2] {
            for v in [Variant::Full, Variant::Qualitative] {
                let m = on(sigma, v);
                for a in dirs {
                    for b in dirs {
                        let f = eval(&m, a, b);
                        assert!(
                            f.is_finite() && f.min_element() >= 0.0,
                            "{sigma} {v:?} {a} {b}: {f}"
                        );
                        let s = sample(&m, a, 0.0, Vec2::new(0.3, 0.7)).unwrap();
                        assert!(s.weight.is_finite() && s.pdf > 0.0);
                    }
                }
            }
        }
    }

    #[test]
    fn trig_free_qualitative_equals_angle_form() {
        let (sigma, a_deg, b_deg, dphi) = (0.6f32, 35.0f32, 70.0f32, 40.0f32);
        let m = on(sigma, Variant::Qualitative);
        let f = eval(
            &m,
            dir_from_theta_deg(a_deg, 10.0),
            dir_from_theta_deg(b_deg, 10.0 + dphi),
        )
        .x;
        let s2 = sigma * sigma;
        let (a, b) = (1.0 - 0.5 * s2 / (s2 + 0.33), 0.45 * s2 / (s2 + 0.09));
        let expect = FRAC_1_PI
            * (a + b
                * dphi.to_radians().cos()
                * b_deg.to_radians().sin()
                * a_deg.to_radians().tan());
        assert!((f - expect).abs() < 1e-5 * expect, "{f} vs {expect}");
    }
}
