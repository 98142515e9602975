//! The checks every reflectance model's test file runs through the validation harness
//! (`brdfwave::brdf::validate`), written once; each model's file gives its cases and the
//! tolerances it is held to as data.

pub use brdfwave::brdf::validate::Chi2Config;
use brdfwave::brdf::validate::{
    albedo_quadrature, albedo_sampled, chi2_test_with, dir_from_theta_deg, material_from_toml,
    reciprocity_error, sample_consistency, sidak, Chi2Result,
};
use brdfwave::brdf::{Brdf, Material};
use glam::Vec3;

/// A material from the fields of one `[materials.x]` table, named `test.toml` in messages.
pub fn material(src: &str) -> Result<(Material, Vec<String>), String> {
    material_from_toml("test.toml", src)
}

/// Materials by name, as the checks take them.
pub fn materials(v: &[(String, Material)]) -> Vec<(String, &dyn Brdf)> {
    v.iter()
        .map(|(n, m)| (n.clone(), m.brdf.as_ref()))
        .collect()
}

/// Models of one concrete type by name, as the checks take them.
pub fn models<S: std::fmt::Display, B: Brdf>(v: &[(S, B)]) -> Vec<(String, &dyn Brdf)> {
    v.iter()
        .map(|(n, m)| (n.to_string(), m as &dyn Brdf))
        .collect()
}

/// The seeds of the χ² tests.
#[derive(Clone, Copy, Debug)]
pub enum Seeds {
    /// The same seed for every configuration.
    Same(u64),
    /// One more than the last for each configuration, starting after the given one (the Šidák
    /// level assumes independent tests).
    After(u64),
}

/// How a model's sampler is tested against its pdf, and the tolerances it is held to.
#[derive(Clone, Copy, Debug)]
pub struct SamplerCheck {
    /// Incident angles θ in degrees, all at the azimuth `phi`.
    pub angles: &'static [f32],
    pub phi: f32,
    pub chi2_samples: usize,
    pub seeds: Seeds,
    pub grid: Chi2Config,
    /// Bound on |∫pdf − fraction of samples produced| when the model's pdf integrates to what
    /// its sampler produces (`None`: not checked).
    pub integral: Option<f64>,
    /// Samples and seed of the consistency check (each sample's pdf and weight recomputed).
    pub consistency_samples: usize,
    pub consistency_seed: u64,
    /// Largest relative error of a sample's pdf and of its weight.
    pub pdf_rel: f64,
    pub weight_rel: f64,
}

/// The sampler check of the lobe models (Phong, Blinn–Phong, Ward, Oren–Nayar): three incident
/// angles at φ = 10°, 200 000 χ² samples per configuration with seeds counting up from 100,
/// ∫pdf to 1 %, 20 000 consistency samples (seed 5), pdf to 10⁻⁵ and weight to 10⁻⁴. A model's
/// file overrides what it holds differently.
pub fn lobe_sampler() -> SamplerCheck {
    SamplerCheck {
        angles: &[0.0, 45.0, 80.0],
        phi: 10.0,
        chi2_samples: 200_000,
        seeds: Seeds::After(100),
        grid: Chi2Config::default(),
        integral: Some(0.01),
        consistency_samples: 20_000,
        consistency_seed: 5,
        pdf_rel: 1e-5,
        weight_rel: 1e-4,
    }
}

/// The sampled albedo of a lobe model (Phong, Blinn–Phong), every form and exponent at every
/// angle (φ = 0, no delta part): 100 000 samples, within 5 standard errors + 0.2 %.
pub fn check_lobe_albedo(
    forms: &[&str],
    exponents: &[f32],
    angles: &[f32],
    material: impl Fn(&str, f32) -> Material,
) {
    const ALBEDO: AlbedoCheck = AlbedoCheck {
        quadrature: (100, 100),
        samples: 100_000,
        seed: 3,
        sigmas: 5.0,
        rel: 2e-3,
    };
    for form in forms {
        for &n in exponents {
            let m = material(form, n);
            for &t in angles {
                check_sampled_albedo(
                    &format!("{form} n={n}"),
                    m.brdf.as_ref(),
                    (t, 0.0),
                    0.0,
                    &ALBEDO,
                );
            }
        }
    }
}

