//! A render in K independent batches (`brdfwave render --batches K`), for a variance of each
//! pixel's estimate that is right whatever the sampler: the batch-means method (e.g. Law &
//! Kelton, "Simulation Modeling and Analysis", 3rd ed. 2000, sec. 9.5.3; as for randomized
//! quasi-Monte Carlo, Owen 2013, "Monte Carlo theory, methods and examples", ch. 17, the
//! replicates must be independently randomized).
//!
//! The samples `S..E` of the render are cut into K consecutive batches of P = (E − S) / K; each
//! batch is rendered as its own call and handed over as a film ([`Renderer::render`] with
//! `take_film`), whose per-pixel mean is one batch mean. The K batch means of a pixel are
//! independent draws of an estimator of its value, so their sample variance s² over K gives the
//! variance of their mean, the pixel's estimate, with K − 1 degrees of freedom. The variance of
//! one sample over the spp ([`crate::output::RenderOutput::variance`]) is that only when a
//! pixel's samples are independent; with stratified or low-discrepancy points it overstates
//! it.
//!
//! **Independence and the random numbers.** Every number is keyed on (pixel, sample, depth,
//! dimension) (`crate::rng`):
//! * `independent`: each number is its own hash, so batches of sample ranges are independent
//!   and a batched render is the unbatched render of the same samples: the same image, bit for
//!   bit on the CPU (the film sums in blocks fixed by the sample indices, `crate::film`), within
//!   rounding on the GPU (its film sums each batch in f32);
//! * `multijitter`: the points of one pattern are stratified together, so batches cut from one
//!   pattern of N points are negatively correlated, and their spread would measure the variance
//!   of unstratified sampling (a partition of the pattern's strata at random: s² / K then
//!   estimates the one-sample variance over N, which is what the test had without batches). A
//!   batched render therefore sizes the pattern by the batch
//!   ([`Integrator::batch_spp`](crate::scene::Integrator) = P, a power of two): the sampler
//!   keys each block of P sample indices on its own pattern, so each batch is an independent
//!   P-point pattern. The image is NOT the unbatched render's (that one draws one N-point
//!   pattern): it is the render of N samples in patterns of P points, which is also what any
//!   split of the batched render into parts (`--samples`, whole batches) merges into.
//!   Stratification then works within P samples, not N: the price of a valid variance.
//! * `sobol`: the aligned blocks of one Owen-scrambled sequence are nets, but they share its
//!   scramble and so are not independent. In batches, each block of P samples gets its own
//!   index shuffle and scrambles ([`crate::rng::sobol_batch_key`]): independently randomized
//!   (0,m,2)-nets. The first batch draws the unbatched render's numbers, the later ones not: the
//!   image is not the unbatched one, for the same reason as `multijitter`'s.

use super::{Progress, RenderRequest, Rendered, Renderer};
use crate::film::{Film, Tile};
use crate::imageio::{BatchVariance, Image};
use crate::output::RenderOutput;
use crate::rng::{Sampler, MULTIJITTER_MAX_BITS};
use crate::scene::Scene;
use anyhow::{bail, Result};
use std::ops::Range;

/// The batches of a render: K batches of P samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Batches {
    /// K >= 2.
    pub count: u32,
    /// P >= 1 samples per pixel per batch.
    pub size: u32,
}

