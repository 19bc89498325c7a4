//! A virtual fleet: many trucks of the virtual-truck family, each logging its days at 10 Hz
//! while a levelling controller works its valve (issue #17, `airsus fleet generate`).
//!
//! Each truck is a member of the family ([`VirtualTruck::variant`]), with its own empty weight
//! and its own days ([`plan`]); a few trucks grow an air leak from an onset time on. The day
//! is simulated on the virtual truck in [`SupplyMode::Tank`] (the tank droops while the valve
//! fills and the compressor refills it), with the ambient temperature of the hour and the
//! leak of that hour. A truck's days follow each other: the state at midnight carries over.
//!
//! # Closed loop at fleet cost
//! A day is 864 000 samples; stepping the plant sample by sample as [`crate::control`] does
//! costs about 20 µs a sample. Here the plant is simulated open-loop (valve closed) over a
//! chunk (60 s awake, an hour asleep) and the controller is run over the chunk's readings;
//! at the first sample where it opens the valve, the chunk is cut there and the plant is
//! stepped sample by sample until the controller closes the valve again. The controller sees
//! exactly what it would see stepping every sample — its decision at a sample depends only on
//! readings up to that sample, and those come from the closed-valve trajectory until it opens
//! — so the result is the stepped closed loop, at open-loop cost where nothing happens.
//!
//! What is logged is what the controller read (the same sensors: noise, then quantisation).

pub mod plan;

use airsus_data::ValveState;
use airsus_model::{InitialCondition, InputSample, SuspensionModel};
use airsus_sim::{InitialState, InputSeries, SimulationProblem, SolverOptions, simulate};
use airsus_truck::model::{SupplyMode, TruckModel};
use airsus_truck::sensors::{NoiseSource, SensorSpec};
use airsus_truck::truth::VirtualTruck;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Uniform};

use crate::control::{DeadbandController, GuardSettings, LevelController, Reading};
use crate::error::{AppError, invalid};
pub use plan::{
    ControllerMode, DayPlan, SAMPLE_TIME_S, SAMPLES_PER_DAY, SAMPLES_PER_HOUR, TruckLoads, plan_day,
};

/// Ride height the trucks' controllers hold (sensor), m.
pub const TARGET_HEIGHT_M: f64 = 0.235;
/// Supply-tank gauge pressure on the first morning, Pa.
const START_SUPPLY_GAUGE_PA: f64 = 850e3;
/// Relative tolerance of the fleet's simulations. The sensors resolve 0.1 mm and 0.1 kPa and
/// add noise of 0.15 mm and 0.2 kPa; at 1e-4 the noise-free outputs stay within 0.01 mm and
/// 0.025 kPa of the default 1e-6's over a whole truck-day (measured), and a truck-day takes
/// 4.1 s instead of 7.2 s.
const FLEET_RTOL: f64 = 1e-4;
/// Awake, the plant is simulated open-loop over chunks of this many samples (60 s).
const AWAKE_CHUNK: usize = 600;

/// What to generate.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetSpec {
    pub trucks: u32,
    pub days: u32,
    pub seed: u64,
    /// How many trucks grow a leak.
    pub leaking_trucks: u32,
}

impl FleetSpec {
    /// `trucks` trucks for `days` days; one truck in eight (at least one) leaks.
    pub fn new(trucks: u32, days: u32, seed: u64) -> Result<Self, AppError> {
        if trucks == 0 || days == 0 {
            return Err(invalid(
                "fleet",
                format!("{trucks} trucks for {days} days; both must be at least 1"),
            ));
        }
        Ok(Self {
            trucks,
            days,
            seed,
            leaking_trucks: trucks.div_ceil(8),
        })
    }

    pub fn with_leaking_trucks(mut self, leaking: u32) -> Result<Self, AppError> {
        if leaking > self.trucks {
            return Err(invalid(
                "leaking trucks",
                format!("{leaking} of a fleet of {}", self.trucks),
            ));
        }
        self.leaking_trucks = leaking;
        Ok(self)
    }
}

/// A leak that grows linearly from its onset: `G(t) = min(G_max, ġ (t − t_onset))`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeakGrowth {
    /// Onset, seconds from midnight before day 0.
    pub onset_s: f64,
    /// Growth of the conductance per hour, mol/(s·Pa·h).
    pub growth_per_h: f64,
    /// Largest conductance, mol/(s·Pa).
    pub max_conductance: f64,
}

impl LeakGrowth {
    /// The leak conductance at fleet time `t_s` (seconds from midnight before day 0).
    pub fn conductance_at(&self, t_s: f64) -> f64 {
        let hours = ((t_s - self.onset_s) / 3600.0).max(0.0);
        (self.growth_per_h * hours).min(self.max_conductance)
    }
}

