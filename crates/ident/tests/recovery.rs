//! Recovery of known systems from simulated, noisy data: every parameter within three
//! reported standard deviations of the truth, for each structure.

mod common;

use airsus_ident::linear::{
    ArmaxOrders, ArxOrders, BjOrders, IdData, IdentError, OeOrders, PemOptions, StopReason, armax,
    armax_merged, arx, arx_merged, bj, bj_merged, oe, oe_merged,
};
use common::*;

const N: usize = 4000;

#[test]
fn arx_recovers_second_order_system() {
    // A = 1 - 1.5 q^-1 + 0.7 q^-2, B = q^-1 (1 + 0.5 q^-1), e white, std 0.3
    let mut r = rng(1);
    let u = binary(&mut r, N, 0.3);
    let e = white(&mut r, N, 0.3);
    let a = [1.0, -1.5, 0.7];
    let y = add(
        &lfilter(&[1.0, 0.5], 1, &a, &u),
        &lfilter(&[1.0], 0, &a, &e),
    );
    let data = IdData::siso(y, u, 0.1).expect("valid data");
    let est = arx(&data, &ArxOrders::siso(2, 2, 1)).expect("arx");
    assert_within_sigmas(&est, &[-1.5, 0.7, 1.0, 0.5], 3.0);
    assert_eq!(est.stop, StopReason::Exact);
    // Loss is the innovation variance, FPE slightly above it.
    assert!((est.loss - 0.09).abs() < 0.01, "loss {}", est.loss);
    assert!(est.fpe > est.loss);
}

#[test]
fn armax_recovers_coloured_noise_system() {
    // A = 1 - 1.5 q^-1 + 0.7 q^-2, B = q^-1 (1 + 0.5 q^-1), C = 1 - q^-1 + 0.2 q^-2
    let mut r = rng(2);
    let u = binary(&mut r, N, 0.3);
    let e = white(&mut r, N, 0.5);
    let a = [1.0, -1.5, 0.7];
    let c = [1.0, -1.0, 0.2];
    let y = add(&lfilter(&[1.0, 0.5], 1, &a, &u), &lfilter(&c, 0, &a, &e));
    let data = IdData::siso(y, u, 0.1).expect("valid data");
    let est = armax(
        &data,
        &ArmaxOrders::siso(2, 2, 2, 1),
        &PemOptions::default(),
    )
    .expect("armax");
    assert_within_sigmas(&est, &[-1.5, 0.7, 1.0, 0.5, -1.0, 0.2], 3.0);
    assert!(est.model.is_stable());
    assert!((est.noise_variance - 0.25).abs() < 0.02);
}

#[test]
fn oe_recovers_system_under_white_measurement_noise() {
    // y = (0.5 q^-2 + 0.3 q^-3) / (1 - 1.2 q^-1 + 0.5 q^-2) u + e
    let mut r = rng(3);
    let u = binary(&mut r, N, 0.2);
    let e = white(&mut r, N, 0.2);
    let f = [1.0, -1.2, 0.5];
    let y = add(&lfilter(&[0.5, 0.3], 2, &f, &u), &e);
    let data = IdData::siso(y, u, 0.08).expect("valid data");
    let est = oe(&data, &OeOrders::siso(2, 2, 2), &PemOptions::default()).expect("oe");
    assert_within_sigmas(&est, &[0.5, 0.3, -1.2, 0.5], 3.0);
    assert!(matches!(
        est.stop,
        StopReason::Converged | StopReason::NoFurtherImprovement
    ));
    assert!(est.fit_percent > 80.0, "fit {}", est.fit_percent);
}

