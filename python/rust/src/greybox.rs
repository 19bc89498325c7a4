//! `airsus.greybox`: crates/cli/src/commands/greybox.rs, the result as data.

use anyhow::{Context, bail};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use airsus_data::{Outputs, TruckParameters};
use airsus_estimate::{
    FreeParameter, GreyboxOptions, GreyboxProblem, IdentifiabilityPolicy, InitialChoice, LoadRamp,
    MultiStart, Normalisation, OutputWeights, PrefixOptions, StartMethod, check_force_map_noise_n,
    estimate_with_starts, estimation_start, no_trade::keep_every_run_by_fits,
};
use airsus_truck::models::{build_any_model, default_free};

use crate::error::OrPy;
use crate::progress::{Progress, ProgressObserver};
use crate::runs::{RunSource, RunSpec};
use crate::truck::NativeTruck;

/// The command's options, with its defaults filled in.
struct Settings {
    free: Vec<String>,
    bounds: Vec<(String, f64, f64)>,
    max_iterations: usize,
    tolerance: f64,
    initial: InitialChoice,
    height_weight: f64,
    pressure_weight: f64,
    max_relative_std: f64,
    keep_unidentifiable: bool,
    /// Keep the pooled estimate where it trades an estimation run (`--allow-trades`).
    allow_trades: bool,
    normalisation: Normalisation,
    start: StartMethod,
    /// The estimation runs' starts refitted with the parameters (`joint`) or held (`prefix`).
    refit_starts: bool,
    load_ramp: LoadRamp,
    /// A bellow force map file as a prior on the effective-area law, and its force error
    /// (None: the misfit of the truck's law to it), as `--force-map`.
    force_map: Option<std::path::PathBuf>,
    force_map_noise_n: Option<f64>,
}

/// The loss normalisation by the command's name (`--normalisation`).
pub fn parse_normalisation(name: &str) -> anyhow::Result<Normalisation> {
    Ok(match name {
        "pooled-spread" => Normalisation::PooledSpread,
        "noise-level" => Normalisation::NoiseLevel,
        other => {
            anyhow::bail!("normalisation `{other}`: expected `pooled-spread` or `noise-level`")
        }
    })
}

struct Estimated {
    json: String,
    text: String,
    /// How the runs started, in words (the joint estimate's rounds for prefix starts).
    start: String,
    /// What easing the logged load did, in words; each change's transition time per run
    /// (empty lists: none estimated), and the one time for other runs (None: as logged).
    load: String,
    load_transitions_s: Vec<Vec<f64>>,
    load_ramp_s: Option<f64>,
    /// What the guard against trading estimation runs did, in words (None: nothing traded).
    trades: Option<String>,
    stop: String,
    converged: bool,
    truck: TruckParameters,
}

