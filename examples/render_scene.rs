//! Renders the Cornell box small through the library API and writes an EXR:
//!
//! ```text
//! cargo run --release --example render_scene -- [cpu|gpu] [OUT.exr]
//! ```
//!
//! (default: the CPU reference, `out/render_scene.exr`).

use anyhow::{bail, Result};
use brdfwave::api::{self, Options, Scene};
use std::path::PathBuf;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let base = match args.next().as_deref() {
        None | Some("cpu") => Options::cpu(),
        Some("gpu") => Options::gpu(),
        Some(other) => bail!("unknown backend '{other}': expected cpu or gpu"),
    };
    let out = PathBuf::from(args.next().unwrap_or("out/render_scene.exr".into()));
    let scene = Scene::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-box.toml"
    ))?;
    let options = Options {
        res: Some((64, 64)),
        spp: Some(16),
        seed: Some(1),
        ..base
    };
    let r = api::render(&scene, &options)?;
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    brdfwave::imageio::write(&out, &r.image)?;
    let mean = r.image.mean();
    println!(
        "{}x{}, {} spp on {} ({}) in {:.3} s: mean radiance {:.4} {:.4} {:.4}, {} non-finite; wrote {}",
        r.image.width,
        r.image.height,
        r.spp,
        r.device,
        r.backend,
        r.seconds,
        mean[0],
        mean[1],
        mean[2],
        r.nonfinite_samples,
        out.display()
    );
    Ok(())
}
