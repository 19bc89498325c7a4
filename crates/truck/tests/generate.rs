//! `generate`: the reference study follows the data contract, looks like the thesis' truck,
//! and is byte-for-byte reproducible from its seed.

use std::path::Path;

use airsus_data::{
    Role, ValveState, read_discharge, read_force_map, read_run, read_study, read_truck,
};
use airsus_truck::experiments::generate;

fn generate_into(dir: &Path, seed: u64) -> airsus_truck::experiments::GeneratedStudy {
    let mut steps = Vec::new();
    let study = generate(dir, seed, &mut |s: &str| steps.push(s.to_owned())).unwrap();
    assert!(
        steps.len() >= 9,
        "progress reported step by step: {steps:?}"
    );
    study
}

fn std_dev(x: &[f64]) -> f64 {
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
}

#[test]
fn the_study_follows_the_data_contract_and_looks_like_the_thesis_truck() {
    let dir = tempfile::tempdir().unwrap();
    let generated = generate_into(dir.path(), 1);

    // Every file loads back through the public readers.
    let study = read_study(&generated.study).unwrap();
    let estimated = |study: &airsus_data::Study| -> Vec<String> {
        study
            .runs
            .iter()
            .filter(|r| r.role == Role::Estimation)
            .map(|r| r.name.clone())
            .collect()
    };
    // The thesis' four data-sets, then the levelling and road runs; the thesis protocol
    // estimates on data-set 1, ours on a loading, a valve, a levelling and a road run.
    let files: Vec<_> = study
        .runs
        .iter()
        .map(|r| r.file.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        files,
        [
            "ds1.csv",
            "ds2.csv",
            "ds3.csv",
            "ds4.csv",
            "lev1.csv",
            "lev2.csv",
            "road1.csv",
            "road2.csv"
        ]
    );
    assert!(study.runs.iter().all(|r| r.truth.is_some()));
    assert_eq!(estimated(&study), ["data-set 1"]);
    let valve_study = read_study(&generated.study_valve).unwrap();
    assert_eq!(
        estimated(&valve_study),
        ["data-set 1", "data-set 3", "levelling 1", "road 1"]
    );
    let nominal = read_truck(&study.truck).unwrap();
    assert_eq!(
        nominal.parameters,
        airsus_data::TruckParameters::reference()
    );
    assert_eq!(
        read_force_map(study.force_map.as_ref().unwrap())
            .unwrap()
            .len(),
        182
    );
    assert_eq!(study.discharges.len(), 4);
    for d in &study.discharges {
        assert!(read_discharge(&d.file).unwrap().time_s.len() > 1000);
    }
    let runs: Vec<_> = study
        .runs
        .iter()
        .map(|r| read_run(&r.file).unwrap())
        .collect();
    let truths: Vec<_> = ["ds1", "ds2", "ds3", "ds4"]
        .iter()
        .map(|n| read_run(&dir.path().join("truth").join(format!("{n}.csv"))).unwrap())
        .collect();
    assert_eq!(runs[0].len(), 15_001);
    // The truth of the extra effects, keyed by the truck model's parameter names, parses.
    let effects = std::fs::read_to_string(dir.path().join("truth/effects.toml")).unwrap();
    let effects: toml::Table = effects.parse().unwrap();
    let kap = effects["parameters"]["kap"].as_float().unwrap();
    assert_eq!(
        kap,
        airsus_truck::truth::VirtualTruck::reference()
            .effect_parameters
            .area_pressure_coefficient
    );

    // Sensors: 0.1 mm and 0.1 kPa grids, noise as configured (0.15 mm and 0.2 kPa, plus the
    // quantisation's res²/12).
    let (ds1, truth1) = (
        runs[0].outputs.as_ref().unwrap(),
        truths[0].outputs.as_ref().unwrap(),
    );
    let on_grid = |v: f64, res: f64| ((v / res) - (v / res).round()).abs() < 1e-6;
    assert!(ds1.sensor_height_m.iter().all(|&h| on_grid(h, 1e-4)));
    assert!(ds1.bellow_gauge_pa.iter().all(|&p| on_grid(p, 100.0)));
    let height_noise: Vec<f64> = ds1
        .sensor_height_m
        .iter()
        .zip(&truth1.sensor_height_m)
        .map(|(m, t)| m - t)
        .collect();
    let expected = (0.15e-3f64.powi(2) + 1e-8 / 12.0).sqrt();
    assert!(
        (std_dev(&height_noise) / expected - 1.0).abs() < 0.05,
        "height noise {}",
        std_dev(&height_noise)
    );
    let pressure_noise: Vec<f64> = ds1
        .bellow_gauge_pa
        .iter()
        .zip(&truth1.bellow_gauge_pa)
        .map(|(m, t)| m - t)
        .collect();
    let expected = (200f64.powi(2) + 1e4 / 12.0).sqrt();
    assert!(
        (std_dev(&pressure_noise) / expected - 1.0).abs() < 0.05,
        "pressure noise {}",
        std_dev(&pressure_noise)
    );

    // Plausible operating point: ride height ≈ 235 mm, pressure a few hundred kPa, supply ≈ 850 kPa.
    assert!((truth1.sensor_height_m[0] - 0.235).abs() < 1e-9);
    assert!(
        (300e3..450e3).contains(&truth1.bellow_gauge_pa[0]),
        "{}",
        truth1.bellow_gauge_pa[0]
    );
    assert!((runs[0].inputs.supply_gauge_pa[0] - 850e3).abs() < 5e3);

    // After the first load step (logged at 120 s) the height keeps creeping for tens of seconds.
    let h = &truth1.sensor_height_m;
    let creep = h[1200 + 100] - h[1200 + 900];
    assert!(
        (1e-3..8e-3).contains(&creep),
        "creep between 10 s and 90 s after the step: {creep} m"
    );

    // Data-set 4: the first long fill raises the truck a few mm/s.
    let ds4 = &runs[3];
    let truth4 = truths[3].outputs.as_ref().unwrap();
    let start = ds4
        .inputs
        .valve
        .iter()
        .position(|&v| v == ValveState::Fill)
        .unwrap();
    let rate = (truth4.sensor_height_m[start + 50] - truth4.sensor_height_m[start]) / 5.0;
    assert!((1e-3..8e-3).contains(&rate), "fill rate {rate} m/s");
    // The supply tank droops while the valve fills.
    let supply = &truths[3].inputs.supply_gauge_pa;
    assert!(
        supply[start] - supply[start + 80] > 20e3,
        "tank droop {}",
        supply[start] - supply[start + 80]
    );

    // Hysteresis: data-sets 1 and 3 start at the same height with different pressures.
    let p1 = truth1.bellow_gauge_pa[0];
    let p3 = truths[2].outputs.as_ref().unwrap().bellow_gauge_pa[0];
    assert!((p1 - p3).abs() > 2e3, "{p1} vs {p3}");
    assert!((truths[2].outputs.as_ref().unwrap().sensor_height_m[0] - 0.235).abs() < 1e-9);
}

