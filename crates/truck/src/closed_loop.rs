//! Closed-loop simulation of a level controller on a model or the virtual truck: the levelling
//! runs of the reference experiments and `airsus control`.
//!
//! The controller runs at every sample of the scenario (100 ms): it reads the plant's outputs at `t_k`
//! through the truck's sensors (noise, then quantisation: 0.1 mm, 0.1 kPa; thesis 2.2), decides
//! the valve command, and the plant is simulated over `[t_k, t_k+1]` with every input held
//! (valve, load sampled from the scenario, supply, road) from the state it ended the previous
//! interval in. `airsus-sim` has no step API, so each interval is one `simulate` call on a
//! two-sample problem; it costs about 0.01–0.03 ms per 100 ms interval on Models 1–3 and the
//! virtual truck (measured; diffsol's setup is cheap), so a 6-minute scenario takes well under
//! a second and a step API is not needed.

use airsus_data::{Run, RunInputs, RunOutputs, ValveState};
use airsus_model::{InitialCondition, InputSample, StateRole, SuspensionModel};
use airsus_sim::{InitialState, InputSeries, SimulationProblem, SolverOptions, simulate};

use crate::ecu::{LevelController, Reading};
use crate::error::{TruckError, invalid};
use crate::model::TruckModel;
use crate::sensors::{NoiseSource, SensorSpec};

/// What the controller acts on.
#[derive(Debug, Clone)]
pub enum Plant {
    /// Any model; the supply pressure is the constant `supply_gauge_pa` of the config.
    Model(Box<dyn SuspensionModel>),
    /// The virtual truck, usually in `SupplyMode::Tank`: the tank droops while the valve fills
    /// and the compressor refills it; the controller reads the simulated tank pressure.
    Truck(Box<TruckModel>),
}

impl Plant {
    pub fn model(&self) -> &dyn SuspensionModel {
        match self {
            Plant::Model(m) => m.as_ref(),
            Plant::Truck(t) => t.as_ref(),
        }
    }

    fn supply_gauge_pa(&self, x: &[f64], u: &InputSample) -> f64 {
        match self {
            Plant::Model(_) => u.supply_gauge_pa,
            Plant::Truck(t) => t.tank_gauge_pa(x, u),
        }
    }
}

/// Sensors and supply of a closed-loop run.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedLoopConfig {
    pub height_sensor: SensorSpec,
    pub pressure_sensor: SensorSpec,
    pub supply_sensor: SensorSpec,
    /// Supply gauge pressure for [`Plant::Model`] (and the start of the truck's tank), Pa.
    pub supply_gauge_pa: f64,
    pub seed: u64,
}

impl Default for ClosedLoopConfig {
    fn default() -> Self {
        Self {
            height_sensor: SensorSpec::HEIGHT_M,
            pressure_sensor: SensorSpec::BELLOW_PRESSURE_PA,
            supply_sensor: SensorSpec::SUPPLY_PRESSURE_PA,
            supply_gauge_pa: 850e3,
            seed: 1,
        }
    }
}

/// The closed-loop trajectory, one entry per controller sample.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ClosedLoopRun {
    pub controller: String,
    pub plant: String,
    pub time_s: Vec<f64>,
    pub target_m: Vec<f64>,
    pub true_load_kg: Vec<f64>,
    /// Road height under the wheel, m.
    pub road_height_m: Vec<f64>,
    /// True (noise-free) sensor height, m.
    pub height_m: Vec<f64>,
    /// What the controller read, m.
    pub measured_height_m: Vec<f64>,
    /// True bellow gauge pressure, Pa.
    pub bellow_gauge_pa: Vec<f64>,
    /// What the controller read: bellow and supply gauge pressure, Pa.
    pub measured_gauge_pa: Vec<f64>,
    pub measured_supply_pa: Vec<f64>,
    /// Command applied over `[t_k, t_k+1)`.
    pub valve: Vec<ValveState>,
    /// Air let in through the fill channel and out through the exhaust, mol.
    pub air_filled_mol: f64,
    pub air_exhausted_mol: f64,
}

impl ClosedLoopRun {
    /// The run as its log reads (the sensors' readings, the valve as commanded, the load as a
    /// weighbridge would log it) and as it was (noise-free outputs), e.g. a levelling run to
    /// weigh or to identify on. The logged load is the true load: a levelling test's loads
    /// are known.
    pub fn to_runs(&self, name: &str) -> (Run, Run) {
        let n = self.time_s.len();
        let sample_time_s = if n > 1 {
            (self.time_s[n - 1] - self.time_s[0]) / (n - 1) as f64
        } else {
            0.0
        };
        let run = |height: &[f64], gauge: &[f64], supply: &[f64]| Run {
            name: name.to_owned(),
            time_s: self.time_s.clone(),
            sample_time_s,
            inputs: RunInputs {
                wheel_load_kg: self.true_load_kg.clone(),
                valve: self.valve.clone(),
                supply_gauge_pa: supply.to_vec(),
                road_height_m: self.road_height_m.clone(),
            },
            outputs: Some(RunOutputs {
                sensor_height_m: height.to_vec(),
                bellow_gauge_pa: gauge.to_vec(),
            }),
        };
        (
            run(
                &self.measured_height_m,
                &self.measured_gauge_pa,
                &self.measured_supply_pa,
            ),
            run(
                &self.height_m,
                &self.bellow_gauge_pa,
                &self.measured_supply_pa,
            ),
        )
    }
}

