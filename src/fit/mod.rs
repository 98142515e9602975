//! Fitting the survey's models to a measured material (`brdfwave brdf fit`), after Ngan, Durand
//! and Matusik (2005, "Experimental analysis of BRDF models"), who fitted analytic models to the
//! MERL database the same way.
//!
//! **Loss.** The weighted RMS over the domain of ∛(f_fit cosθi) − ∛(f_measured cosθi), the
//! channels averaged ([`loss::loss`]). Ngan et al. fit the cosine-weighted BRDF, f cosθi (what
//! a rendering integrates against the light); taken as it is, the squared error of that quantity
//! is ruled by the few cells of the specular peak, whose values are orders of magnitude above the
//! rest, and a fit can miss the whole off-specular shape. The cube root compresses that range as
//! the eye does (it is the exponent of CIE lightness); Forés, Ferwerda and Gu (2012, "Toward a
//! perceptually based metric for BRDF modeling") compared the metrics in use and found that
//! fits by the cube-root metric match the measured materials best in renderings, most of all for
//! sharp lobes. Löw et al.'s (2012) log metric, ln(1 + f cosθi), behaves alike but depends on the
//! unit of f (the 1 sets which values count as small); the cube root is scale-free.
//!
//! **Domain.** The centres of a strided subset of the MERL cells ([`loss::samples`]: about
//! `samples` cells of the grid, θh sampled twice as densely as θd and φd, so that the √θh
//! spacing keeps most of them near the peak; about half lie inside the cut-off), each weighted by its measure dωi dωo so that the sum approximates the
//! integral over pairs of directions. Both directions within `max_theta` of the normal (80° by
//! default, Ngan et al.'s cut-off: measurements toward grazing are the least reliable, and a
//! model's grazing behaviour would otherwise rule the fit); cells with a missing channel are left
//! out. The optimiser works on an even thinning of these to at most `fit_samples`; the final
//! error, the ranking and the plots use them all.
//!
//! **Parameters and bounds** from the registry ([`space`]): the model file's `PARAMS`, their
//! declared ranges and defaults; nothing is listed per model here.
//!
//! **Variants.** A model's name stands for each of its variants, one option of each of its
//! choice parameters ([`space::ModelSpec::expand`]: Ward's three normalisations, Cook–Torrance's
//! distribution × geometry × Fresnel term, …), and each variant is a fit of its own, ranked
//! with the others by its error. Variants can be nested (a conductor's Fresnel term with κ = 0
//! is the dielectric one): on data of the smaller one the larger fits as well, and may rank
//! first, as that smaller one.
//!
//! **Optimiser.** Nelder–Mead on the unit cube of the parameters' coordinates
//! ([`nelder_mead`]), in three stages, because the colour coefficients make the space large
//! (He has four RGB parameters) while the lobe's shape is shared by the channels:
//! 1. *shape*: every RGB parameter grey (one coordinate), all channels compared; the starts
//!    are the defaults and a Halton set of `screen` points, of which the `starts` best are run
//!    (several starts, because these fits have local minima: a narrow lobe on the peak against a
//!    wide one under the diffuse floor);
//! 2. *colour*: the scalars held, each channel's coefficients fitted to that channel alone
//!    (every model's channel c depends only on its RGB parameters' channel c), from the best of
//!    the shape's values and `screen` Halton points of the channel's coefficients (where a
//!    coefficient changes the lobe's shape per channel, a conductor's η and κ, the grey values
//!    of stage 1 can sit in a region where the channel's error does not change, F = 1);
//! 3. *polish*: the scalars again with the colours held, then the colours once more.
//!
//! Candidates are built through the model's own parser, so every bound and constraint of the
//! scene format holds for the result; a candidate the parser refuses has infinite loss. The
//! models are fitted in parallel (rayon), the starts of a model too, on the CPU models.
//!
//! Outputs: [`report`] (`fit.md`, `fit.csv`, `materials.toml`, the lineup scene) and [`plots`]
//! (the plane of incidence at θi = 0/30/60/75°, the θh × θd error slices); the command is
//! `src/cmd/fit.rs`.

pub mod loss;
pub mod nelder_mead;
pub mod plots;
pub mod report;
pub mod space;

