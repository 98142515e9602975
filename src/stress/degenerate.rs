//! The `degenerate` group: zero-area, sliver, duplicate and extreme primitives added to the
//! Cornell box (see the [`crate::stress`] module documentation).

use super::geometry::flat_triangle;
use super::harness::{backend_name, render_cpu, render_on, small, CaseResult, Env};
use super::rng::Rng;
use crate::scene::Scene;
use anyhow::Result;
use glam::Vec3;

/// What [`degenerate_item`] adds: its kind, a triangle or a sphere (centre, radius, inward).
type DegenerateItem = (&'static str, Option<[Vec3; 3]>, Option<(Vec3, f32, bool)>);

/// One degenerate addition to the Cornell box (millimetres, the box spans 0..556).
fn degenerate_item(r: &mut Rng, scene: &Scene) -> DegenerateItem {
    let p = |r: &mut Rng| {
        Vec3::new(
            r.range(0.0, 556.0),
            r.range(0.0, 548.0),
            r.range(0.0, 559.0),
        )
    };
    let existing =
        |r: &mut Rng| scene.triangles[(r.next_u64() % scene.triangles.len() as u64) as usize].v;
    match r.next_u64() % 7 {
        0 => {
            let (a, b) = (p(r), p(r));
            let t = *r.pick(&[0.0f32, 1.0, 0.5, 2.0, -1.0, 1e-7]);
            let v = if r.next_u64() % 2 == 0 {
                [a, a, a]
            } else {
                [a, b, a + (b - a) * t]
            };
            ("zero-area", Some(v), None)
        }
        1 => {
            let (a, b) = (p(r), p(r));
            let n = (b - a).cross(p(r) - a).normalize_or_zero();
            let eps = r.log_range(1e-12, 1e-3);
            let m = a + (b - a) * r.f() + n * (eps * (b - a).length());
            ("sliver", Some([a, b, m]), None)
        }
        2 => {
            let mut v = existing(r);
            if r.next_u64() % 2 == 0 {
                v.swap(1, 2);
            }
            ("duplicate triangle", Some(v), None)
        }
        3 => {
            let (a, b) = (p(r), p(r));
            ("duplicate vertex", Some([a, b, a]), None)
        }
        4 => {
            // Coplanar and overlapping: an existing face moved within its own plane and
            // shrunk or grown about its centroid.
            let v = existing(r);
            let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
            let shift = e1 * r.range(-0.5, 0.5) + e2 * r.range(-0.5, 0.5);
            let c = (v[0] + v[1] + v[2]) / 3.0;
            let k = r.range(0.2, 2.0);
            (
                "coplanar overlap",
                Some(v.map(|x| c + (x - c) * k + shift)),
                None,
            )
        }
        5 => {
            let radius = (556.0 * r.log_range(10.0, 1e35) as f64).min(3e38) as f32;
            let center = match r.next_u64() % 3 {
                0 => p(r),
                1 => scene.camera.position,
                _ => Vec3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0)) * radius,
            };
            (
                "huge sphere",
                None,
                Some((center, radius, r.next_u64() % 2 == 0)),
            )
        }
        _ => {
            let radius = 556.0 * r.log_range(1e-40, 1e-3);
            let center = match r.next_u64() % 3 {
                0 => p(r),
                1 => scene.camera.position,
                _ => existing(r)[0],
            };
            ("tiny sphere", None, Some((center, radius, false)))
        }
    }
}

