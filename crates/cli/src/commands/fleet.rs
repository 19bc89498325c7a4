//! `airsus fleet generate`: a virtual fleet as a Parquet dataset partitioned by truck.
//!
//! ```text
//! DIR/fleet.toml                                what was generated (trucks, days, seed, layout)
//! DIR/truck.toml                                the nominal truck file the fleet starts from
//! DIR/logs/truck_id=K/day-DDD.parquet           what truck K logged on day D, one row per
//!                                               100 ms sample
//! DIR/truth/trucks.csv                          per truck: variant, empty load, leak onset
//! DIR/truth/truck_id=K/truck.toml, effects.toml  the truck's true parameters
//! DIR/truth/loads/truck_id=K/day-DDD.parquet    the true wheel load, outputs and leak
//! ```
//! Log columns: `time_s` (s since midnight), `day`, `height_mm`, `pressure_kpa`, `valve`
//! (0/1/2), `supply_kpa`, `speed_kmh`, `ambient_temp_c`, `reference_load_kg` (null where the
//! load is not known). No wheel-load column: a truck does not log its load.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

use airsus_apps::fleet::{
    FleetSpec, FleetTruck, SAMPLE_TIME_S, TruckDayLog, TruckSimulator, fleet_trucks,
};
use airsus_data::TruckParameters;
use airsus_data::atomic::write_text_atomically;
use airsus_logs::{TableColumn, write_table_parquet};
use airsus_truck::experiments::effects_toml;

/// Fleet-scale data: a virtual fleet to run the Spark jobs on.
#[derive(Debug, Clone, clap::Args)]
pub struct FleetArgs {
    #[command(subcommand)]
    pub command: FleetCommand,
}

#[derive(Debug, Clone, clap::Subcommand)]
pub enum FleetCommand {
    /// Generate a virtual fleet: trucks of the virtual-truck family logging their days at 10 Hz
    /// (depot loading, deliveries over ISO 8608 roads, a levelling controller at work), a few
    /// with a slowly growing air leak, as a Parquet dataset partitioned by truck; the truth
    /// apart in truth/.
    Generate(FleetGenerateArgs),
}

#[derive(Debug, Clone, clap::Args)]
pub struct FleetGenerateArgs {
    /// Number of trucks (truck K is variant K+1 of the family).
    #[arg(long, value_name = "N")]
    pub trucks: u32,
    /// Days per truck, 24 h each at 10 Hz (864 000 rows a truck-day).
    #[arg(long, value_name = "D", default_value_t = 1)]
    pub days: u32,
    /// Output folder; it must not hold a fleet already.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Seed of every random detail: the same seed writes the same data.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// How many trucks grow a leak (default: one in eight, at least one).
    #[arg(long, value_name = "K")]
    pub leaking: Option<u32>,
}

pub fn run(args: &FleetArgs) -> anyhow::Result<()> {
    match &args.command {
        FleetCommand::Generate(a) => generate(a),
    }
}

/// Rounds to `decimals` (the sensors' resolution, so the files hold what a logger holds).
fn rounded(values: impl Iterator<Item = f64>, scale: f64, decimals: i32) -> Vec<f64> {
    let f = 10f64.powi(decimals);
    values.map(|v| (v * scale * f).round() / f).collect()
}

fn write_day(out: &Path, log: &TruckDayLog) -> anyhow::Result<()> {
    let n = log.len();
    let day = vec![log.day as i32; n];
    let valve: Vec<i32> = log.valve.iter().map(|v| i32::from(v.code())).collect();
    let time = rounded(log.time_s.iter().copied(), 1.0, 1);
    let height = rounded(log.height_m.iter().copied(), 1e3, 1);
    let pressure = rounded(log.bellow_gauge_pa.iter().copied(), 1e-3, 1);
    let supply = rounded(log.supply_gauge_pa.iter().copied(), 1e-3, 0);
    let file = format!("day-{:03}.parquet", log.day);
    let partition = format!("truck_id={}", log.truck_id);
    let logged = [
        TableColumn::double("time_s", "s", &time),
        TableColumn::int32("day", &day),
        TableColumn::double("height_mm", "mm", &height),
        TableColumn::double("pressure_kpa", "kPa", &pressure),
        TableColumn::int32("valve", &valve),
        TableColumn::double("supply_kpa", "kPa", &supply),
        TableColumn::double("speed_kmh", "km/h", &log.speed_kmh),
        TableColumn::double("ambient_temp_c", "degC", &log.ambient_temp_c),
        TableColumn::nullable("reference_load_kg", "kg", &log.reference_load_kg),
    ];
    let dir = out.join("logs").join(&partition);
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    write_table_parquet(&dir.join(&file), "fleet_log", &partition, &logged)?;

    let true_height = rounded(log.true_height_m.iter().copied(), 1e3, 6);
    let true_pressure = rounded(log.true_gauge_pa.iter().copied(), 1e-3, 6);
    let truth = [
        TableColumn::double("time_s", "s", &time),
        TableColumn::int32("day", &day),
        TableColumn::double("wheel_load_kg", "kg", &log.true_load_kg),
        TableColumn::double("height_mm", "mm", &true_height),
        TableColumn::double("pressure_kpa", "kPa", &true_pressure),
        TableColumn::double(
            "leak_conductance_mol_s_pa",
            "mol/(s Pa)",
            &log.leak_conductance,
        ),
    ];
    let dir = out.join("truth").join("loads").join(&partition);
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    write_table_parquet(&dir.join(&file), "fleet_truth", &partition, &truth)?;
    Ok(())
}

