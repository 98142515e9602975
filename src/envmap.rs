//! Environment maps: an equirectangular (latitude–longitude) image of radiance around the
//! scene, seen by every ray that leaves it, looked up with bilinear filtering and sampled for
//! next-event estimation in proportion to luminance × sin θ. GLSL twin (independent code, the
//! same conventions and numbers): `shaders/envmap.glsl`.
//!
//! **Mapping.** Mitsuba 3's `envmap` convention, so that its scenes render alike: a world
//! direction d is turned into the map's frame by the inverse of its rotation (`to_world`),
//! d_l = R⁻¹ d, and then
//!
//! u = atan2(d_l.x, −d_l.z) / 2π (taken modulo 1),  v = acos(d_l.y) / π,
//!
//! so +y is the top row (v = 0), −z the left edge (u = 0) and the image runs towards +x. The
//! inverse is d_l = (sin 2πu · sin πv, cos πv, −cos 2πu · sin πv).
//!
//! **Lookup.** Bilinear between texel centres placed as Mitsuba places them: column x at
//! u = (x + ½)/W, wrapping around from the last column to the first; row y at v = y/(H − 1),
//! so the first and the last rows lie on the poles. A map therefore needs at least 2 × 2
//! texels.
//!
//! **Sampling** (the 2-D piecewise-constant distribution of Pharr, Jakob & Humphreys 2016,
//! *Physically Based Rendering*, 3rd ed., §13.6.7 and §14.2.4; Mitsuba 3 samples a bilinear
//! version of the same density). The cells of the distribution are the W × (H − 1) patches
//! between four texel centres; cell (x, y) weighs the mean luminance of its four corners times
//! sin θ at its centre, θ = π(y + ½)/(H − 1), so every cell whose radiance is not zero
//! everywhere has a positive probability. A row is chosen by the marginal CDF over rows, a
//! cell by its row's conditional CDF, and the point uniformly within the cell (the
//! continuous offset of the two CDF inversions). The density in (u, v) is p(u, v) = f(x, y) ·
//! W (H − 1) / Σf, and in solid angle, as dω = 2π² sin θ du dv,
//!
//! p(ω) = p(u, v) / (2π² sin θ).
//!
//! The CDFs and each cell's p(u, v) are computed here in f64 once and stored in f32, read by
//! both renderers. The power the light table weighs the map with (`crate::lights`) is
//! R² · ∫ lum(L) dω, the integral taken over the same cells.

use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;
use std::fmt;
use std::path::PathBuf;

/// Rec. 709 luminance, as everywhere else.
use crate::lights::luminance;

/// An environment map, loaded and checked (`scenes/README.md`, `[environment]`).
#[derive(Clone)]
pub struct EnvMap {
    /// The image file, for messages and `convert`.
    pub path: PathBuf,
    /// The factor the file's values were multiplied by (`scale`).
    pub scale: f32,
    /// The rotation from the map's frame to the world (`to_world`, `transform`).
    pub to_world: Mat3,
    pub width: u32,
    pub height: u32,
    /// Radiance, scale applied, row by row from the top (v = 0).
    pub texels: Vec<[f32; 3]>,
    /// The marginal CDF over the H − 1 rows of cells: H entries, from 0 to exactly 1.
    pub marginal: Vec<f32>,
    /// Each row's conditional CDF over its W cells: W + 1 entries a row, from 0 to exactly 1.
    pub conditional: Vec<f32>,
    /// Each cell's density in (u, v), W a row.
    pub cell_pdf: Vec<f32>,
    /// ∫ lum(L) dω over the sphere (the cells' piecewise-constant approximation).
    pub luminance_integral: f64,
}

impl fmt::Debug for EnvMap {
    /// The scene hash of partial films prints the scene with `{:?}`: the texels enter as a
    /// hash of their bits, not as millions of numbers.
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(
            f,
            "EnvMap {{ {}x{}, scale {:?}, to_world {:?}, texels {:016x} }}",
            self.width,
            self.height,
            self.scale,
            self.to_world,
            crate::hash::texels_hash(&self.texels)
        )
    }
}

