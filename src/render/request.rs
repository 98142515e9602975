//! What the caller asks of a render: the overrides of the scene's settings, and the samples of
//! one [`Renderer::render`](super::Renderer::render) call.

use crate::film::Tile;
use crate::rng::Sampler;
use crate::scene::Scene;
use anyhow::{bail, Context as _, Result};
use std::ops::Range;

/// Settings that override the scene file's (the options of `brdfwave render` of the same
/// names); None keeps the scene's.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    /// Samples per pixel, at least 1.
    pub spp: Option<u32>,
    /// Image size (width, height), checked by the parser of `--res`.
    pub res: Option<(u32, u32)>,
    /// Maximum path segments, 1 ..= [`crate::conventions::MAX_DEPTH`].
    pub max_depth: Option<u32>,
    pub seed: Option<u32>,
    pub sampler: Option<Sampler>,
    /// Only these sample indices (default: 0..spp), for a partial film.
    pub samples: Option<Range<u32>>,
    /// Only the pixels of this tile (default: the whole image), for a partial film.
    pub tile: Option<Tile>,
}

/// The part of the render asked for, once the overrides are applied.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Resolved {
    pub samples: Range<u32>,
    pub tile: Tile,
}

impl Overrides {
    /// Applies the overrides to `scene` and returns the samples and tile to render; a value out
    /// of range is refused with the option's name. The scene's `spp` becomes the number of
    /// samples asked for: the GPU sizes its waves by it, and a render's summary reports it.
    pub fn apply(&self, scene: &mut Scene) -> Result<Resolved> {
        if let Some(spp) = self.spp {
            if spp == 0 {
                bail!("--spp must be at least 1");
            }
            scene.integrator.spp = spp;
        }
        if let Some((w, h)) = self.res {
            scene.width = w;
            scene.height = h;
        }
        if let Some(d) = self.max_depth {
            if d == 0 {
                bail!("--max-depth must be at least 1 (the camera segment)");
            }
            if d > crate::conventions::MAX_DEPTH {
                bail!(
                    "--max-depth {d} is over the largest supported depth, {} segments",
                    crate::conventions::MAX_DEPTH
                );
            }
            scene.integrator.max_depth = d;
        }
        if let Some(s) = self.seed {
            scene.integrator.seed = s;
        }
        if let Some(s) = self.sampler {
            scene.integrator.sampler = s;
        }
        // A part (`--samples`) is a range of the whole render's samples, 0..spp: the spp given
        // beside it (`--spp`), else the scene's. It sizes the sampler's patterns, which every
        // part keeps, and merge checks that the parts cover it.
        let whole = scene.integrator.pattern_spp();
        if let Some(s) = &self.samples {
            if s.end > whole {
                let spp = match self.spp {
                    Some(_) => format!("--spp {whole}"),
                    None => format!("the scene's integrator.spp = {whole}"),
                };
                bail!(
                    "--samples {}..{} goes beyond the whole render's samples 0..{whole} ({spp}): \
                     a part renders a range of them (give the whole render's spp with --spp)",
                    s.start,
                    s.end
                );
            }
        }
        let samples = self.samples.clone().unwrap_or(0..whole);
        // The parts of a split render keep the whole render's sampler patterns.
        if self.samples.is_some() {
            scene.integrator.pattern_spp = Some(whole);
        }
        scene.integrator.spp = samples.end - samples.start;
        let tile = self.tile.unwrap_or(Tile::full(scene.width, scene.height));
        tile.check_within(scene.width, scene.height)
            .map_err(anyhow::Error::msg)
            .context("--tile")?;
        Ok(Resolved { samples, tile })
    }
}

/// One [`Renderer::render`](super::Renderer::render) call: the samples to add, and whether to
/// hand the film's sums over too (for a partial film, `.bwfilm`): the renderer then starts a
/// new, empty film, so the sums are moved, never copied (they can be most of the memory).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RenderRequest {
    /// Sample indices, START..END (END exclusive).
    pub samples: Range<u32>,
    pub take_film: bool,
}

impl RenderRequest {
    /// The samples `samples`, without the film.
    pub fn samples(samples: Range<u32>) -> Self {
        RenderRequest {
            samples,
            take_film: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn cornell() -> Scene {
        let source = include_str!("../../scenes/cornell-box.toml");
        crate::scene::load_str(source, Path::new("cornell-box.toml")).unwrap()
    }

    #[test]
    fn overrides_apply_and_name_the_option_they_refuse() {
        let mut s = cornell();
        let o = Overrides {
            spp: Some(7),
            res: Some((20, 10)),
            max_depth: Some(3),
            seed: Some(9),
            sampler: Some(Sampler::Independent),
            samples: None,
            tile: None,
        };
        let r = o.apply(&mut s).unwrap();
        assert_eq!(r.samples, 0..7);
        assert_eq!(r.tile, Tile::full(20, 10));
        assert_eq!((s.width, s.height, s.integrator.max_depth), (20, 10, 3));
        assert_eq!(
            (s.integrator.seed, s.integrator.sampler),
            (9, Sampler::Independent)
        );

        // A sample range sets the scene's spp to its length; the whole render's spp (given
        // beside it, or the scene's) sizes the patterns and bounds the range.
        let part = Overrides {
            samples: Some(4..10),
            ..Overrides::default()
        };
        let mut s = cornell();
        assert_eq!(part.apply(&mut s).unwrap().samples, 4..10);
        assert_eq!(s.integrator.spp, 6);
        assert_eq!(s.integrator.pattern_spp(), 16);
        for (spp, samples) in [(32, 16..32), (32, 0..32), (1, 0..1), (100, 99..100)] {
            let mut s = cornell();
            let part = Overrides {
                spp: Some(spp),
                samples: Some(samples.clone()),
                ..Overrides::default()
            };
            assert_eq!(part.apply(&mut s).unwrap().samples, samples);
            assert_eq!(s.integrator.spp, samples.end - samples.start);
            assert_eq!(s.integrator.pattern_spp(), spp);
        }
        for (spp, samples) in [(Some(8), 4..9), (None, 8..17), (Some(1), 1..2)] {
            let e = format!(
                "{:#}",
                Overrides {
                    spp,
                    samples: Some(samples),
                    ..Overrides::default()
                }
                .apply(&mut cornell())
                .unwrap_err()
            );
            assert!(
                e.starts_with("--samples") && e.contains("goes beyond"),
                "{e}"
            );
        }

        let refused = |o: Overrides| format!("{:#}", o.apply(&mut cornell()).unwrap_err());
        assert!(refused(Overrides {
            spp: Some(0),
            ..Overrides::default()
        })
        .starts_with("--spp"));
        assert!(refused(Overrides {
            max_depth: Some(0),
            ..Overrides::default()
        })
        .starts_with("--max-depth"));
        assert!(refused(Overrides {
            max_depth: Some(crate::conventions::MAX_DEPTH + 1),
            ..Overrides::default()
        })
        .starts_with("--max-depth"));
        assert!(refused(Overrides {
            res: Some((8, 8)),
            tile: Some(Tile {
                x: 4,
                y: 4,
                width: 5,
                height: 1
            }),
            ..Overrides::default()
        })
        .starts_with("--tile"));
    }
}
