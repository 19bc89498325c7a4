//! Stability is enforced even when the data pull the fit towards an unstable model.

mod common;

use airsus_ident::linear::{
    ArmaxOrders, ArxOrders, IdData, OeOrders, PemOptions, PolyModel, Structure, armax, arx,
    is_stable, oe, pem, roots,
};
use common::*;

/// Data from a system with a pole at z = 1.004 (outside the unit circle): over 600 samples it
/// grows by a factor ~11, so the best unconstrained fit is unstable.
fn unstable_data() -> IdData {
    let n = 600;
    let mut r = rng(11);
    let u = binary(&mut r, n, 0.3);
    let e = white(&mut r, n, 0.05);
    let f = conv(&[1.0, -1.004], &[1.0, -0.5]);
    let y = add(&lfilter(&[0.2, 0.1], 1, &f, &u), &e);
    IdData::siso(y, u, 1.0).expect("valid data")
}

fn max_root_radius(p: &[f64]) -> f64 {
    roots(p)
        .expect("roots")
        .iter()
        .map(|r| r.norm())
        .fold(0.0, f64::max)
}

#[test]
fn least_squares_arx_on_these_data_is_unstable() {
    // Establishes that the data really push towards instability: the unconstrained
    // (unique) least-squares ARX puts a root outside the unit circle.
    let est = arx(&unstable_data(), &ArxOrders::siso(2, 2, 1)).expect("arx");
    assert!(max_root_radius(&est.model.a) > 1.0, "{:?}", est.model.a);
    assert!(!est.model.is_stable());
}

#[test]
fn oe_result_is_stable_when_data_push_towards_instability() {
    let data = unstable_data();
    let est = oe(&data, &OeOrders::siso(2, 2, 1), &PemOptions::default()).expect("oe");
    let radius = max_root_radius(&est.model.f[0]);
    assert!(
        radius < 1.0,
        "F roots radius {radius}: {:?}",
        est.model.f[0]
    );
    assert!(is_stable(&est.model.f[0]));
    // It is the best stable model, so it pushes right up to the boundary.
    assert!(radius > 0.95, "radius {radius}");
    let sim = est.model.simulate(data.u()).expect("simulate");
    assert!(sim.iter().all(|v| v.is_finite()));
}

#[test]
fn armax_result_is_stable_when_data_push_towards_instability() {
    let data = unstable_data();
    let est = armax(
        &data,
        &ArmaxOrders::siso(2, 2, 1, 1),
        &PemOptions::default(),
    )
    .expect("armax");
    assert!(max_root_radius(&est.model.a) < 1.0, "{:?}", est.model.a);
    assert!(max_root_radius(&est.model.c) < 1.0, "{:?}", est.model.c);
    assert!(est.model.is_stable());
}

#[test]
fn pem_reflects_an_unstable_initial_model() {
    // Start PEM from an OE model whose F has roots 2 and 0.5 (unstable) on data from a
    // stable system: the start is reflected (root 2 -> 0.5) and the search ends stable and
    // close to the truth.
    let n = 2000;
    let mut r = rng(12);
    let u = binary(&mut r, n, 0.3);
    let e = white(&mut r, n, 0.05);
    let y = add(&lfilter(&[1.0], 1, &[1.0, -0.7], &u), &e);
    let data = IdData::siso(y, u, 1.0).expect("valid data");
    let start = PolyModel {
        structure: Structure::Oe,
        a: vec![1.0],
        b: vec![vec![0.3]],
        c: vec![1.0],
        d: vec![1.0],
        f: vec![vec![1.0, -2.0]],
        nk: vec![1],
        ts_s: 1.0,
    };
    let est = pem(&data, &start, &PemOptions::default()).expect("pem");
    assert!(est.model.is_stable());
    assert!((est.model.f[0][1] + 0.7).abs() < 3.0 * est.parameters[1].std + 1e-3);
    assert!((est.model.b[0][0] - 1.0).abs() < 3.0 * est.parameters[0].std + 1e-3);
}
