//! Runs from Python: a file path, or named columns in the file's units (a pandas DataFrame or a
//! dict of arrays, flattened by the Python package into `(name, float64 array)` pairs).
//!
//! A frame is checked exactly as a file is: its columns are printed as CSV in Rust's shortest
//! round-trip form (which parses back to the same `f64`, bit for bit) and handed to the data
//! contract's own parser, `airsus_data::run::parse_run`. So a frame and the file it was read
//! from give the same `Run` to the last bit, every check of the contract applies (uniform
//! time, valve codes, signs, finite values), and errors read like a file's, naming
//! ``DataFrame `NAME`:LINE:COLUMN`` where LINE is the row position + 2 (the line that row takes
//! in the CSV `write_run` writes: line 1 is the header).

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::bail;
use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use airsus_data::atomic::write_atomically;
use airsus_data::run::{columns, parse_run, parse_run_from};
use airsus_data::table::{ColumnSpec, NumericTable, parse_table};
use airsus_data::{DataError, Outputs, Run};

use crate::error::OrPy;

/// A run as the Python package passes it: `(path, None, None)` for a file, or
/// `(None, name, [(column, float64 array), ...])` for columns in the file's units.
pub type RunSpec<'py> = (
    Option<PathBuf>,
    Option<String>,
    Option<Vec<(String, PyReadonlyArray1<'py, f64>)>>,
);

/// A run source owned by Rust (so it can cross into code that runs without the GIL).
#[derive(Debug, Clone)]
pub enum RunSource {
    File(PathBuf),
    Frame {
        name: String,
        columns: Vec<(String, Vec<f64>)>,
    },
}

impl RunSource {
    /// Copies the arrays out of Python (slices of contiguous float64 arrays).
    pub fn from_spec(spec: RunSpec<'_>) -> PyResult<Self> {
        let (path, name, frame) = spec;
        if let Some(path) = path {
            return Ok(Self::File(path));
        }
        let columns = frame
            .unwrap_or_default()
            .iter()
            .map(|(column, values)| Ok((column.clone(), values.as_slice()?.to_vec())))
            .collect::<PyResult<Vec<_>>>()?;
        Ok(Self::Frame {
            name: name.unwrap_or_else(|| "run".to_owned()),
            columns,
        })
    }

    /// How errors and messages name the source: the path, or ``DataFrame `NAME` ``.
    pub fn label(&self) -> String {
        match self {
            Self::File(path) => path.display().to_string(),
            Self::Frame { name, .. } => format!("DataFrame `{name}`"),
        }
    }

    /// The path errors name (for a frame, its label).
    pub fn path(&self) -> PathBuf {
        match self {
            Self::File(path) => path.clone(),
            Self::Frame { .. } => PathBuf::from(self.label()),
        }
    }

    /// The CSV bytes: the file's content, or the frame printed as CSV.
    pub fn bytes(&self) -> anyhow::Result<Vec<u8>> {
        match self {
            Self::File(path) => Ok(std::fs::read(path).map_err(|e| DataError::io(path, e))?),
            Self::Frame { columns, .. } => frame_csv(columns),
        }
    }

    /// The run, read as `airsus_data::read_run_with` reads a file. A frame's run is named
    /// after the frame (a file's after its stem, as the command line names it).
    /// A file may be any log airsus reads (CSV, MDF4, Parquet), under the contract's names.
    pub fn load(&self, outputs: Outputs) -> anyhow::Result<Run> {
        self.load_with(outputs, &airsus_data::RunSource::default())
    }

    /// The run, read as `how` says (e.g. with the wheel load optional, for weighing).
    pub fn load_with(&self, outputs: Outputs, how: &airsus_data::RunSource) -> anyhow::Result<Run> {
        match self {
            Self::File(path) => Ok(airsus_logs::read_run(path, outputs, how)?.run),
            Self::Frame { name, columns } => {
                let bytes = frame_csv(columns)?;
                let mut run = parse_run_from(&bytes, &self.path(), outputs, how)?.run;
                run.name = name.clone();
                Ok(run)
            }
        }
    }

