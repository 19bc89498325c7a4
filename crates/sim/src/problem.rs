//! The problem: what to simulate (model, inputs at sample times, initial condition) and how
//! accurately (tolerances, method). Plain data, cheap to copy with a new model
//! ([`SimulationProblem::with_model`], SciML's `remake`).

use airsus_data::{Run, ValveState};
use airsus_model::{InitialCondition, InputSample, SuspensionModel};

use crate::error::SimError;

/// The inputs of one simulation, borrowed from their owner (usually an [`airsus_data::Run`]),
/// one value per sample time. Validated once at construction: equal lengths, at least one
/// sample, finite values, strictly increasing finite times.
///
/// Between samples each input is held constant (zero-order hold): on `[t_k, t_{k+1})` the
/// model sees sample `k`.
#[derive(Debug, Clone, Copy)]
pub struct InputSeries<'a> {
    time_s: &'a [f64],
    wheel_load_kg: &'a [f64],
    valve: &'a [ValveState],
    supply_gauge_pa: &'a [f64],
    road_height_m: &'a [f64],
}

impl<'a> InputSeries<'a> {
    /// Checks and wraps input signals (SI units: s, kg, Pa gauge, m).
    pub fn new(
        time_s: &'a [f64],
        wheel_load_kg: &'a [f64],
        valve: &'a [ValveState],
        supply_gauge_pa: &'a [f64],
        road_height_m: &'a [f64],
    ) -> Result<Self, SimError> {
        let invalid = |reason: String| SimError::InvalidInputs { reason };
        let n = time_s.len();
        if n == 0 {
            return Err(invalid("the input series has no samples".to_owned()));
        }
        for (name, len) in [
            ("wheel_load_kg", wheel_load_kg.len()),
            ("valve", valve.len()),
            ("supply_gauge_pa", supply_gauge_pa.len()),
            ("road_height_m", road_height_m.len()),
        ] {
            if len != n {
                return Err(invalid(format!("{name} has {len} samples, time_s has {n}")));
            }
        }
        if let Some(k) = time_s.iter().position(|t| !t.is_finite()) {
            return Err(invalid(format!(
                "time_s[{k}] = {} is not finite",
                time_s[k]
            )));
        }
        if let Some(k) = time_s.windows(2).position(|w| w[1] <= w[0]) {
            return Err(invalid(format!(
                "time_s is not strictly increasing: t[{}] = {} then t[{}] = {}",
                k,
                time_s[k],
                k + 1,
                time_s[k + 1]
            )));
        }
        for (name, signal) in [
            ("wheel_load_kg", wheel_load_kg),
            ("supply_gauge_pa", supply_gauge_pa),
            ("road_height_m", road_height_m),
        ] {
            if let Some(k) = signal.iter().position(|v| !v.is_finite()) {
                return Err(invalid(format!(
                    "{name}[{k}] = {} at t = {} s is not finite",
                    signal[k], time_s[k]
                )));
            }
        }
        Ok(Self {
            time_s,
            wheel_load_kg,
            valve,
            supply_gauge_pa,
            road_height_m,
        })
    }

    /// The inputs of a run.
    pub fn from_run(run: &'a Run) -> Result<Self, SimError> {
        Self::new(
            &run.time_s,
            &run.inputs.wheel_load_kg,
            &run.inputs.valve,
            &run.inputs.supply_gauge_pa,
            &run.inputs.road_height_m,
        )
    }

    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// Never true for a constructed series; present for API completeness.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    pub fn time_s(&self) -> &'a [f64] {
        self.time_s
    }

    /// The wheel load at every sample, kg.
    pub fn wheel_load_kg(&self) -> &'a [f64] {
        self.wheel_load_kg
    }

    /// The road height at every sample, m.
    pub fn road_height_m(&self) -> &'a [f64] {
        self.road_height_m
    }

    /// The inputs held from sample `k` on, `None` past the end.
    pub fn get(&self, k: usize) -> Option<InputSample> {
        (k < self.len()).then(|| self.sample(k))
    }

    /// The inputs held from sample `k`, which must be below [`Self::len`].
    pub fn sample(&self, k: usize) -> InputSample {
        InputSample {
            wheel_load_kg: self.wheel_load_kg[k],
            valve: self.valve[k],
            supply_gauge_pa: self.supply_gauge_pa[k],
            road_height_m: self.road_height_m[k],
            // Held, the road does not move between samples; followed linearly, the solver
            // gives the rate of the segment it is in.
            road_rate_m_s: 0.0,
        }
    }
}

