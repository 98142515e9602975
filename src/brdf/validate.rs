//! Validation harness for the reflectance models: a χ² test of each sampler against its pdf,
//! the directional albedo ("white furnace") by quadrature and by the model's own sampling,
//! and a reciprocity check. Used by the `tests/brdf_*.rs` files and by the `brdf report`
//! command.
//!
//! Conventions (those of [`super`]): `given` is the direction the renderer already knows (the
//! viewer direction wo); `sample(given, …)` returns wi; `eval(wi, wo)` excludes the cosine.
//! The directional albedo is ρ(wo) = ∫ f(wi, wo) cosθi dωi with wo = `given`; for a model
//! that is not reciprocal this is the albedo the path tracer sees.
//!
//! Everything here is deterministic: the random numbers are the crate's counter-based
//! [`crate::rng::random_f32`] keyed on (seed, sample index, dimension), and the quadratures are
//! fixed grids. All sums are accumulated in f64; the models themselves stay f32.
//!
//! Scalars: where a function returns one number for an RGB model (albedo), it is the mean of
//! the three channels; the `_rgb` variants return the channels.

use super::{parse_material, Brdf, BrdfSample, Material, Origin};
use crate::rng::random_f32;
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use std::f64::consts::PI;

/// A material from the fields of one scene-file material table (`model = "…"` and its
/// parameters, one per line), as the scene loader reads it; errors name `file`, the line and
/// the field. Returns the material and its warnings. For tests and tools that build materials
/// from text.
pub fn material_from_toml(file: &str, src: &str) -> Result<(Material, Vec<String>), String> {
    let fields: std::collections::BTreeMap<String, toml::Spanned<toml::Value>> =
        toml::from_str(src).map_err(|e| format!("{file}: {e}"))?;
    let origin = Origin {
        file,
        source: src,
        material: "m",
        span: 0..src.len(),
        dir: None,
    };
    parse_material(origin, fields).map_err(|e| e.to_string())
}

/// The outcome of [`chi2_test`].
#[derive(Clone, Debug, PartialEq)]
pub struct Chi2Result {
    /// Probability of a χ² statistic at least this large if `sample` draws from `pdf`.
    pub p_value: f64,
    /// Degrees of freedom (number of cells after pooling, minus one).
    pub dof: usize,
    /// Pearson's χ² statistic.
    pub statistic: f64,
    /// Non-delta samples at which `pdf(given, wi)` or the sample's own `pdf` is zero (or not
    /// finite), plus samples that fell in cells whose integrated pdf is zero. Must be 0.
    pub zero_pdf_hits: usize,
    /// ∫ pdf over the upper hemisphere by the cell quadrature (1 − P_delta − the mass the
    /// sampler rejects, e.g. lobe parts below the horizon).
    pub pdf_integral: f64,
    /// Fraction of the samples that were non-delta and landed in the upper hemisphere; equals
    /// `pdf_integral` up to noise when sampler and pdf agree.
    pub sample_fraction: f64,
}

/// Grid settings of [`chi2_test_with`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chi2Config {
    /// Cells in θ, uniform over [0, π/2] (the upper hemisphere; reflection-only models).
    pub theta_res: usize,
    /// Cells in φ, uniform over [0, 2π).
    pub phi_res: usize,
    /// Each cell is split into sub × sub parts, each integrated by the adaptive 3 × 3
    /// Gauss–Legendre rule, for the expected counts (the parts must be small enough that some
    /// node sees every lobe: 4 gives nodes ~0.003 rad apart).
    pub sub: usize,
    /// Cells whose expected count is below this are pooled.
    pub min_expected: f64,
}

impl Default for Chi2Config {
    fn default() -> Self {
        Chi2Config {
            theta_res: 40,
            phi_res: 80,
            sub: 4,
            min_expected: 5.0,
        }
    }
}

