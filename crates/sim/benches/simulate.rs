//! 25-minute load-step run (15,001 samples at 100 ms, ±300 kg every 3 min, valve closed,
//! noisy logged supply pressure), reference truck, rtol 1e-6, one core.
//!
//! And a 40 s road run (ISO 8608 class C at 50 km/h, sampled at 100 ms, as the virtual
//! truck's road runs), the road linear between samples: BDF at three tolerances, and
//! `Method::Auto`.
//!
//! `cargo bench -p airsus-sim --bench simulate`

use airsus_data::{Run, RunInputs, TruckParameters, ValveState};
use airsus_model::{InitialCondition, SuspensionModel, build_model};
use airsus_sim::reference::{DampedOscillator, ToyQuarterCar, load_step_run};
use airsus_sim::{
    InitialState, InputSeries, Method, SimulationProblem, SimulationResponse, SolverOptions,
    simulate_into,
};
use criterion::{Criterion, criterion_group, criterion_main};

fn bench_model(
    c: &mut Criterion,
    label: &str,
    model: &dyn SuspensionModel,
    initial: InitialState,
    methods: &[Method],
) {
    let run = load_step_run(1500.0, 0.1, 3350.0, 300.0, 180.0);
    let inputs = InputSeries::from_run(&run).expect("valid run");
    let mut group = c.benchmark_group("load_steps_25min");
    for &method in methods {
        let problem = SimulationProblem::new(model, inputs, initial.clone())
            .with_options(SolverOptions::default().with_method(method).with_rtol(1e-6));
        let mut response = SimulationResponse::default();
        simulate_into(&problem, &mut response).expect("simulates");
        let s = response.statistics;
        eprintln!(
            "{label} {method:?}: {} steps, {} rejected, {} rhs evaluations, {} Jacobians, {} LU setups, {} restarts",
            s.steps,
            s.rejected_steps,
            s.rhs_evaluations,
            s.jacobian_evaluations,
            s.linear_solver_setups,
            s.restarts
        );
        group.bench_function(format!("{label}/{method:?}"), |b| {
            b.iter(|| simulate_into(&problem, &mut response).expect("simulates"))
        });
    }
    group.finish();
}

fn benches(c: &mut Criterion) {
    let truck = TruckParameters::reference();
    let at_350_kpa =
        InitialState::Equilibrium(InitialCondition::BellowPressure { gauge_pa: 350e3 });
    for name in ["m1", "m2"] {
        let model = build_model(name, &truck).expect("model builds");
        bench_model(
            c,
            name,
            &*model,
            at_350_kpa.clone(),
            &[Method::Bdf, Method::TrBdf2, Method::Esdirk34],
        );
    }
    for name in ["m2x", "m2xh", "m3"] {
        let model = build_model(name, &truck).expect("model builds");
        bench_model(c, name, &*model, at_350_kpa.clone(), &[Method::Bdf]);
    }
    bench_model(
        c,
        "ref-quarter-car",
        &ToyQuarterCar::reference(),
        at_350_kpa,
        &[Method::Bdf],
    );
    let oscillator = DampedOscillator::tire_like();
    bench_model(
        c,
        "ref-oscillator",
        &oscillator,
        InitialState::State(vec![oscillator.equilibrium(3350.0), 0.0]),
        &[Method::Bdf, Method::Tsit45],
    );
}

/// 40 s of an ISO 8608 class C road at 50 km/h sampled every 100 ms: 200 cosines between
/// 0.011 and 0.29 cycles/m with the class's displacement PSD `256e-6 (n / 0.1)^-2` m³ and
/// fixed pseudo-random phases (the virtual truck's road run 2 draws its road the same way).
fn iso_road_run() -> Run {
    let (dt_s, speed_m_s, n) = (0.1, 50.0 / 3.6, 401);
    let time_s: Vec<f64> = (0..n).map(|k| k as f64 * dt_s).collect();
    let (n_min, n_max, waves) = (0.011, 0.4 / (dt_s * speed_m_s), 200);
    let dn = (n_max - n_min) / waves as f64;
    let mut seed: u64 = 0x9e37_79b9_7f4a_7c15;
    let components: Vec<(f64, f64, f64)> = (0..waves)
        .map(|i| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let phase = (seed % 1_000_000) as f64 / 1e6 * std::f64::consts::TAU;
            let n_cyc = n_min + (i as f64 + 0.5) * dn;
            let psd = 256e-6 * (n_cyc / 0.1).powi(-2);
            ((2.0 * psd * dn).sqrt(), n_cyc, phase)
        })
        .collect();
    let height = |d: f64| -> f64 {
        components
            .iter()
            .map(|(a, n_cyc, phase)| a * (std::f64::consts::TAU * n_cyc * d + phase).cos())
            .sum()
    };
    let start = height(0.0);
    Run {
        name: "iso-road".to_owned(),
        sample_time_s: dt_s,
        inputs: RunInputs {
            wheel_load_kg: vec![3390.0; n],
            valve: vec![ValveState::Closed; n],
            supply_gauge_pa: vec![850e3; n],
            road_height_m: time_s
                .iter()
                .map(|t| height(t * speed_m_s) - start)
                .collect(),
        },
        time_s,
        outputs: None,
    }
}

/// The road run with BDF at three tolerances and with `Method::Auto` (the explicit method
/// while the road moves); what each costs in accuracy is printed against a BDF solution at
/// rtol 1e-9.
fn bench_road(c: &mut Criterion) {
    let truck = TruckParameters::reference();
    let run = iso_road_run();
    let inputs = InputSeries::from_run(&run).expect("valid run");
    let initial = InitialState::Equilibrium(InitialCondition::SensorHeight { height_m: 0.22 });
    let mut group = c.benchmark_group("iso_road_40s");
    for name in ["m1", "m2"] {
        let model = build_model(name, &truck).expect("model builds");
        let solve = |method: Method, rtol: f64| {
            let problem = SimulationProblem::new(&*model, inputs, initial.clone())
                .with_options(SolverOptions::default().with_method(method).with_rtol(rtol));
            let mut response = SimulationResponse::default();
            simulate_into(&problem, &mut response).expect("simulates");
            (problem, response)
        };
        let (_, reference) = solve(Method::Bdf, 1e-9);
        let worst = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max)
        };
        for (method, rtol) in [
            (Method::Bdf, 1e-6),
            (Method::Bdf, 1e-5),
            (Method::Bdf, 1e-4),
            (Method::Auto, 1e-6),
        ] {
            let (problem, mut response) = solve(method, rtol);
            let s = response.statistics;
            eprintln!(
                "{name} {method:?} rtol {rtol:e}: {} steps, {} rejected, {} rhs evaluations, {} Jacobians, {} restarts; against rtol 1e-9 height {:.2e} mm, pressure {:.2e} kPa at worst",
                s.steps,
                s.rejected_steps,
                s.rhs_evaluations,
                s.jacobian_evaluations,
                s.restarts,
                1e3 * worst(&response.sensor_height_m, &reference.sensor_height_m),
                1e-3 * worst(&response.bellow_gauge_pa, &reference.bellow_gauge_pa),
            );
            group.bench_function(format!("{name}/{method:?}/rtol{rtol:e}"), |b| {
                b.iter(|| simulate_into(&problem, &mut response).expect("simulates"))
            });
        }
    }
    group.finish();
}

criterion_group!(road, bench_road);
criterion_group!(simulation, benches);
criterion_main!(simulation, road);
