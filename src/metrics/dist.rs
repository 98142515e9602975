//! The distributions the statistical tests need: two-sided tail probabilities of the standard
//! normal and of Student's t, their inverses (critical values), and the Welch–Satterthwaite
//! degrees of freedom of a sum of variance estimates.
//!
//! Student's t tail is the regularized incomplete beta function,
//! P(|T| > t) = I_x(ν/2, 1/2) with x = ν / (ν + t²) (Abramowitz & Stegun 1964, eq. 26.7.1 with
//! 26.5.27), evaluated by its continued fraction (DLMF §8.17(v), eq. 8.17.22) with the modified
//! Lentz method (Thompson & Barnett 1986), on the side of x where it converges fast (DLMF
//! eq. 8.17.4 otherwise). The tail is computed directly, so p-values far below machine epsilon
//! keep their relative accuracy.

use std::f64::consts::SQRT_2;

/// Degrees of freedom above which Student's t is the normal distribution to well within the
/// accuracy a test needs (the tail ratio at |t| = 6 is 1 + 3e-6).
const NORMAL_DOF: f64 = 1e7;

/// P(|Z| > |z|) for a standard normal Z.
pub fn normal_two_sided(z: f64) -> f64 {
    libm::erfc(z.abs() / SQRT_2)
}

/// P(|T| > |t|) for Student's t with `dof` degrees of freedom (> 0; infinite or very large is
/// the normal distribution). NaN `t` gives 0 (a test that cannot be computed fails).
pub fn t_two_sided(t: f64, dof: f64) -> f64 {
    if t.is_nan() {
        return 0.0;
    }
    if t.is_infinite() {
        return 0.0;
    }
    if dof.is_nan() || dof >= NORMAL_DOF {
        return normal_two_sided(t);
    }
    let dof = dof.max(1e-3);
    let x = dof / (dof + t * t);
    incomplete_beta(x, dof / 2.0, 0.5).clamp(0.0, 1.0)
}

