//! `airsus.simulate`: crates/cli/src/commands/simulate.rs without the file output.

use anyhow::{Context, bail};
use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use airsus_data::units::{PA_PER_KPA, mm_from_m};
use airsus_data::{Outputs, TruckParameters};
use airsus_estimate::{PrefixOptions, StartChoice, StartMethod, resolve_start};
use airsus_sim::{InputSeries, Method, SimulationProblem, SolverOptions};
use airsus_truck::models::build_any_model;

use crate::error::OrPy;
use crate::runs::{RunSource, RunSpec};
use crate::truck::NativeTruck;

/// How an estimation's runs start, by the command's name (`--initial-state` of `greybox`
/// and `study`): the start method, and whether the estimation runs' starts are refitted with
/// the parameters (`joint`) or fitted once and held (`prefix`).
pub fn parse_estimation_start(name: &str) -> anyhow::Result<(StartMethod, bool)> {
    Ok(match name {
        "equilibrium" => (StartMethod::Equilibrium, false),
        "prefix" => (StartMethod::Prefix, false),
        "joint" => (StartMethod::Prefix, true),
        other => bail!("initial_state `{other}`: expected `joint`, `prefix` or `equilibrium`"),
    })
}

/// The integration method by its command-line name (`--method`).
pub fn parse_method(name: &str) -> anyhow::Result<Method> {
    Ok(match name {
        "auto" => Method::Auto,
        "bdf" => Method::Bdf,
        "tr-bdf2" | "trbdf2" => Method::TrBdf2,
        "esdirk34" => Method::Esdirk34,
        "tsit45" => Method::Tsit45,
        other => {
            bail!("unknown method `{other}`; the methods are: auto, bdf, tr-bdf2, esdirk34, tsit45")
        }
    })
}

