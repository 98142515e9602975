//! The parameter documentation, generated from each model's declared parameters
//! ([`ModelInfo::params`](super::ModelInfo)): the table at the top of the model's Rust file,
//! its row of docs/models.md's model table and its row of scenes/README.md's per-model table.
//! tests/docs.rs compares the three texts exactly; [`update_model_file`] and [`update_rows`]
//! rewrite them (`BRDFWAVE_WRITE_DOCS=1 cargo test --release --test docs` does that).

use super::params::fmt_num;
use super::{Kind, ModelInfo, Param};

/// A table cell: `|` escaped.
fn cell(s: &str) -> String {
    s.replace('|', "\\|")
}

/// A number as the tables write it: 1e6 rather than 1000000.
fn num(x: f32) -> String {
    if x.abs() >= 1e5 && x.is_finite() {
        format!("{x:e}")
    } else {
        fmt_num(x)
    }
}

/// The default as the model-file table writes it: `[0.5, 0.5, 0.5]`, `0.3`, `"full"`.
fn default_text(p: &Param) -> String {
    if let Some(t) = p.default_text {
        return t.to_string();
    }
    match p.kind {
        Kind::Rgb(c) => format!("`[{}, {}, {}]`", num(c[0]), num(c[1]), num(c[2])),
        Kind::Scalar(x) => format!("`{}`", num(x)),
        Kind::Choice(_, d) => format!("`\"{d}\"`"),
        Kind::File => "required".to_string(),
    }
}

/// The default as scenes/README.md writes it: a grey RGB as one number.
fn short_default(p: &Param) -> String {
    if let Some(t) = p.default_text {
        return t.to_string();
    }
    match p.kind {
        Kind::Rgb(c) if c[0] == c[1] && c[1] == c[2] => num(c[0]),
        Kind::Rgb(c) => format!("[{}, {}, {}]", num(c[0]), num(c[1]), num(c[2])),
        Kind::Scalar(x) => num(x),
        Kind::Choice(_, d) => d.to_string(),
        Kind::File => "required".to_string(),
    }
}

fn options(p: &Param, sep: &str) -> String {
    match p.kind {
        Kind::Choice(o, _) => o
            .iter()
            .map(|o| format!("`{o}`"))
            .collect::<Vec<_>>()
            .join(sep),
        _ => String::new(),
    }
}

/// The range as the tables write it: `[0, 1]`, `≥ 0`, or the options.
fn range_text(p: &Param) -> String {
    if let Some(t) = p.range_text {
        return t.to_string();
    }
    if let Kind::Choice(..) = p.kind {
        return options(p, ", ");
    }
    match (p.min == f32::NEG_INFINITY, p.max == f32::INFINITY) {
        (true, true) => "any".to_string(),
        (false, true) => format!("≥ {}", num(p.min)),
        (true, false) => format!("≤ {}", num(p.max)),
        (false, false) => format!("[{}, {}]", num(p.min), num(p.max)),
    }
}

/// The parameter table of the model's Rust file, as `//! ` doc lines.
pub fn model_file_table(m: &ModelInfo) -> String {
    let mut s = String::from(
        "//! | parameter | unit | default | range | meaning | texture: GPU record |\n//! |---|---|---|---|---|---|\n",
    );
    for p in m.params {
        s += &format!(
            "//! | `{}` | {} | {} | {} | {} | {} |\n",
            p.name,
            cell(p.unit),
            cell(&default_text(p)),
            cell(&range_text(p)),
            cell(p.meaning),
            slot_text(p)
        );
    }
    s
}

/// Where a textured parameter's value goes in the GPU record (`brdf::textured`), as the
/// model-file table writes it: `p[1].xyz`, `p[0].w`, `p[2].zw` (cos, sin); `—` for a parameter
/// that cannot be a texture.
fn slot_text(p: &Param) -> String {
    use super::textured::SlotMode;
    let Some(slot) = p.slot else {
        return "—".to_string();
    };
    let n = match slot.mode {
        SlotMode::Rgb | SlotMode::Splat => 3,
        SlotMode::Scalar => 1,
        SlotMode::Angle => 2,
    };
    let (v, c) = (slot.word / 4, slot.word % 4);
    let comps: String = (c..c + n)
        .map(|k| ["x", "y", "z", "w"][k as usize])
        .collect();
    let mut t = format!("`p[{v}].{comps}`");
    if slot.mode == SlotMode::Angle {
        t += " (cos, sin)";
    }
    t
}

/// The table of a texture's fields (`kd = { texture = "…", … }`) in scenes/README.md, from
/// their declaration ([`crate::texture::TABLE_FIELDS`]).
pub fn texture_fields_table() -> String {
    let mut s = String::from("| field | type | default | meaning |\n|---|---|---|---|\n");
    for f in crate::texture::TABLE_FIELDS {
        s += &format!(
            "| `{}` | {} | {} | {} |\n",
            f.name,
            cell(f.kind),
            cell(f.default),
            cell(f.meaning)
        );
    }
    s
}

