//! The `scene_numbers` group: scene files with numbers near the f32 limit (see the
//! [`crate::stress`] module documentation).

use super::harness::{render_cpu, CaseResult, Env};
use super::rng::Rng;
use anyhow::Result;
use std::path::Path;

/// A scene file for checks of the number range: the camera at `position` looking at `target`
/// (TOML arrays), a `size`×`size` film, 2 samples per pixel of at most 3 bounces, and one grey
/// Lambertian material `m` for the `shapes` (`[[shapes]]` tables) to use. The random cases of
/// this group and the fixed regressions of the same number-range faults are written with it, so
/// that a regression reads as one case with its numbers written out.
pub fn numbers_scene(position: &str, target: &str, size: u32, shapes: &str) -> String {
    format!(
        r#"[camera]
position = {position}
target = {target}
fov_y = 40
[film]
width = {size}
height = {size}
[integrator]
spp = 2
max_depth = 3
[materials.m]
model = "lambert"
albedo = 0.5
{shapes}"#
    )
}

pub(super) fn case_scene_numbers(_env: &mut Env, seed: u64) -> Result<CaseResult> {
    let mut r = Rng::new(seed);
    let big = |r: &mut Rng| -> f32 {
        let v = match r.next_u64() % 4 {
            0 => f32::MAX,
            1 => f32::MAX * r.range(0.5, 1.0),
            2 => r.log_range(1e18, 3e38),
            _ => r.log_range(1e-38, 1e-18),
        };
        if r.next_u64() % 2 == 0 {
            v
        } else {
            -v
        }
    };
    let s = r.log_range(1e-30, 1e30);
    let v = |r: &mut Rng, big_p: bool| -> String {
        let mut c = [
            r.range(-1.0, 1.0) * s,
            r.range(-1.0, 1.0) * s,
            r.range(-1.0, 1.0) * s,
        ];
        if big_p {
            let i = (r.next_u64() % 3) as usize;
            c[i] = big(r);
        }
        format!("[{:e}, {:e}, {:e}]", c[0], c[1], c[2])
    };
    let kind = r.next_u64() % 4;
    let cam = v(&mut r, kind == 0);
    let target = v(&mut r, false);
    let tri = [v(&mut r, kind == 1), v(&mut r, kind == 1), v(&mut r, false)];
    let radius = if kind == 2 { big(&mut r).abs() } else { s };
    let emission = if kind == 3 { big(&mut r).abs() } else { 1.0 };
    let shapes = format!(
        r#"[[shapes]]
material = "m"
emission = [{emission:e}, {emission:e}, {emission:e}]
triangles = [[{}, {}, {}]]
[[shapes]]
material = "m"
sphere = {{ center = {}, radius = {radius:e} }}
"#,
        tri[0],
        tri[1],
        tri[2],
        v(&mut r, false)
    );
    let text = numbers_scene(&cam, &target, 6, &shapes);
    let loaded =
        std::panic::catch_unwind(|| crate::scene::load_str(&text, Path::new("stress.toml")));
    let scene = match loaded {
        Err(_) => return Ok(CaseResult::fail(1.0, format!("loading panicked:\n{text}"))),
        Ok(Err(e)) => {
            let msg = e.to_string();
            if msg.trim().is_empty() {
                return Ok(CaseResult::fail(
                    1.0,
                    format!("refused without a message:\n{text}"),
                ));
            }
            return Ok(CaseResult::ok(0.0));
        }
        Ok(Ok(s)) => s,
    };
    let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| render_cpu(&scene)));
    match out {
        Err(_) => Ok(CaseResult::fail(
            1.0,
            format!("the CPU render panicked:\n{text}"),
        )),
        Ok(o) => {
            let finite = o.mean.data.iter().flatten().all(|v| v.is_finite());
            if !finite {
                return Ok(CaseResult::fail(
                    1.0,
                    format!("a non-finite pixel:\n{text}"),
                ));
            }
            Ok(CaseResult::ok(0.0))
        }
    }
}
