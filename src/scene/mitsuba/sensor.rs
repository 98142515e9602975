//! `<sensor type="perspective">` (with its `<film>` and `<sampler>`) and `<integrator
//! type="path">` → the raw camera, film and integrator.
//!
//! * The camera is our pinhole: `position`, `target`, `up` from a `to_world` that is one
//!   `<lookat>` (the written points, exactly), or else from the matrix: position = M·0,
//!   target = M·(0, 0, 1), up = M·(0, 1, 0) − position (Mitsuba's camera looks along its local
//!   +z with +y up). The matrix must be a rotation, a uniform scale and a translation.
//! * `fov` is along `fov_axis` (Mitsuba's default `x`); it is turned into our vertical field of
//!   view with the film's aspect ratio. Without a `fov`, `focal_length` (Mitsuba's default
//!   "50mm") is a 35 mm camera's: the film's diagonal sees what a 36 × 24 mm frame's diagonal
//!   sees through a lens of that focal length.
//! * Depth: Mitsuba's `max_depth` counts path segments as we do (1: emitters seen directly, 2:
//!   direct light); its −1 ("unlimited", also its default) becomes our largest depth. Russian
//!   roulette: Mitsuba's `rr_depth` (default 5) is our `rr_start_depth` (both count the
//!   segments before the vertex where roulette may end the path); a `rr_depth` ≥ `max_depth`
//!   turns it off.

use super::doc::El;
use super::plugins::{sp, Props};
use super::values::to_world;
use crate::conventions::{MAX_DEPTH, MAX_FILM_SIZE};
use crate::scene::error::SceneError;
use crate::scene::schema::{Arr, RawCamera, RawFilm, RawIntegrator};
use crate::scene::spanned::{Cx, Sp};
use glam::DVec3;

/// Mitsuba's `rr_depth` default.
const MITSUBA_RR_DEPTH: u32 = 5;