/// Why a map cannot be built from an image; the loader adds the file and the field.
#[derive(Debug, PartialEq)]
pub enum EnvMapError {
    TooSmall {
        width: u32,
        height: u32,
    },
    /// A texel that is not a finite number ≥ 0 (x, y, its value).
    BadTexel {
        x: u32,
        y: u32,
        value: [f32; 3],
    },
    /// A texel that the scale makes infinite.
    Overflow {
        x: u32,
        y: u32,
        value: [f32; 3],
    },
}

impl fmt::Display for EnvMapError {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self {
            EnvMapError::TooSmall { width, height } => write!(
                f,
                "the map is {width}x{height} texels: an environment map needs at least 2x2 (the rows lie on the poles)"
            ),
            EnvMapError::BadTexel { x, y, value } => write!(
                f,
                "texel ({x}, {y}) is {value:?}: an environment map's radiance must be finite and >= 0 in every channel"
            ),
            EnvMapError::Overflow { x, y, value } => write!(
                f,
                "texel ({x}, {y}) {value:?} times the scale overflows single precision"
            ),
        }
    }
}

impl EnvMap {
    /// The map of an image (`width` × `height` texels, row 0 at the top) times `scale`, turned
    /// by `to_world` (a rotation). Refuses a map smaller than 2 × 2 and any texel that is not
    /// finite and ≥ 0, before or after scaling.
    ///
    /// The pixels become the texels in place, and the cells' weights are made again, a row at a
    /// time, for each of the two passes that need them: a map costs its texels (12 bytes each)
    /// and the sampling tables (8 bytes a cell), 5 GiB at the largest size, 16384².
    pub fn new(
        path: PathBuf,
        width: u32,
        height: u32,
        pixels: Vec<[f32; 3]>,
        scale: f32,
        to_world: Mat3,
    ) -> Result<EnvMap, EnvMapError> {
        if width < 2 || height < 2 {
            return Err(EnvMapError::TooSmall { width, height });
        }
        let (w, h) = (width as usize, height as usize);
        assert_eq!(pixels.len(), w * h, "the image holds width × height pixels");
        let mut texels = pixels;
        for (i, p) in texels.iter_mut().enumerate() {
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            if !p.iter().all(|c| c.is_finite() && *c >= 0.0) {
                return Err(EnvMapError::BadTexel { x, y, value: *p });
            }
            let s = p.map(|c| c * scale);
            if !s.iter().all(|c| c.is_finite()) {
                return Err(EnvMapError::Overflow { x, y, value: *p });
            }
            *p = s;
        }
        // The weights of row y's cells, in f64: the mean luminance of the four corners times
        // sin θ at the centre.
        let rows = h - 1;
        let lum = |i: usize| luminance(Vec3::from_array(texels[i])) as f64;
        let row_weights = |y: usize, f: &mut Vec<f64>| {
            f.clear();
            let sin = (std::f64::consts::PI * (y as f64 + 0.5) / rows as f64).sin();
            for x in 0..w {
                let x1 = (x + 1) % w;
                let corners =
                    lum(y * w + x) + lum(y * w + x1) + lum((y + 1) * w + x) + lum((y + 1) * w + x1);
                f.push(0.25 * corners * sin);
            }
        };
        let mut f = Vec::with_capacity(w);
        let row_sums: Vec<f64> = (0..rows)
            .map(|y| {
                row_weights(y, &mut f);
                f.iter().sum()
            })
            .collect();
        let total: f64 = row_sums.iter().sum();
        // A black map has nothing to sample: uniform cells (never chosen, since its light
        // weight is 0).
        let uniform = total <= 0.0 || !total.is_finite();
        let cells = (w * rows) as f64;
        let mut conditional = Vec::with_capacity(rows * (w + 1));
        let mut cell_pdf = Vec::with_capacity(rows * w);
        for (y, &sum) in row_sums.iter().enumerate() {
            row_weights(y, &mut f);
            conditional.extend(cdf(&f, uniform || sum <= 0.0));
            cell_pdf.extend(f.iter().map(|v| match uniform {
                true => 1.0,
                false => (v * cells / total) as f32,
            }));
        }
        let marginal = cdf(&row_sums, uniform);
        // ∫ lum dω = Σ f · (du dv) · 2π² (f already carries the sin θ).
        let luminance_integral = total / cells * 2.0 * std::f64::consts::PI * std::f64::consts::PI;
        Ok(EnvMap {
            path,
            scale,
            to_world,
            width,
            height,
            texels,
            marginal,
            conditional,
            cell_pdf,
            luminance_integral,
        })
    }

