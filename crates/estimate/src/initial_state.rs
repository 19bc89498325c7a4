//! A run's initial internal state, estimated from its first seconds (issue #12, item 2).
//!
//! A run does not start at rest in the model's sense: the bellow wall's friction and creep,
//! the gas temperature and the amount of air carry the run's history. At the same load and
//! height, a run that starts after a fill sits several kPa from one that starts after an
//! exhaust. Static equilibrium at the first measured height ([`InitialState::from_run`])
//! cannot know that, and the error decays only as slowly as those states do (minutes).
//!
//! The prefix method: start from that equilibrium, free the states whose role carries history
//! ([`StateRole::BellowAir`], [`StateRole::Force`], [`StateRole::GasTemperature`]), and fit
//! them by least squares (Levenberg–Marquardt, crate `levenberg-marquardt`) so that the
//! simulated outputs match the measured ones over a short prefix (default 10 s), each output
//! weighted by its measurement noise ([`airsus_validate::estimate_noise_std`]). The parameters
//! stay fixed. Never worse than the equilibrium on the prefix: if the fit does not improve it,
//! the equilibrium is kept.

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::storage::Owned;
use nalgebra::{DMatrix, DVector, Dyn};

use airsus_data::Run;
use airsus_model::{StateRole, SuspensionModel};
use airsus_sim::{InitialState, InputSeries, SimulationProblem, simulate};

use crate::error::EstimateError;
use crate::greybox::{HEIGHT_RESOLUTION_M, PRESSURE_RESOLUTION_PA, measurement_noise};

/// Default length of the prefix, s.
pub const DEFAULT_PREFIX_S: f64 = 10.0;

/// How a simulation of a measured run starts.
///
/// The default stays the equilibrium: parameters estimated today assume it (the grey-box
/// fit starts every run there), and scoring them from a fitted start mixes two assumptions.
/// With parameters that are right (the virtual truck's true ones), the prefix start brings
/// data-set 3's pressure from 76.3 % to the noise ceiling, 90.8 %; with a structure that
/// mismatches (Model 3), fitting the air amount to 10 s can shift the whole run. Estimating
/// the start jointly with the parameters is the next step (issue #12, item 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StartMethod {
    /// Static equilibrium at the first measured sensor height ([`InitialState::from_run`]).
    #[default]
    Equilibrium,
    /// That equilibrium with the history-carrying states fitted to the first seconds.
    Prefix,
}

impl StartMethod {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Equilibrium => "equilibrium",
            Self::Prefix => "prefix",
        }
    }
}

/// Options of [`estimate_initial_state`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrefixOptions {
    /// Length of the prefix the states are fitted to, s.
    pub prefix_s: f64,
    pub max_iterations: usize,
}

impl Default for PrefixOptions {
    fn default() -> Self {
        Self {
            prefix_s: DEFAULT_PREFIX_S,
            max_iterations: 30,
        }
    }
}

/// One state the prefix fit moved.
#[derive(Debug, Clone, PartialEq)]
pub struct AdjustedState {
    pub name: &'static str,
    pub unit: &'static str,
    pub equilibrium: f64,
    pub estimated: f64,
}

/// The estimated start of a run.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimatedStart {
    pub initial: InitialState,
    pub method: StartMethod,
    /// The freed states, equilibrium value and estimate (empty for the equilibrium).
    pub adjusted: Vec<AdjustedState>,
    /// RMS of the noise-normalised prefix residuals from the equilibrium and from the
    /// estimate (1 ≈ the noise level).
    pub prefix_rms_equilibrium: f64,
    pub prefix_rms_estimated: f64,
}

impl EstimatedStart {
    /// In words, for a progress line or a report.
    pub fn describe(&self) -> String {
        match self.method {
            StartMethod::Equilibrium => self.initial.describe(),
            StartMethod::Prefix => {
                let moved: Vec<String> = self
                    .adjusted
                    .iter()
                    .filter(|s| s.estimated != s.equilibrium)
                    .map(|s| format!("{} {:+.4e} {}", s.name, s.estimated - s.equilibrium, s.unit))
                    .collect();
                format!(
                    "static equilibrium with its history states fitted to the first seconds ({}); prefix residual {:.2} → {:.2} × noise",
                    if moved.is_empty() {
                        "unchanged".to_owned()
                    } else {
                        moved.join(", ")
                    },
                    self.prefix_rms_equilibrium,
                    self.prefix_rms_estimated
                )
            }
        }
    }
}

/// The states a prefix fit may move: those whose role carries the run's history.
fn history_states(model: &dyn SuspensionModel) -> Vec<usize> {
    model
        .states()
        .iter()
        .enumerate()
        .filter(|(_, s)| {
            matches!(
                s.role,
                StateRole::BellowAir | StateRole::Force | StateRole::GasTemperature
            )
        })
        .map(|(i, _)| i)
        .collect()
}

