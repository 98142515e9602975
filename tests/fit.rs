//! `brdfwave::fit`: the survey's models fitted to synthetic MERL tables made from known
//! materials. A coarse subsample of the grid keeps each fit to a few seconds.

use brdfwave::brdf::inline::parse_inline;
use brdfwave::fit::{self, space::ModelSpec, FitOptions, ModelFit};
use brdfwave::measured::merl::MerlTable;
use glam::Vec3;

/// The coarse options of the tests: about 1300 cells compared, 500 of them driving the
/// optimiser.
fn options() -> FitOptions {
    FitOptions {
        samples: 2500,
        fit_samples: 500,
        ..FitOptions::default()
    }
}

fn table(material: &str) -> MerlTable {
    MerlTable::from_brdf(parse_inline(material).unwrap().brdf.as_ref())
}

fn fit(table: &MerlTable, model: &str) -> ModelFit {
    let spec = ModelSpec::parse(model).unwrap();
    fit::fit_all(table, &[spec], &options()).unwrap().remove(0)
}

/// Every fitted parameter named in `truth` is within `rel` (relative) plus `abs` of its value.
fn assert_recovers(f: &ModelFit, truth: &[(&str, [f32; 3])], rel: f32, abs: f32) {
    let got: Vec<(&str, Vec3)> = f
        .space
        .bounds
        .iter()
        .zip(&f.values)
        .map(|(b, v)| (b.param.name, *v))
        .collect();
    for (name, want) in truth {
        let want = Vec3::from_array(*want);
        let (_, v) = got
            .iter()
            .find(|(n, _)| n == name)
            .unwrap_or_else(|| panic!("{name} is not fitted: {got:?}"));
        let is_scalar = want.x == want.y && want.y == want.z;
        let v = if is_scalar { Vec3::splat(v.x) } else { *v };
        let ok = ((v - want).abs() - want.abs() * rel).max_element() <= abs;
        assert!(
            ok,
            "{}: {name} = {v}, expected {want} (± {rel}·value + {abs}); error {:.4}, all {got:?}",
            f.space.spec.label(),
            f.error
        );
    }
}

/// A material's text and its fitted parameters' true values.
struct Case {
    model: &'static str,
    fields: &'static [(&'static str, [f32; 3])],
}

fn text(c: &Case) -> String {
    let mut s = format!("model = \"{}\"", c.model);
    for (k, v) in c.fields {
        if v[0] == v[1] && v[1] == v[2] {
            s.push_str(&format!(", {k} = {}", v[0]));
        } else {
            s.push_str(&format!(", {k} = [{}, {}, {}]", v[0], v[1], v[2]));
        }
    }
    s
}

/// The models with a closed form (He's BRDF is a series and is left out), at parameters away
/// from their defaults and from the bounds.
const CASES: &[Case] = &[
    Case {
        model: "lambert",
        fields: &[("albedo", [0.6, 0.4, 0.2])],
    },
    Case {
        model: "oren_nayar",
        fields: &[("albedo", [0.5, 0.4, 0.3]), ("sigma", [0.4; 3])],
    },
    Case {
        model: "phong",
        fields: &[
            ("kd", [0.3, 0.2, 0.1]),
            ("ks", [0.2, 0.25, 0.3]),
            ("exponent", [30.0; 3]),
        ],
    },
    Case {
        model: "blinn_phong",
        fields: &[
            ("kd", [0.2, 0.3, 0.1]),
            ("ks", [0.4, 0.3, 0.2]),
            ("exponent", [60.0; 3]),
        ],
    },
    Case {
        model: "cook_torrance",
        fields: &[
            ("kd", [0.2, 0.1, 0.05]),
            ("ks", [0.1, 0.12, 0.15]),
            ("roughness", [0.25; 3]),
            ("ior", [1.8; 3]),
        ],
    },
    Case {
        model: "ward",
        fields: &[
            ("kd", [0.2, 0.3, 0.1]),
            ("ks", [0.3, 0.25, 0.2]),
            ("alpha_x", [0.12; 3]),
        ],
    },
    Case {
        model: "schlick",
        fields: &[("c", [0.7, 0.5, 0.3]), ("r", [0.15; 3])],
    },
];

/// Tolerance of the exact-data recovery: 3% of the value plus 0.005.
#[test]
fn every_closed_form_model_recovers_its_parameters() {
    for c in CASES {
        let t = std::time::Instant::now();
        let f = fit(&table(&text(c)), c.model);
        eprintln!(
            "{}: error {:.2e}, {} evaluations, {:.2} s: {}",
            c.model,
            f.error,
            f.evals,
            t.elapsed().as_secs_f64(),
            f.material_text()
        );
        assert_recovers(&f, c.fields, 0.03, 0.005);
    }
}

