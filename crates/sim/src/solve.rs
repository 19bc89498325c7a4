//! The engine: `simulate(&problem)` integrates the model with a diffsol solver, segment by
//! segment between input discontinuities, and samples the outputs at the run's sample times.
//!
//! # Algorithm
//! 1. The state starts at `x0` (static equilibrium or given) at `t_0`, with inputs `u_0` held.
//! 2. A *segment* runs from the current sample to the next sample `r` whose inputs differ from
//!    the held ones in a way that matters ([`SupplyRelevance`]). The solver is given `t_r` as
//!    stop time, so no step straddles the discontinuity.
//! 3. Within a segment the solver takes its own adaptive steps; samples falling inside a step
//!    are obtained from the method's continuous extension (`interpolate`), so the step size is
//!    not limited by the 100 ms sampling.
//! 4. At `t_r` the solver restarts cleanly: the held inputs become `u_r`, `dx/dt` is recomputed,
//!    the initial step size is re-estimated (Hairer–Nørsett–Wanner II.4), BDF drops to order 1
//!    and the Jacobian is re-evaluated.
//! 5. Output `k` is `output(x(t_k), u_k)`: the sample's own inputs (the ZOH value on
//!    `[t_k, t_{k+1})`), which matters for direct feed-through (lever flex under load, eq 3.14).
//!
//! The road is the exception to the hold ([`RoadInput::Linear`], the default): a surface is
//! continuous, so the rhs sees the road interpolated linearly between samples and a road
//! sample ends no segment, except where the road starts or stops moving (a hump on a level
//! road: a solver in long steps would step over it). On a 20 s ISO 8608 road at 2 ms (Model
//! 2) that is 0 restarts instead of 9,999, 161 k rhs calls instead of 261 k, and no
//! artificial steps into the tire force (its extremes 8.6–55.2 kN instead of 7.8–55.9 kN).
//! Inside a segment the explicit method stops at every kink of the road, without a restart
//! (it loses nothing by a stop, and no feature narrower than a step is stepped over); BDF
//! steps across them (see `Engine::kinks`).
//!
//! Under [`Method::Auto`] each segment gets its method: Tsitouras 5(4) where the road moves
//! (and over a level stretch of a second or less between two such segments), BDF elsewhere;
//! at a change of method the state passes from one solver to the other at the segment's
//! clean restart.
//!
//! After every accepted step the state is checked (finite, inside [`StateBounds`]); every
//! output must be finite. A violation is a typed [`SimError`] naming model, time and state.
//!
//! # Fallback
//! BDF is the fastest method here but reuses its Newton matrix over many steps; on inputs that
//! change every few milliseconds (a road profile) the piecewise-affine damper's kink at zero
//! velocity can defeat its Newton iteration ("too many Newton failures", measured on Model 2
//! over a 3 Hz road sampled at 2 ms, where TR-BDF2 and ESDIRK34 finish). When BDF fails with a
//! solver failure the simulation is run once more with the L-stable TR-BDF2, and if its Newton
//! iteration fails too, with the explicit Tsit45 on a step budget, which needs no Newton iteration (Model 2 with a
//! study-estimated file on an ISO 8608 class C road at 50 km/h: BDF and TR-BDF2 both fail with
//! too many Newton failures at the same instant, t = 57.70 s, where Tsit45 finishes; a kink of
//! the right-hand side, such as the tire's at lift-off, is the likely cause);
//! [`SolverStatistics::fallback`] says which ran. A [`Method::Auto`] run that fails (an
//! explicit segment over its step budget, or any solver failure) is run again with BDF and
//! this chain. A state that blows up or leaves its admissible
//! region is not retried: that is the model's answer, not the method's.
//!
//! # Jacobian
//! The implicit methods get a dense Jacobian by forward differences of `rhs`, evaluated once per
//! (state, time, held input) and cached: `n + 1` rhs calls per Jacobian. diffsol asks for it
//! column by column through a Jacobian–vector product; the cache answers all columns.

use std::cell::{Cell, RefCell};

use airsus_model::{InputSample, StateInfo, SuspensionModel};
use diffsol::error::OdeSolverError;
use diffsol::ode_solver::OdeSolverStatistics;
use diffsol::ode_solver::state::StateCommon;
use diffsol::{
    BdfState, DiffsolError, NalgebraContext, NalgebraLU, NalgebraMat, NalgebraVec, OdeBuilder,
    OdeEquations, OdeSolverMethod, OdeSolverProblem, OdeSolverState, OdeSolverStopReason, RkState,
    Vector, VectorCommon,
};

use crate::error::{NamedState, SimError, SolverFailure, StateViolation};
use crate::problem::{
    AbsoluteTolerance, DEFAULT_SUPPLY_DEADBAND_PA, InitialState, LoadInput, Method, RoadInput,
    SimulationProblem, StateBounds, SupplyRelevance,
};
use crate::response::{SimulationResponse, SolverStatistics};

type Mat = NalgebraMat<f64>;
type Lu = NalgebraLU<f64>;
type V = NalgebraVec<f64>;

/// A blow-up guard for [`StateBounds::FromRoles`]: no state of a truck suspension in SI units
/// comes anywhere near this.
const BLOW_UP_LIMIT: f64 = 1e9;

/// The explicit fallback's step budget per input sample (the implicit methods' failing point
/// on a 90 s ISO road, 901 samples, took Tsit45 50,613 steps, 56 per sample, 60 ms, before
/// it stopped at the road's kinks).
const TSIT45_FALLBACK_STEPS_PER_SAMPLE: usize = 200;

/// Under [`Method::Auto`], the explicit method's step budget per sample of a driving segment
/// at rtol 1e-6 (on the virtual truck's ISO road it takes about 15; BDF takes about five
/// times as many), and at least [`AUTO_TSIT45_MIN_STEPS`] per segment: a one-sample
/// pothole's segment is two samples long, and the wheel hop it sets off is resolved in it
/// (Model 1 at rtol 1e-10: over 200 steps).
const AUTO_TSIT45_STEPS_PER_SAMPLE: usize = 100;
const AUTO_TSIT45_MIN_STEPS: usize = 2_000;

/// Under [`Method::Auto`], the longest level stretch between two moving ones that the
/// explicit method drives through, s.
const SHORT_LEVEL_STRETCH_S: f64 = 1.0;

