//! `airsus weigh`: axle-load estimation from a run's bellow pressure and height.

use airsus_data::atomic::refuse_overwriting_inputs;
use std::path::PathBuf;

use anyhow::Context;

use airsus_apps::plot::{WeighingPlot, plot_weighing};
use airsus_apps::weigh::{
    CalibrationTerms, EkfTuning, HysteresisStart, LinearCalibration, StandstillDetector,
    StandstillRule, StaticLaw, StaticWeigher, WeighQuality, WeighingUncertainty, evaluate_series,
    quality_flags, weigh_ekf, weigh_static_from, write_weigh_csv,
};
use airsus_data::{Outputs, RunSource, read_run, read_truck};

use super::{RunSourceArgs, read_run_file};

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// Static force balance inverted, averaged over --window-s.
    Static,
    /// Extended Kalman filter on a model with the load as a random-walk state.
    Ekf,
}

/// How the truck came to the run's first reading (what its wall friction holds at the start).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum StartHysteresis {
    /// Not known: the EKF's interval holds the friction's whole range until the bellow moves.
    Unknown,
    /// Lowered onto its height (a load set down, an exhaust): the friction holds it up.
    Lowered,
    /// Raised onto its height (a fill, a load taken off): the friction holds it down.
    Raised,
}

impl From<StartHysteresis> for HysteresisStart {
    fn from(s: StartHysteresis) -> Self {
        match s {
            StartHysteresis::Unknown => Self::Unknown,
            StartHysteresis::Lowered => Self::Lowered,
            StartHysteresis::Raised => Self::Raised,
        }
    }
}

/// Estimate the wheel load over time from the measured bellow pressure and height (the logged
/// load column is not used), with its standard deviation.
#[derive(Debug, Clone, clap::Args)]
pub struct WeighArgs {
    /// Truck parameter file (nominal, or identified parameters).
    #[arg(long, value_name = "T.toml")]
    pub truck: PathBuf,
    /// Run file with height_mm and pressure_kpa (CSV, MDF4, Parquet or a CAN log); a wheel-load
    /// column is not needed (it is what weighing estimates).
    #[arg(long, value_name = "R.csv")]
    pub run: PathBuf,
    /// How the run (and the calibration run) map onto the run columns.
    #[command(flatten)]
    pub source: RunSourceArgs,
    #[arg(long, value_enum, default_value_t = Method::Static)]
    pub method: Method,
    /// Model the EKF runs (`airsus models`).
    #[arg(long, default_value = "m2")]
    pub model: String,
    /// How the truck came to the run's first reading, for an estimator with wall friction
    /// (the EKF on `truck`; the static method with a `truck`-structure file, one with an
    /// `[effects]` section): at rest the friction and the load trade off exactly, so until
    /// the bellow first moves an unknown start is uncertain by the friction's whole range.
    #[arg(long, value_enum, default_value_t = StartHysteresis::Unknown)]
    pub start_hysteresis: StartHysteresis,
    /// Averaging window of the static method, s.
    #[arg(long, default_value_t = 2.0)]
    pub window_s: f64,
    /// A sample is flagged `loading` (a load arriving, read with the interval the calibration
    /// runs' arrivals measured) when the mean pressure over --loading-window-s after it
    /// differs from the mean over the window before it by more than this, with the valve
    /// closed (the window after ends where it opens) and the road still, kPa. The default
    /// suits 100-300 kg steps on a truck axle (about 30 kPa); smaller loads or a noisier
    /// sensor want another.
    #[arg(long, default_value_t = StandstillDetector::default().loading_shift_pa / 1e3)]
    pub loading_shift_kpa: f64,
    /// The windows the `loading` flag compares, s (see --loading-shift-kpa).
    #[arg(long, default_value_t = StandstillDetector::default().loading_window_s)]
    pub loading_window_s: f64,
    /// How long the `loading` flag holds after the last shift, s; a valve opened within it
    /// (a levelling controller answering the load) carries it on to the valve's closing.
    #[arg(long, default_value_t = StandstillDetector::default().loading_hold_s)]
    pub loading_hold_s: f64,
    /// A run whose logged load is trusted at standstill (e.g. weighbridge loads, a study's
    /// estimation runs): the interval then comes from its residuals (the part the estimate's
    /// own noise does not explain, sized to hold 95 % of each run's known loads). A gain, an
    /// offset, the wall friction's hysteresis and a height term are fitted on it and applied,
    /// except to an estimator with the wall, which carries all four: the EKF on `truck`, and
    /// the static method with a `truck`-structure file (one naming kc, tc, fc and kdahl).
    /// Repeat it to fit on several runs at once: a loading run and a run at one load with the
    /// valve moving the height determine the height term, a loading run alone not.
    /// Calibration runs start as --calibration-start says, else with an unknown wall
    /// friction.
    #[arg(long, value_name = "C.csv")]
    pub calibration_run: Vec<PathBuf>,
    /// How each calibration run starts (as --start-hysteresis), one per --calibration-run in
    /// the same order, comma-separated or repeated: `--calibration-start lowered,raised`.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub calibration_start: Vec<StartHysteresis>,
    /// A run carrying the true load (the virtual truck's truth/ file): score the estimate.
    #[arg(long, value_name = "TRUTH.csv")]
    pub truth: Option<PathBuf>,
    /// Plot of the estimate with its 95 % interval and the standstills marked (with --truth
    /// also the true load and the error against the interval): SVG by the `.svg` extension,
    /// PNG otherwise (written atomically).
    #[arg(long, value_name = "W.svg")]
    pub plot: Option<PathBuf>,
    /// Output CSV: time_s, wheel_load_kg, wheel_load_std_kg, quality (written atomically).
    #[arg(long, value_name = "W.csv")]
    pub out: Option<PathBuf>,
}

