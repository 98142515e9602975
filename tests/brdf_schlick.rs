//! Schlick 1994 (survey eqs. 18–26) through the validation harness: an albedo table by
//! independent quadrature (the glossy lobe exceeds 1 near grazing for small r), the non-normalised
//! azimuth factor, the non-conserving survey forms, χ² of the sampler for every form,
//! anisotropy and the two-layer material, sampled vs quadrature albedo with the mirror delta,
//! reciprocity and the parameter errors.

use brdfwave::brdf::schlick::{self, Form, Schlick};
mod common;
use brdfwave::brdf::validate::{albedo_quadrature, dir_from_theta_deg};
use brdfwave::brdf::{Brdf, BrdfSample, Params};
use common::brdf::{
    check_reciprocal, check_sampled_albedo, check_sampler, default_of, grey, mixture_albedo,
    mixture_sampler, model, models, rejects_fields, warns_each, ANGLES,
};
use glam::{Vec2, Vec3};

/// The glossy lobe B = G G' Z A/(4π v v') alone with S ≡ 1 (C = 1): the quantity of the §10
/// table, which no single scene material isolates for r ≠ 0.5.
#[derive(Debug)]
struct GlossyOnly {
    r: f32,
    p: f32,
}

impl Brdf for GlossyOnly {
    fn eval(&self, wi: Vec3, wo: Vec3) -> Vec3 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (wi + wo).normalize();
        Vec3::splat(schlick::glossy(self.r, self.p, 1.0, 0.0, wi, wo, h))
    }
    fn pdf(&self, given: Vec3, sampled: Vec3) -> f32 {
        if given.z <= 0.0 || sampled.z <= 0.0 {
            return 0.0;
        }
        schlick::glossy_pdf(self.r, self.p, 1.0, 0.0, given, sampled)
    }
    fn sample(&self, given: Vec3, _u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
        let h = schlick::sample_glossy_h(self.r, self.p, 1.0, 0.0, u);
        let wi = 2.0 * given.dot(h) * h - given;
        let pdf = self.pdf(given, wi);
        if given.dot(h) <= 0.0 || wi.z <= 0.0 || pdf <= 0.0 {
            return None;
        }
        Some(BrdfSample {
            wi,
            weight: self.eval(wi, given) * wi.z / pdf,
            pdf,
            delta: false,
        })
    }
    fn pack(&self) -> Params {
        Params::default()
    }
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
    fn with_params(&self, _: &brdfwave::brdf::textured::ParamValues) -> std::sync::Arc<dyn Brdf> {
        std::sync::Arc::new(GlossyOnly {
            r: self.r,
            p: self.p,
        })
    }
}

#[test]
fn albedo_table_of_section_10() {
    let table = [
        (0.005, [0.995, 0.985, 1.000, 1.90]),
        (0.05, [0.932, 0.865, 1.074, 1.63]),
        (0.2, [0.720, 0.655, 0.774, 0.866]),
        (0.5, [0.451, 0.435, 0.455, 0.463]),
    ];
    eprintln!("r      0°            60°           85°           89°   (measured (reference))");
    for (r, vals) in table {
        let b = GlossyOnly { r, p: 1.0 };
        let mut line = format!("{r:<6}");
        for (th, want) in [0.0f32, 60.0, 85.0, 89.0].into_iter().zip(vals) {
            // The r = 0.005 lobe (GGX α = 0.07) near grazing needs a fine grid.
            let n = if th >= 85.0 && r < 0.1 { 120 } else { 60 };
            let q = albedo_quadrature(&b, dir_from_theta_deg(th, 0.0), n);
            line += &format!(" {q:.4} ({want})");
            // The §10 table is accurate to ~1e-3 except the grazing entries of the narrow
            // lobes (r ≤ 0.05 at 85–89°), which differ from a fine f64 quadrature by up to
            // 1.6 % (see `grazing_entries_match_an_f64_half_vector_quadrature`).
            let tol = if th >= 85.0 && r < 0.1 { 2e-2 } else { 5e-3 };
            assert!((q / want - 1.0).abs() < tol, "r={r} θ={th}: {q} vs {want}");
        }
        eprintln!("{line}");
    }
    // At r = 0.5 the continuum form is exactly the glossy lobe (b = 1, a = c = 0).
    let m = Schlick {
        c: Vec3::ONE,
        r: 0.5,
        ..Default::default()
    };
    let q = albedo_quadrature(&m, dir_from_theta_deg(60.0, 0.0), 60);
    assert!((q - 0.435).abs() < 2e-3, "{q}");
}

