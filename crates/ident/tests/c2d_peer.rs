//! Zero-order-hold `c2d` / `d2c` of multi-state, multi-input, multi-output systems against an
//! independent reference: SciPy.
//!
//! The fixture `tests/fixtures/peer_scipy_c2d.json` was written by
//! `tools/peer_ss/cont2discrete.py` (see `tools/peer_ss/README.md`; SciPy 1.17.1, NumPy
//! 2.4.6): for three continuous systems — 3 states × 2 inputs × 2 outputs with a lightly
//! damped complex pair and a feedthrough, a 4-state heavy-truck quarter car (two complex
//! pairs, input columns whose scales differ by ~3000), and a dense, non-normal 4-state system
//! with real poles spread over a factor of 800 — it holds `scipy.signal.cont2discrete(...,
//! method="zoh")` (SciPy's `expm`, Al-Mohy & Higham) and, since SciPy has no `d2c`,
//! `scipy.linalg.logm([Ad Bd; 0 I]) / Ts`.
//!
//! Tolerances. Each entry is compared relative to itself, but never to less than 1e-3 of the
//! largest magnitude in its column (a column is one state's or one input's unit; the floor
//! keeps exact zeros and entries that cancel to rounding level from demanding more than
//! double precision can give). `c2d` must agree to 1e-10 in that measure: both sides are
//! backward-stable scaling-and-squaring Padé evaluations of the same matrix exponential, and
//! SciPy's result is within 1.3e-14 of a 50-digit `mpmath` evaluation for these systems.
//! `d2c` of SciPy's discrete matrices must return the continuous ones to 1e-8: the logarithm
//! amplifies the rounding of `Ad`, `Bd` (SciPy's own `logm` round trip is off by up to
//! 1.7e-12 in this measure).

use std::path::Path;

use airsus_ident::linear::{StateSpace, TimeDomain};
use nalgebra::DMatrix;
use serde_json::Value;

/// `c2d` against SciPy's `cont2discrete`.
const C2D_REL: f64 = 1e-10;
/// `d2c` of SciPy's discretisation against the continuous system (and SciPy's `logm`).
const D2C_REL: f64 = 1e-8;
/// Entries are judged relative to at least this fraction of their column's largest entry.
const COLUMN_FLOOR: f64 = 1e-3;

fn systems() -> Vec<Value> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/peer_scipy_c2d.json");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let fx: Value = serde_json::from_str(&text).expect("fixture is JSON");
    fx["systems"].as_array().expect("systems").clone()
}

/// A row-major list of rows as a matrix.
fn matrix(v: &Value) -> DMatrix<f64> {
    let rows: Vec<Vec<f64>> = v
        .as_array()
        .expect("matrix: a list of rows")
        .iter()
        .map(|r| {
            r.as_array()
                .expect("row")
                .iter()
                .map(|x| x.as_f64().expect("number"))
                .collect()
        })
        .collect();
    let ncols = rows.first().map_or(0, Vec::len);
    assert!(rows.iter().all(|r| r.len() == ncols), "ragged matrix {v}");
    DMatrix::from_row_slice(rows.len(), ncols, &rows.concat())
}

fn name(s: &Value) -> &str {
    s["name"].as_str().expect("name")
}

fn ts_of(s: &Value) -> f64 {
    s["ts_s"].as_f64().expect("ts_s")
}

fn continuous(s: &Value) -> StateSpace {
    let c = &s["continuous"];
    StateSpace::new(
        matrix(&c["a"]),
        matrix(&c["b"]),
        matrix(&c["c"]),
        matrix(&c["d"]),
        TimeDomain::Continuous,
    )
    .expect("valid continuous system")
}

fn scipy_discrete(s: &Value) -> StateSpace {
    let d = &s["discrete_scipy_zoh"];
    StateSpace::new(
        matrix(&d["a"]),
        matrix(&d["b"]),
        matrix(&d["c"]),
        matrix(&d["d"]),
        TimeDomain::Discrete { ts_s: ts_of(s) },
    )
    .expect("valid discrete system")
}