/// Simulates `problem`: outputs (and optionally states) at exactly the input sample times.
///
/// Errors, never panics, on bad problems, failed equilibria, solver failures and blow-ups.
pub fn simulate<M: SuspensionModel + ?Sized>(
    problem: &SimulationProblem<'_, M>,
) -> Result<SimulationResponse, SimError> {
    let mut response = SimulationResponse::default();
    simulate_into(problem, &mut response)?;
    Ok(response)
}

/// As [`simulate`], writing into `response` and reusing its buffers (for estimation loops).
/// On error the content of `response` is unspecified.
pub fn simulate_into<M: SuspensionModel + ?Sized>(
    problem: &SimulationProblem<'_, M>,
    response: &mut SimulationResponse,
) -> Result<(), SimError> {
    match simulate_with(problem, problem.options.method, response) {
        Err(SimError::SolverFailed { .. }) if problem.options.method == Method::Auto => {
            // An explicit segment that was stiff after all, or a Newton failure in a BDF
            // segment: the whole run again with BDF and its fallbacks.
            let bdf = problem
                .clone()
                .with_options(problem.options.clone().with_method(Method::Bdf));
            simulate_into(&bdf, response)?;
            response.statistics.fallback.get_or_insert(Method::Bdf);
            Ok(())
        }
        Err(SimError::SolverFailed { .. }) if problem.options.method == Method::Bdf => {
            match simulate_with(problem, Method::TrBdf2, response) {
                Err(
                    newton @ SimError::SolverFailed {
                        failure: SolverFailure::TooManyNonlinearSolverFailures,
                        ..
                    },
                ) => {
                    // Only where the Newton iteration failed (what Tsit45 has none of), and on
                    // a budget: a point stiff enough to defeat both implicit methods for other
                    // reasons would cost an explicit method up to the whole step budget, and
                    // grey-box fits try many such points. Its failure is reported as TR-BDF2's.
                    let budget = problem
                        .options
                        .max_steps
                        .min(TSIT45_FALLBACK_STEPS_PER_SAMPLE * problem.inputs.len().max(1));
                    let explicit = problem
                        .clone()
                        .with_options(problem.options.clone().with_max_steps(budget));
                    if simulate_with(&explicit, Method::Tsit45, response).is_err() {
                        return Err(newton);
                    }
                    response.statistics.fallback = Some(Method::Tsit45);
                }
                other => {
                    other?;
                    response.statistics.fallback = Some(Method::TrBdf2);
                }
            }
            Ok(())
        }
        other => other,
    }
}

