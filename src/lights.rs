//! The emitter table both renderers sample for next-event estimation.
//!
//! Every emissive primitive is a light; one is chosen with probability proportional to
//! area × luminance(radiance), then a point uniformly by area on it. With that choice the
//! solid-angle density of a light point seen from x is
//!
//! p(ω) = lum(Le) / W · d² / |cos θ_light|,  W = Σ area·lum(Le),
//!
//! in which the primitive's area cancels, so the MIS weight of a BSDF-sampled ray that hits
//! an emitter needs only the emitter's selection density lum(Le)/W, the distance and the cosine
//! (no per-primitive lookup). lum(Le)/W is computed here in f64, once per emitter, and read by
//! both renderers: computed on a GPU as lum(Le)·(1/W), it was 0 on an NVIDIA H200 for W above
//! about 8.5e37, where 1/W is a denormal that the GPU flushes to zero (next-event estimation
//! then silently did nothing). GLSL twin: `sample_light` and `light_pdf` in
//! `shaders/wavefront/surface.glsl`.

use crate::bvh::SPHERE_BIT;
use crate::scene::Scene;

/// Rec. 709 luminance, the light-selection weight (one definition for the whole crate).
pub use crate::brdf::common::luminance;

#[derive(Clone, Debug, Default)]
pub struct LightTable {
    /// Primitive references (triangle index, or sphere index | SPHERE_BIT).
    pub prims: Vec<u32>,
    /// Inclusive CDF over `prims`; the last entry is exactly 1.
    pub cdf: Vec<f32>,
    /// lum(Le)/W for each of the scene's emitters (by emitter index; 0 when there are no
    /// lights): the light-selection density per unit area.
    pub select_density: Vec<f32>,
}

impl LightTable {
    pub fn build(scene: &Scene) -> LightTable {
        let mut prims = Vec::new();
        let mut weights = Vec::new();
        for (i, t) in scene.triangles.iter().enumerate() {
            if let Some(e) = t.emitter {
                let w = t.area() * luminance(scene.emitters[e as usize].radiance) as f64;
                if w > 0.0 {
                    prims.push(i as u32);
                    weights.push(w);
                }
            }
        }
        for (i, s) in scene.spheres.iter().enumerate() {
            if let Some(e) = s.emitter {
                let area = 4.0 * std::f64::consts::PI * (s.radius as f64).powi(2);
                let w = area * luminance(scene.emitters[e as usize].radiance) as f64;
                if w > 0.0 {
                    prims.push(i as u32 | SPHERE_BIT);
                    weights.push(w);
                }
            }
        }
        let total: f64 = weights.iter().sum();
        let mut acc = 0.0;
        let mut cdf: Vec<f32> = weights
            .iter()
            .map(|w| {
                acc += w;
                (acc / total) as f32
            })
            .collect();
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        let select_density = scene
            .emitters
            .iter()
            .map(|e| {
                if total > 0.0 {
                    (luminance(e.radiance) as f64 / total) as f32
                } else {
                    0.0
                }
            })
            .collect();
        LightTable {
            prims,
            cdf,
            select_density,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }

    /// Index of the light chosen by `u` in [0, 1): the first entry whose CDF exceeds `u`
    /// (binary search; the GLSL twin runs the same loop).
    pub fn select(&self, u: f32) -> usize {
        let (mut lo, mut hi) = (0usize, self.cdf.len() - 1);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if self.cdf[mid] > u {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        lo
    }
}
