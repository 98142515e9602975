//! Phong (survey eq. 4, and the normalized form) through the validation harness.

mod common;
use brdfwave::brdf::validate::{
    albedo_quadrature, albedo_quadrature_light, dir_from_theta_deg, reciprocity_error,
};
use brdfwave::brdf::Material;
use common::brdf::{
    check_lobe_albedo, check_sampler, default_evaluates_as, lobe_sampler, material, materials,
    rejects, warns_once,
};

fn phong(kd: f32, ks: f32, n: f32, form: &str) -> Material {
    let src =
        format!("model = \"phong\"\nkd = {kd}\nks = {ks}\nexponent = {n}\nform = \"{form}\"\n");
    material(&src).unwrap().0
}

const FORMS: [&str; 2] = ["survey", "normalized"];
const ANGLES: [f32; 5] = [0.0, 30.0, 60.0, 80.0, 89.0];

#[test]
fn default_is_the_survey_form() {
    default_evaluates_as(
        "phong",
        &phong(0.5, 0.3, 20.0, "survey"),
        dir_from_theta_deg(50.0, 0.0),
        dir_from_theta_deg(45.0, 170.0),
    );
}

#[test]
fn sampler_matches_pdf() {
    let mut models = Vec::new();
    for form in FORMS {
        for n in [1.0, 30.0, 500.0] {
            models.push((format!("{form} n={n}"), phong(0.4, 0.6, n, form)));
        }
    }
    check_sampler(&materials(&models), &lobe_sampler());
}

/// k_s = 1, light direction fixed: survey albedo (Phong 1975) 2π/3 ≈ 2.09 at 0° and 8.725 at
/// 85° for n = 1; 0.00627 at n = 1000. Normalized (Lafortune & Willems 1994): exactly k_s at 0°,
/// 0.5 at 60° for n = 100.
#[test]
fn white_furnace_against_reference_values() {
    let s1 = phong(0.0, 1.0, 1.0, "survey");
    let a0 = albedo_quadrature_light(s1.brdf.as_ref(), dir_from_theta_deg(0.0, 0.0), 100);
    let a85 = albedo_quadrature_light(s1.brdf.as_ref(), dir_from_theta_deg(85.0, 0.0), 100);
    eprintln!("survey n=1, light fixed: 0° {a0:.4} (ref 2.09 = 2π/3), 85° {a85:.4} (ref 7.95?)");
    assert!((a0 - 2.0 * std::f64::consts::PI / 3.0).abs() < 2e-3, "{a0}");
    // A value of 7.95 at 85° is sometimes quoted. It does not reproduce: ∫max(0, r·w) cosθ dω / cos85°
    // by an independent Monte-Carlo estimate (Python, 2·10⁶ uniform hemisphere samples) is
    // 8.728 ± 0.01 and by a 600 × 300 midpoint rule 8.7254, so the test uses 8.725.
    assert!((a85 - 8.725).abs() < 0.005 * 8.725, "{a85}");
    // What the path tracer integrates (viewer fixed): ∫cosθ dω = π at normal incidence.
    let v0 = albedo_quadrature(s1.brdf.as_ref(), dir_from_theta_deg(0.0, 0.0), 100);
    eprintln!("survey n=1, viewer fixed: 0° {v0:.4} (analytic π)");
    assert!((v0 - std::f64::consts::PI).abs() < 1e-3, "{v0}");
    let s1000 = phong(0.0, 1.0, 1000.0, "survey");
    let a = albedo_quadrature_light(s1000.brdf.as_ref(), dir_from_theta_deg(0.0, 0.0), 100);
    eprintln!("survey n=1000, 0°: {a:.5} (ref 0.00627)");
    assert!((a - 0.00627).abs() < 0.01 * 0.00627, "{a}");

    let n100 = phong(0.0, 1.0, 100.0, "normalized");
    let a0 = albedo_quadrature(n100.brdf.as_ref(), dir_from_theta_deg(0.0, 0.0), 100);
    let a60 = albedo_quadrature(n100.brdf.as_ref(), dir_from_theta_deg(60.0, 0.0), 100);
    eprintln!("normalized n=100: 0° {a0:.4} (ref 1), 60° {a60:.4} (ref 0.470?, analytic 0.5)");
    assert!((a0 - 1.0).abs() < 2e-3, "{a0}");
    // A value of 0.470 at 60° is sometimes quoted. Analytically, while the lobe is not clipped by the
    // horizon (at 60° and n = 100 the clipped mass is ~cos¹⁰⁰30° ≈ 6e-7), averaging cosθi over
    // the lobe's azimuth gives cosθr·cosα, so the albedo is k_s (n+2)/(2π)·cosθr·2π/(n+2) =
    // cos 60° = 0.5 exactly; the test uses that.
    assert!((a60 - 0.5).abs() < 2e-3, "{a60}");

    // Tables for the report; the normalized form never exceeds k_d + k_s = 1.
    for (form, n) in [
        ("survey", 1.0),
        ("survey", 20.0),
        ("normalized", 1.0),
        ("normalized", 20.0),
        ("normalized", 1000.0),
    ] {
        let m = phong(0.0, 1.0, n, form);
        let row: Vec<f64> = ANGLES
            .iter()
            .map(|&t| albedo_quadrature(m.brdf.as_ref(), dir_from_theta_deg(t, 0.0), 100))
            .collect();
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
                    "{n}: {row:?} {light:?}"
                );
            }
        }
    }
    // The survey form at n = 1 breaks conservation on both sides.
    let m = phong(0.0, 1.0, 1.0, "survey");
    assert!(albedo_quadrature(m.brdf.as_ref(), dir_from_theta_deg(30.0, 0.0), 100) > 2.0);
}

