//! One interface to both renderers: the Vulkan wavefront integrator (`crate::gpu`) and the CPU
//! reference (`crate::cpu`), used alike by `brdfwave render`, `bench`, `stress` and the tests.
//!
//! As in pbrt-v4 and Mitsuba 3, where an integrator renders into a film it owns and the caller
//! only asks for samples and reads the film back (pbrt-v4 `Integrator::Render`, `Film`; Mitsuba
//! `Integrator::render`), the caller here says once what is rendered (the scene, with the
//! [`Overrides`] of the command line applied, its BVH and the [`Tile`] of the image: they fix
//! the renderer's buffers) and on which [`Backend`]; then each [`Renderer::render`] call adds a
//! [`RenderRequest`]'s samples to the renderer's film and returns the image so far. A render
//! split into calls, processes or machines gives the same sums, bit for bit (`crate::film`).
//!
//! A render in independent batches, for the variance of each pixel's mean, is a sequence of
//! such calls (`batches.rs`).
//!
//! The adapters (`cpu.rs`, `gpu.rs`) hold the backends' own renderers and reconcile what
//! differed: the film (passed in by the CPU, held by the GPU), the tile (of the film on the
//! CPU, of the renderer on the GPU) and the progress (rows on the CPU, samples on the GPU; here
//! one [`Progress`] that says its unit).

mod batches;
mod cpu;
mod gpu;
mod request;

pub use batches::{render_batches, Batches};
pub use cpu::CpuBackend;
pub use gpu::GpuBackend;
pub use request::{Overrides, RenderRequest, Resolved};

use crate::bvh::Bvh;
use crate::film::{Film, Tile};
use crate::gpu::{Integrator, SetupStats};
use crate::output::RenderOutput;
use crate::scene::Scene;
use crate::vk::{Context, ShaderCompiler};
use anyhow::Result;
use std::sync::Arc;

/// A renderer of one tile of one scene, with a film that each [`render`](Renderer::render)
/// call adds samples to. A backend supplies the three steps of a call; what a call means (its
/// timing, the film handed over) is [`render`](Renderer::render)'s, written once for both.
pub trait Renderer {
    /// Adds the request's samples (the ones after those already in the film, or any while it is
    /// empty) of every pixel of the tile to the film, or says why it cannot. `progress` is
    /// called from the rendering threads as the work goes on.
    fn add_samples(
        &mut self,
        request: &RenderRequest,
        progress: &(dyn Fn(Progress) + Sync),
    ) -> Result<()>;
    /// The image of all the samples in the film so far, and the counts of their paths.
    fn output(&mut self) -> Result<RenderOutput>;
    /// The film (its sums), handed over; the renderer's film is then empty again.
    fn take_film(&mut self) -> Result<Film>;
    /// The backend, device and set-up, for summaries.
    fn describe(&self) -> Description;

    /// Adds the request's samples ([`add_samples`](Renderer::add_samples)) and returns the image
    /// so far, with the film when the request asks for it.
    fn render(
        &mut self,
        request: &RenderRequest,
        progress: &(dyn Fn(Progress) + Sync),
    ) -> Result<Rendered> {
        let t = std::time::Instant::now();
        self.add_samples(request, progress)?;
        let seconds_samples = t.elapsed().as_secs_f64();
        let output = self.output()?;
        let film = match request.take_film {
            true => Some(self.take_film()?),
            false => None,
        };
        Ok(Rendered {
            output,
            film,
            seconds_samples,
        })
    }
}

/// What one [`Renderer::render`] call returns.
pub struct Rendered {
    /// The image of all the samples in the film so far, and the counts of their paths.
    pub output: RenderOutput,
    /// The film itself (its sums), when the request asked for it (`take_film`); the renderer's
    /// film is then empty again.
    pub film: Option<Film>,
    /// Seconds spent adding the samples, without reading the image back.
    pub seconds_samples: f64,
}

/// How far a [`Renderer::render`] call is: `done` of `total` units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    pub done: f64,
    pub total: f64,
    pub unit: ProgressUnit,
}

/// What [`Progress`] counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgressUnit {
    /// Rows of the tile finished (the CPU renders rows in parallel, all samples of a pixel at
    /// once).
    Rows,
    /// Samples per pixel done, fractional within a wave (the GPU renders waves of samples).
    Samples,
}

