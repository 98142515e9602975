//! Ray set-up and the ray/box, ray/triangle and ray/sphere tests the traversal runs (twins in
//! `shaders/bvh.glsl`: `bvh_make_ray`, `bvh_box_hit`, `bvh_triangle`, `bvh_sphere`); the
//! methods and their numerics are those of the [`crate::bvh`] module documentation.

use super::wide::{Lanes, WIDTH};
use crate::robust::gamma;
use glam::{DVec3, Vec2, Vec3, Vec3A, Vec4};

/// Ize 2013: the far slab distance is multiplied by this (1 + 2^-20, exact in f32), more than
/// the 1 + 2·γ₃ the three roundings of `(b - o) · inv` need, to absorb the rounding of the
/// primitive tests' `t` as well.
pub const BOX_WIDEN: f32 = 1.0 + 1.0 / (1u32 << 20) as f32;
/// Direction components smaller than this (2^-80) are treated as zero in the box test.
pub(super) const ZERO_DIR: f32 = 1.0 / (1u128 << 80) as f32;
/// Inverse used for zero direction components (2^120; finite, so `0 · ZERO_INV = 0`).
pub(super) const ZERO_INV: f32 = (1u128 << 120) as f32;
/// Padding of the slab interval of a zero direction component (2^80): an origin inside the
/// slab, or on its faces, gets an interval wider than any `t` a scene can produce; one outside
/// by more than `ZERO_PAD / ZERO_INV = 2^-40` gets an empty one.
pub(super) const ZERO_PAD: f32 = (1u128 << 80) as f32;

/// Per-ray constants of the box and triangle tests.
#[derive(Clone, Copy, Debug)]
pub(super) struct Ray {
    /// The origin on the permuted axes, (o[kx], o[ky], o[kz]) (triangle test).
    op: Vec3,
    /// The origin as a SIMD vector (box test).
    o_a: Vec3A,
    /// Safe inverse direction (box test).
    inv: Vec3A,
    /// ZERO_PAD on zero components, else 0.
    pad: Vec3A,
    /// Woop et al.: axes of the shear, kz = largest |d| component.
    kx: Axis,
    ky: Axis,
    kz: Axis,
    /// Shear constants (Sx, Sy, Sz).
    s: Vec3,
    /// The direction on the permuted axes (the f64 test of ambiguous hits).
    dp: Vec3,
    /// The constants of `triangle_simd`.
    #[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
    simd: simd::SimdRay,
}

impl Ray {
    /// None for a zero, infinite or NaN direction: such a ray hits nothing.
    #[inline]
    pub(super) fn new(o: Vec3, d: Vec3) -> Option<Ray> {
        // Components read from arrays by `Axis` (in range by its type, so without a bounds
        // check): glam's `Vec3` indexing is a chain of comparisons for each read, about 75
        // instructions a ray in all (docs/bench-log.md, "The ray set-up's axes").
        let (oa, da, aa) = (o.to_array(), d.to_array(), d.abs().to_array());
        let kz = if aa[0] >= aa[1] && aa[0] >= aa[2] {
            Axis::X
        } else if aa[1] >= aa[2] {
            Axis::Y
        } else {
            Axis::Z
        };
        let dz = da[kz as usize];
        if !(aa[kz as usize] > 0.0 && aa[kz as usize] <= f32::MAX) {
            return None;
        }
        let mut kx = kz.next();
        let mut ky = kx.next();
        if dz < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let (dx, dy) = (da[kx as usize], da[ky as usize]);
        // The divisions as two SIMD divisions (each lane the same IEEE quotient as a scalar
        // division): the shear (d[kx] / d[kz], d[ky] / d[kz], 1 / d[kz]), and the safe inverse,
        // which is ZERO_INV with the slab padded by ZERO_PAD where |d| < ZERO_DIR (there the
        // quotient, possibly infinite, is not used).
        let s = Vec3::from(Vec3A::new(dx, dy, 1.0) / Vec3A::splat(dz));
        let d_a = Vec3A::from(d);
        let zero = d_a.abs().cmplt(Vec3A::splat(ZERO_DIR));
        Some(Ray {
            op: Vec3::new(oa[kx as usize], oa[ky as usize], oa[kz as usize]),
            o_a: Vec3A::from(o),
            inv: Vec3A::select(zero, Vec3A::splat(ZERO_INV), Vec3A::ONE / d_a),
            pad: Vec3A::select(zero, Vec3A::splat(ZERO_PAD), Vec3A::ZERO),
            kx,
            ky,
            kz,
            s,
            dp: Vec3::new(dx, dy, dz),
            #[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
            simd: simd::SimdRay::new(o, [kx, ky, kz]),
        })
    }