impl Batches {
    /// The batches of `count` for a render of the scene's samples `samples` (a range of the
    /// whole render of `whole_spp` samples: `0..whole_spp` unless it is a part), or why not: K
    /// must divide `whole_spp`, the batch size P = whole_spp / K must be a power of two for
    /// `multijitter` and `sobol` (their patterns and scrambles are keyed by aligned blocks of a
    /// power of two), and `samples` must hold whole batches, at least two. Messages name
    /// `--batches`.
    pub fn plan(
        count: u32,
        whole_spp: u32,
        samples: &Range<u32>,
        sampler: Sampler,
    ) -> Result<Batches> {
        if count < 2 {
            bail!("--batches {count}: a variance from batch means takes at least 2 batches");
        }
        if whole_spp % count != 0 {
            bail!(
                "--batches {count}: the render's {whole_spp} samples per pixel do not divide into \
                 {count} equal batches"
            );
        }
        let size = whole_spp / count;
        if sampler != Sampler::Independent && !size.is_power_of_two() {
            // The largest power of two under the batch size that divides the spp.
            let fit = prev_power_of_two(size).min(1 << whole_spp.trailing_zeros());
            bail!(
                "--batches {count}: batches of {size} samples; with the {sampler} sampler a \
                 batch is one pattern, whose size is a power of two (e.g. --batches {} for \
                 batches of {fit})",
                whole_spp / fit,
            );
        }
        if sampler != Sampler::Independent && size > 1 << MULTIJITTER_MAX_BITS {
            bail!(
                "--batches {count}: batches of {size} samples; a {sampler} pattern holds at most \
                 2^{MULTIJITTER_MAX_BITS}: use more batches"
            );
        }
        if samples.start % size != 0 || samples.end % size != 0 || samples.len() < 2 * size as usize
        {
            bail!(
                "--batches {count}: the samples {}..{} are not at least two whole batches of {size} \
                 (batch k holds samples k*{size}..(k+1)*{size})",
                samples.start,
                samples.end
            );
        }
        Ok(Batches { count, size })
    }

    /// Sizes the sampler's patterns by the batch (module docs): every batch its own pattern
    /// or scramble. The independent sampler has none.
    pub fn apply(&self, scene: &mut Scene) {
        if scene.integrator.sampler != Sampler::Independent {
            scene.integrator.batch_spp = Some(self.size);
        }
    }
}

fn prev_power_of_two(n: u32) -> u32 {
    1 << (31 - n.max(1).leading_zeros())
}

/// Renders `samples` (whole batches of `size`) of `tile` with `r`, one call per batch, and
/// returns what one call over all of them returns (the film when `take_film`; the counts
/// added) with the variance of each pixel's mean from the batch means. `progress` counts as
/// one call over all the samples would.
pub fn render_batches(
    r: &mut dyn Renderer,
    samples: Range<u32>,
    size: u32,
    tile: Tile,
    take_film: bool,
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<(Rendered, BatchVariance)> {
    let count = samples.len() as u32 / size;
    let mut film = Film::new(tile);
    let mut moments = Moments::new(tile.pixels());
    let mut total: Option<RenderOutput> = None;
    let mut seconds_samples = 0.0;
    for k in 0..count {
        let start = samples.start + k * size;
        let request = RenderRequest {
            samples: start..start + size,
            take_film: true,
        };
        let whole = progress_of_whole(k, count, tile, &samples, progress);
        let batch = r.render(&request, &whole)?;
        seconds_samples += batch.seconds_samples;
        let batch_film = batch.film.expect("the film was asked for");
        moments.add(&batch.output.mean);
        film.add_blocks(batch_film.blocks);
        total = Some(match total {
            None => batch.output,
            Some(t) => add_counts(t, batch.output),
        });
    }
    let mut output = total.expect("at least two batches");
    let (mean, variance) = film.images();
    output.mean = mean;
    output.variance = variance;
    output.spp = film.spp();
    let rendered = Rendered {
        output,
        film: take_film.then_some(film),
        seconds_samples,
    };
    Ok((
        rendered,
        BatchVariance {
            variance: moments.variance_of_mean(tile),
            batches: count,
        },
    ))
}

/// The progress of batch `k` of `count` as progress of the whole call: the CPU counts rows of
/// the tile per call (each call covers every row), the GPU samples.
fn progress_of_whole<'p>(
    k: u32,
    count: u32,
    tile: Tile,
    samples: &Range<u32>,
    progress: &'p (dyn Fn(Progress) + Sync),
) -> impl Fn(Progress) + Sync + 'p {
    let samples = samples.clone();
    move |p: Progress| {
        let whole = p.unit.total(tile, &samples);
        let per_call = p.total.max(1e-30);
        progress(Progress {
            done: (k as f64 * per_call + p.done) * whole / (count as f64 * per_call),
            total: whole,
            unit: p.unit,
        })
    }
}