/// Where the state starts.
#[derive(Debug, Clone, PartialEq)]
pub enum InitialState {
    /// Static equilibrium under the first sample's inputs, fixed by a measured quantity
    /// ([`SuspensionModel::initial_state`]).
    Equilibrium(InitialCondition),
    /// An explicit state vector (e.g. the end state of an earlier simulation).
    State(Vec<f64>),
    /// Static equilibrium as [`Self::Equilibrium`] with the hysteresis preloaded to `preload`
    /// of its range ([`SuspensionModel::initial_state_with_hysteresis`]: the gas then carries
    /// the wall friction and the lever is at rest), plus `offsets` (one per state, SI): a start
    /// estimated from a run's first seconds that stays relative to the equilibrium, so it
    /// still fits when the parameters change (grey-box estimation with estimated starts).
    EquilibriumOffset {
        condition: InitialCondition,
        preload: f64,
        offsets: Vec<f64>,
    },
}

impl InitialState {
    /// How the state starts, in words for a progress line or a report
    /// (`static equilibrium at sensor height 235.0 mm`).
    pub fn describe(&self) -> String {
        match self {
            Self::Equilibrium(InitialCondition::BellowPressure { gauge_pa }) => format!(
                "static equilibrium at bellow pressure {:.1} kPa",
                gauge_pa / 1e3
            ),
            Self::Equilibrium(InitialCondition::SensorHeight { height_m }) => format!(
                "static equilibrium at sensor height {:.1} mm",
                height_m * 1e3
            ),
            Self::State(_) => "given state".to_owned(),
            Self::EquilibriumOffset { condition, .. } => format!(
                "{} with its history states estimated",
                Self::Equilibrium(*condition).describe()
            ),
        }
    }

    /// The default start of every simulation and estimation of a run (`simulate`, `greybox`,
    /// the study, the apps, the Python package): static equilibrium at the run's first
    /// measured sensor height, when the run has measured outputs.
    ///
    /// Height, not pressure: the effective area rises, peaks and falls with height (eq 5.4),
    /// so one pressure can mean two equilibrium heights or none, while a height gives one
    /// pressure. `InitialCondition::BellowPressure` starts from a pressure instead.
    pub fn from_run(run: &Run) -> Option<Self> {
        let height_m = *run.outputs.as_ref()?.sensor_height_m.first()?;
        Some(Self::Equilibrium(InitialCondition::SensorHeight {
            height_m,
        }))
    }
}

/// The integration method (all from diffsol, all adaptive).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// Variable-order (1–5) BDF with a dense finite-difference Jacobian throughout (the
    /// library's default): the fastest on long quasi-static stretches between short, stiff
    /// transients, and what the estimators use. Its steps, grown long on a level road, can
    /// span a pothole or hump of a sample or a few at some tolerances (Model 1 with the
    /// built-in study's estimate on the virtual truck's road run 1 scored 27-48 % height
    /// NRMSE across rtol 1e-5 to 1e-9, 20-40 mm off where it missed one); `Auto` does not.
    #[default]
    Bdf,
    /// BDF, and Tsitouras 5(4) on the segments where a road followed linearly moves
    /// (`airsus simulate`'s and Python's default). Driving, the wheel hop keeps every state
    /// moving and the steps are the accuracy's, not the stiffness's: the explicit method of
    /// order 5 takes about a fifth of BDF's steps (90 s of the virtual truck's ISO road: 8.6 ms
    /// instead of 46 ms for the `truck` structure, 0.001 mm and 0.004 kPa off a solution at
    /// rtol 1e-9; see BENCHMARKS.md). Standing, BDF strides over the quasi-static stretches
    /// where the stiff gas and valve laws hold an explicit method to short steps (Model 2 on
    /// data-set 1: 24,000 steps against BDF's 1,500). An explicit segment over its step
    /// budget, or any solver failure, runs the whole simulation again with BDF and its
    /// fallbacks.
    ///
    /// Not the estimators' method: in the built-in study's fits it took the `truck`
    /// structure's road runs a point below their ceiling (road 1 96.4/97.6 % against
    /// 97.1/98.8 % with BDF; its error, four times BDF's, enters the finite-difference
    /// Jacobians) and cost more simulations than it saved.
    Auto,
    /// TR-BDF2, an L-stable SDIRK of order 2.
    TrBdf2,
    /// ESDIRK3(4), an L-stable SDIRK of order 3.
    Esdirk34,
    /// Tsitouras 5(4), explicit: only for non-stiff models and cross-checks. Stops at every
    /// kink of a road followed linearly (no restart).
    Tsit45,
}

