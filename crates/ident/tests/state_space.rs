//! State-space conversion and zero-order-hold c2d/d2c.

mod common;

use airsus_ident::linear::{
    IdData, IdentError, OeOrders, PemOptions, PolyModel, StateSpace, Structure, TimeDomain, oe,
};
use common::*;
use nalgebra::DMatrix;

fn max_abs_diff(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).abs().max()
}

/// A damped mass-spring with an extra real pole: ẋ = A x + B u.
fn continuous_plant() -> StateSpace {
    let a = DMatrix::from_row_slice(3, 3, &[0.0, 1.0, 0.0, -4.0, -0.8, 1.0, 0.0, 0.0, -2.5]);
    let b = DMatrix::from_row_slice(3, 2, &[0.0, 0.0, 1.0, 0.0, 0.5, 2.0]);
    let c = DMatrix::from_row_slice(1, 3, &[1.0, 0.0, 0.3]);
    let d = DMatrix::from_row_slice(1, 2, &[0.0, 0.1]);
    StateSpace::new(a, b, c, d, TimeDomain::Continuous).expect("valid")
}

#[test]
fn c2d_matches_closed_form_for_first_order_system() {
    // ẋ = -a x + b u  ->  x+ = e^{-aT} x + b/a (1 - e^{-aT}) u
    let (a, b, ts) = (2.0, 3.0, 0.1);
    let sys = StateSpace::new(
        DMatrix::from_element(1, 1, -a),
        DMatrix::from_element(1, 1, b),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 0.0),
        TimeDomain::Continuous,
    )
    .expect("valid");
    let d = sys.c2d(ts).expect("c2d");
    let ad = (-a * ts).exp();
    assert!((d.a[(0, 0)] - ad).abs() < 1e-14);
    assert!((d.b[(0, 0)] - b / a * (1.0 - ad)).abs() < 1e-14);
    assert_eq!(d.domain, TimeDomain::Discrete { ts_s: ts });
}

#[test]
fn c2d_then_d2c_round_trip() {
    let sys = continuous_plant();
    for ts in [0.01, 0.1, 0.5] {
        let back = sys.c2d(ts).expect("c2d").d2c().expect("d2c");
        assert!(max_abs_diff(&back.a, &sys.a) < 1e-9, "ts {ts}: {}", back.a);
        assert!(max_abs_diff(&back.b, &sys.b) < 1e-9, "ts {ts}: {}", back.b);
        assert_eq!(back.c, sys.c);
        assert_eq!(back.d, sys.d);
        assert_eq!(back.domain, TimeDomain::Continuous);
    }
}

#[test]
fn d2c_then_c2d_round_trip_of_identified_model() {
    // OE like thesis Table 5.6, converted to continuous time as Model 3 needs, then sampled
    // again: same discrete impulse response.
    let mut r = rng(21);
    let n = 3000;
    let u1 = binary(&mut r, n, 0.1);
    let u2 = white(&mut r, n, 1.0);
    let y = add(
        &add(
            &lfilter(&[0.10, 0.08], 1, &[1.0, -1.6, 0.7], &u1),
            &lfilter(&[0.5, -0.3], 3, &[1.0, -0.5, 0.3], &u2),
        ),
        &white(&mut r, n, 0.05),
    );
    let data = IdData::new(y, vec![u1, u2], 0.01).expect("valid");
    let orders = OeOrders {
        nb: vec![2, 2],
        nf: vec![2, 2],
        nk: vec![1, 3],
    };
    let est = oe(&data, &orders, &PemOptions::default()).expect("oe");
    let subsystems = est.model.to_continuous_state_space().expect("d2c");
    assert_eq!(subsystems.len(), 2);
    assert_eq!(subsystems[0].input_delay_s, 0.0);
    assert!((subsystems[1].input_delay_s - 0.02).abs() < 1e-15);
    for sub in &subsystems {
        assert_eq!(sub.ss.domain, TimeDomain::Continuous);
        assert_eq!(sub.ss.n_states(), 2);
        let resampled = sub.ss.c2d(0.01).expect("c2d");
        let h_ss = resampled.impulse_response(0, 60).expect("impulse");
        let delay = (sub.input_delay_s / 0.01).round() as usize;
        let h_tf = est
            .model
            .impulse_response(sub.input, 60 + delay)
            .expect("tf impulse");
        for k in 0..60 {
            assert!(
                (h_ss[(0, k)] - h_tf[k + delay]).abs() < 1e-10,
                "input {} k {k}: {} vs {}",
                sub.input,
                h_ss[(0, k)],
                h_tf[k + delay]
            );
        }
    }
}

