//! Both controllers on both scenarios on a few plants: `cargo run -p airsus-apps --example control_study`.
use airsus_apps::control::*;
use airsus_data::TruckParameters;
use airsus_model::build_model;
use airsus_truck::model::{SupplyMode, TruckModel};
use airsus_truck::truth::VirtualTruck;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let nominal = TruckParameters::reference();
    let rt = 8.314462618 * 293.15;
    for plant_name in ["m2", "truck"] {
        let plant = if plant_name == "truck" {
            Plant::Truck(Box::new(TruckModel::new(
                VirtualTruck::reference(),
                SupplyMode::Tank,
            )))
        } else {
            Plant::Model(build_model(plant_name, &nominal)?)
        };
        for scen in SCENARIO_NAMES {
            let s = level_scenario(scen, 0.240, 3390.0)?;
            let g = GuardSettings::default();
            let mut ctrls: Vec<Box<dyn LevelController>> = vec![
                Box::new(DeadbandController::new(g.clone())),
                Box::new(PredictiveController::new(
                    g.clone(),
                    ValveModel::from_truck(&nominal),
                )),
            ];
            for c in ctrls.iter_mut() {
                let t0 = std::time::Instant::now();
                let run =
                    simulate_closed_loop(&plant, c.as_mut(), &s, &ClosedLoopConfig::default())?;
                let el = t0.elapsed().as_secs_f64();
                let sc = score(&run, &s.events_s, &g, rt, 101325.0);
                println!(
                    "{plant_name} {scen} {}: settle {:?} overshoot {:.1} mm steady {:.2} mm switches {} openings {} short {} rev {} quick {} air {:.3} mol ({:.1} l) exh {:.3} mol  [{el:.2} s]",
                    c.name(),
                    sc.worst_settling_time_s,
                    sc.max_overshoot_m * 1e3,
                    sc.max_steady_error_m * 1e3,
                    sc.switches,
                    sc.openings,
                    sc.short_openings,
                    sc.reversals,
                    sc.quick_reversals,
                    sc.air_filled_mol,
                    sc.air_filled_free_l,
                    sc.air_exhausted_mol
                );
                for seg in &sc.segments {
                    println!(
                        "    t={:.0} settle {:?} over {:.1} steady {:.2} maxdev {:.1}",
                        seg.start_s,
                        seg.settling_time_s,
                        seg.overshoot_m * 1e3,
                        seg.steady_error_m * 1e3,
                        seg.max_deviation_m * 1e3
                    );
                }
            }
        }
    }
    Ok(())
}
