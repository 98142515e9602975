//! The `[[lights]]` tables: point and directional lights ([`DeltaLight`]), each field checked
//! against its type (`scenes/README.md`).

use super::assemble::fmt_vec;
use super::error::SceneError;
use super::schema::RawLight;
use super::spanned::{Cx, Sp};
use super::DeltaLight;
use glam::Vec3;

/// The lights of the scene, in file order. A light of zero power is kept out (with a warning).
pub(super) fn delta_lights(
    cx: &mut Cx,
    raw: &[Sp<RawLight>],
) -> Result<Vec<DeltaLight>, SceneError> {
    let mut out = Vec::new();
    for (i, l) in raw.iter().enumerate() {
        let f = format!("lights[{i}]");
        let r = &l.value;
        let span = l.span().or(r.kind.span());
        let kind = r.kind.value.as_str();
        let (takes, others) = match kind {
            "point" => (
                "position and intensity",
                [
                    ("direction", r.direction.is_some()),
                    ("irradiance", r.irradiance.is_some()),
                ],
            ),
            "directional" => (
                "direction and irradiance",
                [
                    ("position", r.position.is_some()),
                    ("intensity", r.intensity.is_some()),
                ],
            ),
            other => {
                let msg =
                    format!("unknown light type {other:?}: expected \"point\" or \"directional\"");
                return Err(cx.err(r.kind.span(), &format!("{f}.type"), msg));
            }
        };
        if let Some((name, _)) = others.iter().find(|(_, given)| *given) {
            let msg = format!("a {kind} light has no '{name}' (it takes {takes})");
            return Err(cx.err(span, &format!("{f}.{name}"), msg));
        }
        let missing = |name: &str| {
            let msg = format!("a {kind} light needs '{name}' (it takes {takes})");
            cx.err(span.clone(), &format!("{f}.{name}"), msg)
        };
        let light = if kind == "point" {
            let p = r.position.as_ref().ok_or_else(|| missing("position"))?;
            let e = r.intensity.as_ref().ok_or_else(|| missing("intensity"))?;
            DeltaLight::Point {
                position: cx.v3(p, &format!("{f}.position"))?,
                intensity: cx.radiance(e, &format!("{f}.intensity"))?,
            }
        } else {
            let d = r.direction.as_ref().ok_or_else(|| missing("direction"))?;
            let e = r.irradiance.as_ref().ok_or_else(|| missing("irradiance"))?;
            let fd = format!("{f}.direction");
            let v = cx.v3(d, &fd)?;
            let direction = crate::robust::normalize_scaled(v);
            if direction == Vec3::ZERO {
                let msg = format!("{} has zero length: no direction", fmt_vec(v));
                return Err(cx.err(d.span(), &fd, msg));
            }
            DeltaLight::Directional {
                direction,
                irradiance: cx.radiance(e, &format!("{f}.irradiance"))?,
            }
        };
        let power = match &light {
            DeltaLight::Point { intensity, .. } => *intensity,
            DeltaLight::Directional { irradiance, .. } => *irradiance,
        };
        if power == Vec3::ZERO {
            cx.warn(
                span,
                &f,
                "the light is black (all channels 0): it is left out",
            );
            continue;
        }
        out.push(light);
    }
    Ok(out)
}
