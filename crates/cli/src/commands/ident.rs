//! `airsus ident`: estimate a linear black-box model (ARX, ARMAX, OE, BJ) from one run file.
//!
//! Columns are read by name; the sample time comes from the `time_s` column when the file has
//! one (checked for uniform sampling), otherwise from `--ts-s`. Orders given once apply to
//! every input; a comma-separated list gives one value per input, in `--inputs` order.
//! Orders the chosen structure does not have (e.g. `--na` for OE) are rejected rather than
//! ignored. The estimate is printed like MATLAB's System Identification Toolbox prints an
//! `idpoly`, or as JSON with `--json`.

use std::path::{Path, PathBuf};

use airsus_data::Location;
use airsus_data::table::read_columns;
use airsus_data::time_axis::{check_time_axis, check_uniform};
use airsus_ident::linear::{
    ArmaxOrders, ArxOrders, BjOrders, Estimate, IdData, IdentError, OeOrders, Offsets, PemOptions,
    armax, arx, bj, fit_percent, oe_with,
};
use anyhow::{Context, anyhow, bail};
use serde::Serialize;

use super::RunSourceArgs;

/// Model structure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum StructureArg {
    /// A y = B u + e (least squares; needs --na --nb --nk).
    Arx,
    /// A y = B u + C e (needs --na --nb --nc --nk).
    Armax,
    /// y = B/F u + e (needs --nb --nf --nk).
    Oe,
    /// y = B/F u + C/D e (needs --nb --nc --nd --nf --nk).
    Bj,
}

impl StructureArg {
    fn label(self) -> &'static str {
        match self {
            StructureArg::Arx => "ARX",
            StructureArg::Armax => "ARMAX",
            StructureArg::Oe => "OE",
            StructureArg::Bj => "BJ",
        }
    }
}

/// Estimate a linear black-box model of one output from one or more inputs of a run file.
#[derive(Debug, Clone, clap::Args)]
pub struct IdentArgs {
    /// Model structure.
    #[arg(long, value_enum)]
    pub structure: StructureArg,
    /// Input column names, comma-separated (e.g. wheel_load_kg,pressure_kpa).
    #[arg(long, value_delimiter = ',', required = true)]
    pub inputs: Vec<String>,
    /// Output column name (e.g. height_mm).
    #[arg(long)]
    pub output: String,
    /// Order of A (ARX, ARMAX).
    #[arg(long)]
    pub na: Option<usize>,
    /// Number of B coefficients: one value for every input, or one per input (comma-separated).
    #[arg(long, value_delimiter = ',')]
    pub nb: Vec<usize>,
    /// Order of C (ARMAX, BJ).
    #[arg(long)]
    pub nc: Option<usize>,
    /// Order of D (BJ).
    #[arg(long)]
    pub nd: Option<usize>,
    /// Order of F (OE, BJ): one value or one per input.
    #[arg(long, value_delimiter = ',')]
    pub nf: Vec<usize>,
    /// Input delay in samples: one value or one per input.
    #[arg(long, value_delimiter = ',')]
    pub nk: Vec<usize>,
    /// Sample time in seconds, used only when the file has no `time_s` column.
    #[arg(long)]
    pub ts_s: Option<f64>,
    /// Remove the means of output and inputs before estimating (MATLAB `detrend(z, 0)`);
    /// linear models describe deviations from an operating point.
    #[arg(long)]
    pub detrend: bool,
    /// Print the result as JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Run file: CSV with a header row, or an MDF4, Parquet or CAN log (its channels by name).
    pub run: PathBuf,
    /// Another run of the same system, estimated together with RUN (≙ MATLAB `merge`): one
    /// model, each run's filters started at its own first sample, where runs laid end to end
    /// would invent a step at each joint. For what no single run determines (a loading run
    /// moves the pressure with the load; a valve run the pressure alone). OE only;
    /// repeatable; the same columns and sample time as RUN.
    #[arg(long = "merge", value_name = "RUN")]
    pub merge: Vec<PathBuf>,
    /// Resampling and CAN decoding of a log's channels (`--columns` only names a Parquet
    /// file's time column).
    #[command(flatten)]
    pub source: RunSourceArgs,
}

/// What `--json` prints.
#[derive(Debug, Serialize)]
struct IdentReport<'a> {
    run: &'a Path,
    structure: StructureArg,
    output: &'a str,
    inputs: &'a [String],
    samples: usize,
    ts_s: f64,
    /// Means removed before estimation (`--detrend`), else null.
    offsets: Option<Offsets>,
    /// The runs estimated together with `run` (`--merge`), each with its samples and, with
    /// `--detrend`, its own means.
    merged: Vec<MergedRun<'a>>,
    estimate: &'a Estimate,
}

/// One `--merge` run in the JSON report.
#[derive(Debug, Serialize)]
struct MergedRun<'a> {
    run: &'a Path,
    samples: usize,
    offsets: Option<Offsets>,
}

