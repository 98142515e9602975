//! `brdfwave diff`: RMSE, relMSE and FLIP of a test image against a reference
//! (`brdfwave::metrics`), and a verdict for CI: thresholds on the metrics (`--max`) and the
//! per-pixel statistical test of means (`--z-test`). A failed check exits with status 1.

use anyhow::{bail, Context as _, Result};
use brdfwave::{
    imageio::{self, Image, Layered, Provenance},
    metrics::{self, Metric, Threshold, VarianceModel, ZTestOptions, ZTestReport},
    outfile::{self, Output},
    plot,
};
use serde_json::json;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct DiffArgs {
    /// The image to test (.exr, .png or .pfm).
    test: PathBuf,
    /// The reference image, the same size.
    reference: PathBuf,
    /// Write the error map (the per-pixel FLIP error): .svg or .png draw it with axes and a
    /// colour bar labelled with its range, its values going beside it as CSV (same stem,
    /// .csv); .exr or .pfm hold the colour-mapped pixels only, at the image's size.
    #[arg(long, value_name = "FILE")]
    error_map: Option<PathBuf>,
    /// Write the test image, the reference and the error map side by side (.svg or .png), with
    /// the error's colour bar; the error values go beside it as CSV.
    #[arg(long, value_name = "FILE")]
    triptych: Option<PathBuf>,
    /// Print the metrics as one JSON object on stdout.
    #[arg(long)]
    json: bool,
    /// Fail (exit status 1) when METRIC is over VALUE; may be given several times. METRIC is
    /// rmse, mse, relmse, flip, max_abs or over (the fraction of pixels off by more than
    /// --tolerance / --rel-tolerance in any channel), e.g. `--max relmse=1e-3 --max flip=0.05`.
    #[arg(long = "max", value_name = "METRIC=VALUE", value_parser = parse_threshold)]
    max: Vec<Threshold>,
    /// `--max over=…`: a pixel-channel is over when |t - r| > ABS + REL * max(|t|, |r|); this
    /// is ABS (default 0).
    #[arg(long, value_name = "ABS", value_parser = parse_tolerance)]
    tolerance: Option<f64>,
    /// `--max over=…`: the relative part REL of the tolerance (default 0).
    #[arg(long, value_name = "REL", value_parser = parse_tolerance)]
    rel_tolerance: Option<f64>,
    /// The per-pixel two-sample test of means (Mitsuba 3 style): the two images are
    /// independent renders, each with its per-pixel variance of one sample and its sample
    /// count; fails when they differ by more than their noise explains.
    #[arg(long)]
    z_test: bool,
    /// --z-test: the test image's variance of one sample (default: its EXR's variance layer,
    /// which `render` and `merge` write).
    #[arg(long, requires = "z_test", value_name = "FILE")]
    test_variance: Option<PathBuf>,
    /// --z-test: the test image's samples per pixel (default: its EXR metadata).
    #[arg(long, requires = "z_test", value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    test_spp: Option<u64>,
    /// --z-test: the reference's variance of one sample (default: its EXR variance layer).
    #[arg(long, requires = "z_test", value_name = "FILE")]
    reference_variance: Option<PathBuf>,
    /// --z-test: the reference's samples per pixel (default: its EXR metadata).
    #[arg(long, requires = "z_test", value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    reference_spp: Option<u64>,
    /// --z-test: the family-wise false-alarm rate, in (0, 1).
    #[arg(long, requires = "z_test", value_name = "A", default_value_t = 0.01, value_parser = parse_alpha)]
    alpha: f64,
    /// --z-test: the variance of the difference of means: `pooled` (both sides run the same
    /// estimator: two seeds, GPU against CPU), `welch` (different estimators, or an exact
    /// reference with zero variance), or `auto` (the default: pooled, welch when one side's
    /// variance is zero everywhere). The two agree when both sides have the same spp.
    #[arg(
        long,
        requires = "z_test",
        value_name = "MODEL",
        value_enum,
        default_value = "auto"
    )]
    variance_model: VarianceArg,
    /// --z-test: write the per-pixel-channel p-values as an image (.exr keeps them exact).
    #[arg(long, requires = "z_test", value_name = "FILE")]
    p_map: Option<PathBuf>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum VarianceArg {
    Auto,
    Pooled,
    Welch,
}

