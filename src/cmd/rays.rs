//! `brdfwave rays`: the BVH traversal alone, brdfwave's against the platform's ray queries
//! (`brdfwave::bench::rays`).

use super::parse_res;
use anyhow::{bail, Result};
use brdfwave::bench::rays::{self, RaysOptions};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct RaysArgs {
    /// The scene file whose rays are traced (triangles only).
    scene: PathBuf,
    /// Image size WxH of the camera rays (overrides the scene).
    #[arg(value_name = "WxH", long, value_parser = parse_res)]
    res: Option<(u32, u32)>,
    /// Camera rays per pixel; each camera hit adds one bounce ray and one shadow ray.
    #[arg(value_name = "N", long, default_value_t = 4)]
    per_pixel: u32,
    /// Seed of the rays' random numbers.
    #[arg(value_name = "N", long, default_value_t = 1)]
    seed: u64,
    /// Timed dispatches per kernel and kind of ray, after an untimed one; the fastest counts.
    #[arg(value_name = "N", long, default_value_t = 5)]
    repeats: u32,
    /// Vulkan device: a case-insensitive part of its name (default: lavapipe if present). It
    /// needs VK_KHR_ray_query (lavapipe from Mesa 24.1) unless --ours-only.
    #[arg(value_name = "NAME", long)]
    device: Option<String>,
    /// Trace with brdfwave's traversal alone (a device without ray queries).
    #[arg(long)]
    ours_only: bool,
}

pub fn run(a: RaysArgs) -> Result<()> {
    if a.per_pixel == 0 || a.per_pixel > 1024 {
        bail!("--per-pixel takes 1 to 1024 rays, got {}", a.per_pixel);
    }
    if a.repeats == 0 || a.repeats > 1000 {
        bail!("--repeats takes 1 to 1000, got {}", a.repeats);
    }
    let mut scene = brdfwave::scene::load(&a.scene)?;
    if let Some((w, h)) = a.res {
        (scene.width, scene.height) = (w, h);
    }
    let report = rays::run(
        &scene,
        &RaysOptions {
            per_pixel: a.per_pixel,
            seed: a.seed,
            repeats: a.repeats,
            device: a.device,
            ours_only: a.ours_only,
        },
    )?;
    outln!("Host: {}.", brdfwave::bench::machine())?;
    outln!("Device: {} ({}).", report.device, report.driver)?;
    outln!(
        "Scene: {}, {} triangles, {}x{} pixels, {} camera rays per pixel.\n",
        a.scene.display(),
        scene.triangles.len(),
        scene.width,
        scene.height,
        a.per_pixel
    )?;
    outln!("| rays | count | brdfwave M rays/s | ray query M rays/s | brdfwave / ray query | same hit | CPU traversal M rays/s |")?;
    outln!("|---|---|---|---|---|---|---|")?;
    for r in &report.rows {
        let q = r.query_mrays.map_or("–".into(), |q| format!("{q:.3}"));
        let ratio = r
            .query_mrays
            .map_or("–".into(), |q| format!("{:.2}x", r.ours_mrays / q));
        let agree = r
            .agreement
            .map_or("–".into(), |s| format!("{:.4} %", 100.0 * s));
        outln!(
            "| {} | {} | {:.3} | {q} | {ratio} | {agree} | {:.3} |",
            r.kind,
            r.rays,
            r.ours_mrays,
            r.cpu_mrays
        )?;
    }
    Ok(())
}