fn simulate_with<M: SuspensionModel + ?Sized>(
    problem: &SimulationProblem<'_, M>,
    method: Method,
    response: &mut SimulationResponse,
) -> Result<(), SimError> {
    let model = problem.model;
    let model_name = model.name();
    let names = model.state_names();
    let names = names.as_slice();
    let n = names.len();
    let options = &problem.options;
    let inputs = &problem.inputs;
    let invalid = |reason: String| SimError::InvalidProblem {
        model: model_name.to_owned(),
        reason,
    };

    if n == 0 {
        return Err(invalid("the model has no states".to_owned()));
    }
    if !(options.rtol.is_finite() && options.rtol > 0.0 && options.rtol < 1.0) {
        return Err(invalid(format!(
            "rtol = {} must be in (0, 1)",
            options.rtol
        )));
    }
    if options.max_steps == 0 {
        return Err(invalid("max_steps must be at least 1".to_owned()));
    }

    let u0 = inputs.sample(0);
    let x0 = match &problem.initial {
        InitialState::Equilibrium(ic) => {
            model
                .initial_state(&u0, ic)
                .map_err(|source| SimError::InitialState {
                    model: model_name.to_owned(),
                    source: Box::new(source),
                })?
        }
        InitialState::State(x) => x.clone(),
        InitialState::EquilibriumOffset {
            condition,
            preload,
            offsets,
        } => {
            let mut x = model
                .initial_state_with_hysteresis(&u0, condition, *preload)
                .map_err(|source| SimError::InitialState {
                    model: model_name.to_owned(),
                    source: Box::new(source),
                })?;
            if offsets.len() != x.len() {
                return Err(invalid(format!(
                    "{} start offsets for {} states",
                    offsets.len(),
                    x.len()
                )));
            }
            for (xi, d) in x.iter_mut().zip(offsets) {
                *xi += d;
            }
            x
        }
    };
    if x0.len() != n {
        return Err(invalid(format!(
            "the initial state has {} values, the model has {n} states",
            x0.len()
        )));
    }

    let atol = absolute_tolerance(&options.atol, options.rtol, &x0).map_err(invalid)?;
    let bounds = state_bounds(&options.bounds, model.states()).map_err(invalid)?;
    let t0 = inputs.time_s()[0];
    check_state(model_name, names, &bounds, t0, &x0)?;

    // Output buffers: reuse the caller's allocations.
    let len = inputs.len();
    response.model.clear();
    response.model.push_str(model_name);
    response.time_s.clear();
    response.time_s.extend_from_slice(inputs.time_s());
    response.sensor_height_m.clear();
    response.sensor_height_m.reserve(len);
    response.bellow_gauge_pa.clear();
    response.bellow_gauge_pa.reserve(len);
    response.states = if options.record_states {
        let mut history = response.states.take().unwrap_or_default();
        history.names.clear();
        history.names.extend_from_slice(names);
        history.values.clear();
        history.values.reserve(len * n);
        Some(history)
    } else {
        None
    };
    let mut recorder = Recorder {
        model,
        names,
        response,
    };
    recorder.record(t0, &x0, &u0)?;
    if len == 1 {
        recorder.response.statistics = SolverStatistics::default();
        return Ok(());
    }

    // Finite-difference increments: relative to the state's magnitude scale.
    let scales: Vec<f64> = atol.iter().map(|a| a / options.rtol).collect();
    // A road that never moves needs no interpolation.
    let road_moves = inputs.road_height_m().windows(2).any(|w| w[0] != w[1]);
    let load_moves = inputs.wheel_load_kg().windows(2).any(|w| w[0] != w[1]);
    let shared = Shared {
        model,
        input: Cell::new(u0),
        road: (options.road == RoadInput::Linear && road_moves)
            .then(|| Polyline::new(inputs.time_s(), inputs.road_height_m())),
        load: (options.load == LoadInput::Linear && load_moves)
            .then(|| Polyline::new(inputs.time_s(), inputs.wheel_load_kg())),
        epoch: Cell::new(0),
        rhs_calls: Cell::new(0),
        jacobian: RefCell::new(FdJacobian::new(n, scales)),
    };

    let rhs = |x: &[f64], _p: &[f64], t: f64, dx: &mut [f64]| shared.rhs(t, x, dx);
    let jac = |x: &[f64], _p: &[f64], t: f64, v: &[f64], y: &mut [f64]| shared.jac_vec(t, x, v, y);
    let init = |_p: &[f64], _t: f64, y: &mut [f64]| y.copy_from_slice(&x0);
    let ode = OdeBuilder::<Mat>::new()
        .t0(t0)
        .rtol(options.rtol)
        .atol(atol.iter().copied())
        .rhs_implicit(rhs, jac)
        .init(init, n)
        .build()
        .map_err(|e| invalid(format!("diffsol rejected the problem: {e}")))?;

    let engine = Engine {
        model_name,
        names,
        bounds: &bounds,
        problem,
        ode: &ode,
        shared: &shared,
        // The road's only: a load's changes are steps and ramps whose end value stays, so a
        // long step cannot miss one, and stops inside eased load steps moved the thesis
        // protocol's fits (of a loading run, no road) for nothing.
        kinks: shared
            .road
            .as_ref()
            .map(|_| followed_kinks(inputs.time_s(), inputs.road_height_m()))
            .unwrap_or_default(),
        method,
    };
    let start_failure = |e: DiffsolError| engine.solver_error(t0, &x0, &e);
    let mut progress = Progress::new(u0);
    let first = engine.segment_end(&progress);
    progress.planned = Some(first);
    // `method` is the one asked for, except where the fallback runs another.
    let mut current = match method {
        Method::Auto => engine.segment_method(0, first.1),
        other => other,
    };
    // The state a solver hands to the next at a change of method (under `Method::Auto`).
    let mut handover: Option<StateCommon<V>> = None;
    loop {
        let ended = match (current, handover.take()) {
            (Method::Bdf | Method::Auto, None) => {
                let solver = ode.bdf::<Lu>().map_err(start_failure)?;
                engine.run(solver, Method::Bdf, &mut progress, &mut recorder)?
            }
            (Method::Bdf | Method::Auto, Some(state)) => {
                let solver = ode
                    .bdf_solver::<Lu>(BdfState::new_from_common(state))
                    .map_err(start_failure)?;
                engine.run(solver, Method::Bdf, &mut progress, &mut recorder)?
            }
            (Method::Tsit45, None) => {
                let solver = ode.tsit45().map_err(start_failure)?;
                engine.run(solver, Method::Tsit45, &mut progress, &mut recorder)?
            }
            (Method::Tsit45, Some(state)) => {
                let solver = ode
                    .tsit45_solver(RkState::new_from_common(state))
                    .map_err(start_failure)?;
                engine.run(solver, Method::Tsit45, &mut progress, &mut recorder)?
            }
            // Only `Method::Auto` changes method between segments, and only to BDF or the
            // explicit method: a state handed to these would be a defect, reported as such.
            (method @ (Method::TrBdf2 | Method::Esdirk34), Some(_)) => {
                return Err(invalid(format!(
                    "internal: a state handed over to {method:?}, which no segment asks for"
                )));
            }
            (Method::TrBdf2, None) => {
                let solver = ode.tr_bdf2::<Lu>().map_err(start_failure)?;
                engine.run(solver, Method::TrBdf2, &mut progress, &mut recorder)?
            }
            (Method::Esdirk34, None) => {
                let solver = ode.esdirk34::<Lu>().map_err(start_failure)?;
                engine.run(solver, Method::Esdirk34, &mut progress, &mut recorder)?
            }
        };
        match ended {
            None => break,
            Some((next_method, state)) => {
                current = next_method;
                handover = Some(state);
            }
        }
    }
    let mut statistics = progress.statistics();
    statistics.rhs_evaluations = shared.rhs_calls.get();
    statistics.jacobian_evaluations = shared.jacobian.borrow().evaluations;
    recorder.response.statistics = statistics;
    Ok(())
}

/// Whether the inputs at a new sample end the current segment (see [`SupplyRelevance`];
/// a road or a load followed linearly between samples, [`RoadInput::Linear`] and
/// [`LoadInput::Linear`], never does).
pub fn input_change_matters(
    held: &InputSample,
    next: &InputSample,
    supply: SupplyRelevance,
    road: RoadInput,
    load: LoadInput,
) -> bool {
    if (load == LoadInput::Hold && held.wheel_load_kg != next.wheel_load_kg)
        || (road == RoadInput::Hold && held.road_height_m != next.road_height_m)
        || held.valve != next.valve
    {
        return true;
    }
    if held.supply_gauge_pa == next.supply_gauge_pa {
        return false;
    }
    match supply {
        SupplyRelevance::Always => true,
        SupplyRelevance::WhileFilling => next.valve == airsus_data::ValveState::Fill,
        SupplyRelevance::Beyond { deadband_pa } => {
            next.valve == airsus_data::ValveState::Fill
                || (next.supply_gauge_pa - held.supply_gauge_pa).abs() >= deadband_pa
        }
    }
}

/// The interior samples where a road followed linearly changes its slope.
fn followed_kinks(times: &[f64], values: &[f64]) -> Vec<usize> {
    let slope = |k: usize| (values[k + 1] - values[k]) / (times[k + 1] - times[k]);
    (1..times.len().saturating_sub(1))
        .filter(|&k| {
            let (behind, ahead) = (slope(k - 1), slope(k));
            // A ramp read from a file changes its slope by rounding at every sample.
            (ahead - behind).abs() > 1e-9 * ahead.abs().max(behind.abs())
        })
        .collect()
}

