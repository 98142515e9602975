//! `<shape>` → a raw shape: its geometry (`obj`; `rectangle`, `cube` and `disk` as quads or
//! triangles in their local frame; `sphere` analytic), its `to_world` as the shape's matrix
//! transform, its BSDF (inline, `<ref>`, or Mitsuba's default diffuse 0.5) and its `area`
//! emitter.
//!
//! Mitsuba's local shapes: `rectangle` is [−1, 1]² at z = 0 facing +z, `cube` is [−1, 1]³ facing
//! out, `disk` the unit disk at z = 0 facing +z (here a fan of [`DISK_SEGMENTS`] triangles:
//! its area is 0.99990 × π), `sphere` `center` (default 0) and `radius` (default 1), kept
//! analytic when `to_world` is a similarity. `flip_normals` turns a sphere inward and reverses
//! the winding of the generated shapes.

use super::doc::El;
use super::plugins::{bsdf, emitter_error, raw_shape, raw_sphere, shape_transform, sp, Props};
use crate::scene::error::SceneError;
use crate::scene::schema::{Arr, MaterialTable, RawShape, Triple};
use crate::scene::spanned::{Cx, Sp};
use std::collections::BTreeMap;

/// Triangles of a `disk`.
pub(super) const DISK_SEGMENTS: usize = 256;

/// The name of the material of shapes without a BSDF (Mitsuba's default diffuse, 0.5).
const DEFAULT_MATERIAL: &str = "(default diffuse)";
/// The same for emitting shapes, to which Mitsuba gives a black diffuse BSDF (reflectance 0):
/// a light without a BSDF emits and reflects nothing.
const DEFAULT_EMITTER_MATERIAL: &str = "(default diffuse of an emitter, black)";

pub(super) fn shape(
    cx: &mut Cx,
    el: &El,
    index: usize,
    materials: &mut BTreeMap<String, Sp<MaterialTable>>,
) -> Result<Sp<RawShape>, SceneError> {
    let kind = cx.attr(el, "type")?.to_string();
    let mut p = Props::new(cx, el)?;
    let label = match el.attr("id") {
        Some(id) => format!("shape '{id}'"),
        None => format!("shape {index}"),
    };
    let emitters = p.take_tag("emitter");
    let material = material(cx, el, &label, &mut p, materials, !emitters.is_empty())?;
    let mut raw = raw_shape(el, material);
    raw.emission = area_emitter(cx, &emitters)?;
    let to_world = p.take("to_world");
    let flip = match p.take("flip_normals") {
        Some(f) => cx.bool_of(f)?,
        None => false,
    };
    let supported = geometry(cx, el, &kind, &mut p, flip, &mut raw)?;
    raw.transform = shape_transform(cx, to_world)?;
    raw.as_written = raw.transform.is_none();
    p.finish(cx, supported)?;
    Ok(sp(el, raw))
}

/// An `area` emitter's radiance (at most one emitter, of that type).
fn area_emitter(cx: &Cx, emitters: &[&El]) -> Result<Option<Sp<Triple>>, SceneError> {
    match emitters {
        [] => Ok(None),
        [e] if e.attr("type") == Some("area") => {
            let mut ep = Props::new(cx, e)?;
            let Some(r) = ep.take("radiance") else {
                return Err(cx.el_err(e, "<emitter type=\"area\"> needs a radiance"));
            };
            let c = Sp {
                span: Some(r.span.clone()),
                value: Triple(cx.emission_of(r)?),
            };
            ep.finish(cx, "radiance")?;
            Ok(Some(c))
        }
        [e] => Err(emitter_error(cx, e, true)),
        [_, e, ..] => Err(cx.el_err(e, "a second emitter: a shape has at most one")),
    }
}

