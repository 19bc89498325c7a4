//! Bad input gives a clear error, never a panic.

mod common;

use airsus_ident::linear::{
    ArmaxOrders, ArxGrid, ArxOrders, BjOrders, IdData, IdentError, OeOrders, PemOptions, arx,
    arx_struc, bj, oe,
};
use common::*;

fn good_data(n: usize) -> IdData {
    let mut r = rng(31);
    let u = binary(&mut r, n, 0.3);
    let y = add(
        &lfilter(&[1.0], 1, &[1.0, -0.5], &u),
        &white(&mut r, n, 0.1),
    );
    IdData::siso(y, u, 0.1).expect("valid")
}

#[test]
fn mismatched_lengths() {
    let err = IdData::new(vec![0.0; 10], vec![vec![1.0; 10], vec![1.0; 9]], 1.0).unwrap_err();
    assert_eq!(
        err,
        IdentError::LengthMismatch {
            input: 1,
            input_len: 9,
            output_len: 10
        }
    );
    // Zero-based index in the field, counted from 1 in the message (like u1, u2).
    assert!(
        err.to_string()
            .contains("input 2 has 9 samples but the output has 10")
    );
}

#[test]
fn nan_and_infinity() {
    let mut y = vec![0.0; 10];
    y[3] = f64::NAN;
    let err = IdData::siso(y, vec![1.0; 10], 1.0).unwrap_err();
    assert!(
        matches!(err, IdentError::NonFinite { ref signal, index: 3, .. } if signal == "output")
    );
    let mut u = vec![0.0; 10];
    u[7] = f64::INFINITY;
    let err = IdData::siso(vec![0.0; 10], u, 1.0).unwrap_err();
    assert!(
        matches!(err, IdentError::NonFinite { ref signal, index: 7, .. } if signal == "input 1")
    );
}

#[test]
fn empty_data_and_bad_sample_time() {
    assert_eq!(
        IdData::siso(vec![], vec![], 1.0).unwrap_err(),
        IdentError::Empty
    );
    for ts in [0.0, -1.0, f64::NAN] {
        assert!(matches!(
            IdData::siso(vec![1.0], vec![1.0], ts).unwrap_err(),
            IdentError::InvalidSampleTime(_)
        ));
    }
}

#[test]
fn constant_input_is_unidentifiable() {
    let n = 200;
    let mut r = rng(32);
    let y = white(&mut r, n, 1.0);
    let data = IdData::new(y, vec![binary(&mut r, n, 0.3), vec![2.5; n]], 1.0).expect("valid");
    let orders = OeOrders {
        nb: vec![1, 1],
        nf: vec![1, 1],
        nk: vec![1, 1],
    };
    let err = oe(&data, &orders, &PemOptions::default()).unwrap_err();
    assert_eq!(
        err,
        IdentError::ConstantInput {
            input: 1,
            value: 2.5
        }
    );
    let err = arx(
        &data,
        &ArxOrders {
            na: 1,
            nb: vec![1, 2],
            nk: vec![1, 1],
        },
    )
    .unwrap_err();
    assert!(matches!(err, IdentError::ConstantInput { input: 1, .. }));
    // Leaving the constant input out (nb = 0) is fine for ARX.
    assert!(
        arx(
            &data,
            &ArxOrders {
                na: 1,
                nb: vec![1, 0],
                nk: vec![1, 0]
            }
        )
        .is_ok()
    );
}

#[test]
fn too_few_samples_for_the_order() {
    let data = good_data(12);
    let err = arx(&data, &ArxOrders::siso(5, 5, 1)).unwrap_err();
    assert!(
        matches!(
            err,
            IdentError::TooFewSamples {
                available: 7,
                parameters: 10,
                required: 11
            }
        ),
        "{err:?}"
    );
    let err = oe(&data, &OeOrders::siso(4, 4, 3), &PemOptions::default()).unwrap_err();
    assert!(matches!(err, IdentError::TooFewSamples { .. }), "{err:?}");
}

