//! Ray set-up and the ray/box, ray/triangle and ray/sphere tests the traversal runs (twins in
//! `shaders/bvh.glsl`: `bvh_make_ray`, `bvh_box_hit`, `bvh_triangle`, `bvh_sphere`); the
//! methods and their numerics are those of the [`crate::bvh`] module documentation.

use crate::robust::dot3;
use glam::{Vec2, Vec3, Vec3A, Vec4};

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

/// A ray origin closer to a sphere's surface than about `M · 2^-19`, M = max(|o|∞, r), counts
/// as on the surface (16 ulps of the largest coordinate, more than the rounding of a point
/// computed on the sphere): the root at t ≈ 0 is dropped so the ray finds the far side (see
/// [`intersect_sphere`]). `|f|² - r²` is compared with `r · M · SPHERE_ON_SURFACE`.
pub(super) const SPHERE_ON_SURFACE: f32 = 1.0 / (1u32 << 18) as f32;

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
    kx: usize,
    ky: usize,
    kz: usize,
    /// Shear constants (Sx, Sy, Sz).
    s: Vec3,
}

impl Ray {
    /// None for a zero, infinite or NaN direction: such a ray hits nothing.
    #[inline]
    pub(super) fn new(o: Vec3, d: Vec3) -> Option<Ray> {
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        if !(a[kz] > 0.0 && a[kz] <= f32::MAX) {
            return None;
        }
        let mut kx = if kz == 2 { 0 } else { kz + 1 };
        let mut ky = if kx == 2 { 0 } else { kx + 1 };
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        // The divisions as two SIMD divisions (each lane the same IEEE quotient as a scalar
        // division): the shear (d[kx] / d[kz], d[ky] / d[kz], 1 / d[kz]), and the safe inverse,
        // which is ZERO_INV with the slab padded by ZERO_PAD where |d| < ZERO_DIR (there the
        // quotient, possibly infinite, is not used).
        let s = Vec3::from(Vec3A::new(d[kx], d[ky], 1.0) / Vec3A::splat(d[kz]));
        let d_a = Vec3A::from(d);
        let zero = d_a.abs().cmplt(Vec3A::splat(ZERO_DIR));
        Some(Ray {
            op: Vec3::new(o[kx], o[ky], o[kz]),
            o_a: Vec3A::from(o),
            inv: Vec3A::select(zero, Vec3A::splat(ZERO_INV), Vec3A::ONE / d_a),
            pad: Vec3A::select(zero, Vec3A::splat(ZERO_PAD), Vec3A::ZERO),
            kx,
            ky,
            kz,
            s,
        })
    }

    /// The per-axis splats of the box test's constants, for [`RaySplats::box_hit4`].
    #[inline]
    pub(super) fn splats(&self) -> RaySplats {
        let splat = |v: Vec3A| [Vec4::splat(v.x), Vec4::splat(v.y), Vec4::splat(v.z)];
        RaySplats {
            o: splat(self.o_a),
            inv: splat(self.inv),
            pad: splat(self.pad),
        }
    }

    /// Woop–Benthin–Wald watertight test; (t, (b1, b2)) with t in (0, tmax]: a hit at
    /// exactly `tmax` is returned, for the tie rule (the [`crate::bvh`] module documentation).
    #[inline]
    pub(super) fn triangle(&self, v: &[Vec3; 3], tmax: f32) -> Option<(f32, Vec2)> {
        // Each vertex relative to the origin on the ray's permuted axes (kx, ky, kz): the same
        // subtractions as (v - o)[k], reading the vertex's components straight from memory.
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
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
        // t > 0 needs T and det of the same sign (and T != 0).
        if (det < 0.0 && tt >= 0.0) || (det > 0.0 && tt <= 0.0) {
            return None;
        }
        let rcp = 1.0 / det;
        let t = tt * rcp;
        if !(t > 0.0 && t <= tmax) {
            return None;
        }
        Some((t, Vec2::new(v_ * rcp, w * rcp)))
    }
}

