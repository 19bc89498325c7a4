//! `airsus greybox`: grey-box estimation of a model's physical parameters from one or more
//! runs at once (thesis 5.2.6, Tables 5.10–5.12; MATLAB `nlgreyest` with simulation focus).
//!
//! Prints the NRMSE per run and output (nominal and estimated), the estimates with standard
//! deviations, the identifiability findings (freed parameters the runs cannot determine are
//! kept at their nominal values and listed), the number of simulations and the time; or the
//! same as JSON with `--json`. `--out` writes the truck file with the estimates, which loads
//! back with `--truck`.
//!
//! Each run starts from its first seconds (`--initial-state joint`, the default): the
//! states that carry its history are fitted to them under the start values, the parameters
//! are fitted from those starts, and starts and parameters are then refitted in turn (the
//! joint estimate, `airsus_estimate::estimate_jointly`); `--initial-state prefix` fits the
//! starts once under the start values and holds them. With `--initial-state equilibrium`
//! each run starts in static equilibrium at its first measured sensor height (the reference
//! truck's effective area is flat near its working point, so the pressure would pin the
//! height poorly), or at its first measured pressure with `--initial pressure`.

use airsus_data::atomic::refuse_overwriting_inputs;
use std::path::PathBuf;

use airsus_data::{Outputs, read_force_map, read_truck, write_truck};
use airsus_estimate::{
    FreeParameter, GreyboxOptions, GreyboxProblem, IdentifiabilityPolicy, InitialChoice, LoadRamp,
    MultiStart, NoProgress, Normalisation, Observer, OutputWeights, PrefixOptions, StartMethod,
    TerminalProgress, estimate_with_starts, estimation_start, initial_state::DEFAULT_PREFIX_S,
    no_trade::keep_every_run_by_fits,
};
use airsus_truck::models::{build_any_model, default_free};

use super::{RunSourceArgs, read_run_file};
use anyhow::{Context, bail};

/// `--load-ramp` (here and in `study`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum LoadRampArg {
    Logged,
    Estimate,
}

impl From<LoadRampArg> for LoadRamp {
    fn from(arg: LoadRampArg) -> Self {
        match arg {
            LoadRampArg::Logged => Self::Logged,
            LoadRampArg::Estimate => Self::Estimate,
        }
    }
}

/// What fixes each run's initial equilibrium.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum InitialArg {
    /// The first measured sensor height (default).
    Height,
    /// The first measured bellow pressure.
    Pressure,
}