/// One truck of the fleet.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetTruck {
    pub truck_id: u32,
    /// Its member of the virtual-truck family.
    pub variant: u32,
    pub truth: VirtualTruck,
    pub loads: TruckLoads,
    pub leak: Option<LeakGrowth>,
    /// Fixes the truck's days and sensor noise.
    pub seed: u64,
}

/// The trucks of a fleet, deterministic for the spec: truck `k` is variant `k + 1` of the
/// family, with an empty sprung load of 2300–2700 kg on the modeled wheel; the leaking
/// trucks are drawn from the seed, their onsets in the first half of the period, growing by
/// 5e-12 mol/(s·Pa) an hour (about 0.05 % of the circuit's air an hour, per hour) up to
/// 1.5e-10 (about 1.5 %/h: a night parked then costs a fifth of the air, and the bellow
/// never runs empty).
pub fn fleet_trucks(spec: &FleetSpec) -> Vec<FleetTruck> {
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed ^ 0xF1EE_7000);
    let mut uniform =
        |low: f64, high: f64| Uniform::new(low, high).map_or(low, |d| d.sample(&mut rng));
    let mut ids: Vec<u32> = (0..spec.trucks).collect();
    // Fisher–Yates with the fleet's stream: which trucks leak.
    for i in (1..ids.len()).rev() {
        let j = (uniform(0.0, 1.0) * (i + 1) as f64) as usize;
        ids.swap(i, j.min(i));
    }
    let leaking: Vec<u32> = ids[..spec.leaking_trucks as usize].to_vec();
    let period_s = f64::from(spec.days) * 86_400.0;
    (0..spec.trucks)
        .map(|truck_id| {
            let truth = VirtualTruck::variant(truck_id + 1);
            let tare_kg = truth.physical.mass.unsprung_kg + uniform(2300.0, 2700.0);
            let onset_s = uniform(0.0, 0.5) * period_s;
            FleetTruck {
                truck_id,
                variant: truck_id + 1,
                truth,
                loads: TruckLoads { tare_kg },
                leak: leaking.contains(&truck_id).then_some(LeakGrowth {
                    onset_s,
                    growth_per_h: 5e-12,
                    max_conductance: 1.5e-10,
                }),
                seed: spec.seed ^ (u64::from(truck_id) << 20) ^ 0x7A0C,
            }
        })
        .collect()
}

/// One truck-day as logged and as it was, SI units.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TruckDayLog {
    pub truck_id: u32,
    pub day: u32,
    /// Seconds since midnight.
    pub time_s: Vec<f64>,
    /// Logged: sensor height, m; bellow gauge pressure, Pa; supply-tank gauge pressure, Pa.
    pub height_m: Vec<f64>,
    pub bellow_gauge_pa: Vec<f64>,
    pub supply_gauge_pa: Vec<f64>,
    pub valve: Vec<ValveState>,
    pub speed_kmh: Vec<f64>,
    /// Logged ambient temperature (0.5 °C resolution), °C.
    pub ambient_temp_c: Vec<f64>,
    /// Known wheel load (weighbridge, loading list), kg; NaN where unknown.
    pub reference_load_kg: Vec<f64>,
    /// Truth: wheel load, kg; noise-free sensor height, m, and bellow gauge pressure, Pa; the
    /// leak conductance, mol/(s·Pa).
    pub true_load_kg: Vec<f64>,
    pub true_height_m: Vec<f64>,
    pub true_gauge_pa: Vec<f64>,
    pub leak_conductance: Vec<f64>,
}

impl TruckDayLog {
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }
}

/// Simulates one truck's days in order, carrying its state from one midnight to the next.
pub struct TruckSimulator {
    truck: FleetTruck,
    state: Option<Vec<f64>>,
    noise: NoiseSource,
}

/// The controller of each awake mode.
fn controller_for(mode: ControllerMode) -> Option<DeadbandController> {
    match mode {
        ControllerMode::Asleep => None,
        ControllerMode::Standing => Some(DeadbandController::new(GuardSettings::default())),
        // Driving: ±10 mm, a 5 s filter and 10 s debounce, so the road does not work the valve.
        ControllerMode::Driving => Some(DeadbandController::new(GuardSettings {
            tolerance_m: 10e-3,
            debounce_s: 10.0,
            filter_time_constant_s: 5.0,
            ..GuardSettings::default()
        })),
    }
}

/// Where a day's simulation stands between samples.
struct DayRun<'a> {
    plan: &'a DayPlan,
    log: TruckDayLog,
    model: TruckModel,
    /// The hour `model` was built for.
    hour: usize,
    mode: ControllerMode,
    controller: Option<DeadbandController>,
}

impl TruckSimulator {
    pub fn new(truck: FleetTruck) -> Self {
        let noise = NoiseSource::new(truck.seed ^ 0x5E75);
        Self {
            truck,
            state: None,
            noise,
        }
    }

