//! A logged load step eased over seconds (`airsus_estimate::ramp_logged_load` makes such a
//! load) is a smooth transition. Held between samples it is a staircase that restarts the
//! solver at every sample; followed linearly it restarts only where the ramp starts and
//! ends, and the two agree with each other and with an explicit solution.

mod common;

use airsus_data::{TruckParameters, ValveState};
use airsus_model::{InitialCondition, build_model};
use airsus_sim::{
    InitialState, InputSeries, LoadInput, Method, SimulationProblem, SolverOptions, simulate,
};
use common::max_abs_diff;

/// Smoothstep from 0 to 1 over `[0, 1]`.
fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

#[test]
fn an_eased_load_followed_linearly_restarts_only_where_it_starts_and_stops_moving() {
    let truck = TruckParameters::reference();
    let model = build_model("m2", &truck).unwrap();
    let n = 1200;
    let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.1).collect();
    // Two 300 kg steps, each eased over 6 s: up at 20 s, down at 70 s.
    let load: Vec<f64> = t
        .iter()
        .map(|&t| 3390.0 + 300.0 * (smoothstep((t - 20.0) / 6.0) - smoothstep((t - 70.0) / 6.0)))
        .collect();
    let valve = vec![ValveState::Closed; n];
    let supply = vec![850e3; n];
    let road = vec![0.0; n];
    let initial = InitialState::Equilibrium(InitialCondition::SensorHeight { height_m: 0.235 });
    let run = |options: SolverOptions| {
        let inputs = InputSeries::new(&t, &load, &valve, &supply, &road).unwrap();
        simulate(&SimulationProblem::new(&*model, inputs, initial.clone()).with_options(options))
            .unwrap()
    };
    let held = run(SolverOptions::default());
    let linear = run(SolverOptions::default().with_load(LoadInput::Linear));
    // 59 changing samples per ramp held; a start and an end per ramp followed linearly.
    assert!(held.statistics.restarts >= 100, "{:?}", held.statistics);
    assert!(linear.statistics.restarts <= 4, "{:?}", linear.statistics);
    assert!(
        linear.statistics.steps * 2 < held.statistics.steps,
        "held {:?}, linear {:?}",
        held.statistics,
        linear.statistics
    );
    let explicit = run(SolverOptions::default()
        .with_method(Method::Tsit45)
        .with_load(LoadInput::Linear));
    let w = max_abs_diff(&linear.sensor_height_m, &explicit.sensor_height_m);
    assert!(
        w < 1e-5,
        "linear load: height differs by {w} m between methods"
    );
    // The staircase lags the polyline by half a sample: at the ramp's steepest (75 kg/s)
    // about 4 kg, 0.22 mm of height while the truck moves.
    let w = max_abs_diff(&held.sensor_height_m, &linear.sensor_height_m);
    assert!(w < 5e-4, "held vs linear load: {w} m");
    let moved = max_abs_diff(&held.sensor_height_m, &vec![held.sensor_height_m[0]; n]);
    assert!(moved > 5e-3, "the load moved the truck: {moved} m");
}
