//! Materials given inline on the command line: the inside of a TOML inline table, as in
//! `--material 'model = "ward", kd = 0.1, ks = 0.8, alpha_x = 0.2, alpha_y = 0.1'`, or the same
//! fields one per line.

use super::{parse_material, Material, Origin};
use anyhow::{anyhow, Result};
use std::collections::BTreeMap;
use toml::{Spanned, Value};

#[derive(serde::Deserialize)]
struct Wrapped {
    material: BTreeMap<String, Spanned<Value>>,
    /// Anything beside the material: a `}` in the text closes the wrapping table early and lets
    /// the rest define other tables, which must be refused, not ignored.
    #[serde(flatten)]
    other: BTreeMap<String, Value>,
}

/// Parse an inline material into a material; warnings go to stderr.
pub fn parse_inline(src: &str) -> Result<Material> {
    let (m, warnings) = parse_inline_from("--material", src)?;
    for w in warnings {
        eprintln!("{w}");
    }
    Ok(m)
}

/// [`parse_inline`] for fields that come from `from` (named in messages), returning the
/// material's warnings instead of printing them.
pub fn parse_inline_from(from: &str, src: &str) -> Result<(Material, Vec<String>)> {
    parse_inline_at(from, src, None)
}

/// [`parse_inline_from`] with relative file parameters resolved against `dir` (the working
/// directory when `None`).
pub fn parse_inline_at(
    from: &str,
    src: &str,
    dir: Option<&std::path::Path>,
) -> Result<(Material, Vec<String>)> {
    // Comma-separated fields are the inside of an inline table; newline-separated fields are a
    // table body. Try the first, then the second.
    let wrapped = format!("material = {{ {} }}", src.trim());
    let (source, fields) = match toml::from_str::<Wrapped>(&wrapped) {
        Ok(w) if !w.other.is_empty() => {
            let extra: Vec<String> = w.other.keys().map(|k| format!("'{k}'")).collect();
            return Err(anyhow!(
                "{from}: only the material's fields are allowed, but the text also defines {} \
                 (a '}}' in it ends the material's table early)",
                extra.join(", ")
            ));
        }
        Ok(w) => (wrapped.clone(), w.material),
        Err(first) => match toml::from_str::<BTreeMap<String, Spanned<Value>>>(src) {
            Ok(f) => (src.to_string(), f),
            Err(_) => return Err(anyhow!("{from}: not a TOML table of fields: {first}")),
        },
    };
    let origin = Origin {
        file: from,
        source: &source,
        material: "inline",
        span: 0..source.len(),
        dir,
    };
    Ok(parse_material(origin, fields)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comma_and_newline_forms_parse_and_bad_fields_are_named() {
        let a = parse_inline(r#"model = "lambert", albedo = [0.2, 0.5, 0.9]"#).unwrap();
        let b = parse_inline("model = \"lambert\"\nalbedo = [0.2, 0.5, 0.9]").unwrap();
        assert_eq!(a.model_name(), "lambert");
        assert_eq!(a.brdf.pack(), b.brdf.pack());
        let e = parse_inline(r#"model = "lambert", albedo = -1"#)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("--material") && e.contains("albedo") && e.contains("out of range"),
            "{e}"
        );
        let e = parse_inline(r#"model = "lambert", albdo = 1"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("albdo") && e.contains("unknown field"), "{e}");
        assert!(parse_inline("model = ").is_err());
        // Text that closes the wrapping table and smuggles in other tables is refused.
        let e = parse_inline("model = \"lambert\", albedo = 0.5 }\n[x]\ny = 1\nz = {")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("'x'") && e.contains("only the material's fields"),
            "{e}"
        );
        let e = parse_inline("model = \"lambert\" }\nother = { a = 1")
            .unwrap_err()
            .to_string();
        assert!(e.contains("'other'"), "{e}");
    }
}