impl ProgressUnit {
    /// The units of a render of `samples` of `tile`.
    pub fn total(self, tile: Tile, samples: &std::ops::Range<u32>) -> f64 {
        match self {
            ProgressUnit::Rows => tile.height as f64,
            ProgressUnit::Samples => samples.len() as f64,
        }
    }

    /// `progress` as the callback of a backend's own renderer, which counts `done` in this
    /// unit out of `total`.
    pub fn reporter<'p>(
        self,
        total: f64,
        progress: &'p (dyn Fn(Progress) + Sync),
    ) -> impl Fn(f64) + Sync + 'p {
        move |done| {
            progress(Progress {
                done,
                total,
                unit: self,
            })
        }
    }
}

/// A renderer's backend, device and set-up.
#[derive(Clone, Debug)]
pub struct Description {
    /// `gpu` or `cpu`, as `--backend` names it.
    pub backend: &'static str,
    /// The device, in words: the Vulkan device's name, or the CPU reference and its threads.
    pub device: String,
    pub progress: ProgressUnit,
    /// The GPU's set-up (pipelines, their compile and create times, the wave); None on the CPU.
    pub gpu: Option<GpuDescription>,
}

#[derive(Clone, Debug)]
pub struct GpuDescription {
    pub integrator: Integrator,
    pub setup: SetupStats,
}

/// Where to render.
#[derive(Clone, Copy)]
pub enum Backend<'c> {
    /// The CPU reference path tracer.
    Cpu,
    /// The Vulkan integrator on this device, with these options (`tile` is ignored: the tile is
    /// given to [`open`]).
    Gpu {
        ctx: &'c Context,
        compiler: &'c ShaderCompiler,
        options: crate::gpu::GpuOptions,
    },
}

impl<'c> Backend<'c> {
    /// The GPU with the default options: the wavefront integrator, the largest wave.
    pub fn gpu(ctx: &'c Context, compiler: &'c ShaderCompiler) -> Self {
        Backend::Gpu {
            ctx,
            compiler,
            options: crate::gpu::GpuOptions::default(),
        }
    }
}

/// A renderer of `tile` of `scene` (whose BVH is `bvh`) on `backend`, with an empty film. The
/// tile must lie within the image. The CPU reference keeps the BVH; the GPU uploads it and
/// lets go of it, so a caller that passes its only reference frees the host's copy here (36 MB
/// of nodes for a million triangles: docs/bench-log.md, the scene's memory).
pub fn open<'a>(
    backend: Backend<'a>,
    scene: &'a Scene,
    bvh: Arc<Bvh>,
    tile: Tile,
) -> Result<Box<dyn Renderer + 'a>> {
    tile.check_within(scene.width, scene.height)
        .map_err(anyhow::Error::msg)?;
    Ok(match backend {
        Backend::Cpu => Box::new(CpuBackend::new(scene, bvh, tile)),
        Backend::Gpu {
            ctx,
            compiler,
            options,
        } => Box::new(GpuBackend::new(ctx, compiler, scene, bvh, tile, options)?),
    })
}

/// Renders `scene.integrator.spp` samples per pixel of the whole image on `backend`, building
/// the BVH: the common case of the tests and the stress harness.
pub fn render_whole(backend: Backend<'_>, scene: &Scene) -> Result<RenderOutput> {
    render_all(backend, scene, Arc::new(crate::bvh::build(scene)))
}

