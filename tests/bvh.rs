//! BVH traversal against brute force, watertightness on closed meshes, spheres seen from
//! inside, degenerate inputs, and a compile check of the GLSL twin (`shaders/bvh.glsl`).
//!
//! Run `cargo test --test bvh -- --nocapture` to see the BVH statistics of every scene.

use brdfwave::bvh::{self, Bvh, Hit, MAX_DEPTH, SPHERE_BIT};
use brdfwave::gpu::interface::{self, ProbeBinding};
use brdfwave::gpu::scene_buffers;
use brdfwave::robust;
use brdfwave::scene::shapes::icosphere;
use brdfwave::scene::{Camera, Integrator, Scene, Sphere, Triangle};
use brdfwave::stress::Rng;
use brdfwave::vk::{raw, Context, ContextOptions, Resource, ShaderCompiler};
use glam::{Vec2, Vec3};

// ---------------------------------------------------------------------------------------------
// Helpers

/// Random points and directions for test rays, from the stress tests' SplitMix64.
trait RayRng {
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

fn scene(tris: Vec<[Vec3; 3]>, spheres: Vec<(Vec3, f32, bool)>) -> Scene {
    Scene {
        path: "test".into(),
        camera: Camera {
            position: Vec3::ZERO,
            target: Vec3::Z,
            up: Vec3::Y,
            fov_y_deg: 45.0,
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
                n: None,
                uv: None,
                material: 0,
                emitter: None,
            })
            .collect(),
        spheres: spheres
            .into_iter()
            .map(|(center, radius, inward)| Sphere {
                center,
                radius,
                material: 0,
                emitter: None,
                inward,
            })
            .collect(),
        lights: Vec::new(),
        environment: Vec3::ZERO,
        warnings: Vec::new(),
    }
}

fn prim_t(s: &Scene, prim: u32, o: Vec3, d: Vec3, tmax: f32) -> Option<f32> {
    if prim & SPHERE_BIT != 0 {
        let sp = &s.spheres[(prim & !SPHERE_BIT) as usize];
        bvh::intersect_sphere(o, d, sp.center, sp.radius, tmax)
    } else {
        bvh::intersect_triangle(o, d, &s.triangles[prim as usize].v, tmax).map(|(t, _)| t)
    }
}

/// Closest hit over all primitives, strictly smaller t wins.
fn brute_closest(s: &Scene, o: Vec3, d: Vec3, tmax: f32) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    for (i, tri) in s.triangles.iter().enumerate() {
        let lim = best.map_or(tmax, |h| h.t);
        if let Some((t, bary)) = bvh::intersect_triangle(o, d, &tri.v, lim) {
            best = Some(Hit {
                t,
                prim: i as u32,
                bary,
            });
        }
    }
    for (i, sp) in s.spheres.iter().enumerate() {
        let lim = best.map_or(tmax, |h| h.t);
        if let Some(t) = bvh::intersect_sphere(o, d, sp.center, sp.radius, lim) {
            best = Some(Hit {
                t,
                prim: i as u32 | SPHERE_BIT,
                bary: Vec2::ZERO,
            });
        }
    }
    best
}

#[derive(Default, Debug)]
struct Tally {
    rays: usize,
    hits: usize,
    ties: usize,
}

/// Compare the BVH with brute force for one ray; returns the BVH's closest hit.
fn check(s: &Scene, b: &Bvh, o: Vec3, d: Vec3, tmax: f32, tally: &mut Tally) -> Option<Hit> {
    let got = b.closest(s, o, d, tmax);
    let want = brute_closest(s, o, d, tmax);
    tally.rays += 1;
    match (got, want) {
        (None, None) => {}
        (Some(g), Some(w)) => {
            tally.hits += 1;
            assert_eq!(
                g.t.to_bits(),
                w.t.to_bits(),
                "t differs: o={o:?} d={d:?} bvh={g:?} brute={w:?}"
            );
            if g.prim != w.prim {
                // Equal t from another primitive: the BVH's primitive must really be hit there.
                assert_eq!(
                    prim_t(s, g.prim, o, d, tmax),
                    Some(w.t),
                    "o={o:?} d={d:?} {g:?} {w:?}"
                );
                tally.ties += 1;
            } else {
                assert_eq!(g.bary, w.bary);
            }
        }
        (g, w) => panic!(
            "BVH and brute force disagree: o={o:?} d={d:?} tmax={tmax} bvh={g:?} brute={w:?}"
        ),
    }
    assert_eq!(
        b.occluded(s, o, d, tmax),
        want.is_some(),
        "any-hit disagrees: o={o:?} d={d:?} tmax={tmax}"
    );
    got
}

/// Random ray tmax: mostly unbounded (the renderer's extension rays), some short (shadow rays).
fn tmax_of(rng: &mut Rng, scale: f32) -> f32 {
    if rng.f() < 0.3 {
        rng.range(0.0, scale)
    } else {
        f32::MAX
    }
}

