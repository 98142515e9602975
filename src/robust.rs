//! Robust geometry: overflow-safe vectors, hit points with rounding-error bounds, ray origins
//! offset off the surface they leave, and the limits of single precision for spheres. GLSL twin: `shaders/robust.glsl`, the same
//! functions under the same names with the same arithmetic (intermediate values `precise`, so
//! no fused multiply-adds).
//!
//! # Overflow-safe vectors
//! A cross product or a squared length of vectors beyond about 1.8e19 overflows f32, and one
//! below about 1e-19 underflows, even though the direction they describe is representable.
//! Scaling a vector by a power of two is exact (away from the subnormal range), so scaling
//! first by `2^-e`, with `e` the binary exponent of its largest component, gives the same
//! direction bit for bit where nothing overflowed and a finite one where something would have
//! (GLSL: `frexp`/`ldexp`, also exact).
//!
//! # Every ray that leaves a surface
//! This section is the one statement of how the renderers keep a ray from finding the surface
//! it leaves (or the light it aims at) where there is none; the CPU reference
//! (`src/cpu/scatter.rs`, `src/cpu/surface.rs`) and the GPU twins (`shaders/wavefront/scatter.glsl`,
//! `shaders/wavefront/surface.glsl`, `shaders/bvh.glsl`) cite it and do the same, operation for
//! operation. It follows Pharr, Jakob & Humphreys 2016 ("Physically Based Rendering", 3rd ed.,
//! sec. 3.9; pbrt-v4's `OffsetRayOrigin` and `SpawnRayTo`), which bounds the rounding error of
//! both halves of the problem, the point a ray leaves from and the hit test it meets:
//!
//! 1. **The origin.** A hit point is computed with an absolute bound on its distance from the
//!    true surface, per coordinate ([`triangle_point`], from the barycentrics, never from
//!    `o + t·d`; [`sphere_point`], in f64). A triangle's barycentrics are first moved a few ulps
//!    inside its edges ([`pull_inside`]), so that a point near an edge is not on the plane of
//!    the neighbouring face. The new ray leaves from the point moved along the geometric normal,
//!    to the side it goes to, by that bound and one float more ([`offset_ray_origin`]; a
//!    coordinate that this leaves within 2^-100 of 0 goes to ±2^-100, [`ORIGIN_MIN`], never
//!    to a subnormal): in exact arithmetic the origin is then strictly on that side of the
//!    surface.
//! 2. **The hit test.** That alone is not enough: the test that meets the new ray has its own
//!    rounding. A triangle test's `t` carries an error that grows with the triangle's extent
//!    relative to the origin, not with the origin's coordinates, so where the origin's bound is
//!    small (a floor through y = 0 tilted by 2.4e-16, or by 1e-3) a ray leaving the floor got a
//!    false hit on it at t ≈ 1e-7: 16 % of a lone floor's sky light was lost. So a triangle
//!    hit counts only where `t` exceeds the bound on its own error (the module
//!    `crate::bvh::intersect`'s `triangle_t_error`, after the book's sec. 3.9.6); then an
//!    origin strictly in front of a triangle can never hit it. A sphere's test computes the
//!    origin's side, `|o − c|² − r²`, from exact products summed without loss
//!    ([`crate::bvh::sphere_c`]), and drops the root at the origin when that value is within
//!    its error bound.
//!
//! The rays, one by one:
//! * **Continuation rays** (BSDF samples) leave from the origin of point 1, on the side of the
//!   geometric normal that the incoming ray came from; a direction below that side ends the
//!   path (the renderers never sample through a surface).
//! * **Two-sided surfaces** seen from behind are shaded as a front with both normals turned,
//!   so the origin moves to the back: the same rule.
//! * **Shadow rays to points on area lights** (triangles, spheres): the same origin; the
//!   sampled point is itself offset off the light, towards the side it emits to, by its own
//!   bound, and the segment ends [`SHADOW_EPSILON`] of its length before that point, so the
//!   light's own surface, whose hit carries the rounding of the whole segment, is not taken
//!   for an occluder.
//! * **Shadow rays to point lights** end [`SHADOW_EPSILON`] of their length before the light.
//! * **Shadow rays to directions** (directional lights) have no end (`f32::MAX`); the sky is
//!   found by continuation rays that hit nothing.
//! * **Large, small and far meshes, transformed meshes**: every bound above is relative to the
//!   coordinates or the extents involved, so it scales with the scene; transforms are applied
//!   to the vertices when the scene loads, so the tests see world-space triangles only.
//! * **Spheres, huge and small**: the f64 test and point resolve a ground sphere of radius
//!   1e20 under a camera one unit above it. What single precision cannot render (a sphere
//!   smaller than a few hundred float steps at its centre, one too large to place the camera
//!   beside, one whose bounds overflow) the loader refuses ([`sphere_precision_problem`]).
//!
//! Fixed offsets (Wächter & Binder 2019, "A Fast and Robust Method for Avoiding
//! Self-Intersection", Ray Tracing Gems ch. 6: 256 integer ulps, or 1/65536 near zero) are
//! cheaper but not scale-free: they moved origins by a visible part of a scene scaled by 1e-6
//! and can fall short for a large triangle seen from near its plane. `stress --group
//! self_shadow` counts false occlusions and leaks of every kind of ray above.

