//! The pictures of `brdf fit`: each fit against the measurement in the plane of incidence, and
//! its error over θh × θd.

use super::ModelFit;
use crate::brdf::Brdf;
use crate::lights::luminance;
use crate::measured::merl::{self, MerlTable, PHI_D, THETA_D, THETA_H};
use crate::plot::{self, Figure, HeatMap, LineChart, Panel, Pixels, Scale, Series};
use glam::Vec3;
use image::{Rgb, RgbImage};

/// The angles of incidence of the plane-of-incidence plots, degrees.
pub const THETA_I: [f32; 4] = [0.0, 30.0, 60.0, 75.0];
/// The φd of the error slices, as cell indices (0.5°, 45.5°, 90.5°).
pub const SLICES: [usize; 3] = [0, 45, 90];

/// luminance(f) in the plane of incidence at θi, against the signed θo in degrees (wi on the +x
/// side, so the mirror direction is at −θi).
fn incidence_curve(f: impl Fn(Vec3, Vec3) -> Vec3, theta_i: f32) -> Vec<(f64, f64)> {
    let ti = theta_i.to_radians();
    let wi = Vec3::new(ti.sin(), 0.0, ti.cos());
    (-89..=89)
        .map(|deg| {
            let t = (deg as f32).to_radians();
            let wo = Vec3::new(t.sin(), 0.0, t.cos());
            (deg as f64, luminance(f(wi, wo)) as f64)
        })
        .collect()
}

/// Four panels (θi = 0, 30, 60, 75°): the measurement and the fit, luminance of f_r on a log
/// scale against θo.
pub fn incidence(table: &MerlTable, fit: &ModelFit) -> RgbImage {
    let label = fit.space.spec.label();
    let panels: Vec<RgbImage> = THETA_I
        .iter()
        .map(|&ti| {
            let series = [
                Series {
                    label: "measured".into(),
                    points: incidence_curve(|a, b| table.lookup(a, b), ti),
                },
                Series {
                    label: label.clone(),
                    points: incidence_curve(|a, b| fit.brdf.eval(a, b), ti),
                },
            ];
            let chart = LineChart {
                title: format!("plane of incidence, θi = {ti}° (mirror direction at θo = −{ti}°)"),
                x_label: "θo (degrees)".into(),
                y_label: "luminance of f (1/sr)".into(),
                x_scale: Scale::Linear,
                y_scale: Scale::Log,
                x_range: Some((-90.0, 90.0)),
                series: series.to_vec(),
            };
            plot::render_rgb(&Figure::Lines(chart)).expect("a line chart draws into a bitmap")
        })
        .collect();
    let (w, h) = (panels[0].width(), panels[0].height());
    let mut img = RgbImage::new(2 * w, 2 * h);
    for (k, p) in panels.iter().enumerate() {
        image::imageops::replace(
            &mut img,
            p,
            (k as u32 % 2 * w) as i64,
            (k as u32 / 2 * h) as i64,
        );
    }
    img
}

/// The data of [`incidence`]: `theta_i,theta_o,measured,fit` (degrees; luminance of f, 1/sr),
/// one row per θo of each panel.
pub fn incidence_csv(table: &MerlTable, fit: &ModelFit) -> String {
    let mut s = String::from("theta_i,theta_o,measured,fit\n");
    for &ti in &THETA_I {
        let measured = incidence_curve(|a, b| table.lookup(a, b), ti);
        let fitted = incidence_curve(|a, b| fit.brdf.eval(a, b), ti);
        for ((t, m), (_, f)) in measured.iter().zip(&fitted) {
            s.push_str(&format!("{ti},{t},{m},{f}\n"));
        }
    }
    s
}

/// The data of [`error_slices`]: `phi_d,theta_h_index,theta_d_index,theta_h,theta_d,error`
/// (degrees at the cell centres; the signed cube-root error, empty outside the domain).
pub fn error_slices_csv(table: &MerlTable, fit: &ModelFit, max_theta_deg: f32) -> String {
    let mut s = String::from("phi_d,theta_h_index,theta_d_index,theta_h,theta_d,error\n");
    for ip in SLICES {
        for ih in 0..THETA_H {
            for id in 0..THETA_D {
                let (th, td, pd) = merl::cell_centre(ih, id, ip);
                let e = cell_error(table, fit.brdf.as_ref(), (ih, id, ip), max_theta_deg);
                let e = e.map_or(String::new(), |e| e.to_string());
                let deg = |r: f32| r.to_degrees();
                s.push_str(&format!(
                    "{},{ih},{id},{},{},{e}\n",
                    deg(pd),
                    deg(th),
                    deg(td)
                ));
            }
        }
    }
    s
}