    /// The box test's per-ray constants, for [`BoxRay::box_hit`].
    #[inline]
    pub(super) fn box_ray(&self) -> BoxRay {
        BoxRay {
            o: self.o_a.to_array(),
            inv: self.inv.to_array(),
            pad: self.pad.to_array(),
        }
    }

    /// Woop–Benthin–Wald watertight test; (t, (b1, b2)) with t in (0, tmax]: a hit at
    /// exactly `tmax` is returned, for the tie rule (the [`crate::bvh`] module documentation).
    // Inlined as the profile-guided build inlines it (docs/bench-log.md, "Hot functions inlined
    // by hand").
    #[inline(always)]
    pub(super) fn triangle(&self, v: &[Vec3; 3], tmax: f32) -> Option<(f32, Vec2)> {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
        return self.triangle_simd(v, tmax);
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx")))]
        return self.triangle_scalar(v, tmax);
    }

    /// [`Ray::triangle`] one coordinate at a time: the steps of the GLSL twin, and the test on
    /// CPUs without AVX; `triangle_simd` computes the same numbers.
    #[cfg_attr(all(target_arch = "x86_64", target_feature = "avx"), allow(dead_code))]
    #[inline(always)]
    pub(super) fn triangle_scalar(&self, v: &[Vec3; 3], tmax: f32) -> Option<(f32, Vec2)> {
        // Each vertex relative to the origin on the ray's permuted axes (kx, ky, kz): the same
        // subtractions as (v - o)[k], reading the vertex's components straight from memory.
        let (kx, ky, kz) = (self.kx as usize, self.ky as usize, self.kz as usize);
        let rel = |p: &Vec3| {
            let p: &[f32; 3] = p.as_ref();
            Vec3::new(p[kx] - self.op.x, p[ky] - self.op.y, p[kz] - self.op.z)
        };
        let (a, b, c) = (rel(&v[0]), rel(&v[1]), rel(&v[2]));
        let ax = a.x - self.s.x * a.z;
        let ay = a.y - self.s.y * a.z;
        let bx = b.x - self.s.x * b.z;
        let by = b.y - self.s.y * b.z;
        let cx = c.x - self.s.x * c.z;
        let cy = c.y - self.s.y * c.z;
        let u = cx * by - cy * bx;
        let v_ = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v_ < 0.0 || w < 0.0) && (u > 0.0 || v_ > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v_ + w;
        if det == 0.0 {
            return None;
        }
        let az = self.s.z * a.z;
        let bz = self.s.z * b.z;
        let cz = self.s.z * c.z;
        let tt = u * az + v_ * bz + w * cz;
        let rcp = 1.0 / det;
        let t = tt * rcp;
        if t.is_nan() || t > tmax {
            return None;
        }
        // A hit counts only where t exceeds the bound on its own rounding error, so that it
        // lies in front of the origin in exact arithmetic too (Pharr, Jakob & Humphreys 2016,
        // "Physically Based Rendering" 3rd ed., sec. 3.9.6; the `crate::robust` module
        // documentation says why the ray offsets need it). Within the bound, on either side of
        // 0, single precision cannot tell: the test is redone in f64 ([`Ray::triangle_f64`]).
        let bound = triangle_t_error(
            [a, b, c],
            [ax, bx, cx],
            [ay, by, cy],
            [az, bz, cz],
            [u, v_, w],
            rcp,
        );
        if t > bound {
            Some((t, Vec2::new(v_ * rcp, w * rcp)))
        } else if t < -bound {
            None
        } else {
            self.triangle_f64(v, tmax)
        }
    }

