//! The model registry, weighing, the study pipeline, the virtual truck's reference experiments
//! and NRMSE: crates/cli/src/commands/{weigh,study,generate}.rs as functions.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use airsus_apps::weigh::{
    CalibrationTerms, EkfTuning, HysteresisStart, LinearCalibration, StandstillDetector,
    StandstillRule, StaticLaw, StaticWeigher, WeighSeries, WeighingUncertainty, quality_flags,
    weigh_ekf, weigh_static_from,
};
use airsus_data::{Outputs, Run, TruckParameters};
use airsus_study::{
    Event, Protocol, StudyOptions, check_models, load_study, run_builtin, run_study, study_models,
};
use airsus_truck::models::{build_any_model, describe_models};

use crate::error::OrPy;
use crate::progress::Progress;
use crate::runs::{RunSource, RunSpec};
use crate::truck::NativeTruck;

/// Every model airsus builds by name (the registry, as `airsus models --json`):
/// `[{"name", "description", "parameters", "units", "states", "roles", "default_free",
/// "valve_free", "road_free", "road_refit"}, ...]`,
/// built with the reference truck.
#[pyfunction]
pub fn models(py: Python<'_>) -> PyResult<Vec<Bound<'_, PyDict>>> {
    let mut out = Vec::new();
    for model in describe_models().or_py()? {
        let entry = PyDict::new(py);
        entry.set_item("name", model.name)?;
        entry.set_item("description", model.summary)?;
        let infos: Vec<_> = model.parameters.iter().map(|p| &p.info).collect();
        entry.set_item(
            "parameters",
            infos.iter().map(|i| i.name).collect::<Vec<_>>(),
        )?;
        entry.set_item("units", infos.iter().map(|i| i.unit).collect::<Vec<_>>())?;
        entry.set_item(
            "states",
            model.states.iter().map(|s| s.name).collect::<Vec<_>>(),
        )?;
        entry.set_item(
            "roles",
            model
                .states
                .iter()
                .map(|s| s.role.as_str())
                .collect::<Vec<_>>(),
        )?;
        entry.set_item("default_free", model.default_free.to_vec())?;
        entry.set_item("valve_free", model.valve_free.to_vec())?;
        entry.set_item("road_free", model.road_free.to_vec())?;
        entry.set_item("road_refit", model.road_refit.to_vec())?;
        out.push(entry);
    }
    Ok(out)
}

struct Weighed {
    series: WeighSeries,
    /// One quality flag per sample, from the run alone.
    quality: Vec<&'static str>,
    /// The calibration, when one was fitted.
    calibration: Option<LinearCalibration>,
}

/// How a run starts, by the name Python gives it; `what` names the argument in the error.
fn parse_hysteresis_start(name: &str, what: &str) -> anyhow::Result<HysteresisStart> {
    Ok(match name {
        "unknown" => HysteresisStart::Unknown,
        "lowered" => HysteresisStart::Lowered,
        "raised" => HysteresisStart::Raised,
        other => bail!("unknown {what} `{other}`; it is one of: unknown, lowered, raised"),
    })
}

#[allow(clippy::too_many_arguments)]
fn run_weigh(
    truck: &TruckParameters,
    source: &RunSource,
    method: &str,
    model_name: &str,
    window_s: f64,
    start: HysteresisStart,
    calibration: &[(RunSource, HysteresisStart)],
    detector: &StandstillDetector,
) -> anyhow::Result<Weighed> {
    let ekf = match method {
        "static" => false,
        "ekf" => true,
        other => bail!("unknown method `{other}`; the methods are: static, ekf"),
    };

    // Weighing estimates the load: a run without a wheel-load column is weighed as it is.
    let weighed = airsus_data::RunSource {
        load_optional: true,
        ..airsus_data::RunSource::default()
    };
    let run = source
        .load_with(Outputs::Required, &weighed)
        .with_context(|| format!("reading run {}", source.label()))?;
    let weigher = StaticWeigher::new(StaticLaw::from_truck(truck), WeighingUncertainty::default());
    if !(window_s.is_finite() && window_s >= 0.0) {
        bail!("window_s must be a non-negative number of seconds");
    }
    let window = ((window_s / run.sample_time_s).round() as usize).max(1);
    let estimate = |run: &Run, start: HysteresisStart| -> anyhow::Result<WeighSeries> {
        Ok(if ekf {
            let model = build_any_model(model_name, truck)?;
            let tuning = EkfTuning {
                start_hysteresis: start,
                ..EkfTuning::default()
            };
            weigh_ekf(run, model, &weigher, &tuning)?
        } else {
            weigh_static_from(run, &weigher, window, start)?
        })
    };
    let mut series =
        estimate(&run, start).with_context(|| format!("weighing {}", source.label()))?;
    let flags = quality_flags(&run, detector)
        .with_context(|| format!("flagging the samples of {}", source.label()))?;
    let quality = flags.iter().map(|q| q.as_str()).collect();
    let mut fitted = None;
    if !calibration.is_empty() {
        let rule = StandstillRule::default();
        let mut cal_runs = Vec::new();
        for &(ref cal_source, cal_start) in calibration {
            let cal_run = cal_source
                .load(Outputs::Required)
                .with_context(|| format!("reading {}", cal_source.label()))?;
            let cal_est = estimate(&cal_run, cal_start)
                .with_context(|| format!("weighing {}", cal_source.label()))?;
            cal_runs.push((cal_run, cal_est));
        }
        let runs: Vec<_> = cal_runs.iter().map(|(run, est)| (run, est)).collect();
        let terms = if ekf {
            CalibrationTerms::for_estimate(Some(build_any_model(model_name, truck)?.as_ref()))
        } else {
            CalibrationTerms::for_static(&weigher.law)
        };
        let cal = LinearCalibration::fit_weighed_runs_flagged_by(&runs, &rule, terms, detector)
            .context("calibrating")?;
        series = cal.apply_with_quality(
            &series,
            Some(&run.measured()?.sensor_height_m),
            Some(&flags),
            Some(&run.inputs.valve),
        )?;
        fitted = Some(cal);
    }
    Ok(Weighed {
        series,
        quality,
        calibration: fitted,
    })
}

/// The wheel load over a run from its measured pressure and height, as `airsus weigh` does
/// (`method` `static` or `ekf`, `model` for the filter, `window_s` for the static average).
/// Returns `{"time_s", "wheel_load_kg", "wheel_load_std_kg", "quality", "calibration"}` at full
/// precision (the command's CSV rounds to 3 decimals).
#[pyfunction]
#[pyo3(signature = (truck, run, method=None, model=None, window_s=None, calibration_run=None, start_hysteresis=None, calibration_start=None, loading_shift_kpa=None, loading_window_s=None, loading_hold_s=None))]
#[allow(clippy::too_many_arguments)]
pub fn weigh<'py>(
    py: Python<'py>,
    truck: PyRef<'py, NativeTruck>,
    run: RunSpec<'py>,
    method: Option<String>,
    model: Option<String>,
    window_s: Option<f64>,
    calibration_run: Option<Vec<RunSpec<'py>>>,
    start_hysteresis: Option<String>,
    calibration_start: Option<Vec<String>>,
    loading_shift_kpa: Option<f64>,
    loading_window_s: Option<f64>,
    loading_hold_s: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let defaults = StandstillDetector::default();
    let detector = defaults
        .clone()
        .with_loading(
            loading_shift_kpa.map_or(defaults.loading_shift_pa, |kpa| kpa * 1e3),
            loading_window_s.unwrap_or(defaults.loading_window_s),
            loading_hold_s.unwrap_or(defaults.loading_hold_s),
        )
        .map_err(|e| {
            crate::error::to_py(anyhow::anyhow!(
                "loading_shift_kpa, loading_window_s, loading_hold_s: {e}"
            ))
        })?;
    let params = truck.params.clone();
    drop(truck);
    let source = RunSource::from_spec(run)?;
    let calibration = calibration_run
        .unwrap_or_default()
        .into_iter()
        .map(RunSource::from_spec)
        .collect::<PyResult<Vec<_>>>()?;
    // Each calibration run with how it starts: as given, one per run, or all unknown; said
    // before any run is weighed, not after the first.
    let starts = match calibration_start {
        None => vec![HysteresisStart::Unknown; calibration.len()],
        Some(starts) if starts.len() == calibration.len() => starts
            .iter()
            .map(|name| parse_hysteresis_start(name, "calibration_start"))
            .collect::<anyhow::Result<Vec<_>>>()
            .or_py()?,
        Some(starts) => {
            return Err(crate::error::AirsusError::new_err(format!(
                "calibration_start gives {} start(s) for {} calibration run(s): give one per run, in the same order",
                starts.len(),
                calibration.len()
            )));
        }
    };
    let calibration: Vec<(RunSource, HysteresisStart)> =
        calibration.into_iter().zip(starts).collect();
    // The command's defaults: `--method static --model m2 --window-s 2`.
    let method = method.unwrap_or_else(|| "static".to_owned());
    let model = model.unwrap_or_else(|| "m2".to_owned());
    let window_s = window_s.unwrap_or(2.0);
    let start = parse_hysteresis_start(
        start_hysteresis.as_deref().unwrap_or("unknown"),
        "start_hysteresis",
    )
    .or_py()?;
    let weighed = py
        .detach(|| {
            run_weigh(
                &params,
                &source,
                &method,
                &model,
                window_s,
                start,
                &calibration,
                &detector,
            )
        })
        .or_py()?;
    let out = PyDict::new(py);
    let s = weighed.series;
    out.set_item("notes", s.notes)?;
    out.set_item("time_s", s.time_s.into_pyarray(py))?;
    out.set_item("wheel_load_kg", s.wheel_load_kg.into_pyarray(py))?;
    out.set_item("wheel_load_std_kg", s.std_kg.into_pyarray(py))?;
    out.set_item("quality", weighed.quality)?;
    match weighed.calibration {
        Some(c) => {
            let cal = PyDict::new(py);
            cal.set_item("gain", c.gain)?;
            cal.set_item("offset_kg", c.offset_kg)?;
            cal.set_item("hysteresis_kg", c.hysteresis_kg)?;
            cal.set_item("height_kg_per_mm", c.height_kg_per_mm)?;
            cal.set_item("reference_height_mm", c.reference_height_mm)?;
            cal.set_item("samples", c.samples)?;
            cal.set_item("residual_rms_kg", c.residual_rms_kg)?;
            cal.set_item("residual_q95_kg", c.residual_q95_kg)?;
            cal.set_item("settling_q95_kg", c.settling_q95_kg)?;
            cal.set_item("valve_q95_kg", c.valve_q95_kg)?;
            cal.set_item("standstill_std_kg", c.standstill_std_kg)?;
            cal.set_item("settling_std_kg", c.settling_std_kg)?;
            cal.set_item("valve_std_kg", c.valve_std_kg)?;
            cal.set_item("own_std_scale", c.own_std_scale)?;
            cal.set_item("settling_own_scale", c.settling_own_scale)?;
            cal.set_item("valve_own_scale", c.valve_own_scale)?;
            cal.set_item("late_settling_std_kg", c.late_settling_std_kg)?;
            cal.set_item("late_settling_own_scale", c.late_settling_own_scale)?;
            cal.set_item("late_settling_after_s", c.late_settling_after_s)?;
            cal.set_item("load_settling_std_kg", c.load_settling_std_kg)?;
            cal.set_item("load_settling_own_scale", c.load_settling_own_scale)?;
            cal.set_item("loading_q95_kg", c.loading_q95_kg)?;
            cal.set_item("loading_std_kg", c.loading_std_kg)?;
            cal.set_item("loading_own_scale", c.loading_own_scale)?;
            cal.set_item("height_range_mm", c.height_range_mm)?;
            cal.set_item("dropped", c.dropped)?;
            out.set_item("calibration", cal)?;
        }
        None => out.set_item("calibration", py.None())?,
    }
    Ok(out)
}