use glam::{DVec3, Vec3};

/// `a · b` as three products and two sums in this order (no fused multiply-add; GLSL writes it
/// out, `precise`).
#[inline]
pub fn dot3(a: Vec3, b: Vec3) -> f32 {
    a.x * b.x + a.y * b.y + a.z * b.z
}

/// `v · 2^-e` where `2^(e-1) <= max|v_i| < 2^e`, so the largest component is in [0.5, 1).
/// Zero, infinite and NaN vectors are returned as they are.
pub fn scale_to_unit_exponent(v: Vec3) -> Vec3 {
    let m = v.abs().max_element();
    if !(m > 0.0 && m.is_finite()) {
        return v;
    }
    let (_, e) = libm::frexpf(m);
    Vec3::new(
        libm::ldexpf(v.x, -e),
        libm::ldexpf(v.y, -e),
        libm::ldexpf(v.z, -e),
    )
}

/// `normalize(v)` that neither overflows nor underflows; zero for a zero or non-finite `v`.
pub fn normalize_scaled(v: Vec3) -> Vec3 {
    scale_to_unit_exponent(v).normalize_or_zero()
}

/// The unit normal `normalize((v1 - v0) × (v2 - v0))` of a triangle, with each edge scaled to
/// unit exponent first (exact), so that huge or tiny triangles get a normal; the edges
/// themselves must be finite (zero otherwise, as for a zero-area triangle).
pub fn triangle_normal(v: &[Vec3; 3]) -> Vec3 {
    let e1 = scale_to_unit_exponent(v[1] - v[0]);
    let e2 = scale_to_unit_exponent(v[2] - v[0]);
    e1.cross(e2).normalize_or_zero()
}

/// Twice the triangle's area in f64 (finite for every finite f32 triangle).
pub fn triangle_double_area_f64(v: &[Vec3; 3]) -> f64 {
    let d = |a: Vec3| DVec3::new(a.x as f64, a.y as f64, a.z as f64);
    (d(v[1]) - d(v[0])).cross(d(v[2]) - d(v[0])).length()
}

/// `gamma(n) = n·u / (1 - n·u)` with `u = 2^-24` the unit roundoff of f32: a bound on the
/// relative error of `n` successive roundings (Higham 2002, "Accuracy and Stability of Numerical
/// Algorithms", lemma 3.1; used this way by Pharr, Jakob & Humphreys 2016, "Physically Based
/// Rendering" 3rd ed., sec. 3.9).
pub const fn gamma(n: u32) -> f32 {
    let nu = n as f32 * (f32::EPSILON * 0.5);
    nu / (1.0 - nu)
}

/// The barycentrics (b1, b2) of a hit on the triangle `v`, moved a little towards the centroid
/// (1/3, 1/3), for the point a new ray leaves from.
///
/// Within the plane, the error of a hit point (the intersection's barycentrics and the rounding
/// of the coordinates, a few ulps) can put a point near an edge on, or just beyond, the plane of
/// the neighbouring face. A ray leaving from there, offset only along this face's normal, starts
/// on that plane and passes through the face unseen (a closed box seen from inside showed the
/// environment through its corners). Moving the barycentrics a fraction t towards (1/3, 1/3)
/// moves the point by t·(c − p), c − p = (1/3 − b1)·e1 + (1/3 − b2)·e2: by [`SHIFT_ULPS`] ulps
/// of the coordinates' magnitude (estimated as |v0| + 3·|c − p|, max-norm; at most half way),
/// so the point is a few roundings inside every edge, and no further: the move is a bias (30
/// ulps darkened a Cornell box moved 1e6 away by 0.26 %). Sampled light points need no move
/// (they are interior with probability 1, and a shadow ray ends before its target).
pub fn pull_inside(v: &[Vec3; 3], b1: f32, b2: f32) -> (f32, f32) {
    let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
    let third = 1.0 / 3.0;
    let (d1, d2) = (third - b1, third - b2);
    let dist = (e1 * d1 + e2 * d2).abs().max_element();
    if !(dist > 0.0 && dist.is_finite()) {
        return (b1, b2);
    }
    let delta = ulp(v[0].abs().max_element() + 3.0 * dist) * SHIFT_ULPS;
    let t = (delta / dist).min(0.5);
    (b1 + t * d1, b2 + t * d2)
}

