//! `render --set KEY=VALUE`: edits of the scene document before it is checked, so that an
//! override is type-checked exactly like the file and a wrong one is refused naming it.
//!
//! Syntax (one for every scene format): KEY is the dotted path of a field as the loader's
//! messages name it, e.g. `integrator.spp`, `materials.gold.roughness`,
//! `shapes[2].sphere.radius` (array indices 0-based, in file order; keys are bare TOML keys:
//! letters, digits, `_` and `-`). VALUE is a TOML value: `256`, `0.1`, `true`,
//! `[0.5, 0.5, 0.5]`, `"text"`; a word that is no TOML value is taken as a string
//! (`materials.gold.model=phong`). An existing field keeps its place and its comment; a new
//! one is added to its table (made when missing). Overrides apply in order, a later one over an
//! earlier one.
//!
//! The parsed [`Set`]s are format-independent; [`apply_toml`] edits a TOML document and
//! [`load_toml`] loads a scene file with them. Another format edits its own parsed document
//! with the same [`Set`]s (their [`Key`] path and their TOML [`Set::value`]) before its checks.

use crate::scene::{self, Scene, SceneError};
use std::path::Path;
use toml_edit::{DocumentMut, Item, Table, Value};

/// One part of a key path.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Key {
    Field(String),
    Index(usize),
}

/// One `--set KEY=VALUE`.
#[derive(Clone, Debug)]
pub struct Set {
    pub path: Vec<Key>,
    /// The key as written, dotted (`shapes[2].sphere.radius`).
    pub key: String,
    pub value: Value,
    /// The whole argument, for messages: `integrator.spp=256`.
    pub text: String,
}

impl Set {
    /// Parses `KEY=VALUE` (see the module documentation).
    pub fn parse(s: &str) -> Result<Set, String> {
        let (key, raw) = s
            .split_once('=')
            .ok_or_else(|| format!("'{s}' is not KEY=VALUE (e.g. integrator.spp=256)"))?;
        let key = key.trim();
        let path = parse_key(key).map_err(|e| format!("'{s}': {e}"))?;
        let raw = raw.trim();
        let value = match raw.parse::<Value>() {
            Ok(v) => v,
            Err(_) if is_word(raw) => Value::from(raw),
            Err(e) => {
                return Err(format!(
                    "'{s}': the value '{raw}' is not a TOML value ({}), nor a word taken as a \
                     string; quote a string with spaces: KEY='\"a b\"'",
                    e.to_string()
                        .lines()
                        .find(|l| !l.trim().is_empty())
                        .unwrap_or("")
                        .trim()
                ))
            }
        };
        Ok(Set {
            path,
            key: key.to_string(),
            value,
            text: format!("{key}={raw}"),
        })
    }

    /// Whether a loader error is about this override's field: its dotted path is the key or
    /// inside it, or (a material's parameter) it names the material and the field.
    fn is_about(&self, e: &SceneError) -> bool {
        match e {
            SceneError::Invalid { field: Some(f), .. } => {
                f == &self.key
                    || f.starts_with(&format!("{}.", self.key))
                    || f.starts_with(&format!("{}[", self.key))
            }
            SceneError::Material(p) => match self.path.as_slice() {
                [Key::Field(m), Key::Field(name), Key::Field(field), ..] if m == "materials" => {
                    p.0.contains(&format!("material '{name}', field '{field}'"))
                }
                [Key::Field(m), Key::Field(name)] if m == "materials" => {
                    p.0.contains(&format!("material '{name}'"))
                }
                _ => false,
            },
            _ => false,
        }
    }
}

fn is_word(s: &str) -> bool {
    !s.is_empty()
        && s.chars()
            .all(|c| c.is_alphanumeric() || matches!(c, '_' | '-' | '.' | '/'))
}

fn parse_key(key: &str) -> Result<Vec<Key>, String> {
    let mut path = Vec::new();
    for segment in key.split('.') {
        let (name, mut rest) = segment.split_at(segment.find('[').unwrap_or(segment.len()));
        let bare = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
        if name.is_empty() || !name.chars().all(bare) {
            return Err(format!(
                "the key '{key}' has an empty or non-bare part '{name}' (a bare key is letters, \
                 digits, _ and -)"
            ));
        }
        path.push(Key::Field(name.to_string()));
        while !rest.is_empty() {
            let close = rest
                .find(']')
                .filter(|_| rest.starts_with('['))
                .ok_or_else(|| format!("the key '{key}' has a malformed index in '{segment}'"))?;
            let i = rest[1..close].parse::<usize>().map_err(|_| {
                format!("the index '{}' in '{key}' is not a number", &rest[1..close])
            })?;
            path.push(Key::Index(i));
            rest = &rest[close + 1..];
        }
    }
    Ok(path)
}

