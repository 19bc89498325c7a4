//! Grey-box estimation of any model's physical parameters (thesis 3.2.3, 5.2.6; SPEC §4),
//! the counterpart of MATLAB's `nlgreyest` with simulation focus.
//!
//! * [`GreyboxProblem`] — what is minimised: a model (its current values are the nominal
//!   point), estimation runs, freed parameters with bounds, output weights. The loss and its
//!   normalisation are documented there.
//! * [`GreyboxOptions`] — how: iterations, tolerances, finite-difference step,
//!   identifiability policy.
//! * [`estimate`] — the executor: nominal simulation → Jacobian and identifiability check →
//!   Levenberg–Marquardt on the identifiable parameters → Jacobian at the estimate →
//!   (if more parameters turn out undetermined: fix them and refit) → uncertainty and report.
//!   Progress goes to an [`Observer`](crate::progress::Observer).
//!
//! Parameters are scaled to O(1) relative to their nominal values, and bounds are handled by
//! projection with an exterior penalty (see the `evaluate` module). The Jacobian is a forward
//! difference, one simulation of every run per freed parameter, computed in parallel with
//! rayon. Each run starts from its own static equilibrium at its first measured sample.
//!
//! Assumptions behind the reported standard deviations: the model structure is right and the
//! residuals are white within each (run, output) block; model error (the real truck is richer
//! than any of the models) makes residuals coloured, and the standard deviations are then
//! optimistic — read them as a lower bound and compare fits across runs.

mod evaluate;
pub mod identifiability;
mod multistart;
mod problem;
mod result;
mod solver;

use std::time::Instant;

pub use evaluate::{HEIGHT_RESOLUTION_M, PRESSURE_RESOLUTION_PA};
pub use identifiability::{
    CorrelatedPair, JacobianAnalysis, NotIdentifiable, Stage, Unidentifiable,
};
pub use multistart::{
    MultiStart, MultiStartSummary, estimate_multistart, estimate_multistart_capped,
};
pub use problem::{
    ForceMapPrior, FreeParameter, GreyboxOptions, GreyboxProblem, IdentifiabilityPolicy,
    InitialChoice, Normalisation, OutputWeights, check_force_map_noise_n,
    check_load_change_exclusion_s,
};
pub use result::{
    Correlation, EstimatedParameter, GreyboxEstimate, IdentifiabilityReport, ParameterStatus,
    ResidualBatches, RunFit, StopReason,
};

use airsus_validate::nrmse_percent;

use crate::error::EstimateError;
use crate::progress::Observer;
pub(crate) use evaluate::measurement_noise;
use evaluate::{Evaluator, Responses, noise_variance_from_data};
use identifiability::{
    LiveColumns, Screen, analyse, correlated_covariance, correlation, select_identifiable,
};
use solver::{ColumnsAt, FitSettings, fit};

/// After a fit, parameters found undetermined are fixed and the rest refitted, at most this
/// many rounds in all.
const MAX_ROUNDS: usize = 3;

pub(crate) fn check_options(o: &GreyboxOptions) -> Result<(), EstimateError> {
    let bad = |s: String| Err(EstimateError::InvalidOption(s));
    if o.max_iterations == 0 {
        return bad("max_iterations must be at least 1".to_owned());
    }
    if !(o.tolerance.is_finite() && o.tolerance > 0.0) {
        return bad(format!("tolerance must be positive, got {}", o.tolerance));
    }
    if let Some(t) = o.loss_tolerance
        && !(t.is_finite() && t > 0.0 && t < 1.0)
    {
        return bad(format!("loss_tolerance must be in (0, 1), got {t}"));
    }
    if !(o.fd_step.is_finite() && o.fd_step > 0.0 && o.fd_step < 0.5) {
        return bad(format!("fd_step must be in (0, 0.5), got {}", o.fd_step));
    }
    if !(o.max_relative_std.is_finite() && o.max_relative_std > 0.0) {
        return bad(format!(
            "max_relative_std must be positive, got {}",
            o.max_relative_std
        ));
    }
    if !(o.rcond.is_finite() && o.rcond > 0.0 && o.rcond < 1.0) {
        return bad(format!("rcond must be in (0, 1), got {}", o.rcond));
    }
    if !(o.correlation_warning > 0.0 && o.correlation_warning <= 1.0) {
        return bad(format!(
            "correlation_warning must be in (0, 1], got {}",
            o.correlation_warning
        ));
    }
    Ok(())
}

