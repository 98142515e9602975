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
//! * S = S₁(θi)·S₁(θo) (eq. 13, [`shadowing`]), S₁ = [1 − ½ erfc(a)]/[1 + Λ(a)], a = τ cotθ/(2σ₀), with the
//!   erratum Λ(a) = ½[e^(−a²)/(a√π) − erfc(a)] (the survey and the 1991 paper lack e^(−a²)).
//!   Evaluated as S₁ = N/(N + e^(−a²)/(2√π)), N = a(1 − ½ erfc a): no 1/a, no cancellation.
//! * σ is He's effective roughness ([`shadowing`]): x = z₀/σ₀ solves x·e^(x²/2) = (K(θi) + K(θo))/√(8π),
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
//! The series is in [`mod@series`] (how it is summed, its window and its accuracy).
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
//!
//! **Files**, as the model's parts split (the GLSL twin `shaders/brdf/he.glsl` includes
//! `shaders/brdf/he/*.glsl` of the same names): this file has the parameters, f_r and the
//! sampling; [`terms`] the directional-diffuse and coherent (specular) terms; [`shadowing`]
//! the shadowing function S₁ and the effective roughness σ; [`mod@series`] the series of f_dd.

pub mod series;
pub mod shadowing;
pub mod terms;

pub use series::{
    phi_ln, series, series_ends, series_log_ratio, series_log_term, series_looks_narrow,
    series_mode, series_ratio, series_walk, stirling_remainder, HE_BISECTION_STEPS, HE_MAX_TERMS,
    HE_STRIDED_TERMS, HE_WINDOW_DROP,
};
pub use shadowing::{effective_sigma, shadow_s1, solve_z0, HE_NEWTON_STEPS};
pub use terms::{dd_unit, specular_attenuation, specular_reflectance};

use super::common::{
    beckmann_d, cosine_hemisphere_pdf, expm1_f, fresnel_conductor, luminance, reflect_about,
    reflected_pdf, same_hemisphere_up, sample_beckmann_h, sample_cosine_hemisphere,
};
use super::{flag, Brdf, BrdfSample, Param, ParamError, ParamReader, Params, Representative};
use glam::{Vec2, Vec3, Vec4};
use std::f32::consts::{FRAC_1_PI, PI};
use std::sync::Arc;
use terms::specular_exp;

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
