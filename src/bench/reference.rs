//! The reference image: a given file, or one rendered by the CPU reference and cached.

use super::BenchOptions;
use crate::bvh::Bvh;
use crate::imageio::{self, Image};
use crate::render;
use crate::scene::Scene;
use crate::vk;
use anyhow::{bail, Context as _, Result};
use std::sync::Arc;
use std::time::Instant;

/// The reference's own expected relMSE, from its per-sample variance: the mean over
/// pixel-channels of var / (N (r + 0.01)²), the expected relMSE of an N-sample mean of
/// independent samples (an upper bound for a `sobol` reference, whose mean varies less).
fn reference_error(mean: &Image, variance: &Image, n: u32) -> f64 {
    let mut sum = 0.0;
    for (m, v) in mean.data.iter().zip(&variance.data) {
        for c in 0..3 {
            let r = m[c] as f64 + 0.01;
            sum += v[c] as f64 / n as f64 / (r * r);
        }
    }
    sum / (3 * mean.data.len()).max(1) as f64
}

/// The reference image: the given file, or one rendered by the CPU reference at
/// `reference_spp` with a seed of its own and cached; and, for a rendered one, its own
/// expected relMSE ([`reference_error`]).
pub(super) fn reference(
    o: &BenchOptions,
    sc: &Scene,
    bvh: &Arc<Bvh>,
) -> Result<(Image, Option<f64>)> {
    if let Some(p) = &o.reference {
        let img =
            imageio::read(p).with_context(|| format!("reading --reference {}", p.display()))?;
        if img.count_nonfinite() > 0 {
            bail!(
                "--reference {} holds {} non-finite values: a reference must be finite (relMSE would leave them out)",
                p.display(),
                img.count_nonfinite()
            );
        }
        if img.width != sc.width || img.height != sc.height {
            bail!(
                "--reference {} is {}x{}, the benchmark renders {}x{}",
                p.display(),
                img.width,
                img.height,
                sc.width,
                sc.height
            );
        }
        return Ok((img, None));
    }
    let mut key = crate::hash::Fnv64::new();
    let scene = crate::infile::read(&o.scene, crate::infile::SCENE)
        .with_context(|| format!("reading {}", crate::errors::shown_path(&o.scene)))?;
    key.bytes(&scene);
    for v in [
        sc.width,
        sc.height,
        sc.integrator.max_depth,
        sc.integrator.seed,
        o.reference_spp,
    ] {
        key.u64(v as u64);
    }
    key.u64(sc.integrator.russian_roulette as u64);
    key.bytes(sc.integrator.sampler.name().as_bytes());
    if let Ok(exe) = std::env::current_exe().and_then(std::fs::read) {
        key.bytes(&exe);
    }
    let cache = vk::cache::default_cache_dir().map(|d| {
        d.join("reference")
            .join(format!("{:016x}.exr", key.finish()))
    });
    let error_file = cache.as_ref().map(|p| p.with_extension("relmse"));
    if let Some(p) = cache.as_ref().filter(|p| p.exists()) {
        // A cache entry that does not read back as a finite image of the right size is
        // discarded and rendered again, never fatal.
        match imageio::read(p) {
            Ok(img) if img.width == sc.width && img.height == sc.height && img.count_nonfinite() == 0 => {
                eprintln!("reference: {} (cached)", p.display());
                let err = error_file
                    .as_ref()
                    .and_then(|f| std::fs::read_to_string(f).ok())
                    .and_then(|s| s.trim().parse().ok());
                return Ok((img, err));
            }
            Ok(img) => eprintln!(
                "warning: discarding the cached reference {} ({}x{}, {} non-finite values); rendering it again",
                p.display(),
                img.width,
                img.height,
                img.count_nonfinite()
            ),
            Err(e) => eprintln!("warning: discarding the cached reference: {e}; rendering it again"),
        }
    }
    let mut rs = sc.clone();
    rs.integrator.seed ^= 0x5EED_5EED;
    rs.integrator.spp = o.reference_spp;
    eprintln!(
        "reference: rendering {} spp on the CPU reference (once; cached)",
        o.reference_spp
    );
    let t = Instant::now();
    let out = render::render_all(render::Backend::Cpu, &rs, bvh.clone())?;
    let err = reference_error(&out.mean, &out.variance, o.reference_spp);
    let img = out.mean;
    eprintln!("reference: {:.1} s", t.elapsed().as_secs_f64());
    if let Some(p) = &cache {
        if let Some(dir) = p.parent() {
            let _ = std::fs::create_dir_all(dir);
        }
        // The program's own cache entry, read above and found stale: it may be replaced.
        crate::infile::forget(p);
        if let Err(e) = imageio::write(p, &img) {
            eprintln!(
                "warning: could not cache the reference at {}: {e}",
                p.display()
            );
        } else if let Some(f) = &error_file {
            let _ = crate::outfile::write(f, format!("{err:e}\n").as_bytes());
        }
    }
    Ok((img, Some(err)))
}
