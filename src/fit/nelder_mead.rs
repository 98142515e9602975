//! Nelder and Mead's (1965) downhill simplex on the unit cube, with the adaptive coefficients of
//! Gao and Han (2012) (reflection 1, expansion 1 + 2/n, contraction 0.75 − 1/(2n), shrink
//! 1 − 1/n), which keep the method effective beyond a few dimensions. Points outside the cube are
//! projected back onto it, so the bounds of every parameter hold without penalties. It needs no
//! gradients (several models are not smooth in their parameters: clamps, floors), and a few
//! hundred evaluations per start are enough for the 1–6 coordinates of a stage ([`super`]).

/// When to stop: after `max_evals` evaluations, or when the simplex is smaller than `x_tol` in
/// every coordinate and its values agree within `f_tol` (relative).
#[derive(Clone, Copy, Debug)]
pub struct Options {
    pub max_evals: usize,
    pub x_tol: f64,
    pub f_tol: f64,
    /// Edge of the initial simplex (unit-cube units).
    pub step: f64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            max_evals: 600,
            x_tol: 1e-4,
            f_tol: 1e-7,
            step: 0.1,
        }
    }
}

/// The best point found, its value and the evaluations spent.
#[derive(Clone, Debug)]
pub struct Minimum {
    pub x: Vec<f64>,
    pub f: f64,
    pub evals: usize,
}

fn project(x: &mut [f64]) {
    for v in x {
        *v = if v.is_finite() {
            v.clamp(0.0, 1.0)
        } else {
            0.5
        };
    }
}

/// Minimises `f` over [0, 1]ⁿ from `x0`. A simplex pressed onto a face of the cube by the
/// projection collapses there and can no longer move along the face, and any simplex can
/// stall in a valley; so each run that ends is restarted from its best point with a fresh
/// simplex, until a restart no longer improves (Nelder–Mead with restarts, as is usual) or the
/// evaluations are spent.
pub fn minimize(f: impl Fn(&[f64]) -> f64, x0: &[f64], opt: Options) -> Minimum {
    let mut best = run(&f, x0, opt);
    while best.evals < opt.max_evals {
        let left = Options {
            max_evals: opt.max_evals - best.evals,
            ..opt
        };
        let next = run(&f, &best.x, left);
        let evals = best.evals + next.evals;
        let improved = next.f < best.f - opt.f_tol * best.f.abs().max(1e-12);
        if next.f < best.f {
            best = Minimum { evals, ..next };
        } else {
            best.evals = evals;
        }
        if !improved {
            break;
        }
    }
    best
}

/// One Nelder–Mead run from `x0`.
fn run(f: &impl Fn(&[f64]) -> f64, x0: &[f64], opt: Options) -> Minimum {
    let n = x0.len();
    let evals = std::cell::Cell::new(0usize);
    let eval = |x: &[f64]| {
        evals.set(evals.get() + 1);
        let v = f(x);
        if v.is_nan() {
            f64::INFINITY
        } else {
            v
        }
    };
    let nf = n as f64;
    let (alpha, gamma, rho, sigma) = (
        1.0,
        1.0 + 2.0 / nf,
        0.75 - 1.0 / (2.0 * nf),
        1.0 - 1.0 / nf.max(2.0),
    );
    let mut start = x0.to_vec();
    project(&mut start);
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    let f0 = eval(&start);
    simplex.push((start.clone(), f0));
    for i in 0..n {
        let mut x = start.clone();
        x[i] += if x[i] + opt.step <= 1.0 {
            opt.step
        } else {
            -opt.step
        };
        let v = eval(&x);
        simplex.push((x, v));
    }
    let point = |c: &[f64], w: &[f64], t: f64| -> Vec<f64> {
        let mut p: Vec<f64> = c.iter().zip(w).map(|(a, b)| a + t * (b - a)).collect();
        project(&mut p);
        p
    };
    while evals.get() < opt.max_evals {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best, worst) = (simplex[0].1, simplex[n].1);
        let size = (0..n)
            .map(|k| {
                let (lo, hi) = simplex.iter().fold((1.0f64, 0.0f64), |(lo, hi), (x, _)| {
                    (lo.min(x[k]), hi.max(x[k]))
                });
                hi - lo
            })
            .fold(0.0, f64::max);
        if size < opt.x_tol && (worst - best).abs() <= opt.f_tol * best.abs().max(1e-12) {
            break;
        }
        // The centroid of all but the worst.
        let mut c = vec![0.0; n];
        for (x, _) in &simplex[..n] {
            for k in 0..n {
                c[k] += x[k] / nf;
            }
        }
        let w = simplex[n].0.clone();
        let xr = point(&c, &w, -alpha);
        let fr = eval(&xr);
        if fr < simplex[0].1 {
            let xe = point(&c, &w, -gamma);
            let fe = eval(&xe);
            simplex[n] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[n - 1].1 {
            simplex[n] = (xr, fr);
        } else {
            // Outside contraction if the reflection improved on the worst, inside otherwise.
            let (xc, fc) = if fr < worst {
                let x = point(&c, &w, -rho);
                let v = eval(&x);
                (x, v)
            } else {
                let x = point(&c, &w, rho);
                let v = eval(&x);
                (x, v)
            };
            if fc < fr.min(worst) {
                simplex[n] = (xc, fc);
            } else {
                let b = simplex[0].0.clone();
                for (x, v) in simplex.iter_mut().skip(1) {
                    *x = point(&b, x, sigma);
                    *v = eval(x);
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (x, f) = simplex.swap_remove(0);
    Minimum {
        x,
        f,
        evals: evals.get(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_minimum_of_a_narrow_valley_and_respects_the_cube() {
        // Rosenbrock scaled into the cube: minimum at (0.6, 0.36).
        let rosen = |x: &[f64]| {
            let (a, b) = (x[0], x[1]);
            (0.6 - a).powi(2) + 100.0 * (b - a * a).powi(2)
        };
        let m = minimize(
            rosen,
            &[0.1, 0.9],
            Options {
                max_evals: 2000,
                ..Options::default()
            },
        );
        assert!(
            (m.x[0] - 0.6).abs() < 1e-3 && (m.x[1] - 0.36).abs() < 1e-3,
            "{m:?}"
        );
        // A minimum outside the cube ends on its face.
        let m = minimize(
            |x: &[f64]| (x[0] - 2.0).powi(2) + (x[1] - 0.3).powi(2),
            &[0.5, 0.5],
            Options::default(),
        );
        assert!(
            (m.x[0] - 1.0).abs() < 1e-6 && (m.x[1] - 0.3).abs() < 1e-3,
            "{m:?}"
        );
        assert!(m.evals <= Options::default().max_evals + 4);
    }
}
