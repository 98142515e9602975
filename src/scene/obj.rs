//! The OBJ reader: a line-by-line check of the file (tobj reports no line numbers), then
//! tobj's triangulated meshes turned into [`Triangle`]s with the shape's transform, material
//! and emitter.

use super::error::SceneError;
use super::geometry::{degenerate, edge_overflow, Transform};
use super::mtl::{mtl_material, MtlOut};
use super::spanned::{Cx, Sp};
use super::Triangle;
use glam::{Vec2, Vec3};
use std::path::Path;

/// Checks the face indices of an OBJ text line by line (tobj reports no line numbers, and
/// some malformed relative indices make its index arithmetic overflow). Returns whether the
/// file refers to MTL materials.
pub(super) fn scan_obj(text: &str) -> Result<bool, (usize, String)> {
    let (mut nv, mut nt, mut nn) = (0i64, 0i64, 0i64);
    let mut uses_mtl = false;
    for (l, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let kw = words.next();
        // tobj reports malformed numbers without a line ("position parse error"): check them.
        if let Some((what, min, max)) = match kw {
            Some("v") => Some(("vertex position", 3, 6)),
            Some("vt") => Some(("texture coordinate", 1, 3)),
            Some("vn") => Some(("normal", 3, 3)),
            _ => None,
        } {
            let nums: Vec<&str> = line.split_whitespace().skip(1).collect();
            if nums.len() < min || nums.len() > max {
                let want = if min == max {
                    format!("{min}")
                } else {
                    format!("{min} to {max}")
                };
                return Err((
                    l + 1,
                    format!("a {what} needs {want} numbers, found {}", nums.len()),
                ));
            }
            if let Some(bad) = nums.iter().find(|x| x.parse::<f32>().is_err()) {
                return Err((l + 1, format!("{what}: '{bad}' is not a number")));
            }
        }
        match kw {
            Some("v") => nv += 1,
            Some("vt") => nt += 1,
            Some("vn") => nn += 1,
            Some("mtllib") | Some("usemtl") => uses_mtl = true,
            Some(kw @ ("f" | "l")) => {
                let mut count = 0;
                for w in words {
                    count += 1;
                    let parts: Vec<&str> = w.split('/').collect();
                    if parts.len() > 3 {
                        return Err((l + 1, format!("'{w}' has more than three indices")));
                    }
                    let kinds = [("vertex", nv), ("texture coordinate", nt), ("normal", nn)];
                    for (p, (kind, n)) in parts.iter().zip(kinds) {
                        if p.is_empty() && kind != "vertex" {
                            continue;
                        }
                        let i: i64 = p
                            .parse()
                            .map_err(|_| (l + 1, format!("'{w}': '{p}' is not an index")))?;
                        let ok = if i > 0 { i <= n } else { i < 0 && n + i >= 0 };
                        if !ok {
                            let msg = format!(
                                "'{w}': {kind} index {i} does not exist ({n} defined before this line; \
                                 indices start at 1, negative ones count back)"
                            );
                            return Err((l + 1, msg));
                        }
                    }
                }
                if kw == "f" && count < 3 {
                    return Err((
                        l + 1,
                        format!("a face needs at least 3 vertices, found {count}"),
                    ));
                }
            }
            _ => {}
        }
    }
    Ok(uses_mtl)
}

/// What an OBJ shape's triangles get, and how its messages name it.
pub(super) struct ObjShape {
    pub(super) field: String,
    pub(super) label: String,
    pub(super) material: u32,
    pub(super) emitter: Option<u32>,
}

pub(super) fn obj_triangles(
    cx: &mut Cx,
    shape: &ObjShape,
    obj: &Sp<String>,
    xf: &Transform,
    out: &mut Vec<Triangle>,
) -> Result<(), SceneError> {
    obj_triangles_mtl(cx, shape, obj, xf, out, None)
}

