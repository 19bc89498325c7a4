//! The grey-box *problem* (what is minimised) and the *options* of the solver (how), kept
//! apart as in argmin; [`super::estimate`] is the executor that runs them.

use crate::error::EstimateError;
use crate::submodel::{EffectiveAreaOptions, sweep_friction_n};
use airsus_data::{EffectiveAreaLaw, ForceMap, Run};
use airsus_model::{InitialCondition, SuspensionModel};
use airsus_sim::{InitialState, SolverOptions};

/// One freed parameter: a short name of the model (SPEC §5, `parameter_info`) and optional
/// bounds that narrow the model's admissible range (its [`airsus_model::ParameterInfo`]
/// bounds are the default).
#[derive(Debug, Clone, PartialEq)]
pub struct FreeParameter {
    pub name: String,
    pub lower: Option<f64>,
    pub upper: Option<f64>,
}

impl FreeParameter {
    pub fn new(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            lower: None,
            upper: None,
        }
    }

    pub fn with_bounds(mut self, lower: f64, upper: f64) -> Self {
        self.lower = Some(lower);
        self.upper = Some(upper);
        self
    }
}

/// What fixes each run's initial static equilibrium (the runs start at rest).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum InitialChoice {
    /// The first measured sensor height (default). The reference truck works near the flat
    /// top of the effective area, where a pressure pins the height down poorly (see
    /// `airsus_model` corner docs); the height also makes the initial pressure a *prediction*
    /// of the parameters (force balance), which is information for `p0..p4` and `m2`.
    #[default]
    SensorHeight,
    /// The first measured bellow pressure.
    BellowPressure,
}

impl InitialChoice {
    /// What fixes `run`'s static equilibrium: its first measured height or pressure; `None`
    /// where the run has no measured outputs.
    pub(crate) fn condition(self, run: &Run) -> Option<InitialCondition> {
        let outputs = run.outputs.as_ref()?;
        Some(match self {
            Self::SensorHeight => InitialCondition::SensorHeight {
                height_m: *outputs.sensor_height_m.first()?,
            },
            Self::BellowPressure => InitialCondition::BellowPressure {
                gauge_pa: *outputs.bellow_gauge_pa.first()?,
            },
        })
    }
}

/// How the residuals are made dimensionless and weighed against each other.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Normalisation {
    /// Each output by its spread pooled over all runs; a run counts in proportion to its
    /// length (the default, and the thesis' NRMSE).
    #[default]
    PooledSpread,
    /// Each output of each run by its own measurement noise (estimated from the data), each
    /// run weighted equally whatever its length: a model that explains everything but the
    /// noise scores 1 per run and output, whatever the output's spread.
    ///
    /// Not the default, measured on the built-in study (seed 1, stop 43, every model with its
    /// prefix starts, global stage and load ramps), mean held-out NRMSE over both outputs,
    /// pooled → noise level: valve protocol `truck` 96.1 → 96.2 %, `m2x` 62.4 → 64.8,
    /// `m2xh` 69.5 → 73.3 (data-set 4 pressure −24.1 → −2.6), but `m1` 60.8 → 58.4 and `m2`
    /// 60.5 → 57.9 (data-set 4 pressure −16.1 → −29.1); the thesis protocol's `truck` 85.2 →
    /// 76.3 (its road runs lose 15-21 points; on its one estimation run only the two
    /// outputs' relative weight changes) and `m1` 7.0 → −1.6. Before the prefix starts and
    /// the global stage it lifted every model's data-set 4 pressure (m2 −48.7 → 8.9 %, truck
    /// 16.8 → 37.3 %): a long loading run no longer drowned a valve run's small pressure
    /// swings. `greybox` m2 on ds1 + ds3 from the nominal truck, ds4 pressure, pooled →
    /// noise: seed 1 −143.6 → −83.7 %, seed 2 −6.6 → −5.4 %, seed 3 −228.1 → −79.7 %, but
    /// seed 5 −65.5 → −77.3 %. And where a structure misses a run's pressure by 50× its noise,
    /// that block dominates the Jacobian: from a poor start (the submodel fits, seed 5) the
    /// identifiability screen then froze every m2 parameter. Issue #12, items 3 and 4.
    NoiseLevel,
}

/// Relative weights of the two outputs in the loss (after normalisation, see
/// [`GreyboxProblem`]); `0` leaves an output out.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct OutputWeights {
    pub height: f64,
    pub pressure: f64,
}

impl Default for OutputWeights {
    fn default() -> Self {
        Self {
            height: 1.0,
            pressure: 1.0,
        }
    }
}

