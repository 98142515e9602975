//! `brdfwave diff`: RMSE, relMSE and FLIP of a test image against a reference
//! (`brdfwave::metrics`), and a verdict for CI: thresholds on the metrics (`--max`) and the
//! statistical test of means per pixel and per block (`--z-test`), each side's variance from
//! its batch means when its EXR carries them, else from one sample's. A failed check exits
//! with status 1.

use anyhow::{bail, Context as _, Result};
use brdfwave::{
    imageio::{self, Image, Layered, Provenance},
    metrics::{
        self, Detectable, Metric, SideVariance, Threshold, VarianceModel, VarianceSource, ZSide,
        ZTestOptions, ZTestReport,
    },
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
    /// The two-sample test of means of two independent renders, per pixel (Mitsuba 3 style)
    /// and per block of 4x4 pixels up to the whole image, at the family-wise false-alarm rate
    /// --alpha; fails when they differ by more than their noise explains, and reports the
    /// smallest bias each scale would have seen. Each image's variance: see
    /// --variance-source.
    #[arg(long)]
    z_test: bool,
    /// --z-test: where each image's variance of its pixel means comes from: `auto` (the
    /// default) takes the variance from batch means where the EXR carries it (a render in
    /// batches: right for every sampler), else the variance of one sample over the spp (right
    /// for the independent sampler only: a stratified render's overstates its error, which
    /// makes the test weak); `batches` requires the former, `one-sample` takes the latter.
    #[arg(
        long,
        requires = "z_test",
        value_name = "SOURCE",
        value_enum,
        default_value = "auto"
    )]
    variance_source: SourceArg,
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
pub enum SourceArg {
    Auto,
    Batches,
    OneSample,
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

/// The fewest batches whose variance of the means the z-test's approximations (Student's t
/// with Welch–Satterthwaite degrees of freedom, normal batch means) are trusted with: with 2
/// batches (1 degree of freedom per pixel) and 4 spp, a 1024x1024 pair of one scene failed.
const MIN_BATCHES: u32 = 8;

/// One side of the z-test: its variance image, and its sample count or batches.
struct Side {
    variance: Image,
    source: VarianceSource,
}

impl Side {
    fn variance(&self) -> SideVariance<'_> {
        match self.source {
            VarianceSource::OneSample { spp } => SideVariance::OneSample {
                variance: &self.variance,
                spp,
            },
            VarianceSource::BatchMeans { batches } => SideVariance::BatchMeans {
                variance: &self.variance,
                batches,
            },
        }
    }
}

/// The variance of one image's pixel means: its batch means' (when `source` allows and the EXR
/// has them, and no variance file is given), else one sample's from the option or its EXR,
/// with the spp from the option or its EXR.
fn side(
    name: &str,
    path: &Path,
    layers: &Layered,
    source: SourceArg,
    variance: Option<&Path>,
    spp: Option<u64>,
) -> Result<Side> {
    if source != SourceArg::OneSample && variance.is_none() {
        if let Some(b) = &layers.batch_variance {
            return Ok(Side {
                variance: b.variance.clone(),
                source: VarianceSource::BatchMeans { batches: b.batches },
            });
        }
    }
    if source == SourceArg::Batches {
        bail!(
            "--variance-source batches: the {name} image {} {}: render it with --batches K",
            path.display(),
            if variance.is_some() {
                format!("is given a variance of one sample (--{name}-variance)")
            } else {
                format!(
                    "has no {} layer (the variance of its means from batches)",
                    imageio::MEAN_VARIANCE_LAYER
                )
            }
        );
    }
    let variance = match (variance, &layers.variance) {
        (Some(v), _) => imageio::read(v).with_context(|| format!("--{name}-variance"))?,
        (None, Some(v)) => v.clone(),
        (None, None) => bail!(
            "--z-test needs the variance of the {name} image {}, which has no {} layer: give \
             --{name}-variance FILE, or render it with --batches K",
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
    Ok(Side {
        variance,
        source: VarianceSource::OneSample { spp },
    })
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
    .map(|(name, path, layers, variance, spp)| {
        side(
            name,
            path,
            layers,
            a.variance_source,
            variance.as_deref(),
            spp,
        )
    });
    let (t, r) = (t?, r?);
    for (name, side) in [("test", &t), ("reference", &r)] {
        if let VarianceSource::BatchMeans { batches } = side.source {
            if batches < MIN_BATCHES {
                eprintln!(
                    "warning: the {name} image has {batches} batches: the variance of each pixel's \
                     mean has {} degrees of freedom, too few for the test's approximations \
                     (false alarms can exceed --alpha); render with --batches {MIN_BATCHES} or more",
                    batches - 1
                );
            }
        }
    }
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
    metrics::z_test(
        &ZSide {
            mean: &test.image,
            variance: t.variance(),
        },
        &ZSide {
            mean: &reference.image,
            variance: r.variance(),
        },
        &opts,
    )
    .context("--z-test")
}

fn source_json(s: VarianceSource) -> serde_json::Value {
    match s {
        VarianceSource::OneSample { spp } => json!({"source": s.name(), "spp": spp}),
        VarianceSource::BatchMeans { batches } => json!({"source": s.name(), "batches": batches}),
    }
}

fn detectable_json(d: &Option<Detectable>) -> serde_json::Value {
    match d {
        Some(d) => json!({"bias": d.bias, "bias_95": d.bias_95, "block": d.block,
                          "channel": d.channel, "typical_bias": d.typical_bias}),
        None => serde_json::Value::Null,
    }
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
    let mut j = json!({
        "pass": z.pass,
        "alpha": z.alpha,
        "members": z.members,
        "alpha_member": z.alpha_member,
        "alpha_sidak": z.alpha_sidak,
        "variance": {
            "test": source_json(z.variance_sources[0]),
            "reference": source_json(z.variance_sources[1]),
        },
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
        "pixel_detectable": detectable_json(&z.pixel_detectable),
        "nonfinite": z.nonfinite,
        "min_p": z.min_p,
        "mean_z": z.mean_z,
        "worst": worst,
    });
    if let Some(b) = &z.blocks {
        let scales: Vec<_> = b
            .scales
            .iter()
            .map(|s| {
                json!({
                    "side": s.side,
                    "whole_image": s.whole_image,
                    "blocks": s.blocks,
                    "tests": s.tests,
                    "level": s.level,
                    "rejected": s.rejected,
                    "worst": s.worst.map(|w| json!({
                        "block": w.block, "channel": w.channel, "test": w.mean_a,
                        "reference": w.mean_b, "t": finite_or_null(w.t),
                        "dof": finite_or_null(w.dof), "p": w.p,
                    })),
                    "detectable": detectable_json(&s.detectable),
                })
            })
            .collect();
        j["blocks"] = json!({
            "pass": b.pass,
            "tests": b.tests,
            "rejected": b.rejected,
            "min_adjusted_p": b.min_adjusted_p,
            "scales": scales,
        });
    }
    j
}

/// JSON has no infinity or NaN: an infinite number of degrees of freedom (a normal test) or a
/// statistic that could not be computed is null.
fn finite_or_null(x: f64) -> serde_json::Value {
    if x.is_finite() {
        json!(x)
    } else {
        serde_json::Value::Null
    }
}