    pub fn truck(&self) -> &FleetTruck {
        &self.truck
    }

    /// The plant in hour `hour` of day `day`: that hour's ambient temperature and leak.
    fn model_for(&self, plan: &DayPlan, day: u32, hour: usize) -> TruckModel {
        let mut truth = self.truck.truth.clone();
        truth.physical.environment.temperature_k = plan.hourly_ambient_k[hour.min(23)];
        let mid_hour_s = f64::from(day) * 86_400.0 + (hour as f64 + 0.5) * 3600.0;
        truth.effect_parameters.leak_conductance_mol_s_pa = self
            .truck
            .leak
            .map_or(0.0, |leak| leak.conductance_at(mid_hour_s));
        TruckModel::new(truth, SupplyMode::Tank)
    }

    /// Rebuilds the plant when sample `k` lies in another hour than the one it was built for.
    fn enter_hour(&self, run: &mut DayRun, day: u32, k: usize) {
        let hour = k / SAMPLES_PER_HOUR;
        if hour != run.hour {
            run.model = self.model_for(run.plan, day, hour);
            run.hour = hour;
        }
    }

    fn input(plan: &DayPlan, k: usize, valve: ValveState) -> InputSample {
        InputSample {
            wheel_load_kg: plan.true_load_kg[k],
            valve,
            supply_gauge_pa: START_SUPPLY_GAUGE_PA,
            road_height_m: plan.road_height_m[k],
            road_rate_m_s: 0.0,
        }
    }

    /// Reads the sensors at sample `k` in state `x`, lets the controller decide, logs both.
    fn observe(&mut self, run: &mut DayRun, k: usize, x: &[f64]) -> ValveState {
        let plan = run.plan;
        let u = Self::input(plan, k, ValveState::Closed);
        let out = run.model.output(x, &u);
        let supply = run.model.tank_gauge_pa(x, &u);
        let reading = Reading {
            sensor_height_m: self
                .noise
                .measure(&[out.sensor_height_m], SensorSpec::HEIGHT_M)[0],
            bellow_gauge_pa: self
                .noise
                .measure(&[out.bellow_gauge_pa], SensorSpec::BELLOW_PRESSURE_PA)[0],
            supply_gauge_pa: self
                .noise
                .measure(&[supply], SensorSpec::SUPPLY_PRESSURE_PA)[0],
            speed_m_s: plan.speed_kmh[k] / 3.6,
        };
        if plan.mode[k] != run.mode {
            run.mode = plan.mode[k];
            run.controller = controller_for(run.mode);
        }
        let t = plan.time_s[k];
        let valve = run.controller.as_mut().map_or(ValveState::Closed, |c| {
            c.update(t, TARGET_HEIGHT_M, &reading)
        });
        let log = &mut run.log;
        log.time_s.push(t);
        log.height_m.push(reading.sensor_height_m);
        log.bellow_gauge_pa.push(reading.bellow_gauge_pa);
        log.supply_gauge_pa.push(reading.supply_gauge_pa);
        log.valve.push(valve);
        log.speed_kmh
            .push((plan.speed_kmh[k] * 10.0).round() / 10.0);
        let ambient_c = plan.hourly_ambient_k[(k / SAMPLES_PER_HOUR).min(23)] - 273.15;
        log.ambient_temp_c.push((ambient_c * 2.0).round() / 2.0);
        log.reference_load_kg.push(plan.reference_load_kg[k]);
        log.true_load_kg.push(plan.true_load_kg[k]);
        log.true_height_m.push(out.sensor_height_m);
        log.true_gauge_pa.push(out.bellow_gauge_pa);
        log.leak_conductance.push(
            run.model
                .truth()
                .effect_parameters
                .leak_conductance_mol_s_pa,
        );
        valve
    }

    /// Simulates samples `from..=to` with the valve held, from `x` at `from`.
    fn integrate(
        run: &DayRun,
        from: usize,
        to: usize,
        valve: ValveState,
        x: &[f64],
    ) -> Result<airsus_sim::SimulationResponse, AppError> {
        let plan = run.plan;
        let len = to - from + 1;
        let valves = vec![valve; len];
        let supply = vec![START_SUPPLY_GAUGE_PA; len];
        let inputs = InputSeries::new(
            &plan.time_s[from..=to],
            &plan.true_load_kg[from..=to],
            &valves,
            &supply,
            &plan.road_height_m[from..=to],
        )?;
        let problem = SimulationProblem::new(
            &run.model as &dyn SuspensionModel,
            inputs,
            InitialState::State(x.to_vec()),
        )
        .with_options(
            SolverOptions::default()
                .with_rtol(FLEET_RTOL)
                .with_states(true),
        );
        Ok(simulate(&problem)?)
    }

