//! Phong (1975): a Lambertian base plus a specular lobe around the mirror direction. Survey
//! §2.1.3, eq. 4: f_r(L, V) = k_s (R·V)^{n_s} / (N·L), R = L mirrored about N; the diffuse base
//! is eq. 3 with k_d.
//!
//! | parameter | unit | default | range | meaning | texture: GPU record |
//! |---|---|---|---|---|---|
//! | `kd` | RGB, unitless | `[0.5, 0.5, 0.5]` | [0, 1] | diffuse coefficient k_d (f_d = k_d/π) | `p[0].xyz` |
//! | `ks` | RGB, unitless | `[0.3, 0.3, 0.3]` | [0, 1] | specular coefficient k_s | `p[1].xyz` |
//! | `exponent` | unitless | `20` | [0, 1e6] | shininess n_s (0: dull, ∞: mirror) | `p[0].w` |
//! | `form` | — | `"survey"` | `survey`, `normalized` | eq. 4 as written, or the energy-normalised reciprocal lobe | — |
//!
//! * `survey` (default, eq. 4 exactly): f = k_d/π + k_s·max(0, R·V)ⁿ / cosθi.
//! * `normalized` (Lafortune & Willems 1994, Lewis 1994): f = k_d/π + k_s (n+2)/(2π)·max(0, R·V)ⁿ.
//!
//! **The survey form is neither reciprocal nor energy conserving.** R·V is symmetric in L and
//! V, so the only asymmetry is 1/cosθi: f(wi, wo)/f(wo, wi) = cosθo/cosθi. Its albedo depends
//! on which direction is held fixed. With the viewer direction fixed (what this path tracer
//! integrates) the lobe albedo is k_s ∫ max(0, cosα)ⁿ dω over the lobe part above the horizon
//! ≤ 2π k_s/(n+1) — π at n = 1 (3× too bright), 0.00627 at n = 1000 (energy lost). With the
//! light fixed (quadrature in tests/brdf_phong.rs) it is 2π/3 ≈ 2.09 at 0° and 8.73 at 85° for
//! n = 1, k_s = 1, and
//! grows without bound toward grazing light. A warning is given when k_d + 2π k_s/(n+1) > 1.
//! The `normalized` form is reciprocal and conserves energy iff k_d + k_s ≤ 1 (its lobe albedo
//! is exactly k_s at normal incidence, ≈ k_s cosθ at oblique incidence for large n since part
//! of the lobe falls below the horizon); k_d + k_s > 1 gives a warning.
//!
//! Sampling: a mixture of the cosine-weighted diffuse lobe and the Phong lobe around the mirror
//! direction r = refl(given) (cosα = u^{1/(n+1)}, pdf (n+1)/(2π) cosⁿα), the lobe chosen with
//! probability P_s = lum(k_s e_s)/(lum(k_d) + lum(k_s e_s)), where e_s is the lobe's albedo
//! estimate (2π/(n+1) for `survey`, 1 for `normalized`); the pdf is the mixture
//! (1 − P_s) cosθ/π + P_s (n+1)/(2π) cosⁿα. Lobe samples below the horizon are rejected (not
//! renormalised: the pdf keeps their mass, so the estimator stays unbiased).
//!
//! Numerics: cosⁿα = exp(n·log1p(−x)) with x = 1 − cosα = |r − w|²/2 (large n in f32);
//! sin²α = −expm1(2 ln u/(n+1)) in sampling (no 1 − cos² cancellation); 1/cosθi uses
//! max(cosθi, 1e-6).
//!
//! GPU record: `p[0].xyz` = kd, `p[0].w` = exponent, `p[1].xyz` = ks, `p[1].w` = form
//! (0 survey, 1 normalized), `p[2].x` = P_s (lobe-selection probability, computed on the host).

use super::common::{
    diffuse_specular_pdf, luminance, one_minus_dot, orthonormal_basis, pow_one_minus, reflect_z,
    same_hemisphere_up, sample_cosine_hemisphere, sample_power_cosine, specular_probability,
};
use super::{Brdf, BrdfSample, Param, ParamError, ParamReader, Params, Representative};
use glam::{Vec2, Vec3, Vec4};
use std::f32::consts::{FRAC_1_PI, PI};
use std::sync::Arc;

#[derive(Clone, Debug, PartialEq)]
pub struct Phong {
    pub kd: Vec3,
    pub ks: Vec3,
    pub exponent: f32,
    pub form: Form,
    /// Probability of sampling the specular lobe (derived from the parameters).
    p_spec: f32,
}

choice_enum! {
    pub enum Form {
        Survey = "survey" => "PHONG_SURVEY",
        Normalized = "normalized" => "PHONG_NORMALIZED",
    }
}

/// Smallest cosθi the survey form divides by.
const COS_FLOOR: f32 = 1e-6;

impl Phong {
    pub fn new(kd: Vec3, ks: Vec3, exponent: f32, form: Form) -> Phong {
        let es = spec_albedo_estimate(exponent, form);
        let (d, s) = (luminance(kd), luminance(ks) * es);
        let p_spec = specular_probability(d, s);
        Phong {
            kd,
            ks,
            exponent,
            form,
            p_spec,
        }
    }
    pub fn p_spec(&self) -> f32 {
        self.p_spec
    }
}

/// The specular lobe's albedo per unit k_s at normal incidence (viewer fixed).
fn spec_albedo_estimate(n: f32, form: Form) -> f32 {
    match form {
        Form::Survey => 2.0 * PI / (n + 1.0),
        Form::Normalized => 1.0,
    }
}