/// The point with barycentrics (b1, b2) of the triangle `v`, computed as
/// `v0 + (b1·(v1 − v0) + b2·(v2 − v0))`, and the absolute error bound of its distance from the
/// triangle's plane, per coordinate: `gamma(4)·(|b1·e1| + |b2·e2|) + gamma(2)·|p|`.
///
/// Any b1, b2 give a point of the plane in exact arithmetic, so the barycentrics' own error
/// moves the point within the plane only (see [`pull_inside`] for what that needs); what moves
/// it off the plane is the rounding of the edges, the products and the two sums (Higham 2002,
/// lemma 3.1; Pharr, Jakob & Humphreys 2016, sec. 3.9.4, which bounds the form Σ bᵢ·vᵢ by
/// gamma(7)·Σ|bᵢ·vᵢ|). For a scene far from the origin this is about 2 ulps of the
/// coordinates, not 7.
pub fn triangle_point(v: &[Vec3; 3], b1: f32, b2: f32) -> (Vec3, Vec3) {
    let e1 = (v[1] - v[0]) * b1;
    let e2 = (v[2] - v[0]) * b2;
    let p = v[0] + (e1 + e2);
    let err = (e1.abs() + e2.abs()) * gamma(4) + p.abs() * gamma(2);
    (p, err)
}

/// How far [`pull_inside`] moves a hit point towards the centroid, in ulps of the largest vertex
/// coordinate.
pub const SHIFT_ULPS: f32 = 4.0;

/// The spacing of the floats at `x` (non-negative): 2^(exponent − 23), or the smallest
/// subnormal below 2^-126.
pub fn ulp(x: f32) -> f32 {
    let e = (x.to_bits() >> 23) & 0xff;
    if e > 23 {
        f32::from_bits((e - 23) << 23)
    } else {
        f32::from_bits(1)
    }
}

/// The point of the sphere (`center`, `radius`) in the direction `toward` from its centre (any
/// non-zero length), its absolute error bound per coordinate, and the unit outward normal
/// there.
///
/// Computed in f64 and rounded once: `center + toward · (radius / |toward|)`, so the point is
/// on the sphere to within half an ulp of its own coordinates (plus the f64 roundings, about
/// 2^-50 of the sphere's extent): for a hit, `toward = o + t·d − center` in f64. An f32
/// reprojection (`center + u·radius`) would be off the surface by a few ulps of the radius,
/// which for a sphere of radius 1e6 under a camera one unit above is far larger than the
/// camera's height. The bound is `2^-24·|p| + 2^-50·(|center| + radius)`.
pub fn sphere_point(center: Vec3, radius: f32, toward: DVec3) -> (Vec3, Vec3, Vec3) {
    let c = center.as_dvec3();
    let len = (toward.x * toward.x + toward.y * toward.y + toward.z * toward.z).sqrt();
    let u = toward / len;
    let p = (c + u * radius as f64).as_vec3();
    let err = p.abs() * SPHERE_ROUND + (center.abs() + Vec3::splat(radius.abs())) * SPHERE_F64;
    (p, err, u.as_vec3())
}

