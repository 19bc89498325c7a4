//! The start of a measured run (issue #12, item 2): with the parameters right, fitting the
//! states that carry the run's history to its first 10 s takes the simulation to the noise
//! ceiling, where static equilibrium at the first measured height stays far below it.

use airsus_estimate::{PrefixOptions, StartMethod, estimate_initial_state};
use airsus_model::{InitialCondition, StateRole, build_model};
use airsus_sim::{InitialState, InputSeries, SimulationProblem, simulate};
use airsus_study::ceiling::noise_ceiling;
use airsus_study::load_study;
use airsus_study::models::simulate_run;
use airsus_truck::models::build_any_model;
use airsus_validate::nrmse_percent;

#[test]
fn a_known_offset_in_the_air_amount_is_recovered_from_the_prefix() {
    // Model 2 started with 1 % more air than static equilibrium at 235 mm: it rises and
    // settles. Noise-free outputs of that run; the prefix fit must find the offset.
    let truck = airsus_data::TruckParameters::reference();
    let model = build_model("m2", &truck).unwrap();
    let mut run = data_set_4_of_seed_2();
    let inputs = InputSeries::from_run(&run).unwrap();
    let x_eq = equilibrium_at_first_height(&*model, &run);
    let air = model.state_index(StateRole::BellowAir).unwrap();
    let mut x_true = x_eq.clone();
    x_true[air] *= 1.01;
    let truth = simulate(&SimulationProblem::new(
        &*model,
        inputs,
        InitialState::State(x_true.clone()),
    ))
    .unwrap();
    // The run now "starts" at the true first height, which is not the equilibrium's.
    let (start, offsets) = prefix_fit_on(&*model, &mut run, &truth);
    let relative = (x_eq[air] + offsets[air] - x_true[air]) / x_true[air];
    assert!(
        relative.abs() < 1e-3,
        "air amount off by {relative:e}: {start:?}"
    );
    assert!(start.prefix_rms_estimated < 0.1 * start.prefix_rms_equilibrium);
}

#[test]
fn with_the_true_parameters_the_prefix_start_reaches_the_noise_ceiling() {
    // The virtual truck's own model at its true values, fed the logged inputs of the valve
    // runs (no load changes, so no input error): only the start separates it from the noise
    // ceiling. Data-sets 3 and 4 begin after a raise, the wall friction holding the bellow
    // down. A start fitted to 10 s, anchored at the first second's mean height and with the
    // gas temperature held near ambient unless the data say otherwise. Measured on seed 7:
    // data-set 3 91.8/90.7 % (ceiling 94.2/90.7), data-set 4 99.3/96.8 % (99.3/96.8);
    // anchored at the first sample the height was 88.4 %, without the temperature prior
    // 88.2 %; from the equilibrium 57.4/74.2 and 95.5/90.5 %. The prefix fit's height is
    // sensitive to the noise weights: with the noise read from the quiet stretches (seed 7's
    // data-set 3 height noise 0.1528 mm where the whole run's second differences gave 0.1533)
    // data-set 3 scores 91.1 %: held to 3.5 points.
    for seed in [1, 7] {
        let dir = tempfile::tempdir().unwrap();
        let generated =
            airsus_truck::experiments::generate_variant(dir.path(), seed, 0, &mut |_| {}).unwrap();
        let input = load_study(&generated.study).unwrap();
        // The whole truth as a `truck`-structure file: the model built from it is the virtual
        // truck.
        let truth =
            airsus_data::read_truck(&dir.path().join("truth/truck_structure.toml")).unwrap();
        let model = build_any_model("truck", &truth.parameters).unwrap();
        for name in ["data-set 3", "data-set 4"] {
            let run = input.run(name).unwrap();
            let ceiling = noise_ceiling(run).unwrap();
            let measured = run.run.outputs.as_ref().unwrap();
            let score = |method| {
                let sim = simulate_run(&*model, &run.run, method, &PrefixOptions::default(), None)
                    .unwrap();
                (
                    nrmse_percent(&measured.sensor_height_m, &sim.sensor_height_m).unwrap(),
                    nrmse_percent(&measured.bellow_gauge_pa, &sim.bellow_gauge_pa).unwrap(),
                )
            };
            let (h_eq, p_eq) = score(StartMethod::Equilibrium);
            let (h, p) = score(StartMethod::Prefix);
            assert!(
                h > ceiling.height_percent - 3.5 && p > ceiling.pressure_percent - 0.5,
                "seed {seed}, {name}: {h:.1}/{p:.1} % against the ceiling {:.1}/{:.1} %",
                ceiling.height_percent,
                ceiling.pressure_percent
            );
            assert!(
                p - p_eq > 5.0 && h > h_eq,
                "seed {seed}, {name}: equilibrium {h_eq:.2}/{p_eq:.2} %, prefix {h:.2}/{p:.2} %"
            );
        }
    }
}

