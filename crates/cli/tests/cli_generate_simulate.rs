//! The virtual truck's study end to end through the binary: generate, check, simulate.

use std::process::Command;

fn airsus(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_airsus"))
        .args(args)
        .output()
        .expect("the airsus binary runs")
}

#[test]
fn generate_then_check_then_simulate_every_model() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let generated = airsus(&["generate", "--out", out, "--seed", "3"]);
    assert!(
        generated.status.success(),
        "{}",
        String::from_utf8_lossy(&generated.stderr)
    );
    let study = dir.path().join("study.toml");
    assert!(
        String::from_utf8(generated.stdout)
            .unwrap()
            .contains("study.toml")
    );
    let check = airsus(&["check", study.to_str().unwrap()]);
    assert!(
        check.status.success(),
        "{}",
        String::from_utf8_lossy(&check.stdout)
    );

    let truck = dir.path().join("truck.toml");
    let run = dir.path().join("ds1.csv");
    for model in ["m1", "m2", "m2x", "m2xh", "m3", "truck"] {
        let sim = dir.path().join(format!("sim_{model}.csv"));
        let res = airsus(&[
            "simulate",
            "--model",
            model,
            "--truck",
            truck.to_str().unwrap(),
            "--run",
            run.to_str().unwrap(),
            "--out",
            sim.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&res.stderr);
        assert!(res.status.success(), "{model}: {stderr}");
        assert!(
            stderr.contains("NRMSE against the run's measurements"),
            "{stderr}"
        );
        let simulated = airsus_data::read_run(&sim).unwrap();
        let original = airsus_data::read_run(&run).unwrap();
        assert_eq!(simulated.len(), original.len());
        assert_eq!(
            simulated.inputs, original.inputs,
            "inputs are copied unchanged"
        );
        let height = &simulated.outputs.unwrap().sensor_height_m;
        if model != "m3" {
            // Physical models start at the measured ride height and sag under load.
            assert!((height[0] - 0.235).abs() < 1e-3, "{model}: {}", height[0]);
            assert!(
                height[3000] < height[1000] - 0.01,
                "{model}: loading lowers the truck"
            );
        }
    }
}

#[test]
fn simulate_rejects_an_unknown_model_with_a_suggestion() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    assert!(airsus(&["generate", "--out", out]).status.success());
    let truck = dir.path().join("truck.toml");
    let run = dir.path().join("ds3.csv");
    let res = airsus(&[
        "simulate",
        "--model",
        "m22",
        "--truck",
        truck.to_str().unwrap(),
        "--run",
        run.to_str().unwrap(),
        "--out",
        dir.path().join("x.csv").to_str().unwrap(),
    ]);
    assert!(!res.status.success());
    let stderr = String::from_utf8_lossy(&res.stderr);
    assert!(
        stderr.contains("unknown model `m22`") && stderr.contains("did you mean"),
        "{stderr}"
    );
    assert!(
        !dir.path().join("x.csv").exists(),
        "nothing written on failure"
    );
}
