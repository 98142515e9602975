//! `brdfwave diff`: RMSE, relMSE and FLIP of a test image against a reference
//! (`brdfwave::metrics`).

use anyhow::{bail, Context as _, Result};
use brdfwave::{
    imageio, metrics,
    outfile::{self, Output},
};
use serde_json::json;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct DiffArgs {
    /// The image to test (.exr, .png or .pfm).
    test: PathBuf,
    /// The reference image, the same size.
    reference: PathBuf,
    /// Write an error map image.
    #[arg(long)]
    error_map: Option<PathBuf>,
    /// Print the metrics as one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

pub fn run(a: DiffArgs) -> Result<()> {
    let (test, reference, error_map, json_out) =
        (&a.test, &a.reference, a.error_map.as_deref(), a.json);
    if let Some(p) = error_map {
        imageio::Format::from_path(p).context("--error-map")?;
        for (name, input) in [("TEST", test), ("REFERENCE", reference)] {
            if outfile::resolve(p) == outfile::resolve(input) {
                bail!(
                    "--error-map {} is the {name} image: it would be overwritten; give the error \
                     map its own path",
                    p.display()
                );
            }
        }
        outfile::prepare(&[Output {
            option: "--error-map",
            path: p,
        }])?;
    }
    let a = imageio::read(test)?;
    let b = imageio::read(reference)?;
    let report = metrics::diff(&a, &b)?;
    if let Some(p) = error_map {
        imageio::write(p, &metrics::error_map(&a, &b)?)?;
    }
    if json_out {
        let j = json!({
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
        outln!("{j}")?;
    } else {
        out!("{report}")?;
    }
    // The metrics leave non-finite values out (two all-NaN images scored RMSE 0, FLIP 0): such
    // images do not compare, whatever the numbers above say.
    if report.nonfinite_test + report.nonfinite_reference > 0 {
        bail!(
            "the images hold non-finite values ({} in {}, {} in {}), which the metrics leave out: they do not compare",
            report.nonfinite_test,
            test.display(),
            report.nonfinite_reference,
            reference.display()
        );
    }
    Ok(())
}
