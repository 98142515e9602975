//! The `brdfwave brdf …` tools: evaluate a material on a list of direction pairs, plot its lobe,
//! and measure every model under comparable conditions (the survey's "compare the models under
//! similar conditions", measured).

use crate::brdf::{validate, Brdf, Material};
use crate::lights::luminance;
use anyhow::{anyhow, bail, Context as _, Result};
use glam::Vec3;
use std::fmt::Write as _;
use std::path::Path;

/// Direction pairs from a CSV with header `wi_x,wi_y,wi_z,wo_x,wo_y,wo_z` (local frame).
pub fn read_direction_csv(path: &Path) -> Result<Vec<(Vec3, Vec3)>> {
    let text = crate::infile::read_text(path, crate::infile::CSV)
        .with_context(|| format!("reading {}", crate::errors::shown_path(path)))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let expected = ["wi_x", "wi_y", "wi_z", "wo_x", "wo_y", "wo_z"];
    let (_, header) = lines
        .next()
        .ok_or_else(|| anyhow!("{}: empty file, expected a header line", path.display()))?;
    // A byte-order mark (spreadsheets write one) is not part of the first column's name: it
    // gave a mismatch that printed like the expected header.
    let header = header.strip_prefix('\u{feff}').unwrap_or(header);
    let cols: Vec<&str> = header.split(',').map(|c| c.trim()).collect();
    if cols != expected {
        bail!(
            "{}:1: header must be '{}', found '{}'",
            path.display(),
            expected.join(","),
            header.trim()
        );
    }
    let mut pairs = Vec::new();
    for (i, line) in lines {
        let n = i + 1;
        let vals: Vec<&str> = line.split(',').map(|c| c.trim()).collect();
        if vals.len() != 6 {
            bail!(
                "{}:{n}: expected 6 numbers, found {}",
                path.display(),
                vals.len()
            );
        }
        let mut v = [0f32; 6];
        for (k, s) in vals.iter().enumerate() {
            v[k] = s
                .parse::<f32>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    anyhow!(
                        "{}:{n}: column '{}': '{s}' is not a finite number",
                        path.display(),
                        expected[k]
                    )
                })?;
        }
        let wi = Vec3::new(v[0], v[1], v[2]);
        let wo = Vec3::new(v[3], v[4], v[5]);
        for (name, w) in [("wi", wi), ("wo", wo)] {
            if (w.length() - 1.0).abs() > 1e-3 {
                bail!(
                    "{}:{n}: {name} has length {}, expected a unit vector",
                    path.display(),
                    crate::brdf::params::fmt_num(w.length())
                );
            }
        }
        pairs.push((wi.normalize(), wo.normalize()));
    }
    Ok(pairs)
}

/// The output CSV: the input columns plus `f_r,f_g,f_b,pdf`.
pub fn format_eval_csv(pairs: &[(Vec3, Vec3)], values: &[(Vec3, f32)]) -> String {
    let mut s = String::from("wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,f_r,f_g,f_b,pdf\n");
    for ((wi, wo), (f, pdf)) in pairs.iter().zip(values) {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{:e},{:e},{:e},{:e}",
            wi.x, wi.y, wi.z, wo.x, wo.y, wo.z, f.x, f.y, f.z, pdf
        );
    }
    s
}

/// CPU values of f(wi, wo) and pdf(given = wi, sampled = wo).
pub fn eval_cpu(m: &Material, pairs: &[(Vec3, Vec3)]) -> Vec<(Vec3, f32)> {
    pairs
        .iter()
        .map(|(wi, wo)| (m.brdf.eval(*wi, *wo), m.brdf.pdf(*wi, *wo)))
        .collect()
}

/// Writes a drawn picture in the format of `path`'s extension (see
/// [`crate::imageio`]): a PNG holds the drawn sRGB colours exactly, an EXR or PFM the same
/// colours decoded to linear values; any other extension is refused.
pub fn write_plot(path: &Path, img: &image::RgbImage) -> Result<()> {
    let linear = crate::imageio::Image::from_srgb8(img.width(), img.height(), img.as_raw())?;
    crate::imageio::write(path, &linear)?;
    Ok(())
}

