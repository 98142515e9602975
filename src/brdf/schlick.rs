//! Schlick 1994, "An Inexpensive BRDF Model for Physically-based Rendering": single
//! (homogeneous) and double (heterogeneous, two-layer) materials. Survey eqs. 18–26.
//!
//! | parameter | unit | default | range | meaning | texture: GPU record |
//! |---|---|---|---|---|---|
//! | `c` | RGB | `[0.8, 0.8, 0.8]` | [0, 1] | C_λ, reflectance at normal incidence (eq. 18's f_λ) | `p[0].xyz` |
//! | `r` | — | `0.2` | [0, 1] | roughness: 0 mirror, 0.5 purely glossy, 1 Lambertian (continuum form) | `p[0].w` |
//! | `p` | — | `1` | [0, 1] | isotropy: 1 isotropic, → 0 fully anisotropic (clamped to ≥ 1e-3 inside A) | `p[2].x` |
//! | `c2` | RGB | `[0.5, 0.5, 0.5]` | [0, 1] | C_λ of the second (lower) layer of eq. 22; giving `c2` makes the material heterogeneous | `p[1].xyz` |
//! | `r2` | — | `1` | [0, 1] | roughness of the second layer (needs `c2`) | `p[1].w` |
//! | `p2` | — | `1` | [0, 1] | isotropy of the second layer (needs `c2`) | `p[2].y` |
//! | `form` | — | `"continuum"` | `basic`, `attenuated`, `continuum` | the directional factor D (eqs. 24, 25, 26) | — |
//! | `rotation` | degrees | `0` | [-360, 360] | rotation of the anisotropy axis (tangent x) about the normal | `p[3].xy` (cos, sin) |
//!
//! The survey gives no numerical defaults; the defaults are a light-grey, fairly glossy
//! isotropic single material in Schlick's final (eq. 26) form.
//!
//! **Factors** (t = cosθh = n·h, u = wi·h, v = cosθi, v' = cosθo, w = cos of the azimuth of h
//! from the tangent x, all with h the unit half vector):
//! * S(u) = C + (1 − C)(1 − u)⁵ (eq. 18). The survey writes u = V·L; Schlick's u is the
//!   angle to the microfacet normal, u = V·H, which also keeps the model reciprocal.
//! * Z(t) = r/(1 + r t² − t²)², evaluated as r/(hx² + hy² + r hz²)². The survey's eq. 24 drops
//!   the r in the numerator; without it ∫Z(t)·2t dt = 1/r and the lobe is 1/r too bright (with
//!   it, Z/π is exactly the GGX NDF with α² = r). The survey's remark that r = 0 is Lambertian
//!   and r = 1 specular is also reversed; its own parameter description (r = 0 perfect
//!   specular) is the one used.
//! * A(w) = √(p/(p² − p²w² + w²)). The survey prints p² + p²w² + w²; with that sign p = 1 is
//!   not even isotropic (A = 1/√(1 + 2w²)). Schlick's (and every port's) minus sign gives the
//!   denominator p² sin²φ + cos²φ > 0 and A ≡ 1 at p = 1. A is not normalised: its mean over φ is 0.971 at p = 0.5 and
//!   0.381 at p = 0.01, so anisotropic materials lose that energy (as in the paper). At the
//!   pole (h = n) the azimuth is undefined and A = 1 is used.
//! * G(v) = v/(r − rv + v) (eq. 20 with k = r: Schlick's own choice inside the model), used in
//!   the simplified product G(v)G(v')/(4π v v') = 1/(4π (r + (1−r)v)(r + (1−r)v')) (as RISE),
//!   which has no 0·∞ at grazing.
//! * r is clamped to ≥ [`R_MIN`] = 1e-4 inside Z and G (GGX α ≥ 0.01).
//!
//! **Forms** (one layer's D; how each is read from the survey):
//! * `basic`, eq. 24: D = Z(t)A(w)/(4π v v'). No shadowing: like Dür's Ward it diverges at
//!   grazing angles (albedo ~ 1/v), not energy conserving. No delta lobe (r → 0 is a narrow
//!   lobe at the clamped r).
//! * `attenuated`, eq. 25 exactly as the survey prints it:
//!   D = G(v)G(v')Z A/(4π v v') + (1 − G(v)G(v'))/(4π v v'). The second term is Schlick's
//!   re-emission of the light the facets block, written by the survey with the same 1/(4π v v')
//!   as the first; it grows like 1/(v v') at grazing angles, so this form is not energy
//!   conserving either (the albedo diverges like 1/v). (Some ports use (1 − GG')/π there,
//!   which is bounded; that is not what the survey writes.)
//! * `continuum`, eq. 26 (the default): D = a/π + b·B + c·δ_mirror, B = G(v)G(v')Z A/(4π v v')
//!   (the "Beckmann-like factor" of eq. 25's first term; the a/π term takes the place of the
//!   re-emission term), b = 4r(1 − r), and a = 0, c = 1 − b for r < 0.5, a = 1 − b, c = 0
//!   otherwise: r = 0 is a mirror, r = 0.5 purely glossy, r = 1 Lambertian. The c term is a
//!   delta lobe with reflectance S(cosθ)·c. Its albedo (B alone, C = 1, p = 1, by quadrature
//!   in tests/brdf_schlick.rs) shows that because Schlick's G exceeds Smith at grazing
//!   angles for r < 0.25 the glossy lobe reflects up to 1.90 at 89° for r = 0.005, i.e. the
//!   model is not strictly energy conserving there; elsewhere it is ≤ 1.
//!
//! Single material: f = S(u)·D (eq. 22 top). Double material: f = S(u)·D + (1 − S(u))·S'(u)·D'
//! (eq. 22 bottom) with D' from (r2, p2) and S' from c2, the same form. Every form is
//! reciprocal (u = wi·h = wo·h; Z, A, G products symmetric).
//!
//! **Sampling**: from the known direction μ = cosθ_given the lobes get weights
//! luminance(S(μ))·{b, a (or 1 − G(μ) for the attenuated re-emission), c} for layer 1 and the
//! same with (1 − S(μ))·S'(μ) for layer 2. The glossy lobes sample t exactly as Schlick
//! (t² = x/(r − rx + x), identical to GGX with α² = r) and the azimuth exactly from the
//! normalised non-square-root density A²/(2π) (quadrant CDF (2/π)·atan(p tanφ)), so the half
//! vector density is Z(t)·t·A²/π and pdf = that/(4 given·h): the true density of the sampler,
//! with A (not A²) left in the weight. The continuum's a/π lobe is cosine-sampled; the
//! attenuated form's re-emission is sampled uniformly over the hemisphere (its 1/v' makes
//! cosine sampling infinite-variance). pdf = Σ P_lobe pdf_lobe with Σ P = 1 − P_delta.
//!
//! GPU record: p[0..3] c, p[3] r, p[4..7] c2, p[7] r2, p[8] p, p[9] p2, p[10] form
//! (0 basic, 1 attenuated, 2 continuum), p[11] layered (0/1), p[12] cos(rotation),
//! p[13] sin(rotation). Defines: `SCHLICK_LAYERED` (second layer), `SCHLICK_ANISOTROPIC`
//! (p < 1 or p2 < 1; without it A ≡ 1, exact for isotropic materials).

