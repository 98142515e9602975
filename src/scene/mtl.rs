//! MTL materials of an OBJ shape with `mtl = true` (`scenes/README.md`): each material of the
//! library that a face uses becomes a scene material, by its `illum` model:
//!
//! * `illum 0`, `1` (colour, no highlight): `lambert` with `albedo = Kd`;
//! * `illum 2` or none (the highlight model): `blinn_phong` in its energy-normalised form
//!   (`form = "normalized"`) with `kd = Kd`, `ks = Ks`, `exponent = Ns`;
//! * `illum 3` to `10` (ray-traced reflection, refraction, glass): as 2, with a warning that
//!   the rest is ignored.
//!
//! `Ke` (non-zero) makes the material's faces emitters of radiance `Ke`. `Ka`, texture maps
//! (`map_*`, `bump`, `norm`, `disp`, `decal`, `refl`), `d`/`Tr` (transparency), the physically
//! based statements (`Pr`, `Pm`, …) and `Ni` are not used: a warning names those that would
//! change the picture (a non-zero `Ka`, `d` < 1 or `Tr` > 0, any map or physically based
//! statement; not `Ni`, which matters only to refraction, itself warned about). The values are
//! checked by the models, so that a `Kd` above 1 is an error naming the material
//! (`OBJ:NAME`), the MTL file and the line of its `Kd`.
//!
//! A library is read bounded ([`crate::infile::MTL`]) and checked line by line before tobj
//! reads it ([`scan_mtl`]): tobj reports no line numbers (`material parse error`), panics on a
//! colour of one number, and reads `1e39` as inf. A file without any `newmtl` is not an MTL
//! library (`mtllib /etc/passwd`) and is refused; an unknown statement is warned about.

use super::error::SceneError;
use super::spanned::Cx;
use super::Emitter;
use crate::brdf::{self, Origin};
use glam::Vec3;
use std::collections::BTreeMap;
use std::ops::Range;

/// An MTL library as read: the file as messages show it, its text, and where each of its
/// materials is written.
pub(super) struct MtlLibrary {
    pub(super) file: String,
    pub(super) text: String,
    pub(super) materials: Vec<MtlLines>,
    /// Lines of statements no MTL reader knows, with their keyword.
    pub(super) unknown: Vec<(usize, String)>,
}

impl MtlLibrary {
    /// Where the material `name` is written (its last definition, as tobj's lookup keeps).
    pub(super) fn lines_of(&self, name: &str) -> Option<&MtlLines> {
        self.materials.iter().rev().find(|m| m.name == name)
    }
}

/// Where one material of an MTL library is written: the byte range of its `newmtl` line and of
/// the line of each statement (by keyword).
pub(super) struct MtlLines {
    pub(super) name: String,
    pub(super) newmtl: Range<usize>,
    pub(super) keys: BTreeMap<String, Range<usize>>,
}

/// Colour statements: three numbers (tobj reads the first three, and panics on fewer).
const COLOURS: &[&str] = &["Ka", "Kd", "Ks", "Ke", "Tf"];
/// Statements of one number.
const SCALARS: &[&str] = &["Ns", "Ni", "d", "Tr", "sharpness"];
/// Texture maps besides `map_*`, not read.
const TEXTURE_MAPS: &[&str] = &["bump", "disp", "decal", "refl", "norm"];
/// The physically based extension's statements (roughness, metallic, sheen, clearcoat,
/// anisotropy), not read.
const PBR: &[&str] = &["Pr", "Pm", "Ps", "Pc", "Pcr", "aniso", "anisor"];

