//! Test scenes and random rays for the BVH tests (`tests/bvh.rs` on the host,
//! `tests/bvh_glsl.rs` on a Vulkan device).

use brdfwave::scene::shapes::icosphere;
use brdfwave::scene::{Camera, Integrator, Scene, Sphere, Triangle};
use brdfwave::stress::Rng;
use glam::Vec3;

/// Random points and directions for test rays, from the stress tests' SplitMix64.
pub trait RayRng {
    fn vec(&mut self, lo: f32, hi: f32) -> Vec3;
    /// Uniform direction.
    fn dir(&mut self) -> Vec3;
}

impl RayRng for Rng {
    fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    fn dir(&mut self) -> Vec3 {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, std::f32::consts::TAU);
        let s = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(s * phi.cos(), s * phi.sin(), z)
    }
}

pub fn scene(tris: Vec<[Vec3; 3]>, spheres: Vec<(Vec3, f32, bool)>) -> Scene {
    Scene {
        path: "test".into(),
        camera: Camera {
            position: Vec3::ZERO,
            target: Vec3::Z,
            up: Vec3::Y,
            fov_y_deg: 45.0,
            aperture_radius: 0.0,
            focus_distance: 1.0,
            mirror: false,
        },
        width: 1,
        height: 1,
        integrator: Integrator::default(),
        materials: Vec::new(),
        material_names: Vec::new(),
        material_params: Vec::new(),
        emitters: Vec::new(),
        triangles: tris
            .into_iter()
            .map(|v| Triangle {
                v,
                material: 0,
                emitter: None,
            })
            .collect(),
        attributes: Vec::new(),
        spheres: spheres
            .into_iter()
            .map(|(center, radius, inward)| Sphere {
                center,
                radius,
                material: 0,
                emitter: None,
                inward,
                frame: None,
            })
            .collect(),
        lights: Vec::new(),
        environment: Vec3::ZERO,
        environment_map: None,
        warnings: Vec::new(),
    }
}

/// Random ray tmax: mostly unbounded (the renderer's extension rays), some short (shadow rays).
pub fn tmax_of(rng: &mut Rng, scale: f32) -> f32 {
    if rng.f() < 0.3 {
        rng.range(0.0, scale)
    } else {
        f32::MAX
    }
}

pub fn random_soup(rng: &mut Rng, n: usize, extent: f32) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|_| {
            let c = rng.vec(-extent, extent);
            let size = extent * 0.3 * (2.0f32).powf(-rng.range(0.0, 8.0));
            [
                c + rng.dir() * size,
                c + rng.dir() * size,
                c + rng.dir() * size,
            ]
        })
        .collect()
}

pub fn random_spheres(rng: &mut Rng, n: usize, extent: f32) -> Vec<(Vec3, f32, bool)> {
    (0..n)
        .map(|_| {
            (
                rng.vec(-extent, extent),
                extent * 0.2 * (2.0f32).powf(-rng.range(0.0, 5.0)),
                false,
            )
        })
        .collect()
}

/// Points a ray can be aimed at: vertices, centroids and sphere points.
pub fn targets(s: &Scene, rng: &mut Rng) -> Vec<Vec3> {
    let mut t: Vec<Vec3> = Vec::new();
    for tri in &s.triangles {
        t.push(tri.v[(rng.next_u64() % 3) as usize]);
        t.push((tri.v[0] + tri.v[1] + tri.v[2]) / 3.0);
    }
    for sp in &s.spheres {
        t.push(sp.center + rng.dir() * sp.radius);
    }
    t
}

/// Closed axis-aligned cube [lo, hi]^3, every face an n × n grid of quads (two triangles each),
/// vertices exactly shared.
pub fn grid_cube(n: usize, lo: f32, hi: f32) -> Vec<[Vec3; 3]> {
    let coord = |i: usize| lo + (hi - lo) * i as f32 / n as f32;
    let mut tris = Vec::new();
    for axis in 0..3 {
        for &side in &[lo, hi] {
            for i in 0..n {
                for j in 0..n {
                    let p = |a: usize, b: usize| {
                        let mut q = [0.0f32; 3];
                        q[axis] = side;
                        q[(axis + 1) % 3] = coord(a);
                        q[(axis + 2) % 3] = coord(b);
                        Vec3::from(q)
                    };
                    let (p00, p10, p01, p11) = (p(i, j), p(i + 1, j), p(i, j + 1), p(i + 1, j + 1));
                    // Alternate the diagonal so vertices have different valences.
                    if (i + j) % 2 == 0 {
                        tris.push([p00, p10, p11]);
                        tris.push([p00, p11, p01]);
                    } else {
                        tris.push([p00, p10, p01]);
                        tris.push([p10, p11, p01]);
                    }
                }
            }
        }
    }
    tris
}

/// The mixed scene: `tris` random triangles and `spheres` random spheres in [−5, 5]³, an
/// icosphere, and a large inward-facing sphere around them all.
pub fn mixed_scene(rng: &mut Rng, tris: usize, spheres: usize) -> Scene {
    let mut t = random_soup(rng, tris, 5.0);
    let (v, f) = icosphere(2, Vec3::new(2.0, 1.0, -1.0), 1.5);
    t.extend(f.iter().map(|t| [v[t[0]], v[t[1]], v[t[2]]]));
    let mut sp = random_spheres(rng, spheres, 5.0);
    sp.push((Vec3::ZERO, 20.0, true));
    scene(t, sp)
}
