//! Small line charts drawn into an RGB image with the `font8x8` bitmap font: log-log (the
//! benchmark's error against time) and linear-log (`brdf fit`'s lobes against the angle);
//! decade grid, tick labels, one coloured curve with markers per series and a legend.

use font8x8::UnicodeFonts;
use image::{Rgb, RgbImage};

/// One curve: its legend label and its (x, y) points; points that are not positive and finite
/// cannot be drawn on log axes and are left out.
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

const W: u32 = 960;
const H: u32 = 600;
const LEFT: i32 = 84;
const RIGHT: i32 = 250;
const TOP: i32 = 44;
const BOTTOM: i32 = 56;
const PALETTE: [[u8; 3]; 8] = [
    [31, 119, 180],
    [214, 39, 40],
    [44, 160, 44],
    [255, 127, 14],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [23, 190, 207],
];

/// Draws `series` on log-log axes spanning whole decades around their points.
pub fn log_log(title: &str, x_label: &str, y_label: &str, series: &[Series]) -> RgbImage {
    chart(title, x_label, y_label, XAxis::Log, series)
}

/// Draws `series` with a linear x axis over [`lo`, `hi`] (a grid line and label every `step`)
/// and a log y axis spanning whole decades around the points (the lobes of `brdf fit`).
pub fn lin_log(
    title: &str,
    x_label: &str,
    y_label: &str,
    (lo, hi, step): (f64, f64, f64),
    series: &[Series],
) -> RgbImage {
    chart(
        title,
        x_label,
        y_label,
        XAxis::Linear { lo, hi, step },
        series,
    )
}

/// The x axis of a chart.
#[derive(Clone, Copy)]
enum XAxis {
    Log,
    Linear { lo: f64, hi: f64, step: f64 },
}

fn chart(title: &str, x_label: &str, y_label: &str, xaxis: XAxis, series: &[Series]) -> RgbImage {
    let mut img = RgbImage::from_pixel(W, H, Rgb([255, 255, 255]));
    let x_ok = |v: f64| match xaxis {
        XAxis::Log => v.is_finite() && v > 0.0,
        XAxis::Linear { lo, hi, .. } => v.is_finite() && (lo..=hi).contains(&v),
    };
    let y_ok = |v: f64| v.is_finite() && v > 0.0;
    let pts: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(|&(x, y)| x_ok(x) && y_ok(y))
        .collect();
    let range = |vals: Vec<f64>| -> (i32, i32) {
        let lo = vals.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if !lo.is_finite() {
            return (0, 1);
        }
        let (a, b) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
        (a, b.max(a + 1))
    };
    let (x0, x1) = range(pts.iter().map(|p| p.0).collect());
    let (y0, y1) = range(pts.iter().map(|p| p.1).collect());
    let (pw, ph) = (W as i32 - LEFT - RIGHT, H as i32 - TOP - BOTTOM);
    let px = |x: f64| {
        let t = match xaxis {
            XAxis::Log => (x.log10() - x0 as f64) / (x1 - x0) as f64,
            XAxis::Linear { lo, hi, .. } => (x - lo) / (hi - lo),
        };
        LEFT + (t * pw as f64).round() as i32
    };
    let py =
        |y: f64| TOP + ph - ((y.log10() - y0 as f64) / (y1 - y0) as f64 * ph as f64).round() as i32;
    let grid = Rgb([225, 225, 225]);
    let minor = Rgb([242, 242, 242]);
    let black = Rgb([0, 0, 0]);
    // Grid: decades, and 2..9 within each (x: every step on a linear axis).
    let x_ticks: Vec<(f64, String)> = match xaxis {
        XAxis::Log => {
            for d in x0..x1 {
                for k in 2..10 {
                    let x = px(k as f64 * 10f64.powi(d));
                    line(&mut img, x, TOP, x, TOP + ph, minor, 1);
                }
            }
            (x0..=x1)
                .map(|d| (10f64.powi(d), decade_label(d)))
                .collect()
        }
        XAxis::Linear { lo, hi, step } => {
            let n = ((hi - lo) / step).floor().max(0.0) as i32;
            (0..=n)
                .map(|k| lo + k as f64 * step)
                .map(|x| (x, format!("{x}")))
                .collect()
        }
    };
    for d in y0..y1 {
        for k in 2..10 {
            let y = py(k as f64 * 10f64.powi(d));
            line(&mut img, LEFT, y, LEFT + pw, y, minor, 1);
        }
    }
    for (xv, label) in &x_ticks {
        let x = px(*xv);
        line(&mut img, x, TOP, x, TOP + ph, grid, 1);
        text(
            &mut img,
            x - 4 * label.len() as i32,
            TOP + ph + 8,
            label,
            black,
        );
    }
    for d in y0..=y1 {
        let y = py(10f64.powi(d));
        line(&mut img, LEFT, y, LEFT + pw, y, grid, 1);
        let label = decade_label(d);
        text(
            &mut img,
            LEFT - 8 - 8 * label.len() as i32,
            y - 4,
            &label,
            black,
        );
    }
    // Frame, title, axis labels.
    line(&mut img, LEFT, TOP, LEFT + pw, TOP, black, 1);
    line(&mut img, LEFT, TOP + ph, LEFT + pw, TOP + ph, black, 1);
    line(&mut img, LEFT, TOP, LEFT, TOP + ph, black, 1);
    line(&mut img, LEFT + pw, TOP, LEFT + pw, TOP + ph, black, 1);
    text(&mut img, LEFT, 12, title, black);
    text(&mut img, LEFT, TOP - 14, y_label, black);
    text(
        &mut img,
        LEFT + pw / 2 - 4 * x_label.len() as i32,
        H as i32 - 22,
        x_label,
        black,
    );
    // Curves and legend.
    for (i, s) in series.iter().enumerate() {
        let c = Rgb(PALETTE[i % PALETTE.len()]);
        let p: Vec<(i32, i32)> = s
            .points
            .iter()
            .filter(|&&(x, y)| x_ok(x) && y_ok(y))
            .map(|&(x, y)| (px(x), py(y)))
            .collect();
        for w in p.windows(2) {
            line(&mut img, w[0].0, w[0].1, w[1].0, w[1].1, c, 2);
        }
        for &(x, y) in &p {
            rect(&mut img, x - 2, y - 2, 5, 5, c);
        }
        let ly = TOP + 8 + 18 * i as i32;
        let lx = LEFT + pw + 16;
        rect(&mut img, lx, ly, 22, 4, c);
        text(&mut img, lx + 30, ly - 2, &s.label, black);
    }
    img
}

