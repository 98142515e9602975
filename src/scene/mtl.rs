//! MTL materials of an OBJ shape with `mtl = true` (`scenes/README.md`): each material of the
//! library that a face uses becomes a scene material, by its `illum` model:
//!
//! * `illum 0`, `1` (colour, no highlight): `lambert` with `albedo = Kd`;
//! * `illum 2` or none (the highlight model): `blinn_phong` in its energy-normalised form
//!   (`form = "normalized"`) with `kd = Kd`, `ks = Ks`, `exponent = Ns`;
//! * `illum 3` to `10` (ray-traced reflection, refraction, glass): as 2, with a warning that
//!   the rest is ignored.
//!
//! `Ke` (non-zero) makes the material's faces emitters of radiance `Ke`. `Ka`, textures,
//! `d`/`Tr` (transparency) and `Ni` are not used (a warning names those given). The values are
//! checked by the models, so that a `Kd` above 1 is an error naming the material
//! (`OBJ:NAME`), at the scene's `obj` line.

use super::error::SceneError;
use super::spanned::Cx;
use super::Emitter;
use crate::brdf::{self, Origin};
use glam::Vec3;
use std::collections::BTreeMap;
use std::ops::Range;

/// Where the MTL materials of OBJ shapes go: materials appended after the scene's `base`
/// ones, emitters after the scene's.
pub(super) struct MtlOut<'a> {
    pub(super) materials: &'a mut Vec<(String, brdf::Material)>,
    pub(super) emitters: &'a mut Vec<Emitter>,
    /// The number of the scene's own materials.
    pub(super) base: u32,
}

/// The scene material (index) and emitter of an MTL material.
pub(super) fn mtl_material(
    cx: &mut Cx,
    span: Option<Range<usize>>,
    field: &str,
    obj: &str,
    m: &tobj::Material,
    out: &mut MtlOut,
) -> Result<(u32, Option<u32>), SceneError> {
    let name = format!("{obj}:{}", m.name);
    let s = span.clone().unwrap_or(0..0);
    let value = |v: toml::Value| toml::Spanned::new(s.clone(), v);
    let rgb = |c: [f32; 3]| {
        value(toml::Value::Array(
            c.iter().map(|&x| toml::Value::Float(x as f64)).collect(),
        ))
    };
    let kd = m.diffuse.unwrap_or([0.8; 3]);
    let illum = m.illumination_model.unwrap_or(2);
    let mut fields = BTreeMap::new();
    if illum <= 1 {
        fields.insert("model".into(), value(toml::Value::String("lambert".into())));
        fields.insert("albedo".into(), rgb(kd));
    } else {
        fields.insert(
            "model".into(),
            value(toml::Value::String("blinn_phong".into())),
        );
        fields.insert(
            "form".into(),
            value(toml::Value::String("normalized".into())),
        );
        fields.insert("kd".into(), rgb(kd));
        fields.insert("ks".into(), rgb(m.specular.unwrap_or([0.0; 3])));
        let ns = m.shininess.unwrap_or(0.0);
        fields.insert("exponent".into(), value(toml::Value::Float(ns as f64)));
    }
    let mut ignored: Vec<&str> = Vec::new();
    if illum > 2 {
        ignored.push("the reflection and refraction of illum > 2");
    }
    if m.ambient.is_some_and(|a| a != [0.0; 3]) {
        ignored.push("Ka");
    }
    if m.dissolve.is_some_and(|d| d < 1.0) {
        ignored.push("d/Tr (transparency)");
    }
    let textures = [
        &m.ambient_texture,
        &m.diffuse_texture,
        &m.specular_texture,
        &m.normal_texture,
        &m.shininess_texture,
        &m.dissolve_texture,
    ];
    if textures.iter().any(|t| t.is_some()) {
        ignored.push("texture maps");
    }
    if !ignored.is_empty() {
        let msg = format!("material '{name}': ignored: {}", ignored.join(", "));
        cx.warn(span.clone(), field, msg);
    }
    let origin = Origin {
        file: &cx.file,
        source: cx.source,
        material: &name,
        span: s.clone(),
        dir: Some(&cx.dir),
    };
    let (material, warnings) = brdf::parse_material(origin, fields)?;
    cx.warnings.extend(warnings);
    let index = out.base + out.materials.len() as u32;
    out.materials.push((name.clone(), material));

    let ke = Vec3::from_array(m.emissive.unwrap_or([0.0; 3]));
    let emitter = if ke == Vec3::ZERO {
        None
    } else {
        if !(ke.is_finite() && ke.min_element() >= 0.0) {
            let msg = format!("material '{name}': Ke {ke} must be finite and >= 0");
            return Err(cx.err(span, field, msg));
        }
        out.emitters.push(Emitter { radiance: ke });
        Some(out.emitters.len() as u32 - 1)
    };
    Ok((index, emitter))
}