/// [`obj_triangles`], with the MTL materials of the faces when `mtl` is given (the shape's
/// `mtl = true`: [`super::mtl`]); faces without one get the shape's material and emitter.
pub(super) fn obj_triangles_mtl(
    cx: &mut Cx,
    shape: &ObjShape,
    obj: &Sp<String>,
    xf: &Transform,
    out: &mut Vec<Triangle>,
    mut mtl: Option<&mut MtlOut>,
) -> Result<(), SceneError> {
    let fo = shape.field.as_str();
    let span = obj.span();
    let rel = Path::new(&obj.value);
    let full = if rel.is_absolute() {
        rel.to_path_buf()
    } else {
        cx.dir.join(rel)
    };
    let shown = full.display().to_string();
    let text = crate::errors::read_utf8(&full).map_err(|e| {
        cx.err(
            span.clone(),
            fo,
            format!("cannot read OBJ file '{shown}': {e}"),
        )
    })?;
    let uses_mtl = scan_obj(&text).map_err(|(line, msg)| {
        cx.err(
            span.clone(),
            fo,
            format!("OBJ file '{shown}', line {line}: {msg}"),
        )
    })?;
    if uses_mtl && mtl.is_none() {
        let msg = format!("OBJ file '{shown}' refers to MTL materials; they are ignored: every face uses this shape's material (mtl = true uses them)");
        cx.warn(span.clone(), fo, msg);
    }
    if !uses_mtl && mtl.is_some() {
        let msg = format!("OBJ file '{shown}' has no MTL materials (mtllib, usemtl): every face uses this shape's material");
        cx.warn(span.clone(), fo, msg);
    }
    // Points (`p`) and polylines (`l`) are not surfaces: tobj's ignore_points / ignore_lines
    // drop only those of one and two vertices, and `l 1 2 3` became a face. Removed here (the
    // line numbers stay), and counted.
    let (mut points, mut polylines) = (0usize, 0usize);
    let text: String = text
        .lines()
        .map(|l| match l.split_whitespace().next() {
            Some("p") => {
                points += 1;
                ""
            }
            Some("l") => {
                polylines += 1;
                ""
            }
            _ => l,
        })
        .collect::<Vec<_>>()
        .join("\n");
    if points + polylines > 0 {
        let msg = format!(
            "OBJ file '{shown}': {points} point and {polylines} line element(s) ('p', 'l') ignored: only faces ('f') are surfaces"
        );
        cx.warn(span.clone(), fo, msg);
    }
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // Without `mtl`, the MTL loader refuses every library: the scene file assigns the material.
    // With it, libraries are read relative to the OBJ file.
    let obj_dir = full.parent().map(Path::to_path_buf).unwrap_or_default();
    let read_mtl = mtl.is_some();
    let loaded = std::panic::catch_unwind(|| {
        tobj::load_obj_buf(&mut text.as_bytes(), &opts, |p| match read_mtl {
            true => tobj::load_mtl(obj_dir.join(p)),
            false => Err(tobj::LoadError::OpenFileFailed),
        })
    });
    let (models, libraries) = match loaded {
        Ok(Ok(m)) => m,
        Ok(Err(e)) => {
            return Err(cx.err(span, fo, format!("cannot parse OBJ file '{shown}': {e}")))
        }
        Err(_) => {
            return Err(cx.err(
                span,
                fo,
                format!("cannot parse OBJ file '{shown}': malformed content"),
            ))
        }
    };

    let mut library = Vec::new();
    if read_mtl && uses_mtl {
        library = libraries.map_err(|e| {
            let msg = format!("OBJ file '{shown}': cannot read its MTL library (mtllib, relative to the OBJ file): {e}");
            cx.err(span.clone(), fo, msg)
        })?;
    }
    // Scene materials and emitters of the library's materials, made when a face uses them.
    let mut made: Vec<Option<(u32, Option<u32>)>> = vec![None; library.len()];

    let start = out.len();
    let (mut skipped, mut dropped_normals, mut flipped) = (0usize, 0usize, 0usize);
    for model in &models {
        let m = &model.mesh;
        let (material, emitter) = match (m.material_id, mtl.as_deref_mut()) {
            (Some(id), Some(mo)) if id < library.len() => match made[id] {
                Some(me) => me,
                None => {
                    let me = mtl_material(cx, span.clone(), fo, &obj.value, &library[id], mo)?;
                    made[id] = Some(me);
                    me
                }
            },
            _ => (shape.material, shape.emitter),
        };
        let nverts = m.positions.len() / 3;
        let has_n = !m.normals.is_empty() && m.normals.len() == 3 * nverts;
        let has_uv = !m.texcoords.is_empty() && m.texcoords.len() == 2 * nverts;
        if !m.normals.is_empty() && !has_n {
            let msg = format!(
                "OBJ file '{shown}', object '{}': only some vertices have normals; all are ignored",
                model.name
            );
            cx.warn(span.clone(), fo, msg);
        }
        if !m.texcoords.is_empty() && !has_uv {
            let msg = format!(
                "OBJ file '{shown}', object '{}': only some vertices have texture coordinates; all are ignored",
                model.name
            );
            cx.warn(span.clone(), fo, msg);
        }
        for (t, face) in m.indices.chunks_exact(3).enumerate() {
            let mut v = [Vec3::ZERO; 3];
            let mut n = [Vec3::ZERO; 3];
            let mut uv = [Vec2::ZERO; 3];
            for j in 0..3 {
                let i = face[j] as usize;
                let Some(p) = m.positions.get(3 * i..3 * i + 3) else {
                    return Err(cx.err(
                        span,
                        fo,
                        format!("OBJ file '{shown}': vertex index out of range"),
                    ));
                };
                let p = Vec3::new(p[0], p[1], p[2]);
                if !p.is_finite() {
                    let msg = format!(
                        "OBJ file '{shown}', object '{}', triangle {t}: vertex {p} is not finite",
                        model.name
                    );
                    return Err(cx.err(span, fo, msg));
                }
                v[j] = xf.point(p);
                if !v[j].is_finite() {
                    let msg = format!(
                        "OBJ file '{shown}': the transform moves vertex {p} out of the single-precision range"
                    );
                    return Err(cx.err(span, fo, msg));
                }
                if has_n {
                    n[j] = xf.normal(Vec3::new(
                        m.normals[3 * i],
                        m.normals[3 * i + 1],
                        m.normals[3 * i + 2],
                    ));
                }
                if has_uv {
                    uv[j] = Vec2::new(m.texcoords[2 * i], m.texcoords[2 * i + 1]);
                }
            }
            if let Some(msg) = edge_overflow(&v) {
                let msg = format!(
                    "OBJ file '{shown}', object '{}', triangle {t}: {msg}",
                    model.name
                );
                return Err(cx.err(span, fo, msg));
            }
            if degenerate(&v) {
                skipped += 1;
                continue;
            }
            let mut normals = None;
            if has_n {
                if n.iter().all(|x| x.is_finite() && *x != Vec3::ZERO) {
                    let g = crate::robust::triangle_normal(&v);
                    if (n[0] + n[1] + n[2]).dot(g) < 0.0 {
                        flipped += 1;
                    }
                    normals = Some(n);
                } else {
                    dropped_normals += 1;
                }
            }
            let uv = (has_uv && uv.iter().all(|x| x.is_finite())).then_some(uv);
            out.push(Triangle {
                v,
                n: normals,
                uv,
                material,
                emitter,
            });
        }
    }
    if skipped > 0 {
        cx.warn(
            span.clone(),
            fo,
            format!("OBJ file '{shown}': skipped {skipped} zero-area triangle(s)"),
        );
    }
    if dropped_normals > 0 {
        let msg = format!(
            "OBJ file '{shown}': {dropped_normals} triangle(s) have zero or invalid vertex normals; \
             they use the geometric normal"
        );
        cx.warn(span.clone(), fo, msg);
    }
    if flipped > 0 {
        let msg = format!(
            "OBJ file '{shown}': {flipped} triangle(s) have vertex normals opposite to their winding \
             (the front side follows the counter-clockwise winding)"
        );
        cx.warn(span.clone(), fo, msg);
    }
    if out.len() == start {
        cx.warn(
            span,
            fo,
            format!(
                "{}: OBJ file '{shown}' contains no usable triangles",
                shape.label
            ),
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_scan_checks_indices() {
        assert_eq!(
            scan_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf -3 -2 -1\n"),
            Ok(false)
        );
        assert_eq!(scan_obj("v 0 0 0\nf 1 2 3\n").unwrap_err().0, 2);
        assert_eq!(
            scan_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2 3\n")
                .unwrap_err()
                .0,
            4
        );
        assert_eq!(
            scan_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n")
                .unwrap_err()
                .0,
            4
        );
        assert_eq!(
            scan_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n")
                .unwrap_err()
                .0,
            4
        );
        assert_eq!(scan_obj("v 0 0 0\nv 1 0 0\nf 1 2\n").unwrap_err().0, 3);
        assert_eq!(scan_obj("mtllib a.mtl\n"), Ok(true));
    }
}
