//! The geometry that the shape assembly ([`super::assemble`]) and the mesh readers
//! ([`super::obj`], [`super::ply_shape`]) apply: the shape transform, the triangle checks and
//! the face rules of meshes.

use super::schema::Sides;
use super::spanned::Cx;
use super::{Triangle, VertexAttributes};
use glam::{DMat3, DVec3, Vec2, Vec3};
use std::ops::Range;
use std::path::{Path, PathBuf};

/// A shape's placement. Two forms:
/// * [`Transform::Trs`], the original TOML form `translate + R_y(angle) · (scale ⊙ p)`,
///   evaluated in f32 exactly as it always was (the shipped scenes' vertices stay bit for bit);
/// * [`Transform::Affine`], any invertible affine map `p' = A p + t` (a TOML `matrix`, a
///   rotation about any axis, a Mitsuba `to_world`), evaluated in f64 and rounded once to f32.
///
/// Normals go through the inverse transpose and are renormalised.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Transform {
    Trs {
        translate: Vec3,
        scale: Vec3,
        cos: f32,
        sin: f32,
    },
    Affine {
        /// The linear part `A`.
        a: DMat3,
        /// The translation `t`.
        t: DVec3,
    },
    /// No transform at all (a Mitsuba mesh without `to_world`): points as written, and normals
    /// as written when they are unit to single precision (so that the OBJ files `brdfwave
    /// convert` writes give back the very same normals), else normalised.
    AsWritten,
}

fn d(v: Vec3) -> DVec3 {
    DVec3::new(v.x as f64, v.y as f64, v.z as f64)
}

fn f(v: DVec3) -> Vec3 {
    Vec3::new(v.x as f32, v.y as f32, v.z as f32)
}

impl Transform {
    pub(super) fn identity() -> Self {
        Transform::Trs {
            translate: Vec3::ZERO,
            scale: Vec3::ONE,
            cos: 1.0,
            sin: 0.0,
        }
    }
    /// The affine map of a row-major 4×4 matrix whose last row is `[0, 0, 0, 1]`.
    pub(super) fn from_rows(m: &[[f64; 4]; 4]) -> Self {
        Transform::Affine {
            a: DMat3::from_cols(
                DVec3::new(m[0][0], m[1][0], m[2][0]),
                DVec3::new(m[0][1], m[1][1], m[2][1]),
                DVec3::new(m[0][2], m[1][2], m[2][2]),
            ),
            t: DVec3::new(m[0][3], m[1][3], m[2][3]),
        }
    }
    /// The same map as an [`Transform::Affine`] (in f64).
    pub(super) fn affine(&self) -> (DMat3, DVec3) {
        match *self {
            Transform::Trs {
                translate,
                scale,
                cos,
                sin,
            } => {
                let (c, s) = (cos as f64, sin as f64);
                let r = DMat3::from_cols(DVec3::new(c, 0.0, -s), DVec3::Y, DVec3::new(s, 0.0, c));
                (r * DMat3::from_diagonal(d(scale)), d(translate))
            }
            Transform::Affine { a, t } => (a, t),
            Transform::AsWritten => (DMat3::IDENTITY, DVec3::ZERO),
        }
    }
    /// Rotation about +y, counter-clockwise seen from above (+z turns toward +x).
    fn rot(cos: f32, sin: f32, p: Vec3) -> Vec3 {
        Vec3::new(cos * p.x + sin * p.z, p.y, -sin * p.x + cos * p.z)
    }
    pub(super) fn point(&self, p: Vec3) -> Vec3 {
        match self {
            Transform::Trs {
                translate,
                scale,
                cos,
                sin,
            } => *translate + Self::rot(*cos, *sin, *scale * p),
            Transform::Affine { a, t } => f(*a * d(p) + *t),
            Transform::AsWritten => p,
        }
    }
    pub(super) fn normal(&self, n: Vec3) -> Vec3 {
        match self {
            Transform::Trs {
                scale, cos, sin, ..
            } => Self::rot(*cos, *sin, n / *scale).normalize_or_zero(),
            Transform::Affine { a, .. } => f((a.inverse().transpose() * d(n)).normalize_or_zero()),
            Transform::AsWritten if (n.length_squared() - 1.0).abs() <= 4.0 * f32::EPSILON => n,
            Transform::AsWritten => n.normalize_or_zero(),
        }
    }
    /// The uniform scale factor `s` when the map is a similarity (`AᵀA = s² I` to within
    /// 1e-6 relative: a rotation, a uniform scale, a translation), else `None`.
    pub(super) fn similarity_scale(&self) -> Option<f64> {
        let (a, _) = self.affine();
        let ata = a.transpose() * a;
        let s2 = (ata.x_axis.x + ata.y_axis.y + ata.z_axis.z) / 3.0;
        let dev = (ata - DMat3::from_diagonal(DVec3::splat(s2)))
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        (s2 > 0.0 && s2.is_finite() && dev <= 1e-6 * s2).then(|| s2.sqrt())
    }
}

