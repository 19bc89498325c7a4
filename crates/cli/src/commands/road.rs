//! `airsus road`: a model driven over a bump or an ISO 8608 random road.

use airsus_data::atomic::refuse_overwriting_inputs;
use std::path::PathBuf;

use anyhow::Context;

use airsus_apps::road::{Iso8608Road, half_sine_bump_m, simulate_road, time_axis, write_road_csv};
use airsus_data::read_truck;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Profile {
    /// A half-sine bump of --bump-height-mm over --bump-length-m, 1 s after the start.
    Bump,
    /// An ISO 8608 random road of --class.
    Iso8608,
}

/// Simulate a model over a road profile and report height, pressure, tire force and contact.
#[derive(Debug, Clone, clap::Args)]
pub struct RoadArgs {
    #[arg(long, value_name = "T.toml")]
    pub truck: PathBuf,
    /// Any registered model with a tire (`airsus models`; Model 3 has none).
    #[arg(long, default_value = "m2")]
    pub model: String,
    #[arg(long, value_enum)]
    pub profile: Profile,
    /// ISO 8608 class, A (smooth) to H.
    #[arg(long, default_value = "C")]
    pub class: char,
    #[arg(long, default_value_t = 60.0)]
    pub speed_kmh: f64,
    /// Duration, s (default 20 for iso8608, 4 for bump).
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Seed of the random road's phases.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[arg(long, default_value_t = 50.0)]
    pub bump_height_mm: f64,
    #[arg(long, default_value_t = 0.5)]
    pub bump_length_m: f64,
    /// Wheel load, kg.
    #[arg(long, default_value_t = 3390.0)]
    pub load_kg: f64,
    /// Ride height (sensor) at the start, mm.
    #[arg(long, default_value_t = 240.0)]
    pub height_mm: f64,
    /// Sample time, ms (the road is held between samples).
    #[arg(long, default_value_t = 2.0)]
    pub sample_ms: f64,
    /// Output run file (contract columns plus tire_force_n and contact).
    #[arg(long, value_name = "R.csv")]
    pub out: PathBuf,
}

pub fn run(args: &RoadArgs) -> anyhow::Result<()> {
    refuse_overwriting_inputs(&args.out, &[&args.truck])?;
    let truck = read_truck(&args.truck)
        .with_context(|| format!("reading truck file {}", args.truck.display()))?
        .parameters;
    let model = airsus_truck::models::build_any_model(&args.model, &truck)?;
    if !(args.speed_kmh.is_finite() && args.speed_kmh > 0.0) {
        anyhow::bail!("--speed-kmh must be positive");
    }
    let speed = args.speed_kmh / 3.6;
    let dt = args.sample_ms * 1e-3;
    let duration = args.duration_s.unwrap_or(match args.profile {
        Profile::Bump => 4.0,
        Profile::Iso8608 => 20.0,
    });
    let time = time_axis(duration, dt)?;
    let distance: Vec<f64> = time.iter().map(|t| t * speed).collect();
    let (road, what) = match args.profile {
        Profile::Bump => {
            if !(args.bump_length_m > 0.0 && args.bump_height_mm.is_finite()) {
                anyhow::bail!("--bump-length-m must be positive");
            }
            let start = speed * 1.0;
            (
                distance
                    .iter()
                    .map(|&s| {
                        half_sine_bump_m(s, start, args.bump_length_m, args.bump_height_mm * 1e-3)
                    })
                    .collect::<Vec<_>>(),
                format!(
                    "half-sine bump {:.0} mm over {:.2} m",
                    args.bump_height_mm, args.bump_length_m
                ),
            )
        }
        Profile::Iso8608 => {
            // ISO 8608 band, cut to what the sampling carries (n v < 0.4 / dt).
            let n_max = 2.83f64.min(0.4 / (speed * dt));
            let road = Iso8608Road::new(args.class, 0.011, n_max, 2000, args.seed)?;
            let z = road.heights_m(&distance);
            let what = format!(
                "ISO 8608 class {} (Gd(n0) = {:.0}e-6 m³, {:.3} to {:.2} cycles/m, seed {}, rms {:.1} mm)",
                road.class,
                road.gd_n0_m3 * 1e6,
                0.011,
                n_max,
                args.seed,
                road.variance_m2().sqrt() * 1e3
            );
            (z, what)
        }
    };
    let r = simulate_road(
        model.as_ref(),
        &truck,
        &time,
        &road,
        args.load_kg,
        args.height_mm * 1e-3,
    )
    .with_context(|| format!("simulating {} over the road", args.model))?;
    let s = &r.summary;
    println!(
        "{} on {what} at {:.0} km/h, {:.1} s at {:.1} ms, wheel load {:.0} kg",
        r.model, args.speed_kmh, duration, args.sample_ms, args.load_kg
    );
    println!(
        "  sensor height {:.1} to {:.1} mm (std {:.2} mm)",
        s.height_min_m * 1e3,
        s.height_max_m * 1e3,
        s.height_std_m * 1e3
    );
    println!(
        "  bellow pressure {:.1} to {:.1} kPa gauge",
        s.pressure_min_pa / 1e3,
        s.pressure_max_pa / 1e3
    );
    println!(
        "  tire force {:.0} to {:.0} N (static {:.0} N), dynamic load coefficient {:.3}",
        s.tire_force_min_n, s.tire_force_max_n, s.static_tire_force_n, s.dynamic_load_coefficient
    );
    println!(
        "  contact lost {:.2} % of the time, longest {:.3} s",
        100.0 * s.contact_loss_fraction,
        s.longest_contact_loss_s
    );
    write_road_csv(&args.out, &r).with_context(|| format!("writing {}", args.out.display()))?;
    eprintln!("wrote {}", args.out.display());
    Ok(())
}