/// Why single precision cannot render the sphere (`center`, `radius`) seen from `camera`, or
/// `None` when it can. The scene loader refuses such a sphere with this message.
///
/// * Its bounds must be finite floats (the BVH's boxes are f32).
/// * Its radius must span at least [`SPHERE_MIN_STEPS`] floats at its centre: below that, the
///   f32 points on it are too coarse to shade (a sphere of radius 1e-4 at 1e7, where floats
///   are 1 apart, has no points of its own).
/// * The sphere test must tell on which side of the surface the camera is, by a factor of
///   [`SPHERE_MIN_RESOLUTION`]: the test resolves distances from the surface down to about
///   2^-97·(|center| + radius)²/radius ([`crate::bvh::sphere_c`]), so a ground sphere of
///   radius 1e20 under a camera one unit above it renders right, and one of radius 1e30 does
///   not.
pub fn sphere_precision_problem(center: Vec3, radius: f32, camera: Vec3) -> Option<String> {
    let extent = center.abs().max_element() as f64 + radius as f64;
    if extent > f32::MAX as f64 {
        return Some(format!(
            "the sphere reaches {extent:e}, beyond the largest float ({:e})",
            f32::MAX
        ));
    }
    let step = ulp(center.abs().max_element());
    if radius < step * SPHERE_MIN_STEPS {
        return Some(format!(
            "radius {radius:e} is smaller than {SPHERE_MIN_STEPS} float steps at its centre \
             (floats there are {step:e} apart), so single precision cannot place points on it"
        ));
    }
    let (c, c_err) = crate::bvh::sphere_c(camera, center, radius);
    if c.abs() <= c_err * SPHERE_MIN_RESOLUTION {
        let r2 = 2.0 * radius as f64;
        return Some(format!(
            "the camera is {:.3e} from its surface, and the sphere test resolves distances from \
             a sphere of radius {radius:e} there only to about {:.1e}: too large a sphere for \
             single precision to place the camera beside it (a large flat ground is better \
             made as a quad)",
            c.abs() / r2,
            c_err / r2
        ));
    }
    None
}

/// The fewest float steps at its centre a sphere's radius may span
/// ([`sphere_precision_problem`]).
pub const SPHERE_MIN_STEPS: f32 = 256.0;
/// How many times the sphere test's resolution the camera's distance from a sphere must be
/// ([`sphere_precision_problem`]).
pub const SPHERE_MIN_RESOLUTION: f64 = (1u32 << 20) as f64;

/// 2^-24, the rounding of an f64 value to f32 (relative; [`sphere_point`]).
const SPHERE_ROUND: f32 = 1.0 / (1u32 << 24) as f32;
/// 2^-50, a bound on the f64 roundings of [`sphere_point`] relative to the sphere's extent.
const SPHERE_F64: f32 = 1.0 / (1u64 << 50) as f32;

/// Shadow rays end this fraction of their length before the point on the light (Pharr, Jakob &
/// Humphreys 2016, sec. 3.9.5, `ShadowEpsilon`): the light point is offset off its surface by
/// its own error bound, but the ray's hit distance with that surface carries the rounding of
/// the whole ray (origin, direction and intersection), which can be larger where the light's
/// plane coordinate is small and the others are not (a Cornell box moved so that its ceiling
/// is near y = 0 lost 15 % of its direct light to shadow rays blocked by the light itself).
pub const SHADOW_EPSILON: f32 = 1e-4;

/// The least magnitude of a coordinate [`offset_ray_origin`] moves: 2^-100. Products of it
/// with the factors the intersection tests and error bounds apply (down to γ₃ ≈ 2^-21.4, or a
/// shear factor above 2^-26) stay normal floats, and it is far below any distance a scene can
/// hold: 2^-100 ≈ 7.9e-31 is 1e-11 of the smallest distance whose square is a normal float
/// (about 1.1e-19), which the light densities need.
pub const ORIGIN_MIN: f32 = 1.0 / (1u128 << 100) as f32;

/// The next f32 above `x` (towards +inf); +0 for -0. Infinities and NaN are returned as they are.
#[inline]
pub fn next_float_up(x: f32) -> f32 {
    if !x.is_finite() {
        return x;
    }
    let x = if x == 0.0 { 0.0 } else { x };
    let bits = x.to_bits();
    f32::from_bits(if x >= 0.0 { bits + 1 } else { bits - 1 })
}

/// The next f32 below `x` (towards -inf); -0 for +0. Infinities and NaN are returned as they are.
#[inline]
pub fn next_float_down(x: f32) -> f32 {
    if !x.is_finite() {
        return x;
    }
    let x = if x == 0.0 { -0.0 } else { x };
    let bits = x.to_bits();
    f32::from_bits(if x <= 0.0 { bits + 1 } else { bits - 1 })
}

