//! Pinhole camera rays, shared by both renderers through the same precomputed vectors
//! (GLSL: `camera_ray` in `shaders/wavefront/generate.comp`).
//!
//! Image x runs to the camera's right and row 0 is the top (cornell_box.json conventions).
//! The pixel filter is a box one pixel wide: the sample position is uniform in the pixel.

use crate::scene::Scene;
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraBasis {
    pub origin: Vec3,
    pub forward: Vec3,
    /// Camera right, scaled by tan(fov_y/2)·aspect.
    pub right: Vec3,
    /// Camera up, scaled by tan(fov_y/2).
    pub up: Vec3,
}

impl CameraBasis {
    pub fn new(scene: &Scene) -> CameraBasis {
        let c = &scene.camera;
        // Scaled first: the camera may be up to ~3e38 from its target, and `up` any length.
        let forward = crate::robust::normalize_scaled(c.target - c.position);
        let right = forward
            .cross(crate::robust::normalize_scaled(c.up))
            .normalize();
        let up = right.cross(forward);
        let tan_half = (c.fov_y_deg.to_radians() * 0.5).tan();
        let aspect = scene.width as f32 / scene.height as f32;
        CameraBasis {
            origin: c.position,
            forward,
            right: right * (tan_half * aspect),
            up: up * tan_half,
        }
    }

    /// Direction through film position (fx, fy) in pixels, (0,0) the top-left corner.
    pub fn ray_direction(&self, fx: f32, fy: f32, width: u32, height: u32) -> Vec3 {
        let sx = 2.0 * fx / width as f32 - 1.0;
        let sy = 1.0 - 2.0 * fy / height as f32;
        (self.forward + sx * self.right + sy * self.up).normalize()
    }
}
