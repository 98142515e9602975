//! The emitter table both renderers sample for next-event estimation.
//!
//! Every emissive primitive is a light; one is chosen with probability proportional to
//! area × luminance(radiance), then a point uniformly by area on it. With that choice the
//! solid-angle density of a light point seen from x is
//!
//! p(ω) = lum(Le) / W · d² / |cos θ_light|,  W = Σ area·lum(Le),
//!
//! in which the primitive's area cancels, so the MIS weight of a BSDF-sampled ray that hits
//! an emitter needs only the emitter's radiance, the distance and the cosine (no per-primitive
//! lookup). GLSL twin: `shaders/wavefront/lights.glsl`.

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
    /// W = Σ area·lum(Le).
    pub total_weight: f32,
}

impl LightTable {
    pub fn build(scene: &Scene) -> LightTable {
        let mut prims = Vec::new();
        let mut weights = Vec::new();
        for (i, t) in scene.triangles.iter().enumerate() {
            if let Some(e) = t.emitter {
                let w = t.area() as f64 * luminance(scene.emitters[e as usize].radiance) as f64;
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
        LightTable {
            prims,
            cdf,
            total_weight: total as f32,
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
