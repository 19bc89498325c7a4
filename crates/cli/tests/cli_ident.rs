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
    let out = Command::new(env!("CARGO_BIN_EXE_airsus"))
        .args(&args)
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