/// Unit direction from polar angle θ (from the normal, degrees) and azimuth φ (from the
/// tangent x, degrees) in the local shading frame.
pub fn dir_from_theta_deg(theta_deg: f32, phi_deg: f32) -> Vec3 {
    let (st, ct) = theta_deg.to_radians().sin_cos();
    let (sp, cp) = phi_deg.to_radians().sin_cos();
    Vec3::new(st * cp, st * sp, ct)
}

/// The harness's uniform random number for (seed, sample index, dimension).
#[inline]
fn rand(seed: u64, i: usize, dim: u32) -> f32 {
    random_f32(
        seed as u32,
        (seed >> 32) as u32,
        i as u32,
        (i >> 32) as u32,
        dim,
    )
}

/// The three random numbers of sample `i`: (u_lobe, u).
#[inline]
fn sample_inputs(seed: u64, i: usize) -> (f32, Vec2) {
    (
        rand(seed, i, 0),
        Vec2::new(rand(seed, i, 1), rand(seed, i, 2)),
    )
}

fn dvec(v: Vec3) -> DVec3 {
    DVec3::new(v.x as f64, v.y as f64, v.z as f64)
}

fn mean3(v: DVec3) -> f64 {
    (v.x + v.y + v.z) / 3.0
}

/// Mitsuba/pbrt-style χ² test of `sample` against `pdf` for a fixed `given` direction:
/// 40 × 80 cells over the upper hemisphere (θ, φ uniform), the pdf integrated per cell by an
/// adaptive Gauss–Legendre rule on 4 × 4 parts, cells with expected count < 5 pooled, plus one
/// cell for "no non-delta sample in the upper hemisphere" (delta samples, rejected samples)
/// whose expected count is samples·(1 − ∫pdf). Deterministic for a given seed.
pub fn chi2_test(b: &dyn Brdf, given: Vec3, samples: usize, seed: u64) -> Chi2Result {
    chi2_test_with(b, given, samples, seed, Chi2Config::default())
}

/// [`chi2_test`] with an explicit grid.
pub fn chi2_test_with(
    b: &dyn Brdf,
    given: Vec3,
    samples: usize,
    seed: u64,
    cfg: Chi2Config,
) -> Chi2Result {
    let (nt, np, sub) = (cfg.theta_res.max(1), cfg.phi_res.max(1), cfg.sub.max(1));
    let dtheta = 0.5 * PI / nt as f64;
    let dphi = 2.0 * PI / np as f64;
    let cell_of = |w: Vec3| -> Option<usize> {
        if w.z <= 0.0 {
            return None;
        }
        let w = dvec(w);
        let theta = w.z.clamp(-1.0, 1.0).acos();
        let mut phi = w.y.atan2(w.x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let it = ((theta / dtheta) as usize).min(nt - 1);
        let ip = ((phi / dphi) as usize).min(np - 1);
        Some(it * np + ip)
    };

    // Observed counts.
    let mut observed = vec![0u64; nt * np];
    let mut zero_pdf_hits = 0usize;
    let mut inside = 0u64;
    for i in 0..samples {
        let (ul, u) = sample_inputs(seed, i);
        let s: BrdfSample = match b.sample(given, ul, u) {
            Some(s) if !s.delta => s,
            _ => continue,
        };
        let p = b.pdf(given, s.wi);
        if !(p > 0.0 && p.is_finite() && s.pdf > 0.0 && s.pdf.is_finite()) {
            zero_pdf_hits += 1;
            continue;
        }
        if let Some(c) = cell_of(s.wi) {
            observed[c] += 1;
            inside += 1;
        }
    }

    let expected = expected_cell_mass(b, given, nt, np, sub);
    let pdf_integral: f64 = expected.iter().sum();

    // Cells (expected, observed), plus the "outside" cell.
    let n = samples as f64;
    let mut cells: Vec<(f64, f64)> = expected
        .iter()
        .zip(&observed)
        .map(|(e, o)| (e * n, *o as f64))
        .collect();
    cells.push((
        ((1.0 - pdf_integral) * n).max(0.0),
        (samples as u64 - inside) as f64 - zero_pdf_hits as f64,
    ));
    // Samples in cells of zero expected mass are pdf errors, not statistics.
    for (e, o) in &cells {
        if *e <= 0.0 && *o > 0.0 {
            zero_pdf_hits += *o as usize;
        }
    }
    cells.retain(|(e, _)| *e > 0.0);
    cells.sort_by(|a, b| a.0.total_cmp(&b.0));

    let (stat, ncells) = pooled_statistic(cells, cfg.min_expected);
    let dof = ncells.saturating_sub(1);
    let p_value = if dof == 0 {
        1.0
    } else {
        chi2_survival(dof as f64, stat)
    };
    Chi2Result {
        p_value,
        dof,
        statistic: stat,
        zero_pdf_hits,
        pdf_integral,
        sample_fraction: inside as f64 / n.max(1.0),
    }
}

/// The probability mass ∫cell pdf dω of each of the nt × np cells (θ-major), each cell split
/// into sub × sub parts integrated by the adaptive Gauss–Legendre rule of the albedo quadrature.
fn expected_cell_mass(b: &dyn Brdf, given: Vec3, nt: usize, np: usize, sub: usize) -> Vec<f64> {
    let dtheta = 0.5 * PI / nt as f64;
    let dphi = 2.0 * PI / np as f64;
    let g = |theta: f64, phi: f64| -> DVec3 {
        let (st, ct) = theta.sin_cos();
        let w = Vec3::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, ct as f32);
        let p = b.pdf(given, w) as f64;
        DVec3::splat(if p.is_finite() && p > 0.0 {
            p * st
        } else {
            0.0
        })
    };
    let abs_density = 1e-7 / (0.5 * PI * 2.0 * PI);
    let (st, sp) = (dtheta / sub as f64, dphi / sub as f64);
    (0..nt * np)
        .into_par_iter()
        .map(|c| {
            let (it, ip) = (c / np, c % np);
            let mut sum = 0.0f64;
            for a in 0..sub {
                let t0 = it as f64 * dtheta + a as f64 * st;
                for k in 0..sub {
                    let p0 = ip as f64 * dphi + k as f64 * sp;
                    sum += adaptive_cell(&g, t0, t0 + st, p0, p0 + sp, abs_density, 0).x;
                }
            }
            sum
        })
        .collect()
}

