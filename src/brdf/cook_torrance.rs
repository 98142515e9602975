//! Cook–Torrance (1982): microfacet specular lobe plus an optional Lambertian diffuse lobe.
//! Survey eqs. 6 (Beckmann D), 7 (dielectric Fresnel), 8 (V-cavity G) and 9 (the BRDF).
//!
//! | parameter | unit | default | range | meaning | texture: GPU record |
//! |---|---|---|---|---|---|
//! | `kd` | RGB | `[0, 0, 0]` | [0, 1] | Lambertian diffuse albedo (survey: "simply adding" a diffuse part) | `p[0].xyz` |
//! | `ks` | RGB | `[1, 1, 1]` | [0, 1] | scale of the specular lobe | `p[1].xyz` |
//! | `roughness` | rms slope m | `0.3` | [0, 4] | Beckmann m = GGX α; below 1e-3 the lobe is a delta mirror | `p[0].w` |
//! | `distribution` | — | `"beckmann"` | `beckmann`, `ggx` | microfacet NDF (`beckmann`: survey eq. 6) | — |
//! | `geometry` | — | `"v_cavity"` | `v_cavity`, `smith` | masking-shadowing G (`v_cavity`: survey eq. 8) | — |
//! | `fresnel` | — | `"dielectric"` | `dielectric`, `conductor`, `schlick` | Fresnel term at c = wi·h (`dielectric`: survey eq. 7; `conductor`: the exact formula) | — |
//! | `ior` | — | `1.5` | [1, 100] | relative index, `fresnel = "dielectric"` (eq. 7) | `p[2].x` |
//! | `eta` | RGB | `[0.143036, 0.375307, 1.44205]` | (0, 100] | real part η of the complex index η + iκ, `fresnel = "conductor"` (default gold-like) | `p[2].xyz` |
//! | `k` | RGB | `[3.983, 2.38556, 1.60336]` | [0, 100] | imaginary part κ of the complex index, `fresnel = "conductor"` | `p[3].xyz` |
//! | `f0` | RGB | `[0.04, 0.04, 0.04]` | [0, 1] | normal-incidence reflectance, `fresnel = "schlick"` | `p[2].xyz` |
//! | `normalization` | — | `"survey"` | `survey`, `walter` | the specular denominator: `survey` (eq. 9) or `walter`, see below | — |
//!
//! f_r = kd/π + ks · F(wi·h) · D(h) · G · N / (4 cosθi cosθo), with D normalised
//! (∫ D cosθh dω = 1) and N = 4 for `survey`, N = 1 for `walter`.
//!
//! **The survey's form (the default) is 4× too bright.** Eq. 9 reads f = (F/π)·D·G/(cosθi cosθo)
//! with the *un-normalised* Beckmann of eq. 6, whose integral ∫ D cosθh dω is π, not 1. Writing
//! D₆ = π·D, eq. 9 is F·D·G/(cosθi cosθo) = 4 × the Torrance–Sparrow / Walter et al. 2007 BRDF
//! F·D·G/(4 cosθi cosθo): with F = 1 and m = 0.1 it reflects 4.0 times the incident energy at
//! normal incidence (Walter et al. 2007, eq. 20; quadrature in tests/brdf_cook_torrance.rs). `normalization = "walter"` divides by 4 and is
//! energy-conserving for kd + ks ≤ 1 (the specular albedo is ≤ F ≤ 1). For `ggx` the survey
//! form uses π·D_GGX in place of eq. 6, so the ratio survey/walter is exactly 4 for both NDFs.
//! Both forms are reciprocal (F depends on wi·h = wo·h, D and G are symmetric).
//!
//! `geometry = "smith"` is the separable G1(wi)·G1(wo): for Beckmann G1 is Walter et al. 2007's
//! rational approximation (within 0.35 % of exact), for GGX the exact G1. `v_cavity` is eq. 8,
//! min(1, 2 cosθh cosθo/(wo·h), 2 cosθh cosθi/(wi·h)). The Cornell box's glossy material
//! (`cornell_box.json`, `gold_rough`) is `distribution = "beckmann"`, `roughness = 0.2`
//! (its `roughness_alpha`), `geometry = "smith"`, `fresnel = "conductor"` with its `eta`, `k`,
//! `normalization = "walter"`, `kd = 0`, `ks = 1`.
//!
//! Roughness below [`MIRROR_ROUGHNESS`] (1e-3, as pbrt-v4) makes the specular lobe a delta
//! mirror with weight ks·F(cosθ)·N (N = 4 for `survey`: the m → 0 limit of eq. 9, G → 1).
//!
//! Sampling: with probability P_s (∝ luminance(ks·F(cosθ_given))·N against luminance(kd),
//! clamped to [0.1, 0.9] when both lobes exist) a half vector h, reflecting `given` about it;
//! otherwise a cosine-weighted direction. Reflected samples below the horizon are rejected
//! (weight 0), never renormalised; with the delta mirror, P_s is P_delta and pdf =
//! (1 − P_delta)·cosθ/π. The half vector ([`Sampler`], [`CookTorrance::sampler`]):
//!
//! | geometry | h drawn from | pdf of the reflected direction |
//! |---|---|---|
//! | `smith` | visible normals D_wo(h) = G1(wo) max(0, wo·h) D(h)/cosθo (Beckmann: Heitz & d'Eon 2014 with Jakob 2014's inversion; GGX: Heitz 2018) | P_s·G1(wo) D(h)/(4 cosθo) + (1 − P_s)·cosθ/π |
//! | `v_cavity` | D(h) cosθh (Beckmann: tan²θh = −m² ln(1−u); GGX: tan²θh = α² u/(1−u)) | P_s·D(h) cosθh/(4 wo·h) + (1 − P_s)·cosθ/π |
//!
//! wo is `given`; G1 is the *exact* Smith G1 of the distribution ([`exact_g1`]: for Beckmann
//! the erfc form, not the rational approximation the BRDF's `smith` G uses), because that is
//! the density the visible-normal sampler draws. Both samplers are valid for every variant; the
//! choice is by the variance of one sample's weight f·cosθ/pdf (`tests/brdf_cook_torrance.rs`,
//! `visible_normals_lower_the_weight_variance`, θ = 0°–89°, m = 0.05–0.5, kd = 0 and 0.3).
//! With `smith` the visible normals divide it, summed over the angles, by 4–60 (ratio
//! 0.016–0.23) and never raise it at any angle (the weight is F·G1(wi) at most). With
//! `v_cavity` (weight F·G/G1(wo), and G is not Smith's) they raise it at grazing incidence
//! (89°: ×1.3 for Beckmann m = 0.5, ×1.6–2.5 for GGX m = 0.2–0.5; over all angles ×1.29 for
//! GGX m = 0.5), so `v_cavity` keeps D(h) cosθh. The normalisation does not change the choice
//! (`survey` is `walter` times 4; only P_s differs).
//!
//! GPU record (`p[k]`, `vec4 p[7]` in GLSL as p[k/4][k%4]):
//! p[0..3] kd, p[3] roughness, p[4..7] ks, p[7] N (4 survey, 1 walter),
//! p[8..11] Fresnel parameter A (dielectric: ior in all three; conductor: η; schlick: f0),
//! p[11] distribution (0 beckmann, 1 ggx), p[12..15] κ (conductor), p[15] geometry
//! (0 v_cavity, 1 smith), p[16] fresnel (0 dielectric, 1 conductor, 2 schlick), p[17] the
//! half-vector sampler (0 D(h) cosθh, 1 visible normals; from the geometry, on the host).

