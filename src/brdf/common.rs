//! Building blocks shared by the models, grouped by topic: sampling the hemisphere, directions
//! and frames, special functions, colour, Fresnel reflectance, microfacet distributions. Each
//! function has a GLSL twin of the same name and the same arithmetic in
//! `shaders/brdf/common.glsl`, so that both renderers compute the same numbers.

use glam::{Vec2, Vec3, Vec3A};
use std::f32::consts::PI;

// ---------------------------------------------------------------------------------------------
// Sampling the hemisphere
// ---------------------------------------------------------------------------------------------

/// Cosine-weighted hemisphere sample (Malley's method on the concentric disk, Shirley & Chiu
/// 1997). pdf = cosθ/π.
///
/// The disk's rim (a coordinate of `u` exactly 0, probability 2^-24 per number, or rounding at
/// |a| ≈ 1) would give cosθ = 0: a tangent direction of pdf 0, which ends the path. Once in
/// 10^7 segments is nothing for a shallow path but cut 0.9 % of a white furnace's segments at
/// depth 2^20 (issue 22). There the point is moved inwards to 1 − |d|² = [`MIN_COS2`], below
/// the value at the largest radius under 1 that 24-bit numbers reach, so nothing else changes.
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let a = 2.0 * u - Vec2::ONE;
    let d = if a.x == 0.0 && a.y == 0.0 {
        Vec2::ZERO
    } else if a.x.abs() > a.y.abs() {
        // φ = (π/4)(a.y/a.x), in [−π/4, π/4].
        let (sin, cos) = sin_cos_quarter((PI / 4.0) * (a.y / a.x));
        Vec2::new(a.x * cos, a.x * sin)
    } else {
        // φ = π/2 − ψ with ψ = (π/4)(a.x/a.y): cos φ = sin ψ, sin φ = cos ψ.
        let (sin, cos) = sin_cos_quarter((PI / 4.0) * (a.x / a.y));
        Vec2::new(a.y * sin, a.y * cos)
    };
    let z2 = 1.0 - d.length_squared();
    if z2 < MIN_COS2 {
        let d = d * ((1.0 - MIN_COS2).sqrt() / d.length());
        return Vec3::new(d.x, d.y, MIN_COS2.sqrt());
    }
    Vec3::new(d.x, d.y, z2.sqrt())
}

/// (sin x, cos x) for |x| ≤ π/4, the only angles the concentric map needs: the minimax
/// polynomials of Cephes' `sinf` and `cosf` on that interval (Moshier 1989), within 2 ulp of
/// the true values (`tests`, against f64). Plain arithmetic, where libm's `sincosf` is a call:
/// the lane kernels (`cpu/lanes.rs`) do it for 16 angles at once with the same operations.
/// No GLSL twin: the shaders' `sample_cosine_hemisphere` reduces the angle alike and calls the
/// builtin `sin` and `cos`, so the two sides agree to rounding, not bit for bit.
#[inline(always)]
pub fn sin_cos_quarter(x: f32) -> (f32, f32) {
    let z = x * x;
    let sin = x + x * z * ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1);
    let cos = 1.0 - 0.5 * z + z * z * ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2);
    (sin, cos)
}

/// The least cos²θ of [`sample_cosine_hemisphere`]: 2^-23, half of 1 − r² ≈ 2^-22 at the
/// largest disk radius below 1 that 24-bit numbers give (r = 1 − 2^-23 at u = 2^-24 or
/// 1 − 2^-24), so that only the rim and rounding right at it are moved.
pub const MIN_COS2: f32 = 1.0 / (1u32 << 23) as f32;

pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) / PI
}

/// Both directions strictly above the surface.
#[inline]
pub fn same_hemisphere_up(a: Vec3, b: Vec3) -> bool {
    a.z > 0.0 && b.z > 0.0
}

/// The pdf of the diffuse models (Lambert, Oren–Nayar): cosθ/π over the upper hemisphere, 0
/// unless both directions are above the surface.
pub fn diffuse_pdf(given: Vec3, sampled: Vec3) -> f32 {
    if !same_hemisphere_up(given, sampled) {
        return 0.0;
    }
    cosine_hemisphere_pdf(sampled.z)
}

/// The pdf of the models with one specular lobe beside a Lambertian one (Phong, Blinn–Phong,
/// Ward): the specular lobe, of density `ps` at `sampled`, is chosen with probability `p_spec`
/// (`u_lobe < p_spec` in their samplers), the cosine-weighted diffuse lobe otherwise. For
/// directions both above the surface (the caller checks). GLSL: `diffuse_specular_pdf`.
pub fn diffuse_specular_pdf(p_spec: f32, ps: f32, sampled: Vec3) -> f32 {
    (1.0 - p_spec) * cosine_hemisphere_pdf(sampled.z) + p_spec * ps
}

/// The probability of choosing the specular lobe of a diffuse + specular mixture: its share of
/// the luminances `d` of the diffuse albedo and `s` of the lobe's albedo estimate (0 when both
/// are 0). Phong, Blinn–Phong and Ward compute it on the host (the record's P_s).
pub fn specular_probability(d: f32, s: f32) -> f32 {
    if d + s > 0.0 {
        s / (d + s)
    } else {
        0.0
    }
}

/// A direction about +z of density (n+1)/(2π) cosⁿθ: cosθ = u'^{1/(n+1)} with u' = 1 − u.x in
/// (0, 1], sin²θ = −expm1(2 ln u'/(n+1)) (no 1 − cos² cancellation), φ = 2π u.y. Phong samples
/// its lobe with it about the mirror direction, Blinn–Phong its half vector.
pub fn sample_power_cosine(u: Vec2, n: f32) -> Vec3 {
    let l = (1.0 - u.x).ln() / (n + 1.0);
    let cos = l.exp();
    let sin = (-expm1_f(2.0 * l)).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(sin * phi.cos(), sin * phi.sin(), cos)
}

/// The solid-angle density at `sampled` of a lobe that samples a half vector h and reflects
/// `given` about it: pdf_h(h) / (4 given·h), with `pdf_h` the half vector's density (cosθh
/// included) and 4 given·h the Jacobian of the reflection (Walter et al. 2007); h =
/// normalize(given + sampled). 0 when given·h ≤ 0, where [`reflect_about`] rejects the sample.
/// Cook–Torrance, He and Schlick use it. GLSL: the `RETURN_REFLECTED_PDF` macro.
pub fn reflected_pdf(given: Vec3, sampled: Vec3, pdf_h: impl FnOnce(Vec3) -> f32) -> f32 {
    let h = (given + sampled).normalize();
    let c = given.dot(h);
    if c <= 0.0 {
        return 0.0;
    }
    pdf_h(h) / (4.0 * c)
}