fn study_event(progress: &Progress, event: Event<'_>) {
    match event {
        Event::Stage(stage) => progress.stage(stage),
        Event::ModelDone {
            protocol,
            model,
            seconds,
            done,
            total,
        } => progress.emit(|d| {
            d.set_item("event", "model_done")?;
            d.set_item("protocol", protocol)?;
            d.set_item("model", model)?;
            d.set_item("seconds", seconds)?;
            d.set_item("done", done)?;
            d.set_item("total", total)
        }),
    }
}

struct Studied {
    results_json: PathBuf,
    report_html: PathBuf,
    notes: Vec<String>,
    chart_failures: Vec<String>,
}

fn run_the_study(
    study: Option<&Path>,
    out: &Path,
    fit: StudyOptions,
    (seed, variant): (u64, u32),
    progress: &Progress,
) -> anyhow::Result<Studied> {
    check_models(&fit.models)?;
    if fit.max_iterations == 0 {
        bail!("max_iterations must be at least 1");
    }
    if fit.starts == 0 {
        bail!("starts must be at least 1");
    }
    let on_event = |event: Event<'_>| study_event(progress, event);
    let mut notes = Vec::new();
    let outcome = match study {
        Some(path) => {
            let input = load_study(path)?;
            for d in &input.defaulted {
                notes.push(format!("{} omits {}", input.truck_file.display(), d));
            }
            let options = StudyOptions {
                protocols: vec![Protocol::from_roles(&input)],
                ..fit
            };
            run_study(&input, &options, out, &on_event)
        }
        None => run_builtin(out, seed, variant, fit, &on_event),
    }
    .with_context(|| format!("running the study into {}", out.display()))?;
    Ok(Studied {
        results_json: outcome.report.json,
        report_html: outcome.report.html,
        notes,
        chart_failures: outcome.report.chart_failures,
    })
}