fn absolute_tolerance(atol: &AbsoluteTolerance, rtol: f64, x0: &[f64]) -> Result<Vec<f64>, String> {
    let values = match atol {
        AbsoluteTolerance::Uniform(a) => vec![*a; x0.len()],
        AbsoluteTolerance::PerState(v) => {
            if v.len() != x0.len() {
                return Err(format!(
                    "atol has {} values, the model has {} states",
                    v.len(),
                    x0.len()
                ));
            }
            v.clone()
        }
        AbsoluteTolerance::Scaled { floor } => {
            if !(floor.is_finite() && *floor > 0.0) {
                return Err(format!("the atol floor {floor} must be positive"));
            }
            x0.iter().map(|x| rtol * x.abs().max(*floor)).collect()
        }
    };
    if let Some(a) = values.iter().find(|a| !(a.is_finite() && **a > 0.0)) {
        return Err(format!("atol = {a} must be positive and finite"));
    }
    Ok(values)
}

fn state_bounds(bounds: &StateBounds, states: &[StateInfo]) -> Result<Vec<(f64, f64)>, String> {
    match bounds {
        StateBounds::FromRoles => Ok(states
            .iter()
            .map(|state| {
                if state.role.must_stay_positive() {
                    (0.0, BLOW_UP_LIMIT)
                } else {
                    (-BLOW_UP_LIMIT, BLOW_UP_LIMIT)
                }
            })
            .collect()),
        StateBounds::PerState(b) => {
            if b.len() != states.len() {
                return Err(format!(
                    "{} state bounds for {} states",
                    b.len(),
                    states.len()
                ));
            }
            if let Some((lo, hi)) = b
                .iter()
                .find(|(lo, hi)| lo.is_nan() || hi.is_nan() || lo >= hi)
            {
                return Err(format!("state bound ({lo}, {hi}) is empty"));
            }
            Ok(b.clone())
        }
    }
}

/// Finite and strictly inside the bounds.
fn check_state(
    model: &str,
    names: &[&'static str],
    bounds: &[(f64, f64)],
    t: f64,
    x: &[f64],
) -> Result<(), SimError> {
    for (i, &value) in x.iter().enumerate() {
        let (lower, upper) = bounds[i];
        let violation = if !value.is_finite() {
            StateViolation::NonFinite { name: names[i] }
        } else if value > lower && value < upper {
            continue;
        } else {
            StateViolation::OutOfBounds {
                name: names[i],
                value,
                lower,
                upper,
            }
        };
        return Err(SimError::InadmissibleState {
            model: model.to_owned(),
            time_s: t,
            violation,
            state: NamedState::new(names, x),
        });
    }
    Ok(())
}

/// What the rhs and Jacobian closures share with the driver: the held input and counters.
struct Shared<'m, M: SuspensionModel + ?Sized> {
    model: &'m M,
    input: Cell<InputSample>,
    /// The road followed linearly between samples ([`RoadInput::Linear`]).
    road: Option<Polyline<'m>>,
    /// The load followed linearly between samples ([`LoadInput::Linear`]).
    load: Option<Polyline<'m>>,
    /// Bumped at each restart so that the Jacobian cache never mixes inputs.
    epoch: Cell<u64>,
    rhs_calls: Cell<usize>,
    jacobian: RefCell<FdJacobian>,
}

/// A sampled input as a polyline: linear between samples, constant beyond the ends.
struct Polyline<'a> {
    time_s: &'a [f64],
    values: &'a [f64],
    /// The interval of the last lookup: the solver asks for nearby times, so the search
    /// starts there.
    cursor: Cell<usize>,
    /// The samples the solver's current segment runs between (first, last): the rate is
    /// taken from the polyline's segments between them, so a segment's last evaluations (at
    /// its stop time, or a rounding error past it) get the slope behind and a restart's first
    /// the slope ahead, whichever side of the sample the solver's clock lands on.
    segment: Cell<(usize, usize)>,
}

impl<'a> Polyline<'a> {
    fn new(time_s: &'a [f64], values: &'a [f64]) -> Self {
        Self {
            time_s,
            values,
            cursor: Cell::new(0),
            segment: Cell::new((0, time_s.len().saturating_sub(1))),
        }
    }

    fn value_at(&self, t: f64) -> f64 {
        self.value_and_rate_at(t).0
    }

    /// The value and its rate: the slope of the segment `t` lies in (at a sample, the one
    /// ahead), within the solver's current segment ([`Self::segment`]); at the first and last
    /// sample, the first and last segment's; 0 beyond the ends.
    fn value_and_rate_at(&self, t: f64) -> (f64, f64) {
        let (ts, hs) = (self.time_s, self.values);
        let last = ts.len() - 1;
        let slope = |k: usize| {
            if last == 0 {
                0.0
            } else {
                (hs[k + 1] - hs[k]) / (ts[k + 1] - ts[k])
            }
        };
        // The ends give the sample's own value (exactly, not interpolated); their rate is
        // that of the road there, which a two-sample series (an FMU step) sees at both ends.
        if t <= ts[0] {
            return (hs[0], if t == ts[0] { slope(0) } else { 0.0 });
        }
        if t >= ts[last] {
            return (hs[last], if t == ts[last] { slope(last - 1) } else { 0.0 });
        }
        let mut k = self.cursor.get().min(last - 1);
        while k > 0 && ts[k] > t {
            k -= 1;
        }
        while k + 1 < last && ts[k + 1] <= t {
            k += 1;
        }
        self.cursor.set(k);
        let (span, rise) = (ts[k + 1] - ts[k], hs[k + 1] - hs[k]);
        let w = (t - ts[k]) / span;
        let (first, last_sample) = self.segment.get();
        let within = k.clamp(first, last_sample.saturating_sub(1).max(first));
        (hs[k] + w * rise, slope(within))
    }
}

impl<M: SuspensionModel + ?Sized> Shared<'_, M> {
    fn rhs(&self, t: f64, x: &[f64], dx: &mut [f64]) {
        self.rhs_calls.set(self.rhs_calls.get() + 1);
        let mut input = self.input.get();
        if let Some(road) = &self.road {
            (input.road_height_m, input.road_rate_m_s) = road.value_and_rate_at(t);
        }
        if let Some(load) = &self.load {
            input.wheel_load_kg = load.value_at(t);
        }
        self.model.rhs(t, x, &input, dx);
    }

    fn hold(&self, input: InputSample) {
        self.input.set(input);
        self.epoch.set(self.epoch.get() + 1);
    }

    fn jac_vec(&self, t: f64, x: &[f64], v: &[f64], y: &mut [f64]) {
        // The closure is only ever called from the one thread running this simulation and
        // never re-entrantly, so the borrow cannot fail; `try_borrow_mut` keeps it panic-free.
        let Ok(mut jac) = self.jacobian.try_borrow_mut() else {
            y.fill(f64::NAN);
            return;
        };
        let epoch = self.epoch.get();
        if !jac.is_cached(t, x, epoch) {
            jac.evaluate(t, x, epoch, |t, x, dx| self.rhs(t, x, dx));
        }
        jac.mul(v, y);
    }
}