#[test]
fn bj_recovers_independent_noise_model() {
    // y = (1 + 0.5 q^-1) q^-1 / (1 - 0.8 q^-1) u + (1 + 0.6 q^-1)/(1 - 0.9 q^-1) e
    let mut r = rng(4);
    let u = binary(&mut r, N, 0.3);
    let e = white(&mut r, N, 0.3);
    let y = add(
        &lfilter(&[1.0, 0.5], 1, &[1.0, -0.8], &u),
        &lfilter(&[1.0, 0.6], 0, &[1.0, -0.9], &e),
    );
    let data = IdData::siso(y, u, 1.0).expect("valid data");
    let est = bj(
        &data,
        &BjOrders::siso(2, 1, 1, 1, 1),
        &PemOptions::default(),
    )
    .expect("bj");
    // parameter order: b1 b2 c1 d1 f1
    assert_within_sigmas(&est, &[1.0, 0.5, 0.6, -0.9, -0.8], 3.0);
    assert!(est.model.is_stable());
}

#[test]
fn two_input_oe_like_thesis_model_3() {
    // nb = [2 2], nf = [2 2], nk = [1 1] as thesis Table 5.6: a slow well-damped path from
    // input 1 and a faster one from input 2.
    let mut r = rng(5);
    let u1 = binary(&mut r, N, 0.1);
    let u2 = white(&mut r, N, 1.0);
    let e = white(&mut r, N, 0.1);
    let (b1, f1) = ([0.10, 0.08], [1.0, -1.6, 0.7]);
    let (b2, f2) = ([0.5, -0.3], [1.0, -0.5, 0.3]);
    let y = add(
        &add(&lfilter(&b1, 1, &f1, &u1), &lfilter(&b2, 1, &f2, &u2)),
        &e,
    );
    let data = IdData::new(y, vec![u1, u2], 0.01).expect("valid data");
    let orders = OeOrders {
        nb: vec![2, 2],
        nf: vec![2, 2],
        nk: vec![1, 1],
    };
    let est = oe(&data, &orders, &PemOptions::default()).expect("oe");
    // getpvec order: b(u1), b(u2), f(u1), f(u2)
    assert_within_sigmas(&est, &[0.10, 0.08, 0.5, -0.3, -1.6, 0.7, -0.5, 0.3], 3.0);
    assert_eq!(est.parameters[0].name, "b1(u1)");
    assert_eq!(est.parameters[7].name, "f2(u2)");
    // For OE the simulation is the one-step predictor.
    let sim = est.model.simulate(data.u()).expect("simulate");
    let pred = est.model.predict(data.y(), data.u(), 1).expect("predict");
    for (s, p) in sim.iter().zip(&pred) {
        assert!((s - p).abs() < 1e-9);
    }
}