use super::common::{
    beckmann_d, cosine_hemisphere_pdf, fresnel_conductor, fresnel_dielectric, fresnel_schlick,
    ggx_d, luminance, reflect_about, reflected_pdf, same_hemisphere_up, sample_beckmann_h,
    sample_beckmann_vndf, sample_cosine_hemisphere, sample_ggx_h, sample_ggx_vndf,
    smith_g1_beckmann, smith_g1_beckmann_walter, smith_g1_ggx, visible_reflected_pdf,
};
use super::{Brdf, BrdfSample, Param, ParamError, ParamReader, Params, Representative};
use glam::{Vec2, Vec3, Vec4};
use std::f32::consts::FRAC_1_PI;
use std::sync::Arc;

/// Below this rms slope the specular lobe is a delta mirror.
pub const MIRROR_ROUGHNESS: f32 = 1e-3;

#[derive(Clone, Debug, PartialEq)]
pub struct CookTorrance {
    pub kd: Vec3,
    pub ks: Vec3,
    pub roughness: f32,
    pub distribution: Distribution,
    pub geometry: Geometry,
    pub fresnel: Fresnel,
    pub ior: f32,
    pub eta: Vec3,
    pub k: Vec3,
    pub f0: Vec3,
    pub normalization: Normalization,
}