/// The absolute tolerance, per state.
#[derive(Debug, Clone, PartialEq)]
pub enum AbsoluteTolerance {
    /// The same value for every state.
    Uniform(f64),
    /// One value per state, in state order.
    PerState(Vec<f64>),
    /// `atol_i = rtol * max(|x0_i|, floor)`: relative to the initial state's magnitude, with a
    /// floor for states that start at zero (velocities). The default, with `floor = 0.1`:
    /// states are SI (m, m/s, mol), so a velocity is controlled to `rtol * 0.1 m/s`.
    Scaled { floor: f64 },
}

impl Default for AbsoluteTolerance {
    fn default() -> Self {
        Self::Scaled { floor: 0.1 }
    }
}

/// Which input changes end an integration segment (the solver restarts cleanly there: new
/// held inputs, fresh derivative, fresh step size, fresh Jacobian).
///
/// Wheel load and valve state always matter: any change restarts; so does the road height
/// when it is held between samples ([`RoadInput::Hold`]; followed linearly, the default, it
/// never does). For a model that uses the supply while the valve is shut, the simulator
/// replaces `WhileFilling` by [`Self::Beyond`] with [`DEFAULT_SUPPLY_DEADBAND_PA`]. The supply
/// pressure enters the models only through the fill flow (SPEC §2, eq 3.19), so by default
/// a change restarts only when the valve is in `Fill` at the new sample; a noisy logged supply
/// pressure then costs nothing while the valve is closed or exhausting.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum SupplyRelevance {
    /// Supply changes matter only while filling (default).
    #[default]
    WhileFilling,
    /// Every supply change restarts (for a model that uses the supply pressure otherwise).
    Always,
    /// For a model that uses the supply while the valve is shut (a supply line,
    /// [`airsus_model::SuspensionModel::uses_supply_while_valve_shut`]): while filling, every
    /// change restarts; otherwise a change restarts once the supply has moved at least
    /// `deadband_pa` from the held value. A logged supply changes at nearly every sample by
    /// its sensor noise (1 kPa steps); restarting on each made such a model 20x slower, while
    /// real changes (tank droop, compressor refill: tens of kPa) are still followed to within
    /// the deadband. The simulator picks this for such models unless `Always` is asked for.
    Beyond { deadband_pa: f64 },
}

/// The supply deadband of [`SupplyRelevance::Beyond`] the simulator uses by default: a few
/// times a supply sensor's noise and resolution (1 kPa), far below a tank's real swings.
pub const DEFAULT_SUPPLY_DEADBAND_PA: f64 = 5e3;

/// Admissible state region, checked after every accepted step. Leaving it is an error
/// ([`SimError::InadmissibleState`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub enum StateBounds {
    /// From the states' roles ([`airsus_model::StateRole`]): amounts of gas and absolute
    /// temperatures must stay positive; every state must stay finite and within `±1e9` in SI
    /// units (a blow-up guard far beyond any physical suspension state).
    #[default]
    FromRoles,
    /// One `(lower, upper)` pair per state, in state order.
    PerState(Vec<(f64, f64)>),
}

/// How the road height acts between samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RoadInput {
    /// Linear between samples (first-order hold, the default): a road surface is continuous,
    /// so a sampled profile is a polyline, not a staircase of steps into the tire; and the
    /// solver need not restart at every road sample.
    #[default]
    Linear,
    /// Held constant between samples, restarting where it changes (zero-order hold, like
    /// every other input).
    Hold,
}

