//! A `ply = "mesh.ply"` shape: the file read by [`super::ply`], its polygons fan-triangulated
//! and turned into triangles with the shape's transform, material and emitter, with the
//! checks and warnings of OBJ shapes ([`super::obj`]): zero-area triangles skipped, vertex
//! normals that are zero or not finite dropped, normals opposite to the winding counted.

use super::error::SceneError;
use super::geometry::{
    edge_overflow, mesh_path, vertex_normals, FaceRules, Transform, TriangleSink,
};
use super::obj::ObjShape;
use super::spanned::{Cx, Sp};
use glam::Vec3;

pub(super) fn ply_triangles(
    cx: &mut Cx,
    shape: &ObjShape,
    ply: &Sp<String>,
    xf: &Transform,
    mut out: TriangleSink,
) -> Result<(), SceneError> {
    let fp = shape.field.as_str();
    let span = ply.span();
    let full = mesh_path(cx, &ply.value);
    let shown = crate::errors::shown_path(&full);
    let bytes = cx.read_referenced(&full, crate::infile::PLY).map_err(|e| {
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
    let mut normals: Option<Vec<Vec3>> = mesh
        .normals
        .as_ref()
        .map(|n| n.iter().map(|&n| xf.normal(n)).collect());
    let mut rules = FaceRules::new(shape.sides, shape.flip);
    if normals.is_none() && shape.smooth {
        // Smooth normals of the file's vertices, from the placed ones.
        let indices: Vec<u32> = mesh.triangles().flatten().collect();
        normals = Some(vertex_normals(&positions, &indices));
        rules.computed_normals(true);
    }

    for (t, idx) in mesh.triangles().enumerate() {
        let [a, b, c] = idx.map(|i| i as usize);
        let v = [positions[a], positions[b], positions[c]];
        if let Some(msg) = edge_overflow(&v) {
            return Err(cx.err(span, fp, format!("PLY file '{shown}', triangle {t}: {msg}")));
        }
        let n = normals.as_ref().map(|ns| [ns[a], ns[b], ns[c]]);
        let uv = mesh.uvs.as_ref().map(|u| [u[a], u[b], u[c]]);
        if let Some(face) = rules.face(v, n, uv, shape.material, shape.emitter) {
            out.push(face);
        }
    }
    rules.warn(cx, span, fp, ("PLY", &shown, &shape.label));
    Ok(())
}