/// The rotation by `deg` degrees about `axis` (any non-zero vector), counter-clockwise when
/// the axis points at the viewer (the right-hand rule, as Mitsuba's `rotate`): Rodrigues'
/// formula in f64.
pub(super) fn axis_rotation(axis: DVec3, deg: f64) -> DMat3 {
    rodrigues(axis.normalize(), deg)
}

/// Rodrigues' formula with the axis `k` as given, `cos θ·I + sin θ·[k]× + (1 − cos θ)·k·kᵀ`: the
/// rotation by `deg` degrees about `k` when `k` is a unit vector. Mitsuba 3 applies it to the
/// axis of a `<rotate>` as written, unit or not (`crate::scene::mitsuba`).
pub(super) fn rodrigues(k: DVec3, deg: f64) -> DMat3 {
    let (s, c) = deg.to_radians().sin_cos();
    let kx = DMat3::from_cols(
        DVec3::new(0.0, k.z, -k.y),
        DVec3::new(-k.z, 0.0, k.x),
        DVec3::new(k.y, -k.x, 0.0),
    );
    DMat3::IDENTITY * c + kx * s + DMat3::from_cols(k * k.x, k * k.y, k * k.z) * (1.0 - c)
}

/// Zero-area test: the two edges from `v0` are parallel or empty to within single precision,
/// `|e1 × e2| <= 1e-6 |e1| |e2|`, evaluated in f64 so that no finite f32 triangle overflows
/// (or underflows) into looking degenerate. An edge that itself overflows f32 (vertices of
/// opposite sign near 3.4e38) counts as degenerate here; the loaders refuse such input first
/// with a message ([`edge_overflow`]).
pub(super) fn degenerate(v: &[Vec3; 3]) -> bool {
    let d = |a: Vec3| glam::DVec3::new(a.x as f64, a.y as f64, a.z as f64);
    let e1 = d(v[1]) - d(v[0]);
    let e2 = d(v[2]) - d(v[0]);
    let c = e1.cross(e2).length();
    let edges_finite = (v[1] - v[0]).is_finite() && (v[2] - v[0]).is_finite();
    !(c > 1e-6 * e1.length() * e2.length() && c.is_finite() && edges_finite)
}

/// A message when an edge `v1 - v0` or `v2 - v0` of a triangle with finite vertices is not
/// finite in f32 (the renderers work with f32 edges).
pub(super) fn edge_overflow(v: &[Vec3; 3]) -> Option<String> {
    if (v[1] - v[0]).is_finite() && (v[2] - v[0]).is_finite() && (v[2] - v[1]).is_finite() {
        return None;
    }
    Some(format!(
        "the triangle {} {} {} has an edge longer than the single-precision range (about 3.4e38)",
        v[0], v[1], v[2]
    ))
}

/// A mesh file named in a scene: as written when absolute, else relative to the scene's folder.
pub(super) fn mesh_path(cx: &Cx, name: &str) -> PathBuf {
    let rel = Path::new(name);
    if rel.is_absolute() {
        rel.to_path_buf()
    } else {
        cx.dir.join(rel)
    }
}

