//! The drawing of each [`Figure`](super::Figure) kind on any `plotters` backend (SVG or bitmap).

use super::{Figure, HeatMap, LineChart, Panel, Pixels, PolarChart, Scale, Series};
use anyhow::{anyhow, Result};
use plotters::chart::MeshStyle;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Tableau 10's first eight colours, one per series.
const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];
const FAMILY: &str = "sans-serif";

/// Makes the embedded font the one `plotters` draws "sans-serif" text with (once).
pub fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The font is embedded and known good; a failure would only leave text undrawn.
        let _ = plotters::style::register_font(FAMILY, FontStyle::Normal, super::FONT);
    });
}

fn err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("drawing the plot: {e}")
}

pub fn figure<DB: DrawingBackend>(backend: DB, fig: &Figure) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let root = backend.into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    match fig {
        Figure::Lines(c) => lines(&root, c)?,
        Figure::Polar(c) => polar(&root, c)?,
        Figure::Heat(h) => heat(&root, h)?,
    }
    root.present().map_err(err)
}

/// A tick label: plain for moderate values, else in exponent form (2.5e-3).
pub fn number(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if (1e-2..1e4).contains(&a) {
        // Three significant digits.
        let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.decimals$}");
        match s.contains('.') {
            true => s.trim_end_matches('0').trim_end_matches('.').to_string(),
            false => s,
        }
    } else {
        let s = format!("{v:.1e}");
        s.replace(".0e", "e")
    }
}

/// The axes of a line chart or a heat-map panel: the descriptions `x` and `y`, ticks written by
/// [`number`], tick labels of `size` and descriptions 2 larger.
fn axes<'m, 'a, 'b, X, Y, DB>(
    mesh: &'m mut MeshStyle<'a, 'b, X, Y, DB>,
    x: &str,
    y: &str,
    size: i32,
) -> &'m mut MeshStyle<'a, 'b, X, Y, DB>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
    DB: DrawingBackend,
{
    mesh.x_desc(x)
        .y_desc(y)
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .label_style((FAMILY, size))
        .axis_desc_style((FAMILY, size + 2))
}

/// [`number`] as a tick-label formatter.
fn tick(v: &f64) -> String {
    number(*v)
}

/// The caption's font size: 22, smaller for a title too long for the width (down to 11).
fn title_size<DB: DrawingBackend>(title: &str, area: &DrawingArea<DB, Shift>) -> u32 {
    let chars = title.chars().count().max(1) as u32;
    // DejaVu Sans averages about 0.55 em per character.
    (area.dim_in_pixel().0 * 9 / (5 * chars)).clamp(11, 22)
}

/// The drawable points of a series on these scales.
fn drawable(s: &Series, x: Scale, y: Scale) -> Vec<(f64, f64)> {
    let ok = |v: f64, sc: Scale| v.is_finite() && (sc == Scale::Linear || v > 0.0);
    s.points
        .iter()
        .copied()
        .filter(|&(a, b)| ok(a, x) && ok(b, y))
        .collect()
}

/// The range of `values` on `scale`: whole decades on a log axis, a little margin on a linear
/// one; (0, 1) or (0.1, 1) when there is nothing to draw.
fn range(values: impl Iterator<Item = f64>, scale: Scale) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    match scale {
        _ if lo > hi => match scale {
            Scale::Linear => (0.0, 1.0),
            Scale::Log => (0.1, 1.0),
        },
        Scale::Log => {
            let (a, b) = (lo.log10().floor(), hi.log10().ceil());
            (10f64.powf(a), 10f64.powf(if b > a { b } else { a + 1.0 }))
        }
        Scale::Linear => {
            let pad = if hi > lo { 0.05 * (hi - lo) } else { 0.5 };
            let lo = if lo >= 0.0 && lo - pad < 0.0 {
                0.0
            } else {
                lo - pad
            };
            (lo, hi + pad)
        }
    }
}