/// The step that is "one unit" of a freed state in the fit's scaled coordinates.
fn scale(unit: &str, value: f64) -> f64 {
    let typical: f64 = match unit {
        "N" => 100.0,
        "m" => 1e-3,
        "K" => 1.0,
        _ => 0.0,
    };
    typical.max(1e-3 * value.abs()).max(1e-9)
}

struct PrefixFit<'a> {
    model: &'a dyn SuspensionModel,
    inputs: InputSeries<'a>,
    x0: Vec<f64>,
    free: Vec<usize>,
    scales: Vec<f64>,
    measured_h: &'a [f64],
    measured_p: &'a [f64],
    noise_h: f64,
    noise_p: f64,
    z: DVector<f64>,
}

impl PrefixFit<'_> {
    fn state(&self, z: &DVector<f64>) -> Vec<f64> {
        let mut x = self.x0.clone();
        for (k, &i) in self.free.iter().enumerate() {
            x[i] += z[k] * self.scales[k];
        }
        x
    }

    /// Noise-normalised residuals of height and pressure; `None` when the start does not
    /// simulate (an inadmissible state, say).
    fn residuals_at(&self, z: &DVector<f64>) -> Option<DVector<f64>> {
        let problem =
            SimulationProblem::new(self.model, self.inputs, InitialState::State(self.state(z)));
        let response = simulate(&problem).ok()?;
        let n = self.measured_h.len();
        let mut r = DVector::zeros(2 * n);
        for k in 0..n {
            r[k] = (response.sensor_height_m[k] - self.measured_h[k]) / self.noise_h;
            r[n + k] = (response.bellow_gauge_pa[k] - self.measured_p[k]) / self.noise_p;
        }
        Some(r)
    }
}

/// A failed trial simulation counts as a large residual rather than an abort.
const FAILED_RESIDUAL: f64 = 1e3;

impl LeastSquaresProblem<f64, Dyn, Dyn> for PrefixFit<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, z: &DVector<f64>) {
        self.z = z.clone();
    }

    fn params(&self) -> DVector<f64> {
        self.z.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        Some(
            self.residuals_at(&self.z).unwrap_or_else(|| {
                DVector::from_element(2 * self.measured_h.len(), FAILED_RESIDUAL)
            }),
        )
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        // Forward differences in scaled coordinates: each column one prefix simulation.
        let base = self.residuals()?;
        let mut jacobian = DMatrix::zeros(base.len(), self.z.len());
        for k in 0..self.z.len() {
            let step = 1e-3;
            let mut z = self.z.clone();
            z[k] += step;
            let r = self.residuals_at(&z).unwrap_or_else(|| {
                DVector::from_element(2 * self.measured_h.len(), FAILED_RESIDUAL)
            });
            jacobian.set_column(k, &((r - &base) / step));
        }
        Some(jacobian)
    }
}

fn rms(r: &DVector<f64>) -> f64 {
    (r.norm_squared() / r.len() as f64).sqrt()
}

