//! Cook–Torrance (survey eqs. 6–9) through the validation harness: the survey form is exactly
//! 4× the Walter form, an albedo table by independent quadrature, energy conservation of the
//! Walter form, χ² of the sampler, sampled vs quadrature albedo (delta mirror included),
//! reciprocity, Fresnel reference values (Fresnel's equations; Schlick 1994's approximation) and the
//! parameter errors.

use brdfwave::brdf::common::{
    fresnel_conductor1, fresnel_dielectric, fresnel_schlick, smith_g1_beckmann_walter,
};
use brdfwave::brdf::cook_torrance::{
    self, CookTorrance, Distribution, Fresnel, Geometry, Normalization, Sampler,
};
mod common;
use brdfwave::brdf::validate::{
    albedo_quadrature, albedo_quadrature_rgb, chi2_test, dir_from_theta_deg, reciprocity_error,
};
use brdfwave::brdf::Brdf;
use common::brdf::{
    check_reciprocal, check_sampled_albedo, check_sampler, grey, material, mixture_albedo,
    mixture_sampler, models, rejects_fields, warns_each, with_fields, SamplerCheck, Tampered,
    ANGLES,
};
use glam::{Vec2, Vec3};

/// F ≡ 1 (Schlick with f0 = 1), no diffuse: the setting of the §7 table.
fn white(m: f32, distribution: Distribution, geometry: Geometry, n: Normalization) -> CookTorrance {
    CookTorrance {
        kd: Vec3::ZERO,
        ks: Vec3::ONE,
        roughness: m,
        distribution,
        geometry,
        fresnel: Fresnel::Schlick,
        f0: Vec3::ONE,
        normalization: n,
        ..Default::default()
    }
}

