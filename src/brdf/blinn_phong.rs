//! Blinn–Phong (1977): Phong's lobe with the halfway vector. Survey §2.1.4, eq. 5:
//! H = (L + V)/|L + V|; the lobe is (N·H)ⁿ in place of Phong's (R·V)ⁿ (eq. 4).
//!
//! | parameter | unit | default | range | meaning | texture: GPU record |
//! |---|---|---|---|---|---|
//! | `kd` | RGB, unitless | `[0.5, 0.5, 0.5]` | [0, 1] | diffuse coefficient k_d (f_d = k_d/π, eq. 3) | `p[0].xyz` |
//! | `ks` | RGB, unitless | `[0.3, 0.3, 0.3]` | [0, 1] | specular coefficient k_s | `p[1].xyz` |
//! | `exponent` | unitless | `80` | [0, 1e6] | shininess n (≈ 4× the Phong exponent for a similar highlight) | `p[0].w` |
//! | `form` | — | `"classic"` | `classic`, `normalized` | the survey's form (eq. 5) or the energy-normalised reciprocal lobe | — |
//!
//! * `classic` (default): f = k_d/π + k_s·max(0, N·H)ⁿ / cosθi. The survey defines Blinn–Phong
//!   as Phong's model (eq. 4) with R·V replaced by N·H (eq. 5), so it keeps eq. 4's 1/(N·L):
//!   the specular *intensity* is k_s (N·H)ⁿ, as in Blinn's shading formula (BRDF Explorer's
//!   `blinnphong.brdf` with `divide_by_NdotL`, the same reading).
//! * `normalized`: f = k_d/π + k_s·k_n·max(0, N·H)ⁿ, k_n = (n+2)(n+4)/(8π(2^{−n/2} + n))
//!   (Giesen 2009), which makes the lobe albedo exactly k_s at normal incidence; k_n is the
//!   normalised Blinn–Phong NDF (n+2)/(2π) cosⁿθh over 4, up to the factor
//!   (n+4)/(n+2^{−n/2}) that accounts for the cosθi weighting.
//!
//! **The classic form is neither reciprocal nor energy conserving**: f(wi, wo)/f(wo, wi) =
//! cosθo/cosθi (as for the survey Phong), and with the viewer fixed its lobe albedo at normal
//! incidence is 8π k_s (1 − 2^{−(n+2)/2})/(n+2) — 5.41 k_s at n = 1, 0.306 k_s at n = 80 —
//! growing with 1/cosθ toward grazing light; a warning is given when k_d plus that value
//! exceeds 1. The `normalized` form is reciprocal; its lobe albedo is k_s at normal incidence
//! and below k_s elsewhere (measured in tests/brdf_blinn_phong.rs); k_d + k_s > 1 warns.
//!
//! Sampling: cosine-weighted diffuse or the half vector, the lobe chosen with probability
//! P_s = lum(k_s e_s)/(lum(k_d) + lum(k_s e_s)) (e_s: the lobe albedo per unit k_s at normal
//! incidence, above); the half vector has density (e+1)/(2π) cosᵉθh, cosθh = u^{1/(e+1)}, with
//! e = n + 1 for `normalized` (the normalised NDF times cosθh) and e = n for `classic` (f·cosθi
//! is then k_s cosⁿθh, so the weight k_s cosⁿθh·4(wo·h)/pdf_h = 8π k_s (wo·h)/(n+1) is bounded by
//! 8π k_s/(n+1)); wi = reflect(wo, h), pdf = pdf_h/(4 wo·h); mixture pdf. Samples below the
//! horizon are rejected, not renormalised.
//!
//! Numerics: 1 − cosθh = sin²θh/(1 + cosθh) with sin²θh = (Hx² + Hy²)/|H|² from the
//! un-normalised H = wi + wo (no cancellation), cosⁿ via log1p; 1/cosθi uses max(cosθi, 1e-6);
//! |H|² ≤ 1e-20 (both directions grazing and opposite) has no half vector: lobe and pdf 0.
//!
//! GPU record: `p[0].xyz` = kd, `p[0].w` = exponent, `p[1].xyz` = ks, `p[1].w` = form
//! (0 classic, 1 normalized), `p[2].x` = P_s, `p[2].y` = k_n (normalized) — both computed on
//! the host.

