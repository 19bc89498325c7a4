//! Property tests: whatever bytes the readers are fed, they return `Ok` or `Err`, never panic.

use std::path::Path;

use airsus_data::run::parse_run;
use airsus_data::{Outputs, lab, study, truck};
use proptest::prelude::*;

/// Bytes that look a little like our files, so the generator reaches past the header checks.
fn csvish() -> impl Strategy<Value = Vec<u8>> {
    let cell = prop_oneof![
        Just("time_s".to_owned()),
        Just("wheel_load_kg".to_owned()),
        Just("valve".to_owned()),
        Just("supply_kpa".to_owned()),
        Just("height_mm".to_owned()),
        Just("pressure_kpa".to_owned()),
        Just("road_mm".to_owned()),
        Just("tank_kpa".to_owned()),
        Just("bellow_height_mm".to_owned()),
        Just("force_n".to_owned()),
        Just("NaN".to_owned()),
        Just("inf".to_owned()),
        Just("".to_owned()),
        Just("\"".to_owned()),
        any::<f64>().prop_map(|v| v.to_string()),
        (0u8..4).prop_map(|v| v.to_string()),
        (0u32..2000).prop_map(|v| format!("{}", f64::from(v) / 10.0)),
        "[ -~]{0,6}",
    ];
    let line = prop::collection::vec(cell, 0..8).prop_map(|cells| cells.join(","));
    prop::collection::vec(line, 0..12).prop_map(|lines| lines.join("\n").into_bytes())
}

fn feed_all(bytes: &[u8]) {
    let p = Path::new("fuzz.csv");
    let _ = parse_run(bytes, p, Outputs::Required);
    let _ = parse_run(bytes, p, Outputs::IfPresent);
    let _ = lab::parse_force_map(bytes, p);
    let _ = lab::parse_discharge(bytes, p);
    let text = String::from_utf8_lossy(bytes);
    let _ = truck::parse_truck(&text, Path::new("fuzz.toml"));
    let _ = study::parse_study(&text, Path::new("fuzz.toml"));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        feed_all(&bytes);
    }

    #[test]
    fn csv_like_bytes_never_panic(bytes in csvish()) {
        feed_all(&bytes);
    }

    #[test]
    fn toml_like_text_never_panics(lines in prop::collection::vec(
        prop_oneof![
            Just("[environment]".to_owned()), Just("[geometry]".to_owned()), Just("[damper]".to_owned()),
            Just("[[run]]".to_owned()), Just("[bellow]".to_owned()),
            "[a-z_]{1,12} = [-0-9.e]{1,8}",
            "[a-z_]{1,12} = \\[[-0-9., ]{0,20}\\]",
            "[a-z_]{1,8} = \"[a-z.]{0,8}\"",
        ], 0..20)) {
        feed_all(lines.join("\n").as_bytes());
    }
}

#[test]
fn a_well_formed_run_survives_the_same_entry_point() {
    // Guards the property tests against passing only because everything is rejected.
    let text = b"time_s,wheel_load_kg,valve,supply_kpa,height_mm,pressure_kpa\n0,2830,0,850,240,350\n0.1,2830,0,850,240,350\n";
    assert!(parse_run(text, Path::new("ok.csv"), Outputs::Required).is_ok());
}

/// Valid files of every kind, to mutate: a run, a force map, a discharge, a truck file (the
/// reference truck as the writer writes it) and a study file.
const VALID: [&str; 5] = [
    "time_s,wheel_load_kg,valve,supply_kpa,road_mm,height_mm,pressure_kpa\n0.0,2830.0,0,850,0.0,240.1,350.2\n0.1,2830.0,1,849,0.0,240.3,351.0\n0.2,3130.0,2,848,0.0,239.0,361.4\n0.3,3130.0,0,848,0.0,238.9,361.3\n",
    "bellow_height_mm,pressure_kpa,force_n\n250,200,10500\n250,400,21000\n300,200,11200\n300,400,22400\n350,200,11000\n350,400,22100\n",
    "time_s,tank_kpa\n0.0,800.0\n0.1,790.5\n0.2,781.2\n0.3,772.0\n0.4,763.1\n",
    "TRUCK",
    "truck = \"truck.toml\"\n[[run]]\nname = \"data-set 1\"\nfile = \"ds1.csv\"\nrole = \"estimation\"\n[force_map]\nfile = \"force_map.csv\"\n[[discharge]]\nfile = \"fill_a.csv\"\nchannel = \"fill\"\ntank_volume_l = 20.0\ntemperature_k = 293.15\nrole = \"estimation\"\n",
];