/// Applies `sets` to a parsed TOML document, in order. Errors name the override and the part of
/// its key that does not fit the document (a field of a number, an index past the end).
pub fn apply_toml(doc: &mut DocumentMut, sets: &[Set]) -> Result<(), String> {
    for s in sets {
        set_in_table(doc.as_table_mut(), &s.path, &s.value, "")
            .map_err(|e| format!("--set {}: {e}", s.text))?;
    }
    Ok(())
}

fn describe(prefix: &str) -> String {
    if prefix.is_empty() {
        "the document".into()
    } else {
        format!("'{prefix}'")
    }
}

fn joined(prefix: &str, k: &Key) -> String {
    match k {
        Key::Field(f) if prefix.is_empty() => f.clone(),
        Key::Field(f) => format!("{prefix}.{f}"),
        Key::Index(i) => format!("{prefix}[{i}]"),
    }
}

/// `new` in place of `old`, keeping the old value's spacing and comment.
fn replace(old: &mut Value, new: &Value) {
    let decor = old.decor().clone();
    *old = new.clone();
    *old.decor_mut() = decor;
}

fn set_in_table(t: &mut Table, path: &[Key], v: &Value, prefix: &str) -> Result<(), String> {
    let Key::Field(f) = &path[0] else {
        return Err(format!("{} is a table, not an array", describe(prefix)));
    };
    let here = joined(prefix, &path[0]);
    if path.len() == 1 {
        match t.get_mut(f) {
            Some(Item::Value(old)) => replace(old, v),
            _ => {
                t.insert(f, Item::Value(v.clone()));
            }
        }
        return Ok(());
    }
    if t.get(f).is_none() {
        let mut new = Table::new();
        new.set_implicit(true);
        t.insert(f, Item::Table(new));
    }
    set_in_item(t.get_mut(f).expect("inserted"), &path[1..], v, &here)
}

fn set_in_item(item: &mut Item, path: &[Key], v: &Value, prefix: &str) -> Result<(), String> {
    match (item, &path[0]) {
        (Item::Table(t), _) => set_in_table(t, path, v, prefix),
        (Item::ArrayOfTables(a), Key::Index(i)) => {
            let n = a.len();
            let t = a
                .get_mut(*i)
                .ok_or_else(|| format!("index {i} is past the end: '{prefix}' has {n} entries"))?;
            if path.len() == 1 {
                return Err(format!("'{prefix}[{i}]' is a table: set one of its fields"));
            }
            set_in_table(t, &path[1..], v, &joined(prefix, &path[0]))
        }
        (Item::Value(value), _) => set_in_value(value, path, v, prefix),
        (other, _) => Err(format!(
            "'{prefix}' is {}, which has no '{}'",
            other.type_name(),
            joined("", &path[0])
        )),
    }
}

fn set_in_value(value: &mut Value, path: &[Key], v: &Value, prefix: &str) -> Result<(), String> {
    let here = joined(prefix, &path[0]);
    let slot = match (value, &path[0]) {
        (Value::InlineTable(t), Key::Field(f)) => {
            if path.len() == 1 && t.get(f).is_none() {
                t.insert(f, v.clone());
                // The spacing of the entries, made even after the one added.
                t.fmt();
                return Ok(());
            }
            t.get_mut(f)
                .ok_or_else(|| format!("'{prefix}' has no field '{f}' to set inside"))?
        }
        (Value::Array(a), Key::Index(i)) => {
            let n = a.len();
            a.get_mut(*i)
                .ok_or_else(|| format!("index {i} is past the end: '{prefix}' has {n} entries"))?
        }
        (other, k) => {
            return Err(format!(
                "'{prefix}' is {}, which has no {}",
                other.type_name(),
                match k {
                    Key::Field(f) => format!("field '{f}'"),
                    Key::Index(i) => format!("index {i}"),
                }
            ))
        }
    };
    if path.len() == 1 {
        replace(slot, v);
        Ok(())
    } else {
        set_in_value(slot, &path[1..], v, &here)
    }
}

