//! Shared test helpers: runs built in code, "measured" by a model with seeded sensor noise.

#![allow(dead_code)]

use airsus_data::{Run, RunInputs, RunOutputs, TruckParameters, ValveState};
use airsus_model::{InitialCondition, SuspensionModel};
use airsus_sim::{InitialState, InputSeries, SimulationProblem, simulate};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Sensor noise of the synthetic measurements: 0.2 mm and 1 kPa (white, Gaussian).
pub const HEIGHT_NOISE_M: f64 = 2e-4;
pub const PRESSURE_NOISE_PA: f64 = 1000.0;

pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

fn run_from(name: &str, dt: f64, load: Vec<f64>, valve: Vec<ValveState>) -> Run {
    let n = load.len();
    Run {
        name: name.to_owned(),
        time_s: (0..n).map(|k| k as f64 * dt).collect(),
        sample_time_s: dt,
        inputs: RunInputs {
            wheel_load_kg: load,
            valve,
            supply_gauge_pa: vec![850e3; n],
            road_height_m: vec![0.0; n],
        },
        outputs: None,
    }
}

/// Closed valve, load `base` with `+step` on/off alternately every `period` s (up, up, down…).
pub fn load_step_run(
    name: &str,
    duration_s: f64,
    base_kg: f64,
    step_kg: f64,
    period_s: f64,
) -> Run {
    let dt = 0.1;
    let n = (duration_s / dt).round() as usize + 1;
    let pattern = [0.0, 1.0, 2.0, 1.0];
    let load = (0..n)
        .map(|k| {
            let t = k as f64 * dt;
            base_kg + step_kg * pattern[(t / period_s).floor() as usize % pattern.len()]
        })
        .collect();
    run_from(name, dt, load, vec![ValveState::Closed; n])
}

/// Constant load; valve pulses: every `period` s a fill pulse of `fill_s`, half a period
/// later an exhaust pulse of `exhaust_s` (thesis data-set 3 style).
pub fn valve_pulse_run(
    name: &str,
    duration_s: f64,
    load_kg: f64,
    period_s: f64,
    fill_s: f64,
    exhaust_s: f64,
) -> Run {
    let dt = 0.1;
    let n = (duration_s / dt).round() as usize + 1;
    let valve = (0..n)
        .map(|k| {
            let t = k as f64 * dt;
            let phase = t % period_s;
            if t < 5.0 {
                ValveState::Closed
            } else if phase < fill_s {
                ValveState::Fill
            } else if phase >= 0.5 * period_s && phase < 0.5 * period_s + exhaust_s {
                ValveState::Exhaust
            } else {
                ValveState::Closed
            }
        })
        .collect();
    run_from(name, dt, vec![load_kg; n], valve)
}

/// Simulates `model` on `run` from equilibrium at `initial_height_m` and attaches the outputs
/// with seeded white noise.
pub fn measure(model: &dyn SuspensionModel, mut run: Run, initial_height_m: f64, seed: u64) -> Run {
    let inputs = InputSeries::from_run(&run).expect("valid inputs");
    let problem = SimulationProblem::new(
        model,
        inputs,
        InitialState::Equilibrium(InitialCondition::SensorHeight {
            height_m: initial_height_m,
        }),
    )
    .with_options(airsus_sim::SolverOptions::default().with_rtol(1e-8));
    let sim = simulate(&problem).expect("the true model simulates");
    let mut r = rng(seed);
    let mut noisy = |x: f64, s: f64| {
        let z: f64 = StandardNormal.sample(&mut r);
        x + s * z
    };
    // The first sample is the initial condition the estimator starts from: measured exactly,
    // so that the test compares parameters, not an initial-state error.
    let height: Vec<f64> = sim
        .sensor_height_m
        .iter()
        .enumerate()
        .map(|(k, &h)| if k == 0 { h } else { noisy(h, HEIGHT_NOISE_M) })
        .collect();
    let pressure: Vec<f64> = sim
        .bellow_gauge_pa
        .iter()
        .map(|&p| noisy(p, PRESSURE_NOISE_PA))
        .collect();
    run.outputs = Some(RunOutputs {
        sensor_height_m: height,
        bellow_gauge_pa: pressure,
    });
    run
}

/// The reference truck with its freeable parameters moved by the factors given.
pub fn perturbed(
    truck: &TruckParameters,
    model: &str,
    changes: &[(&str, f64)],
) -> Box<dyn SuspensionModel> {
    let mut m = airsus_model::build_model(model, truck).expect("model builds");
    for (name, factor) in changes {
        let v = m.parameter(name).expect("parameter exists");
        m.set_parameter(name, v * factor).expect("in range");
    }
    m
}
