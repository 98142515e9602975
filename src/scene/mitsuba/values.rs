//! Typed values of Mitsuba elements (`<float>`, `<integer>`, `<rgb>`, `<point>`, …) and the
//! `<transform name="to_world">` composition, each error naming the element and its line.
//!
//! Every number is read as the nearest single-precision value (Rust's correctly rounded
//! `parse::<f32>()`) and carried on as that exact f64, so that the loader's `as f32` is exact:
//! a number written with `{}` of an f32 (what `brdfwave convert` writes) reads back to the very
//! same f32. (TOML numbers are parsed to f64 first, then rounded; the two agree except for
//! decimals within 2⁻⁵³ relative of a midpoint between two f32s.)

use super::doc::El;
use crate::scene::error::SceneError;
use crate::scene::spanned::Cx;
use glam::{DMat3, DMat4, DVec3, DVec4};

impl Cx<'_> {
    pub(super) fn el_err(&self, el: &El, msg: impl std::fmt::Display) -> SceneError {
        self.err(Some(el.span.clone()), &el.path, msg)
    }

    /// Where an element is, for a message about another: `scene.xml:12`.
    pub(super) fn where_is(&self, el: &El) -> String {
        let (file, text, start) = self.part_of(el.span.start);
        let line = crate::brdf::params::line_of(text, el.span.start - start);
        format!("{file}:{line}")
    }

    /// A required attribute.
    pub(super) fn attr<'e>(&self, el: &'e El, name: &str) -> Result<&'e str, SceneError> {
        el.attr(name)
            .ok_or_else(|| self.el_err(el, format!("{} needs a {name} attribute", el.describe())))
    }

    /// One number of an attribute, checked finite and within single precision
    /// ([`crate::numbers::parse_f32`]).
    pub(super) fn number(&self, el: &El, text: &str) -> Result<f64, SceneError> {
        crate::numbers::parse_f32(text)
            .map(f64::from)
            .map_err(|msg| self.el_err(el, format!("{}: {msg}", el.describe())))
    }

    /// A list of numbers separated by commas and/or white space.
    pub(super) fn numbers(&self, el: &El, text: &str) -> Result<Vec<f64>, SceneError> {
        text.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|w| !w.is_empty())
            .map(|w| self.number(el, w))
            .collect()
    }

    /// Exactly `n` numbers of attribute `attr`.
    pub(super) fn n_numbers<const N: usize>(
        &self,
        el: &El,
        attr: &str,
    ) -> Result<[f64; N], SceneError> {
        let v = self.numbers(el, self.attr(el, attr)?)?;
        v.as_slice().try_into().map_err(|_| {
            let msg = format!(
                "{}: {attr} needs {N} numbers, found {}",
                el.describe(),
                v.len()
            );
            self.el_err(el, msg)
        })
    }

    /// A `<point>` or `<vector>`: `x`, `y`, `z` attributes (each default 0) or `value="x, y, z"`.
    pub(super) fn xyz(&self, el: &El, default: f64) -> Result<[f64; 3], SceneError> {
        if el.attr("value").is_some() {
            let v = self.numbers(el, el.attr("value").unwrap_or_default())?;
            return match v.as_slice() {
                [x] => Ok([*x; 3]),
                [x, y, z] => Ok([*x, *y, *z]),
                _ => Err(self.el_err(
                    el,
                    format!(
                        "{}: value needs 1 or 3 numbers, found {}",
                        el.describe(),
                        v.len()
                    ),
                )),
            };
        }
        let mut p = [default; 3];
        for (i, a) in ["x", "y", "z"].iter().enumerate() {
            if let Some(t) = el.attr(a) {
                p[i] = self.number(el, t)?;
            }
        }
        Ok(p)
    }
}

/// A composed `to_world`: the matrix, and the lookat's (origin, target, up) when the
/// transform is exactly one `<lookat>` (a camera then keeps the written points exactly).
#[derive(Debug)]
pub(super) struct ToWorld {
    pub(super) m: DMat4,
    pub(super) lookat: Option<[[f64; 3]; 3]>,
}

