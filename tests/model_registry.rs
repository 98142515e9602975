//! The model registry (`brdf::MODELS`) drives everything outside a model's two twin files and
//! its test file; these tests fail, naming the model, where something is not derived from it:
//! the stress generator, the `brdf report` materials, the lineup scene, the parameter
//! declarations and the generated GLSL. (GPU parity: tests/brdf_gpu_parity.rs; the docs:
//! tests/docs.rs; the lineup's pipelines: tests/render_models.rs.)

mod common;
use brdfwave::brdf::{glsl, inline::parse_inline, inline::parse_inline_at, Kind, MODELS};
use common::brdf::{assert_no_model_missing, fixtures};
use std::collections::BTreeMap;

/// Whether the model reads its data from a file (a measured table): such a model has no
/// parameter-only material, so the coverage rules build its instances from the files
/// `brdf::write_fixtures` writes.
fn reads_a_file(m: &brdfwave::brdf::ModelInfo) -> bool {
    m.params.iter().any(|p| p.kind == Kind::File)
}

/// The stress test's random materials (`stress::random_material`) cover every model, and each
/// generated material is of the model asked for.
#[test]
fn stress_generates_materials_of_every_model() {
    let mut missing = Vec::new();
    for (i, m) in MODELS.iter().enumerate() {
        let mut r = brdfwave::stress::Rng::new(7);
        match brdfwave::stress::random_material_of(m.name, &mut r) {
            None => missing.push(m.name),
            Some(src) => {
                let mat = brdfwave::stress::quiet_material(&src)
                    .unwrap_or_else(|e| panic!("{src}: {e:#}"));
                assert_eq!(mat.model, i, "{}: generated {src}", m.name);
            }
        }
    }
    assert_no_model_missing(&missing, "stress::random_material_of");
}

/// `brdf report` measures at least one material of every model, each of its own model; the
/// data files they name are the registry's fixtures (`brdf::write_fixtures`, which `brdf
/// report` writes too).
#[test]
fn the_report_measures_every_model() {
    let fixtures = fixtures();
    for (i, m) in MODELS.iter().enumerate() {
        assert!(
            !m.report_materials().is_empty(),
            "{}: REPRESENTATIVE is empty, so `brdf report` skips the model",
            m.name
        );
        for (label, src) in m.report_materials() {
            let (mat, _) = parse_inline_at("--material", &src, Some(fixtures.path()))
                .unwrap_or_else(|e| panic!("{label}: {e:#}"));
            assert_eq!(mat.model, i, "{}: {label} is another model's", m.name);
        }
    }
    let labels = brdfwave::brdf_tools::representative();
    let distinct: std::collections::BTreeSet<_> = labels.iter().map(|(l, _)| l).collect();
    assert_eq!(distinct.len(), labels.len(), "report labels repeat");
}

/// scenes/lineup.toml shows every analytic model side by side. A measured model's table cannot
/// be shipped: `brdf fit`'s lineup shows it beside its fits instead (tests/brdf_measured.rs
/// renders that lineup on both backends).
#[test]
fn the_lineup_shows_every_model() {
    let scene = brdfwave::scene::load(&common::repo().join("scenes/lineup.toml")).unwrap();
    let shown = scene.shaded_models();
    let missing: Vec<&str> = (0..MODELS.len())
        .filter(|&i| !shown.contains(&i) && !reads_a_file(&MODELS[i]))
        .map(|i| MODELS[i].name)
        .collect();
    assert_no_model_missing(&missing, "scenes/lineup.toml");
}

/// Each model's parser reads exactly the parameters it declares (so the declared defaults,
/// ranges and docs are the parser's), and no declared default is outside its declared range.
#[test]
fn every_model_reads_exactly_its_declared_parameters() {
    let fixtures = fixtures();
    for m in MODELS.iter() {
        // The fields read for a material that gives none (but the file a model requires: its
        // representative material's, from the fixtures).
        let src = match reads_a_file(m) {
            false => format!(r#"model = "{}", no_such_field = 1"#, m.name),
            true => format!("{}, no_such_field = 1", m.report_materials()[0].1),
        };
        let err = parse_inline_at("--material", &src, Some(fixtures.path()))
            .unwrap_err()
            .to_string();
        let mut declared: Vec<&str> = m.params.iter().map(|p| p.name).collect();
        declared.sort_unstable();
        assert!(
            err.contains(&format!("(it takes: {})", declared.join(", "))),
            "{}: {err}",
            m.name
        );
        let names_read = {
            let origin = brdfwave::brdf::Origin {
                file: "test",
                source: "",
                material: "m",
                span: 0..0,
                dir: None,
            };
            let mut r = brdfwave::brdf::ParamReader::new(origin, BTreeMap::new());
            // Only a required file parameter may refuse the empty material.
            if let Err(e) = (m.parse)(&mut r) {
                assert!(reads_a_file(m), "{}: {e}", m.name);
                assert!(e.to_string().contains("field 'file': missing"), "{e}");
            }
            r.names_read().join(", ")
        };
        assert_eq!(
            names_read,
            declared.join(", "),
            "{}: fields read vs declared",
            m.name
        );
        for p in m.params {
            let value = match p.kind {
                Kind::Rgb(c) => format!("[{:?}, {:?}, {:?}]", c[0], c[1], c[2]),
                Kind::Scalar(x) => format!("{x:?}"),
                // A file has no default: the registry's fixtures cover it (the report test).
                Kind::File => continue,
                Kind::Choice(options, d) => {
                    assert!(
                        options.contains(&d),
                        "{}.{}: default not an option",
                        m.name,
                        p.name
                    );
                    format!("\"{d}\"")
                }
            };
            if p.default_text.is_some() {
                continue;
            }
            // A parameter another one needs (Schlick's second layer) may be refused alone; the
            // declared default must not be out of the declared range.
            if let Kind::Rgb(c) = p.kind {
                assert!(
                    c.iter().all(|x| (p.min..=p.max).contains(x)),
                    "{}.{}",
                    m.name,
                    p.name
                );
            }
            if let Kind::Scalar(x) = p.kind {
                assert!((p.min..=p.max).contains(&x), "{}.{}", m.name, p.name);
            }
            let one = format!(r#"model = "{}", {} = {value}"#, m.name, p.name);
            if let Err(e) = parse_inline(&one) {
                assert!(
                    !e.to_string().contains("out of range"),
                    "{}: the declared default of {} is refused: {e:#}",
                    m.name,
                    p.name
                );
            }
        }
    }
}

/// The megakernel's dispatch includes and switches on every model, and each model's GLSL file
/// defines the three functions it calls; every record code a model declares is defined in the
/// generated record header and named by the model's GLSL file (in its code, or for the last
/// case of a branch in its record comment).
#[test]
fn the_generated_glsl_covers_every_model() {
    let any = glsl::any_glsl();
    let record = glsl::record_glsl();
    for m in MODELS.iter() {
        let file = format!("shaders/brdf/{}.glsl", m.name);
        let text = std::fs::read_to_string(common::repo().join(&file))
            .unwrap_or_else(|e| panic!("{}: {file}: {e}", m.name));
        for op in ["eval", "pdf", "sample"] {
            let f = format!("{}_{op}(", m.name);
            assert!(any.contains(&f), "brdf/any.glsl does not call {f}");
            assert!(text.contains(&f), "{file} does not define {f}");
        }
        for (code, _) in m.record_codes() {
            assert!(record.contains(&format!("#define {code} ")), "{code}");
            assert!(
                text.contains(code),
                "{file} does not name its record code {code}"
            );
        }
    }
}
