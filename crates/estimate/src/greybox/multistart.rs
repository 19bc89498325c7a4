//! A global stage before the local fit (issue #12, item 3): Levenberg–Marquardt from several
//! starts spread over the parameter box, the best result kept.
//!
//! The starts are a Latin hypercube (each parameter's range cut into `count` strata, one
//! start per stratum, strata paired at random): space-filling in every single parameter with
//! any number of starts, where a grid needs `kᵈ`. Each parameter ranges over its nominal ±
//! `spread` (relative), inside its bounds: the admissible ranges are deliberately wide
//! (they exclude nonsense, not unlikely values), and a start anywhere in them mostly does not
//! simulate. Start 0 is the nominal point itself, so the result is never worse than the plain
//! local fit. The starts run in parallel (rayon); each is a complete [`estimate`], with its
//! own identifiability screen.
//!
//! Hand-written because the stage is a loop over the existing local solver: the maintained
//! global optimisers (argmin's particle swarm, `cmaes`) would replace Levenberg–Marquardt
//! rather than seed it, and lose its Jacobian-based uncertainty and identifiability report.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use super::{GreyboxEstimate, GreyboxOptions, GreyboxProblem, estimate};
use crate::error::EstimateError;
use crate::progress::{NoProgress, Observer};

/// How many starts, how far apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultiStart {
    /// Number of starts, the nominal one included (1: the plain local fit).
    pub count: usize,
    /// Half-width of each parameter's range around its nominal value, relative.
    pub spread: f64,
    pub seed: u64,
}

impl Default for MultiStart {
    fn default() -> Self {
        Self {
            count: 1,
            spread: 0.5,
            seed: 1,
        }
    }
}

/// What the global stage found: the losses of every start's local optimum, best first, and
/// how many starts did not simulate or failed. A start other than the nominal one wins only
/// when its fit kept every parameter (its screen resets to the start's own random values);
/// its result is then reported against the real nominal point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MultiStartSummary {
    pub starts: usize,
    pub failed: usize,
    /// The local optima's losses (mean squared normalised residual), best first.
    pub losses: Vec<f64>,
    /// Which start (0 = nominal) gave the result.
    pub best_start: usize,
}

/// The start points: row 0 nominal, then a Latin hypercube over nominal ± spread in bounds.
fn design(problem: &GreyboxProblem<'_>, ms: &MultiStart) -> Vec<Vec<(String, f64)>> {
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
        // One stratum per start after the nominal one, in random order.
        let n = ms.count - 1;
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
    for k in 0..ms.count.saturating_sub(1) {
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
    if ms.count == 0 || !(ms.spread.is_finite() && ms.spread > 0.0) {
        return Err(EstimateError::InvalidOption(format!(
            "multi-start needs at least one start and a positive spread, got {} and {}",
            ms.count, ms.spread
        )));
    }
    // The nominal start reports progress; the others run quietly beside it.
    let nominal = estimate(problem, options, observer)?;
    if ms.count == 1 {
        let summary = MultiStartSummary {
            starts: 1,
            failed: 0,
            losses: vec![nominal.loss_estimated],
            best_start: 0,
        };
        return Ok((nominal, summary));
    }
    let others: Vec<Option<GreyboxEstimate>> = design(problem, ms)
        .into_par_iter()
        .skip(1)
        .map(|start| {
            let mut model = problem.model.box_clone();
            for (name, value) in &start {
                model.set_parameter(name, *value).ok()?;
            }
            let moved = GreyboxProblem {
                model: &*model,
                ..problem.clone()
            };
            estimate(&moved, options, &mut NoProgress).ok()
        })
        .collect();
    let failed = others.iter().filter(|o| o.is_none()).count();
    // A start's own values are its fit's "nominal" point: a parameter its screen found not
    // identifiable went back to the random draw, not to the truck file's value. Only fully
    // fitted starts can win (they still count among the local optima).
    let mut losses: Vec<f64> = std::iter::once(nominal.loss_estimated)
        .chain(others.iter().flatten().map(|e| e.loss_estimated))
        .collect();
    losses.sort_by(f64::total_cmp);
    let mut results: Vec<(usize, GreyboxEstimate)> = std::iter::once((0, nominal))
        .chain(
            others
                .into_iter()
                .enumerate()
                .filter_map(|(i, o)| o.map(|e| (i + 1, e)))
                .filter(|(_, e)| e.identifiability.not_identifiable.is_empty()),
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
            starts: ms.count,
            failed,
            losses,
            best_start,
        },
    ))
}
