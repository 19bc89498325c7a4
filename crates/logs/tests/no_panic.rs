//! Damaged logs never panic: every truncation and many single-byte corruptions of the MDF4,
//! Parquet and candump fixtures give a run or an error, never a crash. The readers are
//! third-party crates behind our interface; this is what holds them to the project's rule.

use std::path::{Path, PathBuf};

use airsus_data::{ColumnMap, Outputs, RunSource};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

fn source(columns: &str, dbc: bool) -> RunSource {
    RunSource {
        columns: ColumnMap::parse_list(columns).unwrap(),
        dbc: dbc.then(|| fixture("truck.dbc")),
        resample: Some(airsus_data::Resample::new(airsus_data::ResampleMethod::Zoh, 0.1).unwrap()),
        load_optional: false,
    }
}

/// Truncations at `cuts` points and corruptions of one byte at `flips` points spread over the
/// file (a multiplicative stride, so every region is hit); each variant is read once.
fn damage(name: &str, source: &RunSource, cuts: usize, flips: usize) {
    let bytes = std::fs::read(fixture(name)).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    let read = |data: &[u8], what: &str| {
        std::fs::write(&path, data).unwrap();
        let outcome = std::panic::catch_unwind(|| {
            let _ = airsus_logs::read_run(&path, Outputs::Required, source);
        });
        assert!(outcome.is_ok(), "{name}: {what} panicked");
    };
    for k in 0..cuts {
        let at = bytes.len() * k / cuts;
        read(&bytes[..at], &format!("truncated at {at}"));
    }
    for k in 0..flips {
        let at = (k * 7919 + 13) % bytes.len();
        let mut data = bytes.clone();
        data[at] ^= 0xA5;
        read(&data, &format!("byte {at} flipped"));
        // Text stays text: a printable character, or a two-byte one (é), in its place.
        let mut data = bytes.clone();
        data[at] = b"#0Z(). -9F\t"[k % 11];
        read(&data, &format!("byte {at} replaced"));
        let mut data = bytes.clone();
        data.splice(at..=at, "é".bytes());
        read(&data, &format!("byte {at} made non-ASCII"));
    }
}

const MDF_COLUMNS: &str = "wheel_load_kg=WheelLoad,valve=ValveCmd,supply_kpa=SupplyPressure,\
                           height_mm=AxleHeight,pressure_kpa=BellowPressure";
const CAN_COLUMNS: &str = "wheel_load_kg=WheelLoad,valve=ValveState,supply_kpa=SupplyPressure,\
                           height_mm=AxleHeight,pressure_kpa=BellowPressure";

#[test]
fn damaged_mdf4_files_never_panic() {
    damage("run_plain.mf4", &source(MDF_COLUMNS, false), 64, 400);
    damage(
        "run_dz_transposed.mf4",
        &source(MDF_COLUMNS, false),
        64,
        400,
    );
    damage("run_can.mf4", &source(CAN_COLUMNS, true), 64, 400);
}

#[test]
fn damaged_parquet_files_never_panic() {
    damage(
        "run.parquet",
        &source("time_s=timestamp,supply_kpa=supply_bar", false),
        64,
        400,
    );
    damage("run_zstd.parquet", &source("", false), 64, 400);
}

#[test]
fn damaged_can_logs_never_panic() {
    damage("run.log", &source(CAN_COLUMNS, true), 32, 200);
}
