//! The real data sets vendored in `tests/data/` (sources and terms in `tests/data/README.md`)
//! and the peer fixtures in `tests/fixtures/` that describe how to cut and detrend them.
//! Shared by `peer_agreement.rs` (ARX, OE) and `peer_armax_bj.rs` (ARMAX, BJ).

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use airsus_ident::linear::IdData;
use serde_json::Value;

/// `crates/ident/tests/data`: inside the repository, so the tests run on a fresh clone.
pub fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

/// `tests/fixtures/<stem>.json`, parsed.
pub fn fixture(stem: &str) -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(format!("{stem}.json"));
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    serde_json::from_str(&text).expect("fixture is JSON")
}

/// DaISy `.dat`: whitespace-separated numbers, no header.
pub fn read_dat(path: &Path) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            l.split_whitespace()
                .map(|v| v.parse().expect("number"))
                .collect()
        })
        .collect()
}

/// nonlinearbenchmark CSV: quoted header, trailing comma (empty last field), columns by name.
pub fn read_csv_columns(path: &Path, names: &[&str]) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .expect("header")
        .split(',')
        .map(|h| h.trim().trim_matches('"').to_owned())
        .collect();
    let idx: Vec<usize> = names
        .iter()
        .map(|n| header.iter().position(|h| h == n).expect("column"))
        .collect();
    let rows: Vec<Vec<&str>> = lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.split(',').collect())
        .collect();
    idx.iter()
        .map(|&i| {
            rows.iter()
                .map(|r| r[i].trim().parse().expect("number"))
                .collect()
        })
        .collect()
}

pub fn usize_of(v: &Value) -> usize {
    usize::try_from(
        v.as_u64()
            .unwrap_or_else(|| panic!("integer expected, got {v}")),
    )
    .expect("fits usize")
}

pub fn f64_of(v: &Value) -> f64 {
    v.as_f64()
        .unwrap_or_else(|| panic!("number expected, got {v}"))
}

pub fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("array expected, got {v}"))
        .iter()
        .map(f64_of)
        .collect()
}

/// Estimation and validation data exactly as the fixture describes (file, columns, split,
/// detrending).
pub fn load(fx: &Value) -> (IdData, IdData) {
    let path = data_dir().join(fx["file"].as_str().expect("file"));
    let ts = f64_of(&fx["ts_s"]);
    let (ue, ye, uv, yv) = if fx["format"] == "dat" {
        let rows = read_dat(&path);
        let col = |c: &str| -> Vec<f64> {
            let k = usize_of(&fx["columns"][c]);
            rows.iter().map(|r| r[k]).collect()
        };
        let (u, y) = (col("u"), col("y"));
        let e = floats(&fx["estimation"]);
        let v = floats(&fx["validation"]);
        let (e0, e1, v0, v1) = (e[0] as usize, e[1] as usize, v[0] as usize, v[1] as usize);
        (
            u[e0..e1].to_vec(),
            y[e0..e1].to_vec(),
            u[v0..v1].to_vec(),
            y[v0..v1].to_vec(),
        )
    } else {
        let c = &fx["columns"];
        let names = ["u_est", "y_est", "u_val", "y_val"].map(|k| c[k].as_str().expect("name"));
        let mut cols = read_csv_columns(&path, &names).into_iter();
        let mut next = || cols.next().expect("column");
        (next(), next(), next(), next())
    };
    let est = IdData::siso(ye, ue, ts).expect("valid estimation data");
    let val = IdData::siso(yv, uv, ts).expect("valid validation data");
    match fx["detrend"].as_str() {
        Some("segment_mean") => (est.detrend().0, val.detrend().0),
        Some("estimation_mean") => {
            let (est_d, offsets) = est.detrend();
            (est_d, val.remove_offsets(&offsets))
        }
        other => panic!("unknown detrend mode {other:?}"),
    }
}