/// Renders `scene.integrator.spp` samples per pixel of the whole image on `backend`.
pub fn render_all(backend: Backend<'_>, scene: &Scene, bvh: Arc<Bvh>) -> Result<RenderOutput> {
    let mut r = open(backend, scene, bvh, Tile::full(scene.width, scene.height))?;
    let request = RenderRequest::samples(0..scene.integrator.spp);
    Ok(r.render(&request, &|_| {})?.output)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;
    use std::sync::Mutex;

    fn cornell(size: u32, spp: u32) -> Scene {
        let source = include_str!("../../scenes/cornell-box.toml");
        let mut s = crate::scene::load_str(source, Path::new("cornell-box.toml")).unwrap();
        s.width = size;
        s.height = size;
        s.integrator.spp = spp;
        s.integrator.max_depth = 4;
        s
    }

    /// Samples added over several calls give the film of one call, bit for bit, and a tile
    /// the same pixels as the whole image: the request, not the call pattern, fixes the image.
    #[test]
    fn calls_and_tiles_do_not_change_the_cpu_image() {
        let s = cornell(12, 6);
        let bvh = Arc::new(crate::bvh::build(&s));
        let whole = render_all(Backend::Cpu, &s, bvh.clone()).unwrap();
        let tile = Tile {
            x: 3,
            y: 5,
            width: 6,
            height: 4,
        };
        let mut r = open(Backend::Cpu, &s, bvh.clone(), tile).unwrap();
        r.render(&RenderRequest::samples(0..1), &|_| {}).unwrap();
        let last = r.render(&RenderRequest::samples(1..6), &|_| {}).unwrap();
        assert_eq!(last.output.spp, 6);
        for y in 0..tile.height {
            for x in 0..tile.width {
                let t = (y * tile.width + x) as usize;
                let w = ((y + tile.y) * s.width + x + tile.x) as usize;
                assert_eq!(
                    last.output.mean.data[t], whole.mean.data[w],
                    "pixel ({x}, {y}) of the tile"
                );
            }
        }
    }

    /// A film handed over holds the samples asked for, and the renderer starts a new one.
    #[test]
    fn take_film_hands_the_film_over() {
        let s = cornell(4, 3);
        let bvh = Arc::new(crate::bvh::build(&s));
        let mut r = open(Backend::Cpu, &s, bvh.clone(), Tile::full(4, 4)).unwrap();
        let request = RenderRequest {
            samples: 2..5,
            take_film: true,
        };
        let film = r.render(&request, &|_| {}).unwrap().film.unwrap();
        assert_eq!(film.samples(), 2..5);
        // The new film takes any samples, as an empty one does.
        let again = r.render(&RenderRequest::samples(0..1), &|_| {}).unwrap();
        assert_eq!(again.output.spp, 1);
        assert!(again.film.is_none());
    }

    /// Samples that do not follow the film's are an error naming both, never a panic.
    #[test]
    fn samples_must_follow_the_film() {
        let s = cornell(4, 2);
        let bvh = Arc::new(crate::bvh::build(&s));
        let mut r = open(Backend::Cpu, &s, bvh.clone(), Tile::full(4, 4)).unwrap();
        r.render(&RenderRequest::samples(0..2), &|_| {}).unwrap();
        let e = r
            .render(&RenderRequest::samples(3..4), &|_| {})
            .err()
            .expect("a gap is refused");
        assert_eq!(
            e.to_string(),
            "samples from 3 asked for, but the film holds samples 0..2"
        );
    }

    /// A tile outside the image is refused when the renderer is made.
    #[test]
    fn open_refuses_a_tile_outside_the_image() {
        let s = cornell(4, 1);
        let bvh = Arc::new(crate::bvh::build(&s));
        let outside = Tile {
            x: 2,
            y: 0,
            width: 3,
            height: 4,
        };
        assert!(open(Backend::Cpu, &s, bvh.clone(), outside).is_err());
    }

    /// The CPU reports every row of the tile once, in rows of the tile.
    #[test]
    fn cpu_progress_counts_rows() {
        let s = cornell(5, 1);
        let bvh = Arc::new(crate::bvh::build(&s));
        let mut r = open(Backend::Cpu, &s, bvh.clone(), Tile::full(5, 5)).unwrap();
        assert_eq!(r.describe().progress, ProgressUnit::Rows);
        let seen = Mutex::new(Vec::new());
        r.render(&RenderRequest::samples(0..1), &|p| {
            seen.lock().unwrap().push(p)
        })
        .unwrap();
        let mut done: Vec<f64> = seen.lock().unwrap().iter().map(|p| p.done).collect();
        done.sort_by(f64::total_cmp);
        assert_eq!(done, [1.0, 2.0, 3.0, 4.0, 5.0]);
        assert!(seen
            .lock()
            .unwrap()
            .iter()
            .all(|p| p.total == 5.0 && p.unit == ProgressUnit::Rows));
    }
}
