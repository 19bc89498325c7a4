//! One FMU instance in safe Rust: the FMI 2.0 co-simulation state machine (§4.2.4) around a
//! model, its inputs and its state. The C API in `fmi2.rs` only converts pointers and reports.
//!
//! Phases and what they allow (a subset of the standard's table, lenient where that harms
//! nothing — e.g. reading variables before initialisation):
//!
//! | phase | set inputs | set tunable | set `initial_height_mm` | do step | get |
//! |---|---|---|---|---|---|
//! | instantiated | yes | yes | yes | – | yes (outputs from the equilibrium) |
//! | initialisation | yes | yes | yes | – | yes (outputs from the equilibrium) |
//! | step complete | yes | yes | – | yes | yes |
//! | terminated | – | – | – | – | yes |
//! | error | – | – | – | – | yes (for debugging) |
//!
//! `fmi2Reset` returns to *instantiated* from anywhere; `fmi2SetFMUstate` restores a
//! snapshot (phase included).
//!
//! A communication step `[t, t + h]` is one call of [`airsus_sim::simulate_into`] on two
//! samples (`t`, `t + h`) holding the inputs (the road moving at its given rate), from the
//! current state, with the tolerances of
//! `airsus simulate`: rtol 1e-6 and `atol_i = rtol · max(|x0_i|, 0.1)` from the initial state
//! (the engine's default, frozen at initialisation so every step uses the same scale). Steps
//! shorter than [`EULER_STEP_S`] take one explicit Euler step instead (below any time scale of
//! the models, and an adaptive solver has no room to start there).

use airsus_data::ValveState;
use airsus_data::units::{PA_PER_KPA, m_from_mm, mm_from_m};
use airsus_model::{InitialCondition, InputSample, OutputSample, SuspensionModel};
use airsus_sim::{
    AbsoluteTolerance, InitialState, InputSeries, SimulationProblem, SimulationResponse,
    SolverOptions, simulate_into,
};

use crate::config::Prepared;
use crate::description::{
    DEFAULT_ROAD_MM, DEFAULT_ROAD_RATE_MM_S, DEFAULT_SUPPLY_KPA, DEFAULT_WHEEL_LOAD_KG, Role,
    VarType, Variable,
};

/// Relative tolerance of every step: that of `airsus simulate`. A host's `fmi2SetupExperiment`
/// tolerance is used only when it is tighter.
pub const DEFAULT_RTOL: f64 = 1e-6;

/// Communication steps shorter than this (s) are one explicit Euler step.
pub const EULER_STEP_S: f64 = 1e-9;

/// FMI status codes (`fmi2Status`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Status {
    Ok = 0,
    Warning = 1,
    Discard = 2,
    Error = 3,
    Fatal = 4,
}

/// A call that did not return `fmi2OK`: the status and what to tell the logger.
#[derive(Debug, Clone, PartialEq)]
pub struct Failure {
    pub status: Status,
    pub message: String,
}

impl Failure {
    pub fn error(message: impl Into<String>) -> Self {
        Self {
            status: Status::Error,
            message: message.into(),
        }
    }

    pub fn discard(message: impl Into<String>) -> Self {
        Self {
            status: Status::Discard,
            message: message.into(),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    Instantiated,
    Initialization,
    StepComplete,
    Terminated,
    Error,
}

/// The inputs as the host set them (file units: kg, 0/1/2, kPa gauge, mm).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Inputs {
    wheel_load_kg: f64,
    valve: ValveState,
    supply_kpa: f64,
    road_mm: f64,
    /// mm/s: the road moves at it over a step from `road_mm` (first-order extrapolation of a
    /// host's road signal by its derivative); 0 holds the road.
    road_rate_mm_s: f64,
}

impl Inputs {
    fn start() -> Self {
        Self {
            wheel_load_kg: DEFAULT_WHEEL_LOAD_KG,
            valve: ValveState::Closed,
            supply_kpa: DEFAULT_SUPPLY_KPA,
            road_mm: DEFAULT_ROAD_MM,
            road_rate_mm_s: DEFAULT_ROAD_RATE_MM_S,
        }
    }