fn parse_threshold(s: &str) -> std::result::Result<Threshold, String> {
    Threshold::parse(s).map_err(|e| e.to_string())
}

fn parse_tolerance(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a finite number >= 0")),
    }
}

fn parse_alpha(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v > 0.0 && v < 1.0 => Ok(v),
        _ => Err(format!("'{s}' is not a number in (0, 1)")),
    }
}

/// The images the command may write, each checked before anything is computed.
fn prepare_outputs(a: &DiffArgs) -> Result<()> {
    let mut planned = Vec::new();
    let mut csvs = Vec::new();
    for (option, path) in [
        ("--error-map", &a.error_map),
        ("--p-map", &a.p_map),
        ("--triptych", &a.triptych),
    ] {
        let Some(p) = path else { continue };
        if is_figure(option, p)? {
            csvs.push((option, plot::csv_path(p)));
        } else {
            imageio::Format::from_path(p).context(option)?;
        }
        for (name, input) in [("TEST", &a.test), ("REFERENCE", &a.reference)] {
            if outfile::resolve(p) == outfile::resolve(input) {
                bail!(
                    "{option} {} is the {name} image: it would be overwritten; give the {} its \
                     own path",
                    p.display(),
                    &option[2..].replace('-', " ")
                );
            }
        }
        planned.push(Output { option, path: p });
    }
    planned.extend(csvs.iter().map(|(option, path)| Output { option, path }));
    outfile::prepare(&planned)?;
    Ok(())
}

/// Whether `path` of `option` is a drawn figure (.svg, .png: the error map and the triptych)
/// rather than an image of the pixels (the error map's .exr and .pfm, the p-value map).
fn is_figure(option: &str, path: &Path) -> Result<bool> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match option {
        "--triptych" => {
            if !matches!(ext.as_str(), "svg" | "png") {
                bail!(
                    "--triptych {}: unknown extension '.{ext}': the triptych is .svg or .png",
                    path.display()
                );
            }
            Ok(true)
        }
        "--error-map" => {
            // The figure's extensions and the image formats' (whose own message lists only
            // the latter).
            if !matches!(ext.as_str(), "svg" | "png" | "exr" | "pfm") {
                bail!(
                    "--error-map {}: unknown extension '.{ext}': the error map is .svg or .png \
                     (a figure with axes and a colour bar) or .exr or .pfm (the coloured pixels \
                     alone)",
                    brdfwave::errors::shown_path(path)
                );
            }
            Ok(matches!(ext.as_str(), "svg" | "png"))
        }
        _ => Ok(false),
    }
}

/// The error map figure: the FLIP error per pixel, with the test and reference images before
/// it for the triptych; and its CSV (x, y from the top-left, flip).
fn error_figure(
    test: &Image,
    reference: &Image,
    flip: &[f32],
    triptych: bool,
) -> (plot::Figure, String) {
    let (w, h) = (test.width as usize, test.height as usize);
    let (lo, hi) = flip
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let mut panels = Vec::new();
    if triptych {
        for (label, img) in [("test", test), ("reference", reference)] {
            let srgb = img.to_srgb8();
            panels.push(plot::Panel {
                label: label.into(),
                width: w,
                height: h,
                pixels: plot::Pixels::Rgb(
                    srgb.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
                ),
            });
        }
    }
    panels.push(plot::Panel {
        label: format!("FLIP error, {lo:.4} to {hi:.4}"),
        width: w,
        height: h,
        pixels: plot::Pixels::Values(flip.iter().map(|&v| v as f64).collect()),
    });
    let mut csv = String::from("x,y,flip\n");
    for (i, v) in flip.iter().enumerate() {
        csv.push_str(&format!("{},{},{v}\n", i % w, i / w));
    }
    let figure = plot::Figure::Heat(plot::HeatMap {
        title: "Error map: LDR-FLIP (Andersson et al., 2020)".into(),
        x_label: "x (pixels)".into(),
        y_label: "y (pixels, from the bottom)".into(),
        x_range: (0.0, w as f64),
        y_range: (0.0, h as f64),
        value_label: "FLIP error".into(),
        scale: plot::Scale::Linear,
        panels,
    });
    (figure, csv)
}

