//! The terms of He et al.'s BRDF (survey eqs. 11 and 15): the directional-diffuse term f_dd
//! without its Fresnel factor (geometry, shadowing and the series D), and the coherent
//! (specular) lobe's attenuation e^(−g_s)·S₁² and reflectance. GLSL twin:
//! `shaders/brdf/he/terms.glsl`.

use super::series::series;
use super::shadowing::{effective_sigma, shadow_s1};
use super::He;
use crate::brdf::common::fresnel_conductor;
use glam::Vec3;
use std::f32::consts::PI;

/// The directional-diffuse term without Fresnel, G·S·D/(π cosθi cosθo), for one wavelength
/// λ and effective roughness σ (tests compare it with the rough-limit table of §8).
pub fn dd_unit(m: &He, lambda: f32, sigma: f32, wi: Vec3, wo: Vec3) -> f32 {
    let v = wi + wo;
    let vz = wi.z + wo.z;
    if vz <= 1e-6 {
        return 0.0;
    }
    let vxy2 = v.x * v.x + v.y * v.y;
    let gg = v.dot(v) / vz;
    let geo = gg * gg;
    let s = shadow_s1(m.sigma0, m.tau, wi) * shadow_s1(m.sigma0, m.tau, wo);
    let kw = 2.0 * PI / lambda;
    let ks = kw * sigma * vz;
    let g = ks * ks;
    let c = 0.25 * kw * kw * vxy2 * m.tau * m.tau;
    // D/π = (π τ²/(4λ²)) Σ.
    let d_over_pi = PI * m.tau * m.tau / (4.0 * lambda * lambda) * series(g, c);
    geo * s * d_over_pi / (wi.z * wo.z).max(1e-30)
}

/// e^(−g_s)·S₁(θ)², the specular lobe's attenuation at incidence cosθ = w.z for wavelength λ
/// (σ evaluated at θo = θi).
pub fn specular_attenuation(m: &He, lambda: f32, w: Vec3) -> f32 {
    let sigma = effective_sigma(m, w, w);
    let s1 = shadow_s1(m.sigma0, m.tau, w);
    let a = 4.0 * PI * sigma * w.z / lambda;
    (-a * a).exp() * s1 * s1
}

/// e^(−g_s) per channel for the effective roughness σ at incidence cosθ = w.z.
pub(super) fn specular_exp(m: &He, sigma: f32, w: Vec3) -> Vec3 {
    let l = m.wavelengths;
    let k = 4.0 * PI * sigma * w.z;
    let a = Vec3::new(k / l.x, k / l.y, k / l.z);
    Vec3::new((-a.x * a.x).exp(), (-a.y * a.y).exp(), (-a.z * a.z).exp())
}

/// The delta lobe's reflectance F(cosθ)·e^(−g_s)·S₁² per channel.
pub fn specular_reflectance(m: &He, w: Vec3) -> Vec3 {
    let f = fresnel_conductor(w.z, m.ior, m.k);
    let sigma = effective_sigma(m, w, w);
    let s1 = shadow_s1(m.sigma0, m.tau, w);
    f * specular_exp(m, sigma, w) * (s1 * s1)
}
