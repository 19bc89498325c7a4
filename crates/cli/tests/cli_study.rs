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
}