/// Independent f64 reference for the glossy albedo (C = 1, p = 1): quadrature over the GGX
/// (α² = r) half-vector warp, ρ(wo) = ∫ (B cosθi / pdf) with B cosθi/pdf = cosθi (wo·h)/(q q' t).
fn glossy_albedo_f64(r: f64, theta_deg: f64, n: usize) -> f64 {
    let wo = [
        theta_deg.to_radians().sin(),
        0.0,
        theta_deg.to_radians().cos(),
    ];
    let mut s = 0.0;
    for iu in 0..n {
        let u = (iu as f64 + 0.5) / n as f64;
        let t2 = r * u / (1.0 - u);
        let ct = 1.0 / (1.0 + t2).sqrt();
        let st = t2.sqrt() * ct;
        for ip in 0..n {
            let phi = 2.0 * std::f64::consts::PI * (ip as f64 + 0.5) / n as f64;
            let h = [st * phi.cos(), st * phi.sin(), ct];
            let oh = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2];
            let wiz = 2.0 * oh * h[2] - wo[2];
            if oh <= 0.0 || wiz <= 0.0 {
                continue;
            }
            let (q, qo) = (r + (1.0 - r) * wiz, r + (1.0 - r) * wo[2]);
            s += wiz * oh / (q * qo * ct);
        }
    }
    s / (n * n) as f64
}

#[test]
fn grazing_entries_match_an_f64_half_vector_quadrature() {
    for (r, th) in [
        (0.005f32, 85.0f32),
        (0.005, 89.0),
        (0.05, 89.0),
        (0.2, 85.0),
    ] {
        let q = albedo_quadrature(&GlossyOnly { r, p: 1.0 }, dir_from_theta_deg(th, 0.0), 120);
        let want = glossy_albedo_f64(r as f64, th as f64, 2500);
        eprintln!("r={r} θ={th}: {q:.4} vs f64 {want:.4}");
        // validate's adaptive quadrature against the independent f64 half-vector grid.
        assert!((q / want - 1.0).abs() < 5e-3, "r={r} θ={th}: {q} vs {want}");
    }
}

/// A(w) is not normalised: at normal incidence and small r the lobe's albedo is the mean of
/// A over φ times the isotropic one: 0.971 (p = 0.5), 0.744 (p = 0.1), 0.381 (p = 0.01).
#[test]
fn azimuth_factor_loses_the_documented_energy() {
    let iso = albedo_quadrature(&GlossyOnly { r: 0.02, p: 1.0 }, Vec3::Z, 60);
    for (p, want) in [(0.5, 0.971), (0.1, 0.744), (0.01, 0.381)] {
        let q = albedo_quadrature(&GlossyOnly { r: 0.02, p }, Vec3::Z, 60);
        eprintln!("p={p}: albedo ratio {:.4} (mean A {want})", q / iso);
        assert!(
            (q / iso - want).abs() < 0.01,
            "p={p}: {} vs {want}",
            q / iso
        );
    }
}

#[test]
fn survey_forms_basic_and_attenuated_diverge_at_grazing() {
    for form in [Form::Basic, Form::Attenuated] {
        let m = Schlick {
            c: Vec3::ONE,
            r: 0.3,
            form,
            ..Default::default()
        };
        let a60 = albedo_quadrature(&m, dir_from_theta_deg(60.0, 0.0), 60);
        let a89 = albedo_quadrature(&m, dir_from_theta_deg(89.0, 0.0), 120);
        let a895 = albedo_quadrature(&m, dir_from_theta_deg(89.5, 0.0), 120);
        eprintln!("{form:?}: albedo 60° {a60:.3}, 89° {a89:.3}, 89.5° {a895:.3}");
        assert!(a89 > 1.5 && a895 > 1.5 * a89, "{form:?}: {a89} {a895}");
    }
    // The continuum form stays ≤ 1 for r ≥ 0.25 at every angle.
    for r in [0.25, 0.5, 0.8, 1.0] {
        let m = Schlick {
            c: Vec3::ONE,
            r,
            ..Default::default()
        };
        for th in [0.0, 30.0, 60.0, 80.0, 89.0] {
            let q = albedo_quadrature(&m, dir_from_theta_deg(th, 0.0), 60);
            assert!(q <= 1.002, "r={r} θ={th}: {q}");
        }
    }
}

