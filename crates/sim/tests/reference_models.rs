//! The engine against models with known answers (crate `reference` module).

mod common;

use airsus_data::ValveState;
use airsus_model::{InitialCondition, SuspensionModel};
use airsus_sim::reference::{
    DampedOscillator, FirstOrderLag, GasVolume, Runaway, ToyQuarterCar, load_step_run,
};
use airsus_sim::{
    AbsoluteTolerance, InitialState, InputSeries, Method, RoadInput, SimError, SimulationProblem,
    SimulationResponse, SolverFailure, SolverOptions, StateViolation, SupplyRelevance, simulate,
    simulate_into,
};
use common::max_abs_diff;

fn grid(n: usize, dt: f64) -> Vec<f64> {
    (0..n).map(|k| k as f64 * dt).collect()
}

struct Signals {
    time: Vec<f64>,
    load: Vec<f64>,
    valve: Vec<ValveState>,
    supply: Vec<f64>,
    road: Vec<f64>,
}

impl Signals {
    fn new(time: Vec<f64>, load: impl Fn(f64) -> f64) -> Self {
        let n = time.len();
        Self {
            load: time.iter().map(|&t| load(t)).collect(),
            time,
            valve: vec![ValveState::Closed; n],
            supply: vec![850e3; n],
            road: vec![0.0; n],
        }
    }

    fn inputs(&self) -> InputSeries<'_> {
        InputSeries::new(
            &self.time,
            &self.load,
            &self.valve,
            &self.supply,
            &self.road,
        )
        .expect("valid inputs")
    }
}

fn step_load(t: f64) -> f64 {
    if (2.0..5.0).contains(&t) {
        3650.0
    } else if t >= 5.0 {
        3050.0
    } else {
        3350.0
    }
}

#[test]
fn oscillator_matches_analytic_solution_at_rtol_1e_6() {
    let model = DampedOscillator::tire_like();
    let s = Signals::new(grid(801, 0.01), step_load);
    // start 2 mm off equilibrium, at rest
    let x0 = model.equilibrium(3350.0) + 0.002;
    let problem = SimulationProblem::new(
        &model,
        s.inputs(),
        InitialState::Equilibrium(InitialCondition::SensorHeight { height_m: x0 }),
    );
    let exact = model.exact_response(&s.time, &s.load, x0);
    for method in [
        Method::Bdf,
        Method::TrBdf2,
        Method::Esdirk34,
        Method::Tsit45,
    ] {
        let options = SolverOptions::default().with_method(method).with_rtol(1e-6);
        let r = simulate(&problem.clone().with_options(options)).expect("simulates");
        let err = max_abs_diff(&r.sensor_height_m, &exact);
        eprintln!("{method:?}: max error {err:e} m; {:?}", r.statistics);
        // global error within 10 x the local tolerance rtol |x| + atol (atol = 1e-6 * 0.1 m)
        assert!(
            err < 10.0 * (1e-6 * 0.02 + 1e-7),
            "{method:?}: max error {err:e} m"
        );
        assert_eq!(r.statistics.restarts, 2, "{method:?}");
    }
}

#[test]
fn accuracy_improves_with_tolerance() {
    let model = DampedOscillator::tire_like();
    let s = Signals::new(grid(801, 0.01), step_load);
    let x0 = model.equilibrium(3350.0) + 0.002;
    let exact = model.exact_response(&s.time, &s.load, x0);
    let problem = SimulationProblem::new(
        &model,
        s.inputs(),
        InitialState::Equilibrium(InitialCondition::SensorHeight { height_m: x0 }),
    );
    let err = |rtol: f64| {
        let options = SolverOptions::default()
            .with_rtol(rtol)
            .with_atol(AbsoluteTolerance::Uniform(rtol * 1e-2));
        let r = simulate(&problem.clone().with_options(options)).expect("simulates");
        max_abs_diff(&r.sensor_height_m, &exact)
    };
    let (coarse, fine) = (err(1e-4), err(1e-8));
    assert!(
        fine < coarse / 100.0,
        "rtol 1e-4: {coarse:e}, rtol 1e-8: {fine:e}"
    );
    assert!(fine < 10.0 * (1e-8 * 0.02 + 1e-10), "rtol 1e-8: {fine:e}");
}

