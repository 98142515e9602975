//! A material's texture tables (`kd = { texture = "wood.png", raw, filter, wrap, to_uv }`,
//! `scenes/README.md`) checked and read into [`Texture`]s: the image through
//! [`super::images`] (every failure names the field and the file), its values as the parameter
//! reads them (`crate::texture`), clamped into the parameter's range with one warning per
//! texture. The model's parser then checks the material with each textured parameter set to its
//! texture's largest value (so that `scatters` and the model's warnings see it), and the
//! textures are bound to the parameters ([`bind`]).

use super::error::SceneError;
use super::spanned::{Cx, Sp};
use crate::brdf::params::Param;
use crate::brdf::{Kind, Material, MODELS};
use crate::texture::{Filter, ParamTexture, Texture, Wrap, IDENTITY_UV};
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;
use toml::Value;

/// Images already read, by path (a file named by several parameters is read once), and the
/// textures made, by everything that makes them differ.
#[derive(Default)]
pub(super) struct TextureCache {
    images: HashMap<std::path::PathBuf, Arc<crate::imageio::Stored>>,
    textures: HashMap<String, Arc<Texture>>,
}

/// The textured parameters of material `name` (its raw fields `table`, whose texture tables
/// are replaced by the constant the parser checks), with their textures.
pub(super) fn texture_fields(
    cx: &mut Cx,
    name: &str,
    table: &mut BTreeMap<String, Sp<Value>>,
    cache: &mut TextureCache,
) -> Result<Vec<(&'static Param, Arc<Texture>)>, SceneError> {
    if !table.values().any(|v| matches!(v.value, Value::Table(_))) {
        return Ok(Vec::new());
    }
    let model = table
        .get("model")
        .and_then(|m| m.value.as_str())
        .and_then(|m| MODELS.iter().find(|x| x.name == m));
    let mut out = Vec::new();
    for (key, v) in table.iter_mut() {
        let Value::Table(spec) = &v.value else {
            continue;
        };
        let field = format!("materials.{name}.{key}");
        let span = v.span();
        // An unknown model or parameter is the parser's to report.
        let Some(model) = model else { continue };
        let Some(param) = model.params.iter().find(|p| p.name == key) else {
            continue;
        };
        if !matches!(param.kind, Kind::Rgb(_) | Kind::Scalar(_)) || param.slot.is_none() {
            let msg = format!(
                "material '{name}': '{key}' cannot be a texture (only colour and number parameters can)"
            );
            return Err(cx.err(span, &field, msg));
        }
        let tex = texture(cx, &field, span.clone(), spec, param, cache)?;
        // The parser checks the material at the texture's largest value.
        let top = tex.texels.iter().fold([f32::NEG_INFINITY; 3], |m, t| {
            [0, 1, 2].map(|c| m[c].max(t[c]))
        });
        v.value = match param.kind {
            Kind::Rgb(_) => Value::Array(top.iter().map(|x| Value::Float(*x as f64)).collect()),
            _ => Value::Float(top[0] as f64),
        };
        out.push((param, tex));
    }
    // A parameter whose default is another's (Ward's `alpha_y` = `alpha_x`) follows that one's
    // texture when it is not given.
    if let Some(model) = model {
        let mut follow = Vec::new();
        for p in model.params {
            let Some(text) = p.default_text else { continue };
            for (q, t) in &out {
                if text == format!("= `{}`", q.name) && !table.contains_key(p.name) {
                    follow.push((p, t.clone()));
                }
            }
        }
        out.extend(follow);
    }
    Ok(out)
}