fn lines<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, c: &LineChart) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let pts: Vec<Vec<(f64, f64)>> = c
        .series
        .iter()
        .map(|s| drawable(s, c.x_scale, c.y_scale))
        .collect();
    let (x0, x1) = c
        .x_range
        .unwrap_or_else(|| range(pts.iter().flatten().map(|p| p.0), c.x_scale));
    let (y0, y1) = range(pts.iter().flatten().map(|p| p.1), c.y_scale);
    match (c.x_scale, c.y_scale) {
        (Scale::Linear, Scale::Linear) => lines_on(root, c, &pts, x0..x1, y0..y1),
        (Scale::Linear, Scale::Log) => lines_on(root, c, &pts, x0..x1, (y0..y1).log_scale()),
        (Scale::Log, Scale::Linear) => lines_on(root, c, &pts, (x0..x1).log_scale(), y0..y1),
        (Scale::Log, Scale::Log) => {
            lines_on(root, c, &pts, (x0..x1).log_scale(), (y0..y1).log_scale())
        }
    }
}

fn lines_on<DB: DrawingBackend, X, Y>(
    root: &DrawingArea<DB, Shift>,
    c: &LineChart,
    pts: &[Vec<(f64, f64)>],
    x: X,
    y: Y,
) -> Result<()>
where
    DB::ErrorType: 'static,
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(root)
        .caption(&c.title, (FAMILY, title_size(&c.title, root)))
        .margin(16)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(x, y)
        .map_err(err)?;
    axes(&mut chart.configure_mesh(), &c.x_label, &c.y_label, 15)
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(210, 210, 210))
        .draw()
        .map_err(err)?;
    for (k, (s, p)) in c.series.iter().zip(pts).enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        chart
            .draw_series(LineSeries::new(p.iter().copied(), colour.stroke_width(2)))
            .map_err(err)?
            .label(s.label.as_str())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        // Markers where the points are few enough to tell apart.
        if p.len() <= 40 {
            chart
                .draw_series(p.iter().map(|&q| Circle::new(q, 3, colour.filled())))
                .map_err(err)?;
        }
    }
    legend(&mut chart, !c.series.is_empty())
}

fn legend<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    any: bool,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    if !any {
        return Ok(());
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FAMILY, 15))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .draw()
        .map_err(err)
}

/// The radius (0 to 1) of `v` with the largest value `vmax`.
fn radius(v: f64, vmax: f64, scale: Scale) -> f64 {
    if !(v.is_finite() && v > 0.0 && vmax > 0.0) {
        return 0.0;
    }
    match scale {
        Scale::Linear => v / vmax,
        Scale::Log => (1.0 + (v / vmax).log10() / Scale::DECADES).max(0.0),
    }
}