fn random_soup(rng: &mut Rng, n: usize, extent: f32) -> Vec<[Vec3; 3]> {
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

fn random_spheres(rng: &mut Rng, n: usize, extent: f32) -> Vec<(Vec3, f32, bool)> {
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
fn targets(s: &Scene, rng: &mut Rng) -> Vec<Vec3> {
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
fn grid_cube(n: usize, lo: f32, hi: f32) -> Vec<[Vec3; 3]> {
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

fn report(name: &str, b: &Bvh, tally: &Tally) {
    println!(
        "{name}: {} | {} rays, {} hits, {} equal-t ties",
        b.stats, tally.rays, tally.hits, tally.ties
    );
}

/// `rays` random rays from [−extent, extent]³ checked against brute force, every other one
/// aimed at a point of the scene, tmax from [`tmax_of`] with `tmax_scale`; reported as `name`.
fn check_random_rays(
    s: &Scene,
    rng: &mut Rng,
    name: &str,
    rays: usize,
    extent: f32,
    tmax_scale: f32,
) -> Tally {
    let b = bvh::build(s);
    let tg = targets(s, rng);
    let mut tally = Tally::default();
    for k in 0..rays {
        let o = rng.vec(-extent, extent);
        let d = if k % 2 == 0 {
            rng.dir()
        } else {
            tg[(rng.next_u64() % tg.len() as u64) as usize] - o
        };
        let tmax = tmax_of(rng, tmax_scale);
        check(s, &b, o, d, tmax, &mut tally);
    }
    report(name, &b, &tally);
    tally
}

// ---------------------------------------------------------------------------------------------
// Agreement with brute force

#[test]
fn random_triangle_soup_matches_brute_force() {
    let mut rng = Rng::new(1);
    let s = scene(random_soup(&mut rng, 2000, 10.0), vec![]);
    let tally = check_random_rays(&s, &mut rng, "soup", 4000, 15.0, 30.0);
    assert!(
        tally.hits > 2000,
        "too few hits to mean anything: {tally:?}"
    );
}

#[test]
fn spheres_match_brute_force_from_outside_inside_and_on_surface() {
    let mut rng = Rng::new(2);
    let mut sp = random_spheres(&mut rng, 300, 10.0);
    // An inward room around everything.
    sp.push((Vec3::new(0.5, -0.25, 0.125), 40.0, true));
    let s = scene(vec![], sp);
    let b = bvh::build(&s);
    let mut tally = Tally::default();
    for k in 0..3000 {
        let (o, d) = match k % 3 {
            // Random rays inside the room: every one must hit something.
            0 => (rng.vec(-15.0, 15.0), rng.dir()),
            // From inside a small sphere.
            1 => {
                let (c, r) = (s.spheres[k % 300].center, s.spheres[k % 300].radius);
                (c + rng.dir() * r * rng.range(0.0, 0.99), rng.dir())
            }
            // From exactly on a sphere's surface (as far as f32 allows), any direction.
            _ => {
                let sph = &s.spheres[(rng.next_u64() % s.spheres.len() as u64) as usize];
                (sph.center + rng.dir() * sph.radius, rng.dir())
            }
        };
        let tmax = if k % 7 == 0 {
            rng.range(0.0, 20.0)
        } else {
            f32::MAX
        };
        let h = check(&s, &b, o, d, tmax, &mut tally);
        if tmax == f32::MAX && k % 3 != 2 {
            assert!(
                h.is_some(),
                "a ray inside the room escaped: o={o:?} d={d:?}"
            );
        }
    }
    report("spheres", &b, &tally);
}

#[test]
fn rays_from_a_room_surface_find_the_far_side() {
    // Points on an inward room sphere, rays going inwards: the far side, never t ≈ 0.
    let mut rng = Rng::new(3);
    for &(c, r) in &[
        (Vec3::ZERO, 1.0f32),
        (Vec3::new(100.0, -50.0, 20.0), 30.0),
        (Vec3::splat(1.0e3), 5.0),
    ] {
        let s = scene(vec![], vec![(c, r, true)]);
        let b = bvh::build(&s);
        for _ in 0..500 {
            let u = rng.dir();
            let p = c + u * r;
            // Any inward direction, down to grazing ones.
            let mut d = rng.dir();
            if d.dot(u) > 0.0 {
                d -= 2.0 * d.dot(u) * u;
            }
            // Not grazing: p is only on the surface up to rounding (about ulp(|p|)).
            if d.dot(u) > -0.02 {
                continue;
            }
            let chord = -2.0 * r * d.dot(u) / d.length_squared();
            let h = b
                .closest(&s, p, d, f32::MAX)
                .unwrap_or_else(|| panic!("no hit from {p} along {d}"));
            // p is off the surface by up to about one ulp of its coordinates.
            let cos = -d.dot(u) / d.length();
            let tol =
                1e-5 * chord + 4.0 * p.abs().max_element() * f32::EPSILON / (cos * d.length());
            assert!(
                (h.t - chord).abs() < tol,
                "t {} vs chord {chord} (tol {tol})",
                h.t
            );
            // Leaving outwards from the surface finds nothing.
            assert!(b.closest(&s, p, -d, f32::MAX).is_none());
        }
    }
}

#[test]
fn mixed_scene_matches_brute_force() {
    let mut rng = Rng::new(4);
    let mut tris = random_soup(&mut rng, 600, 5.0);
    let (v, f) = icosphere(2, Vec3::new(2.0, 1.0, -1.0), 1.5);
    tris.extend(f.iter().map(|t| [v[t[0]], v[t[1]], v[t[2]]]));
    let mut sp = random_spheres(&mut rng, 60, 5.0);
    sp.push((Vec3::ZERO, 20.0, true));
    let s = scene(tris, sp);
    check_random_rays(&s, &mut rng, "mixed", 3000, 8.0, 10.0);
}

// ---------------------------------------------------------------------------------------------
// Watertightness

/// Rays from inside a closed mesh aimed exactly at its vertices and at points on its edges
/// must all hit (and agree with brute force).
fn watertight_icosphere(center: Vec3, radius: f32, seed: u64) -> Tally {
    let mut rng = Rng::new(seed);
    let (v, f) = icosphere(3, center, radius);
    let s = scene(
        f.iter().map(|t| [v[t[0]], v[t[1]], v[t[2]]]).collect(),
        vec![],
    );
    let b = bvh::build(&s);
    let mut edges: Vec<(usize, usize)> = f
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .collect();
    edges.retain(|&(a, b)| a < b);
    let mut tally = Tally::default();
    let mut misses = 0;
    let mut shoot = |o: Vec3, target: Vec3, tally: &mut Tally| {
        if check(&s, &b, o, target - o, f32::MAX, tally).is_none() {
            misses += 1;
        }
    };
    for (i, &p) in v.iter().enumerate() {
        let o = center + rng.dir() * radius * rng.range(0.0, 0.9);
        shoot(o, p, &mut tally);
        // Also from the mirrored point, so rays cross every vertex from many sides.
        let o2 = center - (o - center);
        shoot(o2, v[(i * 7) % v.len()], &mut tally);
    }
    for &(a, e) in &edges {
        let o = center + rng.dir() * radius * rng.range(0.0, 0.9);
        shoot(o, (v[a] + v[e]) * 0.5, &mut tally);
        let w = rng.f();
        shoot(o, v[a] * (1.0 - w) + v[e] * w, &mut tally);
    }
    assert_eq!(
        misses, 0,
        "rays from inside a closed mesh escaped through edges or vertices"
    );
    // From outside, aimed at vertices along their outward direction: they enter the mesh.
    for &p in &v {
        let out = (p - center).normalize();
        let o = p + (out + rng.dir() * 0.3).normalize() * radius * rng.range(0.1, 3.0);
        assert!(
            check(&s, &b, o, p - o, f32::MAX, &mut tally).is_some(),
            "missed vertex {p} from {o}"
        );
    }
    tally
}

#[test]
fn closed_icosphere_is_watertight_at_vertices_and_edges() {
    let t = watertight_icosphere(Vec3::ZERO, 1.0, 5);
    println!("icosphere r=1: {t:?}");
    // Far from the origin and large: ulps are big compared to the features.
    let t = watertight_icosphere(Vec3::new(3000.0, -1500.0, 700.0), 250.0, 6);
    println!("icosphere r=250 at 3000: {t:?}");
    let t = watertight_icosphere(Vec3::new(0.01, 0.02, -0.01), 0.001, 7);
    println!("icosphere r=0.001: {t:?}");
}

#[test]
fn grid_cube_axis_aligned_rays_through_vertices_and_edges_hit() {
    // Rays with two zero direction components through shared vertices and edges of a closed
    // grid cube: the origin lies exactly on node-box face planes.
    let n = 8;
    let s = scene(grid_cube(n, -1.0, 1.0), vec![]);
    let b = bvh::build(&s);
    let coord = |i: usize| -1.0 + 2.0 * i as f32 / n as f32;
    let mut tally = Tally::default();
    let mut rng = Rng::new(8);
    for i in 0..=n {
        for j in 0..=n {
            for axis in 0..3 {
                // Along `axis`, the other two coordinates on grid lines (vertices) or half-way
                // (edges), from inside in both directions.
                for &(a, bb) in &[(coord(i), coord(j)), (coord(i), rng.range(-1.0, 1.0))] {
                    let mut o = [0.0f32; 3];
                    o[axis] = rng.range(-0.9, 0.9);
                    o[(axis + 1) % 3] = a;
                    o[(axis + 2) % 3] = bb;
                    let o = Vec3::from(o);
                    for sign in [1.0f32, -1.0] {
                        let mut d = [0.0f32; 3];
                        d[axis] = sign;
                        let d = Vec3::from(d);
                        let on_surface = o.abs().max_element() == 1.0;
                        let h = check(&s, &b, o, d, f32::MAX, &mut tally);
                        if !on_surface {
                            assert!(h.is_some(), "axis-aligned ray escaped: o={o} d={d}");
                        }
                        // Negative zero components behave like positive ones.
                        let dn = Vec3::new(
                            if d.x == 0.0 { -0.0 } else { d.x },
                            if d.y == 0.0 { -0.0 } else { d.y },
                            if d.z == 0.0 { -0.0 } else { d.z },
                        );
                        let hn = check(&s, &b, o, dn, f32::MAX, &mut tally);
                        assert_eq!(h.map(|h| h.t), hn.map(|h| h.t));
                    }
                }
            }
        }
    }
    // Diagonal rays in coordinate planes (one zero component) through interior grid lines.
    for _ in 0..2000 {
        let axis = (rng.next_u64() % 3) as usize;
        let mut o = rng.vec(-0.9, 0.9).to_array();
        o[axis] = coord((rng.next_u64() % (n as u64 + 1)) as usize);
        let mut d = rng.dir().to_array();
        d[axis] = 0.0;
        let (o, d) = (Vec3::from(o), Vec3::from(d));
        let on_surface = o.abs().max_element() == 1.0;
        let h = check(&s, &b, o, d, f32::MAX, &mut tally);
        if !on_surface {
            assert!(
                h.is_some(),
                "ray with a zero component escaped: o={o} d={d}"
            );
        }
    }
    report("grid cube", &b, &tally);
}

#[test]
fn rays_grazing_along_box_faces_agree_with_brute_force() {
    // A ray lying in the cube's top face plane, parallel to it, meets the side faces exactly
    // at their top edge. Every node box touching the top face has that plane as a face, so this
    // needs the zero-component handling of the slab test.
    let s = scene(grid_cube(4, -1.0, 1.0), vec![]);
    let b = bvh::build(&s);
    let mut tally = Tally::default();
    let mut rng = Rng::new(9);
    let mut hits = 0;
    for _ in 0..500 {
        let axis = (rng.next_u64() % 3) as usize;
        let mut o = rng.vec(-0.95, 0.95).to_array();
        o[axis] = if rng.f() < 0.5 { -1.0 } else { 1.0 };
        let mut d = rng.dir().to_array();
        d[axis] = 0.0;
        if rng.f() < 0.5 {
            // Axis-aligned within the face.
            let k = (axis + 1 + (rng.next_u64() % 2) as usize) % 3;
            d = [0.0; 3];
            d[k] = if rng.f() < 0.5 { -1.0 } else { 1.0 };
        }
        let h = check(&s, &b, Vec3::from(o), Vec3::from(d), f32::MAX, &mut tally);
        hits += h.is_some() as usize;
    }
    // Brute force hits the edge of the side faces; so must the BVH (checked above).
    assert!(
        hits > 400,
        "only {hits} of 500 grazing rays hit the side edges"
    );
    report("grazing", &b, &tally);
}

// ---------------------------------------------------------------------------------------------
// Self-intersection

#[test]
fn offset_origins_do_not_hit_their_own_surface() {
    let mut rng = Rng::new(10);
    // Scales down to 1e-6 and up to 1e6, and a scene moved 1e6 from the origin: the offset
    // comes from the hit point's error bound, which follows the coordinates' magnitude.
    for &(scale, shift) in &[
        (1.0f32, 3.0f32),
        (1.0e3, 3.0e3),
        (1.0e-2, 3.0e-2),
        (1.0e-6, 3.0e-6),
        (1.0e6, 3.0e6),
        (1.0, 1.0e6),
    ] {
        let tris: Vec<[Vec3; 3]> = random_soup(&mut rng, 300, 10.0)
            .into_iter()
            .map(|t| t.map(|v| v * scale + Vec3::splat(shift)))
            .collect();
        let sp: Vec<(Vec3, f32, bool)> = random_spheres(&mut rng, 50, 10.0)
            .into_iter()
            .map(|(c, r, i)| (c * scale + Vec3::splat(shift), r * scale, i))
            .collect();
        let s = scene(tris, sp);
        let b = bvh::build(&s);
        let tg = targets(&s, &mut rng);
        let mut count = 0;
        for _ in 0..1500 {
            let o = rng.vec(-15.0 * scale, 20.0 * scale) + Vec3::splat(shift - 3.0 * scale);
            let d = tg[(rng.next_u64() % tg.len() as u64) as usize] - o;
            let Some(h) = b.closest(&s, o, d, f32::MAX) else {
                continue;
            };
            // A surface point of the primitive hit (spheres: a random one) and its normal.
            let (p, err, ng, radius) = if h.prim & SPHERE_BIT != 0 {
                let sph = &s.spheres[(h.prim & !SPHERE_BIT) as usize];
                let u = rng.dir();
                let (p, err) = robust::sphere_point(sph.center, u, sph.radius);
                (p, err, u, sph.radius)
            } else {
                let v = s.triangles[h.prim as usize].v;
                let (p, err) = robust::triangle_point(&v, h.bary.x, h.bary.y);
                (p, err, brdfwave::robust::triangle_normal(&v), 0.0)
            };
            // Leave from both sides of the surface.
            for n in [ng, -ng] {
                let origin = robust::offset_ray_origin(p, err, n);
                let mut d = rng.dir();
                if d.dot(n) < 0.0 {
                    d -= 2.0 * d.dot(n) * n;
                }
                if d.dot(n) < 1e-3 {
                    continue;
                }
                if let Some(h2) = b.closest(&s, origin, d, f32::MAX) {
                    if h2.prim == h.prim {
                        // Only a sphere left inwards may be hit again, on its far side
                        // (chord = 2r·cos >= 2e-3 r here).
                        assert!(
                            h.prim & SPHERE_BIT != 0 && n == -ng && h2.t > 1e-3 * radius,
                            "scale {scale}: self-intersection of prim {:#x} at t={} (p={p}, n={n})",
                            h.prim,
                            h2.t
                        );
                    }
                }
                count += 1;
            }
        }
        assert!(count > 1000, "scale {scale}: only {count} rays");
    }
}

// ---------------------------------------------------------------------------------------------
// Degenerate inputs

#[test]
fn empty_scene_hits_nothing() {
    let s = scene(vec![], vec![]);
    let b = bvh::build(&s);
    assert_eq!(b.nodes.len(), 1);
    assert!(b.prims.is_empty());
    let n = b.nodes[0];
    assert_eq!((n.left, n.left_count, n.right, n.right_count), (0, 0, 0, 0));
    assert!(b.closest(&s, Vec3::ZERO, Vec3::X, f32::MAX).is_none());
    assert!(!b.occluded(&s, Vec3::ZERO, Vec3::X, f32::MAX));
}

#[test]
fn single_primitives_and_zero_directions() {
    let mut rng = Rng::new(11);
    let tri = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    for s in [
        scene(vec![tri], vec![]),
        scene(vec![], vec![(Vec3::new(0.3, 0.3, 0.0), 0.5, false)]),
    ] {
        let b = bvh::build(&s);
        // Root is inner, left child the one-primitive leaf, right child absent.
        assert_eq!(b.nodes.len(), 1);
        let n = b.nodes[0];
        assert_eq!((n.left, n.left_count, n.right, n.right_count), (0, 1, 0, 0));
        let mut tally = Tally::default();
        for _ in 0..2000 {
            let o = rng.vec(-2.0, 2.0);
            let target = Vec3::new(rng.range(-0.2, 1.0), rng.range(-0.2, 1.0), 0.0);
            check(&s, &b, o, target - o, tmax_of(&mut rng, 5.0), &mut tally);
        }
        // Axis-aligned rays, and rays with zero components of both signs.
        for &d in &[
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(0.0, -0.0, 1.0),
            Vec3::new(-0.0, 0.0, -2.0),
        ] {
            let o = Vec3::new(0.25, 0.25, -3.0 * d.z.signum());
            assert!(check(&s, &b, o, d, f32::MAX, &mut tally).is_some());
        }
        for &d in &[Vec3::X, -Vec3::Y, Vec3::new(1.0, 1.0, 0.0)] {
            check(&s, &b, Vec3::new(-1.0, -1.0, 0.0), d, f32::MAX, &mut tally);
            check(&s, &b, Vec3::new(-1.0, 0.1, 0.1), d, f32::MAX, &mut tally);
        }
        // A zero direction hits nothing and does not panic.
        assert!(b
            .closest(&s, Vec3::new(0.2, 0.2, -1.0), Vec3::ZERO, f32::MAX)
            .is_none());
        assert!(!b.occluded(&s, Vec3::new(0.2, 0.2, -1.0), Vec3::ZERO, f32::MAX));
        assert!(tally.hits > 100, "{tally:?}");
    }
}

#[test]
fn coincident_and_degenerate_primitives() {
    let mut rng = Rng::new(12);
    let tri = [
        Vec3::new(-1.0, -1.0, 2.0),
        Vec3::new(1.0, -1.0, 2.0),
        Vec3::new(0.0, 1.0, 2.0),
    ];
    // 100 identical triangles (all centroids equal: median splits), zero-area triangles
    // (a point and a segment), identical spheres, and a few ordinary triangles.
    let mut tris = vec![tri; 100];
    tris.push([Vec3::ONE; 3]);
    tris.push([Vec3::ZERO, Vec3::ONE, Vec3::ONE * 2.0]);
    tris.extend(random_soup(&mut rng, 20, 3.0));
    let s = scene(tris, vec![(Vec3::new(0.0, 0.0, 4.0), 0.5, false); 20]);
    let b = bvh::build(&s);
    assert!(b.stats.median_splits > 0);
    assert!(b.stats.max_leaf_size <= bvh::MAX_LEAF);
    let mut tally = Tally::default();
    for _ in 0..2000 {
        let o = rng.vec(-3.0, 3.0) - Vec3::Z * 3.0;
        let target = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(2.0, 4.0),
        );
        check(&s, &b, o, target - o, tmax_of(&mut rng, 8.0), &mut tally);
    }
    // Identical primitives give equal t: one of them is reported (ties counted).
    assert!(tally.ties > 0 || tally.hits > 0);
    report("coincident", &b, &tally);
}

#[test]
fn pathological_distribution_keeps_depth_within_the_stack() {
    // Geometric spacing (x = 2^(i/2)) with sizes growing alike: binned SAH peels off the largest
    // triangles at every level, so without the depth limit the tree would be ~100 levels deep.
    let mut rng = Rng::new(13);
    let tris: Vec<[Vec3; 3]> = (0..400)
        .map(|i| {
            let x = 2.0f32.powf(i as f32 * 0.5 - 100.0);
            let s = x * 0.05;
            [
                Vec3::new(x, -s, -s),
                Vec3::new(x + s, s, 0.0),
                Vec3::new(x, 0.0, s),
            ]
        })
        .collect();
    let s = scene(tris, vec![]);
    let b = bvh::build(&s);
    assert!(b.stats.max_depth <= MAX_DEPTH, "{}", b.stats);
    assert!(
        b.stats.median_splits > 0,
        "the depth limit was not reached: {}",
        b.stats
    );
    let mut tally = Tally::default();
    for i in 0..400 {
        let v = s.triangles[i].v;
        let c = (v[0] + v[1] + v[2]) / 3.0;
        // Along the x axis from before the first triangle, and from random points.
        check(
            &s,
            &b,
            Vec3::new(-1.0, c.y, c.z),
            Vec3::X,
            f32::MAX,
            &mut tally,
        );
        let o = rng.vec(-1.0, 1.0) * c.x * 2.0;
        check(&s, &b, o, c - o, f32::MAX, &mut tally);
    }
    report("geometric", &b, &tally);
}

// ---------------------------------------------------------------------------------------------
// Statistics and the GLSL twin

#[test]
fn print_stats_and_cpu_throughput() {
    let mut rng = Rng::new(14);
    for (name, s) in [
        (
            "soup 20k",
            scene(random_soup(&mut rng, 20_000, 10.0), vec![]),
        ),
        ("icosphere 5120", {
            let (v, f) = icosphere(4, Vec3::ZERO, 1.0);
            scene(
                f.iter().map(|t| [v[t[0]], v[t[1]], v[t[2]]]).collect(),
                vec![],
            )
        }),
        ("grid cube 24", scene(grid_cube(24, -1.0, 1.0), vec![])),
        (
            "spheres 2k",
            scene(vec![], random_spheres(&mut rng, 2000, 10.0)),
        ),
    ] {
        let t0 = std::time::Instant::now();
        let b = bvh::build(&s);
        let build = t0.elapsed();
        // Half the rays aimed at primitives (mostly hits), half in random directions.
        let tg = targets(&s, &mut rng);
        let rays: Vec<(Vec3, Vec3)> = (0..20_000)
            .map(|k| {
                let o = rng.vec(-12.0, 12.0);
                (
                    o,
                    if k % 2 == 0 {
                        rng.dir()
                    } else {
                        tg[(rng.next_u64() % tg.len() as u64) as usize] - o
                    },
                )
            })
            .collect();
        let t0 = std::time::Instant::now();
        let hits = rays
            .iter()
            .filter(|&&(o, d)| b.closest(&s, o, d, f32::MAX).is_some())
            .count();
        let dt = t0.elapsed().as_secs_f64();
        println!(
            "{name}: {} | build {:.1} ms | {:.2} Mrays/s closest (1 thread, dev profile), {hits} hits",
            b.stats,
            build.as_secs_f64() * 1e3,
            rays.len() as f64 / dt / 1e6
        );
        assert!(b.stats.max_leaf_size <= bvh::MAX_LEAF);
        assert!(b.stats.sah_cost > 0.0 && b.stats.sah_cost.is_finite());
        assert_eq!(b.nodes.len(), b.stats.inner_nodes);
        assert_eq!(b.prims.len(), s.triangles.len() + s.spheres.len());
        // Every primitive appears exactly once.
        let mut seen = b.prims.clone();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), b.prims.len());
    }
}

// ---------------------------------------------------------------------------------------------
// GLSL twin on a Vulkan device (lavapipe in CI): same hits as the CPU traversal

/// The probe kernel: per ray two vec4 in (o, tmax), (d, 0); out two uvec4:
/// (closest prim or ~0, t, b1, b2) and (any hit, offset_ray_origin(o, |o|·4e-7, d)). Its
/// bindings and push constant are declared by the header [`probe_interface`] generates.
const PROBE: &str = r#"#version 460
#extension GL_GOOGLE_include_directive : require
#include "bvh_probe/interface.glsl"
#include "bvh.glsl"
#include "robust.glsl"
layout(local_size_x = 64) in;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    vec4 o = rays[2u * i];
    vec4 d = rays[2u * i + 1u];
    Hit h;
    bool c = trace_closest(o.xyz, d.xyz, o.w, h);
    bool a = trace_any(o.xyz, d.xyz, o.w);
    vec3 q = offset_ray_origin(o.xyz, abs(o.xyz) * 4.0e-7, d.xyz);
    outp[2u * i] = uvec4(c ? h.prim : 0xFFFFFFFFu, floatBitsToUint(h.t), floatBitsToUint(h.bary.x), floatBitsToUint(h.bary.y));
    outp[2u * i + 1u] = uvec4(a ? 1u : 0u, floatBitsToUint(q.x), floatBitsToUint(q.y), floatBitsToUint(q.z));
}
"#;