/// The whole pipeline, as `airsus study STUDY.toml --out OUT` (or `--builtin --seed SEED` when
/// `study` is None). Returns `{"results": path of results.json, "report": path of report.html,
/// "notes", "chart_failures"}`.
#[pyfunction]
#[pyo3(signature = (study_file, out, models=None, max_iterations=None, seed=None, progress=None, initial_state=None, normalisation=None, starts=None, screen=None, variant=None, load_ramp=None, exclude_after_load_change_s=None, validation_transitions=None, prefix_s=None, allow_trades=false))]
#[allow(clippy::too_many_arguments)]
pub fn study<'py>(
    py: Python<'py>,
    study_file: Option<PathBuf>,
    out: PathBuf,
    models: Option<Vec<String>>,
    max_iterations: Option<usize>,
    seed: Option<u64>,
    progress: Option<Py<PyAny>>,
    initial_state: Option<String>,
    normalisation: Option<String>,
    starts: Option<usize>,
    screen: Option<usize>,
    variant: Option<u32>,
    load_ramp: Option<String>,
    exclude_after_load_change_s: Option<f64>,
    validation_transitions: Option<String>,
    prefix_s: Option<f64>,
    allow_trades: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let prefix_s = airsus_estimate::check_prefix_s(
        prefix_s.unwrap_or(airsus_estimate::initial_state::DEFAULT_PREFIX_S),
    )
    .map_err(|e| crate::error::to_py(anyhow::anyhow!("prefix_s {e}")))?;
    let validation_transitions = match validation_transitions.as_deref().unwrap_or("fitted") {
        "fitted" => true,
        "common" => false,
        other => {
            return Err(crate::error::to_py(anyhow::anyhow!(
                "validation_transitions `{other}`: expected `fitted` or `common`"
            )));
        }
    };
    let exclude_after_load_change_s = airsus_estimate::check_load_change_exclusion_s(
        exclude_after_load_change_s.unwrap_or(airsus_study::DEFAULT_EXCLUDE_AFTER_LOAD_CHANGE_S),
    )
    .map_err(|e| crate::error::to_py(anyhow::anyhow!("exclude_after_load_change_s {e}")))?;
    let load_ramp: airsus_study::LoadRamp = load_ramp
        .as_deref()
        .unwrap_or("estimate")
        .parse()
        .map_err(|e| crate::error::to_py(anyhow::anyhow!("load_ramp {e}")))?;
    if study_file.is_some() && (seed.is_some() || variant.is_some()) {
        return Err(crate::error::to_py(anyhow::anyhow!(
            "seed and variant apply to the built-in study only (study=None)"
        )));
    }
    // The command's defaults: every study model, `--max-iterations 60`, `--seed 1`.
    let models = models.unwrap_or_else(|| study_models().iter().map(|m| (*m).to_owned()).collect());
    let (start, refit_starts) =
        crate::simulate::parse_estimation_start(initial_state.as_deref().unwrap_or("joint"))
            .or_py()?;
    let fit = StudyOptions {
        models,
        max_iterations: max_iterations.unwrap_or(60),
        initial: start,
        prefix: airsus_estimate::PrefixOptions {
            prefix_s,
            refit_starts,
            ..airsus_estimate::PrefixOptions::default()
        },
        normalisation: crate::greybox::parse_normalisation(
            normalisation.as_deref().unwrap_or("pooled-spread"),
        )
        .or_py()?,
        starts: starts.unwrap_or(airsus_study::DEFAULT_STARTS),
        screen: screen.unwrap_or(airsus_study::DEFAULT_SCREEN),
        load_ramp,
        exclude_after_load_change_s,
        validation_transitions,
        allow_trades,
        ..StudyOptions::new(vec![])
    };
    let builtin = (seed.unwrap_or(1), variant.unwrap_or(0));
    let progress = Progress::new(progress);
    let result = py.detach(|| run_the_study(study_file.as_deref(), &out, fit, builtin, &progress));
    progress.finish()?;
    let studied = result.or_py()?;
    let dict = PyDict::new(py);
    dict.set_item("results", studied.results_json.display().to_string())?;
    dict.set_item("report", studied.report_html.display().to_string())?;
    dict.set_item("notes", studied.notes)?;
    dict.set_item("chart_failures", studied.chart_failures)?;
    Ok(dict)
}