#[test]
fn the_prefix_start_of_a_noise_free_run_after_a_move_reproduces_it() {
    // Variant 2's road run 1 begins after the truck was lowered onto its height (the wall
    // friction holding it up), data-set 3 after it was raised. The `truck` structure at the
    // variant's true values, fed the noise-free truth run: a right start reproduces the run.
    // With the friction fitted as an offset of its state from the unloaded equilibrium (the
    // lever out of balance, the gas unaware of the friction) the fit bent the gas temperature
    // to -0.63 K, and road run 1's height drifted 0.3 mm over its 70 s: 96.6 % here.
    let dir = tempfile::tempdir().unwrap();
    airsus_truck::experiments::generate_variant(dir.path(), 1, 2, &mut |_| {}).unwrap();
    let truth = airsus_data::read_truck(&dir.path().join("truth/truck_structure.toml")).unwrap();
    let model = build_any_model("truck", &truth.parameters).unwrap();
    for file in ["road1", "ds3"] {
        let run = airsus_data::read_run(&dir.path().join(format!("truth/{file}.csv"))).unwrap();
        let measured = run.outputs.as_ref().unwrap();
        let sim = simulate_run(
            &*model,
            &run,
            StartMethod::Prefix,
            &PrefixOptions::default(),
            None,
        )
        .unwrap();
        let h = nrmse_percent(&measured.sensor_height_m, &sim.sensor_height_m).unwrap();
        let p = nrmse_percent(&measured.bellow_gauge_pa, &sim.bellow_gauge_pa).unwrap();
        assert!(h > 99.8 && p > 99.8, "{file}: {h:.3}/{p:.3} %");
    }
}

#[test]
fn a_creep_under_way_in_an_identified_block_is_recovered_from_the_prefix() {
    // Model 2 extended's OE block is the creep after a load change (33 s time constant).
    // Started with the creep of an earlier step still under way, a run's height drifts for
    // a minute; the block's state, in its own scaling (unit "1"), is freed by the prefix fit
    // like the other history states. Noise-free outputs of data-set 4 (one load, valve
    // steps) from that start.
    let truck = airsus_data::TruckParameters::reference();
    let model = build_model("m2x", &truck).unwrap();
    let mut run = data_set_4_of_seed_2();
    let inputs = InputSeries::from_run(&run).unwrap();
    let x_eq = equilibrium_at_first_height(&*model, &run);
    let filter = model
        .states()
        .iter()
        .position(|s| s.role == StateRole::Filter)
        .unwrap();
    let simulate_from = |x: Vec<f64>| {
        simulate(&SimulationProblem::new(
            &*model,
            inputs,
            InitialState::State(x),
        ))
        .unwrap()
    };
    let at_rest = simulate_from(x_eq.clone());
    // The block is linear: a state that moves the height by 3 mm at most.
    let mut unit = x_eq.clone();
    unit[filter] += 1.0;
    let per_unit_m = simulate_from(unit)
        .sensor_height_m
        .iter()
        .zip(&at_rest.sensor_height_m)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let mut x_true = x_eq.clone();
    x_true[filter] += 3e-3 / per_unit_m;
    let truth = simulate_from(x_true.clone());
    let (start, offsets) = prefix_fit_on(&*model, &mut run, &truth);
    assert!(start.left_at_rest.is_empty(), "{start:?}");
    let recovered = offsets[filter] / (x_true[filter] - x_eq[filter]);
    assert!(
        (recovered - 1.0).abs() < 0.05,
        "creep state recovered at {recovered:.3} of the truth: {start:?}"
    );
    // The whole run follows: the creep at rest leaves it millimetres off for a minute.
    let sim = simulate_run(
        &*model,
        &run,
        StartMethod::Prefix,
        &PrefixOptions::default(),
        None,
    )
    .unwrap();
    let rest = simulate_run(
        &*model,
        &run,
        StartMethod::Equilibrium,
        &PrefixOptions::default(),
        None,
    )
    .unwrap();
    let h = nrmse_percent(&truth.sensor_height_m, &sim.sensor_height_m).unwrap();
    let h_rest = nrmse_percent(&truth.sensor_height_m, &rest.sensor_height_m).unwrap();
    // Measured 99.99 % against 98.30 % (data-set 4's valve steps span 60 mm; the creep's
    // 3 mm is what the start at rest misses).
    assert!(
        h > 99.9 && h_rest < 99.0,
        "{h:.2} % against {h_rest:.2} % at rest"
    );
}