    /// The watertight test in f64, for a hit whose f32 `t` is within its error bound of 0: a
    /// ray leaving a surface near an edge, whose real hit on the neighbouring face lies closer
    /// than the f32 test can resolve (a ray from a room's floor, a few ulps from a wall, escaped
    /// through the corner), or the face the ray leaves itself. The same steps on f64 values
    /// (the f32 inputs are exact in f64), with the same bound for f64's rounding; a `t` still
    /// within it is taken for the surface the ray leaves, and missed. Woop, Benthin & Wald 2013
    /// fall back to double precision where an edge function is 0; here it is `t` that needs it.
    /// The GLSL twin runs it after the traversal loop on the (up to four) triangles it found
    /// ambiguous, not where it meets them (`bvh_traverse`: on lavapipe a branch does not skip
    /// code); the tie rule makes the hit the same.
    #[cold]
    #[inline(never)]
    fn triangle_f64(&self, v: &[Vec3; 3], tmax: f32) -> Option<(f32, Vec2)> {
        let (kx, ky, kz) = (self.kx as usize, self.ky as usize, self.kz as usize);
        let o = self.op.as_dvec3();
        let d = self.dp.as_dvec3();
        let rel = |p: &Vec3| {
            let p: &[f32; 3] = p.as_ref();
            DVec3::new(p[kx] as f64 - o.x, p[ky] as f64 - o.y, p[kz] as f64 - o.z)
        };
        let (a, b, c) = (rel(&v[0]), rel(&v[1]), rel(&v[2]));
        let (sx, sy, sz) = (d.x / d.z, d.y / d.z, 1.0 / d.z);
        let ax = a.x - sx * a.z;
        let ay = a.y - sy * a.z;
        let bx = b.x - sx * b.z;
        let by = b.y - sy * b.z;
        let cx = c.x - sx * c.z;
        let cy = c.y - sy * c.z;
        let u = cx * by - cy * bx;
        let v_ = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v_ < 0.0 || w < 0.0) && (u > 0.0 || v_ > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v_ + w;
        if det == 0.0 {
            return None;
        }
        let (az, bz, cz) = (sz * a.z, sz * b.z, sz * c.z);
        let rcp = 1.0 / det;
        let t = (u * az + v_ * bz + w * cz) * rcp;
        if t.is_nan() || t > tmax as f64 {
            return None;
        }
        let max3 = |p: f64, q: f64, r: f64| p.abs().max(q.abs()).max(r.abs());
        let (max_x, max_y, max_z) = (max3(ax, bx, cx), max3(ay, by, cy), max3(az, bz, cz));
        let max_e = max3(u, v_, w);
        let rel_max = a.abs().max(b.abs()).max(c.abs());
        let delta_x = gamma64(5) * (rel_max.x + rel_max.z);
        let delta_y = gamma64(5) * (rel_max.y + rel_max.z);
        let delta_z = gamma64(3) * max_z;
        let delta_e = 2.0 * (gamma64(2) * max_x * max_y + delta_y * max_x + delta_x * max_y);
        let bound =
            3.0 * (gamma64(3) * max_e * max_z + delta_e * max_z + delta_z * max_e) * rcp.abs();
        if t <= bound {
            return None;
        }
        // A t below the smallest f32 is still a hit in front of the origin.
        let t32 = (t as f32).max(f32::from_bits(1));
        Some((t32, Vec2::new((v_ * rcp) as f32, (w * rcp) as f32)))
    }
}

/// The triangle test in 128-bit SIMD registers (x86-64 with AVX): the same operations on the
/// same values as [`Ray::triangle_scalar`], in lanes.
#[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
mod simd {
    use super::{t_error_of_maxima, Axis, Ray};
    use glam::{Vec2, Vec3};
    use std::arch::x86_64::*;

    /// The origin as (x, y, z, 0) and (0, x, y, z), and the permutations that put a vertex's
    /// (kx, ky, kz) coordinates in lanes 0–2, for a vertex loaded into lanes 0–2 (`perm`) and
    /// into lanes 1–3 (`perm_high`).
    #[derive(Clone, Copy, Debug)]
    pub(super) struct SimdRay {
        o: __m128,
        o_high: __m128,
        perm: __m128i,
        perm_high: __m128i,
    }

    impl SimdRay {
        #[inline(always)]
        pub(super) fn new(o: Vec3, [kx, ky, kz]: [Axis; 3]) -> SimdRay {
            let k = [kx as i32, ky as i32, kz as i32];
            // SAFETY: the build enables the instructions (the module's `cfg`).
            unsafe {
                SimdRay {
                    o: _mm_setr_ps(o.x, o.y, o.z, 0.0),
                    o_high: _mm_setr_ps(0.0, o.x, o.y, o.z),
                    perm: _mm_setr_epi32(k[0], k[1], k[2], 3),
                    perm_high: _mm_setr_epi32(k[0] + 1, k[1] + 1, k[2] + 1, 0),
                }
            }
        }
    }

    /// The lanes of `v`.
    #[inline(always)]
    fn lanes(v: __m128) -> [f32; 4] {
        let mut a = [0.0f32; 4];
        // SAFETY: `a` has room for four floats; the build enables the instruction.
        unsafe { _mm_storeu_ps(a.as_mut_ptr(), v) };
        a
    }

