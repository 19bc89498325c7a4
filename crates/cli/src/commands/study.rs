//! `airsus study`: the whole thesis pipeline on a study file, or on the built-in virtual truck.

use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Instant;

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};

use airsus_study::{
    Event, Protocol, StudyOptions, check_models, load_study, run_builtin, run_study, study_models,
    summary_table,
};

/// Run the thesis pipeline: submodel fits, grey-box estimation of every model (m1, m2, m2x,
/// m2xh, m3 and the virtual-truck structure), validation with residual analysis on every run,
/// and a report (report.html, results.json, figures, estimated truck files).
#[derive(Debug, Clone, clap::Args)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["study", "builtin"])))]
pub struct StudyArgs {
    /// Study file (TOML) naming a truck file, runs, a force map and tank discharges.
    #[arg(value_name = "STUDY.toml")]
    pub study: Option<PathBuf>,
    /// Generate the reference experiments with the built-in virtual truck (into DIR/data) and
    /// run two protocols side by side: the thesis' (estimation on data-set 1) and ours (plus
    /// the valve pulses of data-set 3).
    #[arg(long)]
    pub builtin: bool,
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Seed of the built-in study.
    #[arg(long, default_value_t = 1, requires = "builtin")]
    pub seed: u64,
    /// Member of the virtual truck family the built-in study is generated with (0, the
    /// default, is the reference truck; see `airsus generate --variant`).
    #[arg(long, default_value_t = 0, requires = "builtin")]
    pub variant: u32,
    /// Models to estimate (comma-separated).
    #[arg(long, value_delimiter = ',', default_values_t = study_models().iter().map(|m| (*m).to_owned()).collect::<Vec<_>>())]
    pub models: Vec<String>,
    /// How runs start: `joint` (default: each run's history states fitted to its first
    /// 10 s; in estimation runs refitted with the parameters in turn, in validation runs with
    /// the parameters fixed), `prefix` (the same, but the estimation runs' starts fitted once
    /// under the start values and held) or `equilibrium` (static, at the first measured
    /// height).
    #[arg(long, value_enum, default_value_t = crate::commands::simulate::StartArg::Joint)]
    pub initial_state: crate::commands::simulate::StartArg,
    /// Length of the prefix each run's start is fitted to, s (estimation and validation
    /// runs).
    #[arg(long, default_value_t = airsus_estimate::initial_state::DEFAULT_PREFIX_S)]
    pub prefix_s: f64,
    /// How the grey-box loss weighs runs and outputs: `pooled-spread` (each output by its
    /// spread over all runs; long runs count more) or `noise-level` (each run and output by
    /// its own measurement noise, every run equally).
    #[arg(long, value_enum, default_value_t = crate::commands::greybox::NormalisationArg::PooledSpread)]
    pub normalisation: crate::commands::greybox::NormalisationArg,
    /// Local fits of each grey-box fit's global stage at most, the start's included (1: the
    /// plain local fit). The others begin at the best of the `--screen` points that explain
    /// the estimation runs better than the start does; each costs about one more fit.
    #[arg(long, default_value_t = airsus_study::DEFAULT_STARTS)]
    pub starts: usize,
    /// Points of a Latin hypercube over the start ± 50 % the global stage screens by their
    /// loss (one simulation of each run each) before it starts a local fit from any; 0: the
    /// local fits begin at the hypercube's first points unscreened.
    #[arg(long, default_value_t = airsus_study::DEFAULT_SCREEN)]
    pub screen: usize,
    /// Iteration limit of each grey-box fit.
    #[arg(long, default_value_t = 60)]
    pub max_iterations: usize,
    /// How the logged load reaches the models: `logged` (steps stay steps) or `estimate`
    /// (each logged change of the estimation runs eased over its own transition time,
    /// estimated in turn with the parameters; validation runs eased over one time fitted to
    /// the estimation runs; for logs that record a load change as a step while the wheel
    /// takes it over seconds).
    #[arg(long, value_enum, default_value_t = crate::commands::greybox::LoadRampArg::Estimate)]
    pub load_ramp: crate::commands::greybox::LoadRampArg,
    /// Seconds after each logged load change that the estimation's loss leaves out (0:
    /// none): a log records a step where the wheel takes the load over seconds, each time
    /// differently, and fitted to those seconds the parameters absorb the transition.
    #[arg(long, value_name = "SECONDS", default_value_t = airsus_study::DEFAULT_EXCLUDE_AFTER_LOAD_CHANGE_S)]
    pub exclude_after_load_change_s: f64,
    /// How a validation run's logged load changes are eased: `fitted`, each over its own
    /// transition time fitted to the run with the parameters fixed (as its start is to its
    /// first seconds: a crane sets each load down in its own time, which the log does not
    /// record); `common`, all over the one time fitted to the estimation runs. With
    /// `--load-ramp estimate`.
    #[arg(long, value_enum, default_value_t = ValidationTransitionsArg::Fitted)]
    pub validation_transitions: ValidationTransitionsArg,
    /// Keep each model's pooled estimate where it explains an estimation run and output
    /// worse than the start values did (a fit as MATLAB's `greyest` gives it), naming each
    /// such trade in the model's notes. By default it is refitted with the traded runs
    /// weighted more, and its fits are kept in results.json as each run's `pooled`.
    #[arg(long)]
    pub allow_trades: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ValidationTransitionsArg {
    Fitted,
    Common,
}

pub fn run(args: &StudyArgs) -> anyhow::Result<()> {
    let started = Instant::now();
    check_models(&args.models)?;
    airsus_estimate::check_load_change_exclusion_s(args.exclude_after_load_change_s)
        .map_err(|e| anyhow::anyhow!("--exclude-after-load-change-s {e}"))?;
    airsus_estimate::check_prefix_s(args.prefix_s)
        .map_err(|e| anyhow::anyhow!("--prefix-s {e}"))?;
    if args.max_iterations == 0 {
        bail!("--max-iterations must be at least 1");
    }
    let bar = ProgressBar::new(0);
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    let bar = Mutex::new(bar);
    let progress = |event: Event| {
        let Ok(bar) = bar.lock() else { return };
        match event {
            Event::Stage(stage) => bar.set_message(stage.to_owned()),
            Event::ModelDone {
                protocol,
                model,
                seconds,
                done,
                total,
            } => {
                bar.set_length(total as u64);
                bar.set_position(done as u64);
                bar.println(format!(
                    "  {protocol}: {model} estimated and validated in {seconds:.1} s"
                ));
            }
        }
    };
    let options = StudyOptions {
        models: args.models.clone(),
        max_iterations: args.max_iterations,
        initial: args.initial_state.into(),
        prefix: airsus_estimate::PrefixOptions {
            prefix_s: args.prefix_s,
            refit_starts: args.initial_state.refits_starts(),
            ..airsus_estimate::PrefixOptions::default()
        },
        normalisation: args.normalisation.into(),
        starts: args.starts,
        screen: args.screen,
        load_ramp: args.load_ramp.into(),
        exclude_after_load_change_s: args.exclude_after_load_change_s,
        validation_transitions: args.validation_transitions == ValidationTransitionsArg::Fitted,
        allow_trades: args.allow_trades,
        ..StudyOptions::new(vec![])
    };
    let outcome = match &args.study {
        Some(path) => {
            let input = load_study(path)?;
            for d in &input.defaulted {
                eprintln!("note: {} omits {}", input.truck_file.display(), d);
            }
            let options = StudyOptions {
                protocols: vec![Protocol::from_roles(&input)],
                ..options
            };
            run_study(&input, &options, &args.out, &progress)
        }
        None => run_builtin(&args.out, args.seed, args.variant, options, &progress),
    }
    .with_context(|| format!("running the study into {}", args.out.display()))?;
    if let Ok(bar) = bar.lock() {
        bar.finish_and_clear();
    }
    print!("{}", summary_table(&outcome.results));
    for failure in &outcome.report.chart_failures {
        eprintln!("warning: {failure}");
    }
    eprintln!(
        "report: {}\nresults: {}\n{} figures; finished in {:.1} s",
        outcome.report.html.display(),
        outcome.report.json.display(),
        outcome.report.figures.len(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