use super::common::{
    diffuse_specular_pdf, luminance, pow_one_minus, reflect_about, same_hemisphere_up,
    sample_cosine_hemisphere, sample_power_cosine, specular_probability,
};
use super::{Brdf, BrdfSample, Param, ParamError, ParamReader, Params, Representative};
use glam::{Vec2, Vec3, Vec4};
use std::f32::consts::{FRAC_1_PI, PI};
use std::sync::Arc;

#[derive(Clone, Debug, PartialEq)]
pub struct BlinnPhong {
    pub kd: Vec3,
    pub ks: Vec3,
    pub exponent: f32,
    pub form: Form,
    /// Probability of sampling the specular lobe (derived).
    p_spec: f32,
    /// Giesen's normalisation k_n (derived; used by `normalized`).
    k_n: f32,
}

choice_enum! {
    pub enum Form {
        Classic = "classic" => "BLINN_PHONG_CLASSIC",
        Normalized = "normalized" => "BLINN_PHONG_NORMALIZED",
    }
}

const COS_FLOOR: f32 = 1e-6;

/// Giesen 2009: (n+2)(n+4)/(8π(2^{−n/2} + n)).
pub fn giesen_norm(n: f32) -> f32 {
    (n + 2.0) * (n + 4.0) / (8.0 * PI * ((-0.5 * n).exp2() + n))
}

/// Lobe albedo per unit k_s at normal incidence with the viewer fixed.
fn spec_albedo_estimate(n: f32, form: Form) -> f32 {
    match form {
        Form::Classic => 8.0 * PI * (1.0 - (-0.5 * (n + 2.0)).exp2()) / (n + 2.0),
        Form::Normalized => 1.0,
    }
}

impl BlinnPhong {
    pub fn new(kd: Vec3, ks: Vec3, exponent: f32, form: Form) -> BlinnPhong {
        let (d, s) = (
            luminance(kd),
            luminance(ks) * spec_albedo_estimate(exponent, form),
        );
        let p_spec = specular_probability(d, s);
        BlinnPhong {
            kd,
            ks,
            exponent,
            form,
            p_spec,
            k_n: giesen_norm(exponent),
        }
    }
    pub fn p_spec(&self) -> f32 {
        self.p_spec
    }
    /// Exponent of cosθh in the half-vector sampling density.
    fn sample_exponent(&self) -> f32 {
        match self.form {
            Form::Classic => self.exponent,
            Form::Normalized => self.exponent + 1.0,
        }
    }
}

