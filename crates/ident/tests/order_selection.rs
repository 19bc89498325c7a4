//! Order selection over a grid picks the true order of a simulated ARX system.

mod common;

use airsus_ident::linear::{ArxGrid, IdData, SelectionCriterion, arx, arx_struc, select_structure};
use common::*;

#[test]
fn arxstruc_and_selstruc_pick_the_true_order() {
    // True system: ARX [na nb nk] = [2 2 3].
    let n = 3000;
    let mut r = rng(41);
    let u = white(&mut r, n, 1.0);
    let e = white(&mut r, n, 0.2);
    let a = [1.0, -1.3, 0.6];
    let y = add(
        &lfilter(&[0.8, 0.4], 3, &a, &u),
        &lfilter(&[1.0], 0, &a, &e),
    );
    let data = IdData::siso(y, u, 0.08).expect("valid");
    let est = data.samples(0..1500).expect("split");
    let val = data.samples(1500..3000).expect("split");
    let grid = ArxGrid {
        na: (1..=5).collect(),
        nb: (1..=5).collect(),
        nk: (1..=5).collect(),
    };
    let candidates = arx_struc(&est, &val, &grid).expect("arxstruc");
    assert_eq!(candidates.len(), 125);
    for criterion in [SelectionCriterion::Aic, SelectionCriterion::Mdl] {
        let best = select_structure(&candidates, criterion).expect("non-empty");
        assert_eq!(
            (best.orders.na, best.orders.nb[0], best.orders.nk[0]),
            (2, 2, 3),
            "{criterion:?}"
        );
    }
    // Best validation fit alone may prefer extra parameters, but never misses the dynamics:
    // it must contain the true delay and at least the true orders.
    let best = select_structure(&candidates, SelectionCriterion::BestFit).expect("non-empty");
    assert_eq!(best.orders.nk[0], 3);
    assert!(best.orders.na >= 2 && best.orders.nb[0] >= 2);
    // The loss reported for a candidate is that of `arx` with the same orders.
    let chosen = select_structure(&candidates, SelectionCriterion::Mdl).expect("non-empty");
    let direct = arx(&est, &chosen.orders).expect("arx");
    assert!((direct.loss - chosen.estimation_loss).abs() < 1e-12 * direct.loss);
    // An under-modelled candidate has a clearly larger validation loss.
    let small = candidates
        .iter()
        .find(|c| c.orders.na == 1 && c.orders.nb[0] == 1 && c.orders.nk[0] == 3)
        .expect("present");
    assert!(small.validation_loss > 1.5 * chosen.validation_loss);
}
