//! The emitter table both renderers sample for next-event estimation.
//!
//! Every emissive primitive is a light; one is chosen with probability proportional to
//! area × luminance(radiance), then a point uniformly by area on it. Two consecutive emissive
//! triangles that split a quad along its diagonal, (v0, v1, v2) and (v0, v2, v3) of one
//! emitter and of equal area, are one light (entry [`PAIR_BIT`] | the first triangle): its
//! point takes both numbers of one 2-D sample over the unit square, the half below the diagonal
//! mapped to the first triangle and the half above to the second, each by a linear map of
//! determinant one. The square's stratification (a (0,2)-net under the `sobol` sampler) then
//! covers the whole quad, continuous across the shared diagonal, as Mitsuba 3's `rectangle`
//! emitter samples its parameter square; choosing one of the two triangles with a separate,
//! independently padded number would break it. With that choice the
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
//!
//! Point and directional lights ([`DeltaLight`]) join the same table after the emissive
//! primitives, with the weight of the same unit, power/π: area·lum(Le) for an emitter
//! (power π·A·Le), 4·lum(I) for a point light (power 4π·I) and R²·lum(E) for a directional
//! light, R the radius of the scene's bounding sphere (power π·R²·E, pbrt-v4's
//! `DistantLight::Phi`). W then includes them, and so does every emitter's lum(Le)/W. Without
//! such lights the table is built exactly as before, bit for bit. A delta light's entry is
//! [`DELTA_TAG`] | its first texel in the GPU's emitter data ([`LightTable::delta_base`]).
//!
//! An environment map ([`crate::envmap`]) is the last entry, [`ENV_ENTRY`], of weight
//! R²·∫lum(L)dω (power π·R²·∫L dω over the scene's bounding disc, as pbrt-v4's
//! `ImageInfiniteLight::Phi`); a light sample that chooses it draws a direction from the map's
//! own distribution. A scene without a map has no such entry.

use crate::bvh::SPHERE_BIT;
use crate::scene::{DeltaLight, Scene};
use glam::Vec3;

/// The tag of a delta light's entry in [`LightTable::prims`] (both high bits; a sphere entry
/// has only [`SPHERE_BIT`], and no scene has 2^30 spheres). GLSL twin: `DELTA_TAG`.
pub const DELTA_TAG: u32 = 0xC000_0000;

/// The tag of an entry that is a pair of triangles, `first | PAIR_BIT`, the second triangle
/// being `first + 1` (see the module's text). GLSL twin: `PAIR_BIT`.
pub const PAIR_BIT: u32 = 0x4000_0000;

/// The entry of the environment map in [`LightTable::prims`]: the largest delta-tagged value,
/// which no delta light reaches (its index would need 2^29 emitters). GLSL twin: `ENV_ENTRY`.
pub const ENV_ENTRY: u32 = 0xFFFF_FFFF;

/// The largest relative difference of the two areas for which two triangles are sampled as a
/// pair. Each gets half the samples, a density 1/(2·A_i) per unit area where the table assumes
/// 1/(A_1 + A_2): the images are off by at most this fraction, far below f32 rounding of the
/// radiance sums. A quad's halves computed from f32 vertices differ by about 1e-7.
pub const PAIR_AREA_TOLERANCE: f64 = 1e-6;

/// Whether triangles `i` and `i + 1` of the scene are sampled as one light: the same emitter,
/// (v0, v1, v2) and (v0, v2, v3) sharing the diagonal v0–v2, areas within
/// [`PAIR_AREA_TOLERANCE`], and an index below the tag bits.
pub fn pairs_with_next(scene: &Scene, i: usize) -> bool {
    let (Some(a), Some(b)) = (scene.triangles.get(i), scene.triangles.get(i + 1)) else {
        return false;
    };
    if a.emitter.is_none() || a.emitter != b.emitter || i + 1 >= PAIR_BIT as usize {
        return false;
    }
    let (aa, ab) = (a.area(), b.area());
    a.v[0] == b.v[0]
        && a.v[2] == b.v[1]
        && aa > 0.0
        && (aa - ab).abs() <= PAIR_AREA_TOLERANCE * (aa + ab)
}

