//! The Vulkan integrator (`crate::gpu::GpuRenderer`) behind [`Renderer`]: it holds its film on
//! the device, and its tile from its creation.

use super::{Description, GpuDescription, Progress, ProgressUnit, RenderRequest, Renderer};
use crate::bvh::Bvh;
use crate::film::{Film, Tile};
use crate::gpu::{GpuOptions, GpuRenderer, Integrator};
use crate::output::RenderOutput;
use crate::scene::Scene;
use crate::vk::{Context, ShaderCompiler};
use anyhow::Result;
use std::sync::Arc;

pub struct GpuBackend<'a> {
    renderer: GpuRenderer<'a>,
    ctx: &'a Context,
    integrator: Integrator,
}

impl<'a> GpuBackend<'a> {
    /// A renderer of `tile` (within the image) of `scene` with `options` (whose own tile is
    /// replaced by `tile`), with an empty film.
    pub fn new(
        ctx: &'a Context,
        compiler: &ShaderCompiler,
        scene: &'a Scene,
        bvh: Arc<Bvh>,
        tile: Tile,
        options: GpuOptions,
    ) -> Result<Self> {
        let options = GpuOptions {
            tile: Some(tile),
            ..options
        };
        let renderer = GpuRenderer::with_options(ctx, scene, bvh, compiler, options)?;
        Ok(GpuBackend {
            integrator: renderer.integrator(),
            renderer,
            ctx,
        })
    }
}

impl Renderer for GpuBackend<'_> {
    fn add_samples(
        &mut self,
        request: &RenderRequest,
        progress: &(dyn Fn(Progress) + Sync),
    ) -> Result<()> {
        let total = request.samples.len() as f64;
        let report = ProgressUnit::Samples.reporter(total, progress);
        self.renderer
            .render_samples(request.samples.clone(), &report)
    }

    fn output(&mut self) -> Result<RenderOutput> {
        self.renderer.output()
    }

    /// Downloaded again (`output` keeps only the images), and the device's film cleared.
    fn take_film(&mut self) -> Result<Film> {
        let film = self.renderer.film()?;
        self.renderer.reset()?;
        Ok(film)
    }

    fn describe(&self) -> Description {
        Description {
            backend: "gpu",
            device: self.ctx.device_name.clone(),
            progress: ProgressUnit::Samples,
            gpu: Some(GpuDescription {
                integrator: self.integrator,
                setup: self.renderer.setup.clone(),
            }),
        }
    }
}