/// A warning for each `to_uv` under `els` that maps z into u or v: a texture's map is rows and
/// columns 0, 1 and 3 of the 4×4 transform, as Mitsuba 3 takes it, so column 2 is dropped. The
/// common case is a 3×3 `<matrix>` written as a 2-D homogeneous map, whose third column a
/// reader would take for a (u, v) offset: Mitsuba 3 reads it as the linear part of a 3-D
/// transform, and so does brdfwave. Transforms it cannot read are left to `to_world`'s errors.
pub(super) fn to_uv_warnings(cx: &mut Cx, els: &[El]) {
    for el in els {
        if el.tag == "transform" && el.attr("name") == Some("to_uv") {
            if let Ok(t) = to_world(cx, el) {
                let r = rows(&t.m);
                if r[0][2] != 0.0 || r[1][2] != 0.0 {
                    let msg = format!(
                        "to_uv: the map's z column ({}, {}) is dropped, as Mitsuba 3 drops it: (u, v) maps by rows and columns 0, 1 and 3 of the 4×4 transform, and a 3×3 <matrix> is its linear part, so its third column does not move (u, v); a <translate> does",
                        r[0][2] as f32,
                        r[1][2] as f32
                    );
                    cx.warn(Some(el.span.clone()), &el.path, msg);
                }
            }
        }
        to_uv_warnings(cx, &el.children);
    }
}

/// A warning for each `<rotate>` under `els` whose axis is not of unit length (off by more than
/// 1e-3, a stretch an image could show). Mitsuba 3 puts the axis as written into Rodrigues'
/// formula, so such a "rotation" also stretches what it turns; [`to_world`] does as Mitsuba 3
/// does, and the warning says so. Axes it cannot read are left to `to_world`'s errors.
pub(super) fn rotate_axis_warnings(cx: &mut Cx, els: &[El]) {
    for el in els {
        if el.tag == "rotate" {
            if let Ok(a) = cx.xyz(el, 0.0) {
                let len = DVec3::from(a).length();
                if len > 0.0 && (len - 1.0).abs() > 1e-3 {
                    let msg = format!(
                        "the axis ({}, {}, {}) has length {len:.6}, not 1: Mitsuba 3 rotates by the axis as written, which also stretches the shape, and so does brdfwave; give a unit axis for a rotation",
                        a[0], a[1], a[2]
                    );
                    cx.warn(Some(el.span.clone()), &el.path, msg);
                }
            }
        }
        rotate_axis_warnings(cx, &el.children);
    }
}