/// Makes sure `dir` can take the report's files (creating it when missing) before anything is
/// measured; the errors name `--out`.
pub fn prepare_report_dir(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        bail!(
            "--out {}: is a file; brdf report needs a directory for report.md, report.csv and \
             lobe_*.png",
            dir.display()
        );
    }
    let files = ["report.md", "report.csv"].map(|f| dir.join(f));
    let outputs: Vec<crate::outfile::Output> = files
        .iter()
        .map(|p| crate::outfile::Output {
            option: "--out",
            path: p,
        })
        .collect();
    crate::outfile::prepare(&outputs)
}

/// Three significant digits without an exponent: 5670, 4.28, 0.00431 (GPU costs span 10⁶).
fn three_digits(v: f64) -> String {
    if !(v.is_finite() && v > 0.0) {
        return format!("{v}");
    }
    let decimals = (2 - v.log10().floor() as i32).max(0) as usize;
    format!("{v:.decimals$}")
}

/// Representative parameters for the report, every model's
/// ([`ModelInfo::representative`](crate::brdf::ModelInfo), in [`MODELS`](crate::brdf::MODELS)
/// order): comparable gloss where the model has gloss.
pub fn representative() -> Vec<(String, String)> {
    crate::brdf::MODELS
        .iter()
        .flat_map(|m| m.report_materials())
        .collect()
}

pub const REPORT_ANGLES: [f32; 5] = [0.0, 30.0, 60.0, 80.0, 89.0];

/// One row of the report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ReportRow {
    pub label: String,
    pub material: String,
    /// Directional albedo (luminance) at REPORT_ANGLES: quadrature plus sampled delta lobes.
    pub albedo: Vec<f64>,
    /// Maximum directional albedo over 0..89° in 2° steps, and where it occurs.
    pub albedo_max: f64,
    pub albedo_max_angle: f64,
    pub reciprocity_error: f64,
    /// Smallest χ² p-value over the tested incident angles.
    pub chi2_p_value: f64,
    pub ns_per_eval_cpu: f64,
    pub ns_per_eval_gpu: Option<f64>,
    /// Variance of one sample of the sampled albedo estimator at 30°.
    pub sampled_albedo_variance: f64,
}

/// Luminance albedo of the delta lobes alone, E[weight · 1{delta}], by the model's sampler
/// (a delta lobe's weight is its reflectance over its selection probability, so few samples
/// suffice).
pub fn delta_albedo(b: &dyn Brdf, given: Vec3, samples: u32) -> f64 {
    let mut sum = 0.0f64;
    for i in 0..samples {
        let u = |d| crate::rng::random_f32(17, i, 0, 0, d);
        if let Some(s) = b.sample(given, u(0), glam::Vec2::new(u(1), u(2))) {
            if s.delta {
                sum += luminance(s.weight) as f64;
            }
        }
    }
    sum / samples as f64
}

