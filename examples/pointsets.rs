//! The samplers' 2-D point sets on test integrands: the variance of the N-sample estimate over
//! many pixels, for `independent`, `sobol` and `multijitter` at N = 16, 64 and 256 (the figures
//! of BENCHMARKS.md, "Multi-jittered points"). Run with
//! `cargo run --release --example pointsets`.
use brdfwave::rng::{dim, Sampler};
use std::f64::consts::PI;

/// The concentric map of the unit square to the disk, lifted to the hemisphere (the
/// cosine-weighted direction a Lambertian BSDF samples).
fn cosine_direction(x: f64, y: f64) -> (f64, f64, f64) {
    let (a, b) = (2.0 * x - 1.0, 2.0 * y - 1.0);
    let (r, phi) = if a == 0.0 && b == 0.0 {
        (0.0, 0.0)
    } else if a.abs() > b.abs() {
        (a, PI / 4.0 * b / a)
    } else {
        (b, PI / 2.0 - PI / 4.0 * a / b)
    };
    let (dx, dy) = (r * phi.cos(), r * phi.sin());
    (dx, dy, (1.0 - dx * dx - dy * dy).max(0.0).sqrt())
}

type Integrand = (&'static str, fn(f64, f64) -> f64);

fn main() {
    let integrands: [Integrand; 5] = [
        ("disk", |x, y| {
            ((x - 0.5).powi(2) + (y - 0.45).powi(2) < 0.09) as u8 as f64
        }),
        ("edge", |x, y| (x + 0.37 * y < 0.61) as u8 as f64),
        ("gaussian", |x, y| {
            (-((x - 0.4).powi(2) + (y - 0.6).powi(2)) * 8.0).exp()
        }),
        // A rectangular window seen through cosine-weighted directions.
        ("window", |x, y| {
            let (dx, dy, dz) = cosine_direction(x, y);
            (dz > 0.0 && (dx / dz - 0.3).abs() < 0.5 && (dy / dz + 0.2).abs() < 0.4) as u8 as f64
        }),
        // A smooth radiance over the hemisphere.
        ("hemisphere", |x, y| {
            let (dx, _, dz) = cosine_direction(x, y);
            (1.0 + dx) * dz
        }),
    ];
    let pixels = 20_000u32;
    println!("variance of the N-sample mean over {pixels} pixels (BSDF direction pair, depth 1)");
    println!(
        "{:>4} {:<11} {:>12} {:>12} {:>12}",
        "N", "integrand", "independent", "sobol", "multijitter"
    );
    for n in [16u32, 64, 256] {
        for (name, f) in &integrands {
            let mut line = format!("{n:>4} {name:<11}");
            for sampler in [Sampler::Independent, Sampler::Sobol, Sampler::Multijitter] {
                let (mut s1, mut s2) = (0.0, 0.0);
                for p in 0..pixels {
                    let e = (0..n)
                        .map(|i| {
                            let u = sampler.get(1, n, p, i, 1, dim::BSDF_U) as f64;
                            let v = sampler.get(1, n, p, i, 1, dim::BSDF_V) as f64;
                            f(u, v)
                        })
                        .sum::<f64>()
                        / n as f64;
                    s1 += e;
                    s2 += e * e;
                }
                let mean = s1 / pixels as f64;
                line += &format!(" {:>12.3e}", s2 / pixels as f64 - mean * mean);
            }
            println!("{line}");
        }
    }
}
