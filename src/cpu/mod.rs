//! The CPU reference path tracer.
//!
//! The same algorithm as the GPU wavefront integrator (`crate::gpu`), written in plain Rust so
//! the two can disagree when one is wrong. Shared with the GPU side are only the scene, the BVH
//! (built once on the host), the emitter table and the random-number keys; the shading, light
//! sampling and BRDFs are independent code (`src/brdf/*.rs` vs `shaders/brdf/*.glsl`).
//!
//! Algorithm (both sides): unidirectional path tracing with next-event estimation on emitters,
//! combined with BSDF sampling by multiple importance sampling (power heuristic). `max_depth`
//! counts path segments, the camera segment being the first: emission seen at the end of
//! segment d counts when d ≤ max_depth, and a light sample from the vertex at the end of segment
//! d adds segment d+1, so it is taken only when d < max_depth. Surfaces reflect on their front
//! side only; a path that reaches a back face ends. Russian roulette is optional.
//!
//! A path is [`CpuRenderer::trace_path`]; the renderer traces a pixel's samples a packet at a
//! time in lockstep (`lanes.rs`), which gives the same image and shades part of each segment in
//! SIMD lanes.

mod lanes;
mod path;
mod scatter;
pub mod surface;

use crate::bvh::Bvh;
use crate::camera::CameraBasis;
use crate::conventions::SEGMENTS_COUNTED;
use crate::film::{self, Block, Film, PairwiseSum, Tile};
use crate::lights::LightTable;
use crate::output::{nonfinite_stages, RenderOutput};
use crate::rng::{LaneRng, PacketRng};
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// Statistics of one path.
#[derive(Default)]
struct PathStats {
    extension_rays: u64,
    shadow_rays: u64,
    shadow_rays_occluded: u64,
    /// By path segment (index d - 1; the last also counts deeper segments).
    segment_extension: [u64; SEGMENTS_COUNTED as usize],
    segment_shadow: [u64; SEGMENTS_COUNTED as usize],
    /// Non-finite emitted contributions dropped (the GPU's `extend`).
    nonfinite_extend: u64,
    /// Non-finite light contributions or continuations dropped, by model index (the GPU's
    /// `shade_<model>`).
    nonfinite_shade: [u64; crate::brdf::MODELS_COUNT],
}

impl PathStats {
    fn add(&mut self, o: &PathStats) {
        self.extension_rays += o.extension_rays;
        self.shadow_rays += o.shadow_rays;
        self.shadow_rays_occluded += o.shadow_rays_occluded;
        for d in 0..SEGMENTS_COUNTED as usize {
            self.segment_extension[d] += o.segment_extension[d];
            self.segment_shadow[d] += o.segment_shadow[d];
        }
        self.nonfinite_extend += o.nonfinite_extend;
        for (a, b) in self.nonfinite_shade.iter_mut().zip(&o.nonfinite_shade) {
            *a += b;
        }
    }
}

/// The samples rendered so far of one tile of the image (progressive and split rendering), and
/// the counts of the paths that made them.
pub struct CpuFilm {
    pub film: Film,
    stats: PathStats,
    nonfinite_accumulate: u64,
}

impl CpuFilm {
    /// Samples per pixel held.
    pub fn spp(&self) -> u32 {
        self.film.spp()
    }
}

pub struct CpuRenderer<'a> {
    scene: &'a Scene,
    /// Shared, so that a caller that hands its only reference to a GPU renderer frees the tree
    /// once it is uploaded (`render::open`).
    bvh: Arc<Bvh>,
    lights: LightTable,
    camera: CameraBasis,
    /// The geometric normal of each triangle ([`crate::scene::Triangle::geometric_normal`]),
    /// computed once instead of at every hit and light sample (the same bits either way).
    normals: Vec<Vec3>,
    /// Some material has textures: surfaces get their texture coordinates.
    textured: bool,
    /// Trace a pixel's samples in lockstep packets (`lanes.rs`); `BRDFWAVE_LANES=0` turns it
    /// off (one path at a time, the same image: for timing the two side by side).
    use_lanes: bool,
    /// Per material, whether it scatters light ([`crate::brdf::Brdf::scatters`]).
    scatters: Vec<bool>,
    /// Per material, the albedo when the lane kernel shades its vertices.
    lane_albedo: Vec<Option<Vec3>>,
    /// The index of Lambert in [`crate::brdf::MODELS`].
    lambert_model: usize,
    /// The lanes turn triangle hits into surfaces: no triangle has vertex normals or texture
    /// coordinates.
    lane_surfaces: bool,
}

