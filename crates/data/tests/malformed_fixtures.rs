//! Each malformed fixture file is rejected with an error that names the file, the line and
//! the column, and says what was expected.

use std::path::PathBuf;

use airsus_data::{DataErrorKind, read_discharge, read_run, read_study};

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// Reads a malformed run and returns its error text, checking the file is named.
fn run_error(name: &str) -> (String, airsus_data::DataError) {
    let err = read_run(&fixture(name)).expect_err(name);
    let text = err.to_string();
    assert!(text.contains(name), "error does not name the file: {text}");
    (text, err)
}

#[test]
fn the_good_fixture_loads() {
    let run = read_run(&fixture("good_run.csv")).unwrap();
    assert_eq!(run.len(), 3);
}

#[test]
fn misspelt_column_suggests_the_valid_name() {
    let (text, err) = run_error("misspelt_column.csv");
    assert_eq!(err.location.line, Some(1));
    assert!(
        text.contains("required column `height_mm` is missing (did you mean `hieght_mm`?)"),
        "{text}"
    );
}

#[test]
fn non_numeric_nan_and_infinite_cells_name_line_and_column() {
    let (text, _) = run_error("non_numeric.csv");
    assert!(
        text.ends_with("non_numeric.csv:3:5 (column `height_mm`): expected a number, found `abc`"),
        "{text}"
    );
    let (text, err) = run_error("nan_cell.csv");
    assert!(text.contains(":3:6 (column `pressure_kpa`)"), "{text}");
    assert!(matches!(err.kind, DataErrorKind::NotFinite { .. }));
    let (_, err) = run_error("infinite_cell.csv");
    assert!(matches!(err.kind, DataErrorKind::NotFinite { .. }));
}

#[test]
fn time_errors_say_where() {
    let (text, err) = run_error("time_backwards.csv");
    assert_eq!(err.location.line, Some(4));
    assert!(text.contains("(column `time_s`)"), "{text}");
    let (text, err) = run_error("gap.csv");
    assert_eq!(err.location.line, Some(5));
    assert!(text.contains("non-uniform sampling"), "{text}");
    assert!(
        text.contains("0.30000000000000004 s") || text.contains("0.3 s"),
        "{text}"
    );
}

#[test]
fn bad_valve_and_negative_load_name_the_cell() {
    let (text, _) = run_error("bad_valve.csv");
    assert!(text.contains(":3:3 (column `valve`)"), "{text}");
    let (text, _) = run_error("negative_load.csv");
    assert!(text.contains(":3:2 (column `wheel_load_kg`)"), "{text}");
}

#[test]
fn study_paths_resolve_against_the_study_folder_whatever_the_working_directory() {
    let study = read_study(&fixture("study_dir/study.toml")).unwrap();
    // The run file is found although the test's working directory is the crate root.
    let run = read_run(&study.runs[0].file).unwrap();
    assert_eq!(run.len(), 3);
    let discharge = read_discharge(&study.discharges[0].file).unwrap();
    assert_eq!(discharge.tank_gauge_pa[0], 800_000.0);
}

#[test]
fn negative_tank_volume_is_rejected_with_its_line() {
    let err = read_study(&fixture("study_dir/negative_volume.toml")).unwrap_err();
    assert_eq!(err.location.line, Some(9));
    assert!(err.to_string().contains("negative_volume.toml:9"), "{err}");
}

#[test]
fn a_missing_file_is_named() {
    let err = read_run(&fixture("no_such_run.csv")).unwrap_err();
    assert!(
        err.to_string()
            .contains("no_such_run.csv: cannot read or write the file"),
        "{err}"
    );
}