pub(super) fn sensor(
    cx: &mut Cx,
    el: &El,
    integrator: &mut RawIntegrator,
) -> Result<(RawCamera, RawFilm), SceneError> {
    let thin_lens = el.attr("type") == Some("thinlens");
    if el.attr("type") != Some("perspective") && !thin_lens {
        let msg = format!(
            "{} is not supported (supported: perspective, thinlens)",
            el.describe()
        );
        return Err(cx.el_err(el, msg));
    }
    let mut p = Props::new(cx, el)?;
    // thinlens: the aperture (required, as in Mitsuba) and the distance in focus (Mitsuba's
    // default: the far clipping plane's, 10^4 unless given).
    let mut far_clip = 1e4;
    let lens = match thin_lens {
        false => None,
        true => {
            let Some(a) = p.take("aperture_radius") else {
                return Err(cx.el_err(
                    el,
                    "<sensor type=\"thinlens\"> needs a <float name=\"aperture_radius\">",
                ));
            };
            let f = p.take("focus_distance");
            Some((a, f))
        }
    };
    let fov_el = p.take("fov");
    let focal_el = p.take("focal_length");
    let axis_el = p.take("fov_axis");
    // The field of view, and the axis it is along.
    let (fov, axis) = match (fov_el, focal_el) {
        (Some(f), None) => {
            let fov = cx.float(f)?;
            // Checked as written, before it becomes the vertical field of view.
            if !(fov > 0.0 && fov < 180.0) {
                let msg = format!("fov {fov} is out of range: must be in (0, 180) degrees");
                return Err(cx.el_err(f, msg));
            }
            let axis = match axis_el {
                Some(a) => cx.attr(a, "value")?.to_string(),
                None => "x".to_string(),
            };
            (fov, axis)
        }
        (Some(_), Some(l)) => {
            return Err(cx.el_err(
                l,
                "give either a fov or a focal_length, not both (as Mitsuba)",
            ));
        }
        (None, focal) => {
            if let Some(a) = axis_el {
                let msg = "fov_axis goes with a fov: a focal_length (or Mitsuba's default, 50mm) gives the diagonal's field of view";
                return Err(cx.el_err(a, msg));
            }
            let mm = match focal {
                Some(l) => focal_length_mm(cx, l)?,
                None => 50.0,
            };
            (diagonal_fov(mm), "diagonal".to_string())
        }
    };
    for ignored in ["near_clip", "far_clip"] {
        if let Some(c) = p.take(ignored) {
            let v = cx.float(c)?;
            if ignored == "far_clip" {
                far_clip = v;
            }
            cx.warn(
                Some(c.span.clone()),
                &c.path,
                format!("{ignored} is ignored: brdfwave's camera has no clipping planes"),
            );
        }
    }
    let camera_el = p.take("to_world");
    let films = p.take_tag("film");
    let samplers = p.take_tag("sampler");
    p.finish(
        cx,
        match thin_lens {
            false => "fov, fov_axis, focal_length, to_world, near_clip, far_clip, film, sampler",
            true => "aperture_radius, focus_distance, fov, fov_axis, focal_length, to_world, near_clip, far_clip, film, sampler",
        },
    )?;

    let film = match films.as_slice() {
        [] => default_film(el),
        [f] => film(cx, f)?,
        [_, f, ..] => return Err(cx.el_err(f, "a second <film>")),
    };
    match samplers.as_slice() {
        [] => integrator.spp = Some(sp(el, 4)),
        [s] => sampler(cx, s, integrator)?,
        [_, s, ..] => return Err(cx.el_err(s, "a second <sampler>")),
    }

    let (w, h) = (film.width.value as f64, film.height.value as f64);
    let fov_el = fov_el.or(focal_el).unwrap_or(el);
    let half = (fov.to_radians() / 2.0).tan();
    let fov_y = match axis.as_str() {
        "y" => fov,
        "x" => 2.0 * (half * h / w).atan().to_degrees(),
        "diagonal" => 2.0 * (half * h / (w * w + h * h).sqrt()).atan().to_degrees(),
        "smaller" if w < h => 2.0 * (half * h / w).atan().to_degrees(),
        "smaller" => fov,
        "larger" if w > h => 2.0 * (half * h / w).atan().to_degrees(),
        "larger" => fov,
        other => {
            let msg = format!("fov_axis '{other}' is not one of x, y, diagonal, smaller, larger");
            return Err(cx.el_err(axis_el.unwrap_or(el), msg));
        }
    };
    let fov_y = sp(fov_el, fov_y);
    let mut camera = match camera_el {
        None => {
            // Mitsuba's identity camera: at the origin, looking along +z, +y up.
            let v = |x: [f64; 3]| sp(el, Arr(x));
            RawCamera {
                position: v([0.0; 3]),
                target: v([0.0, 0.0, 1.0]),
                up: Some(v([0.0, 1.0, 0.0])),
                fov_y,
                aperture_radius: None,
                focus_distance: None,
                mirror: None,
            }
        }
        Some(t) => camera(cx, t, fov_y)?,
    };
    if let Some((a, f)) = lens {
        camera.aperture_radius = Some(sp(a, cx.float(a)?));
        camera.focus_distance = Some(match f {
            Some(f) => sp(f, cx.float(f)?),
            None => sp(el, far_clip),
        });
    }
    Ok((camera, film))
}

fn camera(cx: &Cx, t: &El, fov_y: Sp<f64>) -> Result<RawCamera, SceneError> {
    let tw = to_world(cx, t)?;
    let v = |x: [f64; 3]| sp(t, Arr(x));
    if let Some([o, target, up]) = tw.lookat {
        return Ok(RawCamera {
            position: v(o),
            target: v(target),
            up: Some(v(up)),
            fov_y,
            aperture_radius: None,
            focus_distance: None,
            mirror: None,
        });
    }
    let m = tw.m;
    let a = glam::DMat3::from_mat4(m);
    let similar = crate::scene::geometry::Transform::Affine { a, t: DVec3::ZERO }
        .similarity_scale()
        .is_some();
    let det = a.determinant();
    if !similar || det == 0.0 {
        let msg = "the camera's to_world must be a rotation (or a mirror), a uniform scale and a translation (no shear)";
        return Err(cx.el_err(t, msg));
    }
    // A mirroring to_world (`<scale x="-1"/>` before a lookat) mirrors the image: the camera's
    // local x, which Mitsuba's image runs against, turns over while the view and up directions
    // do not.
    let mirror = (det < 0.0).then(|| sp(t, true));
    let o = m.transform_point3(DVec3::ZERO);
    Ok(RawCamera {
        position: v(o.to_array()),
        target: v(m.transform_point3(DVec3::Z).to_array()),
        up: Some(v(m.transform_vector3(DVec3::Y).to_array())),
        fov_y,
        aperture_radius: None,
        focus_distance: None,
        mirror,
    })
}

