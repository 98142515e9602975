//! Figures for papers and reports, drawn with `plotters` in SVG or PNG (chosen by the output's
//! extension) with the embedded DejaVu Sans font: line charts on linear or log axes
//! ([`LineChart`]: the bench's error against time, albedo against θ, the fits' lobes), polar
//! plots in the plane of incidence ([`PolarChart`]) and images of a value over two angles with a
//! colour bar ([`HeatMap`]: the θh×θd slice, the hemisphere, the error map). [`write`] writes
//! the figure and its data as CSV beside it (same stem, `.csv`), both atomically.

mod draw;
pub mod lobe;

use anyhow::{bail, Result};
use std::path::{Path, PathBuf};

/// DejaVu Sans (Bitstream Vera licence, `assets/fonts/LICENSE-DejaVu.txt`), embedded so that
/// text looks the same on every machine.
const FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// One curve: its legend label and its (x, y) points; points that cannot be drawn (not finite,
/// or not positive on a log axis) are left out of the drawing (not of the CSV).
#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

/// How an axis (or a colour bar) maps values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    Linear,
    /// Logarithmic, over whole decades around the values (at most [`Scale::DECADES`] below the
    /// largest for polar plots and colour bars).
    Log,
}

impl Scale {
    pub const DECADES: f64 = 4.0;

    /// `lin` or `log`, as `--scale` takes it.
    pub fn parse(s: &str) -> std::result::Result<Scale, String> {
        match s {
            "lin" | "linear" => Ok(Scale::Linear),
            "log" => Ok(Scale::Log),
            _ => Err(format!("unknown scale '{s}': expected lin or log")),
        }
    }
}

/// Curves on two axes, with a title, axis labels and a legend.
#[derive(Clone, Debug)]
pub struct LineChart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub x_scale: Scale,
    pub y_scale: Scale,
    /// The x range; None: the points' (whole decades on a log axis).
    pub x_range: Option<(f64, f64)>,
    pub series: Vec<Series>,
}

/// Curves of a value against the signed angle θ (degrees, −90 to 90; +x to the right) in a
/// plane, drawn as radius: the lobe of a BRDF in the plane of incidence. Rings mark values,
/// spokes every 15° the angle; a line marks the light's direction.
#[derive(Clone, Debug)]
pub struct PolarChart {
    pub title: String,
    /// What the radius shows (the ring labels' unit).
    pub value_label: String,
    pub scale: Scale,
    /// The light's direction, degrees (drawn as a line), if any.
    pub light_deg: Option<f64>,
    pub series: Vec<Series>,
}

/// What a [`HeatMap`] panel shows.
#[derive(Clone, Debug)]
pub enum Pixels {
    /// A value per cell, coloured by the shared colour bar; NaN cells are left blank.
    Values(Vec<f64>),
    /// Colours as they are (sRGB), e.g. the tone-mapped images of a triptych.
    Rgb(Vec<[u8; 3]>),
}

/// One image of a [`HeatMap`]: `width` × `height` cells, row 0 at the top.
#[derive(Clone, Debug)]
pub struct Panel {
    pub label: String,
    pub width: usize,
    pub height: usize,
    pub pixels: Pixels,
}

/// Images of a value over two coordinates side by side, sharing axes and one colour bar.
#[derive(Clone, Debug)]
pub struct HeatMap {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    /// The coordinates of the left and right edges, and of the bottom and top edges.
    pub x_range: (f64, f64),
    pub y_range: (f64, f64),
    /// The colour bar's label (the value and its unit) and scale.
    pub value_label: String,
    pub scale: Scale,
    pub panels: Vec<Panel>,
}

/// A figure [`write`] can draw.
#[derive(Clone, Debug)]
pub enum Figure {
    Lines(LineChart),
    Polar(PolarChart),
    Heat(HeatMap),
}

impl Figure {
    /// The size in pixels (PNG) or user units (SVG).
    pub fn size(&self) -> (u32, u32) {
        match self {
            Figure::Lines(_) => (960, 600),
            Figure::Polar(_) => (960, 600),
            Figure::Heat(h) => (140 + 420 * h.panels.len().max(1) as u32, 480),
        }
    }
}

/// The output formats of a figure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Svg,
    Png,
    /// The PNG's colours decoded to linear values, in an EXR or PFM image (`brdf plot` wrote
    /// these before it drew axes).
    Image,
}

impl Format {
    /// The format of `path` by its extension; `option` names the option in the error.
    pub fn of(path: &Path, option: &str) -> Result<Format> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        Ok(match ext.as_str() {
            "svg" => Format::Svg,
            "png" => Format::Png,
            "exr" | "pfm" => Format::Image,
            _ => bail!(
                "{option} {}: unknown extension '.{ext}': a plot is .svg or .png (or .exr, .pfm \
                 for the picture as linear values)",
                path.display()
            ),
        })
    }
}

/// The CSV written beside `path`: the same stem, `.csv`.
pub fn csv_path(path: &Path) -> PathBuf {
    path.with_extension("csv")
}

/// Draws `figure` into `path` (its format from the extension, [`Format::of`]) and writes `csv`,
/// its data, beside it ([`csv_path`]); both atomically. `option` names the output's option in
/// errors.
pub fn write(path: &Path, option: &str, figure: &Figure, csv: &str) -> Result<()> {
    write_figure(path, option, figure)?;
    crate::outfile::write(&csv_path(path), csv.as_bytes())?;
    Ok(())
}

/// [`write`] without the CSV, for a figure whose data is written beside it by its caller.
pub fn write_figure(path: &Path, option: &str, figure: &Figure) -> Result<()> {
    let format = Format::of(path, option)?;
    if format == Format::Svg {
        let svg = render_svg(figure)?;
        crate::outfile::write(path, svg.as_bytes())?;
    } else {
        let img = render_rgb(figure)?;
        match format {
            Format::Png => {
                let mut png = Vec::new();
                img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
                crate::outfile::write(path, &png)?;
            }
            _ => crate::brdf_tools::write_plot(path, &img)?,
        }
    }
    Ok(())
}

/// The figure as an SVG document (text as `<text>` elements).
pub fn render_svg(figure: &Figure) -> Result<String> {
    draw::register_font();
    let mut svg = String::new();
    {
        let root = plotters::prelude::SVGBackend::with_string(&mut svg, figure.size());
        draw::figure(root, figure)?;
    }
    Ok(svg)
}

/// The figure drawn into an sRGB image.
pub fn render_rgb(figure: &Figure) -> Result<image::RgbImage> {
    draw::register_font();
    let (w, h) = figure.size();
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = plotters::prelude::BitMapBackend::with_buffer(&mut buf, (w, h));
        draw::figure(root, figure)?;
    }
    Ok(image::RgbImage::from_raw(w, h, buf).expect("a buffer of the figure's size"))
}

/// A CSV of curves sampled at the same x: the header `x_name,label1,label2,…`, then one row per
/// x of the first series (the others are looked up by index).
pub fn series_csv(x_name: &str, series: &[Series]) -> String {
    let mut s = String::from(x_name);
    for c in series {
        s.push(',');
        s.push_str(&csv_field(&c.label));
    }
    s.push('\n');
    let rows = series.first().map_or(0, |c| c.points.len());
    for i in 0..rows {
        s.push_str(&format!("{}", series[0].points[i].0));
        for c in series {
            match c.points.get(i) {
                Some(p) => s.push_str(&format!(",{}", p.1)),
                None => s.push(','),
            }
        }
        s.push('\n');
    }
    s
}

/// A CSV field, quoted when it holds a comma, quote or newline.
pub fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}