/// Inputs of a closed-loop run: the true load and the target height at every sample.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelScenario {
    pub name: String,
    pub time_s: Vec<f64>,
    pub true_load_kg: Vec<f64>,
    /// Target sensor height, m.
    pub target_m: Vec<f64>,
    /// Road height under the wheel, m (linear between samples; 0 = standing or a level road).
    pub road_height_m: Vec<f64>,
    /// Vehicle speed, m/s (what the controller reads from the bus).
    pub speed_m_s: Vec<f64>,
    /// Times at which something happens (load change starts, target changes), s.
    pub events_s: Vec<f64>,
}

impl LevelScenario {
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// `duration_s` at `sample_s` with a constant load and target, standing on a level road.
    pub fn constant(
        name: &str,
        duration_s: f64,
        sample_s: f64,
        load_kg: f64,
        target_m: f64,
    ) -> Self {
        let n = (duration_s / sample_s).round() as usize + 1;
        Self {
            name: name.to_owned(),
            time_s: (0..n).map(|i| i as f64 * sample_s).collect(),
            true_load_kg: vec![load_kg; n],
            target_m: vec![target_m; n],
            road_height_m: vec![0.0; n],
            speed_m_s: vec![0.0; n],
            events_s: Vec::new(),
        }
    }

    /// A load change of `delta_kg` from `start_s` over a smooth ramp of `ramp_s` (a crane
    /// setting a load down takes seconds, not a sample).
    pub fn load_change(&mut self, start_s: f64, delta_kg: f64, ramp_s: f64) {
        for (t, m) in self.time_s.iter().zip(self.true_load_kg.iter_mut()) {
            let x = ((t - start_s) / ramp_s).clamp(0.0, 1.0);
            *m += delta_kg * x * x * (3.0 - 2.0 * x);
        }
        self.events_s.push(start_s);
    }

    /// The target becomes `target_m` from `start_s` on.
    pub fn target_change(&mut self, start_s: f64, target_m: f64) {
        for (t, h) in self.time_s.iter().zip(self.target_m.iter_mut()) {
            if *t >= start_s - 1e-9 {
                *h = target_m;
            }
        }
        self.events_s.push(start_s);
    }
}

/// Runs `controller` on `plant` through `scenario`, starting in static equilibrium at the first
/// target height with the first load.
pub fn simulate_closed_loop(
    plant: &Plant,
    controller: &mut dyn LevelController,
    scenario: &LevelScenario,
    config: &ClosedLoopConfig,
) -> Result<ClosedLoopRun, TruckError> {
    let n = scenario.len();
    if n < 2 {
        return Err(invalid("scenario", "it needs at least two samples"));
    }
    let model = plant.model();
    let amount_index = model.state_index(StateRole::BellowAir);
    let input = |k: usize, valve: ValveState| InputSample {
        wheel_load_kg: scenario.true_load_kg[k],
        valve,
        supply_gauge_pa: config.supply_gauge_pa,
        road_height_m: scenario.road_height_m.get(k).copied().unwrap_or(0.0),
        road_rate_m_s: 0.0,
    };
    let mut x = model.initial_state(
        &input(0, ValveState::Closed),
        &InitialCondition::SensorHeight {
            height_m: scenario.target_m[0],
        },
    )?;
    let mut noise = NoiseSource::new(config.seed);
    let mut run = ClosedLoopRun {
        controller: controller.name().to_owned(),
        plant: model.name().to_owned(),
        ..ClosedLoopRun::default()
    };
    let options = SolverOptions::default().with_states(true);
    for k in 0..n {
        let t = scenario.time_s[k];
        let u_closed = input(k, ValveState::Closed);
        let out = model.output(&x, &u_closed);
        let supply = plant.supply_gauge_pa(&x, &u_closed);
        let reading = Reading {
            sensor_height_m: noise.measure(&[out.sensor_height_m], config.height_sensor)[0],
            bellow_gauge_pa: noise.measure(&[out.bellow_gauge_pa], config.pressure_sensor)[0],
            supply_gauge_pa: noise.measure(&[supply], config.supply_sensor)[0],
            speed_m_s: scenario.speed_m_s.get(k).copied().unwrap_or(0.0),
        };
        let valve = controller.update(t, scenario.target_m[k], &reading);
        run.time_s.push(t);
        run.target_m.push(scenario.target_m[k]);
        run.true_load_kg.push(scenario.true_load_kg[k]);
        run.road_height_m.push(u_closed.road_height_m);
        run.height_m.push(out.sensor_height_m);
        run.measured_height_m.push(reading.sensor_height_m);
        run.bellow_gauge_pa.push(out.bellow_gauge_pa);
        run.measured_gauge_pa.push(reading.bellow_gauge_pa);
        run.measured_supply_pa.push(reading.supply_gauge_pa);
        run.valve.push(valve);
        if k + 1 == n {
            break;
        }
        let times = [t, scenario.time_s[k + 1]];
        let u = input(k, valve);
        let load = [u.wheel_load_kg; 2];
        let valves = [valve; 2];
        let supplies = [u.supply_gauge_pa; 2];
        // The road is linear between samples (the simulator's default), so it passes
        // without a restart.
        let road = [u.road_height_m, input(k + 1, valve).road_height_m];
        let inputs = InputSeries::new(&times, &load, &valves, &supplies, &road)?;
        let problem = SimulationProblem::new(model, inputs, InitialState::State(x.clone()))
            .with_options(options.clone());
        let response = simulate(&problem)?;
        let next = response
            .final_state()
            .ok_or_else(|| invalid("simulation", "no final state was recorded"))?
            .to_vec();
        if let Some(i) = amount_index {
            let dn = next[i] - x[i];
            match valve {
                ValveState::Fill => run.air_filled_mol += dn.max(0.0),
                ValveState::Exhaust => run.air_exhausted_mol += (-dn).max(0.0),
                ValveState::Closed => {}
            }
        }
        x = next;
    }
    Ok(run)
}