    /// The model's input sample, converted exactly as `airsus_data` converts a run file.
    fn sample(&self) -> InputSample {
        InputSample {
            wheel_load_kg: self.wheel_load_kg,
            valve: self.valve,
            supply_gauge_pa: self.supply_kpa * PA_PER_KPA,
            road_height_m: m_from_mm(self.road_mm),
            road_rate_m_s: m_from_mm(self.road_rate_mm_s),
        }
    }
}

/// Everything that changes during a run: what `fmi2GetFMUstate` copies.
#[derive(Debug, Clone)]
struct Dynamic {
    model: Box<dyn SuspensionModel>,
    inputs: Inputs,
    initial_height_mm: f64,
    phase: Phase,
    start_time: f64,
    stop_time: Option<f64>,
    rtol: f64,
    time: f64,
    /// `None` until `fmi2ExitInitializationMode`.
    state: Option<Vec<f64>>,
    atol: Vec<f64>,
    /// Why the instance is in the error phase.
    error: Option<String>,
}

impl Dynamic {
    fn start(prepared: &Prepared) -> Self {
        Self {
            model: prepared.model.clone(),
            inputs: Inputs::start(),
            initial_height_mm: prepared.config.initial_height_mm,
            phase: Phase::Instantiated,
            start_time: 0.0,
            stop_time: None,
            rtol: DEFAULT_RTOL,
            time: 0.0,
            state: None,
            atol: Vec::new(),
            error: None,
        }
    }
}

/// A copy of an instance's state (`fmi2FMUstate`).
#[derive(Debug, Clone)]
pub struct Snapshot {
    guid: String,
    dynamic: Dynamic,
}

/// One FMU instance.
#[derive(Debug)]
pub struct Slave {
    prepared: Prepared,
    d: Dynamic,
    /// Reused between steps.
    response: SimulationResponse,
}

impl Slave {
    pub fn new(prepared: Prepared) -> Self {
        let d = Dynamic::start(&prepared);
        Self {
            prepared,
            d,
            response: SimulationResponse::default(),
        }
    }

    pub fn prepared(&self) -> &Prepared {
        &self.prepared
    }

    pub fn phase(&self) -> Phase {
        self.d.phase
    }

    /// The end of the last completed communication step (or the start time), s.
    pub fn time(&self) -> f64 {
        self.d.time
    }

    /// The model state, once initialised.
    pub fn state(&self) -> Option<&[f64]> {
        self.d.state.as_deref()
    }

    /// `fmi2Reset`: as freshly instantiated.
    pub fn reset(&mut self) {
        self.d = Dynamic::start(&self.prepared);
    }

    /// `fmi2SetupExperiment`.
    pub fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start_time: f64,
        stop_time: Option<f64>,
    ) -> Result<(), Failure> {
        self.require(&[Phase::Instantiated], "fmi2SetupExperiment")?;
        if !start_time.is_finite() {
            return Err(Failure::error(format!(
                "startTime = {start_time} is not finite"
            )));
        }
        if let Some(stop) = stop_time
            && !(stop.is_finite() && stop >= start_time)
        {
            return Err(Failure::error(format!(
                "stopTime = {stop} must be finite and not before startTime = {start_time}"
            )));
        }
        self.d.rtol = match tolerance {
            Some(tol) if tol.is_finite() && tol > 0.0 && tol < DEFAULT_RTOL => tol,
            _ => DEFAULT_RTOL,
        };
        self.d.start_time = start_time;
        self.d.stop_time = stop_time;
        self.d.time = start_time;
        Ok(())
    }

    /// `fmi2EnterInitializationMode`.
    pub fn enter_initialization_mode(&mut self) -> Result<(), Failure> {
        self.require(&[Phase::Instantiated], "fmi2EnterInitializationMode")?;
        self.d.phase = Phase::Initialization;
        Ok(())
    }