/// Loads the TOML scene file at `path` with `sets` applied to its document before the checks;
/// returns the scene and the file's bytes. An error about an overridden field is prefixed with
/// the override (`--set materials.gold.roughnes=0.1: box.toml:12: material 'gold', field
/// 'roughnes': unknown field …`); another error is the file's own, with its lines, when the
/// file alone has it too, or else prefixed with the last override that makes an error alone
/// (a value of the wrong type: `--set shapes[0].transform.translate=x: …`).
pub fn load_toml(path: &Path, sets: &[Set]) -> anyhow::Result<(Scene, Vec<u8>)> {
    let source = crate::infile::read_text(path, crate::infile::SCENE).map_err(|source| {
        SceneError::Read {
            file: crate::errors::shown_path(path),
            source,
        }
    })?;
    let bytes = source.clone().into_bytes();
    if sets.is_empty() {
        return Ok((scene::load_str(&source, path)?, bytes));
    }
    let mut doc: DocumentMut = match source.parse() {
        Ok(d) => d,
        // The loader's message for the file's own syntax error.
        Err(_) => {
            return Err(scene::load_str(&source, path).err().map_or_else(
                || anyhow::anyhow!("{}: not a TOML document", path.display()),
                Into::into,
            ))
        }
    };
    let doc_of = |src: &str| -> DocumentMut { src.parse().expect("parsed once already") };
    apply_toml(&mut doc, sets).map_err(anyhow::Error::msg)?;
    let edited = doc.to_string();
    match scene::load_str(&edited, path) {
        Ok(sc) => Ok((sc, bytes)),
        Err(e) => {
            if let Some(s) = sets.iter().rev().find(|s| s.is_about(&e)) {
                return Err(anyhow::anyhow!("--set {}: {e}", s.text));
            }
            if let Err(own) = scene::load_str(&source, path) {
                return Err(own.into());
            }
            // An error that names no overridden field (a value of the wrong type, a key the
            // schema lacks): the last override that makes an error on its own is named.
            for s in sets.iter().rev() {
                let mut alone = doc_of(&source);
                if apply_toml(&mut alone, std::slice::from_ref(s)).is_ok() {
                    if let Err(e) = scene::load_str(&alone.to_string(), path) {
                        return Err(anyhow::anyhow!("--set {}: {e}", s.text));
                    }
                }
            }
            Err(anyhow::anyhow!("with the --set overrides: {e}"))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn edit(src: &str, sets: &[&str]) -> Result<String, String> {
        let sets: Vec<Set> = sets
            .iter()
            .map(|s| Set::parse(s))
            .collect::<Result<_, _>>()?;
        let mut doc: DocumentMut = src.parse().unwrap();
        apply_toml(&mut doc, &sets)?;
        Ok(doc.to_string())
    }

    #[test]
    fn keys_and_values_parse_or_are_refused_with_the_reason() {
        let s = Set::parse("shapes[2].sphere.radius = 1.5").unwrap();
        assert_eq!(
            s.path,
            vec![
                Key::Field("shapes".into()),
                Key::Index(2),
                Key::Field("sphere".into()),
                Key::Field("radius".into())
            ]
        );
        assert_eq!(s.text, "shapes[2].sphere.radius=1.5");
        assert_eq!(
            Set::parse("a.model=phong").unwrap().value.as_str(),
            Some("phong")
        );
        assert_eq!(
            Set::parse("a.b=\"x y\"").unwrap().value.as_str(),
            Some("x y")
        );
        assert!(Set::parse("a.c=[1, 2, 3]").unwrap().value.is_array());
        for (bad, needle) in [
            ("spp", "not KEY=VALUE"),
            ("a..b=1", "empty or non-bare"),
            ("a[x]=1", "not a number"),
            ("a[1=1", "malformed index"),
            ("a=[1,", "not a TOML value"),
        ] {
            let e = Set::parse(bad).unwrap_err();
            assert!(e.contains(needle), "{bad}: {e}");
        }
    }

    #[test]
    fn edits_keep_the_layout_and_add_what_is_missing() {
        let src = "# head\n[integrator]\nspp = 16 # samples\n\n[[shapes]]\nr = [1, 2]\n\n[[shapes]]\nx = { a = 1 }\n";
        let out = edit(
            src,
            &[
                "integrator.spp=256",
                "integrator.seed=3",
                "shapes[0].r[1]=5",
                "shapes[1].x.a=2",
                "shapes[1].x.b=true",
                "camera.fov_y=40",
            ],
        )
        .unwrap();
        assert!(
            out.starts_with("# head\n[integrator]\nspp = 256 # samples\nseed = 3\n"),
            "{out}"
        );
        assert!(
            out.contains("r = [1, 5]") && out.contains("x = { a = 2, b = true }"),
            "{out}"
        );
        assert!(out.contains("[camera]\nfov_y = 40"), "{out}");
        // Later overrides win.
        assert!(edit(src, &["integrator.spp=1", "integrator.spp=2"])
            .unwrap()
            .contains("spp = 2 "));
        for (set, needle) in [
            (
                "shapes[5].r=1",
                "index 5 is past the end: 'shapes' has 2 entries",
            ),
            (
                "integrator.spp.x=1",
                "'integrator.spp' is integer, which has no field 'x'",
            ),
            ("shapes[0]=1", "is a table: set one of its fields"),
            ("shapes[0].r[9]=1", "index 9 is past the end"),
        ] {
            let e = edit(src, &[set]).unwrap_err();
            assert!(
                e.starts_with(&format!("--set {set}: ")) && e.contains(needle),
                "{e}"
            );
        }
    }
}
