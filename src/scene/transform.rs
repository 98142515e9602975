//! The `transform` table of a TOML shape checked into a [`Transform`]: the original
//! `translate` / `scale` / `rotate_y_deg` form (kept bit for bit), a rotation about any axis
//! (`rotate = { axis, angle_deg }`), or a row-major 4×4 `matrix`. The Mitsuba reader
//! ([`super::mitsuba`]) writes every `to_world` as such a `matrix`, so both formats are checked
//! here.

use super::assemble::fmt_vec;
use super::error::SceneError;
use super::geometry::{axis_rotation, Transform};
use super::schema::{RawTransform, Sides};
use super::spanned::{Cx, Sp};
use glam::{DMat3, DVec3};

pub(super) fn transform(
    cx: &mut Cx,
    f: &str,
    t: &Sp<RawTransform>,
    sides: Sides,
) -> Result<Transform, SceneError> {
    let raw = &t.value;
    if let Some(m) = &raw.matrix {
        let others = [
            raw.translate.is_some().then_some("translate"),
            raw.scale.is_some().then_some("scale"),
            raw.rotate_y_deg.is_some().then_some("rotate_y_deg"),
            raw.rotate.is_some().then_some("rotate"),
        ];
        if let Some(other) = others.into_iter().flatten().next() {
            let msg = format!(
                "matrix stands alone: give either a matrix or translate/scale/rotate, not both (found {other})"
            );
            return Err(cx.err(m.span(), &format!("{f}.transform.matrix"), msg));
        }
        return matrix(cx, &format!("{f}.transform.matrix"), m, sides);
    }
    let (mut translate, mut scale) = (glam::Vec3::ZERO, glam::Vec3::ONE);
    if let Some(v) = &raw.translate {
        translate = cx.v3(v, &format!("{f}.transform.translate"))?;
    }
    if let Some(s) = &raw.scale {
        let fs = format!("{f}.transform.scale");
        scale = cx.vec3(s.span(), &fs, s.value.0)?;
        if scale.min_element() <= 0.0 {
            let msg = format!(
                "{} is out of range: every scale factor must be > 0 (a mirror would turn the mesh inside out; a matrix may mirror)",
                fmt_vec(scale)
            );
            return Err(cx.err(s.span(), &fs, msg));
        }
    }
    if let Some(r) = &raw.rotate {
        let fr = format!("{f}.transform.rotate");
        if let Some(y) = &raw.rotate_y_deg {
            let msg = "give either rotate or rotate_y_deg, not both";
            return Err(cx.err(y.span(), &format!("{f}.transform.rotate_y_deg"), msg));
        }
        let axis = cx.v3(&r.value.axis, &format!("{fr}.axis"))?;
        if axis == glam::Vec3::ZERO {
            let msg = "the rotation axis has zero length";
            return Err(cx.err(r.value.axis.span(), &format!("{fr}.axis"), msg));
        }
        let a = &r.value.angle_deg;
        let deg = cx.finite(a.span(), &format!("{fr}.angle_deg"), a.value)?;
        let axis = DVec3::new(axis.x as f64, axis.y as f64, axis.z as f64);
        let s = DVec3::new(scale.x as f64, scale.y as f64, scale.z as f64);
        let t = DVec3::new(translate.x as f64, translate.y as f64, translate.z as f64);
        return Ok(Transform::Affine {
            a: axis_rotation(axis, deg as f64) * DMat3::from_diagonal(s),
            t,
        });
    }
    let (mut cos, mut sin) = (1.0, 0.0);
    if let Some(a) = &raw.rotate_y_deg {
        let deg = cx.finite(a.span(), &format!("{f}.transform.rotate_y_deg"), a.value)?;
        let rad = (deg as f64).to_radians();
        cos = rad.cos() as f32;
        sin = rad.sin() as f32;
    }
    Ok(Transform::Trs {
        translate,
        scale,
        cos,
        sin,
    })
}

/// A row-major 4×4 matrix: finite, affine (last row `[0, 0, 0, 1]`), invertible. A mirror
/// (negative determinant) is legal; it reverses the winding, and where the winding decides the
/// front side (`sides`) that is warned about: the front sides turn over.
fn matrix(
    cx: &mut Cx,
    field: &str,
    m: &Sp<super::schema::Arr<super::schema::Arr<f64, 4>, 4>>,
    sides: Sides,
) -> Result<Transform, SceneError> {
    let mut rows = [[0.0f64; 4]; 4];
    for (i, row) in m.value.iter().enumerate() {
        for (j, x) in row.iter().enumerate() {
            // Checked for finiteness and the f32 range; the written f64 is kept.
            cx.finite(m.span(), field, *x)?;
            rows[i][j] = *x;
        }
    }
    if rows[3] != [0.0, 0.0, 0.0, 1.0] {
        let msg = format!(
            "the last row is {:?}: only affine matrices (last row [0, 0, 0, 1]) are supported, not projective ones",
            rows[3]
        );
        return Err(cx.err(m.span(), field, msg));
    }
    let xf = Transform::from_rows(&rows);
    let (a, _) = xf.affine();
    let det = a.determinant();
    let norm = a.to_cols_array().iter().map(|x| x * x).sum::<f64>().sqrt();
    if det.is_nan() || det.abs() <= 1e-12 * norm * norm * norm {
        let msg =
            format!("the matrix is singular (determinant {det:.3e}): it would flatten the shape");
        return Err(cx.err(m.span(), field, msg));
    }
    let turns_over = match sides {
        Sides::Winding => Some("it reverses the winding, so each triangle's front side turns over"),
        Sides::Kept => None,
        Sides::ByNormals => Some("as in Mitsuba, a triangle with vertex normals keeps the side they face (its winding is turned to agree), and one without turns over"),
    };
    if let (true, Some(what)) = (det < 0.0, turns_over) {
        let msg = format!("the matrix mirrors (negative determinant): {what}");
        cx.warn(m.span(), field, msg);
    }
    Ok(xf)
}
