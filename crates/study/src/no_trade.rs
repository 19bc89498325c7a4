//! The study's guard that no estimation run is explained worse than by the start values
//! ([`airsus_estimate::no_trade`], issue #12 item 6), scored as the study scores: whole runs,
//! the start values from their prefix starts with the load as logged, an estimate from its
//! joint starts with the load it was fitted to.

use airsus_data::Run;
pub use airsus_estimate::no_trade::{Guarded, TRADE_MARGIN_POINTS};
use airsus_estimate::no_trade::{RunScore, refit_free};
use airsus_estimate::{
    GreyboxOptions, GreyboxProblem, JointEstimate, NoProgress, PrefixOptions, StartMethod,
};
use airsus_model::SuspensionModel;
use airsus_report::results::OutputFit;

use crate::models::{FeltLoad, bounds, output_fit};

/// Each estimation run's scores under `joint`'s estimate, as the study scores it: from the
/// joint estimate's start of the run (else one fitted to its prefix, or in equilibrium, as
/// `initial` says), the load as `joint` was fitted to it.
pub fn estimation_scores(
    joint: &JointEstimate,
    runs: &[&Run],
    initial: StartMethod,
    prefix: &PrefixOptions,
) -> Vec<Option<OutputFit>> {
    let felt = FeltLoad::of(joint, runs);
    runs.iter()
        .enumerate()
        .map(|(i, run)| {
            let start = joint.starts.get(i).cloned().flatten();
            let (_, simulated) = felt.simulate(
                &*joint.estimate.estimated_model,
                run,
                start,
                initial,
                prefix,
            );
            simulated.ok().and_then(|r| output_fit(run, &r))
        })
        .collect()
}

/// `joint` (fitted on `problem`), or a refit of it that explains no estimation run and
/// output worse than `nominal`, the start values, did (`floors`: their scores, per run of
/// `problem`, as the study scores them) beyond [`TRADE_MARGIN_POINTS`], or falls least
/// short of that ([`airsus_estimate::no_trade::keep_every_run`], scored as the study scores;
/// `joint` itself, its trades named, with [`GreyboxOptions::allow_trades`]). The
/// parameters named in `held` stay at `joint`'s values: the study's road refit fits them on
/// the road runs alone, because fitted with the other runs they absorb what those leave
/// unexplained (the `truck` structure's tire stiffness came out 10-20 % low), and its notes
/// describe them.
#[allow(clippy::too_many_arguments)]
pub fn keep_every_run(
    joint: JointEstimate,
    problem: &GreyboxProblem<'_>,
    nominal: &dyn SuspensionModel,
    floors: &[Option<OutputFit>],
    held: &[&str],
    options: &GreyboxOptions,
    initial: StartMethod,
    prefix: &PrefixOptions,
) -> Guarded {
    let runs = &problem.runs;
    let floors: Vec<Option<RunScore>> = floors.iter().map(|f| f.map(run_score)).collect();
    // A parameter the study's refit with the lab's valve freed (not `problem`) is bounded
    // as there.
    let free = refit_free(&joint, problem, held, &|name| bounds(nominal, name));
    let score = |j: &JointEstimate| -> Vec<Option<RunScore>> {
        estimation_scores(j, runs, initial, prefix)
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

/// The pooled estimate's fit of each of `runs` (the guarded problem's), by run name, where
/// it traded some ([`Guarded::pooled_scores`]; empty where it traded none).
pub fn pooled_fits(guarded: &Guarded, runs: &[&Run]) -> Vec<(String, Option<OutputFit>)> {
    let Some(scores) = &guarded.pooled_scores else {
        return Vec::new();
    };
    runs.iter()
        .zip(scores)
        .map(|(run, score)| {
            let fit = score.map(|s| OutputFit {
                height_percent: s.height_percent,
                pressure_percent: s.pressure_percent,
            });
            (run.name.clone(), fit)
        })
        .collect()
}