    /// `fmi2ExitInitializationMode`: the static equilibrium at `initial_height_mm` under the
    /// current inputs becomes the state. A model without that equilibrium puts the instance in
    /// the error phase.
    pub fn exit_initialization_mode(&mut self) -> Result<(), Failure> {
        self.require(&[Phase::Initialization], "fmi2ExitInitializationMode")?;
        match self.equilibrium() {
            Ok(x0) => {
                let floor = match AbsoluteTolerance::default() {
                    AbsoluteTolerance::Scaled { floor } => floor,
                    _ => 0.1,
                };
                let rtol = self.d.rtol;
                self.d.atol = x0.iter().map(|x| rtol * x.abs().max(floor)).collect();
                self.d.state = Some(x0);
                self.d.time = self.d.start_time;
                self.d.phase = Phase::StepComplete;
                Ok(())
            }
            Err(failure) => Err(self.fail(failure)),
        }
    }

    /// `fmi2Terminate`.
    pub fn terminate(&mut self) -> Result<(), Failure> {
        self.require(&[Phase::StepComplete, Phase::Terminated], "fmi2Terminate")?;
        self.d.phase = Phase::Terminated;
        Ok(())
    }

    /// `fmi2DoStep(t, h)`: integrate from the current state over `[t, t + h]`, the inputs held
    /// (the road moving at `road_rate_mm_s`).
    /// On failure the state stays at `t` and the instance enters the error phase.
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<(), Failure> {
        self.require(&[Phase::StepComplete], "fmi2DoStep")?;
        if !(t.is_finite() && h.is_finite() && h > 0.0) {
            return Err(Failure::error(format!(
                "fmi2DoStep(currentCommunicationPoint = {t}, communicationStepSize = {h}): the step size must be positive and both finite"
            )));
        }
        // The master's clock and ours may differ by rounding (the Reference FMUs allow 1e-5);
        // the master's value then wins.
        let slack = (1e-9 * t.abs()).max(1e-6);
        if (t - self.d.time).abs() > slack {
            return Err(Failure::error(format!(
                "fmi2DoStep: currentCommunicationPoint = {t} s is not where the last step ended ({} s); use fmi2SetFMUstate to go back in time",
                self.d.time
            )));
        }
        let end = t + h;
        if let Some(stop) = self.d.stop_time
            && end > stop + (1e-9 * stop.abs()).max(1e-6)
        {
            return Err(Failure::error(format!(
                "fmi2DoStep: the step ends at {end} s, after stopTime = {stop} s of fmi2SetupExperiment"
            )));
        }
        if end <= t {
            // h is below the resolution of t: nothing happens.
            self.d.time = t;
            return Ok(());
        }
        let Some(x) = self.d.state.clone() else {
            return Err(self.fail(Failure::error("fmi2DoStep: the instance has no state")));
        };
        let u = self.d.inputs.sample();
        let result = if h < EULER_STEP_S {
            self.euler_step(t, &x, &u, h)
        } else {
            self.integrate(t, end, x, u)
        };
        match result {
            Ok(next) => {
                self.d.state = Some(next);
                self.d.time = end;
                Ok(())
            }
            Err(message) => Err(self.fail(Failure::error(format!(
                "fmi2DoStep from t = {t} s over {h} s: {message}"
            )))),
        }
    }

    fn integrate(
        &mut self,
        t: f64,
        end: f64,
        x: Vec<f64>,
        u: InputSample,
    ) -> Result<Vec<f64>, String> {
        let times = [t, end];
        let load = [u.wheel_load_kg; 2];
        let valve = [u.valve; 2];
        let supply = [u.supply_gauge_pa; 2];
        // The road from where the host set it, moving at its rate: the simulator follows it
        // linearly over the step and hands the tire that rate (a held road when it is 0).
        let road = [
            u.road_height_m,
            u.road_height_m + u.road_rate_m_s * (end - t),
        ];
        let inputs =
            InputSeries::new(&times, &load, &valve, &supply, &road).map_err(|e| e.to_string())?;
        let options = SolverOptions::default()
            .with_rtol(self.d.rtol)
            .with_atol(AbsoluteTolerance::PerState(self.d.atol.clone()))
            .with_states(true);
        let problem = SimulationProblem::new(&*self.d.model, inputs, InitialState::State(x))
            .with_options(options);
        simulate_into(&problem, &mut self.response).map_err(|e| e.to_string())?;
        self.response
            .final_state()
            .map(<[f64]>::to_vec)
            .ok_or_else(|| "the engine returned no final state".to_owned())
    }