#[test]
fn a_filter_state_the_prefix_cannot_move_is_named_not_left_at_rest_silently() {
    // Model 2 extended whose creep block acts with no force (`k_sd` 0): its state reaches no
    // output, no probe step moves the prefix, and the start says so.
    let mut truck = airsus_data::TruckParameters::reference();
    truck.slow_dynamics.force_scale = Some(0.0);
    let model = build_model("m2x", &truck).unwrap();
    let run = data_set_4_of_seed_2();
    let start = estimate_initial_state(
        &*model,
        &run,
        StartMethod::Prefix,
        &PrefixOptions::default(),
    )
    .unwrap();
    let filter = model
        .states()
        .iter()
        .find(|s| s.role == StateRole::Filter)
        .unwrap();
    assert_eq!(start.left_at_rest, [filter.name], "{start:?}");
    assert!(
        start
            .describe()
            .contains(&format!("{} left at rest", filter.name)),
        "{}",
        start.describe()
    );
    assert!(start.adjusted.iter().all(|a| a.name != filter.name));
}

/// Data-set 4 of the virtual truck's seed-2 study (one load, valve steps).
fn data_set_4_of_seed_2() -> airsus_data::Run {
    let dir = tempfile::tempdir().unwrap();
    let generated = airsus_truck::experiments::generate(dir.path(), 2, &mut |_| {}).unwrap();
    let input = load_study(&generated.study).unwrap();
    input.run("data-set 4").unwrap().run.clone()
}

/// `model`'s static equilibrium at `run`'s first measured height.
fn equilibrium_at_first_height(
    model: &dyn airsus_model::SuspensionModel,
    run: &airsus_data::Run,
) -> Vec<f64> {
    let inputs = InputSeries::from_run(run).unwrap();
    let first = run.outputs.as_ref().unwrap().sensor_height_m[0];
    model
        .initial_state(
            &inputs.sample(0),
            &InitialCondition::SensorHeight { height_m: first },
        )
        .unwrap()
}

/// `run` with `truth`'s outputs, its start fitted to the prefix: the start and its offsets
/// from the equilibrium (relative to it, so that a start survives a parameter change).
fn prefix_fit_on(
    model: &dyn airsus_model::SuspensionModel,
    run: &mut airsus_data::Run,
    truth: &airsus_sim::SimulationResponse,
) -> (airsus_estimate::EstimatedStart, Vec<f64>) {
    let outputs = run.outputs.as_mut().unwrap();
    outputs.sensor_height_m = truth.sensor_height_m.clone();
    outputs.bellow_gauge_pa = truth.bellow_gauge_pa.clone();
    let start =
        estimate_initial_state(model, run, StartMethod::Prefix, &PrefixOptions::default()).unwrap();
    assert_eq!(start.method, StartMethod::Prefix);
    let InitialState::EquilibriumOffset { offsets, .. } = &start.initial else {
        panic!("{start:?}")
    };
    let offsets = offsets.clone();
    (start, offsets)
}