/// The probe's bindings in slot order: the rays, the results, then the scene as the renderer
/// binds it ([`interface::BVH_BINDINGS`]).
fn probe_bindings() -> Vec<ProbeBinding> {
    let own = |block, member, access| ProbeBinding::Storage {
        block,
        member,
        access,
        about: "",
    };
    let mut b = vec![
        own("Rays", "vec4 rays[]", "readonly"),
        own("Out", "uvec4 outp[]", "writeonly"),
    ];
    b.extend(interface::BVH_BINDINGS.map(ProbeBinding::Layout));
    b
}

/// The probe's generated interface: its bindings and `uint count` as its push constant.
fn probe_interface() -> String {
    let push = [interface::Field {
        name: "count",
        glsl: "uint",
        doc: "",
    }];
    interface::probe_glsl("BVH_PROBE_INTERFACE", &probe_bindings(), &push)
}

/// The probe compiled by the product's shader compiler (shaders as embedded in the build), with
/// `defines` (the renderer's [`brdfwave::gpu::bvh_defines`] for a tree, or none: the array
/// stack).
fn compile_probe(defines: &[(String, String)]) -> Vec<u32> {
    let generated = [("bvh_probe/interface.glsl".to_string(), probe_interface())];
    ShaderCompiler::new()
        .and_then(|c| c.with_source("bvh_probe.comp", PROBE))
        .and_then(|c| c.compile_generated("bvh_probe.comp", defines, &[], &generated))
        .map(|c| c.spirv)
        .unwrap_or_else(|e| panic!("shaders/bvh.glsl does not compile:\n{e:#}"))
}