/// How the 2-D sample (u1, u2) of a pair picks its triangle and point: `(second, b1, b2)`, the
/// barycentric weights of vertices 1 and 2 of the chosen triangle. Below the diagonal
/// (u2 ≤ u1) the first, (b1, b2) = (u1 − u2, u2); above it the second, (u1, u2 − u1). Both
/// maps have determinant one, so each triangle is sampled uniformly with probability 1/2.
/// GLSL twin: the first lines of `sample_triangle_pair_light` (surface.glsl).
pub fn pair_barycentrics(u1: f32, u2: f32) -> (bool, f32, f32) {
    if u2 > u1 {
        (true, u1, u2 - u1)
    } else {
        (false, u1 - u2, u2)
    }
}

/// A point or directional light as both renderers sample it.
#[derive(Clone, Debug, PartialEq)]
pub struct DeltaEntry {
    /// The light is directional (else a point light).
    pub directional: bool,
    /// The position of a point light; the unit direction towards a directional one.
    pub v: Vec3,
    /// Intensity (point) or irradiance (directional).
    pub value: Vec3,
    /// The probability that next-event estimation chooses this light, its weight / W.
    pub select_prob: f32,
}

/// Rec. 709 luminance, the light-selection weight (one definition for the whole crate).
pub use crate::brdf::common::luminance;

#[derive(Clone, Debug, Default)]
pub struct LightTable {
    /// Primitive references: a triangle index, a pair's first triangle | [`PAIR_BIT`], a sphere
    /// index | SPHERE_BIT, or a delta light's `DELTA_TAG | k`.
    pub prims: Vec<u32>,
    /// Inclusive CDF over `prims`; the last entry is exactly 1.
    pub cdf: Vec<f32>,
    /// lum(Le)/W for each of the scene's emitters (by emitter index; 0 when there are no
    /// lights): the light-selection density per unit area.
    pub select_density: Vec<f32>,
    /// The delta lights with non-zero weight, in scene order; entry `j` of them is
    /// `DELTA_TAG | (delta_base + 2j)` in `prims`.
    pub delta: Vec<DeltaEntry>,
    /// The index of the first delta light's texels in the GPU's emitter data: the number of
    /// emitters (each emitter one texel, each delta light two after them).
    pub delta_base: u32,
    /// The probability that next-event estimation chooses the environment map (its entry
    /// [`ENV_ENTRY`]); 0 without one.
    pub env_select: f32,
}

impl LightTable {
    pub fn build(scene: &Scene) -> LightTable {
        let mut prims = Vec::new();
        let mut weights = Vec::new();
        let mut i = 0;
        while i < scene.triangles.len() {
            let t = &scene.triangles[i];
            let pair = pairs_with_next(scene, i);
            if let Some(e) = t.emitter {
                let area = if pair {
                    t.area() + scene.triangles[i + 1].area()
                } else {
                    t.area()
                };
                let w = area * luminance(scene.emitters[e as usize].radiance) as f64;
                if w > 0.0 {
                    prims.push(if pair { i as u32 | PAIR_BIT } else { i as u32 });
                    weights.push(w);
                }
            }
            i += if pair { 2 } else { 1 };
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
        let mut delta = Vec::new();
        let delta_base = scene.emitters.len() as u32;
        if !scene.lights.is_empty() {
            let r2 = bounding_radius(scene).powi(2);
            for l in &scene.lights {
                let (directional, v, value, w) = match *l {
                    DeltaLight::Point {
                        position,
                        intensity,
                    } => (
                        false,
                        position,
                        intensity,
                        4.0 * luminance(intensity) as f64,
                    ),
                    DeltaLight::Directional {
                        direction,
                        irradiance,
                    } => (
                        true,
                        -direction,
                        irradiance,
                        r2 * luminance(irradiance) as f64,
                    ),
                };
                if w > 0.0 && w.is_finite() {
                    prims.push(DELTA_TAG | (delta_base + 2 * delta.len() as u32));
                    weights.push(w);
                    delta.push(DeltaEntry {
                        directional,
                        v,
                        value,
                        select_prob: 0.0,
                    });
                }
            }
        }
        let n_delta = delta.len();
        if let Some(m) = &scene.environment_map {
            let w = bounding_radius(scene).powi(2) * m.luminance_integral;
            if w > 0.0 && w.is_finite() {
                prims.push(ENV_ENTRY);
                weights.push(w);
            }
        }
        let n_env = prims.last().map_or(0, |&p| (p == ENV_ENTRY) as usize);
        let total: f64 = weights.iter().sum();
        let n_area = weights.len() - n_delta - n_env;
        for (d, w) in delta.iter_mut().zip(&weights[n_area..]) {
            d.select_prob = (w / total) as f32;
        }
        let env_select = match n_env {
            1 => (weights[weights.len() - 1] / total) as f32,
            _ => 0.0,
        };
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
            delta,
            delta_base,
            env_select,
        }
    }