impl<'a> CpuRenderer<'a> {
    pub fn new(scene: &'a Scene, bvh: Arc<Bvh>) -> Self {
        // Read at every hit, in no order: on huge pages, as the BVH's arrays are.
        let mut normals: Vec<Vec3> = crate::memory::huge_page_vec(scene.triangles.len());
        normals.par_extend(scene.triangles.par_iter().map(|t| t.geometric_normal()));
        let lights = LightTable::build(scene);
        let textured = scene.materials.iter().any(|m| !m.textures.is_empty());
        CpuRenderer {
            scene,
            bvh,
            camera: CameraBasis::new(scene),
            normals,
            textured,
            use_lanes: std::env::var("BRDFWAVE_LANES").map_or(true, |v| v != "0"),
            scatters: scene.materials.iter().map(|m| m.brdf.scatters()).collect(),
            lane_albedo: lanes::lane_albedos(scene, &lights),
            lambert_model: crate::brdf::MODELS
                .iter()
                .position(|m| m.name == "lambert")
                .expect("Lambert is a model"),
            lane_surfaces: !textured && !scene.has_shading_normals() && !scene.has_uvs(),
            lights,
        }
    }

    /// Whether to trace a pixel's samples in lockstep packets (`lanes.rs`, the default) or one
    /// path at a time ([`Self::trace_path`]); the image and counts are the same either way.
    pub fn with_lanes(mut self, on: bool) -> Self {
        self.use_lanes = on;
        self
    }

    /// Render `scene.integrator.spp` samples per pixel. `progress` is called with the number of
    /// rows finished.
    pub fn render(&self, progress: &(dyn Fn(u32) + Sync)) -> RenderOutput {
        let mut film = self.film();
        self.render_samples(&mut film, 0..self.scene.integrator.spp, progress);
        self.output(&film)
    }

    /// An empty film of the whole image, for [`render_samples`](Self::render_samples).
    pub fn film(&self) -> CpuFilm {
        self.film_of(Tile::full(self.scene.width, self.scene.height))
    }

    /// An empty film of one tile of the image (which must lie within it).
    pub fn film_of(&self, tile: Tile) -> CpuFilm {
        assert!(tile
            .check_within(self.scene.width, self.scene.height)
            .is_ok());
        CpuFilm {
            film: Film::new(tile),
            stats: PathStats::default(),
            nonfinite_accumulate: 0,
        }
    }

    /// Adds the samples `samples` (sample indices; the next ones after those in `film`, or any
    /// when it is empty) of every pixel of the film's tile. Each pixel's samples are summed in
    /// the dyadic blocks of `crate::film`, so any split into passes, processes or machines
    /// gives the same sums, bit for bit. `progress` is called with the number of rows finished.
    pub fn render_samples(
        &self,
        film: &mut CpuFilm,
        samples: std::ops::Range<u32>,
        progress: &(dyn Fn(u32) + Sync),
    ) {
        assert!(
            film.film.blocks.is_empty() || samples.start == film.film.samples().end,
            "samples must follow those in the film"
        );
        if samples.is_empty() {
            return;
        }
        let s = self.scene;
        let tile = film.film.tile;
        let pixel_samples = samples.len() as u32;
        let blocks = film::dyadic_blocks(samples);
        let nb = blocks.len();
        let rows_done = AtomicU64::new(0);
        // Pixel p's sums of block b at p·nb + b, split into the blocks' planes below.
        let mut sums = vec![[0f64; 6]; tile.pixels() * nb];
        let per_row: Vec<(PathStats, u64)> = sums
            .par_chunks_mut(tile.width as usize * nb)
            .enumerate()
            .map(|(row, out)| {
                let mut stats = PathStats::default();
                let mut bad = 0u64;
                let y = tile.y + row as u32;
                // A pixel's samples draw their numbers a packet at a time (`rng::PacketRng`).
                let mut packet = PacketRng::new(
                    s.integrator.sampler,
                    s.integrator.seed,
                    s.integrator.pattern_bits(),
                    pixel_samples,
                );
                for (i, x) in (tile.x..tile.x + tile.width).enumerate() {
                    let pixel = y * s.width + x;
                    for (b, range) in blocks.iter().enumerate() {
                        let mut acc = PairwiseSum::default();
                        // Sums in f64: no finite f32 sample overflows them, or its square (the
                        // GPU film scales its f32 sums instead). A non-finite sample is
                        // dropped, counted, and adds 0.
                        let mut push = |l: Vec3| {
                            acc.push(if l.is_finite() {
                                film::sample_sums(l.to_array())
                            } else {
                                bad += 1;
                                [0.0; 6]
                            })
                        };
                        // The lane kernels always compute all LANES lanes, so packets of
                        // fewer than MIN_LANES samples (renders of 1 or 2 spp) trace one path
                        // at a time (docs/bench-log.md, "A pixel's samples in lockstep").
                        if self.use_lanes && packet.lanes() >= lanes::MIN_LANES {
                            // Chunks that do not cross a packet of the sampler.
                            let lanes = packet.lanes() as u32;
                            let mut sample = range.start;
                            while sample < range.end {
                                let end = ((sample & !(lanes - 1)) + lanes).min(range.end);
                                let n = (end - sample) as usize;
                                let at = (x, y, pixel);
                                let ls = self.trace_packet(at, sample, n, &mut packet, &mut stats);
                                ls[..n].iter().for_each(|&l| push(l));
                                sample = end;
                            }
                        } else {
                            for sample in range.clone() {
                                let mut rng = packet.path(pixel, sample);
                                push(self.trace_path(x, y, &mut rng, &mut stats));
                            }
                        }
                        out[i * nb + b] = acc.total();
                    }
                }
                let done = rows_done.fetch_add(1, Ordering::Relaxed) + 1;
                progress(done as u32);
                (stats, bad)
            })
            .collect();
        for (stats, bad) in per_row {
            film.stats.add(&stats);
            film.nonfinite_accumulate += bad;
        }
        film.film.add_blocks(
            blocks
                .into_iter()
                .enumerate()
                .map(|(b, range)| Block {
                    samples: range,
                    sums: sums.iter().skip(b).step_by(nb).copied().collect(),
                })
                .collect(),
        );
    }

