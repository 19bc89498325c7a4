//! Runs read from logs written by independent tools (tools/logs/make_fixtures.py: asammdf,
//! pyarrow, cantools, python-can) must be the run of `run.csv`; malformed logs must give
//! errors that name the file and the channel.

use std::path::{Path, PathBuf};

use airsus_data::{
    ColumnMap, DataErrorKind, Outputs, Resample, ResampleMethod, Run, RunSource, read_run,
};
use airsus_logs::{CanDatabase, LogFormat, detect_format};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

fn csv_run() -> Run {
    read_run(&fixture("run.csv")).unwrap()
}

fn source(columns: &str) -> RunSource {
    RunSource {
        columns: ColumnMap::parse_list(columns).unwrap(),
        ..RunSource::default()
    }
}

/// The channel names and units the MDF4 fixtures use for the run columns.
const MDF_COLUMNS: &str = "wheel_load_kg=WheelLoad,valve=ValveCmd,supply_kpa=SupplyPressure,\
                           height_mm=AxleHeight,pressure_kpa=BellowPressure";
/// The DBC's signal names.
const CAN_COLUMNS: &str = "wheel_load_kg=WheelLoad,valve=ValveState,supply_kpa=SupplyPressure,\
                           height_mm=AxleHeight,pressure_kpa=BellowPressure";

fn assert_close(name: &str, a: &[f64], b: &[f64], tolerance: f64) {
    assert_eq!(a.len(), b.len(), "{name}: lengths");
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= tolerance * (1.0 + y.abs()),
            "{name}[{i}]: {x} against {y}"
        );
    }
}

/// Same samples, same values (to `tolerance`, relative), time shifted by `shift_s`.
fn assert_same_run(got: &Run, want: &Run, shift_s: f64, tolerance: f64) {
    let shifted: Vec<f64> = want.time_s.iter().map(|t| t + shift_s).collect();
    assert_close("time", &got.time_s, &shifted, 1e-9);
    assert!((got.sample_time_s - want.sample_time_s).abs() < 1e-9);
    let (g, w) = (&got.inputs, &want.inputs);
    assert_eq!(g.valve, w.valve, "valve");
    assert_close("load", &g.wheel_load_kg, &w.wheel_load_kg, tolerance);
    assert_close("supply", &g.supply_gauge_pa, &w.supply_gauge_pa, tolerance);
    assert_close("road", &g.road_height_m, &w.road_height_m, tolerance);
    let (g, w) = (
        got.outputs.as_ref().unwrap(),
        want.outputs.as_ref().unwrap(),
    );
    assert_close("height", &g.sensor_height_m, &w.sensor_height_m, tolerance);
    assert_close(
        "pressure",
        &g.bellow_gauge_pa,
        &w.bellow_gauge_pa,
        tolerance,
    );
}

/// The run without its last `k` samples (a span the channels do not all cover).
fn drop_last(mut run: Run, k: usize) -> Run {
    let n = run.len() - k;
    run.time_s.truncate(n);
    let i = &mut run.inputs;
    i.wheel_load_kg.truncate(n);
    i.valve.truncate(n);
    i.supply_gauge_pa.truncate(n);
    i.road_height_m.truncate(n);
    if let Some(o) = run.outputs.as_mut() {
        o.sensor_height_m.truncate(n);
        o.bellow_gauge_pa.truncate(n);
    }
    run
}