/// Pearson's statistic over `cells` (expected, observed), sorted by expected count: cells
/// under `min_expected` are pooled into one (with the cells after them until the pool reaches
/// it). The statistic and the number of cells it sums.
pub fn pooled_statistic(cells: Vec<(f64, f64)>, min_expected: f64) -> (f64, usize) {
    let (mut stat, mut ncells) = (0.0f64, 0usize);
    let (mut pool_e, mut pool_o) = (0.0f64, 0.0f64);
    for (e, o) in cells {
        if e < min_expected || (pool_e > 0.0 && pool_e < min_expected) {
            pool_e += e;
            pool_o += o;
        } else {
            stat += (o - e) * (o - e) / e;
            ncells += 1;
        }
    }
    if pool_e > 0.0 {
        stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        ncells += 1;
    }
    (stat, ncells)
}

/// Šidák-corrected significance level for `tests` independent tests at overall level `alpha`.
pub fn sidak(alpha: f64, tests: usize) -> f64 {
    1.0 - (1.0 - alpha).powf(1.0 / tests.max(1) as f64)
}

/// P(X ≥ x) for X ~ χ²(k): the regularized upper incomplete gamma Q(k/2, x/2).
pub fn chi2_survival(k: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    gamma_q(0.5 * k, 0.5 * x)
}

/// Regularized upper incomplete gamma Q(a, x) = Γ(a, x)/Γ(a): the series for P when
/// x < a + 1, the Lentz continued fraction for Q otherwise (Numerical Recipes §6.2 layout).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let ln_prefix = a * x.ln() - x - libm::lgamma(a);
    if x < a + 1.0 {
        // P(a, x) = e^{-x} x^a / Γ(a+1) · Σ x^n / ((a+1)…(a+n)).
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (1.0 - sum * ln_prefix.exp()).clamp(0.0, 1.0)
    } else {
        let tiny = 1e-300;
        let mut bb = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / bb;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            bb += 2.0;
            d = an * d + bb;
            if d.abs() < tiny {
                d = tiny;
            }
            c = bb + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (ln_prefix.exp() * h).clamp(0.0, 1.0)
    }
}

