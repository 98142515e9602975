//! The `gpu_math` group: the GLSL math helpers against f64 references (see the
//! [`crate::stress`] module documentation).

use super::harness::{CaseResult, Env};
use super::models::quiet_material;
use super::rng::Rng;
use anyhow::Result;

/// f64 reference of He's series, Σ_{m≥1} gᵐe^(−g)/(m!·m) · exp(−c/m) (the D of survey eq. 12;
/// `brdf::he::series`), brute force: every term from m = 1 up to where the terms
/// have fallen by e^-60 from the largest and keep falling geometrically (the ratio of
/// consecutive terms decreases with m, so once it is below ½ the rest is less than the last
/// term). No window. Also the reference of `tests/brdf_he.rs`.
pub fn he_series_f64(g: f64, c: f64) -> f64 {
    let ln_t = |m: f64| m * g.ln() - g - libm::lgamma(m + 1.0) - m.ln() - c / m;
    let (mut sum, mut best, mut m) = (0.0f64, f64::NEG_INFINITY, 1.0f64);
    loop {
        let l = ln_t(m);
        best = best.max(l);
        sum += l.exp();
        if (l < best - 60.0 && ln_t(m + 1.0) - l < -std::f64::consts::LN_2) || m > 1e7 {
            return sum;
        }
        m += 1.0;
    }
}

/// One GLSL helper over 256 arguments across its range against an f64 reference. The error is
/// reported as a fraction of the tolerance, which follows the precision Vulkan allows (exp and
/// exp2 to 3 + 2|x| ulp, log to 3 ulp or 2^-21 absolute near 1) with a margin.
pub(super) fn case_gpu_math(env: &mut Env, seed: u64) -> Result<CaseResult> {
    let mut r = Rng::new(seed);
    let op = (r.next_u64() % 5) as u32;
    let mut inputs = Vec::new();
    for k in 0..256 {
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        let (x, y) = match op {
            0 => (sign * r.extreme(0.0, 10.0, 1e-6), 0.0),
            1 => (sign * r.extreme(0.0, 80.0, 1e-7), 0.0),
            2 => {
                if sign > 0.0 {
                    (r.extreme(0.0, 1e30, 1e-7), 0.0)
                } else {
                    (-r.extreme(0.0, 0.999_999, 1e-7), 0.0)
                }
            }
            3 => (r.extreme(0.0, 1.0, 1e-7), r.extreme(0.0, 1e6, 1e-3)),
            _ => {
                let g = r.log_range(1e-6, 1e4);
                (g, g.max(1.0) * r.extreme(0.0, 1e4, 1e-3))
            }
        };
        inputs.push((x, y));
    }
    let m = quiet_material(r#"model = "he", sigma0 = 0.5, tau = 3"#)?;
    let (ctx, compiler) = env.gpu()?;
    let got = crate::gpu::brdf_probe::math(ctx, compiler, &m, op, &inputs)?;
    let name = ["erfc", "expm1_f", "log1p_f", "pow_one_minus", "he_series"][op as usize];
    let eps = f32::EPSILON as f64;
    let mut worst = 0.0f64;
    for (&(x, y), &g) in inputs.iter().zip(&got) {
        let (x64, y64) = (x as f64, y as f64);
        let (want, tol) = match op {
            0 => {
                let w = libm::erfc(x64);
                // The exp of up to -100 - 1.3: (3 + 2·101) ulp, the fit 1.2e-7.
                (w, w * ((3.0 + 2.0 * (x64 * x64 + 1.3)) * eps + 2e-7) * 2.0)
            }
            1 => {
                let w = x64.exp_m1();
                let e = (3.0 + 2.0 * x64.abs()) * eps * x64.exp();
                (w, (e + 1e-6 * w.abs()) * 2.0)
            }
            2 => {
                let w = x64.ln_1p();
                (
                    w,
                    (2f64.powi(-21) + 3.0 * eps * w.abs() + 1e-6 * w.abs()) * 2.0,
                )
            }
            3 => {
                let w = (y64 * (-x64).ln_1p()).exp();
                let arg = (y64 * (-x64).ln_1p()).abs();
                // log1p's relative error times n, then exp's (3 + 2|arg|) ulp.
                (w, w * (arg * 4e-7 + (3.0 + 2.0 * arg) * eps) * 2.0)
            }
            _ => {
                let w = he_series_f64(x64, y64);
                (w, w * 2e-3)
            }
        };
        if want.abs() < 1e-30 && (g as f64).abs() < 1e-29 {
            continue; // both underflow: nothing to compare in f32
        }
        let tol = tol.max(1e-30);
        let e = (g as f64 - want).abs() / tol;
        if e.is_finite() {
            worst = worst.max(e);
        }
        if e.is_nan() || e > 1.0 {
            return Ok(CaseResult::fail(
                e,
                format!(
                    "GLSL {name}({x:e}, {y:e}) = {g:e}, f64 reference {want:e}, tolerance {tol:e}"
                ),
            ));
        }
    }
    Ok(CaseResult::ok(worst))
}