    fn euler_step(&self, t: f64, x: &[f64], u: &InputSample, h: f64) -> Result<Vec<f64>, String> {
        let mut dx = vec![0.0; x.len()];
        self.d.model.rhs(t, x, u, &mut dx);
        let next: Vec<f64> = x.iter().zip(&dx).map(|(x, d)| x + h * d).collect();
        if next.iter().all(|v| v.is_finite()) {
            Ok(next)
        } else {
            Err("the state derivative is not finite".to_owned())
        }
    }

    /// The Real variable `vr`'s value.
    pub fn get_real(&self, vr: u32) -> Result<f64, Failure> {
        let var = self.variable(VarType::Real, vr)?;
        match var.role {
            Role::WheelLoad => Ok(self.d.inputs.wheel_load_kg),
            Role::Supply => Ok(self.d.inputs.supply_kpa),
            Role::Road => Ok(self.d.inputs.road_mm),
            Role::RoadRate => Ok(self.d.inputs.road_rate_mm_s),
            Role::Height => Ok(mm_from_m(self.outputs()?.sensor_height_m)),
            Role::Pressure => Ok(self.outputs()?.bellow_gauge_pa / PA_PER_KPA),
            Role::InitialHeight => Ok(self.d.initial_height_mm),
            Role::Parameter => self
                .d
                .model
                .parameter(&var.name)
                .map_err(|e| Failure::error(e.to_string())),
            Role::Valve => Err(Failure::error(format!(
                "fmi2GetReal: value reference {vr} is not a Real"
            ))),
        }
    }

    /// The Integer variable `vr`'s value.
    pub fn get_integer(&self, vr: u32) -> Result<i32, Failure> {
        let var = self.variable(VarType::Integer, vr)?;
        match var.role {
            Role::Valve => Ok(i32::from(self.d.inputs.valve.code())),
            _ => Err(Failure::error(format!(
                "fmi2GetInteger: value reference {vr} is not an Integer"
            ))),
        }
    }

    /// Sets the Real variable `vr`.
    pub fn set_real(&mut self, vr: u32, value: f64) -> Result<(), Failure> {
        let var = self.variable(VarType::Real, vr)?;
        let (role, name) = (var.role, var.name.clone());
        match role {
            Role::WheelLoad | Role::Supply | Role::Road | Role::RoadRate => {
                self.require_input_phase(&name)?;
                if !value.is_finite() || (role == Role::WheelLoad && value < 0.0) {
                    return Err(Failure::error(format!(
                        "input {name} = {value} must be finite{}",
                        if role == Role::WheelLoad {
                            " and not negative"
                        } else {
                            ""
                        }
                    )));
                }
                match role {
                    Role::WheelLoad => self.d.inputs.wheel_load_kg = value,
                    Role::Supply => self.d.inputs.supply_kpa = value,
                    Role::Road => self.d.inputs.road_mm = value,
                    _ => self.d.inputs.road_rate_mm_s = value,
                }
                Ok(())
            }
            Role::Height | Role::Pressure => Err(Failure::error(format!(
                "{name} is an output and cannot be set"
            ))),
            Role::InitialHeight => {
                self.require(
                    &[Phase::Instantiated, Phase::Initialization],
                    "setting the fixed parameter initial_height_mm",
                )?;
                if !(value.is_finite() && value > 0.0) {
                    return Err(Failure::discard(format!(
                        "initial_height_mm = {value} must be a positive number of millimetres"
                    )));
                }
                self.d.initial_height_mm = value;
                Ok(())
            }
            Role::Parameter => {
                self.require(
                    &[
                        Phase::Instantiated,
                        Phase::Initialization,
                        Phase::StepComplete,
                    ],
                    &format!("setting the parameter {name}"),
                )?;
                // Out of range: fmi2Discard, as FMI 2.0 §2.2.7 suggests for parameters.
                self.d
                    .model
                    .set_parameter(&name, value)
                    .map_err(|e| Failure::discard(e.to_string()))
            }
            Role::Valve => Err(Failure::error(format!(
                "fmi2SetReal: value reference {vr} is not a Real"
            ))),
        }
    }

