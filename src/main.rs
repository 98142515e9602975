//! `brdfwave` command line: render scenes on the GPU (Vulkan) or the CPU reference, compare
//! images, and measure the reflectance models.

use anyhow::{bail, Context as _, Result};
use brdfwave::{
    bvh, cpu::CpuRenderer, gpu::GpuRenderer, imageio, metrics, output::RenderOutput, scene, vk,
};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Parser)]
#[command(
    name = "brdfwave",
    version,
    about = "Vulkan wavefront path tracer for the survey's surface models"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Backend {
    Gpu,
    Cpu,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene file to one or more images (.exr linear, .png sRGB).
    Render {
        scene: PathBuf,
        #[arg(long, value_enum, default_value = "gpu")]
        backend: Backend,
        /// Samples per pixel (overrides the scene).
        #[arg(long)]
        spp: Option<u32>,
        /// Image size WxH (overrides the scene).
        #[arg(long, value_parser = parse_res)]
        res: Option<(u32, u32)>,
        /// Maximum path segments; the camera segment is one (overrides the scene).
        #[arg(long)]
        max_depth: Option<u32>,
        #[arg(long)]
        seed: Option<u32>,
        /// Output files; may be given several times. Default: out/<scene name>.png
        #[arg(long = "out")]
        out: Vec<PathBuf>,
        /// Also write the per-pixel variance of one sample (EXR), for statistical tests.
        #[arg(long)]
        variance_out: Option<PathBuf>,
        /// Vulkan device: a case-insensitive part of its name (default: lavapipe if present).
        #[arg(long)]
        device: Option<String>,
        /// Enable the Khronos validation layer (fails the run if it reports anything).
        #[arg(long)]
        validation: bool,
        /// GPU: most paths in flight at a time, 64 to 1048576 (the default). The image does not
        /// depend on it.
        #[arg(long)]
        wave_paths: Option<u32>,
        /// Print the summary as one JSON object on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Compare a test image with a reference: RMSE, relMSE (pbrt) and FLIP.
    Diff {
        test: PathBuf,
        reference: PathBuf,
        /// Write an error map image.
        #[arg(long)]
        error_map: Option<PathBuf>,
        #[arg(long)]
        json: bool,
    },
    /// List the Vulkan devices.
    Devices,
    /// Evaluate, plot and measure reflectance models.
    Brdf {
        #[command(subcommand)]
        command: BrdfCommand,
    },
    /// Randomized numerical-stability checks within a time budget (see src/stress.rs).
    Stress {
        /// Seconds to spend, shared equally by the groups (each runs at least one case).
        #[arg(long, default_value_t = 60.0)]
        budget: f64,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Run again exactly the failing cases listed in this file.
        #[arg(long)]
        replay: Option<PathBuf>,
        /// Where failing cases are written (JSON lines), for --replay.
        #[arg(long, default_value = "stress-failures.jsonl")]
        failures: PathBuf,
        /// Only this group (may be given several times).
        #[arg(long = "group")]
        groups: Vec<String>,
        #[arg(long)]
        device: Option<String>,
    },
}

#[derive(Subcommand)]
enum BrdfCommand {
    /// Evaluate f and pdf for direction pairs from a CSV (header wi_x,wi_y,wi_z,wo_x,wo_y,wo_z).
    Eval {
        /// The material as an inline TOML table, e.g. 'model = "ward", ks = [1,1,1], alpha_x = 0.2, alpha_y = 0.1'.
        #[arg(long)]
        material: String,
        #[arg(long)]
        dirs: PathBuf,
        #[arg(long, value_enum, default_value = "cpu")]
        backend: Backend,
        /// Output CSV (default: stdout).
        #[arg(long)]
        out: Option<PathBuf>,
        #[arg(long)]
        device: Option<String>,
    },
    /// Plot the lobe: polar plot of f·cosθo in the plane of incidence and a hemisphere image.
    Plot {
        #[arg(long)]
        material: String,
        #[arg(long, allow_hyphen_values = true)]
        theta_i: f32,
        #[arg(long)]
        out: PathBuf,
    },
    /// Measure every model at representative parameters: albedo, reciprocity, χ², cost, variance.
    Report {
        #[arg(long, default_value = "out/report")]
        out: PathBuf,
        /// Skip the GPU cost measurement.
        #[arg(long)]
        no_gpu: bool,
        #[arg(long)]
        device: Option<String>,
    },
}

fn parse_res(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}' is not WxH (e.g. 256x256)"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("bad width in '{s}'"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("bad height in '{s}'"))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!(
            "resolution '{s}' must be between 1x1 and 16384x16384"
        ));
    }
    Ok((w, h))
}

