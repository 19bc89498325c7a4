//! Grey-box Model 2 with the thesis' "Estimation 2" set (p0–p4, m2, ig; Table 5.11) on a
//! 25-minute load-step run (15,001 samples at 100 ms, ±300 kg every 3 min, valve closed),
//! "measured" on the reference truck with 0.2 mm / 1 kPa noise, from a start 20–25 % off
//! (p0, m2, ig). Also one simulation of the same run, to split the time into
//! simulations × time per simulation.
//!
//! `cargo bench -p airsus-estimate --bench greybox`

use airsus_data::{RunOutputs, TruckParameters};
use airsus_estimate::{GreyboxOptions, GreyboxProblem, NoProgress, estimate};
use airsus_model::{InitialCondition, build_model};
use airsus_sim::reference::load_step_run;
use airsus_sim::{InitialState, InputSeries, SimulationProblem, SolverOptions, simulate};
use criterion::{Criterion, criterion_group, criterion_main};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

fn benches(c: &mut Criterion) {
    let truck = TruckParameters::reference();
    let truth = build_model("m2", &truck).expect("m2");
    let mut run = load_step_run(1500.0, 0.1, 3350.0, 300.0, 180.0);
    let ic = InitialState::Equilibrium(InitialCondition::SensorHeight { height_m: 0.24 });
    let inputs = InputSeries::from_run(&run).expect("inputs");
    let sim = simulate(
        &SimulationProblem::new(&*truth, inputs, ic.clone())
            .with_options(SolverOptions::default().with_rtol(1e-8)),
    )
    .expect("simulates");
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut noise = |s: f64| {
        let z: f64 = StandardNormal.sample(&mut rng);
        s * z
    };
    let height = sim
        .sensor_height_m
        .iter()
        .enumerate()
        .map(|(k, h)| if k == 0 { *h } else { h + noise(2e-4) })
        .collect();
    let pressure = sim.bellow_gauge_pa.iter().map(|p| p + noise(1e3)).collect();
    run.outputs = Some(RunOutputs {
        sensor_height_m: height,
        bellow_gauge_pa: pressure,
    });

    let mut start = build_model("m2", &truck).expect("m2");
    for (name, factor) in [("p0", 1.2), ("m2", 1.25), ("ig", 0.75)] {
        let v = start.parameter(name).expect("exists");
        start.set_parameter(name, v * factor).expect("in range");
    }
    let free = ["p0", "p1", "p2", "p3", "p4", "m2", "ig"];
    let problem = GreyboxProblem::new(&*start, &[&run], &free);
    let options = GreyboxOptions::default();
    let result = estimate(&problem, &options, &mut NoProgress).expect("estimates");
    eprintln!("{result}");

    let inputs = InputSeries::from_run(&run).expect("inputs");
    let one = SimulationProblem::new(&*start, inputs, ic);
    let mut group = c.benchmark_group("greybox");
    group.sample_size(10);
    group.bench_function("m2_simulation_25min", |b| {
        b.iter(|| simulate(&one).expect("simulates"))
    });
    group.bench_function("m2_estimation2_25min", |b| {
        b.iter(|| estimate(&problem, &options, &mut NoProgress).expect("estimates"))
    });
    group.finish();
}

criterion_group!(greybox, benches);
criterion_main!(greybox);
