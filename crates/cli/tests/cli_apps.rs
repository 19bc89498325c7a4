//! `airsus weigh`, `control` and `road` end to end on the virtual truck's study.

use std::process::Command;

fn airsus(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_airsus"))
        .args(args)
        .output()
        .expect("the airsus binary runs")
}

#[test]
fn weigh_control_and_road_run_and_write_their_files() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    assert!(airsus(&["generate", "--out", &p("")]).status.success());

    let weigh = airsus(&[
        "weigh",
        "--truck",
        &p("truck.toml"),
        "--run",
        &p("ds2.csv"),
        "--out",
        &p("w.csv"),
    ]);
    assert!(
        weigh.status.success(),
        "{}",
        String::from_utf8_lossy(&weigh.stderr)
    );
    let text = std::fs::read_to_string(p("w.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("time_s,wheel_load_kg,wheel_load_std_kg"));
    let first: Vec<f64> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    // Nominal parameters: within 10 % of the true 3390 kg, with a stated uncertainty.
    assert!(
        (first[1] - 3390.0).abs() < 340.0 && first[2] > 0.0,
        "{first:?}"
    );

    let control = airsus(&[
        "control",
        "--truck",
        &p("truck.toml"),
        "--target-mm",
        "240",
        "--scenario",
        "load-steps",
        "--plot",
        &p("c.svg"),
    ]);
    assert!(
        control.status.success(),
        "{}",
        String::from_utf8_lossy(&control.stderr)
    );
    let report = String::from_utf8_lossy(&control.stdout).into_owned()
        + &String::from_utf8_lossy(&control.stderr);
    assert!(
        report.contains("deadband") && report.contains("predictive"),
        "{report}"
    );
    assert!(
        std::fs::read_to_string(p("c.svg"))
            .unwrap()
            .starts_with("<svg")
    );

    let road = airsus(&[
        "road",
        "--truck",
        &p("truck.toml"),
        "--model",
        "m2",
        "--profile",
        "bump",
        "--out",
        &p("r.csv"),
    ]);
    assert!(
        road.status.success(),
        "{}",
        String::from_utf8_lossy(&road.stderr)
    );
    let run = airsus_data::read_run(std::path::Path::new(&p("r.csv"))).unwrap();
    assert!(
        run.inputs.road_height_m.iter().any(|&z| z > 0.01),
        "the bump is in the road column"
    );
}