/// The signed cube-root error (fit − measured) of cell (ih, id, ip), the mean over channels;
/// `None` outside the domain (a direction beyond `max_theta_deg`, or a missing value).
pub fn cell_error(
    table: &MerlTable,
    b: &dyn Brdf,
    (ih, id, ip): (usize, usize, usize),
    max_theta_deg: f32,
) -> Option<f32> {
    let [Some(r), Some(g), Some(bl)] = table.cell(ih, id, ip) else {
        return None;
    };
    let (th, td, pd) = merl::cell_centre(ih, id, ip);
    let (wi, wo) = merl::directions(th, td, pd);
    let zmin = max_theta_deg.to_radians().cos();
    if wi.z < zmin || wo.z < zmin {
        return None;
    }
    let cbrt = |v: Vec3| (v.max(Vec3::ZERO) * wi.z).powf(1.0 / 3.0);
    let d = cbrt(b.eval(wi, wo)) - cbrt(Vec3::new(r, g, bl));
    Some(d.element_sum() / 3.0)
}

/// The largest |error| over the slices (the colour scale of [`error_slices`]).
pub fn max_slice_error(table: &MerlTable, b: &dyn Brdf, max_theta_deg: f32) -> f32 {
    let mut m = 0.0f32;
    for ip in SLICES {
        for ih in 0..THETA_H {
            for id in 0..THETA_D {
                if let Some(e) = cell_error(table, b, (ih, id, ip), max_theta_deg) {
                    m = m.max(e.abs());
                }
            }
        }
    }
    m
}

/// Diverging colour: blue where the fit is low, white at 0, red where it is high.
fn diverging(t: f32) -> Rgb<u8> {
    let t = t.clamp(-1.0, 1.0);
    let fade = |a: f32| (255.0 * (1.0 - a)).round() as u8;
    if t >= 0.0 {
        Rgb([255, fade(t), fade(t)])
    } else {
        Rgb([fade(-t), fade(-t), 255])
    }
}

/// The error slices: θd across (0..90°), the √θh index up (0 at the bottom: the specular
/// peak), one panel per φd of [`SLICES`], coloured by the signed cube-root error on the scale
/// ±`scale`; grey outside the domain.
pub fn error_slices(table: &MerlTable, fit: &ModelFit, max_theta_deg: f32, scale: f32) -> RgbImage {
    let scale = scale.max(1e-6);
    let panels = SLICES
        .iter()
        .map(|&ip| {
            // Row 0 at the top: the largest θh index.
            let pixels = (0..THETA_H * THETA_D)
                .map(|i| {
                    let (ih, id) = (THETA_H - 1 - i / THETA_D, i % THETA_D);
                    match cell_error(table, fit.brdf.as_ref(), (ih, id, ip), max_theta_deg) {
                        Some(e) => diverging(e / scale).0,
                        None => [190, 190, 190],
                    }
                })
                .collect();
            Panel {
                label: format!("φd = {}°", (ip as f32 + 0.5) * 180.0 / PHI_D as f32),
                width: THETA_D,
                height: THETA_H,
                pixels: Pixels::Rgb(pixels),
            }
        })
        .collect();
    let figure = Figure::Heat(HeatMap {
        title: format!(
            "{}: ∛(f cos) fit − measured; red high, blue low, ±{scale:.3}; grey outside the domain",
            fit.space.spec.label()
        ),
        x_label: "θd (degrees)".into(),
        y_label: "√θh index".into(),
        x_range: (0.0, 90.0),
        y_range: (0.0, THETA_H as f64),
        value_label: String::new(),
        scale: Scale::Linear,
        panels,
    });
    plot::render_rgb(&figure).expect("a heat map draws into a bitmap")
}
