//! The checks every reflectance model's test file runs through the validation harness
//! (`brdfwave::brdf::validate`), written once; each model's file gives its cases and the
//! tolerances it is held to as data.

pub use brdfwave::brdf::validate::Chi2Config;
use brdfwave::brdf::validate::{
    albedo_quadrature, albedo_quadrature_light, albedo_sampled, chi2_test_with, dir_from_theta_deg,
    material_from_toml, reciprocity_error, sample_consistency, sidak, Chi2Result,
};
use brdfwave::brdf::{Brdf, BrdfSample, Material, Params};
use glam::{Vec2, Vec3};
use std::fmt::Display;
use std::sync::Arc;

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

/// The sampler check of the models with several lobes and a delta part (Cook–Torrance, He,
/// Schlick) at the azimuth `phi` with the seed `seed` for every configuration: incident angles
/// 10°, 45° and 75°, 100 000 χ² samples, ∫pdf not checked, 5 000 consistency samples (seed 8),
/// pdf to 10⁻⁴ and weight to 10⁻³. A model's file overrides what it holds differently.
pub fn mixture_sampler(phi: f32, seed: u64) -> SamplerCheck {
    SamplerCheck {
        angles: &[10.0, 45.0, 75.0],
        phi,
        chi2_samples: 100_000,
        seeds: Seeds::Same(seed),
        grid: Chi2Config::default(),
        integral: None,
        consistency_samples: 5000,
        consistency_seed: 8,
        pdf_rel: 1e-4,
        weight_rel: 1e-3,
    }
}

/// The sampled albedo of the models with a delta part (Cook–Torrance, Schlick; He overrides)
/// with the seed `seed`: 100 000 samples, within 4 standard errors + 0.3 % of a quadrature of
/// 60 × 60 below 80° and 120 × 120 from 80° on (a narrow lobe at grazing incidence needs the
/// finer grid).
pub fn mixture_albedo(seed: u64) -> AlbedoCheck {
    AlbedoCheck {
        quadrature: (60, 120),
        samples: 100_000,
        seed,
        sigmas: 4.0,
        rel: 3e-3,
    }
}

/// The incident angles θ in degrees of the albedo tables and sampled-albedo checks, from normal
/// incidence to grazing.
pub const ANGLES: [f32; 5] = [0.0, 30.0, 60.0, 80.0, 89.0];

/// A material of the model `name` with the given fields (`key = value`, one a line), which must
/// load.
pub fn model(name: &str, fields: &str) -> Material {
    let src = with_fields(name, fields);
    material(&src).unwrap_or_else(|e| panic!("{src:?}: {e}")).0
}

/// One material for every `a` of `outer` and `b` of `inner`, named "{a} {label}{b}" (as
/// "classic n=40" with the label "n=").
pub fn grid<A: Copy + Display, B: Copy + Display>(
    outer: &[A],
    inner: &[B],
    label: &str,
    make: impl Fn(A, B) -> Material,
) -> Vec<(String, Material)> {
    let mut v = Vec::new();
    for &a in outer {
        for &b in inner {
            v.push((format!("{a} {label}{b}"), make(a, b)));
        }
    }
    v
}

/// The sampled albedo of the lobe models (Phong, Blinn–Phong, Oren–Nayar): 100 000 samples,
/// within 5 standard errors + 0.2 % of a 100 × 100 quadrature.
pub const LOBE_ALBEDO: AlbedoCheck = AlbedoCheck {
    quadrature: (100, 100),
    samples: 100_000,
    seed: 3,
    sigmas: 5.0,
    rel: 2e-3,
};

/// [`check_sampled_albedo`] of each model (no delta part) at each angle θ at the azimuth `phi`.
pub fn check_albedos(
    models: &[(String, &dyn Brdf)],
    angles: &[f32],
    phi: f32,
    check: &AlbedoCheck,
) {
    for (name, m) in models {
        for &t in angles {
            check_sampled_albedo(name, *m, (t, phi), 0.0, check);
        }
    }
}

/// The albedo by `n` × `n` quadrature at each angle θ (φ = 0) with the viewer fixed, as the path
/// tracer integrates it.
pub fn albedo_row(m: &dyn Brdf, angles: &[f32], n: usize) -> Vec<f64> {
    angles
        .iter()
        .map(|&t| albedo_quadrature(m, dir_from_theta_deg(t, 0.0), n))
        .collect()
}

