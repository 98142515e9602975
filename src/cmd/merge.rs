//! `brdfwave merge`: partial films into one image (`brdfwave::film::merge`).

use super::summary::{stage_counts, write_nonfinite, StageCount};
use anyhow::{bail, Context as _, Result};
use brdfwave::{
    film, imageio,
    outfile::{self, Output},
};
use serde::Serialize;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct MergeArgs {
    /// The partial films (.bwfilm), in any order.
    #[arg(value_name = "PART.bwfilm", required = true)]
    parts: Vec<PathBuf>,
    /// Output images (.exr, .png or .pfm); may be given several times.
    #[arg(value_name = "FILE", long = "out", required = true)]
    out: Vec<PathBuf>,
    /// The samples the parts must hold together, START..END: a set that holds others (a
    /// missing last part) is refused (default: 0..spp, all the samples of the render the parts
    /// record).
    #[arg(value_name = "START..END", long, value_parser = brdfwave::film::parse_samples)]
    samples: Option<std::ops::Range<u32>>,
    /// Also write the per-pixel variance of one sample (EXR).
    #[arg(value_name = "FILE.exr", long)]
    variance_out: Option<PathBuf>,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

/// What `merge` reports.
#[derive(Serialize)]
struct MergeSummary {
    scene: String,
    parts: usize,
    tiles: usize,
    width: u32,
    height: u32,
    samples: [u32; 2],
    spp: u32,
    backends: Vec<String>,
    extension_rays: u64,
    shadow_rays: u64,
    nonfinite_samples: u64,
    nonfinite_by_stage: Vec<StageCount>,
    /// The parts' render times added: the compute time of the whole job.
    seconds_render: f64,
    mean_radiance: [f64; 3],
    outputs: Vec<String>,
    variance_output: Option<String>,
}

impl std::fmt::Display for MergeSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "merged         {} parts ({} tile{}) of {}",
            self.parts,
            self.tiles,
            if self.tiles == 1 { "" } else { "s" },
            self.scene
        )?;
        writeln!(
            f,
            "image          {}x{}, {} spp (samples {}..{})",
            self.width, self.height, self.spp, self.samples[0], self.samples[1]
        )?;
        writeln!(f, "rendered on    {}", self.backends.join("; "))?;
        writeln!(
            f,
            "work           {:.3} s of rendering, {} extension and {} shadow rays",
            self.seconds_render, self.extension_rays, self.shadow_rays
        )?;
        write_nonfinite(f, self.nonfinite_samples, &self.nonfinite_by_stage)?;
        for o in self.outputs.iter().chain(&self.variance_output) {
            writeln!(f, "wrote          {o}")?;
        }
        Ok(())
    }
}

pub fn run(a: MergeArgs) -> Result<()> {
    let MergeArgs {
        parts,
        out,
        samples,
        variance_out,
        json,
    } = a;
    let (parts, out, variance_out) = (&parts[..], &out[..], variance_out.as_deref());
    let mut planned: Vec<Output> = out
        .iter()
        .map(|p| Output {
            option: "--out",
            path: p,
        })
        .collect();
    if let Some(v) = variance_out {
        planned.push(Output {
            option: "--variance-out",
            path: v,
        });
    }
    for o in &planned {
        imageio::Format::from_path(o.path).with_context(|| o.option.to_string())?;
        if let Some(p) = parts
            .iter()
            .find(|p| outfile::resolve(p) == outfile::resolve(o.path))
        {
            bail!(
                "{} {} is also a part to merge: it would be overwritten",
                o.option,
                p.display()
            );
        }
    }
    outfile::prepare(&planned)?;
    let m = film::merge_samples(parts, samples)?;
    let provenance = provenance(parts, &m)?;
    let paths: Vec<&Path> = planned.iter().map(|o| o.path).collect();
    outfile::write_each(&paths, |i, p| {
        let (img, variance) = if i < out.len() {
            (&m.mean, Some(&m.variance))
        } else {
            (&m.variance, None)
        };
        let extras = imageio::Extras {
            variance,
            provenance: Some(&provenance),
            ..imageio::Extras::default()
        };
        imageio::write_layered(p, img, &extras)?;
        Ok(())
    })?;
    let nonfinite_samples = m.nonfinite_by_stage.iter().map(|s| s.1).sum();
    let summary = MergeSummary {
        scene: m.scene.clone(),
        parts: parts.len(),
        tiles: m.tiles,
        width: m.mean.width,
        height: m.mean.height,
        samples: [m.samples.start, m.samples.end],
        spp: m.samples.end - m.samples.start,
        backends: m.backends.clone(),
        extension_rays: m.extension_rays,
        shadow_rays: m.shadow_rays,
        nonfinite_samples,
        nonfinite_by_stage: stage_counts(&m.nonfinite_by_stage),
        seconds_render: m.seconds_render,
        mean_radiance: m.mean.mean(),
        outputs: out.iter().map(|o| o.display().to_string()).collect(),
        variance_output: variance_out.map(|v| v.display().to_string()),
    };
    if json {
        outln!("{}", serde_json::to_string(&summary)?)?;
    } else {
        out!("{summary}")?;
    }
    if nonfinite_samples > 0 {
        eprintln!("warning: the parts dropped {nonfinite_samples} non-finite values");
    }
    Ok(())
}

/// What the merged image's EXR attributes say: the union of the parts' samples, their render
/// times added, and the scene hash and version they share (`film::merge` checked that they
/// agree); the backends and devices of the parts, each once. The seed, sampler and depth are
/// in the scene hash but not in the parts' headers, so they are not written.
fn provenance(parts: &[PathBuf], m: &film::Merged) -> Result<imageio::Provenance> {
    let headers = parts
        .iter()
        .map(|p| film::read_header(p))
        .collect::<Result<Vec<_>>>()?;
    let each_once = |f: fn(&film::PartHeader) -> &str| {
        let mut v: Vec<&str> = Vec::new();
        for h in &headers {
            if !v.contains(&f(h)) {
                v.push(f(h));
            }
        }
        v.join("; ")
    };
    let first = &headers[0];
    Ok(imageio::Provenance {
        spp: Some(m.samples.end - m.samples.start),
        samples: Some(m.samples.clone()),
        render_seconds: Some(m.seconds_render),
        scene: Some(m.scene.clone()),
        scene_hash: Some(first.scene_hash.clone()),
        version: Some(first.code_version.clone()),
        backend: Some(each_once(|h| &h.backend)),
        device: Some(each_once(|h| &h.device)),
        ..imageio::Provenance::default()
    })
}