/// Estimate named physical parameters of a model by minimising the simulation error of
/// height and pressure (each normalised by its spread in each run) over all runs at once.
#[derive(Debug, Clone, clap::Args)]
pub struct GreyboxArgs {
    /// Model: any registered model (`airsus models`).
    #[arg(long)]
    pub model: String,
    /// Parameters to estimate, comma-separated short names (`airsus models` lists each
    /// model's). The others stay fixed. Default: the model's default set (thesis "Estimation
    /// 2"), plus the flow parameters and the gas volume's scale when a run has valve action,
    /// and the damper table's scale when a run has road input.
    #[arg(long, value_delimiter = ',')]
    pub free: Vec<String>,
    /// Truck parameter file with the nominal (start) values.
    #[arg(long)]
    pub truck: PathBuf,
    /// Estimation run with measured height and pressure (CSV, MDF4, Parquet or a CAN log);
    /// repeat for several runs.
    #[arg(long = "run", required = true)]
    pub runs: Vec<PathBuf>,
    /// How the runs map onto the run columns (the same for every --run).
    #[command(flatten)]
    pub source: RunSourceArgs,
    /// Write the estimated parameters as a truck file.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Bounds for a freed parameter, NAME=LOWER:UPPER (default: the model's admissible
    /// range); repeatable.
    #[arg(long = "bounds", value_name = "NAME=LOWER:UPPER")]
    pub bounds: Vec<String>,
    /// Maximum Levenberg–Marquardt iterations per fit round.
    #[arg(long, default_value_t = GreyboxOptions::default().max_iterations)]
    pub max_iterations: usize,
    /// Relative tolerance on the loss decrease and the scaled step (convergence test); the
    /// rounds that refit the starts with the parameters stop at a 0.1 % loss decrease where
    /// this is tighter.
    #[arg(long, default_value_t = GreyboxOptions::default().tolerance)]
    pub tolerance: f64,
    /// What fixes each run's initial equilibrium.
    #[arg(long, value_enum, default_value_t = InitialArg::Height)]
    pub initial: InitialArg,
    /// How runs start: `joint` (the default, except with `--initial pressure`) fits the
    /// states that carry each run's history (friction, creep, gas temperature, air amount) to
    /// its first seconds and estimates starts and parameters in turn; `prefix` fits them
    /// once under the start values and holds them while the parameters are fitted;
    /// `equilibrium` starts every run in static equilibrium.
    #[arg(long, value_enum)]
    pub initial_state: Option<crate::commands::simulate::StartArg>,
    /// Length of the prefix each start is fitted to, s.
    #[arg(long, default_value_t = DEFAULT_PREFIX_S)]
    pub prefix_s: f64,
    /// Seconds after each logged load change that the loss leaves out (0, the default:
    /// none): a log records a step where the wheel takes the load over seconds, and fitted
    /// to those seconds the parameters absorb the transition.
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0)]
    pub exclude_after_load_change_s: f64,
    /// How the logged load reaches the model: `estimate` (the default: each logged change
    /// eased over its own transition time, estimated in turn with the parameters; for logs
    /// that record a load change as a step while the wheel takes it over seconds) or
    /// `logged` (steps stay steps).
    #[arg(long, value_enum, default_value_t = LoadRampArg::Estimate)]
    pub load_ramp: LoadRampArg,
    /// How the loss weighs runs and outputs: `pooled-spread` (each output by its spread over
    /// all runs; long runs count more) or `noise-level` (each run and output by its own
    /// measurement noise, every run equally).
    #[arg(long, value_enum, default_value_t = NormalisationArg::PooledSpread)]
    pub normalisation: NormalisationArg,
    /// Weight of the height error (after normalisation; 0 leaves it out).
    #[arg(long, default_value_t = 1.0)]
    pub height_weight: f64,
    /// Weight of the pressure error (after normalisation; 0 leaves it out).
    #[arg(long, default_value_t = 1.0)]
    pub pressure_weight: f64,
    /// Local fits of the global stage at most: the nominal point's, and fits from a Latin
    /// hypercube over nominal ± `--start-spread` inside the bounds (its first points, or with
    /// `--screen` the best screened points that beat the nominal one); the best kept (1: the
    /// plain local fit; where it is the only one and the alternation of starts follows, it
    /// is held to a round's 15 iterations).
    #[arg(long, default_value_t = 1)]
    pub starts: usize,
    /// Points of the Latin hypercube screened by their loss (one simulation of each run
    /// each) before any local fit: the starts beside the nominal one then begin at the best
    /// of the points that explain the runs better than the nominal point does (fewer when
    /// fewer do). 0: the starts are the hypercube's first points, unscreened.
    #[arg(long, default_value_t = 0)]
    pub screen: usize,
    /// Half-width of the starts' range around each nominal value, relative.
    #[arg(long, default_value_t = 0.5)]
    pub start_spread: f64,
    /// Relative standard deviation above which a parameter counts as not determined by the
    /// runs (kept at its start value).
    #[arg(long, default_value_t = 0.5)]
    pub max_relative_std: f64,
    /// Estimate parameters found not identifiable anyway (they are only reported).
    #[arg(long)]
    pub keep_unidentifiable: bool,
    /// Keep the pooled estimate where it explains an estimation run and output worse than
    /// the start values did (a fit as MATLAB's `greyest` gives it), naming each such trade on
    /// stderr. By default it is refitted with the traded runs weighted more.
    #[arg(long)]
    pub allow_trades: bool,
    /// A bellow force map (lab: `bellow_height_mm, pressure_kpa, force_n`) that enters the
    /// loss as a prior on the effective-area law: one residual per point, weighted as one
    /// more output of a run at its noise. The runs pin the area only at the heights they
    /// visit; the map holds it elsewhere.
    #[arg(long, value_name = "MAP.csv")]
    pub force_map: Option<PathBuf>,
    /// The force map's error, N (default: the misfit of the truck file's effective-area law
    /// to the map, which is the map's noise when the law was fitted to it).
    #[arg(long, value_name = "N", requires = "force_map")]
    pub force_map_noise_n: Option<f64>,
    /// Print the result as JSON.
    #[arg(long)]
    pub json: bool,
}

