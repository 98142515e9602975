//! Merging partial films (`brdfwave merge`): checking that the parts belong to one render and
//! cover every pixel's samples once, then joining their sums exactly.

use super::{read_header, read_part, Block, Film, PartHeader, Tile};
use crate::imageio::Image;
use anyhow::{bail, Result};
use std::ops::Range;
use std::path::PathBuf;

/// The image merged from partial films, and what the parts rendered together.
pub struct Merged {
    pub mean: Image,
    pub variance: Image,
    pub samples: Range<u32>,
    pub tiles: usize,
    pub extension_rays: u64,
    pub shadow_rays: u64,
    pub nonfinite_by_stage: Vec<(String, u64)>,
    /// Render seconds of all parts added (CPU time of the whole job, not its wall time).
    pub seconds_render: f64,
    pub scene: String,
    pub backends: Vec<String>,
}

/// Merges the partial films `paths`: they must come from the same scene and code, and every
/// pixel must lie in parts that cover the same sample range, each sample once (tiles may differ
/// between sample ranges: e.g. samples 0..64 of the whole image and 64..128 in two halves).
///
/// The headers are read and checked first; then the parts' sums are read one part at a time,
/// in sample order, and joined into the films of the cells the tiles cut the image into, so
/// memory holds one part and a few blocks per cell (parts of aligned power-of-two ranges join
/// as they arrive), not every part.
///
/// The parts must hold all the samples of the render they are parts of, 0..spp (each part
/// records spp): a set with the last part missing is refused. [`merge_samples`] takes
/// another range.
pub fn merge(paths: &[PathBuf]) -> Result<Merged> {
    merge_samples(paths, None)
}

/// [`merge`], the parts holding the samples `want` together (`merge --samples`), or, when
/// `want` is None, all of the render's 0..spp.
pub fn merge_samples(paths: &[PathBuf], want: Option<Range<u32>>) -> Result<Merged> {
    if paths.is_empty() {
        bail!("no partial films to merge");
    }
    let headers = paths
        .iter()
        .map(|p| read_header(p))
        .collect::<Result<Vec<_>>>()?;
    check_one_render(paths, &headers)?;
    let (mut cells, samples) = cells(paths, &headers)?;
    if let Some(have) = &samples {
        let spp = headers[0].spp;
        let (want, asked) = match want {
            Some(w) => (w, "asked for (--samples)".to_string()),
            None => (
                0..spp,
                format!("of the whole {spp}-spp render the parts record"),
            ),
        };
        if *have != want {
            bail!(
                "the parts hold samples {}..{}, not the samples {}..{} {asked}: a part is \
                 missing or left over (merge --samples {}..{} merges these alone)",
                have.start,
                have.end,
                want.start,
                want.end,
                have.start,
                have.end
            );
        }
    }
    join_sums(paths, &headers, &mut cells)?;
    let (mean, variance) = images(headers[0].width, headers[0].height, &cells);
    totals(&headers, mean, variance, samples)
}

/// A cell of the grid the tiles' edges cut the image into, and the parts whose tiles hold it.
type Cell = (Film, Vec<usize>);

/// The partial film `i`'s sample range.
fn samples_of(headers: &[PartHeader], i: usize) -> Range<u32> {
    headers[i].samples[0]..headers[i].samples[1]
}