/// The shape's geometry of Mitsuba type `kind` into `raw`; returns the properties it supports
/// (for the message on an unknown one).
fn geometry(
    cx: &mut Cx,
    el: &El,
    kind: &str,
    p: &mut Props,
    flip: bool,
    raw: &mut RawShape,
) -> Result<&'static str, SceneError> {
    const GENERATED: &str = "bsdf or ref, emitter type=\"area\", to_world, flip_normals";
    match kind {
        "obj" | "ply" => {
            let Some(f) = p.take("filename") else {
                let msg = format!("<shape type=\"{kind}\"> needs a <string name=\"filename\">");
                return Err(cx.el_err(el, msg));
            };
            let name = cx.attr(f, "value")?;
            let file = Some(sp(f, el.dir.join(name).display().to_string()));
            if kind == "obj" {
                raw.obj = file;
            } else {
                raw.ply = file;
            }
            if let Some(n) = p.take("face_normals") {
                raw.face_normals = Some(sp(n, cx.bool_of(n)?));
            }
            // Mitsuba gives a mesh without normals smooth ones (unless face_normals).
            raw.smooth_if_no_normals = true;
            if flip {
                let a = if kind == "obj" { "an" } else { "a" };
                return Err(cx.el_err(el, format!("flip_normals on {a} {kind} mesh is not supported (reverse the faces' winding in the file)")));
            }
            Ok("filename, face_normals, bsdf or ref, emitter type=\"area\", to_world")
        }
        "sphere" => {
            let center = match p.take("center") {
                Some(c) => cx.xyz(c, 0.0)?,
                None => [0.0; 3],
            };
            let radius = match p.take("radius") {
                Some(r) => cx.float(r)?,
                None => 1.0,
            };
            raw.sphere = Some(raw_sphere(el, center, radius, flip));
            Ok("center, radius, bsdf or ref, emitter type=\"area\", to_world, flip_normals")
        }
        "rectangle" | "cube" => {
            let faces: Vec<[[f64; 3]; 4]> = if kind == "rectangle" {
                vec![face([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])]
            } else {
                CUBE_FACES
                    .iter()
                    .map(|(n, u, v)| face(*n, *u, *v))
                    .collect()
            };
            let quads = faces
                .into_iter()
                .map(|mut q| {
                    if flip {
                        q.reverse();
                    }
                    sp(el, Arr(q.map(Arr)))
                })
                .collect();
            raw.quads = Some(sp(el, quads));
            Ok(GENERATED)
        }
        "disk" => {
            let at = |i: usize| {
                let a = std::f64::consts::TAU * (i % DISK_SEGMENTS) as f64 / DISK_SEGMENTS as f64;
                [a.cos(), a.sin(), 0.0]
            };
            let tris = (0..DISK_SEGMENTS)
                .map(|i| {
                    let mut t = [[0.0; 3], at(i), at(i + 1)];
                    if flip {
                        t.swap(1, 2);
                    }
                    sp(el, Arr(t.map(Arr)))
                })
                .collect();
            raw.triangles = Some(sp(el, tris));
            Ok(GENERATED)
        }
        other => {
            let msg = format!(
                "<shape type=\"{}\"> is not supported (supported: {})",
                crate::errors::excerpt(other),
                SHAPES.join(", ")
            );
            Err(cx.el_err(el, msg))
        }
    }
}

/// The shape types [`geometry`] reads, in the order its message lists them (a test checks that
/// each is read: `tests/mitsuba_xml.rs`).
pub(super) const SHAPES: [&str; 6] = ["obj", "ply", "rectangle", "cube", "sphere", "disk"];

/// The outward faces of [−1, 1]³: (normal, u, v) with u × v = normal.
const CUBE_FACES: [([f64; 3], [f64; 3], [f64; 3]); 6] = [
    ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
    ([-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
    ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
    ([0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
    ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
    ([0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]),
];

/// The quad `c − u − v, c + u − v, c + u + v, c − u + v`, facing u × v.
fn face(c: [f64; 3], u: [f64; 3], v: [f64; 3]) -> [[f64; 3]; 4] {
    let p = |su: f64, sv: f64| [0, 1, 2].map(|i| c[i] + su * u[i] + sv * v[i]);
    [p(-1.0, -1.0), p(1.0, -1.0), p(1.0, 1.0), p(-1.0, 1.0)]
}

/// The shape's material name: a `<ref>` to a top-level BSDF, an inline `<bsdf>` (added under
/// the name `LABEL bsdf`), or Mitsuba's default diffuse: reflectance 0.5, or 0 for a shape
/// that `emits`, as Mitsuba gives them.
fn material(
    cx: &Cx,
    el: &El,
    label: &str,
    p: &mut Props,
    materials: &mut BTreeMap<String, Sp<MaterialTable>>,
    emits: bool,
) -> Result<Sp<String>, SceneError> {
    let refs = p.take_tag("ref");
    let inline = p.take_tag("bsdf");
    match (refs.as_slice(), inline.as_slice()) {
        ([], []) => {
            let name = if emits {
                DEFAULT_EMITTER_MATERIAL
            } else {
                DEFAULT_MATERIAL
            };
            if !materials.contains_key(name) {
                let mut t = MaterialTable::new();
                t.insert(
                    "model".into(),
                    sp(el, toml::Value::String("lambert".into())),
                );
                if emits {
                    t.insert("albedo".into(), sp(el, toml::Value::Float(0.0)));
                }
                materials.insert(name.into(), sp(el, t));
            }
            Ok(sp(el, name.to_string()))
        }
        ([r], []) => {
            let id = cx.attr(r, "id")?;
            if !materials.contains_key(id) {
                return Err(cx.el_err(r, super::plugins::undefined_ref(id, materials.keys())));
            }
            Ok(sp(r, id.to_string()))
        }
        ([], [b]) => {
            let name = format!("{label} bsdf");
            let table = bsdf(cx, b, materials)?;
            materials.insert(name.clone(), sp(b, table));
            Ok(sp(b, name))
        }
        _ => Err(cx.el_err(el, "a shape has one BSDF: give one <bsdf> or one <ref>")),
    }
}
