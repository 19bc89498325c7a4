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
//! road: a solver in long steps would step over it). On a 20 s ISO 8608 road at 2 ms (Model 2) that is 0 restarts
//! instead of 9,999, 161 k rhs calls instead of 261 k, and no artificial steps into the tire
//! force (its extremes 8.6–55.2 kN instead of 7.8–55.9 kN).
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
//! [`SolverStatistics::fallback`] says which ran. A state that blows up or leaves its admissible
//! region is not retried: that is the model's answer, not the method's.
//!
//! # Jacobian
//! The implicit methods get a dense Jacobian by forward differences of `rhs`, evaluated once per
//! (state, time, held input) and cached: `n + 1` rhs calls per Jacobian. diffsol asks for it
//! column by column through a Jacobian–vector product; the cache answers all columns.

use std::cell::{Cell, RefCell};

use airsus_model::{InputSample, StateInfo, SuspensionModel};
use diffsol::error::OdeSolverError;
use diffsol::{
    DiffsolError, NalgebraContext, NalgebraLU, NalgebraMat, NalgebraVec, OdeBuilder, OdeEquations,
    OdeSolverMethod, OdeSolverProblem, OdeSolverStopReason, Vector, VectorCommon,
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
/// on a 90 s ISO road, 901 samples, takes Tsit45 50,613 steps, 56 per sample, 60 ms).
const TSIT45_FALLBACK_STEPS_PER_SAMPLE: usize = 200;

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
    };
    let start_failure = |e: DiffsolError| engine.solver_error(t0, &x0, &e);
    let mut statistics = match method {
        Method::Bdf => engine.run(ode.bdf::<Lu>().map_err(start_failure)?, &mut recorder)?,
        Method::TrBdf2 => engine.run(ode.tr_bdf2::<Lu>().map_err(start_failure)?, &mut recorder)?,
        Method::Esdirk34 => {
            engine.run(ode.esdirk34::<Lu>().map_err(start_failure)?, &mut recorder)?
        }
        Method::Tsit45 => engine.run(ode.tsit45().map_err(start_failure)?, &mut recorder)?,
    };
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

    fn run<S: OdeSolverMethod<'e, Eqn>>(
        &self,
        mut solver: S,
        recorder: &mut Recorder<'_, 'a, M>,
    ) -> Result<SolverStatistics, SimError> {
        let inputs = &self.problem.inputs;
        let options = &self.problem.options;
        let supply_relevance = match options.supply {
            SupplyRelevance::WhileFilling if self.problem.model.uses_supply_while_valve_shut() => {
                SupplyRelevance::Beyond {
                    deadband_pa: DEFAULT_SUPPLY_DEADBAND_PA,
                }
            }
            chosen => chosen,
        };
        let times = inputs.time_s();
        let len = times.len();
        let n = self.names.len();
        let mut y = V::zeros(n, NalgebraContext::default());
        let mut dx = vec![0.0; n];
        let mut held = inputs.sample(0);
        let mut next = 1;
        // The sample the current solver segment starts at.
        let mut segment_start = 0usize;
        let mut steps = 0usize;
        let mut restarts = 0usize;
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

        while next < len {
            // The segment ends at the first sample whose inputs matter and differ, or at the end.
            let mut r = next;
            while r < len
                && !motion_kink(r)
                && !input_change_matters(
                    &held,
                    &inputs.sample(r),
                    supply_relevance,
                    options.road,
                    options.load,
                )
            {
                r += 1;
            }
            let last = r.min(len - 1);
            let t_end = times[last];
            if let Some(road) = &self.shared.road {
                road.segment.set((segment_start, last));
            }
            solver
                .set_stop_time(t_end)
                .map_err(|e| self.fail(&solver, &e))?;

            loop {
                if steps >= options.max_steps {
                    return Err(self.fail_steps(&solver, options.max_steps));
                }
                let reason = solver.step().map_err(|e| self.fail(&solver, &e))?;
                steps += 1;
                let state = solver.state();
                let t_now = state.t;
                let x_now = state.y.inner().as_slice();
                let at_stop = matches!(reason, OdeSolverStopReason::TstopReached);
                // Samples inside the step first (each checked), so that a violation is reported
                // at the first sample past it rather than at the end of a long step.
                while next <= last && (times[next] <= t_now || (at_stop && next == last)) {
                    let u = inputs.sample(next);
                    let t_k = times[next];
                    if at_stop && next == last {
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
                    next += 1;
                }
                check_state(self.model_name, self.names, self.bounds, t_now, x_now)?;
                if at_stop {
                    break;
                }
            }

            if r < len && next < len {
                // Clean restart at t_r under the new inputs.
                held = inputs.sample(r);
                self.shared.hold(held);
                // The restart begins the next segment: the road's rate there is the one ahead.
                segment_start = last;
                if let Some(road) = &self.shared.road {
                    road.segment.set((segment_start, len - 1));
                }
                let order = solver.order();
                {
                    let mut state = solver.state_mut();
                    let t = *state.t;
                    self.shared.rhs(t, state.y.inner().as_slice(), &mut dx);
                    for (i, v) in dx.iter().enumerate() {
                        state.dy[i] = *v;
                    }
                    state.set_step_size(
                        1.0,
                        &self.ode.atol,
                        self.ode.rtol,
                        &self.ode.eqn,
                        order.max(1),
                    );
                }
                // Forces a fresh Jacobian (and Newton matrix) at the restart.
                drop(solver.checkpoint());
                restarts += 1;
            }
        }

        let s = solver.get_statistics();
        Ok(SolverStatistics {
            steps: s.number_of_steps,
            rejected_steps: s.number_of_error_test_failures,
            rhs_evaluations: 0,
            jacobian_evaluations: 0,
            newton_iterations: s.number_of_nonlinear_solver_iterations,
            linear_solver_setups: s.number_of_linear_solver_setups,
            restarts,
            fallback: None,
        })
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