/// Several experiments in one estimate (≙ MATLAB `oe(merge(z1, z2), orders)`), as a
/// bellow's loading run and valve run: in the first the two inputs move together (the
/// pressure follows the load), so their paths cannot be told apart; in the second the first
/// input is constant. Neither determines the model alone; merged, each experiment's filters
/// started at its own first sample, they recover the truth. End to end they do not: the
/// filters carry the first experiment's end into the second's start.
#[test]
fn merged_experiments_determine_what_neither_does_alone() {
    let mut r = rng(11);
    let (b1, f1) = ([0.10, 0.08], [1.0, -1.6, 0.7]);
    let (b2, f2) = ([0.5, -0.3], [1.0, -0.5, 0.3]);
    let system = |u1: &[f64], u2: &[f64], e: &[f64]| {
        add(
            &add(&lfilter(&b1, 1, &f1, u1), &lfilter(&b2, 1, &f2, u2)),
            e,
        )
    };
    // Experiment 1: the second input is the first plus a little of its own (`own`).
    let mut loading_run = |own: f64| {
        let u1 = binary(&mut r, N, 0.05);
        let u2: Vec<f64> = u1
            .iter()
            .zip(white(&mut r, N, own))
            .map(|(a, b)| 0.8 * a + b)
            .collect();
        let e = white(&mut r, N, 0.05);
        let y = system(&u1, &u2, &e);
        IdData::new(y, vec![u1, u2], 0.01).unwrap()
    };
    let loading = loading_run(0.001);
    let distinct = loading_run(0.1);
    // Experiment 2: the first input held.
    let u1 = vec![0.0; N];
    let u2 = white(&mut r, N, 1.0);
    let e = white(&mut r, N, 0.05);
    let y = system(&u1, &u2, &e);
    let valve = IdData::new(y, vec![u1, u2], 0.01).unwrap();
    let orders = OeOrders {
        nb: vec![2, 2],
        nf: vec![2, 2],
        nk: vec![1, 1],
    };
    let truth = [0.10, 0.08, 0.5, -0.3, -1.6, 0.7, -0.5, 0.3];
    let options = PemOptions::default();

    // One experiment merged is that experiment's estimate.
    let alone = oe(&distinct, &orders, &options).unwrap();
    let one = oe_merged(std::slice::from_ref(&distinct), &orders, &options).unwrap();
    for (a, b) in alone.parameters.iter().zip(&one.parameters) {
        assert!(
            (a.value - b.value).abs() < 1e-9 * a.value.abs().max(1.0),
            "{a:?} {b:?}"
        );
    }
    // Alone, the valve run cannot see the first input at all.
    assert!(oe(&valve, &orders, &options).is_err());

    let merged = oe_merged(&[loading.clone(), valve.clone()], &orders, &options).unwrap();
    println!("{merged}");
    assert_within_sigmas(&merged, &truth, 3.0);
    assert_eq!(merged.n_samples, 2 * N);
    // The loading run alone is far off (or refused) where the merged estimate is not.
    let worst = |est: &airsus_ident::linear::Estimate| {
        est.parameters
            .iter()
            .zip(&truth)
            .map(|(p, t)| (p.value - t).abs())
            .fold(0.0, f64::max)
    };
    if let Ok(alone) = oe(&loading, &orders, &options) {
        println!("the loading run alone:\n{alone}");
        assert!(worst(&alone) > 10.0 * worst(&merged), "{alone}\n{merged}");
    }
    // End to end, the boundary's transient is an error of the data.
    let joined = IdData::new(
        [loading.y(), valve.y()].concat(),
        (0..2)
            .map(|i| [loading.u()[i].as_slice(), valve.u()[i].as_slice()].concat())
            .collect(),
        0.01,
    )
    .unwrap();
    let end_to_end = oe(&joined, &orders, &options).unwrap();
    assert!(end_to_end.loss > merged.loss, "{end_to_end}");

    // Experiments must agree in inputs and sample time; an input constant in every one is
    // named.
    let other_ts = IdData::new(valve.y().to_vec(), valve.u().to_vec(), 0.02).unwrap();
    assert!(oe_merged(&[loading.clone(), other_ts], &orders, &options).is_err());
    let held = IdData::new(valve.y().to_vec(), vec![vec![0.0; N], vec![0.0; N]], 0.01).unwrap();
    assert!(oe_merged(&[held.clone(), held], &orders, &options).is_err());
    assert!(oe_merged(&[], &orders, &options).is_err());
}

/// A bellow's two runs for a two-input system `system(u1, u2, e)`: a loading run, where the
/// second input follows the first (`0.8 u1` plus 0.1 % of its own), and a valve run with the
/// first input held. Neither determines both paths; merged they do.
fn loading_and_valve_runs(
    seed: u64,
    noise_std: f64,
    system: impl Fn(&[f64], &[f64], &[f64]) -> Vec<f64>,
) -> (IdData, IdData) {
    let mut r = rng(seed);
    let u1 = binary(&mut r, N, 0.05);
    let u2: Vec<f64> = u1
        .iter()
        .zip(white(&mut r, N, 0.001))
        .map(|(a, b)| 0.8 * a + b)
        .collect();
    let e = white(&mut r, N, noise_std);
    let loading = IdData::new(system(&u1, &u2, &e), vec![u1, u2], 0.01).unwrap();
    let u1 = vec![0.0; N];
    let u2 = white(&mut r, N, 1.0);
    let e = white(&mut r, N, noise_std);
    let valve = IdData::new(system(&u1, &u2, &e), vec![u1, u2], 0.01).unwrap();
    (loading, valve)
}

