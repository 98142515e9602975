//! The figures of `brdfwave brdf plot`, several materials at once: the polar plot of f in the
//! plane of incidence, the θh×θd slice of the BRDF Explorer (Burley, 2012) in Rusinkiewicz's
//! (1998) half/difference angles, the albedo against the angle of incidence, and the hemisphere
//! of f·cosθo. Each returns the figure and its data as CSV.

use super::{csv_field, series_csv, Figure, HeatMap, LineChart, Panel, Pixels, PolarChart};
use super::{Scale, Series};
use crate::brdf::common::luminance;
use crate::brdf::Brdf;
use glam::Vec3;

/// A material to plot: its legend label and its model.
pub struct Plotted<'a> {
    pub label: String,
    pub brdf: &'a dyn Brdf,
}

fn light(theta_i_deg: f64) -> Vec3 {
    let t = (theta_i_deg as f32).to_radians();
    Vec3::new(t.sin(), 0.0, t.cos())
}

/// The luminance of f(wi, wo) for wo at `deg` (−90 to 90) in the plane of incidence, every
/// half degree; the light at `theta_i_deg` on the +x side.
pub fn polar(materials: &[Plotted], theta_i_deg: f64, scale: Scale) -> (Figure, String) {
    let wi = light(theta_i_deg);
    let series: Vec<Series> = materials
        .iter()
        .map(|m| Series {
            label: m.label.clone(),
            points: (0..=360)
                .map(|k| {
                    let deg = -90.0 + 0.5 * k as f64;
                    let t = (deg as f32).to_radians();
                    let wo = Vec3::new(t.sin(), 0.0, t.cos());
                    (deg, luminance(m.brdf.eval(wi, wo)) as f64)
                })
                .collect(),
        })
        .collect();
    let csv = series_csv("theta_o_deg", &series);
    let fig = Figure::Polar(PolarChart {
        title: format!("BRDF in the plane of incidence, θi = {theta_i_deg}°"),
        value_label: "f (luminance, 1/sr)".into(),
        scale,
        light_deg: Some(theta_i_deg),
        series,
    });
    (fig, csv)
}

/// The directions of Rusinkiewicz's (1998) half/difference angles with φh = 0: the half vector
/// at θh in the xz plane, the difference vector at (θd, φd) about it.
pub fn from_half_diff(theta_h: f32, theta_d: f32, phi_d: f32) -> (Vec3, Vec3) {
    let d = Vec3::new(
        theta_d.sin() * phi_d.cos(),
        theta_d.sin() * phi_d.sin(),
        theta_d.cos(),
    );
    // Rotate by θh about y: the normal goes to the half vector.
    let (s, c) = theta_h.sin_cos();
    let wi = Vec3::new(d.x * c + d.z * s, d.y, -d.x * s + d.z * c);
    let h = Vec3::new(s, 0.0, c);
    let wo = 2.0 * wi.dot(h) * h - wi;
    (wi, wo)
}

const SLICE_CELLS: usize = 90;

/// The luminance of f over θh (x) and θd (y), 0 to 90° in 1° cells (centres), at φd = 90°
/// (the BRDF Explorer's image slice); directions below the horizon are blank (NaN).
pub fn slice(materials: &[Plotted], scale: Scale) -> (Figure, String) {
    let n = SLICE_CELLS;
    let centre = |k: usize| (k as f32 + 0.5) * 90.0 / n as f32;
    let mut csv = header("theta_h_deg,theta_d_deg", materials);
    let values: Vec<Vec<f64>> = materials
        .iter()
        .map(|m| {
            let mut v = Vec::with_capacity(n * n);
            for row in 0..n {
                // Row 0 at the top: the largest θd.
                let td = centre(n - 1 - row);
                for col in 0..n {
                    let (wi, wo) = from_half_diff(
                        centre(col).to_radians(),
                        td.to_radians(),
                        std::f32::consts::FRAC_PI_2,
                    );
                    v.push(if wi.z > 0.0 && wo.z > 0.0 {
                        luminance(m.brdf.eval(wi, wo)) as f64
                    } else {
                        f64::NAN
                    });
                }
            }
            v
        })
        .collect();
    for i in 0..n * n {
        let (row, col) = (i / n, i % n);
        csv.push_str(&format!("{},{}", centre(col), centre(n - 1 - row)));
        push_values(&mut csv, values.iter().map(|v| v[i]));
    }
    let fig = Figure::Heat(HeatMap {
        title: "BRDF slice at φd = 90° (BRDF Explorer)".into(),
        x_label: "θh (degrees)".into(),
        y_label: "θd (degrees)".into(),
        x_range: (0.0, 90.0),
        y_range: (0.0, 90.0),
        value_label: "f (luminance, 1/sr)".into(),
        scale,
        panels: panels(materials, values, n),
    });
    (fig, csv)
}

