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
