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

/// `model` over a road with the valve as given, 3390 kg on the wheel, from equilibrium at
/// 220 mm.
fn over_road(
    model: &dyn airsus_model::SuspensionModel,
    (t, road, valve): (&[f64], &[f64], &[ValveState]),
    method: Method,
    rtol: f64,
) -> airsus_sim::SimulationResponse {
    let n = t.len();
    let (load, supply) = (vec![3390.0; n], vec![850e3; n]);
    let inputs = InputSeries::new(t, &load, valve, &supply, road).unwrap();
    let initial = InitialState::Equilibrium(InitialCondition::SensorHeight { height_m: 0.22 });
    simulate(
        &SimulationProblem::new(model, inputs, initial)
            .with_options(SolverOptions::default().with_method(method).with_rtol(rtol)),
    )
    .unwrap()
}

/// A level road at the logger's 100 ms with a one-sample pothole and a four-sample hump, each
/// after seconds of level road (as the virtual truck's road run 1 lays them out).
fn level_road_with_features() -> (Vec<f64>, Vec<f64>) {
    let n = 400;
    let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.1).collect();
    let mut road = vec![0.0; n];
    road[170] = -0.010;
    road[275..279].copy_from_slice(&[0.0282, 0.0603, 0.0591, 0.0254]);
    (t, road)
}

#[test]
fn auto_steps_over_no_pothole_or_hump_at_any_tolerance() {
    let truck = TruckParameters::reference();
    let (t, road) = level_road_with_features();
    let valve = vec![ValveState::Closed; t.len()];
    for name in ["m1", "m2"] {
        let model = build_model(name, &truck).unwrap();
        let run = |method, rtol| over_road(&*model, (&t, &road, &valve), method, rtol);
        let reference = run(Method::Auto, 1e-10);
        assert_eq!(reference.statistics.fallback, None, "{name}");
        // Each feature moves the height by centimetres within 2 s; before it, it is at rest.
        for (start, what) in [(170, "pothole"), (275, "hump")] {
            let rest = reference.sensor_height_m[start - 1];
            let moved_mm = reference.sensor_height_m[start..start + 20]
                .iter()
                .map(|h| (h - rest).abs() * 1e3)
                .fold(0.0, f64::max);
            assert!(
                moved_mm > 5.0,
                "{name}: the {what} moved the height {moved_mm:.2} mm"
            );
        }
        // At every tolerance `Auto` (the explicit method, stopping at each of the road's
        // kinks) sees what it sees at 1e-10. BDF, whose steps grow long on the level road,
        // missed a feature, 31.6 mm off, at some tolerances and not others (Model 1 at 1e-5,
        // 1e-6, 1e-7 and 1e-10; Model 2 at 1e-5, 1e-7 and 1e-8).
        for rtol in [1e-4, 1e-5, 1e-6, 1e-7, 1e-8] {
            let response = run(Method::Auto, rtol);
            let height_mm =
                1e3 * max_abs_diff(&response.sensor_height_m, &reference.sensor_height_m);
            let pressure_kpa =
                1e-3 * max_abs_diff(&response.bellow_gauge_pa, &reference.bellow_gauge_pa);
            assert!(
                height_mm < 0.05 && pressure_kpa < 0.1,
                "{name} at rtol {rtol:e}: {height_mm:.3} mm, {pressure_kpa:.3} kPa off rtol 1e-10"
            );
        }
    }
}

/// 10 s standing, 40 s of a rough road (a sum of sines from 0.5 to 12 Hz, 100 ms samples, as
/// the logger records it; `scale` 1: 12 mm at 0.5 Hz), then 10 s standing with the valve
/// filling for 2 s.
fn drive_then_fill(scale: f64) -> (Vec<f64>, Vec<f64>, Vec<ValveState>) {
    let n = 601;
    let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.1).collect();
    let road = t
        .iter()
        .map(|&t| {
            if (10.0..50.0).contains(&t) {
                scale
                    * [
                        (0.5, 0.012, 0.3),
                        (1.7, 0.004, 1.1),
                        (4.1, 0.002, 2.0),
                        (11.8, 0.001, 0.7),
                    ]
                    .iter()
                    .map(|(f, a, phase)| a * (std::f64::consts::TAU * f * (t - 10.0) + phase).sin())
                    .sum::<f64>()
                    - scale
                        * [(0.012, 0.3), (0.004, 1.1), (0.002, 2.0), (0.001, 0.7)]
                            .iter()
                            .map(|(a, phase): &(f64, f64)| a * phase.sin())
                            .sum::<f64>()
            } else {
                0.0
            }
        })
        .collect();
    let valve = filling_over(&t, 53.0..55.0);
    (t, road, valve)
}

/// The valve filling while the time is in `seconds`, closed otherwise.
fn filling_over(t: &[f64], seconds: std::ops::Range<f64>) -> Vec<ValveState> {
    t.iter()
        .map(|t| {
            if seconds.contains(t) {
                ValveState::Fill
            } else {
                ValveState::Closed
            }
        })
        .collect()
}