/// Directional albedo ρ(wo) = ∫ f(wi, wo) cosθi dωi with wo = `given`, by deterministic
/// quadrature independent of the sampler: a base grid of n × 2n cells in (θi, φi) over the
/// upper hemisphere, each integrated by an adaptive 3 × 3 Gauss–Legendre rule (cells split
/// while the 2 × 2 and 3 × 3 rules differ by more than 1e-5 relative, up to 7 levels), f64
/// accumulation. Mean of the RGB channels; delta lobes are not seen. The base grid must be
/// fine enough that every lobe touches some node: n = 200 (cells 0.008 × 0.016 rad) finds
/// lobes down to ~0.005 rad wide, such as Ward α = 0.05 reflected at 89° (0.002 rad in φ).
pub fn albedo_quadrature(b: &dyn Brdf, given: Vec3, n: usize) -> f64 {
    mean3(albedo_quadrature_rgb(b, given, n))
}

/// [`albedo_quadrature`] per channel.
pub fn albedo_quadrature_rgb(b: &dyn Brdf, given: Vec3, n: usize) -> DVec3 {
    quadrature(b, given, n, false)
}

/// The albedo with the *light* direction held fixed: ρ(wi) = ∫ f(wi, wo) cosθo dωo with
/// wi = `light` (the usual convention of published albedo tables). Equal to
/// [`albedo_quadrature`] for reciprocal models; for the survey's Phong (eq. 4) the two differ,
/// and the path tracer (which samples wi given wo) sees [`albedo_quadrature`].
pub fn albedo_quadrature_light(b: &dyn Brdf, light: Vec3, n: usize) -> f64 {
    mean3(quadrature(b, light, n, true))
}

fn quadrature(b: &dyn Brdf, fixed: Vec3, n: usize, fixed_is_light: bool) -> DVec3 {
    let nt = n.max(1);
    let np = 2 * nt;
    let dtheta = 0.5 * PI / nt as f64;
    let dphi = 2.0 * PI / np as f64;
    let g = |theta: f64, phi: f64| -> DVec3 {
        let (st, ct) = theta.sin_cos();
        let w = Vec3::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, ct as f32);
        let f = match fixed_is_light {
            false => dvec(b.eval(w, fixed)),
            true => dvec(b.eval(fixed, w)),
        };
        if f.is_finite() {
            f * (ct * st)
        } else {
            DVec3::ZERO
        }
    };
    // Absolute error allowed per unit of (θ, φ) parameter area: 1e-7 over the hemisphere.
    let abs_density = 1e-7 / (0.5 * PI * 2.0 * PI);
    (0..nt)
        .into_par_iter()
        .map(|it| {
            let t0 = it as f64 * dtheta;
            let mut row = DVec3::ZERO;
            for ip in 0..np {
                let p0 = ip as f64 * dphi;
                row += adaptive_cell(&g, t0, t0 + dtheta, p0, p0 + dphi, abs_density, 0);
            }
            row
        })
        .reduce(|| DVec3::ZERO, |a, c| a + c)
}

/// Gauss–Legendre nodes and weights on [−1, 1].
const GL2: [(f64, f64); 2] = [
    (-0.577_350_269_189_625_8, 1.0),
    (0.577_350_269_189_625_8, 1.0),
];
const GL3: [(f64, f64); 3] = [
    (-0.774_596_669_241_483_4, 5.0 / 9.0),
    (0.0, 8.0 / 9.0),
    (0.774_596_669_241_483_4, 5.0 / 9.0),
];
const MAX_DEPTH: u32 = 7;

