//! `brdfwave brdf eval | plot | report` (`brdfwave::brdf_tools`), `brdf merl` (a synthetic MERL
//! file, `brdfwave::measured::merl`) and `brdf fit` (`super::fit`).

use super::{parse_device, warn_gpu_only, Backend};
use anyhow::{bail, Context as _, Result};
use brdfwave::brdf::inline::parse_inline;
use brdfwave::brdf_tools as tools;
use brdfwave::{
    outfile::{self, Output},
    vk,
};
use clap::Subcommand;
use std::path::{Path, PathBuf};

#[derive(Subcommand)]
pub enum BrdfCommand {
    /// Evaluate f and pdf for direction pairs from a CSV (header wi_x,wi_y,wi_z,wo_x,wo_y,wo_z).
    Eval {
        /// The material as an inline TOML table, e.g. 'model = "ward", kd = 0.1, ks = 0.8, alpha_x = 0.2, alpha_y = 0.1'.
        #[arg(value_name = "TOML", long)]
        material: String,
        /// CSV of direction pairs, header wi_x,wi_y,wi_z,wo_x,wo_y,wo_z: unit vectors in the
        /// local frame (z = normal), both pointing away from the surface, wi toward the light.
        #[arg(value_name = "FILE.csv", long)]
        dirs: PathBuf,
        /// Where to evaluate: the Rust model or its GLSL twin on the Vulkan device.
        #[arg(long, value_enum, default_value = "cpu")]
        backend: Backend,
        /// Output CSV (default: stdout); missing directories are created.
        #[arg(value_name = "FILE.csv", long)]
        out: Option<PathBuf>,
        /// Vulkan device for --backend gpu: a case-insensitive part of its name (default:
        /// lavapipe if present; `brdfwave devices` lists them).
        #[arg(value_name = "NAME", long, value_parser = parse_device)]
        device: Option<String>,
    },
    /// Plot materials, overlaid with a legend: the polar plot in the plane of incidence, the
    /// θh×θd slice, the albedo against θi, or the hemisphere image; the data goes beside the
    /// plot as CSV (same stem, .csv).
    Plot {
        /// A material as an inline TOML table, as for `brdf eval`; may be given several times
        /// (one curve or panel each).
        #[arg(value_name = "TOML", long, required = true)]
        material: Vec<String>,
        /// What to draw: `polar` (f in the plane of incidence), `slice` (f over θh×θd at
        /// φd = 90°, the BRDF Explorer's image slice), `albedo` (against θi) or `hemisphere`
        /// (f·cosθo over the directions seen from above).
        #[arg(long, value_enum, default_value = "polar")]
        kind: PlotKind,
        /// Angle of incidence in degrees, in [0, 90) (polar and hemisphere plots).
        #[arg(
            value_name = "DEG",
            long,
            allow_hyphen_values = true,
            default_value = "45"
        )]
        theta_i: f32,
        /// Value scale: `lin` or `log` (default: lin for polar and albedo, log for slice and
        /// hemisphere).
        #[arg(value_name = "lin|log", long, value_parser = brdfwave::plot::Scale::parse)]
        scale: Option<brdfwave::plot::Scale>,
        /// Output: .svg or .png; .exr or .pfm for the drawn picture as linear values. Missing
        /// directories are created.
        #[arg(value_name = "FILE", long)]
        out: PathBuf,
    },
    /// Measure every model at representative parameters: albedo, reciprocity, χ², cost, variance.
    Report {
        /// Directory for report.md, report.csv and lobe_*.png (created if missing).
        #[arg(value_name = "DIR", long, default_value = "out/report")]
        out: PathBuf,
        /// Skip the GPU cost measurement.
        #[arg(long)]
        no_gpu: bool,
        /// Vulkan device for the GPU cost measurement: a case-insensitive part of its name
        /// (default: lavapipe if present; `brdfwave devices` lists them).
        #[arg(value_name = "NAME", long, value_parser = parse_device)]
        device: Option<String>,
    },
    /// Write a synthetic MERL .binary file: the material sampled at every cell centre (for
    /// trying `brdf fit` without measured data, which MERL distributes).
    Merl {
        /// The material as an inline TOML table, as for `brdf eval`.
        #[arg(value_name = "TOML", long)]
        material: String,
        /// Output .binary file (34992012 bytes); missing directories are created.
        #[arg(value_name = "FILE.binary", long)]
        out: PathBuf,
    },
    /// Fit the survey's models to a measured material (a MERL .binary file): fit.md, fit.csv,
    /// materials.toml, plots and a lineup scene.
    Fit(super::fit::FitArgs),
}