/// The virtual truck's reference experiments, as `airsus generate --out OUT --seed SEED
/// --variant K`.
/// Returns `{"study", "study_valve", "files"}` (paths).
#[pyfunction]
#[pyo3(signature = (out, seed=1, progress=None, variant=0))]
pub fn generate<'py>(
    py: Python<'py>,
    out: PathBuf,
    seed: u64,
    progress: Option<Py<PyAny>>,
    variant: u32,
) -> PyResult<Bound<'py, PyDict>> {
    let progress = Progress::new(progress);
    let result = py.detach(|| {
        airsus_truck::experiments::generate_variant(&out, seed, variant, &mut |step: &str| {
            progress.stage(step)
        })
        .with_context(|| format!("generating the reference study into {}", out.display()))
    });
    progress.finish()?;
    let generated = result.or_py()?;
    let dict = PyDict::new(py);
    dict.set_item("study", generated.study.display().to_string())?;
    dict.set_item("study_valve", generated.study_valve.display().to_string())?;
    dict.set_item(
        "files",
        generated
            .files
            .iter()
            .map(|f| f.display().to_string())
            .collect::<Vec<_>>(),
    )?;
    Ok(dict)
}

/// NRMSE in percent, thesis eq 3.33: `100 (1 - ||y - yhat|| / ||y - mean(y)||)`.
#[pyfunction]
pub fn nrmse(
    measured: PyReadonlyArray1<'_, f64>,
    simulated: PyReadonlyArray1<'_, f64>,
) -> PyResult<f64> {
    airsus_validate::nrmse_percent(measured.as_slice()?, simulated.as_slice()?).or_py()
}
