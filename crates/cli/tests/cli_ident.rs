//! `airsus ident` end to end on a file with a known OE system.

use std::fmt::Write as _;
use std::process::Command;

/// y(t) = 0.8 y(t-1) + 0.5 u(t-1) in OE form (B = 0.5 q^-1, F = 1 - 0.8 q^-1), plus small
/// output noise; u a pseudo-random binary signal from a fixed LCG, so the file is the same on
/// every run.
fn oe_csv() -> String {
    let mut state: u64 = 2024;
    let mut rand = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut text = String::from("time_s,u_in,y_out\n");
    let (mut x, mut u_prev) = (0.0, 0.0);
    for t in 0..2000 {
        x = 0.8 * x + 0.5 * u_prev;
        let u = if rand() < 0.5 { -1.0 } else { 1.0 };
        let y = x + 0.01 * (rand() - 0.5);
        let _ = writeln!(text, "{},{},{}", f64::from(t) * 0.1, u, y);
        u_prev = u;
    }
    text
}

fn run_ident(extra: &[&str]) -> (bool, String, String) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("oe.csv");
    std::fs::write(&path, oe_csv()).unwrap();
    let mut args = vec![
        "ident",
        "--structure",
        "oe",
        "--nb",
        "1",
        "--nf",
        "1",
        "--nk",
        "1",
        "--inputs",
        "u_in",
        "--output",
        "y_out",
    ];
    args.extend_from_slice(extra);
    args.push(path.to_str().unwrap());
    airsus(&args)
}

/// `airsus ARGS`: whether it succeeded, its stdout and its stderr.
fn airsus<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_airsus"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

#[test]
fn ident_json_recovers_the_oe_coefficients() {
    let (ok, stdout, stderr) = run_ident(&["--json"]);
    assert!(ok, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let text = json.to_string();
    let params = json["estimate"]["parameters"]
        .as_array()
        .unwrap_or_else(|| panic!("no parameters in {text}"));
    let value = |name: &str| {
        params
            .iter()
            .find(|p| p["name"].as_str().is_some_and(|n| n.starts_with(name)))
            .and_then(|p| p["value"].as_f64())
            .unwrap_or_else(|| panic!("{name} missing in {text}"))
    };
    assert!((value("b1") - 0.5).abs() < 0.005, "{text}");
    assert!((value("f1") + 0.8).abs() < 0.005, "{text}");
}

#[test]
fn ident_prints_a_toolbox_style_estimate() {
    let (ok, stdout, stderr) = run_ident(&[]);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("B(z) = 0.4999 (±"), "{stdout}");
    assert!(stdout.contains("F(z) = 1 - 0.800"), "{stdout}");
    assert!(stdout.contains("FPE"), "{stdout}");
}

#[test]
fn ident_names_a_missing_column() {
    let (ok, _, stderr) = run_ident(&["--inputs", "u_inn"]);
    assert!(!ok);
    assert!(stderr.contains("u_inn"), "{stderr}");
}

/// `--merge`: a loading-like run whose two inputs move together and a valve-like run whose
/// first input is held, of the system `y = 0.5/(1 − 0.8 q⁻¹) u1(t−1) + 0.3/(1 − 0.8 q⁻¹)
/// u2(t−1)`. Neither file determines both paths; merged, the OE and the ARX estimates
/// recover them.
#[test]
fn ident_merges_runs_that_each_excite_part_of_the_model() {
    let mut state: u64 = 77;
    let mut rand = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    // `u2 = gain · u1 + own`: the loading run has gain 0.8 and no own part, the valve run
    // gain 0 and u1 held at 0.
    let mut file = |gain: f64, own: f64, held: bool| {
        let mut text = String::from("time_s,u1,u2,y\n");
        let (mut x1, mut x2, mut u1_prev, mut u2_prev) = (0.0, 0.0, 0.0, 0.0);
        let mut u1 = 0.0;
        for t in 0..3000 {
            x1 = 0.8 * x1 + 0.5 * u1_prev;
            x2 = 0.8 * x2 + 0.3 * u2_prev;
            if !held && rand() < 0.05 {
                u1 = if rand() < 0.5 { -1.0 } else { 1.0 };
            }
            let u2 = gain * u1 + own * (rand() - 0.5);
            let y = x1 + x2 + 0.1 * (rand() - 0.5);
            let _ = writeln!(text, "{},{},{},{}", f64::from(t) * 0.1, u1, u2, y);
            (u1_prev, u2_prev) = (u1, u2);
        }
        text
    };
    let dir = tempfile::tempdir().unwrap();
    let loading = dir.path().join("loading.csv");
    let valve = dir.path().join("valve.csv");
    std::fs::write(&loading, file(0.8, 0.0, false)).unwrap();
    std::fs::write(&valve, file(0.0, 2.0, true)).unwrap();
    let ident = |structure: &str, runs: &[&std::path::Path]| {
        let mut args: Vec<String> = [
            "ident",
            "--structure",
            structure,
            "--nb",
            "1",
            "--nk",
            "1",
            "--inputs",
            "u1,u2",
            "--output",
            "y",
            "--json",
        ]
        .map(str::to_owned)
        .to_vec();
        if structure != "arx" {
            args.extend(["--nf".to_owned(), "1".to_owned()]);
        } else {
            args.extend(["--na".to_owned(), "1".to_owned()]);
        }
        args.push(runs[0].to_str().unwrap().to_owned());
        for run in &runs[1..] {
            args.extend(["--merge".to_owned(), run.to_str().unwrap().to_owned()]);
        }
        airsus(&args)
    };
    let values = |stdout: &str| -> Vec<(String, f64)> {
        let json: serde_json::Value = serde_json::from_str(stdout).unwrap();
        json["estimate"]["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| {
                (
                    p["name"].as_str().unwrap().to_owned(),
                    p["value"].as_f64().unwrap(),
                )
            })
            .collect()
    };
    let truth = [
        ("b1(u1)", 0.5),
        ("b1(u2)", 0.3),
        ("f1(u1)", -0.8),
        ("f1(u2)", -0.8),
    ];
    let worst = |stdout: &str| {
        let got = values(stdout);
        truth
            .iter()
            .map(|(name, t)| {
                let v = got.iter().find(|(n, _)| n == name).unwrap().1;
                (v - t).abs()
            })
            .fold(0.0, f64::max)
    };
    let (ok, merged, stderr) = ident("oe", &[&loading, &valve]);
    assert!(ok, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&merged).unwrap();
    assert_eq!(json["merged"][0]["samples"], 3000, "{merged}");
    // Measured 0.0011.
    assert!(worst(&merged) < 0.02, "{merged}");
    // The loading run alone cannot tell the two paths apart, and says so.
    let (ok, _, stderr) = ident("oe", &[&loading]);
    assert!(!ok && stderr.contains("rank deficient"), "{stderr}");
    // ARX merges the same way (both paths share the pole 0.8: A = 1 − 0.8 q⁻¹); the
    // loading run alone is refused as well.
    let (ok, arx_merged, stderr) = ident("arx", &[&loading, &valve]);
    assert!(ok, "{stderr}");
    let got = values(&arx_merged);
    for (name, t) in [("a1", -0.8), ("b1(u1)", 0.5), ("b1(u2)", 0.3)] {
        let v = got.iter().find(|(n, _)| n == name).unwrap().1;
        // Measured within 0.002 (the output noise biases ARX a little).
        assert!((v - t).abs() < 0.02, "{name} {v}: {arx_merged}");
    }
    let (ok, _, stderr) = ident("arx", &[&loading]);
    assert!(!ok && stderr.contains("rank deficient"), "{stderr}");
}
