//! The library entry point: load a scene, render it on a backend, get the image and its
//! statistics, in three calls. A thin layer over [`crate::scene`] and [`crate::render`] (the
//! [`Renderer`](crate::render::Renderer) interface that `brdfwave render` itself uses), so the
//! same scene, options and seed give the same pixels as the command line, bit for bit.
//!
//! ```no_run
//! use brdfwave::api::{self, Options, Scene};
//!
//! fn main() -> anyhow::Result<()> {
//!     let scene = Scene::load("scenes/cornell-box.toml")?;
//!     let options = Options {
//!         res: Some((64, 64)),
//!         spp: Some(16),
//!         ..Options::cpu()
//!     };
//!     let r = api::render(&scene, &options)?;
//!     assert_eq!(r.nonfinite_samples, 0);
//!     println!("{} spp in {:.2} s on {}", r.spp, r.seconds, r.device);
//!     brdfwave::imageio::write(std::path::Path::new("cornell.exr"), &r.image)?;
//!     Ok(())
//! }
//! ```
//!
//! For split renders (sample ranges, tiles, partial films), progress reports or several
//! renders on one Vulkan device, use [`crate::render::open`] directly.

use crate::gpu::{GpuOptions, Integrator, MAX_WAVE_PATHS};
use crate::render::{self, Overrides, RenderRequest};
use crate::rng::Sampler;
use crate::vk::{Context, ContextOptions, ShaderCompiler};
use anyhow::{bail, Context as _, Result};
use std::path::Path;
use std::time::Instant;

pub use crate::imageio::Image;
pub use crate::scene::Scene;

impl Scene {
    /// Loads a scene file: TOML, or Mitsuba 3 XML when it ends in `.xml` (`scenes/README.md`
    /// documents both). Its warnings are in [`Scene::warnings`].
    pub fn load(path: impl AsRef<Path>) -> Result<Scene> {
        Ok(crate::scene::load(path.as_ref())?)
    }
}

/// Which renderer [`render`] uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// The CPU reference path tracer, on rayon's global thread pool.
    Cpu,
    /// The Vulkan wavefront integrator (lavapipe when present; see [`Options::device`]).
    Gpu,
}

/// How to render; `None` keeps the scene file's setting, as the `brdfwave render` options of
/// the same names do.
#[derive(Clone, Debug)]
pub struct Options {
    pub backend: Backend,
    /// Samples per pixel, at least 1.
    pub spp: Option<u32>,
    /// Image size (width, height).
    pub res: Option<(u32, u32)>,
    /// Maximum path segments (the camera segment is one), 1 ..= [`crate::conventions::MAX_DEPTH`].
    pub max_depth: Option<u32>,
    pub seed: Option<u32>,
    pub sampler: Option<Sampler>,
    /// GPU: a case-insensitive part of the Vulkan device's name (default: lavapipe if present).
    pub device: Option<String>,
    /// GPU: how paths are followed; every choice gives the same image. Default `Auto`, as on
    /// the command line.
    pub integrator: Integrator,
    /// GPU: most paths in flight at a time, 64 to [`MAX_WAVE_PATHS`] (the default).
    pub wave_paths: u32,
}

impl Options {
    /// The CPU reference with the scene's settings.
    pub fn cpu() -> Options {
        Options {
            backend: Backend::Cpu,
            spp: None,
            res: None,
            max_depth: None,
            seed: None,
            sampler: None,
            device: None,
            integrator: Integrator::Auto,
            wave_paths: MAX_WAVE_PATHS,
        }
    }

    /// The Vulkan integrator with the scene's settings and the command line's defaults.
    pub fn gpu() -> Options {
        Options {
            backend: Backend::Gpu,
            ..Options::cpu()
        }
    }
}

/// A finished render: the image and its statistics.
pub struct Render {
    /// Per-pixel mean radiance, linear RGB.
    pub image: Image,
    /// Per-pixel variance of one sample (unbiased); the variance of the mean is this over `spp`.
    pub variance: Image,
    pub spp: u32,
    /// Seconds of rendering (without loading the scene, building the BVH or set-up).
    pub seconds: f64,
    /// Non-finite (NaN or infinite) values dropped: 0 in a correct render.
    pub nonfinite_samples: u64,
    /// The same by stage (`extend`, `shade_<model>`, `accumulate`).
    pub nonfinite_by_stage: Vec<(String, u64)>,
    /// Extension (closest-hit) and shadow (any-hit) rays traced.
    pub extension_rays: u64,
    pub shadow_rays: u64,
    /// Shadow rays that found an occluder.
    pub shadow_rays_occluded: u64,
    /// `cpu` or `gpu`, and the device in words.
    pub backend: &'static str,
    pub device: String,
}

/// Renders `scene` with `options` (applied to a copy of the scene). The GPU backend makes its
/// Vulkan device and shader compiler for this call and fails if there is no Vulkan device.
pub fn render(scene: &Scene, options: &Options) -> Result<Render> {
    let mut sc = scene.clone();
    let overrides = Overrides {
        spp: options.spp,
        res: options.res,
        max_depth: options.max_depth,
        seed: options.seed,
        sampler: options.sampler,
        samples: None,
        tile: None,
    };
    let part = overrides.apply(&mut sc)?;
    let bvh = crate::bvh::build_for(
        &sc,
        match options.backend {
            Backend::Gpu => crate::bvh::Traversal::GpuOnly,
            Backend::Cpu => crate::bvh::Traversal::CpuOnly,
        },
    );
    crate::memory::release_free_heap();
    let gpu = match options.backend {
        Backend::Cpu => None,
        Backend::Gpu => {
            crate::gpu::check_wave_paths(options.wave_paths).context("wave_paths")?;
            let ctx = Context::new(&ContextOptions {
                device: options.device.clone(),
                validation: false,
                ray_query: false,
            })?;
            Some((ctx, ShaderCompiler::new()?))
        }
    };
    let backend = match &gpu {
        Some((ctx, compiler)) => render::Backend::Gpu {
            ctx,
            compiler,
            options: GpuOptions {
                wave_paths: options.wave_paths,
                integrator: options.integrator,
                tile: None,
            },
        },
        None => render::Backend::Cpu,
    };
    let mut r = render::open(backend, &sc, std::sync::Arc::new(bvh), part.tile)?;
    let description = r.describe();
    let t = Instant::now();
    let out = r
        .render(&RenderRequest::samples(part.samples), &|_| {})?
        .output;
    let seconds = t.elapsed().as_secs_f64();
    drop(r);
    if let Some((ctx, compiler)) = gpu {
        drop(compiler);
        let msgs = ctx.finish();
        if !msgs.is_empty() {
            bail!("the Vulkan driver reported: {}", msgs.join("\n"));
        }
    }
    Ok(Render {
        image: out.mean,
        variance: out.variance,
        spp: out.spp,
        seconds,
        nonfinite_samples: out.nonfinite_samples,
        nonfinite_by_stage: out.nonfinite_by_stage,
        extension_rays: out.extension_rays,
        shadow_rays: out.shadow_rays,
        shadow_rays_occluded: out.shadow_rays_occluded,
        backend: description.backend,
        device: description.device,
    })
}
