//! Oren–Nayar (survey §2.1.2) through the validation harness: sampler vs pdf, white-furnace
//! albedo against reference values (Oren & Nayar 1994), reciprocity, sampled vs quadrature albedo, bad parameters.

mod common;
use brdfwave::brdf::validate::{albedo_quadrature, dir_from_theta_deg};
use brdfwave::brdf::Material;
use common::brdf::{
    albedo_row, check_albedos, check_reciprocal, check_sampler, default_evaluates_as, grid,
    lobe_sampler, materials, model, rejects_each, warns_each, SamplerCheck, ANGLES, LOBE_ALBEDO,
};

fn on(albedo: f32, sigma: f32, variant: &str) -> Material {
    model(
        "oren_nayar",
        &format!("albedo = {albedo}\nsigma = {sigma}\nvariant = \"{variant}\""),
    )
}

const VARIANTS: [&str; 2] = ["full", "qualitative"];

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
    let models = grid(&VARIANTS, &[0.5], "σ ", |v, sigma| on(0.8, sigma, v));
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
            let row = albedo_row(m.brdf.as_ref(), &ANGLES, 100);
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
    let models = grid(&VARIANTS, &[0.7], "σ ", |v, sigma| on(0.9, sigma, v));
    check_albedos(&materials(&models), &ANGLES, 0.0, &LOBE_ALBEDO);
}

#[test]
fn reciprocal() {
    let models = grid(&VARIANTS, &[0.2, 0.8, 1.5], "σ ", |v, sigma| {
        on(0.7, sigma, v)
    });
    check_reciprocal(&materials(&models), 20_000, 9, 1e-5);
}

#[test]
fn bad_parameters() {
    rejects_each(
        "oren_nayar",
        &[
            ("sigma = 20", &["test.toml:2", "sigma", "radians"]),
            ("sigma = -0.1", &["sigma", "out of range"]),
            ("variant = \"fast\"", &["variant", "full, qualitative"]),
            ("roughness = 0.3", &["roughness", "unknown field"]),
        ],
    );
    warns_each("oren_nayar", &[("albedo = 0.99", &["albedo", "0.97"])]);
}
