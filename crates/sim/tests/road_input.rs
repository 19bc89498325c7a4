//! Road input sampled every 2 ms: a restart at every sample and a damper velocity that keeps
//! crossing the table's kink at zero. BDF gives up there; the fallback finishes the run, and
//! the result agrees with an independent explicit solution.

use airsus_data::{TruckParameters, ValveState};
use airsus_model::{InitialCondition, build_model};
use airsus_sim::{InitialState, InputSeries, Method, SimulationProblem, SolverOptions, simulate};

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
    let default = run(SolverOptions::default()).expect("the fallback finishes the run");
    assert_eq!(
        default.statistics.fallback,
        Some(Method::TrBdf2),
        "BDF failed and TR-BDF2 took over"
    );
    let explicit = run(SolverOptions::default().with_method(Method::Tsit45)).unwrap();
    assert_eq!(explicit.statistics.fallback, None);
    let worst = default
        .sensor_height_m
        .iter()
        .zip(&explicit.sensor_height_m)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-5, "height differs by {worst} m between methods");
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