/// 10^d as a short label: 0.001 .. 1000 written out, 1e-7 style beyond.
fn decade_label(d: i32) -> String {
    match d {
        -3..=-1 => format!("{}", 10f64.powi(d)),
        0..=3 => format!("{}", 10i64.pow(d as u32)),
        _ => format!("1e{d}"),
    }
}

fn put(img: &mut RgbImage, x: i32, y: i32, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, c);
    }
}

fn rect(img: &mut RgbImage, x: i32, y: i32, w: i32, h: i32, c: Rgb<u8>) {
    for j in 0..h {
        for i in 0..w {
            put(img, x + i, y + j, c);
        }
    }
}

/// A line `width` pixels wide (a square brush along a DDA).
fn line(img: &mut RgbImage, x0: i32, y0: i32, x1: i32, y1: i32, c: Rgb<u8>, width: i32) {
    let n = (x1 - x0).abs().max((y1 - y0).abs()).max(1);
    for k in 0..=n {
        let t = k as f64 / n as f64;
        let x = (x0 as f64 + t * (x1 - x0) as f64).round() as i32;
        let y = (y0 as f64 + t * (y1 - y0) as f64).round() as i32;
        rect(
            img,
            x - (width - 1) / 2,
            y - (width - 1) / 2,
            width,
            width,
            c,
        );
    }
}

/// Text in the 8x8 bitmap font, top-left at (x, y).
pub fn text(img: &mut RgbImage, x: i32, y: i32, s: &str, c: Rgb<u8>) {
    for (i, ch) in s.chars().enumerate() {
        let glyph = font8x8::BASIC_FONTS
            .get(ch)
            .or_else(|| font8x8::LATIN_FONTS.get(ch))
            .unwrap_or([0; 8]);
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8 {
                if bits & (1 << col) != 0 {
                    put(img, x + 8 * i as i32 + col, y + row as i32, c);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curves_land_inside_the_frame_in_their_colour() {
        let s = vec![Series {
            label: "a".into(),
            points: vec![(0.1, 1.0), (1.0, 0.1), (10.0, 0.01), (f64::NAN, 1.0)],
        }];
        let img = log_log("t", "x", "y", &s);
        let c = Rgb(PALETTE[0]);
        // The middle point (1, 0.1) sits at the centre of the decades drawn.
        let (pw, ph) = (W as i32 - LEFT - RIGHT, H as i32 - TOP - BOTTOM);
        let (x, y) = (LEFT + pw / 2, TOP + ph / 2);
        assert_eq!(*img.get_pixel(x as u32, y as u32), c);
        // Nothing of the curve's colour left of or below the plot area (markers on the frame
        // reach 2 pixels over it); the legend swatch is to the right.
        let outside = img
            .enumerate_pixels()
            .filter(|(x, y, p)| **p == c && ((*x as i32) < LEFT - 2 || (*y as i32) > TOP + ph + 2))
            .count();
        assert_eq!(outside, 0);
    }

    #[test]
    fn linear_x_axis_maps_its_range_onto_the_plot_area() {
        let s = vec![Series {
            label: "a".into(),
            // (0, 1) is the middle of x in [-90, 90] and of the decades 0.1 .. 10; the point
            // outside the x range is left out.
            points: vec![(-90.0, 0.1), (0.0, 1.0), (90.0, 10.0), (120.0, 1.0)],
        }];
        let img = lin_log("t", "x", "y", (-90.0, 90.0, 30.0), &s);
        let c = Rgb(PALETTE[0]);
        let (pw, ph) = (W as i32 - LEFT - RIGHT, H as i32 - TOP - BOTTOM);
        assert_eq!(
            *img.get_pixel((LEFT + pw / 2) as u32, (TOP + ph / 2) as u32),
            c
        );
        let right_of_plot = img
            .enumerate_pixels()
            .filter(|(x, y, p)| {
                **p == c && (*x as i32) > LEFT + pw + 2 && (*y as i32) > TOP + 8 + 6
            })
            .count();
        assert_eq!(right_of_plot, 0, "the point at x = 120 was drawn");
    }
}
