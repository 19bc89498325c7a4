//! Road input (thesis 1.2, secondary requirement; SPEC §7): the response of a model to a road
//! profile under the modeled wheel, and Model 2 linearised about its equilibrium.
//!
//! # Sampling
//! The data contract's runs are uniformly sampled and the simulator holds inputs between
//! samples, so the road is a staircase at the run's sample time. Road input needs a fine one:
//! the wheel-hop mode (axle on the tire, about 9 Hz) and, at 60 km/h, road wavelengths down to
//! a few metres are 10–20 Hz; the default here is 2 ms (500 Hz).
//!
//! # Solver
//! The road changes at every sample, so the simulator restarts at every sample; the explicit
//! Tsit45 method is used (BDF, the default, fails with repeated Newton failures on Model 2 over
//! a 2 ms staircase road — reported to the simulation crate's owner).
//!
//! # Tire force and contact
//! `F_w = k_w max(0, z_r - y_axle)` (eq 3.15) with the axle height from the state: Model 1's
//! `x2`, or `x - h0 - l1 sin α` for Model 2, its extensions and the virtual truck. Contact is
//! lost where `F_w = 0`. Model 3 has no mechanics and is refused.

pub mod linear;
/// The road profiles live with the virtual truck, which drives its road runs over them.
pub use airsus_truck::road as profile;

use std::io::Write;
use std::path::Path;

use airsus_data::atomic::write_atomically;
use airsus_data::{TruckParameters, ValveState};
use airsus_model::submodels::Tire;
use airsus_model::{InitialCondition, SuspensionModel};
use airsus_sim::{InitialState, InputSeries, Method, SimulationProblem, SolverOptions, simulate};

use crate::error::{AppError, invalid};
pub use linear::{LinearModel, linearize, simulate_linear};
pub use profile::{
    ISO8608_N0, Iso8608Road, estimate_psd_m3, half_sine_bump_m, iso8608_gd_n0_m3, iso8608_psd_m3,
};

/// Where the axle sits in a model's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AxleGeometry {
    /// Model 1: the axle height is state `x2_m`, its velocity `v2_m_s`.
    Direct { index: usize, velocity_index: usize },
    /// Model 2 family and the truck: `y = x - h0 - l1 sin α` (states 0 and 1, their rates 2
    /// and 3).
    Lever { h0_m: f64, l1_m: f64 },
}

impl AxleGeometry {
    /// The axle geometry of `model` (by its state names), or an error for models without one.
    pub fn of(model: &dyn SuspensionModel, truck: &TruckParameters) -> Result<Self, AppError> {
        let names = model.state_names();
        let at = |name: &str| names.iter().position(|s| *s == name);
        if let (Some(index), Some(velocity_index)) = (at("x2_m"), at("v2_m_s")) {
            return Ok(Self::Direct {
                index,
                velocity_index,
            });
        }
        if names.starts_with(&["x_m", "alpha_rad", "xdot_m_s", "alphadot_rad_s"]) {
            return Ok(Self::Lever {
                h0_m: truck.geometry.h0_m,
                l1_m: truck.geometry.l1_m,
            });
        }
        Err(AppError::UnsupportedModel {
            model: model.name().to_owned(),
            reason:
                "it has no axle and tire in its state (road input needs m1, m2, m2x, m2xh or truck)"
                    .to_owned(),
        })
    }

    pub fn axle_height_m(&self, x: &[f64]) -> f64 {
        match *self {
            Self::Direct { index, .. } => x[index],
            Self::Lever { h0_m, l1_m } => x[0] - h0_m - l1_m * x[1].sin(),
        }
    }

    /// The axle's vertical velocity, m/s: `ẏ = ẋ - l1 cos α α̇` on the lever.
    pub fn axle_velocity_m_s(&self, x: &[f64]) -> f64 {
        match *self {
            Self::Direct { velocity_index, .. } => x[velocity_index],
            Self::Lever { l1_m, .. } => x[2] - l1_m * x[1].cos() * x[3],
        }
    }

    /// The force `tire` puts on the axle in state `x` over a road at `road_m` moving at
    /// `road_rate_m_s`, N.
    pub fn tire_force_n(&self, tire: &Tire, x: &[f64], road_m: f64, road_rate_m_s: f64) -> f64 {
        tire.force_n(
            road_m - self.axle_height_m(x),
            road_rate_m_s - self.axle_velocity_m_s(x),
        )
    }
}

/// The rate of a road sampled at `time_s` at sample `k`, m/s: the slope of the segment ahead,
/// as the simulator follows it (0 at the last sample).
pub fn road_rate_at(time_s: &[f64], road_m: &[f64], k: usize) -> f64 {
    match (time_s.get(k..=k + 1), road_m.get(k..=k + 1)) {
        (Some(t), Some(z)) => (z[1] - z[0]) / (t[1] - t[0]),
        _ => 0.0,
    }
}

/// A road run's signals and scores.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RoadResponse {
    pub model: String,
    pub time_s: Vec<f64>,
    pub road_m: Vec<f64>,
    pub sensor_height_m: Vec<f64>,
    pub bellow_gauge_pa: Vec<f64>,
    pub tire_force_n: Vec<f64>,
    pub wheel_load_kg: f64,
    pub summary: RoadSummary,
}