fn default_film(el: &El) -> RawFilm {
    RawFilm {
        width: sp(el, 768),
        height: sp(el, 576),
    }
}

fn film(cx: &mut Cx, f: &El) -> Result<RawFilm, SceneError> {
    if f.attr("type") != Some("hdrfilm") {
        return Err(cx.el_err(
            f,
            format!("{} is not supported (supported: hdrfilm)", f.describe()),
        ));
    }
    let mut p = Props::new(cx, f)?;
    let mut out = default_film(f);
    for (name, slot) in [("width", &mut out.width), ("height", &mut out.height)] {
        if let Some(e) = p.take(name) {
            let v = size(cx, e)?;
            // Checked here, by its own name: the field of view is computed from the aspect.
            if v == 0 || v > MAX_FILM_SIZE {
                let msg = format!("{name} {v} is out of range: must be in [1, {MAX_FILM_SIZE}]");
                return Err(cx.el_err(e, msg));
            }
            *slot = sp(e, v);
        }
    }
    let filters = p.take_tag("rfilter");
    for r in &filters {
        if r.attr("type") != Some("box") {
            let msg = format!(
                "{} is replaced by brdfwave's one-pixel box filter",
                r.describe()
            );
            cx.warn(Some(r.span.clone()), &r.path, msg);
        }
    }
    if filters.is_empty() {
        // Mitsuba's film defaults to a Gaussian filter: the same means, a softer image.
        let msg = "no <rfilter>: Mitsuba's default is a Gaussian (stddev 0.5), brdfwave filters with a one-pixel box (write <rfilter type=\"box\"/> for the same image in both)";
        cx.warn(Some(f.span.clone()), &f.path, msg);
    }
    for name in ["pixel_format", "component_format", "file_format"] {
        if let Some(e) = p.take(name) {
            let msg =
                format!("{name} is ignored: the output format follows the output file's extension");
            cx.warn(Some(e.span.clone()), &e.path, msg);
        }
    }
    p.finish(
        cx,
        "width, height, rfilter, pixel_format, component_format, file_format",
    )?;
    Ok(out)
}

/// A whole number from 0 to 2³²−1 (the loader checks the ranges).
fn size(cx: &Cx, e: &El) -> Result<u32, SceneError> {
    let t = cx.attr(e, "value")?.trim();
    if e.tag != "integer" {
        return Err(cx.el_err(
            e,
            format!(
                "'{}' must be an <integer>",
                e.attr("name").unwrap_or_default()
            ),
        ));
    }
    t.parse().map_err(|_| {
        cx.el_err(
            e,
            format!("'{t}' is not a whole number from 0 to 4294967295"),
        )
    })
}

fn sampler(cx: &mut Cx, s: &El, integrator: &mut RawIntegrator) -> Result<(), SceneError> {
    let kind = cx.attr(s, "type")?;
    let ours = match kind {
        "independent" => "independent",
        "multijitter" => "multijitter",
        "ldsampler" => "sobol",
        "stratified" | "orthogonal" => {
            let msg = format!(
                "{} is rendered with brdfwave's multi-jittered sampler",
                s.describe()
            );
            cx.warn(Some(s.span.clone()), &s.path, msg);
            "multijitter"
        }
        other => {
            let msg = format!("<sampler type=\"{other}\"> is not supported (supported: independent, multijitter, ldsampler as Sobol', and stratified, orthogonal as multijitter with a warning)");
            return Err(cx.el_err(s, msg));
        }
    };
    integrator.sampler = Some(sp(s, ours.to_string()));
    let mut p = Props::new(cx, s)?;
    integrator.spp = Some(sp(s, 4));
    if let Some(n) = p.take("sample_count") {
        integrator.spp = Some(sp(n, size(cx, n)?));
    }
    if let Some(n) = p.take("seed") {
        integrator.seed = Some(size(cx, n)?);
    }
    p.finish(cx, "sample_count, seed")
}