/// The model's row of docs/models.md's model table: where the survey gives it, the parameter names,
/// and a choice's options.
pub fn models_page_row(m: &ModelInfo) -> String {
    let params: Vec<String> = m
        .params
        .iter()
        .map(|p| match p.kind {
            Kind::Choice(..) => format!("`{}` = {}", p.name, options(p, " \\| ")),
            _ => format!("`{}`", p.name),
        })
        .collect();
    format!("| `{}` | {} | {} |", m.name, m.survey, params.join(", "))
}

/// The model's row of scenes/README.md's table: each parameter's default and range.
pub fn scenes_readme_row(m: &ModelInfo) -> String {
    let params: Vec<String> = m
        .params
        .iter()
        .map(|p| match p.kind {
            Kind::Choice(o, d) => {
                let o: Vec<String> = o
                    .iter()
                    .map(|o| match *o == d {
                        true => format!("`{o}` (default)"),
                        false => format!("`{o}`"),
                    })
                    .collect();
                format!("`{}` = {}", p.name, o.join(" \\| "))
            }
            _ => format!(
                "`{}` {} ({})",
                p.name,
                cell(&short_default(p)),
                cell(&range_text(p))
            ),
        })
        .collect();
    format!("| `{}` | {} |", m.name, params.join(", "))
}

/// `text` (a model's Rust file) with its parameter table (the first block of `//! |` lines)
/// replaced by [`model_file_table`]; `None` when the file has no such block.
pub fn update_model_file(text: &str, m: &ModelInfo) -> Option<String> {
    let lines: Vec<&str> = text.split_inclusive('\n').collect();
    let start = lines.iter().position(|l| l.starts_with("//! |"))?;
    let end = start
        + lines[start..]
            .iter()
            .take_while(|l| l.starts_with("//! |"))
            .count();
    let mut out: String = lines[..start].concat();
    out += &model_file_table(m);
    out += &lines[end..].concat();
    Some(out)
}

/// Whether `line` is the table row of the model `name` (it starts with `` | `name` | ``).
pub fn is_row_of(line: &str, name: &str) -> bool {
    line.strip_prefix("| `")
        .and_then(|rest| rest.strip_prefix(name))
        .is_some_and(|rest| rest.starts_with("` |"))
}

/// `text` with each model's row (the line that [`is_row_of`] the model) replaced by
/// `row(model)`, and the names of the models that had no row. A missing row is inserted after
/// the row of the model before it in `models` (registry order), so that a new model's row can be
/// written; one whose predecessor has no row either (or the first model's) is left out of the
/// text: the caller finds it by its absence.
pub fn update_rows(
    text: &str,
    models: &[ModelInfo],
    row: impl Fn(&ModelInfo) -> String,
) -> (String, Vec<&'static str>) {
    let mut missing = Vec::new();
    let mut lines: Vec<String> = text.split('\n').map(String::from).collect();
    // The line of the previous model's row, if it has one.
    let mut previous: Option<usize> = None;
    for m in models {
        previous = match lines.iter().position(|l| is_row_of(l, m.name)) {
            Some(at) => {
                lines[at] = row(m);
                Some(at)
            }
            None => {
                missing.push(m.name);
                previous.map(|at| {
                    lines.insert(at + 1, row(m));
                    at + 1
                })
            }
        };
    }
    (lines.join("\n"), missing)
}

#[cfg(test)]
mod tests {
    use super::super::MODELS;
    use super::*;

    #[test]
    fn tables_name_every_parameter_once() {
        for m in MODELS.iter() {
            let t = model_file_table(m);
            assert_eq!(t.lines().count(), 2 + m.params.len(), "{}", m.name);
            // A colour or number parameter has its texture's place in the record.
            for p in m.params {
                let has = t
                    .lines()
                    .any(|l| l.contains(&format!("`{}`", p.name)) && l.contains("`p["));
                assert_eq!(has, p.slot.is_some(), "{}.{}", m.name, p.name);
            }
            for p in m.params {
                assert!(
                    models_page_row(m).contains(&format!("`{}`", p.name)),
                    "{}",
                    p.name
                );
                assert!(scenes_readme_row(m).contains(&format!("`{}`", p.name)));
            }
        }
    }

    #[test]
    fn rows_are_replaced_and_missing_rows_named() {
        let text = "a\n| `lambert` | old |\nb";
        let (out, missing) = update_rows(text, &MODELS, models_page_row);
        // Lambert's row replaced, every other model's inserted after it in registry order.
        let rows: Vec<String> = MODELS.iter().map(models_page_row).collect();
        assert_eq!(out, format!("a\n{}\nb", rows.join("\n")));
        assert_eq!(missing.len(), MODELS.len() - 1);
        assert!(missing.contains(&"ward"));
        // Without the first model's row there is nothing to insert after.
        let (out, missing) = update_rows("a\nb", &MODELS[..2], models_page_row);
        assert_eq!((out.as_str(), missing.len()), ("a\nb", 2));
    }
}