fn polar<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, c: &PolarChart) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let area = root
        .titled(&c.title, (FAMILY, 22))
        .map_err(err)?
        .margin(10, 10, 10, 10);
    let (w, h) = area.dim_in_pixel();
    // Equal units on both axes: y spans −0.12 to 1.15, x what the width allows.
    let unit = h as f64 / 1.27;
    let half = w as f64 / unit / 2.0;
    let mut chart = ChartBuilder::on(&area)
        .build_cartesian_2d(-half..half, -0.12..1.15)
        .map_err(err)?;
    let vmax = c
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1))
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    let grey = RGBColor(200, 200, 200);
    let dir = |deg: f64, r: f64| {
        let t = deg.to_radians();
        (r * t.sin(), r * t.cos())
    };
    let arc = |r: f64| (0..=180).map(move |k| dir(k as f64 - 90.0, r));
    // Rings with their values, spokes every 15° with their angles, the surface.
    let rings: Vec<(f64, f64)> = match c.scale {
        Scale::Linear => [0.25, 0.5, 0.75, 1.0].map(|f| (f, f * vmax)).to_vec(),
        Scale::Log => (0..=Scale::DECADES as i32)
            .map(|d| (1.0 - d as f64 / Scale::DECADES, vmax * 10f64.powi(-d)))
            .filter(|r| r.0 > 0.0)
            .collect(),
    };
    let text = |s: String, at: (f64, f64), pos: Pos| {
        Text::new(s, at, TextStyle::from((FAMILY, 14).into_font()).pos(pos))
    };
    for &(r, v) in &rings {
        chart
            .draw_series(LineSeries::new(arc(r), grey))
            .map_err(err)?;
        chart
            .draw_series([text(
                number(v),
                (r, -0.02),
                Pos::new(HPos::Center, VPos::Top),
            )])
            .map_err(err)?;
    }
    for k in -6..=6 {
        let deg = 15.0 * k as f64;
        chart
            .draw_series(LineSeries::new([(0.0, 0.0), dir(deg, 1.0)], grey))
            .map_err(err)?;
        chart
            .draw_series([text(
                format!("{deg}°"),
                dir(deg, 1.06),
                Pos::new(HPos::Center, VPos::Center),
            )])
            .map_err(err)?;
    }
    chart
        .draw_series(LineSeries::new([(-1.0, 0.0), (1.0, 0.0)], BLACK))
        .map_err(err)?;
    if let Some(l) = c.light_deg {
        let blue = RGBColor(60, 60, 220);
        chart
            .draw_series(LineSeries::new(
                [(0.0, 0.0), dir(l, 1.0)],
                blue.stroke_width(2),
            ))
            .map_err(err)?
            .label("light")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], blue));
    }
    for (k, s) in c.series.iter().enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .map(|&(deg, v)| dir(deg, radius(v, vmax, c.scale)))
            .collect();
        chart
            .draw_series(LineSeries::new(pts, colour.stroke_width(2)))
            .map_err(err)?
            .label(s.label.as_str())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
    }
    chart
        .draw_series([text(
            format!(
                "radius: {} ({})",
                c.value_label,
                match c.scale {
                    Scale::Linear => "linear".to_string(),
                    Scale::Log => format!("log, {} decades", Scale::DECADES),
                }
            ),
            (-half + 0.02, 1.13),
            Pos::new(HPos::Left, VPos::Top),
        )])
        .map_err(err)?;
    legend(&mut chart, !c.series.is_empty())
}

/// Viridis (van der Walt and Smith, 2015) at nine stops, interpolated linearly.
pub fn viridis(t: f64) -> RGBColor {
    const STOPS: [[f64; 3]; 9] = [
        [68.0, 1.0, 84.0],
        [71.0, 44.0, 122.0],
        [59.0, 81.0, 139.0],
        [44.0, 113.0, 142.0],
        [33.0, 144.0, 141.0],
        [39.0, 173.0, 129.0],
        [92.0, 200.0, 99.0],
        [170.0, 220.0, 50.0],
        [253.0, 231.0, 37.0],
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    } * 8.0;
    let i = (t.floor() as usize).min(7);
    let f = t - i as f64;
    let c = |k: usize| (STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f).round() as u8;
    RGBColor(c(0), c(1), c(2))
}

/// The colour bar's range of the panels' values, and the position (0 to 1) of a value in it.
pub struct ColourScale {
    pub lo: f64,
    pub hi: f64,
    pub scale: Scale,
}

impl ColourScale {
    pub fn of(panels: &[Panel], scale: Scale) -> ColourScale {
        let values = panels.iter().flat_map(|p| match &p.pixels {
            Pixels::Values(v) => v.as_slice(),
            Pixels::Rgb(_) => &[],
        });
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for &v in values.filter(|v| v.is_finite() && (scale == Scale::Linear || **v > 0.0)) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if lo > hi {
            (lo, hi) = (if scale == Scale::Log { 0.1 } else { 0.0 }, 1.0);
        }
        if scale == Scale::Log {
            lo = lo.max(hi * 10f64.powf(-Scale::DECADES));
        }
        if hi <= lo {
            hi = if scale == Scale::Log {
                lo * 10.0
            } else {
                lo + 1.0
            };
        }
        ColourScale { lo, hi, scale }
    }