use crate::brdf::Brdf;
use crate::measured::merl::MerlTable;
use anyhow::Result;
use glam::Vec3;
use loss::{Channels, Sample};
use rayon::prelude::*;
use space::{ModelSpec, Space};
use std::sync::Arc;
use std::time::Instant;

/// How a fit is run.
#[derive(Clone, Copy, Debug)]
pub struct FitOptions {
    /// About how many MERL cells the final error, the ranking and the plots compare.
    pub samples: usize,
    /// At most this many of them (an even thinning) drive the optimiser: enough for a handful
    /// of parameters, and what keeps He's fit (its series costs ~200 times Ward's evaluation)
    /// to seconds.
    pub fit_samples: usize,
    /// Grazing cut-off, degrees from the normal, for both directions.
    pub max_theta_deg: f32,
    /// Nelder–Mead runs of the shape stage.
    pub starts: usize,
    /// Points screened for those starts.
    pub screen: usize,
    /// Evaluations per Nelder–Mead run.
    pub max_evals: usize,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            samples: 6000,
            fit_samples: 800,
            max_theta_deg: 80.0,
            starts: 3,
            screen: 32,
            max_evals: 300,
        }
    }
}

/// One model's best fit.
#[derive(Clone, Debug)]
pub struct ModelFit {
    pub space: Space,
    /// The fitted values, one per fitted parameter (`space.bounds`), grey for scalars.
    pub values: Vec<Vec3>,
    pub brdf: Arc<dyn Brdf>,
    /// The final loss.
    pub error: f64,
    /// Loss evaluations spent.
    pub evals: usize,
    pub seconds: f64,
}

impl ModelFit {
    /// The material's fields as TOML (the fitted parameters and the fixed ones).
    pub fn material_text(&self) -> String {
        self.space.spec.text(&self.space.fields(&self.values))
    }
}

/// The i-th point of the Halton sequence in `dims` dimensions (bases: the first primes).
fn halton(i: usize, dims: usize) -> Vec<f64> {
    const PRIMES: [usize; 16] = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53];
    (0..dims)
        .map(|d| {
            let b = PRIMES[d % PRIMES.len()];
            let (mut f, mut r, mut n) = (1.0, 0.0, i + 1);
            while n > 0 {
                f /= b as f64;
                r += f * (n % b) as f64;
                n /= b;
            }
            r
        })
        .collect()
}

/// Which values one stage's coordinates move: (parameter, channel or all three).
type Coords = Vec<(usize, Option<usize>)>;

struct Stage<'a> {
    space: &'a Space,
    samples: &'a [Sample],
    channels: Channels,
    coords: Coords,
    base: Vec<Vec3>,
}

impl Stage<'_> {
    fn values(&self, u: &[f64]) -> Vec<Vec3> {
        let mut v = self.base.clone();
        for (&(p, ch), &x) in self.coords.iter().zip(u) {
            let value = self.space.bounds[p].value(x);
            match ch {
                Some(c) => v[p][c] = value,
                None => v[p] = Vec3::splat(value),
            }
        }
        v
    }
    fn loss(&self, u: &[f64]) -> f64 {
        match self.space.material(&self.values(u)) {
            Ok(m) => loss::loss(m.as_ref(), self.samples, self.channels),
            Err(_) => f64::INFINITY,
        }
    }
    fn unit_of(&self, values: &[Vec3]) -> Vec<f64> {
        self.coords
            .iter()
            .map(|&(p, ch)| {
                let v = match ch {
                    Some(c) => values[p][c],
                    None => values[p].element_sum() / 3.0,
                };
                self.space.bounds[p].unit(v)
            })
            .collect()
    }
    /// The `starts` best of `first` and `opt.screen` Halton points, and the evaluations spent
    /// screening them.
    fn screened(&self, first: Vec<f64>, starts: usize, opt: &FitOptions) -> (Vec<Vec<f64>>, usize) {
        let mut candidates = vec![first];
        candidates.extend((0..opt.screen).map(|i| halton(i, self.coords.len())));
        let evals = candidates.len();
        let mut screened: Vec<(f64, Vec<f64>)> = candidates
            .into_par_iter()
            .map(|u| (self.loss(&u), u))
            .collect();
        screened.sort_by(|a, b| a.0.total_cmp(&b.0));
        let starts = screened
            .into_iter()
            .take(starts.max(1))
            .map(|(_, u)| u)
            .collect();
        (starts, evals)
    }
    /// Runs Nelder–Mead from each start; the best values, loss and evaluations.
    fn run(&self, starts: &[Vec<f64>], opt: &FitOptions) -> (Vec<Vec3>, f64, usize) {
        let nm = nelder_mead::Options {
            max_evals: opt.max_evals,
            ..Default::default()
        };
        let runs: Vec<_> = starts
            .par_iter()
            .map(|s| nelder_mead::minimize(|u| self.loss(u), s, nm))
            .collect();
        let evals = runs.iter().map(|r| r.evals).sum();
        let best = runs
            .into_iter()
            .min_by(|a, b| a.f.total_cmp(&b.f))
            .expect("at least one start");
        (self.values(&best.x), best.f, evals)
    }
}