/// ∫∫ g over a (θ, φ) cell: the 3 × 3 Gauss–Legendre rule, split into four while it differs
/// from the 2 × 2 rule by more than 1e-5 relative (plus an absolute floor proportional to the
/// cell's area), up to 7 levels (a base cell down to 1/128 of its side).
fn adaptive_cell(
    g: &(impl Fn(f64, f64) -> DVec3 + Sync),
    t0: f64,
    t1: f64,
    p0: f64,
    p1: f64,
    abs_density: f64,
    depth: u32,
) -> DVec3 {
    let (tc, th) = (0.5 * (t0 + t1), 0.5 * (t1 - t0));
    let (pc, ph) = (0.5 * (p0 + p1), 0.5 * (p1 - p0));
    let rule = |nodes: &[(f64, f64)]| -> DVec3 {
        let mut sum = DVec3::ZERO;
        for &(xt, wt) in nodes {
            for &(xp, wp) in nodes {
                sum += g(tc + th * xt, pc + ph * xp) * (wt * wp);
            }
        }
        sum * (th * ph)
    };
    let i3 = rule(&GL3);
    if depth >= MAX_DEPTH {
        return i3;
    }
    let i2 = rule(&GL2);
    let err = mean3((i3 - i2).abs());
    let tol = 1e-5 * mean3(i3.abs()) + abs_density * (t1 - t0) * (p1 - p0);
    if err <= tol {
        return i3;
    }
    adaptive_cell(g, t0, tc, p0, pc, abs_density, depth + 1)
        + adaptive_cell(g, tc, t1, p0, pc, abs_density, depth + 1)
        + adaptive_cell(g, t0, tc, pc, p1, abs_density, depth + 1)
        + adaptive_cell(g, tc, t1, pc, p1, abs_density, depth + 1)
}

/// Directional albedo by the model's own importance sampling, delta lobes included: the mean
/// of the sample weights over `samples` samples (a rejected sample counts 0) and the variance
/// of one sample's weight (channel means).
pub fn albedo_sampled(b: &dyn Brdf, given: Vec3, samples: usize, seed: u64) -> (f64, f64) {
    let (s1, s2) = (0..samples)
        .into_par_iter()
        .map(|i| {
            let (ul, u) = sample_inputs(seed, i);
            let w = match b.sample(given, ul, u) {
                Some(s) => mean3(dvec(s.weight)),
                None => 0.0,
            };
            let w = if w.is_finite() { w } else { f64::NAN };
            (w, w * w)
        })
        .reduce(|| (0.0, 0.0), |a, c| (a.0 + c.0, a.1 + c.1));
    let n = samples.max(1) as f64;
    let mean = s1 / n;
    let var = (s2 / n - mean * mean).max(0.0) * n / (n - 1.0).max(1.0);
    (mean, var)
}

/// Max relative reciprocity error |f(a,b) − f(b,a)| / max(f(a,b), f(b,a), floor) over random
/// pairs of upper-hemisphere directions (uniform in solid angle) and the three channels;
/// floor = 1e-6 sr⁻¹ so that values at the f32 noise level of a vanishing lobe do not count.
pub fn reciprocity_error(b: &dyn Brdf, pairs: usize, seed: u64) -> f64 {
    let floor = 1e-6f64;
    (0..pairs)
        .map(|i| {
            let a = uniform_hemisphere(Vec2::new(rand(seed, i, 0), rand(seed, i, 1)));
            let c = uniform_hemisphere(Vec2::new(rand(seed, i, 2), rand(seed, i, 3)));
            let fab = dvec(b.eval(a, c));
            let fba = dvec(b.eval(c, a));
            let mut e = 0.0f64;
            for k in 0..3 {
                let d = (fab[k] - fba[k]).abs() / fab[k].max(fba[k]).max(floor);
                e = e.max(if d.is_finite() { d } else { f64::INFINITY });
            }
            e
        })
        .fold(0.0, f64::max)
}