/// Move the surface point `p`, whose coordinates are within `err` of the true surface point,
/// off the surface to the side of the unit normal `n` the new ray leaves from, far enough that
/// the new ray cannot hit the surface it starts on (Pharr et al. 2016, sec. 3.9.5, and the
/// pbrt-v4 sources' `OffsetRayOrigin`): along `n` by `d = |n|·err`, the distance from the plane
/// of the box `p ± err`, then each coordinate one float further along `n`, so that
/// the rounding of `p + d·n` cannot bring the point back inside that box. The offset scales
/// with the error of `p` itself, so it is the same fraction of the scene at every scale and
/// translation (fixed offsets are not: Wächter & Binder 2019's 256 ulps and `n/65536` near zero
/// moved origins by a visible part of a scene scaled by 1e-6 or moved 1e6 away).
///
/// A coordinate the step leaves within [`ORIGIN_MIN`] of 0 (a point on a coordinate plane,
/// such as a floor at y = 0, whose bound there is 0) is set to ±`ORIGIN_MIN` on the side of
/// `n` instead: one float from 0 would be a subnormal, and every ray from such a floor would
/// carry subnormals through its box and triangle tests, which Intel cores compute in
/// microcode, about a hundred times slower (docs/bench-log.md: the CPU reference 1.2x and
/// lavapipe 2x slower on the Cornell box). Further along `n` is on the same side.
///
/// Written without branches ([`step_off`]): with the branches of `next_float_up`/`down` on the
/// signs of the normal's components, which change from one hit to the next, the function was
/// 5 % of a Cornell box render on the CPU reference; without them renders are 1.6–2.4 %
/// faster with the same bits (docs/bench-log.md, "Data-dependent branches").
pub fn offset_ray_origin(p: Vec3, err: Vec3, n: Vec3) -> Vec3 {
    let d = dot3(n.abs(), err);
    let q = p + n * d;
    // By the sign of n, not of the offset: a point with a zero error bound (a vertex at the
    // origin) still moves.
    #[cfg(target_arch = "x86_64")]
    return step_off_lanes(q, n);
    #[cfg(not(target_arch = "x86_64"))]
    return Vec3::new(step_off(q.x, n.x), step_off(q.y, n.y), step_off(q.z, n.z));
}

/// [`step_off`] of the three coordinates at once, in the lanes of 128-bit SSE2 registers (every
/// x86-64 CPU has them): the same integer selects on the bits, so the same result
/// (`tests::step_off_lanes_is_step_off`), in about a third of the instructions.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn step_off_lanes(q: Vec3, n: Vec3) -> Vec3 {
    use std::arch::x86_64::*;
    const MAGNITUDE: i32 = 0x7fff_ffff;
    // SAFETY: SSE2 is part of x86-64; the loads and the store are of four floats, from and to
    // arrays of four.
    unsafe {
        let qv = _mm_loadu_ps([q.x, q.y, q.z, 0.0].as_ptr());
        let nv = _mm_loadu_ps([n.x, n.y, n.z, 0.0].as_ptr());
        let bits = _mm_castps_si128(qv);
        let zero = _mm_setzero_ps();
        let down = _mm_castps_si128(_mm_cmplt_ps(nv, zero));
        let moves = _mm_or_si128(_mm_castps_si128(_mm_cmpgt_ps(nv, zero)), down);
        let magnitude = _mm_and_si128(bits, _mm_set1_epi32(MAGNITUDE));
        let finite = _mm_cmplt_epi32(magnitude, _mm_set1_epi32(0x7f80_0000));
        let negative = _mm_srai_epi32::<31>(bits);
        let away = _mm_or_si128(
            _mm_cmpeq_epi32(negative, down),
            _mm_cmpeq_epi32(magnitude, _mm_setzero_si128()),
        );
        // +1 away from 0, −1 towards it.
        let delta = _mm_add_epi32(_mm_and_si128(away, _mm_set1_epi32(2)), _mm_set1_epi32(-1));
        let step = _mm_add_epi32(bits, delta);
        let floor = _mm_set1_epi32(ORIGIN_MIN.to_bits() as i32);
        let least = _mm_or_si128(floor, _mm_and_si128(down, _mm_set1_epi32(i32::MIN)));
        let small = _mm_cmplt_epi32(_mm_and_si128(step, _mm_set1_epi32(MAGNITUDE)), floor);
        let stepped = _mm_or_si128(_mm_and_si128(small, least), _mm_andnot_si128(small, step));
        let take = _mm_and_si128(moves, finite);
        let out = _mm_or_si128(_mm_and_si128(take, stepped), _mm_andnot_si128(take, bits));
        let mut r = [0.0f32; 4];
        _mm_storeu_ps(r.as_mut_ptr(), _mm_castsi128_ps(out));
        Vec3::new(r[0], r[1], r[2])
    }
}

