//! A global stage before the local fit (issue #12, item 3): Levenberg–Marquardt from several
//! starts spread over the parameter box, the best result kept.
//!
//! The starts are a Latin hypercube (each parameter's range cut into as many strata as there
//! are points, one point per stratum, strata paired at random): space-filling in every single
//! parameter with any number of points, where a grid needs `kᵈ`. Each parameter ranges over
//! its nominal ± `spread` (relative), inside its bounds: the admissible ranges are
//! deliberately wide (they exclude nonsense, not unlikely values), and a start anywhere in
//! them mostly does not simulate. Start 0 is the nominal point itself, so the result is never
//! worse than the plain local fit (where other starts run; a lone start may be held to a cap,
//! [`estimate_multistart_capped`]). The starts run in parallel (rayon); each is a complete
//! [`estimate`], with its own identifiability screen.
//!
//! With [`MultiStart::screen`] the design is first screened, the way MATLAB's `GlobalSearch`
//! scores its trial points before it starts `fmincon` from any: every point's loss from one
//! simulation of each run, and a local fit only from the points that already explain the runs
//! better than the nominal point does, best first. A local fit costs a simulation of every
//! run per freed parameter and iteration, a screened point one of each: on the built-in study
//! four unscreened starts took the `truck` structure's valve fit from 46 to 75 s, two of the three
//! random starts failed and none won; 32 screened points cost about a second.
//!
//! Hand-written because the stage is a loop over the existing local solver: the maintained
//! global optimisers (argmin's particle swarm, `cmaes`) would replace Levenberg–Marquardt
//! rather than seed it, and lose its Jacobian-based uncertainty and identifiability report.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use super::{GreyboxEstimate, GreyboxOptions, GreyboxProblem, estimate, loss_and_steps_at};
use crate::error::EstimateError;
use crate::progress::{NoProgress, Observer};

/// A screened point's simulations may take this many times the nominal point's steps
/// (the most any run took), and at least [`SCREEN_MIN_STEPS`].
const SCREEN_STEP_FACTOR: usize = 5;
const SCREEN_MIN_STEPS: usize = 10_000;

/// How many starts, how far apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultiStart {
    /// Local fits at most, the nominal one included (1: the plain local fit, or one held to
    /// a cap, [`estimate_multistart_capped`]).
    pub count: usize,
    /// Half-width of each parameter's range around its nominal value, relative.
    pub spread: f64,
    pub seed: u64,
    /// Points of the design screened by their loss before any local fit (module docs); the
    /// local fits beside the nominal one start from the best of those that explain the runs
    /// better than the nominal point, `count - 1` at most. 0: no screen, the local fits start
    /// from the design's first `count - 1` points whatever their loss.
    pub screen: usize,
}

impl Default for MultiStart {
    fn default() -> Self {
        Self {
            count: 1,
            spread: 0.5,
            seed: 1,
            screen: 0,
        }
    }
}

/// What the global stage found: the losses of every start's local optimum, best first, and
/// how many starts did not simulate or failed. A start other than the nominal one that wins
/// is reported against the real nominal point; a parameter its fit could not determine
/// stays at that start's draw (the result's parameter then reads moved, and undetermined).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MultiStartSummary {
    /// Local fits run, the nominal one included.
    pub starts: usize,
    pub failed: usize,
    /// The local optima's losses (mean squared normalised residual), best first; a lone
    /// start held to a cap ([`estimate_multistart_capped`]): its loss there.
    pub losses: Vec<f64>,
    /// Which start (0 = nominal) gave the result.
    pub best_start: usize,
    /// Design points screened by their loss ([`MultiStart::screen`]; 0: none).
    pub screened: usize,
    /// Of those, the points whose runs did not all simulate.
    pub screened_failed: usize,
    /// Of those, the points that explained the runs better than the nominal point: the
    /// candidates the local fits beside the nominal one started from (best first).
    pub screened_better: usize,
}

impl MultiStartSummary {
    /// One line for a report: how many local fits, how many points screened, what failed.
    pub fn describe(&self) -> String {
        let fits = format!(
            "{} local fit{}",
            self.starts,
            if self.starts == 1 { "" } else { "s" }
        );
        let failed = if self.failed > 0 {
            format!(" ({} failed)", self.failed)
        } else {
            String::new()
        };
        if self.screened == 0 {
            return format!("{fits}{failed}");
        }
        format!(
            "{} design points screened ({} did not simulate), {} explained the runs better than the start; {fits}{failed}",
            self.screened, self.screened_failed, self.screened_better
        )
    }
}

