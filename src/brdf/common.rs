//! Building blocks shared by the models (GLSL twin: `shaders/brdf/common.glsl`).

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Cosine-weighted hemisphere sample (Malley's method on the concentric disk, Shirley & Chiu
/// 1997). pdf = cosθ/π.
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let a = 2.0 * u - Vec2::ONE;
    let d = if a.x == 0.0 && a.y == 0.0 {
        Vec2::ZERO
    } else if a.x.abs() > a.y.abs() {
        let r = a.x;
        let phi = (PI / 4.0) * (a.y / a.x);
        Vec2::new(r * phi.cos(), r * phi.sin())
    } else {
        let r = a.y;
        let phi = PI / 2.0 - (PI / 4.0) * (a.x / a.y);
        Vec2::new(r * phi.cos(), r * phi.sin())
    };
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) / PI
}

/// Both directions strictly above the surface.
#[inline]
pub fn same_hemisphere_up(a: Vec3, b: Vec3) -> bool {
    a.z > 0.0 && b.z > 0.0
}

// ---------------------------------------------------------------------------------------------
// Helpers added by models-a (Oren–Nayar, Phong, Blinn–Phong, Ward). GLSL twins under the same
// marker in shaders/brdf/common.glsl, same names and the same arithmetic.
// ---------------------------------------------------------------------------------------------

/// Rec. 709 luminance, used to turn RGB lobe albedos into lobe-selection probabilities.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Mirror direction about the normal z: refl(w) = (−w.x, −w.y, w.z).
#[inline]
pub fn reflect_z(w: Vec3) -> Vec3 {
    Vec3::new(-w.x, -w.y, w.z)
}

/// Reflect `w` about the unit vector `h`: 2(w·h)h − w.
#[inline]
pub fn reflect_about(w: Vec3, h: Vec3) -> Vec3 {
    2.0 * w.dot(h) * h - w
}

/// Orthonormal basis (t, b) completing the unit vector `n` (Duff et al. 2017, "Building an
/// Orthonormal Basis, Revisited", JCGT 6(1)); right-handed: t × b = n.
#[inline]
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
    (t, bt)
}

/// Rotate `w` about z by the angle whose cosine and sine are `c`, `s`.
#[inline]
pub fn rotate_z(w: Vec3, c: f32, s: f32) -> Vec3 {
    Vec3::new(c * w.x - s * w.y, s * w.x + c * w.y, w.z)
}

/// e^x − 1 with relative accuracy near 0 (GLSL has no expm1): Taylor series to x⁶ for
/// |x| < 0.1 (truncation < 3e-10 relative), exp(x) − 1 elsewhere.
#[inline]
pub fn expm1_f(x: f32) -> f32 {
    if x.abs() < 0.1 {
        x * (1.0
            + x * (0.5
                + x * (1.0 / 6.0 + x * (1.0 / 24.0 + x * (1.0 / 120.0 + x * (1.0 / 720.0))))))
    } else {
        x.exp() - 1.0
    }
}

/// ln(1 + x) with relative accuracy near 0 (GLSL has no log1p): alternating series to x⁸ for
/// |x| < 0.1 (truncation < 1.2e-9 relative), ln(1 + x) elsewhere. x > −1.
#[inline]
pub fn log1p_f(x: f32) -> f32 {
    if x.abs() < 0.1 {
        x * (1.0
            + x * (-0.5
                + x * (1.0 / 3.0
                    + x * (-0.25 + x * (0.2 + x * (-1.0 / 6.0 + x * (1.0 / 7.0 + x * -0.125)))))))
    } else {
        (1.0 + x).ln()
    }
}

/// cⁿ for the cosine c = 1 − x of a small angle, where x = 1 − c is supplied accurately (e.g.
/// |a − b|²/2 for unit a, b): exp(n·log1p(−x)), so lobes with n up to 10⁶ keep their shape in
/// f32. Returns 0 for c ≤ 0 (x ≥ 1) and 1 for n = 0 with c > 0 (the lobe is max(0, c)ⁿ).
#[inline]
pub fn pow_one_minus(x: f32, n: f32) -> f32 {
    if x >= 1.0 {
        return 0.0;
    }
    if n <= 0.0 {
        return 1.0;
    }
    (n * log1p_f(-x.max(0.0))).exp()
}

/// 1 − a·b for unit vectors, accurate when they are nearly parallel: |a − b|²/2.
#[inline]
pub fn one_minus_dot(a: Vec3, b: Vec3) -> f32 {
    0.5 * (a - b).length_squared()
}

#[cfg(test)]
mod models_a_tests {
    use super::*;

    #[test]
    fn expm1_and_log1p_match_libm() {
        let mut x = -5.0f64;
        while x < 5.0 {
            for s in [1e-7f64, 1e-4, 1e-2, 1.0] {
                let v = x * s;
                let e = libm::expm1(v);
                assert!(
                    ((expm1_f(v as f32) as f64) - e).abs() <= 4e-7 * e.abs().max(1e-30),
                    "expm1 {v}"
                );
                if v > -0.999 {
                    let l = libm::log1p(v);
                    assert!(
                        ((log1p_f(v as f32) as f64) - l).abs() <= 4e-7 * l.abs().max(1e-30),
                        "log1p {v}"
                    );
                }
            }
            x += 0.0371;
        }
    }

    #[test]
    fn pow_one_minus_is_accurate_for_huge_exponents() {
        // (1 − x)^n for x = 1e-7, n = 1e6: e^{−0.1} ≈ 0.904837 (pow(1 − x, n) in f32 gives 0.89).
        let v = pow_one_minus(1e-7, 1e6) as f64;
        let exact = (1e6 * libm::log1p(-1e-7)).exp();
        assert!((v - exact).abs() < 1e-6, "{v} vs {exact}");
        assert_eq!(pow_one_minus(1.0, 5.0), 0.0);
        assert_eq!(pow_one_minus(0.5, 0.0), 1.0);
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in
            [Vec3::Z, -Vec3::Z, Vec3::new(0.6, 0.0, 0.8), Vec3::new(-0.36, 0.48, -0.8), Vec3::X]
        {
            let (t, b) = orthonormal_basis(n);
            assert!(t.dot(b).abs() < 1e-6 && t.dot(n).abs() < 1e-6 && b.dot(n).abs() < 1e-6);
            assert!((t.length() - 1.0).abs() < 1e-6 && (b.length() - 1.0).abs() < 1e-6);
            assert!((t.cross(b) - n).length() < 1e-5);
        }
    }
}
