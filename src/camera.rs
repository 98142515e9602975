//! Camera rays, shared by both renderers through the same precomputed vectors (GLSL:
//! `camera_ray` in `shaders/wavefront/path.glsl`).
//!
//! Image x runs to the camera's right and row 0 is the top (cornell_box.json conventions).
//! The pixel filter is a box one pixel wide: the sample position is uniform in the pixel.
//!
//! A pinhole, or a thin lens (Pharr, Jakob & Humphreys 2016, *Physically Based Rendering*,
//! 3rd ed., §6.2.3; Mitsuba 3's `thinlens`): a lens of radius `aperture_radius` in the plane
//! through the camera's position perpendicular to the view direction, focused on the plane at
//! `focus_distance` along it. The ray through film position (sx, sy) leaves from a point of the
//! lens drawn uniformly by Shirley & Chiu's (1997) concentric map of the 2-D sample (depth 0,
//! dimensions `LENS_U`, `LENS_V`) and passes through the point the pinhole ray would meet on
//! the plane in focus: o + d·f with d = forward + sx·right + sy·up (d·forward = 1).

use crate::scene::Scene;
use glam::{Vec2, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraBasis {
    pub origin: Vec3,
    pub forward: Vec3,
    /// Camera right, scaled by tan(fov_y/2)·aspect.
    pub right: Vec3,
    /// Camera up, scaled by tan(fov_y/2).
    pub up: Vec3,
    /// The unit right and up vectors times the aperture radius (zero for a pinhole).
    pub lens_right: Vec3,
    pub lens_up: Vec3,
    /// The distance of the plane in focus.
    pub focus_distance: f32,
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
        // A mirrored image: x runs to the camera's left (the lens's disc turned alike).
        let right = if c.mirror { -right } else { right };
        let tan_half = (c.fov_y_deg.to_radians() * 0.5).tan();
        let aspect = scene.width as f32 / scene.height as f32;
        CameraBasis {
            origin: c.position,
            forward,
            right: right * (tan_half * aspect),
            up: up * tan_half,
            lens_right: right * c.aperture_radius,
            lens_up: up * c.aperture_radius,
            focus_distance: c.focus_distance,
        }
    }

    /// Whether the camera has a lens (else a pinhole).
    pub fn thin_lens(&self) -> bool {
        self.lens_right != Vec3::ZERO
    }

    /// The thin lens's ray (origin, unit direction) through film position (fx, fy), the lens
    /// point drawn by `u` (module docs).
    pub fn lens_ray(&self, fx: f32, fy: f32, width: u32, height: u32, u: Vec2) -> (Vec3, Vec3) {
        let sx = 2.0 * fx / width as f32 - 1.0;
        let sy = 1.0 - 2.0 * fy / height as f32;
        let d = self.forward + sx * self.right + sy * self.up;
        let lens = concentric_disk(u);
        let offset = lens.x * self.lens_right + lens.y * self.lens_up;
        (
            self.origin + offset,
            (d * self.focus_distance - offset).normalize(),
        )
    }

    /// Direction through film position (fx, fy) in pixels, (0,0) the top-left corner.
    pub fn ray_direction(&self, fx: f32, fy: f32, width: u32, height: u32) -> Vec3 {
        let sx = 2.0 * fx / width as f32 - 1.0;
        let sy = 1.0 - 2.0 * fy / height as f32;
        (self.forward + sx * self.right + sy * self.up).normalize()
    }
}

/// Shirley & Chiu's (1997) concentric map of the unit square onto the unit disc: uniform in
/// area, each ring of the square onto a ring of the disc. GLSL twin: `concentric_disk`
/// (path.glsl).
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let (a, b) = (2.0 * u.x - 1.0, 2.0 * u.y - 1.0);
    if a == 0.0 && b == 0.0 {
        return Vec2::ZERO;
    }
    // φ in turns, its sine and cosine by basic operations (the same bits on both renderers).
    let (r, turns) = if a.abs() > b.abs() {
        (a, 0.125 * (b / a))
    } else {
        (b, 0.25 - 0.125 * (a / b))
    };
    let (s, c) = crate::envmap::sincos_turns(turns);
    Vec2::new(r * c, r * s)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The concentric map is uniform: equal numbers of a grid in each of 8 sectors and in the
    /// inner and outer halves of the area.
    #[test]
    fn the_concentric_map_is_uniform_on_the_disc() {
        let n = 256;
        let (mut sectors, mut inner) = ([0u32; 8], 0u32);
        for i in 0..n {
            for j in 0..n {
                let p = concentric_disk(Vec2::new(
                    (i as f32 + 0.5) / n as f32,
                    (j as f32 + 0.5) / n as f32,
                ));
                assert!(p.length() <= 1.0 + 1e-6);
                let s = ((p.y.atan2(p.x) + std::f32::consts::PI) / (std::f32::consts::PI / 4.0))
                    as usize;
                sectors[s.min(7)] += 1;
                inner += (p.length_squared() < 0.5) as u32;
            }
        }
        let total = (n * n) as f32;
        for s in sectors {
            assert!((s as f32 / total - 0.125).abs() < 0.003, "{sectors:?}");
        }
        // The grid's rings: 182² of 256² points (0.505) lie within r² < 1/2.
        assert!((inner as f32 / total - 0.5).abs() < 0.01, "{inner}");
    }

    /// A mirrored camera sees through film position (x, y) what the plain one sees through
    /// (width − x, y): the image turned left to right, the vertical untouched.
    #[test]
    fn a_mirrored_camera_mirrors_the_image() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
        let mut s = crate::scene::load(&path).unwrap();
        s.camera.up = Vec3::new(0.2, 1.0, 0.1);
        let plain = CameraBasis::new(&s);
        s.camera.mirror = true;
        let mirrored = CameraBasis::new(&s);
        let (w, h) = (s.width, s.height);
        for (fx, fy) in [(0.5, 0.5), (10.25, 200.0), (w as f32 - 3.0, h as f32 * 0.5)] {
            let a = mirrored.ray_direction(fx, fy, w, h);
            let b = plain.ray_direction(w as f32 - fx, fy, w, h);
            assert!((a - b).length() < 1e-6, "({fx}, {fy}): {a} against {b}");
        }
        assert_eq!(mirrored.up, plain.up);
    }
}