/// A dense forward-difference Jacobian, cached for one (t, x, input epoch).
struct FdJacobian {
    n: usize,
    scales: Vec<f64>,
    valid: bool,
    t: f64,
    epoch: u64,
    x: Vec<f64>,
    f0: Vec<f64>,
    xp: Vec<f64>,
    fp: Vec<f64>,
    /// Column-major `n x n`.
    j: Vec<f64>,
    evaluations: usize,
}

impl FdJacobian {
    fn new(n: usize, scales: Vec<f64>) -> Self {
        Self {
            n,
            scales,
            valid: false,
            t: 0.0,
            epoch: 0,
            x: vec![0.0; n],
            f0: vec![0.0; n],
            xp: vec![0.0; n],
            fp: vec![0.0; n],
            j: vec![0.0; n * n],
            evaluations: 0,
        }
    }

    fn is_cached(&self, t: f64, x: &[f64], epoch: u64) -> bool {
        self.valid && self.t == t && self.epoch == epoch && self.x == x
    }

    fn evaluate(
        &mut self,
        t: f64,
        x: &[f64],
        epoch: u64,
        mut f: impl FnMut(f64, &[f64], &mut [f64]),
    ) {
        let n = self.n;
        self.evaluations += 1;
        self.x.copy_from_slice(x);
        self.t = t;
        self.epoch = epoch;
        f(t, x, &mut self.f0);
        let sqrt_eps = f64::EPSILON.sqrt();
        for c in 0..n {
            self.xp.copy_from_slice(x);
            let h = sqrt_eps * x[c].abs().max(self.scales[c]);
            self.xp[c] = x[c] + h;
            let h = self.xp[c] - x[c];
            f(t, &self.xp, &mut self.fp);
            for r in 0..n {
                self.j[c * n + r] = (self.fp[r] - self.f0[r]) / h;
            }
        }
        self.valid = true;
    }

    fn mul(&self, v: &[f64], y: &mut [f64]) {
        let n = self.n;
        y.fill(0.0);
        for (c, &vc) in v.iter().enumerate() {
            if vc != 0.0 {
                for (yr, jrc) in y.iter_mut().zip(&self.j[c * n..(c + 1) * n]) {
                    *yr += jrc * vc;
                }
            }
        }
    }
}

/// Writes outputs (and states) sample by sample.
struct Recorder<'r, 'm, M: SuspensionModel + ?Sized> {
    model: &'m M,
    names: &'m [&'static str],
    response: &'r mut SimulationResponse,
}

impl<M: SuspensionModel + ?Sized> Recorder<'_, '_, M> {
    fn record(&mut self, t: f64, x: &[f64], u: &InputSample) -> Result<(), SimError> {
        let y = self.model.output(x, u);
        for (output, value) in [
            ("sensor_height_m", y.sensor_height_m),
            ("bellow_gauge_pa", y.bellow_gauge_pa),
        ] {
            if !value.is_finite() {
                return Err(SimError::NonFiniteOutput {
                    model: self.model.name().to_owned(),
                    time_s: t,
                    output,
                    state: NamedState::new(self.names, x),
                });
            }
        }
        self.response.sensor_height_m.push(y.sensor_height_m);
        self.response.bellow_gauge_pa.push(y.bellow_gauge_pa);
        if let Some(states) = self.response.states.as_mut() {
            states.values.extend_from_slice(x);
        }
        Ok(())
    }
}

struct Engine<'e, 'a, M: SuspensionModel + ?Sized, Eqn: OdeEquations> {
    model_name: &'static str,
    names: &'e [&'static str],
    bounds: &'e [(f64, f64)],
    problem: &'e SimulationProblem<'a, M>,
    ode: &'e OdeSolverProblem<Eqn>,
    shared: &'e Shared<'a, M>,
    /// The road's kinks ([`followed_kinks`]), where the explicit method stops (no restart).
    ///
    /// So no feature of the road narrower than a step is stepped over. BDF can: Model 1 with
    /// the built-in study's estimate on the virtual truck's road run 1 (level road,
    /// one-sample potholes, four-sample humps) missed a pothole at rtol 1e-6 and a hump at
    /// 1e-5 and 1e-8, 20-40 mm off; the steps that had grown long on the level road spanned
    /// each feature, and the right-hand side was never evaluated inside it. BDF stopping at
    /// a kink wherever its step was longer than the samples around it felt every feature at
    /// every tolerance, but is not done: the `truck` structure's road 1 moved by 0.00015 mm
    /// (three stops), and that moved the variants' estimates (variant 3's held-out data-set 4
    /// pressure 94.6 → 91.3 %, variant 5's 93.9 → 86.2 %; the thesis models' fits took 2-5
    /// times the simulations, to lower losses). [`Method::Auto`] runs the explicit method
    /// wherever the road moves, so `airsus simulate` feels every feature.
    kinks: Vec<usize>,
    /// The method this simulation runs: the requested one, or a fallback's.
    method: Method,
}

/// Where a run stands: what the next segment starts from, and what the solvers did so far.
struct Progress {
    /// The inputs held over the current segment.
    held: InputSample,
    /// The next sample to record.
    next: usize,
    /// The sample the current segment starts at.
    segment_start: usize,
    /// The first kink not yet passed.
    kink_cursor: usize,
    /// The current segment's `(r, last)` ([`Engine::segment_end`]) where the restart that
    /// began it already found them.
    planned: Option<(usize, usize)>,
    steps: usize,
    restarts: usize,
    method_changes: usize,
    /// The finished solvers' counts.
    rejected_steps: usize,
    newton_iterations: usize,
    linear_solver_setups: usize,
}

