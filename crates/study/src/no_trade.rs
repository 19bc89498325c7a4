//! The study's guard that no estimation run is explained worse than by the start values
//! ([`airsus_estimate::no_trade`], issue #12 item 6), scored as the study scores: whole runs,
//! the start values from their prefix starts with the load as logged, an estimate from its
//! joint starts with the load it was fitted to.

use airsus_data::Run;
use airsus_estimate::no_trade::RunScore;
pub use airsus_estimate::no_trade::{Guarded, TRADE_MARGIN_POINTS};
use airsus_estimate::{
    FreeParameter, GreyboxOptions, GreyboxProblem, JointEstimate, NoProgress, PrefixOptions,
    StartMethod,
};
use airsus_model::SuspensionModel;
use airsus_report::results::OutputFit;

use crate::models::{FeltLoad, bounds, output_fit, simulate_from, simulate_run};

/// Each estimation run's scores, as the study scores it: `model` from the joint estimate's
/// start of the run (else fitted to its prefix, or in equilibrium, as `initial` says), the
/// load as `felt` feeds it.
pub fn estimation_scores(
    model: &dyn SuspensionModel,
    runs: &[&Run],
    joint: &JointEstimate,
    felt: &FeltLoad,
    initial: StartMethod,
    prefix: &PrefixOptions,
) -> Vec<Option<OutputFit>> {
    let load_ramp_s = Some(felt.longest_s()).filter(|&longest| longest > 0.0);
    runs.iter()
        .enumerate()
        .map(|(i, run)| {
            let fed = felt.feed(run);
            let simulated = match joint.starts.get(i).cloned().flatten() {
                Some(start) => simulate_from(model, &fed, start, load_ramp_s),
                None => simulate_run(model, &fed, initial, prefix, load_ramp_s),
            };
            simulated.ok().and_then(|r| output_fit(run, &r))
        })
        .collect()
}

/// `joint` (fitted on `problem`), or a refit of it that explains no estimation run and
/// output worse than `nominal` did beyond [`TRADE_MARGIN_POINTS`], or falls least short of
/// that ([`airsus_estimate::no_trade::keep_every_run`], scored as the study scores). The
/// parameters named in `held` stay at `joint`'s values: the study's road refit fits them on
/// the road runs alone, because fitted with the other runs they absorb what those leave
/// unexplained (the `truck` structure's tire stiffness came out 10-20 % low), and its notes
/// describe them.
#[allow(clippy::too_many_arguments)]
pub fn keep_every_run(
    joint: JointEstimate,
    problem: &GreyboxProblem<'_>,
    nominal: &dyn SuspensionModel,
    held: &[&str],
    options: &GreyboxOptions,
    initial: StartMethod,
    prefix: &PrefixOptions,
) -> Guarded {
    let runs = &problem.runs;
    let floors: Vec<Option<RunScore>> = runs
        .iter()
        .map(|run| {
            simulate_run(nominal, run, initial, prefix, None)
                .ok()
                .and_then(|r| output_fit(run, &r))
                .map(run_score)
        })
        .collect();
    let free: Vec<FreeParameter> = joint
        .estimate
        .parameters
        .iter()
        .filter(|p| !held.contains(&p.name.as_str()))
        .map(|p| {
            problem
                .free
                .iter()
                .find(|f| f.name == p.name)
                .cloned()
                .unwrap_or_else(|| {
                    // Freed by the study's refit with the lab's valve: its bounds as there.
                    let free = FreeParameter::new(p.name.clone());
                    match bounds(nominal, &p.name) {
                        Some((lo, hi)) => free.with_bounds(lo, hi),
                        None => free,
                    }
                })
        })
        .collect();
    let score = |j: &JointEstimate| -> Vec<Option<RunScore>> {
        estimation_scores(
            &*j.estimate.estimated_model,
            runs,
            j,
            &FeltLoad::of(j, runs),
            initial,
            prefix,
        )
        .into_iter()
        .map(|f| f.map(run_score))
        .collect()
    };
    let prefix_if = (initial == StartMethod::Prefix && prefix.refit_starts).then_some(prefix);
    airsus_estimate::no_trade::keep_every_run(
        joint,
        problem,
        free,
        options,
        prefix_if,
        &floors,
        &score,
        &mut NoProgress,
    )
}

fn run_score(fit: OutputFit) -> RunScore {
    RunScore {
        height_percent: fit.height_percent,
        pressure_percent: fit.pressure_percent,
    }
}
