//! The geometry that both the shape assembly ([`super::assemble`]) and the OBJ reader
//! ([`super::obj`]) apply: the shape transform and the triangle checks.

use glam::Vec3;

/// `p' = translate + R_y(angle) · (scale ⊙ p)`; normals `n' = normalize(R_y · (n / scale))`.
pub(super) struct Transform {
    pub(super) translate: Vec3,
    pub(super) scale: Vec3,
    pub(super) cos: f32,
    pub(super) sin: f32,
}

impl Transform {
    pub(super) fn identity() -> Self {
        Transform {
            translate: Vec3::ZERO,
            scale: Vec3::ONE,
            cos: 1.0,
            sin: 0.0,
        }
    }
    /// Rotation about +y, counter-clockwise seen from above (+z turns toward +x).
    fn rot(&self, p: Vec3) -> Vec3 {
        Vec3::new(
            self.cos * p.x + self.sin * p.z,
            p.y,
            -self.sin * p.x + self.cos * p.z,
        )
    }
    pub(super) fn point(&self, p: Vec3) -> Vec3 {
        self.translate + self.rot(self.scale * p)
    }
    pub(super) fn normal(&self, n: Vec3) -> Vec3 {
        self.rot(n / self.scale).normalize_or_zero()
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transform_rotates_counter_clockwise_from_above() {
        let mut xf = Transform::identity();
        xf.cos = 0.0;
        xf.sin = 1.0;
        assert!((xf.point(Vec3::Z) - Vec3::X).length() < 1e-6);
        xf.scale = Vec3::new(2.0, 1.0, 1.0);
        // A normal of a plane x = y stretched in x: the normal tilts toward y.
        let n = Transform {
            cos: 1.0,
            sin: 0.0,
            ..xf
        }
        .normal(Vec3::new(1.0, -1.0, 0.0));
        assert!((n - Vec3::new(1.0, -2.0, 0.0).normalize()).length() < 1e-6);
    }

    #[test]
    fn degenerate_triangles() {
        assert!(degenerate(&[Vec3::ZERO, Vec3::X, 2.0 * Vec3::X]));
        assert!(degenerate(&[Vec3::ZERO, Vec3::ZERO, Vec3::Y]));
        assert!(!degenerate(&[Vec3::ZERO, Vec3::X, Vec3::Y]));
        assert!(degenerate(&[Vec3::ZERO, Vec3::X, Vec3::splat(f32::NAN)]));
    }
}