/// χ² goodness of fit of each model's sampler against its pdf at each angle (all tests
/// together at the 1 % level, Šidák-corrected), and the consistency of each sample's pdf and
/// weight with `pdf` and `eval`. Returns the χ² results in order (models outer, angles inner).
pub fn check_sampler(models: &[(String, &dyn Brdf)], check: &SamplerCheck) -> Vec<Chi2Result> {
    let level = sidak(0.01, models.len() * check.angles.len());
    let mut results = Vec::new();
    let mut seed = match check.seeds {
        Seeds::Same(s) | Seeds::After(s) => s,
    };
    let mut min_p = 1.0f64;
    for (name, m) in models {
        for &th in check.angles {
            let wo = dir_from_theta_deg(th, check.phi);
            if let Seeds::After(_) = check.seeds {
                seed += 1;
            }
            let r = chi2_test_with(*m, wo, check.chi2_samples, seed, check.grid);
            eprintln!(
                "{name} θ={th}: p={:.3} dof={} ∫pdf={:.4}",
                r.p_value, r.dof, r.pdf_integral
            );
            min_p = min_p.min(r.p_value);
            assert_eq!(r.zero_pdf_hits, 0, "{name} θ={th}: {r:?}");
            assert!(r.p_value > level, "{name} θ={th}: {r:?}");
            if let Some(tol) = check.integral {
                assert!(
                    (r.pdf_integral - r.sample_fraction).abs() < tol,
                    "{name} θ={th}: {r:?}"
                );
            }
            let c = sample_consistency(*m, wo, check.consistency_samples, check.consistency_seed);
            assert_eq!(c.bad_samples + c.delta_with_pdf, 0, "{name} θ={th}: {c:?}");
            assert!(
                c.pdf_rel_error < check.pdf_rel && c.weight_rel_error < check.weight_rel,
                "{name} θ={th}: {c:?}"
            );
            results.push(r);
        }
    }
    eprintln!("smallest χ² p-value {min_p:.4} (level {level:.5})");
    results
}

/// How the sampled albedo (the path tracer's estimator) is compared with quadrature.
#[derive(Clone, Copy, Debug)]
pub struct AlbedoCheck {
    /// Quadrature resolution: below 80° and from 80° on.
    pub quadrature: (usize, usize),
    pub samples: usize,
    pub seed: u64,
    /// Tolerance: `sigmas` standard errors of the sampled mean plus `rel` of the reference.
    pub sigmas: f64,
    pub rel: f64,
}

/// The sampled albedo at the direction (θ, φ) in degrees agrees with the quadrature of the
/// non-delta lobes plus `delta`, the albedo of the delta lobes (0 for a model without).
/// Returns (quadrature, sampled mean, its standard error).
pub fn check_sampled_albedo(
    name: &str,
    m: &dyn Brdf,
    (theta, phi): (f32, f32),
    delta: f64,
    check: &AlbedoCheck,
) -> (f64, f64, f64) {
    let wo = dir_from_theta_deg(theta, phi);
    let n = if theta >= 80.0 {
        check.quadrature.1
    } else {
        check.quadrature.0
    };
    let q = albedo_quadrature(m, wo, n);
    let (s, var) = albedo_sampled(m, wo, check.samples, check.seed);
    let se = (var / check.samples as f64).sqrt();
    let tol = check.sigmas * se + check.rel * (q + delta);
    assert!(
        (s - (q + delta)).abs() < tol,
        "{name} θ={theta}: sampled {s} ± {se}, quadrature {q} + delta {delta} (tol {tol})"
    );
    (q, s, se)
}

/// Each model is reciprocal to within `tol` (largest relative |f(a, b) − f(b, a)|).
pub fn check_reciprocal(models: &[(String, &dyn Brdf)], pairs: usize, seed: u64, tol: f64) {
    for (name, m) in models {
        let e = reciprocity_error(*m, pairs, seed);
        eprintln!("{name}: reciprocity error {e:e}");
        assert!(e < tol, "{name}: {e}");
    }
}

/// `model = "…"` alone loads without warnings and evaluates as `explicit` does at (a, b).
/// Returns the default material.
pub fn default_evaluates_as(model: &str, explicit: &Material, a: Vec3, b: Vec3) -> Material {
    let (m, w) = material(&format!("model = \"{model}\"\n")).unwrap();
    assert!(w.is_empty(), "{w:?}");
    assert_eq!(m.brdf.eval(a, b), explicit.brdf.eval(a, b));
    m
}

/// The material is refused with a message that contains every one of `needles`.
pub fn rejects(src: &str, needles: &[&str]) {
    let e = material(src).unwrap_err();
    for n in needles {
        assert!(e.contains(n), "{src:?}: {e:?} lacks {n:?}");
    }
}

/// The material loads with exactly one warning, which contains every one of `needles`.
pub fn warns_once(src: &str, needles: &[&str]) -> Material {
    let (m, w) = material(src).unwrap();
    assert_eq!(w.len(), 1, "{src:?}: {w:?}");
    for n in needles {
        assert!(w[0].contains(n), "{src:?}: {w:?} lacks {n:?}");
    }
    m
}
