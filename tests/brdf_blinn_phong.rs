//! Blinn–Phong (survey eq. 5 with Phong's eq. 4: `classic`; Giesen-normalized: `normalized`)
//! through the validation harness.

mod common;
use brdfwave::brdf::validate::{albedo_quadrature, albedo_quadrature_light, dir_from_theta_deg};
use brdfwave::brdf::Material;
use common::brdf::{rejects_each, warns_each, Lobe};
use std::f64::consts::PI;

/// Blinn–Phong's forms; the checks it shares with Phong are `Lobe`'s.
const BLINN_PHONG: Lobe = Lobe {
    model: "blinn_phong",
    forms: ["classic", "normalized"],
};

fn bp(kd: f32, ks: f32, n: f32, form: &str) -> Material {
    BLINN_PHONG.material(kd, ks, n, form)
}

#[test]
fn default_is_the_classic_form() {
    BLINN_PHONG.check_default(80.0);
}

#[test]
fn sampler_matches_pdf() {
    BLINN_PHONG.check_sampler(&[1.0, 40.0, 1000.0]);
}

/// Analytic values at normal incidence (k_s = 1, k_d = 0), derived with c = cos(θ/2):
/// classic, viewer fixed: 8π(1 − 2^{−(n+2)/2})/(n+2); classic, light fixed:
/// 8π[2(1 − 2^{−(n+4)/2})/(n+4) − (1 − 2^{−(n+2)/2})/(n+2)]; normalized: exactly 1 (Giesen
/// 2009, "Phong and Blinn-Phong normalization factors").
#[test]
fn white_furnace_against_reference_values() {
    let z = dir_from_theta_deg(0.0, 0.0);
    for n in [1.0f64, 10.0, 100.0] {
        let c = bp(0.0, 1.0, n as f32, "classic");
        let v = albedo_quadrature(c.brdf.as_ref(), z, 100);
        let l = albedo_quadrature_light(c.brdf.as_ref(), z, 100);
        let ev = 8.0 * PI * (1.0 - (-(n + 2.0) / 2.0).exp2()) / (n + 2.0);
        let el = 8.0
            * PI
            * (2.0 * (1.0 - (-(n + 4.0) / 2.0).exp2()) / (n + 4.0)
                - (1.0 - (-(n + 2.0) / 2.0).exp2()) / (n + 2.0));
        eprintln!("classic n={n}: 0° viewer fixed {v:.4} (analytic {ev:.4}), light fixed {l:.4} (analytic {el:.4})");
        assert!(
            (v - ev).abs() < 2e-3 * ev && (l - el).abs() < 2e-3 * el,
            "{n}"
        );
        let m = bp(0.0, 1.0, n as f32, "normalized");
        let a = albedo_quadrature(m.brdf.as_ref(), z, 100);
        eprintln!("normalized n={n}: 0° {a:.5} (analytic 1)");
        assert!((a - 1.0).abs() < 2e-3, "{n}: {a}");
    }
    let rows = BLINN_PHONG.albedo_table(&[
        ("classic", 1.0),
        ("classic", 80.0),
        ("normalized", 1.0),
        ("normalized", 80.0),
        ("normalized", 2000.0),
    ]);
    assert!(
        rows[0].iter().all(|a| *a > 2.0),
        "classic n=1 reflects > 2× what it receives: {:?}",
        rows[0]
    );
}

#[test]
fn sampled_albedo_agrees_with_quadrature() {
    BLINN_PHONG.check_sampled_albedo(&[3.0, 300.0]);
}

#[test]
fn reciprocity() {
    BLINN_PHONG.check_reciprocity();
}

#[test]
fn bad_parameters() {
    rejects_each(
        "blinn_phong",
        &[
            (
                "exponent = 2e6",
                &["test.toml:2", "exponent", "out of range"],
            ),
            ("form = \"survey\"", &["form", "classic, normalized"]),
            ("kd = [0.1, 0.2, -0.3]", &["kd", "-0.3"]),
        ],
    );
    warns_each(
        "blinn_phong",
        &[
            (
                "form = \"normalized\"\nkd = 0.6\nks = 0.6",
                &["kd + ks = 1.200"],
            ),
            ("exponent = 1\nks = 0.5", &["classic"]),
        ],
    );
}