use super::common::{
    cosine_hemisphere_pdf, luminance, reflect_about, reflected_pdf, same_hemisphere_up,
    sample_cosine_hemisphere,
};
use super::{flag, Brdf, BrdfSample, Param, ParamError, ParamReader, Params, Representative};
use glam::{Vec2, Vec3, Vec4};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, PI};
use std::sync::Arc;

/// Smallest roughness used inside Z and G.
pub const R_MIN: f32 = 1e-4;
/// Smallest isotropy used inside A.
pub const P_MIN: f32 = 1e-3;

#[derive(Clone, Debug, PartialEq)]
pub struct Schlick {
    pub c: Vec3,
    pub r: f32,
    pub p: f32,
    pub c2: Vec3,
    pub r2: f32,
    pub p2: f32,
    /// The heterogeneous (two-layer) material of eq. 22 (`c2` given).
    pub layered: bool,
    pub form: Form,
    /// Degrees.
    pub rotation: f32,
}

choice_enum! {
    pub enum Form {
        /// Eq. 24.
        Basic = "basic" => "SCHLICK_BASIC",
        /// Eq. 25.
        Attenuated = "attenuated" => "SCHLICK_ATTENUATED",
        /// Eq. 26.
        Continuum = "continuum" => "SCHLICK_CONTINUUM",
    }
}

impl Default for Schlick {
    fn default() -> Self {
        Schlick {
            c: Vec3::splat(0.8),
            r: 0.2,
            p: 1.0,
            c2: Vec3::splat(0.5),
            r2: 1.0,
            p2: 1.0,
            layered: false,
            form: Form::Continuum,
            rotation: 0.0,
        }
    }
}