#[test]
fn auto_drives_with_the_explicit_method_and_stands_with_bdf() {
    let (t, road, valve) = drive_then_fill(1.0);
    let n = t.len();
    for name in ["m1", "m2"] {
        let model = build_model(name, &TruckParameters::reference()).unwrap();
        let run = |method, rtol| over_road(&*model, (&t, &road, &valve), method, rtol);
        let reference = run(Method::Bdf, 1e-10);
        let bdf = run(Method::Bdf, 1e-6);
        let auto = run(Method::Auto, 1e-6);
        assert_eq!(auto.statistics.fallback, None, "{name}");
        for (label, response) in [("bdf", &bdf), ("auto", &auto)] {
            let height_mm =
                1e3 * max_abs_diff(&response.sensor_height_m, &reference.sensor_height_m);
            let pressure_kpa =
                1e-3 * max_abs_diff(&response.bellow_gauge_pa, &reference.bellow_gauge_pa);
            // The sensors resolve 0.1 mm and 0.1 kPa; both methods are far inside.
            assert!(
                height_mm < 0.01 && pressure_kpa < 0.02,
                "{name} {label}: {height_mm:.4} mm, {pressure_kpa:.4} kPa off rtol 1e-10"
            );
        }
        // The fill lifted the truck: the standing segments were simulated, not skipped.
        let lift_mm = 1e3 * (auto.sensor_height_m[n - 1] - auto.sensor_height_m[525]);
        assert!(
            lift_mm > 5.0,
            "{name}: the fill lifted the truck {lift_mm:.2} mm"
        );
        assert!(
            2 * auto.statistics.steps < bdf.statistics.steps,
            "{name}: auto {} steps, BDF {}",
            auto.statistics.steps,
            bdf.statistics.steps
        );
        // Standing → driving → standing.
        assert_eq!(auto.statistics.method_changes, 2, "{name}");
        assert_eq!(bdf.statistics.method_changes, 0, "{name}");
    }
}

#[test]
fn auto_drives_through_a_road_logged_in_whole_millimetres() {
    // Rounded to the millimetre, the rough road repeats a sample here and there: a level
    // stretch of 0.1-0.3 s between moving ones, which the explicit method drives through.
    let (t, road, valve) = drive_then_fill(1.0);
    let road_mm: Vec<f64> = road.iter().map(|r| (r * 1e3).round() * 1e-3).collect();
    let repeats = road_mm[100..500]
        .windows(2)
        .filter(|w| w[0] == w[1])
        .count();
    assert!(repeats >= 20, "{repeats} repeated samples");
    let model = build_model("m2", &TruckParameters::reference()).unwrap();
    let run = |method, rtol| over_road(&*model, (&t, &road_mm, &valve), method, rtol);
    let auto = run(Method::Auto, 1e-6);
    let reference = run(Method::Bdf, 1e-10);
    assert_eq!(auto.statistics.fallback, None);
    assert_eq!(auto.statistics.method_changes, 2);
    let height_mm = 1e3 * max_abs_diff(&auto.sensor_height_m, &reference.sensor_height_m);
    assert!(height_mm < 0.01, "{height_mm:.4} mm off rtol 1e-10");
}

#[test]
fn auto_hands_the_state_on_at_a_fill_while_driving() {
    // The valve filling for 2 s in the middle of the rough road: the explicit method runs on
    // across the fill's restarts, and hands over to BDF where the road ends.
    let (t, road, _) = drive_then_fill(1.0);
    let valve = filling_over(&t, 30.0..32.0);
    let model = build_model("m2", &TruckParameters::reference()).unwrap();
    let run = |method, rtol| over_road(&*model, (&t, &road, &valve), method, rtol);
    let auto = run(Method::Auto, 1e-6);
    let bdf = run(Method::Bdf, 1e-6);
    let reference = run(Method::Bdf, 1e-10);
    assert_eq!(auto.statistics.fallback, None);
    let height_mm = 1e3 * max_abs_diff(&auto.sensor_height_m, &reference.sensor_height_m);
    let pressure_kpa = 1e-3 * max_abs_diff(&auto.bellow_gauge_pa, &reference.bellow_gauge_pa);
    assert!(
        height_mm < 0.01 && pressure_kpa < 0.02,
        "{height_mm:.4} mm, {pressure_kpa:.4} kPa off rtol 1e-10"
    );
    // The fill lifted the truck while it drove (2 s averages, before and after).
    let mean = |from: usize| auto.sensor_height_m[from..from + 20].iter().sum::<f64>() / 20.0;
    let lift_mm = 1e3 * (mean(335) - mean(278));
    assert!(lift_mm > 5.0, "the fill lifted the truck {lift_mm:.2} mm");
    assert!(
        2 * auto.statistics.steps < bdf.statistics.steps,
        "auto {} steps, BDF {}",
        auto.statistics.steps,
        bdf.statistics.steps
    );
}

#[test]
fn auto_runs_a_stiff_road_again_with_bdf() {
    // A tire damped 1,000 times more than a real one: its wheel-hop mode decays within a
    // tenth of a millisecond, which holds an explicit method to steps shorter than that. On
    // a road of a hundredth of the amplitude, so that the damping does not lift the wheel.
    let mut truck = TruckParameters::reference();
    truck.tire.damping_n_s_per_m = 1e7;
    let model = build_model("m2", &truck).unwrap();
    let (t, road, valve) = drive_then_fill(0.01);
    let run = |method| over_road(&*model, (&t, &road, &valve), method, 1e-6);
    let auto = run(Method::Auto);
    assert_eq!(
        auto.statistics.fallback,
        Some(Method::Bdf),
        "the explicit segment ran over its budget, and BDF ran the whole run"
    );
    let bdf = run(Method::Bdf);
    assert_eq!(auto.sensor_height_m, bdf.sensor_height_m);
}