    /// The map's rows of the world-to-map rotation R⁻¹ = Rᵀ (GPU: `Globals::env_x` …).
    pub fn to_local_rows(&self) -> [Vec3; 3] {
        let t = self.to_world.transpose();
        [t.row(0), t.row(1), t.row(2)]
    }

    /// A world direction in the map's frame.
    pub fn to_local(&self, d: Vec3) -> Vec3 {
        let [x, y, z] = self.to_local_rows();
        Vec3::new(x.dot(d), y.dot(d), z.dot(d))
    }

    /// A direction of the map's frame in the world.
    pub fn to_world_dir(&self, l: Vec3) -> Vec3 {
        let [x, y, z] = self.to_local_rows();
        x * l.x + y * l.y + z * l.z
    }

    /// The texel at column x (any integer, taken modulo W) and row y.
    fn texel(&self, x: usize, y: usize) -> Vec3 {
        Vec3::from_array(self.texels[y * self.width as usize + x])
    }

    /// The radiance at (u, v), bilinear between texel centres (module docs).
    pub fn lookup(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.width as usize, self.height as usize);
        let (x0, y0, fx, fy) = env_cell(uv, self.width, self.height);
        let x1 = if x0 + 1 == w { 0 } else { x0 + 1 };
        let _ = h;
        let a = self.texel(x0, y0) * (1.0 - fx) + self.texel(x1, y0) * fx;
        let b = self.texel(x0, y0 + 1) * (1.0 - fx) + self.texel(x1, y0 + 1) * fx;
        a * (1.0 - fy) + b * fy
    }

    /// The radiance arriving from world direction `d` (unit).
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        self.lookup(env_uv(self.to_local(d)))
    }

    /// The solid-angle density with which [`EnvMap::sample`] chooses world direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        let l = self.to_local(d);
        let sin_theta = (l.x * l.x + l.z * l.z).sqrt();
        if sin_theta.is_nan() || sin_theta <= 0.0 {
            return 0.0;
        }
        let (x, y) = env_cell_of(env_uv(l), self.width, self.height);
        self.cell_pdf[y * self.width as usize + x] / (2.0 * PI * PI * sin_theta)
    }

    /// A world direction drawn by (u1, u2) in [0, 1)², its solid-angle density and the
    /// radiance from it; `None` for a direction at a pole (sin θ = 0, measure zero).
    pub fn sample(&self, u1: f32, u2: f32) -> Option<EnvSample> {
        let (w, h) = (self.width as usize, self.height as usize);
        let (y, dv) = sample_cdf(&self.marginal, u2);
        let row = &self.conditional[y * (w + 1)..(y + 1) * (w + 1)];
        let (x, du) = sample_cdf(row, u1);
        let mut u = (x as f32 + 0.5 + du) / w as f32;
        if u >= 1.0 {
            u -= 1.0;
        }
        let v = (y as f32 + dv) / (h - 1) as f32;
        let (sin_t, cos_t) = sincos_turns(0.5 * v);
        let (sin_p, cos_p) = sincos_turns(u);
        if sin_t.is_nan() || sin_t <= 0.0 {
            return None;
        }
        let local = Vec3::new(sin_p * sin_t, cos_t, -cos_p * sin_t);
        let pdf = self.cell_pdf[y * w + x] / (2.0 * PI * PI * sin_t);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        Some(EnvSample {
            wi: self.to_world_dir(local),
            pdf,
            radiance: self.lookup(Vec2::new(u, v)),
        })
    }
}

/// A direction chosen by [`EnvMap::sample`].
#[derive(Clone, Copy, Debug)]
pub struct EnvSample {
    /// The world direction towards the environment.
    pub wi: Vec3,
    /// Its solid-angle density.
    pub pdf: f32,
    /// The radiance arriving from it.
    pub radiance: Vec3,
}

/// 1/(2π) and 1/π, the nearest f32s (written out so that both sides use the same bits).
const INV_2PI: f32 = 0.159_154_94;
const INV_PI: f32 = 0.318_309_87;