choice_enum! {
    pub enum Distribution {
        /// Survey eq. 6 (normalised: divided by π).
        Beckmann = "beckmann" => "CT_BECKMANN",
        /// GGX / Trowbridge–Reitz.
        Ggx = "ggx" => "CT_GGX",
    }
}

choice_enum! {
    pub enum Geometry {
        /// Survey eq. 8, the V-cavity (V-groove) term.
        VCavity = "v_cavity" => "CT_V_CAVITY",
        /// Separable Smith G1(wi)·G1(wo).
        Smith = "smith" => "CT_SMITH",
    }
}

choice_enum! {
    pub enum Fresnel {
        /// Survey eq. 7 with `ior`.
        Dielectric = "dielectric" => "CT_FRESNEL_DIELECTRIC",
        /// Exact complex-index formula with `eta`, `k`.
        Conductor = "conductor" => "CT_FRESNEL_CONDUCTOR",
        /// Schlick's approximation with `f0`.
        Schlick = "schlick" => "CT_FRESNEL_SCHLICK",
    }
}

choice_enum! {
    /// Not a code in the record: `pack` writes its factor N ([`CookTorrance::norm_factor`]).
    pub enum Normalization {
        /// Survey eq. 9 as written: 4× the microfacet BRDF.
        Survey = "survey",
        /// Walter et al. 2007: F·D·G/(4 cosθi cosθo).
        Walter = "walter",
    }
}

choice_enum! {
    /// How the specular lobe draws its half vector (not a parameter: [`CookTorrance::sampler`]
    /// chooses it per variant; `pack` writes its code).
    pub enum Sampler {
        /// D(h) cosθh (Walter et al. 2007).
        Ndf = "ndf" => "CT_SAMPLE_NDF",
        /// The visible normals D_wo(h) (Heitz & d'Eon 2014; Heitz 2018 for GGX).
        Visible = "visible" => "CT_SAMPLE_VISIBLE",
    }
}

impl Default for CookTorrance {
    /// The survey's model: Beckmann, V-cavity, dielectric Fresnel (n = 1.5), eq. 9 as written.
    fn default() -> Self {
        CookTorrance {
            kd: Vec3::ZERO,
            ks: Vec3::ONE,
            roughness: 0.3,
            distribution: Distribution::Beckmann,
            geometry: Geometry::VCavity,
            fresnel: Fresnel::Dielectric,
            ior: 1.5,
            eta: Vec3::new(0.143_036, 0.375_307, 1.442_05),
            k: Vec3::new(3.983, 2.385_56, 1.603_36),
            f0: Vec3::splat(0.04),
            normalization: Normalization::Survey,
        }
    }
}

impl CookTorrance {
    /// N of the header: 4 for the survey's eq. 9, 1 for Walter.
    pub fn norm_factor(&self) -> f32 {
        match self.normalization {
            Normalization::Survey => 4.0,
            Normalization::Walter => 1.0,
        }
    }
    /// Whether the specular lobe is a delta mirror.
    pub fn is_mirror(&self) -> bool {
        self.roughness < MIRROR_ROUGHNESS
    }
    /// The half-vector sampler of this variant: the visible normals with `smith`, D(h) cosθh
    /// with `v_cavity` (the header gives the figures).
    pub fn sampler(&self) -> Sampler {
        match self.geometry {
            Geometry::Smith => Sampler::Visible,
            Geometry::VCavity => Sampler::Ndf,
        }
    }
}