/// Where a shape appends its triangles: the scene's triangles and their vertex attributes
/// (`Scene::attributes`, kept up to the last triangle that has any).
pub(super) struct TriangleSink<'a> {
    pub(super) triangles: &'a mut Vec<Triangle>,
    pub(super) attributes: &'a mut Vec<VertexAttributes>,
}

impl TriangleSink<'_> {
    /// Appends one triangle and its attributes.
    pub(super) fn push(&mut self, (t, a): (Triangle, VertexAttributes)) {
        if a != VertexAttributes::NONE {
            self.attributes
                .resize(self.triangles.len(), VertexAttributes::NONE);
            self.attributes.push(a);
        }
        self.triangles.push(t);
    }
}

/// The face rules that OBJ and PLY meshes share, with the counts their closing warnings give:
/// zero-area triangles skipped, vertex normals that are zero or not finite dropped (the
/// triangle uses its geometric normal), normals opposite to the winding counted (or, by
/// Mitsuba's rule, [`Sides::ByNormals`], the winding turned to them), texture coordinates that
/// are not finite dropped.
#[derive(Default)]
pub(super) struct FaceRules {
    by_normals: bool,
    flip: bool,
    /// The normals are computed from the faces ([`vertex_normals`]), not the file's: they do
    /// not choose sides, are not counted as opposite to the winding, and a zero one (where its
    /// vertex's faces cancel) is the face's normal.
    computed: bool,
    skipped: usize,
    dropped_normals: usize,
    flipped: usize,
    made: usize,
}

impl FaceRules {
    /// The rules for a mesh whose front sides are chosen by `sides`, turned over (winding and
    /// normals) where `flip` (Mitsuba's `flip_normals`).
    pub(super) fn new(sides: Sides, flip: bool) -> FaceRules {
        FaceRules {
            by_normals: sides == Sides::ByNormals,
            flip,
            ..FaceRules::default()
        }
    }

    /// Rules with the same choice of front sides, and no counts yet (for a part of the mesh).
    pub(super) fn part(&self) -> FaceRules {
        FaceRules {
            by_normals: self.by_normals,
            flip: self.flip,
            computed: self.computed,
            ..FaceRules::default()
        }
    }

    /// Whether the normals given to [`Self::face`] from now on are computed from the faces.
    pub(super) fn computed_normals(&mut self, computed: bool) {
        self.computed = computed;
    }

    /// The triangle of the placed vertices `v` (checked by [`edge_overflow`] first), with the
    /// attributes of their normals `n` and texture coordinates `uv`, or `None` when it has zero
    /// area.
    pub(super) fn face(
        &mut self,
        v: [Vec3; 3],
        n: Option<[Vec3; 3]>,
        uv: Option<[Vec2; 3]>,
        material: u32,
        emitter: Option<u32>,
    ) -> Option<(Triangle, VertexAttributes)> {
        if degenerate(&v) {
            self.skipped += 1;
            return None;
        }
        let (mut v, mut uv) = (v, uv);
        // A computed normal is zero where its vertex's faces cancel: that corner takes this
        // face's normal.
        let n = match self.computed {
            true => n.map(|n| {
                n.map(|x| match x == Vec3::ZERO {
                    true => crate::robust::triangle_normal(&v),
                    false => x,
                })
            }),
            false => n,
        };
        let mut n = n.filter(|n| {
            let usable = n.iter().all(|x| x.is_finite() && *x != Vec3::ZERO);
            if !usable {
                self.dropped_normals += 1;
            }
            usable
        });
        // The same triangle wound the other way, its attributes following their vertices.
        // Without texture coordinates a point's are its barycentrics (b1, b2) (`crate::texture`):
        // where the triangle keeps attributes they are written out, so that they stay those of
        // the file's order.
        let reverse = |v: &mut [Vec3; 3], n: &mut Option<[Vec3; 3]>, uv: &mut Option<[Vec2; 3]>| {
            v.swap(1, 2);
            if let Some(n) = n {
                n.swap(1, 2);
            }
            if uv.is_some() || n.is_some() {
                let mut t = uv.unwrap_or([Vec2::ZERO, Vec2::X, Vec2::Y]);
                t.swap(1, 2);
                *uv = Some(t);
            }
        };
        if self.flip {
            // Mitsuba's flip_normals on a mesh: both normals turned over.
            reverse(&mut v, &mut n, &mut uv);
            if let Some(n) = &mut n {
                *n = n.map(|x| -x);
            }
        }
        if let Some(normals) = n.filter(|_| !self.computed) {
            if (normals[0] + normals[1] + normals[2]).dot(crate::robust::triangle_normal(&v)) < 0.0
            {
                if self.by_normals {
                    // Mitsuba's front side: where the normals point.
                    reverse(&mut v, &mut n, &mut uv);
                } else {
                    self.flipped += 1;
                }
            }
        }
        self.made += 1;
        let attributes = VertexAttributes {
            n,
            uv: uv.filter(|u| u.iter().all(|x| x.is_finite())),
        };
        Some((
            Triangle {
                v,
                material,
                emitter,
            },
            attributes,
        ))
    }