/// `--normalisation`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum NormalisationArg {
    PooledSpread,
    NoiseLevel,
}

impl From<NormalisationArg> for Normalisation {
    fn from(n: NormalisationArg) -> Self {
        match n {
            NormalisationArg::PooledSpread => Normalisation::PooledSpread,
            NormalisationArg::NoiseLevel => Normalisation::NoiseLevel,
        }
    }
}

fn parse_bounds(text: &str) -> anyhow::Result<(String, f64, f64)> {
    let parse = || -> Option<(String, f64, f64)> {
        let (name, range) = text.split_once('=')?;
        let (lo, hi) = range.split_once(':')?;
        Some((
            name.trim().to_owned(),
            lo.trim().parse().ok()?,
            hi.trim().parse().ok()?,
        ))
    };
    parse()
        .with_context(|| format!("--bounds `{text}`: expected NAME=LOWER:UPPER, e.g. m2=300:800"))
}

pub fn run(args: &GreyboxArgs) -> anyhow::Result<()> {
    airsus_estimate::check_load_change_exclusion_s(args.exclude_after_load_change_s)
        .map_err(|e| anyhow::anyhow!("--exclude-after-load-change-s {e}"))?;
    let source = args.source.source()?;
    if let Some(out) = &args.out {
        let mut inputs: Vec<&std::path::Path> = vec![&args.truck];
        inputs.extend(args.runs.iter().map(PathBuf::as_path));
        inputs.extend(source.dbc.as_deref());
        inputs.extend(args.force_map.as_deref());
        refuse_overwriting_inputs(out, &inputs)?;
    }
    if let Some(noise) = args.force_map_noise_n {
        airsus_estimate::check_force_map_noise_n(noise)
            .map_err(|e| anyhow::anyhow!("--force-map-noise-n {e}"))?;
    }
    let force_map = args.force_map.as_deref().map(read_force_map).transpose()?;
    let loaded = read_truck(&args.truck)?;
    if !loaded.defaulted.is_empty() {
        eprintln!(
            "truck {}: {} key(s) not in the file, using defaults: {}",
            args.truck.display(),
            loaded.defaulted.len(),
            loaded
                .defaulted
                .iter()
                .map(|d| format!("{} = {}", d.key, d.value))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let mut truck = loaded.parameters;
    let model = build_any_model(&args.model, &truck)?;
    let runs = args
        .runs
        .iter()
        .map(|p| read_run_file(p, Outputs::Required, &source))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let run_refs: Vec<&_> = runs.iter().collect();

    let free_names: Vec<String> = if args.free.is_empty() {
        let (names, excitation) = default_free(&*model, &run_refs)?;
        let excited = excitation.describe();
        eprintln!(
            "freeing {}'s default set{}: {}",
            args.model,
            if excited.is_empty() {
                String::new()
            } else {
                format!(" with what {excited} determines (the runs have {excited})")
            },
            names.join(",")
        );
        names.iter().map(|n| (*n).to_owned()).collect()
    } else {
        args.free.clone()
    };
    let mut free: Vec<FreeParameter> = free_names.iter().map(FreeParameter::new).collect();
    for text in &args.bounds {
        let (name, lo, hi) = parse_bounds(text)?;
        let Some(p) = free.iter_mut().find(|p| p.name == name) else {
            bail!("--bounds {name}: `{name}` is not in --free");
        };
        *p = FreeParameter::new(name).with_bounds(lo, hi);
    }
    let mut problem = GreyboxProblem::new(&*model, &run_refs, &[])
        .with_weights(OutputWeights {
            height: args.height_weight,
            pressure: args.pressure_weight,
        })
        .with_initial(match args.initial {
            InitialArg::Height => InitialChoice::SensorHeight,
            InitialArg::Pressure => InitialChoice::BellowPressure,
        })
        .with_normalisation(args.normalisation.into())
        .with_exclusion_after_load_changes(args.exclude_after_load_change_s);
    problem.free = free;
    if let Some(map) = &force_map {
        problem = problem.with_force_map(map, args.force_map_noise_n);
        if let (Some(prior), false) = (&problem.force_map, args.json) {
            eprintln!(
                "force map: {} points in the loss, force error {:.1} N",
                map.len(),
                prior.force_noise_n
            );
        }
    }
    let options = GreyboxOptions {
        max_iterations: args.max_iterations,
        tolerance: args.tolerance,
        max_relative_std: args.max_relative_std,
        policy: if args.keep_unidentifiable {
            IdentifiabilityPolicy::ReportOnly
        } else {
            IdentifiabilityPolicy::FixAtNominal
        },
        allow_trades: args.allow_trades,
        ..GreyboxOptions::default()
    };
    let mut terminal = TerminalProgress::new();
    let mut quiet = NoProgress;
    let observer: &mut dyn Observer = if args.json { &mut quiet } else { &mut terminal };
    if args.screen > 0 && args.starts == 1 {
        eprintln!(
            "note: --screen {} has no effect with --starts 1 (no local fit beside the nominal one to start from a screened point)",
            args.screen
        );
    }
    let start = estimation_start(problem.initial, args.initial_state.map(Into::into))
        .map_err(|e| anyhow::anyhow!("--initial pressure with --initial-state prefix: {e}"))?;
    let prefix = PrefixOptions {
        prefix_s: args.prefix_s,
        refit_starts: args.initial_state.is_none_or(|arg| arg.refits_starts()),
        ..PrefixOptions::default()
    };
    let (joint, global) = estimate_with_starts(
        &problem,
        &options,
        &MultiStart {
            count: args.starts,
            spread: args.start_spread,
            seed: 1,
            screen: args.screen,
        },
        start,
        &prefix,
        args.load_ramp.into(),
        observer,
    )?;
    // No run or output explained worse than by the start values (issue #12).
    let prefix_if = (start == StartMethod::Prefix && prefix.refit_starts).then_some(&prefix);
    // The estimate's bar is finished: each refit is announced on a line of its own on
    // stderr (with --json too, as the notes are).
    let guarded = keep_every_run_by_fits(joint, &problem, &options, prefix_if, &mut StageLines);
    let joint = guarded.joint;
    for note in joint.start_notes.iter().chain(&joint.load_notes) {
        eprintln!("{note}");
    }
    if start == StartMethod::Prefix || joint.transitions_s.is_some() {
        eprintln!("{}", joint.describe(args.prefix_s));
    }
    if let Some(note) = &guarded.note {
        eprintln!("{note}");
    }
    let result = joint.estimate;
    if args.starts > 1 {
        eprintln!(
            "global stage: {}, best from start {}; {} {}",
            global.describe(),
            global.best_start,
            if global.starts == 1 {
                "no design point beat the start; its fit's loss"
            } else {
                "local optima's losses"
            },
            global
                .losses
                .iter()
                .map(|l| format!("{l:.4e}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }

    if args.json {
        println!("{}", serde_json::to_string_pretty(&result)?);
    } else {
        print!("{result}");
    }
    if let Some(out) = &args.out {
        result.estimated_model.write_parameters(&mut truck);
        write_truck(out, &truck)?;
        if !args.json {
            println!();
            println!("estimated parameters written to {}", out.display());
        }
        // Every registered model's parameters have a truck-file home; a model whose don't (or
        // a value the file cannot hold) is said so rather than lost silently.
        let reread = build_any_model(&args.model, &truck)?;
        let unsaved: Vec<String> = free_names
            .iter()
            .filter_map(|name| {
                let estimated = result.estimated_model.parameter(name).ok()?;
                let saved = reread.parameter(name).ok()?;
                (estimated != saved).then(|| format!("{name} = {estimated:e}"))
            })
            .collect();
        if !unsaved.is_empty() {
            eprintln!(
                "warning: {} has no truck-file key for {}; they are in the printed result only",
                args.model,
                unsaved.join(", ")
            );
        }
    }
    if !result.stop.is_converged() {
        eprintln!("warning: the estimation did not converge ({})", result.stop);
    }
    Ok(())
}

/// Stage messages as lines on stderr (after the estimate's progress bar has finished).
struct StageLines;

impl Observer for StageLines {
    fn stage(&mut self, message: &str) {
        eprintln!("{message}");
    }
}