/// Uniform direction on the upper hemisphere, z in (0, 1].
fn uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = 1.0 - u.x; // (0, 1]
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// The outcome of [`sample_consistency`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SampleConsistency {
    /// Non-delta samples checked.
    pub samples: usize,
    /// Max |s.pdf − pdf(given, s.wi)| / pdf(given, s.wi).
    pub pdf_rel_error: f64,
    /// Max over channels of |s.weight − f·cosθ/pdf| / max(f·cosθ/pdf, 1e-6).
    pub weight_rel_error: f64,
    /// Samples whose weight, pdf or direction is not finite, or whose direction is not unit.
    pub bad_samples: usize,
    /// Delta samples whose pdf is not 0 (the interface says 0).
    pub delta_with_pdf: usize,
}

/// Checks that every sample agrees with `pdf` and `eval`: the sample's pdf equals
/// `pdf(given, wi)` and its weight equals f(wi, given)·cosθi / pdf (non-delta samples).
pub fn sample_consistency(
    b: &dyn Brdf,
    given: Vec3,
    samples: usize,
    seed: u64,
) -> SampleConsistency {
    let mut r = SampleConsistency::default();
    for i in 0..samples {
        let (ul, u) = sample_inputs(seed, i);
        let Some(s) = b.sample(given, ul, u) else {
            continue;
        };
        if !(s.wi.is_finite() && s.weight.is_finite() && s.pdf.is_finite())
            || (s.wi.length() - 1.0).abs() > 1e-3
        {
            r.bad_samples += 1;
            continue;
        }
        if s.delta {
            if s.pdf != 0.0 {
                r.delta_with_pdf += 1;
            }
            continue;
        }
        r.samples += 1;
        let p = b.pdf(given, s.wi) as f64;
        let sp = s.pdf as f64;
        if p > 0.0 {
            r.pdf_rel_error = r.pdf_rel_error.max((sp - p).abs() / p);
        } else {
            r.pdf_rel_error = f64::INFINITY;
        }
        if sp > 0.0 {
            let expect = dvec(b.eval(s.wi, given)) * (s.wi.z.max(0.0) as f64) / sp;
            let w = dvec(s.weight);
            for k in 0..3 {
                let d = (w[k] - expect[k]).abs() / expect[k].abs().max(1e-6);
                r.weight_rel_error = r.weight_rel_error.max(d);
            }
        }
    }
    r
}

/// For the lobe models' unit tests: at the normal, at 30°, at grazing (down to z = 1e-30) and
/// at `extra` directions, `eval` and `pdf` between every two are finite and non-negative, and
/// every sample drawn from each (lobe choice 0 and 0.99; u at the origin, at the far edge and
/// in the middle) has a finite weight, a positive pdf and a unit direction above the surface.
/// `label` names the model in failure messages.
#[cfg(test)]
pub(crate) fn assert_finite_at_mirror_and_grazing(m: &dyn Brdf, extra: &[Vec3], label: &str) {
    let mut dirs = vec![
        Vec3::Z,
        dir_from_theta_deg(89.9999, 0.0),
        dir_from_theta_deg(89.9999, 180.0),
        Vec3::new(1.0, 0.0, 1e-30),
        Vec3::new(-1.0, 0.0, 1e-30),
        Vec3::new(-1.0, 0.0, 1e-12),
        dir_from_theta_deg(30.0, 180.0),
        dir_from_theta_deg(30.0, 0.0),
    ];
    dirs.extend_from_slice(extra);
    let dirs = &dirs[..];
    assert_eval_pdf_finite(m, dirs, label);
    for &a in dirs {
        for ul in [0.0, 0.99] {
            for u in [
                Vec2::ZERO,
                Vec2::new(0.999_999_9, 0.5),
                Vec2::new(0.5, 0.25),
            ] {
                if let Some(s) = m.sample(a, ul, u) {
                    assert!(s.weight.is_finite() && s.pdf > 0.0 && s.wi.z > 0.0);
                    assert!((s.wi.length() - 1.0).abs() < 1e-5);
                }
            }
        }
    }
}