/// The report's row of the material `src`, whose relative file parameters are resolved against
/// `dir` (the working directory when `None`).
pub fn report_row(label: &str, src: &str, dir: Option<&Path>) -> Result<(ReportRow, Material)> {
    let (m, warnings) = crate::brdf::inline::parse_inline_at("--material", src, dir)?;
    for w in warnings {
        eprintln!("{w}");
    }
    let b = m.brdf.as_ref();
    let dir = validate::dir_from_theta_deg;
    // Quadrature covers the non-delta lobes; delta (mirror) lobes are added by sampling.
    let total = |t: f32, n: usize| {
        validate::albedo_quadrature(b, dir(t, 0.0), n) + delta_albedo(b, dir(t, 0.0), 20_000)
    };
    let albedo: Vec<f64> = REPORT_ANGLES.iter().map(|&t| total(t, 128)).collect();
    let (mut amax, mut amax_angle) = (0.0f64, 0.0f64);
    for k in 0..=45 {
        let t = k as f32 * 2.0;
        let a = total(t.min(89.0), 96);
        if a > amax {
            amax = a;
            amax_angle = t.min(89.0) as f64;
        }
    }
    let chi2 = [10.0f32, 45.0, 75.0]
        .iter()
        .map(|&t| validate::chi2_test(b, dir(t, 20.0), 200_000, 11).p_value)
        .fold(1.0f64, f64::min);
    let (_, var) = validate::albedo_sampled(b, dir(30.0, 0.0), 100_000, 5);
    // Evaluation cost on the CPU: many random pairs, one thread.
    let pairs: Vec<(Vec3, Vec3)> = (0..200_000u32)
        .map(|i| {
            let u = |d| crate::rng::random_f32(1, i, 0, 0, d);
            let a = crate::brdf::common::sample_cosine_hemisphere(glam::Vec2::new(u(0), u(1)));
            let c = crate::brdf::common::sample_cosine_hemisphere(glam::Vec2::new(u(2), u(3)));
            (a, c)
        })
        .collect();
    let t = std::time::Instant::now();
    let mut acc = Vec3::ZERO;
    for (wi, wo) in &pairs {
        acc += b.eval(*wi, *wo);
    }
    std::hint::black_box(acc);
    let ns_cpu = t.elapsed().as_secs_f64() * 1e9 / pairs.len() as f64;
    Ok((
        ReportRow {
            label: label.to_string(),
            material: src.to_string(),
            albedo,
            albedo_max: amax,
            albedo_max_angle: amax_angle,
            reciprocity_error: validate::reciprocity_error(b, 20_000, 3),
            chi2_p_value: chi2,
            ns_per_eval_cpu: ns_cpu,
            ns_per_eval_gpu: None,
            sampled_albedo_variance: var,
        },
        m,
    ))
}

/// How a number is written in the Markdown report; the CSV writes every number in full.
#[derive(Clone, Copy)]
enum Shown {
    /// This many decimals.
    Fixed(usize),
    /// Scientific notation with this many decimals.
    Sci(usize),
    /// Three significant digits, as [`three_digits`].
    ThreeDigits,
}

/// A report column after the label: CSV name, Markdown heading, the row's value (`None`: not
/// measured) and its Markdown form.
type Column = (
    &'static str,
    &'static str,
    fn(&ReportRow) -> Option<f64>,
    Shown,
);

/// The report's columns, described once for both renderings (Markdown and CSV).
#[rustfmt::skip]
const COLUMNS: [Column; 12] = [
    ("albedo_0", "ρ(0°)", |r| Some(r.albedo[0]), Shown::Fixed(4)),
    ("albedo_30", "ρ(30°)", |r| Some(r.albedo[1]), Shown::Fixed(4)),
    ("albedo_60", "ρ(60°)", |r| Some(r.albedo[2]), Shown::Fixed(4)),
    ("albedo_80", "ρ(80°)", |r| Some(r.albedo[3]), Shown::Fixed(4)),
    ("albedo_89", "ρ(89°)", |r| Some(r.albedo[4]), Shown::Fixed(4)),
    ("albedo_max", "max ρ", |r| Some(r.albedo_max), Shown::Fixed(4)),
    ("albedo_max_angle", "at θ (°)", |r| Some(r.albedo_max_angle), Shown::Fixed(0)),
    ("reciprocity_error", "reciprocity err", |r| Some(r.reciprocity_error), Shown::Sci(2)),
    ("chi2_p_value", "χ² p", |r| Some(r.chi2_p_value), Shown::Fixed(3)),
    ("ns_per_eval_cpu", "ns/eval CPU", |r| Some(r.ns_per_eval_cpu), Shown::Fixed(1)),
    ("ns_per_eval_gpu", "ns/eval GPU", |r| r.ns_per_eval_gpu, Shown::ThreeDigits),
    ("sampled_albedo_variance", "var(ρ̂)", |r| Some(r.sampled_albedo_variance), Shown::Sci(3)),
];

