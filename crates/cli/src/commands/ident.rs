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
use airsus_ident::linear::{IdData, LabelledData, PemOptions, Request, RequestedOrders, Structure};
use anyhow::{Context, bail};

use super::RunSourceArgs;

/// Model structure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
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

impl From<StructureArg> for Structure {
    fn from(s: StructureArg) -> Self {
        match s {
            StructureArg::Arx => Structure::Arx,
            StructureArg::Armax => Structure::Armax,
            StructureArg::Oe => Structure::Oe,
            StructureArg::Bj => Structure::Bj,
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
    /// moves the pressure with the load; a valve run the pressure alone). Every structure;
    /// repeatable; the same columns and sample time as RUN.
    #[arg(long = "merge", value_name = "RUN")]
    pub merge: Vec<PathBuf>,
    /// Resampling and CAN decoding of a log's channels (`--columns` only names a Parquet
    /// file's time column).
    #[command(flatten)]
    pub source: RunSourceArgs,
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
fn read_data(args: &IdentArgs, path: &Path) -> anyhow::Result<LabelledData> {
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
        return Ok(labelled(path, data, rows));
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
    Ok(labelled(path, data, rows))
}

fn labelled(path: &Path, data: IdData, rows: usize) -> LabelledData {
    LabelledData {
        label: path.display().to_string(),
        data,
        rows,
    }
}

/// Runs `airsus ident`.
pub fn run(args: &IdentArgs) -> anyhow::Result<()> {
    let orders = RequestedOrders {
        na: args.na,
        nb: args.nb.clone(),
        nc: args.nc,
        nd: args.nd,
        nf: args.nf.clone(),
        nk: args.nk.clone(),
    };
    let request = Request {
        structure: args.structure.into(),
        orders: &orders,
        inputs: &args.inputs,
        output: &args.output,
        detrend: args.detrend,
        flag_prefix: "--",
    };
    // What needs no data first: a wrong flag is named before a file is read.
    request.check()?;
    request.check_columns()?;
    let run = read_data(args, &args.run)?;
    let merged = args
        .merge
        .iter()
        .map(|path| read_data(args, path))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let identified = request.estimate(run, merged, &PemOptions::default())?;
    if args.json {
        let mut text = serde_json::to_string_pretty(&identified.report)?;
        text.push('\n');
        return emit(&text);
    }
    emit(&identified.text)
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
