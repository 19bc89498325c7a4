//! `airsus fleet generate`: the layout of a fleet, its logs read back through the Parquet
//! reader, and the refusals (issue #17).

mod common;

use common::{airsus, ok};

#[test]
fn a_fleet_is_written_whole_and_never_over_another() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fleet");
    let out_s = out.to_str().unwrap();
    let (stdout, stderr) = ok(&["fleet", "generate", "--trucks", "1", "--out", out_s]);
    assert_eq!(stdout.trim(), out_s);
    assert!(stderr.contains("1 trucks x 1 days (1 leaking)"), "{stderr}");
    for file in [
        "fleet.toml",
        "truck.toml",
        "logs/truck_id=0/day-000.parquet",
        "truth/trucks.csv",
        "truth/truck_id=0/truck.toml",
        "truth/truck_id=0/effects.toml",
        "truth/loads/truck_id=0/day-000.parquet",
    ] {
        assert!(out.join(file).is_file(), "{file} is missing");
    }
    // Nothing of the scratch folder is left.
    let names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        names.iter().all(|n| !n.starts_with(".fleet-partial")),
        "{names:?}"
    );
    let trucks = std::fs::read_to_string(out.join("truth/trucks.csv")).unwrap();
    let row: Vec<&str> = trucks.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(&row[..2], ["0", "1"], "truck 0 is variant 1: {trucks}");
    assert_eq!(row[3], "1", "the one truck leaks: {trucks}");

    // The log reads as a run through the Parquet reader (no wheel-load column: loads are
    // what the fleet jobs estimate), 24 h at 10 Hz, the sensors' resolution kept.
    let source = airsus_data::RunSource {
        load_optional: true,
        ..airsus_data::RunSource::default()
    };
    let run = airsus_logs::read_run(
        &out.join("logs/truck_id=0/day-000.parquet"),
        airsus_data::Outputs::Required,
        &source,
    )
    .unwrap()
    .run;
    assert_eq!(run.len(), 864_000);
    assert!(
        (run.sample_time_s - 0.1).abs() < 1e-9,
        "{}",
        run.sample_time_s
    );
    let heights = &run.outputs.as_ref().unwrap().sensor_height_m;
    assert!(heights.iter().all(|h| (0.15..0.30).contains(h)));
    assert!(
        run.inputs
            .valve
            .iter()
            .any(|v| *v != airsus_data::ValveState::Closed)
    );

    // A second run into the same folder is refused and changes nothing.
    let before = std::fs::read(out.join("logs/truck_id=0/day-000.parquet")).unwrap();
    let again = airsus(&["fleet", "generate", "--trucks", "2", "--out", out_s]);
    assert!(!again.status.success());
    let message = String::from_utf8_lossy(&again.stderr);
    assert!(message.contains("already holds a fleet"), "{message}");
    assert_eq!(
        std::fs::read(out.join("logs/truck_id=0/day-000.parquet")).unwrap(),
        before
    );
}

#[test]
fn fleet_arguments_are_checked_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f");
    let out_s = out.to_str().unwrap();
    for (args, expected) in [
        (vec!["--trucks", "0"], "both must be at least 1"),
        (
            vec!["--trucks", "2", "--days", "0"],
            "both must be at least 1",
        ),
        (vec!["--trucks", "2", "--leaking", "3"], "3 of a fleet of 2"),
        (vec!["--trucks", "200000"], "at most 100 000 trucks"),
    ] {
        let mut all = vec!["fleet", "generate", "--out", out_s];
        all.extend(args.iter().copied());
        let result = airsus(&all);
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert!(!result.status.success(), "{args:?} succeeded");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
    }
    assert!(!out.join("fleet.toml").exists());
}