declare_model! {
    survey: "§2.1.3, eq. 4";
    params: {
        KD = rgb("kd", "RGB, unitless", [0.5; 3], (0.0, 1.0), "diffuse coefficient k_d (f_d = k_d/π)").at(0);
        KS = rgb("ks", "RGB, unitless", [0.3; 3], (0.0, 1.0), "specular coefficient k_s").at(4);
        EXPONENT = scalar("exponent", "unitless", 20.0, (0.0, 1e6), "shininess n_s (0: dull, ∞: mirror)").at(3);
        FORM = choice("form", Form::NAMES, Form::Survey.name(), "eq. 4 as written, or the energy-normalised reciprocal lobe");
    }
    representative: Representative::EachOption(r#"model = "phong", kd = 0.0, ks = 0.8, exponent = 50"#, FORM);
    record_codes: [Form];
}

pub fn parse(r: &mut ParamReader) -> Result<Arc<dyn Brdf>, ParamError> {
    let kd = r.rgb_of(&KD)?;
    let ks = r.rgb_of(&KS)?;
    let exponent = r.scalar_of(&EXPONENT)?;
    let form = r.choice_of(&FORM)?;
    let es = spec_albedo_estimate(exponent, form);
    let total = (kd + ks * es).max_element();
    if total > 1.0 {
        let msg = match form {
            Form::Survey => format!(
                "kd + 2π·ks/(exponent+1) = {total:.3} > 1: the survey Phong (eq. 4) reflects \
                 more than it receives"
            ),
            Form::Normalized => {
                format!("kd + ks = {total:.3} > 1: the normalized Phong then reflects more than it receives")
            }
        };
        r.warn("ks", msg);
    }
    Ok(Arc::new(Phong::new(kd, ks, exponent, form)))
}

/// max(0, refl(wi)·wo)ⁿ, accurate for large n.
fn lobe(n: f32, wi: Vec3, wo: Vec3) -> f32 {
    pow_one_minus(one_minus_dot(reflect_z(wi), wo), n)
}

/// f_r: survey eq. 4 (plus eq. 3 diffuse) or the normalized form; no cosine.
pub fn eval(m: &Phong, wi: Vec3, wo: Vec3) -> Vec3 {
    if !same_hemisphere_up(wi, wo) {
        return Vec3::ZERO;
    }
    let l = lobe(m.exponent, wi, wo);
    let spec = match m.form {
        Form::Survey => l / wi.z.max(COS_FLOOR),
        Form::Normalized => l * (m.exponent + 2.0) * (0.5 * FRAC_1_PI),
    };
    m.kd * FRAC_1_PI + m.ks * spec
}

pub fn pdf(m: &Phong, given: Vec3, sampled: Vec3) -> f32 {
    if !same_hemisphere_up(given, sampled) {
        return 0.0;
    }
    let ps = (m.exponent + 1.0) * (0.5 * FRAC_1_PI) * lobe(m.exponent, given, sampled);
    diffuse_specular_pdf(m.p_spec, ps, sampled)
}

pub fn sample(m: &Phong, given: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
    if given.z <= 0.0 {
        return None;
    }
    let wi = if u_lobe < m.p_spec {
        let r = reflect_z(given);
        let (t, b) = orthonormal_basis(r);
        let d = sample_power_cosine(u, m.exponent);
        t * d.x + b * d.y + r * d.z
    } else {
        sample_cosine_hemisphere(u)
    };
    BrdfSample::scattered(wi, |wi| pdf(m, given, wi), |wi| eval(m, wi, given))
}

impl_brdf!(Phong {
    fn with_params(&self, v: &super::textured::ParamValues) -> Arc<dyn Brdf> {
        Arc::new(Phong::new(
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
            Vec4::new(self.p_spec, 0.0, 0.0, 0.0),
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
    fn finite_everywhere_including_mirror_and_grazing() {
        for form in [Form::Survey, Form::Normalized] {
            for n in [0.0, 1.0, 1e3, 1e6] {
                let m = Phong::new(Vec3::splat(0.3), Vec3::splat(0.7), n, form);
                assert_finite_at_mirror_and_grazing(&m, &[], &format!("{form:?} {n}"));
            }
        }
    }

    #[test]
    fn exact_mirror_configuration() {
        // At the mirror direction the lobe is 1: survey f = ks/cosθi, normalized ks (n+2)/(2π).
        let wi = dir_from_theta_deg(60.0, 0.0);
        let wo = dir_from_theta_deg(60.0, 180.0);
        let s = Phong::new(Vec3::ZERO, Vec3::ONE, 1e5, Form::Survey);
        assert!((eval(&s, wi, wo).x - 2.0).abs() < 1e-5);
        let n = Phong::new(Vec3::ZERO, Vec3::ONE, 1e5, Form::Normalized);
        assert!((eval(&n, wi, wo).x / ((1e5 + 2.0) * 0.5 * FRAC_1_PI) - 1.0).abs() < 1e-5);
        // The lobe sample with u = 0 (u' = 1) is exactly the mirror direction.
        let smp = sample(&n, wo, 0.0, Vec2::new(0.0, 0.3)).unwrap();
        assert!((smp.wi - wi).length() < 1e-5);
    }

    #[test]
    fn exponent_zero_is_a_hemisphere_around_the_mirror() {
        let m = Phong::new(Vec3::ZERO, Vec3::ONE, 0.0, Form::Normalized);
        let wo = dir_from_theta_deg(40.0, 0.0);
        let r = reflect_z(wo);
        let inside = dir_from_theta_deg(10.0, 90.0);
        assert!(inside.dot(r) > 0.0);
        assert!((eval(&m, inside, wo).x - FRAC_1_PI).abs() < 1e-6);
        let outside = dir_from_theta_deg(80.0, 0.0);
        assert!(outside.dot(r) < 0.0);
        assert_eq!(eval(&m, outside, wo).x, 0.0);
    }
}