fn read(name: &str, source: &RunSource) -> airsus_data::LoadedRun {
    airsus_logs::read_run(&fixture(name), Outputs::Required, source)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn formats_are_told_by_content() {
    assert_eq!(detect_format(&fixture("run.csv")).unwrap(), LogFormat::Csv);
    assert_eq!(
        detect_format(&fixture("run_plain.mf4")).unwrap(),
        LogFormat::Mdf4
    );
    assert_eq!(
        detect_format(&fixture("run.parquet")).unwrap(),
        LogFormat::Parquet
    );
    assert_eq!(
        detect_format(&fixture("run.log")).unwrap(),
        LogFormat::CanLog
    );
}

#[test]
fn mdf4_with_units_and_conversions_is_the_csv_run() {
    let loaded = read("run_plain.mf4", &source(MDF_COLUMNS));
    // SupplyPressure is in bar and the raw counts pass through linear conversion blocks.
    assert_same_run(&loaded.run, &csv_run(), 0.0, 1e-12);
    assert!(loaded.notes.is_empty(), "{:?}", loaded.notes);
}

#[test]
fn dz_compressed_mdf4_reads_as_the_plain_file() {
    let plain = read("run_plain.mf4", &source(MDF_COLUMNS)).run;
    for name in ["run_dz.mf4", "run_dz_transposed.mf4"] {
        let compressed = read(name, &source(MDF_COLUMNS)).run;
        assert_eq!(compressed.inputs, plain.inputs, "{name}");
        assert_eq!(compressed.outputs, plain.outputs, "{name}");
        assert_eq!(compressed.time_s, plain.time_s, "{name}");
    }
}

#[test]
fn two_time_bases_are_refused_until_resampling_is_asked_and_then_match_numpy() {
    let err = airsus_logs::read_run(
        &fixture("run_two_bases.mf4"),
        Outputs::Required,
        &source(MDF_COLUMNS),
    )
    .unwrap_err();
    assert!(matches!(err.kind, DataErrorKind::TimeBases { .. }), "{err}");
    let text = err.to_string();
    assert!(text.contains("run_two_bases.mf4"), "{text}");
    assert!(text.contains("never resamples silently"), "{text}");

    let mut resampled = source(MDF_COLUMNS);
    resampled.resample = Some(Resample::new(ResampleMethod::Linear, 0.1).unwrap());
    let loaded = read("run_two_bases.mf4", &resampled);
    assert!(
        loaded
            .notes
            .iter()
            .any(|n| n.contains("linear interpolation")),
        "{:?}",
        loaded.notes
    );
    // numpy's interp and searchsorted, written by the fixture script.
    let expected = airsus_data::read_run(&fixture("expected_two_bases_linear.csv")).unwrap();
    assert_same_run(&loaded.run, &expected, 0.0, 1e-12);
}

#[test]
fn parquet_with_timestamps_and_units_is_the_csv_run() {
    let loaded = read(
        "run.parquet",
        &source("time_s=timestamp,supply_kpa=supply_bar"),
    );
    assert_same_run(&loaded.run, &csv_run(), 0.0, 1e-12);
    assert!(
        loaded
            .notes
            .iter()
            .any(|n| n.contains("1777881600 s since 1970")),
        "{:?}",
        loaded.notes
    );
    // zstd, three row groups, the contract's names, no metadata, no road column.
    let plain = read("run_zstd.parquet", &RunSource::default());
    assert_same_run(&plain.run, &csv_run(), 0.0, 0.0);
}

#[test]
fn parquet_written_by_airsus_reads_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sim.parquet");
    let run = csv_run();
    airsus_logs::write_run(&path, &run).unwrap();
    assert_eq!(detect_format(&path).unwrap(), LogFormat::Parquet);
    let back = airsus_logs::read_plain_run(&path).unwrap();
    assert_same_run(&back, &run, 0.0, 1e-15);
    // Nothing is left beside it (written whole, then renamed).
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(names.len(), 1);
}

#[test]
fn candump_log_decodes_j1939_frames_from_another_source_address() {
    let mut can = source(CAN_COLUMNS);
    can.dbc = Some(fixture("truck.dbc"));
    // The two messages come 2 ms apart: they are two time bases.
    let err = airsus_logs::read_run(&fixture("run.log"), Outputs::Required, &can).unwrap_err();
    assert!(matches!(err.kind, DataErrorKind::TimeBases { .. }), "{err}");

    can.resample = Some(Resample::new(ResampleMethod::Zoh, 0.1).unwrap());
    let loaded = read("run.log", &can);
    // Held onto the later message's times: every value is the CSV's, 2 ms later, up to the
    // last frame of the earlier message (the common span).
    assert_same_run(&loaded.run, &drop_last(csv_run(), 1), 0.002, 1e-12);
    let notes = loaded.notes.join("; ");
    assert!(notes.contains("2002 CAN frames decoded"), "{notes}");
    assert!(
        notes.contains("1001 frames of messages it does not define skipped"),
        "{notes}"
    );
}

#[test]
fn bus_logging_mdf4_decodes_like_the_candump_log() {
    let mut can = source(CAN_COLUMNS);
    can.dbc = Some(fixture("truck.dbc"));
    can.resample = Some(Resample::new(ResampleMethod::Zoh, 0.1).unwrap());
    let loaded = read("run_can.mf4", &can);
    // python-can stored float timestamps: the start is 2 ms within a microsecond.
    let run = &loaded.run;
    assert!((run.time_s[0] - 0.002).abs() < 1e-6, "{}", run.time_s[0]);
    let mut want = drop_last(csv_run(), 1);
    want.time_s = want.time_s.iter().map(|t| t + run.time_s[0]).collect();
    assert_same_run(run, &want, 0.0, 1e-12);
    // Decoded by the same path as the candump log, and counted alike.
    let notes = loaded.notes.join("; ");
    assert!(notes.contains("2002 CAN frames decoded"), "{notes}");
    assert!(
        notes.contains("1001 frames of messages it does not define skipped"),
        "{notes}"
    );

    // Without the DBC, the missing channel's error says why.
    let err = airsus_logs::read_run(
        &fixture("run_can.mf4"),
        Outputs::Required,
        &source(CAN_COLUMNS),
    )
    .unwrap_err();
    let text = err.to_string();
    assert!(text.contains("logs CAN frames"), "{text}");
    assert!(text.contains("give the DBC"), "{text}");
}