fn variants() -> Vec<(&'static str, Schlick)> {
    let d = Schlick::default();
    vec![
        (
            "continuum r 0.2",
            Schlick {
                c: Vec3::new(0.9, 0.6, 0.3),
                ..d.clone()
            },
        ),
        (
            "continuum r 0.3 p 0.1 rot 30",
            Schlick {
                r: 0.3,
                p: 0.1,
                rotation: 30.0,
                ..d.clone()
            },
        ),
        (
            "continuum r 0.7 p 0.5",
            Schlick {
                r: 0.7,
                p: 0.5,
                ..d.clone()
            },
        ),
        (
            "attenuated r 0.3 p 0.5",
            Schlick {
                r: 0.3,
                p: 0.5,
                form: Form::Attenuated,
                ..d.clone()
            },
        ),
        (
            "basic r 0.2",
            Schlick {
                r: 0.2,
                form: Form::Basic,
                ..d.clone()
            },
        ),
        (
            "layered varnish c .05 r .1 / c2 .7 r2 .8 p2 .3",
            Schlick {
                c: Vec3::splat(0.05),
                r: 0.1,
                layered: true,
                c2: Vec3::new(0.7, 0.4, 0.2),
                r2: 0.8,
                p2: 0.3,
                rotation: -45.0,
                ..d.clone()
            },
        ),
    ]
}

#[test]
fn sampler_matches_pdf() {
    let vs = variants();
    check_sampler(&models(&vs), &mixture_sampler(70.0, 6));
}

#[test]
fn sampled_albedo_matches_quadrature_plus_delta() {
    let check = mixture_albedo(31);
    for (name, m) in variants() {
        // The survey forms' albedo diverges at grazing: compare them up to 80°.
        let angles = if m.form == Form::Continuum {
            &ANGLES[..]
        } else {
            &ANGLES[..4]
        };
        for &th in angles {
            let delta = grey(schlick::mirror_reflectance(
                &m,
                dir_from_theta_deg(th, 20.0),
            ));
            check_sampled_albedo(name, &m, (th, 20.0), delta, &check);
        }
    }
}

#[test]
fn reciprocal() {
    check_reciprocal(&models(&variants()), 20_000, 9, 1e-4);
}

#[test]
fn parameters_defines_and_errors() {
    let m = default_of("schlick");
    assert!(m.brdf.defines().is_empty());
    let p = m.brdf.pack();
    assert_eq!((p.0[3], p.0[8], p.0[10], p.0[11]), (0.2, 1.0, 2.0, 0.0));
    let m = model("schlick", "c2 = [0.5, 0.3, 0.1]\nr2 = 0.9\np2 = 0.5");
    assert_eq!(
        m.brdf.defines(),
        vec!["SCHLICK_LAYERED", "SCHLICK_ANISOTROPIC"]
    );
    let m = model("schlick", "p = 0.3\nrotation = 90");
    assert_eq!(m.brdf.defines(), vec!["SCHLICK_ANISOTROPIC"]);
    assert!(m.brdf.pack().0[12].abs() < 1e-6 && (m.brdf.pack().0[13] - 1.0).abs() < 1e-6);
    warns_each("schlick", &[("form = \"basic\"", &["energy"])]);
    let cases = [
        ("r = 1.5", "r", "out of range"),
        ("p = -0.1", "p", "out of range"),
        ("c = [0.1, 0.2, 1.1]", "c", "out of range"),
        ("r2 = 0.5", "r2", "c2"),
        ("form = \"ward\"", "form", "unknown value"),
        ("rotation = 400", "rotation", "out of range"),
        ("roughness = 0.5", "roughness", "unknown field"),
    ];
    rejects_fields("schlick", "test.toml:2", &cases);
}
