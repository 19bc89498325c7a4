//! The global stage: from a start 50 % off in every freed parameter, multi-start reaches the
//! optimum that a fit started at the truth reaches (issue #12, items 3 and 6).

mod common;

use airsus_data::Run;
use airsus_data::TruckParameters;
use airsus_estimate::{
    GreyboxEstimate, GreyboxOptions, GreyboxProblem, LoadRamp, MultiStart, NoProgress,
    PrefixOptions, StartMethod, StopReason, estimate, estimate_multistart,
    estimate_multistart_capped, estimate_with_starts,
};
use airsus_model::SuspensionModel;
use airsus_model::build_model;
use common::{load_step_run, measure, perturbed, valve_pulse_run};

/// The reference truck's Model 2 and two noisy runs it makes: load steps and valve pulses.
fn measured_runs() -> (TruckParameters, Box<dyn SuspensionModel>, Run, Run) {
    let truck = TruckParameters::reference();
    let truth = build_model("m2", &truck).unwrap();
    let steps = measure(
        &*truth,
        load_step_run("load steps", 240.0, 3350.0, 300.0, 60.0),
        0.24,
        31,
    );
    let pulses = measure(
        &*truth,
        valve_pulse_run("valve pulses", 120.0, 3350.0, 30.0, 2.0, 2.0),
        0.24,
        32,
    );
    (truck, truth, steps, pulses)
}

/// `best` is the fit `reference` (started at the truth) is: its loss within 0.1 %, every
/// freed parameter within 1 %.
fn reaches_the_truths_optimum(best: &GreyboxEstimate, reference: &GreyboxEstimate, free: &[&str]) {
    assert!(
        best.loss_estimated <= reference.loss_estimated * (1.0 + 1e-3),
        "multi-start loss {} vs from the truth {}",
        best.loss_estimated,
        reference.loss_estimated
    );
    for name in free {
        let (got, want) = (
            best.parameter(name).unwrap().estimate,
            reference.parameter(name).unwrap().estimate,
        );
        assert!(
            ((got - want) / want).abs() < 0.01,
            "{name}: {got} from 50 % off, {want} from the truth"
        );
    }
}

/// Model 2 with every parameter the tests free 50 % off the truth, alternately up and down.
fn fifty_percent_off(truck: &TruckParameters) -> Box<dyn SuspensionModel> {
    perturbed(
        truck,
        "m2",
        &[
            ("p0", 1.5),
            ("m2", 0.5),
            ("rflow1", 1.5),
            ("rflow2", 0.5),
            ("a1", 1.5),
        ],
    )
}

#[test]
fn fifty_percent_off_reaches_the_optimum_of_a_start_at_the_truth() {
    let (truck, truth, steps, pulses) = measured_runs();
    let free = ["p0", "m2", "rflow1", "rflow2", "a1"];
    let options = GreyboxOptions::default();

    let at_truth = GreyboxProblem::new(&*truth, &[&steps, &pulses], &free);
    let reference = estimate(&at_truth, &options, &mut NoProgress).unwrap();

    let start = fifty_percent_off(&truck);
    let off = GreyboxProblem::new(&*start, &[&steps, &pulses], &free);
    let ms = MultiStart {
        count: 4,
        spread: 0.5,
        seed: 3,
        screen: 0,
    };
    let (best, summary) = estimate_multistart(&off, &options, &ms, &mut NoProgress).unwrap();
    assert_eq!(summary.starts, 4);
    assert_eq!(summary.losses.len(), 4 - summary.failed);
    assert!(summary.losses.windows(2).all(|w| w[0] <= w[1]));
    assert_eq!(summary.losses[0], best.loss_estimated);
    reaches_the_truths_optimum(&best, &reference, &free);
    // Whichever start won, the result is reported against the real start point.
    for p in &best.parameters {
        assert_eq!(p.nominal, start.parameter(&p.name).unwrap(), "{}", p.name);
    }
    // One start is the plain local fit.
    let (single, one) = estimate_multistart(
        &off,
        &options,
        &MultiStart { count: 1, ..ms },
        &mut NoProgress,
    )
    .unwrap();
    assert_eq!(one.starts, 1);
    let plain = estimate(&off, &options, &mut NoProgress).unwrap();
    assert_eq!(single.loss_estimated, plain.loss_estimated);
    eprintln!(
        "loss: from the truth {:.6e}, plain from 50 % off {:.6e}, multi-start {:.6e} (start {} of {:?})",
        reference.loss_estimated,
        plain.loss_estimated,
        best.loss_estimated,
        summary.best_start,
        summary.losses
    );
}

