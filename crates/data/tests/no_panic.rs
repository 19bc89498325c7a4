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
