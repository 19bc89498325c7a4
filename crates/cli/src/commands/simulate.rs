//! `airsus simulate`: one model, one truck, one run → the simulated outputs as a run file.
//!
//! Initial condition, in order of precedence:
//! 1. `--initial-pressure-kpa` or `--initial-height-mm` (static equilibrium at that bellow gauge
//!    pressure or sensor height under the first sample's inputs);
//! 2. the run's first measured sensor height, when the run has measured outputs. Not the
//!    pressure, although the SPEC words it so: the effective area rises, peaks and falls over
//!    the stroke, so one pressure can mean two heights (or none, for a slightly low pressure),
//!    while a height gives exactly one pressure. The grey-box estimator starts the same way, so
//!    a simulation reproduces the fit it came from;
//! 3. otherwise an error asking for one of the two flags: an inputs-only scenario carries no
//!    information about the amount of air in the bellows, and guessing it would silently shift
//!    the whole simulated pressure and height.

use std::path::PathBuf;
use std::time::Instant;

use airsus_data::atomic::refuse_overwriting_inputs;
use airsus_data::{Outputs, RunOutputs};
use airsus_estimate::initial_state::DEFAULT_PREFIX_S;
use airsus_estimate::{PrefixOptions, StartChoice, StartMethod, resolve_start};
use airsus_sim::{InputSeries, Method, SimulationProblem, SolverOptions, simulate};
use airsus_truck::models::build_any_model;
use anyhow::{Context, bail};

use super::{RunSourceArgs, read_run_file, read_truck_listing_defaults};

/// Integration method (see BENCHMARKS.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MethodArg {
    /// BDF, and Tsitouras 5(4) where the road moves (default).
    Auto,
    /// Variable-order BDF throughout.
    Bdf,
    /// TR-BDF2 (SDIRK, order 2).
    TrBdf2,
    /// ESDIRK3(4) (SDIRK, order 3).
    Esdirk34,
    /// Tsitouras 5(4), explicit (non-stiff cross-check; slow on stiff models).
    Tsit45,
}

impl From<MethodArg> for Method {
    fn from(m: MethodArg) -> Self {
        match m {
            MethodArg::Auto => Method::Auto,
            MethodArg::Bdf => Method::Bdf,
            MethodArg::TrBdf2 => Method::TrBdf2,
            MethodArg::Esdirk34 => Method::Esdirk34,
            MethodArg::Tsit45 => Method::Tsit45,
        }
    }
}

/// Simulate a model over a run's inputs and write the simulated outputs in the run format.
#[derive(Debug, Clone, clap::Args)]
pub struct SimulateArgs {
    /// Model to simulate: any registered model (`airsus models`).
    #[arg(long)]
    pub model: String,
    /// Truck parameter file (TOML); omitted *est* keys take the reference truck's values.
    #[arg(long)]
    pub truck: PathBuf,
    /// Run file whose inputs drive the model (CSV, MDF4, Parquet or a CAN log; see
    /// --columns); measured outputs are optional.
    #[arg(long)]
    pub run: PathBuf,
    #[command(flatten)]
    pub source: RunSourceArgs,
    /// Output run file: the inputs copied, `height_mm` and `pressure_kpa` simulated; Parquet
    /// when it ends in `.parquet`, else CSV.
    #[arg(long)]
    pub out: PathBuf,
    /// Relative tolerance of the adaptive ODE solver. The default is the estimator's (its
    /// finite-difference Jacobians need it), so a run simulates as a study scored it; 1e-4
    /// simulates a road run 2-3 times faster, 0.01 mm and 0.03 kPa off at worst (BENCHMARKS.md),
    /// far below the sensors' noise.
    #[arg(long, default_value_t = 1e-6)]
    pub rtol: f64,
    /// Integration method. `auto` runs the explicit Tsitouras 5(4) where the road moves and
    /// BDF elsewhere: a rough road 3-5 times faster than `bdf` (the study's method), 0.001 mm
    /// and 0.004 kPa off a tight solution, so the scores match the study's to their printed
    /// precision (BENCHMARKS.md).
    #[arg(long, value_enum, default_value_t = MethodArg::Auto)]
    pub method: MethodArg,
    /// Start in static equilibrium at this bellow gauge pressure (kPa) instead of the run's
    /// first measured height.
    #[arg(long, conflicts_with_all = ["initial_height_mm", "initial_state"])]
    pub initial_pressure_kpa: Option<f64>,
    /// Start in static equilibrium at this sensor height (mm).
    #[arg(long, conflicts_with = "initial_state")]
    pub initial_height_mm: Option<f64>,
    /// How a run with measured outputs starts: `prefix` (default, as the study starts its
    /// validation runs) is static equilibrium with the states that carry the run's history
    /// (friction, creep, gas temperature, air amount, and the height it is anchored at)
    /// fitted to its first seconds; `equilibrium` is static equilibrium at the first
    /// measured height; `joint` belongs to an estimation (`greybox`, `study`) and is refused
    /// here.
    #[arg(long, value_enum, default_value_t = StartArg::Prefix)]
    pub initial_state: StartArg,
    /// Length of the prefix the start is fitted to, s.
    #[arg(long, default_value_t = DEFAULT_PREFIX_S)]
    pub prefix_s: f64,
    /// Ease every change of the logged load over this many seconds (smoothstep), as the
    /// wheel takes a load over seconds while a log records a step; `study --load-ramp
    /// estimate` fits it. The output file keeps the eased load.
    #[arg(long, value_name = "SECONDS")]
    pub load_ramp_s: Option<f64>,
    /// Ease each change of the logged load over its own time, s, one per change in time
    /// order (what `greybox` estimated for an estimation run), e.g. `4.9,4.4,6.6`.
    #[arg(
        long,
        value_name = "S,S,...",
        value_delimiter = ',',
        conflicts_with = "load_ramp_s"
    )]
    pub load_transitions_s: Vec<f64>,
}

