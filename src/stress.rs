//! `brdfwave stress`: randomized numerical-stability checks (the suite itself follows).

use crate::scene::Scene;
use glam::Vec3;

/// The scene scaled by `scale` about the origin, then moved by `translate`: geometry and camera.
/// Radiance and materials are scale-free, so the image should not change (up to the rounding
/// of the coordinates).
pub fn transform_scene(scene: &Scene, scale: f32, translate: Vec3) -> Scene {
    let mut s = scene.clone();
    let f = |p: Vec3| p * scale + translate;
    for t in &mut s.triangles {
        t.v = t.v.map(f);
    }
    for sp in &mut s.spheres {
        sp.center = f(sp.center);
        sp.radius *= scale;
    }
    s.camera.position = f(s.camera.position);
    s.camera.target = f(s.camera.target);
    s
}
