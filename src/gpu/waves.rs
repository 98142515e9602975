//! How the samples of a render are cut into waves: a small image takes several consecutive
//! samples of every pixel per wave (so that a large GPU has enough paths in flight), a large one
//! one sample of one chunk of pixels per wave.

use std::ops::Range;

/// Path slots of a wave over `pixels` pixels at `spp` samples per pixel with at most
/// `most` paths: every sample that fits of every pixel (at most `max_samples` per pixel), or,
/// for an image larger than `most`, one sample of a chunk of `most` pixels.
pub(super) fn wave_slots(pixels: u64, spp: u32, most: u32, max_samples: u32) -> u32 {
    let (spp, most) = (spp.max(1) as u64, most as u64);
    if pixels <= most {
        (pixels * spp.min(most / pixels.max(1)).min(max_samples as u64)) as u32
    } else {
        most as u32
    }
}

/// One wave: `samples` consecutive samples, from `sample`, of the pixels
/// `offset .. offset + pixels`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Wave {
    pub sample: u32,
    pub samples: u32,
    pub offset: u32,
    pub pixels: u32,
    /// Samples per pixel complete once this wave is done.
    pub samples_done: u32,
}

/// The waves that render the sample indices `samples` over `pixels` pixels with `wave_paths`
/// path slots, in order (an iterator: a long render at a high sample count holds no list of
/// them).
pub(super) fn waves(
    pixels: u32,
    samples: Range<u32>,
    wave_paths: u32,
) -> impl Iterator<Item = Wave> {
    let spp = samples.end;
    let (mut sample, mut offset) = (samples.start, 0u32);
    std::iter::from_fn(move || {
        if sample >= spp {
            return None;
        }
        if pixels <= wave_paths {
            let k = (wave_paths / pixels).min(spp - sample);
            let w = Wave {
                sample,
                samples: k,
                offset: 0,
                pixels,
                samples_done: sample + k,
            };
            sample += k;
            Some(w)
        } else {
            let n = (pixels - offset).min(wave_paths);
            let w = Wave {
                sample,
                samples: 1,
                offset,
                pixels: n,
                samples_done: if offset + n == pixels {
                    sample + 1
                } else {
                    sample
                },
            };
            offset += n;
            if offset == pixels {
                offset = 0;
                sample += 1;
            }
            Some(w)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::{waves, Wave};

    /// Every (pixel, sample) pair lies in exactly one wave, in sample order per pixel, and no
    /// wave is larger than `wave_paths`.
    fn check(pixels: u32, spp: u32, wave_paths: u32) -> Vec<Wave> {
        let w: Vec<Wave> = waves(pixels, 0..spp, wave_paths).collect();
        let mut seen = vec![0u32; (pixels * spp) as usize];
        let mut next_sample = vec![0u32; pixels as usize];
        let mut done = 0;
        for x in &w {
            assert!(x.pixels * x.samples <= wave_paths, "{x:?}");
            assert!(x.samples_done >= done, "progress goes back: {x:?}");
            done = x.samples_done;
            for s in x.sample..x.sample + x.samples {
                for p in x.offset..x.offset + x.pixels {
                    seen[(s * pixels + p) as usize] += 1;
                    assert_eq!(next_sample[p as usize], s, "pixel {p} out of order");
                    next_sample[p as usize] += 1;
                }
            }
        }
        assert!(
            seen.iter().all(|&c| c == 1),
            "{pixels} px × {spp} spp, wave_paths {wave_paths}"
        );
        assert_eq!(done, spp);
        w
    }

    #[test]
    fn waves_cover_every_pixel_sample_once() {
        // Whole image, several samples per wave, last wave shorter.
        assert_eq!(check(480, 5, 960).len(), 3);
        // Chunks of the image, the last one partial.
        assert_eq!(check(480, 3, 64).len(), 3 * 8);
        // Exactly one wave; one pixel; wave_paths equal to the image.
        assert_eq!(check(100, 4, 1 << 20).len(), 1);
        check(1, 7, 64);
        check(640, 2, 640);
    }
}