fn rand_dir(i: u32, d: u32) -> Vec3 {
    let u = brdfwave::rng::random_f32(99, i, 0, 0, d);
    let v = brdfwave::rng::random_f32(99, i, 0, 0, d + 1);
    let z = 1.0 - u;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * v;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[test]
fn survey_is_exactly_four_times_walter() {
    for distribution in [Distribution::Beckmann, Distribution::Ggx] {
        for geometry in [Geometry::VCavity, Geometry::Smith] {
            for fresnel in [Fresnel::Dielectric, Fresnel::Conductor, Fresnel::Schlick] {
                let mk = |normalization| CookTorrance {
                    roughness: 0.35,
                    distribution,
                    geometry,
                    fresnel,
                    normalization,
                    ..Default::default()
                };
                let (s, w) = (mk(Normalization::Survey), mk(Normalization::Walter));
                for i in 0..2000 {
                    let (a, b) = (rand_dir(i, 0), rand_dir(i, 2));
                    let (fs, fw) = (cook_torrance::eval(&s, a, b), cook_torrance::eval(&w, a, b));
                    // Exact wherever the value is a normal float (subnormals lose bits).
                    if fw.min_element() > 1e-30 {
                        assert_eq!(
                            fs,
                            4.0 * fw,
                            "{distribution:?} {geometry:?} {fresnel:?} {a} {b}"
                        );
                    } else {
                        assert!((fs - 4.0 * fw).abs().max_element() < 1e-35);
                    }
                }
                let wo = dir_from_theta_deg(40.0, 0.0);
                let (qs, qw) = (albedo_quadrature(&s, wo, 40), albedo_quadrature(&w, wo, 40));
                assert!((qs / qw - 4.0).abs() < 1e-5, "albedo ratio {}", qs / qw);
            }
        }
    }
}

/// F = 1: albedo of the survey form (Cook & Torrance 1982) and of Walter et al. 2007 (eq. 20)
/// with the V-cavity G, by an independent double-precision midpoint quadrature.
#[test]
fn albedo_table_of_section_7() {
    // (m, θ, survey, walter + V-cavity)
    let table = [
        (0.1, 0.0, 4.000, 1.000),
        (0.1, 60.0, 3.996, 0.999),
        (0.1, 85.0, 3.750, 0.938),
        (0.5, 0.0, 3.570, 0.892),
        (0.5, 60.0, 3.548, 0.887),
        (0.5, 85.0, 3.909, 0.977),
        (1.0, 0.0, 1.814, 0.453),
        (1.0, 60.0, 3.167, 0.792),
        (1.0, 85.0, 3.878, 0.969),
    ];
    eprintln!("m     θ    survey (ref)      walter+v_cavity (ref)");
    for (m, th, survey, walter) in table {
        let wo = dir_from_theta_deg(th, 0.0);
        let s = white(
            m,
            Distribution::Beckmann,
            Geometry::VCavity,
            Normalization::Survey,
        );
        let w = white(
            m,
            Distribution::Beckmann,
            Geometry::VCavity,
            Normalization::Walter,
        );
        let qs = albedo_quadrature(&s, wo, 60);
        let qw = albedo_quadrature(&w, wo, 60);
        eprintln!("{m:.1}  {th:>4}  {qs:.4} ({survey:.3})   {qw:.4} ({walter:.3})");
        assert!(
            (qs / survey - 1.0).abs() < 2e-3,
            "survey m={m} θ={th}: {qs} vs {survey}"
        );
        assert!(
            (qw / walter - 1.0).abs() < 2e-3,
            "walter m={m} θ={th}: {qw} vs {walter}"
        );
    }
}

/// Independent f64 reference for Walter + separable Smith (Walter's G1 approximation), by
/// quadrature over the half vector: ρ(wo) = ∫ D(h) G(wi,wo) (wo·h)/(wo.z) [wi.z>0] dωh.
fn smith_albedo_reference(m: f64, theta_deg: f64) -> f64 {
    let wo = [
        theta_deg.to_radians().sin(),
        0.0,
        theta_deg.to_radians().cos(),
    ];
    let g1 = |w: [f64; 3]| -> f64 {
        if w[2] <= 0.0 {
            return 0.0;
        }
        let s = (w[0] * w[0] + w[1] * w[1]).sqrt();
        if s == 0.0 {
            return 1.0;
        }
        let a = w[2] / (m * s);
        if a >= 1.6 {
            1.0
        } else {
            (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
        }
    };
    // θh via the Beckmann CDF warp: tan²θh = −m² ln(1−u), density D cosθh: integrate
    // ∫ (D cosθh dωh) · G (wo·h)/(wo.z cosθh).
    let (nu, np) = (600usize, 600usize);
    let mut sum = 0.0;
    for iu in 0..nu {
        let u = (iu as f64 + 0.5) / nu as f64;
        let t2 = -m * m * (1.0 - u).ln();
        let ct = 1.0 / (1.0 + t2).sqrt();
        let st = t2.sqrt() * ct;
        for ip in 0..np {
            let phi = 2.0 * std::f64::consts::PI * (ip as f64 + 0.5) / np as f64;
            let h = [st * phi.cos(), st * phi.sin(), ct];
            let oh = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2];
            if oh <= 0.0 {
                continue;
            }
            let wi = [
                2.0 * oh * h[0] - wo[0],
                2.0 * oh * h[1] - wo[1],
                2.0 * oh * h[2] - wo[2],
            ];
            if wi[2] <= 0.0 {
                continue;
            }
            sum += g1(wi) * g1(wo) * oh / (wo[2] * ct);
        }
    }
    sum / (nu * np) as f64
}

#[test]
fn walter_smith_albedo_matches_an_independent_quadrature() {
    // Third column of §7 is the height-correlated Smith; ours is separable, which is ≤ it.
    let hc = [
        (0.5, 0.0, 0.943),
        (0.5, 60.0, 0.869),
        (1.0, 0.0, 0.462),
        (1.0, 85.0, 0.959),
    ];
    for (m, th, hc_ref) in hc {
        let w = white(
            m,
            Distribution::Beckmann,
            Geometry::Smith,
            Normalization::Walter,
        );
        let q = albedo_quadrature(&w, dir_from_theta_deg(th, 0.0), 60);
        let r = smith_albedo_reference(m as f64, th as f64);
        eprintln!("smith m={m} θ={th}: {q:.4} (f64 reference {r:.4}, height-correlated {hc_ref})");
        assert!((q / r - 1.0).abs() < 2e-3, "m={m} θ={th}: {q} vs {r}");
        assert!(
            q <= hc_ref * 1.004,
            "separable above height-correlated: {q} > {hc_ref}"
        );
    }
}

#[test]
fn walter_form_conserves_energy_and_survey_form_does_not() {
    for distribution in [Distribution::Beckmann, Distribution::Ggx] {
        for geometry in [Geometry::VCavity, Geometry::Smith] {
            for m in [0.05, 0.3, 1.0] {
                for th in [0.0, 30.0, 60.0, 80.0, 89.0] {
                    let wo = dir_from_theta_deg(th, 0.0);
                    let w = white(m, distribution, geometry, Normalization::Walter);
                    let q = albedo_quadrature(&w, wo, 60);
                    assert!(
                        q <= 1.003,
                        "{distribution:?} {geometry:?} m={m} θ={th}: {q}"
                    );
                    assert!(q > 0.2, "{distribution:?} {geometry:?} m={m} θ={th}: {q}");
                }
            }
        }
    }
    let s = white(
        0.1,
        Distribution::Ggx,
        Geometry::Smith,
        Normalization::Survey,
    );
    let q = albedo_quadrature(&s, Vec3::Z, 60);
    assert!(q > 3.9, "survey GGX at normal incidence {q}");
}

fn chi2_variants() -> Vec<(String, CookTorrance)> {
    let mut v = Vec::new();
    for distribution in [Distribution::Beckmann, Distribution::Ggx] {
        for (kd, fresnel) in [(0.0, Fresnel::Conductor), (0.5, Fresnel::Dielectric)] {
            for m in [0.08, 0.5] {
                v.push((
                    format!("{distribution:?} kd={kd} {fresnel:?} m={m}"),
                    CookTorrance {
                        kd: Vec3::splat(kd),
                        ks: Vec3::splat(0.5),
                        roughness: m,
                        distribution,
                        geometry: Geometry::Smith,
                        fresnel,
                        normalization: Normalization::Walter,
                        ..Default::default()
                    },
                ));
            }
        }
    }
    // Delta mirror with a diffuse lobe: the non-delta part is (1 − P_delta)·cos/π.
    v.push((
        "mirror kd=0.5".into(),
        CookTorrance {
            kd: Vec3::splat(0.5),
            ks: Vec3::splat(0.5),
            roughness: 0.0,
            ..Default::default()
        },
    ));
    v
}

#[test]
fn sampler_matches_pdf() {
    let vs = chi2_variants();
    check_sampler(
        &models(&vs),
        &SamplerCheck {
            angles: &[10.0, 45.0, 80.0, 88.0],
            integral: Some(0.01),
            ..mixture_sampler(30.0, 3)
        },
    );
}

#[test]
fn sampled_albedo_matches_quadrature_including_the_delta_mirror() {
    let check = mixture_albedo(17);
    for (name, m) in chi2_variants() {
        for th in ANGLES {
            // The delta lobe's reflectance, seen only by the sampler.
            let delta = if m.is_mirror() {
                let cos = dir_from_theta_deg(th, 10.0).z;
                grey(m.ks * cook_torrance::fresnel(&m, cos) * m.norm_factor())
            } else {
                0.0
            };
            check_sampled_albedo(&name, &m, (th, 10.0), delta, &check);
        }
    }
}

#[test]
fn reciprocal() {
    check_reciprocal(&models(&chi2_variants()), 20_000, 5, 1e-4);
    for geometry in [Geometry::VCavity, Geometry::Smith] {
        let m = CookTorrance {
            geometry,
            ..Default::default()
        };
        assert!(reciprocity_error(&m, 20_000, 6) < 1e-4);
    }
}

/// Exact unpolarised Fresnel reflectance (Born & Wolf, Principles of Optics, §1.5) and Schlick
/// 1994's approximation for n = 1.5 and two conductors; Walter et al. 2007's rational
/// approximation of the Smith–Beckmann G1 against the exact G1 (with erfc).
#[test]
fn fresnel_and_g1_reference_values() {
    let th = [0.0f32, 30.0, 45.0, 60.0, 75.0, 80.0, 85.0, 89.0];
    let exact = [
        0.040000, 0.041523, 0.050240, 0.089187, 0.253061, 0.387704, 0.612800, 0.904185,
    ];
    let schlick = [
        0.040000, 0.040041, 0.042069, 0.070000, 0.254730, 0.409910, 0.648492, 0.919102,
    ];
    for i in 0..th.len() {
        let c = th[i].to_radians().cos();
        let fe = fresnel_dielectric(c, 1.5);
        let fc = fresnel_conductor1(c, 1.5, 0.0);
        let fs = fresnel_schlick(c, Vec3::splat(0.04)).x;
        assert!(
            (fe - exact[i]).abs() < 2e-6,
            "eq. 7 at {}: {fe} vs {}",
            th[i],
            exact[i]
        );
        assert!(
            (fc - exact[i]).abs() < 2e-6,
            "conductor k=0 at {}: {fc}",
            th[i]
        );
        assert!((fs - schlick[i]).abs() < 2e-6, "schlick at {}: {fs}", th[i]);
    }
    for (n, k, vals) in [
        (
            0.2f32,
            3.0f32,
            [
                (0.0f32, 0.923372f32),
                (45.0, 0.921320),
                (60.0, 0.918411),
                (80.0, 0.938558),
                (89.0, 0.992126),
            ],
        ),
        (
            1.2,
            7.0,
            [
                (0.0, 0.910847),
                (45.0, 0.906616),
                (60.0, 0.894815),
                (80.0, 0.847715),
                (89.0, 0.959204),
            ],
        ),
    ] {
        for (t, v) in vals {
            let f = fresnel_conductor1(t.to_radians().cos(), n, k);
            assert!(
                (f - v).abs() < 3e-6,
                "conductor ({n}, {k}) at {t}: {f} vs {v}"
            );
        }
    }
    // G1 with a = 1/(α tanθ): α = 1, tanθ = 1/a.
    for (a, v) in [
        (0.25f32, 0.589610f32),
        (0.5, 0.831252),
        (1.0, 0.976593),
        (1.5, 0.999755),
    ] {
        let w = Vec3::new(1.0, 0.0, a).normalize();
        let g = smith_g1_beckmann_walter(w, 1.0);
        assert!((g - v).abs() < 2e-6, "G1({a}) = {g} vs {v}");
    }
}

/// The Cornell box's glossy material (cornell_box.json `gold_rough`) in our scene names.
#[test]
fn cornell_gold_rough_is_expressible() {
    let src = "model = \"cook_torrance\"\ndistribution = \"beckmann\"\nroughness = 0.2\n\
               geometry = \"smith\"\nfresnel = \"conductor\"\neta = [0.143036, 0.375307, 1.44205]\n\
               k = [3.983, 2.38556, 1.60336]\nnormalization = \"walter\"\nkd = [0, 0, 0]\nks = [1, 1, 1]\n";
    let (m, warnings) = material(src).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(m.model_name(), "cook_torrance");
    let p = m.brdf.pack();
    assert_eq!(p.0[3], 0.2);
    assert_eq!(p.0[7], 1.0);
    // Gold: red reflects most; the albedo per channel is below 1 and below F0.
    let a = albedo_quadrature_rgb(m.brdf.as_ref(), Vec3::Z, 60);
    let f0 = Vec3::new(
        fresnel_conductor1(1.0, 0.143036, 3.983),
        fresnel_conductor1(1.0, 0.375307, 2.38556),
        fresnel_conductor1(1.0, 1.44205, 1.60336),
    );
    eprintln!("gold albedo at 0°: {a:?}, F0 {f0}");
    assert!(a.x > a.y && a.y > a.z, "{a:?}");
    for c in 0..3 {
        assert!(
            (a[c] / f0[c] as f64 - 1.0).abs() < 0.02 && a[c] < 1.0,
            "{a:?} vs F0 {f0}"
        );
    }
    // The JSON's name for the roughness is not ours.
    let e = material(&src.replace("roughness =", "roughness_alpha =")).unwrap_err();
    assert!(
        e.contains("roughness_alpha") && e.contains("unknown field"),
        "{e}"
    );
}

#[test]
fn default_is_the_survey_model_and_warns_about_its_energy() {
    let (m, warnings) = material("model = \"cook_torrance\"\n").unwrap();
    let p = m.brdf.pack();
    assert_eq!(
        (p.0[7], p.0[11], p.0[15], p.0[16], p.0[8]),
        (4.0, 0.0, 0.0, 0.0, 1.5)
    );
    assert!(
        warnings.len() == 1 && warnings[0].contains("walter") && warnings[0].contains("4"),
        "{warnings:?}"
    );
    let (_, warnings) = material(&with_fields(
        "cook_torrance",
        "normalization = \"walter\"\nkd = 0.3\nks = 0.7",
    ))
    .unwrap();
    assert!(warnings.is_empty());
    warns_each(
        "cook_torrance",
        &[(
            "normalization = \"walter\"\nkd = 0.5\nks = 0.7",
            &["kd + ks"],
        )],
    );
}

#[test]
fn bad_parameters_are_rejected() {
    let cases = [
        ("roughness = -0.1", "roughness", "out of range"),
        ("roughness = nan", "roughness", "not a finite"),
        ("distribution = \"phong\"", "distribution", "unknown value"),
        ("geometry = \"smith_hc\"", "geometry", "unknown value"),
        ("normalization = \"pi\"", "normalization", "unknown value"),
        ("eta = [1, 1, 1]", "eta", "fresnel = \"conductor\""),
        (
            "fresnel = \"conductor\"\nior = 1.3",
            "ior",
            "fresnel = \"dielectric\"",
        ),
        ("fresnel = \"conductor\"\neta = [0, 1, 1]", "eta", "> 0"),
        ("fresnel = \"schlick\"\nf0 = 1.5", "f0", "out of range"),
        ("ior = 0.5", "ior", "out of range"),
        ("kd = [0.1, 0.2]", "kd", "array of 2"),
    ];
    // Some cases take two lines: the error names test.toml, at whichever line.
    rejects_fields("cook_torrance", "test.toml:", &cases);
}

/// Both half-vector samplers (v_cavity: D(h) cosθh; smith: the visible normals) at grazing
/// incidence, smooth to the mirror threshold and rough, on a grid of random numbers that
/// includes 0.
#[test]
fn sample_weights_are_finite_at_grazing() {
    for (distribution, geometry) in [
        (Distribution::Beckmann, Geometry::VCavity),
        (Distribution::Beckmann, Geometry::Smith),
        (Distribution::Ggx, Geometry::Smith),
    ] {
        for roughness in [1e-3, 0.02, 1.0] {
            let m = CookTorrance {
                kd: Vec3::splat(0.3),
                ks: Vec3::splat(0.7),
                roughness,
                distribution,
                geometry,
                ..Default::default()
            };
            for th in [0.0, 89.0, 89.9, 89.99] {
                let wo = dir_from_theta_deg(th, 0.0);
                for i in 0..2000u32 {
                    let u = Vec2::new((i % 50) as f32 / 50.0, (i / 50) as f32 / 40.0);
                    if let Some(s) = m.sample(wo, (i % 7) as f32 / 7.0, u) {
                        assert!(
                            s.weight.is_finite() && s.pdf.is_finite() && s.wi.is_finite(),
                            "{m:?} θ={th}: {s:?}"
                        );
                    }
                }
            }
        }
    }
}

/// The visible-normal density D_wo(h) = G1(wo) max(0, wo·h) D(h)/cosθo integrates to 1 over h
/// only with the exact Smith G1 ([`cook_torrance::exact_g1`]; Beckmann: the erfc form, not
/// Walter's approximation): an f64 quadrature over h by the NDF warp (tan²θh = −α² ln(1 − u)
/// or α² u/(1 − u), density D(h) cosθh), rough and smooth, normal to grazing incidence. The
/// sampler's χ² test checks the shape; this pins the normalisation, to 2·10⁻⁴ (Walter's G1 is
/// up to 3.5·10⁻³ off).
#[test]
fn visible_normal_density_integrates_to_one() {
    for distribution in [Distribution::Beckmann, Distribution::Ggx] {
        for alpha in [0.05f32, 0.2, 0.8] {
            let m = white(alpha, distribution, Geometry::Smith, Normalization::Walter);
            for th in [0.0f32, 45.0, 80.0, 89.0] {
                let wo = dir_from_theta_deg(th, 20.0);
                let g1 = cook_torrance::exact_g1(&m, wo) as f64;
                let a = alpha as f64;
                let (nu, np) = (2000usize, 400usize);
                let mut sum = 0.0f64;
                for iu in 0..nu {
                    // u = 1 − (1 − s)², du = 2(1 − s) ds: GGX's tail (integrand ~ (1 − u)^−½)
                    // becomes bounded.
                    let s = (iu as f64 + 0.5) / nu as f64;
                    let u = 1.0 - (1.0 - s) * (1.0 - s);
                    let du = 2.0 * (1.0 - s);
                    let t2 = match distribution {
                        Distribution::Beckmann => -a * a * (1.0 - u).ln(),
                        Distribution::Ggx => a * a * u / (1.0 - u),
                    };
                    let ct = 1.0 / (1.0 + t2).sqrt();
                    let st = t2.sqrt() * ct;
                    for ip in 0..np {
                        let phi = 2.0 * std::f64::consts::PI * (ip as f64 + 0.5) / np as f64;
                        let oh = wo.x as f64 * st * phi.cos()
                            + wo.y as f64 * st * phi.sin()
                            + wo.z as f64 * ct;
                        sum += du * oh.max(0.0) / ct;
                    }
                }
                let total = g1 * sum / (nu * np) as f64 / wo.z as f64;
                eprintln!("{distribution:?} α={alpha} θ={th}: ∫D_wo = {total:.6} (G1 {g1:.5})");
                assert!(
                    (total - 1.0).abs() < 2e-4,
                    "{distribution:?} α={alpha} θ={th}: {total}"
                );
            }
        }
    }
}

/// The gold block's material with `kd`: the Cornell box's glossy variant.
fn gold(kd: f32) -> CookTorrance {
    CookTorrance {
        kd: Vec3::splat(kd),
        ks: Vec3::splat(1.0 - kd),
        roughness: 0.2,
        distribution: Distribution::Beckmann,
        geometry: Geometry::Smith,
        fresnel: Fresnel::Conductor,
        normalization: Normalization::Walter,
        ..Default::default()
    }
}

fn gold_ndf_pdf(given: Vec3, sampled: Vec3) -> f32 {
    cook_torrance::pdf_with(&gold(0.0), Sampler::Ndf, given, sampled)
}

/// The χ² test would catch a visible-normal sampler whose pdf is not its density: the gold's
/// samples against the D(h) cosθh density of the old sampler are rejected at 10⁻⁶.
#[test]
fn chi2_rejects_the_ndf_pdf_for_visible_samples() {
    let m = Tampered {
        inner: std::sync::Arc::new(gold(0.0)),
        pdf: Some(gold_ndf_pdf),
        sample: None,
    };
    assert_eq!(gold(0.0).sampler(), Sampler::Visible);
    for th in [45.0, 80.0] {
        let r = chi2_test(&m, dir_from_theta_deg(th, 30.0), 100_000, 3);
        eprintln!("tampered θ={th}: {r:?}");
        assert!(r.p_value < 1e-6, "θ={th}: {r:?}");
    }
}

/// Variance of one sample's weight f·cosθ/pdf (grey, the albedo estimator of the path
/// tracer's BSDF sampling) with the half-vector sampler `s`: n samples at `wo`, seed 11.
fn weight_variance(m: &CookTorrance, s: Sampler, wo: Vec3, n: u32) -> (f64, f64) {
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for i in 0..n {
        let r = |d| brdfwave::rng::random_f32(11, i, 0, 0, d);
        if let Some(smp) = cook_torrance::sample_with(m, s, wo, r(0), Vec2::new(r(1), r(2))) {
            let w = grey(smp.weight);
            sum += w;
            sum2 += w * w;
        }
    }
    let mean = sum / n as f64;
    (mean, sum2 / n as f64 - mean * mean)
}

/// Which variants sample visible normals, by figures: the variance of one sample's weight
/// (the albedo estimator) with either sampler for every distribution, geometry and
/// normalisation, without and with a diffuse part, rough and smooth, normal to grazing
/// incidence (printed; `--nocapture`). Where a variant uses the visible normals, they must not
/// raise the variance summed over the angles, nor at any one angle by more than 2 %.
#[test]
fn visible_normals_lower_the_weight_variance() {
    let angles = [0.0f32, 30.0, 60.0, 75.0, 85.0, 89.0];
    let mut bad = Vec::new();
    for distribution in [Distribution::Beckmann, Distribution::Ggx] {
        for geometry in [Geometry::Smith, Geometry::VCavity] {
            for normalization in [Normalization::Walter, Normalization::Survey] {
                for kd in [0.0f32, 0.3] {
                    for m in [0.05f32, 0.2, 0.5] {
                        let mat = CookTorrance {
                            roughness: m,
                            distribution,
                            geometry,
                            normalization,
                            ..gold(kd)
                        };
                        let (mut tn, mut tv, mut worst) = (0.0, 0.0, 0.0f64);
                        let mut row = String::new();
                        for th in angles {
                            let wo = dir_from_theta_deg(th, 10.0);
                            let (mn, vn) = weight_variance(&mat, Sampler::Ndf, wo, 40_000);
                            let (mv, vv) = weight_variance(&mat, Sampler::Visible, wo, 40_000);
                            let ratio = vv / vn.max(1e-30);
                            row += &format!(" {th}°:{ratio:.2}");
                            tn += vn;
                            tv += vv;
                            if vn > 1e-6 * mn.max(mv) * mn.max(mv) {
                                worst = worst.max(ratio);
                            }
                        }
                        let name = format!(
                            "{distribution:?} {geometry:?} {normalization:?} kd={kd} m={m}"
                        );
                        eprintln!(
                            "{name}: Var ratio visible/ndf {:.3} (per angle{row})",
                            tv / tn
                        );
                        if mat.sampler() == Sampler::Visible && !(tv <= tn && worst < 1.02) {
                            bad.push(format!("{name}: {tv} vs {tn}, worst {worst}"));
                        }
                    }
                }
            }
        }
    }
    assert!(
        bad.is_empty(),
        "visible normals raise the variance: {bad:#?}"
    );
}

/// `eval_pdf`, which shares the half vector and D(h) between the two, gives `eval(wi, wo)` and
/// `pdf(wo, wi)` bit for bit, for both half-vector samplers, every Fresnel term, both
/// distributions and geometries, a diffuse lobe or none, the delta mirror, and directions on
/// either side of the horizon; and a sample's weight and pdf are those of the two calls.
#[test]
fn eval_pdf_is_eval_and_pdf_bit_for_bit() {
    let mut variants = chi2_variants();
    for geometry in [Geometry::VCavity, Geometry::Smith] {
        for fresnel in [Fresnel::Dielectric, Fresnel::Conductor, Fresnel::Schlick] {
            for kd in [0.0, 0.3] {
                variants.push((
                    format!("{geometry:?} {fresnel:?} kd={kd}"),
                    CookTorrance {
                        kd: Vec3::splat(kd),
                        ks: Vec3::splat(0.6),
                        roughness: 0.25,
                        geometry,
                        fresnel,
                        ..Default::default()
                    },
                ));
            }
        }
    }
    let bits = |v: Vec3| v.to_array().map(f32::to_bits);
    for (name, m) in &variants {
        for s in [Sampler::Ndf, Sampler::Visible] {
            for i in 0..400 {
                let (mut wi, mut wo) = (rand_dir(i, 0), rand_dir(i, 2));
                if i % 7 == 0 {
                    wi.z = -wi.z;
                }
                if i % 11 == 0 {
                    wo.z = -wo.z;
                }
                let (f, p) = cook_torrance::eval_pdf_with(m, s, wi, wo);
                let want_p = cook_torrance::pdf_with(m, s, wo, wi);
                assert_eq!(
                    bits(f),
                    bits(cook_torrance::eval(m, wi, wo)),
                    "{name} {s:?} f"
                );
                assert_eq!(p.to_bits(), want_p.to_bits(), "{name} {s:?} pdf");
                let u = Vec2::new(
                    brdfwave::rng::random_f32(7, i, 0, 0, 0),
                    brdfwave::rng::random_f32(7, i, 0, 0, 1),
                );
                let u_lobe = brdfwave::rng::random_f32(7, i, 0, 0, 2);
                if let Some(bs) = cook_torrance::sample_with(m, s, wo, u_lobe, u) {
                    if !bs.delta {
                        let p = cook_torrance::pdf_with(m, s, wo, bs.wi);
                        let w = cook_torrance::eval(m, bs.wi, wo) * (bs.wi.z / p);
                        assert_eq!(bs.pdf.to_bits(), p.to_bits(), "{name} {s:?} sample pdf");
                        assert_eq!(bits(bs.weight), bits(w), "{name} {s:?} sample weight");
                    }
                }
            }
        }
        let (f, p) = m.eval_pdf(rand_dir(3, 0), rand_dir(3, 2));
        let want = cook_torrance::eval_pdf_with(m, m.sampler(), rand_dir(3, 0), rand_dir(3, 2));
        assert_eq!(
            (bits(f), p.to_bits()),
            (bits(want.0), want.1.to_bits()),
            "{name} trait"
        );
    }
}