#[test]
fn measurement_files_carry_the_sensor_resolution_without_float_artefacts() {
    let dir = tempfile::tempdir().unwrap();
    generate_into(dir.path(), 3);
    // Decimals per column as the sensors resolve them: time (100 ms clock) 1, load 1,
    // valve 0, supply (1 kPa) 0, road 2, height (0.1 mm) 1, pressure (0.1 kPa) 1.
    let max_decimals = [1usize, 1, 0, 0, 2, 1, 1];
    for name in ["ds1", "ds2", "ds3", "ds4", "lev1", "lev2", "road1", "road2"] {
        let path = dir.path().join(format!("{name}.csv"));
        let text = std::fs::read_to_string(&path).unwrap();
        let mut lines = text.lines();
        assert_eq!(
            lines.next(),
            Some("time_s,wheel_load_kg,valve,supply_kpa,road_mm,height_mm,pressure_kpa")
        );
        for (k, line) in lines.enumerate() {
            for (col, (cell, &most)) in line.split(',').zip(&max_decimals).enumerate() {
                let decimals = cell.split_once('.').map_or(0, |(_, f)| f.len());
                assert!(
                    decimals <= most && !(cell.starts_with('-') && cell.parse() == Ok(0.0)),
                    "{name}.csv:{}:{}: `{cell}` has {decimals} decimals, the sensor {most}",
                    k + 2,
                    col + 1
                );
            }
        }
        // The values are the quantised ones, not merely rounded for show: reading the file
        // back lands on the same 0.1 mm grid the sensor model produced.
        let run = read_run(&path).unwrap();
        let heights = &run.outputs.as_ref().unwrap().sensor_height_m;
        assert!(
            heights
                .iter()
                .all(|h| ((h * 1e4) - (h * 1e4).round()).abs() < 1e-6)
        );
    }
}