/// A lobe model with the parameters kd, ks, exponent and form (Phong, Blinn–Phong): its name and
/// its two forms, the unnormalized one (the default) first, then "normalized". The checks that
/// both models run are written here once; each model's file gives the exponents as data.
pub struct Lobe {
    pub model: &'static str,
    pub forms: [&'static str; 2],
}

impl Lobe {
    pub fn material(&self, kd: f32, ks: f32, n: f32, form: &str) -> Material {
        model(
            self.model,
            &format!("kd = {kd}\nks = {ks}\nexponent = {n}\nform = \"{form}\""),
        )
    }

    /// `model = "…"` alone is the unnormalized form with k_d = 0.5, k_s = 0.3 and exponent `n`.
    pub fn check_default(&self, n: f32) {
        default_evaluates_as(
            self.model,
            &self.material(0.5, 0.3, n, self.forms[0]),
            dir_from_theta_deg(50.0, 0.0),
            dir_from_theta_deg(45.0, 170.0),
        );
    }

    /// Both forms at each exponent with the given k_d and k_s, named "form n=…".
    fn forms_at(&self, exponents: &[f32], kd: f32, ks: f32) -> Vec<(String, Material)> {
        grid(&self.forms, exponents, "n=", |form, n| {
            self.material(kd, ks, n, form)
        })
    }

    /// The [`lobe_sampler`] check of both forms at each exponent (k_d = 0.4, k_s = 0.6).
    pub fn check_sampler(&self, exponents: &[f32]) {
        check_sampler(
            &materials(&self.forms_at(exponents, 0.4, 0.6)),
            &lobe_sampler(),
        );
    }

    /// The [`LOBE_ALBEDO`] check of both forms at each exponent (k_d = 0.3, k_s = 0.6) at each
    /// of [`ANGLES`] (φ = 0).
    pub fn check_sampled_albedo(&self, exponents: &[f32]) {
        let models = self.forms_at(exponents, 0.3, 0.6);
        check_albedos(&materials(&models), &ANGLES, 0.0, &LOBE_ALBEDO);
    }

    /// The white-furnace table (k_d = 0, k_s = 1) for the report: for each (form, exponent),
    /// the albedo at each of [`ANGLES`] with the viewer fixed and with the light fixed
    /// (quadrature 100). The normalized form never exceeds 1 (+ 2·10⁻³) and is the same both
    /// ways (to 2·10⁻³). Returns the viewer-fixed rows in the order of `cases`.
    pub fn albedo_table(&self, cases: &[(&str, f32)]) -> Vec<Vec<f64>> {
        let mut rows = Vec::new();
        for &(form, n) in cases {
            let m = self.material(0.0, 1.0, n, form);
            let row = albedo_row(m.brdf.as_ref(), &ANGLES, 100);
            let light: Vec<f64> = ANGLES
                .iter()
                .map(|&t| albedo_quadrature_light(m.brdf.as_ref(), dir_from_theta_deg(t, 0.0), 100))
                .collect();
            eprintln!(
                "{form:10} n={n:6}: viewer fixed {row:.4?}\n{:20}light fixed  {light:.4?}",
                ""
            );
            if form == "normalized" {
                for (a, b) in row.iter().zip(&light) {
                    assert!(
                        *a <= 1.0 + 2e-3 && (a - b).abs() < 2e-3,
                        "{form} n={n}: {row:?} {light:?}"
                    );
                }
            }
            rows.push(row);
        }
        rows
    }