pub fn run(cmd: BrdfCommand) -> Result<()> {
    match cmd {
        BrdfCommand::Eval {
            material,
            dirs,
            backend,
            out,
            device,
        } => eval(&material, &dirs, backend, out.as_deref(), device),
        BrdfCommand::Plot {
            material,
            kind,
            theta_i,
            scale,
            out,
        } => plot(&material, kind, theta_i, scale, &out),
        BrdfCommand::Report {
            out,
            no_gpu,
            device,
        } => report(&out, no_gpu, device),
        BrdfCommand::Merl { material, out } => merl(&material, &out),
        BrdfCommand::Fit(args) => super::fit::run(args),
    }
}

/// `brdf eval`: f and pdf of each direction pair, on the Rust model or its GLSL twin.
fn eval(
    material: &str,
    dirs: &Path,
    backend: Backend,
    out: Option<&Path>,
    device: Option<String>,
) -> Result<()> {
    if backend == Backend::Cpu {
        warn_gpu_only(&[("--device", device.is_some())]);
    }
    if let Some(p) = out {
        let o = [Output {
            option: "--out",
            path: p,
        }];
        outfile::refuse_inputs(&o, &[("--dirs file", dirs)])?;
        outfile::prepare(&o)?;
    }
    let m = parse_inline(material)?;
    let pairs = tools::read_direction_csv(dirs)?;
    // Below the horizon every model is 0 by definition: say so rather than print zeros
    // without a word.
    let below = pairs
        .iter()
        .filter(|(wi, wo)| wi.z <= 0.0 || wo.z <= 0.0)
        .count();
    if below > 0 {
        eprintln!(
            "warning: {}: {below} of {} direction pairs have wi or wo at or below the horizon (z <= 0), where f and pdf are 0",
            dirs.display(),
            pairs.len()
        );
    }
    let values = match backend {
        Backend::Cpu => tools::eval_cpu(&m, &pairs),
        Backend::Gpu => {
            let ctx = vk::Context::new(&vk::ContextOptions {
                device,
                validation: false,
                ray_query: false,
            })?;
            let compiler = vk::ShaderCompiler::new()?;
            brdfwave::gpu::brdf_probe::eval(&ctx, &compiler, &m, &pairs)?
        }
    };
    let csv = tools::format_eval_csv(&pairs, &values);
    match out {
        Some(p) => outfile::write(p, csv.as_bytes())?,
        None => out!("{csv}")?,
    }
    Ok(())
}

/// What `brdf plot` draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PlotKind {
    Polar,
    Slice,
    Albedo,
    Hemisphere,
}