fn main() {
    // Rust ignores SIGPIPE, so printing to a closed pipe (`brdfwave diff a b | head`) would
    // panic; restore the default action and end quietly, as other command-line tools do.
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render {
            scene,
            backend,
            spp,
            res,
            max_depth,
            seed,
            out,
            variance_out,
            device,
            validation,
            wave_paths,
            json,
        } => render(RenderArgs {
            scene,
            backend,
            spp,
            res,
            max_depth,
            seed,
            out,
            variance_out,
            device,
            validation,
            wave_paths,
            json,
        }),
        Command::Diff {
            test,
            reference,
            error_map,
            json,
        } => diff(&test, &reference, error_map.as_deref(), json),
        Command::Brdf { command } => brdf_command(command),
        Command::Stress {
            budget,
            seed,
            replay,
            failures,
            groups,
            device,
        } => brdfwave::stress::cli(budget, seed, replay, failures, groups, device),
        Command::Devices => vk::Context::list_devices().map(|d| {
            for name in d {
                println!("{name}");
            }
        }),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

struct RenderArgs {
    scene: PathBuf,
    backend: Backend,
    spp: Option<u32>,
    res: Option<(u32, u32)>,
    max_depth: Option<u32>,
    seed: Option<u32>,
    out: Vec<PathBuf>,
    variance_out: Option<PathBuf>,
    device: Option<String>,
    validation: bool,
    wave_paths: Option<u32>,
    json: bool,
}

fn progress_bar(len: u64, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template(&format!(
            "{{spinner}} {what} [{{bar:40}}] {{pos}}/{{len}} {{elapsed}} eta {{eta}}"
        ))
        .expect("valid template")
        .progress_chars("=> "),
    );
    pb
}