/// The albedo ρ(wi) = ∫ f(wi, wo) cosθo dωo (light fixed, by quadrature,
/// [`crate::brdf::validate::albedo_quadrature_light`]; delta lobes not seen), every 2° of θi
/// from 0 to 88°.
pub fn albedo(materials: &[Plotted], scale: Scale) -> (Figure, String) {
    let series: Vec<Series> = materials
        .iter()
        .map(|m| Series {
            label: m.label.clone(),
            points: (0..45)
                .map(|k| {
                    let deg = 2.0 * k as f64;
                    let a = crate::brdf::validate::albedo_quadrature_light(m.brdf, light(deg), 48);
                    (deg, a)
                })
                .collect(),
        })
        .collect();
    let csv = series_csv("theta_i_deg", &series);
    let fig = Figure::Lines(LineChart {
        title: "Directional albedo against the angle of incidence".into(),
        x_label: "θi (degrees)".into(),
        y_label: "albedo ρ(θi)".into(),
        x_scale: Scale::Linear,
        y_scale: scale,
        x_range: Some((0.0, 90.0)),
        series,
    });
    (fig, csv)
}

const HEMISPHERE_CELLS: usize = 96;

/// The luminance of f·cosθo over the hemisphere of wo seen from above (orthographic; x right,
/// y up), the light at `theta_i_deg` on the +x side; cells outside the disc are blank.
pub fn hemisphere(materials: &[Plotted], theta_i_deg: f64, scale: Scale) -> (Figure, String) {
    let n = HEMISPHERE_CELLS;
    let wi = light(theta_i_deg);
    let centre = |k: usize| -1.0 + (k as f32 + 0.5) * 2.0 / n as f32;
    let mut csv = header("wo_x,wo_y", materials);
    let values: Vec<Vec<f64>> = materials
        .iter()
        .map(|m| {
            (0..n * n)
                .map(|i| {
                    let (x, y) = (centre(i % n), -centre(i / n));
                    let r2 = x * x + y * y;
                    if r2 >= 1.0 {
                        return f64::NAN;
                    }
                    let wo = Vec3::new(x, y, (1.0 - r2).sqrt());
                    (luminance(m.brdf.eval(wi, wo)) * wo.z) as f64
                })
                .collect()
        })
        .collect();
    for i in 0..n * n {
        csv.push_str(&format!("{},{}", centre(i % n), -centre(i / n)));
        push_values(&mut csv, values.iter().map(|v| v[i]));
    }
    let fig = Figure::Heat(HeatMap {
        title: format!("f·cosθo over the hemisphere, θi = {theta_i_deg}° (light on the right)"),
        x_label: "wo x".into(),
        y_label: "wo y".into(),
        x_range: (-1.0, 1.0),
        y_range: (-1.0, 1.0),
        value_label: "f·cosθo (luminance, 1/sr)".into(),
        scale,
        panels: panels(materials, values, n),
    });
    (fig, csv)
}

fn header(coords: &str, materials: &[Plotted]) -> String {
    let mut s = coords.to_string();
    for m in materials {
        s.push(',');
        s.push_str(&csv_field(&m.label));
    }
    s.push('\n');
    s
}

/// Appends `,v` for each value (empty for a blank cell) and the line's end.
fn push_values(csv: &mut String, values: impl Iterator<Item = f64>) {
    for v in values {
        if v.is_finite() {
            csv.push_str(&format!(",{v}"));
        } else {
            csv.push(',');
        }
    }
    csv.push('\n');
}

fn panels(materials: &[Plotted], values: Vec<Vec<f64>>, n: usize) -> Vec<Panel> {
    materials
        .iter()
        .zip(values)
        .map(|(m, v)| Panel {
            label: m.label.clone(),
            width: n,
            height: n,
            pixels: Pixels::Values(v),
        })
        .collect()
}