    impl Ray {
        /// [`Ray::triangle_scalar`] with the three vertices, their shear and the three edge
        /// functions in SIMD lanes: the vertices relative to the origin as three 4-lane
        /// subtractions and permutations onto (kx, ky, kz), transposed to x, y and z of all
        /// three, sheared and crossed a lane per vertex. Each lane's operations are the scalar
        /// test's, in its order (no fused multiply-add), so the result is the same bit for
        /// bit (`tests::simd_triangle_matches_scalar`).
        #[inline(always)]
        pub(in crate::bvh) fn triangle_simd(
            &self,
            v: &[Vec3; 3],
            tmax: f32,
        ) -> Option<(f32, Vec2)> {
            // SAFETY: the build enables the instructions (the module's `cfg`), and the loads
            // read floats 0–3, 3–6 and 5–8 of the triangle's nine.
            unsafe {
                let r = &self.simd;
                let f = v.as_ptr() as *const f32;
                let (v0, v1, v2) = (
                    _mm_loadu_ps(f),
                    _mm_loadu_ps(f.add(3)),
                    _mm_loadu_ps(f.add(5)),
                );
                let a = _mm_permutevar_ps(_mm_sub_ps(v0, r.o), r.perm);
                let b = _mm_permutevar_ps(_mm_sub_ps(v1, r.o), r.perm);
                let c = _mm_permutevar_ps(_mm_sub_ps(v2, r.o_high), r.perm_high);
                // x, y and z of the three vertices (lane 3 zero).
                let zero = _mm_setzero_ps();
                let (ab_lo, c_lo) = (_mm_unpacklo_ps(a, b), _mm_unpacklo_ps(c, zero));
                let (ab_hi, c_hi) = (_mm_unpackhi_ps(a, b), _mm_unpackhi_ps(c, zero));
                let x = _mm_movelh_ps(ab_lo, c_lo);
                let y = _mm_movehl_ps(c_lo, ab_lo);
                let z = _mm_movelh_ps(ab_hi, c_hi);
                let xs = _mm_sub_ps(x, _mm_mul_ps(_mm_set1_ps(self.s.x), z));
                let ys = _mm_sub_ps(y, _mm_mul_ps(_mm_set1_ps(self.s.y), z));
                // (u, v, w) = (cx·by − cy·bx, ax·cy − ay·cx, bx·ay − by·ax).
                const CAB: i32 = 0b11_01_00_10;
                const BCA: i32 = 0b11_00_10_01;
                let p = _mm_mul_ps(_mm_permute_ps::<CAB>(xs), _mm_permute_ps::<BCA>(ys));
                let q = _mm_mul_ps(_mm_permute_ps::<CAB>(ys), _mm_permute_ps::<BCA>(xs));
                let e = _mm_sub_ps(p, q);
                let negative = _mm_movemask_ps(_mm_cmplt_ps(e, zero)) & 7;
                let positive = _mm_movemask_ps(_mm_cmpgt_ps(e, zero)) & 7;
                if negative != 0 && positive != 0 {
                    return None;
                }
                let [u, v_, w, _] = lanes(e);
                let det = u + v_ + w;
                if det == 0.0 {
                    return None;
                }
                let zs = _mm_mul_ps(_mm_set1_ps(self.s.z), z);
                let [m0, m1, m2, _] = lanes(_mm_mul_ps(e, zs));
                let tt = m0 + m1 + m2;
                let rcp = 1.0 / det;
                let t = tt * rcp;
                if t.is_nan() || t > tmax {
                    return None;
                }
                // The bound's maxima: of |x|, |y|, |z| and |e| over the three lanes, by a
                // transpose, and of the unsheared coordinates by axis. No value here is NaN (a
                // NaN anywhere makes t NaN), so `maxps` is `f32::max`.
                let sign = _mm_set1_ps(-0.0);
                let abs = |v: __m128| _mm_andnot_ps(sign, v);
                let (r0, r1, r2, r3) = (abs(xs), abs(ys), abs(zs), abs(e));
                let (t0, t1) = (_mm_unpacklo_ps(r0, r1), _mm_unpacklo_ps(r2, r3));
                let (t2, t3) = (_mm_unpackhi_ps(r0, r1), _mm_unpackhi_ps(r2, r3));
                let (c0, c1) = (_mm_movelh_ps(t0, t1), _mm_movehl_ps(t1, t0));
                let c2 = _mm_movelh_ps(t2, t3);
                let maxima = lanes(_mm_max_ps(_mm_max_ps(c0, c1), c2));
                let rel = lanes(_mm_max_ps(_mm_max_ps(abs(a), abs(b)), abs(c)));
                let rel_max = Vec3::new(rel[0], rel[1], rel[2]);
                let bound = t_error_of_maxima(maxima, rel_max, rcp);
                if t > bound {
                    Some((t, Vec2::new(v_ * rcp, w * rcp)))
                } else if t < -bound {
                    None
                } else {
                    self.triangle_f64(v, tmax)
                }
            }
        }
    }
}