declare_model! {
    survey: "eqs. 18–26";
    params: {
        C = rgb("c", "RGB", [0.8; 3], (0.0, 1.0), "C_λ, reflectance at normal incidence (eq. 18's f_λ)").at(0);
        R = scalar("r", "—", 0.2, (0.0, 1.0), "roughness: 0 mirror, 0.5 purely glossy, 1 Lambertian (continuum form)").at(3);
        P = scalar("p", "—", 1.0, (0.0, 1.0), "isotropy: 1 isotropic, → 0 fully anisotropic (clamped to ≥ 1e-3 inside A)").at(8);
        C2 = rgb("c2", "RGB", [0.5; 3], (0.0, 1.0), "C_λ of the second (lower) layer of eq. 22; giving `c2` makes the material heterogeneous").at(4);
        R2 = scalar("r2", "—", 1.0, (0.0, 1.0), "roughness of the second layer (needs `c2`)").at(7);
        P2 = scalar("p2", "—", 1.0, (0.0, 1.0), "isotropy of the second layer (needs `c2`)").at(9);
        FORM = choice("form", Form::NAMES, Form::Continuum.name(), "the directional factor D (eqs. 24, 25, 26)");
        ROTATION = scalar("rotation", "degrees", 0.0, (-360.0, 360.0), "rotation of the anisotropy axis (tangent x) about the normal").angle_at(12);
    }
    representative: Representative::One(r#"model = "schlick", c = 0.8, r = 0.1, p = 1.0"#);
    record_codes: [Form];
}

pub fn parse(r: &mut ParamReader) -> Result<Arc<dyn Brdf>, ParamError> {
    let c = r.rgb_of(&C)?;
    let rough = r.scalar_of(&R)?;
    let p = r.scalar_of(&P)?;
    let layered = r.has("c2");
    for key in ["r2", "p2"] {
        if r.has(key) && !layered {
            return Err(r.error(
                key,
                "belongs to the second layer of the heterogeneous material: give its reflectance c2 too",
            ));
        }
    }
    let c2 = r.rgb_of(&C2)?;
    let r2 = r.scalar_of(&R2)?;
    let p2 = r.scalar_of(&P2)?;
    let form = r.choice_of(&FORM)?;
    let rotation = r.scalar_of(&ROTATION)?;
    if p < P_MIN || (layered && p2 < P_MIN) {
        let key = if p < P_MIN { "p" } else { "p2" };
        r.warn(
            key,
            format!("isotropy below {P_MIN} is clamped to {P_MIN} (A(w) ~ p^(-1/2))"),
        );
    }
    if form != Form::Continuum {
        r.warn(
            "form",
            "the survey's eq. 24/25 forms are not energy conserving: their albedo grows without \
             bound toward grazing angles (form = \"continuum\" is bounded except near 89° for r < 0.25)",
        );
    }
    Ok(Arc::new(Schlick {
        c,
        r: rough,
        p,
        c2,
        r2,
        p2,
        layered,
        form,
        rotation,
    }))
}

/// S(u) = C + (1 − C)(1 − u)⁵ (eq. 18).
pub fn spectral(c: Vec3, u: f32) -> Vec3 {
    let m = (1.0 - u.clamp(0.0, 1.0)).clamp(0.0, 1.0);
    let m2 = m * m;
    c + (Vec3::ONE - c) * (m2 * m2 * m)
}

/// (a, b, c) of eq. 26 for roughness r.
pub fn continuum_coeffs(r: f32) -> (f32, f32, f32) {
    let b = 4.0 * r * (1.0 - r);
    if r < 0.5 {
        (0.0, b, 1.0 - b)
    } else {
        (1.0 - b, b, 0.0)
    }
}

/// Z(t) = r/(1 + r t² − t²)² for the unit half vector h (r clamped to ≥ R_MIN).
pub fn zenith(r: f32, h: Vec3) -> f32 {
    let r = r.max(R_MIN);
    let d = h.x * h.x + h.y * h.y + r * h.z * h.z;
    if d <= 0.0 {
        return 0.0;
    }
    r / (d * d)
}

/// A(w)² = p/(p² − p²w² + w²) for the unit half vector h, the tangent rotated by (cs, sn)
/// (p clamped to ≥ P_MIN; 1 at the pole).
pub fn azimuth2(p: f32, cs: f32, sn: f32, h: Vec3) -> f32 {
    let p = p.max(P_MIN);
    let s2 = h.x * h.x + h.y * h.y;
    if s2 <= 1e-20 {
        return 1.0;
    }
    let hx = h.x * cs + h.y * sn;
    let hy = h.y * cs - h.x * sn;
    p * s2 / (p * p * hy * hy + hx * hx)
}

/// q(v) = r + (1 − r)v = v/G(v).
#[inline]
fn q_of(r: f32, v: f32) -> f32 {
    let r = r.max(R_MIN);
    r + (1.0 - r) * v
}

/// G(v) = v/(r − rv + v) (eq. 20 with k = r).
pub fn shadow_g(r: f32, v: f32) -> f32 {
    v / q_of(r, v)
}

/// The glossy lobe B = G(v)G(v')Z(t)A(w)/(4π v v') = Z A/(4π q(v) q(v')) of one layer.
pub fn glossy(r: f32, p: f32, cs: f32, sn: f32, wi: Vec3, wo: Vec3, h: Vec3) -> f32 {
    zenith(r, h) * azimuth2(p, cs, sn, h).sqrt() / (4.0 * PI * q_of(r, wi.z) * q_of(r, wo.z))
}

/// One layer's non-delta D(t, v, v', w) for `form` (eqs. 24–26), without S. (The argument
/// list mirrors the GLSL twin `schlick_layer_d`.)
#[allow(clippy::too_many_arguments)]
pub fn layer_d(form: Form, r: f32, p: f32, cs: f32, sn: f32, wi: Vec3, wo: Vec3, h: Vec3) -> f32 {
    let vv = (wi.z * wo.z).max(1e-20);
    match form {
        Form::Basic => zenith(r, h) * azimuth2(p, cs, sn, h).sqrt() / (4.0 * PI * vv),
        Form::Attenuated => {
            let gg = shadow_g(r, wi.z) * shadow_g(r, wo.z);
            glossy(r, p, cs, sn, wi, wo, h) + (1.0 - gg).max(0.0) / (4.0 * PI * vv)
        }
        Form::Continuum => {
            let (a, b, _) = continuum_coeffs(r);
            let mut d = a * FRAC_1_PI;
            if b > 0.0 {
                d += b * glossy(r, p, cs, sn, wi, wo, h);
            }
            d
        }
    }
}

impl Schlick {
    /// (cos, sin) of the rotation of the anisotropy axis.
    pub fn rotation_cs(&self) -> (f32, f32) {
        let (s, c) = self.rotation.to_radians().sin_cos();
        (c, s)
    }
}

/// f_r (eq. 22, with eq. 24/25/26 D); the mirror delta is not seen.
pub fn eval(m: &Schlick, wi: Vec3, wo: Vec3) -> Vec3 {
    if !same_hemisphere_up(wi, wo) {
        return Vec3::ZERO;
    }
    let (cs, sn) = m.rotation_cs();
    let h = (wi + wo).normalize();
    let u = wi.dot(h);
    let s1 = spectral(m.c, u);
    let mut f = s1 * layer_d(m.form, m.r, m.p, cs, sn, wi, wo, h);
    if m.layered {
        let s2 = (Vec3::ONE - s1) * spectral(m.c2, u);
        f += s2 * layer_d(m.form, m.r2, m.p2, cs, sn, wi, wo, h);
    }
    f
}

/// Lobe weights of one layer for the known direction: (glossy, diffuse-like, delta).
fn layer_weights(form: Form, r: f32, s: f32, mu: f32) -> (f32, f32, f32) {
    match form {
        Form::Basic => (s, 0.0, 0.0),
        Form::Attenuated => {
            let g = shadow_g(r, mu);
            (s * g, s * (1.0 - g), 0.0)
        }
        Form::Continuum => {
            let (a, b, c) = continuum_coeffs(r);
            (s * b, s * a, s * c)
        }
    }
}

/// Selection probabilities for the known direction:
/// [glossy layer 1, glossy layer 2, diffuse-like, delta].
pub fn lobe_probabilities(m: &Schlick, given: Vec3) -> [f32; 4] {
    let s1 = spectral(m.c, given.z);
    let (g1, d1, m1) = layer_weights(m.form, m.r, luminance(s1), given.z);
    let (mut g2, mut d2, mut m2) = (0.0, 0.0, 0.0);
    if m.layered {
        let s2 = (Vec3::ONE - s1) * spectral(m.c2, given.z);
        (g2, d2, m2) = layer_weights(m.form, m.r2, luminance(s2), given.z);
    }
    let total = g1 + g2 + d1 + d2 + m1 + m2;
    if total <= 0.0 {
        return [1.0, 0.0, 0.0, 0.0];
    }
    [g1 / total, g2 / total, (d1 + d2) / total, (m1 + m2) / total]
}

/// The delta lobe's reflectance: S(cosθ)·c + (1 − S)·S'·c' (continuum form only).
pub fn mirror_reflectance(m: &Schlick, given: Vec3) -> Vec3 {
    if m.form != Form::Continuum {
        return Vec3::ZERO;
    }
    let s1 = spectral(m.c, given.z);
    let mut f = s1 * continuum_coeffs(m.r).2;
    if m.layered {
        f += (Vec3::ONE - s1) * spectral(m.c2, given.z) * continuum_coeffs(m.r2).2;
    }
    f
}

/// Sample the glossy half vector: t from GGX with α² = r (Schlick's t = √(x/(r − rx + x))),
/// the azimuth from the normalised density A²/(2π) in the rotated frame.
pub fn sample_glossy_h(r: f32, p: f32, cs: f32, sn: f32, u: Vec2) -> Vec3 {
    let r = r.max(R_MIN);
    let p = p.max(P_MIN);
    let tan2 = r * u.x / (1.0 - u.x).max(1e-30);
    let cos_t = 1.0 / (1.0 + tan2).sqrt();
    let sin_t = tan2.sqrt() * cos_t;
    let v = 4.0 * u.y;
    let quadrant = v.floor().min(3.0);
    let uq = v - quadrant;
    let a = uq * FRAC_PI_2;
    let phi0 = a.sin().atan2(p * a.cos());
    let phi = if quadrant < 0.5 {
        phi0
    } else if quadrant < 1.5 {
        PI - phi0
    } else if quadrant < 2.5 {
        PI + phi0
    } else {
        2.0 * PI - phi0
    };
    let (sp, cp) = phi.sin_cos();
    // Rotate from the anisotropy frame back to the local frame.
    let x = cp * cs - sp * sn;
    let y = sp * cs + cp * sn;
    Vec3::new(sin_t * x, sin_t * y, cos_t)
}

/// Solid-angle density of `sampled` under one glossy sampler: Z t A²/π/(4 given·h).
pub fn glossy_pdf(r: f32, p: f32, cs: f32, sn: f32, given: Vec3, sampled: Vec3) -> f32 {
    reflected_pdf(given, sampled, |h| {
        zenith(r, h) * h.z * azimuth2(p, cs, sn, h) * FRAC_1_PI
    })
}

/// Uniform hemisphere direction, pdf 1/(2π) (for the attenuated form's re-emission).
pub fn sample_uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = 1.0 - u.x;
    let s = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(s * phi.cos(), s * phi.sin(), z)
}