/// How the wheel load acts between samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LoadInput {
    /// Held constant between samples, restarting where it changes (zero-order hold, the
    /// default): a logged load changes in steps.
    #[default]
    Hold,
    /// Linear between samples (first-order hold), and a load sample ends no segment: for a
    /// load that is itself a smooth transition (a logged step eased over seconds,
    /// `airsus_estimate::ramp_logged_load`), which held would be a staircase restarting the
    /// solver at every sample (540 restarts and 6× the time on a 25-minute loading run).
    Linear,
}

/// How to integrate.
#[derive(Debug, Clone, PartialEq)]
pub struct SolverOptions {
    pub method: Method,
    /// Relative tolerance (default `1e-6`).
    pub rtol: f64,
    pub atol: AbsoluteTolerance,
    /// Step budget for the whole run (default one million); exceeding it is an error.
    pub max_steps: usize,
    /// Record the state at every sample time in the response (default off).
    pub record_states: bool,
    pub supply: SupplyRelevance,
    pub bounds: StateBounds,
    pub road: RoadInput,
    pub load: LoadInput,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            method: Method::default(),
            rtol: 1e-6,
            atol: AbsoluteTolerance::default(),
            max_steps: 1_000_000,
            record_states: false,
            supply: SupplyRelevance::default(),
            bounds: StateBounds::default(),
            road: RoadInput::default(),
            load: LoadInput::default(),
        }
    }
}

impl SolverOptions {
    pub fn with_method(mut self, method: Method) -> Self {
        self.method = method;
        self
    }

    pub fn with_rtol(mut self, rtol: f64) -> Self {
        self.rtol = rtol;
        self
    }

    pub fn with_atol(mut self, atol: AbsoluteTolerance) -> Self {
        self.atol = atol;
        self
    }

    pub fn with_states(mut self, record_states: bool) -> Self {
        self.record_states = record_states;
        self
    }

    pub fn with_road(mut self, road: RoadInput) -> Self {
        self.road = road;
        self
    }

    pub fn with_load(mut self, load: LoadInput) -> Self {
        self.load = load;
        self
    }

    pub fn with_max_steps(mut self, max_steps: usize) -> Self {
        self.max_steps = max_steps;
        self
    }
}

/// A simulation problem: a model, the inputs at the sample times, where the state starts and
/// how to integrate. Outputs are returned at exactly the input sample times.
///
/// `M` is usually `dyn SuspensionModel` (a model from `build_model`), or a concrete model type.
/// The problem borrows model and inputs; it is `Send + Sync`, so a grey-box estimator can share
/// one problem across rayon workers and [`Self::with_model`] a fresh parameter set per call.
#[derive(Debug)]
pub struct SimulationProblem<'a, M: SuspensionModel + ?Sized = dyn SuspensionModel> {
    pub model: &'a M,
    pub inputs: InputSeries<'a>,
    pub initial: InitialState,
    pub options: SolverOptions,
}

// Manual: the problem only borrows the model, so it is `Clone` for unsized models too.
impl<M: SuspensionModel + ?Sized> Clone for SimulationProblem<'_, M> {
    fn clone(&self) -> Self {
        Self {
            model: self.model,
            inputs: self.inputs,
            initial: self.initial.clone(),
            options: self.options.clone(),
        }
    }
}

impl<'a, M: SuspensionModel + ?Sized> SimulationProblem<'a, M> {
    /// A problem with default [`SolverOptions`] (BDF, rtol `1e-6`).
    pub fn new(model: &'a M, inputs: InputSeries<'a>, initial: InitialState) -> Self {
        Self {
            model,
            inputs,
            initial,
            options: SolverOptions::default(),
        }
    }

    pub fn with_options(mut self, options: SolverOptions) -> Self {
        self.options = options;
        self
    }

    /// The same problem for another model value (typically the same model with new
    /// parameters): SciML's `remake`.
    pub fn with_model<'b, N: SuspensionModel + ?Sized>(
        &self,
        model: &'b N,
    ) -> SimulationProblem<'b, N>
    where
        'a: 'b,
    {
        SimulationProblem {
            model,
            inputs: self.inputs,
            initial: self.initial.clone(),
            options: self.options.clone(),
        }
    }
}