/// A run whose second input has its own excitation (0.3 of white noise added), so that it
/// determines the model alone.
fn with_own_excitation(run: &IdData) -> IdData {
    let mut r = rng(99);
    let u2: Vec<f64> = run.u()[1]
        .iter()
        .zip(white(&mut r, run.len(), 0.3))
        .map(|(a, b)| a + b)
        .collect();
    IdData::new(run.y().to_vec(), vec![run.u()[0].clone(), u2], run.ts_s()).unwrap()
}

/// The largest distance of an estimate's parameters from the truth.
fn worst_error(est: &airsus_ident::linear::Estimate, truth: &[f64]) -> f64 {
    est.parameters
        .iter()
        .zip(truth)
        .map(|(p, t)| (p.value - t).abs())
        .fold(0.0, f64::max)
}

/// [`merged_experiments_determine_what_neither_does_alone`] for ARX, ARMAX and BJ
/// (≙ MATLAB `arx(merge(z1, z2), …)` etc.): merged, every parameter within three standard
/// deviations of the truth; the valve run alone refused (its first input is constant); the
/// loading run alone refused or ten times further off.
#[test]
fn merged_arx_armax_and_bj_determine_what_neither_run_does_alone() {
    let options = PemOptions::default();
    let a = [1.0, -1.5, 0.7];
    let (b1, b2) = ([0.10, 0.08], [0.5, -0.3]);

    // ARX: A y = B1 u1 + B2 u2 + e.
    let (loading, valve) = loading_and_valve_runs(21, 0.05, |u1, u2, e| {
        add(
            &add(&lfilter(&b1, 1, &a, u1), &lfilter(&b2, 1, &a, u2)),
            &lfilter(&[1.0], 0, &a, e),
        )
    });
    let orders = ArxOrders {
        na: 2,
        nb: vec![2, 2],
        nk: vec![1, 1],
    };
    let truth = [-1.5, 0.7, 0.10, 0.08, 0.5, -0.3];
    let merged = arx_merged(&[loading.clone(), valve.clone()], &orders).unwrap();
    println!("{merged}");
    assert_within_sigmas(&merged, &truth, 3.0);
    // Each run's rows from its own t0 = 2: none across the joint.
    assert_eq!(merged.n_samples, 2 * (N - 2));
    assert!(arx(&valve, &orders).is_err());
    if let Ok(alone) = arx(&loading, &orders) {
        assert!(
            worst_error(&alone, &truth) > 10.0 * worst_error(&merged, &truth),
            "{alone}"
        );
    }
    // One run merged is that run's estimate.
    let one = arx_merged(
        std::slice::from_ref(&with_own_excitation(&loading)),
        &orders,
    )
    .unwrap();
    let alone = arx(&with_own_excitation(&loading), &orders).unwrap();
    for (a, b) in alone.parameters.iter().zip(&one.parameters) {
        assert!(
            (a.value - b.value).abs() < 1e-9 * a.value.abs().max(1.0),
            "{a:?} {b:?}"
        );
    }
    // An input held in every run is named, not solved to noise, even where it is held at
    // another level in each (the runs end to end would show it step once).
    let held = |level: f64| {
        IdData::new(
            loading.y().to_vec(),
            vec![loading.u()[0].clone(), vec![level; N]],
            0.01,
        )
        .unwrap()
    };
    let refused = arx_merged(&[held(0.0), held(1.0)], &orders);
    assert!(
        matches!(refused, Err(IdentError::ConstantInput { .. })),
        "{refused:?}"
    );
    // An input the orders leave out (nb = 0) may be held, merged as alone.
    let without_second = ArxOrders {
        na: orders.na,
        nb: vec![orders.nb[0], 0],
        nk: orders.nk.clone(),
    };
    let alone = arx(&held(1.0), &without_second);
    assert!(alone.is_ok(), "{alone:?}");
    assert!(arx_merged(&[held(0.0), held(1.0)], &without_second).is_ok());

    // ARMAX: A y = B1 u1 + B2 u2 + C e.
    let c = [1.0, -0.5];
    let (loading, valve) = loading_and_valve_runs(22, 0.05, |u1, u2, e| {
        add(
            &add(&lfilter(&b1, 1, &a, u1), &lfilter(&b2, 1, &a, u2)),
            &lfilter(&c, 0, &a, e),
        )
    });
    let orders = ArmaxOrders {
        na: 2,
        nb: vec![2, 2],
        nc: 1,
        nk: vec![1, 1],
    };
    let truth = [-1.5, 0.7, 0.10, 0.08, 0.5, -0.3, -0.5];
    let merged = armax_merged(&[loading.clone(), valve.clone()], &orders, &options).unwrap();
    println!("{merged}");
    assert_within_sigmas(&merged, &truth, 3.0);
    assert_eq!(merged.n_samples, 2 * N);
    assert!(
        merged.simulation_fit_percent.is_some_and(|f| f > 50.0),
        "{merged}"
    );
    assert!(armax(&valve, &orders, &options).is_err());
    if let Ok(alone) = armax(&loading, &orders, &options) {
        assert!(
            worst_error(&alone, &truth) > 10.0 * worst_error(&merged, &truth),
            "{alone}"
        );
    }

    // BJ: y = B1/F1 u1 + B2/F2 u2 + C/D e.
    let (f1, f2) = ([1.0, -1.6, 0.7], [1.0, -0.5, 0.3]);
    let (cn, dn) = ([1.0, 0.5], [1.0, -0.9]);
    let (loading, valve) = loading_and_valve_runs(23, 0.05, |u1, u2, e| {
        add(
            &add(&lfilter(&b1, 1, &f1, u1), &lfilter(&b2, 1, &f2, u2)),
            &lfilter(&cn, 0, &dn, e),
        )
    });
    let orders = BjOrders {
        nb: vec![2, 2],
        nc: 1,
        nd: 1,
        nf: vec![2, 2],
        nk: vec![1, 1],
    };
    // getpvec order: b(u1), b(u2), c, d, f(u1), f(u2).
    let truth = [0.10, 0.08, 0.5, -0.3, 0.5, -0.9, -1.6, 0.7, -0.5, 0.3];
    let merged = bj_merged(&[loading.clone(), valve.clone()], &orders, &options).unwrap();
    println!("{merged}");
    assert_within_sigmas(&merged, &truth, 3.0);
    assert!(bj(&valve, &orders, &options).is_err());
    if let Ok(alone) = bj(&loading, &orders, &options) {
        assert!(
            worst_error(&alone, &truth) > 10.0 * worst_error(&merged, &truth),
            "{alone}"
        );
    }
}