/// The screened global stage (issue #12, item 3): the design's points are scored by their
/// loss first, and a local fit begins only at those that explain the runs better than the
/// start does. From 50 % off, some do, and the best of them reaches the optimum of a fit
/// started at the truth; from the truth, none does, and the stage costs no local fit.
#[test]
fn a_screened_stage_starts_local_fits_only_where_the_design_beats_the_start() {
    let (truck, truth, steps, pulses) = measured_runs();
    let free = ["p0", "m2", "rflow1", "rflow2", "a1"];
    let options = GreyboxOptions::default();
    let ms = MultiStart {
        count: 3,
        spread: 0.5,
        seed: 3,
        screen: 24,
    };

    let at_truth = GreyboxProblem::new(&*truth, &[&steps, &pulses], &free);
    let reference = estimate(&at_truth, &options, &mut NoProgress).unwrap();
    let (from_truth, summary) =
        estimate_multistart(&at_truth, &options, &ms, &mut NoProgress).unwrap();
    assert_eq!(summary.screened, 24);
    assert_eq!(summary.screened_better, 0, "{summary:?}");
    assert_eq!((summary.starts, summary.best_start), (1, 0), "{summary:?}");
    assert_eq!(from_truth.loss_estimated, reference.loss_estimated);

    let start = fifty_percent_off(&truck);
    let off = GreyboxProblem::new(&*start, &[&steps, &pulses], &free);
    let (best, summary) = estimate_multistart(&off, &options, &ms, &mut NoProgress).unwrap();
    eprintln!("from 50 % off: {}", summary.describe());
    assert!(summary.screened_better >= 1, "{summary:?}");
    assert!(summary.screened_failed < summary.screened, "{summary:?}");
    // The nominal fit and at most `count - 1` others, never more than the design offered.
    assert_eq!(summary.starts, 1 + summary.screened_better.min(2));
    assert_eq!(summary.losses.len(), summary.starts - summary.failed);
    assert_eq!(summary.losses[0], best.loss_estimated);
    reaches_the_truths_optimum(&best, &reference, &free);
}

/// A lone start's fit, which the alternation continues, may stop at a cap; where other starts
/// run, every fit runs to the options' limit: the starts are compared at their optima (capped
/// alike, a drawn start that had not reached its optimum lost to the nominal one).
#[test]
fn only_a_lone_start_is_capped() {
    let (truck, _, steps, pulses) = measured_runs();
    let free = ["p0", "m2", "rflow1", "rflow2", "a1"];
    let options = GreyboxOptions::default();
    let start = fifty_percent_off(&truck);
    let off = GreyboxProblem::new(&*start, &[&steps, &pulses], &free);
    let ms = MultiStart {
        count: 3,
        spread: 0.5,
        seed: 3,
        screen: 0,
    };

    let lone = MultiStart { count: 1, ..ms };
    let (capped, summary) =
        estimate_multistart_capped(&off, &options, &lone, 2, &mut NoProgress).unwrap();
    assert_eq!(summary.starts, 1);
    assert_eq!(capped.stop, StopReason::MaxIterations { iterations: 2 });
    let plain = estimate(&off, &options, &mut NoProgress).unwrap();
    assert!(plain.stop.is_converged(), "{:?}", plain.stop);
    assert!(capped.loss_estimated > plain.loss_estimated);

    let (best, several) =
        estimate_multistart_capped(&off, &options, &ms, 2, &mut NoProgress).unwrap();
    let (uncapped, reference) = estimate_multistart(&off, &options, &ms, &mut NoProgress).unwrap();
    assert_eq!(several.starts, 3);
    assert_eq!(several.losses, reference.losses);
    assert_eq!(best.loss_estimated, uncapped.loss_estimated);
}