fn run_fits(ev: &Evaluator<'_>, nominal: &Responses, estimated: &Responses) -> Vec<RunFit> {
    let fit = |measured: &[f64], r: &Responses, k: usize, height: bool| {
        r[k].as_ref().ok().and_then(|sim| {
            let s = if height {
                &sim.sensor_height_m
            } else {
                &sim.bellow_gauge_pa
            };
            nrmse_percent(measured, s).ok()
        })
    };
    ev.runs
        .iter()
        .enumerate()
        .map(|(k, run)| RunFit {
            run: run.name.clone(),
            samples: run.height.len(),
            height_nominal_percent: fit(run.height, nominal, k, true),
            height_estimated_percent: fit(run.height, estimated, k, true),
            pressure_nominal_percent: fit(run.pressure, nominal, k, false),
            pressure_estimated_percent: fit(run.pressure, estimated, k, false),
        })
        .collect()
}

/// Per-block noise variances from residuals, with the `p` degrees of freedom spent on the
/// parameters shared out in proportion to block length.
fn noise_variance_from_residuals(
    r: &[f64],
    blocks: &[std::ops::Range<usize>],
    n_params: usize,
) -> Vec<f64> {
    let n: usize = blocks.iter().map(|b| b.len()).sum();
    blocks
        .iter()
        .map(|b| {
            let rss: f64 = r[b.clone()].iter().map(|x| x * x).sum();
            let dof = b.len() as f64 * (1.0 - n_params as f64 / n as f64);
            rss / dof.max(1.0)
        })
        .collect()
}

/// The Jacobian with all freed parameters as columns, computed for `cols` only (the others
/// are held fixed: zero columns), so column indices stay parameter indices; and the columns
/// whose simulations failed.
fn jacobian_full(
    ev: &Evaluator<'_>,
    z: &[f64],
    cols: &[usize],
    r: &[f64],
    fd_step: f64,
) -> (nalgebra::DMatrix<f64>, Vec<usize>) {
    let (part, failed) = ev.jacobian(z, cols, r, fd_step);
    (full_columns(part.as_view(), cols, z.len()), failed)
}

/// `part`'s columns (those of `cols`) placed at their parameter indices among `n`, the
/// others zero.
fn full_columns(
    part: nalgebra::DMatrixView<'_, f64>,
    cols: &[usize],
    n: usize,
) -> nalgebra::DMatrix<f64> {
    let mut j = nalgebra::DMatrix::zeros(part.nrows(), n);
    for (k, &c) in cols.iter().enumerate() {
        j.set_column(c, &part.column(k));
    }
    j
}

/// The evaluator of `problem`'s model as it stands: its free list ignored.
fn as_it_stands<'a>(problem: &GreyboxProblem<'a>) -> Result<Evaluator<'a>, EstimateError> {
    Evaluator::new(&GreyboxProblem {
        free: Vec::new(),
        ..problem.clone()
    })
}

/// `Ok` when every run of `responses` simulated; else the first failure, by run.
fn all_simulated(ev: &Evaluator<'_>, responses: &Responses) -> Result<(), EstimateError> {
    for (run, response) in ev.runs.iter().zip(responses) {
        if let Err(e) = response {
            return Err(EstimateError::StartDoesNotSimulate {
                run: run.name.clone(),
                source: Box::new(e.clone()),
            });
        }
    }
    Ok(())
}