declare_model! {
    survey: "eqs. 6–9";
    params: {
        KD = rgb("kd", "RGB", [0.0; 3], (0.0, 1.0), "Lambertian diffuse albedo (survey: \"simply adding\" a diffuse part)").at(0);
        KS = rgb("ks", "RGB", [1.0; 3], (0.0, 1.0), "scale of the specular lobe").at(4);
        ROUGHNESS = scalar("roughness", "rms slope m", 0.3, (0.0, 4.0), "Beckmann m = GGX α; below 1e-3 the lobe is a delta mirror").at(3);
        DISTRIBUTION = choice("distribution", Distribution::NAMES, Distribution::Beckmann.name(), "microfacet NDF (`beckmann`: survey eq. 6)");
        GEOMETRY = choice("geometry", Geometry::NAMES, Geometry::VCavity.name(), "masking-shadowing G (`v_cavity`: survey eq. 8)");
        FRESNEL = choice("fresnel", Fresnel::NAMES, Fresnel::Dielectric.name(), "Fresnel term at c = wi·h (`dielectric`: survey eq. 7; `conductor`: the exact formula)");
        IOR = scalar("ior", "—", 1.5, (1.0, 100.0), "relative index, `fresnel = \"dielectric\"` (eq. 7)").at(8);
        // η > 0 is checked in `parse`.
        ETA = rgb("eta", "RGB", [0.143_036, 0.375_307, 1.442_05], (0.0, 100.0), "real part η of the complex index η + iκ, `fresnel = \"conductor\"` (default gold-like)").range_text("(0, 100]").at(8).texels_in(f32::MIN_POSITIVE, 100.0);
        K = rgb("k", "RGB", [3.983, 2.385_56, 1.603_36], (0.0, 100.0), "imaginary part κ of the complex index, `fresnel = \"conductor\"`").at(12);
        F0 = rgb("f0", "RGB", [0.04; 3], (0.0, 1.0), "normal-incidence reflectance, `fresnel = \"schlick\"`").at(8);
        NORMALIZATION = choice("normalization", Normalization::NAMES, Normalization::Survey.name(), "the specular denominator: `survey` (eq. 9) or `walter`, see below").same_family("`walter` with ks is `survey` with ks/4: every `walter` lobe is a `survey` lobe");
    }
    representative: Representative::Listed(&[
        ("cook_torrance (survey)", r#"model = "cook_torrance", kd = 0.0, ks = 1.0, roughness = 0.2, fresnel = "schlick", f0 = 0.8, normalization = "survey""#),
        ("cook_torrance (walter)", r#"model = "cook_torrance", kd = 0.0, ks = 1.0, roughness = 0.2, fresnel = "schlick", f0 = 0.8, normalization = "walter", geometry = "smith""#),
    ]);
    record_codes: [Distribution, Geometry, Fresnel, Sampler];
}

pub fn parse(r: &mut ParamReader) -> Result<Arc<dyn Brdf>, ParamError> {
    let kd = r.rgb_of(&KD)?;
    let ks = r.rgb_of(&KS)?;
    let roughness = r.scalar_of(&ROUGHNESS)?;
    let distribution = r.choice_of(&DISTRIBUTION)?;
    let geometry = r.choice_of(&GEOMETRY)?;
    let fresnel = r.choice_of(&FRESNEL)?;
    let normalization = r.choice_of(&NORMALIZATION)?;
    // Fresnel parameters apply to one Fresnel choice each.
    let owner = |key: &str| match key {
        "ior" => Fresnel::Dielectric,
        "eta" | "k" => Fresnel::Conductor,
        _ => Fresnel::Schlick,
    };
    for key in ["ior", "eta", "k", "f0"] {
        if r.has(key) && owner(key) != fresnel {
            let want = owner(key).name();
            return Err(r.error(key, format!("applies only with fresnel = \"{want}\"")));
        }
    }
    let ior = r.scalar_of(&IOR)?;
    let eta = r.rgb_of(&ETA)?;
    if eta.min_element() <= 0.0 {
        return Err(r.error("eta", "must be > 0 in every channel"));
    }
    let k = r.rgb_of(&K)?;
    let f0 = r.rgb_of(&F0)?;
    let m = CookTorrance {
        kd,
        ks,
        roughness,
        distribution,
        geometry,
        fresnel,
        ior,
        eta,
        k,
        f0,
        normalization,
    };
    let n = m.norm_factor();
    if (kd + n * ks).max_element() > 1.0 {
        let msg = match m.normalization {
            Normalization::Survey => format!(
                "kd + 4·ks = {:.3} > 1: the survey's eq. 9 is 4× the microfacet BRDF and can \
                 reflect more energy than it receives; normalization = \"walter\" conserves \
                 energy for kd + ks ≤ 1",
                (kd + n * ks).max_element()
            ),
            Normalization::Walter => format!(
                "kd + ks = {:.3} > 1: the material can reflect more energy than it receives",
                (kd + ks).max_element()
            ),
        };
        r.warn(
            if m.normalization == Normalization::Survey && !r.has("normalization") {
                "normalization"
            } else {
                "ks"
            },
            msg,
        );
    }
    Ok(Arc::new(m))
}

/// Fresnel reflectance at cos c (c = wi·h, or cosθ for the mirror).
pub fn fresnel(m: &CookTorrance, c: f32) -> Vec3 {
    match m.fresnel {
        Fresnel::Dielectric => Vec3::splat(fresnel_dielectric(c, m.ior)),
        Fresnel::Conductor => fresnel_conductor(c, m.eta, m.k),
        Fresnel::Schlick => fresnel_schlick(c, m.f0),
    }
}

/// The normalised NDF D(h) (eq. 6 / π for Beckmann).
pub fn ndf(m: &CookTorrance, h: Vec3) -> f32 {
    match m.distribution {
        Distribution::Beckmann => beckmann_d(h, m.roughness),
        Distribution::Ggx => ggx_d(h, m.roughness),
    }
}

/// Masking-shadowing G(wi, wo, h): eq. 8 (V-cavity) or separable Smith.
pub fn geometry(m: &CookTorrance, wi: Vec3, wo: Vec3, h: Vec3) -> f32 {
    match m.geometry {
        Geometry::VCavity => {
            let c = wo.dot(h);
            if c <= 0.0 {
                return 0.0;
            }
            let g_mask = 2.0 * h.z * wo.z / c;
            let g_shadow = 2.0 * h.z * wi.z / c;
            g_mask.min(g_shadow).min(1.0)
        }
        Geometry::Smith => match m.distribution {
            Distribution::Beckmann => {
                smith_g1_beckmann_walter(wi, m.roughness)
                    * smith_g1_beckmann_walter(wo, m.roughness)
            }
            Distribution::Ggx => smith_g1_ggx(wi, m.roughness) * smith_g1_ggx(wo, m.roughness),
        },
    }
}

/// f_r(wi, wo), survey eq. 9 (×¼ for `walter`), plus kd/π. The delta mirror is not seen.
pub fn eval(m: &CookTorrance, wi: Vec3, wo: Vec3) -> Vec3 {
    if !same_hemisphere_up(wi, wo) {
        return Vec3::ZERO;
    }
    let diffuse = m.kd * FRAC_1_PI;
    if m.is_mirror() {
        return diffuse;
    }
    let h = (wi + wo).normalize();
    diffuse + specular(m, wi, wo, h, ndf(m, h))
}

/// The specular lobe of [`eval`] at half vector `h`, whose D(h) is `d`.
fn specular(m: &CookTorrance, wi: Vec3, wo: Vec3, h: Vec3, d: f32) -> Vec3 {
    let c = wi.dot(h);
    let g = geometry(m, wi, wo, h);
    let denom = (4.0 * wi.z * wo.z).max(1e-20);
    // D·G/(4 cos cos), then the exact power-of-two factor N: survey = 4 × walter bit for bit.
    let s = d * g / denom * m.norm_factor();
    m.ks * fresnel(m, c) * s
}

/// [`eval`]`(wi, wo)` and [`pdf_with`]`(s, wo, wi)` at once, the same values, with the half
/// vector and D(h) computed once for both (a light sample's MIS weight and a BRDF sample's
/// weight need the two at one pair of directions).
pub fn eval_pdf_with(m: &CookTorrance, s: Sampler, wi: Vec3, wo: Vec3) -> (Vec3, f32) {
    if !same_hemisphere_up(wi, wo) {
        return (Vec3::ZERO, 0.0);
    }
    let diffuse = m.kd * FRAC_1_PI;
    let ps = specular_probability(m, wo.z);
    let mut p = (1.0 - ps) * cosine_hemisphere_pdf(wi.z);
    if m.is_mirror() {
        return (diffuse, p);
    }
    // (wi + wo) and pdf_with's (given + sampled) are the same sum.
    let h = (wi + wo).normalize();
    let d = ndf(m, h);
    if ps > 0.0 {
        p += ps * specular_pdf(m, s, wo, wi, |_| d);
    }
    (diffuse + specular(m, wi, wo, h, d), p)
}

/// Probability of choosing the specular lobe (the delta mirror when rough < 1e-3) given the
/// cosine of the known direction.
pub fn specular_probability(m: &CookTorrance, cos_given: f32) -> f32 {
    // Without a diffuse lobe the answer is 1 whatever the Fresnel term: it is not evaluated.
    let wd = luminance(m.kd);
    if wd <= 0.0 {
        return 1.0;
    }
    let ws = luminance(m.ks * fresnel(m, cos_given)) * m.norm_factor();
    if ws <= 0.0 {
        return 0.0;
    }
    (ws / (ws + wd)).clamp(0.1, 0.9)
}

/// The exact Smith G1 of the distribution (whatever G the BRDF evaluates): the visible-normal
/// sampler's density holds it.
pub fn exact_g1(m: &CookTorrance, w: Vec3) -> f32 {
    match m.distribution {
        Distribution::Beckmann => smith_g1_beckmann(w, m.roughness),
        Distribution::Ggx => smith_g1_ggx(w, m.roughness),
    }
}

/// Solid-angle density of the half-vector sampler `s` mapped to `sampled`: D(h) cosθh/(4
/// given·h) for [`Sampler::Ndf`], G1(given) D(h)/(4 cosθ_given) for [`Sampler::Visible`].
/// `d` gives D(h) at the half vector h of `given` and `sampled`.
fn specular_pdf(
    m: &CookTorrance,
    s: Sampler,
    given: Vec3,
    sampled: Vec3,
    d: impl FnOnce(Vec3) -> f32,
) -> f32 {
    match s {
        Sampler::Ndf => reflected_pdf(given, sampled, |h| d(h) * h.z),
        Sampler::Visible => visible_reflected_pdf(given, sampled, exact_g1(m, given), d),
    }
}

pub fn pdf(m: &CookTorrance, given: Vec3, sampled: Vec3) -> f32 {
    pdf_with(m, m.sampler(), given, sampled)
}

/// [`pdf`] with the half-vector sampler `s` in place of the variant's own.
pub fn pdf_with(m: &CookTorrance, s: Sampler, given: Vec3, sampled: Vec3) -> f32 {
    if !same_hemisphere_up(given, sampled) {
        return 0.0;
    }
    let ps = specular_probability(m, given.z);
    let mut p = (1.0 - ps) * cosine_hemisphere_pdf(sampled.z);
    if !m.is_mirror() && ps > 0.0 {
        p += ps * specular_pdf(m, s, given, sampled, |h| ndf(m, h));
    }
    p
}

pub fn sample(m: &CookTorrance, given: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
    sample_with(m, m.sampler(), given, u_lobe, u)
}

/// [`sample`] with the half-vector sampler `s` in place of the variant's own (the weight and
/// pdf are those of [`pdf_with`] for `s`).
pub fn sample_with(
    m: &CookTorrance,
    s: Sampler,
    given: Vec3,
    u_lobe: f32,
    u: Vec2,
) -> Option<BrdfSample> {
    if given.z <= 0.0 {
        return None;
    }
    let ps = specular_probability(m, given.z);
    let wi = if u_lobe < ps {
        if m.is_mirror() {
            let weight = m.ks * fresnel(m, given.z) * (m.norm_factor() / ps);
            return Some(BrdfSample::mirror(given, weight));
        }
        let h = match (s, m.distribution) {
            (Sampler::Ndf, Distribution::Beckmann) => sample_beckmann_h(u, m.roughness),
            (Sampler::Ndf, Distribution::Ggx) => sample_ggx_h(u, m.roughness),
            (Sampler::Visible, Distribution::Beckmann) => {
                sample_beckmann_vndf(given, u, m.roughness)
            }
            (Sampler::Visible, Distribution::Ggx) => sample_ggx_vndf(given, u, m.roughness),
        };
        reflect_about(given, h)?
    } else {
        sample_cosine_hemisphere(u)
    };
    let (f, p) = eval_pdf_with(m, s, wi, given);
    BrdfSample::scattered(wi, |_| p, |_| f)
}

impl_brdf!(CookTorrance {
    fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (Vec3, f32) {
        eval_pdf_with(self, self.sampler(), wi, wo)
    }
    fn with_params(&self, v: &super::textured::ParamValues) -> Arc<dyn Brdf> {
        Arc::new(CookTorrance {
            kd: v.rgb(&KD, self.kd),
            ks: v.rgb(&KS, self.ks),
            roughness: v.scalar(&ROUGHNESS, self.roughness),
            ior: v.scalar(&IOR, self.ior),
            eta: v.rgb(&ETA, self.eta),
            k: v.rgb(&K, self.k),
            f0: v.rgb(&F0, self.f0),
            ..self.clone()
        })
    }
    /// The Fresnel slot (words 8–10) holds the parameter of this material's Fresnel term
    /// only: the dielectric's ior (in all three words), the conductor's η, or Schlick's f0;
    /// κ only for a conductor.
    fn record_slot(&self, p: &Param) -> Option<super::textured::RecordSlot> {
        use super::textured::{RecordSlot, SlotMode};
        match (p.name, self.fresnel) {
            ("ior", Fresnel::Dielectric) => Some(RecordSlot {
                word: 8,
                mode: SlotMode::Splat,
            }),
            ("eta" | "k", Fresnel::Conductor) | ("f0", Fresnel::Schlick) => p.slot,
            ("ior" | "eta" | "k" | "f0", _) => None,
            _ => p.slot,
        }
    }
    fn pack(&self) -> Params {
        let fresnel = self.fresnel.code();
        let a = match self.fresnel {
            Fresnel::Dielectric => Vec3::splat(self.ior),
            Fresnel::Conductor => self.eta,
            Fresnel::Schlick => self.f0,
        };
        Params::from_vec4s([
            self.kd.extend(self.roughness),
            self.ks.extend(self.norm_factor()),
            a.extend(self.distribution.code()),
            self.k.extend(self.geometry.code()),
            Vec4::new(fresnel, self.sampler().code(), 0.0, 0.0),
        ])
    }
    fn scatters(&self) -> bool {
        self.kd != Vec3::ZERO || self.ks != Vec3::ZERO
    }
});

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brdf::common::reflect_z;
    use crate::brdf::validate::{assert_finite_on_sample_grid, dir_from_theta_deg as dir};

    fn variants() -> Vec<CookTorrance> {
        let mut v = Vec::new();
        for distribution in [Distribution::Beckmann, Distribution::Ggx] {
            for geometry in [Geometry::VCavity, Geometry::Smith] {
                for fresnel in [Fresnel::Dielectric, Fresnel::Conductor, Fresnel::Schlick] {
                    for roughness in [0.0, 1e-3, 0.01, 0.3, 1.0] {
                        v.push(CookTorrance {
                            kd: Vec3::splat(0.2),
                            roughness,
                            distribution,
                            geometry,
                            fresnel,
                            ..Default::default()
                        });
                    }
                }
            }
        }
        v
    }

    #[test]
    fn finite_at_edge_configurations() {
        for m in variants() {
            assert_finite_on_sample_grid(&m, &[0.0, 0.5, 0.95], &format!("{m:?}"));
        }
    }

    #[test]
    fn exact_mirror_configuration_and_normal_incidence() {
        let m = CookTorrance {
            roughness: 0.1,
            ..Default::default()
        };
        let w = dir(30.0, 0.0);
        let f = eval(&m, w, reflect_z(w));
        // D(n) = 1/(π m²), G = 1, F(cos 30°): survey form F·D·G/(cos²).
        let expect = fresnel_dielectric(w.z, 1.5) / (std::f32::consts::PI * 0.01) / (w.z * w.z);
        assert!((f.x / expect - 1.0).abs() < 1e-5, "{f} {expect}");
        let n = Vec3::Z;
        let f = eval(&m, n, n);
        let expect = 0.04 / (std::f32::consts::PI * 0.01);
        assert!((f.x / expect - 1.0).abs() < 1e-5, "{f} {expect}");
    }

    #[test]
    fn zero_roughness_is_a_delta_mirror_with_fresnel_weight() {
        let m = CookTorrance {
            roughness: 0.0,
            normalization: Normalization::Walter,
            ..Default::default()
        };
        let given = dir(60.0, 30.0);
        let s = sample(&m, given, 0.3, Vec2::splat(0.5)).unwrap();
        assert!(s.delta && s.pdf == 0.0);
        assert!((s.wi - reflect_z(given)).length() < 1e-6);
        let f = fresnel_dielectric(0.5, 1.5);
        assert!((s.weight.x - f).abs() < 1e-6, "{s:?} {f}");
        assert_eq!(eval(&m, s.wi, given), Vec3::ZERO);
        assert_eq!(pdf(&m, given, s.wi), 0.0);
    }
}