/// Started far off (50 % in `p0`, `m2`, `rflow1`, `rflow2`, `a1`, 10-50 % in `p1`, `ig`),
/// the starts fitted to the runs' first seconds under those values explain the runs far worse
/// than the static equilibrium does; fitted from them, the parameters stayed where they
/// started (loss 845, the valve pulses at −11,073 % height NRMSE, "converged"). The first fit
/// now starts the runs in equilibrium, says so, and the estimate reaches the optimum of a fit
/// started at the truth; the alternation then refits the starts. Where no round of the
/// alternation replaces the first fit (capped at a round's iterations), it is finished.
#[test]
fn starts_fitted_under_far_off_values_do_not_hold_the_fit_there() {
    let (truck, truth, steps, pulses) = measured_runs();
    let free = ["p0", "p1", "m2", "ig", "rflow1", "rflow2", "a1"];
    let options = GreyboxOptions::default();
    let at_truth = GreyboxProblem::new(&*truth, &[&steps, &pulses], &free);
    let lone = MultiStart {
        count: 1,
        ..MultiStart::default()
    };
    // One start, starts fitted to the runs' prefixes, as `greybox` and the study fit.
    let fit = |problem: &GreyboxProblem<'_>, prefix: &PrefixOptions, load: LoadRamp| {
        estimate_with_starts(
            problem,
            &options,
            &lone,
            StartMethod::Prefix,
            prefix,
            load,
            &mut NoProgress,
        )
        .unwrap()
        .0
    };
    let joint_starts = PrefixOptions::default();
    let reference = fit(&at_truth, &joint_starts, LoadRamp::Logged);
    assert!(
        reference.start_notes.is_empty(),
        "{:?}",
        reference.start_notes
    );

    let start = perturbed(
        &truck,
        "m2",
        &[
            ("p0", 1.5),
            ("p1", 0.9),
            ("m2", 0.5),
            ("ig", 1.5),
            ("rflow1", 1.5),
            ("rflow2", 0.5),
            ("a1", 1.5),
        ],
    );
    let off = GreyboxProblem::new(&*start, &[&steps, &pulses], &free);
    let joint = fit(&off, &joint_starts, LoadRamp::Logged);
    assert!(
        joint.start_notes.iter().any(|n| n.starts_with(
            "under the start values, the starts fitted to the runs' first seconds explained the runs more than 2 times worse than the static equilibrium at each run's first height"
        ) && n.contains("valve pulses")),
        "{:?}",
        joint.start_notes
    );
    let (got, want) = (
        joint.estimate.loss_estimated,
        reference.estimate.loss_estimated,
    );
    assert!(
        got <= want * (1.0 + 1e-3),
        "loss {got} from far off, {want} from the truth"
    );
    for name in ["p0", "p1", "m2", "a1"] {
        let (got, want) = (
            joint.estimate.parameter(name).unwrap().estimate,
            reference.estimate.parameter(name).unwrap().estimate,
        );
        assert!(
            ((got - want) / want).abs() < 0.02,
            "{name}: {got} from far off, {want} from the truth"
        );
    }
    // With the load eased where that helps (here it does not): the first fit, capped at a
    // round's 15 iterations (loss 0.0042 there), is finished before easing is judged, and the
    // finished fit is the optimum: no round improves on it. (Not finished, two rounds of
    // the alternation reach the same optimum from the capped fit.)
    let eased = fit(&off, &joint_starts, LoadRamp::Estimate);
    let got = eased.estimate.loss_estimated;
    assert!(
        got <= want * (1.0 + 1e-3),
        "loss {got} with the load eased where that helps, {want} from the truth"
    );
    assert!(
        eased.rounds.is_empty() && eased.estimate.iterations > 15,
        "the first fit finished: {} rounds, {} iterations",
        eased.rounds.len(),
        eased.estimate.iterations
    );
    // Held starts (`--initial-state prefix`) are what the estimate says it was fitted from:
    // they are kept as fitted.
    let held = PrefixOptions {
        refit_starts: false,
        ..PrefixOptions::default()
    };
    let from_held = fit(&off, &held, LoadRamp::Logged);
    assert!(from_held.starts_held);
    assert!(
        from_held.start_notes.is_empty(),
        "{:?}",
        from_held.start_notes
    );
    // Every run explained as from the truth: the valve pulses' height within a point.
    for (fit, reference) in joint.estimate.fits.iter().zip(&reference.estimate.fits) {
        let (got, want) = (
            fit.height_estimated_percent.unwrap(),
            reference.height_estimated_percent.unwrap(),
        );
        assert!(
            (got - want).abs() < 1.0,
            "{}: {got} against {want}",
            fit.run
        );
    }
}