    /// Named columns, all required, as `airsus_data::table::read_columns` reads a file.
    pub fn table(&self, names: &[&str]) -> anyhow::Result<NumericTable> {
        let specs: Vec<ColumnSpec> = names.iter().map(|n| ColumnSpec::required(n)).collect();
        Ok(parse_table(&self.bytes()?, &self.path(), &specs)?)
    }
}

/// Columns printed as CSV, every value in Rust's shortest round-trip form (`{}`): parsing the
/// text gives back the same `f64`s. NaN prints as `NaN` and infinities as `inf`, which the
/// contract's parser then rejects by cell, as it would in a file.
pub fn frame_csv(columns: &[(String, Vec<f64>)]) -> anyhow::Result<Vec<u8>> {
    use std::fmt::Write as _;
    let rows = columns.first().map_or(0, |(_, values)| values.len());
    for (name, values) in columns {
        if name.contains([',', '"', '\n', '\r']) {
            bail!(
                "column name `{name}` contains a comma, a quote or a line break; rename the column"
            );
        }
        if values.len() != rows {
            bail!(
                "column `{name}` has {} values where `{}` has {rows}",
                values.len(),
                columns[0].0
            );
        }
    }
    let mut text = String::with_capacity((rows + 1) * (columns.len() * 12 + 1));
    let header: Vec<&str> = columns.iter().map(|(name, _)| name.as_str()).collect();
    text.push_str(&header.join(","));
    text.push('\n');
    for row in 0..rows {
        for (k, (_, values)) in columns.iter().enumerate() {
            if k > 0 {
                text.push(',');
            }
            // Writing into a String cannot fail.
            let _ = write!(text, "{}", values[row]);
        }
        text.push('\n');
    }
    Ok(text.into_bytes())
}

/// The contract's run columns, in the order `write_run` writes them; the outputs only when
/// the run has them.
fn run_specs(with_outputs: bool) -> Vec<ColumnSpec<'static>> {
    let mut specs = vec![
        ColumnSpec::required(columns::TIME),
        ColumnSpec::required(columns::WHEEL_LOAD),
        ColumnSpec::required(columns::VALVE),
        ColumnSpec::required(columns::SUPPLY),
        ColumnSpec::optional(columns::ROAD, 0.0),
    ];
    if with_outputs {
        specs.push(ColumnSpec::required(columns::HEIGHT));
        specs.push(ColumnSpec::required(columns::PRESSURE));
    }
    specs
}

/// A run's validated columns in the file's units, exactly as the file has them.
struct RawRun {
    name: String,
    sample_time_s: f64,
    names: Vec<String>,
    columns: Vec<Vec<f64>>,
}

fn read_raw(source: &RunSource) -> anyhow::Result<RawRun> {
    let bytes = source.bytes()?;
    let path = source.path();
    // Every check of the contract, with the same errors as `airsus simulate --run`.
    let mut run = parse_run(&bytes, &path, Outputs::IfPresent)?;
    if let RunSource::Frame { name, .. } = source {
        run.name = name.clone();
    }
    // The values as written (the SI conversion of `Run` may round in the last place).
    let table = parse_table(&bytes, &path, &run_specs(run.outputs.is_some()))?;
    Ok(RawRun {
        name: run.name,
        sample_time_s: run.sample_time_s,
        names: table.names,
        columns: table.columns,
    })
}

/// A run read from a log (MDF4, Parquet, CAN, or a CSV under other names): the contract's
/// columns in its file units, converted back from SI (the log's own values may differ from
/// these in the last bit), and what reading did.
fn read_log(
    path: &Path,
    source: &airsus_data::RunSource,
) -> anyhow::Result<(RawRun, Vec<String>, &'static str)> {
    let loaded = airsus_logs::read_run(path, Outputs::IfPresent, source)?;
    let (names, columns) = loaded
        .run
        .file_columns()
        .into_iter()
        .map(|(name, _, values)| (name.to_owned(), values))
        .unzip();
    Ok((
        RawRun {
            name: loaded.run.name,
            sample_time_s: loaded.run.sample_time_s,
            names,
            columns,
        },
        loaded.notes,
        loaded.format,
    ))
}