/// Fits one model to the samples.
pub fn fit_model(spec: ModelSpec, all: &[Sample], opt: &FitOptions) -> Result<ModelFit> {
    let t0 = Instant::now();
    let stride = all.len().div_ceil(opt.fit_samples.max(1)).max(1);
    let thinned: Vec<Sample> = all.iter().step_by(stride).copied().collect();
    let samples = thinned.as_slice();
    let probes: Vec<(Vec3, Vec3)> = all.iter().step_by(97).map(|s| (s.wi, s.wo)).collect();
    let space = Space::new(spec, &probes)?;
    let n = space.bounds.len();
    let rgb = space.rgb_indices();
    let scalars: Vec<usize> = (0..n).filter(|i| !rgb.contains(i)).collect();
    let stage = |channels, coords: Coords, base: Vec<Vec3>| Stage {
        space: &space,
        samples,
        channels,
        coords,
        base,
    };
    // 1. Shape: grey colours, screened starts.
    let shape = stage(
        Channels::All,
        (0..n).map(|p| (p, None)).collect(),
        space.defaults(),
    );
    let (starts, screen_evals) = shape.screened(shape.unit_of(&space.defaults()), opt.starts, opt);
    let (mut values, _, mut evals) = shape.run(&starts, opt);
    evals += screen_evals;
    // 2. Colour per channel, 3. polish the scalars, then the colours again.
    let colour = |values: &mut Vec<Vec3>, evals: &mut usize, screen: bool| {
        let fits: Vec<(Vec<Vec3>, usize)> = (0..3)
            .into_par_iter()
            .map(|c| {
                let s = stage(
                    Channels::One(c),
                    rgb.iter().map(|&p| (p, Some(c))).collect(),
                    values.clone(),
                );
                let here = s.unit_of(values);
                let (starts, screen_evals) = match screen {
                    true => s.screened(here, 1, opt),
                    false => (vec![here], 0),
                };
                let (v, _, e) = s.run(&starts, opt);
                (v, e + screen_evals)
            })
            .collect();
        for (c, (v, e)) in fits.into_iter().enumerate() {
            for &p in &rgb {
                values[p][c] = v[p][c];
            }
            *evals += e;
        }
    };
    if !rgb.is_empty() {
        colour(&mut values, &mut evals, true);
        if !scalars.is_empty() {
            let s = stage(
                Channels::All,
                scalars.iter().map(|&p| (p, None)).collect(),
                values.clone(),
            );
            let (v, _, e) = s.run(&[s.unit_of(&values)], opt);
            values = v;
            evals += e;
            colour(&mut values, &mut evals, false);
        }
    }
    let brdf = space.material(&values)?;
    let error = loss::loss(brdf.as_ref(), all, Channels::All);
    Ok(ModelFit {
        space,
        values,
        brdf,
        error,
        evals,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// Fits every model in `specs` to the table, in parallel; in the order given.
pub fn fit_all(table: &MerlTable, specs: &[ModelSpec], opt: &FitOptions) -> Result<Vec<ModelFit>> {
    let samples = loss::samples(table, loss::strides(opt.samples), opt.max_theta_deg);
    if samples.len() < 16 {
        anyhow::bail!(
            "only {} measured cells inside the {}° cut-off: too few to fit (is the file mostly \
             missing values?)",
            samples.len(),
            opt.max_theta_deg
        );
    }
    specs
        .par_iter()
        .map(|s| fit_model(s.clone(), &samples, opt))
        .collect()
}
