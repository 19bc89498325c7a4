//! The spline effective-area law's interpolant against SciPy's `PchipInterpolator`, an
//! independent implementation of the same monotone cubic (fixtures made by
//! `tools/peer_spline/pchip_reference.py`, SciPy 1.17.1).

use std::collections::BTreeMap;

use airsus_data::laws::MonotoneSpline;

fn rows(text: &str) -> impl Iterator<Item = Vec<&str>> {
    text.lines().skip(1).map(|l| l.split(',').collect())
}

#[test]
fn the_monotone_spline_agrees_with_scipys_pchip() {
    let mut knots: BTreeMap<&str, (Vec<f64>, Vec<f64>)> = BTreeMap::new();
    for row in rows(include_str!("fixtures/pchip_knots.csv")) {
        let entry = knots.entry(row[0]).or_default();
        entry.0.push(row[1].parse().unwrap());
        entry.1.push(row[2].parse().unwrap());
    }
    let splines: BTreeMap<&str, MonotoneSpline> = knots
        .into_iter()
        .map(|(case, (x, y))| (case, MonotoneSpline::new(x, y).unwrap()))
        .collect();
    let mut checked = 0;
    for row in rows(include_str!("fixtures/pchip_scipy.csv")) {
        let s = &splines[row[0]];
        let [x, value, derivative, integral]: [f64; 4] =
            std::array::from_fn(|i| row[i + 1].parse().unwrap());
        let x0 = s.knots_x()[0];
        let ours = [
            s.value(x),
            s.slope(x),
            s.integral_from_zero(x) - s.integral_from_zero(x0),
        ];
        for (name, ours, theirs) in [
            ("value", ours[0], value),
            ("derivative", ours[1], derivative),
            ("integral", ours[2], integral),
        ] {
            assert!(
                (ours - theirs).abs() <= 1e-12 * (1.0 + theirs.abs()),
                "{} at x = {x}: {name} {ours} against SciPy's {theirs}",
                row[0]
            );
        }
        checked += 1;
    }
    assert_eq!(checked, 6 * 39);
}