/// The start points: row 0 nominal, then `points` of a Latin hypercube over nominal ± spread
/// in bounds.
fn design(problem: &GreyboxProblem<'_>, ms: &MultiStart, points: usize) -> Vec<Vec<(String, f64)>> {
    let mut rng = ChaCha8Rng::seed_from_u64(ms.seed);
    let model = problem.model;
    let mut columns: Vec<Vec<(String, f64)>> = Vec::new();
    for free in &problem.free {
        let (Ok(nominal), Some(info)) = (
            model.parameter(&free.name),
            model.parameter_info().iter().find(|i| i.name == free.name),
        ) else {
            continue;
        };
        let lower = free.lower.unwrap_or(info.lower);
        let upper = free.upper.unwrap_or(info.upper);
        // Floored, as the estimator's scale is (`Evaluator::new`), by the parameter's usual
        // magnitude where one is declared; else by a thousandth of the range (the spread's
        // own floor, which the estimator uses only for a nominal of 0).
        let scale = match info.typical {
            Some(typical) => nominal.abs().max(typical),
            None => nominal.abs().max(1e-3 * (upper - lower)),
        };
        let half = ms.spread * scale;
        let (lo, hi) = ((nominal - half).max(lower), (nominal + half).min(upper));
        // One stratum per point after the nominal one, in random order.
        let n = points;
        let mut strata: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() {
            let j = ((rng.random::<f64>() * (i + 1) as f64) as usize).min(i);
            strata.swap(i, j);
        }
        columns.push(
            strata
                .iter()
                .map(|&s| {
                    let u = (s as f64 + rng.random::<f64>()) / n as f64;
                    (free.name.clone(), lo + u * (hi - lo))
                })
                .collect(),
        );
    }
    let mut starts = vec![Vec::new()];
    for k in 0..points {
        starts.push(columns.iter().map(|c| c[k].clone()).collect());
    }
    starts
}

/// [`estimate`] from `ms.count` starts; the result with the lowest loss, with the summary.
/// One start is exactly [`estimate`].
pub fn estimate_multistart(
    problem: &GreyboxProblem<'_>,
    options: &GreyboxOptions,
    ms: &MultiStart,
    observer: &mut dyn Observer,
) -> Result<(GreyboxEstimate, MultiStartSummary), EstimateError> {
    estimate_multistart_capped(problem, options, ms, options.max_iterations, observer)
}