fn run_greybox(
    model_name: &str,
    mut truck: TruckParameters,
    sources: &[RunSource],
    settings: &Settings,
    progress: &Progress,
) -> anyhow::Result<Estimated> {
    let model = build_any_model(model_name, &truck)?;
    let runs = sources
        .iter()
        .map(|s| {
            s.load(Outputs::Required)
                .with_context(|| format!("estimation run {}", s.label()))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let run_refs: Vec<&_> = runs.iter().collect();

    let free_names: Vec<String> = if settings.free.is_empty() {
        let (names, _) = default_free(&*model, &run_refs)?;
        names.iter().map(|n| (*n).to_owned()).collect()
    } else {
        settings.free.clone()
    };
    let mut free: Vec<FreeParameter> = free_names.iter().map(FreeParameter::new).collect();
    for (name, lo, hi) in &settings.bounds {
        let Some(p) = free.iter_mut().find(|p| p.name == *name) else {
            bail!("bounds {name}: `{name}` is not in free");
        };
        *p = FreeParameter::new(name.clone()).with_bounds(*lo, *hi);
    }
    let mut problem = GreyboxProblem::new(&*model, &run_refs, &[])
        .with_weights(OutputWeights {
            height: settings.height_weight,
            pressure: settings.pressure_weight,
        })
        .with_initial(settings.initial)
        .with_normalisation(settings.normalisation);
    problem.free = free;
    let force_map = settings
        .force_map
        .as_deref()
        .map(airsus_data::read_force_map)
        .transpose()?;
    if let Some(noise_n) = settings.force_map_noise_n {
        check_force_map_noise_n(noise_n).map_err(|e| anyhow::anyhow!("force_map_noise_n {e}"))?;
    }
    if let Some(map) = &force_map {
        problem = problem.with_force_map(map, settings.force_map_noise_n);
    }
    let options = GreyboxOptions {
        max_iterations: settings.max_iterations,
        tolerance: settings.tolerance,
        max_relative_std: settings.max_relative_std,
        policy: if settings.keep_unidentifiable {
            IdentifiabilityPolicy::ReportOnly
        } else {
            IdentifiabilityPolicy::FixAtNominal
        },
        allow_trades: settings.allow_trades,
        ..GreyboxOptions::default()
    };
    let mut observer = ProgressObserver(progress);
    let prefix = PrefixOptions {
        refit_starts: settings.refit_starts,
        ..PrefixOptions::default()
    };
    let (joint, _) = estimate_with_starts(
        &problem,
        &options,
        &MultiStart::default(),
        settings.start,
        &prefix,
        settings.load_ramp,
        &mut observer,
    )?;
    // No run or output explained worse than by the start values (issue #12), as the
    // command does.
    let prefix_if =
        (settings.start == StartMethod::Prefix && prefix.refit_starts).then_some(&prefix);
    let guarded = keep_every_run_by_fits(joint, &problem, &options, prefix_if, &mut observer);
    let joint = guarded.joint;
    let start = match settings.start {
        StartMethod::Prefix => joint.describe(PrefixOptions::default().prefix_s),
        StartMethod::Equilibrium => "every run starts in static equilibrium".to_owned(),
    };
    let start = joint
        .start_notes
        .iter()
        .chain(std::iter::once(&start))
        .cloned()
        .collect::<Vec<_>>()
        .join("\n");
    let load = joint.load_notes.join("\n");
    let load_transitions_s = joint
        .fitted_transitions_s()
        .map_or_else(|| vec![Vec::new(); runs.len()], <[_]>::to_vec);
    let load_ramp_s = joint.load_ramp_s;
    let result = joint.estimate;

    // What `--json` prints (compact here; the values are the same) and what the command
    // prints without it.
    let json = serde_json::to_string(&result)?;
    let text = result.to_string();
    result.estimated_model.write_parameters(&mut truck);
    Ok(Estimated {
        json,
        text,
        start,
        load,
        load_transitions_s,
        load_ramp_s,
        trades: guarded.note,
        stop: result.stop.to_string(),
        converged: result.stop.is_converged(),
        truck,
    })
}

/// Grey-box estimation of `free` parameters of `model` on all `runs` at once, as
/// `airsus greybox` does. Options left `None` take the command's defaults.
///
/// Returns `{"report": JSON text of `--json`, "text": the command's printout, "stop_reason",
/// "converged", "start", "load" (what easing the logged load did), "load_transitions_s" (per
/// run, each logged change's transition time), "load_ramp_s", "trades" (what was done where
/// the pooled estimate explained a run and output worse than the start values: refitted
/// with it weighted more, or named and kept with `allow_trades`; None where nothing was
/// traded), "truck": the truck with the
/// estimates written back (as `--out`)}`.
#[pyfunction]
#[pyo3(signature = (model, truck, runs, free, bounds=None, max_iterations=None, tolerance=None, initial=None, height_weight=None, pressure_weight=None, max_relative_std=None, keep_unidentifiable=false, progress=None, normalisation=None, initial_state=None, load_ramp=None, force_map=None, force_map_noise_n=None, allow_trades=false))]
#[allow(clippy::too_many_arguments)]
pub fn greybox<'py>(
    py: Python<'py>,
    model: String,
    truck: PyRef<'py, NativeTruck>,
    runs: Vec<RunSpec<'py>>,
    free: Vec<String>,
    bounds: Option<Vec<(String, f64, f64)>>,
    max_iterations: Option<usize>,
    tolerance: Option<f64>,
    initial: Option<String>,
    height_weight: Option<f64>,
    pressure_weight: Option<f64>,
    max_relative_std: Option<f64>,
    keep_unidentifiable: bool,
    progress: Option<Py<PyAny>>,
    normalisation: Option<String>,
    initial_state: Option<String>,
    load_ramp: Option<String>,
    force_map: Option<std::path::PathBuf>,
    force_map_noise_n: Option<f64>,
    allow_trades: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let params = truck.params.clone();
    drop(truck);
    let sources = runs
        .into_iter()
        .map(RunSource::from_spec)
        .collect::<PyResult<Vec<_>>>()?;
    let initial = match initial.as_deref().unwrap_or("height") {
        "height" => InitialChoice::SensorHeight,
        "pressure" => InitialChoice::BellowPressure,
        other => {
            return Err(crate::error::to_py(anyhow::anyhow!(
                "initial `{other}`: expected `height` or `pressure`"
            )));
        }
    };
    // As the command: prefix starts unless the equilibrium is fixed by the first pressure.
    let requested = initial_state
        .as_deref()
        .map(crate::simulate::parse_estimation_start)
        .transpose()
        .or_py()?;
    let refit_starts = requested.is_none_or(|(_, refit)| refit);
    let start = estimation_start(initial, requested.map(|(method, _)| method))
        .map_err(|e| anyhow::anyhow!("initial=\"pressure\" with initial_state=\"prefix\": {e}"))
        .or_py()?;
    let load_ramp: LoadRamp = load_ramp
        .as_deref()
        .unwrap_or("estimate")
        .parse()
        .map_err(|e| crate::error::to_py(anyhow::anyhow!("load_ramp {e}")))?;
    let defaults = GreyboxOptions::default();
    let settings = Settings {
        start,
        refit_starts,
        load_ramp,
        free,
        bounds: bounds.unwrap_or_default(),
        max_iterations: max_iterations.unwrap_or(defaults.max_iterations),
        tolerance: tolerance.unwrap_or(defaults.tolerance),
        initial,
        // The command's defaults (`--height-weight 1`, `--pressure-weight 1`,
        // `--max-relative-std 0.5`).
        height_weight: height_weight.unwrap_or(1.0),
        pressure_weight: pressure_weight.unwrap_or(1.0),
        max_relative_std: max_relative_std.unwrap_or(0.5),
        keep_unidentifiable,
        allow_trades,
        normalisation: parse_normalisation(normalisation.as_deref().unwrap_or("pooled-spread"))
            .or_py()?,
        force_map,
        force_map_noise_n,
    };
    let progress = Progress::new(progress);
    let result = py.detach(|| run_greybox(&model, params, &sources, &settings, &progress));
    progress.finish()?;
    let estimated = result.or_py()?;

    let out = PyDict::new(py);
    out.set_item("report", estimated.json)?;
    out.set_item("text", estimated.text)?;
    out.set_item("stop_reason", estimated.stop)?;
    out.set_item("converged", estimated.converged)?;
    out.set_item("start", estimated.start)?;
    out.set_item("load", estimated.load)?;
    out.set_item("load_transitions_s", estimated.load_transitions_s)?;
    out.set_item("load_ramp_s", estimated.load_ramp_s)?;
    out.set_item("trades", estimated.trades)?;
    out.set_item("truck", NativeTruck::new(estimated.truck))?;
    Ok(out)
}
