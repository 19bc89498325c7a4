//! Road input sampled every 2 ms with a damper velocity that keeps crossing the table's kink
//! at zero. Held between samples (a restart at every sample), BDF gives up and the fallback
//! finishes the run; followed linearly (the default, no restarts), BDF finishes by itself.
//! Both agree with an independent explicit solution.

mod common;

use airsus_data::{TruckParameters, ValveState};
use airsus_model::{InitialCondition, build_model};
use airsus_sim::{
    InitialState, InputSeries, Method, RoadInput, SimulationProblem, SolverOptions, simulate,
};
use common::max_abs_diff;

#[test]
fn a_road_run_that_defeats_bdf_finishes_with_tr_bdf2_and_matches_tsit45() {
    let truck = TruckParameters::reference();
    let model = build_model("m2", &truck).unwrap();
    let n = 5000;
    let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.002).collect();
    let load = vec![3390.0; n];
    let valve = vec![ValveState::Closed; n];
    let supply = vec![850e3; n];
    // A 10 mm, 3 Hz road sine: the case BDF failed on (t ≈ 3.26 s).
    let road: Vec<f64> = t
        .iter()
        .map(|t| 0.01 * (2.0 * std::f64::consts::PI * 3.0 * t).sin())
        .collect();
    let initial = InitialState::Equilibrium(InitialCondition::SensorHeight { height_m: 0.22 });
    let run = |options: SolverOptions| {
        let inputs = InputSeries::new(&t, &load, &valve, &supply, &road).unwrap();
        simulate(&SimulationProblem::new(&*model, inputs, initial.clone()).with_options(options))
    };
    let held = run(SolverOptions::default().with_road(RoadInput::Hold))
        .expect("the fallback finishes the run");
    assert_eq!(
        held.statistics.fallback,
        Some(Method::TrBdf2),
        "BDF failed and TR-BDF2 took over"
    );
    let default = run(SolverOptions::default()).expect("BDF finishes a linear road");
    assert_eq!(default.statistics.fallback, None);
    assert_eq!(default.statistics.restarts, 0);
    for road in [RoadInput::Hold, RoadInput::Linear] {
        let explicit = run(SolverOptions::default()
            .with_method(Method::Tsit45)
            .with_road(road))
        .unwrap();
        assert_eq!(explicit.statistics.fallback, None);
        let implicit = if road == RoadInput::Hold {
            &held
        } else {
            &default
        };
        let w = max_abs_diff(&implicit.sensor_height_m, &explicit.sensor_height_m);
        assert!(
            w < 1e-5,
            "{road:?}: height differs by {w} m between methods"
        );
    }
    // Held and linear roads differ by about half a sample of road motion, not more.
    let w = max_abs_diff(&held.sensor_height_m, &default.sensor_height_m);
    assert!(w < 1e-3, "held vs linear road: {w} m");
    // The road moves the corner: the check is not comparing two constants.
    let spread = default
        .sensor_height_m
        .iter()
        .fold(f64::NEG_INFINITY, |m, &v| m.max(v))
        - default
            .sensor_height_m
            .iter()
            .fold(f64::INFINITY, |m, &v| m.min(v));
    assert!(spread > 2e-3, "height range {spread} m");
}