    /// Adds the counts of `other` (the rules of another part of the same mesh).
    pub(super) fn add(&mut self, other: &FaceRules) {
        self.skipped += other.skipped;
        self.dropped_normals += other.dropped_normals;
        self.flipped += other.flipped;
        self.made += other.made;
    }

    /// The closing warnings of the mesh file `shown` of `format` ("OBJ", "PLY"), read for the
    /// shape `label`.
    pub(super) fn warn(
        &self,
        cx: &mut Cx,
        span: Option<Range<usize>>,
        field: &str,
        (format, shown, label): (&str, &str, &str),
    ) {
        let FaceRules {
            by_normals: _,
            flip: _,
            computed: _,
            skipped,
            dropped_normals,
            flipped,
            made,
        } = *self;
        if skipped > 0 {
            let msg = format!("{format} file '{shown}': skipped {skipped} zero-area triangle(s)");
            cx.warn(span.clone(), field, msg);
        }
        if dropped_normals > 0 {
            let msg = format!(
                "{format} file '{shown}': {dropped_normals} triangle(s) have zero or invalid vertex normals; \
                 they use the geometric normal"
            );
            cx.warn(span.clone(), field, msg);
        }
        if flipped > 0 {
            let msg = format!(
                "{format} file '{shown}': {flipped} triangle(s) have vertex normals opposite to their winding \
                 (the front side follows the counter-clockwise winding)"
            );
            cx.warn(span.clone(), field, msg);
        }
        if made == 0 {
            let msg = format!("{label}: {format} file '{shown}' contains no usable triangles");
            cx.warn(span, field, msg);
        }
    }
}