/// Largest error of `got` against `want`, each entry relative to `max(|want|, COLUMN_FLOOR ×
/// largest |want| in its column)` (absolute for an all-zero column).
fn max_rel_error(got: &DMatrix<f64>, want: &DMatrix<f64>) -> f64 {
    assert_eq!(got.shape(), want.shape(), "shapes differ");
    let mut worst = 0.0f64;
    for (gc, wc) in got.column_iter().zip(want.column_iter()) {
        let floor = COLUMN_FLOOR * wc.amax();
        for (g, w) in gc.iter().zip(wc.iter()) {
            let scale = w.abs().max(floor);
            let err = (g - w).abs();
            worst = worst.max(if scale > 0.0 { err / scale } else { err });
        }
    }
    worst
}

fn assert_close(what: &str, got: &DMatrix<f64>, want: &DMatrix<f64>, tol: f64) {
    let err = max_rel_error(got, want);
    println!("{what}: {err:.2e}");
    assert!(
        err <= tol,
        "{what}: relative error {err:e} > {tol:e}\nairsus {got}\nreference {want}"
    );
}

#[test]
fn fixture_holds_multi_state_mimo_systems() {
    let systems = systems();
    assert_eq!(systems.len(), 3);
    for s in &systems {
        let sys = continuous(s);
        assert!(sys.n_states() >= 3, "{}", name(s));
        assert!(sys.c.nrows() >= 2, "{}: outputs", name(s));
    }
    assert!(systems.iter().any(|s| continuous(s).b.ncols() >= 2));
    // A complex pole pair somewhere (the oscillator and the quarter car have them).
    assert!(systems.iter().any(|s| {
        s["continuous_poles"]
            .as_array()
            .expect("poles")
            .iter()
            .any(|p| p[1].as_f64().expect("imaginary part").abs() > 1.0)
    }));
}

#[test]
fn c2d_matches_scipy_cont2discrete() {
    for s in &systems() {
        let ts = ts_of(s);
        let ours = continuous(s).c2d(ts).expect("c2d");
        let scipy = scipy_discrete(s);
        assert_eq!(ours.domain, TimeDomain::Discrete { ts_s: ts });
        let n = name(s);
        assert_close(&format!("{n} c2d A"), &ours.a, &scipy.a, C2D_REL);
        assert_close(&format!("{n} c2d B"), &ours.b, &scipy.b, C2D_REL);
        assert_close(&format!("{n} c2d C"), &ours.c, &scipy.c, C2D_REL);
        assert_close(&format!("{n} c2d D"), &ours.d, &scipy.d, C2D_REL);
    }
}

#[test]
fn d2c_of_scipy_discretisation_recovers_the_continuous_system() {
    for s in &systems() {
        let back = scipy_discrete(s).d2c().expect("d2c");
        let original = continuous(s);
        assert_eq!(back.domain, TimeDomain::Continuous);
        let n = name(s);
        assert_close(&format!("{n} d2c A"), &back.a, &original.a, D2C_REL);
        assert_close(&format!("{n} d2c B"), &back.b, &original.b, D2C_REL);
        assert_close(&format!("{n} d2c C"), &back.c, &original.c, D2C_REL);
        assert_close(&format!("{n} d2c D"), &back.d, &original.d, D2C_REL);
        // And the same matrices as SciPy's principal logarithm.
        let logm = &s["d2c_scipy_logm"];
        assert_close(
            &format!("{n} d2c A vs scipy logm"),
            &back.a,
            &matrix(&logm["a"]),
            D2C_REL,
        );
        assert_close(
            &format!("{n} d2c B vs scipy logm"),
            &back.b,
            &matrix(&logm["b"]),
            D2C_REL,
        );
    }
}