#[test]
fn same_seed_same_bytes_and_another_seed_other_bytes() {
    let (a, b, c) = (
        tempfile::tempdir().unwrap(),
        tempfile::tempdir().unwrap(),
        tempfile::tempdir().unwrap(),
    );
    let files_a = generate_into(a.path(), 7).files;
    generate_into(b.path(), 7);
    generate_into(c.path(), 8);
    let mut differing = 0;
    for file in &files_a {
        let rel = file.strip_prefix(a.path()).unwrap();
        let bytes_a = std::fs::read(file).unwrap();
        assert_eq!(
            bytes_a,
            std::fs::read(b.path().join(rel)).unwrap(),
            "{} differs for the same seed",
            rel.display()
        );
        if bytes_a != std::fs::read(c.path().join(rel)).unwrap() {
            differing += 1;
        }
    }
    // Logged runs, truths, force map and discharges all depend on the seed.
    assert!(
        differing >= 12,
        "only {differing} files changed with the seed"
    );
}

#[test]
fn a_variant_is_generated_from_its_own_truth_and_the_same_nominal_start() {
    use airsus_truck::truth::VirtualTruck;
    let dir = tempfile::tempdir().unwrap();
    let generated =
        airsus_truck::experiments::generate_variant(dir.path(), 1, 3, &mut |_: &str| {}).unwrap();
    let study = read_study(&generated.study).unwrap();
    // The study starts from the same nominal guess as for the reference truck ...
    assert_eq!(
        read_truck(&study.truck).unwrap().parameters,
        airsus_data::TruckParameters::reference()
    );
    // ... while the truth is the variant's: its values, its valve law (variant 3 flows
    // through linear resistances), and the variant named in the effects file.
    let variant = VirtualTruck::variant(3);
    let truth = read_truck(&dir.path().join("truth/truck.toml"))
        .unwrap()
        .parameters;
    assert_eq!(truth.mass.unsprung_kg, variant.physical.mass.unsprung_kg);
    assert_eq!(
        truth.bellow.effective_area,
        variant.physical.bellow.effective_area
    );
    let effects = std::fs::read_to_string(dir.path().join("truth/effects.toml")).unwrap();
    assert!(
        effects.starts_with("# Virtual truck variant 3"),
        "{effects}"
    );
    assert!(effects.contains("orifice_flow = false"), "{effects}");
    // Its measurements differ from the reference truck's under the same seed.
    let reference = tempfile::tempdir().unwrap();
    generate_into(reference.path(), 1);
    let a = read_run(&dir.path().join("ds3.csv")).unwrap();
    let b = read_run(&reference.path().join("ds3.csv")).unwrap();
    let (pa, pb) = (
        &a.outputs.as_ref().unwrap().bellow_gauge_pa,
        &b.outputs.as_ref().unwrap().bellow_gauge_pa,
    );
    let mean_gap = pa.iter().zip(pb).map(|(x, y)| (x - y).abs()).sum::<f64>() / pa.len() as f64;
    assert!(mean_gap > 2e3, "mean pressure difference {mean_gap} Pa");
}