pub(super) fn integrator(cx: &mut Cx, el: &El, out: &mut RawIntegrator) -> Result<(), SceneError> {
    // Mitsuba's other unidirectional path tracers render what `path` renders where there are
    // no participating media (which brdfwave has none of): the volumetric ones, and the
    // path-replay ones, whose forward pass is `path`'s. They take the same properties.
    const PATH_TRACERS: [&str; 5] = ["path", "volpath", "volpathmis", "prb", "prbvolpath"];
    if !el.attr("type").is_some_and(|t| PATH_TRACERS.contains(&t)) {
        let msg = format!(
            "{} is not supported (supported: path, and volpath, volpathmis, prb and prbvolpath, which render as path without participating media)",
            el.describe()
        );
        return Err(cx.el_err(el, msg));
    }
    let mut p = Props::new(cx, el)?;
    let depth = |cx: &Cx, e: &El| -> Result<i64, SceneError> {
        let t = cx.attr(e, "value")?.trim();
        let d: i64 = t
            .parse()
            .map_err(|_| cx.el_err(e, format!("'{t}' is not a whole number")))?;
        if d < -1 || d == 0 || d > u32::MAX as i64 {
            return Err(cx.el_err(e, format!("{d} is out of range: -1 (unlimited) or >= 1")));
        }
        Ok(d)
    };
    let max_depth = match p.take("max_depth") {
        Some(e) => Some((e, depth(cx, e)?)),
        None => None,
    };
    let rr = match p.take("rr_depth") {
        Some(e) => (e, depth(cx, e)?),
        None => (el, MITSUBA_RR_DEPTH as i64),
    };
    if let Some(h) = p.take("hide_emitters") {
        out.hide_emitters = Some(cx.bool_of(h)?);
    }
    p.finish(cx, "max_depth, rr_depth, hide_emitters")?;
    match max_depth {
        Some((e, d)) if d >= 1 => out.max_depth = Some(sp(e, d as u32)),
        Some((e, _)) => unlimited(cx, e, out),
        None => unlimited(cx, el, out),
    }
    let max = out.max_depth.as_ref().map_or(u32::MAX, |d| d.value) as i64;
    let (rr_el, rr) = rr;
    if rr == -1 || rr >= max {
        out.russian_roulette = Some(false);
    } else {
        out.russian_roulette = Some(true);
        out.rr_start_depth = Some(sp(rr_el, rr as u32));
    }
    Ok(())
}

/// Without an `<integrator>`: Mitsuba's path tracer with its defaults.
pub(super) fn default_depth(cx: &mut Cx, out: &mut RawIntegrator) {
    out.max_depth = Some(Sp {
        span: None,
        value: MAX_DEPTH,
    });
    out.russian_roulette = Some(true);
    out.rr_start_depth = Some(Sp {
        span: None,
        value: MITSUBA_RR_DEPTH,
    });
    cx.warnings.push(format!(
        "warning: {}: no <integrator>: Mitsuba's default path tracer (max_depth -1, held to brdfwave's limit {}; Russian roulette from depth {MITSUBA_RR_DEPTH})",
        cx.file,
        MAX_DEPTH
    ));
}

fn unlimited(cx: &mut Cx, e: &El, out: &mut RawIntegrator) {
    out.max_depth = Some(sp(e, MAX_DEPTH));
    let msg = format!(
        "max_depth -1 (unlimited) is held to brdfwave's limit {}",
        MAX_DEPTH
    );
    cx.warn(Some(e.span.clone()), &e.path, msg);
}

/// The diagonal of a 35 mm camera's frame, 36 × 24 mm, in mm.
const FRAME_DIAGONAL_MM: f64 = 43.266_615_305_567_87;

/// The diagonal field of view, in degrees, of a 35 mm camera whose lens has focal length `mm`:
/// 2·atan(43.27 / 2f) (Mitsuba's `focal_length`: 50mm gives 46.8°, so 34.0° across a square
/// film).
fn diagonal_fov(mm: f64) -> f64 {
    2.0 * (FRAME_DIAGONAL_MM / (2.0 * mm)).atan().to_degrees()
}

/// A `focal_length` string, "50mm" or "50" (both millimetres, as Mitsuba reads them), > 0.
fn focal_length_mm(cx: &Cx, el: &El) -> Result<f64, SceneError> {
    let text = cx.attr(el, "value")?;
    let number = text.trim().strip_suffix("mm").unwrap_or(text.trim());
    match number.trim().parse::<f64>() {
        Ok(mm) if mm > 0.0 && mm.is_finite() => Ok(mm),
        _ => {
            let msg = format!(
                "focal_length '{}' is not a length in millimetres > 0 (such as \"50mm\")",
                crate::errors::excerpt(text)
            );
            Err(cx.el_err(el, msg))
        }
    }
}