/// Checks an MTL library line by line and finds where each material is written; an error is
/// (line, what is wrong). The numbers tobj reads are checked ([`crate::numbers::parse_f32`]:
/// finite and within single precision, named as written), a colour has three, `illum` is a
/// whole number from 0 to 10, and the file must define a material.
pub(super) fn scan_mtl(text: &str) -> Result<MtlLibrary, (usize, String)> {
    let mut materials: Vec<MtlLines> = Vec::new();
    let mut unknown = Vec::new();
    let mut first_statement = None;
    let mut at = 0;
    for (l, raw) in text.split_inclusive('\n').enumerate() {
        let range = at..at + raw.len();
        at += raw.len();
        let line = raw.trim();
        let mut words = line.split_whitespace();
        let Some(kw) = words.next() else { continue };
        if kw.starts_with('#') {
            continue;
        }
        let n = l + 1;
        first_statement.get_or_insert((n, line));
        let nums: Vec<&str> = words.collect();
        let number = |t: &str| crate::numbers::parse_f32(t).map_err(|m| (n, format!("{kw}: {m}")));
        if kw == "newmtl" {
            let name = line[6..].trim();
            if name.is_empty() {
                return Err((n, "newmtl needs a material name".into()));
            }
            materials.push(MtlLines {
                name: name.to_string(),
                newmtl: range.clone(),
                keys: BTreeMap::new(),
            });
            continue;
        } else if COLOURS.contains(&kw) {
            if nums
                .first()
                .is_some_and(|w| ["spectral", "xyz"].contains(w))
            {
                let msg = format!(
                    "{kw} {}: only RGB colours are read (three numbers)",
                    nums[0]
                );
                return Err((n, msg));
            }
            if nums.len() != 3 {
                let msg = format!("{kw} needs 3 numbers (r g b), found {}", nums.len());
                return Err((n, msg));
            }
            for t in &nums {
                number(t)?;
            }
        } else if SCALARS.contains(&kw) {
            if nums.len() != 1 {
                return Err((n, format!("{kw} needs 1 number, found {}", nums.len())));
            }
            number(nums[0])?;
        } else if kw == "illum" {
            if !(nums.len() == 1 && nums[0].parse::<u8>().is_ok_and(|i| i <= 10)) {
                let msg = format!(
                    "illum needs a whole number from 0 to 10, found '{}'",
                    crate::errors::excerpt(&nums.join(" "))
                );
                return Err((n, msg));
            }
        } else if !(kw.starts_with("map_") || TEXTURE_MAPS.contains(&kw) || PBR.contains(&kw)) {
            unknown.push((n, crate::errors::excerpt(kw)));
            continue;
        }
        if let Some(m) = materials.last_mut() {
            m.keys.insert(kw.to_string(), range);
        }
    }
    if materials.is_empty() {
        let what = match first_statement {
            Some((n, line)) => format!(", and line {n} reads '{}'", crate::errors::excerpt(line)),
            None => String::new(),
        };
        let line = first_statement.map_or(1, |(n, _)| n);
        return Err((
            line,
            format!("no material (newmtl): this is not an MTL library{what}"),
        ));
    }
    Ok(MtlLibrary {
        file: String::new(),
        text: String::new(),
        materials,
        unknown,
    })
}

/// A material's parameters as TOML values, `model` included.
pub(super) type Params = BTreeMap<String, toml::Value>;

/// Where the MTL materials of OBJ shapes go: materials appended after the scene's `base`
/// ones, emitters after the scene's.
pub(super) struct MtlOut<'a> {
    /// Each with its parameters as TOML values (`Scene::material_params`).
    pub(super) materials: &'a mut Vec<(String, brdf::Material, Params)>,
    pub(super) emitters: &'a mut Vec<Emitter>,
    /// The number of the scene's own materials.
    pub(super) base: u32,
}