/// Scores of a road run.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RoadSummary {
    pub height_min_m: f64,
    pub height_max_m: f64,
    /// Standard deviation of the sensor height, m.
    pub height_std_m: f64,
    pub pressure_min_pa: f64,
    pub pressure_max_pa: f64,
    pub tire_force_min_n: f64,
    pub tire_force_max_n: f64,
    /// Static tire force `m_tot g`, N.
    pub static_tire_force_n: f64,
    /// Dynamic load coefficient: std of the tire force over its static value.
    pub dynamic_load_coefficient: f64,
    /// Fraction of the samples without tire contact.
    pub contact_loss_fraction: f64,
    /// Longest stretch without contact, s.
    pub longest_contact_loss_s: f64,
}

fn std_dev(v: &[f64]) -> f64 {
    let n = v.len().max(1) as f64;
    let mean = v.iter().sum::<f64>() / n;
    (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt()
}

/// Simulates `model` over `road_m` (at `time_s`) with a constant wheel load, from the static
/// equilibrium at `initial_sensor_height_m`, valve closed.
pub fn simulate_road(
    model: &dyn SuspensionModel,
    truck: &TruckParameters,
    time_s: &[f64],
    road_m: &[f64],
    wheel_load_kg: f64,
    initial_sensor_height_m: f64,
) -> Result<RoadResponse, AppError> {
    let axle = AxleGeometry::of(model, truck)?;
    let n = time_s.len();
    if road_m.len() != n || n < 2 {
        return Err(invalid(
            "road input",
            format!(
                "{} road samples for {n} times (need >= 2, equal)",
                road_m.len()
            ),
        ));
    }
    let load = vec![wheel_load_kg; n];
    let valve = vec![ValveState::Closed; n];
    let supply = vec![850e3; n];
    let inputs = InputSeries::new(time_s, &load, &valve, &supply, road_m)?;
    let problem = SimulationProblem::new(
        model,
        inputs,
        InitialState::Equilibrium(InitialCondition::SensorHeight {
            height_m: initial_sensor_height_m,
        }),
    )
    .with_options(
        SolverOptions::default()
            .with_method(Method::Tsit45)
            .with_states(true),
    );
    let response = simulate(&problem)?;
    let states = response
        .states
        .as_ref()
        .ok_or_else(|| invalid("simulation", "no states were recorded"))?;
    let wheel = Tire::new(&truck.tire);
    let tire: Vec<f64> = (0..n)
        .map(|k| {
            states.at(k).map_or(f64::NAN, |x| {
                axle.tire_force_n(&wheel, x, road_m[k], road_rate_at(time_s, road_m, k))
            })
        })
        .collect();
    let g = truck.environment.gravity_m_s2;
    let dt = (time_s[n - 1] - time_s[0]) / (n - 1) as f64;
    let (mut lost, mut run, mut longest) = (0usize, 0usize, 0usize);
    for &f in &tire {
        if f <= 0.0 {
            lost += 1;
            run += 1;
            longest = longest.max(run);
        } else {
            run = 0;
        }
    }
    let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    let max = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let static_force = wheel_load_kg * g;
    let summary = RoadSummary {
        height_min_m: min(&response.sensor_height_m),
        height_max_m: max(&response.sensor_height_m),
        height_std_m: std_dev(&response.sensor_height_m),
        pressure_min_pa: min(&response.bellow_gauge_pa),
        pressure_max_pa: max(&response.bellow_gauge_pa),
        tire_force_min_n: min(&tire),
        tire_force_max_n: max(&tire),
        static_tire_force_n: static_force,
        dynamic_load_coefficient: std_dev(&tire) / static_force,
        contact_loss_fraction: lost as f64 / n as f64,
        longest_contact_loss_s: longest as f64 * dt,
    };
    Ok(RoadResponse {
        model: model.name().to_owned(),
        time_s: time_s.to_vec(),
        road_m: road_m.to_vec(),
        sensor_height_m: response.sensor_height_m,
        bellow_gauge_pa: response.bellow_gauge_pa,
        tire_force_n: tire,
        wheel_load_kg,
        summary,
    })
}

/// Writes the road run in the run format (SPEC §5 columns, so `airsus simulate`/`check` read
/// it) plus the extra columns `tire_force_n` and `contact` (1/0), atomically.
pub fn write_road_csv(path: &Path, r: &RoadResponse) -> Result<(), AppError> {
    write_atomically(path, |w: &mut dyn Write| {
        writeln!(
            w,
            "time_s,wheel_load_kg,valve,supply_kpa,road_mm,height_mm,pressure_kpa,tire_force_n,contact"
        )?;
        for k in 0..r.time_s.len() {
            writeln!(
                w,
                "{},{},0,850,{:.4},{:.4},{:.4},{:.1},{}",
                r.time_s[k],
                r.wheel_load_kg,
                r.road_m[k] * 1e3,
                r.sensor_height_m[k] * 1e3,
                r.bellow_gauge_pa[k] / 1e3,
                r.tire_force_n[k],
                u8::from(r.tire_force_n[k] > 0.0)
            )?;
        }
        Ok(())
    })?;
    Ok(())
}

/// Time axis `0, dt, .., duration` and distances travelled at `speed_m_s`.
pub fn time_axis(duration_s: f64, sample_time_s: f64) -> Result<Vec<f64>, AppError> {
    if !(duration_s.is_finite()
        && duration_s > 0.0
        && sample_time_s > 0.0
        && sample_time_s.is_finite())
    {
        return Err(invalid(
            "time axis",
            format!("duration {duration_s} s, sample time {sample_time_s} s"),
        ));
    }
    let n = (duration_s / sample_time_s).round() as usize + 1;
    if n > 10_000_000 {
        return Err(invalid("time axis", format!("{n} samples is too many")));
    }
    Ok((0..n).map(|k| k as f64 * sample_time_s).collect())
}