/// The parts come from the same scene and settings, the same program and the same image size.
fn check_one_render(paths: &[PathBuf], headers: &[PartHeader]) -> Result<()> {
    let name = |i: usize| paths[i].display().to_string();
    let first = &headers[0];
    for (i, h) in headers.iter().enumerate().skip(1) {
        let differs = |what: &str, a: &dyn std::fmt::Display, b: &dyn std::fmt::Display| {
            anyhow::anyhow!(
                "{} and {} come from different {what} ({a} and {b}): parts of different renders cannot be merged",
                name(0),
                name(i)
            )
        };
        if h.scene_hash != first.scene_hash {
            return Err(differs(
                "scenes or settings",
                &format!("{} #{}", first.scene, first.scene_hash),
                &format!("{} #{}", h.scene, h.scene_hash),
            ));
        }
        if h.code_version != first.code_version {
            return Err(differs(
                "program versions",
                &first.code_version,
                &h.code_version,
            ));
        }
        if h.spp != first.spp {
            return Err(differs(
                "renders",
                &format!("{} spp", first.spp),
                &format!("{} spp", h.spp),
            ));
        }
        if (h.width, h.height) != (first.width, first.height) {
            return Err(differs(
                "image sizes",
                &format!("{}x{}", first.width, first.height),
                &format!("{}x{}", h.width, h.height),
            ));
        }
    }
    Ok(())
}