/// A coordinate axis: an index below 3 by its type, so that reading `[f32; 3]` with it needs
/// no bounds check.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub(super) enum Axis {
    X = 0,
    Y = 1,
    Z = 2,
}

impl Axis {
    /// The next axis in cyclic order (x, y, z, x).
    #[inline]
    fn next(self) -> Axis {
        match self {
            Axis::X => Axis::Y,
            Axis::Y => Axis::Z,
            Axis::Z => Axis::X,
        }
    }
}

/// [`gamma`] for f64: `n·u / (1 − n·u)` with `u = 2^-53`.
pub(super) const fn gamma64(n: u32) -> f64 {
    let nu = n as f64 * (f64::EPSILON * 0.5);
    nu / (1.0 - nu)
}

/// The bound on the rounding error of the watertight test's `t` = (Σ eᵢ·zᵢ)/det, after Pharr,
/// Jakob & Humphreys 2016 ("Physically Based Rendering" 3rd ed., sec. 3.9.6): the vertices
/// relative to the origin `rel` (on the permuted axes, before the shear), the sheared `x`,
/// `y`, the scaled heights `z`, the edge functions `e` and 1/det. The translation and shear
/// bound the errors of x and y (by γ₅ of the unsheared coordinates: |Sx|, |Sy| ≤ 1) and of z
/// (γ₃ of z itself), these the edge functions', and all of them t's. (The book bounds the
/// shear's error by the *scaled* heights, which equal the unscaled ones only for a unit
/// direction; the traversal's directions are not normalised.) A ray whose origin is off a
/// triangle's plane by a rounding error's worth, leaving it, gets at most this `t` from that
/// triangle, however the sheared coordinates cancel.
#[cfg_attr(all(target_arch = "x86_64", target_feature = "avx"), allow(dead_code))]
#[inline]
fn triangle_t_error(
    rel: [Vec3; 3],
    x: [f32; 3],
    y: [f32; 3],
    z: [f32; 3],
    e: [f32; 3],
    rcp: f32,
) -> f32 {
    let max3 = |a: [f32; 3]| a[0].abs().max(a[1].abs()).max(a[2].abs());
    let (max_x, max_y, max_z, max_e) = (max3(x), max3(y), max3(z), max3(e));
    let rel_max = rel[0].abs().max(rel[1].abs()).max(rel[2].abs());
    t_error_of_maxima([max_x, max_y, max_z, max_e], rel_max, rcp)
}

/// [`triangle_t_error`] from the largest magnitudes of the sheared x, y, the scaled heights
/// and the edge functions, and of the unsheared coordinates by axis (`rel_max`).
#[inline(always)]
fn t_error_of_maxima([max_x, max_y, max_z, max_e]: [f32; 4], rel_max: Vec3, rcp: f32) -> f32 {
    let delta_x = gamma(5) * (rel_max.x + rel_max.z);
    let delta_y = gamma(5) * (rel_max.y + rel_max.z);
    let delta_z = gamma(3) * max_z;
    let delta_e = 2.0 * (gamma(2) * max_x * max_y + delta_y * max_x + delta_x * max_y);
    3.0 * (gamma(3) * max_e * max_z + delta_e * max_z + delta_z * max_e) * rcp.abs()
}

/// The box test's per-ray constants (x, y, z).
#[derive(Clone, Copy, Debug)]
pub(super) struct BoxRay {
    o: [f32; 3],
    inv: [f32; 3],
    pad: [f32; 3],
}

