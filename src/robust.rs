//! Overflow-safe vector helpers for coordinates anywhere in the f32 range.
//!
//! A cross product or a squared length of vectors beyond about 1.8e19 overflows f32, and one
//! below about 1e-19 underflows, even though the direction they describe is representable.
//! Scaling a vector by a power of two is exact (away from the subnormal range), so scaling
//! first by `2^-e`, with `e` the binary exponent of its largest component, gives the same
//! direction bit for bit where nothing overflowed and a finite one where something would have.
//! GLSL twins (`frexp`/`ldexp`, also exact): `scaled_edge` in `shaders/wavefront/surface.glsl`.

use glam::{DVec3, Vec3};

/// `v · 2^-e` where `2^(e-1) <= max|v_i| < 2^e`, so the largest component is in [0.5, 1).
/// Zero, infinite and NaN vectors are returned as they are.
pub fn scale_to_unit_exponent(v: Vec3) -> Vec3 {
    let m = v.abs().max_element();
    if !(m > 0.0 && m.is_finite()) {
        return v;
    }
    let (_, e) = libm::frexpf(m);
    Vec3::new(
        libm::ldexpf(v.x, -e),
        libm::ldexpf(v.y, -e),
        libm::ldexpf(v.z, -e),
    )
}

/// `normalize(v)` that neither overflows nor underflows; zero for a zero or non-finite `v`.
pub fn normalize_scaled(v: Vec3) -> Vec3 {
    scale_to_unit_exponent(v).normalize_or_zero()
}

/// The unit normal `normalize((v1 - v0) × (v2 - v0))` of a triangle, with each edge scaled to
/// unit exponent first (exact), so that huge or tiny triangles get a normal; the edges
/// themselves must be finite (zero otherwise, as for a zero-area triangle).
pub fn triangle_normal(v: &[Vec3; 3]) -> Vec3 {
    let e1 = scale_to_unit_exponent(v[1] - v[0]);
    let e2 = scale_to_unit_exponent(v[2] - v[0]);
    e1.cross(e2).normalize_or_zero()
}

/// Twice the triangle's area in f64 (finite for every finite f32 triangle).
pub fn triangle_double_area_f64(v: &[Vec3; 3]) -> f64 {
    let d = |a: Vec3| DVec3::new(a.x as f64, a.y as f64, a.z as f64);
    (d(v[1]) - d(v[0])).cross(d(v[2]) - d(v[0])).length()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_of_huge_and_tiny_triangles() {
        for s in [1e-30f32, 1e-20, 1.0, 1e20, 1e30, 1e38] {
            let v = [Vec3::ZERO, Vec3::new(s, 0.0, 0.0), Vec3::new(0.0, s, 0.0)];
            let n = triangle_normal(&v);
            assert!((n - Vec3::Z).length() < 1e-6, "scale {s}: {n}");
            let a = triangle_double_area_f64(&v) / (s as f64 * s as f64);
            assert!((a - 1.0).abs() < 1e-12, "scale {s}: {a}");
        }
        let n = normalize_scaled(Vec3::new(2e19, 0.0, 2e19));
        assert!(
            (n - Vec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-6,
            "{n}"
        );
        assert_eq!(normalize_scaled(Vec3::ZERO), Vec3::ZERO);
    }

    /// Where nothing overflows the scaled result is the unscaled one, bit for bit.
    #[test]
    fn scaling_is_exact() {
        let v = [
            Vec3::new(0.3, -1.7, 2.9),
            Vec3::new(5.1, 0.2, -0.7),
            Vec3::new(-3.3, 4.4, 1.1),
        ];
        let plain = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        assert_eq!(triangle_normal(&v), plain);
    }
}