#[test]
fn lag_restarts_at_each_load_step_and_outputs_use_the_sample_input() {
    let model = FirstOrderLag {
        tau_s: 0.7,
        gain_m_per_kg: 1e-4,
    };
    let s = Signals::new(grid(101, 0.1), step_load);
    let problem = SimulationProblem::new(
        &model,
        s.inputs(),
        InitialState::Equilibrium(InitialCondition::BellowPressure { gauge_pa: 0.0 }),
    );
    let r = simulate(&problem).expect("simulates");
    assert_eq!(r.statistics.restarts, 2);
    let exact = model.exact_response(&s.time, &s.load, 0.335);
    let err = max_abs_diff(&r.sensor_height_m, &exact);
    // 10 x (rtol |y| + atol), atol = rtol * 0.335
    assert!(err < 10.0 * 1e-6 * (0.365 + 0.335), "max error {err:e}");
    // output k sees input k (zero-order hold value on [t_k, t_k+1)), also at the step samples
    assert_eq!(r.bellow_gauge_pa, s.load);
    // before the first step the state does not move at all
    assert!(
        r.sensor_height_m[..20]
            .iter()
            .all(|&y| (y - 0.335).abs() < 1e-12)
    );
}

#[test]
fn outputs_are_at_exactly_the_sample_times_even_on_a_jittered_grid() {
    let model = FirstOrderLag {
        tau_s: 1.3,
        gain_m_per_kg: 1e-4,
    };
    let time: Vec<f64> = (0..60)
        .map(|k| k as f64 * 0.1 + if k % 3 == 1 { 0.004 } else { 0.0 })
        .collect();
    let s = Signals::new(time, step_load);
    let problem = SimulationProblem::new(
        &model,
        s.inputs(),
        InitialState::Equilibrium(InitialCondition::BellowPressure { gauge_pa: 0.0 }),
    );
    let r = simulate(&problem).expect("simulates");
    assert_eq!(r.time_s, s.time);
    assert_eq!(r.sensor_height_m.len(), s.time.len());
    let exact = model.exact_response(&s.time, &s.load, 0.335);
    let err = max_abs_diff(&r.sensor_height_m, &exact);
    assert!(err < 10.0 * 1e-6 * (0.365 + 0.335), "max error {err:e}");
}

#[test]
fn supply_changes_restart_only_while_filling() {
    let model = GasVolume::reference();
    let n = 301;
    let time = grid(n, 0.1);
    // closed 0-10 s, fill 10-15 s, closed 15-20 s, exhaust 20-25 s, closed after
    let valve: Vec<ValveState> = time
        .iter()
        .map(|&t| match t {
            t if (10.0..15.0).contains(&t) => ValveState::Fill,
            t if (20.0..25.0).contains(&t) => ValveState::Exhaust,
            _ => ValveState::Closed,
        })
        .collect();
    // a noisy logged supply: every sample differs
    let supply: Vec<f64> = (0..n)
        .map(|k| 850e3 + 500.0 * ((k * 7919) % 13) as f64)
        .collect();
    let load = vec![3350.0; n];
    let road = vec![0.0; n];
    let inputs = InputSeries::new(&time, &load, &valve, &supply, &road).expect("valid");
    let problem = SimulationProblem::new(
        &model,
        inputs,
        InitialState::Equilibrium(InitialCondition::BellowPressure { gauge_pa: 350e3 }),
    );
    let r = simulate(&problem).expect("simulates");
    // 4 valve switches + 49 supply changes inside the 50 fill samples (the first fill sample
    // is already a valve switch)
    assert_eq!(r.statistics.restarts, 4 + 49, "{:?}", r.statistics);
    let exact = model.exact_response(&time, &valve, &supply, 350e3);
    let err = max_abs_diff(&r.bellow_gauge_pa, &exact);
    eprintln!("gas: max error {err} Pa; {:?}", r.statistics);
    // 10 x rtol of the absolute pressure (atol is rtol * n0)
    let tol = 10.0 * 1e-6 * (950e3 + 450e3);
    assert!(err < tol, "max error {err} Pa");

    let always = problem.clone().with_options(SolverOptions {
        supply: SupplyRelevance::Always,
        ..SolverOptions::default()
    });
    let r_always = simulate(&always).expect("simulates");
    assert!(
        r_always.statistics.restarts > 290,
        "{:?}",
        r_always.statistics
    );
    assert!(max_abs_diff(&r_always.bellow_gauge_pa, &exact) < tol);
}