/// Smooth vertex normals for a mesh that has none, as Mitsuba 3 gives every mesh without
/// normals (unless `face_normals`): at each vertex the average of its faces' unit normals
/// weighted by the face's angle at that vertex (Thürmer & Wüthrich 1998, "Computing Vertex
/// Normals from Polygonal Facets", JGT 3(1)), from the placed vertices `positions` (after the
/// shape's transform, as Mitsuba computes them) and the triangles' vertex `indices`. A vertex
/// is a vertex of the file, as Mitsuba keys them (an OBJ file's (v, vt, vn) triple, a PLY
/// file's vertex), so that vertices apart in the file stay apart, even at one position.
/// Zero-area and non-finite triangles add nothing; a vertex whose faces cancel, or that no
/// face uses, gets zero ([`FaceRules`] gives that corner the face's normal).
pub(super) fn vertex_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut sums = vec![DVec3::ZERO; positions.len()];
    for face in indices.chunks_exact(3) {
        let at = |j: usize| positions.get(face[j] as usize).map(|p| p.as_dvec3());
        let (Some(a), Some(b), Some(c)) = (at(0), at(1), at(2)) else {
            continue;
        };
        let v = [a, b, c];
        let n = (v[1] - v[0]).cross(v[2] - v[0]);
        let len = n.length();
        if !(len > 0.0 && len.is_finite()) {
            continue;
        }
        let n = n / len;
        for j in 0..3 {
            let (d0, d1) = (v[(j + 1) % 3] - v[j], v[(j + 2) % 3] - v[j]);
            let c = d0.dot(d1) / (d0.length() * d1.length());
            let angle = c.clamp(-1.0, 1.0).acos();
            if angle.is_finite() {
                sums[face[j] as usize] += n * angle;
            }
        }
    }
    sums.into_iter()
        .map(|s| {
            let len = s.length();
            if len > 0.0 && len.is_finite() {
                (s / len).as_vec3()
            } else {
                Vec3::ZERO
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transform_rotates_counter_clockwise_from_above() {
        let xf = Transform::Trs {
            translate: Vec3::ZERO,
            scale: Vec3::ONE,
            cos: 0.0,
            sin: 1.0,
        };
        assert!((xf.point(Vec3::Z) - Vec3::X).length() < 1e-6);
        // A normal of a plane x = y stretched in x: the normal tilts toward y.
        let n = Transform::Trs {
            translate: Vec3::ZERO,
            scale: Vec3::new(2.0, 1.0, 1.0),
            cos: 1.0,
            sin: 0.0,
        }
        .normal(Vec3::new(1.0, -1.0, 0.0));
        assert!((n - Vec3::new(1.0, -2.0, 0.0).normalize()).length() < 1e-6);
    }

    /// Both forms of one map agree: scale 2, 90° about y, then a translation.
    #[test]
    fn affine_form_matches_the_trs_form() {
        let trs = Transform::Trs {
            translate: Vec3::new(1.0, 2.0, 3.0),
            scale: Vec3::new(2.0, 3.0, 4.0),
            cos: 0.0,
            sin: 1.0,
        };
        let (a, t) = trs.affine();
        let aff = Transform::Affine { a, t };
        for p in [Vec3::X, Vec3::Y, Vec3::new(0.5, -2.0, 7.0)] {
            assert!((trs.point(p) - aff.point(p)).length() < 1e-5);
            assert!((trs.normal(p) - aff.normal(p)).length() < 1e-6);
        }
        assert_eq!(trs.similarity_scale(), None);
        let uniform = Transform::Affine {
            a: axis_rotation(DVec3::new(1.0, 1.0, 0.0), 33.0) * 2.5,
            t: DVec3::ZERO,
        };
        assert!((uniform.similarity_scale().unwrap() - 2.5).abs() < 1e-12);
    }

    /// Rodrigues against hand-computed rotations: 90° about +z takes +x to +y; 120° about
    /// (1, 1, 1) permutes the axes x → y → z → x.
    #[test]
    fn axis_rotation_follows_the_right_hand_rule() {
        let r = axis_rotation(DVec3::Z, 90.0);
        assert!((r * DVec3::X - DVec3::Y).length() < 1e-15);
        let r = axis_rotation(DVec3::ONE, 120.0);
        assert!((r * DVec3::X - DVec3::Y).length() < 1e-15);
        assert!((r * DVec3::Y - DVec3::Z).length() < 1e-15);
        // About y the right-hand rule turns +z toward +x, as rotate_y_deg does.
        let r = axis_rotation(DVec3::Y, 90.0);
        assert!((r * DVec3::Z - DVec3::X).length() < 1e-15);
    }

    #[test]
    fn degenerate_triangles() {
        assert!(degenerate(&[Vec3::ZERO, Vec3::X, 2.0 * Vec3::X]));
        assert!(degenerate(&[Vec3::ZERO, Vec3::ZERO, Vec3::Y]));
        assert!(!degenerate(&[Vec3::ZERO, Vec3::X, Vec3::Y]));
        assert!(degenerate(&[Vec3::ZERO, Vec3::X, Vec3::splat(f32::NAN)]));
    }
}