/// One edit of a valid file: what careless hands and broken loggers do.
#[derive(Debug, Clone)]
enum Mutation {
    DeleteByte(usize),
    InsertByte(usize, u8),
    ReplaceToken(usize, &'static str),
    Truncate(usize),
    DuplicateLine(usize),
    SwapLines(usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let token = prop_oneof![
        Just("NaN"),
        Just("-inf"),
        Just("1e308"),
        Just("-1e308"),
        Just("4.9e-324"),
        Just(""),
        Just(","),
        Just(",,,,"),
        Just("\""),
        Just("="),
        Just("["),
        Just("]"),
        Just("[[run]]"),
        Just("\r\n"),
        Just("\u{feff}"),
        Just("é"),
        Just("0x10"),
        Just("18446744073709551616"),
        Just("-0"),
        Just("3"),
    ];
    prop_oneof![
        any::<usize>().prop_map(Mutation::DeleteByte),
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Mutation::InsertByte(i, b)),
        (any::<usize>(), token).prop_map(|(i, t)| Mutation::ReplaceToken(i, t)),
        any::<usize>().prop_map(Mutation::Truncate),
        any::<usize>().prop_map(Mutation::DuplicateLine),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapLines(a, b)),
    ]
}

fn seed(which: usize) -> String {
    match VALID[which] {
        "TRUCK" => truck::truck_to_toml(&airsus_data::TruckParameters::reference()),
        text => text.to_owned(),
    }
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    let n = bytes.len().max(1);
    match *m {
        Mutation::DeleteByte(i) => {
            if !bytes.is_empty() {
                bytes.remove(i % n);
            }
        }
        Mutation::InsertByte(i, b) => bytes.insert(i % (bytes.len() + 1), b),
        Mutation::ReplaceToken(i, token) => {
            // Replace the run of non-separator bytes around position i (a cell or a value).
            let at = i % n;
            let is_sep = |c: u8| matches!(c, b',' | b'\n' | b' ' | b'=');
            let start = (0..at.min(bytes.len()))
                .rev()
                .find(|&k| is_sep(bytes[k]))
                .map_or(0, |k| k + 1);
            let end = (at..bytes.len())
                .find(|&k| is_sep(bytes[k]))
                .unwrap_or(bytes.len());
            if start <= end {
                bytes.splice(start..end, token.bytes());
            }
        }
        Mutation::Truncate(i) => bytes.truncate(i % n),
        Mutation::DuplicateLine(i) | Mutation::SwapLines(i, _) => {
            let text = String::from_utf8_lossy(bytes).into_owned();
            let mut lines: Vec<&str> = text.split('\n').collect();
            let k = i % lines.len();
            match *m {
                Mutation::DuplicateLine(_) => lines.insert(k, lines[k]),
                Mutation::SwapLines(_, j) => {
                    let j = j % lines.len();
                    lines.swap(k, j);
                }
                _ => {}
            }
            *bytes = lines.join("\n").into_bytes();
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    /// Near-valid files of every kind (one to four edits of a valid one) through every
    /// reader: an error or a value, never a panic; and quickly (each case is a few hundred
    /// bytes, so a hang or a runaway allocation would show as a stalled test).
    #[test]
    fn near_valid_files_never_panic(
        which in 0..VALID.len(),
        mutations in prop::collection::vec(mutation(), 1..5),
    ) {
        let mut bytes = seed(which).into_bytes();
        for m in &mutations {
            apply(&mut bytes, m);
        }
        let started = std::time::Instant::now();
        feed_all(&bytes);
        prop_assert!(started.elapsed() < std::time::Duration::from_secs(2));
    }
}

#[test]
fn the_valid_seeds_are_valid() {
    // Without this the mutation test could pass on seeds every reader rejects outright.
    let p = Path::new("seed.csv");
    assert!(parse_run(VALID[0].as_bytes(), p, Outputs::Required).is_ok());
    assert!(lab::parse_force_map(VALID[1].as_bytes(), p).is_ok());
    assert!(lab::parse_discharge(VALID[2].as_bytes(), p).is_ok());
    let truck = truck::parse_truck(&seed(3), Path::new("truck.toml"));
    assert!(truck.is_ok(), "{:?}", truck.err().map(|e| e.to_string()));
    let study = study::parse_study(VALID[4], Path::new("/data/study.toml"));
    assert!(study.is_ok(), "{:?}", study.err().map(|e| e.to_string()));
}