impl BoxRay {
    /// Conservative slab test (Ize 2013) of the boxes of a wide node at once (the compiler
    /// puts the lanes in SIMD registers): the hit lanes as bits (absent children included; the
    /// caller masks them) and the entry distances, clamped to 0. Per lane the arithmetic of the
    /// GLSL twin (`bvh_box_hit`), so a box is hit or missed alike on both sides: for a finite
    /// origin, a direction that [`Ray::new`] accepts and a finite box no value here is NaN, so
    /// the minima and maxima are those of the GLSL's scalar order (a NaN would be dropped by one
    /// order and kept by another).
    #[inline]
    pub(super) fn box_hit(&self, lo: &[Lanes; 3], hi: &[Lanes; 3], tmax: f32) -> (u32, Lanes) {
        let mut tnear = [0.0f32; WIDTH];
        let mut tfar = [tmax; WIDTH];
        for a in 0..3 {
            let (o, inv, pad) = (self.o[a], self.inv[a], self.pad[a]);
            for k in 0..WIDTH {
                let t0 = (lo[a][k] - o) * inv;
                let t1 = (hi[a][k] - o) * inv;
                let (t_in, t_out) = if t1 < t0 { (t1, t0) } else { (t0, t1) };
                let n = t_in - pad;
                let f = t_out + pad;
                tnear[k] = if n > tnear[k] { n } else { tnear[k] };
                tfar[k] = if f < tfar[k] { f } else { tfar[k] };
            }
        }
        // The comparisons four lanes at a time, each four a `movmskps`: written lane by lane,
        // the compiler assembled the mask one bit at a time.
        let mut hits = 0u32;
        for (q, (n, f)) in tnear.chunks_exact(4).zip(tfar.chunks_exact(4)).enumerate() {
            let (n, f) = (Vec4::from_slice(n), Vec4::from_slice(f));
            hits |= n.cmple(f * BOX_WIDEN).bitmask() << (4 * q);
        }
        (hits, tnear)
    }
}

/// Watertight ray/triangle intersection (Woop, Benthin & Wald 2013): the hit distance `t` in
/// (0, tmax) and the barycentrics (b1, b2) of v1 and v2. None for a zero direction.
pub fn intersect_triangle(o: Vec3, d: Vec3, v: &[Vec3; 3], tmax: f32) -> Option<(f32, Vec2)> {
    Ray::new(o, d)?.triangle(v, tmax).filter(|h| h.0 < tmax)
}

/// Ray/sphere intersection: the smallest root in (0, tmax), so a ray starting inside finds the
/// far side; see [`sphere`]. `d` need not be normalised.
pub fn intersect_sphere(o: Vec3, d: Vec3, center: Vec3, radius: f32, tmax: f32) -> Option<f32> {
    sphere(o, d, center, radius, tmax).filter(|&t| t < tmax)
}

/// `c = |o − center|² − radius²`, whose sign says on which side of the sphere the origin
/// lies, and a bound on its error: the sum of the ten products `oᵢ², −2·oᵢ·centerᵢ, centerᵢ²`
/// and `−radius²`, each exact in f64 (two 24-bit significands), summed with error-free
/// transformations (Ogita, Rump & Oishi 2005, "Accurate Sum and Dot Product", SIAM J. Sci.
/// Comput. 26(6), algorithm Sum2). The result is as accurate as a sum in twice f64's precision:
/// the error is at most 2^-52·|c| + γ₉²·Σ|terms| (their proposition 4.5), and the bound
/// returned, 2^-98·Σ|terms|, covers the second part, the only one that can change c's sign.
/// A camera one unit above a ground sphere of radius 1e19 is told from its surface with
/// room to spare; f64 alone (`|o − center|²` rounded) would blur the surface by 2^-50 of the
/// radius.
pub fn sphere_c(o: Vec3, center: Vec3, radius: f32) -> (f64, f64) {
    let (o, c, r) = (o.as_dvec3(), center.as_dvec3(), radius as f64);
    let terms = [
        o.x * o.x,
        -2.0 * o.x * c.x,
        c.x * c.x,
        o.y * o.y,
        -2.0 * o.y * c.y,
        c.y * c.y,
        o.z * o.z,
        -2.0 * o.z * c.z,
        c.z * c.z,
        -(r * r),
    ];
    let (mut s, mut e, mut abs) = (0.0f64, 0.0f64, 0.0f64);
    for x in terms {
        // TwoSum (Knuth): s + x = sum + err exactly.
        let sum = s + x;
        let bb = sum - s;
        let err = (s - (sum - bb)) + (x - bb);
        s = sum;
        e += err;
        abs += x.abs();
    }
    (s + e, abs * SPHERE_C_ERROR)
}

/// 2^-98 ([`sphere_c`]).
pub(super) const SPHERE_C_ERROR: f64 = 1.0 / (1u128 << 98) as f64;