fn render(a: RenderArgs) -> Result<()> {
    let t0 = Instant::now();
    let mut sc = scene::load(&a.scene)?;
    for w in &sc.warnings {
        eprintln!("{w}");
    }
    if let Some(spp) = a.spp {
        if spp == 0 {
            bail!("--spp must be at least 1");
        }
        sc.integrator.spp = spp;
    }
    if let Some((w, h)) = a.res {
        sc.width = w;
        sc.height = h;
    }
    if let Some(d) = a.max_depth {
        if d == 0 {
            bail!("--max-depth must be at least 1 (the camera segment)");
        }
        sc.integrator.max_depth = d;
    }
    if let Some(s) = a.seed {
        sc.integrator.seed = s;
    }
    if let Some(w) = a.wave_paths {
        brdfwave::gpu::check_wave_paths(w).context("--wave-paths")?;
        if a.backend == Backend::Cpu {
            eprintln!("warning: --wave-paths applies to the GPU backend only; ignored");
        }
    }
    let outs = if a.out.is_empty() {
        let stem = a
            .scene
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("render");
        std::fs::create_dir_all("out").context("creating the default output directory out/")?;
        vec![PathBuf::from(format!("out/{stem}.png"))]
    } else {
        a.out.clone()
    };
    for o in outs.iter().chain(a.variance_out.iter()) {
        imageio::check_writable(o)?;
    }
    let t_bvh = Instant::now();
    let bvh = bvh::build(&sc);
    let seconds_bvh = t_bvh.elapsed().as_secs_f64();

    let mut summary = json!({});
    let (output, device, seconds_setup, seconds_render): (RenderOutput, String, f64, f64);
    match a.backend {
        Backend::Gpu => {
            let ctx = vk::Context::new(&vk::ContextOptions {
                device: a.device.clone(),
                validation: a.validation,
            })?;
            let compiler = vk::ShaderCompiler::new()?;
            let wave = a.wave_paths.unwrap_or(brdfwave::gpu::MAX_CAPACITY);
            let mut r = GpuRenderer::with_wave_paths(&ctx, &sc, &bvh, &compiler, wave)?;
            seconds_setup = t0.elapsed().as_secs_f64();
            let pb = progress_bar(sc.integrator.spp as u64, "samples");
            let t = Instant::now();
            output = r.render(&|n| pb.set_position(n as u64))?;
            seconds_render = t.elapsed().as_secs_f64();
            pb.finish_and_clear();
            device = ctx.device_name.clone();
            summary["pipelines"] = json!(r.setup.pipelines);
            summary["seconds_shader_compile"] = json!(r.setup.seconds_shader_compile);
            summary["seconds_pipeline_create"] = json!(r.setup.seconds_pipeline_create);
            summary["wave_paths"] = json!(r.setup.wave_paths);
            summary["subgroup_queues"] = json!(r.setup.subgroup_queues);
            drop(r);
            // Tear down now so that messages raised at device destruction (leaks) count too.
            let msgs = ctx.finish();
            if !msgs.is_empty() {
                bail!(
                    "the validation layer reported {} message(s):\n{}",
                    msgs.len(),
                    msgs.join("\n")
                );
            }
        }
        Backend::Cpu => {
            seconds_setup = t0.elapsed().as_secs_f64();
            let r = CpuRenderer::new(&sc, &bvh);
            let pb = progress_bar(sc.height as u64, "rows");
            let t = Instant::now();
            output = r.render(&|n| pb.set_position(n as u64));
            seconds_render = t.elapsed().as_secs_f64();
            pb.finish_and_clear();
            device = format!("CPU reference ({} threads)", rayon::current_num_threads());
        }
    }
    for o in &outs {
        imageio::write(o, &output.mean).with_context(|| format!("writing {}", o.display()))?;
    }
    if let Some(v) = &a.variance_out {
        imageio::write(v, &output.variance).with_context(|| format!("writing {}", v.display()))?;
    }
    let paths = sc.width as f64 * sc.height as f64 * output.spp as f64;
    let rays = (output.extension_rays + output.shadow_rays) as f64;
    let base = json!({
        "backend": match a.backend { Backend::Gpu => "gpu", Backend::Cpu => "cpu" },
        "device": device,
        "scene": a.scene.display().to_string(),
        "width": sc.width,
        "height": sc.height,
        "spp": output.spp,
        "max_depth": sc.integrator.max_depth,
        "seed": sc.integrator.seed,
        "russian_roulette": sc.integrator.russian_roulette,
        "seconds_bvh": seconds_bvh,
        "bvh_nodes": bvh.nodes.len(),
        "seconds_setup": seconds_setup,
        "seconds_render": seconds_render,
        "paths_per_second": paths / seconds_render.max(1e-9),
        "rays_per_second": rays / seconds_render.max(1e-9),
        "extension_rays": output.extension_rays,
        "shadow_rays": output.shadow_rays,
        "nonfinite_samples": output.nonfinite_samples,
        "nonfinite_by_stage": output.nonfinite_by_stage.iter().map(|(k, v)| json!({"stage": k, "count": v})).collect::<Vec<_>>(),
        "mean_radiance": output.mean.mean(),
        "stage_seconds": output.stage_seconds.iter().map(|(k, v)| json!({"stage": k, "seconds": v})).collect::<Vec<_>>(),
        "outputs": outs.iter().map(|o| o.display().to_string()).collect::<Vec<_>>(),
    });
    for (k, v) in base.as_object().unwrap() {
        summary[k] = v.clone();
    }
    if a.json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        print_summary(&summary);
    }
    if output.nonfinite_samples > 0 {
        eprintln!(
            "warning: {} non-finite values were dropped (see the stages above)",
            output.nonfinite_samples
        );
    }
    Ok(())
}

fn print_summary(s: &serde_json::Value) {
    println!(
        "backend        {} on {}",
        s["backend"].as_str().unwrap_or(""),
        s["device"].as_str().unwrap_or("")
    );
    println!(
        "image          {}x{}, {} spp, max depth {}",
        s["width"], s["height"], s["spp"], s["max_depth"]
    );
    if let Some(p) = s.get("pipelines") {
        println!(
            "pipelines      {} (compile {:.3} s, create {:.3} s)",
            p.as_array()
                .map(|a| a
                    .iter()
                    .filter_map(|x| x.as_str())
                    .collect::<Vec<_>>()
                    .join(", "))
                .unwrap_or_default(),
            s["seconds_shader_compile"].as_f64().unwrap_or(0.0),
            s["seconds_pipeline_create"].as_f64().unwrap_or(0.0)
        );
    }
    if let Some(w) = s.get("wave_paths") {
        let sg = if s["subgroup_queues"] == true {
            ", subgroup-aggregated queue pushes"
        } else {
            ""
        };
        println!("wave           {w} paths in flight{sg}");
    }
    println!(
        "time           set-up {:.3} s (BVH {:.3} s), render {:.3} s",
        s["seconds_setup"].as_f64().unwrap_or(0.0),
        s["seconds_bvh"].as_f64().unwrap_or(0.0),
        s["seconds_render"].as_f64().unwrap_or(0.0)
    );
    println!(
        "throughput     {:.3} M paths/s, {:.3} M rays/s",
        s["paths_per_second"].as_f64().unwrap_or(0.0) / 1e6,
        s["rays_per_second"].as_f64().unwrap_or(0.0) / 1e6
    );
    let by_stage: Vec<String> = s["nonfinite_by_stage"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|e| format!("{} {}", e["stage"].as_str().unwrap_or(""), e["count"]))
        .collect();
    println!(
        "non-finite     {} values dropped ({})",
        s["nonfinite_samples"],
        by_stage.join(", ")
    );
    if let Some(st) = s["stage_seconds"].as_array().filter(|a| !a.is_empty()) {
        let parts: Vec<String> = st
            .iter()
            .map(|e| {
                format!(
                    "{} {:.3}",
                    e["stage"].as_str().unwrap_or(""),
                    e["seconds"].as_f64().unwrap_or(0.0)
                )
            })
            .collect();
        println!("stages (s)     {}", parts.join(", "));
    }
    for o in s["outputs"].as_array().into_iter().flatten() {
        println!("wrote          {}", o.as_str().unwrap_or(""));
    }
}