/// `--initial-state`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum StartArg {
    /// Static equilibrium with the history states fitted to the run's first seconds; in an
    /// estimation, fitted once under the start values and held.
    Prefix,
    /// Static equilibrium at the first measured height.
    Equilibrium,
    /// In an estimation (`greybox`, `study`): the estimation runs' starts fitted to their
    /// first seconds and refitted with the parameters in turn (validation runs: prefix, the
    /// parameters fixed).
    Joint,
}

impl From<StartArg> for StartMethod {
    fn from(s: StartArg) -> Self {
        match s {
            StartArg::Prefix | StartArg::Joint => StartMethod::Prefix,
            StartArg::Equilibrium => StartMethod::Equilibrium,
        }
    }
}

impl StartArg {
    /// Whether an estimation refits the starts with the parameters
    /// ([`PrefixOptions::refit_starts`]).
    pub fn refits_starts(self) -> bool {
        self == StartArg::Joint
    }
}

pub fn run(args: &SimulateArgs) -> anyhow::Result<()> {
    if args.initial_state == StartArg::Joint {
        bail!(
            "--initial-state joint estimates each run's start together with parameters, which `greybox` and `study` do; `simulate` fits no parameters: use prefix (the start fitted to the first seconds) or equilibrium"
        );
    }
    if !(args.rtol.is_finite() && args.rtol > 0.0 && args.rtol < 1.0) {
        bail!("--rtol {} must be between 0 and 1", args.rtol);
    }
    let source = args.source.source()?;
    let mut inputs_read: Vec<&std::path::Path> = vec![&args.truck, &args.run];
    inputs_read.extend(source.dbc.as_deref());
    refuse_overwriting_inputs(&args.out, &inputs_read)?;
    let loaded = read_truck_listing_defaults(&args.truck)?;
    let mut run = read_run_file(&args.run, Outputs::IfPresent, &source)?;
    if let Some(tau) = args.load_ramp_s {
        let tau = airsus_estimate::check_load_ramp_s(tau)
            .map_err(|e| anyhow::anyhow!("--load-ramp-s: {e}"))?;
        run = airsus_estimate::ramp_logged_load(&run, tau);
    }
    if !args.load_transitions_s.is_empty() {
        airsus_estimate::check_load_transitions(&run, &args.load_transitions_s)
            .map_err(|e| anyhow::anyhow!("--load-transitions-s: {e}"))?;
        run = airsus_estimate::ease_logged_load(&run, &args.load_transitions_s);
    }
    let longest_transition_s = args
        .load_transitions_s
        .iter()
        .copied()
        .fold(args.load_ramp_s.unwrap_or(0.0), f64::max);
    let model = build_any_model(&args.model, &loaded.parameters)?;

    let choice = match (args.initial_pressure_kpa, args.initial_height_mm) {
        (Some(kpa), _) => StartChoice::PressureKpa(kpa),
        (None, Some(mm)) => StartChoice::HeightMm(mm),
        (None, None) => StartChoice::FromRun(
            args.initial_state.into(),
            PrefixOptions {
                prefix_s: args.prefix_s,
                ..PrefixOptions::default()
            },
        ),
    };
    let (initial, what) = resolve_start(&*model, &run, &choice)
        .with_context(|| format!("the start of run {}", args.run.display()))?;

    let inputs = InputSeries::from_run(&run)?;
    let options = airsus_estimate::solver_for_ramp(
        &SolverOptions::default()
            .with_method(args.method.into())
            .with_rtol(args.rtol),
        longest_transition_s,
    );
    let problem = SimulationProblem::new(&*model, inputs, initial).with_options(options);
    let started = Instant::now();
    let response = simulate(&problem).with_context(|| {
        format!(
            "simulating model {} over run {}",
            model.name(),
            args.run.display()
        )
    })?;
    let elapsed = started.elapsed();

    let mut out = run.clone();
    out.outputs = Some(RunOutputs {
        sensor_height_m: response.sensor_height_m,
        bellow_gauge_pa: response.bellow_gauge_pa,
    });
    airsus_logs::write_run(&args.out, &out)?;

    let s = &response.statistics;
    let method = match s.fallback {
        Some(finished) => format!("{:?} (finished by {finished:?})", args.method),
        None => format!("{:?}", args.method),
    };
    eprintln!(
        "{}: {} samples ({:.1} s) from {}; {}, rtol {:e}: {} steps ({} rejected), {} rhs evaluations, {} restarts at input changes, {:.1} ms",
        model.name(),
        run.len(),
        run.time_s.last().unwrap_or(&0.0) - run.time_s.first().unwrap_or(&0.0),
        what,
        method,
        args.rtol,
        s.steps,
        s.rejected_steps,
        s.rhs_evaluations,
        s.restarts,
        elapsed.as_secs_f64() * 1e3
    );
    if let Some(measured) = &run.outputs {
        let fit = |m: &[f64], s: &[f64]| {
            airsus_validate::nrmse_percent(m, s)
                .map_or_else(|e| format!("n/a ({e})"), |v| format!("{v:.2} %"))
        };
        let simulated = out.outputs.as_ref().map_or((&[][..], &[][..]), |o| {
            (&o.sensor_height_m[..], &o.bellow_gauge_pa[..])
        });
        eprintln!(
            "NRMSE against the run's measurements (eq 3.33): height {}, pressure {}",
            fit(&measured.sensor_height_m, simulated.0),
            fit(&measured.bellow_gauge_pa, simulated.1)
        );
    }
    eprintln!("wrote {}", args.out.display());
    Ok(())
}