/// For the unit tests of the models with a delta lobe (Cook–Torrance, He, Schlick): at the
/// normal, near it, at 30° and 45° in and across the plane of incidence, at grazing and at the
/// horizon (z = 1e-7), `eval` and `pdf` between every two directions are finite and
/// non-negative, and every sample drawn from each (u on an 8 × 8 grid, each lobe choice of
/// `u_lobes`) has a finite weight and pdf and a unit direction above the surface.
#[cfg(test)]
pub(crate) fn assert_finite_on_sample_grid(m: &dyn Brdf, u_lobes: &[f32], label: &str) {
    let d = dir_from_theta_deg;
    let dirs = [
        Vec3::Z,
        d(1e-3, 0.0),
        d(1e-3, 10.0),
        d(30.0, 0.0),
        d(30.0, 180.0),
        d(45.0, 0.0),
        d(45.0, 90.0),
        d(45.0, 180.0),
        d(89.9, 0.0),
        d(89.9, 180.0),
        d(89.99, 180.0),
        d(89.999, 90.0),
        Vec3::new(1.0, 0.0, 1e-7).normalize(),
        Vec3::new(-1.0, 0.0, 1e-7).normalize(),
        Vec3::new(0.0, -1.0, 1e-7).normalize(),
    ];
    assert_eval_pdf_finite(m, &dirs, label);
    for a in dirs {
        for i in 0..64 {
            let u = Vec2::new((i % 8) as f32 / 8.0, (i / 8) as f32 / 8.0);
            for &ul in u_lobes {
                if let Some(s) = m.sample(a, ul, u) {
                    assert!(
                        s.weight.is_finite() && s.pdf.is_finite(),
                        "{label} {a}: {s:?}"
                    );
                    assert!(
                        s.wi.z > 0.0 && (s.wi.length() - 1.0).abs() < 1e-4,
                        "{label} {a}: {s:?}"
                    );
                }
            }
        }
    }
}

#[cfg(test)]
fn assert_eval_pdf_finite(m: &dyn Brdf, dirs: &[Vec3], label: &str) {
    for &a in dirs {
        for &b in dirs {
            let f = m.eval(a, b);
            assert!(
                f.is_finite() && f.min_element() >= 0.0,
                "{label} {a} {b}: {f}"
            );
            let p = m.pdf(a, b);
            assert!(p.is_finite() && p >= 0.0, "{label} {a} {b}: {p}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gamma_q_matches_known_values() {
        // Q(1, x) = e^{-x}; χ²(2) survival = e^{-x/2}.
        for x in [0.1f64, 1.0, 3.0, 10.0] {
            assert!((gamma_q(1.0, x) - (-x).exp()).abs() < 1e-12);
            assert!((chi2_survival(2.0, x) - (-0.5 * x).exp()).abs() < 1e-12);
        }
        // Q(1/2, x) = erfc(√x).
        for x in [0.01f64, 0.5, 2.0, 8.0] {
            let e = libm::erfc(x.sqrt());
            assert!((gamma_q(0.5, x) - e).abs() < 1e-12 * e.max(1e-3), "{x}");
        }
        // χ²(100) at its 5 % upper quantile 124.342.
        assert!((chi2_survival(100.0, 124.342) - 0.05).abs() < 1e-4);
        // Large dof: median ≈ k(1 − 2/(9k))³.
        let k: f64 = 3000.0;
        let med = k * (1.0 - 2.0 / (9.0 * k)).powi(3);
        assert!((chi2_survival(k, med) - 0.5).abs() < 2e-3);
    }

    #[test]
    fn sidak_level() {
        assert!((sidak(0.01, 1) - 0.01).abs() < 1e-15);
        assert!(
            (sidak(0.01, 10) - 0.001_004_528_708).abs() < 1e-12,
            "{}",
            sidak(0.01, 10)
        );
    }

    #[test]
    fn directions_are_unit_and_placed() {
        let w = dir_from_theta_deg(60.0, 90.0);
        assert!((w.length() - 1.0).abs() < 1e-6);
        assert!((w.z - 0.5).abs() < 1e-6 && w.x.abs() < 1e-6 && w.y > 0.8);
    }
}