/// [`estimate_multistart`], with the nominal start's fit held to `lone_max_iterations` when
/// no other start runs: the caller continues that fit (the alternation of
/// [`crate::estimate_with_starts`]). Where other starts run, every fit runs to `options`'
/// limit: starts are compared at their optima (capped alike, Model 3's drawn starts on a
/// virtual-truck variant had not reached theirs, and the nominal start won with a loss of
/// 2.12 against their 1.65).
pub fn estimate_multistart_capped(
    problem: &GreyboxProblem<'_>,
    options: &GreyboxOptions,
    ms: &MultiStart,
    lone_max_iterations: usize,
    observer: &mut dyn Observer,
) -> Result<(GreyboxEstimate, MultiStartSummary), EstimateError> {
    if ms.count == 0 || !(ms.spread.is_finite() && ms.spread > 0.0) {
        return Err(EstimateError::InvalidOption(format!(
            "multi-start needs at least one start and a positive spread, got {} and {}",
            ms.count, ms.spread
        )));
    }
    // Before the screen spends its simulations.
    super::check_options(options)?;
    let lone_options = options
        .clone()
        .with_max_iterations(lone_max_iterations.max(1).min(options.max_iterations));
    if ms.count == 1 {
        let nominal = estimate(problem, &lone_options, observer)?;
        let summary = MultiStartSummary {
            starts: 1,
            failed: 0,
            losses: vec![nominal.loss_estimated],
            best_start: 0,
            screened: 0,
            screened_failed: 0,
            screened_better: 0,
        };
        return Ok((nominal, summary));
    }
    let moved_to = |start: &[(String, f64)]| {
        let mut model = problem.model.box_clone();
        for (name, value) in start {
            model.set_parameter(name, *value).ok()?;
        }
        Some(model)
    };
    // The nominal point's loss by the screen's measure; where even that fails (a run does
    // not simulate alone), no screen: the nominal fit is the result.
    let screen_reference = (ms.screen > 0)
        .then(|| loss_and_steps_at(problem, true).ok())
        .flatten();
    let (starts, screened, screened_failed, screened_better) = if ms.screen == 0 {
        let design = design(problem, ms, ms.count - 1);
        (design.into_iter().skip(1).collect::<Vec<_>>(), 0, 0, 0)
    } else if let Some((reference, steps)) = screen_reference {
        observer.stage(&format!(
            "screening {} design points for the global stage",
            ms.screen
        ));
        // A point whose runs take many times the nominal point's steps is not promising, and
        // a run that does not simulate at all would otherwise crawl to the solver's budget of
        // a million steps first: on the built-in study, uncapped, 14 of 32 points failed that
        // way and screening took Model 2's valve fit from 6 to 28 s.
        let mut solver = problem.solver.clone();
        solver.max_steps = solver
            .max_steps
            .min((SCREEN_STEP_FACTOR * steps).max(SCREEN_MIN_STEPS));
        let design = design(problem, ms, ms.screen);
        let losses: Vec<Option<f64>> = design
            .par_iter()
            .skip(1)
            .map(|start| {
                let model = moved_to(start)?;
                let moved = GreyboxProblem {
                    model: &*model,
                    solver: solver.clone(),
                    ..problem.clone()
                };
                loss_and_steps_at(&moved, false)
                    .ok()
                    .map(|(loss, _)| loss)
                    .filter(|l| l.is_finite())
            })
            .collect();
        let failed = losses.iter().filter(|l| l.is_none()).count();
        let mut better: Vec<(f64, Vec<(String, f64)>)> = losses
            .into_iter()
            .zip(design.into_iter().skip(1))
            .filter_map(|(loss, start)| Some((loss?, start)))
            .filter(|(loss, _)| *loss < reference)
            .collect();
        better.sort_by(|a, b| a.0.total_cmp(&b.0));
        let n_better = better.len();
        let chosen = better
            .into_iter()
            .take(ms.count - 1)
            .map(|(_, start)| start)
            .collect();
        (chosen, ms.screen, failed, n_better)
    } else {
        (Vec::new(), 0, 0, 0)
    };
    // The nominal start reports progress; the others run quietly beside it.
    let nominal = estimate(
        problem,
        if starts.is_empty() {
            &lone_options
        } else {
            options
        },
        observer,
    )?;
    let others: Vec<Option<GreyboxEstimate>> = starts
        .into_par_iter()
        .map(|start| {
            let model = moved_to(&start)?;
            let moved = GreyboxProblem {
                model: &*model,
                ..problem.clone()
            };
            estimate(&moved, options, &mut NoProgress).ok()
        })
        .collect();
    let others_run = others.len();
    let failed = others.iter().filter(|o| o.is_none()).count();
    // A start's own values are its fit's "nominal" point: a parameter its screen found not
    // identifiable stays at the start's draw, not at the truck file's value; the winner is
    // reported against the file's values, so such a parameter shows as moved and undetermined.
    // Tried: letting only starts whose fit determined every parameter win (Model 3's runs on
    // the built-in study determine neither `rflow1` nor `a0`, and every start but the nominal
    // one was out of the running), and refitting a start's estimate with those parameters
    // back at the file's values (Model 3 then fell back to the nominal optimum, loss 0.469
    // against 0.353: at the drawn point they matter). The better optimum is kept and said.
    let mut losses: Vec<f64> = std::iter::once(nominal.loss_estimated)
        .chain(others.iter().flatten().map(|e| e.loss_estimated))
        .collect();
    losses.sort_by(f64::total_cmp);
    let mut results: Vec<(usize, GreyboxEstimate)> = std::iter::once((0, nominal))
        .chain(
            others
                .into_iter()
                .enumerate()
                .filter_map(|(i, o)| o.map(|e| (i + 1, e))),
        )
        .collect();
    // The real nominal point's values, fits and loss, to report the winner against.
    let reference = &results[0].1;
    let nominal_values: Vec<f64> = reference.parameters.iter().map(|p| p.nominal).collect();
    let nominal_fits: Vec<(Option<f64>, Option<f64>)> = reference
        .fits
        .iter()
        .map(|f| (f.height_nominal_percent, f.pressure_nominal_percent))
        .collect();
    let nominal_loss = reference.loss_nominal;
    results.sort_by(|a, b| a.1.loss_estimated.total_cmp(&b.1.loss_estimated));
    let (best_start, mut best) = results.swap_remove(0);
    if best_start != 0 {
        for (p, value) in best.parameters.iter_mut().zip(nominal_values) {
            p.nominal = value;
        }
        for (f, (h, p)) in best.fits.iter_mut().zip(nominal_fits) {
            f.height_nominal_percent = h;
            f.pressure_nominal_percent = p;
        }
        best.loss_nominal = nominal_loss;
    }
    Ok((
        best,
        MultiStartSummary {
            starts: 1 + others_run,
            failed,
            losses,
            best_start,
            screened,
            screened_failed,
            screened_better,
        },
    ))
}