/// The start of `run` by `method`: the equilibrium at the first measured height, or that
/// with its history states fitted to the first `options.prefix_s` seconds.
pub fn estimate_initial_state(
    model: &dyn SuspensionModel,
    run: &Run,
    method: StartMethod,
    options: &PrefixOptions,
) -> Result<EstimatedStart, EstimateError> {
    let invalid = |reason: &str| EstimateError::InvalidRun {
        run: run.name.clone(),
        reason: reason.to_owned(),
    };
    let equilibrium = InitialState::from_run(run)
        .ok_or_else(|| invalid("it has no measured outputs to start from"))?;
    let unchanged = |rms: f64| EstimatedStart {
        initial: equilibrium.clone(),
        method: StartMethod::Equilibrium,
        adjusted: vec![],
        prefix_rms_equilibrium: rms,
        prefix_rms_estimated: rms,
    };
    if method == StartMethod::Equilibrium {
        return Ok(unchanged(f64::NAN));
    }
    if !(options.prefix_s.is_finite() && options.prefix_s > 0.0) {
        return Err(EstimateError::InvalidOption(format!(
            "the prefix must be a positive time in s, got {}",
            options.prefix_s
        )));
    }
    let outputs = run.measured().map_err(|e| invalid(&e.to_string()))?;
    let t0 = run.time_s.first().copied().unwrap_or(0.0);
    let n = run
        .time_s
        .iter()
        .take_while(|t| **t - t0 <= options.prefix_s + 1e-9)
        .count();
    if n < 3 {
        return Err(invalid("the prefix holds fewer than 3 samples"));
    }
    // Each output in units of its noise over the whole run, floored at the sensors'
    // quantisation, as the grey-box estimator weighs it.
    let noise_h = measurement_noise(&outputs.sensor_height_m, HEIGHT_RESOLUTION_M);
    let noise_p = measurement_noise(&outputs.bellow_gauge_pa, PRESSURE_RESOLUTION_PA);

    let all = InputSeries::from_run(run).map_err(|e| invalid(&e.to_string()))?;
    let inputs = InputSeries::new(
        &all.time_s()[..n],
        &run.inputs.wheel_load_kg[..n],
        &run.inputs.valve[..n],
        &run.inputs.supply_gauge_pa[..n],
        &run.inputs.road_height_m[..n],
    )
    .map_err(|e| invalid(&e.to_string()))?;
    let InitialState::Equilibrium(condition) = equilibrium else {
        return Ok(unchanged(f64::NAN));
    };
    let x0 = model.initial_state(&inputs.sample(0), &condition)?;
    let free = history_states(model);
    let states = model.states();
    let scales: Vec<f64> = free.iter().map(|&i| scale(states[i].unit, x0[i])).collect();
    let fit = PrefixFit {
        model,
        inputs,
        x0: x0.clone(),
        free: free.clone(),
        scales,
        measured_h: &outputs.sensor_height_m[..n],
        measured_p: &outputs.bellow_gauge_pa[..n],
        noise_h,
        noise_p,
        z: DVector::zeros(free.len()),
    };
    let start = fit
        .residuals_at(&fit.z)
        .ok_or_else(|| invalid("the equilibrium start does not simulate"))?;
    let rms_start = rms(&start);
    if free.is_empty() {
        return Ok(unchanged(rms_start));
    }
    let lm = LevenbergMarquardt::new().with_patience(options.max_iterations.max(1));
    let (fit, _report) = lm.minimize(fit);
    let best = fit.z.clone();
    let rms_best = fit.residuals_at(&best).map_or(f64::INFINITY, |r| rms(&r));
    if !(rms_best < rms_start) {
        return Ok(unchanged(rms_start));
    }
    let x = fit.state(&best);
    let offsets: Vec<f64> = x.iter().zip(&x0).map(|(a, b)| a - b).collect();
    Ok(EstimatedStart {
        adjusted: free
            .iter()
            .map(|&i| AdjustedState {
                name: states[i].name,
                unit: states[i].unit,
                equilibrium: x0[i],
                estimated: x[i],
            })
            .collect(),
        initial: InitialState::EquilibriumOffset { condition, offsets },
        method: StartMethod::Prefix,
        prefix_rms_equilibrium: rms_start,
        prefix_rms_estimated: rms_best,
    })
}

/// How a caller asks a simulation of a run to start: the command line's `--initial-*` flags
/// and Python's `initial_state`, resolved in one place.
#[derive(Debug, Clone, PartialEq)]
pub enum StartChoice {
    /// From the run's measurements by `method` (default: the equilibrium).
    FromRun(StartMethod, PrefixOptions),
    /// Static equilibrium at this bellow gauge pressure, kPa.
    PressureKpa(f64),
    /// Static equilibrium at this sensor height, mm.
    HeightMm(f64),
    /// This state vector (SI, the model's state order).
    State(Vec<f64>),
}

impl Default for StartChoice {
    fn default() -> Self {
        Self::FromRun(StartMethod::default(), PrefixOptions::default())
    }
}

/// The start `choice` asks for on `run`, with a description for a progress line. A run
/// without measured outputs cannot start `FromRun`: the error says what to give instead.
pub fn resolve_start(
    model: &dyn SuspensionModel,
    run: &Run,
    choice: &StartChoice,
) -> Result<(InitialState, String), EstimateError> {
    let initial = match choice {
        StartChoice::PressureKpa(kpa) => {
            InitialState::Equilibrium(airsus_model::InitialCondition::BellowPressure {
                gauge_pa: kpa * airsus_data::units::PA_PER_KPA,
            })
        }
        StartChoice::HeightMm(mm) => {
            InitialState::Equilibrium(airsus_model::InitialCondition::SensorHeight {
                height_m: airsus_data::units::m_from_mm(*mm),
            })
        }
        StartChoice::State(x) => InitialState::State(x.clone()),
        StartChoice::FromRun(method, options) => {
            if run.outputs.is_none() {
                return Err(EstimateError::InvalidRun {
                    run: run.name.clone(),
                    reason: "it has no measured outputs to start from: give an initial pressure, height or state".to_owned(),
                });
            }
            let start = estimate_initial_state(model, run, *method, options)?;
            let what = start.describe();
            return Ok((start.initial, what));
        }
    };
    let what = initial.describe();
    Ok((initial, what))
}