/// The counts of two outputs of the same renderer added (the images are set by the caller).
fn add_counts(mut a: RenderOutput, b: RenderOutput) -> RenderOutput {
    a.nonfinite_samples += b.nonfinite_samples;
    for ((name, n), (other, m)) in a.nonfinite_by_stage.iter_mut().zip(&b.nonfinite_by_stage) {
        debug_assert_eq!(name, other, "the same stages in every call");
        *n += m;
    }
    a.extension_rays += b.extension_rays;
    a.shadow_rays += b.shadow_rays;
    for (s, t) in a.rays_by_segment.iter_mut().zip(&b.rays_by_segment) {
        s.0 += t.0;
        s.1 += t.1;
    }
    for (name, t) in b.stage_seconds {
        match a.stage_seconds.iter_mut().find(|(n, _)| *n == name) {
            Some((_, s)) => *s += t,
            None => a.stage_seconds.push((name, t)),
        }
    }
    a
}

/// Per pixel-channel running mean and sum of squared deviations of the batch means (Welford
/// 1962), in f64.
struct Moments {
    n: u32,
    mean: Vec<[f64; 3]>,
    m2: Vec<[f64; 3]>,
}

impl Moments {
    fn new(pixels: usize) -> Self {
        Moments {
            n: 0,
            mean: vec![[0.0; 3]; pixels],
            m2: vec![[0.0; 3]; pixels],
        }
    }

    fn add(&mut self, batch_mean: &Image) {
        self.n += 1;
        let n = self.n as f64;
        for ((m, m2), x) in self.mean.iter_mut().zip(&mut self.m2).zip(&batch_mean.data) {
            for c in 0..3 {
                let x = x[c] as f64;
                let delta = x - m[c];
                m[c] += delta / n;
                m2[c] += delta * (x - m[c]);
            }
        }
    }