/// The sample of the diffuse models (Lambert, Oren–Nayar): a cosine-weighted direction wi with
/// the weight `weight(wi)` = f·cosθ/pdf, which each model writes out (no 0/0 at the horizon).
/// None when `given` is not above the surface or the pdf of wi is 0.
pub fn sample_diffuse(
    given: Vec3,
    u: Vec2,
    weight: impl FnOnce(Vec3) -> Vec3,
) -> Option<super::BrdfSample> {
    if given.z <= 0.0 {
        return None;
    }
    let wi = sample_cosine_hemisphere(u);
    let pdf = cosine_hemisphere_pdf(wi.z);
    if pdf <= 0.0 {
        return None;
    }
    Some(super::BrdfSample {
        wi,
        weight: weight(wi),
        pdf,
        delta: false,
    })
}

// ---------------------------------------------------------------------------------------------
// Directions and frames
// ---------------------------------------------------------------------------------------------

/// Mirror direction about the normal z: refl(w) = (−w.x, −w.y, w.z).
#[inline]
pub fn reflect_z(w: Vec3) -> Vec3 {
    Vec3::new(-w.x, -w.y, w.z)
}

/// Reflect `w` about the unit vector `h`: 2(w·h)h − w; None when w·h ≤ 0, where `w` lies below
/// the plane of `h` and the mirror image is no sample of the lobe (every sampler rejects it).
#[inline]
pub fn reflect_about(w: Vec3, h: Vec3) -> Option<Vec3> {
    let c = w.dot(h);
    if c <= 0.0 {
        return None;
    }
    Some(2.0 * c * h - w)
}

/// Orthonormal basis (t, b) completing the unit vector `n` (Duff et al. 2017, "Building an
/// Orthonormal Basis, Revisited", JCGT 6(1)); right-handed: t × b = n.
#[inline]
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
    (t, bt)
}

/// Rotate `w` about z by the angle whose cosine and sine are `c`, `s`.
#[inline]
pub fn rotate_z(w: Vec3, c: f32, s: f32) -> Vec3 {
    Vec3::new(c * w.x - s * w.y, s * w.x + c * w.y, w.z)
}

/// 1 − a·b for unit vectors, accurate when they are nearly parallel: |a − b|²/2.
#[inline]
pub fn one_minus_dot(a: Vec3, b: Vec3) -> f32 {
    0.5 * (a - b).length_squared()
}

/// tan²θ of a direction or (un-normalised) half vector from its components: (x² + y²)/z²,
/// never (1 − cos²)/cos². Requires z > 0.
#[inline]
pub fn tan2_theta(w: Vec3) -> f32 {
    (w.x * w.x + w.y * w.y) / (w.z * w.z)
}

// ---------------------------------------------------------------------------------------------
// Special functions: accurate where GLSL has no library function
// ---------------------------------------------------------------------------------------------

/// e^x − 1 with relative accuracy near 0 (GLSL has no expm1): Taylor series to x⁶ for
/// |x| < 0.1 (truncation < 3e-10 relative), exp(x) − 1 elsewhere.
#[inline]
pub fn expm1_f(x: f32) -> f32 {
    if x.abs() < 0.1 {
        x * (1.0
            + x * (0.5
                + x * (1.0 / 6.0 + x * (1.0 / 24.0 + x * (1.0 / 120.0 + x * (1.0 / 720.0))))))
    } else {
        x.exp() - 1.0
    }
}

/// ln(1 + x) with relative accuracy near 0 (GLSL has no log1p): alternating series to x⁸ for
/// |x| < 0.1 (truncation < 1.2e-9 relative), ln(1 + x) elsewhere. x > −1.
#[inline]
pub fn log1p_f(x: f32) -> f32 {
    if x.abs() < 0.1 {
        x * (1.0
            + x * (-0.5
                + x * (1.0 / 3.0
                    + x * (-0.25 + x * (0.2 + x * (-1.0 / 6.0 + x * (1.0 / 7.0 + x * -0.125)))))))
    } else {
        (1.0 + x).ln()
    }
}

/// cⁿ for the cosine c = 1 − x of a small angle, where x = 1 − c is supplied accurately (e.g.
/// |a − b|²/2 for unit a, b): exp(n·log1p(−x)), so lobes with n up to 10⁶ keep their shape in
/// f32. Returns 0 for c ≤ 0 (x ≥ 1) and 1 for n = 0 with c > 0 (the lobe is max(0, c)ⁿ).
#[inline]
pub fn pow_one_minus(x: f32, n: f32) -> f32 {
    if x >= 1.0 {
        return 0.0;
    }
    if n <= 0.0 {
        return 1.0;
    }
    (n * log1p_f(-x.max(0.0))).exp()
}

/// Where [`erfc`]'s value drops below f32's smallest normal number (1.18e-38): the formula gives
/// 1.28e-38 at 9.19 and a subnormal 1.17e-38 at 9.195.
pub const ERFC_ZERO: f32 = 9.19;