#[test]
fn a_25_minute_load_step_run_restarts_only_at_load_steps() {
    let run = load_step_run(1500.0, 0.1, 3350.0, 300.0, 180.0);
    assert_eq!(run.len(), 15_001);
    let model = ToyQuarterCar::reference();
    let problem = SimulationProblem::new(
        &model,
        InputSeries::from_run(&run).expect("valid"),
        InitialState::Equilibrium(InitialCondition::BellowPressure { gauge_pa: 350e3 }),
    );
    let r = simulate(&problem).expect("simulates");
    // 1500 s / 180 s: 8 load changes; the noisy supply does not count with the valve closed
    assert_eq!(r.statistics.restarts, 8);
    assert_eq!(r.len(), 15_001);
    assert!(r.bellow_gauge_pa.iter().all(|p| p.is_finite()));
}

#[test]
fn exploding_state_is_an_error_naming_model_time_and_state() {
    let model = Runaway {
        leak_mol_per_s: 0.0,
        growth_per_s: 50.0,
        n0_mol: 2.0,
        x0_m: 1.0,
    };
    let s = Signals::new(grid(51, 0.1), |_| 3350.0);
    let problem = SimulationProblem::new(
        &model,
        s.inputs(),
        InitialState::Equilibrium(InitialCondition::BellowPressure { gauge_pa: 0.0 }),
    );
    let err = simulate(&problem).expect_err("must fail");
    let SimError::InadmissibleState {
        ref model,
        time_s,
        ref violation,
        ref state,
    } = err
    else {
        panic!("unexpected error {err}");
    };
    assert_eq!(model, "ref-runaway");
    // x = e^{50 t} passes 1e9 at t = 0.414 s; reported at the first sample past it (or the step end)
    assert!((0.41..=0.6).contains(&time_s), "t = {time_s}");
    assert!(
        matches!(violation, StateViolation::OutOfBounds { name: "x_m", .. }),
        "{violation}"
    );
    assert!(state.get("x_m").is_some_and(|x| x >= 1e9));
    let message = err.to_string();
    assert!(
        message.contains("ref-runaway") && message.contains("x_m") && message.contains("n_mol"),
        "{message}"
    );
}

#[test]
fn negative_amount_of_air_is_an_error() {
    let model = Runaway {
        leak_mol_per_s: 1.0,
        growth_per_s: 0.0,
        n0_mol: 2.0,
        x0_m: 0.3,
    };
    let s = Signals::new(grid(101, 0.1), |_| 3350.0);
    let problem = SimulationProblem::new(
        &model,
        s.inputs(),
        InitialState::Equilibrium(InitialCondition::BellowPressure { gauge_pa: 0.0 }),
    );
    let err = simulate(&problem).expect_err("must fail");
    assert!(
        matches!(
            &err,
            SimError::InadmissibleState {
                violation: StateViolation::OutOfBounds { name: "n_mol", .. },
                ..
            }
        ),
        "{err}"
    );
    let t = err.time_s().expect("has a time");
    assert!((2.0..=2.11).contains(&t), "t = {t}");
    assert!(
        err.state()
            .and_then(|s| s.get("n_mol"))
            .is_some_and(|n| n <= 0.0)
    );
}