#[test]
fn k_step_prediction_interpolates_between_one_step_and_simulation() {
    let mut r = rng(6);
    let u = binary(&mut r, N, 0.3);
    let e = white(&mut r, N, 0.3);
    let a = [1.0, -1.5, 0.7];
    let y = add(
        &lfilter(&[1.0, 0.5], 1, &a, &u),
        &lfilter(&[1.0], 0, &a, &e),
    );
    let data = IdData::siso(y.clone(), u, 0.1).expect("valid data");
    let est = arx(&data, &ArxOrders::siso(2, 2, 1)).expect("arx");
    let mse = |k: usize| {
        let p = est.model.predict(&y, data.u(), k).expect("predict");
        p.iter()
            .zip(&y)
            .skip(50)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / (N - 50) as f64
    };
    let (m1, m3, m50) = (mse(1), mse(3), mse(200));
    let sim = est.model.simulate(data.u()).expect("simulate");
    let msim = sim
        .iter()
        .zip(&y)
        .skip(50)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        / (N - 50) as f64;
    assert!(m1 < m3 && m3 < m50, "{m1} {m3} {m50}");
    assert!((m50 - msim).abs() < 1e-6 * msim, "{m50} vs {msim}");
    // One-step ARX prediction error variance ≈ noise variance.
    assert!((m1 - 0.09).abs() < 0.01);
}

