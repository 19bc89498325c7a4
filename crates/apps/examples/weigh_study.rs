//! Scores static and EKF weighing on a generated reference study (`airsus generate --out DIR`):
//! `cargo run -p airsus-apps --example weigh_study -- DIR`.
use std::path::PathBuf;
use std::time::Instant;

use airsus_apps::weigh::*;
use airsus_data::{read_run, read_truck};
use airsus_model::Model2;
use airsus_truck::model::{SupplyMode, TruckModel};
use airsus_truck::truth::VirtualTruck;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "/tmp/ref".into()));
    let nominal = read_truck(&dir.join("truck.toml"))?.parameters;
    let truth_params = read_truck(&dir.join("truth/truck.toml"))?.parameters;
    let vt = VirtualTruck::reference();
    let laws = [
        ("nominal", StaticLaw::from_truck(&nominal), nominal.clone()),
        (
            "true (thesis structure)",
            StaticLaw::from_truck(&truth_params),
            truth_params.clone(),
        ),
        (
            "true incl. wall stretch",
            StaticLaw::from_virtual_truck(&vt),
            truth_params.clone(),
        ),
    ];
    let rule = StandstillRule::default();
    for name in ["ds1", "ds2", "ds3", "ds4"] {
        let run = read_run(&dir.join(format!("{name}.csv")))?;
        let truth = read_run(&dir.join(format!("truth/{name}.csv")))?;
        for (label, law, params) in &laws {
            let w = StaticWeigher::new(law.clone(), WeighingUncertainty::default());
            let s = weigh_static(&run, &w, 20)?;
            let a = evaluate_series(&run, &truth.inputs.wheel_load_kg, &s, &rule)?;
            let t0 = Instant::now();
            let model: Box<dyn airsus_model::SuspensionModel> = if label.contains("stretch") {
                Box::new(TruckModel::new(vt.clone(), SupplyMode::Measured))
            } else {
                Box::new(Model2::new(params))
            };
            let e = weigh_ekf(&run, model, &w, &EkfTuning::default())?;
            let el = t0.elapsed().as_secs_f64();
            let b = evaluate_series(&run, &truth.inputs.wheel_load_kg, &e, &rule)?;
            for (m, acc) in [("static", &a), ("ekf", &b)] {
                println!(
                    "{name} {label:26} {m:6} standstill mean {:+.3}% max {:.3}% (n={}) | quiet {:+.3}% max {:.3}% | after-valve {:+.3}% max {:.3}% (n={}) | all rms {:.1} kg | std {:.1} kg",
                    acc.standstill.mean_error_percent,
                    acc.standstill.max_abs_error_percent,
                    acc.standstill.samples,
                    acc.quiet_standstill.mean_error_percent,
                    acc.quiet_standstill.max_abs_error_percent,
                    acc.after_valve.mean_error_percent,
                    acc.after_valve.max_abs_error_percent,
                    acc.after_valve.samples,
                    acc.all.rms_error_kg,
                    acc.standstill.mean_std_kg
                );
            }
            eprintln!("  ekf took {el:.2} s");
        }
    }
    Ok(())
}