pub fn run(args: &WeighArgs) -> anyhow::Result<()> {
    let source = args.source.source()?;
    let mut inputs: Vec<&std::path::Path> = vec![&args.truck, &args.run];
    inputs.extend(source.dbc.as_deref());
    inputs.extend(args.calibration_run.iter().map(PathBuf::as_path));
    inputs.extend(args.truth.as_deref());
    for output in [&args.out, &args.plot].into_iter().flatten() {
        refuse_overwriting_inputs(output, &inputs)?;
    }
    let loaded = read_truck(&args.truck)
        .with_context(|| format!("reading truck file {}", args.truck.display()))?;
    for d in &loaded.defaulted {
        eprintln!("note: {} not in the truck file, using {}", d.key, d.value);
    }
    let truck = loaded.parameters;
    // Weighing estimates the load: a log without a wheel-load channel is weighed as it is.
    let weighed = RunSource {
        load_optional: true,
        ..source.clone()
    };
    let run = read_run_file(&args.run, Outputs::Required, &weighed)?;
    let weigher = StaticWeigher::new(
        StaticLaw::from_truck(&truck),
        WeighingUncertainty::default(),
    );
    if !(args.window_s.is_finite() && args.window_s >= 0.0) {
        anyhow::bail!("--window-s must be a non-negative number of seconds");
    }
    let window = ((args.window_s / run.sample_time_s).round() as usize).max(1);
    let estimate = |run: &airsus_data::Run, start: HysteresisStart| -> anyhow::Result<_> {
        Ok(match args.method {
            Method::Static => weigh_static_from(run, &weigher, window, start)?,
            Method::Ekf => {
                let model = airsus_truck::models::build_any_model(&args.model, &truck)?;
                let tuning = EkfTuning {
                    start_hysteresis: start,
                    ..EkfTuning::default()
                };
                weigh_ekf(run, model, &weigher, &tuning)?
            }
        })
    };
    let mut series = estimate(&run, args.start_hysteresis.into())
        .with_context(|| format!("weighing {}", args.run.display()))?;
    for note in &series.notes {
        eprintln!("note: {note}");
    }
    let rule = StandstillRule::default();
    let detector = StandstillDetector::default()
        .with_loading(
            args.loading_shift_kpa * 1e3,
            args.loading_window_s,
            args.loading_hold_s,
        )
        .context("--loading-shift-kpa, --loading-window-s, --loading-hold-s")?;
    // How far each sample can be trusted, from the run alone.
    let quality = quality_flags(&run, &detector)
        .with_context(|| format!("flagging the samples of {}", args.run.display()))?;
    let calibration_starts =
        calibration_starts(&args.calibration_start, args.calibration_run.len())?;
    if !args.calibration_run.is_empty() {
        let mut cal_runs = Vec::new();
        for (path, &start) in args.calibration_run.iter().zip(&calibration_starts) {
            let cal_run = read_run_file(path, Outputs::Required, &source)?;
            let cal_est = estimate(&cal_run, start)
                .with_context(|| format!("weighing {}", path.display()))?;
            cal_runs.push((cal_run, cal_est));
        }
        let runs: Vec<_> = cal_runs.iter().map(|(run, est)| (run, est)).collect();
        let names = args
            .calibration_run
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ");
        let terms = match args.method {
            Method::Static => CalibrationTerms::for_static(&weigher.law),
            Method::Ekf => CalibrationTerms::for_estimate(Some(
                airsus_truck::models::build_any_model(&args.model, &truck)?.as_ref(),
            )),
        };
        let cal = LinearCalibration::fit_weighed_runs_flagged_by(&runs, &rule, terms, &detector)
            .with_context(|| format!("calibrating on {names}"))?;
        println!(
            "calibration on {names}: load = {:.5} x estimate {:+.1} kg {:+.1} kg x z (wall-friction state) {:+.2} kg/mm x (height - {:.1} mm) ({} standstill samples, residual rms {:.1} kg, 95 % within {:.1} kg; interval σ {:.1} kg beside the estimate's own × {:.3})",
            cal.gain,
            cal.offset_kg,
            cal.hysteresis_kg,
            cal.height_kg_per_mm,
            cal.reference_height_mm,
            cal.samples,
            cal.residual_rms_kg,
            cal.residual_q95_kg,
            cal.standstill_std_kg,
            cal.own_std_scale
        );
        if let (Some(settling), Some(valve)) = (cal.settling_q95_kg, cal.valve_q95_kg) {
            println!(
                "  away from standstill, 95 % within {settling:.1} kg settling (σ {:.1} kg), {valve:.1} kg with the valve open (σ {:.1} kg)",
                cal.settling_std_kg.unwrap_or(f64::NAN),
                cal.valve_std_kg.unwrap_or(f64::NAN)
            );
        }
        if let Some(std) = cal.late_settling_std_kg {
            println!(
                "  settling {:.0} s or more after the valve or a load last moved, σ {std:.1} kg",
                cal.late_settling_after_s
            );
        }
        if let Some(std) = cal.load_settling_std_kg {
            println!(
                "  settling within {:.0} s of a load's arrival, the valve closed, σ {std:.1} kg",
                cal.late_settling_after_s
            );
        }
        if let (Some(q95), Some(std)) = (cal.loading_q95_kg, cal.loading_std_kg) {
            println!("  while a load arrives, 95 % within {q95:.1} kg (σ {std:.1} kg)");
        }
        if let Some((lo, hi)) = cal.height_range_mm {
            println!(
                "  calibrated between sensor heights {lo:.1} and {hi:.1} mm; beyond them the interval widens toward the assumed parameter errors ({} samples of this run)",
                run.measured()?
                    .sensor_height_m
                    .iter()
                    .filter(|&&h| cal.is_beyond_calibrated_heights(h))
                    .count()
            );
        }
        for why in &cal.dropped {
            eprintln!("note: calibration term left out, {why}");
        }
        series = cal.apply_with_quality(
            &series,
            Some(&run.measured()?.sensor_height_m),
            Some(&quality),
            Some(&run.inputs.valve),
        )?;
    }
    let count = |q: WeighQuality| quality.iter().filter(|&&f| f == q).count();
    let method = match args.method {
        Method::Static => format!("static force balance, {:.1} s average", args.window_s),
        Method::Ekf => format!("EKF on model {}", args.model),
    };
    println!(
        "{}: {} samples, {method}, parameters from {}",
        args.run.display(),
        series.len(),
        args.truck.display()
    );
    let n = series.len();
    if n > 0 {
        let (lo, hi) = series
            .wheel_load_kg
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &m| {
                (a.min(m), b.max(m))
            });
        println!(
            "  final wheel load {:.1} kg ± {:.1} kg (1σ); range over the run {:.1} to {:.1} kg",
            series.wheel_load_kg[n - 1],
            series.std_kg[n - 1],
            lo,
            hi
        );
        println!(
            "  samples: {} standstill, {} settling, {} with a load arriving, {} with the valve open",
            count(WeighQuality::Standstill),
            count(WeighQuality::Settling),
            count(WeighQuality::Loading),
            count(WeighQuality::Valve)
        );
        let standstill: Vec<usize> = (0..n)
            .filter(|&k| quality[k] == WeighQuality::Standstill)
            .collect();
        if let Some(&last) = standstill.last() {
            println!(
                "  last standstill reading: {:.1} kg ± {:.1} kg (1σ) at {:.1} s",
                series.wheel_load_kg[last], series.std_kg[last], series.time_s[last]
            );
        }
    }
    let truth = match &args.truth {
        Some(path) => {
            let truth = read_run(path).with_context(|| format!("reading {}", path.display()))?;
            if truth.len() != run.len() {
                anyhow::bail!(
                    "{} has {} samples, the run {}",
                    path.display(),
                    truth.len(),
                    run.len()
                );
            }
            Some(truth)
        }
        None => None,
    };
    if let (Some(path), Some(truth)) = (&args.truth, &truth) {
        let acc = evaluate_series(&run, &truth.inputs.wheel_load_kg, &series, &rule)?;
        println!(
            "  error against the true load ({}; standstill = load steady, valve closed and road still for {:.0} s):",
            path.display(),
            rule.settle_s
        );
        println!(
            "    {:<24} {:>8} {:>10} {:>10} {:>10} {:>9} {:>9} {:>9}",
            "samples", "n", "mean %", "max |%|", "rms kg", "in ±1 %", "mean σ kg", "in 95 %"
        );
        let load_changing = format!("load arriving ({:.0} s)", rule.load_settle_s);
        for (name, s) in [
            ("all", acc.all),
            ("standstill", acc.standstill),
            ("  quiet", acc.quiet_standstill),
            ("  after valve activity", acc.after_valve),
            ("valve at work", acc.valve_activity),
            ("driving", acc.driving),
            (load_changing.as_str(), acc.load_change),
            ("settling", acc.settling),
        ] {
            // A run that never drives (or never changes its load) has no such row.
            if (name == "driving" || name == load_changing) && s.samples == 0 {
                continue;
            }
            println!(
                "    {:<24} {:>8} {:>+10.3} {:>10.3} {:>10.1} {:>8.1}% {:>9.1} {:>8.1}%",
                name,
                s.samples,
                s.mean_error_percent,
                s.max_abs_error_percent,
                s.rms_error_kg,
                100.0 * s.within_1_percent,
                s.mean_std_kg,
                100.0 * s.within_95_interval
            );
        }
        for (level, s) in &acc.by_load_level {
            println!(
                "    standstill at {:>6.0} kg: mean {:+.3} %, max |{:.3}| % ({} samples)",
                level, s.mean_error_percent, s.max_abs_error_percent, s.samples
            );
        }
    }
    if let Some(path) = &args.plot {
        let standstill: Vec<bool> = quality
            .iter()
            .map(|&q| q == WeighQuality::Standstill)
            .collect();
        let title = format!("{}: wheel load, {method}", args.run.display());
        plot_weighing(
            path,
            &WeighingPlot {
                time_s: &series.time_s,
                wheel_load_kg: &series.wheel_load_kg,
                std_kg: &series.std_kg,
                standstill: &standstill,
                truth_kg: truth.as_ref().map(|t| &t.inputs.wheel_load_kg[..]),
                title: &title,
            },
        )
        .with_context(|| format!("plotting {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    if let Some(out) = &args.out {
        write_weigh_csv(out, &series, Some(&quality))
            .with_context(|| format!("writing {}", out.display()))?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

/// The start of each of `runs` calibration runs: as given, one per run, or all unknown when
/// none is given.
fn calibration_starts(
    given: &[StartHysteresis],
    runs: usize,
) -> anyhow::Result<Vec<HysteresisStart>> {
    if given.is_empty() {
        return Ok(vec![HysteresisStart::Unknown; runs]);
    }
    if given.len() != runs {
        anyhow::bail!(
            "--calibration-start gives {} start(s) for {runs} --calibration-run(s): give one per run, in the same order",
            given.len()
        );
    }
    Ok(given.iter().map(|&s| s.into()).collect())
}
