//! The CPU reference (`crate::cpu::CpuRenderer`) behind [`Renderer`]: the adapter holds the film
//! that the CPU renderer is passed.

use super::{Description, Progress, ProgressUnit, RenderRequest, Renderer};
use crate::bvh::Bvh;
use crate::cpu::{CpuFilm, CpuRenderer};
use crate::film::{self, Film, Tile};
use crate::output::RenderOutput;
use crate::scene::Scene;
use anyhow::Result;
use std::ops::Range;
use std::sync::Arc;

pub struct CpuBackend<'a> {
    renderer: CpuRenderer<'a>,
    film: CpuFilm,
}

impl<'a> CpuBackend<'a> {
    /// A renderer of `tile` (within the image) of `scene`, with an empty film.
    pub fn new(scene: &'a Scene, bvh: Arc<Bvh>, tile: Tile) -> Self {
        let renderer = CpuRenderer::new(scene, bvh);
        let film = renderer.film_of(tile);
        CpuBackend { renderer, film }
    }

    /// `scene.integrator.spp` samples per pixel of the whole image. Unlike
    /// [`Renderer::render`] it does not ask first whether the film fits in memory, so it cannot
    /// fail: for the small scenes of the stress harness, whose geometry cases catch panics.
    pub fn render_all(scene: &'a Scene, bvh: Arc<Bvh>) -> RenderOutput {
        let mut r = CpuBackend::new(scene, bvh, Tile::full(scene.width, scene.height));
        r.add(0..scene.integrator.spp, &|_| {});
        r.renderer.output(&r.film)
    }

    /// Adds the samples `samples` to the film.
    fn add(&mut self, samples: Range<u32>, progress: &(dyn Fn(Progress) + Sync)) {
        let total = ProgressUnit::Rows.total(self.film.film.tile, &samples);
        let report = ProgressUnit::Rows.reporter(total, progress);
        self.renderer
            .render_samples(&mut self.film, samples, &|rows| report(rows as f64));
    }
}

impl Renderer for CpuBackend<'_> {
    fn add_samples(
        &mut self,
        request: &RenderRequest,
        progress: &(dyn Fn(Progress) + Sync),
    ) -> Result<()> {
        let tile = self.film.film.tile;
        film::check_continues(&self.film.film.samples(), &request.samples)?;
        // The film (6 f64 sums per pixel and block), the mean and variance images, and the
        // encoded output (a partial film is the sums again): an allocation that fails aborts,
        // so ask first.
        let blocks = film::dyadic_blocks(request.samples.clone()).len() as u64;
        let per_pixel = 48 * blocks + 24 + if request.take_film { 48 * blocks } else { 12 };
        crate::memory::check(
            tile.pixels() as u64 * per_pixel,
            &format!("a CPU render of {}x{} pixels", tile.width, tile.height),
            "render a smaller image or split it into tiles (--tile)",
        )?;
        self.add(request.samples.clone(), progress);
        Ok(())
    }

    fn output(&mut self) -> Result<RenderOutput> {
        Ok(self.renderer.output(&self.film))
    }

    fn take_film(&mut self) -> Result<Film> {
        let empty = self.renderer.film_of(self.film.film.tile);
        Ok(std::mem::replace(&mut self.film, empty).film)
    }

    fn describe(&self) -> Description {
        Description {
            backend: "cpu",
            device: format!("CPU reference ({} threads)", rayon::current_num_threads()),
            progress: ProgressUnit::Rows,
            gpu: None,
        }
    }
}