    /// s² / K: the variance of the mean of the K batch means (K >= 2), clamped to f32.
    fn variance_of_mean(&self, tile: Tile) -> Image {
        let k = self.n as f64;
        let data = self
            .m2
            .iter()
            .map(|m2| m2.map(|v| (v / (k - 1.0) / k).clamp(0.0, f32::MAX as f64) as f32))
            .collect();
        Image {
            width: tile.width,
            height: tile.height,
            data,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::{open, Backend};
    use std::sync::Arc;

    fn cornell(size: u32, spp: u32, sampler: Sampler) -> Scene {
        let source = include_str!("../../scenes/cornell-box.toml");
        let mut s =
            crate::scene::load_str(source, std::path::Path::new("cornell-box.toml")).unwrap();
        s.width = size;
        s.height = size;
        s.integrator.spp = spp;
        s.integrator.max_depth = 3;
        s.integrator.sampler = sampler;
        s
    }

    #[test]
    fn plans_refuse_what_would_not_be_independent_batches() {
        let m = Sampler::Multijitter;
        assert_eq!(
            Batches::plan(8, 64, &(0..64), m).unwrap(),
            Batches { count: 8, size: 8 }
        );
        assert_eq!(
            Batches::plan(3, 12, &(0..12), Sampler::Independent).unwrap(),
            Batches { count: 3, size: 4 }
        );
        // A part of whole batches of the whole render; sobol in batches of a power of two.
        assert!(Batches::plan(8, 64, &(16..48), m).is_ok());
        assert!(Batches::plan(4, 64, &(0..64), Sampler::Sobol).is_ok());
        for (k, spp, samples, sampler, needle) in [
            (1, 64, 0..64, m, "at least 2"),
            (5, 64, 0..64, m, "do not divide"),
            (3, 18, 0..18, m, "--batches 9 for batches of 2"),
            (4, 48, 0..48, m, "--batches 6 for batches of 8"),
            (
                4,
                48,
                0..48,
                Sampler::Sobol,
                "with the sobol sampler a batch is one pattern",
            ),
            (8, 64, 4..64, m, "whole batches"),
            (8, 64, 0..8, m, "at least two"),
        ] {
            let e = Batches::plan(k, spp, &samples, sampler)
                .unwrap_err()
                .to_string();
            assert!(e.contains(needle) && e.starts_with("--batches"), "{e}");
        }
    }

    /// With the independent sampler, a batched CPU render is the unbatched one bit for bit, its
    /// counts are the sums of the batches', and the variance of the means is that of the batch
    /// means computed here from separate renders.
    #[test]
    fn independent_batches_are_the_unbatched_render() {
        let s = cornell(6, 12, Sampler::Independent);
        let bvh = Arc::new(crate::bvh::build(&s));
        let tile = Tile::full(6, 6);
        let whole = super::super::render_all(Backend::Cpu, &s, bvh.clone()).unwrap();
        let mut r = open(Backend::Cpu, &s, bvh.clone(), tile).unwrap();
        let (b, v) = render_batches(r.as_mut(), 0..12, 4, tile, true, &|_| {}).unwrap();
        assert_eq!(b.output.mean, whole.mean);
        assert_eq!(b.output.variance, whole.variance);
        assert_eq!(b.output.spp, 12);
        assert_eq!(
            (b.output.extension_rays, b.output.shadow_rays),
            (whole.extension_rays, whole.shadow_rays)
        );
        assert_eq!(b.output.rays_by_segment, whole.rays_by_segment);
        assert_eq!(b.film.unwrap().samples(), 0..12);
        assert_eq!(v.batches, 3);
        // The batch means, rendered apart.
        let means: Vec<Image> = (0..3)
            .map(|k| {
                let mut r = open(Backend::Cpu, &s, bvh.clone(), tile).unwrap();
                let req = RenderRequest::samples(4 * k..4 * k + 4);
                r.render(&req, &|_| {}).unwrap().output.mean
            })
            .collect();
        for i in 0..36 {
            for c in 0..3 {
                let x: Vec<f64> = means.iter().map(|m| m.data[i][c] as f64).collect();
                let m = x.iter().sum::<f64>() / 3.0;
                let s2 = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / 2.0;
                let want = (s2 / 3.0) as f32;
                let got = v.variance.data[i][c];
                assert!(
                    (got - want).abs() <= 1e-6 * want.abs() + 1e-12,
                    "pixel {i} ch {c}: {got} vs {want}"
                );
            }
        }
    }

    /// With multijitter and sobol, the batched render is the render whose patterns (or
    /// scrambles) are the batch's: the same image as that render's, and not the unbatched image
    /// (one pattern or scramble of 16 samples).
    #[test]
    fn stratified_batches_are_patterns_of_the_batch_size() {
        for sampler in [Sampler::Multijitter, Sampler::Sobol] {
            let mut s = cornell(5, 16, sampler);
            let bvh = Arc::new(crate::bvh::build(&s));
            let tile = Tile::full(5, 5);
            let unbatched = super::super::render_all(Backend::Cpu, &s, bvh.clone()).unwrap();
            let plan = Batches::plan(4, 16, &(0..16), s.integrator.sampler).unwrap();
            plan.apply(&mut s);
            assert_eq!(s.integrator.batch_spp, Some(4));
            let mut r = open(Backend::Cpu, &s, bvh.clone(), tile).unwrap();
            let (b, v) =
                render_batches(r.as_mut(), 0..16, plan.size, tile, false, &|_| {}).unwrap();
            let same_pattern = super::super::render_all(Backend::Cpu, &s, bvh.clone()).unwrap();
            assert_eq!(b.output.mean, same_pattern.mean, "{sampler}");
            assert_ne!(b.output.mean, unbatched.mean, "{sampler}");
            assert!(v
                .variance
                .data
                .iter()
                .flatten()
                .all(|x| x.is_finite() && *x >= 0.0));
            assert!(v.variance.data.iter().flatten().any(|&x| x > 0.0));
        }
    }

    /// The progress of the batches reads as one call's: rows (CPU) up to the tile's height.
    #[test]
    fn progress_counts_as_one_call() {
        let s = cornell(4, 4, Sampler::Independent);
        let bvh = Arc::new(crate::bvh::build(&s));
        let tile = Tile::full(4, 4);
        let mut r = open(Backend::Cpu, &s, bvh, tile).unwrap();
        let seen = std::sync::Mutex::new(Vec::new());
        render_batches(r.as_mut(), 0..4, 2, tile, false, &|p| {
            seen.lock().unwrap().push((p.done, p.total))
        })
        .unwrap();
        let seen = seen.into_inner().unwrap();
        assert!(seen
            .iter()
            .all(|&(d, t)| t == 4.0 && (0.0..=4.0).contains(&d)));
        assert!(seen.iter().any(|&(d, _)| d == 4.0));
        assert!(seen.iter().any(|&(d, _)| d <= 2.0));
    }
}
