//! A `ply = "mesh.ply"` shape: the file read by [`super::ply`], its polygons fan-triangulated
//! and turned into [`Triangle`]s with the shape's transform, material and emitter, with the
//! checks and warnings of OBJ shapes ([`super::obj`]): zero-area triangles skipped, vertex
//! normals that are zero or not finite dropped, normals opposite to the winding counted.

use super::error::SceneError;
use super::geometry::{degenerate, edge_overflow, Transform};
use super::obj::ObjShape;
use super::spanned::{Cx, Sp};
use super::Triangle;
use glam::{Vec2, Vec3};
use std::path::Path;

pub(super) fn ply_triangles(
    cx: &mut Cx,
    shape: &ObjShape,
    ply: &Sp<String>,
    xf: &Transform,
    out: &mut Vec<Triangle>,
) -> Result<(), SceneError> {
    let fp = shape.field.as_str();
    let span = ply.span();
    let rel = Path::new(&ply.value);
    let full = if rel.is_absolute() {
        rel.to_path_buf()
    } else {
        cx.dir.join(rel)
    };
    let shown = full.display().to_string();
    let bytes = std::fs::read(&full).map_err(|e| {
        let msg = format!("cannot read PLY file '{shown}': {e}");
        cx.err(span.clone(), fp, msg)
    })?;
    let mesh = super::ply::parse(&bytes)
        .map_err(|e| cx.err(span.clone(), fp, format!("PLY file '{shown}', {e}")))?;

    let mut positions = Vec::with_capacity(mesh.positions.len());
    for (i, &p) in mesh.positions.iter().enumerate() {
        if !p.is_finite() {
            let msg =
                format!("PLY file '{shown}', vertex {i}: {p} is not finite (in single precision)");
            return Err(cx.err(span, fp, msg));
        }
        let q = xf.point(p);
        if !q.is_finite() {
            let msg = format!(
                "PLY file '{shown}', vertex {i}: the transform moves {p} out of the single-precision range"
            );
            return Err(cx.err(span, fp, msg));
        }
        positions.push(q);
    }
    let normals: Option<Vec<Vec3>> = mesh
        .normals
        .as_ref()
        .map(|n| n.iter().map(|&n| xf.normal(n)).collect());

    let start = out.len();
    let (mut skipped, mut dropped_normals, mut flipped) = (0usize, 0usize, 0usize);
    for (t, idx) in mesh.triangles().enumerate() {
        let [a, b, c] = idx.map(|i| i as usize);
        let v = [positions[a], positions[b], positions[c]];
        if let Some(msg) = edge_overflow(&v) {
            return Err(cx.err(span, fp, format!("PLY file '{shown}', triangle {t}: {msg}")));
        }
        if degenerate(&v) {
            skipped += 1;
            continue;
        }
        let mut n = None;
        if let Some(ns) = &normals {
            let tn = [ns[a], ns[b], ns[c]];
            if tn.iter().all(|x| x.is_finite() && *x != Vec3::ZERO) {
                if (tn[0] + tn[1] + tn[2]).dot(crate::robust::triangle_normal(&v)) < 0.0 {
                    flipped += 1;
                }
                n = Some(tn);
            } else {
                dropped_normals += 1;
            }
        }
        let uv: Option<[Vec2; 3]> = mesh
            .uvs
            .as_ref()
            .map(|u| [u[a], u[b], u[c]])
            .filter(|u| u.iter().all(|x| x.is_finite()));
        out.push(Triangle {
            v,
            n,
            uv,
            material: shape.material,
            emitter: shape.emitter,
        });
    }
    if skipped > 0 {
        let msg = format!("PLY file '{shown}': skipped {skipped} zero-area triangle(s)");
        cx.warn(span.clone(), fp, msg);
    }
    if dropped_normals > 0 {
        let msg = format!(
            "PLY file '{shown}': {dropped_normals} triangle(s) have zero or invalid vertex normals; \
             they use the geometric normal"
        );
        cx.warn(span.clone(), fp, msg);
    }
    if flipped > 0 {
        let msg = format!(
            "PLY file '{shown}': {flipped} triangle(s) have vertex normals opposite to their winding \
             (the front side follows the counter-clockwise winding)"
        );
        cx.warn(span.clone(), fp, msg);
    }
    if out.len() == start {
        let msg = format!(
            "{}: PLY file '{shown}' contains no usable triangles",
            shape.label
        );
        cx.warn(span, fp, msg);
    }
    Ok(())
}