struct Simulated {
    model: &'static str,
    what: String,
    time_s: Vec<f64>,
    height_mm: Vec<f64>,
    pressure_kpa: Vec<f64>,
    states: Vec<(&'static str, Vec<f64>)>,
    statistics: airsus_sim::SolverStatistics,
    nrmse: Option<(Option<f64>, Option<f64>)>,
}

#[allow(clippy::too_many_arguments)]
fn run_simulation(
    model_name: &str,
    truck: &TruckParameters,
    source: &RunSource,
    initial: StartChoice,
    rtol: f64,
    method: Method,
    record_states: bool,
    load_ramp_s: Option<f64>,
    load_transitions_s: Option<Vec<f64>>,
) -> anyhow::Result<Simulated> {
    if !(rtol.is_finite() && rtol > 0.0 && rtol < 1.0) {
        bail!("rtol {rtol} must be between 0 and 1");
    }
    let mut run = source.load(Outputs::IfPresent)?;
    if let Some(tau) = load_ramp_s {
        let tau = airsus_estimate::check_load_ramp_s(tau).map_err(anyhow::Error::msg)?;
        run = airsus_estimate::ramp_logged_load(&run, tau);
    }
    let mut longest_transition_s = load_ramp_s.unwrap_or(0.0);
    if let Some(durations) = &load_transitions_s {
        if load_ramp_s.is_some() {
            bail!("give load_ramp_s (one time for every change) or load_transitions_s, not both");
        }
        airsus_estimate::check_load_transitions(&run, durations)
            .map_err(|e| anyhow::anyhow!("load_transitions_s: {e}"))?;
        run = airsus_estimate::ease_logged_load(&run, durations);
        longest_transition_s = durations.iter().copied().fold(0.0, f64::max);
    }
    let model = build_any_model(model_name, truck)?;

    let (initial, what) = resolve_start(&*model, &run, &initial)
        .with_context(|| format!("the start of run {}", source.label()))?;

    let inputs = InputSeries::from_run(&run)?;
    let options = airsus_estimate::solver_for_ramp(
        &SolverOptions::default()
            .with_method(method)
            .with_rtol(rtol)
            .with_states(record_states),
        longest_transition_s,
    );
    let problem = SimulationProblem::new(&*model, inputs, initial).with_options(options);
    let response = airsus_sim::simulate(&problem).with_context(|| {
        format!(
            "simulating model {} over run {}",
            model.name(),
            source.label()
        )
    })?;

    // As `write_run` converts the simulated outputs to file units.
    let height_mm: Vec<f64> = response
        .sensor_height_m
        .iter()
        .map(|&m| mm_from_m(m))
        .collect();
    let pressure_kpa: Vec<f64> = response
        .bellow_gauge_pa
        .iter()
        .map(|&pa| pa / PA_PER_KPA)
        .collect();
    let states = match &response.states {
        Some(history) => history
            .names
            .iter()
            .map(|&name| (name, history.trajectory(name).unwrap_or_default()))
            .collect(),
        None => Vec::new(),
    };
    // The NRMSE the command prints against the run's measurements (SI, eq 3.33).
    let nrmse = run.outputs.as_ref().map(|measured| {
        (
            airsus_validate::nrmse_percent(&measured.sensor_height_m, &response.sensor_height_m)
                .ok(),
            airsus_validate::nrmse_percent(&measured.bellow_gauge_pa, &response.bellow_gauge_pa)
                .ok(),
        )
    });
    Ok(Simulated {
        model: model.name(),
        what,
        time_s: run.time_s,
        height_mm,
        pressure_kpa,
        states,
        statistics: response.statistics,
        nrmse,
    })
}

/// Simulates `model` with `truck`'s parameters over a run's inputs, as `airsus simulate` does.
///
/// `initial_kind`: `None` (the run's first measured height), `"pressure_kpa"` or `"height_mm"`
/// with `initial_value`, or `"state"` with `initial_state` (SI, the model's state order).
/// Returns `{"model", "initial", "time_s", "height_mm", "pressure_kpa", "states",
/// "statistics", "nrmse_height", "nrmse_pressure"}`.
#[pyfunction]
#[pyo3(signature = (model, truck, run, initial_kind=None, initial_value=None, initial_state=None, rtol=None, method=None, states=false, load_ramp_s=None, load_transitions_s=None))]
#[allow(clippy::too_many_arguments)]
pub fn simulate<'py>(
    py: Python<'py>,
    model: String,
    truck: PyRef<'py, NativeTruck>,
    run: RunSpec<'py>,
    initial_kind: Option<String>,
    initial_value: Option<f64>,
    initial_state: Option<PyReadonlyArray1<'py, f64>>,
    rtol: Option<f64>,
    method: Option<String>,
    states: bool,
    load_ramp_s: Option<f64>,
    load_transitions_s: Option<Vec<f64>>,
) -> PyResult<Bound<'py, PyDict>> {
    let params = truck.params.clone();
    drop(truck);
    let source = RunSource::from_spec(run)?;
    let initial = match initial_kind.as_deref() {
        None | Some("prefix") => {
            StartChoice::FromRun(StartMethod::Prefix, PrefixOptions::default())
        }
        Some("equilibrium") => {
            StartChoice::FromRun(StartMethod::Equilibrium, PrefixOptions::default())
        }
        Some(kind @ ("pressure_kpa" | "height_mm")) => {
            let Some(value) = initial_value else {
                return Err(crate::error::to_py(anyhow::anyhow!(
                    "initial_state {kind} needs a value"
                )));
            };
            if kind == "pressure_kpa" {
                StartChoice::PressureKpa(value)
            } else {
                StartChoice::HeightMm(value)
            }
        }
        Some("state") => match &initial_state {
            Some(x) => StartChoice::State(x.as_slice()?.to_vec()),
            None => {
                return Err(crate::error::to_py(anyhow::anyhow!(
                    "initial_state: no state vector given"
                )));
            }
        },
        Some(other) => {
            return Err(crate::error::to_py(anyhow::anyhow!(
                "initial_state: unknown key `{other}`; give \"prefix\", \"equilibrium\", pressure_kpa, height_mm or a state vector"
            )));
        }
    };
    let method = parse_method(method.as_deref().unwrap_or("auto")).or_py()?;
    // The command's default `--rtol`.
    let rtol = rtol.unwrap_or(1e-6);

    let sim = py
        .detach(|| {
            run_simulation(
                &model,
                &params,
                &source,
                initial,
                rtol,
                method,
                states,
                load_ramp_s,
                load_transitions_s,
            )
        })
        .or_py()?;

    let out = PyDict::new(py);
    out.set_item("model", sim.model)?;
    out.set_item("initial", sim.what)?;
    out.set_item("time_s", sim.time_s.into_pyarray(py))?;
    out.set_item("height_mm", sim.height_mm.into_pyarray(py))?;
    out.set_item("pressure_kpa", sim.pressure_kpa.into_pyarray(py))?;
    let state_columns = PyDict::new(py);
    for (name, values) in sim.states {
        state_columns.set_item(name, values.into_pyarray(py))?;
    }
    out.set_item("states", state_columns)?;
    let s = sim.statistics;
    let statistics = PyDict::new(py);
    statistics.set_item("fallback", s.fallback.map(|m| format!("{m:?}")))?;
    statistics.set_item("steps", s.steps)?;
    statistics.set_item("rejected_steps", s.rejected_steps)?;
    statistics.set_item("rhs_evaluations", s.rhs_evaluations)?;
    statistics.set_item("jacobian_evaluations", s.jacobian_evaluations)?;
    statistics.set_item("newton_iterations", s.newton_iterations)?;
    statistics.set_item("linear_solver_setups", s.linear_solver_setups)?;
    statistics.set_item("restarts", s.restarts)?;
    out.set_item("statistics", statistics)?;
    let (h, p) = sim.nrmse.unwrap_or((None, None));
    out.set_item("nrmse_height", h)?;
    out.set_item("nrmse_pressure", p)?;
    Ok(out)
}