/// [`intersect_sphere`] with t in (0, tmax]: the smallest root in (0, tmax], as the traversal's
/// tie rule needs (a root at exactly `tmax` is returned).
///
/// In f64, from the f32 inputs. The quadratic in the form of Haines et al. 2019 ("Precision
/// Improvements for Ray/Sphere Intersection", Ray Tracing Gems ch. 7): the discriminant from
/// the distance of the centre to the line, the roots as `c/q` and `q/a` without cancellation,
/// with `c` from [`sphere_c`]. The near root `c/q` is dropped when |c| is within its error
/// bound: the origin is then on the surface as far as the test can tell, so a ray leaving the
/// surface outwards finds nothing and one leaving it inwards finds the far side. Every ray
/// that leaves a sphere starts off it by the hit point's error bound ([`crate::robust`]),
/// thousands of times that resolution for spheres the scene loader accepts.
pub(super) fn sphere(o: Vec3, d: Vec3, center: Vec3, radius: f32, tmax: f32) -> Option<f32> {
    let f = o.as_dvec3() - center.as_dvec3();
    let d = d.as_dvec3();
    let a = d.x * d.x + d.y * d.y + d.z * d.z;
    // Also rejects NaN (GLSL: `!(a > 0.0)`).
    if a.is_nan() || a <= 0.0 {
        return None;
    }
    let b = f.x * d.x + f.y * d.y + f.z * d.z;
    let r2 = radius as f64 * radius as f64;
    let (c, c_err) = sphere_c(o, center, radius);
    // Discriminant / a from the squared distance of the centre to the line.
    let k = b / a;
    let l = f - d * k;
    let disc = a * (r2 - (l.x * l.x + l.y * l.y + l.z * l.z));
    if disc.is_nan() || disc < 0.0 {
        return None;
    }
    let sq = disc.sqrt();
    let q = if b >= 0.0 { -b - sq } else { -b + sq };
    if q == 0.0 {
        return None;
    }
    let t0 = if c.abs() <= c_err {
        0.0
    } else {
        (c / q) as f32
    };
    let t1 = (q / a) as f32;
    let (lo, hi) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
    if lo > 0.0 && lo <= tmax {
        Some(lo)
    } else if hi > 0.0 && hi <= tmax {
        Some(hi)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SIMD triangle test gives the scalar test's answers bit for bit: hits, misses,
    /// distances and barycentrics, on rays through and beside triangles at scales from 2^-40
    /// to 2^40, rays leaving a triangle (the error bound and the f64 test), rays along axes
    /// (zero direction components), degenerate triangles and small `tmax`.
    #[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
    #[test]
    fn simd_triangle_matches_scalar() {
        // The renderer's own counter-based numbers, one key per draw.
        let draws = std::cell::Cell::new(0u32);
        let unit = || {
            draws.set(draws.get() + 1);
            crate::rng::random_f32(11, draws.get(), 0, 0, 0)
        };
        let (mut hits, mut near_zero, mut cases) = (0, 0, 0);
        for i in 0..200_000 {
            let scale = 2f32.powi((i % 81) - 40);
            let shift = Vec3::splat(if i % 7 == 0 { scale * 1000.0 } else { 0.0 });
            let p = || shift + Vec3::new(unit(), unit(), unit()) * 2.0 * scale - scale;
            let mut v = [p(), p(), p()];
            if i % 97 == 0 {
                v[2] = v[1]; // degenerate
            }
            let on = v[0] + (v[1] - v[0]) * unit() * 0.5 + (v[2] - v[0]) * unit() * 0.5;
            let o = match i % 3 {
                0 => p(),
                // On (or a rounding off) the triangle: t within its error bound of 0.
                1 => on,
                _ => on + (v[1] - v[0]).cross(v[2] - v[0]) * (unit() - 0.5) * 1e-6,
            };
            let mut d = if i % 2 == 0 {
                on + (p() - on) * 0.01 - o
            } else {
                Vec3::new(unit(), unit(), unit()) * 2.0 - 1.0
            };
            if i % 11 == 0 {
                d[(i / 11 % 3) as usize] = 0.0;
            }
            if i % 13 == 0 {
                d = Vec3::new(0.0, 0.0, 1.0) * (unit() - 0.5);
            }
            let tmax = if i % 5 == 0 { unit() * 2.0 } else { f32::MAX };
            let Some(ray) = Ray::new(o, d) else { continue };
            let bits = |h: Option<(f32, Vec2)>| h.map(|(t, b)| [t, b.x, b.y].map(f32::to_bits));
            let (scalar, simd) = (ray.triangle_scalar(&v, tmax), ray.triangle_simd(&v, tmax));
            assert_eq!(
                bits(scalar),
                bits(simd),
                "o {o:?} d {d:?} v {v:?} tmax {tmax}"
            );
            cases += 1;
            hits += usize::from(scalar.is_some());
            near_zero += usize::from(scalar.is_some_and(|(t, _)| t < 1e-3 * scale));
        }
        assert!(
            cases > 190_000 && hits > 30_000 && near_zero > 100,
            "{cases} {hits} {near_zero}"
        );
    }

    #[test]
    fn triangle_hit_values() {
        let v = [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ];
        let (t, b) = intersect_triangle(Vec3::new(0.25, 0.5, 0.0), Vec3::Z, &v, f32::MAX).unwrap();
        assert_eq!(t, 1.0);
        assert!((b - Vec2::new(0.25, 0.5)).abs().max_element() < 1e-6, "{b}");
        // From behind and with a reversed direction: both sides hit (no culling).
        let (t, _) =
            intersect_triangle(Vec3::new(0.25, 0.5, 3.0), -Vec3::Z * 2.0, &v, f32::MAX).unwrap();
        assert!((t - 1.0).abs() < 1e-6);
        // Behind the origin, beyond tmax, outside, zero direction.
        assert!(intersect_triangle(Vec3::new(0.25, 0.5, 2.0), Vec3::Z, &v, f32::MAX).is_none());
        assert!(intersect_triangle(Vec3::new(0.25, 0.5, 0.0), Vec3::Z, &v, 1.0).is_none());
        assert!(intersect_triangle(Vec3::new(0.75, 0.5, 0.0), Vec3::Z, &v, f32::MAX).is_none());
        assert!(intersect_triangle(Vec3::new(0.25, 0.5, 0.0), Vec3::ZERO, &v, f32::MAX).is_none());
        // A ray lying in the triangle's plane misses (det = 0).
        assert!(intersect_triangle(Vec3::new(-1.0, 0.2, 1.0), Vec3::X, &v, f32::MAX).is_none());
    }

    #[test]
    fn sphere_roots_outside_inside_and_on_surface() {
        let c = Vec3::new(1.0, 2.0, 3.0);
        let t = intersect_sphere(c - Vec3::X * 5.0, Vec3::X, c, 2.0, f32::MAX).unwrap();
        assert!((t - 3.0).abs() < 1e-6);
        // Unnormalised direction: t in units of d.
        let t = intersect_sphere(c - Vec3::X * 5.0, Vec3::X * 2.0, c, 2.0, f32::MAX).unwrap();
        assert!((t - 1.5).abs() < 1e-6);
        // From inside: the far side.
        let t = intersect_sphere(c, Vec3::Y, c, 2.0, f32::MAX).unwrap();
        assert!((t - 2.0).abs() < 1e-6);
        // From exactly on the surface: inwards finds the far side, outwards nothing.
        let p = c + Vec3::new(0.0, 0.0, 2.0);
        let t = intersect_sphere(p, -Vec3::Z, c, 2.0, f32::MAX).unwrap();
        assert!((t - 4.0).abs() < 1e-5);
        assert!(intersect_sphere(p, Vec3::Z, c, 2.0, f32::MAX).is_none());
        // Miss, behind, tmax.
        assert!(
            intersect_sphere(c + Vec3::new(0.0, 3.0, -5.0), Vec3::Z, c, 2.0, f32::MAX).is_none()
        );
        assert!(intersect_sphere(c + Vec3::X * 5.0, Vec3::X, c, 2.0, f32::MAX).is_none());
        assert!(intersect_sphere(c - Vec3::X * 5.0, Vec3::X, c, 2.0, 3.0).is_none());
    }

    #[test]
    fn sphere_far_away_is_precise() {
        // Small sphere at distance 1e4: the naive quadratic loses the discriminant.
        let c = Vec3::new(0.0, 0.0, 1.0e4);
        let t = intersect_sphere(Vec3::new(0.0, 0.0099, 0.0), Vec3::Z, c, 0.01, f32::MAX).unwrap();
        let exact = 1.0e4 - (0.01f64 * 0.01 - 0.0099f64 * 0.0099).sqrt();
        assert!((t as f64 - exact).abs() < 2e-3, "{t} vs {exact}");
    }
}
