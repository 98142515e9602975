//! The fit's domain (a subsample of the MERL grid inside the grazing cut-off) and its loss
//! (see [`super`] for the choice).

use crate::brdf::Brdf;
use crate::measured::merl::{self, MerlTable, PHI_D, THETA_D, THETA_H};
use glam::Vec3;

/// One measured value the fit compares against.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    /// Toward the light, local frame.
    pub wi: Vec3,
    /// Toward the viewer.
    pub wo: Vec3,
    /// ∛(f_measured · cosθi), per channel.
    pub target: Vec3,
    /// Quadrature weight: the cell's share of the measure dωi dωo.
    pub weight: f32,
}

/// The strides along θh, θd and φd that give about `target` cells (θh twice as dense as the
/// other two: the specular peak lives there).
pub fn strides(target: usize) -> [usize; 3] {
    let full = (THETA_H * THETA_D * PHI_D) as f64;
    let s = (2.0 * full / target.max(1) as f64).cbrt().round().max(1.0) as usize;
    [s.div_ceil(2).max(1), s, s]
}

/// The samples of the fit: the centres of every `strides`-th cell with both directions within
/// `max_theta_deg` of the normal and no channel missing. Each sample's pair is turned about the
/// normal by its own φh (a golden-ratio sequence), so that a model with an azimuthal preference
/// cannot fit isotropic data better by aligning with φh = 0. The weight is the cell's measure,
/// dωi dωo = 4 cosθd sinθh sinθd dθh dφh dθd dφd (Rusinkiewicz 1998), with dθh from the √θh
/// spacing.
pub fn samples(table: &MerlTable, strides: [usize; 3], max_theta_deg: f32) -> Vec<Sample> {
    let zmin = max_theta_deg.to_radians().cos();
    let pick = |n: usize, s: usize| (0..n.div_ceil(s)).map(move |k| (k * s + s / 2).min(n - 1));
    let mut out = Vec::new();
    for ih in pick(THETA_H, strides[0]) {
        for id in pick(THETA_D, strides[1]) {
            for ip in pick(PHI_D, strides[2]) {
                let [Some(r), Some(g), Some(b)] = table.cell(ih, id, ip) else {
                    continue;
                };
                let (th, td, pd) = merl::cell_centre(ih, id, ip);
                let (wi, wo) = merl::directions(th, td, pd);
                if wi.z < zmin || wo.z < zmin {
                    continue;
                }
                let phi_h = std::f32::consts::TAU * (out.len() as f32 * 0.618_034).fract();
                let (s, c) = phi_h.sin_cos();
                let turn = |w: Vec3| Vec3::new(c * w.x - s * w.y, s * w.x + c * w.y, w.z);
                // dθh/dt for θh = (π/2) t², t = (ih + ½)/90.
                let dtheta_h = std::f32::consts::PI * (ih as f32 + 0.5) / THETA_H as f32;
                let weight = 4.0 * td.cos() * th.sin() * td.sin() * dtheta_h;
                out.push(Sample {
                    wi: turn(wi),
                    wo: turn(wo),
                    target: (Vec3::new(r, g, b) * wi.z).powf(1.0 / 3.0),
                    weight: weight.max(0.0),
                });
            }
        }
    }
    out
}

/// Which channels the loss compares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channels {
    All,
    One(usize),
}

/// The loss of a candidate: the weighted RMS, over the samples (and channels), of
/// ∛(f_fit cosθi) − ∛(f_measured cosθi). Non-finite model values count as the largest error
/// a sample can have in this metric's units (1 per unit weight), so the optimiser moves away.
pub fn loss(b: &dyn Brdf, samples: &[Sample], channels: Channels) -> f64 {
    let mut sum = 0.0f64;
    let mut wsum = 0.0f64;
    for s in samples {
        let f = b.eval(s.wi, s.wo);
        let fit = (f.max(Vec3::ZERO) * s.wi.z).powf(1.0 / 3.0);
        let d = fit - s.target;
        let e2 = match channels {
            Channels::All => d.length_squared() as f64 / 3.0,
            Channels::One(c) => (d[c] * d[c]) as f64,
        };
        sum += s.weight as f64 * if e2.is_finite() { e2 } else { 1e6 };
        wsum += s.weight as f64;
    }
    if wsum > 0.0 {
        (sum / wsum).sqrt()
    } else {
        0.0
    }
}