/// `q` one float further in the direction of the sign of `n` ([`next_float_up`] for n > 0,
/// [`next_float_down`] for n < 0), a result below [`ORIGIN_MIN`] in magnitude replaced by
/// ±`ORIGIN_MIN` on the side of `n` (compared on the bits, so that the subnormal is never an
/// operand of arithmetic); `q` itself for n = 0 or NaN and for an infinite or NaN `q`. Every
/// case is a select on integer bits, not a branch. (The CPU reference's lanes use it for 16
/// points at a time, `cpu/lanes.rs`.)
#[inline(always)]
pub(crate) fn step_off(q: f32, n: f32) -> f32 {
    const MAGNITUDE: u32 = 0x7fff_ffff;
    let bits = q.to_bits();
    let down = n < 0.0;
    // `|`, not `||`: both comparisons, no branch. NaN compares false both ways.
    let moves = (n > 0.0) | down;
    let finite = bits & MAGNITUDE < 0x7f80_0000;
    // Away from 0 when q's sign is the direction's, and from ±0 always (next_float_up(-0) is
    // the least positive float, which the floor below replaces anyway); else towards 0.
    let away = ((bits >> 31 != 0) == down) | (bits & MAGNITUDE == 0);
    let step = if away {
        bits.wrapping_add(1)
    } else {
        bits.wrapping_sub(1)
    };
    let least = ORIGIN_MIN.to_bits() | (u32::from(down) << 31);
    let stepped = if step & MAGNITUDE < ORIGIN_MIN.to_bits() {
        least
    } else {
        step
    };
    f32::from_bits(if moves & finite { stepped } else { bits })
}

