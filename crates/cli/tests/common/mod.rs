//! Helpers shared by the command-line tests: run the binary, demand success, read back the
//! fit it prints.
#![allow(dead_code)] // each test file uses its own subset

use std::process::{Command, Output};

pub fn airsus(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_airsus"))
        .args(args)
        .output()
        .expect("the airsus binary runs")
}

/// Runs `airsus args`, fails the test with its stderr unless it succeeds; (stdout, stderr).
pub fn ok(args: &[&str]) -> (String, String) {
    let out = airsus(args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "airsus {}: {stderr}", args.join(" "));
    (String::from_utf8_lossy(&out.stdout).into_owned(), stderr)
}

/// The NRMSE of `output` (`height` or `pressure`) that `airsus simulate` prints, percent.
pub fn printed_nrmse(stderr: &str, output: &str) -> f64 {
    let tail = stderr
        .split(&format!("{output} "))
        .last()
        .unwrap_or_else(|| panic!("no {output} NRMSE in: {stderr}"));
    tail.split(' ')
        .next()
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no {output} NRMSE in: {stderr}"))
}

/// The virtual truck's reference study (seed 1) in a fresh folder, and a path maker for it.
pub fn generated() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    ok(&["generate", "--out", dir.path().to_str().unwrap()]);
    dir
}

/// `dir/name` as a string argument.
pub fn path(dir: &tempfile::TempDir, name: &str) -> String {
    dir.path().join(name).to_str().unwrap().to_owned()
}