    /// Simulates and logs day `day` (days must come in order: the state carries over).
    pub fn day(&mut self, day: u32) -> Result<TruckDayLog, AppError> {
        let plan = plan_day(self.truck.loads, self.truck.seed, day)?;
        let n = plan.time_s.len();
        let truck_id = self.truck.truck_id;
        let context = move |e: AppError, k: usize| -> AppError {
            invalid(
                format!("truck {truck_id} day {day}"),
                format!("at {:.1} s: {e}", k as f64 * SAMPLE_TIME_S),
            )
        };
        let mut run = DayRun {
            plan: &plan,
            log: TruckDayLog {
                truck_id: self.truck.truck_id,
                day,
                ..TruckDayLog::default()
            },
            model: self.model_for(&plan, day, 0),
            hour: 0,
            mode: ControllerMode::Asleep,
            controller: None,
        };
        let mut x = match self.state.take() {
            Some(x) => x,
            None => run
                .model
                .equilibrium_with_friction(
                    &Self::input(&plan, 0, ValveState::Closed),
                    &InitialCondition::SensorHeight {
                        height_m: TARGET_HEIGHT_M,
                    },
                    0.0,
                )
                .map_err(|e| context(e.into(), 0))?,
        };
        // Hour starts and controller-mode changes cut the chunks.
        let mut boundaries: Vec<usize> = (1..24).map(|h| h * SAMPLES_PER_HOUR).collect();
        boundaries.extend((1..n).filter(|&k| plan.mode[k] != plan.mode[k - 1]));
        boundaries.push(n - 1);
        boundaries.sort_unstable();
        boundaries.dedup();

        let mut valve = self.observe(&mut run, 0, &x);
        let mut k = 0;
        while k + 1 < n {
            self.enter_hour(&mut run, day, k);
            if valve != ValveState::Closed {
                let response =
                    Self::integrate(&run, k, k + 1, valve, &x).map_err(|e| context(e, k))?;
                x = final_state(&response).map_err(|e| context(e, k))?;
                k += 1;
                // Stepping, the sample that starts an hour is read with that hour's plant.
                self.enter_hour(&mut run, day, k);
                valve = self.observe(&mut run, k, &x);
                continue;
            }
            let next_boundary = boundaries[boundaries.partition_point(|&b| b <= k)];
            let to = if plan.mode[k] == ControllerMode::Asleep {
                next_boundary
            } else {
                next_boundary.min(k + AWAKE_CHUNK)
            };
            let response =
                Self::integrate(&run, k, to, ValveState::Closed, &x).map_err(|e| context(e, k))?;
            let states = response
                .states
                .as_ref()
                .ok_or_else(|| invalid("simulation", "no states were recorded"))?;
            let mut stopped = to;
            for j in k + 1..=to {
                let xj = states
                    .at(j - k)
                    .ok_or_else(|| context(invalid("simulation", "a state is missing"), j))?
                    .to_vec();
                valve = self.observe(&mut run, j, &xj);
                if valve != ValveState::Closed || j == to {
                    x = xj;
                    stopped = j;
                    break;
                }
            }
            k = stopped;
        }
        self.state = Some(x);
        Ok(run.log)
    }
}

fn final_state(response: &airsus_sim::SimulationResponse) -> Result<Vec<f64>, AppError> {
    response
        .final_state()
        .map(<[f64]>::to_vec)
        .ok_or_else(|| invalid("simulation", "no final state was recorded"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spec_picks_the_leaking_trucks_and_refuses_empty_fleets() {
        assert!(FleetSpec::new(0, 1, 1).is_err());
        assert!(FleetSpec::new(3, 0, 1).is_err());
        let spec = FleetSpec::new(20, 2, 5).unwrap();
        assert_eq!(spec.leaking_trucks, 3);
        assert!(spec.clone().with_leaking_trucks(21).is_err());
        let trucks = fleet_trucks(&spec);
        assert_eq!(trucks.len(), 20);
        let leaking: Vec<&FleetTruck> = trucks.iter().filter(|t| t.leak.is_some()).collect();
        assert_eq!(leaking.len(), 3);
        for t in &leaking {
            let leak = t.leak.unwrap();
            assert!(leak.onset_s >= 0.0 && leak.onset_s <= 86_400.0);
            assert_eq!(leak.conductance_at(leak.onset_s - 1.0), 0.0);
            assert!((leak.conductance_at(leak.onset_s + 7200.0) - 1e-11).abs() < 1e-22);
            assert_eq!(leak.conductance_at(leak.onset_s + 1e7), 1.5e-10);
        }
        // Distinct trucks, the same for the same spec.
        assert_ne!(trucks[0].truth, trucks[1].truth);
        assert_eq!(trucks, fleet_trucks(&spec));
    }
}