/// A bellow force map (lab: heights, gauge pressures, forces) as a prior on a model's
/// effective-area law (issue #13 item 3): one residual per point, `(p A_eff(h, p) − F) / σ_F`,
/// scaled so that the map at its noise `σ_F` weighs as much as one output of a run explained
/// to its noise (the mean over the runs' blocks). The runs pin the area only at the heights the
/// truck visited; a law freed on them alone can run away elsewhere (on the virtual truck: the
/// held-out long valve steps' pressure moved by 3 points with the weights of the estimation
/// runs, and the screen left some of the quartic's coefficients undetermined). A model without
/// a truck file ignores it.
#[derive(Debug, Clone)]
pub struct ForceMapPrior<'a> {
    pub map: &'a ForceMap,
    /// The map's force error `σ_F`, N: the load cell's noise and what the law cannot follow
    /// (e.g. the rms misfit of the effective-area fit to the map), floored at 0.1 % of the
    /// map's rms force.
    pub force_noise_n: f64,
    /// The wall friction in each reading, N ([`crate::submodel::sweep_friction_n`]; empty:
    /// none), taken out of the readings before they are compared with `p A_eff`.
    ///
    /// A map measured in up and down sweeps reads `p A_eff ∓ F_c`. Left in, the friction is
    /// most of `σ_F` (on the virtual truck's lab map about 180 N against the load cell's 60
    /// N), and the prior held the area ten times more loosely than the map determines it: on
    /// variant 2 the fit bent the area 1.2 % at the map's lowest height to absorb the valve's
    /// and the wall's errors, 2.5 kPa of the held-out data-set 4's pressure.
    pub friction_n: Vec<f64>,
}

impl<'a> ForceMapPrior<'a> {
    /// The prior of `map` at the force error `force_noise_n`, with the wall friction read
    /// from its sweeps taken out of the readings.
    pub fn new(map: &'a ForceMap, force_noise_n: f64) -> Self {
        Self {
            map,
            force_noise_n,
            // Heights closer than the effective-area fit's default tolerance are one height.
            friction_n: sweep_friction_n(map, EffectiveAreaOptions::default().height_tolerance_m)
                .unwrap_or_default(),
        }
    }

    /// `p A(h, p) − (F − F_friction)` at point `k` of `map` under `law`, N, with the wall
    /// friction in the reading `friction_n[k]` (none past the slice's end).
    pub fn force_error_n(
        map: &ForceMap,
        friction_n: &[f64],
        law: &EffectiveAreaLaw,
        k: usize,
    ) -> f64 {
        let gauge = map.bellow_gauge_pa[k];
        let friction = friction_n.get(k).copied().unwrap_or(0.0);
        gauge * law.area_clamped_m2(map.bellow_height_m[k], gauge) - (map.force_n[k] - friction)
    }

    /// The rms of [`Self::force_error_n`] over `map`, N: for a law fitted to the map (the
    /// study's start), the map's `σ_F`.
    pub fn misfit_n(map: &ForceMap, friction_n: &[f64], law: &EffectiveAreaLaw) -> f64 {
        let n = map.len().max(1) as f64;
        ((0..map.len())
            .map(|k| Self::force_error_n(map, friction_n, law, k).powi(2))
            .sum::<f64>()
            / n)
            .sqrt()
    }
}

