//! The `[environment]` table checked: a constant `radiance`, or an environment `map` (an
//! equirectangular image, [`crate::envmap`]) with its `scale` and rotation (`transform`). The
//! image is read here, so a file that is missing, truncated, not an image, empty, too large or
//! holding a texel that is not a finite number ≥ 0 is refused while the scene loads, with the
//! file and the field named.

use super::error::SceneError;
use super::schema::RawEnvironment;
use super::spanned::{Cx, Sp};
use crate::envmap::EnvMap;
use glam::{DMat3, Mat3, Vec3};
use std::sync::Arc;

/// The environment of a scene: its constant radiance and its map, if any.
pub(super) fn environment(
    cx: &mut Cx,
    raw: Option<&RawEnvironment>,
) -> Result<(Vec3, Option<Arc<EnvMap>>), SceneError> {
    let Some(raw) = raw else {
        return Ok((Vec3::ZERO, None));
    };
    let radiance = match &raw.radiance {
        Some(r) => cx.radiance(r, "environment.radiance")?,
        None => Vec3::ZERO,
    };
    let Some(map) = &raw.map else {
        for (given, field) in [
            (raw.scale.as_ref().map(|s| s.span()), "scale"),
            (raw.transform.as_ref().map(|t| t.span()), "transform"),
        ] {
            if let Some(span) = given {
                let msg = format!("{field} applies only to an environment map (map = \"FILE\")");
                return Err(cx.err(span, &format!("environment.{field}"), msg));
            }
        }
        return Ok((radiance, None));
    };
    if let Some(r) = &raw.radiance {
        let msg = "give either radiance (a constant environment) or map (an image), not both";
        return Err(cx.err(r.span(), "environment.radiance", msg));
    }
    let scale = match &raw.scale {
        Some(s) => {
            let v = cx.finite(s.span(), "environment.scale", s.value)?;
            if v < 0.0 {
                let msg = format!("{v} is out of range: the scale must be >= 0");
                return Err(cx.err(s.span(), "environment.scale", msg));
            }
            v
        }
        None => 1.0,
    };
    let to_world = match &raw.transform {
        Some(t) => rotation(cx, t)?,
        None => Mat3::IDENTITY,
    };
    let path = super::geometry::mesh_path(cx, &map.value);
    let field = "environment.map";
    let stored = super::images::read(cx, map.span(), field, &path)?;
    // A PNG holds sRGB codes: the map is radiance, so they are decoded.
    let mut img = stored.image;
    if stored.srgb {
        img.decode_srgb();
    }
    let m = EnvMap::new(
        path.clone(),
        img.width,
        img.height,
        img.data,
        scale,
        to_world,
    )
    .map_err(|e| {
        let msg = format!("environment map '{}': {e}", path.display());
        cx.err(map.span(), field, msg)
    })?;
    if m.luminance_integral <= 0.0 {
        cx.warn(
            map.span(),
            field,
            format!("the environment map '{}' is black", path.display()),
        );
    }
    Ok((radiance, Some(Arc::new(m))))
}

/// The map's `transform`: a rotation (a translation is allowed and has no effect on a map at
/// infinity); a scale, shear or mirror is refused.
fn rotation(cx: &mut Cx, t: &Sp<super::schema::RawTransform>) -> Result<Mat3, SceneError> {
    let xf = super::transform::transform(cx, "environment", t, super::schema::Sides::Winding)?;
    let (a, _) = xf.affine();
    let dev = (a.transpose() * a - DMat3::IDENTITY)
        .to_cols_array()
        .iter()
        .fold(0.0f64, |m, x| m.max(x.abs()));
    if dev > 1e-6 || a.determinant() <= 0.0 {
        let msg = "an environment map's transform must be a rotation (no scale, shear or mirror)";
        return Err(cx.err(t.span(), "environment.transform", msg));
    }
    Ok(a.as_mat3())
}
