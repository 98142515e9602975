//! What a render produces, whichever backend made it.

use crate::imageio::Image;

/// Path segments counted one by one in [`RenderOutput::rays_by_segment`] (a convention of both
/// renderers, [`crate::conventions`]).
pub use crate::conventions::SEGMENTS_COUNTED;

pub struct RenderOutput {
    /// Per-pixel mean radiance (linear RGB).
    pub mean: Image,
    /// Per-pixel variance of one sample (unbiased), for statistical comparisons.
    pub variance: Image,
    pub spp: u32,
    /// Non-finite (NaN or infinite) values dropped, in all stages: 0 in a correct render.
    pub nonfinite_samples: u64,
    /// The same by stage, where each arose, the same stages on both backends: `extend`
    /// (emitted light reaching the path), `shade_<model>` (a light sample's contribution, or the
    /// path's next throughput, direction or pdf: the path ends there), `accumulate` (a sample's
    /// total radiance).
    pub nonfinite_by_stage: Vec<(String, u64)>,
    /// Extension (closest-hit) rays traced.
    pub extension_rays: u64,
    /// Shadow (any-hit) rays traced.
    pub shadow_rays: u64,
    /// Of those, the ones that found an occluder (`stress --group self_shadow` counts false
    /// occlusions with it, where none can be blocked).
    pub shadow_rays_occluded: u64,
    /// (extension, shadow) rays by path segment from 1, up to the maximum depth or
    /// [`SEGMENTS_COUNTED`] (which then also holds the deeper ones): the queue sizes per segment.
    pub rays_by_segment: Vec<(u64, u64)>,
    /// Time per stage (GPU timestamps; empty for the CPU), summed over all passes.
    pub stage_seconds: Vec<(String, f64)>,
}

/// The non-finite counts by stage, named as the GPU names its pipelines, in its order:
/// `extend`, then `shade_<model>` for each `(model index, count)` in `shade`, then `accumulate`.
/// Both backends build [`RenderOutput::nonfinite_by_stage`] with it.
pub fn nonfinite_stages(
    extend: u64,
    shade: impl IntoIterator<Item = (usize, u64)>,
    accumulate: u64,
) -> Vec<(String, u64)> {
    let mut v = vec![("extend".to_string(), extend)];
    v.extend(
        shade
            .into_iter()
            .map(|(m, n)| (format!("shade_{}", crate::brdf::MODELS[m].name), n)),
    );
    v.push(("accumulate".to_string(), accumulate));
    v
}