#[test]
fn sampled_albedo_agrees_with_quadrature() {
    check_lobe_albedo(&FORMS, &[3.0, 200.0], &ANGLES, |form, n| {
        phong(0.3, 0.6, n, form)
    });
}

#[test]
fn reciprocity() {
    let e = reciprocity_error(phong(0.3, 0.6, 10.0, "normalized").brdf.as_ref(), 20_000, 9);
    assert!(e < 1e-5, "normalized: {e}");
    let m = phong(0.0, 1.0, 10.0, "survey");
    let e = reciprocity_error(m.brdf.as_ref(), 20_000, 9);
    assert!(e > 0.5, "survey claims no reciprocity: {e}");
    // f(a, b)/f(b, a) = cosθ_b/cosθ_a exactly.
    for (ta, tb) in [(20.0, 50.0), (60.0, 10.0), (80.0, 75.0)] {
        let a = dir_from_theta_deg(ta, 0.0);
        let b = dir_from_theta_deg(tb, 170.0);
        let ratio = m.brdf.eval(a, b).x / m.brdf.eval(b, a).x;
        let expect = b.z / a.z;
        assert!(
            (ratio / expect - 1.0).abs() < 1e-5,
            "{ta} {tb}: {ratio} vs {expect}"
        );
    }
}

#[test]
fn bad_parameters() {
    for (src, needles) in [
        (
            "exponent = -1",
            &["test.toml:2", "exponent", "out of range"][..],
        ),
        ("ks = nan", &["ks", "finite"]),
        ("form = \"blinn\"", &["form", "survey, normalized"]),
        ("shininess = 3", &["shininess", "unknown field"]),
    ] {
        rejects(&format!("model = \"phong\"\n{src}\n"), needles);
    }
    warns_once(
        "model = \"phong\"\nform = \"normalized\"\nkd = 0.7\nks = 0.5\n",
        &["kd + ks = 1.200"],
    );
    warns_once(
        "model = \"phong\"\nkd = 0.5\nks = 1\nexponent = 1\n",
        &["eq. 4"],
    );
}
