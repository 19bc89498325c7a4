//! The binary end to end: `params --builtin` round-trips, `check` reports and fails properly.

use std::process::Command;

fn airsus(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_airsus"))
        .args(args)
        .output()
        .expect("the airsus binary runs")
}

#[test]
fn builtin_params_print_as_toml_that_loads_back_unchanged() {
    let out = airsus(&["params", "--builtin"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let loaded = airsus_data::truck::parse_truck(&text, std::path::Path::new("stdout")).unwrap();
    assert_eq!(loaded.parameters, airsus_data::TruckParameters::reference());
    assert!(loaded.defaulted.is_empty());

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("truck.toml");
    let out = airsus(&["params", "--builtin", "--out", path.to_str().unwrap()]);
    assert!(out.status.success());
    assert_eq!(std::fs::read_to_string(&path).unwrap(), text);
    let again = airsus(&["params", "--truck", path.to_str().unwrap()]);
    assert_eq!(String::from_utf8(again.stdout).unwrap(), text);
}

#[test]
fn params_needs_a_source() {
    let out = airsus(&["params"]);
    assert!(!out.status.success());
}

#[test]
fn check_fails_with_file_line_and_column_for_a_bad_run() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.csv");
    std::fs::write(
        &path,
        "time_s,wheel_load_kg,valve,supply_kpa,height_mm,pressure_kpa\n0,2830,0,850,240,350\n0.1,2830,5,850,240,350\n",
    )
    .unwrap();
    let out = airsus(&["check", path.to_str().unwrap()]);
    assert!(!out.status.success());
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(stdout.contains("bad.csv:3:3 (column `valve`)"), "{stdout}");
    assert!(
        String::from_utf8(out.stderr)
            .unwrap()
            .contains("1 of 1 file(s) failed")
    );
}

#[test]
fn check_accepts_a_valid_study_and_everything_it_names() {
    let study = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../data/tests/fixtures/study_dir/study.toml"
    );
    let out = airsus(&["check", study]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
}
