//! The GLSL the shaders get from the model registry ([`MODELS`]) rather than from files kept
//! in step by hand: generated at run time like `gpu::layout::defines()`, and served by the
//! shader compiler as in-memory sources ([`sources`], registered in `ShaderCompiler::new`).
//!
//! * `brdf/any.glsl` ([`any_glsl`]): the megakernel's BRDF interface, one switch over the
//!   material's model index for each of `eval`, `pdf` and `sample`. Each model's functions are
//!   named by the convention `<name>_eval`, `<name>_pdf`, `<name>_sample` of its file
//!   `shaders/brdf/<name>.glsl`; the megakernel defines `MODEL_<NAME>` (the model's index) for
//!   each model the scene uses, and only those are included and switched on.
//! * `brdf/record.glsl` ([`record_glsl`]): the material record's size (from
//!   [`RECORD_WORDS`](super::RECORD_WORDS)) and every model's record codes
//!   ([`ModelInfo::record_codes`](super::ModelInfo)), so that no shader compares a record word
//!   against a bare float code.

use super::{MODELS, RECORD_PARAMS, RECORD_WORDS};
use std::fmt::Write;

/// Virtual path of the megakernel's generated BRDF dispatch.
pub const ANY_GLSL: &str = "brdf/any.glsl";
/// Virtual path of the generated record layout and record codes.
pub const RECORD_GLSL: &str = "brdf/record.glsl";

/// The generated shader sources, (virtual path under `shaders/`, text).
pub fn sources() -> Vec<(String, String)> {
    vec![
        (ANY_GLSL.to_string(), any_glsl()),
        (RECORD_GLSL.to_string(), record_glsl()),
    ]
}

/// One function of the BRDF interface as the megakernel's switch forwards it.
struct Entry {
    /// The interface function: `any_<op>`, forwarding to `<model>_<op>`.
    op: &'static str,
    signature: &'static str,
    args: &'static str,
    /// Statements before the switch.
    prologue: &'static str,
    /// What a model index not compiled in returns.
    fallback: &'static str,
}

const ENTRIES: [Entry; 3] = [
    Entry {
        op: "eval",
        signature: "vec3 any_eval(Material m, vec3 wi, vec3 wo)",
        args: "m, wi, wo",
        prologue: "",
        fallback: "vec3(0.0)",
    },
    Entry {
        op: "pdf",
        signature: "float any_pdf(Material m, vec3 given, vec3 sampled)",
        args: "m, given, sampled",
        prologue: "",
        fallback: "0.0",
    },
    Entry {
        op: "sample",
        signature: "bool any_sample(Material m, vec3 given, float u_lobe, vec2 u, out BrdfSample s)",
        args: "m, given, u_lobe, u, s",
        prologue: "    s.wi = vec3(0.0, 0.0, 1.0);\n    s.weight = vec3(0.0);\n    s.pdf = 0.0;\n    s.delta = false;\n",
        fallback: "false",
    },
];

/// The `MODEL_<NAME>` define of a model (its index when the megakernel compiles it in).
pub fn model_define(name: &str) -> String {
    format!("MODEL_{}", name.to_uppercase())
}

/// `brdf/any.glsl`: every model a scene uses behind one switch on the material's model index,
/// for the megakernel (wavefront/megakernel.comp), which shades every model in one pipeline.
pub fn any_glsl() -> String {
    let mut s = String::from(
        "// Generated from brdf::MODELS by src/brdf/glsl.rs (any_glsl): the megakernel's BRDF\n\
         // interface. MODEL_<NAME> is defined as the model's index for each model the scene uses.\n\
         #ifndef BRDF_ANY_GLSL\n#define BRDF_ANY_GLSL\n#include \"brdf/common.glsl\"\n",
    );
    for m in MODELS.iter() {
        let d = model_define(m.name);
        let _ = writeln!(s, "#ifdef {d}\n#include \"brdf/{}.glsl\"\n#endif", m.name);
    }
    for e in &ENTRIES {
        let _ = write!(
            s,
            "\n{} {{\n{}    switch (m.header.x) {{\n",
            e.signature, e.prologue
        );
        for m in MODELS.iter() {
            let d = model_define(m.name);
            let _ = writeln!(
                s,
                "#ifdef {d}\n    case {d}: return {}_{}({});\n#endif",
                m.name, e.op, e.args
            );
        }
        let _ = write!(s, "    default: return {};\n    }}\n}}\n", e.fallback);
    }
    // A textured material's derived record words (brdf/textured.rs), under SCENE_TEXTURES.
    s += "\n#ifdef SCENE_TEXTURES\nvoid any_textured(inout Material m) {\n    switch (m.header.x) {\n";
    for m in MODELS.iter() {
        let d = model_define(m.name);
        let _ = writeln!(
            s,
            "#ifdef {d}\n    case {d}: {}_textured(m); return;\n#endif",
            m.name
        );
    }
    s += "    default: return;\n    }\n}\n#define BRDF_TEXTURED any_textured\n#endif\n";
    s += "\n#define BRDF_EVAL any_eval\n#define BRDF_PDF any_pdf\n#define BRDF_SAMPLE any_sample\n\n#endif\n";
    s
}

/// A float code as a GLSL literal that reads back exactly (`1.0`, `0.5`).
fn glsl_float(x: f32) -> String {
    let s = format!("{x:?}");
    if s.contains('.') || s.contains('e') {
        s
    } else {
        format!("{s}.0")
    }
}

/// `brdf/record.glsl`: the material record's size, `MATERIAL_TEXELS` uvec4 texels of which the
/// first is the header and the other `MATERIAL_PARAMS` hold `p[]`, and every model's record
/// codes.
pub fn record_glsl() -> String {
    let mut s = String::from(
        "// Generated from brdf::MODELS by src/brdf/glsl.rs (record_glsl): the GPU material\n\
         // record's size and the codes of the enums models write into it.\n\
         #ifndef BRDF_RECORD_GLSL\n#define BRDF_RECORD_GLSL\n",
    );
    let _ = writeln!(s, "#define MATERIAL_TEXELS {}u", RECORD_WORDS / 4);
    let _ = writeln!(s, "#define MATERIAL_PARAMS {}", RECORD_PARAMS / 4);
    for m in MODELS.iter() {
        for (name, code) in m.record_codes() {
            let _ = writeln!(s, "#define {name} {}", glsl_float(*code));
        }
    }
    s += "#endif\n";
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_model_is_included_and_switched_on_in_every_function() {
        let text = any_glsl();
        for m in MODELS.iter() {
            let d = model_define(m.name);
            assert!(text.contains(&format!("#include \"brdf/{}.glsl\"", m.name)));
            for op in ["eval", "pdf", "sample"] {
                assert!(
                    text.contains(&format!("case {d}: return {}_{op}(", m.name)),
                    "{}: no {op} case",
                    m.name
                );
            }
        }
    }

    #[test]
    fn record_codes_are_distinct_names_prefixed_by_their_model() {
        let mut seen = std::collections::BTreeSet::new();
        for m in MODELS.iter() {
            for (name, code) in m.record_codes() {
                let prefix = format!("{}_", m.name.to_uppercase());
                let short = m.name.split('_').map(|w| &w[..1]).collect::<String>();
                assert!(
                    name.starts_with(&prefix)
                        || name.starts_with(&format!("{}_", short.to_uppercase())),
                    "{}: record code {name} is not prefixed by the model",
                    m.name
                );
                assert!(seen.insert(*name), "record code {name} declared twice");
                assert_eq!(glsl_float(*code).parse::<f32>().unwrap(), *code);
            }
        }
    }
}