/// Complementary error function with *relative* accuracy (fractional error < 1.2e-7 for all
/// x in exact arithmetic) where it is a normal f32: the Chebyshev-fitted form
/// exp(−x² + P(t))·t, t = 1/(1 + x/2), of Numerical Recipes' `erfcc`. From |x| = [`ERFC_ZERO`]
/// on, erfc(|x|) is below f32's smallest normal number and is taken as 0 (so erfc(x) = 2 for
/// x ≤ −ERFC_ZERO): subnormal values cost Intel cores a microcode assist per operation (4 % of
/// the lineup scene's CPU time), and a device that flushes subnormals to 0 gives 0 there too.
/// |x| is clamped to 10 in the formula, so no infinity is ever formed.
pub fn erfc(x: f32) -> f32 {
    let z = x.abs().min(10.0);
    let t = 1.0 / (1.0 + 0.5 * z);
    let p = -1.265_512_2
        + t * (1.000_023_7
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_204
                                + t * (1.488_515_9 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = if z >= ERFC_ZERO {
        0.0
    } else {
        t * (-z * z + p).exp()
    };
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

// ---------------------------------------------------------------------------------------------
// Colour
// ---------------------------------------------------------------------------------------------

/// Rec. 709 luminance, used to turn RGB lobe albedos into lobe-selection probabilities.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

// ---------------------------------------------------------------------------------------------
// Fresnel reflectance
// ---------------------------------------------------------------------------------------------

/// Unpolarised Fresnel reflectance of a dielectric, survey eq. 7 (Cook & Torrance 1982):
/// F = ½ (g−c)²/(g+c)² · [1 + (c(g+c) − 1)²/(c(g−c) + 1)²], g² = n² + c² − 1, with c = cos of
/// the angle of incidence (clamped to [0, 1]) and n the relative index. Guards: n = 1 → 0
/// (no interface; avoids 0/0 at c = 0); g² < 0 (n < 1, total internal reflection) → 1.
pub fn fresnel_dielectric(c: f32, n: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if n == 1.0 {
        return 0.0;
    }
    let g2 = n * n + c * c - 1.0;
    if g2 <= 0.0 {
        return 1.0;
    }
    let g = g2.sqrt();
    let a = (g - c) / (g + c);
    let num = c * (g + c) - 1.0;
    let den = c * (g - c) + 1.0;
    let b = num / den;
    (0.5 * a * a * (1.0 + b * b)).clamp(0.0, 1.0)
}

/// [`fresnel_conductor`] of one channel.
pub fn fresnel_conductor1(c: f32, eta: f32, k: f32) -> f32 {
    fresnel_conductor(c, Vec3::splat(eta), Vec3::splat(k)).x
}

/// The square root of each lane (correctly rounded, as `f32::sqrt`).
#[inline(always)]
fn sqrt3(v: Vec3A) -> Vec3A {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    {
        // SAFETY: SSE2 is enabled at compile time.
        Vec3A::from(unsafe { std::arch::x86_64::_mm_sqrt_ps(v.into()) })
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    {
        Vec3A::new(v.x.sqrt(), v.y.sqrt(), v.z.sqrt())
    }
}

/// Exact unpolarised Fresnel reflectance of a conductor with complex index η + iκ, per RGB
/// channel, F = ½(R_s + R_p), in the real-arithmetic form of Born & Wolf / Moeller's
/// "Optics": with s² = sin²θ and x = η² − κ² − s², t = √(x² + 4η²κ²), a² = (t + x)/2,
/// b² = (t − x)/2 (ab = ηκ). The smaller of a², b² is computed as η²κ²/(the larger) so that
/// neither cancels. κ = 0 reduces to the dielectric (η ≥ 1) or total internal reflection.
/// The three channels in SIMD lanes, each branch of the GLSL twin (`fresnel_conductor1` per
/// channel) a select: the same f32 operations in the same order, so the same bits as the
/// branching one-channel form (for every η, κ the model accepts; `tests` below checks it).
pub fn fresnel_conductor(c: f32, eta: Vec3, k: Vec3) -> Vec3 {
    let (eta, k) = (Vec3A::from(eta), Vec3A::from(k));
    let c = c.clamp(0.0, 1.0);
    let c2 = c * c;
    let s2 = (1.0 - c2).max(0.0);
    let x = eta * eta - k * k - s2;
    let ek = eta * k;
    let t = sqrt3(x * x + 4.0 * ek * ek);
    // The larger of a², b² from t ± x, the smaller as η²κ²/(the larger).
    let positive = x.cmpge(Vec3A::ZERO);
    let larger = 0.5 * Vec3A::select(positive, t + x, t - x);
    let smaller = Vec3A::select(larger.cmpgt(Vec3A::ZERO), ek * ek / larger, Vec3A::ZERO);
    let a2 = Vec3A::select(positive, larger, smaller);
    let b2 = Vec3A::select(positive, smaller, larger);
    let a = sqrt3(a2);
    let ab2 = a2 + b2;
    let rs_num = ab2 - 2.0 * a * c + c2;
    let rs_den = ab2 + 2.0 * a * c + c2;
    let rs = Vec3A::select(rs_den.cmpgt(Vec3A::ZERO), rs_num / rs_den, Vec3A::ONE);
    let p_num = c2 * ab2 - 2.0 * a * c * s2 + s2 * s2;
    let p_den = c2 * ab2 + 2.0 * a * c * s2 + s2 * s2;
    let rp = Vec3A::select(p_den.cmpgt(Vec3A::ZERO), rs * p_num / p_den, rs);
    let f = 0.5 * (rs + rp);
    // f32::clamp, lane by lane (a NaN stays NaN, as in the scalar form).
    Vec3::new(
        f.x.clamp(0.0, 1.0),
        f.y.clamp(0.0, 1.0),
        f.z.clamp(0.0, 1.0),
    )
}

/// Schlick's approximation F = f₀ + (1 − f₀)(1 − c)⁵ (survey eq. 18, with u = cos of the angle
/// between the light and the microfacet normal), the fifth power by multiplications.
pub fn fresnel_schlick(c: f32, f0: Vec3) -> Vec3 {
    let m = (1.0 - c.clamp(0.0, 1.0)).clamp(0.0, 1.0);
    let m2 = m * m;
    let m5 = m2 * m2 * m;
    f0 + (Vec3::ONE - f0) * m5
}

// ---------------------------------------------------------------------------------------------
// Microfacet distributions (Beckmann, GGX): normal distributions, Smith masking, sampling
// ---------------------------------------------------------------------------------------------

/// Normalised isotropic Beckmann NDF, D = exp(−tan²θh/α²)/(π α² cos⁴θh) (the survey's eq. 6
/// divided by π, so that ∫ D cosθh dω = 1). `h` unit, upper hemisphere; 0 otherwise.
pub fn beckmann_d(h: Vec3, alpha: f32) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let c2 = h.z * h.z;
    let e = (-tan2_theta(h) / a2).exp();
    e / (std::f32::consts::PI * a2 * c2 * c2)
}

/// Normalised isotropic GGX / Trowbridge–Reitz NDF, D = α²/(π (cos²θh(α² − 1) + 1)²), written
/// with components as α²/(π (hz² α² + hx² + hy²)²) for unit h (no cancellation near h = n).
pub fn ggx_d(h: Vec3, alpha: f32) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let d = h.z * h.z * a2 + h.x * h.x + h.y * h.y;
    if d <= 0.0 {
        return 0.0;
    }
    a2 / (std::f32::consts::PI * d * d)
}

/// Smith G1 for Beckmann by Walter et al. 2007's rational approximation (as used by the
/// Cornell box's glossy material): a = 1/(α tanθ); G1 = 1 for a ≥ 1.6, else
/// (3.535a + 2.181a²)/(1 + 2.276a + 2.577a²). Within 0.35 % of the exact erfc form.
pub fn smith_g1_beckmann_walter(w: Vec3, alpha: f32) -> f32 {
    match beckmann_a(w, alpha, 1.6) {
        Ok(a) => (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a),
        Err(g1) => g1,
    }
}

/// The argument a = cosθ/(α sinθ) of the Beckmann Smith G1 forms, or `Err(G1)` where G1 is
/// decided without it: 0 at or below the horizon, 1 from a ≥ `a_max`. The test a ≥ a_max is
/// made as cosθ ≥ a_max α sinθ, so sinθ = 0 (normal incidence) never divides; below it
/// α sinθ > cosθ/a_max > 0 and a is finite.
fn beckmann_a(w: Vec3, alpha: f32, a_max: f32) -> Result<f32, f32> {
    if w.z <= 0.0 {
        return Err(0.0);
    }
    let s = (w.x * w.x + w.y * w.y).sqrt();
    if w.z >= a_max * alpha * s {
        return Err(1.0);
    }
    Ok(w.z / (alpha * s))
}

/// Exact Smith G1 for GGX, 1/(1 + Λ) with Λ = (√(1 + α² tan²θ) − 1)/2, written as
/// 2 cosθ/(cosθ + √(cos²θ + α² sin²θ)) (no division by cosθ).
pub fn smith_g1_ggx(w: Vec3, alpha: f32) -> f32 {
    if w.z <= 0.0 {
        return 0.0;
    }
    let s2 = w.x * w.x + w.y * w.y;
    let r = (w.z * w.z + alpha * alpha * s2).sqrt();
    2.0 * w.z / (w.z + r)
}

/// Half vector h from tan²θh and u (azimuth 2πu), with cosθh = 1/√(1 + tan²θh) and
/// sinθh = tanθh·cosθh (no 1 − cos² cancellation).
#[inline]
pub fn half_vector_from_tan2(tan2: f32, u: f32) -> Vec3 {
    let cos_t = 1.0 / (1.0 + tan2).sqrt();
    let sin_t = tan2.sqrt() * cos_t;
    let phi = 2.0 * std::f32::consts::PI * u;
    Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
}

/// Beckmann NDF sampling of the half vector (Walter 2007): tan²θh = −α² ln(1 − u₁), φ = 2πu₂.
/// The density is D(h) cosθh w.r.t. solid angle.
pub fn sample_beckmann_h(u: Vec2, alpha: f32) -> Vec3 {
    let tan2 = -alpha * alpha * (1.0 - u.x).max(1e-30).ln();
    half_vector_from_tan2(tan2.max(0.0), u.y)
}

/// GGX NDF sampling of the half vector: tan²θh = α² u₁/(1 − u₁). Density D(h) cosθh.
pub fn sample_ggx_h(u: Vec2, alpha: f32) -> Vec3 {
    let tan2 = alpha * alpha * u.x / (1.0 - u.x).max(1e-30);
    half_vector_from_tan2(tan2, u.y)
}

/// Exact Smith G1 for Beckmann (Heitz 2014, "Understanding the Masking-Shadowing Function in
/// Microfacet-Based BRDFs", JCGT 3(2), eqs. 25 and 43): with a = cosθ/(α sinθ),
/// Λ = (erf(a) − 1)/2 + e^(−a²)/(2a√π) and G1 = 1/(1 + Λ), written with erfc (1 + erf a =
/// 2 − erfc a) and multiplied through by a: G1 = 2a/(a(2 − erfc a) + e^(−a²)/√π). The
/// denominator is ≥ max(a, e^(−a²)/√π) > 0, so no division by 0; 1 from a ≥ 9 (normal
/// incidence included), where 2 − erfc(a) is 2 and e^(−a²)/√π (≤ 4e-36) vanishes beside 2a
/// in f32, so the formula gives exactly 1 there too, without forming subnormal numbers. The visible-normal
/// sampler of [`sample_beckmann_vndf`] draws exactly this G1's density.
pub fn smith_g1_beckmann(w: Vec3, alpha: f32) -> f32 {
    match beckmann_a(w, alpha, 9.0) {
        Ok(a) => {
            let den = a * (2.0 - erfc(a)) + (-a * a).exp() * FRAC_1_SQRT_PI;
            (2.0 * a / den).min(1.0)
        }
        Err(g1) => g1,
    }
}

/// 1/√π.
const FRAC_1_SQRT_PI: f32 = 0.564_189_6;

/// The inverse error function in single precision (Giles 2010, "Approximating the erfinv
/// function", GPU Computing Gems: the single-precision polynomials in w = −ln(1 − x²)). x is
/// clamped to ±(1 − 2⁻²⁴), the largest float below 1, so w is finite (|erfinv| ≤ 3.8).
pub fn erfinv_f(x: f32) -> f32 {
    let x = x.clamp(-ERFINV_MAX, ERFINV_MAX);
    let mut w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        w -= 2.5;
        let mut p = 2.810_226_4e-8;
        p = 3.432_739_4e-7 + p * w;
        p = -3.523_387_7e-6 + p * w;
        p = -4.391_506_5e-6 + p * w;
        p = 0.000_218_580_87 + p * w;
        p = -0.001_253_725 + p * w;
        p = -0.004_177_681_6 + p * w;
        p = 0.246_640_73 + p * w;
        1.501_409_4 + p * w
    } else {
        w = w.sqrt() - 3.0;
        let mut p = -0.000_200_214_26;
        p = 0.000_100_950_56 + p * w;
        p = 0.001_349_343_2 + p * w;
        p = -0.003_673_428_4 + p * w;
        p = 0.005_739_507_7 + p * w;
        p = -0.007_622_461_3 + p * w;
        p = 0.009_438_870_5 + p * w;
        p = 1.001_674 + p * w;
        2.832_976_8 + p * w
    };
    p * x
}

/// The largest float below 1, the clamp of [`erfinv_f`].
pub const ERFINV_MAX: f32 = 1.0 - 1.0 / (1u32 << 24) as f32;

/// Visible-normal sampling of GGX (Heitz 2018, "Sampling the GGX Distribution of Visible
/// Normals", JCGT 7(4), listing in §4): stretch `wo` by α to the α = 1 configuration, sample
/// the projected hemisphere there as a disk whose lower half is squashed by (1 + cosθ)/2, lift
/// the point onto the hemisphere and unstretch. The density of h is the visible-normal
/// distribution D_wo(h) = G1(wo) max(0, wo·h) D(h)/cosθo with the exact G1 ([`smith_g1_ggx`]).
/// `wo.z` > 0.
pub fn sample_ggx_vndf(wo: Vec3, u: Vec2, alpha: f32) -> Vec3 {
    let v = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let len2 = v.x * v.x + v.y * v.y;
    let t1 = if len2 > 0.0 {
        Vec3::new(-v.y, v.x, 0.0) / len2.sqrt()
    } else {
        Vec3::X
    };
    let t2 = v.cross(t1);
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + v.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * (r * phi.sin());
    let n = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * v;
    Vec3::new(alpha * n.x, alpha * n.y, n.z.max(0.0)).normalize()
}

/// Visible-normal sampling of Beckmann (Heitz & d'Eon 2014, "Importance Sampling
/// Microfacet-Based BSDFs using the Distribution of Visible Normals", EGSR, §4: stretch, sample
/// the slopes of the α = 1 distribution seen from the stretched direction, rotate, unstretch),
/// with the slope inversion of [`beckmann_visible_slopes`]. The density of h is D_wo(h) =
/// G1(wo) max(0, wo·h) D(h)/cosθo with the exact G1 ([`smith_g1_beckmann`]). `wo.z` > 0.
pub fn sample_beckmann_vndf(wo: Vec3, u: Vec2, alpha: f32) -> Vec3 {
    let v = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let sin_t = (v.x * v.x + v.y * v.y).sqrt();
    let slope = beckmann_visible_slopes(v.z, sin_t, u);
    // Rotate by the azimuth of wo (that of v), then unstretch.
    let (c, s) = if sin_t > 0.0 {
        (v.x / sin_t, v.y / sin_t)
    } else {
        (1.0, 0.0)
    };
    let sx = alpha * (c * slope.x - s * slope.y);
    let sy = alpha * (s * slope.x + c * slope.y);
    Vec3::new(-sx, -sy, 1.0).normalize()
}

/// The slopes (x, y) of the α = 1 Beckmann distribution of visible normals seen from a
/// direction at θ in the xz-plane (cos, sin given), by the routine of Jakob 2014 ("An Improved
/// Visible Normal Sampling Routine for the Beckmann Distribution"): y = erfinv(2u₂ − 1); x
/// inverts the marginal CDF C(x) ∝ 1 + erf(x) + tanθ e^(−x²)/√π on x < cotθ in the variable
/// b = erf(x), by root-finding steps kept inside a bisection bracket. Two changes from Jakob's
/// routine, which make a sample about a third cheaper (110–122 ns against 175–195 on the gold
/// of the glossy box; docs/bench-log.md, "The Beckmann visible-normal sampler's first guess and
/// Halley steps"):
/// - the first guess is read from a table of the root over (cosθ, √(1 − u₁))
///   ([`beckmann_guess`]), in place of Jakob's fit b_max − (1 + b_max)(1 − u₁)^q(θ), which
///   cost an arccosine and a power (the GLSL twin keeps the fit: on lavapipe a constant table
///   indexed per invocation made the glossy box 1.28x slower; both stop at the same
///   tolerance, so the two backends agree to it, not bit for bit);
/// - each step is Halley's (Press et al. 2007, Numerical Recipes §9.4): the second derivative
///   C''(b) = −norm·tanθ·(√π/2)·e^(x²) costs no more transcendental function, since the step
///   has e^(−x²) already; a Newton step where Halley's denominator is not positive.
///
/// From about 2.9 evaluations of C a sample to 2.0 (`beckmann_vndf_evaluations` in the tests;
/// Halley's steps alone, from Jakob's fit, 2.3).
/// Normal incidence needs no special case: there tanθ = 0, C is linear in b and one step from
/// any guess is exact. GLSL twin: `beckmann_visible_slopes` in `shaders/brdf/common.glsl`.
pub fn beckmann_visible_slopes(cos_t: f32, sin_t: f32, u: Vec2) -> Vec2 {
    beckmann_visible_slopes_counted(cos_t, sin_t, u, &mut 0)
}

/// [`beckmann_visible_slopes`], adding the number of evaluations of C to `evaluations`.
#[inline(always)]
fn beckmann_visible_slopes_counted(cos_t: f32, sin_t: f32, u: Vec2, evaluations: &mut u32) -> Vec2 {
    let view = BeckmannView::new(cos_t, sin_t);
    let BeckmannView {
        tan_t, b_max, norm, ..
    } = view;
    let mut b = beckmann_guess(cos_t, u.x);
    let (mut lo, mut hi) = (-1.0f32, b_max);
    // erf⁻¹(b) of the b that met the tolerance, which the loop has just computed; after the
    // last step without it, of the b that step left.
    let mut converged = None;
    for _ in 0..BECKMANN_VNDF_STEPS {
        if !(b >= lo && b <= hi) {
            b = 0.5 * (lo + hi);
        }
        *evaluations += 1;
        let (x, e, c) = view.cdf(b);
        let value = c - u.x;
        if value.abs() < BECKMANN_VNDF_TOLERANCE {
            converged = Some(x);
            break;
        }
        if value > 0.0 {
            hi = b;
        } else {
            lo = b;
        }
        let slope = norm * (1.0 - x * tan_t);
        // Halley: b − 2·C·C'/(2C'² − C·C''), with C'' = −norm·tanθ·(√π/2)/e^(−x²) (e ≥ e^(−3.8²),
        // as |erf⁻¹| ≤ 3.8, so the quotient is finite).
        let curve = -norm * tan_t * HALF_SQRT_PI / e;
        let den = 2.0 * slope * slope - value * curve;
        b = if slope > 1e-20 && den > 0.0 {
            b - 2.0 * value * slope / den
        } else if slope > 1e-20 {
            b - value / slope
        } else {
            0.5 * (lo + hi)
        };
    }
    let x = converged.unwrap_or_else(|| erfinv_f(b));
    Vec2::new(x, erfinv_f(2.0 * u.y - 1.0))
}

/// The view's terms of [`beckmann_visible_slopes`]' marginal CDF C(b) = norm·(1 + b + k·e^(−x²)),
/// x = erf⁻¹(b), on b ≤ b_max.
struct BeckmannView {
    tan_t: f32,
    /// erf(cotθ), where C reaches 1.
    b_max: f32,
    /// tanθ/√π.
    k: f32,
    /// 1/(1 + b_max + k·e^(−cot²θ)), so that C(b_max) = 1.
    norm: f32,
}

impl BeckmannView {
    #[inline(always)]
    fn new(cos_t: f32, sin_t: f32) -> BeckmannView {
        let tan_t = sin_t / cos_t;
        // cotθ capped at 9 (no infinity at θ = 0): from there erf(cotθ) is 1 and tanθ·e^(−cot²θ)
        // (< 1e-36) vanishes beside 2 in f32, so the cap changes no value, and e^(−81) is still
        // a normal number (e^(−100) was not: subnormal numbers cost Intel cores microcode
        // assists).
        let cot_t = if sin_t * 9.0 >= cos_t {
            cos_t / sin_t
        } else {
            9.0
        };
        let b_max = 1.0 - erfc(cot_t);
        let k = tan_t * FRAC_1_SQRT_PI;
        let norm = 1.0 / (1.0 + b_max + k * (-cot_t * cot_t).exp());
        BeckmannView {
            tan_t,
            b_max,
            k,
            norm,
        }
    }

    /// C(b), with x = erf⁻¹(b) and e^(−x²), which a root-finding step needs too.
    #[inline(always)]
    fn cdf(&self, b: f32) -> (f32, f32, f32) {
        let x = erfinv_f(b);
        let e = (-x * x).exp();
        (x, e, self.norm * (1.0 + b + self.k * e))
    }
}

/// √π/2.
const HALF_SQRT_PI: f32 = 0.886_226_95;

/// Cells of [`BECKMANN_GUESS`] along each of its two axes.
const GUESS_CELLS: u32 = 16;

/// The first guess of [`beckmann_visible_slopes`]: the root b of C(b) = u₁ for the view at
/// cosθ, interpolated bilinearly in (cosθ, √(1 − u₁)) from [`BECKMANN_GUESS`]. In √(1 − u₁)
/// the root is close to linear near u₁ = 1, where C flattens towards b_max (C'(b_max) = 0)
/// and it has a square-root singularity in u₁. Any value is a safe guess (the loop brackets
/// its steps); a NaN cosine reads cell 0 and gives a NaN guess, which the bracket replaces.
#[inline(always)]
fn beckmann_guess(cos_t: f32, u1: f32) -> f32 {
    let n = GUESS_CELLS as f32;
    let fc = cos_t.clamp(0.0, 1.0) * n;
    let fs = (1.0 - u1).max(0.0).sqrt() * n;
    let i = (fc as u32).min(GUESS_CELLS - 1);
    let j = (fs as u32).min(GUESS_CELLS - 1);
    let (a, c) = (fc - i as f32, fs - j as f32);
    let at = |i: u32, j: u32| f32::from_bits(BECKMANN_GUESS[(i * (GUESS_CELLS + 1) + j) as usize]);
    let v0 = at(i, j) + (at(i, j + 1) - at(i, j)) * c;
    let v1 = at(i + 1, j) + (at(i + 1, j + 1) - at(i + 1, j)) * c;
    v0 + (v1 - v0) * a
}

/// The roots b (f32 bits) of C(b) = 1 − s² at cosθ = i/16 (row i; 10⁻³ for row 0) and s = j/16
/// (column j), found by bisection on the f32 functions of [`beckmann_visible_slopes`];
/// `tests::beckmann_guess_table_is_the_roots` regenerates it (and prints it when it differs).
#[rustfmt::skip]
const BECKMANN_GUESS: [u32; 289] = [
    0x3a93e000, 0xbd8e3442, 0xbe0f38cc, 0xbe570f02, 0xbe8f3b7a, 0xbeb2a488,
    0xbed5adce, 0xbef840aa, 0xbf0d2220, 0xbf1dce4c, 0xbf2e14ac, 0xbf3de1e0,
    0xbf4d1db2, 0xbf5ba7d6, 0xbf6950e8, 0xbf75c5d6, 0xbf800000, 0x3d9086e0,
    0xbb7ab880, 0xbda048bc, 0xbe1c3e76, 0xbe680dc2, 0xbe99b298, 0xbebf0ae0,
    0xbee3f662, 0xbf042cc0, 0xbf160aa8, 0xbf278322, 0xbf3880fa, 0xbf48e9cc,
    0xbf589a88, 0xbf675fde, 0xbf74e016, 0xbf800000, 0x3e10cdec, 0x3d81b458,
    0xbc760720, 0xbdbf5f24, 0xbe2fe132, 0xbe7fc20e, 0xbea78e7e, 0xbecedca2,
    0xbef5acbe, 0xbf0dee58, 0xbf20a2b0, 0xbf32dc3e, 0xbf447e48, 0xbf5562ce,
    0xbf655262, 0xbf73ec54, 0xbf800000, 0x3e59e924, 0x3e066ad4, 0x3d497590,
    0xbd0811e8, 0xbded027c, 0xbe4ade74, 0xbe8f6fee, 0xbeb9230a, 0xbee26666,
    0xbf058a2a, 0xbf1980f4, 0xbf2cfe56, 0xbf3fe318, 0xbf520620, 0xbf632bb4,
    0xbf72ebee, 0xbf800000, 0x3e91e792, 0x3e4d13d4, 0x3dead1f8, 0x3ce8d360,
    0xbd6e5318, 0xbe1461c4, 0xbe6d0826, 0xbea2a06e, 0xbece5fec, 0xbef998fa,
    0xbf120e46, 0xbf26d9c8, 0xbf3b0d2a, 0xbf4e7c0c, 0xbf60e628, 0xbf71dc16,
    0xbf800000, 0x3eb76b80, 0x3e8a9226, 0x3e3a1adc, 0x3dbc18d8, 0x3aa39a00,
    0xbdb7cf6c, 0xbe3932c4, 0xbe8b24ea, 0xbeb96c1a, 0xbee740ee, 0xbf0a37e8,
    0xbf205e5a, 0xbf35ef1a, 0xbf4aba42, 0xbf5e7ac8, 0xbf70b954, 0xbf800000,
    0x3edd8ede, 0x3eaf72ae, 0x3e8066c2, 0x3e2137dc, 0x3d810188, 0xbd03fa28,
    0xbe02ed36, 0xbe64f0b2, 0xbea3552e, 0xbed3da14, 0xbf01e72e, 0xbf19783c,
    0xbf307864, 0xbf46b3fe, 0xbf5be0da, 0xbf6f7f48, 0xbf800000, 0x3f0232ba,
    0x3ed54cf6, 0x3ea4ee66, 0x3e670b2c, 0x3e02932c, 0x3ce6e820, 0xbd936192,
    0xbe30af5e, 0xbe8bda26, 0xbebf2720, 0xbef2001a, 0xbf120eb4, 0xbf2a944c,
    0xbf42590a, 0xbf590d40, 0xbf6e284a, 0xbf800000, 0x3f15eaea, 0x3efc36ee,
    0x3ecace82, 0x3e97fc4e, 0x3e48060c, 0x3dbc82b8, 0xbc4deb20, 0xbdf1c84c,
    0xbe6556c6, 0xbea8dbf0, 0xbedebe9e, 0xbf0a0266, 0xbf242838, 0xbf3d9476,
    0xbf55f170, 0xbf6cace6, 0xbf800000, 0x3f29fd42, 0x3f1218ee, 0x3ef22692,
    0x3ebe3726, 0x3e88b5b6, 0x3e23d9a4, 0x3d511370, 0xbd732aa8, 0xbe2ecc02,
    0xbe909862, 0xbec9af9e, 0xbf012a9e, 0xbf1d1146, 0xbf384a74, 0xbf5279ec,
    0xbf6b0300, 0xbf800000, 0x3f3e134c, 0x3f2688c6, 0x3f0d7d92, 0x3ee66096,
    0x3eafa966, 0x3e6e61ac, 0x3df529a8, 0x3b917080, 0xbde639a4, 0xbe6bc2fe,
    0xbeb25d8a, 0xbeeea2ee, 0xbf152098, 0xbf325536, 0xbf4e8bd4, 0xbf691c70,
    0xbf800000, 0x3f51c380, 0x3f3b2902, 0x3f228b22, 0x3f084002, 0x3ed91642,
    0x3e9f4aee, 0x3e4706dc, 0x3d987848, 0xbd444ee8, 0xbe303066, 0xbe982c46,
    0xbed85bb6, 0xbf0c156e, 0xbf2b7f90, 0xbf4a00be, 0xbf66e496, 0xbf800000,
    0x3f642510, 0x3f4f625a, 0x3f37e2a2, 0x3f1e2392, 0x3f028006, 0x3eca81ae,
    0x3e8d48e6, 0x3e1b8d9c, 0x3cc667e0, 0xbdd9b804, 0xbe74925e, 0xbebeb436,
    0xbf019350, 0xbf237bcc, 0xbf449f38, 0xbf643bda, 0xbf800000, 0x3f73871e,
    0x3f620012, 0x3f4cae1a, 0x3f3454c6, 0x3f1971d2, 0x3ef8c72a, 0x3ebaef42,
    0x3e73c80c, 0x3dd88de8, 0xbcfd83f0, 0xbe2f25b2, 0xbea0878e, 0xbeea1fd2,
    0xbf19d1be, 0xbf3e0ba8, 0xbf60ee22, 0xbf800000, 0x3f7d47ae, 0x3f70e456,
    0x3f5f3f02, 0x3f4993ea, 0x3f308c4a, 0x3f149e3a, 0x3eec4dee, 0x3eaaec42,
    0x3e4b4f9c, 0x3d6852f0, 0xbdb9876c, 0xbe781616, 0xbecb4db2, 0xbf0db200,
    0xbf35a146, 0xbf5c9992, 0xbf800000, 0x3f7ff6e4, 0x3f79bb22, 0x3f6d345e,
    0x3f5bd4f6, 0x3f4649a6, 0x3f2d086a, 0x3f106e02, 0x3ee1936e, 0x3e9cc706,
    0x3e2600dc, 0x3c193640, 0xbe1a96ee, 0xbea29c06, 0xbefa6318, 0xbf29cbae,
    0xbf56436a, 0xbf800000, 0x3f800000, 0x3f7e0002, 0x3f780002, 0x3f6e0002,
    0x3f600002, 0x3f4e0002, 0x3f380002, 0x3f1e0002, 0x3f000002, 0x3ebc0002,
    0x3e600004, 0x3d600010, 0xbdfffffc, 0xbea3fffe, 0xbf080000, 0xbf420000,
    0xbf800000,
];

/// Most steps of [`beckmann_visible_slopes`] (from the table's guess one Halley step nearly
/// always meets the tolerance).
pub const BECKMANN_VNDF_STEPS: u32 = 10;
/// |C(b) − u₁| at which [`beckmann_visible_slopes`] stops.
pub const BECKMANN_VNDF_TOLERANCE: f32 = 1e-6;

/// The solid-angle density at `sampled` of a visible-normal half-vector sampler reflecting
/// `given` about h = normalize(given + sampled): D_wo(h)/(4 given·h) = G1(given) D(h)/(4
/// cosθ_given), with `g1` the exact Smith G1 of `given` and `d` = D(h) (Heitz & d'Eon 2014,
/// eq. 17 with Walter et al. 2007's Jacobian). 0 when given·h ≤ 0 (no such h is visible) or
/// `given` is not above the surface. GLSL: the `RETURN_VISIBLE_REFLECTED_PDF` macro.
pub fn visible_reflected_pdf(
    given: Vec3,
    sampled: Vec3,
    g1: f32,
    d: impl FnOnce(Vec3) -> f32,
) -> f32 {
    let h = (given + sampled).normalize();
    if given.dot(h) <= 0.0 || given.z <= 0.0 {
        return 0.0;
    }
    g1 * d(h) / (4.0 * given.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Numbers in [0, 1) from a fixed xorshift sequence (Marsaglia 2003), for the tests' inputs.
    fn uniforms() -> impl FnMut() -> f32 {
        let mut state = 0x9e37_79b9u32;
        move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            (state >> 8) as f32 / (1u32 << 24) as f32
        }
    }

    /// The root b of C(b) = u for the view at cosθ = `cos_t`, by bisection on the f32 functions
    /// of `beckmann_visible_slopes` (to adjacent floats).
    fn beckmann_root(cos_t: f32, u: f32) -> f32 {
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let view = BeckmannView::new(cos_t, sin_t);
        let c = |b: f32| view.cdf(b).2;
        let (mut lo, mut hi) = (-1.0f32, view.b_max);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if c(mid) > u {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        0.5 * (lo + hi)
    }

    /// `BECKMANN_GUESS` holds the roots it says it holds (to 1e-6: the bisection's functions
    /// are libm's, which may round differently on another machine); the table's text is
    /// printed when not, to paste into `common.rs`.
    #[test]
    fn beckmann_guess_table_is_the_roots() {
        let n = GUESS_CELLS;
        let mut bits = Vec::new();
        for i in 0..=n {
            let cos_t = (i as f32 / n as f32).max(1e-3);
            for j in 0..=n {
                let s = j as f32 / n as f32;
                bits.push(beckmann_root(cos_t, 1.0 - s * s).to_bits());
            }
        }
        let text = bits
            .chunks(6)
            .map(|c| {
                let v: Vec<_> = c.iter().map(|b| format!("0x{b:08x}")).collect();
                v.join(", ")
            })
            .collect::<Vec<_>>()
            .join(",\n");
        let far = BECKMANN_GUESS
            .iter()
            .zip(&bits)
            .any(|(&a, &b)| (f32::from_bits(a) - f32::from_bits(b)).abs() > 1e-6);
        assert!(!far, "BECKMANN_GUESS is not the roots; they are:\n{text}");
    }

    /// The GLSL twin's Halley step has the Rust constant.
    #[test]
    fn beckmann_halley_constant_is_the_glsl_twins() {
        let glsl = include_str!("../../shaders/brdf/common.glsl");
        assert!(glsl.contains("const float HALF_SQRT_PI = 0.88622695;"));
        assert_eq!(0.886_226_95f32.to_bits(), HALF_SQRT_PI.to_bits());
        let exact = std::f64::consts::PI.sqrt() / 2.0;
        assert_eq!(HALF_SQRT_PI, exact as f32);
    }

    /// From the table's guess, Halley's steps meet the tolerance in about two evaluations of C
    /// over the views the glossy box's gold sees (α = 0.2 stretches every view towards the
    /// normal) and over views uniform in cosθ, and every sample meets it within the steps.
    #[test]
    fn beckmann_vndf_evaluations() {
        let mut next = uniforms();
        for (alpha, most) in [(0.2f32, 2.15f64), (1.0, 2.15)] {
            let (mut evaluations, samples) = (0u32, 100_000);
            for _ in 0..samples {
                let c0 = next().max(1e-4);
                let v = Vec3::new(alpha * (1.0 - c0 * c0).sqrt(), 0.0, c0).normalize();
                let u = Vec2::new(next(), next());
                let mut count = 0;
                let slope = beckmann_visible_slopes_counted(v.z, v.x, u, &mut count);
                assert!(count < BECKMANN_VNDF_STEPS, "{v} {u}: {count} evaluations");
                assert!(slope.is_finite(), "{v} {u}");
                evaluations += count;
            }
            let mean = evaluations as f64 / samples as f64;
            eprintln!("α {alpha}: {mean:.3} evaluations a sample");
            assert!(mean < most, "α {alpha}: {mean} evaluations a sample");
        }
    }

    #[test]
    fn quarter_sine_and_cosine_are_within_two_ulp() {
        use super::sin_cos_quarter;
        let ulp = |v: f64| (v.abs() as f32).max(f32::MIN_POSITIVE);
        let mut worst = 0f64;
        for k in -100_000..=100_000 {
            let x = (std::f64::consts::FRAC_PI_4 * k as f64 / 100_000.0) as f32;
            let (s, c) = sin_cos_quarter(x);
            let (ws, wc) = ((x as f64).sin(), (x as f64).cos());
            for (got, want) in [(s, ws), (c, wc)] {
                let one_ulp = (ulp(want).next_up() - ulp(want)) as f64;
                let err = (got as f64 - want).abs() / one_ulp;
                worst = worst.max(err);
                assert!(err <= 2.0, "x = {x}: {got} against {want} ({err} ulp)");
            }
        }
        assert!(worst > 0.0);
    }

    /// The one-channel form with branches, as the GLSL twin writes it: the reference that
    /// `fresnel_conductor`'s selects must match bit for bit.
    fn branching_fresnel_conductor1(c: f32, eta: f32, k: f32) -> f32 {
        let c = c.clamp(0.0, 1.0);
        let c2 = c * c;
        let s2 = (1.0 - c2).max(0.0);
        let x = eta * eta - k * k - s2;
        let ek = eta * k;
        let t = (x * x + 4.0 * ek * ek).sqrt();
        let (a2, b2) = if x >= 0.0 {
            let a2 = 0.5 * (t + x);
            (a2, if a2 > 0.0 { ek * ek / a2 } else { 0.0 })
        } else {
            let b2 = 0.5 * (t - x);
            (if b2 > 0.0 { ek * ek / b2 } else { 0.0 }, b2)
        };
        let a = a2.sqrt();
        let ab2 = a2 + b2; // = t
        let rs_num = ab2 - 2.0 * a * c + c2;
        let rs_den = ab2 + 2.0 * a * c + c2;
        let rs = if rs_den > 0.0 { rs_num / rs_den } else { 1.0 };
        let p_num = c2 * ab2 - 2.0 * a * c * s2 + s2 * s2;
        let p_den = c2 * ab2 + 2.0 * a * c * s2 + s2 * s2;
        let rp = if p_den > 0.0 { rs * p_num / p_den } else { rs };
        (0.5 * (rs + rp)).clamp(0.0, 1.0)
    }

    #[test]
    fn conductor_fresnel_in_lanes_is_three_scalar_calls_bit_for_bit() {
        use super::fresnel_conductor;
        use glam::Vec3;
        // η in (0, 100], κ in [0, 100] as the model accepts, and c over [-0.5, 1.5] (clamped).
        let mut next = uniforms();
        let mut values = vec![1e-6, 1e-3, 0.05, 0.5, 1.0, 1.5, 4.0, 100.0];
        values.extend((0..40).map(|_| 10f32.powf(4.0 * next() - 2.0)));
        for &e in &values {
            for &k in values.iter().chain([0.0].iter()).step_by(3) {
                for i in 0..=40 {
                    let c = -0.5 + 2.0 * i as f32 / 40.0;
                    let c = if i % 7 == 3 { next() } else { c };
                    let lanes =
                        fresnel_conductor(c, Vec3::new(e, k.max(1e-6), 1.0), Vec3::new(k, e, 0.0));
                    let one = Vec3::new(
                        branching_fresnel_conductor1(c, e, k),
                        branching_fresnel_conductor1(c, k.max(1e-6), e),
                        branching_fresnel_conductor1(c, 1.0, 0.0),
                    );
                    assert_eq!(
                        lanes.to_array().map(f32::to_bits),
                        one.to_array().map(f32::to_bits),
                        "c {c}, η {e}, κ {k}"
                    );
                }
            }
        }
    }

    #[test]
    fn cosine_samples_on_the_disk_rim_stay_above_the_horizon() {
        // u = 0 in either coordinate is the rim (|a| = 1); it used to give cosθ = 0, pdf 0.
        let top = 1.0 - 1.0 / (1u32 << 24) as f32;
        for k in 0..=64 {
            let v = k as f32 / 64.0 * top;
            for u in [
                Vec2::new(0.0, v),
                Vec2::new(v, 0.0),
                Vec2::new(top, v),
                Vec2::new(v, top),
            ] {
                let w = sample_cosine_hemisphere(u);
                assert!(
                    w.z > 0.0 && cosine_hemisphere_pdf(w.z) > 0.0,
                    "{u:?} -> {w:?}"
                );
                assert!((w.length() - 1.0).abs() < 1e-6, "{u:?} -> {w:?}");
            }
        }
        // Inside the rim nothing changed: the plain formula's value.
        let w = sample_cosine_hemisphere(Vec2::new(0.3, 0.8));
        let plain = (1.0 - w.x * w.x - w.y * w.y).max(0.0).sqrt();
        assert_eq!(w.z, plain);
    }

    /// erfc never returns a subnormal number: below ERFC_ZERO a normal one close to libm's
    /// (f64; the formula's own 1.2e-7, f32's rounding of it, about 10 ulps, and of the
    /// exponent −x², which grows with x²), from it on 0 (2 for negative x).
    #[test]
    fn erfc_is_normal_or_zero() {
        for k in -12_000..=12_000 {
            let x = k as f32 * 1e-3;
            let r = erfc(x);
            assert!(r == 0.0 || r.is_normal(), "erfc({x}) = {r:e}");
            let want = libm::erfc(x as f64);
            if x.abs() < ERFC_ZERO {
                // For x < 0, 2 − erfc(|x|) in f32: an absolute error of a few ulps of 2.
                let err = (r as f64 - want).abs();
                let tol = match x >= 0.0 {
                    true => 6e-7 * (1.0 + (x * x) as f64) * want,
                    false => 5e-7,
                };
                assert!(err < tol, "erfc({x}) = {r:e}, libm {want:e}");
            } else {
                assert_eq!(r, if x > 0.0 { 0.0 } else { 2.0 }, "erfc({x})");
                // 0 only where the true value is at the edge of f32's normal range or below.
                assert!(
                    want < 1.1 * f32::MIN_POSITIVE as f64 || x < 0.0,
                    "erfc({x}) = {want:e}"
                );
            }
        }
    }

    /// The Beckmann G1's cut at a = 9 gives what the formula gives there: exactly 1.
    #[test]
    fn beckmann_g1_is_one_from_its_cut() {
        for k in 0..=1000 {
            let a = 9.0 + k as f32 * 1e-3;
            let den = a * (2.0 - erfc(a)) + (-a * a).exp() * FRAC_1_SQRT_PI;
            assert_eq!((2.0 * a / den).min(1.0), 1.0, "a = {a}");
        }
    }

    #[test]
    fn expm1_and_log1p_match_libm() {
        let mut x = -5.0f64;
        while x < 5.0 {
            for s in [1e-7f64, 1e-4, 1e-2, 1.0] {
                let v = x * s;
                let e = libm::expm1(v);
                assert!(
                    ((expm1_f(v as f32) as f64) - e).abs() <= 4e-7 * e.abs().max(1e-30),
                    "expm1 {v}"
                );
                if v > -0.999 {
                    let l = libm::log1p(v);
                    assert!(
                        ((log1p_f(v as f32) as f64) - l).abs() <= 4e-7 * l.abs().max(1e-30),
                        "log1p {v}"
                    );
                }
            }
            x += 0.0371;
        }
    }

    #[test]
    fn pow_one_minus_is_accurate_for_huge_exponents() {
        // (1 − x)^n for x = 1e-7, n = 1e6: e^{−0.1} ≈ 0.904837 (pow(1 − x, n) in f32 gives 0.89).
        let v = pow_one_minus(1e-7, 1e6) as f64;
        let exact = (1e6 * libm::log1p(-1e-7)).exp();
        assert!((v - exact).abs() < 1e-6, "{v} vs {exact}");
        assert_eq!(pow_one_minus(1.0, 5.0), 0.0);
        assert_eq!(pow_one_minus(0.5, 0.0), 1.0);
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(0.6, 0.0, 0.8),
            Vec3::new(-0.36, 0.48, -0.8),
            Vec3::X,
        ] {
            let (t, b) = orthonormal_basis(n);
            assert!(t.dot(b).abs() < 1e-6 && t.dot(n).abs() < 1e-6 && b.dot(n).abs() < 1e-6);
            assert!((t.length() - 1.0).abs() < 1e-6 && (b.length() - 1.0).abs() < 1e-6);
            assert!((t.cross(b) - n).length() < 1e-5);
        }
    }
}