#[test]
fn step_budget_is_an_error_not_a_hang() {
    let model = DampedOscillator::tire_like();
    let s = Signals::new(grid(101, 0.1), step_load);
    let problem = SimulationProblem::new(
        &model,
        s.inputs(),
        InitialState::Equilibrium(InitialCondition::SensorHeight { height_m: 0.02 }),
    )
    .with_options(SolverOptions::default().with_max_steps(10));
    let err = simulate(&problem).expect_err("must fail");
    assert!(
        matches!(
            err,
            SimError::SolverFailed {
                failure: SolverFailure::TooManySteps { max_steps: 10 },
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn tire_lift_off_over_a_road_drop() {
    let model = ToyQuarterCar::reference();
    let n = 601;
    let time = grid(n, 0.01);
    // the road drops 10 cm at t = 1 s (the wheel leaves the ground) and steps back up at 3 s
    let road: Vec<f64> = time
        .iter()
        .map(|&t| if (1.0..3.0).contains(&t) { -0.1 } else { 0.0 })
        .collect();
    let load = vec![3350.0; n];
    let valve = vec![ValveState::Closed; n];
    let supply = vec![850e3; n];
    let inputs = InputSeries::new(&time, &load, &valve, &supply, &road).expect("valid");
    let problem = SimulationProblem::new(
        &model,
        inputs,
        InitialState::Equilibrium(InitialCondition::BellowPressure { gauge_pa: 350e3 }),
    )
    // A drop is a step, not a ramp between samples: the road is held (zero-order).
    .with_options(
        SolverOptions::default()
            .with_states(true)
            .with_road(RoadInput::Hold),
    );
    let r = simulate(&problem).expect("lift-off must not break the solver");
    assert_eq!(r.statistics.restarts, 2);
    let states = r.states.as_ref().expect("recorded");
    let x2 = states.trajectory("x2_m").expect("axle height");
    let airborne = (0..n)
        .filter(|&k| x2[k] > model.tire_radius_m + road[k])
        .count();
    assert!(
        airborne >= 3,
        "the wheel should leave the road for a while: {airborne} samples"
    );

    let fine = simulate(
        &problem.clone().with_options(
            SolverOptions::default()
                .with_rtol(1e-10)
                .with_road(RoadInput::Hold),
        ),
    )
    .expect("simulates at rtol 1e-10");
    let err = max_abs_diff(&r.sensor_height_m, &fine.sensor_height_m);
    assert!(
        err < 1e-5,
        "height differs by {err:e} m from the rtol 1e-10 solution"
    );
}

#[test]
fn remake_with_new_parameters_and_buffer_reuse() {
    let model = DampedOscillator::tire_like();
    let s = Signals::new(grid(201, 0.01), step_load);
    let problem = SimulationProblem::new(
        &model,
        s.inputs(),
        InitialState::Equilibrium(InitialCondition::SensorHeight { height_m: 0.02 }),
    );
    let mut stiffer = model.clone();
    stiffer.set_parameter("k", 2.5e6).expect("in range");
    let boxed: Box<dyn SuspensionModel> = Box::new(stiffer.clone());
    let remade = problem.with_model(&*boxed);
    let mut response = SimulationResponse::default();
    simulate_into(&remade, &mut response).expect("simulates");
    let exact = stiffer.exact_response(&s.time, &s.load, 0.02);
    assert!(max_abs_diff(&response.sensor_height_m, &exact) < 2e-7);
    // the same buffers again, other parameters
    simulate_into(&problem, &mut response).expect("simulates");
    let exact = model.exact_response(&s.time, &s.load, 0.02);
    assert!(max_abs_diff(&response.sensor_height_m, &exact) < 2e-7);
    assert_eq!(response.len(), 201);
}

#[test]
fn bad_problems_are_errors() {
    let time = grid(5, 0.1);
    let short = vec![0.0; 4];
    let ok = vec![0.0; 5];
    let valve = vec![ValveState::Closed; 5];
    assert!(matches!(
        InputSeries::new(&time, &short, &valve, &ok, &ok),
        Err(SimError::InvalidInputs { .. })
    ));
    let backwards = vec![0.0, 0.1, 0.1, 0.3, 0.4];
    assert!(matches!(
        InputSeries::new(&backwards, &ok, &valve, &ok, &ok),
        Err(SimError::InvalidInputs { .. })
    ));
    let nan = vec![0.0, f64::NAN, 0.0, 0.0, 0.0];
    assert!(matches!(
        InputSeries::new(&time, &nan, &valve, &ok, &ok),
        Err(SimError::InvalidInputs { .. })
    ));
    assert!(matches!(
        InputSeries::new(&[], &[], &[], &[], &[]),
        Err(SimError::InvalidInputs { .. })
    ));

    let model = DampedOscillator::tire_like();
    let inputs = InputSeries::new(&time, &ok, &valve, &ok, &ok).expect("valid");
    let base = SimulationProblem::new(&model, inputs, InitialState::State(vec![0.0, 0.0]));
    for options in [
        SolverOptions::default().with_rtol(0.0),
        SolverOptions::default().with_rtol(f64::NAN),
        SolverOptions::default().with_atol(AbsoluteTolerance::PerState(vec![1e-6])),
        SolverOptions::default().with_atol(AbsoluteTolerance::Uniform(-1.0)),
        SolverOptions::default().with_max_steps(0),
    ] {
        let err = simulate(&base.clone().with_options(options.clone())).expect_err("invalid");
        assert!(
            matches!(err, SimError::InvalidProblem { .. }),
            "{options:?}: {err}"
        );
    }
    let wrong_len = SimulationProblem::new(&model, inputs, InitialState::State(vec![0.0]));
    assert!(matches!(
        simulate(&wrong_len),
        Err(SimError::InvalidProblem { .. })
    ));
    let non_finite =
        SimulationProblem::new(&model, inputs, InitialState::State(vec![f64::NAN, 0.0]));
    assert!(matches!(
        simulate(&non_finite),
        Err(SimError::InadmissibleState { .. })
    ));

    // an equilibrium the model cannot find
    let car = ToyQuarterCar::reference();
    let light = vec![100.0; 5];
    let inputs = InputSeries::new(&time, &light, &valve, &ok, &ok).expect("valid");
    let p = SimulationProblem::new(
        &car,
        inputs,
        InitialState::Equilibrium(InitialCondition::BellowPressure { gauge_pa: 350e3 }),
    );
    assert!(matches!(simulate(&p), Err(SimError::InitialState { .. })));
}

#[test]
fn a_single_sample_run_is_its_initial_output() {
    let model = FirstOrderLag {
        tau_s: 1.0,
        gain_m_per_kg: 1e-4,
    };
    let s = Signals::new(vec![3.0], |_| 3000.0);
    let r = simulate(&SimulationProblem::new(
        &model,
        s.inputs(),
        InitialState::Equilibrium(InitialCondition::BellowPressure { gauge_pa: 0.0 }),
    ))
    .expect("simulates");
    assert_eq!(r.sensor_height_m, vec![0.3]);
    assert_eq!(r.statistics.steps, 0);
}

#[test]
fn problems_and_results_can_cross_threads() {
    fn send_sync<T: Send + Sync>() {}
    send_sync::<SimulationProblem<'static>>();
    send_sync::<SimulationProblem<'static, DampedOscillator>>();
    send_sync::<SimulationResponse>();
    send_sync::<SimError>();

    let model = DampedOscillator::tire_like();
    let s = Signals::new(grid(101, 0.01), step_load);
    let problem = SimulationProblem::new(&model, s.inputs(), InitialState::State(vec![0.02, 0.0]));
    let results: Vec<f64> = std::thread::scope(|scope| {
        let handles: Vec<_> = [1.5e6, 2.0e6]
            .into_iter()
            .map(|k| {
                let problem = &problem;
                scope.spawn(move || {
                    let mut m = problem.model.clone();
                    m.set_parameter("k", k).expect("in range");
                    simulate(&problem.with_model(&m)).map(|r| r.sensor_height_m[100])
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("no panic").expect("simulates"))
            .collect()
    });
    assert!(results[0] != results[1]);
}
