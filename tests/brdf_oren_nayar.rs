//! Oren–Nayar (survey §2.1.2) through the validation harness: sampler vs pdf, white-furnace
//! albedo against reference values (Oren & Nayar 1994), reciprocity, sampled vs quadrature albedo, bad parameters.

mod common;
use brdfwave::brdf::validate::{albedo_quadrature, dir_from_theta_deg};
use brdfwave::brdf::Material;
use common::brdf::{
    check_reciprocal, check_sampled_albedo, check_sampler, default_evaluates_as, lobe_sampler,
    material, materials, rejects, warns_once, AlbedoCheck, SamplerCheck,
};

fn on(albedo: f32, sigma: f32, variant: &str) -> Material {
    let src = format!(
        "model = \"oren_nayar\"\nalbedo = {albedo}\nsigma = {sigma}\nvariant = \"{variant}\"\n"
    );
    material(&src).unwrap().0
}

const VARIANTS: [&str; 2] = ["full", "qualitative"];
const ANGLES: [f32; 5] = [0.0, 30.0, 60.0, 80.0, 89.0];

#[test]
fn default_is_the_full_model() {
    let (a, b) = (
        dir_from_theta_deg(60.0, 0.0),
        dir_from_theta_deg(40.0, 30.0),
    );
    let m = default_evaluates_as("oren_nayar", &on(0.5, 0.3, "full"), a, b);
    assert_ne!(
        m.brdf.eval(a, b),
        on(0.5, 0.3, "qualitative").brdf.eval(a, b)
    );
}

#[test]
fn sampler_matches_pdf() {
    let models: Vec<_> = VARIANTS
        .iter()
        .map(|v| (v.to_string(), on(0.8, 0.5, v)))
        .collect();
    check_sampler(
        &materials(&models),
        &SamplerCheck {
            angles: &[0.0, 50.0, 85.0],
            phi: 30.0,
            integral: None,
            ..lobe_sampler()
        },
    );
}

/// Oren & Nayar 1994, qualitative model: the albedo at normal incidence is exactly ρ·A (0.920, 0.785,
/// 0.624 for σ = 0.25, 0.5, 1 and ρ = 1); near grazing at σ = 0.25 both exceed 1 (qualitative
/// 1.007, full 1.030 at 85°).
#[test]
fn white_furnace_against_reference_values() {
    for (sigma, expect) in [(0.25, 0.920), (0.5, 0.785), (1.0, 0.624)] {
        let m = on(1.0, sigma, "qualitative");
        let a = albedo_quadrature(m.brdf.as_ref(), dir_from_theta_deg(0.0, 0.0), 100);
        eprintln!("qualitative σ={sigma} 0°: {a:.4} (reference {expect})");
        assert!((a - expect).abs() < 1e-3, "σ {sigma}: {a}");
    }
    for (v, expect) in [("qualitative", 1.007), ("full", 1.030)] {
        let m = on(1.0, 0.25, v);
        let a = albedo_quadrature(m.brdf.as_ref(), dir_from_theta_deg(85.0, 0.0), 100);
        eprintln!("{v} σ=0.25 85°: {a:.4} (reference {expect})");
        assert!((a - expect).abs() < 0.005 * expect, "{v}: {a}");
    }
    // The table for the report, and: σ = 0 is Lambert; below 1 away from grazing for ρ = 1.
    for v in VARIANTS {
        for sigma in [0.0f32, 0.25, 0.5, 1.0] {
            let m = on(1.0, sigma, v);
            let row: Vec<f64> = ANGLES
                .iter()
                .map(|&t| albedo_quadrature(m.brdf.as_ref(), dir_from_theta_deg(t, 0.0), 100))
                .collect();
            eprintln!("{v:12} σ={sigma:4}: {row:.4?}");
            for (t, a) in ANGLES.iter().zip(&row) {
                assert!(a.is_finite() && *a > 0.5, "{v} σ {sigma} {t}°: {a}");
                if sigma == 0.0 {
                    assert!((a - 1.0).abs() < 1e-4, "{v} σ 0 {t}°: {a}");
                } else if *t <= 60.0 {
                    assert!(*a < 1.0, "{v} σ {sigma} {t}°: {a}");
                }
            }
        }
    }
}

#[test]
fn sampled_albedo_agrees_with_quadrature() {
    let check = AlbedoCheck {
        quadrature: (100, 100),
        samples: 100_000,
        seed: 3,
        sigmas: 5.0,
        rel: 2e-3,
    };
    for v in VARIANTS {
        let m = on(0.9, 0.7, v);
        for t in ANGLES {
            check_sampled_albedo(v, m.brdf.as_ref(), (t, 0.0), 0.0, &check);
        }
    }
}

#[test]
fn reciprocal() {
    let mut models = Vec::new();
    for v in VARIANTS {
        for sigma in [0.2, 0.8, 1.5] {
            models.push((format!("{v} σ {sigma}"), on(0.7, sigma, v)));
        }
    }
    check_reciprocal(&materials(&models), 20_000, 9, 1e-5);
}

#[test]
fn bad_parameters() {
    for (src, needles) in [
        ("sigma = 20", &["test.toml:2", "sigma", "radians"][..]),
        ("sigma = -0.1", &["sigma", "out of range"]),
        ("variant = \"fast\"", &["variant", "full, qualitative"]),
        ("roughness = 0.3", &["roughness", "unknown field"]),
    ] {
        rejects(&format!("model = \"oren_nayar\"\n{src}\n"), needles);
    }
    warns_once(
        "model = \"oren_nayar\"\nalbedo = 0.99\n",
        &["albedo", "0.97"],
    );
}