/// The scene material (index) and emitter of an MTL material of the library `lib`. Its
/// errors name the MTL file and the line of the statement (its warnings the scene's line).
pub(super) fn mtl_material(
    cx: &mut Cx,
    span: Option<Range<usize>>,
    field: &str,
    obj: &str,
    (m, lib): (&tobj::Material, &MtlLibrary),
    out: &mut MtlOut,
) -> Result<(u32, Option<u32>), SceneError> {
    let name = format!("{obj}:{}", m.name);
    let lines = lib.lines_of(&m.name);
    let s = lines.map_or(0..0, |l| l.newmtl.clone());
    // The line of statement `kw` (else the `newmtl` line).
    let at = |kw: &str| {
        lines
            .and_then(|l| l.keys.get(kw))
            .cloned()
            .unwrap_or(s.clone())
    };
    let value = |v: toml::Value| toml::Spanned::new(s.clone(), v);
    let rgb = |c: [f32; 3], kw: &str| {
        toml::Spanned::new(
            at(kw),
            toml::Value::Array(c.iter().map(|&x| toml::Value::Float(x as f64)).collect()),
        )
    };
    let kd = m.diffuse.unwrap_or([0.8; 3]);
    let illum = m.illumination_model.unwrap_or(2);
    let mut fields: BTreeMap<String, toml::Spanned<toml::Value>> = BTreeMap::new();
    if illum <= 1 {
        fields.insert("model".into(), value(toml::Value::String("lambert".into())));
        fields.insert("albedo".into(), rgb(kd, "Kd"));
    } else {
        fields.insert(
            "model".into(),
            value(toml::Value::String("blinn_phong".into())),
        );
        fields.insert(
            "form".into(),
            value(toml::Value::String("normalized".into())),
        );
        fields.insert("kd".into(), rgb(kd, "Kd"));
        fields.insert("ks".into(), rgb(m.specular.unwrap_or([0.0; 3]), "Ks"));
        let ns = m.shininess.unwrap_or(0.0);
        fields.insert(
            "exponent".into(),
            toml::Spanned::new(at("Ns"), toml::Value::Float(ns as f64)),
        );
    }
    // What the material states and this reader does not use, from the library's own lines (tobj
    // keeps only some statements in its fields).
    let stated: Vec<&str> =
        lines.map_or(Vec::new(), |l| l.keys.keys().map(String::as_str).collect());
    let named = |pick: &dyn Fn(&str) -> bool| -> Option<String> {
        let found: Vec<&str> = stated.iter().copied().filter(|k| pick(k)).collect();
        (!found.is_empty()).then(|| found.join(", "))
    };
    let mut ignored: Vec<String> = Vec::new();
    if illum > 2 {
        ignored.push("the reflection and refraction of illum > 2".into());
    }
    if m.ambient.is_some_and(|a| a != [0.0; 3]) {
        ignored.push("Ka".into());
    }
    let tr = m
        .unknown_param
        .get("Tr")
        .and_then(|t| t.trim().parse::<f32>().ok());
    if m.dissolve.is_some_and(|d| d < 1.0) || tr.is_some_and(|t| t > 0.0) {
        ignored.push("d/Tr (transparency)".into());
    }
    if let Some(maps) = named(&|k| k.starts_with("map_") || TEXTURE_MAPS.contains(&k)) {
        ignored.push(format!("texture maps ({maps})"));
    }
    if let Some(pbr) = named(&|k| PBR.contains(&k)) {
        ignored.push(format!("physically based statements ({pbr})"));
    }
    if !ignored.is_empty() {
        let msg = format!("material '{name}': ignored: {}", ignored.join(", "));
        cx.warn(span.clone(), field, msg);
    }
    let origin = Origin {
        file: &lib.file,
        source: &lib.text,
        material: &name,
        span: s.clone(),
        dir: Some(&cx.dir),
    };
    let params: Params = fields
        .iter()
        .map(|(k, v)| (k.clone(), v.get_ref().clone()))
        .collect();
    let (material, warnings) = brdf::parse_material(origin, fields)?;
    cx.warnings.extend(warnings);
    let index = out.base + out.materials.len() as u32;
    out.materials.push((name.clone(), material, params));

    let ke = Vec3::from_array(m.emissive.unwrap_or([0.0; 3]));
    let emitter = if ke == Vec3::ZERO {
        None
    } else {
        if ke.min_element() < 0.0 {
            // Finite: scan_mtl checked the numbers.
            let line = crate::brdf::params::line_of(&lib.text, at("Ke").start);
            return Err(cx.err(
                span,
                field,
                format!(
                    "MTL file '{}', line {line}: material '{name}': Ke {} must be >= 0",
                    lib.file,
                    super::assemble::fmt_vec(ke)
                ),
            ));
        }
        out.emitters.push(Emitter { radiance: ke });
        Some(out.emitters.len() as u32 - 1)
    };
    Ok((index, emitter))
}