#[test]
fn glsl_twin_compiles_for_vulkan() {
    assert!(compile_probe(&[]).len() > 100);
    let regs = [("BVH_STACK_REGS".to_string(), "8".to_string())];
    assert!(compile_probe(&regs).len() > 100);
}

/// Runs the probe over `rays` ((o, tmax), (d, 0) per ray) against the scene as the renderer
/// uploads it (`gpu::scene_buffers`, texel views in the formats of `gpu::layout`).
fn run_probe(ctx: &Context, spirv: &[u32], s: &Scene, b: &Bvh, rays: &[[f32; 4]]) -> Vec<[u32; 4]> {
    use brdfwave::gpu::layout::{Binding, Kind};
    let storage = raw::BufferUsageFlags::STORAGE_BUFFER;
    let n = rays.len() / 2;
    let inp = ctx.create_buffer_with_data("rays", rays, storage).unwrap();
    let out = ctx
        .create_buffer(
            "out",
            (n * 32) as u64,
            storage,
            brdfwave::vk::MemoryLocation::GpuOnly,
        )
        .unwrap();
    let scene_data: [(Binding, Vec<u8>); 4] = [
        (Binding::BvhNodes, scene_buffers::bvh_nodes(b).to_vec()),
        (Binding::BvhPrims, bytemuck::cast_slice(&b.prims).to_vec()),
        (
            Binding::Triangles,
            bytemuck::cast_slice(&scene_buffers::triangle_data(s)).to_vec(),
        ),
        (
            Binding::Spheres,
            bytemuck::cast_slice(&scene_buffers::sphere_data(s)).to_vec(),
        ),
    ];
    assert!(scene_data.iter().map(|d| d.0).eq(interface::BVH_BINDINGS));
    let mut bufs = Vec::new();
    let mut views = Vec::new();
    for (binding, bytes) in &scene_data {
        let Kind::ReadImage(format) = binding.kind() else {
            panic!("{binding:?} is a texel buffer in the renderer")
        };
        let buf = ctx
            .create_buffer_with_data(binding.name(), bytes, binding.usage())
            .unwrap();
        views.push(ctx.create_buffer_view(&buf, format).unwrap());
        bufs.push(buf);
    }
    let kinds: Vec<_> = probe_bindings()
        .iter()
        .map(|b| b.descriptor_type())
        .collect();
    let p = ctx
        .create_compute_pipeline_with("bvh_probe", spirv, &kinds, 4)
        .unwrap();
    let mut res = vec![Resource::Buffer(&inp), Resource::Buffer(&out)];
    res.extend(
        bufs.iter()
            .zip(&views)
            .map(|(b, &v)| Resource::Texels(b, v)),
    );
    let set = ctx.create_descriptor_set_with(&p, &res).unwrap();
    let mut rec = ctx.begin().unwrap();
    rec.bind(&p, set);
    rec.push_constants(&p, &(n as u32));
    rec.dispatch((n as u32).div_ceil(64), 1, 1);
    ctx.submit_and_wait(rec).unwrap();
    let result: Vec<[u32; 4]> = ctx.download(&out).unwrap();
    ctx.destroy_pipeline(p);
    for v in views {
        ctx.destroy_buffer_view(v);
    }
    for buf in bufs.into_iter().chain([inp, out]) {
        ctx.destroy_buffer(buf);
    }
    result
}