#[test]
fn state_space_reproduces_transfer_function_impulse_response() {
    let model = PolyModel {
        structure: Structure::Oe,
        a: vec![1.0],
        b: vec![vec![0.5, 0.3], vec![1.0, -0.2, 0.1]],
        c: vec![1.0],
        d: vec![1.0],
        f: vec![vec![1.0, -1.2, 0.5], vec![1.0, 0.4]],
        nk: vec![2, 0],
        ts_s: 0.5,
    };
    let ss = model.to_state_space().expect("ss");
    for input in 0..2 {
        let h_ss = ss.impulse_response(input, 40).expect("impulse");
        let h_tf = model.impulse_response(input, 40).expect("impulse");
        for k in 0..40 {
            assert!(
                (h_ss[(0, k)] - h_tf[k]).abs() < 1e-12,
                "input {input} k {k}"
            );
        }
    }
    // The independent difference equation agrees too.
    let pulse: Vec<f64> = (0..40).map(|k| if k == 0 { 1.0 } else { 0.0 }).collect();
    let h_ref = lfilter(&[0.5, 0.3], 2, &[1.0, -1.2, 0.5], &pulse);
    let h_ss = ss.impulse_response(0, 40).expect("impulse");
    for k in 0..40 {
        assert!((h_ss[(0, k)] - h_ref[k]).abs() < 1e-12);
    }
    // And simulation through the state space equals the model's simulation.
    let mut r = rng(22);
    let u = vec![white(&mut r, 100, 1.0), white(&mut r, 100, 1.0)];
    let y_ss = ss.simulate(&u).expect("simulate");
    let y_tf = model.simulate(&u).expect("simulate");
    for (a, b) in y_ss[0].iter().zip(&y_tf) {
        assert!((a - b).abs() < 1e-10);
    }
}

#[test]
fn controller_and_observer_canonical_forms_are_equivalent() {
    let num = [0.0, 1.0, 0.5];
    let den = [1.0, -1.5, 0.7];
    let dom = TimeDomain::Discrete { ts_s: 1.0 };
    let o = StateSpace::observer_canonical(&num, &den, dom).expect("ocf");
    let c = StateSpace::controller_canonical(&num, &den, dom).expect("ccf");
    let ho = o.impulse_response(0, 30).expect("impulse");
    let hc = c.impulse_response(0, 30).expect("impulse");
    assert!(max_abs_diff(&ho, &hc) < 1e-12);
    // Continuous: G(s) = 1/(s^2 + 0.8 s + 4) in controller form has the companion A.
    let cs = StateSpace::controller_canonical(&[1.0], &[1.0, 0.8, 4.0], TimeDomain::Continuous)
        .expect("ccf");
    assert_eq!(cs.a, DMatrix::from_row_slice(2, 2, &[-0.8, -4.0, 1.0, 0.0]));
}

#[test]
fn d2c_rejects_poles_on_the_negative_real_axis_and_at_zero() {
    let dom = TimeDomain::Discrete { ts_s: 0.1 };
    let negative = StateSpace::observer_canonical(&[0.0, 1.0], &[1.0, 0.5], dom).expect("ss");
    match negative.d2c() {
        Err(IdentError::NoRealLogarithm { re, .. }) => assert!((re + 0.5).abs() < 1e-12),
        other => panic!("expected NoRealLogarithm, got {other:?}"),
    }
    // nb > nf puts a pole at z = 0.
    let model = PolyModel {
        structure: Structure::Oe,
        a: vec![1.0],
        b: vec![vec![1.0, 0.5, 0.2]],
        c: vec![1.0],
        d: vec![1.0],
        f: vec![vec![1.0, -0.9]],
        nk: vec![1],
        ts_s: 0.1,
    };
    let err = model.to_continuous_state_space().expect_err("pole at zero");
    assert!(
        matches!(err, IdentError::NoRealLogarithm { re, im, .. } if re.abs() < 1e-9 && im.abs() < 1e-9),
        "{err}"
    );
    assert!(err.to_string().contains("z = 0"), "{err}");
}

#[test]
fn thesis_table_5_4_model_converts_with_a_delay() {
    // nb = 1, nf = 1, nk = 2 with the thesis values: y = b1 q^-2 / (1 + f1 q^-1) u.
    let model = PolyModel {
        structure: Structure::Oe,
        a: vec![1.0],
        b: vec![vec![-8.672e-8]],
        c: vec![1.0],
        d: vec![1.0],
        f: vec![vec![1.0, -0.997]],
        nk: vec![2],
        ts_s: 0.01,
    };
    let sub = &model.to_continuous_state_space().expect("d2c")[0];
    assert!((sub.input_delay_s - 0.01).abs() < 1e-15);
    // Continuous pole at ln(0.997)/T, static gain preserved: b1/(1 + f1).
    let pole = sub.ss.a[(0, 0)];
    assert!((pole - 0.997f64.ln() / 0.01).abs() < 1e-9);
    let gain = -(sub.ss.c[(0, 0)] * sub.ss.b[(0, 0)]) / pole + sub.ss.d[(0, 0)];
    assert!((gain - (-8.672e-8 / (1.0 - 0.997))).abs() < 1e-12, "{gain}");
}