/// The loss of `problem`'s model as it stands (its free list is ignored): the mean squared
/// normalised residual over every run, [`GreyboxEstimate::loss_estimated`] of an estimate
/// that frees nothing, from one simulation of each run. What the load-transition searches
/// and the alternation's baselines evaluate: an [`estimate`] with nothing free simulates
/// each run three times (the nominal point, the final-point check, the report's fits).
/// `parallel`: the runs simulated in parallel. Fails where [`estimate`] would: a malformed
/// problem, or a run that does not simulate.
pub fn loss_at(problem: &GreyboxProblem<'_>, parallel: bool) -> Result<f64, EstimateError> {
    loss_and_steps_at(problem, parallel).map(|(loss, _)| loss)
}

/// `problem`'s model as it stands, each run simulated once (in parallel if `parallel`), and
/// the normalised residuals of those simulations (0 for a run that did not simulate).
fn residuals_as_it_stands<'a>(
    problem: &GreyboxProblem<'a>,
    parallel: bool,
) -> Result<(Evaluator<'a>, Responses, Vec<f64>), EstimateError> {
    let mut ev = as_it_stands(problem)?;
    ev.parallel = parallel;
    let responses = ev.simulate(&[])?;
    let mut residuals = vec![0.0; ev.n_data()];
    ev.residuals_into(&[], &responses, 0.0, &mut residuals);
    Ok((ev, responses, residuals))
}

/// Each run's sum of squared normalised residuals at `problem`'s model as it stands (the
/// runs normalised together, as [`loss_at`] normalises them); infinite for a run that does
/// not simulate. One simulation of each run.
pub(crate) fn run_losses_at(
    problem: &GreyboxProblem<'_>,
    parallel: bool,
) -> Result<Vec<f64>, EstimateError> {
    let (ev, responses, residuals) = residuals_as_it_stands(problem, parallel)?;
    let blocks = ev.blocks();
    Ok(responses
        .iter()
        .enumerate()
        .map(|(r, response)| match response {
            Ok(_) => blocks[2 * r..2 * r + 2]
                .iter()
                .flat_map(|block| &residuals[block.clone()])
                .map(|v| v * v)
                .sum(),
            Err(_) => f64::INFINITY,
        })
        .collect())
}

/// [`loss_at`], and the most solver steps (accepted and rejected) any run took.
pub(crate) fn loss_and_steps_at(
    problem: &GreyboxProblem<'_>,
    parallel: bool,
) -> Result<(f64, usize), EstimateError> {
    let (ev, responses, residuals) = residuals_as_it_stands(problem, parallel)?;
    all_simulated(&ev, &responses)?;
    let steps = responses
        .iter()
        .flatten()
        .map(|r| r.statistics.steps + r.statistics.rejected_steps)
        .max()
        .unwrap_or(0);
    Ok((
        residuals.iter().map(|r| r * r).sum::<f64>() / residuals.len() as f64,
        steps,
    ))
}

/// Per run of `problem`, the factors its height and pressure residuals are multiplied by
/// (the output weights over the normalisation's scale, [`Normalisation`]).
pub(crate) fn output_factors(
    problem: &GreyboxProblem<'_>,
) -> Result<Vec<(f64, f64)>, EstimateError> {
    Ok(as_it_stands(problem)?
        .runs
        .iter()
        .map(|r| (r.height_factor, r.pressure_factor))
        .collect())
}

/// The states of `problem`'s first run at each sample, simulated with its model as it stands
/// (its solver options must record states). Fails where [`loss_at`] would, or when no states
/// were recorded.
pub(crate) fn simulate_states(
    problem: &GreyboxProblem<'_>,
) -> Result<airsus_sim::StateHistory, EstimateError> {
    let mut ev = as_it_stands(problem)?;
    ev.parallel = false;
    let mut responses = ev.simulate(&[])?;
    all_simulated(&ev, &responses)?;
    responses
        .swap_remove(0)
        .ok()
        .and_then(|response| response.states)
        .ok_or_else(|| EstimateError::InvalidOption("the simulation recorded no states".to_owned()))
}