fn diff(test: &Path, reference: &Path, error_map: Option<&Path>, json_out: bool) -> Result<()> {
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
        println!("{j}");
    } else {
        print!("{report}");
    }
    Ok(())
}

fn brdf_command(cmd: BrdfCommand) -> Result<()> {
    use brdfwave::brdf::inline::parse_inline;
    use brdfwave::brdf_tools as tools;
    match cmd {
        BrdfCommand::Eval {
            material,
            dirs,
            backend,
            out,
            device,
        } => {
            let m = parse_inline(&material)?;
            let pairs = tools::read_direction_csv(&dirs)?;
            let values = match backend {
                Backend::Cpu => tools::eval_cpu(&m, &pairs),
                Backend::Gpu => {
                    let ctx = vk::Context::new(&vk::ContextOptions {
                        device,
                        validation: false,
                    })?;
                    let compiler = vk::ShaderCompiler::new()?;
                    brdfwave::gpu::brdf_probe::eval(&ctx, &compiler, &m, &pairs)?
                }
            };
            let csv = tools::format_eval_csv(&pairs, &values);
            match out {
                Some(p) => tools::write_atomic(&p, csv.as_bytes())?,
                None => print!("{csv}"),
            }
        }
        BrdfCommand::Plot {
            material,
            theta_i,
            out,
        } => {
            if !(0.0..90.0).contains(&theta_i) {
                bail!("--theta-i must be in [0, 90) degrees, got {theta_i}");
            }
            let m = parse_inline(&material)?;
            let img = tools::plot_lobe(m.brdf.as_ref(), theta_i);
            let mut bytes = Vec::new();
            img.write_to(
                &mut std::io::Cursor::new(&mut bytes),
                image::ImageFormat::Png,
            )?;
            tools::write_atomic(&out, &bytes)?;
            println!("wrote {}", out.display());
        }
        BrdfCommand::Report {
            out,
            no_gpu,
            device,
        } => {
            std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
            let gpu = if no_gpu {
                None
            } else {
                let ctx = vk::Context::new(&vk::ContextOptions {
                    device,
                    validation: false,
                })?;
                let compiler = vk::ShaderCompiler::new()?;
                Some((ctx, compiler))
            };
            let mut rows = Vec::new();
            for (label, src) in tools::REPRESENTATIVE {
                if !tools::available(src) {
                    eprintln!("skipping {label}: model not built into this binary");
                    continue;
                }
                eprintln!("measuring {label}");
                let (mut row, m) = tools::report_row(label, src)?;
                if let Some((ctx, compiler)) = &gpu {
                    row.ns_per_eval_gpu =
                        Some(brdfwave::gpu::brdf_probe::eval_cost(ctx, compiler, &m)?);
                }
                let img = tools::plot_lobe(m.brdf.as_ref(), 45.0);
                let mut bytes = Vec::new();
                img.write_to(
                    &mut std::io::Cursor::new(&mut bytes),
                    image::ImageFormat::Png,
                )?;
                tools::write_atomic(
                    &out.join(format!("lobe_{}.png", tools::slug(label))),
                    &bytes,
                )?;
                rows.push(row);
            }
            let device_name = gpu.as_ref().map(|(c, _)| c.device_name.clone());
            let md = tools::report_markdown(&rows, device_name.as_deref());
            tools::write_atomic(&out.join("report.md"), md.as_bytes())?;
            tools::write_atomic(&out.join("report.csv"), tools::report_csv(&rows).as_bytes())?;
            print!("{md}");
            println!(
                "\nwrote {}/report.md, report.csv and lobe_*.png",
                out.display()
            );
        }
    }
    Ok(())
}
