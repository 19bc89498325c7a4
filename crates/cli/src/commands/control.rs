//! `airsus control`: level controllers for the 3-state valve in closed loop.

use airsus_data::atomic::refuse_overwriting_inputs;
use std::path::PathBuf;

use anyhow::Context;

use airsus_apps::control::{
    ClosedLoopConfig, DeadbandController, GuardSettings, LevelController, Plant,
    PredictiveController, SCENARIO_NAMES, ValveModel, level_scenario, score, simulate_closed_loop,
};
use airsus_apps::plot::plot_closed_loop;
use airsus_data::read_truck;
use airsus_truck::model::{SupplyMode, TruckModel};
use airsus_truck::truth::VirtualTruck;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ControllerChoice {
    Deadband,
    Predictive,
    Both,
}

/// Simulate ride-height controllers in closed loop (the controller reads quantised, noisy
/// sensors every 100 ms) and report settling, overshoot, steady error, valve switches and air.
#[derive(Debug, Clone, clap::Args)]
pub struct ControlArgs {
    /// Truck parameter file the controllers are designed on: what the predictive controller
    /// believes (the nominal file, or one a study estimated).
    #[arg(long, value_name = "T.toml")]
    pub truck: PathBuf,
    /// The plant the controllers are tried on: `variant:K`, member K of the virtual truck
    /// family (its true laws and values, with a simulated supply tank and compressor; 0 is the
    /// built-in truck the reference experiments come from), or a truck file simulated with
    /// `--model`. The default is a truck the controllers were not designed on: the member
    /// after the one of variants 0-7 the --truck file is nearest (by its effective area,
    /// gas volume, unsprung mass and valve flows; variant 1 for the nominal file).
    #[arg(long, value_name = "variant:K | P.toml")]
    pub plant: Option<String>,
    /// Target sensor height, mm.
    #[arg(long, default_value_t = 240.0)]
    pub target_mm: f64,
    /// load-steps, height-change or road.
    #[arg(long, default_value = "load-steps")]
    pub scenario: String,
    /// The model a `--plant` truck file is simulated with (`airsus models`; default
    /// `truck`). A `variant:K` plant is the virtual truck itself: no model applies.
    #[arg(long)]
    pub model: Option<String>,
    #[arg(long, value_enum, default_value_t = ControllerChoice::Both)]
    pub controller: ControllerChoice,
    /// Half-width of the tolerance band around the target, mm.
    #[arg(long, default_value_t = 5.0)]
    pub band_mm: f64,
    /// Wheel load at the start, kg.
    #[arg(long, default_value_t = 3390.0)]
    pub load_kg: f64,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Plot file (.svg, otherwise PNG).
    #[arg(long, value_name = "out.svg")]
    pub plot: Option<PathBuf>,
}