/// `(column, channel, unit)` triples, a resampling and a DBC as the Python package passes them.
fn log_source(
    columns: Vec<(String, String, Option<String>)>,
    resample: Option<String>,
    sample_s: Option<f64>,
    dbc: Option<PathBuf>,
) -> anyhow::Result<airsus_data::RunSource> {
    let mut map = airsus_data::ColumnMap::default();
    for (column, channel, unit) in columns {
        map.insert(&column, airsus_data::ChannelRef { channel, unit })
            .map_err(anyhow::Error::msg)?;
    }
    let method = resample
        .map(|m| m.parse::<airsus_data::ResampleMethod>())
        .transpose()
        .map_err(anyhow::Error::msg)?;
    let resample =
        airsus_data::Resample::from_parts(method, sample_s).map_err(anyhow::Error::msg)?;
    Ok(airsus_data::RunSource {
        columns: map,
        resample,
        dbc,
        load_optional: false,
    })
}

/// Reads a run file (outputs optional) and returns `{"name", "sample_time_s", "columns",
/// "notes", "format"}` with the contract's columns in the file's units: a contract CSV as the
/// file has them, any other log (MDF4, Parquet, CAN) through the column map, resampling and
/// DBC given.
#[pyfunction]
#[pyo3(signature = (path, columns=Vec::new(), resample=None, sample_s=None, dbc=None))]
pub fn read_run(
    py: Python<'_>,
    path: PathBuf,
    columns: Vec<(String, String, Option<String>)>,
    resample: Option<String>,
    sample_s: Option<f64>,
    dbc: Option<PathBuf>,
) -> PyResult<Bound<'_, PyDict>> {
    let (raw, notes, format) = py
        .detach(|| -> anyhow::Result<_> {
            let source = log_source(columns, resample, sample_s, dbc)?;
            if airsus_logs::detect_format(&path)? == airsus_logs::LogFormat::Csv
                && source.is_plain()
            {
                // A contract CSV: its values exactly as written, not through SI and back.
                let raw = read_raw(&RunSource::File(path.clone()))?;
                return Ok((raw, Vec::new(), "CSV"));
            }
            read_log(&path, &source)
        })
        .or_py()?;
    let out = PyDict::new(py);
    out.set_item("notes", notes)?;
    out.set_item("format", format)?;
    out.set_item("name", raw.name)?;
    out.set_item("sample_time_s", raw.sample_time_s)?;
    let columns = PyDict::new(py);
    for (name, values) in raw.names.into_iter().zip(raw.columns) {
        columns.set_item(name, values.into_pyarray(py))?;
    }
    out.set_item("columns", columns)?;
    Ok(out)
}

fn write_raw(source: &RunSource, out: &Path) -> anyhow::Result<()> {
    let raw = read_raw(source)?;
    let n = raw.columns.first().map_or(0, Vec::len);
    // `write_run`'s layout and number format; the values are the caller's, in file units, so
    // nothing goes through SI and back.
    write_atomically(out, |w: &mut dyn Write| {
        writeln!(w, "{}", raw.names.join(","))?;
        for row in 0..n {
            for (k, column) in raw.columns.iter().enumerate() {
                if k > 0 {
                    write!(w, ",")?;
                }
                if k == 2 {
                    // The valve code, as an integer (checked to be 0, 1 or 2 above).
                    write!(w, "{}", column[row] as u8)?;
                } else {
                    write!(w, "{}", column[row])?;
                }
            }
            writeln!(w)?;
        }
        Ok(())
    })?;
    Ok(())
}

/// Checks a run (as `read_run` would) and writes it atomically in the contract's format: CSV,
/// or Parquet when `path` ends in `.parquet`.
#[pyfunction]
pub fn write_run(py: Python<'_>, run: RunSpec<'_>, path: PathBuf) -> PyResult<()> {
    let source = RunSource::from_spec(run)?;
    py.detach(|| {
        if airsus_logs::is_parquet_path(&path) {
            let run = source.load(Outputs::IfPresent)?;
            Ok(airsus_logs::write_run_parquet(&path, &run)?)
        } else {
            write_raw(&source, &path)
        }
    })
    .or_py()
}