pub fn pdf(m: &Schlick, given: Vec3, sampled: Vec3) -> f32 {
    if !same_hemisphere_up(given, sampled) {
        return 0.0;
    }
    let (cs, sn) = m.rotation_cs();
    let pr = lobe_probabilities(m, given);
    let mut p = 0.0;
    if pr[0] > 0.0 {
        p += pr[0] * glossy_pdf(m.r, m.p, cs, sn, given, sampled);
    }
    if pr[1] > 0.0 {
        p += pr[1] * glossy_pdf(m.r2, m.p2, cs, sn, given, sampled);
    }
    if pr[2] > 0.0 {
        let pd = if m.form == Form::Attenuated {
            0.5 * FRAC_1_PI
        } else {
            cosine_hemisphere_pdf(sampled.z)
        };
        p += pr[2] * pd;
    }
    p
}

pub fn sample(m: &Schlick, given: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
    if given.z <= 0.0 {
        return None;
    }
    let (cs, sn) = m.rotation_cs();
    let pr = lobe_probabilities(m, given);
    let wi = if u_lobe < pr[3] {
        let weight = mirror_reflectance(m, given) / pr[3];
        return Some(BrdfSample::mirror(given, weight));
    } else if u_lobe < pr[3] + pr[0] + pr[1] {
        let h = if u_lobe < pr[3] + pr[0] {
            sample_glossy_h(m.r, m.p, cs, sn, u)
        } else {
            sample_glossy_h(m.r2, m.p2, cs, sn, u)
        };
        reflect_about(given, h)?
    } else if m.form == Form::Attenuated {
        sample_uniform_hemisphere(u)
    } else {
        sample_cosine_hemisphere(u)
    };
    BrdfSample::scattered(wi, |wi| pdf(m, given, wi), |wi| eval(m, wi, given))
}