/// The image outputs: `--error-map` (a figure with a colour bar, or the raw colour-mapped
/// pixels as EXR/PFM), `--triptych` and `--p-map`.
fn write_maps(
    a: &DiffArgs,
    test: &imageio::Image,
    reference: &imageio::Image,
    z: Option<&ZTestReport>,
) -> Result<()> {
    if let Some(p) = &a.error_map {
        if is_figure("--error-map", p)? {
            let (fig, csv) =
                error_figure(test, reference, &metrics::flip_map(test, reference)?, false);
            plot::write(p, "--error-map", &fig, &csv)?;
        } else {
            imageio::write(p, &metrics::error_map(test, reference)?)?;
        }
    }
    if let Some(p) = &a.triptych {
        let (fig, csv) = error_figure(test, reference, &metrics::flip_map(test, reference)?, true);
        plot::write(p, "--triptych", &fig, &csv)?;
    }
    if let (Some(p), Some(z)) = (&a.p_map, z) {
        imageio::write(p, &z.p_map)?;
    }
    Ok(())
}

pub fn run(a: DiffArgs) -> Result<()> {
    let uses_over = a.max.iter().any(|t| t.metric == Metric::Over);
    if !uses_over && (a.tolerance.is_some() || a.rel_tolerance.is_some()) {
        bail!("--tolerance and --rel-tolerance apply to `--max over=FRACTION` only, which is not given");
    }
    prepare_outputs(&a)?;
    let test = imageio::read_layered(&a.test)?;
    let reference = imageio::read_layered(&a.reference)?;
    let (t_layers, r_layers) = (&test, &reference);
    let (test, reference) = (&test.image, &reference.image);
    let report = metrics::diff(test, reference)?;
    let over = if uses_over {
        let agree = metrics::fraction_within(
            test,
            reference,
            a.rel_tolerance.unwrap_or(0.0),
            a.tolerance.unwrap_or(0.0),
        )?;
        1.0 - agree.pixel_fraction
    } else {
        0.0
    };
    let verdicts: Vec<metrics::Verdict> = a
        .max
        .iter()
        .map(|t| t.judge(t.metric.value(&report, over)))
        .collect();
    let z = if a.z_test {
        Some(z_test(&a, t_layers, r_layers)?)
    } else {
        None
    };
    write_maps(&a, test, reference, z.as_ref())?;
    let failed: Vec<String> = verdicts
        .iter()
        .filter(|v| !v.pass)
        .map(|v| v.to_string())
        .chain(
            z.as_ref()
                .filter(|z| !z.pass)
                .map(|_| "FAIL z-test".to_string()),
        )
        .collect();
    if a.json {
        let mut j = json!({
            "width": report.width,
            "height": report.height,
            "mse": report.mse,
            "rmse": report.rmse,
            "relmse": report.relmse,
            "flip_mean": report.flip_mean,
            "max_abs": report.max_abs,
            "mean_test": report.mean_test,
            "mean_reference": report.mean_reference,
            "nonfinite_test": report.nonfinite_test,
            "nonfinite_reference": report.nonfinite_reference,
        });
        if uses_over {
            j["over"] = json!(over);
        }
        if !verdicts.is_empty() {
            j["verdicts"] = json!(verdicts);
        }
        if let Some(z) = &z {
            j["z_test"] = z_json(z);
        }
        if !verdicts.is_empty() || z.is_some() {
            j["pass"] = json!(failed.is_empty());
        }
        outln!("{j}")?;
    } else {
        for (name, l) in [("test", t_layers), ("reference", r_layers)] {
            if l.provenance != Provenance::default() {
                outln!("{name:<11} {}", l.provenance.summary())?;
            }
        }
        out!("{report}")?;
        if uses_over {
            outln!("over        {over:.6e} of the pixels")?;
        }
        for v in &verdicts {
            outln!("{v}")?;
        }
        if let Some(z) = &z {
            out!("{z}")?;
        }
    }
    // The metrics leave non-finite values out (two all-NaN images scored RMSE 0, FLIP 0): such
    // images do not compare, whatever the numbers above say.
    if report.nonfinite_test + report.nonfinite_reference > 0 {
        bail!(
            "the images hold non-finite values ({} in {}, {} in {}), which the metrics leave out: they do not compare",
            report.nonfinite_test,
            a.test.display(),
            report.nonfinite_reference,
            a.reference.display()
        );
    }
    if !failed.is_empty() {
        bail!(
            "{} fails against {}: {}",
            a.test.display(),
            a.reference.display(),
            failed.join("; ")
        );
    }
    Ok(())
}