/// Mitsuba's order: each child is applied after the ones before it, `M = T_n · … · T_1`.
pub(super) fn to_world(cx: &Cx, t: &El) -> Result<ToWorld, SceneError> {
    let mut m = DMat4::IDENTITY;
    let mut lookat = None;
    for c in &t.children {
        let step = match c.tag.as_str() {
            "translate" => DMat4::from_translation(DVec3::from(cx.xyz(c, 0.0)?)),
            "scale" => DMat4::from_scale(DVec3::from(cx.xyz(c, 1.0)?)),
            "rotate" => {
                let axis = DVec3::from(cx.xyz(c, 0.0)?);
                let angle = cx.number(c, cx.attr(c, "angle")?)?;
                if axis == DVec3::ZERO {
                    return Err(cx.el_err(c, "<rotate> needs a non-zero axis (x, y, z or value)"));
                }
                // The axis as written, as Mitsuba 3 takes it (a non-unit one also scales and
                // shears; the reader warns: `rotate_axis_warnings`).
                DMat4::from_mat3(crate::scene::geometry::rodrigues(axis, angle))
            }
            "matrix" => {
                let v = cx.numbers(c, cx.attr(c, "value")?)?;
                match v.len() {
                    16 => DMat4::from_cols_array(&v.try_into().unwrap_or([0.0; 16])).transpose(),
                    9 => DMat4::from_mat3(
                        DMat3::from_cols_array(&v.try_into().unwrap_or([0.0; 9])).transpose(),
                    ),
                    n => {
                        return Err(cx.el_err(
                            c,
                            format!(
                                "<matrix> needs 16 (4×4) or 9 (3×3) numbers, row by row; found {n}"
                            ),
                        ))
                    }
                }
            }
            "lookat" => {
                let o = cx.n_numbers::<3>(c, "origin")?;
                let tg = cx.n_numbers::<3>(c, "target")?;
                let up = match c.attr("up") {
                    Some(_) => cx.n_numbers::<3>(c, "up")?,
                    None => [0.0, 1.0, 0.0],
                };
                if t.children.len() == 1 {
                    lookat = Some([o, tg, up]);
                }
                lookat_matrix(cx, c, o, tg, up)?
            }
            _ => {
                let msg = format!(
                    "{} is not a transform step: <transform> takes translate, rotate, scale, matrix and lookat",
                    c.describe()
                );
                return Err(cx.el_err(c, msg));
            }
        };
        m = step * m;
        // An entry beyond single precision (or inf, NaN) here is an overflow of this step, not
        // a projective transform: named at the step where it happens.
        let worst = m.to_cols_array().iter().fold(0.0f64, |w, x| {
            if x.is_nan() {
                f64::INFINITY
            } else {
                w.max(x.abs())
            }
        });
        if worst > f32::MAX as f64 {
            let msg = format!(
                "{}: the transform overflows here: an entry of the matrix so far is {}, beyond \
                 single precision ({})",
                c.describe(),
                crate::brdf::params::fmt_num(worst),
                crate::numbers::F32_RANGE
            );
            return Err(cx.el_err(c, msg));
        }
    }
    if m.row(3) != DVec4::new(0.0, 0.0, 0.0, 1.0) {
        return Err(cx.el_err(t, "the transform is projective (last row not [0, 0, 0, 1]): only affine transforms are supported"));
    }
    Ok(ToWorld { m, lookat })
}

/// Mitsuba's `lookat`: columns (left, up', dir, origin) with dir = normalize(target − origin),
/// left = normalize(up × dir), up' = dir × left.
fn lookat_matrix(
    cx: &Cx,
    c: &El,
    o: [f64; 3],
    t: [f64; 3],
    up: [f64; 3],
) -> Result<DMat4, SceneError> {
    let (o, t, up) = (DVec3::from(o), DVec3::from(t), DVec3::from(up));
    let dir = (t - o).normalize_or_zero();
    let left = up.cross(dir).normalize_or_zero();
    if dir == DVec3::ZERO || left == DVec3::ZERO {
        return Err(cx.el_err(
            c,
            "<lookat>: the target equals the origin, or up is parallel to the view direction",
        ));
    }
    let new_up = dir.cross(left);
    Ok(DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        o.extend(1.0),
    ))
}

