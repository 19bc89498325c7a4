//! # airsus-study: the thesis pipeline from one call
//!
//! 1. load the study and every file it names ([`input`]);
//! 2. submodel fits from the lab data and the estimation runs, seeding the start values
//!    ([`submodels`], thesis 5.2 and Table 5.9);
//! 3. grey-box estimation of every model — the four thesis models and the virtual-truck
//!    structure `truck` — on each protocol's estimation runs ([`models`]), the models in
//!    parallel;
//! 4. simulation and residual analysis of every model on every run;
//! 5. figures and the report (`report.html`, `results.json`, estimated truck files).

pub mod ceiling;
pub mod coverage;
pub mod figures;
pub mod findings;
pub mod input;
pub mod models;
pub mod no_trade;
pub mod protocol;
pub mod submodels;

use std::path::{Path, PathBuf};
use std::time::Instant;

use airsus_truck::models::{build_any_model, model_entry};
use rayon::prelude::*;

use airsus_report::chart::Chart;
use airsus_report::html::{ReportError, ReportFiles, write_report};
use airsus_report::results::{ProtocolResult, RunInfo, SCHEMA_VERSION, StudyResults};

pub use input::{StudyInput, load_study};
pub use protocol::Protocol;

#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    #[error(transparent)]
    Data(#[from] airsus_data::DataError),
    #[error(transparent)]
    Report(#[from] ReportError),
    #[error(transparent)]
    Generate(#[from] airsus_truck::error::TruckError),
    #[error("protocol `{protocol}`: {reason}")]
    Protocol { protocol: String, reason: String },
    #[error(
        "refusing to write the study into {}: it would write over the input {} (the study writes report.html, results.json, figures/ and estimated/ there); choose another --out",
        out_dir.display(),
        input.display()
    )]
    OutputOverInput { out_dir: PathBuf, input: PathBuf },
    #[error("truth file {}: {reason}", truth.display())]
    Truth { truth: PathBuf, reason: String },
    #[error("cannot create the output folder {path}: {source}")]
    OutputFolder {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// The models a study estimates by default: every registered model, in report order.
pub fn study_models() -> Vec<&'static str> {
    airsus_truck::models::model_names()
}

/// Every name in `models` is a registered model (the error suggests the nearest name).
pub fn check_models(models: &[String]) -> Result<(), airsus_model::ModelError> {
    for name in models {
        model_entry(name)?;
    }
    Ok(())
}

#[derive(Debug, Clone, PartialEq)]
pub struct StudyOptions {
    pub models: Vec<String>,
    pub protocols: Vec<Protocol>,
    pub max_iterations: usize,
    /// How runs start: static equilibrium (default), or with their history states fitted to
    /// the first seconds, estimated jointly with the parameters by alternation.
    pub initial: airsus_estimate::StartMethod,
    /// The prefix the runs' starts are fitted to, and whether the estimation runs' starts are
    /// refitted with the parameters (`joint`, the default) or held (`prefix`).
    pub prefix: airsus_estimate::PrefixOptions,
    /// How the grey-box loss weighs runs and outputs.
    pub normalisation: airsus_estimate::Normalisation,
    /// Local fits of the grey-box fits' global stage at most, the nominal one included (1:
    /// the plain local fit).
    pub starts: usize,
    /// Design points the global stage screens by their loss before it starts a local fit
    /// from any (`airsus_estimate::MultiStart::screen`; 0: the local fits start from the
    /// design's first points unscreened).
    pub screen: usize,
    /// Whether the logged load's steps are eased over a transition time estimated from the
    /// estimation runs (and the parameters refitted with it), or used as logged.
    pub load_ramp: LoadRamp,
    /// Seconds after each logged load change that the estimation's loss leaves out
    /// (`GreyboxProblem::exclude_after_load_change_s`; 0: none). Default
    /// [`DEFAULT_EXCLUDE_AFTER_LOAD_CHANGE_S`].
    pub exclude_after_load_change_s: f64,
    /// Whether each logged load change of a validation run is eased over its own transition
    /// time, fitted to that run with the parameters fixed (with [`LoadRamp::Estimate`]);
    /// `false`: over the common time fitted to the estimation runs.
    pub validation_transitions: bool,
    /// Keep each model's pooled estimate where it explains an estimation run worse than the
    /// start values did, naming the trades (`GreyboxOptions::allow_trades`); `false` (the
    /// default): refit it with the traded runs weighted more.
    pub allow_trades: bool,
}

/// The study's default for [`StudyOptions::exclude_after_load_change_s`]: none yet. Leaving
/// 10 s out (the longest transition a loading traverse takes on the virtual truck, 3-8 s,
/// with a margin) kept a fit started at the truth there, but from the nominal values it
/// moved the `truck` structure's held-out data-set 4 from 94.8/63.7 % to 92.1/31.6 % on
/// variant 0, from 94.9/60.1 % to 96.2/83.8 % on variant 1, and to far below on variants 2
/// and 3 (seed 1): not a default until it helps across the family.
pub const DEFAULT_EXCLUDE_AFTER_LOAD_CHANGE_S: f64 = 0.0;

/// The study's default for [`StudyOptions::starts`] and [`StudyOptions::screen`]: the global
/// stage on, screened. 32 points around the start, and a local fit from at most 3 of them
/// that explain the runs better than the start does. On the built-in study (seed 1) none
/// does for m1, m2, m2x, m2xh and `truck` (the submodel fits start them near their optimum),
/// and the screen costs each 0.1-1.6 s; for Model 3 under the valve protocol 8 do, and one
/// of them wins (loss 0.469 → 0.353). The study takes 64 s, against 57 s without the stage;
/// unscreened, 3 extra local fits took it to 127 s, and none won (BENCHMARKS.md).
pub const DEFAULT_STARTS: usize = 4;
pub const DEFAULT_SCREEN: usize = 32;

/// How a study feeds the logged load to the models (the estimator's choice).
pub use airsus_estimate::LoadRamp;

impl StudyOptions {
    /// Every registered model, the given protocols, 60 iterations, starts fitted to each
    /// run's first seconds, the logged load eased, and the default loss normalisation.
    pub fn new(protocols: Vec<Protocol>) -> Self {
        Self {
            models: study_models().iter().map(|m| (*m).to_owned()).collect(),
            protocols,
            max_iterations: 60,
            // Starts fitted to each run's first seconds: jointly with the parameters in
            // estimation runs, with them fixed in validation runs (issue #12, item 2).
            initial: airsus_estimate::StartMethod::Prefix,
            prefix: airsus_estimate::PrefixOptions::default(),
            normalisation: airsus_estimate::Normalisation::default(),
            starts: DEFAULT_STARTS,
            screen: DEFAULT_SCREEN,
            load_ramp: LoadRamp::default(),
            exclude_after_load_change_s: DEFAULT_EXCLUDE_AFTER_LOAD_CHANGE_S,
            validation_transitions: true,
            allow_trades: false,
        }
    }
}

/// What the pipeline reports while it works.
#[derive(Debug, Clone, Copy)]
pub enum Event<'a> {
    Stage(&'a str),
    ModelDone {
        protocol: &'a str,
        model: &'a str,
        seconds: f64,
        done: usize,
        total: usize,
    },
}

pub struct StudyOutcome {
    pub results: StudyResults,
    pub report: ReportFiles,
}

/// Runs the whole pipeline on `input` and writes everything into `out_dir`.
pub fn run_study(
    input: &StudyInput,
    options: &StudyOptions,
    out_dir: &Path,
    progress: &(dyn Fn(Event) + Sync),
) -> Result<StudyOutcome, StudyError> {
    let started = Instant::now();
    std::fs::create_dir_all(out_dir).map_err(|source| StudyError::OutputFolder {
        path: out_dir.to_path_buf(),
        source,
    })?;
    refuse_writing_over_inputs(input, out_dir)?;
    for p in &options.protocols {
        if p.estimation.is_empty() {
            return Err(StudyError::Protocol {
                protocol: p.name.clone(),
                reason: "no estimation run: mark at least one run `role = \"estimation\"`"
                    .to_owned(),
            });
        }
        if let Some(missing) = p.estimation.iter().find(|n| input.run(n).is_none()) {
            return Err(StudyError::Protocol {
                protocol: p.name.clone(),
                reason: format!("the study has no run named `{missing}`"),
            });
        }
    }

    progress(Event::Stage("submodel fits"));
    let first_estimation = options
        .protocols
        .first()
        .map(|p| p.estimation.clone())
        .unwrap_or_default();
    let (start, submodels) = submodels::fit_submodels(input, &first_estimation);
    let mut charts: Vec<Chart> = [
        figures::force_map_chart(input, &start.truck),
        figures::discharge_chart(input, &start.truck),
        figures::pressure_height_chart(input, &start.truck),
    ]
    .into_iter()
    .flatten()
    .collect();

    let total = options.protocols.len() * options.models.len();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let names: Vec<&str> = options.protocols.iter().map(|p| p.name.as_str()).collect();
    progress(Event::Stage(&format!(
        "grey-box estimation, protocol{} {}",
        if names.len() == 1 { "" } else { "s" },
        names.join(", ")
    )));
    // Every protocol's models in one parallel pass, the costliest first: each worker takes
    // the next pair from one queue. In the order given, the `truck` structure on the valve
    // runs (over half of the study's work) started last, at 27 s of the built-in study, and
    // ran alone at the end; started first, the other pairs fill the second core beside it.
    // (the pair's place in the order asked for, protocol, model)
    let mut pairs: Vec<(usize, usize, &String)> = (0..options.protocols.len())
        .flat_map(|k| options.models.iter().map(move |m| (k, m)))
        .enumerate()
        .map(|(i, (k, m))| (i, k, m))
        .collect();
    let estimation_samples = |k: usize| -> usize {
        options.protocols[k]
            .estimation
            .iter()
            .filter_map(|n| input.run(n))
            .map(|r| r.run.len())
            .sum()
    };
    // A pair's cost, roughly: the samples it simulates times the model's states.
    let states = |m: &str| -> usize {
        model_entry(m)
            .ok()
            .and_then(|entry| build_any_model(m, &start.truck_for(entry)).ok())
            .map_or(1, |model| model.n_states())
    };
    // Stable: pairs of equal cost keep the order asked for.
    pairs.sort_by_cached_key(|&(_, k, m)| std::cmp::Reverse(estimation_samples(k) * states(m)));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let workers = rayon::current_num_threads().clamp(1, pairs.len().max(1));
    let mut all_outcomes: Vec<(usize, usize, models::ModelOutcome)> = (0..workers)
        .into_par_iter()
        .flat_map_iter(|_| {
            let mut mine = Vec::new();
            while let Some(&(i, k, m)) =
                pairs.get(next.fetch_add(1, std::sync::atomic::Ordering::Relaxed))
            {
                let protocol = &options.protocols[k];
                let t = Instant::now();
                let outcome =
                    models::fit_and_validate(input, &start, protocol, m, out_dir, options);
                progress(Event::ModelDone {
                    protocol: &protocol.name,
                    model: m,
                    seconds: t.elapsed().as_secs_f64(),
                    done: done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1,
                    total,
                });
                mine.push((i, k, outcome));
            }
            mine
        })
        .collect();
    // Each protocol's models in the order asked for.
    all_outcomes.sort_by_key(|(i, _, _)| *i);
    let mut outcomes_by_protocol: Vec<Vec<models::ModelOutcome>> =
        options.protocols.iter().map(|_| Vec::new()).collect();
    for (_, k, outcome) in all_outcomes {
        outcomes_by_protocol[k].push(outcome);
    }
    let mut protocols = Vec::new();
    for (k, (protocol, outcomes)) in options
        .protocols
        .iter()
        .zip(outcomes_by_protocol)
        .enumerate()
    {
        // Figures for the last protocol only: the report's other protocols are in the tables,
        // and rendering every combination would double the report for little insight.
        if k + 1 == options.protocols.len() {
            let section = format!("{} protocol", protocol.name);
            for run in &input.runs {
                let sims: Vec<(String, &airsus_sim::SimulationResponse)> = outcomes
                    .iter()
                    .filter_map(|o| {
                        o.responses
                            .iter()
                            .find(|(n, _, _)| *n == run.name)
                            .map(|(_, r, _)| (o.result.model.clone(), r))
                    })
                    .collect();
                charts.extend(figures::measured_vs_simulated(&section, run, &sims));
            }
            for o in &outcomes {
                for run in input
                    .runs
                    .iter()
                    .filter(|r| !protocol.estimation.contains(&r.name))
                {
                    if let Some((_, _, correlations)) =
                        o.responses.iter().find(|(n, _, _)| *n == run.name)
                    {
                        charts.extend(figures::residual_chart(
                            &format!("{section}: residuals of {}", o.result.model),
                            &o.result.model,
                            run,
                            correlations,
                        ));
                    }
                }
            }
        }
        protocols.push(ProtocolResult {
            name: protocol.name.clone(),
            description: protocol.description.clone(),
            estimation_runs: protocol.estimation.clone(),
            models: outcomes.into_iter().map(|o| o.result).collect(),
        });
    }

    progress(Event::Stage("report"));
    let extrapolated = coverage::extrapolation_notes(input, &options.protocols, &input.truck);
    let mut results = StudyResults {
        schema_version: SCHEMA_VERSION,
        airsus_version: env!("CARGO_PKG_VERSION").to_owned(),
        study: input.label.clone(),
        truck: input.truck_file.display().to_string(),
        initial_state: options
            .prefix
            .estimation_start_name(options.initial)
            .to_owned(),
        prefix_s: options.prefix.prefix_s,
        load_ramp: Some(options.load_ramp.as_str().to_owned()),
        exclude_after_load_change_s: options.exclude_after_load_change_s,
        validation_transitions: (options.load_ramp == LoadRamp::Estimate).then(|| {
            if options.validation_transitions {
                "fitted"
            } else {
                "common"
            }
            .to_owned()
        }),
        allow_trades: options.allow_trades,
        runs: input
            .runs
            .iter()
            .map(|r| RunInfo {
                name: r.name.clone(),
                file: r.file.display().to_string(),
                role: r.role.as_str().to_owned(),
                samples: r.run.len(),
                duration_s: r.run.time_s.last().copied().unwrap_or(0.0)
                    - r.run.time_s.first().copied().unwrap_or(0.0),
                valve_action: r.valve_action(),
                thesis_data_set: findings::thesis_data_set(&r.name),
                ceiling: ceiling::noise_ceiling(r),
                format: r.format.to_owned(),
                notes: r
                    .notes
                    .iter()
                    .cloned()
                    .chain(
                        extrapolated
                            .iter()
                            .filter(|(run, _)| *run == r.name)
                            .map(|(_, note)| note.clone()),
                    )
                    .collect(),
            })
            .collect(),
        submodels,
        protocols,
        elapsed_s: 0.0,
        findings: Default::default(),
    };
    results.findings = findings::findings(&results.runs, &results.protocols);
    results.elapsed_s = started.elapsed().as_secs_f64();
    let report = write_report(out_dir, &results, &charts)?;
    Ok(StudyOutcome { results, report })
}

/// Where the pipeline writes inside its output folder: files and whole folders.
const OUTPUT_FILES: [&str; 2] = ["report.html", "results.json"];
const OUTPUT_FOLDERS: [&str; 2] = ["figures", "estimated"];

/// Refuses an output folder in which the study would write over one of its own inputs (a
/// run kept in `estimated/`, a truck file named `results.json`, …), before anything is
/// computed.
fn refuse_writing_over_inputs(input: &StudyInput, out_dir: &Path) -> Result<(), StudyError> {
    let Ok(out) = std::fs::canonicalize(out_dir) else {
        return Ok(());
    };
    for file in &input.files {
        let Ok(canonical) = std::fs::canonicalize(file) else {
            continue;
        };
        let clash = OUTPUT_FILES.iter().any(|f| canonical == out.join(f))
            || OUTPUT_FOLDERS
                .iter()
                .any(|d| canonical.starts_with(out.join(d)));
        if clash {
            return Err(StudyError::OutputOverInput {
                out_dir: out_dir.to_path_buf(),
                input: file.clone(),
            });
        }
    }
    Ok(())
}

/// The virtual truck's reference study: generates it into `out_dir/data` (seed `seed`) and
/// runs both protocols on it (the built-in pair; `options.protocols` is not used).
pub fn run_builtin(
    out_dir: &Path,
    seed: u64,
    variant: u32,
    options: StudyOptions,
    progress: &(dyn Fn(Event) + Sync),
) -> Result<StudyOutcome, StudyError> {
    progress(Event::Stage(
        "generating the reference experiments with the virtual truck",
    ));
    let data = out_dir.join("data");
    let generated = airsus_truck::experiments::generate_variant(&data, seed, variant, &mut |_| {})?;
    let mut input = load_study(&generated.study)?;
    input.label = format!(
        "built-in virtual truck (variant {variant}, seed {seed}), {}",
        generated.study.display()
    );
    let options = StudyOptions {
        protocols: Protocol::builtin_pair(),
        ..options
    };
    run_study(&input, &options, out_dir, progress)
}

/// The summary table: models × runs × outputs, estimated NRMSE, one block per protocol.
pub fn summary_table(results: &StudyResults) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let any_logged_input = results
        .runs
        .iter()
        .any(|r| r.ceiling.as_ref().is_some_and(|c| c.logged_input.is_some()));
    for p in &results.protocols {
        let _ = writeln!(
            s,
            "\nNRMSE [%] (eq 3.33), protocol `{}`: estimation on {}",
            p.name,
            p.estimation_runs.join(" + ")
        );
        let _ = write!(s, "{:<7}", "model");
        for r in &results.runs {
            let mark = if p.estimation_runs.contains(&r.name) {
                "*"
            } else {
                ""
            };
            let _ = write!(s, " {:>19}", format!("{}{mark}", r.name));
        }
        let _ = writeln!(s);
        let _ = write!(s, "{:<7}", "");
        for _ in &results.runs {
            let _ = write!(s, " {:>9} {:>9}", "height", "pressure");
        }
        let _ = writeln!(s);
        for m in &p.models {
            let _ = write!(s, "{:<7}", m.model);
            for r in &results.runs {
                let fit = m.run(&r.name).and_then(|f| f.estimated);
                let cell =
                    |v: Option<f64>| v.map_or_else(|| "failed".to_owned(), |v| format!("{v:.1}"));
                let _ = write!(
                    s,
                    " {:>9} {:>9}",
                    cell(fit.map(|f| f.height_percent)),
                    cell(fit.map(|f| f.pressure_percent))
                );
            }
            let _ = writeln!(s);
        }
        // The noise floor: what a model that explained everything but the noise would score.
        let _ = write!(s, "{:<7}", "ceiling");
        for r in &results.runs {
            let cell = |v: Option<f64>| {
                v.map_or_else(
                    || "–".to_owned(),
                    |v| format!("{v:.1}{}", r.ceiling.as_ref().map_or("", |c| c.mark())),
                )
            };
            let _ = write!(
                s,
                " {:>9} {:>9}",
                cell(r.ceiling.as_ref().map(|c| c.height_percent)),
                cell(r.ceiling.as_ref().map(|c| c.pressure_percent))
            );
        }
        let _ = writeln!(s);
        if any_logged_input {
            let _ = write!(s, "{:<7}", "logged");
            for r in &results.runs {
                let (height, pressure, mark) = match &r.ceiling {
                    Some(c) => match c.logged_input {
                        Some(l) => (l.height_percent, l.pressure_percent, ""),
                        None => (c.height_percent, c.pressure_percent, c.mark()),
                    },
                    None => (f64::NAN, f64::NAN, ""),
                };
                let cell = |v: f64| {
                    if v.is_nan() {
                        "–".to_owned()
                    } else {
                        format!("{v:.1}{mark}")
                    }
                };
                let _ = write!(s, " {:>9} {:>9}", cell(height), cell(pressure));
            }
            let _ = writeln!(s);
        }
    }
    let _ = writeln!(
        s,
        "(* estimation run; ceiling: the noise-free truth against the measurements, ~ estimated from the measurements' noise{})",
        if any_logged_input {
            "; logged: the ceiling of a model driven by the logged load, where the truck felt load changes its log does not show"
        } else {
            ""
        }
    );
    s
}