#[test]
fn decoding_agrees_with_cantools_and_needs_the_j1939_rule() {
    let database = CanDatabase::read(&fixture("truck.dbc")).unwrap();
    assert!(database.j1939);
    let log = std::fs::read_to_string(fixture("run.log")).unwrap();
    let expected = std::fs::read_to_string(fixture("expected_can_decode.csv")).unwrap();
    let mut want: Vec<(String, f64)> = expected
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[1].to_owned(), f[2].parse().unwrap())
        })
        .collect();
    let mut got = Vec::new();
    for line in log.lines().take(30) {
        let frame = line.split_whitespace().nth(2).unwrap();
        let (id, data) = frame.split_once('#').unwrap();
        let id = u32::from_str_radix(id, 16).unwrap();
        let data: Vec<u8> = (0..data.len() / 2)
            .map(|k| u8::from_str_radix(&data[2 * k..2 * k + 2], 16).unwrap())
            .collect();
        for (_, signal, _, value) in database.decode(id, &data) {
            got.push((signal.to_owned(), value));
        }
    }
    want.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    got.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    assert_eq!(got.len(), want.len());
    for ((gn, gv), (wn, wv)) in got.iter().zip(&want) {
        assert_eq!(gn, wn);
        assert!(
            (gv - wv).abs() <= 1e-9 * (1.0 + wv.abs()),
            "{gn}: {gv} against {wv}"
        );
    }

    // The same database without its J1939 markers matches identifiers exactly: the frames,
    // sent by source address 0x21 at priority 3, then decode to nothing.
    let text = std::fs::read_to_string(fixture("truck.dbc")).unwrap();
    let plain: String = text
        .lines()
        .filter(|l| !l.starts_with("BA_"))
        .map(|l| format!("{l}\n"))
        .collect();
    let exact = CanDatabase::parse(plain.as_bytes(), Path::new("plain.dbc")).unwrap();
    assert!(!exact.j1939);
    assert!(exact.decode(0x0CFF_1021, &[0; 8]).is_empty());
    assert_eq!(database.decode(0x0CFF_1021, &[0; 8]).len(), 3);
}

#[test]
fn a_can_log_without_a_dbc_or_a_csv_with_one_is_refused() {
    let err = airsus_logs::read_run(&fixture("run.log"), Outputs::Required, &source(CAN_COLUMNS))
        .unwrap_err();
    assert!(err.to_string().contains("name the DBC file"), "{err}");
    let with_dbc = RunSource {
        dbc: Some(fixture("truck.dbc")),
        ..RunSource::default()
    };
    let err = airsus_logs::read_run(&fixture("run.csv"), Outputs::Required, &with_dbc).unwrap_err();
    assert!(err.to_string().contains("holds none"), "{err}");
}

#[test]
fn malformed_logs_name_the_file_and_what_is_wrong() {
    let cases: &[(&str, &str, &str)] = &[
        ("truncated.mf4", MDF_COLUMNS, "not a readable MDF4 file"),
        ("wrong_magic.mf4", MDF_COLUMNS, "wrong magic"),
        ("truncated.parquet", "", "not a readable Parquet file"),
        (
            "string_column.parquet",
            "",
            "(channel `pressure_kpa`): not a readable Parquet file: the column holds string or binary values",
        ),
        (
            "run_plain.mf4",
            "wheel_load_kg=WheelLoad,valve=ValveCmd,supply_kpa=SupplyPressure,height_mm=AxleHeight,pressure_kpa=BellowPresure",
            "channel `BellowPresure` for column `pressure_kpa` is not in the file (did you mean `BellowPressure`?)",
        ),
        (
            "run.parquet",
            "",
            "channel `time_s` for column `time_s` is not in the file",
        ),
    ];
    for (name, columns, expected) in cases {
        let err = airsus_logs::read_run(&fixture(name), Outputs::Required, &source(columns))
            .expect_err(name);
        let text = err.to_string();
        assert!(text.contains(name), "{name}: {text}");
        assert!(text.contains(expected), "{name}: {text}");
    }
}

#[test]
fn a_unit_the_file_gives_wins_over_none_and_conflicts_are_refused() {
    let err = airsus_logs::read_run(
        &fixture("run_plain.mf4"),
        Outputs::Required,
        &source(
            "wheel_load_kg=WheelLoad,valve=ValveCmd,supply_kpa=SupplyPressure[kPa],height_mm=AxleHeight,pressure_kpa=BellowPressure",
        ),
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        format!(
            "{} (channel `SupplyPressure`): the file gives unit `bar` but the column map says `kPa`; remove the unit from the map or correct it",
            fixture("run_plain.mf4").display()
        )
    );
    // An unknown unit in the file: EngineSpeed is in rpm.
    let err = airsus_logs::read_run(
        &fixture("run_plain.mf4"),
        Outputs::Required,
        &source(
            "wheel_load_kg=WheelLoad,valve=ValveCmd,supply_kpa=EngineSpeed,height_mm=AxleHeight,pressure_kpa=BellowPressure",
        ),
    )
    .unwrap_err();
    assert!(
        err.to_string()
            .contains("unit `rpm` cannot be read as column `supply_kpa`"),
        "{err}"
    );
}