/// atan2(y, x) in f32 by basic operations only (no library call), so that both renderers get
/// the same bits: the library `atan`s of lavapipe and of Rust differ by about 1e-5 rad, which
/// moves a map's bilinear lookup visibly (1e-4 of the radiance on a 32-texel map). The ratio
/// min/max of |x|, |y| in [0, 1] is reduced once more by atan t = π/4 + atan((t − 1)/(t + 1))
/// to |t| ≤ tan(π/8) ≈ 0.4142, where the Taylor series to t¹⁵ is within 2e-8 (the next term,
/// t¹⁷/17); then the octant is restored. 0 at (0, 0). GLSL twin: `env_atan2`.
pub fn atan2_f32(y: f32, x: f32) -> f32 {
    const FRAC_PI_4: f32 = std::f32::consts::FRAC_PI_4;
    const FRAC_PI_2: f32 = std::f32::consts::FRAC_PI_2;
    let (ax, ay) = (x.abs(), y.abs());
    let (hi, lo) = (ax.max(ay), ax.min(ay));
    if hi.is_nan() || hi <= 0.0 {
        return 0.0;
    }
    let a = lo / hi;
    let big = a > 0.414_213_57;
    let t = if big { (a - 1.0) / (a + 1.0) } else { a };
    let s = t * t;
    let mut p = -1.0 / 15.0;
    p = p * s + 1.0 / 13.0;
    p = p * s - 1.0 / 11.0;
    p = p * s + 1.0 / 9.0;
    p = p * s - 1.0 / 7.0;
    p = p * s + 1.0 / 5.0;
    p = p * s - 1.0 / 3.0;
    let mut r = t + t * (s * p);
    if big {
        r += FRAC_PI_4;
    }
    if ay > ax {
        r = FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = std::f32::consts::PI - r;
    }
    if y < 0.0 {
        -r
    } else {
        r
    }
}

