//! Lambert: the ideal diffuse reflector. Survey eq. 3, f_r = ρ/π.
//!
//! | parameter | unit | default | range | meaning | texture: GPU record |
//! |---|---|---|---|---|---|
//! | `albedo` | RGB, unitless | `[0.5, 0.5, 0.5]` | [0, 1] | hemispherical reflectance ρ (f_r = ρ/π, survey eq. 3) | `p[0].xyz` |
//!
//! Reciprocal and energy conserving for ρ ≤ 1; the directional albedo is ρ at every angle
//! (Lambert 1760; survey eq. 3). Sampling is cosine-weighted, so the sample weight is exactly ρ.
//!
//! GPU record: `p[0].xyz` = albedo.

use super::common::{diffuse_pdf, same_hemisphere_up, sample_diffuse};
use super::{Brdf, BrdfSample, Param, ParamError, ParamReader, Params, Representative};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;
use std::sync::Arc;

#[derive(Clone, Debug, PartialEq)]
pub struct Lambert {
    pub albedo: Vec3,
}

declare_model! {
    survey: "eq. 3";
    params: {
        ALBEDO = rgb("albedo", "RGB, unitless", [0.5; 3], (0.0, 1.0), "hemispherical reflectance ρ (f_r = ρ/π, survey eq. 3)").at(0);
    }
    representative: Representative::One(r#"model = "lambert", albedo = 0.8"#);
    record_codes: [];
}

pub fn parse(r: &mut ParamReader) -> Result<Arc<dyn Brdf>, ParamError> {
    let albedo = r.rgb_of(&ALBEDO)?;
    Ok(Arc::new(Lambert { albedo }))
}

/// f_r = ρ/π (survey eq. 3).
pub fn eval(m: &Lambert, wi: Vec3, wo: Vec3) -> Vec3 {
    if !same_hemisphere_up(wi, wo) {
        return Vec3::ZERO;
    }
    m.albedo * FRAC_1_PI
}

pub fn pdf(_m: &Lambert, given: Vec3, sampled: Vec3) -> f32 {
    diffuse_pdf(given, sampled)
}

pub fn sample(m: &Lambert, given: Vec3, _u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
    // f·cos/pdf = (ρ/π)·cos/(cos/π) = ρ, returned directly instead of as 0/0 at the horizon.
    sample_diffuse(given, u, |_| m.albedo)
}

impl_brdf!(Lambert {
    fn with_params(&self, v: &super::textured::ParamValues) -> Arc<dyn Brdf> {
        Arc::new(Lambert {
            albedo: v.rgb(&ALBEDO, self.albedo),
        })
    }
    fn pack(&self) -> Params {
        Params::from_vec4s([self.albedo.extend(0.0)])
    }
    fn scatters(&self) -> bool {
        self.albedo != Vec3::ZERO
    }
});
