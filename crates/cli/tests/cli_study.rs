//! `airsus study --builtin`: the README's main command, restricted to one model for speed.

use std::process::Command;

#[test]
fn study_builtin_writes_the_report_and_prints_the_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_airsus"))
        .args([
            "study",
            "--builtin",
            "--out",
            dir.path().to_str().unwrap(),
            "--models",
            "m2",
            "--max-iterations",
            "5",
            "--prefix-s",
            "12",
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("protocol `thesis`") && stdout.contains("protocol `valve`"),
        "{stdout}"
    );
    assert!(stdout.contains("m2 "), "{stdout}");
    for file in [
        "report.html",
        "results.json",
        "data/study.toml",
        "estimated/thesis_m2.toml",
        "estimated/valve_m2.toml",
        "figures/force_map.svg",
        "figures/force_map.png",
    ] {
        assert!(dir.path().join(file).exists(), "{file} missing; {stderr}");
    }
    // What it wrote says the estimation worked: under the valve protocol m2 goes from a
    // hopeless nominal fit of the valve run to a usable one, and the printed table shows the
    // same numbers as results.json.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("results.json")).unwrap())
            .unwrap();
    let valve = json["protocols"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "valve")
        .unwrap();
    let m2 = &valve["models"][0];
    assert_eq!(m2["model"], "m2");
    // The default start, and the prefix asked for, recorded and reported.
    assert_eq!(json["initial_state"], "joint");
    assert_eq!(json["prefix_s"], 12.0);
    let html = std::fs::read_to_string(dir.path().join("report.html")).unwrap();
    assert!(html.contains("history states fitted to the first 12 s"));
    let ds3 = m2["runs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["run"] == "data-set 3")
        .unwrap();
    let nominal = ds3["nominal"]["height_percent"].as_f64().unwrap();
    let estimated = ds3["estimated"]["height_percent"].as_f64().unwrap();
    assert!(
        nominal < 0.0 && estimated > 70.0,
        "data-set 3 height {nominal} -> {estimated}"
    );
    let printed = format!("{estimated:.1}");
    assert!(stdout.contains(&printed), "{printed} not in {stdout}");
}

#[test]
fn study_needs_a_source_and_rejects_unknown_models() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_airsus"))
            .args(args)
            .output()
            .unwrap()
    };
    assert!(
        !run(&["study", "--out", dir.path().to_str().unwrap()])
            .status
            .success()
    );
    let res = run(&[
        "study",
        "--builtin",
        "--out",
        dir.path().to_str().unwrap(),
        "--models",
        "m9",
    ]);
    assert!(!res.status.success());
    assert!(String::from_utf8_lossy(&res.stderr).contains("unknown model `m9`"));
    let res = run(&[
        "study",
        "--builtin",
        "--out",
        dir.path().to_str().unwrap(),
        "--prefix-s",
        "0",
    ]);
    assert!(!res.status.success());
    assert!(
        String::from_utf8_lossy(&res.stderr)
            .contains("--prefix-s 0: expected a positive number of seconds")
    );
}