/// Degenerate input never gives a NaN, an infinity or a panic, on either backend: the Cornell
/// box plus 1..8 of zero-area triangles (repeated or collinear vertices), slivers (height down
/// to 1e-12 of the base), duplicated faces (either winding), coplanar overlapping faces, huge
/// (to 3e38) and tiny (to 5e-38) spheres, any of them emitting, put straight into the scene
/// (the renderers' API takes them; the loader refuses or skips some). The same triangles as an
/// OBJ file with shared and repeated vertices go through the loader: it loads or refuses with
/// a message, never panics.
pub(super) fn case_degenerate(env: &mut Env, seed: u64) -> Result<CaseResult> {
    let mut r = Rng::new(seed);
    let mut scene = small(env.cornell()?, 16, 4, (seed & 0xffff) as u32);
    let base = scene.clone();
    let mut kinds = Vec::new();
    let mut obj = String::new();
    let mut obj_faces = String::new();
    let mut nv = 0;
    for _ in 0..1 + r.next_u64() % 8 {
        let (kind, tri, sphere) = degenerate_item(&mut r, &base);
        let emitter = if r.next_u64() % 3 == 0 {
            scene.emitters.push(crate::scene::Emitter {
                radiance: Vec3::splat(r.log_range(1e-3, 1e3)),
            });
            Some(scene.emitters.len() as u32 - 1)
        } else {
            None
        };
        let material = (r.next_u64() % scene.materials.len() as u64) as u32;
        if let Some(v) = tri {
            scene.triangles.push(flat_triangle(v, material, emitter));
            for x in v {
                obj += &format!("v {:e} {:e} {:e}\n", x.x, x.y, x.z);
            }
            // In the OBJ, sometimes also a face that repeats an index (zero area) or a quad
            // with a repeated corner, which the loader splits into triangles.
            obj_faces += &match r.next_u64() % 4 {
                0 => format!("f {} {} {}\n", nv + 1, nv + 1, nv + 2),
                1 => format!("f {} {} {} {}\n", nv + 1, nv + 2, nv + 3, nv + 3),
                _ => format!("f {} {} {}\n", nv + 1, nv + 2, nv + 3),
            };
            nv += 3;
        }
        if let Some((center, radius, inward)) = sphere {
            scene.spheres.push(crate::scene::Sphere {
                center,
                radius,
                material,
                emitter,
                inward,
                frame: None,
            });
        }
        kinds.push(match (tri, sphere) {
            (Some(v), _) => format!(
                "{kind} {v:?}{}",
                if emitter.is_some() { " emitting" } else { "" }
            ),
            (_, Some((c, rad, inw))) => format!(
                "{kind} centre {c} radius {rad:e}{}{}",
                if inw { " inward" } else { "" },
                if emitter.is_some() { " emitting" } else { "" }
            ),
            _ => kind.to_string(),
        });
    }
    let what = kinds.join("; ");
    for gpu in [false, true] {
        let out = render_on(env, &scene, gpu)?;
        let finite = out
            .mean
            .data
            .iter()
            .chain(&out.variance.data)
            .flatten()
            .all(|v| v.is_finite());
        if out.nonfinite_samples > 0 || !finite {
            return Ok(CaseResult::fail(
                out.nonfinite_samples as f64,
                format!(
                    "{}: {} non-finite samples ({:?}), image finite: {finite}; the Cornell box plus {what}",
                    backend_name(gpu),
                    out.nonfinite_samples,
                    out.nonfinite_by_stage.iter().filter(|s| s.1 > 0).collect::<Vec<_>>()
                ),
            ));
        }
    }
    if nv > 0 {
        // The loader path: the triangles as an OBJ with repeated vertex lines.
        if let Some(fail) = check_obj_loading(&format!("{obj}{obj_faces}"), &what)? {
            return Ok(fail);
        }
    }
    Ok(CaseResult::ok(0.0))
}

/// The degenerate triangles as an OBJ file (`obj`, described by `what`) in a scene: loading
/// must refuse it with a message or give a scene that renders finite; a failure otherwise.
fn check_obj_loading(obj: &str, what: &str) -> Result<Option<CaseResult>> {
    let dir = tempfile::tempdir()?;
    std::fs::write(dir.path().join("deg.obj"), obj)?;
    let text =
        "[camera]\nposition = [278.0, 273.0, -800.0]\ntarget = [278.0, 273.0, 0.0]\nfov_y = 40\n\
         [film]\nwidth = 8\nheight = 8\n[integrator]\nspp = 2\nmax_depth = 3\n\
         [materials.m]\nmodel = \"lambert\"\nalbedo = 0.5\n\
         [[shapes]]\nmaterial = \"m\"\nemission = [1.0, 1.0, 1.0]\nobj = \"deg.obj\"\n\
         [[shapes]]\nmaterial = \"m\"\nemission = [1.0, 1.0, 1.0]\n\
         triangles = [[[0.0, 0.0, 0.0], [556.0, 0.0, 0.0], [0.0, 0.0, 559.0]]]\n";
    let path = dir.path().join("deg.toml");
    std::fs::write(&path, text)?;
    let fail = |msg: String| Ok(Some(CaseResult::fail(1.0, msg)));
    match std::panic::catch_unwind(|| crate::scene::load(&path)) {
        Err(_) => fail(format!("loading an OBJ of {what} panicked")),
        Ok(Err(e)) if e.to_string().trim().is_empty() => {
            fail(format!("an OBJ of {what} was refused without a message"))
        }
        Ok(Err(_)) => Ok(None),
        Ok(Ok(s)) => {
            let out = render_cpu(&s);
            if out.nonfinite_samples > 0 || !out.mean.data.iter().flatten().all(|v| v.is_finite()) {
                return fail(format!(
                    "an OBJ of {what}: {} non-finite samples",
                    out.nonfinite_samples
                ));
            }
            Ok(None)
        }
    }
}