impl Progress {
    fn new(held: InputSample) -> Self {
        Self {
            held,
            next: 1,
            segment_start: 0,
            kink_cursor: 0,
            planned: None,
            steps: 0,
            restarts: 0,
            method_changes: 0,
            rejected_steps: 0,
            newton_iterations: 0,
            linear_solver_setups: 0,
        }
    }

    fn add(&mut self, s: &OdeSolverStatistics) {
        self.rejected_steps += s.number_of_error_test_failures;
        self.newton_iterations += s.number_of_nonlinear_solver_iterations;
        self.linear_solver_setups += s.number_of_linear_solver_setups;
    }

    fn statistics(&self) -> SolverStatistics {
        SolverStatistics {
            steps: self.steps,
            rejected_steps: self.rejected_steps,
            rhs_evaluations: 0,
            jacobian_evaluations: 0,
            newton_iterations: self.newton_iterations,
            linear_solver_setups: self.linear_solver_setups,
            restarts: self.restarts,
            method_changes: self.method_changes,
            fallback: None,
        }
    }
}

impl<'e, 'a, M, Eqn> Engine<'e, 'a, M, Eqn>
where
    M: SuspensionModel + ?Sized,
    Eqn: OdeEquations<T = f64, V = V, C = NalgebraContext> + 'e,
{
    fn solver_error(&self, t: f64, x: &[f64], error: &DiffsolError) -> SimError {
        let failure = match error {
            DiffsolError::OdeSolverError(OdeSolverError::StepSizeTooSmall { .. }) => {
                SolverFailure::StepSizeTooSmall
            }
            DiffsolError::OdeSolverError(OdeSolverError::TooManyErrorTestFailures { .. }) => {
                SolverFailure::TooManyErrorTestFailures
            }
            DiffsolError::OdeSolverError(OdeSolverError::TooManyNonlinearSolverFailures {
                ..
            }) => SolverFailure::TooManyNonlinearSolverFailures,
            other => SolverFailure::Other(other.to_string()),
        };
        SimError::SolverFailed {
            model: self.model_name.to_owned(),
            time_s: t,
            failure,
            state: NamedState::new(self.names, x),
        }
    }

    /// The current solver state as a failure (time and state at the failure).
    fn fail<S: OdeSolverMethod<'e, Eqn>>(&self, solver: &S, error: &DiffsolError) -> SimError {
        let state = solver.state();
        self.solver_error(state.t, state.y.inner().as_slice(), error)
    }

    fn supply_relevance(&self) -> SupplyRelevance {
        match self.problem.options.supply {
            SupplyRelevance::WhileFilling if self.problem.model.uses_supply_while_valve_shut() => {
                SupplyRelevance::Beyond {
                    deadband_pa: DEFAULT_SUPPLY_DEADBAND_PA,
                }
            }
            chosen => chosen,
        }
    }

    /// The segment `progress` is at: `(r, last)`, `r` the first sample whose inputs end it
    /// (the run's length if none does), `last` the sample it ends at.
    fn segment_end(&self, progress: &Progress) -> (usize, usize) {
        let inputs = &self.problem.inputs;
        let options = &self.problem.options;
        let supply_relevance = self.supply_relevance();
        let len = inputs.len();
        // A load followed linearly still ends a segment where it starts or stops moving: a
        // long step across the start of a ramp met it with a stale Newton matrix and failed
        // ("too many Newton failures" before a load step on data-set 2); two restarts per
        // eased step instead of one per sample.
        // The same for a road followed linearly: a solver that had settled into long steps on
        // a level road stepped over a 0.3 s hump as if it were not there (Model 2, 125 steps
        // over a 70 s road run of seven humps and potholes, not one felt).
        let starts_or_stops_moving = |values: &[f64], r: usize| {
            r >= 1 && r + 1 < len && ((values[r] == values[r - 1]) != (values[r + 1] == values[r]))
        };
        let load = inputs.wheel_load_kg();
        let road = inputs.road_height_m();
        let motion_kink = |r: usize| {
            (options.load == LoadInput::Linear && starts_or_stops_moving(load, r))
                || (options.road == RoadInput::Linear && starts_or_stops_moving(road, r))
        };
        let mut r = progress.next;
        while r < len
            && !motion_kink(r)
            && !input_change_matters(
                &progress.held,
                &inputs.sample(r),
                supply_relevance,
                options.road,
                options.load,
            )
        {
            r += 1;
        }
        (r, r.min(len - 1))
    }

    /// The method for the segment from `start` to `last`: the requested one, or under
    /// [`Method::Auto`] Tsitouras 5(4) where the road (followed linearly) moves, BDF
    /// elsewhere. The valve does not matter: a fill while driving took the explicit method
    /// fewer steps than BDF (Model 2, 40 s of rough road with a 2 s fill: 6,210 steps
    /// throughout against 7,232 with BDF over the fill).
    ///
    /// A level stretch of a second or less between two moving ones is driven through too: a
    /// road logged in whole millimetres repeats a sample now and then while the wheel hops,
    /// and each would otherwise cost two changes of solver.
    fn segment_method(&self, start: usize, last: usize) -> Method {
        if self.method != Method::Auto {
            return self.method;
        }
        if self.shared.road.is_none() {
            return Method::Bdf;
        }
        let road = self.problem.inputs.road_height_m();
        let times = self.problem.inputs.time_s();
        let moves = |k: usize| road.get(k + 1).is_some_and(|next| *next != road[k]);
        let driving = (start..last).any(moves)
            || (start >= 1
                && moves(start - 1)
                && moves(last)
                && times[last] - times[start] <= SHORT_LEVEL_STRETCH_S);
        if driving { Method::Tsit45 } else { Method::Bdf }
    }

    /// Stops `solver` at sample `to`, the road's rate taken between samples `from` and `to`
    /// (so the evaluations at the stop itself get the slope behind).
    fn stop_at<S: OdeSolverMethod<'e, Eqn>>(
        &self,
        solver: &mut S,
        from: usize,
        to: usize,
    ) -> Result<(), SimError> {
        if let Some(road) = &self.shared.road {
            road.segment.set((from, to));
        }
        solver
            .set_stop_time(self.problem.inputs.time_s()[to])
            .map_err(|e| self.fail(solver, &e))
    }

    /// Runs `solver` (of `method`) from `progress` on, segment by segment, until the run
    /// ends (`None`) or the next segment wants another method: then its state, restarted
    /// under the next segment's inputs, and that method.
    fn run<S: OdeSolverMethod<'e, Eqn>>(
        &self,
        mut solver: S,
        method: Method,
        progress: &mut Progress,
        recorder: &mut Recorder<'_, 'a, M>,
    ) -> Result<Option<(Method, StateCommon<V>)>, SimError> {
        let inputs = &self.problem.inputs;
        let options = &self.problem.options;
        let times = inputs.time_s();
        let len = times.len();
        let n = self.names.len();
        let mut y = V::zeros(n, NalgebraContext::default());
        let mut dx = vec![0.0; n];
        // The explicit method stops at every kink of the road: a one-step method loses
        // nothing by a stop, and takes the steps on either side without the kink's error
        // (the `truck` structure on 90 s of ISO road: 4,284 rejected steps instead of 7,263).
        // The implicit methods step across kinks as they always did; see `Engine::kinks`.
        let stops_at_kinks = method == Method::Tsit45;
        // Steps go as rtol^(-1/5) for a method of order 5.
        let tolerance_factor = (1e-6 / options.rtol).powf(0.2).max(1.0);

        while progress.next < len {
            let (r, last) = progress
                .planned
                .unwrap_or_else(|| self.segment_end(progress));
            let wanted = self.segment_method(progress.segment_start, last);
            if wanted != method {
                progress.add(solver.get_statistics());
                progress.method_changes += 1;
                return Ok(Some((wanted, solver.into_state().into_common())));
            }
            progress.planned = None;
            let steps_before = progress.steps;
            let explicit_budget =
                (self.method == Method::Auto && method == Method::Tsit45).then(|| {
                    let samples = (last - progress.segment_start).max(1) as f64;
                    let per_sample = AUTO_TSIT45_STEPS_PER_SAMPLE as f64 * tolerance_factor;
                    (per_sample * samples).max(AUTO_TSIT45_MIN_STEPS as f64) as usize
                });
            // The sample the solver is stopped at: the segment's end, or a kink on the way.
            let mut stop = last;
            let mut stop_from = progress.segment_start;
            self.stop_at(&mut solver, stop_from, last)?;

            loop {
                if progress.steps >= options.max_steps {
                    return Err(self.fail_steps(&solver, options.max_steps));
                }
                if let Some(budget) = explicit_budget {
                    // A segment stiff enough to hold the explicit method to short steps is
                    // BDF's: the caller runs the whole simulation again with it.
                    if progress.steps - steps_before > budget {
                        return Err(self.fail_steps(&solver, budget));
                    }
                }
                let (t_at, h) = {
                    let state = solver.state();
                    (state.t, state.h)
                };
                // Within diffsol's round-off of the current time a kink is behind: a stop
                // there would be "at the current time".
                let behind = t_at + 100.0 * f64::EPSILON * (t_at.abs() + h.abs());
                while progress.kink_cursor < self.kinks.len()
                    && times[self.kinks[progress.kink_cursor]] <= behind
                {
                    progress.kink_cursor += 1;
                }
                let wanted_stop = self
                    .kinks
                    .get(progress.kink_cursor)
                    .copied()
                    .filter(|&k| stops_at_kinks && k < last && times[k] <= t_at + h)
                    .unwrap_or(last);
                if wanted_stop != stop {
                    stop = wanted_stop;
                    self.stop_at(&mut solver, stop_from, stop)?;
                }
                let reason = solver.step().map_err(|e| self.fail(&solver, &e))?;
                progress.steps += 1;
                let state = solver.state();
                let t_now = state.t;
                let x_now = state.y.inner().as_slice();
                let at_stop = matches!(reason, OdeSolverStopReason::TstopReached);
                // Samples inside the step first (each checked), so that a violation is reported
                // at the first sample past it rather than at the end of a long step.
                while progress.next <= stop
                    && (times[progress.next] <= t_now || (at_stop && progress.next == stop))
                {
                    let k = progress.next;
                    let u = inputs.sample(k);
                    let t_k = times[k];
                    if at_stop && k == stop {
                        check_state(self.model_name, self.names, self.bounds, t_k, x_now)?;
                        recorder.record(t_k, x_now, &u)?;
                    } else {
                        solver
                            .interpolate_inplace(t_k, &mut y)
                            .map_err(|e| self.fail(&solver, &e))?;
                        let x_k = y.inner().as_slice();
                        check_state(self.model_name, self.names, self.bounds, t_k, x_k)?;
                        recorder.record(t_k, x_k, &u)?;
                    }
                    progress.next += 1;
                }
                check_state(self.model_name, self.names, self.bounds, t_now, x_now)?;
                if at_stop {
                    if stop == last {
                        break;
                    }
                    // On past the kink, without a restart: the slope ahead from here.
                    stop_from = stop;
                    stop = last;
                    self.stop_at(&mut solver, stop_from, last)?;
                }
            }

            if r < len && progress.next < len {
                // Clean restart at t_r under the new inputs.
                progress.held = inputs.sample(r);
                self.shared.hold(progress.held);
                // The restart begins the next segment: the road's rate there is the one ahead.
                progress.segment_start = last;
                if let Some(road) = &self.shared.road {
                    road.segment.set((last, len - 1));
                }
                // The step size is estimated for the method that takes the next segment, and
                // a solver that hands over needs no fresh Jacobian.
                let next_segment = self.segment_end(progress);
                progress.planned = Some(next_segment);
                let next_method = self.segment_method(last, next_segment.1);
                let order = match next_method {
                    same if same == method => solver.order().max(1),
                    Method::Tsit45 => 5,
                    _ => 1,
                };
                {
                    let mut state = solver.state_mut();
                    let t = *state.t;
                    self.shared.rhs(t, state.y.inner().as_slice(), &mut dx);
                    for (i, v) in dx.iter().enumerate() {
                        state.dy[i] = *v;
                    }
                    state.set_step_size(1.0, &self.ode.atol, self.ode.rtol, &self.ode.eqn, order);
                }
                if next_method == method {
                    // Forces a fresh Jacobian (and Newton matrix) at the restart.
                    drop(solver.checkpoint());
                }
                progress.restarts += 1;
            }
        }
        progress.add(solver.get_statistics());
        Ok(None)
    }

    fn fail_steps<S: OdeSolverMethod<'e, Eqn>>(&self, solver: &S, max_steps: usize) -> SimError {
        let state = solver.state();
        SimError::SolverFailed {
            model: self.model_name.to_owned(),
            time_s: state.t,
            failure: SolverFailure::TooManySteps { max_steps },
            state: NamedState::new(self.names, state.y.inner().as_slice()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use airsus_data::ValveState;

    fn sample(load: f64, valve: ValveState, supply: f64, road: f64) -> InputSample {
        InputSample {
            wheel_load_kg: load,
            valve,
            supply_gauge_pa: supply,
            road_height_m: road,
            road_rate_m_s: 0.0,
        }
    }

    #[test]
    fn restart_policy() {
        use ValveState::*;
        let matters = |held: &InputSample, next: InputSample, supply| {
            input_change_matters(held, &next, supply, RoadInput::Hold, LoadInput::Hold)
        };
        let held = sample(3000.0, Closed, 850e3, 0.0);
        let w = SupplyRelevance::WhileFilling;
        assert!(!matters(&held, held, w));
        assert!(matters(&held, sample(3001.0, Closed, 850e3, 0.0), w));
        assert!(matters(&held, sample(3000.0, Closed, 850e3, 0.01), w));
        assert!(matters(&held, sample(3000.0, Exhaust, 850e3, 0.0), w));
        // supply noise: irrelevant while closed or exhausting, relevant while filling
        assert!(!matters(&held, sample(3000.0, Closed, 851e3, 0.0), w));
        let exhausting = sample(3000.0, Exhaust, 850e3, 0.0);
        assert!(!matters(
            &exhausting,
            sample(3000.0, Exhaust, 849e3, 0.0),
            w
        ));
        let filling = sample(3000.0, Fill, 850e3, 0.0);
        assert!(matters(&filling, sample(3000.0, Fill, 849e3, 0.0), w));
        assert!(matters(
            &held,
            sample(3000.0, Closed, 851e3, 0.0),
            SupplyRelevance::Always
        ));
        // A supply line: noise inside the deadband is held, a real swing restarts, and every
        // change counts while filling.
        let line = SupplyRelevance::Beyond { deadband_pa: 5e3 };
        assert!(!matters(&held, sample(3000.0, Closed, 854e3, 0.0), line));
        assert!(matters(&held, sample(3000.0, Closed, 845e3, 0.0), line));
        assert!(matters(&filling, sample(3000.0, Fill, 849e3, 0.0), line));
        // A road followed linearly between samples never ends a segment.
        assert!(!input_change_matters(
            &held,
            &sample(3000.0, Closed, 850e3, 0.01),
            w,
            RoadInput::Linear,
            LoadInput::Hold
        ));
        // Nor does a load followed linearly; a valve change still does.
        let linear_load = |next: InputSample| {
            input_change_matters(&held, &next, w, RoadInput::Linear, LoadInput::Linear)
        };
        assert!(!linear_load(sample(3010.0, Closed, 850e3, 0.0)));
        assert!(linear_load(sample(3010.0, Fill, 850e3, 0.0)));
    }

    #[test]
    fn a_sampled_road_is_a_polyline() {
        let (t, h) = ([0.0, 0.1, 0.2, 0.3], [0.0, 0.01, -0.01, 0.0]);
        let road = Polyline::new(&t, &h);
        // (time, height, rate): the rate is the slope of the segment the time lies in, the
        // one ahead at a sample, the end segments' at the ends, and 0 beyond them.
        for (at, want, rate) in [
            (-1.0, 0.0, 0.0),
            (0.0, 0.0, 0.1),
            (0.3, 0.0, 0.1),
            (0.05, 0.005, 0.1),
            (0.15, 0.0, -0.2),
            (0.25, -0.005, 0.1),
            (0.1, 0.01, -0.2),
            (0.02, 0.002, 0.1),
            (9.0, 0.0, 0.0),
        ] {
            let (value, slope) = road.value_and_rate_at(at);
            assert!(
                (value - want).abs() < 1e-15 && (slope - rate).abs() < 1e-12,
                "{at}: {value} {slope}"
            );
        }
        // Where the solver's segment ends at a sample, the rate there, and a rounding error
        // past it, is the segment behind's; the next segment's start gets the one ahead.
        road.segment.set((0, 1));
        for at in [0.1, 0.1 + 1e-15] {
            let (value, rate) = road.value_and_rate_at(at);
            assert!(
                (value - 0.01).abs() < 1e-15 && (rate - 0.1).abs() < 1e-12,
                "{at}: {value} {rate}"
            );
        }
        road.segment.set((1, 3));
        for at in [0.1, 0.1 - 1e-15] {
            assert!((road.value_and_rate_at(at).1 + 0.2).abs() < 1e-12, "{at}");
        }
        road.segment.set((0, 3));
        // Elsewhere the segment ahead still: at 0.2 s, 0.1 m/s (not the -0.2 behind).
        assert!((road.value_and_rate_at(0.2).1 - 0.1).abs() < 1e-12);
    }

    #[test]
    fn finite_difference_jacobian_is_cached_and_accurate() {
        // f(x) = [x0^2 + x1, sin(x1)]
        let calls = Cell::new(0);
        let f = |_t: f64, x: &[f64], dx: &mut [f64]| {
            calls.set(calls.get() + 1);
            dx[0] = x[0] * x[0] + x[1];
            dx[1] = x[1].sin();
        };
        let mut jac = FdJacobian::new(2, vec![1.0, 1.0]);
        let x = [1.5, 0.3];
        assert!(!jac.is_cached(0.0, &x, 0));
        jac.evaluate(0.0, &x, 0, f);
        assert_eq!(calls.get(), 3);
        assert!(jac.is_cached(0.0, &x, 0));
        assert!(!jac.is_cached(0.0, &x, 1), "a new input epoch invalidates");
        assert!(!jac.is_cached(0.1, &x, 0));
        let mut y = [0.0; 2];
        jac.mul(&[1.0, 0.0], &mut y);
        assert!((y[0] - 3.0).abs() < 1e-6 && y[1].abs() < 1e-12, "{y:?}");
        jac.mul(&[0.0, 1.0], &mut y);
        assert!(
            (y[0] - 1.0).abs() < 1e-6 && (y[1] - 0.3f64.cos()).abs() < 1e-6,
            "{y:?}"
        );
    }
}
