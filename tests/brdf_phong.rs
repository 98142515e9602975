//! Phong (survey eq. 4, and the normalized form) through the validation harness.

mod common;
use brdfwave::brdf::validate::{albedo_quadrature, albedo_quadrature_light, dir_from_theta_deg};
use brdfwave::brdf::Material;
use common::brdf::{rejects_each, warns_each, Lobe};

/// Phong's forms; the checks it shares with Blinn–Phong are `Lobe`'s.
const PHONG: Lobe = Lobe {
    model: "phong",
    forms: ["survey", "normalized"],
};

fn phong(kd: f32, ks: f32, n: f32, form: &str) -> Material {
    PHONG.material(kd, ks, n, form)
}

#[test]
fn default_is_the_survey_form() {
    PHONG.check_default(20.0);
}

#[test]
fn sampler_matches_pdf() {
    PHONG.check_sampler(&[1.0, 30.0, 500.0]);
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
    let rows = PHONG.albedo_table(&[
        ("survey", 1.0),
        ("survey", 20.0),
        ("normalized", 1.0),
        ("normalized", 20.0),
        ("normalized", 1000.0),
    ]);
    // The survey form at n = 1 breaks conservation on both sides (here at 30°).
    assert!(rows[0][1] > 2.0, "survey n=1: {:?}", rows[0]);
}

#[test]
fn sampled_albedo_agrees_with_quadrature() {
    PHONG.check_sampled_albedo(&[3.0, 200.0]);
}

#[test]
fn reciprocity() {
    PHONG.check_reciprocity();
}

#[test]
fn bad_parameters() {
    rejects_each(
        "phong",
        &[
            (
                "exponent = -1",
                &["test.toml:2", "exponent", "out of range"],
            ),
            ("ks = nan", &["ks", "finite"]),
            ("form = \"blinn\"", &["form", "survey, normalized"]),
            ("shininess = 3", &["shininess", "unknown field"]),
        ],
    );
    warns_each(
        "phong",
        &[
            (
                "form = \"normalized\"\nkd = 0.7\nks = 0.5",
                &["kd + ks = 1.200"],
            ),
            ("kd = 0.5\nks = 1\nexponent = 1", &["eq. 4"]),
        ],
    );
}