    /// The normalized form (k_d = 0.3, k_s = 0.6, n = 10) is reciprocal (to 10⁻⁵; 20 000
    /// pairs, seed 9); the unnormalized form (k_d = 0, k_s = 1, n = 10) is not (error > 0.5),
    /// but only by the cosine of the viewer: f(a, b)/f(b, a) = cosθ_b/cosθ_a to 10⁻⁵.
    pub fn check_reciprocity(&self) {
        let normalized = self.material(0.3, 0.6, 10.0, "normalized");
        let e = reciprocity_error(normalized.brdf.as_ref(), 20_000, 9);
        assert!(e < 1e-5, "{} normalized: {e}", self.model);
        let name = self.forms[0];
        let unnormalized = self.material(0.0, 1.0, 10.0, name);
        let m = unnormalized.brdf.as_ref();
        let e = reciprocity_error(m, 20_000, 9);
        assert!(e > 0.5, "{name} claims no reciprocity: {e}");
        for (ta, tb) in [(20.0, 50.0), (60.0, 10.0), (80.0, 75.0)] {
            let a = dir_from_theta_deg(ta, 0.0);
            let b = dir_from_theta_deg(tb, 170.0);
            let ratio = m.eval(a, b).x / m.eval(b, a).x;
            let expect = b.z / a.z;
            assert!(
                (ratio / expect - 1.0).abs() < 1e-5,
                "{name} {ta} {tb}: {ratio} vs {expect}"
            );
        }
    }
}

/// A model that is `inner` with its pdf or its samples tampered with, to show that a check or a
/// counter catches the fault. Everything not replaced is `inner`'s.
#[derive(Debug)]
pub struct Tampered {
    pub inner: Arc<dyn Brdf>,
    /// Replaces the pdf of (given, sampled).
    pub pdf: Option<fn(Vec3, Vec3) -> f32>,
    /// Changes each sample, given the random numbers `u` that drew it.
    pub sample: Option<fn(&mut BrdfSample, Vec2)>,
}

impl Brdf for Tampered {
    fn eval(&self, wi: Vec3, wo: Vec3) -> Vec3 {
        self.inner.eval(wi, wo)
    }
    fn pdf(&self, given: Vec3, sampled: Vec3) -> f32 {
        match self.pdf {
            Some(pdf) => pdf(given, sampled),
            None => self.inner.pdf(given, sampled),
        }
    }
    fn sample(&self, given: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
        let mut s = self.inner.sample(given, u_lobe, u)?;
        if let Some(tamper) = self.sample {
            tamper(&mut s, u);
        }
        Some(s)
    }
    fn pack(&self) -> Params {
        self.inner.pack()
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
    fn scatters(&self) -> bool {
        self.inner.scatters()
    }
    fn with_params(&self, v: &brdfwave::brdf::textured::ParamValues) -> Arc<dyn Brdf> {
        Arc::new(Tampered {
            inner: self.inner.with_params(v),
            pdf: self.pdf,
            sample: self.sample,
        })
    }
}

/// The grey value of an RGB reflectance (the mean of the channels, as the albedo functions
/// average them).
pub fn grey(v: Vec3) -> f64 {
    ((v.x + v.y + v.z) / 3.0) as f64
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
    eprintln!("{name} θ={theta}: quadrature {q:.4} + delta {delta:.4} | sampled {s:.4} ± {se:.4}");
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

/// `model = "…"` alone, which must load without warnings.
pub fn default_of(model: &str) -> Material {
    let (m, w) = material(&with_fields(model, "")).unwrap();
    assert!(w.is_empty(), "{model}: {w:?}");
    m
}

/// `model = "…"` alone loads without warnings and evaluates as `explicit` does at (a, b).
/// Returns the default material.
pub fn default_evaluates_as(model: &str, explicit: &Material, a: Vec3, b: Vec3) -> Material {
    let m = default_of(model);
    assert_eq!(m.brdf.eval(a, b), explicit.brdf.eval(a, b));
    m
}

/// [`rejects_each`] of cases `(fields, field, message)`: each error names `at` (the file, and
/// the line where every case has one), the field and the message.
pub fn rejects_fields(name: &str, at: &str, cases: &[(&str, &str, &str)]) {
    for (fields, field, msg) in cases {
        rejects(&with_fields(name, fields), &[at, field, msg]);
    }
}

/// The text of a material of the model `name` with the given fields (`key = value`, one a line).
pub fn with_fields(name: &str, fields: &str) -> String {
    format!("model = \"{name}\"\n{fields}\n")
}

/// Each `(fields, needles)`: the model `name` with these fields is refused with a message that
/// contains every one of `needles`.
pub fn rejects_each(name: &str, cases: &[(&str, &[&str])]) {
    for (fields, needles) in cases {
        rejects(&with_fields(name, fields), needles);
    }
}

/// Each `(fields, needles)`: the model `name` with these fields loads with exactly one warning,
/// which contains every one of `needles`.
pub fn warns_each(name: &str, cases: &[(&str, &[&str])]) {
    for (fields, needles) in cases {
        warns_once(&with_fields(name, fields), needles);
    }
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

/// A folder holding the data files the registry's materials name (`brdf::write_fixtures`): the
/// coverage tests build a measured model's instances from it.
pub fn fixtures() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    brdfwave::brdf::write_fixtures(dir.path()).unwrap();
    dir
}

/// A coverage test's verdict: `place` (a list, a generator, a scene) misses none of the models;
/// `missing` are the names of those it misses.
#[track_caller]
pub fn assert_no_model_missing(missing: &[&str], place: &str) {
    assert!(missing.is_empty(), "{place} misses the models {missing:?}");
}
