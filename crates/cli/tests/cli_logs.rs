//! Runs from MDF4, Parquet and CAN logs through the binary: the same simulation as the CSV
//! they were written from (crates/logs/tests/fixtures, written by asammdf, pyarrow, cantools
//! and python-can), Parquet outputs, `check` and a study on logs.

mod common;

use std::path::PathBuf;

use common::{airsus, ok};

fn fixture(name: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../logs/tests/fixtures")
        .join(name)
        .to_str()
        .unwrap()
        .to_owned()
}

const MDF_COLUMNS: &str = "wheel_load_kg=WheelLoad,valve=ValveCmd,supply_kpa=SupplyPressure,\
                           height_mm=AxleHeight,pressure_kpa=BellowPressure";
const CAN_COLUMNS: &str = "wheel_load_kg=WheelLoad,valve=ValveState,supply_kpa=SupplyPressure,\
                           height_mm=AxleHeight,pressure_kpa=BellowPressure";

/// Simulates the virtual truck's own structure over `run` (with `extra` flags) into `out`,
/// from the equilibrium: a start fitted to the first seconds would turn a format's float
/// rounding into differences of the fit's own, and this compares the readers.
fn simulate(run: &str, out: &std::path::Path, extra: &[&str]) -> String {
    let truck = fixture("truck.toml");
    let mut args = vec![
        "simulate",
        "--model",
        "truck",
        "--truck",
        &truck,
        "--initial-state",
        "equilibrium",
    ];
    let out = out.to_str().unwrap();
    args.extend(["--run", run, "--out", out]);
    args.extend(extra);
    ok(&args).1
}

fn outputs(path: &std::path::Path) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let run = airsus_logs::read_plain_run(path).unwrap();
    let o = run.outputs.unwrap();
    (run.time_s, o.sensor_height_m, o.bellow_gauge_pa)
}

fn assert_close(name: &str, a: &[f64], b: &[f64], relative: f64) {
    assert_eq!(a.len(), b.len(), "{name}: lengths");
    let worst = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / y.abs().max(1e-3))
        .fold(0.0, f64::max);
    assert!(
        worst <= relative,
        "{name}: worst relative difference {worst:e}"
    );
}

#[test]
fn a_run_from_mdf4_parquet_or_can_simulates_as_the_csv_it_came_from() {
    let dir = tempfile::tempdir().unwrap();
    let from_csv = dir.path().join("csv.csv");
    simulate(&fixture("run.csv"), &from_csv, &[]);
    let (time, height, pressure) = outputs(&from_csv);

    // MDF4 (bar, raw counts with conversions) and Parquet (timestamps, bar), written as
    // Parquet.
    for (run, columns) in [
        ("run_plain.mf4", MDF_COLUMNS),
        ("run_dz_transposed.mf4", MDF_COLUMNS),
        ("run.parquet", "time_s=timestamp,supply_kpa=supply_bar"),
        ("run_zstd.parquet", ""),
    ] {
        let out = dir.path().join(format!("{run}.parquet"));
        let mut extra = vec![];
        if !columns.is_empty() {
            extra = vec!["--columns", columns];
        }
        simulate(&fixture(run), &out, &extra);
        let (t, h, p) = outputs(&out);
        assert_close(&format!("{run} time"), &t, &time, 1e-12);
        // The inputs agree to the last bits (bar → kPa, counts × 0.1), which may move an
        // adaptive step: the responses agree to far below the sensors' resolution.
        assert_close(&format!("{run} height"), &h, &height, 1e-6);
        assert_close(&format!("{run} pressure"), &p, &pressure, 1e-6);
    }

    // CAN: a candump log and an MDF4 bus log through the DBC, held onto the later message's
    // times (2 ms after the CSV's): the same response, one sample shorter.
    let n = time.len() - 1;
    for run in ["run.log", "run_can.mf4"] {
        let out = dir.path().join(format!("{run}.csv"));
        let stderr = simulate(
            &fixture(run),
            &out,
            &[
                "--columns",
                CAN_COLUMNS,
                "--dbc",
                &fixture("truck.dbc"),
                "--resample",
                "zoh",
                "--sample-s",
                "0.1",
            ],
        );
        assert!(stderr.contains("note:"), "{stderr}");
        assert!(stderr.contains("zero-order hold"), "{stderr}");
        let (t, h, p) = outputs(&out);
        assert_eq!(t.len(), n, "{run}");
        assert!((t[0] - 0.002).abs() < 1e-6, "{run}: {}", t[0]);
        assert_close(&format!("{run} height"), &h, &height[..n], 1e-6);
        assert_close(&format!("{run} pressure"), &p, &pressure[..n], 1e-6);
    }
}