#[test]
fn ward_data_is_fitted_best_by_ward() {
    let t = table(r#"model = "ward", kd = [0.15, 0.2, 0.1], ks = 0.3, alpha_x = 0.1"#);
    // Every analytic model (a measured table has nothing to fit).
    let specs: Vec<ModelSpec> = brdfwave::brdf::MODELS
        .iter()
        .filter(|m| ModelSpec::fittable(m))
        .map(|m| ModelSpec::parse(m.name).unwrap())
        .collect();
    let t0 = std::time::Instant::now();
    let fits = fit::fit_all(&t, &specs, &options()).unwrap();
    let mut ranked: Vec<(&str, f64, f64)> = fits
        .iter()
        .map(|f| (f.space.spec.model.name, f.error, f.seconds))
        .collect();
    ranked.sort_by(|a, b| a.1.total_cmp(&b.1));
    eprintln!("{:.2} s: {ranked:?}", t0.elapsed().as_secs_f64());
    assert_eq!(ranked[0].0, "ward", "{ranked:?}");
    // Clearly ahead, not by rounding.
    assert!(ranked[1].1 > 3.0 * ranked[0].1, "{ranked:?}");
}

/// Measurement-like noise: every value times exp(0.05·g), g ≈ standard normal (a sum of four
/// uniforms), independently per cell and channel. Tolerance: 8% of the value plus 0.01.
#[test]
fn noisy_data_still_recovers_the_parameters_within_a_looser_tolerance() {
    for c in CASES
        .iter()
        .filter(|c| ["ward", "cook_torrance", "oren_nayar"].contains(&c.model))
    {
        let mut t = table(&text(c));
        t.map_values(|ch, cell, v| {
            let u = |d| brdfwave::rng::random_f32(11, cell as u32, ch as u32, 0, d);
            let g = (u(0) + u(1) + u(2) + u(3) - 2.0) * 3f32.sqrt();
            v * (0.05 * g).exp()
        });
        let f = fit(&t, c.model);
        eprintln!(
            "{} (noisy): error {:.2e}: {}",
            c.model,
            f.error,
            f.material_text()
        );
        assert_recovers(&f, c.fields, 0.08, 0.01);
    }
}

#[test]
fn a_table_with_every_value_missing_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut bytes: Vec<u8> = [90i32, 90, 180]
        .iter()
        .flat_map(|d| d.to_le_bytes())
        .collect();
    for _ in 0..3 * brdfwave::measured::merl::CELLS {
        bytes.extend_from_slice(&(-1.0f64).to_le_bytes());
    }
    let p = dir.path().join("empty.binary");
    std::fs::write(&p, bytes).unwrap();
    let t = MerlTable::read(&p).unwrap();
    let e = fit::fit_all(&t, &[ModelSpec::parse("ward").unwrap()], &options()).unwrap_err();
    assert!(e.to_string().contains("too few to fit"), "{e}");
}

/// Fields of a material: (name, value; equal channels for a scalar).
type Fields = &'static [(&'static str, [f32; 3])];

/// A model with variants: the fields of its data away from the defaults, and the fields that
/// only some options take (`(option, fields)`: Cook–Torrance's Fresnel parameters).
struct VariantCase {
    model: &'static str,
    fields: Fields,
    per_option: &'static [(&'static str, Fields)],
}

const VARIANT_CASES: &[VariantCase] = &[
    VariantCase {
        model: "oren_nayar",
        fields: &[("albedo", [0.5, 0.4, 0.3]), ("sigma", [0.4; 3])],
        per_option: &[],
    },
    VariantCase {
        model: "phong",
        fields: &[
            ("kd", [0.3, 0.2, 0.1]),
            ("ks", [0.2, 0.25, 0.3]),
            ("exponent", [30.0; 3]),
        ],
        per_option: &[],
    },
    VariantCase {
        model: "blinn_phong",
        fields: &[
            ("kd", [0.2, 0.3, 0.1]),
            ("ks", [0.4, 0.3, 0.2]),
            ("exponent", [60.0; 3]),
        ],
        per_option: &[],
    },
    VariantCase {
        model: "ward",
        fields: &[
            ("kd", [0.2, 0.3, 0.1]),
            ("ks", [0.3, 0.25, 0.2]),
            ("alpha_x", [0.12; 3]),
        ],
        per_option: &[],
    },
    VariantCase {
        model: "schlick",
        fields: &[("c", [0.7, 0.5, 0.3]), ("r", [0.15; 3])],
        per_option: &[],
    },
    VariantCase {
        model: "cook_torrance",
        fields: &[
            ("kd", [0.2, 0.1, 0.05]),
            ("ks", [0.1, 0.12, 0.15]),
            ("roughness", [0.25; 3]),
        ],
        per_option: &[
            ("dielectric", &[("ior", [1.8; 3])]),
            (
                "conductor",
                &[("eta", [0.3, 0.6, 1.2]), ("k", [3.5, 2.6, 2.0])],
            ),
            ("schlick", &[("f0", [0.5, 0.4, 0.2])]),
        ],
    },
];