/// `brdf plot`: the materials overlaid in one figure, and its data as CSV.
fn plot(
    materials: &[String],
    kind: PlotKind,
    theta_i: f32,
    scale: Option<brdfwave::plot::Scale>,
    out: &Path,
) -> Result<()> {
    use brdfwave::plot::{self, lobe, Scale};
    if !(0.0..90.0).contains(&theta_i) {
        bail!("--theta-i must be in [0, 90) degrees, got {theta_i}");
    }
    plot::Format::of(out, "--out")?;
    let csv = plot::csv_path(out);
    outfile::prepare(&[
        Output {
            option: "--out",
            path: out,
        },
        Output {
            option: "--out (its CSV)",
            path: &csv,
        },
    ])?;
    let parsed = materials
        .iter()
        .enumerate()
        .map(|(k, m)| parse_inline(m).with_context(|| format!("--material {}", k + 1)))
        .collect::<Result<Vec<_>>>()?;
    let plotted: Vec<lobe::Plotted> = materials
        .iter()
        .zip(&parsed)
        .map(|(label, m)| lobe::Plotted {
            label: label.replace('"', ""),
            brdf: m.brdf.as_ref(),
        })
        .collect();
    let t = theta_i as f64;
    let (figure, data) = match kind {
        PlotKind::Polar => lobe::polar(&plotted, t, scale.unwrap_or(Scale::Linear)),
        PlotKind::Slice => lobe::slice(&plotted, scale.unwrap_or(Scale::Log)),
        PlotKind::Albedo => lobe::albedo(&plotted, scale.unwrap_or(Scale::Linear)),
        PlotKind::Hemisphere => lobe::hemisphere(&plotted, t, scale.unwrap_or(Scale::Log)),
    };
    plot::write(out, "--out", &figure, &data)?;
    outln!("wrote {} and {}", out.display(), csv.display())?;
    Ok(())
}

/// `brdf merl`: a synthetic MERL file of the material.
fn merl(material: &str, out: &Path) -> Result<()> {
    outfile::prepare(&[Output {
        option: "--out",
        path: out,
    }])?;
    let m = parse_inline(material)?;
    let table = brdfwave::measured::merl::MerlTable::from_brdf(m.brdf.as_ref());
    table.write(out)?;
    outln!(
        "wrote {} ({} of the {} values below the horizon, marked missing)",
        out.display(),
        table.missing(),
        3 * brdfwave::measured::merl::CELLS
    )?;
    Ok(())
}

/// `brdf report`: every model at its representative parameters.
fn report(out: &Path, no_gpu: bool, device: Option<String>) -> Result<()> {
    use brdfwave::plot::{self, lobe, Scale};
    if no_gpu {
        warn_gpu_only(&[("--device", device.is_some())]);
    }
    tools::prepare_report_dir(out)?;
    let gpu = if no_gpu {
        None
    } else {
        let ctx = vk::Context::new(&vk::ContextOptions {
            device,
            validation: false,
            ray_query: false,
        })?;
        let compiler = vk::ShaderCompiler::new()?;
        Some((ctx, compiler))
    };
    // The data files the representative materials name (a synthetic MERL table), made for the
    // report in a temporary directory: measured data is not shipped.
    let fixtures = tempfile::tempdir()?;
    brdfwave::brdf::write_fixtures(fixtures.path())?;
    let mut rows = Vec::new();
    for (label, src) in tools::representative() {
        eprintln!("measuring {label}");
        let (mut row, m) = tools::report_row(&label, &src, Some(fixtures.path()))?;
        if let Some((ctx, compiler)) = &gpu {
            row.ns_per_eval_gpu = Some(brdfwave::gpu::brdf_probe::eval_cost(ctx, compiler, &m)?);
        }
        // The lobe in the plane of incidence at θi = 45°, as `brdf plot --kind polar` draws it.
        let plotted = [lobe::Plotted {
            label: label.clone(),
            brdf: m.brdf.as_ref(),
        }];
        let (figure, data) = lobe::polar(&plotted, 45.0, Scale::Linear);
        let path = out.join(format!("lobe_{}.png", tools::slug(&label)));
        plot::write(&path, "--out", &figure, &data)?;
        rows.push(row);
    }
    let device_name = gpu.as_ref().map(|(c, _)| c.device_name.clone());
    let md = tools::report_markdown(&rows, device_name.as_deref());
    outfile::write(&out.join("report.md"), md.as_bytes())?;
    outfile::write(&out.join("report.csv"), tools::report_csv(&rows).as_bytes())?;
    out!("{md}")?;
    outln!(
        "\nwrote {}/report.md, report.csv and lobe_*.png (with their data, lobe_*.csv)",
        out.display()
    )?;
    Ok(())
}