/// One side of the z-test: its variance image and sample count.
struct Side {
    variance: Image,
    spp: u64,
}

/// The variance and spp of one image: the options, else what its EXR file carries.
fn side(
    name: &str,
    path: &Path,
    layers: &Layered,
    variance: Option<&Path>,
    spp: Option<u64>,
) -> Result<Side> {
    let variance = match (variance, &layers.variance) {
        (Some(v), _) => imageio::read(v).with_context(|| format!("--{name}-variance"))?,
        (None, Some(v)) => v.clone(),
        (None, None) => bail!(
            "--z-test needs the variance of the {name} image {}, which has no {} layer: give \
             --{name}-variance FILE",
            path.display(),
            imageio::VARIANCE_LAYER
        ),
    };
    let spp = match (spp, layers.provenance.spp) {
        (Some(n), _) => n,
        (None, Some(n)) if n > 0 => n as u64,
        _ => bail!(
            "--z-test needs the samples per pixel of the {name} image {}, whose metadata does \
             not give them: give --{name}-spp N",
            path.display()
        ),
    };
    Ok(Side { variance, spp })
}

fn z_test(a: &DiffArgs, test: &Layered, reference: &Layered) -> Result<ZTestReport> {
    // Both sides read alike; the test side's error comes first.
    let [t, r] = [
        ("test", &a.test, test, &a.test_variance, a.test_spp),
        (
            "reference",
            &a.reference,
            reference,
            &a.reference_variance,
            a.reference_spp,
        ),
    ]
    .map(|(name, path, layers, variance, spp)| side(name, path, layers, variance.as_deref(), spp));
    let (t, r) = (t?, r?);
    let all_zero = |v: &Image| v.data.iter().all(|p| p.iter().all(|&c| c == 0.0));
    let variance = match a.variance_model {
        VarianceArg::Pooled => VarianceModel::Pooled,
        VarianceArg::Welch => VarianceModel::Welch,
        VarianceArg::Auto if all_zero(&t.variance) || all_zero(&r.variance) => VarianceModel::Welch,
        VarianceArg::Auto => VarianceModel::Pooled,
    };
    let opts = ZTestOptions {
        alpha: a.alpha,
        variance,
        ..ZTestOptions::default()
    };
    metrics::z_test_with(
        &test.image,
        &t.variance,
        t.spp,
        &reference.image,
        &r.variance,
        r.spp,
        &opts,
    )
    .context("--z-test")
}

fn z_json(z: &ZTestReport) -> serde_json::Value {
    let worst: Vec<_> = z
        .worst
        .iter()
        .map(|o| {
            json!({"x": o.x, "y": o.y, "channel": o.channel, "test": o.mean_a,
                   "reference": o.mean_b, "z": o.z, "p": o.p})
        })
        .collect();
    json!({
        "pass": z.pass,
        "alpha": z.alpha,
        "alpha_sidak": z.alpha_sidak,
        "variance_model": match z.variance {
            VarianceModel::Welch => "welch",
            VarianceModel::Pooled => "pooled",
        },
        "tests": z.tests,
        "outliers": z.outliers,
        "max_outliers": z.max_outliers,
        "outlier_rule_pass": z.outlier_rule_pass,
        "rejected_pixels": z.rejected_pixels,
        "expected_rejected_pixels": z.expected_rejected_pixels,
        "excess_p": z.excess_p,
        "excess_rule_pass": z.excess_rule_pass,
        "nonfinite": z.nonfinite,
        "min_p": z.min_p,
        "mean_z": z.mean_z,
        "worst": worst,
    })
}