/// The grid the tiles' edges cut the image into, each cell with its (empty) film and its parts,
/// and the sample range every pixel has (None without cells): each cell lies in the same parts' tiles throughout,
/// which must cover the same samples, each sample once.
fn cells(paths: &[PathBuf], headers: &[PartHeader]) -> Result<(Vec<Cell>, Option<Range<u32>>)> {
    let name = |i: usize| paths[i].display().to_string();
    let (width, height) = (headers[0].width, headers[0].height);
    let samples_of = |i: usize| samples_of(headers, i);
    let cuts = |edges: &mut dyn Iterator<Item = u32>, size: u32| {
        let mut v: Vec<u32> = edges.chain([0, size]).collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let xs = cuts(
        &mut headers
            .iter()
            .flat_map(|h| [h.tile.x, h.tile.x + h.tile.width]),
        width,
    );
    let ys = cuts(
        &mut headers
            .iter()
            .flat_map(|h| [h.tile.y, h.tile.y + h.tile.height]),
        height,
    );
    let mut cells: Vec<Cell> = Vec::new();
    let mut range: Option<(Range<u32>, Tile)> = None;
    for y in ys.windows(2) {
        for x in xs.windows(2) {
            let cell = Tile {
                x: x[0],
                y: y[0],
                width: x[1] - x[0],
                height: y[1] - y[0],
            };
            let mut members: Vec<usize> = (0..headers.len())
                .filter(|&i| headers[i].tile.contains(cell.x, cell.y))
                .collect();
            if members.is_empty() {
                bail!(
                    "pixel ({}, {}) of the {width}x{height} image is in no part's tile: a part is missing",
                    cell.x,
                    cell.y
                );
            }
            members.sort_by_key(|&i| (samples_of(i).start, samples_of(i).end));
            let at = format!("pixel ({}, {})", cell.x, cell.y);
            for w in members.windows(2) {
                let (a, b) = (samples_of(w[0]), samples_of(w[1]));
                if b.start > a.end {
                    bail!(
                        "samples {}..{} of {at} are in no part (between {} with {}..{} and {} with {}..{}): a part is missing",
                        a.end, b.start, name(w[0]), a.start, a.end, name(w[1]), b.start, b.end
                    );
                }
                if b.start < a.end {
                    bail!(
                        "samples {}..{} of {at} are in two parts, {} ({}..{}) and {} ({}..{}): each sample must be in one",
                        b.start, a.end.min(b.end), name(w[0]), a.start, a.end, name(w[1]), b.start, b.end
                    );
                }
            }
            let r =
                samples_of(members[0]).start..samples_of(*members.last().expect("not empty")).end;
            match &range {
                None => range = Some((r.clone(), cell)),
                Some((r0, c0)) if *r0 != r => bail!(
                    "pixel ({}, {}) has samples {}..{} but pixel ({}, {}) has {}..{}: every pixel needs the same samples",
                    c0.x, c0.y, r0.start, r0.end, cell.x, cell.y, r.start, r.end
                ),
                _ => {}
            }
            cells.push((Film::new(cell), members));
        }
    }
    Ok((cells, range.map(|(r, _)| r)))
}

/// The sums, one part at a time in sample order: each cell gets its parts' blocks, cut to the
/// cell, in order.
fn join_sums(paths: &[PathBuf], headers: &[PartHeader], cells: &mut [Cell]) -> Result<()> {
    let name = |i: usize| paths[i].display().to_string();
    let mut order: Vec<usize> = (0..headers.len()).collect();
    order.sort_by_key(|&i| (samples_of(headers, i).start, samples_of(headers, i).end));
    for i in order {
        let part = read_part(&paths[i])?;
        if part.header != headers[i] {
            bail!("{} changed while it was being merged", name(i));
        }
        let t = part.film.tile;
        for (film, _) in cells.iter_mut().filter(|(_, m)| m.contains(&i)) {
            let cell = film.tile;
            let blocks = part
                .film
                .blocks
                .iter()
                .map(|b| Block {
                    samples: b.samples.clone(),
                    sums: (cell.y..cell.y + cell.height)
                        .flat_map(|py| {
                            let row = ((py - t.y) * t.width + (cell.x - t.x)) as usize;
                            b.sums[row..row + cell.width as usize].iter().copied()
                        })
                        .collect(),
                })
                .collect();
            film.add_blocks(blocks);
        }
    }
    Ok(())
}

/// The mean and variance images of the whole `width` x `height` image from the cells' films.
fn images(width: u32, height: u32, cells: &[Cell]) -> (Image, Image) {
    let mut mean = Image::new(width, height);
    let mut variance = Image::new(width, height);
    for (film, _) in cells {
        let cell = film.tile;
        let (m, v) = film.images();
        for py in 0..cell.height {
            for px in 0..cell.width {
                let src = (py * cell.width + px) as usize;
                mean.set(cell.x + px, cell.y + py, m.data[src]);
                variance.set(cell.x + px, cell.y + py, v.data[src]);
            }
        }
    }
    (mean, variance)
}

/// The merged result: the images and what the parts rendered together (their counts added).
fn totals(
    headers: &[PartHeader],
    mean: Image,
    variance: Image,
    samples: Option<Range<u32>>,
) -> Result<Merged> {
    let tiles = {
        let mut t: Vec<Tile> = headers.iter().map(|h| h.tile).collect();
        t.sort_by_key(|t| (t.y, t.x, t.height, t.width));
        t.dedup();
        t.len()
    };
    let mut nonfinite_by_stage: Vec<(String, u64)> = Vec::new();
    let mut backends: Vec<String> = Vec::new();
    let overflow = |what: &str| anyhow::anyhow!("the parts' {what} add up to more than 2^64");
    for h in headers {
        for (stage, n) in &h.nonfinite_by_stage {
            match nonfinite_by_stage.iter_mut().find(|(s, _)| s == stage) {
                Some((_, t)) => {
                    *t = t
                        .checked_add(*n)
                        .ok_or_else(|| overflow("non-finite counts"))?
                }
                None => nonfinite_by_stage.push((stage.clone(), *n)),
            }
        }
        let b = format!("{} on {}", h.backend, h.device);
        if !backends.contains(&b) {
            backends.push(b);
        }
    }
    Ok(Merged {
        mean,
        variance,
        samples: samples.expect("at least one cell"),
        tiles,
        extension_rays: headers
            .iter()
            .try_fold(0u64, |t, h| t.checked_add(h.extension_rays))
            .ok_or_else(|| overflow("extension-ray counts"))?,
        shadow_rays: headers
            .iter()
            .try_fold(0u64, |t, h| t.checked_add(h.shadow_rays))
            .ok_or_else(|| overflow("shadow-ray counts"))?,
        nonfinite_by_stage,
        seconds_render: headers.iter().map(|h| h.seconds_render).sum(),
        scene: headers[0].scene.clone(),
        backends,
    })
}