pub fn report_markdown(rows: &[ReportRow], gpu_device: Option<&str>) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# brdfwave model report\n");
    let _ = writeln!(
        s,
        "Directional albedo ρ(θ) = ∫ f cosθo dωo of the luminance, by deterministic quadrature, plus delta (mirror) lobes by sampling; maximum over θ in 2° steps to 89°; \
         reciprocity error = max |f(a,b) − f(b,a)| / max(f) over 20,000 random pairs; χ² = smallest p-value of the sample-vs-pdf test at 10°, 45°, 75° \
         (200,000 samples each); cost = nanoseconds per evaluation of f (CPU: one thread, wall clock; GPU: {}, kernel time by timestamps over the evaluations of the whole device, 64 per invocation, so it is a throughput, not a latency); variance = of one sample of the sampled-albedo estimator at 30°.\n",
        gpu_device.unwrap_or("not measured")
    );
    let headings: Vec<&str> = COLUMNS.iter().map(|c| c.1).collect();
    let _ = writeln!(s, "| model | {} |", headings.join(" | "));
    let _ = writeln!(s, "|---{}|", "|---".repeat(COLUMNS.len()));
    for r in rows {
        let cells: Vec<String> = COLUMNS
            .iter()
            .map(|&(_, _, value, shown)| match (value(r), shown) {
                (None, _) => "-".into(),
                (Some(v), Shown::Fixed(d)) => format!("{v:.d$}"),
                (Some(v), Shown::Sci(d)) => format!("{v:.d$e}"),
                (Some(v), Shown::ThreeDigits) => three_digits(v),
            })
            .collect();
        let _ = writeln!(s, "| {} | {} |", r.label, cells.join(" | "));
    }
    s
}

pub fn report_csv(rows: &[ReportRow]) -> String {
    let names: Vec<&str> = COLUMNS.iter().map(|c| c.0).collect();
    let mut s = format!("label,{}\n", names.join(","));
    for r in rows {
        let cells: Vec<String> = COLUMNS
            .iter()
            .map(|c| c.2(r).map(|v| v.to_string()).unwrap_or_default())
            .collect();
        let _ = writeln!(s, "\"{}\",{}", r.label, cells.join(","));
    }
    s
}

/// File-name-safe version of a label.
pub fn slug(label: &str) -> String {
    label
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect::<String>()
        .replace("__", "_")
        .trim_matches('_')
        .to_string()
}

#[cfg(test)]
mod tests {
    use super::{report_csv, report_markdown, three_digits, ReportRow};

    #[test]
    fn costs_keep_three_significant_digits() {
        assert_eq!(three_digits(5467.1), "5467");
        assert_eq!(three_digits(4.281), "4.28");
        assert_eq!(three_digits(0.004312), "0.00431");
        assert_eq!(three_digits(0.0), "0");
    }

    #[test]
    fn both_reports_have_a_cell_under_every_heading() {
        let row = |label: &str, gpu| ReportRow {
            label: label.into(),
            material: String::new(),
            albedo: vec![0.91, 0.9, 0.85, 0.7, 0.5],
            albedo_max: 0.91,
            albedo_max_angle: 0.0,
            reciprocity_error: 1.5e-7,
            chi2_p_value: 0.42,
            ns_per_eval_cpu: 12.34,
            ns_per_eval_gpu: gpu,
            sampled_albedo_variance: 2.5e-3,
        };
        let rows = [row("a", Some(0.004312)), row("b", None)];
        let md = report_markdown(&rows, None);
        let table: Vec<&str> = md.lines().filter(|l| l.starts_with('|')).collect();
        assert_eq!(table.len(), 4, "{md}");
        let cells = |l: &str| l.matches('|').count();
        assert!(table.iter().all(|l| cells(l) == cells(table[0])), "{md}");
        assert!(table[2].starts_with("| a | 0.9100 | 0.9000 |"), "{md}");
        assert!(
            table[2].contains("| 1.50e-7 | 0.420 | 12.3 | 0.00431 | 2.500e-3 |"),
            "{md}"
        );
        assert!(table[3].contains("| 12.3 | - |"), "{md}");
        let csv_text = report_csv(&rows);
        let csv: Vec<&str> = csv_text.lines().collect();
        assert_eq!(csv.len(), 3);
        let commas = |l: &str| l.matches(',').count();
        assert!(csv.iter().all(|l| commas(l) == commas(csv[0])), "{csv:?}");
        assert!(csv[0].starts_with("label,albedo_0,"));
        assert_eq!(
            csv[1],
            "\"a\",0.91,0.9,0.85,0.7,0.5,0.91,0,0.00000015,0.42,12.34,0.004312,0.0025"
        );
        assert!(csv[2].ends_with(",12.34,,0.0025"));
    }
}
