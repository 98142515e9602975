//! Lambert (survey eq. 3) through the validation harness: the albedo is ρ at every angle, the
//! sampler matches its pdf, the model is reciprocal, and bad parameters are rejected.

mod common;
use brdfwave::brdf::validate::{
    albedo_quadrature, albedo_sampled, chi2_test, dir_from_theta_deg, reciprocity_error,
};
use brdfwave::brdf::Material;
use common::brdf::{
    check_sampler, materials, model, rejects_each, Chi2Config, SamplerCheck, Seeds, Tampered,
    ANGLES,
};

fn lambert([r, g, b]: [f32; 3]) -> Material {
    model("lambert", &format!("albedo = [{r}, {g}, {b}]"))
}

#[test]
fn albedo_is_rho_at_every_angle() {
    let m = lambert([0.8, 0.5, 0.2]);
    for th in ANGLES {
        let wo = dir_from_theta_deg(th, 20.0);
        let q = albedo_quadrature(m.brdf.as_ref(), wo, 100);
        assert!((q - 0.5).abs() < 1e-6, "quadrature albedo {q} at {th}°");
        let (s, var) = albedo_sampled(m.brdf.as_ref(), wo, 10_000, 7);
        // The weight is ρ exactly, so the estimator has no variance at all.
        assert!(
            (s - 0.5).abs() < 1e-6 && var < 1e-10,
            "sampled albedo {s} ± {var} at {th}°"
        );
    }
}

#[test]
fn sampler_matches_pdf() {
    let models = [("lambert".to_string(), lambert([0.5; 3]))];
    let results = check_sampler(
        &materials(&models),
        &SamplerCheck {
            angles: &[0.0, 45.0, 85.0],
            phi: 0.0,
            chi2_samples: 200_000,
            seeds: Seeds::Same(11),
            grid: Chi2Config::default(),
            integral: Some(1e-3),
            consistency_samples: 20_000,
            consistency_seed: 3,
            pdf_rel: 1e-6,
            weight_rel: 1e-5,
        },
    );
    // Every sample lands in the hemisphere, and the pdf integrates to 1.
    for r in results {
        assert!((r.pdf_integral - 1.0).abs() < 1e-3, "{r:?}");
        assert!((r.sample_fraction - 1.0).abs() < 1e-9, "{r:?}");
    }
}

/// The χ² test must be able to fail: a sampler that draws cosine-weighted directions but
/// reports a uniform-hemisphere pdf is rejected.
#[test]
fn chi2_rejects_a_wrong_pdf() {
    let w = Tampered {
        inner: lambert([0.5; 3]).brdf,
        pdf: Some(|_given, sampled| {
            if sampled.z > 0.0 {
                0.5 * std::f32::consts::FRAC_1_PI
            } else {
                0.0
            }
        }),
        sample: None,
    };
    let r = chi2_test(&w, dir_from_theta_deg(30.0, 0.0), 50_000, 5);
    assert!(r.p_value < 1e-6, "{r:?}");
}

#[test]
fn reciprocal() {
    let m = lambert([0.9, 0.4, 0.1]);
    assert_eq!(reciprocity_error(m.brdf.as_ref(), 10_000, 1), 0.0);
}

#[test]
fn bad_parameters_are_rejected() {
    rejects_each(
        "lambert",
        &[
            (
                "albedo = [0.5, 1.5, 0.5]",
                &["test.toml:2", "albedo", "out of range"],
            ),
            ("albedo = [0.5, 0.5]", &["albedo", "array of 2"]),
            ("albdo = 0.5", &["albdo", "unknown field"]),
            ("albedo = \"grey\"", &["expected a number"]),
        ],
    );
}