/// The value of `#define NAME value` in the GLSL source `glsl` (the file `file`, for the
/// message): the twin-constant tests of this module and of `bvh` read their shaders with it.
#[cfg(test)]
pub(crate) fn glsl_define<'a>(glsl: &'a str, file: &str, name: &str) -> &'a str {
    let key = format!("#define {name} ");
    let line = glsl
        .lines()
        .find(|l| l.starts_with(&key))
        .unwrap_or_else(|| panic!("{name} not in {file}"));
    line[key.len()..].trim()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SIMD step is the scalar one, bit for bit, on random bit patterns of q and n (NaN,
    /// infinities, zeros, subnormals among them) and on values around the floor and 0.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn step_off_lanes_is_step_off() {
        // The renderer's own counter-based numbers, one key per draw.
        let mut draws = 0u32;
        let mut next = move || {
            draws += 1;
            crate::rng::random_u32(23, draws, 0, 0, 0)
        };
        let m = ORIGIN_MIN.to_bits();
        let special = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MAX,
            f32::MIN_POSITIVE,
            f32::from_bits(1),
            -f32::from_bits(1),
            ORIGIN_MIN,
            -ORIGIN_MIN,
            f32::from_bits(m - 1),
            f32::from_bits(m + 1),
            -f32::from_bits(m + 1),
        ];
        for i in 0..300_000u32 {
            let pick = |r: u32| match r % 4 {
                0 => special[(r >> 2) as usize % special.len()],
                1 => f32::from_bits(m.wrapping_add(r >> 28).wrapping_sub(8) | (r & 1) << 31),
                _ => f32::from_bits(r),
            };
            let q = Vec3::new(pick(next()), pick(next()), pick(next()));
            let n = Vec3::new(pick(next()), pick(next()), pick(next()));
            let lanes = step_off_lanes(q, n).to_array().map(f32::to_bits);
            let scalar = [step_off(q.x, n.x), step_off(q.y, n.y), step_off(q.z, n.z)];
            assert_eq!(
                lanes,
                scalar.map(f32::to_bits),
                "round {i}: q {q:?} n {n:?}"
            );
        }
    }

    #[test]
    fn normal_of_huge_and_tiny_triangles() {
        for s in [1e-30f32, 1e-20, 1.0, 1e20, 1e30, 1e38] {
            let v = [Vec3::ZERO, Vec3::new(s, 0.0, 0.0), Vec3::new(0.0, s, 0.0)];
            let n = triangle_normal(&v);
            assert!((n - Vec3::Z).length() < 1e-6, "scale {s}: {n}");
            let a = triangle_double_area_f64(&v) / (s as f64 * s as f64);
            assert!((a - 1.0).abs() < 1e-12, "scale {s}: {a}");
        }
        let n = normalize_scaled(Vec3::new(2e19, 0.0, 2e19));
        assert!(
            (n - Vec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-6,
            "{n}"
        );
        assert_eq!(normalize_scaled(Vec3::ZERO), Vec3::ZERO);
    }

    /// Where nothing overflows the scaled result is the unscaled one, bit for bit.
    #[test]
    fn scaling_is_exact() {
        let v = [
            Vec3::new(0.3, -1.7, 2.9),
            Vec3::new(5.1, 0.2, -0.7),
            Vec3::new(-3.3, 4.4, 1.1),
        ];
        let plain = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        assert_eq!(triangle_normal(&v), plain);
    }

    #[test]
    fn offset_moves_to_the_normal_side_at_all_scales() {
        // Down to 1e-18: below it a scene's squared distances are no longer normal floats
        // (so no light density works), and origins near 0 would move by ORIGIN_MIN, more
        // than this test's few error bounds.
        for &s in &[
            1e-18f32, 1e-6, 1e-3, 0.02, 1.0, 100.0, 1.0e4, -1.0e4, 1.0e6, 1.0e30,
        ] {
            let v = [
                Vec3::new(s, -0.7 * s, 0.3 * s),
                Vec3::new(1.3 * s, -0.2 * s, 0.1 * s),
                Vec3::new(0.9 * s, 0.4 * s, -0.5 * s),
            ];
            let n = triangle_normal(&v);
            let (p, err) = triangle_point(&v, 0.3, 0.45);
            let q = offset_ray_origin(p, err, n);
            // In f64: the offset point is off the plane by at least the error bound and by
            // at most a few times it (a tiny fraction of the triangle).
            let to64 = |a: Vec3| [a.x as f64, a.y as f64, a.z as f64];
            let (v0, v1, v2, q64) = (to64(v[0]), to64(v[1]), to64(v[2]), to64(q));
            let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
            let (e1, e2) = (sub(v1, v0), sub(v2, v0));
            let nn = [
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            ];
            let len = (nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]).sqrt();
            let w = sub(q64, v0);
            let dist = (w[0] * nn[0] + w[1] * nn[1] + w[2] * nn[2]) / len;
            assert!(
                dist > 0.0,
                "scale {s}: {p} -> {q} is not on the normal side"
            );
            let bound = (n.abs().dot(err)) as f64;
            assert!(
                dist >= 0.9 * bound && dist < 4.0 * bound + 2.0 * (s.abs() as f64) * 1e-7,
                "scale {s}: moved {dist}, error bound {bound}"
            );
            let q = offset_ray_origin(p, err, -n);
            assert!((q - p).dot(n) < 0.0, "scale {s}: not moved to the back");
        }
        // Coordinates at zero still move, to ±ORIGIN_MIN and never into the subnormals;
        // one near zero moves there too, along n, whatever its sign.
        let q = offset_ray_origin(Vec3::ZERO, Vec3::ZERO, Vec3::Z);
        assert!(q.z == ORIGIN_MIN && q.x == 0.0 && q.y == 0.0);
        let q = offset_ray_origin(Vec3::splat(-0.0), Vec3::ZERO, -Vec3::Z);
        assert_eq!(q.z, -ORIGIN_MIN);
        for z in [-1e-35f32, -1e-40, f32::from_bits(1), 1e-32] {
            let up = offset_ray_origin(Vec3::new(1.0, 2.0, z), Vec3::ZERO, Vec3::Z);
            assert_eq!(up, Vec3::new(1.0, 2.0, ORIGIN_MIN), "{z}");
            let down = offset_ray_origin(Vec3::new(1.0, 2.0, z), Vec3::ZERO, -Vec3::Z);
            assert_eq!(down, Vec3::new(1.0, 2.0, -ORIGIN_MIN), "{z}");
        }
        // Beyond ORIGIN_MIN the step is one float, as before.
        let z = ORIGIN_MIN * 4.0;
        let q = offset_ray_origin(Vec3::new(0.0, 0.0, z), Vec3::ZERO, Vec3::Z);
        assert_eq!(q.z, next_float_up(z));
    }

    /// The branch-free step of `offset_ray_origin` is the branching one it replaced, bit for
    /// bit: that one (below, written with `next_float_up`/`down`) on every sign and class of
    /// coordinate and normal component: zeros of both signs, subnormals, values around
    /// ORIGIN_MIN, the largest finite floats, infinities and NaN, and a million others.
    #[test]
    fn step_off_is_the_branching_step() {
        fn branching(q: f32, n: f32) -> f32 {
            let below = |x: f32| x.to_bits() & 0x7fff_ffff < ORIGIN_MIN.to_bits();
            let (step, least) = if n > 0.0 {
                (next_float_up(q), ORIGIN_MIN)
            } else if n < 0.0 {
                (next_float_down(q), -ORIGIN_MIN)
            } else {
                return q;
            };
            if below(step) {
                least
            } else {
                step
            }
        }
        let m = ORIGIN_MIN.to_bits();
        let mut qs: Vec<u32> = vec![0, 1, 2, m - 1, m, m + 1, 0x7f7f_ffff, 0x7f80_0000];
        qs.extend([
            0x7fc0_0000,
            0x7f80_0001,
            0x3f80_0000,
            0x0080_0000,
            0x007f_ffff,
        ]);
        let signed: Vec<u32> = qs.iter().flat_map(|&b| [b, b | 0x8000_0000]).collect();
        let ns = [1.0, -1.0, 0.0, -0.0, f32::NAN, 1e-30, -1e-42, f32::INFINITY];
        let same = |q: f32, n: f32| {
            let (a, b) = (step_off(q, n), branching(q, n));
            assert_eq!(a.to_bits(), b.to_bits(), "q {:#x}, n {n}", q.to_bits());
        };
        for &q in &signed {
            for &n in &ns {
                same(f32::from_bits(q), n);
            }
        }
        let mut rng = crate::stress::Rng::new(43);
        for _ in 0..1_000_000 {
            let x = rng.next_u64();
            let q = f32::from_bits(x as u32);
            same(q, ns[(x >> 40) as usize % ns.len()]);
            // Near the floor, where the replacement happens.
            let near = f32::from_bits((m as i64 + ((x >> 32) as i64 & 0xffff) - 0x8000) as u32);
            same(
                if x >> 63 != 0 { -near } else { near },
                ns[(x >> 48) as usize % 2],
            );
        }
    }

    #[test]
    fn next_float_steps_one_ulp() {
        assert_eq!(next_float_up(1.0), 1.0 + f32::EPSILON);
        assert_eq!(next_float_down(1.0), 1.0 - f32::EPSILON / 2.0);
        assert_eq!(next_float_up(-1.0), -1.0 + f32::EPSILON / 2.0);
        assert_eq!(next_float_up(-0.0), f32::from_bits(1));
        assert_eq!(next_float_down(0.0), -f32::from_bits(1));
        assert_eq!(next_float_up(f32::MAX), f32::INFINITY);
        assert_eq!(next_float_up(f32::INFINITY), f32::INFINITY);
        assert!(next_float_down(f32::NAN).is_nan());
    }

    /// The GLSL twin's constants (`shaders/robust.glsl`) are the Rust ones, bit for bit.
    #[test]
    fn glsl_constants_match() {
        let glsl = include_str!("../shaders/robust.glsl");
        let define = |name: &str| glsl_define(glsl, "robust.glsl", name);
        for n in [2, 4, 5] {
            let want = format!("uintBitsToFloat({:#010x}u)", gamma(n).to_bits());
            assert_eq!(define(&format!("GAMMA{n}")), want);
        }
        assert_eq!(
            define("SHADOW_EPSILON"),
            format!("uintBitsToFloat({:#010x}u)", SHADOW_EPSILON.to_bits())
        );
        assert_eq!(
            define("ORIGIN_MIN"),
            format!("uintBitsToFloat({:#010x}u)", ORIGIN_MIN.to_bits())
        );
        assert_eq!(define("SHIFT_ULPS").parse::<f32>().unwrap(), SHIFT_ULPS);
        for (name, v) in [("SPHERE_ROUND", SPHERE_ROUND), ("SPHERE_F64", SPHERE_F64)] {
            let want = format!("uintBitsToFloat({:#010x}u)", v.to_bits());
            assert_eq!(define(name), want);
        }
    }
}