/// Estimates the freed parameters of `problem` (module docs). Fails only on malformed
/// problems and on a start that does not simulate; a fit that does not converge returns its
/// best point with a [`StopReason`] saying so.
pub fn estimate(
    problem: &GreyboxProblem<'_>,
    options: &GreyboxOptions,
    observer: &mut dyn Observer,
) -> Result<GreyboxEstimate, EstimateError> {
    check_options(options)?;
    let started = Instant::now();
    let mut ev = Evaluator::new(problem)?;
    ev.parallel = options.parallel;
    let names: Vec<String> = ev.params.iter().map(|p| p.name.clone()).collect();
    // Tie-break of the identifiability screen: position in the model's parameter order.
    let priority: Vec<usize> = names
        .iter()
        .map(|n| {
            problem
                .model
                .parameter_info()
                .iter()
                .position(|i| i.name == n.as_str())
                .unwrap_or(usize::MAX)
        })
        .collect();
    let n = names.len();
    let blocks = ev.blocks();
    let n_data = ev.n_data();

    observer.stage("simulating the nominal parameters");
    let z0 = vec![0.0; n];
    let theta0 = ev.theta(&z0);
    let nominal = ev.simulate(&theta0)?;
    all_simulated(&ev, &nominal)?;
    let mut r0 = vec![0.0; n_data];
    ev.residuals_into(&theta0, &nominal, 0.0, &mut r0);
    let loss0: f64 = r0.iter().map(|r| r * r).sum();
    let rms0 = (loss0 / n_data as f64).sqrt();
    // A failed run's residuals: far above anything a simulating model reaches from here.
    let fail_value = 10.0 * rms0.max(1.0);
    let kappa = 100.0 * (n_data as f64).sqrt() * rms0.max(1.0);

    let all: Vec<usize> = (0..n).collect();
    observer.stage("Jacobian at the nominal point");
    let (j0, failed0) = ev.jacobian(&z0, &all, &r0, options.fd_step);
    let lambda_data = noise_variance_from_data(&ev);
    let (before, _) = analyse(
        &j0,
        &all,
        &names,
        &blocks,
        &lambda_data,
        options.rcond,
        options.correlation_warning,
    );
    let screen = |stage| Screen {
        rcond: options.rcond,
        max_relative_std: options.max_relative_std,
        correlation_warning: options.correlation_warning,
        stage,
    };
    let (identifiable, mut not_identifiable) = select_identifiable(
        &j0,
        &failed0,
        &all,
        &names,
        &priority,
        &blocks,
        &lambda_data,
        screen(Stage::BeforeFit),
    );
    let fix = options.policy == IdentifiabilityPolicy::FixAtNominal;
    let mut active = if fix { identifiable } else { all.clone() };

    let mut z = z0.clone();
    let mut residuals = r0.clone();
    let mut stop = StopReason::NothingToEstimate;
    let mut iterations = 0;
    let mut rounds = 0;
    let mut final_j = None;
    let mut lambda_post = lambda_data.clone();
    // Each round fits the active parameters, then screens them. Flagged parameters go back
    // to nominal and the rest are refitted, so the point returned is always one the optimiser
    // reached with exactly the parameters it reports as estimated: never a fitted set mixed
    // with reset values (such a mix need not even simulate). After MAX_ROUNDS screenings a
    // last refit runs without screening.
    let mut screening = true;
    while !active.is_empty() {
        rounds += 1;
        observer.stage(&format!("fit round {rounds}"));
        let settings = FitSettings {
            fd_step: options.fd_step,
            tolerance: options.tolerance,
            loss_tolerance: options.loss_tolerance.unwrap_or(options.tolerance),
            max_iterations: options.max_iterations,
            fail_value,
            kappa,
            round: rounds,
        };
        // The screen's Jacobian at the nominal point is the solver's first where it starts
        // there (the columns depend only on the point).
        let start_jacobian = (z == z0).then(|| {
            ColumnsAt::new(
                z0.clone(),
                j0.select_columns(&active),
                failed0
                    .iter()
                    .copied()
                    .filter(|c| active.contains(c))
                    .collect(),
            )
        });
        let outcome = fit(
            &ev,
            &active,
            z,
            residuals,
            &settings,
            start_jacobian,
            observer,
        );
        z = outcome.z;
        residuals = outcome.residuals;
        stop = outcome.stop;
        iterations += outcome.iterations;

        observer.stage("Jacobian at the estimate");
        let (j, failed) = match outcome.jacobian {
            Some(known) => (full_columns(known.data(), &active, n), known.failed),
            None => jacobian_full(&ev, &z, &active, &residuals, options.fd_step),
        };
        lambda_post = noise_variance_from_residuals(&residuals, &blocks, active.len());
        final_j = Some(j);
        if !screening {
            break;
        }
        // Screened even when the fit did not converge: wandering along a flat direction is a
        // common reason not to converge, and fixing that parameter lets the refit converge.
        let (keep, newly) = select_identifiable(
            final_j.as_ref().unwrap_or(&j0),
            &failed,
            &active,
            &names,
            &priority,
            &blocks,
            &lambda_post,
            screen(Stage::AfterFit),
        );
        for n in &newly {
            if !not_identifiable.iter().any(|m| m.name == n.name) {
                not_identifiable.push(n.clone());
            }
        }
        if !fix || newly.is_empty() {
            break;
        }
        screening = rounds < MAX_ROUNDS;
        for n in &newly {
            if let Some(i) = names.iter().position(|m| *m == n.name) {
                z[i] = 0.0;
            }
        }
        active = keep;
        // Restart from the fitted values of the kept parameters if that point simulates and
        // is no worse than the nominal one; otherwise from the nominal point.
        match ev.residuals_at(&z) {
            Some(r) if r.iter().map(|v| v * v).sum::<f64>() <= loss0 => residuals = r,
            _ => {
                z = z0.clone();
                residuals = r0.clone();
            }
        }
    }
    // A fit whose every parameter went back to its start is not "converged": say so.
    if n > 0 && z == z0 && stop.is_converged() {
        stop = StopReason::NoParameterMoved {
            fixed: not_identifiable.len(),
            freed: n,
        };
    }
    // The final point's simulations: the report's fits and loss (the nominal point's where
    // nothing moved).
    let mut estimated = if z == z0 {
        nominal.clone()
    } else {
        ev.simulate(&ev.theta(&z)).unwrap_or_default()
    };
    if estimated.len() != nominal.len() || estimated.iter().any(Result::is_err) {
        // The optimiser's best point always simulated; this guards the contract anyway.
        stop = StopReason::NotConverging {
            reason: "the final point does not simulate every run; the nominal values are returned"
                .to_owned(),
        };
        z = z0.clone();
        final_j = None;
        estimated = nominal.clone();
    }

    // How flat the loss is where the fit stopped: the norm of the gradient of the mean
    // squared normalised residual over the parameters left free, in the scaled coordinates
    // the solver works in. What "converged" means, as a number.
    let gradient_norm = final_j
        .as_ref()
        .filter(|_| !active.is_empty() && residuals.len() == n_data)
        .map(|j| {
            let r = nalgebra::DVector::from_column_slice(&residuals);
            let g = j.transpose() * r * (2.0 / n_data as f64);
            active.iter().map(|&i| g[i] * g[i]).sum::<f64>().sqrt()
        });

    // Uncertainty of the estimated parameters at the final point.
    observer.stage("uncertainty and report");
    let (after, cov, correlated) = match (&final_j, active.is_empty()) {
        (Some(j), false) => {
            // The report's analysis and the covariances are of the same matrix, linearised
            // once.
            let (after, kept) = analyse(
                j,
                &active,
                &names,
                &blocks,
                &lambda_post,
                options.rcond,
                options.correlation_warning,
            );
            match kept {
                Some(LiveColumns { columns, j, lin }) => {
                    // The same sandwich with residuals correlated in time allowed for.
                    let correlated = correlated_covariance(
                        &j,
                        &lin,
                        &residuals,
                        &blocks,
                        &lambda_post,
                        ev.runs.len(),
                    );
                    (
                        Some(after),
                        lin.covariance.map(|c| (columns, c)),
                        correlated,
                    )
                }
                None => (Some(after), None, None),
            }
        }
        _ => (None, None, None),
    };
    let theta = ev.theta(&z);
    let mut parameters = Vec::with_capacity(n);
    for (i, p) in ev.params.iter().enumerate() {
        let flagged = not_identifiable.iter().any(|m| m.name == p.name);
        let (lo, hi) = p.z_range();
        let at_bound = z[i] <= lo + 1e-9 || z[i] >= hi - 1e-9;
        let column = cov
            .as_ref()
            .and_then(|(live, _)| live.iter().position(|&l| l == i));
        let std = column
            .zip(cov.as_ref())
            .map(|(k, (_, c))| p.scale * c[(k, k)].sqrt());
        let std_correlated = column
            .zip(correlated.as_ref())
            .map(|(k, c)| p.scale * c.covariance[(k, k)].sqrt());
        let status = if flagged && fix {
            ParameterStatus::FixedNotIdentifiable
        } else if flagged {
            ParameterStatus::NotIdentifiable
        } else if at_bound {
            ParameterStatus::AtBound
        } else {
            ParameterStatus::Estimated
        };
        // Fixed or at a bound: no standard deviation.
        let reported = matches!(
            status,
            ParameterStatus::Estimated | ParameterStatus::NotIdentifiable
        );
        parameters.push(EstimatedParameter {
            name: p.name.clone(),
            unit: p.unit.clone(),
            nominal: p.nominal,
            estimate: theta[i],
            std: std.filter(|_| reported),
            std_correlated: std_correlated.filter(|_| reported),
            lower: p.lower,
            upper: p.upper,
            status,
        });
    }
    let correlation_matrix = match &cov {
        Some((live, c)) => {
            let corr = correlation(c);
            Correlation {
                parameters: live.iter().map(|&i| names[i].clone()).collect(),
                values: (0..live.len())
                    .map(|r| (0..live.len()).map(|c| corr[(r, c)]).collect())
                    .collect(),
            }
        }
        None => Correlation {
            parameters: Vec::new(),
            values: Vec::new(),
        },
    };
    let estimated_model = ev.model_at(&theta)?;
    // What data would determine a parameter; not said where the model failed to simulate
    // (more data is not the cure there).
    for n in not_identifiable
        .iter_mut()
        .filter(|n| n.reason != identifiability::Unidentifiable::SimulationFails)
    {
        if let Some(info) = ev.base.parameter_info().iter().find(|i| i.name == n.name) {
            n.determined_by = info.needs.to_owned();
        }
    }
    let mut r_final = vec![0.0; n_data];
    ev.residuals_into(&ev.theta(&z), &estimated, fail_value, &mut r_final);
    let fits = run_fits(&ev, &nominal, &estimated);
    observer.finish();
    Ok(GreyboxEstimate {
        model: ev.base.name().to_owned(),
        parameters,
        fits,
        identifiability: IdentifiabilityReport {
            before,
            after,
            not_identifiable,
        },
        correlation: correlation_matrix,
        stop,
        iterations,
        rounds,
        simulations: ev.simulations(),
        failed_simulations: ev.failures(),
        loss_nominal: loss0 / n_data as f64,
        loss_estimated: r_final.iter().map(|r| r * r).sum::<f64>() / n_data as f64,
        gradient_norm,
        residual_batches: correlated
            .map(|c| {
                ev.runs
                    .iter()
                    .zip(c.batch_samples)
                    .map(|(run, (batch_samples, longest))| ResidualBatches {
                        run: run.name.clone(),
                        samples: run.len(),
                        batch_samples,
                        longest,
                    })
                    .collect()
            })
            .unwrap_or_default(),
        elapsed_s: started.elapsed().as_secs_f64(),
        estimated_model,
    })
}