    /// The image of the film's tile, and its counts.
    pub fn output(&self, film: &CpuFilm) -> RenderOutput {
        let s = self.scene;
        let (mean, variance) = film.film.images();
        let stats = &film.stats;
        let nonfinite_by_stage = nonfinite_stages(
            stats.nonfinite_extend,
            s.shaded_models()
                .into_iter()
                .map(|m| (m, stats.nonfinite_shade[m])),
            film.nonfinite_accumulate,
        );
        RenderOutput {
            mean,
            variance,
            spp: film.spp(),
            nonfinite_samples: nonfinite_by_stage.iter().map(|s| s.1).sum(),
            nonfinite_by_stage,
            extension_rays: stats.extension_rays,
            shadow_rays: stats.shadow_rays,
            shadow_rays_occluded: stats.shadow_rays_occluded,
            rays_by_segment: (0..s.integrator.max_depth.min(SEGMENTS_COUNTED) as usize)
                .map(|d| (stats.segment_extension[d], stats.segment_shadow[d]))
                .collect(),
            stage_seconds: Vec::new(),
        }
    }

    /// Radiance of one camera path through pixel (x, y): per segment [`Self::segment_end`]
    /// (`path.rs`), then at a surface the path goes on from [`Self::shade_vertex`]
    /// (`scatter.rs`) and its shadow ray, in the order of the GPU megakernel
    /// (`shaders/wavefront/megakernel.comp`).
    fn trace_path(&self, x: u32, y: u32, rng: &mut LaneRng, stats: &mut PathStats) -> Vec3 {
        let s = self.scene;
        let (mut o, mut d) = self.camera_ray(x, y, rng);
        let mut beta = Vec3::ONE;
        let mut l = Vec3::ZERO;
        // Solid-angle pdf of the BSDF sample that produced the current ray; 0 for the camera
        // ray and after delta lobes (emission is then counted with weight 1).
        let mut prev_pdf = 0.0f32;
        // The triangle the ray leaves (none for the camera ray).
        let mut leaving = u32::MAX;
        for depth in 1..=s.integrator.max_depth {
            stats.extension_rays += 1;
            let seg = (depth.min(SEGMENTS_COUNTED) - 1) as usize;
            stats.segment_extension[seg] += 1;
            let end = self.segment_end_inline(depth, (o, d, leaving), prev_pdf, beta, stats);
            if let Some(e) = end.e {
                l += e;
            }
            let Some(si) = end.surface else {
                break;
            };
            let sc = self.shade_vertex_inline(rng, depth, &si, d, beta, stats);
            // Both rays from here leave the surface's primitive, which they cannot meet again.
            if let Some(sh) = sc.shadow {
                stats.shadow_rays += 1;
                stats.segment_shadow[seg] += 1;
                if !self.bvh.occluded_leaving(s, sh.o, sh.d, sh.tmax, si.prim) {
                    l += sh.l;
                } else {
                    stats.shadow_rays_occluded += 1;
                }
            }
            let Some(next) = sc.next else {
                break;
            };
            o = next.o;
            d = next.d;
            beta = next.beta;
            prev_pdf = next.pdf;
            leaving = si.prim;
        }
        l
    }
}