/// Orders expanded to one value per input.
fn per_input(flag: &str, values: &[usize], n_inputs: usize) -> anyhow::Result<Vec<usize>> {
    match values.len() {
        0 => bail!("--{flag} is required for this structure"),
        1 => Ok(vec![values[0]; n_inputs]),
        n if n == n_inputs => Ok(values.to_vec()),
        n => bail!(
            "--{flag} has {n} values but there are {n_inputs} inputs; give one value for all inputs or one per input"
        ),
    }
}

fn required(flag: &str, value: Option<usize>) -> anyhow::Result<usize> {
    value.with_context(|| format!("--{flag} is required for this structure"))
}

/// Rejects orders the structure does not have, so a typo is not silently ignored.
fn reject_unused(args: &IdentArgs) -> anyhow::Result<()> {
    let s = args.structure;
    let uses = |flag: &str| match flag {
        "na" => matches!(s, StructureArg::Arx | StructureArg::Armax),
        "nc" => matches!(s, StructureArg::Armax | StructureArg::Bj),
        "nd" => matches!(s, StructureArg::Bj),
        "nf" => matches!(s, StructureArg::Oe | StructureArg::Bj),
        _ => true,
    };
    let given = [
        ("na", args.na.is_some()),
        ("nc", args.nc.is_some()),
        ("nd", args.nd.is_some()),
        ("nf", !args.nf.is_empty()),
    ];
    for (flag, present) in given {
        if present && !uses(flag) {
            bail!(
                "--{flag} does not apply to {} models (ARX: na nb nk; ARMAX: na nb nc nk; OE: nb nf nk; BJ: nb nc nd nf nk)",
                s.label()
            );
        }
    }
    Ok(())
}

/// `--ts-s`, when given, must agree with the file's own sample time.
fn check_ts_flag(flag: Option<f64>, ts_s: f64, path: &Path) -> anyhow::Result<()> {
    if let Some(flag) = flag
        && (flag - ts_s).abs() > 1e-9 * ts_s
    {
        bail!(
            "--ts-s {flag} contradicts the sample time {ts_s} s of the time in {}",
            path.display()
        );
    }
    Ok(())
}

/// Reads the requested columns of `path` and the sample time.
fn read_data(args: &IdentArgs, path: &Path) -> anyhow::Result<(IdData, usize)> {
    if args.inputs.iter().any(|n| n.trim().is_empty()) {
        bail!("--inputs contains an empty column name");
    }
    for (i, name) in args.inputs.iter().enumerate() {
        if args.inputs[..i].contains(name) {
            bail!("input column `{name}` is listed twice");
        }
        if *name == args.output {
            bail!("column `{name}` is both an input and the output");
        }
    }
    let mut names: Vec<&str> = args.inputs.iter().map(String::as_str).collect();
    names.push(&args.output);
    let source = args.source.source()?;
    if airsus_logs::detect_format(path)? != airsus_logs::LogFormat::Csv {
        let (aligned, notes) = airsus_logs::read_signals(path, &names, &source)?;
        for note in &notes {
            eprintln!("note: {}: {note}", path.display());
        }
        let time_name = aligned.time_name.clone();
        let ts_s = check_uniform(
            &aligned.time_s,
            path,
            |row| Location::file(path).channel(&time_name, Some(row as u64 + 1)),
            2,
        )?;
        check_ts_flag(args.ts_s, ts_s, path)?;
        let mut columns = aligned.values;
        let y = columns.pop().context("output channel missing")?;
        let rows = y.len();
        let data = IdData::new(y, columns, ts_s)
            .with_context(|| format!("invalid identification data in {}", path.display()))?;
        return Ok((data, rows));
    }
    if !source.is_plain() {
        bail!(
            "--columns, --resample and --dbc apply to logs (MDF4, Parquet, CAN); a CSV file's columns are named directly by --inputs and --output"
        );
    }
    let mut table = read_columns(path, &names)?;
    let ts_s = if table.header.iter().any(|h| h == "time_s") {
        names.push("time_s");
        table = read_columns(path, &names)?;
        let ts = check_time_axis(&table, names.len() - 1, path, 2)?;
        check_ts_flag(args.ts_s, ts, path)?;
        ts
    } else {
        args.ts_s.with_context(|| {
            format!(
                "{} has no time_s column: pass the sample time with --ts-s",
                path.display()
            )
        })?
    };
    let n_inputs = args.inputs.len();
    let mut columns = table.columns.into_iter();
    let u: Vec<Vec<f64>> = columns.by_ref().take(n_inputs).collect();
    let y = columns
        .next()
        .context("output column missing from the table")?;
    let rows = y.len();
    let data = IdData::new(y, u, ts_s)
        .with_context(|| format!("invalid identification data in {}", path.display()))?;
    Ok((data, rows))
}

