//! Numerical-range regressions: scenes far from unit scale, coordinates and
//! radiance near the f32 limit. (The randomized versions run in `brdfwave stress`.)

mod common;

use brdfwave::output::RenderOutput;
use brdfwave::stress::{numbers_scene, transform_scene};
use common::*;
use glam::Vec3;

/// Largest relative difference of the per-channel means.
fn mean_rel_diff(a: &RenderOutput, b: &RenderOutput) -> f64 {
    let (ma, mb) = (a.mean.mean(), b.mean.mean());
    (0..3)
        .map(|c| (ma[c] - mb[c]).abs() / mb[c].abs().max(1e-30))
        .fold(0.0, f64::max)
}

/// The Cornell box scaled by 1e-6 .. 1e6 or moved 1e6 away renders the image of the original
/// (same seed) within 0.5% per channel mean, on both backends. With fixed ray offsets (256 ulps,
/// or 1/65536 near zero) it was 2.8% brighter at 1e-6 and at a 1e6 translation.
#[test]
fn the_cornell_box_renders_the_same_at_every_scale_and_translation() {
    // 65536 samples: one sample of the directly seen light moving across its edge (the f32
    // coordinates of a moved box are quantized) changes a channel mean by about 0.05 %.
    let base = scene("cornell-box.toml", 64, 64, 16, 6, 3);
    let ctx = context();
    let ref_cpu = render_cpu(&base);
    let (ref_gpu, _) = render_gpu(&ctx, &base);
    for &(scale, shift) in &[
        (1.0e-6f32, Vec3::ZERO),
        (1.0e-3, Vec3::ZERO),
        (1.0e3, Vec3::ZERO),
        (1.0e6, Vec3::ZERO),
        (1.0, Vec3::new(1.0e6, -1.0e6, 1.0e6)),
        (1.0e-3, Vec3::new(1.0e3, -1.0e3, 1.0e3)),
        (1.0e-6, Vec3::new(1.0e-3, -1.0e-3, 1.0e-3)),
        (1.0e6, Vec3::new(1.0e6, -1.0e6, 1.0e6)),
        // The ceiling and light near y = 0 while x and z are not: shadow rays were blocked by
        // the light itself (15 % darker) until they were shortened by SHADOW_EPSILON.
        (2.6374301e-2, Vec3::new(7.7047534, -13.986234, 23.44608)),
        (1.5884735e-1, Vec3::new(-31.117002, -65.342575, -113.66314)),
    ] {
        let s = transform_scene(&base, scale, shift);
        let cpu = render_cpu(&s);
        let (gpu, _) = render_gpu(&ctx, &s);
        for (name, out, reference) in [("cpu", &cpu, &ref_cpu), ("gpu", &gpu, &ref_gpu)] {
            assert_eq!(
                out.nonfinite_samples, 0,
                "{name} scale {scale} shift {shift}"
            );
            let d = mean_rel_diff(out, reference);
            eprintln!("{name}: scale {scale}, shift {shift}: {:.4}%", 100.0 * d);
            assert!(
                d < 0.005,
                "{name}: scale {scale}, shift {shift}: channel means differ by {:.3}%",
                100.0 * d
            );
        }
    }
    finish(ctx);
}

fn load_text(name: &str, text: &str) -> Result<brdfwave::scene::Scene, String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    std::fs::copy(
        repo().join("tests/data/icosphere.obj"),
        dir.path().join("icosphere.obj"),
    )
    .unwrap();
    brdfwave::scene::load(&path).map_err(|e| e.to_string())
}

/// The target of most scenes here.
const ORIGIN: &str = "[0.0, 0.0, 0.0]";
/// A sphere of radius 1 at the origin in the material `m` of [`numbers_scene`].
const UNIT_SPHERE: &str =
    "[[shapes]]\nmaterial = \"m\"\nsphere = { center = [0.0, 0.0, 0.0], radius = 1.0 }\n";