/// The rows of an affine matrix, as the TOML `matrix` field holds them.
pub(super) fn rows(m: &DMat4) -> [[f64; 4]; 4] {
    let r = |i: usize| m.row(i).to_array();
    [r(0), r(1), r(2), r(3)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::mitsuba::doc;
    use std::path::Path;

    fn compose(xml: &str) -> Result<ToWorld, String> {
        let text = format!(
            "<scene version=\"3.0.0\"><transform name=\"to_world\">{xml}</transform></scene>"
        );
        let files = doc::read(Path::new("t.xml"), &text, &[]).map_err(|e| e.to_string())?;
        let cx = Cx::new("t.xml".into(), &files.source);
        to_world(&cx, &files.elements[0]).map_err(|e| e.to_string())
    }

    fn apply(t: &ToWorld, p: [f64; 3]) -> DVec3 {
        t.m.transform_point3(DVec3::from(p))
    }

    /// Steps apply in the order written: scale, then rotate 90° about z, then translate takes
    /// (1, 0, 0) → (2, 0, 0) → (0, 2, 0) → (0, 2, 5), computed by hand.
    #[test]
    fn steps_compose_in_mitsubas_order() {
        let t = compose("<scale value=\"2\"/><rotate z=\"1\" angle=\"90\"/><translate z=\"5\"/>")
            .unwrap();
        assert!((apply(&t, [1.0, 0.0, 0.0]) - DVec3::new(0.0, 2.0, 5.0)).length() < 1e-12);
        // The other order: translate first, then scale: (1, 0, 0) → (1, 0, 5) → (2, 0, 10).
        let t = compose("<translate z=\"5\"/><scale value=\"2\"/>").unwrap();
        assert!((apply(&t, [1.0, 0.0, 0.0]) - DVec3::new(2.0, 0.0, 10.0)).length() < 1e-12);
        // A scale of one axis leaves the others.
        let t = compose("<scale y=\"3\"/>").unwrap();
        assert_eq!(apply(&t, [1.0, 1.0, 1.0]), DVec3::new(1.0, 3.0, 1.0));
    }

    /// A matrix is row-major (the translation is the last column); a rotation about any axis
    /// follows the right-hand rule: 120° about (1, 1, 1) takes x to y.
    #[test]
    fn matrix_and_axis_rotation() {
        let t = compose("<matrix value=\"1 0 0 7  0 0 -1 8  0 1 0 9  0 0 0 1\"/>").unwrap();
        assert_eq!(apply(&t, [0.0, 1.0, 0.0]), DVec3::new(7.0, 8.0, 10.0));
        let t = compose("<rotate value=\"1, 1, 1\" angle=\"120\"/>").unwrap();
        let third = 1.0 / 3f64.sqrt();
        let t_unit = compose(&format!(
            "<rotate value=\"{third}, {third}, {third}\" angle=\"120\"/>"
        ))
        .unwrap();
        assert!((apply(&t_unit, [1.0, 0.0, 0.0]) - DVec3::Y).length() < 1e-6);
        // A non-unit axis as Mitsuba 3.9.1 takes it (`ScalarTransform4f().rotate([1, 1, 1],
        // 120) @ [1, 0, 0]` is (1, 2.36603, 0.633975)): not a rotation.
        let want = DVec3::new(1.0, 1.5 + 0.75f64.sqrt(), 1.5 - 0.75f64.sqrt());
        assert!((apply(&t, [1.0, 0.0, 0.0]) - want).length() < 1e-12);
        let t = compose("<matrix value=\"2 0 0  0 2 0  0 0 2\"/>").unwrap();
        assert_eq!(apply(&t, [1.0, 1.0, 1.0]), DVec3::splat(2.0));
        assert!(
            compose("<matrix value=\"1 0 0 0 1 0 0 0 1 0 0 0 0 0 1 1\"/>")
                .unwrap_err()
                .contains("projective")
        );
        assert!(compose("<matrix value=\"1 2 3\"/>")
            .unwrap_err()
            .contains("found 3"));
    }

    /// lookat from (0, 0, -5) at the origin with up +y: the camera's +z is the view direction
    /// (0, 0, 1) and its +x is left = up × dir = y × z = x, by hand.
    #[test]
    fn lookat_by_hand() {
        let t = compose("<lookat origin=\"0, 0, -5\" target=\"0, 0, 0\" up=\"0, 1, 0\"/>").unwrap();
        assert_eq!(
            t.lookat,
            Some([[0.0, 0.0, -5.0], [0.0; 3], [0.0, 1.0, 0.0]])
        );
        assert_eq!(apply(&t, [0.0, 0.0, 0.0]), DVec3::new(0.0, 0.0, -5.0));
        assert_eq!(apply(&t, [0.0, 0.0, 1.0]), DVec3::new(0.0, 0.0, -4.0));
        assert_eq!(apply(&t, [1.0, 0.0, 0.0]), DVec3::new(1.0, 0.0, -5.0));
        // Looking along +x from the origin: left = y × x = -z.
        let t = compose("<lookat origin=\"0, 0, 0\" target=\"3, 0, 0\" up=\"0, 1, 0\"/>").unwrap();
        assert!((apply(&t, [1.0, 0.0, 0.0]) - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-15);
        assert!(
            compose("<lookat origin=\"0, 0, 0\" target=\"0, 3, 0\" up=\"0, 1, 0\"/>")
                .unwrap_err()
                .contains("parallel")
        );
    }
}
