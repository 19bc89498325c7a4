//! The load the wheel felt, from a log that steps: with the virtual truck's own structure at
//! its true parameters, the transition time fitted to data-set 1 lies among the ramps the
//! truck really made (3 to 8 s, a different one per step, smoothstep), and easing the steps
//! removes most of the loss they caused. The fit does not know the ramps; it sees the
//! logged steps and the measurements, as on a real truck.

use airsus_data::{Run, TruckParameters, read_run};
use airsus_estimate::{
    GreyboxProblem, LoadRampFit, LoadTransitionsFit, PrefixOptions, ease_logged_load,
    fit_load_ramp, fit_load_transitions, logged_load_changes, prefix_starts, ramp_logged_load,
};
use airsus_truck::models::build_any_model;

/// Data-set 1 of the virtual truck (seed `seed`) as logged, and the truck's true parameters.
fn data_set_1(seed: u64) -> (Run, TruckParameters) {
    let dir = tempfile::tempdir().unwrap();
    airsus_truck::experiments::generate(dir.path(), seed, &mut |_| {}).unwrap();
    let ds1 = read_run(&dir.path().join("ds1.csv")).unwrap();
    let truth = airsus_data::read_truck(&dir.path().join("truth/truck.toml"))
        .unwrap()
        .parameters;
    (ds1, truth)
}

/// The fitted transition lies in `range` (s) and cuts the loss below `fraction` of the
/// logged load's.
fn assert_eases(fit: &LoadRampFit, range: std::ops::RangeInclusive<f64>, fraction: f64) {
    assert!(
        range.contains(&fit.duration_s),
        "fitted {} s",
        fit.duration_s
    );
    assert!(
        fit.loss_ramped < fraction * fit.loss_logged,
        "loss {} as logged, {} eased",
        fit.loss_logged,
        fit.loss_ramped
    );
}

#[test]
fn the_fitted_transition_lies_among_the_true_ramps_and_removes_most_of_the_loss() {
    let (ds1, truth) = data_set_1(2);
    let model = build_any_model("truck", &truth).unwrap();
    let problem = GreyboxProblem::new(&*model, &[&ds1], &[]);
    let fit = fit_load_ramp(&problem).unwrap();
    assert_eases(&fit, 3.0..=8.0, 0.5);
    // The eased load is the log's between changes: only the transitions differ.
    let eased = ramp_logged_load(&ds1, fit.duration_s);
    let differ = eased
        .inputs
        .wheel_load_kg
        .iter()
        .zip(&ds1.inputs.wheel_load_kg)
        .filter(|(a, b)| (*a - *b).abs() > 1e-9)
        .count();
    let changes = ds1
        .inputs
        .wheel_load_kg
        .windows(2)
        .filter(|w| w[0] != w[1])
        .count();
    assert!(differ <= changes * (fit.duration_s / ds1.sample_time_s).ceil() as usize);
}

/// The estimator assumes a smoothstep starting at the logged change, as the virtual truck's
/// loads happen to ramp. A load that arrives otherwise - linearly, half a second after the
/// log says - must still be eased well: the fit is a time scale, not a copy of the
/// generator.
#[test]
fn a_load_that_arrives_linearly_and_late_is_still_eased_well() {
    let (logged, truth) = data_set_1(3);
    let model = build_any_model("m2", &truth).unwrap();

    // The felt load: each logged change arrives linearly over 4 s, starting 0.5 s late.
    let (delay_s, duration_s) = (0.5, 4.0);
    let load = &logged.inputs.wheel_load_kg;
    let mut felt = logged.clone();
    for (k, value) in felt.inputs.wheel_load_kg.iter_mut().enumerate() {
        let t = logged.time_s[k];
        *value = load[0]
            + (1..load.len())
                .filter(|&i| load[i] != load[i - 1])
                .map(|i| {
                    let progress = (t - logged.time_s[i] - delay_s) / duration_s;
                    (load[i] - load[i - 1]) * progress.clamp(0.0, 1.0)
                })
                .sum::<f64>();
    }
    // Measurements: the model's response to the felt load; the log keeps its steps.
    let inputs = airsus_sim::InputSeries::from_run(&felt).unwrap();
    let start = airsus_sim::InitialState::from_run(&felt).unwrap();
    let response =
        airsus_sim::simulate(&airsus_sim::SimulationProblem::new(&*model, inputs, start)).unwrap();
    let outputs = airsus_data::RunOutputs {
        sensor_height_m: response.sensor_height_m,
        bellow_gauge_pa: response.bellow_gauge_pa,
    };
    let mut measured = logged.clone();
    measured.outputs = Some(outputs.clone());

    // A log that records the load as it arrives (a load cell) is left as logged.
    let mut continuous = felt.clone();
    continuous.outputs = Some(outputs);
    let exact = fit_load_ramp(&GreyboxProblem::new(&*model, &[&continuous], &[])).unwrap();
    assert_eq!(exact.duration_s, 0.0, "{exact:?}");

    let problem = GreyboxProblem::new(&*model, &[&measured], &[]);
    // A smoothstep that matches a late linear ramp best is a little longer than it.
    assert_eases(&fit_load_ramp(&problem).unwrap(), 3.0..=7.0, 0.3);
}