pub fn run(args: &ControlArgs) -> anyhow::Result<()> {
    if let Some(plot) = &args.plot {
        let mut inputs = vec![args.truck.clone()];
        inputs.extend(args.plant.as_ref().map(PathBuf::from));
        let inputs: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
        refuse_overwriting_inputs(plot, &inputs)?;
    }
    let truck = read_truck(&args.truck)
        .with_context(|| format!("reading truck file {}", args.truck.display()))?
        .parameters;
    let plant_arg = match &args.plant {
        Some(plant) => plant.clone(),
        None => {
            let (design, distance) = VirtualTruck::nearest_variant(&truck, 0..=FAMILY_LAST);
            let plant = (design + 1) % (FAMILY_LAST + 1);
            println!(
                "plant: virtual truck variant {plant} (--plant not given: {} is nearest variant {design}, {:.1} % apart, so the controllers are tried on the next member)",
                args.truck.display(),
                distance * 100.0
            );
            format!("variant:{plant}")
        }
    };
    let (plant, plant_name) = build_plant(&plant_arg, args.model.as_deref())?;
    let scenario = level_scenario(&args.scenario, args.target_mm * 1e-3, args.load_kg)
        .with_context(|| format!("scenarios: {}", SCENARIO_NAMES.join(", ")))?;
    if !(args.band_mm.is_finite() && args.band_mm > 0.0) {
        anyhow::bail!(
            "--band-mm {}: expected a positive half-width in mm",
            args.band_mm
        );
    }
    let guard = GuardSettings {
        tolerance_m: args.band_mm * 1e-3,
        ..GuardSettings::default()
    };
    let mut controllers: Vec<Box<dyn LevelController>> = Vec::new();
    if matches!(
        args.controller,
        ControllerChoice::Deadband | ControllerChoice::Both
    ) {
        controllers.push(Box::new(DeadbandController::new(guard.clone())));
    }
    if matches!(
        args.controller,
        ControllerChoice::Predictive | ControllerChoice::Both
    ) {
        controllers.push(Box::new(PredictiveController::new(
            guard.clone(),
            ValveModel::from_truck(&truck),
        )));
    }
    let config = ClosedLoopConfig {
        seed: args.seed,
        ..ClosedLoopConfig::default()
    };
    let rt = truck.environment.gas_constant_j_mol_k * truck.environment.temperature_k;
    let ambient = truck.environment.ambient_pressure_pa;
    println!(
        "scenario {} on {} ({} s), designed on {}, target {:.1} mm, band ±{:.1} mm, min on-time {:.1} s, rest {:.1} s, reversal lock-out {:.0} s",
        scenario.name,
        plant_name,
        scenario.time_s.last().copied().unwrap_or(0.0),
        args.truck.display(),
        args.target_mm,
        guard.tolerance_m * 1e3,
        guard.min_on_s,
        guard.min_rest_s,
        guard.reversal_lockout_s
    );
    println!(
        "{:<11} {:>10} {:>10} {:>10} {:>9} {:>9} {:>6} {:>10} {:>10} {:>10} {:>9}",
        "controller",
        "settle s",
        "oversh mm",
        "steady mm",
        "switches",
        "openings",
        "rev",
        "fill mol",
        "fill l",
        "exh mol",
        "out s"
    );
    let mut runs = Vec::new();
    for c in controllers.iter_mut() {
        let run = simulate_closed_loop(&plant, c.as_mut(), &scenario, &config)
            .with_context(|| format!("closed loop with the {} controller", c.name()))?;
        let s = score(&run, &scenario.events_s, &guard, rt, ambient);
        println!(
            "{:<11} {:>10} {:>10.1} {:>10.2} {:>9} {:>9} {:>6} {:>10.3} {:>10.1} {:>10.3} {:>9.1}",
            c.name(),
            s.worst_settling_time_s
                .map_or("never".to_owned(), |t| format!("{t:.1}")),
            s.max_overshoot_m * 1e3,
            s.max_steady_error_m * 1e3,
            s.switches,
            s.openings,
            s.reversals,
            s.air_filled_mol,
            s.air_filled_free_l,
            s.air_exhausted_mol,
            s.time_outside_band_s
        );
        for seg in &s.segments {
            println!(
                "    event at {:>5.0} s: max deviation {:>5.1} mm, settled after {:>6}, overshoot {:>4.1} mm, steady error {:+.2} mm",
                seg.start_s,
                seg.max_deviation_m * 1e3,
                seg.settling_time_s
                    .map_or("never".to_owned(), |t| format!("{t:.1} s")),
                seg.overshoot_m * 1e3,
                seg.steady_error_m * 1e3
            );
        }
        if s.short_openings > 0 || s.quick_reversals > 0 {
            println!(
                "    warning: {} openings shorter than the minimum on-time, {} reversals within the lock-out",
                s.short_openings, s.quick_reversals
            );
        }
        runs.push(run);
    }
    if let Some(path) = &args.plot {
        plot_closed_loop(
            path,
            &runs,
            guard.tolerance_m,
            &format!("{} on {plant_name}", scenario.name),
        )?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

/// The last member of the virtual truck family the default plant is chosen from.
const FAMILY_LAST: u32 = 7;

/// The plant of `--plant`: a virtual truck variant (`variant:K`) or a truck file simulated
/// with `model`; and how to name it.
fn build_plant(plant: &str, model: Option<&str>) -> anyhow::Result<(Plant, String)> {
    if let Some(k) = plant.strip_prefix("variant:") {
        // Said, not ignored: a user who names a model expects the plant to be simulated with it.
        if let Some(model) = model {
            anyhow::bail!(
                "--model {model} applies to a truck-file plant; --plant {plant} is the virtual truck itself, simulated with its own laws (give --plant a truck file to simulate it with {model})"
            );
        }
        let k: u32 = k.trim().parse().with_context(|| {
            format!(
                "--plant {plant}: expected variant:K with K a whole number (0 = the built-in truck)"
            )
        })?;
        let truck = TruckModel::new(VirtualTruck::variant(k), SupplyMode::Tank);
        return Ok((
            Plant::Truck(Box::new(truck)),
            format!("virtual truck variant {k}"),
        ));
    }
    let path = PathBuf::from(plant);
    let truck = read_truck(&path)
        .with_context(|| {
            format!(
                "reading the plant's truck file {plant} (--plant takes variant:K or a truck file)"
            )
        })?
        .parameters;
    let model = airsus_truck::models::build_any_model(model.unwrap_or("truck"), &truck)?;
    let name = format!("{} with {}", model.name(), path.display());
    Ok((Plant::Model(model), name))
}