    /// The delta light of a `prims` entry, if it is one.
    pub fn delta_at(&self, prim: u32) -> Option<&DeltaEntry> {
        if prim & DELTA_TAG != DELTA_TAG || prim == ENV_ENTRY {
            return None;
        }
        let k = (prim & !DELTA_TAG).checked_sub(self.delta_base)?;
        self.delta.get(k as usize / 2)
    }

    pub fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }

    /// Which kinds of area lights the table holds, for the shaders' compile-time choice:
    /// (single triangles, triangle pairs, spheres).
    pub fn area_kinds(&self) -> (bool, bool, bool) {
        let mut k = (false, false, false);
        for &p in &self.prims {
            if p & DELTA_TAG == DELTA_TAG {
                // A delta light or the environment map.
                continue;
            } else if p & SPHERE_BIT != 0 {
                k.2 = true;
            } else if p & PAIR_BIT != 0 {
                k.1 = true;
            } else {
                k.0 = true;
            }
        }
        k
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

/// The radius of the bounding sphere of the scene's primitives (half the diagonal of their
/// box), in f64; at least 1e-3 so that a directional light over a point-sized scene keeps a
/// weight.
fn bounding_radius(scene: &Scene) -> f64 {
    let mut lo = glam::DVec3::splat(f64::INFINITY);
    let mut hi = glam::DVec3::splat(f64::NEG_INFINITY);
    let d = |v: Vec3| v.as_dvec3();
    for t in &scene.triangles {
        for v in t.v {
            lo = lo.min(d(v));
            hi = hi.max(d(v));
        }
    }
    for s in &scene.spheres {
        let r = glam::DVec3::splat(s.radius as f64);
        lo = lo.min(d(s.center) - r);
        hi = hi.max(d(s.center) + r);
    }
    let r = 0.5 * (hi - lo).length();
    if r.is_finite() {
        r.max(1e-3)
    } else {
        1e-3
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glsl_delta_tag_matches() {
        let glsl = include_str!("../shaders/wavefront/surface.glsl");
        let tag = crate::robust::glsl_define(glsl, "surface.glsl", "DELTA_TAG");
        assert_eq!(tag, format!("{DELTA_TAG:#010X}u").replace("0X", "0x"));
        let pair = crate::robust::glsl_define(glsl, "surface.glsl", "PAIR_BIT");
        assert_eq!(pair, format!("{PAIR_BIT:#010X}u").replace("0X", "0x"));
    }

    /// Weights by power/π: a unit-area emitter of radiance 1 (π), a point light of intensity
    /// 1/4 (π) and a directional light of irradiance 1/R² (π) are chosen equally often.
    #[test]
    fn lights_are_chosen_by_power() {
        // The emitter quad spans [0, 1]² at z = 0 and the sphere [0, 2]² × [-1, 1]: the
        // bounding box is 2 wide on each axis, R = √3, R² = 3.
        let src = "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\nfov_y = 30\n\
            [film]\nwidth = 4\nheight = 4\n[materials.m]\nmodel = \"lambert\"\n\
            [[shapes]]\nmaterial = \"m\"\nemission = 1\n\
            quads = [[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]]\n\
            [[shapes]]\nmaterial = \"m\"\nsphere = { center = [1, 1, 0], radius = 1 }\n\
            [[lights]]\ntype = \"point\"\nposition = [0, 0, 1]\nintensity = 0.25\n\
            [[lights]]\ntype = \"directional\"\ndirection = [0, 0, -1]\nirradiance = 0.3333333333333333\n";
        let s = crate::scene::load_str(src, std::path::Path::new("t.toml")).unwrap();
        let t = LightTable::build(&s);
        assert_eq!(t.prims.len(), 3);
        assert_eq!(
            t.prims[0], PAIR_BIT,
            "the quad's two triangles are one light"
        );
        assert_eq!(t.delta_base, 1);
        assert_eq!(t.prims[1], DELTA_TAG | 1);
        assert_eq!(t.prims[2], DELTA_TAG | 3);
        let expect = [1.0 / 3.0, 2.0 / 3.0, 1.0];
        for (c, e) in t.cdf.iter().zip(&expect) {
            assert!((c - e).abs() < 1e-6, "{:?}", t.cdf);
        }
        for d in &t.delta {
            assert!((d.select_prob - 1.0 / 3.0).abs() < 1e-6, "{d:?}");
        }
        assert!(t.delta[1].directional && t.delta[1].v == Vec3::Z);
        assert_eq!(t.delta_at(t.prims[2]), Some(&t.delta[1]));
        assert_eq!(t.delta_at(t.prims[0]), None);
        assert!((t.select_density[0] - 1.0 / 3.0).abs() < 1e-6);
    }

    /// The pair map is the parallelogram's bilinear parameterization v0 + u1·(v1 − v0) +
    /// u2·(v3 − v0) on both halves (continuous across the diagonal, as a rectangle emitter
    /// samples its parameter square), and gives each triangle half of a uniform grid.
    #[test]
    fn a_pair_is_sampled_as_its_parallelogram() {
        let (v0, v1, v2, v3) = (
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.5, 1.0, 0.0),
            Vec3::new(0.5, 1.0, 0.0),
        );
        let n = 64;
        let mut seconds = 0;
        for i in 0..n {
            for j in 0..n {
                let (u1, u2) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let (second, b1, b2) = pair_barycentrics(u1, u2);
                assert!(b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0);
                let [a, b, c] = if second { [v0, v2, v3] } else { [v0, v1, v2] };
                let p = a + b1 * (b - a) + b2 * (c - a);
                let want = v0 + u1 * (v1 - v0) + u2 * (v3 - v0);
                assert!((p - want).length() < 1e-5, "{u1} {u2}: {p} vs {want}");
                seconds += second as u32;
            }
        }
        assert_eq!(seconds, n * (n - 1) / 2, "the half above the diagonal");
    }

    /// Only consecutive emissive triangles of one emitter that share the diagonal and have
    /// equal areas are paired; the pair carries both areas' weight.
    #[test]
    fn only_halves_of_a_quad_are_paired() {
        let scene = |quad: &str, emission2: &str| {
            let src = format!(
                "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\nfov_y = 30\n\
                 [film]\nwidth = 4\nheight = 4\n[materials.m]\nmodel = \"lambert\"\n\
                 [[shapes]]\nmaterial = \"m\"\nemission = 1\nquads = [{quad}]\n\
                 [[shapes]]\nmaterial = \"m\"\nemission = {emission2}\n\
                 triangles = [[[5, 0, 0], [6, 0, 0], [6, 1, 0]], [[5, 0, 0], [6, 1, 0], [5, 1, 0]]]\n"
            );
            crate::scene::load_str(&src, std::path::Path::new("t.toml")).unwrap()
        };
        // A unit square, then two triangles of the same shape but another emitter... of the
        // same radiance: the second shape's triangles pair among themselves, not with the quad.
        let s = scene("[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]", "1");
        let t = LightTable::build(&s);
        assert_eq!(t.prims, [PAIR_BIT, 2 | PAIR_BIT]);
        assert_eq!(t.area_kinds(), (false, true, false));
        assert!((t.cdf[0] - 0.5).abs() < 1e-6);
        // A trapezoid's halves differ in area: two single lights.
        let s = scene("[[0, 0, 0], [2, 0, 0], [1, 1, 0], [0, 1, 0]]", "0");
        let t = LightTable::build(&s);
        assert_eq!(t.prims, [0, 1]);
        assert_eq!(t.area_kinds(), (true, false, false));
    }
}