/// The fitted value of `name` (grey for a scalar).
fn fitted(f: &ModelFit, name: &str) -> Vec3 {
    let i = f.space.bounds.iter().position(|b| b.param.name == name);
    f.values[i.unwrap_or_else(|| panic!("{name} is not fitted"))]
}

/// Data made from each variant of a model, fitted by the model's name alone (every variant):
/// the true variant ranks first and recovers its parameters. Two variants are nested: a
/// conductor's Fresnel term with κ = 0 is the dielectric one with ior = η, so on dielectric
/// data the conductor variant may fit as well (its extra freedom, η per channel, can even fit
/// better within the optimiser's budget); it may then rank first, but only as that dielectric.
/// A conductor's (ks, η, κ) trade off against each other (ks·F is what the data fixes, and F's
/// shape changes little along the trade-off), so for conductor data the recovery is checked
/// on kd, the roughness and the specular reflectance at normal incidence, ks·F(0°).
#[test]
fn each_variant_is_ranked_first_on_its_own_data() {
    use brdfwave::brdf::common::fresnel_conductor;
    let scalar_or_rgb = |v: &[f32; 3]| match v {
        [a, b, c] if a == b && b == c => format!("{a}"),
        [a, b, c] => format!("[{a}, {b}, {c}]"),
    };
    for c in VARIANT_CASES {
        let specs = ModelSpec::expand(c.model).unwrap();
        assert!(specs.len() >= 2, "{}: {specs:?}", c.model);
        for truth in &specs {
            let has = |option: &str| truth.variant.iter().any(|(_, o)| *o == option);
            let mut fields: Vec<(&str, [f32; 3])> = c.fields.to_vec();
            for (option, extra) in c.per_option {
                if has(option) {
                    fields.extend_from_slice(extra);
                }
            }
            let text_fields: Vec<(&str, String)> =
                fields.iter().map(|(k, v)| (*k, scalar_or_rgb(v))).collect();
            let text = truth.text(&text_fields);
            let t0 = std::time::Instant::now();
            let fits = fit::fit_all(&table(&text), &specs, &options()).unwrap();
            let order = fit::report::ranking(&fits);
            let ranked: Vec<(String, f64)> = order
                .iter()
                .map(|&i| (fits[i].space.spec.label(), fits[i].error))
                .collect();
            eprintln!(
                "{} data, {:.1} s: {:?}",
                truth.label(),
                t0.elapsed().as_secs_f64(),
                &ranked[..3.min(ranked.len())]
            );
            let best = &fits[order[0]];
            let get = |n: &str| {
                fields
                    .iter()
                    .find(|f| f.0 == n)
                    .map(|f| Vec3::from_array(f.1))
            };
            let kd_and_roughness: Vec<(&str, [f32; 3])> = fields
                .iter()
                .filter(|f| ["kd", "roughness"].contains(&f.0))
                .copied()
                .collect();
            // ks·F(0°) of the fit (a conductor) against the truth's.
            let reflectance_at_normal = |want: Vec3| {
                let got = fitted(best, "ks")
                    * fresnel_conductor(1.0, fitted(best, "eta"), fitted(best, "k"));
                assert!(
                    ((got - want).abs() - 0.03 * want).max_element() <= 0.0,
                    "{text}: ks·F(0°) = {got}, expected {want}; {}",
                    best.material_text()
                );
            };
            if best.space.spec.label() != truth.label() {
                // Only the dielectric's data, fitted as a conductor of η ≈ ior and a κ that
                // changes F by a few per cent at most (F depends on κ², and κ = 0.25 moves
                // F(0°) by 3 % at η = 1.8).
                let as_conductor = truth.label().replace(":dielectric", ":conductor");
                assert!(
                    has("dielectric") && best.space.spec.label() == as_conductor,
                    "{text}: {ranked:?}"
                );
                let ior = get("ior").unwrap();
                assert_recovers(best, &kd_and_roughness, 0.03, 0.005);
                assert_recovers(best, &[("eta", ior.to_array())], 0.03, 0.005);
                assert!(
                    fitted(best, "k").max_element() < 0.25,
                    "{}",
                    best.material_text()
                );
                reflectance_at_normal(get("ks").unwrap() * fresnel_conductor(1.0, ior, Vec3::ZERO));
            } else if has("conductor") {
                assert_recovers(best, &kd_and_roughness, 0.03, 0.005);
                reflectance_at_normal(
                    get("ks").unwrap()
                        * fresnel_conductor(1.0, get("eta").unwrap(), get("k").unwrap()),
                );
            } else {
                assert_recovers(best, &fields, 0.03, 0.005);
            }
        }
    }
}