#[test]
fn zero_orders_where_not_allowed() {
    let data = good_data(100);
    let err = oe(&data, &OeOrders::siso(0, 2, 1), &PemOptions::default()).unwrap_err();
    assert!(
        matches!(err, IdentError::InvalidOrder(ref m) if m.contains("nb")),
        "{err:?}"
    );
    let err = bj(
        &data,
        &BjOrders::siso(0, 1, 1, 1, 1),
        &PemOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(err, IdentError::InvalidOrder(_)), "{err:?}");
    let err = arx(&data, &ArxOrders::siso(0, 0, 1)).unwrap_err();
    assert!(matches!(err, IdentError::InvalidOrder(ref m) if m.contains("no free parameter")));
}

#[test]
fn orders_for_the_wrong_number_of_inputs() {
    let data = good_data(100);
    let err = arx(
        &data,
        &ArxOrders {
            na: 1,
            nb: vec![1, 1],
            nk: vec![1, 1],
        },
    )
    .unwrap_err();
    assert_eq!(err, IdentError::InputCountMismatch { orders: 2, data: 1 });
    let err = airsus_ident::linear::armax(
        &data,
        &ArmaxOrders {
            na: 1,
            nb: vec![1],
            nc: 1,
            nk: vec![1, 2],
        },
        &PemOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(err, IdentError::InvalidOrder(_)), "{err:?}");
}

#[test]
fn rank_deficient_regression() {
    // u alternates ±1 (a sinusoid at the Nyquist frequency): u(t-2) = -u(t-1), so with
    // nb = 2 the second B column is minus the first.
    let n = 100;
    let u: Vec<f64> = (0..n)
        .map(|k| if k % 2 == 0 { 1.0 } else { -1.0 })
        .collect();
    let y = lfilter(&[1.0], 1, &[1.0, -0.5], &u);
    let data = IdData::siso(y, u, 1.0).expect("valid");
    let err = arx(&data, &ArxOrders::siso(0, 2, 1)).unwrap_err();
    assert!(
        matches!(err, IdentError::RankDeficient { column: 1, ref name } if name == "b2"),
        "{err:?}"
    );
    assert!(err.to_string().contains("linear combination"));
}

#[test]
fn invalid_options_and_horizon() {
    let data = good_data(200);
    let opts = PemOptions {
        tolerance: -1.0,
        ..PemOptions::default()
    };
    assert!(matches!(
        oe(&data, &OeOrders::siso(1, 1, 1), &opts).unwrap_err(),
        IdentError::InvalidOption(_)
    ));
    let est = arx(&data, &ArxOrders::siso(1, 1, 1)).expect("arx");
    assert_eq!(
        est.model.predict(data.y(), data.u(), 0).unwrap_err(),
        IdentError::InvalidHorizon
    );
    assert!(matches!(
        est.model
            .simulate(&[vec![0.0; 5], vec![0.0; 5]])
            .unwrap_err(),
        IdentError::InputCountMismatch { .. }
    ));
    let grid = ArxGrid {
        na: vec![],
        nb: vec![1],
        nk: vec![1],
    };
    assert!(matches!(
        arx_struc(&data, &data, &grid).unwrap_err(),
        IdentError::InvalidOption(_)
    ));
}

#[test]
fn hand_built_inconsistent_model_is_rejected() {
    use airsus_ident::linear::{PolyModel, Structure};
    let bad = PolyModel {
        structure: Structure::Oe,
        a: vec![1.0],
        b: vec![vec![1.0], vec![0.5]],
        c: vec![1.0],
        d: vec![1.0],
        f: vec![vec![1.0, -0.5]],
        nk: vec![1, 1],
        ts_s: 1.0,
    };
    let u = vec![vec![0.0; 10], vec![0.0; 10]];
    assert!(matches!(
        bad.simulate(&u).unwrap_err(),
        IdentError::InvalidOrder(_)
    ));
    assert!(bad.to_state_space().is_err());
    assert!(bad.impulse_response(0, 5).is_none());
    let not_monic = PolyModel {
        f: vec![vec![2.0, -0.5], vec![1.0]],
        ..bad
    };
    assert!(matches!(
        not_monic.validate().unwrap_err(),
        IdentError::InvalidOrder(ref m) if m.contains("monic")
    ));
}
