//! `<shape>` → a raw shape: its geometry (`obj`; `rectangle`, `cube` and `disk` as triangles in
//! their local frame with Mitsuba's texture coordinates; `sphere` analytic), its `to_world` as
//! the shape's matrix transform, its BSDF (inline, `<ref>`, or Mitsuba's default diffuse 0.5)
//! and its `area` emitter.
//!
//! Mitsuba's local shapes: `rectangle` is [−1, 1]² at z = 0 facing +z, `cube` is [−1, 1]³ facing
//! out, `disk` the unit disk at z = 0 facing +z (here a fan of [`DISK_SEGMENTS`] triangles:
//! its area is 0.99990 × π), `sphere` `center` (default 0) and `radius` (default 1), kept
//! analytic when `to_world` is a similarity.
//!
//! Front sides as Mitsuba's: its shapes' normals go through the inverse transpose of
//! `to_world`, so a mirroring `to_world` (negative determinant), which reverses the winding,
//! leaves them facing the same side; the generated shapes are then wound the other way, and a
//! sphere turns inward, as Mitsuba's does. `flip_normals` turns them over. A mesh's triangles
//! face the side of their vertex normals ([`Sides::ByNormals`]: Mitsuba shades by them).

use super::doc::El;
use super::plugins::{bsdf, emitter_error, matrix_transform, raw_shape, raw_sphere, sp, Props};
use crate::scene::error::SceneError;
use crate::scene::schema::{Arr, MaterialTable, RawShape, Sides, Triple};
use crate::scene::spanned::{Cx, Sp};
use glam::DMat3;
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
    let to_world = match to_world {
        Some(t) => Some((t, super::values::to_world(cx, t)?.m)),
        None => None,
    };
    let mirrored = to_world.is_some_and(|(_, m)| DMat3::from_mat4(m).determinant() < 0.0);
    let supported = geometry(cx, el, &kind, &mut p, (flip, mirrored), &mut raw)?;
    raw.transform = to_world.map(|(t, m)| matrix_transform(t, &m));
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
            // Mitsuba's default radiance is 1 (grey, as a <float>).
            let c = match ep.take("radiance") {
                Some(r) => Sp {
                    span: Some(r.span.clone()),
                    value: Triple(cx.emission_of(r)?),
                },
                None => sp(e, Triple([1.0; 3])),
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
    (flip, mirrored): (bool, bool),
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
            // Mitsuba gives a mesh without normals smooth ones (unless face_normals), and shades
            // by the normals: their side is the front.
            raw.mitsuba_mesh = true;
            raw.sides = Sides::ByNormals;
            // flip_normals turns the mesh over: its winding and its normals.
            raw.flip_mesh = flip;
            Ok("filename, face_normals, flip_normals, bsdf or ref, emitter type=\"area\", to_world")
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
            // A mirroring to_world turns Mitsuba's sphere inside out (its normals go through the
            // inverse transpose), as flip_normals does.
            raw.sphere = Some(raw_sphere(el, center, radius, flip != mirrored));
            raw.sides = Sides::Kept;
            Ok("center, radius, bsdf or ref, emitter type=\"area\", to_world, flip_normals")
        }
        "rectangle" | "cube" | "disk" => {
            let (tris, uvs) = match kind {
                "rectangle" => quads_uv(&[RECTANGLE]),
                "cube" => quads_uv(&CUBE_FACES),
                _ => disk_uv(),
            };
            // Mitsuba's normals: +z of the local frame (the cube's outward), through the inverse
            // transpose of to_world, turned by flip_normals. A mirroring to_world reverses the
            // winding but not those normals, so the triangles are wound the other way then too.
            let reverse = flip != mirrored;
            let tris = tris
                .into_iter()
                .map(|mut t| {
                    if reverse {
                        t.swap(1, 2);
                    }
                    sp(el, Arr(t.map(Arr)))
                })
                .collect();
            let uvs = uvs
                .into_iter()
                .map(|mut t| {
                    if reverse {
                        t.swap(1, 2);
                    }
                    t
                })
                .collect();
            raw.triangles = Some(sp(el, tris));
            raw.triangle_uvs = Some(uvs);
            raw.sides = Sides::Kept;
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

/// Mitsuba's `rectangle`: [−1, 1]² at z = 0, (u, v) = ((x + 1)/2, (y + 1)/2), corners
/// counter-clockwise seen from +z.
const RECTANGLE: [Corner; 4] = [
    ([-1.0, -1.0, 0.0], [0.0, 0.0]),
    ([1.0, -1.0, 0.0], [1.0, 0.0]),
    ([1.0, 1.0, 0.0], [1.0, 1.0]),
    ([-1.0, 1.0, 0.0], [0.0, 1.0]),
];

/// Mitsuba's `cube` (a mesh in Mitsuba 3: `src/shapes/cube.cpp`), face by face: its four
/// corners, counter-clockwise seen from outside, and their texture coordinates, which map each
/// face onto [0, 1]² as Mitsuba's do (corner by corner the same (u, v)).
const CUBE_FACES: [[Corner; 4]; 6] = {
    const fn face(c: [[f64; 3]; 4]) -> [Corner; 4] {
        [
            (c[0], [0.0, 1.0]),
            (c[1], [1.0, 1.0]),
            (c[2], [1.0, 0.0]),
            (c[3], [0.0, 0.0]),
        ]
    }
    const P: f64 = 1.0;
    const N: f64 = -1.0;
    [
        face([[P, N, N], [P, N, P], [N, N, P], [N, N, N]]), // −y
        face([[P, P, N], [N, P, N], [N, P, P], [P, P, P]]), // +y
        face([[P, N, N], [P, P, N], [P, P, P], [P, N, P]]), // +x
        face([[P, N, P], [P, P, P], [N, P, P], [N, N, P]]), // +z
        face([[N, N, P], [N, P, P], [N, P, N], [N, N, N]]), // −x
        face([[P, P, N], [P, N, N], [N, N, N], [N, P, N]]), // −z
    ]
};

/// A corner: its position in the shape's local frame and its texture coordinates.
type Corner = ([f64; 3], [f32; 2]);

/// Triangles, and the texture coordinates of their vertices.
type UvTriangles = (Vec<[[f64; 3]; 3]>, Vec<[[f32; 2]; 3]>);

/// Triangles and per-vertex texture coordinates of quads, two triangles each (corners 0 1 2
/// and 0 2 3).
fn quads_uv(quads: &[[Corner; 4]]) -> UvTriangles {
    let mut tris = Vec::new();
    let mut uvs = Vec::new();
    for q in quads {
        for idx in [[0, 1, 2], [0, 2, 3]] {
            tris.push(idx.map(|i| q[i].0));
            uvs.push(idx.map(|i| q[i].1));
        }
    }
    (tris, uvs)
}

/// Mitsuba's `disk`, the unit disk at z = 0 facing +z, as a fan of [`DISK_SEGMENTS`] triangles
/// (area 0.99990 × π) with Mitsuba's texture coordinates (u, v) = (r, φ/2π) at the vertices
/// (the centre's v that of the middle of its triangle; within a triangle they are interpolated
/// linearly, which misplaces v by at most half a segment's width, 1/512, near the centre).
fn disk_uv() -> UvTriangles {
    let n = DISK_SEGMENTS as f64;
    let at = |i: usize| {
        let a = std::f64::consts::TAU * (i % DISK_SEGMENTS) as f64 / n;
        [a.cos(), a.sin(), 0.0]
    };
    let v = |x: f64| (x / n) as f32;
    let tris = (0..DISK_SEGMENTS)
        .map(|i| [[0.0; 3], at(i), at(i + 1)])
        .collect();
    let uvs = (0..DISK_SEGMENTS)
        .map(|i| {
            let i = i as f64;
            [[0.0, v(i + 0.5)], [1.0, v(i)], [1.0, v(i + 1.0)]]
        })
        .collect();
    (tris, uvs)
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