declare_model! {
    survey: "§2.1.4, eq. 5";
    params: {
        KD = rgb("kd", "RGB, unitless", [0.5; 3], (0.0, 1.0), "diffuse coefficient k_d (f_d = k_d/π, eq. 3)").at(0);
        KS = rgb("ks", "RGB, unitless", [0.3; 3], (0.0, 1.0), "specular coefficient k_s").at(4);
        EXPONENT = scalar("exponent", "unitless", 80.0, (0.0, 1e6), "shininess n (≈ 4× the Phong exponent for a similar highlight)").at(3);
        FORM = choice("form", Form::NAMES, Form::Classic.name(), "the survey's form (eq. 5) or the energy-normalised reciprocal lobe");
    }
    representative: Representative::EachOption(r#"model = "blinn_phong", kd = 0.0, ks = 0.8, exponent = 200"#, FORM);
    record_codes: [Form];
}

pub fn parse(r: &mut ParamReader) -> Result<Arc<dyn Brdf>, ParamError> {
    let kd = r.rgb_of(&KD)?;
    let ks = r.rgb_of(&KS)?;
    let exponent = r.scalar_of(&EXPONENT)?;
    let form = r.choice_of(&FORM)?;
    let total = (kd + ks * spec_albedo_estimate(exponent, form)).max_element();
    if total > 1.0 {
        let msg = match form {
            Form::Classic => format!(
                "kd + ks·8π(1 − 2^(−(n+2)/2))/(n+2) = {total:.3} > 1: the classic Blinn–Phong \
                 reflects more than it receives (already at normal incidence)"
            ),
            Form::Normalized => format!(
                "kd + ks = {total:.3} > 1: the normalized Blinn–Phong then reflects more than it \
                 receives"
            ),
        };
        r.warn("ks", msg);
    }
    Ok(Arc::new(BlinnPhong::new(kd, ks, exponent, form)))
}

/// The unit half vector of a and b and 1 − h_z, or None when a + b ≈ 0.
fn half_vector(a: Vec3, b: Vec3) -> Option<(Vec3, f32)> {
    let hv = a + b;
    let len2 = hv.length_squared();
    if len2 <= 1e-20 {
        return None;
    }
    let h = hv / len2.sqrt();
    // 1 − cosθh = sin²θh/(1 + cosθh); h.z > 0 for a, b in the upper hemisphere.
    let sin2 = (hv.x * hv.x + hv.y * hv.y) / len2;
    Some((h, sin2 / (1.0 + h.z.max(0.0))))
}

pub fn eval(m: &BlinnPhong, wi: Vec3, wo: Vec3) -> Vec3 {
    if !same_hemisphere_up(wi, wo) {
        return Vec3::ZERO;
    }
    let diffuse = m.kd * FRAC_1_PI;
    let Some((_, x)) = half_vector(wi, wo) else {
        return diffuse;
    };
    let l = pow_one_minus(x, m.exponent);
    let spec = match m.form {
        Form::Classic => l / wi.z.max(COS_FLOOR),
        Form::Normalized => l * m.k_n,
    };
    diffuse + m.ks * spec
}

pub fn pdf(m: &BlinnPhong, given: Vec3, sampled: Vec3) -> f32 {
    if !same_hemisphere_up(given, sampled) {
        return 0.0;
    }
    let ps = match half_vector(given, sampled) {
        None => 0.0,
        Some((h, x)) => {
            let e = m.sample_exponent();
            let pdf_h = (e + 1.0) * (0.5 * FRAC_1_PI) * pow_one_minus(x, e);
            // given·h = |given + sampled|/2 > 0 here.
            pdf_h / (4.0 * given.dot(h).max(1e-10))
        }
    };
    diffuse_specular_pdf(m.p_spec, ps, sampled)
}

pub fn sample(m: &BlinnPhong, given: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
    if given.z <= 0.0 {
        return None;
    }
    let wi = if u_lobe < m.p_spec {
        reflect_about(given, sample_power_cosine(u, m.sample_exponent()))?
    } else {
        sample_cosine_hemisphere(u)
    };
    BrdfSample::scattered(wi, |wi| pdf(m, given, wi), |wi| eval(m, wi, given))
}

impl_brdf!(BlinnPhong {
    fn with_params(&self, v: &super::textured::ParamValues) -> Arc<dyn Brdf> {
        Arc::new(BlinnPhong::new(
            v.rgb(&KD, self.kd),
            v.rgb(&KS, self.ks),
            v.scalar(&EXPONENT, self.exponent),
            self.form,
        ))
    }
    fn pack(&self) -> Params {
        Params::from_vec4s([
            self.kd.extend(self.exponent),
            self.ks.extend(self.form.code()),
            Vec4::new(self.p_spec, self.k_n, 0.0, 0.0),
        ])
    }
    fn scatters(&self) -> bool {
        self.kd != Vec3::ZERO || self.ks != Vec3::ZERO
    }
});

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brdf::validate::{assert_finite_at_mirror_and_grazing, dir_from_theta_deg};

    #[test]
    fn giesen_norm_values() {
        assert!((giesen_norm(0.0) - FRAC_1_PI).abs() < 1e-7);
        // Large n: ≈ (n+2)(n+4)/(8πn).
        let n = 1e4f32;
        assert!((giesen_norm(n) / ((n + 2.0) * (n + 4.0) / (8.0 * PI * n)) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn finite_everywhere_including_mirror_and_grazing() {
        for form in [Form::Classic, Form::Normalized] {
            for n in [0.0, 1.0, 1e3, 1e6] {
                let m = BlinnPhong::new(Vec3::splat(0.3), Vec3::splat(0.7), n, form);
                assert_finite_at_mirror_and_grazing(&m, &[], &format!("{form:?} {n}"));
            }
        }
    }

    #[test]
    fn mirror_configuration_has_the_full_lobe() {
        let wi = dir_from_theta_deg(70.0, 30.0);
        let wo = dir_from_theta_deg(70.0, 210.0);
        let c = BlinnPhong::new(Vec3::ZERO, Vec3::ONE, 1e6, Form::Classic);
        assert!((eval(&c, wi, wo).x * wi.z - 1.0).abs() < 1e-5);
        let n = BlinnPhong::new(Vec3::ZERO, Vec3::ONE, 1e6, Form::Normalized);
        assert!((eval(&n, wi, wo).x / giesen_norm(1e6) - 1.0).abs() < 1e-5);
        // u.x = 0 samples h = n exactly: the mirror direction.
        let s = sample(&n, wo, 0.0, Vec2::new(0.0, 0.7)).unwrap();
        assert!((s.wi - wi).length() < 1e-5);
    }
}