/// Runs `airsus ident`.
pub fn run(args: &IdentArgs) -> anyhow::Result<()> {
    reject_unused(args)?;
    if !args.merge.is_empty() && args.structure != StructureArg::Oe {
        bail!(
            "--merge estimates OE models only so far; {} models take one run",
            args.structure.label()
        );
    }
    // Each run detrended by its own means, as MATLAB's `detrend` does a merged data set.
    let prepare = |raw: IdData| {
        if args.detrend {
            let (d, o) = raw.detrend();
            (d, Some(o))
        } else {
            (raw, None)
        }
    };
    let (raw, rows) = read_data(args, &args.run)?;
    let m = raw.n_inputs();
    let (data, offsets) = prepare(raw);
    let mut merged_data = Vec::with_capacity(args.merge.len());
    let mut merged = Vec::with_capacity(args.merge.len());
    for path in &args.merge {
        let (raw, samples) = read_data(args, path)?;
        let (d, offsets) = prepare(raw);
        merged_data.push(d);
        merged.push(MergedRun {
            run: path,
            samples,
            offsets,
        });
    }
    let nb = per_input("nb", &args.nb, m)?;
    let nk = per_input("nk", &args.nk, m)?;
    let options = PemOptions::default();
    let context = || {
        format!(
            "{} estimation on {}",
            args.structure.label(),
            args.run.display()
        )
    };
    let estimate = match args.structure {
        StructureArg::Arx => arx(
            &data,
            &ArxOrders {
                na: required("na", args.na)?,
                nb,
                nk,
            },
        ),
        StructureArg::Armax => armax(
            &data,
            &ArmaxOrders {
                na: required("na", args.na)?,
                nb,
                nc: required("nc", args.nc)?,
                nk,
            },
            &options,
        ),
        StructureArg::Oe => {
            let orders = OeOrders {
                nb,
                nf: per_input("nf", &args.nf, m)?,
                nk,
            };
            oe_with(&data, merged_data, &orders, &options)
        }
        StructureArg::Bj => bj(
            &data,
            &BjOrders {
                nb,
                nc: required("nc", args.nc)?,
                nd: required("nd", args.nd)?,
                nf: per_input("nf", &args.nf, m)?,
                nk,
            },
            &options,
        ),
    }
    .map_err(|e| match e {
        // Name the column rather than its position.
        IdentError::ConstantInput { input, value } => anyhow!(
            "input column `{}` is constant ({value}) in {}{}: a constant input carries no information about the dynamics",
            args.inputs.get(input).map_or("?", String::as_str),
            args.run.display(),
            if args.merge.is_empty() {
                ""
            } else {
                " and in every merged run"
            }
        ),
        other => anyhow::Error::new(other).context(context()),
    })?;

    use std::fmt::Write as _;
    if args.json {
        let report = IdentReport {
            run: &args.run,
            structure: args.structure,
            output: &args.output,
            inputs: &args.inputs,
            samples: rows,
            ts_s: data.ts_s(),
            offsets,
            merged,
            estimate: &estimate,
        };
        let mut text = serde_json::to_string_pretty(&report)?;
        text.push('\n');
        return emit(&text);
    }
    let mut out = String::new();
    writeln!(
        out,
        "{} ← {} ({}, {rows} samples)",
        args.output,
        args.inputs.join(", "),
        args.run.display()
    )?;
    for run in &merged {
        writeln!(
            out,
            "merged with {} ({} samples): one model, each run's filters from its own first sample",
            run.run.display(),
            run.samples
        )?;
    }
    if m > 1 {
        let map: Vec<String> = args
            .inputs
            .iter()
            .enumerate()
            .map(|(i, n)| format!("u{} = {n}", i + 1))
            .collect();
        writeln!(out, "Inputs: {}", map.join(", "))?;
    }
    if let Some(o) = &offsets {
        let means: Vec<String> = args
            .inputs
            .iter()
            .zip(&o.u)
            .map(|(n, v)| format!("{n} {v}"))
            .collect();
        writeln!(
            out,
            "Detrended: removed means {} {}, {}",
            args.output,
            o.y,
            means.join(", ")
        )?;
    }
    writeln!(out)?;
    write!(out, "{estimate}")?;
    if estimate.simulation_fit_percent.is_none() {
        // ARX reports the one-step prediction fit; show the simulation fit as well, as it is
        // what the models of the thesis are judged by.
        let sim = estimate.model.simulate(data.u())?;
        match fit_percent(data.y(), &sim) {
            Some(f) => writeln!(out, "Simulation fit to estimation data: {f:.2}%")?,
            None => writeln!(
                out,
                "Simulation fit to estimation data: diverges (unstable A)"
            )?,
        }
    }
    emit(&out)
}

/// Writes to stdout; a reader that closed the pipe early (`airsus ident … | head`) is not an
/// error.
fn emit(text: &str) -> anyhow::Result<()> {
    use std::io::Write as _;
    match std::io::stdout().lock().write_all(text.as_bytes()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e.into()),
        _ => Ok(()),
    }
}