/// (sin 2πt, cos 2πt) in f32 by basic operations only, for the same bits on both renderers
/// (lavapipe's `sin` and `cos` differ from Rust's in the last bits, and a light sample's
/// direction that moves by an ulp can graze past a silhouette on one side only). The angle is
/// reduced exactly in turns to the quadrant q = ⌊4t + ½⌋ and r = t − q/4 in [−⅛, ⅛], x = 2πr
/// in [−π/4, π/4], where the Taylor series to x¹³ (sine) and x¹⁴ (cosine) are within 1e-12;
/// then the quadrant is restored. GLSL twin: `sincos_turns` (common.glsl).
pub fn sincos_turns(t: f32) -> (f32, f32) {
    let q = (t * 4.0 + 0.5).floor();
    let x = (t - q * 0.25) * (2.0 * PI);
    let s2 = x * x;
    let mut sp = 1.0 / 6_227_020_800.0;
    sp = sp * s2 - 1.0 / 39_916_800.0;
    sp = sp * s2 + 1.0 / 362_880.0;
    sp = sp * s2 - 1.0 / 5040.0;
    sp = sp * s2 + 1.0 / 120.0;
    sp = sp * s2 - 1.0 / 6.0;
    let s = x + x * (s2 * sp);
    let mut cp = 1.0 / 87_178_291_200.0;
    cp = cp * s2 - 1.0 / 479_001_600.0;
    cp = cp * s2 + 1.0 / 3_628_800.0;
    cp = cp * s2 - 1.0 / 40320.0;
    cp = cp * s2 + 1.0 / 720.0;
    cp = cp * s2 - 1.0 / 24.0;
    cp = cp * s2 + 0.5;
    let c = 1.0 - s2 * cp;
    match (q as i32).rem_euclid(4) {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// (u, v) of a direction in the map's frame (module docs), u in [0, 1); θ as atan2(sin θ,
/// cos θ), accurate at the poles too.
pub fn env_uv(l: Vec3) -> Vec2 {
    let mut u = atan2_f32(l.x, -l.z) * INV_2PI;
    if u < 0.0 {
        u += 1.0;
    }
    if u >= 1.0 {
        u = 0.0;
    }
    let v = atan2_f32((l.x * l.x + l.z * l.z).sqrt(), l.y) * INV_PI;
    Vec2::new(u, v.min(1.0))
}

/// The bilinear patch of (u, v): its top-left texel (x0, y0) and the weights (fx, fy) of the
/// texels to its right and below. Column x sits at u = (x + ½)/W, row y at v = y/(H − 1).
pub fn env_cell(uv: Vec2, width: u32, height: u32) -> (usize, usize, f32, f32) {
    let (w, h) = (width as f32, height as f32);
    let mut s = uv.x * w - 0.5;
    if s < 0.0 {
        s += w;
    }
    let t = uv.y * (h - 1.0);
    let x0 = (s.max(0.0) as usize).min(width as usize - 1);
    let y0 = (t.max(0.0) as usize).min(height as usize - 2);
    (
        x0,
        y0,
        (s - x0 as f32).clamp(0.0, 1.0),
        (t - y0 as f32).clamp(0.0, 1.0),
    )
}

/// The sampling cell that holds (u, v): the bilinear patch of [`env_cell`].
pub fn env_cell_of(uv: Vec2, width: u32, height: u32) -> (usize, usize) {
    let (x, y, _, _) = env_cell(uv, width, height);
    (x, y)
}

/// The CDF of `weights` (n + 1 entries from 0 to exactly 1), computed in f64; uniform when
/// `uniform` is set (a row without light).
fn cdf(weights: &[f64], uniform: bool) -> Vec<f32> {
    let n = weights.len();
    let total: f64 = weights.iter().sum();
    let mut out = Vec::with_capacity(n + 1);
    out.push(0.0);
    let mut acc = 0.0;
    for (i, w) in weights.iter().enumerate() {
        acc += w;
        out.push(match uniform {
            true => ((i + 1) as f64 / n as f64) as f32,
            false => (acc / total) as f32,
        });
    }
    out[n] = 1.0;
    out
}

/// Inverts a CDF of n + 1 entries at `u` in [0, 1): the interval i with cdf[i] ≤ u <
/// cdf[i + 1] (the last one whose start is ≤ u, skipping empty intervals) and the offset of u
/// within it, in [0, 1). GLSL twin: `env_sample_cdf` (the same binary search).
pub fn sample_cdf(cdf: &[f32], u: f32) -> (usize, f32) {
    let n = cdf.len() - 1;
    // The last i in [0, n) with cdf[i] <= u.
    let (mut lo, mut hi) = (0usize, n - 1);
    while lo < hi {
        let mid = (lo + hi).div_ceil(2);
        if cdf[mid] <= u {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    let width = cdf[lo + 1] - cdf[lo];
    let d = if width > 0.0 {
        ((u - cdf[lo]) / width).clamp(0.0, 0.99999994)
    } else {
        0.0
    };
    (lo, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(w: u32, h: u32, f: impl Fn(u32, u32) -> f32) -> EnvMap {
        let px: Vec<[f32; 3]> = (0..w * h).map(|i| [f(i % w, i / w); 3]).collect();
        EnvMap::new("t.exr".into(), w, h, px, 1.0, Mat3::IDENTITY).unwrap()
    }

    #[test]
    fn the_mapping_is_mitsubas_and_inverts() {
        // +y is the top row, -z the left edge, +x a quarter of the way.
        assert!((env_uv(Vec3::Y).y).abs() < 1e-6);
        assert!((env_uv(-Vec3::Y).y - 1.0).abs() < 1e-6);
        assert!((env_uv(-Vec3::Z) - Vec2::new(0.0, 0.5)).length() < 1e-6);
        assert!((env_uv(Vec3::X) - Vec2::new(0.25, 0.5)).length() < 1e-6);
        let m = map(8, 5, |x, y| (x + y) as f32);
        for i in 1..50 {
            let (u1, u2) = ((i as f32 * 0.618).fract(), (i as f32 * 0.377).fract());
            let s = m.sample(u1, u2).unwrap();
            assert!((s.wi.length() - 1.0).abs() < 1e-5);
            assert!(
                (m.pdf(s.wi) / s.pdf - 1.0).abs() < 1e-3,
                "{} {}",
                m.pdf(s.wi),
                s.pdf
            );
            assert!((m.radiance(s.wi) - s.radiance).length() < 1e-3 * (1.0 + s.radiance.length()));
        }
    }

    #[test]
    fn bilinear_lookup_hits_texel_centres_and_wraps() {
        let m = map(4, 3, |x, y| (10 * y + x) as f32);
        for y in 0..3 {
            for x in 0..4 {
                let uv = Vec2::new((x as f32 + 0.5) / 4.0, y as f32 / 2.0);
                assert!(
                    (m.lookup(uv).x - (10 * y + x) as f32).abs() < 1e-4,
                    "{x} {y}"
                );
            }
        }
        // Halfway between the last column and the first (u = 0): their mean.
        assert!((m.lookup(Vec2::new(0.0, 0.0)).x - 1.5).abs() < 1e-5);
    }

    #[test]
    fn a_constant_map_integrates_to_4_pi() {
        let m = map(16, 9, |_, _| 1.0);
        // Σ sin θ_c Δθ over midpoints is within 1 % of 2 for 8 rows.
        let want = 4.0 * std::f64::consts::PI;
        assert!(
            (m.luminance_integral / want - 1.0).abs() < 0.01,
            "{}",
            m.luminance_integral
        );
        // The solid-angle pdf of a uniform map is about 1/4π away from the poles.
        let p = m.pdf(Vec3::new(1.0, 0.1, 0.2).normalize());
        assert!((p * 4.0 * PI - 1.0).abs() < 0.05, "{p}");
    }

    #[test]
    fn bad_texels_and_tiny_maps_are_refused() {
        let px = vec![[1.0; 3]; 4];
        assert!(matches!(
            EnvMap::new("t".into(), 4, 1, px.clone(), 1.0, Mat3::IDENTITY),
            Err(EnvMapError::TooSmall { .. })
        ));
        let mut px = vec![[1.0; 3]; 6];
        px[4] = [1.0, f32::NAN, 0.0];
        assert!(matches!(
            EnvMap::new("t".into(), 3, 2, px.clone(), 1.0, Mat3::IDENTITY),
            Err(EnvMapError::BadTexel { x: 1, y: 1, .. })
        ));
        px[4] = [1.0, -1.0, 0.0];
        assert!(EnvMap::new("t".into(), 3, 2, px.clone(), 1.0, Mat3::IDENTITY).is_err());
        px[4] = [3e38; 3];
        assert!(matches!(
            EnvMap::new("t".into(), 3, 2, px.clone(), 10.0, Mat3::IDENTITY),
            Err(EnvMapError::Overflow { .. })
        ));
    }

    #[test]
    fn atan2_matches_the_library_within_two_ulps() {
        let mut worst = 0.0f64;
        for i in 0..20000 {
            let a = i as f64 * 0.000_314_159_26 * 2.0 - std::f64::consts::PI;
            for r in [1e-30, 1e-3, 1.0, 7.5e3] {
                let (y, x) = ((a.sin() * r) as f32, (a.cos() * r) as f32);
                let want = (y as f64).atan2(x as f64);
                // ±π are the same angle (a y of -0 gives -π in f64, +π here).
                let e = (atan2_f32(y, x) as f64 - want).abs();
                worst = worst.max(e.min((e - 2.0 * std::f64::consts::PI).abs()));
            }
        }
        // Two f32 ulps at π (2.4e-7 each).
        assert!(worst < 4.8e-7, "{worst}");
        assert_eq!(atan2_f32(0.0, 0.0), 0.0);
        assert_eq!(atan2_f32(0.0, -1.0), std::f32::consts::PI);
    }

    #[test]
    fn sincos_matches_the_library_within_an_ulp_or_two() {
        let mut worst = 0.0f64;
        for i in 0..100_000 {
            let t = i as f32 / 100_000.0 * 1.5 - 0.25;
            let (s, c) = sincos_turns(t);
            let a = 2.0 * std::f64::consts::PI * t as f64;
            worst = worst
                .max((s as f64 - a.sin()).abs())
                .max((c as f64 - a.cos()).abs());
        }
        assert!(worst < 2.5e-7, "{worst}");
        assert_eq!(sincos_turns(0.0), (0.0, 1.0));
        assert_eq!(sincos_turns(0.25), (1.0, 0.0));
        assert_eq!(sincos_turns(0.5), (0.0, -1.0));
    }

    #[test]
    fn sample_cdf_skips_empty_intervals() {
        let c = [0.0, 0.0, 0.5, 0.5, 1.0];
        assert_eq!(sample_cdf(&c, 0.0).0, 1);
        assert_eq!(sample_cdf(&c, 0.25), (1, 0.5));
        assert_eq!(sample_cdf(&c, 0.5).0, 3);
        assert_eq!(sample_cdf(&c, 0.999).0, 3);
    }
}