    /// Where `v` lies, 0 (at or below `lo`) to 1; NaN for a value that is not finite.
    pub fn position(&self, v: f64) -> f64 {
        match self.scale {
            _ if !v.is_finite() => f64::NAN,
            Scale::Linear => ((v - self.lo) / (self.hi - self.lo)).clamp(0.0, 1.0),
            Scale::Log if v <= 0.0 => 0.0,
            Scale::Log => ((v / self.lo).log10() / (self.hi / self.lo).log10()).clamp(0.0, 1.0),
        }
    }
}

fn heat<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, h: &HeatMap) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let area = root.titled(&h.title, (FAMILY, 22)).map_err(err)?;
    let (w, _) = area.dim_in_pixel();
    // The colour bar, only for panels of values (colour panels carry their own key).
    let bar = h
        .panels
        .iter()
        .any(|p| matches!(p.pixels, Pixels::Values(_)));
    let (panels, bar_area) = area.split_horizontally(w.saturating_sub(if bar { 140 } else { 0 }));
    let cs = ColourScale::of(&h.panels, h.scale);
    let cells = panels.split_evenly((1, h.panels.len().max(1)));
    for (p, a) in h.panels.iter().zip(&cells) {
        panel(a, h, p, &cs)?;
    }
    match bar {
        true => colour_bar(&bar_area, h, &cs),
        false => Ok(()),
    }
}

fn panel<DB: DrawingBackend>(
    a: &DrawingArea<DB, Shift>,
    h: &HeatMap,
    p: &Panel,
    cs: &ColourScale,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let ((x0, x1), (y0, y1)) = (h.x_range, h.y_range);
    let mut chart = ChartBuilder::on(a)
        .caption(&p.label, (FAMILY, 17))
        .margin(8)
        .x_label_area_size(44)
        .y_label_area_size(52)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    axes(
        chart.configure_mesh().disable_mesh(),
        &h.x_label,
        &h.y_label,
        13,
    )
    .draw()
    .map_err(err)?;
    let (dx, dy) = (
        (x1 - x0) / p.width.max(1) as f64,
        (y1 - y0) / p.height.max(1) as f64,
    );
    let colour = |i: usize| -> Option<RGBColor> {
        match &p.pixels {
            Pixels::Values(v) => {
                let t = cs.position(*v.get(i)?);
                t.is_finite().then(|| viridis(t))
            }
            Pixels::Rgb(c) => c.get(i).map(|c| RGBColor(c[0], c[1], c[2])),
        }
    };
    let rects = (0..p.width * p.height).filter_map(|i| {
        let (col, row) = (i % p.width, i / p.width);
        let c = colour(i)?;
        let (xa, ya) = (x0 + col as f64 * dx, y1 - row as f64 * dy);
        Some(Rectangle::new([(xa, ya), (xa + dx, ya - dy)], c.filled()))
    });
    chart.draw_series(rects).map_err(err)?;
    Ok(())
}

fn colour_bar<DB: DrawingBackend>(
    a: &DrawingArea<DB, Shift>,
    h: &HeatMap,
    cs: &ColourScale,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    // The bar's axis is linear in the value or in its logarithm; the labels are values.
    let (lo, hi, log) = match cs.scale {
        Scale::Linear => (cs.lo, cs.hi, false),
        Scale::Log => (cs.lo.log10(), cs.hi.log10(), true),
    };
    let mut chart = ChartBuilder::on(a)
        .margin_top(34)
        .margin_bottom(52)
        .margin_right(8)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..1.0, lo..hi)
        .map_err(err)?;
    let label = |v: &f64| number(if log { 10f64.powf(*v) } else { *v });
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(h.value_label.as_str())
        .y_label_formatter(&label)
        .label_style((FAMILY, 13))
        .axis_desc_style((FAMILY, 15))
        .draw()
        .map_err(err)?;
    let n = 128;
    let step = (hi - lo) / n as f64;
    chart
        .draw_series((0..n).map(|k| {
            let v = lo + k as f64 * step;
            Rectangle::new(
                [(0.0, v), (1.0, v + step)],
                viridis(k as f64 / (n - 1) as f64).filled(),
            )
        }))
        .map_err(err)?;
    Ok(())
}