/// The probe's rays for scene `s`: random rays (half aimed at primitives), secondary rays from
/// surface points as the renderer makes them, and axis-aligned rays from grid points.
fn probe_rays(s: &Scene, b: &Bvh, rng: &mut Rng) -> Vec<(Vec3, Vec3, f32)> {
    let tg = targets(s, rng);
    let mut rays: Vec<(Vec3, Vec3, f32)> = Vec::new();
    for k in 0..20_000 {
        let o = rng.vec(-8.0, 8.0);
        let d = if k % 2 == 0 || tg.is_empty() {
            rng.dir()
        } else {
            tg[(rng.next_u64() % tg.len() as u64) as usize] - o
        };
        rays.push((o, d, tmax_of(rng, 10.0)));
    }
    // Secondary rays as the renderer makes them: from surface points (offset along the
    // normal, and raw) in random directions, spheres included.
    for k in 0..4000 {
        let (o, d, tmax) = rays[k];
        let Some(h) = b.closest(s, o, d, tmax) else {
            continue;
        };
        let (p, err, n) = if h.prim & SPHERE_BIT != 0 {
            let sph = &s.spheres[(h.prim & !SPHERE_BIT) as usize];
            let u = (o + d * h.t - sph.center).normalize();
            let (p, err) = robust::sphere_point(sph.center, u, sph.radius);
            (p, err, u)
        } else {
            let v = s.triangles[h.prim as usize].v;
            let (p, err) = robust::triangle_point(&v, h.bary.x, h.bary.y);
            (p, err, brdfwave::robust::triangle_normal(&v))
        };
        let n = if k % 2 == 0 { n } else { -n };
        let mut dir = rng.dir();
        if dir.dot(n) < 0.0 {
            dir -= 2.0 * dir.dot(n) * n;
        }
        rays.push((robust::offset_ray_origin(p, err, n), dir, f32::MAX));
        rays.push((p, dir, f32::MAX));
    }
    // Axis-aligned rays from grid points (zero direction components, box-face origins).
    for k in 0..3000 {
        let o = Vec3::new(
            (rng.next_u64() % 9) as f32 * 0.25 - 1.0,
            (rng.next_u64() % 9) as f32 * 0.25 - 1.0,
            rng.range(-0.9, 0.9),
        );
        let mut d = [0.0f32; 3];
        d[k % 3] = if k % 2 == 0 { 1.0 } else { -1.0 };
        let o = match k % 3 {
            0 => Vec3::new(o.z, o.x, o.y),
            1 => Vec3::new(o.y, o.z, o.x),
            _ => o,
        };
        rays.push((o, Vec3::from(d), f32::MAX));
    }
    rays
}