/// The critical value c > 0 with P(|T| > c) = p for Student's t with `dof` degrees of freedom
/// (normal for infinite `dof`), 0 < p < 1: bisection on the monotone tail, to a relative 1e-12.
pub fn t_critical(p: f64, dof: f64) -> f64 {
    debug_assert!(p > 0.0 && p < 1.0, "a two-sided level in (0, 1)");
    let tail = |t: f64| t_two_sided(t, dof);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while tail(hi) > p {
        lo = hi;
        hi *= 2.0;
        if hi > 1e300 {
            return f64::INFINITY;
        }
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if tail(mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// The standard normal quantile z with P(Z < z) = q, 0 < q < 1 (for the power of a test).
pub fn normal_quantile(q: f64) -> f64 {
    // P(|Z| > c) = 2 (1 − q) for q > 1/2.
    if q > 0.5 {
        t_critical(2.0 * (1.0 - q), f64::INFINITY)
    } else if q < 0.5 {
        -t_critical(2.0 * q, f64::INFINITY)
    } else {
        0.0
    }
}

/// The Welch–Satterthwaite degrees of freedom of an estimate V = Σ v_i whose terms have ν_i
/// degrees of freedom, given V and W = Σ v_i² / ν_i (Satterthwaite 1946): V² / W, infinite when
/// W is 0 (no term is estimated).
pub fn satterthwaite(v: f64, w: f64) -> f64 {
    if w > 0.0 && v > 0.0 {
        v * v / w
    } else {
        f64::INFINITY
    }
}

/// The regularized incomplete beta function I_x(a, b), 0 <= x <= 1, a, b > 0.
fn incomplete_beta(x: f64, a: f64, b: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    // x^a (1 − x)^b / (a B(a, b)), in logs.
    let ln_front =
        libm::lgamma(a + b) - libm::lgamma(a) - libm::lgamma(b) + a * x.ln() + b * libm::log1p(-x);
    // The continued fraction converges fast for x < (a + 1) / (a + b + 2); beyond, use the
    // symmetry I_x(a, b) = 1 − I_{1−x}(b, a).
    if x < (a + 1.0) / (a + b + 2.0) {
        ln_front.exp() * beta_fraction(x, a, b) / a
    } else {
        1.0 - ln_front.exp() * beta_fraction(1.0 - x, b, a) / b
    }
}

/// The continued fraction 1 / (1 + d_1 / (1 + d_2 / (1 + …))) of I_x(a, b) (DLMF 8.17.22), by
/// the modified Lentz method.
fn beta_fraction(x: f64, a: f64, b: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let d = |m: u32| -> f64 {
        let m2 = m / 2;
        let k = m2 as f64;
        if m % 2 == 0 {
            // d_{2k} = k (b − k) x / ((a + 2k − 1)(a + 2k))
            k * (b - k) * x / ((a + 2.0 * k - 1.0) * (a + 2.0 * k))
        } else {
            // d_{2k+1} = −(a + k)(a + b + k) x / ((a + 2k)(a + 2k + 1))
            -(a + k) * (a + b + k) * x / ((a + 2.0 * k) * (a + 2.0 * k + 1.0))
        }
    };
    // f = 1 / (1 + d_1 / (1 + d_2 / …)): Lentz on b_0 = 0, a_1 = 1, b_m = 1, a_{m+1} = d_m.
    let mut f = TINY;
    let mut c = f;
    let mut dd = 0.0;
    for m in 0..10_000u32 {
        let am = if m == 0 { 1.0 } else { d(m) };
        dd = 1.0 + am * dd;
        if dd.abs() < TINY {
            dd = TINY;
        }
        c = 1.0 + am / c;
        if c.abs() < TINY {
            c = TINY;
        }
        dd = 1.0 / dd;
        let delta = c * dd;
        f *= delta;
        if m > 0 && (delta - 1.0).abs() < 1e-15 {
            break;
        }
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * b.abs().max(1e-300)
    }

    /// Closed forms: ν = 1 is the Cauchy distribution, P(|T| > t) = 1 − 2 atan(t) / π; ν = 2
    /// has P(|T| > t) = 1 − t / sqrt(2 + t²); large ν is the normal.
    #[test]
    fn t_tails_match_closed_forms() {
        for t in [0.0, 0.1, 0.5, 1.0, 2.0, 5.0, 30.0, 1e4] {
            let cauchy = 1.0 - 2.0 * f64::atan(t) / std::f64::consts::PI;
            assert!(close(t_two_sided(t, 1.0), cauchy, 1e-10), "t {t}");
            // 1 − t/sqrt(2+t²) = 2 / (sqrt(2+t²) (sqrt(2+t²) + t)), without cancellation.
            let r = (2.0 + t * t).sqrt();
            let two = 2.0 / (r * (r + t));
            assert!(close(t_two_sided(t, 2.0), two, 1e-10), "t {t}");
            assert!(close(t_two_sided(t, 1e9), normal_two_sided(t), 1e-12));
        }
        // ν = 5 at its tabulated 0.05 and 0.01 two-sided critical values (2.5706, 4.0321).
        assert!(close(t_two_sided(2.570_582, 5.0), 0.05, 1e-5));
        assert!(close(t_two_sided(4.032_143, 5.0), 0.01, 1e-5));
        // Far tails keep their accuracy: ν = 2 at t = 1e6.
        let r = (2.0f64 + 1e12).sqrt();
        assert!(close(t_two_sided(1e6, 2.0), 2.0 / (r * (r + 1e6)), 1e-9));
        // Large ν approaches the normal from above (heavier tails).
        let z = 5.0;
        let (p100, p1000, pn) = (
            t_two_sided(z, 100.0),
            t_two_sided(z, 1000.0),
            normal_two_sided(z),
        );
        // At ν = 1000 the tail at 5 is still 18 % heavier (about exp(z⁴ / 4ν)).
        assert!(
            p100 > p1000 && p1000 > pn && close(p1000, pn, 0.25),
            "{p100} {p1000} {pn}"
        );
        assert_eq!(t_two_sided(f64::NAN, 3.0), 0.0);
        assert_eq!(t_two_sided(f64::INFINITY, 3.0), 0.0);
    }

    #[test]
    fn critical_values_invert_the_tails() {
        for dof in [1.0, 2.0, 7.0, 63.0, 1e4, f64::INFINITY] {
            for p in [0.5, 0.05, 1e-3, 1e-6, 1e-9] {
                let c = t_critical(p, dof);
                assert!(close(t_two_sided(c, dof), p, 1e-8), "dof {dof} p {p}");
            }
        }
        assert!(close(t_critical(0.05, f64::INFINITY), 1.959_963_985, 1e-8));
        assert!(close(normal_quantile(0.95), 1.644_853_627, 1e-8));
        assert!(close(normal_quantile(0.05), -1.644_853_627, 1e-8));
        assert_eq!(normal_quantile(0.5), 0.0);
    }

    #[test]
    fn satterthwaite_degrees_of_freedom() {
        // One term: its own ν. Two equal terms of ν each: 2ν.
        assert!(close(satterthwaite(3.0, 9.0 / 7.0), 7.0, 1e-12));
        assert!(close(satterthwaite(2.0, 2.0 / 7.0), 14.0, 1e-12));
        assert_eq!(satterthwaite(1.0, 0.0), f64::INFINITY);
    }
}
