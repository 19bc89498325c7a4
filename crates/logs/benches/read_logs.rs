//! Reading 10 h of 100 Hz logs (3.6 M samples × 7 channels) into a run, from MDF4 (as a
//! logger writes it: one channel group, float64 channels) and from Parquet (as airsus writes
//! it: snappy), beside a DZ-compressed MDF4 and the contract's CSV. Issue target: under 0.5 s each for MDF4 and
//! Parquet. The files are written once into a temporary folder before timing.
//!
//!     cargo bench -p airsus-logs --bench read_logs

use std::hint::black_box;
use std::path::Path;

use airsus_data::{Run, RunInputs, RunOutputs, ValveState};
use criterion::{Criterion, criterion_group, criterion_main};
use falcon_mdf::write::Mf4Writer;

const SAMPLES: usize = 3_600_000;
const SAMPLE_S: f64 = 0.01;

/// A 10 h run with load steps, valve pulses and a moving suspension.
fn long_run() -> Run {
    let time_s: Vec<f64> = (0..SAMPLES).map(|k| k as f64 * SAMPLE_S).collect();
    let load: Vec<f64> = time_s
        .iter()
        .map(|t| 3000.0 + 500.0 * ((t / 600.0).floor() % 3.0))
        .collect();
    let valve: Vec<ValveState> = time_s
        .iter()
        .map(|t| match (t / 7.0) as u64 % 10 {
            0 => ValveState::Fill,
            5 => ValveState::Exhaust,
            _ => ValveState::Closed,
        })
        .collect();
    let supply: Vec<f64> = time_s
        .iter()
        .map(|t| 850e3 + 5e3 * (t / 30.0).sin())
        .collect();
    let height: Vec<f64> = time_s
        .iter()
        .map(|t| 0.235 + 0.01 * (t / 11.0).sin())
        .collect();
    let pressure: Vec<f64> = time_s
        .iter()
        .map(|t| 330e3 + 20e3 * (t / 13.0).cos())
        .collect();
    Run {
        name: "ten_hours".to_owned(),
        sample_time_s: SAMPLE_S,
        inputs: RunInputs {
            wheel_load_kg: load,
            valve,
            supply_gauge_pa: supply,
            road_height_m: vec![0.0; SAMPLES],
        },
        outputs: Some(RunOutputs {
            sensor_height_m: height,
            bellow_gauge_pa: pressure,
        }),
        time_s,
    }
}

/// The run as a logger's MDF4: file units, float64 channels, one channel group.
fn write_mdf4(run: &Run, path: &Path, compressed: bool) {
    let mut writer = Mf4Writer::new();
    writer.set_compression(compressed);
    let group = writer.add_group(&run.time_s).unwrap();
    let i = &run.inputs;
    let o = run.outputs.as_ref().unwrap();
    let kpa = |pa: &[f64]| pa.iter().map(|p| p / 1e3).collect::<Vec<_>>();
    let mm = |m: &[f64]| m.iter().map(|x| x * 1e3).collect::<Vec<_>>();
    let valve: Vec<f64> = i.valve.iter().map(|v| f64::from(v.code())).collect();
    group
        .add_channel("wheel_load_kg", "kg", &i.wheel_load_kg)
        .unwrap();
    group.add_channel("valve", "", &valve).unwrap();
    group
        .add_channel("supply_kpa", "kPa", &kpa(&i.supply_gauge_pa))
        .unwrap();
    group
        .add_channel("road_mm", "mm", &mm(&i.road_height_m))
        .unwrap();
    group
        .add_channel("height_mm", "mm", &mm(&o.sensor_height_m))
        .unwrap();
    group
        .add_channel("pressure_kpa", "kPa", &kpa(&o.bellow_gauge_pa))
        .unwrap();
    writer.write_to_file(path).unwrap();
}

fn read(path: &Path) -> Run {
    airsus_logs::read_plain_run(path).unwrap()
}

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let run = long_run();
    let mdf4 = dir.path().join("ten_hours.mf4");
    let mdf4_dz = dir.path().join("ten_hours_dz.mf4");
    let parquet = dir.path().join("ten_hours.parquet");
    let csv = dir.path().join("ten_hours.csv");
    write_mdf4(&run, &mdf4, false);
    write_mdf4(&run, &mdf4_dz, true);
    airsus_logs::write_run(&parquet, &run).unwrap();
    airsus_data::write_run(&csv, &run).unwrap();
    for path in [&mdf4, &mdf4_dz, &parquet, &csv] {
        let size = std::fs::metadata(path).unwrap().len();
        let back = read(path);
        assert_eq!(back.len(), SAMPLES);
        eprintln!("{}: {:.0} MB", path.display(), size as f64 / 1e6);
    }

    let mut group = c.benchmark_group("read 10 h at 100 Hz");
    group.sample_size(10);
    group.bench_function("MDF4", |b| b.iter(|| black_box(read(&mdf4))));
    group.bench_function("MDF4, DZ (deflate)", |b| {
        b.iter(|| black_box(read(&mdf4_dz)))
    });
    group.bench_function("Parquet", |b| b.iter(|| black_box(read(&parquet))));
    group.bench_function("CSV", |b| b.iter(|| black_box(read(&csv))));
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