/// A grey-box estimation problem (thesis 3.2.3/5.2.6, SPEC §4): a model whose current
/// parameter values are the nominal (start) point, the estimation runs, and the freed
/// parameters.
///
/// The loss is the simulation error (thesis eq 3.29 with `ŷ` the *simulated* output, as
/// MATLAB `greyest`/`nlgreyest` with simulation focus), summed over all runs, each run
/// starting from its own static equilibrium:
///
/// ```text
/// V(θ) = Σ_runs Σ_k  w_h² (h_k − ĥ_k(θ))² / σ_h²  +  w_p² (p_k − p̂_k(θ))² / σ_p²
/// ```
///
/// with `σ_h`, `σ_p` set by [`Normalisation`]. By default ([`Normalisation::PooledSpread`])
/// they are the within-run spreads of the measured height and pressure pooled over all
/// estimation runs (floored at the sensor resolutions 0.1 mm and 0.1 kPa, SPEC §1): both
/// outputs dimensionless, and with a single run a run's term is `N ((1 − NRMSE_h/100)² +
/// (1 − NRMSE_p/100)²)` (eq 3.33). The spread is pooled, not per run, because an output that
/// hardly moves in one run (the pressure at constant load while the valve pulses) would
/// otherwise weigh that run's small offsets enormously; a long run counts in proportion to
/// its length. [`Normalisation::NoiseLevel`] divides each run's outputs by their own
/// measurement noise instead, each run weighing the same.
#[derive(Debug, Clone)]
pub struct GreyboxProblem<'a> {
    pub model: &'a dyn SuspensionModel,
    pub runs: Vec<&'a Run>,
    pub free: Vec<FreeParameter>,
    pub weights: OutputWeights,
    pub normalisation: Normalisation,
    pub initial: InitialChoice,
    /// Per run (in `runs` order), the start a prefix fit estimated
    /// ([`crate::estimate_initial_state`]: an equilibrium at a fitted height plus offsets of
    /// the history states, re-solved under every trial parameter set). `None` or empty: the
    /// equilibrium `initial` names.
    pub start_states: Vec<Option<InitialState>>,
    /// ODE solver options of every simulation (default: BDF, rtol 1e-6, as `airsus-sim`).
    pub solver: SolverOptions,
    /// Seconds after each change of the logged load that the loss leaves out (0: none).
    /// A log records a step where the wheel takes the load over seconds, each time
    /// differently; fitted to those seconds, the parameters absorb the transition's shape. On
    /// the virtual truck, the `truck` structure started at its true values on data-sets 1
    /// and 3 ran away to a creep time of 0.9 s and an unsprung mass of 158 kg (data-set 3
    /// pressure 90.8 → 7.9 %); with 10 s left out it stayed near the truth (88.0 %).
    pub exclude_after_load_change_s: f64,
    /// A bellow force map that enters the loss as a prior on the model's effective-area law
    /// ([`ForceMapPrior`]). `None`: the runs alone.
    pub force_map: Option<ForceMapPrior<'a>>,
    /// Per run (in `runs` order), a further weight on each output, multiplying `weights`
    /// after the normalisation; empty: 1 for every run. What a caller raises on a run and
    /// output the pooled loss would otherwise trade for the others (the study's guard that
    /// no estimation run ends worse than the start values explained it). The force map's
    /// prior keeps the weight the unweighted runs give it.
    pub run_weights: Vec<OutputWeights>,
}

/// Checks a time to leave out after each logged load change, given by a user
/// (`--exclude-after-load-change-s`, Python's `exclude_after_load_change_s`).
pub fn check_load_change_exclusion_s(seconds: f64) -> Result<f64, String> {
    if seconds.is_finite() && seconds >= 0.0 {
        Ok(seconds)
    } else {
        Err(format!("{seconds}: expected a time in seconds, 0 or more"))
    }
}

/// Checks a force-map error given by a user (`--force-map-noise-n`, Python's
/// `force_map_noise_n`).
pub fn check_force_map_noise_n(newtons: f64) -> Result<f64, String> {
    if newtons.is_finite() && newtons > 0.0 {
        Ok(newtons)
    } else {
        Err(format!(
            "{newtons}: expected a force error in newtons, above 0"
        ))
    }
}

impl<'a> GreyboxProblem<'a> {
    /// A problem freeing `free` (short names, default bounds) on `runs`.
    pub fn new(model: &'a dyn SuspensionModel, runs: &[&'a Run], free: &[&str]) -> Self {
        Self {
            model,
            runs: runs.to_vec(),
            free: free.iter().map(|n| FreeParameter::new(*n)).collect(),
            weights: OutputWeights::default(),
            normalisation: Normalisation::default(),
            initial: InitialChoice::default(),
            start_states: Vec::new(),
            solver: SolverOptions::default(),
            exclude_after_load_change_s: 0.0,
            force_map: None,
            run_weights: Vec::new(),
        }
    }

    /// Adds `map`, measured with a force error of `force_noise_n` (checked with
    /// [`check_force_map_noise_n`] where a user gives it), as a prior on the effective-area
    /// law ([`ForceMapPrior`]). `None`: the misfit of the model's own law to the map
    /// ([`ForceMapPrior::misfit_n`]), its noise when the law was fitted to it.
    pub fn with_force_map(mut self, map: &'a ForceMap, force_noise_n: Option<f64>) -> Self {
        let mut prior = ForceMapPrior::new(map, 0.0);
        prior.force_noise_n = force_noise_n.unwrap_or_else(|| {
            self.model.truck_parameters().map_or(0.0, |truck| {
                ForceMapPrior::misfit_n(map, &prior.friction_n, &truck.bellow.effective_area)
            })
        });
        self.force_map = Some(prior);
        self
    }

    /// Starts run `i` from `starts[i]` (when `Some`).
    pub fn with_start_states(mut self, starts: Vec<Option<InitialState>>) -> Self {
        self.start_states = starts;
        self
    }

    /// Narrows the bounds of a freed parameter (no effect if `name` is not freed; the
    /// estimator validates them).
    pub fn with_bounds(mut self, name: &str, lower: f64, upper: f64) -> Self {
        for p in &mut self.free {
            if p.name == name {
                p.lower = Some(lower);
                p.upper = Some(upper);
            }
        }
        self
    }

    pub fn with_weights(mut self, weights: OutputWeights) -> Self {
        self.weights = weights;
        self
    }

    /// Weighs each run's outputs by `run_weights[i]` on top of `weights`
    /// ([`GreyboxProblem::run_weights`]).
    pub fn with_run_weights(mut self, run_weights: Vec<OutputWeights>) -> Self {
        self.run_weights = run_weights;
        self
    }

    /// `run_weights` as one weight per run, or none at all: an error names the counts.
    pub(crate) fn check_run_weights(&self) -> Result<(), EstimateError> {
        if self.run_weights.is_empty() || self.run_weights.len() == self.runs.len() {
            return Ok(());
        }
        Err(EstimateError::InvalidOption(format!(
            "{} run weights for {} runs",
            self.run_weights.len(),
            self.runs.len()
        )))
    }

    /// The run weights of a problem on the runs `picked` (indices into `runs`, in that
    /// order): empty where this problem has none.
    pub(crate) fn run_weights_of(&self, picked: &[usize]) -> Vec<OutputWeights> {
        if self.run_weights.is_empty() {
            return Vec::new();
        }
        picked
            .iter()
            .map(|&i| self.run_weights.get(i).copied().unwrap_or_default())
            .collect()
    }

    /// Leaves the `seconds` after each logged load change out of the loss (checked with
    /// [`check_load_change_exclusion_s`] where a user gives it).
    pub fn with_exclusion_after_load_changes(mut self, seconds: f64) -> Self {
        self.exclude_after_load_change_s = seconds;
        self
    }

    pub fn with_normalisation(mut self, normalisation: Normalisation) -> Self {
        self.normalisation = normalisation;
        self
    }

    pub fn with_initial(mut self, initial: InitialChoice) -> Self {
        self.initial = initial;
        self
    }

    pub fn with_solver(mut self, solver: SolverOptions) -> Self {
        self.solver = solver;
        self
    }
}