/// The textures bound to the parsed material `m`, each with the slot of its value in the
/// material's GPU record.
pub(super) fn bind(m: &mut Material, textures: Vec<(&'static Param, Arc<Texture>)>) {
    m.textures = textures
        .into_iter()
        .map(|(param, texture)| ParamTexture {
            param,
            slot: m.brdf.record_slot(param),
            texture,
        })
        .collect();
}

/// One texture table, checked, its image read and made into the parameter's values.
fn texture(
    cx: &mut Cx,
    field: &str,
    span: Option<std::ops::Range<usize>>,
    spec: &toml::map::Map<String, Value>,
    param: &Param,
    cache: &mut TextureCache,
) -> Result<Arc<Texture>, SceneError> {
    let err = |cx: &Cx, msg: String| cx.err(span.clone(), field, msg);
    let known = crate::texture::TABLE_FIELDS;
    if let Some(k) = spec.keys().find(|k| !known.iter().any(|f| f.name == *k)) {
        let names: Vec<&str> = known.iter().map(|f| f.name).collect();
        return Err(err(
            cx,
            format!(
                "unknown field '{k}' in a texture (it takes: {})",
                names.join(", ")
            ),
        ));
    }
    let file = match spec.get("texture") {
        Some(Value::String(s)) if !s.is_empty() => s.clone(),
        Some(other) => {
            return Err(err(
                cx,
                format!("'texture' is the image file's path, found {other}"),
            ))
        }
        None => {
            return Err(err(
                cx,
                "a table here is a texture: it needs texture = \"FILE\"".into(),
            ))
        }
    };
    let colour = matches!(param.kind, Kind::Rgb(_));
    // By default a colour decodes an sRGB image and a number takes the values as stored.
    let raw = match spec.get("raw") {
        None => !colour,
        Some(Value::Boolean(b)) => *b,
        Some(other) => return Err(err(cx, format!("'raw' is true or false, found {other}"))),
    };
    let choice = |key: &str, names: &[&str]| -> Result<Option<String>, String> {
        match spec.get(key) {
            None => Ok(None),
            Some(Value::String(s)) if names.contains(&s.as_str()) => Ok(Some(s.clone())),
            Some(other) => Err(format!(
                "'{key}' is one of {}, found {other}",
                names.join(", ")
            )),
        }
    };
    let filter = choice("filter", &Filter::NAMES)
        .map_err(|m| err(cx, m))?
        .and_then(|s| Filter::parse(&s))
        .unwrap_or(Filter::Bilinear);
    let wrap = choice("wrap", &Wrap::NAMES)
        .map_err(|m| err(cx, m))?
        .and_then(|s| Wrap::parse(&s))
        .unwrap_or(Wrap::Repeat);
    let to_uv = match spec.get("to_uv") {
        None => IDENTITY_UV,
        Some(t) => to_uv(t).map_err(|m| err(cx, format!("to_uv: {m}")))?,
    };
    let path = super::geometry::mesh_path(cx, &file);
    let stored = match cache.images.get(&path) {
        Some(s) => s.clone(),
        None => {
            let s = Arc::new(super::images::read(cx, span.clone(), field, &path)?);
            cache.images.insert(path.clone(), s.clone());
            s
        }
    };
    let (lo, hi) = param.texture_range();
    let key = format!(
        "{}|{raw}|{colour}|{lo:?}|{hi:?}|{filter:?}|{wrap:?}|{to_uv:?}",
        path.display()
    );
    if let Some(t) = cache.textures.get(&key) {
        return Ok(t.clone());
    }
    let img = &stored.image;
    let (t, clamped) = Texture::for_param(
        path.clone(),
        raw,
        (img.width, img.height, &img.data),
        stored.srgb,
        param,
        filter,
        wrap,
        to_uv,
    );
    if clamped.texels > 0 {
        let range = crate::brdf::params::fmt_num(lo);
        let nan = match clamped.nan {
            0 => String::new(),
            n => format!(" ({n} of them NaN, set to {range})"),
        };
        let msg = format!(
            "{} of the {}x{} texels of '{}' {} outside [{range}, {}], the range of '{}', and {} clamped{nan}",
            clamped.texels,
            img.width,
            img.height,
            path.display(),
            if clamped.texels == 1 { "is" } else { "are" },
            crate::brdf::params::fmt_num(hi),
            param.name,
            if clamped.texels == 1 { "was" } else { "were" },
        );
        cx.warn(span, field, msg);
    }
    let t = Arc::new(t);
    cache.textures.insert(key, t.clone());
    Ok(t)
}

/// A `to_uv` table: `{ scale = s or [su, sv], translate = [tu, tv] }` (scale first), or
/// `{ matrix = [[a, b, c], [d, e, f]] }`, each number finite.
fn to_uv(v: &Value) -> Result<[[f32; 3]; 2], String> {
    let Value::Table(t) = v else {
        return Err(format!(
            "expected a table (scale, translate or matrix), found {v}"
        ));
    };
    let num = |v: &Value| -> Result<f32, String> {
        let x = match v {
            Value::Float(f) => *f,
            Value::Integer(i) => *i as f64,
            other => return Err(format!("expected a number, found {other}")),
        };
        if !x.is_finite() || x.abs() > f32::MAX as f64 {
            return Err(format!("{x} is not a finite single-precision number"));
        }
        Ok(x as f32)
    };
    let nums = |v: &Value, n: usize| -> Result<Vec<f32>, String> {
        match v {
            Value::Array(a) if a.len() == n => a.iter().map(num).collect(),
            other => Err(format!("expected an array of {n} numbers, found {other}")),
        }
    };
    if let Some(k) = t
        .keys()
        .find(|k| !["scale", "translate", "matrix"].contains(&k.as_str()))
    {
        return Err(format!(
            "unknown field '{k}' (it takes scale, translate, or matrix)"
        ));
    }
    if let Some(m) = t.get("matrix") {
        if t.len() > 1 {
            return Err("matrix stands alone (no scale or translate beside it)".into());
        }
        let Value::Array(rows) = m else {
            return Err(format!("matrix is [[a, b, c], [d, e, f]], found {m}"));
        };
        if rows.len() != 2 {
            return Err(format!(
                "matrix has 2 rows of 3 numbers, found {} rows",
                rows.len()
            ));
        }
        let (r0, r1) = (nums(&rows[0], 3)?, nums(&rows[1], 3)?);
        return Ok([[r0[0], r0[1], r0[2]], [r1[0], r1[1], r1[2]]]);
    }
    let (su, sv) = match t.get("scale") {
        None => (1.0, 1.0),
        Some(Value::Array(_)) => {
            let s = nums(&t["scale"], 2)?;
            (s[0], s[1])
        }
        Some(s) => {
            let s = num(s)?;
            (s, s)
        }
    };
    let (tu, tv) = match t.get("translate") {
        None => (0.0, 0.0),
        Some(v) => {
            let s = nums(v, 2)?;
            (s[0], s[1])
        }
    };
    Ok([[su, 0.0, tu], [0.0, sv, tv]])
}
