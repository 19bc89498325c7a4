//! 25-minute load-step run (15,001 samples at 100 ms, ±300 kg every 3 min, valve closed,
//! noisy logged supply pressure), reference truck, rtol 1e-6, one core.
//!
//! `cargo bench -p airsus-sim --bench simulate`

use airsus_data::TruckParameters;
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

criterion_group!(simulation, benches);
criterion_main!(simulation);