/// A camera 2e19 from its target is a valid f32 input (the squared distance overflowed, and it
/// was refused as "the target equals the position"); its basis is finite and unit.
#[test]
fn a_camera_far_from_its_target_is_accepted() {
    for d in [2.0e19f32, 1.0e30, 3.0e38] {
        let text = numbers_scene(&format!("[0.0, 0.0, {:e}]", -d), ORIGIN, 8, UNIT_SPHERE);
        let s = load_text("far.toml", &text).unwrap_or_else(|e| panic!("distance {d}: {e}"));
        let b = brdfwave::camera::CameraBasis::new(&s);
        assert_eq!(b.forward, Vec3::Z, "distance {d}");
        assert!(b.right.is_finite() && b.up.is_finite());
    }
    // Tiny distances too (the squared length underflowed).
    let text = numbers_scene(
        "[0.0, 0.0, -1e-25]",
        ORIGIN,
        8,
        "[[shapes]]\nmaterial = \"m\"\nsphere = { center = [0.0, 0.0, 1.0], radius = 0.5 }\n",
    );
    let s = load_text("near.toml", &text).expect("a camera 1e-25 from its target");
    assert_eq!(brdfwave::camera::CameraBasis::new(&s).forward, Vec3::Z);
    // A difference that overflows f32 is refused, saying so.
    let text = numbers_scene("[0.0, 0.0, -3e38]", "[0.0, 0.0, 3e38]", 8, UNIT_SPHERE);
    let e = load_text("over.toml", &text).unwrap_err();
    assert!(e.contains("overflows single precision"), "{e}");
}

/// An OBJ scaled by 1e30, or with vertices near 3e38, keeps every triangle (the f32 cross
/// product overflowed and real triangles were dropped as zero-area), with unit normals.
#[test]
fn huge_meshes_keep_their_triangles() {
    let obj = |scale: f32| {
        numbers_scene(
            &format!("[0.0, 0.0, {:e}]", -(4.0 * scale).min(3.0e38)),
            ORIGIN,
            8,
            &format!(
                "[[shapes]]\nmaterial = \"m\"\nobj = \"icosphere.obj\"\n\
                 transform = {{ scale = {scale:e} }}\n"
            ),
        )
    };
    for scale in [1.0f32, 1e-30, 1e20, 1e30, 1e38] {
        let s = load_text("obj.toml", &obj(scale)).unwrap_or_else(|e| panic!("scale {scale}: {e}"));
        assert_eq!(s.triangles.len(), 80, "scale {scale}: {:?}", s.warnings);
        for t in &s.triangles {
            let n = t.geometric_normal();
            assert!((n.length() - 1.0).abs() < 1e-5, "scale {scale}: normal {n}");
            assert!(t.area().is_finite() && t.area() > 0.0);
        }
        // It renders: no non-finite value anywhere.
        let out = render_cpu(&s);
        assert_eq!(out.nonfinite_samples, 0, "scale {scale}");
    }
    // Vertices near 3e38 in the file itself.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("big.obj"),
        "v 3.0e38 0 0\nv 0 3.0e38 0\nv 0 0 3.0e38\nf 1 2 3\n",
    )
    .unwrap();
    let text = numbers_scene(
        "[1e38, 1e38, 1e38]",
        ORIGIN,
        8,
        "[[shapes]]\nmaterial = \"m\"\nobj = \"big.obj\"\n",
    );
    std::fs::write(dir.path().join("big.toml"), &text).unwrap();
    let s = brdfwave::scene::load(&dir.path().join("big.toml")).expect("vertices near 3e38");
    assert_eq!(s.triangles.len(), 1, "{:?}", s.warnings);
    assert!((s.triangles[0].geometric_normal() - Vec3::ONE.normalize()).length() < 1e-6);
    // An edge that does not fit in f32 is refused with a message that says so.
    std::fs::write(
        dir.path().join("big.obj"),
        "v 3.0e38 0 0\nv -3.0e38 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let e = brdfwave::scene::load(&dir.path().join("big.toml"))
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(e.contains("longer than the single-precision range"), "{e}");
}