/// Checks the GPU probe's answers `out` for `rays` against the CPU traversal; returns the hits,
/// and how many of them are bit-exact and how many only within 1e-5 in t.
fn compare_probe(
    name: &str,
    s: &Scene,
    b: &Bvh,
    rays: &[(Vec3, Vec3, f32)],
    out: &[[u32; 4]],
) -> (usize, usize, usize) {
    let (mut hits, mut exact, mut inexact) = (0, 0, 0);
    for (i, &(o, d, tmax)) in rays.iter().enumerate() {
        let [prim, t, b1, b2] = out[2 * i];
        let [any, qx, qy, qz] = out[2 * i + 1];
        let cpu = b.closest(s, o, d, tmax);
        let q = robust::offset_ray_origin(o, o.abs() * 4.0e-7, d);
        assert_eq!(
            [qx, qy, qz],
            [q.x.to_bits(), q.y.to_bits(), q.z.to_bits()],
            "{name}: offset_ray_origin({o}, |o|·4e-7, {d})"
        );
        assert_eq!(
            any == 1,
            b.occluded(s, o, d, tmax),
            "{name}: any-hit differs for o={o} d={d} tmax={tmax}"
        );
        match cpu {
            None => assert_eq!(
                prim,
                u32::MAX,
                "{name}: GPU hit {prim:#x} t={}, CPU none: o={o} d={d}",
                f32::from_bits(t)
            ),
            Some(h) => {
                assert_ne!(prim, u32::MAX, "{name}: GPU missed, CPU {h:?}: o={o} d={d}");
                hits += 1;
                let gt = f32::from_bits(t);
                let gb = Vec2::new(f32::from_bits(b1), f32::from_bits(b2));
                // The traversal order, and so the primitive kept among equal-t hits, is
                // the same on both sides.
                assert_eq!(
                    prim, h.prim,
                    "{name}: GPU hit {prim:#x} at {gt}, CPU {h:?}: o={o} d={d}"
                );
                if t == h.t.to_bits() && gb == h.bary {
                    exact += 1;
                } else {
                    // Tolerated on devices whose division or sqrt is not correctly rounded.
                    let rel = (gt - h.t).abs() / h.t.max(1e-30);
                    assert!(
                        rel < 1e-5,
                        "{name}: t differs: GPU {gt}, CPU {h:?}: o={o} d={d}"
                    );
                    inexact += 1;
                }
            }
        }
    }
    (hits, exact, inexact)
}