fn write_truck_truth(out: &Path, truck: &FleetTruck) -> anyhow::Result<()> {
    let dir = out
        .join("truth")
        .join(format!("truck_id={}", truck.truck_id));
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    airsus_data::write_truck(&dir.join("truck.toml"), &truck.truth.physical)?;
    write_text_atomically(
        &dir.join("effects.toml"),
        &format!(
            "# Fleet truck {}: virtual truck variant {}.\n{}",
            truck.truck_id,
            truck.variant,
            effects_toml(&truck.truth)
        ),
    )?;
    Ok(())
}

fn trucks_csv(trucks: &[FleetTruck]) -> String {
    let mut text = String::from(
        "truck_id,variant,tare_kg,leaking,leak_onset_s,leak_growth_mol_s_pa_per_h,leak_max_mol_s_pa\n",
    );
    for t in trucks {
        let (leaking, onset, growth, max) = match t.leak {
            Some(l) => (
                1,
                format!("{:.1}", l.onset_s),
                format!("{:e}", l.growth_per_h),
                format!("{:e}", l.max_conductance),
            ),
            None => (0, String::new(), String::new(), String::new()),
        };
        text.push_str(&format!(
            "{},{},{:.3},{leaking},{onset},{growth},{max}\n",
            t.truck_id, t.variant, t.loads.tare_kg
        ));
    }
    text
}

fn manifest(spec: &FleetSpec) -> String {
    format!(
        "# A virtual fleet written by `airsus fleet generate`.\n\
         trucks = {}\ndays = {}\nseed = {}\nleaking_trucks = {}\nsample_time_s = {SAMPLE_TIME_S}\n\
         truck = \"truck.toml\"\nlogs = \"logs\"\ntruth = \"truth\"\n",
        spec.trucks, spec.days, spec.seed, spec.leaking_trucks
    )
}

/// Simulates every truck-day (trucks in parallel) and writes the whole fleet into `out`.
fn write_fleet(spec: &FleetSpec, out: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let trucks = fleet_trucks(spec);
    let bar = ProgressBar::new(u64::from(spec.trucks) * u64::from(spec.days));
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} truck-days, {eta} left")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let failures = Mutex::new(Vec::new());
    trucks.par_iter().for_each(|truck| {
        let result = (|| -> anyhow::Result<()> {
            write_truck_truth(out, truck)?;
            let mut sim = TruckSimulator::new(truck.clone());
            for day in 0..spec.days {
                let log = sim.day(day)?;
                write_day(out, &log)?;
                bar.inc(1);
            }
            Ok(())
        })();
        if let (Err(e), Ok(mut f)) = (result, failures.lock()) {
            f.push(format!("truck {}: {e:#}", truck.truck_id));
        }
    });
    bar.finish_and_clear();
    let failures = failures.into_inner().unwrap_or_default();
    if !failures.is_empty() {
        bail!(
            "{} truck(s) failed:\n  {}",
            failures.len(),
            failures.join("\n  ")
        );
    }
    airsus_data::write_truck(&out.join("truck.toml"), &TruckParameters::reference())?;
    write_text_atomically(&out.join("truth").join("trucks.csv"), &trucks_csv(&trucks))?;
    write_text_atomically(&out.join("fleet.toml"), &manifest(spec))?;
    Ok(())
}

fn generate(args: &FleetGenerateArgs) -> anyhow::Result<()> {
    let started = Instant::now();
    if args.trucks > 100_000 || args.days > 3650 {
        bail!(
            "{} trucks for {} days is beyond what one machine generates (at most 100 000 trucks and 3650 days)",
            args.trucks,
            args.days
        );
    }
    let mut spec = FleetSpec::new(args.trucks, args.days, args.seed)?;
    if let Some(k) = args.leaking {
        spec = spec.with_leaking_trucks(k)?;
    }
    for existing in ["logs", "truth", "fleet.toml", "truck.toml"] {
        let path = args.out.join(existing);
        if path.exists() {
            bail!(
                "{} already holds a fleet ({} exists); choose another --out or remove it",
                args.out.display(),
                path.display()
            );
        }
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    // Everything is written into a scratch folder inside DIR and moved into place at the end,
    // so a failed or interrupted run leaves no half fleet behind.
    // Created exclusively: a folder left by a killed run is never reused.
    let scratch = tempfile::Builder::new()
        .prefix(".fleet-partial-")
        .tempdir_in(&args.out)
        .with_context(|| format!("creating a scratch folder in {}", args.out.display()))?
        .keep();
    let result = write_fleet(&spec, &scratch);
    let moved = result.and_then(|()| {
        for name in ["truck.toml", "logs", "truth", "fleet.toml"] {
            std::fs::rename(scratch.join(name), args.out.join(name))
                .with_context(|| format!("moving {name} into {}", args.out.display()))?;
        }
        Ok(())
    });
    let _ = std::fs::remove_dir_all(&scratch);
    moved?;
    eprintln!(
        "wrote {} trucks x {} days ({} leaking) to {} in {:.1} s",
        spec.trucks,
        spec.days,
        spec.leaking_trucks,
        args.out.display(),
        started.elapsed().as_secs_f64()
    );
    println!("{}", args.out.display());
    Ok(())
}