/// Environment radiance 1e20 (and up to 3e38) scales the image linearly on both backends: the
/// squares of such samples overflow f32, and the GPU film dropped them (an all-black image);
/// it now scales its per-pixel sums by a power of two when needed.
#[test]
fn huge_environment_radiance_scales_the_image_linearly() {
    let ctx = context();
    let mut base = scene("white-furnace.toml", 8, 8, 16, 4, 1);
    base.environment = Vec3::ONE;
    let ref_cpu = render_cpu(&base);
    let (ref_gpu, _) = render_gpu(&ctx, &base);
    for k in [1.0e20f32, 1.0e30, 3.0e38] {
        let mut s = base.clone();
        s.environment = Vec3::splat(k);
        let cpu = render_cpu(&s);
        let (gpu, _) = render_gpu(&ctx, &s);
        for (name, out, r) in [("cpu", &cpu, &ref_cpu), ("gpu", &gpu, &ref_gpu)] {
            assert_eq!(out.nonfinite_samples, 0, "{name} k={k}");
            for (p, q) in out.mean.data.iter().zip(&r.mean.data) {
                for c in 0..3 {
                    let want = q[c] as f64 * k as f64;
                    let e = (p[c] as f64 - want).abs() / want.max(1e-30);
                    assert!(e < 1e-5, "{name} k={k}: {} vs {want}", p[c]);
                }
            }
            assert!(out.variance.data.iter().flatten().all(|v| v.is_finite()));
        }
    }
    finish(ctx);
}

/// A ray origin made at a hit near an edge or a corner of a closed box, at any scale and far
/// from the origin, lies strictly inside the box (so a ray leaving it meets a face): the hit
/// point is moved towards its triangle's centroid before the offset along the normal. Without
/// that, a point on a face's edge could round onto the neighbouring face's plane, and a camera
/// inside a box 43 000 from the origin saw the environment through a corner (stress suite).
#[test]
fn ray_origins_near_the_edges_of_a_closed_box_stay_inside() {
    use brdfwave::robust::{offset_ray_origin, pull_inside, triangle_point};
    let mut rng = 0x2545_f491_4f6c_dd1du64;
    let mut uniform = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut checked = 0;
    for (lo, size) in [
        (Vec3::new(-230.64294, 15276.683, 41832.973), 2404.6895f32),
        (Vec3::splat(0.0), 1.0),
        (Vec3::new(1e6, -3e5, 2e6), 3.0),
        (Vec3::new(-1e-4, 2e-4, 5e-5), 1e-5),
    ] {
        let hi = lo + Vec3::splat(size);
        // The faces with inward normals, two triangles each.
        for axis in 0..3 {
            for side in [0, 1] {
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let corner = |a: bool, b: bool| {
                    let mut p = if side == 0 { lo } else { hi };
                    p[u] = if a { hi[u] } else { lo[u] };
                    p[v] = if b { hi[v] } else { lo[v] };
                    p
                };
                let mut n = Vec3::ZERO;
                n[axis] = if side == 0 { 1.0 } else { -1.0 };
                let quads = [
                    corner(false, false),
                    corner(true, false),
                    corner(true, true),
                    corner(false, true),
                ];
                for tri in [
                    [quads[0], quads[1], quads[2]],
                    [quads[0], quads[2], quads[3]],
                ] {
                    for k in 0..400 {
                        // Points on an edge or a vertex, or a hair inside.
                        let t = uniform();
                        let tiny = if k % 2 == 0 { 0.0 } else { 1e-7 * uniform() };
                        let (b1, b2) = match k % 4 {
                            0 => (t, tiny),
                            1 => (tiny, t),
                            2 => (t, 1.0 - t - tiny),
                            _ => [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)][k / 4 % 3],
                        };
                        let (b1, b2) = pull_inside(&tri, b1, b2);
                        let (p, err) = triangle_point(&tri, b1, b2);
                        let o = offset_ray_origin(p, err, n);
                        for c in 0..3 {
                            assert!(
                                lo[c] < o[c] && o[c] < hi[c],
                                "box {lo}..{hi}: origin {o} from b = ({b1}, {b2}) on {tri:?} is not inside"
                            );
                        }
                        checked += 1;
                    }
                }
            }
        }
    }
    assert_eq!(checked, 4 * 6 * 2 * 400);
}