/// `n` parallel triangles at z from -0.95 to 0.95, each covering the square [-2, 2]² in x and y.
fn stacked_layers(n: usize) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|i| {
            let z = -0.95 + 1.9 * i as f32 / (n - 1) as f32;
            [
                Vec3::new(-5.0, -3.0, z),
                Vec3::new(5.0, -3.0, z),
                Vec3::new(0.0, 7.0, z),
            ]
        })
        .collect()
}

#[test]
fn glsl_traversal_matches_cpu_on_a_vulkan_device() {
    let ctx = Context::new(&ContextOptions::default()).expect("a Vulkan device (lavapipe)");
    let mut rng = Rng::new(15);
    let mut mixed = random_soup(&mut rng, 800, 5.0);
    let (v, f) = icosphere(2, Vec3::new(2.0, 1.0, -1.0), 1.5);
    mixed.extend(f.iter().map(|t| [v[t[0]], v[t[1]], v[t[2]]]));
    let mut sp = random_spheres(&mut rng, 80, 5.0);
    sp.push((Vec3::ZERO, 20.0, true));
    let scenes = [
        ("mixed", scene(mixed, sp)),
        (
            "grid cube (no spheres)",
            scene(grid_cube(8, -1.0, 1.0), vec![]),
        ),
        (
            "spheres only",
            scene(vec![], random_spheres(&mut rng, 200, 5.0)),
        ),
        ("empty", scene(vec![], vec![])),
        // Parallel triangles across z: a ray along z enters both children of every node on
        // its way, so its stack fills to the tree's depth.
        ("stacked layers", scene(stacked_layers(300), vec![])),
    ];
    // Each tree with the stack the renderer gives it (in registers: every tree here is shallow
    // enough) and with the array stack of deeper trees.
    let mut register_stacks = 0;
    for (name, s) in &scenes {
        let b = bvh::build(s);
        let rays = probe_rays(s, &b, &mut rng);
        let ray_data: Vec<[f32; 4]> = rays
            .iter()
            .flat_map(|&(o, d, t)| [[o.x, o.y, o.z, t], [d.x, d.y, d.z, 0.0]])
            .collect();
        let n = rays.len();
        let defines = brdfwave::gpu::bvh_defines(&b);
        register_stacks += defines.len();
        // ... and with the fewest registers that hold its deepest traversal.
        let tight = vec![(
            "BVH_STACK_REGS".to_string(),
            (b.stats.max_depth + 1).to_string(),
        )];
        for defines in [defines, tight, vec![]] {
            let stack = match defines.first() {
                Some((_, n)) => format!("{n} stack registers"),
                None => "array stack".to_string(),
            };
            let out = run_probe(&ctx, &compile_probe(&defines), s, &b, &ray_data);
            let name = &format!("{name}, {stack} (depth {})", b.stats.max_depth);
            let (hits, exact, inexact) = compare_probe(name, s, &b, &rays, &out);
            println!("{name} on {}: {n} rays, {hits} hits, {exact} bit-exact, {inexact} t/bary off in the last bits", ctx.device_name);
            // lavapipe's float division and sqrt are IEEE: everything must be bit-exact there.
            if ctx.device_name.contains("llvmpipe") {
                assert_eq!(
                    inexact, 0,
                    "{name}: results are not bit-exact on {}",
                    ctx.device_name
                );
            }
        }
    }
    assert_eq!(register_stacks, scenes.len(), "every tree here fits a register stack");
}