impl_brdf!(Schlick {
    fn with_params(&self, v: &super::textured::ParamValues) -> Arc<dyn Brdf> {
        Arc::new(Schlick {
            c: v.rgb(&C, self.c),
            r: v.scalar(&R, self.r),
            p: v.scalar(&P, self.p),
            c2: v.rgb(&C2, self.c2),
            r2: v.scalar(&R2, self.r2),
            p2: v.scalar(&P2, self.p2),
            rotation: v.scalar(&ROTATION, self.rotation),
            ..self.clone()
        })
    }
    /// A textured isotropy may fall below 1 anywhere: the anisotropic factor is compiled in.
    fn textured_defines(&self, textured: &[&str]) -> Vec<&'static str> {
        let mut d = self.defines();
        if (textured.contains(&"p") || textured.contains(&"p2")) && !d.contains(&"SCHLICK_ANISOTROPIC") {
            d.push("SCHLICK_ANISOTROPIC");
        }
        d
    }
    fn pack(&self) -> Params {
        let (cs, sn) = self.rotation_cs();
        let form = self.form.code();
        Params::from_vec4s([
            self.c.extend(self.r),
            self.c2.extend(self.r2),
            Vec4::new(self.p, self.p2, form, flag(self.layered)),
            Vec4::new(cs, sn, 0.0, 0.0),
        ])
    }
    fn defines(&self) -> Vec<&'static str> {
        let mut d = Vec::new();
        if self.layered {
            d.push("SCHLICK_LAYERED");
        }
        if self.p < 1.0 || (self.layered && self.p2 < 1.0) {
            d.push("SCHLICK_ANISOTROPIC");
        }
        d
    }
    fn scatters(&self) -> bool {
        self.c != Vec3::ZERO || (self.layered && self.c2 != Vec3::ZERO)
    }
});

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brdf::common::reflect_z;
    use crate::brdf::validate::{assert_finite_on_sample_grid, dir_from_theta_deg as dir};

    #[test]
    fn finite_at_edges() {
        let mut ms = Vec::new();
        for form in [Form::Basic, Form::Attenuated, Form::Continuum] {
            for (r, p) in [(0.0, 1.0), (1e-5, 0.0), (0.3, 0.01), (0.5, 1.0), (1.0, 0.5)] {
                ms.push(Schlick {
                    r,
                    p,
                    form,
                    rotation: 30.0,
                    ..Default::default()
                });
                ms.push(Schlick {
                    r,
                    p,
                    form,
                    layered: true,
                    r2: 1.0 - r,
                    p2: p,
                    ..Default::default()
                });
            }
        }
        for m in &ms {
            assert_finite_on_sample_grid(m, &[0.0, 0.3, 0.6, 0.99], &format!("{m:?}"));
        }
    }

    #[test]
    fn zenith_is_ggx_and_azimuth_sampler_covers_all_quadrants() {
        // Z/π = GGX with α² = r.
        let h = dir(20.0, 10.0);
        let r = 0.09f32;
        let ggx = super::super::common::ggx_d(h, r.sqrt());
        assert!((zenith(r, h) / PI / ggx - 1.0).abs() < 1e-5);
        let mut quad = [0u32; 4];
        for i in 0..400 {
            let h = sample_glossy_h(0.3, 0.2, 1.0, 0.0, Vec2::new(0.5, (i as f32 + 0.5) / 400.0));
            let phi = h.y.atan2(h.x).rem_euclid(2.0 * PI);
            quad[(phi / FRAC_PI_2) as usize % 4] += 1;
        }
        assert_eq!(quad, [100; 4]);
    }

    #[test]
    fn r_zero_continuum_is_a_mirror() {
        let m = Schlick {
            r: 0.0,
            c: Vec3::splat(0.3),
            ..Default::default()
        };
        let given = dir(50.0, 0.0);
        let s = sample(&m, given, 0.5, Vec2::splat(0.3)).unwrap();
        assert!(s.delta);
        let want = spectral(m.c, given.z);
        assert!((s.weight - want).abs().max_element() < 1e-6);
        assert_eq!(eval(&m, given, reflect_z(given)), Vec3::ZERO);
    }
}