/// What to do with freed parameters the runs cannot determine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum IdentifiabilityPolicy {
    /// Keep them at their nominal values and estimate the rest (default).
    #[default]
    FixAtNominal,
    /// Estimate them anyway; only report (their values are then arbitrary along the
    /// undetermined direction).
    ReportOnly,
}

/// How the solver works and when it stops.
#[derive(Debug, Clone, PartialEq)]
pub struct GreyboxOptions {
    /// Levenberg–Marquardt iterations (Jacobian evaluations) per fit, at least 1.
    pub max_iterations: usize,
    /// Relative tolerance on the scaled parameter step and on the gradient's angle to the
    /// residuals (MINPACK `xtol`, `gtol`), and on the loss decrease where `loss_tolerance`
    /// is `None`.
    pub tolerance: f64,
    /// On the loss decrease alone (MINPACK `ftol`), in (0, 1): a fit stops once a step gains,
    /// and is predicted to gain, less than this share of the sum of squares. `None`:
    /// `tolerance`. The alternation's refits use
    /// [`crate::joint::JOINT_REFIT_LOSS_TOLERANCE`] where this is tighter.
    pub loss_tolerance: Option<f64>,
    /// Forward-difference step in scaled coordinates (a fraction of each parameter's scale,
    /// usually its nominal magnitude).
    pub fd_step: f64,
    pub policy: IdentifiabilityPolicy,
    /// A parameter (or a direction of parameters) whose standard deviation exceeds this
    /// fraction of its scale is "not determined by these runs".
    pub max_relative_std: f64,
    /// Singular values of the column-normalised Jacobian below `rcond · s_max` count as a
    /// structural rank deficiency.
    pub rcond: f64,
    /// Correlations above this (in magnitude) are reported.
    pub correlation_warning: f64,
    /// Parallelise the finite-difference Jacobian (and runs) with rayon.
    pub parallel: bool,
    /// Keep the pooled estimate where it explains an estimation run and output worse than
    /// the start values did, naming each such trade, instead of refitting with the traded
    /// blocks weighted more ([`crate::no_trade`], the default). A fit as MATLAB's `greyest`
    /// returns it, to compare with one.
    pub allow_trades: bool,
}

impl Default for GreyboxOptions {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            tolerance: 1e-8,
            loss_tolerance: None,
            fd_step: 1e-4,
            policy: IdentifiabilityPolicy::default(),
            max_relative_std: 0.5,
            rcond: 1e-7,
            correlation_warning: 0.99,
            parallel: true,
            allow_trades: false,
        }
    }
}

impl GreyboxOptions {
    pub fn with_max_iterations(mut self, n: usize) -> Self {
        self.max_iterations = n;
        self
    }

    /// [`Self::allow_trades`].
    pub fn with_allowed_trades(mut self, allow: bool) -> Self {
        self.allow_trades = allow;
        self
    }

    pub fn with_policy(mut self, policy: IdentifiabilityPolicy) -> Self {
        self.policy = policy;
        self
    }
}
