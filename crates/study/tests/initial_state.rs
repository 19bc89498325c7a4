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
    let dir = tempfile::tempdir().unwrap();
    let generated = airsus_truck::experiments::generate(dir.path(), 2, &mut |_| {}).unwrap();
    let input = load_study(&generated.study).unwrap();
    let mut run = input.run("data-set 4").unwrap().run.clone();
    let inputs = InputSeries::from_run(&run).unwrap();
    let first = run.outputs.as_ref().unwrap().sensor_height_m[0];
    let x_eq = model
        .initial_state(
            &inputs.sample(0),
            &InitialCondition::SensorHeight { height_m: first },
        )
        .unwrap();
    let air = model.state_index(StateRole::BellowAir).unwrap();
    let mut x_true = x_eq.clone();
    x_true[air] *= 1.01;
    let truth = simulate(&SimulationProblem::new(
        &*model,
        inputs,
        InitialState::State(x_true.clone()),
    ))
    .unwrap();
    let outputs = run.outputs.as_mut().unwrap();
    outputs.sensor_height_m = truth.sensor_height_m.clone();
    outputs.bellow_gauge_pa = truth.bellow_gauge_pa.clone();
    // The run now "starts" at the true first height, which is not the equilibrium's.
    let start = estimate_initial_state(
        &*model,
        &run,
        StartMethod::Prefix,
        &PrefixOptions::default(),
    )
    .unwrap();
    assert_eq!(start.method, StartMethod::Prefix);
    // The start stays relative to the equilibrium, so it survives a parameter change.
    let InitialState::EquilibriumOffset { offsets, .. } = &start.initial else {
        panic!("{start:?}")
    };
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
