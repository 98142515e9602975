//! The `radiance` group: emitters and environment scaled across the f32 range scale the image
//! linearly (see the [`crate::stress`] module documentation).

use super::harness::{backend_name, render_on, small, CaseResult, Env};
use super::rng::Rng;
use anyhow::Result;
use glam::Vec3;

pub(super) fn case_radiance(env: &mut Env, seed: u64) -> Result<CaseResult> {
    let mut r = Rng::new(seed);
    let gpu = r.next_u64() % 4 == 0;
    let mut base = small(env.cornell()?, 8, 4, (seed & 0xffff) as u32);
    let env_light = r.next_u64() % 2 == 0;
    if env_light {
        // Open the box: no ceiling/back wall in view matters little; a constant environment
        // reaches the camera through the open front.
        base.environment = Vec3::new(0.3, 0.5, 0.7);
    }
    let lmax = base
        .emitters
        .iter()
        .map(|e| e.radiance.max_element())
        .fold(base.environment.max_element(), f32::max);
    let k = r.log_range(1e-30, 3.0e38 / lmax);
    let mut scaled = base.clone();
    for e in &mut scaled.emitters {
        e.radiance *= k;
    }
    scaled.environment *= k;
    let (a, b) = (render_on(env, &base, gpu)?, render_on(env, &scaled, gpu)?);
    let (ma, mb) = (a.mean.mean(), b.mean.mean());
    let mut worst = 0.0f64;
    for c in 0..3 {
        if ma[c] <= 0.0 {
            continue;
        }
        let want = ma[c] * k as f64;
        let e = (mb[c] - want).abs() / want;
        worst = worst.max(e);
    }
    let backend = backend_name(gpu);
    // The light-selection density and the f32 products round differently at each scale;
    // subnormal products below 1e-38 lose digits (radiance 1e-30 times small throughputs).
    let tol = if k < 1e-20 { 1e-2 } else { 1e-4 };
    if b.nonfinite_samples > 0 || worst > tol {
        return Ok(CaseResult::fail(worst, format!("{backend}: radiance × {k:e} (environment {env_light}): means {mb:?}, expected {ma:?} × k; {} non-finite", b.nonfinite_samples)));
    }
    Ok(CaseResult::ok(worst))
}