/// The box test's per-ray constants, each component in all four lanes (x, y, z).
#[derive(Clone, Copy, Debug)]
pub(super) struct RaySplats {
    o: [Vec4; 3],
    inv: [Vec4; 3],
    pad: [Vec4; 3],
}

impl RaySplats {
    /// Conservative slab test (Ize 2013) of the four boxes of a wide node at once, in SIMD
    /// registers: the hit lanes as bits (absent children included; the caller masks them) and
    /// the entry distances, clamped to 0. Per lane the arithmetic of the GLSL twin
    /// (`bvh_box_hit`), so a box is hit or missed alike on both sides: for a finite origin, a direction
    /// that [`Ray::new`] accepts and a finite box no value here is NaN, so the minima and
    /// maxima are those of the GLSL's scalar order (a NaN would be dropped by one order and
    /// kept by another).
    #[inline]
    pub(super) fn box_hit4(&self, lo: &[Vec4; 3], hi: &[Vec4; 3], tmax: f32) -> (u32, Vec4) {
        let mut tnear = Vec4::ZERO;
        let mut tfar = Vec4::splat(tmax);
        for a in 0..3 {
            let t0 = (lo[a] - self.o[a]) * self.inv[a];
            let t1 = (hi[a] - self.o[a]) * self.inv[a];
            tnear = tnear.max(t0.min(t1) - self.pad[a]);
            tfar = tfar.min(t0.max(t1) + self.pad[a]);
        }
        let tfar = tfar * BOX_WIDEN;
        (tnear.cmple(tfar).bitmask(), tnear)
    }
}

/// Watertight ray/triangle intersection (Woop, Benthin & Wald 2013): the hit distance `t` in
/// (0, tmax) and the barycentrics (b1, b2) of v1 and v2. None for a zero direction.
pub fn intersect_triangle(o: Vec3, d: Vec3, v: &[Vec3; 3], tmax: f32) -> Option<(f32, Vec2)> {
    Ray::new(o, d)?.triangle(v, tmax).filter(|h| h.0 < tmax)
}

/// Ray/sphere intersection (Ray Tracing Gems ch. 7): the smallest root in (0, tmax), so a ray
/// starting inside finds the far side. An origin within about 16 ulps of its largest
/// coordinate (or of the radius) from the surface counts as on it: the root at t ≈ 0 is dropped, so a ray leaving the surface inwards finds
/// the far side and one leaving outwards finds nothing. `d` need not be normalised.
pub fn intersect_sphere(o: Vec3, d: Vec3, center: Vec3, radius: f32, tmax: f32) -> Option<f32> {
    sphere(o, d, center, radius, tmax).filter(|&t| t < tmax)
}

/// [`intersect_sphere`] with t in (0, tmax]: the smallest root in (0, tmax], as the traversal's
/// tie rule needs (a root at exactly `tmax` is returned).
pub(super) fn sphere(o: Vec3, d: Vec3, center: Vec3, radius: f32, tmax: f32) -> Option<f32> {
    let f = o - center;
    let a = dot3(d, d);
    // Also rejects NaN (GLSL: `!(a > 0.0)`).
    if a.is_nan() || a <= 0.0 {
        return None;
    }
    let b = dot3(f, d);
    let r2 = radius * radius;
    let c = dot3(f, f) - r2;
    // Discriminant / a from the squared distance of the centre to the line.
    let k = b / a;
    let l = f - d * k;
    let disc = a * (r2 - dot3(l, l));
    if disc < 0.0 {
        return None;
    }
    let sq = disc.sqrt();
    let q = if b >= 0.0 { -b - sq } else { -b + sq };
    if q == 0.0 {
        return None;
    }
    let m = o.x.abs().max(o.y.abs()).max(o.z.abs().max(radius.abs()));
    let on_surface = c.abs() <= radius.abs() * m * SPHERE_ON_SURFACE;
    let t0 = if on_surface { 0.0 } else { c / q };
    let t1 = q / a;
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
