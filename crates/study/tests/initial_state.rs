//! The start of a measured run (issue #12, item 2): with the parameters right, fitting the
//! states that carry the run's history to its first 10 s takes the simulation to the noise
//! ceiling, where static equilibrium at the first measured height stays far below it.

use airsus_estimate::{PrefixOptions, StartMethod, estimate_initial_state};
use airsus_model::{InitialCondition, StateRole, SuspensionModel, build_model};
use airsus_sim::{InitialState, InputSeries, SimulationProblem, simulate};
use airsus_study::ceiling::noise_ceiling;
use airsus_study::load_study;
use airsus_truck::model::TruckModel;
use airsus_validate::nrmse_percent;

#[test]
fn with_the_true_parameters_the_prefix_start_reaches_the_noise_ceiling() {
    let dir = tempfile::tempdir().unwrap();
    let generated = airsus_truck::experiments::generate(dir.path(), 1, &mut |_| {}).unwrap();
    let input = load_study(&generated.study).unwrap();
    // The virtual truck itself, its true thesis-structure parameters and effects.
    let truth = airsus_data::read_truck(&dir.path().join("truth/truck.toml")).unwrap();
    let model = TruckModel::from_truck_parameters(&truth.parameters);
    for name in ["data-set 3", "data-set 4"] {
        let run = input.run(name).unwrap();
        let ceiling = noise_ceiling(run).unwrap();
        let measured = run.run.outputs.as_ref().unwrap();
        let score = |method| {
            let start = estimate_initial_state(&model, &run.run, method, &PrefixOptions::default())
                .unwrap();
            let inputs = InputSeries::from_run(&run.run).unwrap();
            let r = simulate(&SimulationProblem::new(
                &model as &dyn SuspensionModel,
                inputs,
                start.initial,
            ))
            .unwrap();
            (
                nrmse_percent(&measured.sensor_height_m, &r.sensor_height_m).unwrap(),
                nrmse_percent(&measured.bellow_gauge_pa, &r.bellow_gauge_pa).unwrap(),
            )
        };
        let (h_eq, p_eq) = score(StartMethod::Equilibrium);
        let (h_pre, p_pre) = score(StartMethod::Prefix);
        // Measured on seed 1: ds3 pressure 76.3 → 90.8 % (ceiling 90.8), ds4 90.9 → 97.0 %.
        assert!(
            ceiling.pressure_percent - p_pre < 0.5,
            "{name}: prefix pressure {p_pre:.2} %, ceiling {:.2} %",
            ceiling.pressure_percent
        );
        assert!(
            ceiling.height_percent - h_pre < 4.0,
            "{name}: prefix height {h_pre:.2} %, ceiling {:.2} %",
            ceiling.height_percent
        );
        assert!(
            p_pre - p_eq > 5.0 && h_pre > h_eq,
            "{name}: equilibrium {h_eq:.2}/{p_eq:.2} %, prefix {h_pre:.2}/{p_pre:.2} %"
        );
    }
}

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