#[test]
fn check_reads_logs_and_refuses_two_time_bases_until_resampling_is_asked() {
    let (stdout, _) = ok(&["check", &fixture("run_plain.mf4"), "--columns", MDF_COLUMNS]);
    assert!(
        stdout.contains("run (MDF4), 1001 samples at 0.1 s"),
        "{stdout}"
    );

    let out = airsus(&[
        "check",
        &fixture("run_two_bases.mf4"),
        "--columns",
        MDF_COLUMNS,
    ]);
    assert!(!out.status.success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("different time bases"), "{stdout}");

    let (stdout, _) = ok(&[
        "check",
        &fixture("run_two_bases.mf4"),
        "--columns",
        MDF_COLUMNS,
        "--resample",
        "linear",
        "--sample-s",
        "0.1",
    ]);
    assert!(
        stdout.contains("resampled 5 channel(s) from 2 time base(s)"),
        "{stdout}"
    );

    // A resample without its step is refused by the command line itself.
    let out = airsus(&["check", &fixture("run_plain.mf4"), "--resample", "zoh"]);
    assert!(!out.status.success());
}

#[test]
fn malformed_logs_fail_with_the_file_and_the_channel() {
    for (name, expected) in [
        ("truncated.mf4", "not a readable MDF4 file"),
        ("wrong_magic.mf4", "wrong magic"),
        ("string_column.parquet", "(channel `pressure_kpa`)"),
    ] {
        let out = airsus(&["check", &fixture(name)]);
        assert!(!out.status.success(), "{name}");
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(stdout.contains(&fixture(name)), "{name}: {stdout}");
        assert!(stdout.contains(expected), "{name}: {stdout}");
    }
}

#[test]
fn a_study_reads_its_runs_from_logs_and_reports_how() {
    let dir = tempfile::tempdir().unwrap();
    let study = dir.path().join("study.toml");
    std::fs::write(
        &study,
        format!(
            r#"truck = "{truck}"

[[run]]
name = "valve pulses (MDF4)"
file = "{mdf}"
role = "estimation"
[run.columns]
wheel_load_kg = "WheelLoad"
valve = "ValveCmd"
supply_kpa = {{ channel = "SupplyPressure", unit = "bar" }}
height_mm = "AxleHeight"
pressure_kpa = "BellowPressure"

[[run]]
name = "valve pulses (two bases)"
file = "{two}"
role = "validation"
resample = "linear"
sample_s = 0.1
[run.columns]
wheel_load_kg = "WheelLoad"
valve = "ValveCmd"
supply_kpa = "SupplyPressure"
height_mm = "AxleHeight"
pressure_kpa = "BellowPressure"
"#,
            truck = fixture("truck.toml"),
            mdf = fixture("run_plain.mf4"),
            two = fixture("run_two_bases.mf4"),
        ),
    )
    .unwrap();
    let (stdout, _) = ok(&["check", study.to_str().unwrap()]);
    assert!(stdout.contains("2 run(s)"), "{stdout}");

    let out = dir.path().join("out");
    ok(&[
        "study",
        study.to_str().unwrap(),
        "--models",
        "m1",
        "--out",
        out.to_str().unwrap(),
    ]);
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let runs = results["runs"].as_array().unwrap();
    assert_eq!(runs[0]["format"], "MDF4");
    assert!(runs[0].get("notes").is_none(), "{}", runs[0]);
    let notes = runs[1]["notes"].to_string();
    assert!(notes.contains("linear interpolation"), "{notes}");
    let report = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(report.contains("How the runs were read"), "report");
    assert!(report.contains("resampled 5 channel(s)"), "report");
}

#[test]
fn weigh_reads_a_log_without_a_wheel_load_channel_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    // run.csv without its wheel_load_kg column, as a truck's own log would be.
    let text = std::fs::read_to_string(fixture("run.csv")).unwrap();
    let without: String = text
        .lines()
        .map(|line| {
            let mut cells: Vec<&str> = line.split(',').collect();
            cells.remove(1);
            cells.join(",") + "\n"
        })
        .collect();
    let run = dir.path().join("no_load.csv");
    std::fs::write(&run, without).unwrap();
    let (stdout, stderr) = ok(&[
        "weigh",
        "--truck",
        &fixture("truck.toml"),
        "--run",
        run.to_str().unwrap(),
    ]);
    assert!(stderr.contains("no wheel-load channel"), "{stderr}");
    // The estimate is the load the run carried (3390 kg), to within the weighing's error.
    let final_kg: f64 = stdout
        .split("final wheel load ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no final load in {stdout}"));
    assert!((final_kg - 3390.0).abs() < 0.03 * 3390.0, "{final_kg} kg");
    // A simulation needs the load: the same file is refused there.
    let out = airsus(&[
        "simulate",
        "--model",
        "m2",
        "--truck",
        &fixture("truck.toml"),
        "--run",
        run.to_str().unwrap(),
        "--out",
        dir.path().join("sim.csv").to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("wheel_load_kg"));
}
