//! BVH traversal against brute force, watertightness on closed meshes, spheres seen from
//! inside, degenerate inputs and the tree's statistics; the GLSL twin (`shaders/bvh.glsl`) is
//! checked in `tests/bvh_glsl.rs`.
//!
//! Run `cargo test --test bvh -- --nocapture` to see the BVH statistics of every scene.

mod common;

use brdfwave::bvh::{self, Bvh, Hit, MAX_DEPTH, SPHERE_BIT};
use brdfwave::robust;
use brdfwave::scene::shapes::icosphere;
use brdfwave::scene::Scene;
use brdfwave::stress::Rng;
use common::bvh::{
    grid_cube, mixed_scene, random_soup, random_spheres, scene, targets, tmax_of, RayRng,
};
use glam::{Vec2, Vec3};

// ---------------------------------------------------------------------------------------------
// Helpers

/// Closest hit over all primitives by the tie rule (the smallest t, then the smallest
/// primitive reference), and how many primitives are hit at that t.
fn brute_closest(s: &Scene, o: Vec3, d: Vec3, tmax: f32) -> (Option<Hit>, usize) {
    let tris = s.triangles.iter().enumerate().map(|(i, tri)| {
        bvh::intersect_triangle(o, d, &tri.v, tmax).map(|(t, bary)| Hit {
            t,
            prim: i as u32,
            bary,
        })
    });
    let spheres = s.spheres.iter().enumerate().map(|(i, sp)| {
        bvh::intersect_sphere(o, d, sp.center, sp.radius, tmax).map(|t| Hit {
            t,
            prim: i as u32 | SPHERE_BIT,
            bary: Vec2::ZERO,
        })
    });
    let hits: Vec<Hit> = tris.chain(spheres).flatten().collect();
    let best = hits
        .iter()
        .copied()
        .min_by(|a, b| a.t.total_cmp(&b.t).then(a.prim.cmp(&b.prim)));
    let at_best = best.map_or(0, |b| hits.iter().filter(|h| h.t == b.t).count());
    (best, at_best)
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
    let (want, at_best) = brute_closest(s, o, d, tmax);
    tally.rays += 1;
    match (got, want) {
        (None, None) => {}
        (Some(g), Some(w)) => {
            tally.hits += 1;
            if at_best > 1 {
                tally.ties += 1;
            }
            // The tie rule does not depend on the order of the tests: the very same primitive.
            assert_eq!(
                g, w,
                "o={o:?} d={d:?} ({at_best} primitives at the closest t)"
            );
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
    // Points on an inward room sphere, offset off it as the renderers offset them, rays going
    // inwards: the far side, never t ≈ 0; rays going outwards: nothing.
    let mut rng = Rng::new(3);
    for &(c, r) in &[
        (Vec3::ZERO, 1.0f32),
        (Vec3::new(100.0, -50.0, 20.0), 30.0),
        (Vec3::splat(1.0e3), 5.0),
    ] {
        let s = scene(vec![], vec![(c, r, true)]);
        let b = bvh::build(&s);
        for _ in 0..500 {
            let (p, err, u) = robust::sphere_point(c, r, rng.dir().as_dvec3());
            let inside = robust::offset_ray_origin(p, err, -u);
            let outside = robust::offset_ray_origin(p, err, u);
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
                .closest(&s, inside, d, f32::MAX)
                .unwrap_or_else(|| panic!("no hit from {inside} along {d}"));
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
            assert!(b.closest(&s, outside, -d, f32::MAX).is_none());
        }
    }
}

#[test]
fn mixed_scene_matches_brute_force() {
    let mut rng = Rng::new(4);
    let s = mixed_scene(&mut rng, 600, 60);
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
                let (p, err, u) =
                    robust::sphere_point(sph.center, sph.radius, rng.dir().as_dvec3());
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
                let found = b.closest(&s, origin, d, f32::MAX);
                // Told which primitive it leaves, the traversal skips that triangle (the CPU
                // reference's rays from a surface) and finds the same hit, bit for bit; a
                // sphere it does not skip.
                let leaving = b.closest_leaving(&s, origin, d, f32::MAX, h.prim);
                let bits = |h: &Option<Hit>| {
                    h.as_ref().map(|h| {
                        (
                            h.prim,
                            h.t.to_bits(),
                            h.bary.x.to_bits(),
                            h.bary.y.to_bits(),
                        )
                    })
                };
                assert_eq!(
                    bits(&found),
                    bits(&leaving),
                    "scale {scale}: prim {:#x}",
                    h.prim
                );
                let t = found.as_ref().map_or(1.0e3 * scale, |h| h.t);
                for tmax in [0.5 * t, 1.5 * t] {
                    assert_eq!(
                        b.occluded(&s, origin, d, tmax),
                        b.occluded_leaving(&s, origin, d, tmax, h.prim),
                        "scale {scale}: prim {:#x}",
                        h.prim
                    );
                }
                if let Some(h2) = found {
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
    // Identical primitives give equal t: the one with the smallest reference is reported.
    assert!(
        tally.ties > 0,
        "no ray met coincident primitives: {tally:?}"
    );
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
// Statistics

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
