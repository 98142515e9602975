//! The runners: one configuration rendering pass by pass; brdfwave's own through
//! [`crate::render`] ([`RendererRunner`]), Mitsuba's in [`super::mitsuba`].

use super::mitsuba::MitsubaRunner;
use super::{Config, Details};
use crate::bvh::Bvh;
use crate::film::Tile;
use crate::gpu::GpuOptions;
use crate::imageio::Image;
use crate::output::RenderOutput;
use crate::render::{self, RenderRequest, Renderer};
use crate::scene::Scene;
use crate::vk::{Context, ShaderCompiler};
use anyhow::{anyhow, Result};
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

pub(super) trait Runner {
    /// Renders `n` more samples per pixel; returns the samples per pixel of the image now (a
    /// sampler may round a count up) and the render seconds that image took.
    fn pass(&mut self, n: u32) -> Result<(u32, f64)>;
    /// The running mean of all passes so far.
    fn image(&mut self) -> Result<Image>;
    fn details(&mut self) -> Details;
}

/// brdfwave's own configurations, on either backend, through [`crate::render`]. With a sampler
/// whose points do not depend on the sample count (`sobol`, `independent`) each pass continues
/// the renderer's sample sequence, so the image after k samples is a k-sample render. The
/// `multijitter` pattern is sized by the render's sample count, so there each pass is a fresh
/// render of all the samples so far, set up apart and timed alone, as the Mitsuba peer's
/// stratified samplers are measured.
struct RendererRunner<'a> {
    backend: render::Backend<'a>,
    scene: &'a Scene,
    bvh: Arc<Bvh>,
    /// The renderer that continues the sequence (None: a fresh render per pass).
    renderer: Option<Box<dyn Renderer + 'a>>,
    setup_seconds: f64,
    done: u32,
    seconds: f64,
    /// The image after the last pass, and its counts.
    last: Option<RenderOutput>,
    /// The description of the last renderer that ran.
    description: Option<render::Description>,
}

impl<'a> RendererRunner<'a> {
    fn start(backend: render::Backend<'a>, scene: &'a Scene, bvh: Arc<Bvh>) -> Result<Self> {
        let mut r = RendererRunner {
            backend,
            scene,
            bvh: bvh.clone(),
            renderer: None,
            setup_seconds: 0.0,
            done: 0,
            seconds: 0.0,
            last: None,
            description: None,
        };
        if scene.integrator.sampler != crate::rng::Sampler::Multijitter {
            let t = Instant::now();
            let renderer =
                render::open(backend, scene, bvh, Tile::full(scene.width, scene.height))?;
            r.setup_seconds = t.elapsed().as_secs_f64();
            r.renderer = Some(renderer);
        }
        Ok(r)
    }
}

impl Runner for RendererRunner<'_> {
    fn pass(&mut self, n: u32) -> Result<(u32, f64)> {
        let total = self.done + n;
        let r = match &mut self.renderer {
            Some(renderer) => {
                let request = RenderRequest::samples(self.done..total);
                let r = renderer.render(&request, &|_| {})?;
                self.description = Some(renderer.describe());
                self.seconds += r.seconds_samples;
                r
            }
            None => {
                let mut sc = self.scene.clone();
                sc.integrator.spp = total;
                sc.integrator.pattern_spp = None;
                let t = Instant::now();
                let tile = Tile::full(sc.width, sc.height);
                let mut renderer = render::open(self.backend, &sc, self.bvh.clone(), tile)?;
                self.setup_seconds += t.elapsed().as_secs_f64();
                let request = RenderRequest::samples(0..total);
                let r = renderer.render(&request, &|_| {})?;
                self.description = Some(renderer.describe());
                self.seconds = r.seconds_samples;
                // A short render is timed twice, the faster kept (the same image: the render
                // depends on the seed and the samples alone), as the Mitsuba peer's are.
                if r.seconds_samples < super::REPEAT_BELOW {
                    drop(renderer);
                    let mut again = render::open(self.backend, &sc, self.bvh.clone(), tile)?;
                    let s = again.render(&request, &|_| {})?;
                    self.seconds = self.seconds.min(s.seconds_samples);
                }
                r
            }
        };
        self.done = total;
        self.last = Some(r.output);
        Ok((self.done, self.seconds))
    }
    fn image(&mut self) -> Result<Image> {
        let out = self.last.as_ref().ok_or_else(|| anyhow!("no pass yet"))?;
        Ok(out.mean.clone())
    }
    fn details(&mut self) -> Details {
        let d = match (&self.description, &self.renderer) {
            (Some(d), _) => d.clone(),
            (None, Some(r)) => r.describe(),
            (None, None) => return Details::default(),
        };
        let setup = d.gpu.map(|g| g.setup).unwrap_or_default();
        let out = self.last.as_ref();
        Details {
            device: d.device,
            setup_seconds: self.setup_seconds,
            rays: out.map(|o| o.extension_rays + o.shadow_rays).unwrap_or(0),
            rays_by_segment: out.map(|o| o.rays_by_segment.clone()).unwrap_or_default(),
            stage_seconds: out.map(|o| o.stage_seconds.clone()).unwrap_or_default(),
            pipelines_compile: setup.seconds_shader_compile,
            pipelines_create: setup.seconds_pipeline_create,
            ..Default::default()
        }
    }
}

/// The runner of configuration `c`: ours through [`crate::render`] on the scene `sc` as the
/// configuration renders it (a GPU configuration has its context `ctx`), or the Mitsuba peer
/// when it could be set up (`mitsuba_ok`).
#[allow(clippy::too_many_arguments)]
pub(super) fn runner<'a>(
    c: &Config,
    ctx: Option<&'a Context>,
    sc: &'a Scene,
    bvh: &Arc<Bvh>,
    compiler: &'a ShaderCompiler,
    mitsuba_ok: &Result<()>,
    mitsuba_xml: &Path,
    out: &Path,
) -> Result<Box<dyn Runner + 'a>> {
    match (c, ctx) {
        (Config::Gpu { .. } | Config::Cpu { .. }, ctx) => {
            let backend = match (c, ctx) {
                (Config::Gpu { integrator, .. }, Some(ctx)) => render::Backend::Gpu {
                    ctx,
                    compiler,
                    options: GpuOptions {
                        integrator: *integrator,
                        ..GpuOptions::default()
                    },
                },
                (Config::Gpu { .. }, None) => unreachable!("a GPU configuration has a context"),
                _ => render::Backend::Cpu,
            };
            RendererRunner::start(backend, sc, bvh.clone()).map(|r| Box::new(r) as Box<dyn Runner>)
        }
        (Config::Mitsuba { variant, sampler }, _) => match mitsuba_ok {
            Ok(()) => MitsubaRunner::start(variant, sampler, mitsuba_xml, out)
                .map(|r| Box::new(r) as Box<dyn Runner>),
            Err(e) => Err(anyhow!("{e}")),
        },
    }
}