/// Each logged change's true ramp in `truth` (the virtual truck's felt load, written beside
/// the run): the time from the logged step until the felt load is within 0.1 % of the
/// change of its new value, s.
fn true_ramps_s(logged: &Run, truth_load_kg: &[f64]) -> Vec<f64> {
    logged_load_changes(logged)
        .iter()
        .map(|&(start_s, delta_kg)| {
            let k0 = logged.time_s.iter().position(|&t| t >= start_s).unwrap();
            let before = truth_load_kg[k0 - 1];
            let arrived = (k0..truth_load_kg.len())
                .find(|&k| (truth_load_kg[k] - before - delta_kg).abs() <= 1e-3 * delta_kg.abs())
                .unwrap();
            logged.time_s[arrived] - start_s
        })
        .collect()
}

/// One time for every change leaves each change's own error; fitted change by change, with
/// the truck's true parameters, each time comes out near the ramp the truck really made
/// (seed 2: true 3.6 to 7.3 s, fitted within 0.18 s of each; one common time is 5.6 s),
/// and the loss falls to a fifth of the common time's.
#[test]
fn each_change_gets_its_own_time_near_the_true_ramp() {
    let dir = tempfile::tempdir().unwrap();
    airsus_truck::experiments::generate(dir.path(), 2, &mut |_| {}).unwrap();
    let ds1 = read_run(&dir.path().join("ds1.csv")).unwrap();
    let truth_run = read_run(&dir.path().join("truth/ds1.csv")).unwrap();
    let truth = airsus_data::read_truck(&dir.path().join("truth/truck_structure.toml"))
        .unwrap()
        .parameters;
    let model = build_any_model("truck", &truth).unwrap();
    // Started as the study starts it: its history states fitted to the first 10 s.
    let problem = GreyboxProblem::new(&*model, &[&ds1], &[]).with_start_states(prefix_starts(
        &*model,
        &[&ds1],
        &PrefixOptions::default(),
    ));
    let common = fit_load_ramp(&problem).unwrap();
    let each = fit_load_transitions(
        &problem,
        &LoadTransitionsFit::common(&[&ds1], common.duration_s),
    )
    .unwrap();
    let truth_s = true_ramps_s(&ds1, &truth_run.inputs.wheel_load_kg);
    assert_eq!(each.durations_s.len(), 1);
    assert_eq!(each.durations_s[0].len(), truth_s.len());
    let worst_common = truth_s
        .iter()
        .map(|t| (t - common.duration_s).abs())
        .fold(0.0, f64::max);
    let worst_each = each.durations_s[0]
        .iter()
        .zip(&truth_s)
        .map(|(fitted, t)| (fitted - t).abs())
        .fold(0.0, f64::max);
    assert!(
        worst_each < 0.3 && worst_each < 0.5 * worst_common,
        "true {truth_s:.2?}, each {:.2?}, common {:.2}",
        each.durations_s[0],
        common.duration_s
    );
    assert!(
        each.loss_each < 0.3 * each.loss_start,
        "loss {:.4e} at the common time, {:.4e} each",
        each.loss_start,
        each.loss_each
    );
    // Easing each over its own time is easing all over one when the times agree.
    assert_eq!(
        ease_logged_load(&ds1, &[common.duration_s; 6]),
        ramp_logged_load(&ds1, common.duration_s)
    );
}