#[test]
fn display_prints_polynomials_with_uncertainty_and_statistics() {
    let mut r = rng(3);
    let u = binary(&mut r, N, 0.2);
    let e = white(&mut r, N, 0.2);
    let y = add(&lfilter(&[0.5, 0.3], 2, &[1.0, -1.2, 0.5], &u), &e);
    let data = IdData::siso(y, u, 0.08).expect("valid data");
    let est = oe(&data, &OeOrders::siso(2, 2, 2), &PemOptions::default()).expect("oe");
    let text = est.to_string();
    println!("{text}");
    assert!(text.starts_with("Discrete-time OE model: y(t) = [B(z)/F(z)]u(t) + e(t)"));
    assert!(text.contains("  B(z) = 0.49"), "{text}");
    assert!(text.contains(" z^-2 + 0.30"), "{text}");
    assert!(text.contains("  F(z) = 1 - 1.20"), "{text}");
    assert!(text.contains("(±"), "{text}");
    assert!(text.contains("Sample time: 0.08 seconds"), "{text}");
    assert!(text.contains("nb=2   nf=2   nk=2"), "{text}");
    assert!(text.contains("Fit to estimation data:"), "{text}");
    assert!(text.contains("FPE:") && text.contains("AIC:"), "{text}");

    let json: serde_json::Value = serde_json::to_value(&est).expect("serialise");
    assert_eq!(json["model"]["structure"], "oe");
    assert_eq!(json["model"]["nk"][0], 2);
    assert_eq!(json["parameters"][0]["name"], "b1");
    for key in [
        "loss",
        "fpe",
        "aic",
        "fit_percent",
        "noise_variance",
        "covariance",
        "stop",
    ] {
        assert!(json.get(key).is_some(), "missing {key}");
    }
}

#[test]
fn reported_standard_deviations_match_monte_carlo_spread() {
    // 200 independent noise realisations of the same OE system: the spread of the estimates
    // must agree with the standard deviation the estimator reports (P = λ (Σψψᵀ)⁻¹).
    let runs = 200;
    let n = 1000;
    let truth = [0.5, 0.3, -1.2, 0.5];
    let mut r = rng(7);
    let u = binary(&mut r, n, 0.2);
    let clean = lfilter(&[0.5, 0.3], 1, &[1.0, -1.2, 0.5], &u);
    let mut estimates = vec![Vec::with_capacity(runs); truth.len()];
    let mut reported = vec![0.0; truth.len()];
    for _ in 0..runs {
        let y = add(&clean, &white(&mut r, n, 0.3));
        let data = IdData::siso(y, u.clone(), 1.0).expect("valid");
        let est = oe(&data, &OeOrders::siso(2, 2, 1), &PemOptions::default()).expect("oe");
        for (k, p) in est.parameters.iter().enumerate() {
            estimates[k].push(p.value);
            reported[k] += p.std / runs as f64;
        }
    }
    for k in 0..truth.len() {
        let mean = estimates[k].iter().sum::<f64>() / runs as f64;
        let spread = (estimates[k].iter().map(|v| (v - mean).powi(2)).sum::<f64>()
            / (runs - 1) as f64)
            .sqrt();
        let ratio = reported[k] / spread;
        assert!(
            (0.8..1.25).contains(&ratio),
            "parameter {k}: reported std {} vs Monte-Carlo {spread} (ratio {ratio})",
            reported[k]
        );
        // Unbiased: the mean is within 3 standard errors of the truth.
        assert!((mean - truth[k]).abs() < 3.0 * spread / (runs as f64).sqrt() + 1e-12);
    }
}