    /// Sets the Integer variable `vr` (the valve: 0, 1 or 2).
    pub fn set_integer(&mut self, vr: u32, value: i32) -> Result<(), Failure> {
        let var = self.variable(VarType::Integer, vr)?;
        if var.role != Role::Valve {
            return Err(Failure::error(format!(
                "fmi2SetInteger: value reference {vr} is not an Integer"
            )));
        }
        self.require_input_phase("valve")?;
        let valve = ValveState::from_code(f64::from(value)).ok_or_else(|| {
            Failure::error(format!(
                "input valve = {value}: expected 0 (closed), 1 (fill) or 2 (exhaust)"
            ))
        })?;
        self.d.inputs.valve = valve;
        Ok(())
    }

    /// `fmi2GetFMUstate`.
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            guid: self.prepared.guid.clone(),
            dynamic: self.d.clone(),
        }
    }

    /// `fmi2SetFMUstate`.
    pub fn restore(&mut self, snapshot: &Snapshot) -> Result<(), Failure> {
        if snapshot.guid != self.prepared.guid {
            return Err(Failure::error(format!(
                "fmi2SetFMUstate: the state belongs to another FMU (GUID {}, this one is {})",
                snapshot.guid, self.prepared.guid
            )));
        }
        self.d = snapshot.dynamic.clone();
        Ok(())
    }

    /// Puts the instance in the error phase (after a panic, or from a failure) and returns the
    /// failure for reporting.
    pub fn fail(&mut self, failure: Failure) -> Failure {
        if failure.status >= Status::Error {
            self.d.phase = Phase::Error;
            self.d.error = Some(failure.message.clone());
        }
        failure
    }

    /// The outputs for the current state, or for the starting equilibrium before there is one.
    fn outputs(&self) -> Result<OutputSample, Failure> {
        let u = self.d.inputs.sample();
        let y = match &self.d.state {
            Some(x) => self.d.model.output(x, &u),
            None => self.d.model.output(&self.equilibrium()?, &u),
        };
        if y.sensor_height_m.is_finite() && y.bellow_gauge_pa.is_finite() {
            Ok(y)
        } else {
            Err(Failure::error(format!(
                "the outputs are not finite (height {} m, pressure {} Pa)",
                y.sensor_height_m, y.bellow_gauge_pa
            )))
        }
    }

    /// The static equilibrium at `initial_height_mm` under the current inputs.
    fn equilibrium(&self) -> Result<Vec<f64>, Failure> {
        let u = self.d.inputs.sample();
        let ic = InitialCondition::SensorHeight {
            height_m: m_from_mm(self.d.initial_height_mm),
        };
        let x0 = self.d.model.initial_state(&u, &ic).map_err(|e| {
            Failure::error(format!(
                "no initial state at initial_height_mm = {} mm under wheel_load_kg = {}, valve = {}, supply_kpa = {}, road_mm = {}: {e}",
                self.d.initial_height_mm,
                self.d.inputs.wheel_load_kg,
                self.d.inputs.valve.code(),
                self.d.inputs.supply_kpa,
                self.d.inputs.road_mm
            ))
        })?;
        let n = self.d.model.n_states();
        if x0.len() != n || x0.iter().any(|v| !v.is_finite()) {
            return Err(Failure::error(format!(
                "the initial state {x0:?} is not {n} finite values"
            )));
        }
        Ok(x0)
    }

    fn variable(&self, var_type: VarType, vr: u32) -> Result<&Variable, Failure> {
        self.prepared.variable(var_type, vr).ok_or_else(|| {
            Failure::error(format!(
                "no {} variable has value reference {vr}",
                match var_type {
                    VarType::Real => "Real",
                    VarType::Integer => "Integer",
                }
            ))
        })
    }

    fn require_input_phase(&self, name: &str) -> Result<(), Failure> {
        self.require(
            &[
                Phase::Instantiated,
                Phase::Initialization,
                Phase::StepComplete,
            ],
            &format!("setting the input {name}"),
        )
    }

    fn require(&self, allowed: &[Phase], what: &str) -> Result<(), Failure> {
        if allowed.contains(&self.d.phase) {
            return Ok(());
        }
        let phase = match self.d.phase {
            Phase::Instantiated => {
                "before initialisation (call fmi2EnterInitializationMode and fmi2ExitInitializationMode first)"
                    .to_owned()
            }
            Phase::Initialization => "in initialisation mode".to_owned(),
            Phase::StepComplete => "after initialisation".to_owned(),
            Phase::Terminated => "after fmi2Terminate (call fmi2Reset to start again)".to_owned(),
            Phase::Error => format!(
                "in the error state after: {} (call fmi2Reset or fmi2SetFMUstate, or free the instance)",
                self.d.error.as_deref().unwrap_or("an earlier error")
            ),
        };
        Err(Failure::error(format!("{what} is not allowed {phase}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{DEFAULT_INITIAL_HEIGHT_MM, ExportConfig};
    use crate::description::vr;
    use airsus_data::TruckParameters;
    use airsus_sim::simulate;

    fn slave(model: &str) -> Slave {
        let config = ExportConfig::new(
            model,
            &TruckParameters::reference(),
            DEFAULT_INITIAL_HEIGHT_MM,
        )
        .unwrap();
        Slave::new(Prepared::new(config).unwrap())
    }

    fn initialise(s: &mut Slave) {
        s.setup_experiment(None, 0.0, None).unwrap();
        s.enter_initialization_mode().unwrap();
        s.exit_initialization_mode().unwrap();
    }

    /// A 30 s scenario sampled at 0.1 s: fill pulse, load step, exhaust pulse.
    fn scenario() -> (Vec<f64>, Vec<f64>, Vec<ValveState>) {
        let n = 301;
        let time: Vec<f64> = (0..n).map(|k| k as f64 * 0.1).collect();
        let load = (0..n)
            .map(|k| if k >= 150 { 3690.0 } else { 3390.0 })
            .collect();
        let valve = (0..n)
            .map(|k| match k {
                30..=49 => ValveState::Fill,
                200..=219 => ValveState::Exhaust,
                _ => ValveState::Closed,
            })
            .collect();
        (time, load, valve)
    }

    #[test]
    fn stepping_matches_one_simulation_of_the_whole_run() {
        for model in ["m1", "m2", "truck"] {
            let (time, load, valve) = scenario();
            let n = time.len();
            let supply = vec![850e3; n];
            let road = vec![0.0; n];
            let mut s = slave(model);
            initialise(&mut s);
            let mut height = Vec::new();
            let mut pressure = Vec::new();
            for (k, &t) in time.iter().enumerate() {
                s.set_real(vr::WHEEL_LOAD_KG, load[k]).unwrap();
                s.set_integer(vr::VALVE, i32::from(valve[k].code()))
                    .unwrap();
                // Outputs at t_k under u_k, as the engine samples them.
                height.push(s.get_real(vr::HEIGHT_MM).unwrap());
                pressure.push(s.get_real(vr::PRESSURE_KPA).unwrap());
                if let Some(&next) = time.get(k + 1) {
                    s.do_step(t, next - t).unwrap();
                }
            }
            let inputs = InputSeries::new(&time, &load, &valve, &supply, &road).unwrap();
            let (h_ref, p_ref) = simulated(&*s.prepared().model, inputs);
            let (fh, fp) = (
                nrmse_percent(&h_ref, &height),
                nrmse_percent(&p_ref, &pressure),
            );
            assert!(
                fh > 99.9 && fp > 99.9,
                "{model}: height {fh} %, pressure {fp} %"
            );
        }
    }

    /// A tire that damps feels the road's rate: given `road_rate_mm_s`, the FMU follows the
    /// road as the simulator does (linearly between the host's samples) and matches it; with
    /// the rate left at 0 it holds the road over each step, and the tire's damper never sees
    /// the road move.
    #[test]
    fn a_damped_tire_follows_the_road_by_its_rate_as_the_simulator_does() {
        let mut truck = TruckParameters::reference();
        truck.tire.damping_n_s_per_m = 4000.0;
        let config = ExportConfig::new("m2", &truck, DEFAULT_INITIAL_HEIGHT_MM).unwrap();
        let dt = 0.01;
        let n = 301;
        let time: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
        // A 30 mm half-sine bump over 0.3 s from 0.5 s on.
        let road_mm: Vec<f64> = time
            .iter()
            .map(|&t| {
                let phase = (t - 0.5) / 0.3;
                if (0.0..=1.0).contains(&phase) {
                    30.0 * (std::f64::consts::PI * phase).sin()
                } else {
                    0.0
                }
            })
            .collect();
        let fmu_height = |with_rate: bool| {
            let mut s = Slave::new(Prepared::new(config.clone()).unwrap());
            initialise(&mut s);
            let mut height = Vec::new();
            for (k, &t) in time.iter().enumerate() {
                s.set_real(vr::ROAD_MM, road_mm[k]).unwrap();
                let rate = road_mm
                    .get(k + 1)
                    .map_or(0.0, |next| (next - road_mm[k]) / dt);
                s.set_real(vr::ROAD_RATE_MM_S, if with_rate { rate } else { 0.0 })
                    .unwrap();
                height.push(s.get_real(vr::HEIGHT_MM).unwrap());
                if k + 1 < n {
                    s.do_step(t, dt).unwrap();
                }
            }
            height
        };
        let load = vec![DEFAULT_WHEEL_LOAD_KG; n];
        let valve = vec![ValveState::Closed; n];
        let supply = vec![DEFAULT_SUPPLY_KPA * 1e3; n];
        let road_m: Vec<f64> = road_mm.iter().map(|&z| m_from_mm(z)).collect();
        let reference = |model: &dyn SuspensionModel| {
            let inputs = InputSeries::new(&time, &load, &valve, &supply, &road_m).unwrap();
            simulated(model, inputs).0
        };
        let h_ref = reference(&*Prepared::new(config.clone()).unwrap().model);
        let mut undamped = truck.clone();
        undamped.tire.damping_n_s_per_m = 0.0;
        let h_undamped = reference(&airsus_model::Model2::new(&undamped));
        let (followed, held, without_damper) = (
            nrmse_percent(&h_ref, &fmu_height(true)),
            nrmse_percent(&h_ref, &fmu_height(false)),
            nrmse_percent(&h_ref, &h_undamped),
        );
        println!("followed {followed} %, held {held} %, undamped tire {without_damper} %");
        assert!(followed > 99.9, "with the rate: {followed} %");
        assert!(
            held < followed - 1.0,
            "held {held} %, followed {followed} %"
        );
        // The tire's damper matters here by more than the FMU's mismatch: it reached it.
        assert!(
            without_damper < followed - 1.0,
            "undamped {without_damper} %, followed {followed} %"
        );
    }

    /// Height (mm) and pressure (kPa) of one simulation of `inputs` from the FMU's default
    /// start: what stepping the FMU must reproduce.
    fn simulated(model: &dyn SuspensionModel, inputs: InputSeries<'_>) -> (Vec<f64>, Vec<f64>) {
        let problem = SimulationProblem::new(
            model,
            inputs,
            InitialState::Equilibrium(InitialCondition::SensorHeight {
                height_m: m_from_mm(DEFAULT_INITIAL_HEIGHT_MM),
            }),
        );
        let r = simulate(&problem).unwrap();
        (
            r.sensor_height_m.iter().map(|h| h * 1e3).collect(),
            r.bellow_gauge_pa.iter().map(|p| p / 1e3).collect(),
        )
    }

    /// NRMSE in percent (eq 3.33), here to keep `airsus-validate` out of the dependencies.
    fn nrmse_percent(y: &[f64], yhat: &[f64]) -> f64 {
        let mean = y.iter().sum::<f64>() / y.len() as f64;
        let err: f64 = y.iter().zip(yhat).map(|(a, b)| (a - b).powi(2)).sum();
        let spread: f64 = y.iter().map(|a| (a - mean).powi(2)).sum();
        100.0 * (1.0 - (err / spread).sqrt())
    }

    #[test]
    fn any_step_size_reaches_the_same_state() {
        let mut one = slave("m2");
        let mut many = slave("m2");
        for s in [&mut one, &mut many] {
            initialise(s);
            s.set_integer(vr::VALVE, 1).unwrap();
        }
        one.do_step(0.0, 2.0).unwrap();
        let mut t = 0.0;
        for h in [1e-12, 0.013, 0.5, 0.987, 1e-10, 0.5 - 1e-10 - 1e-12] {
            many.do_step(t, h).unwrap();
            t += h;
        }
        let (a, b) = (
            one.get_real(vr::PRESSURE_KPA).unwrap(),
            many.get_real(vr::PRESSURE_KPA).unwrap(),
        );
        assert!((a - b).abs() < 1e-3 * a.abs(), "{a} vs {b}");
        assert!((one.time() - 2.0).abs() < 1e-12 && (many.time() - 2.0).abs() < 1e-9);
    }

    #[test]
    fn misuse_is_refused_and_errors_are_recoverable() {
        let mut s = slave("m1");
        assert!(s.do_step(0.0, 0.1).is_err(), "step before initialisation");
        assert!(s.set_real(vr::HEIGHT_MM, 1.0).is_err(), "setting an output");
        assert!(s.set_real(999, 1.0).is_err(), "unknown value reference");
        assert!(s.set_integer(vr::VALVE, 3).is_err(), "valve 3");
        assert!(s.set_real(vr::WHEEL_LOAD_KG, f64::NAN).is_err());
        // An impossible start: no equilibrium 2 m high.
        s.set_real(vr::INITIAL_HEIGHT_MM, 2000.0).unwrap();
        s.setup_experiment(None, 0.0, Some(1.0)).unwrap();
        s.enter_initialization_mode().unwrap();
        let err = s.exit_initialization_mode().unwrap_err();
        assert_eq!(err.status, Status::Error);
        assert_eq!(s.phase(), Phase::Error);
        assert!(
            s.do_step(0.0, 0.1)
                .unwrap_err()
                .message
                .contains("error state")
        );
        s.reset();
        assert_eq!(s.phase(), Phase::Instantiated);
        initialise(&mut s);
        assert!(s.do_step(0.5, 0.1).is_err(), "time mismatch");
        s.do_step(0.0, 0.1).unwrap();
        assert!(
            s.set_real(vr::INITIAL_HEIGHT_MM, 230.0).is_err(),
            "fixed after init"
        );
        let kw = s.get_real(vr::FIRST_PARAMETER).unwrap();
        assert!(kw.is_finite());
        s.terminate().unwrap();
        assert!(s.do_step(0.1, 0.1).is_err(), "step after terminate");
    }

    #[test]
    fn snapshots_replay_exactly() {
        let mut s = slave("m2");
        initialise(&mut s);
        s.set_integer(vr::VALVE, 1).unwrap();
        s.do_step(0.0, 0.5).unwrap();
        let snap = s.snapshot();
        s.do_step(0.5, 0.5).unwrap();
        let first = s.get_real(vr::PRESSURE_KPA).unwrap();
        s.set_integer(vr::VALVE, 2).unwrap();
        s.do_step(1.0, 0.5).unwrap();
        s.restore(&snap).unwrap();
        assert_eq!(s.time(), 0.5);
        s.do_step(0.5, 0.5).unwrap();
        assert_eq!(s.get_real(vr::PRESSURE_KPA).unwrap(), first);
    }

    #[test]
    fn tunable_parameters_change_the_next_steps() {
        let mut nominal = slave("m2");
        let mut tuned = slave("m2");
        let a0 = nominal
            .prepared()
            .variables
            .iter()
            .find(|v| v.name == "a0")
            .unwrap()
            .value_reference;
        for s in [&mut nominal, &mut tuned] {
            initialise(s);
            s.set_integer(vr::VALVE, 1).unwrap();
        }
        let value = tuned.get_real(a0).unwrap();
        tuned.set_real(a0, value * 1.2).unwrap();
        assert_eq!(
            tuned.set_real(a0, -1.0).unwrap_err().status,
            Status::Discard
        );
        nominal.do_step(0.0, 2.0).unwrap();
        tuned.do_step(0.0, 2.0).unwrap();
        let (p, q) = (
            nominal.get_real(vr::PRESSURE_KPA).unwrap(),
            tuned.get_real(vr::PRESSURE_KPA).unwrap(),
        );
        assert!((p - q).abs() > 0.1, "{p} vs {q}");
    }
}
