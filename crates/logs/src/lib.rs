//! # airsus-logs: runs from the logs engineers record
//!
//! A run file may be the contract's CSV, an ASAM MDF4 measurement (`.mf4`, plain channel
//! groups or CAN bus logging), a Parquet table, or a plain CAN log (candump format) decoded
//! through a DBC file. [`read_run`] tells them apart by their first bytes (the extension only
//! decides what a file that matches no format was meant to be, for the error), decodes the
//! channels, and hands them to the one mapping path of `airsus-data`
//! ([`airsus_data::run_from_channels`]): column map, unit conversion, time-base check or
//! explicit resampling. Runs are written as CSV or, for a `.parquet` path, as Parquet.
//!
//! Each format's reader is one module and talks to its crate only there, behind
//! [`airsus_data::ChannelSet`]: replacing the MDF4 crate touches `mdf4.rs` alone.

mod can;
mod mdf4;
mod parquet;

use std::io::Read;
use std::path::Path;

use airsus_data::channels::Aligned;
use airsus_data::run::read_run_from;
use airsus_data::{
    ChannelSet, DataError, DataErrorKind, LoadedRun, Location, Outputs, Run, RunSource,
    run_from_channels,
};

pub use can::CanDatabase;
pub use parquet::{ColumnValues, TableColumn, write_run_parquet, write_table_parquet};

/// The formats a run can be read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogFormat {
    Csv,
    Mdf4,
    Parquet,
    /// A text CAN log in candump's format, decoded through a DBC.
    CanLog,
}

impl LogFormat {
    pub fn name(self) -> &'static str {
        match self {
            LogFormat::Csv => "CSV",
            LogFormat::Mdf4 => "MDF4",
            LogFormat::Parquet => "Parquet",
            LogFormat::CanLog => "CAN log",
        }
    }
}

/// MDF4's identification block starts with one of these (`UnFinMF ` while a logger writes).
const MDF_MAGIC: [&[u8; 8]; 2] = [b"MDF     ", b"UnFinMF "];
const PARQUET_MAGIC: &[u8; 4] = b"PAR1";

/// Which format `path` holds, from its first bytes; its extension only decides what a file
/// that matches no magic was meant to be.
pub fn detect_format(path: &Path) -> Result<LogFormat, DataError> {
    let mut head = [0u8; 64];
    let mut file = std::fs::File::open(path).map_err(|e| DataError::io(path, e))?;
    let mut filled = 0;
    while filled < head.len() {
        match file.read(&mut head[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(DataError::io(path, e)),
        }
    }
    let head = &head[..filled];
    if MDF_MAGIC.iter().any(|m| head.starts_with(*m)) {
        return Ok(LogFormat::Mdf4);
    }
    if head.starts_with(PARQUET_MAGIC) {
        return Ok(LogFormat::Parquet);
    }
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let shown = String::from_utf8_lossy(&head[..head.len().min(8)]).into_owned();
    let wrong_magic = |format: &'static str, expected: &str| {
        DataError::in_file(
            path,
            DataErrorKind::Malformed {
                format,
                reason: format!(
                    "wrong magic: the file starts with {shown:?}, where {format} starts with {expected:?} (a renamed or damaged file?)"
                ),
            },
        )
    };
    match extension.as_str() {
        "mf4" | "mdf" => Err(wrong_magic("MDF4", "MDF     ")),
        "parquet" | "parq" | "pq" => Err(wrong_magic("Parquet", "PAR1")),
        "log" | "candump" => Ok(LogFormat::CanLog),
        _ if head.trim_ascii_start().starts_with(b"(") => Ok(LogFormat::CanLog),
        _ => Ok(LogFormat::Csv),
    }
}

/// Reads a run from any supported log, as `source` maps its channels onto the run columns.
/// The notes say what was assumed or done (units, resampling, relative timestamps).
pub fn read_run(path: &Path, outputs: Outputs, source: &RunSource) -> Result<LoadedRun, DataError> {
    let wanted = |name: &str| wanted_channel(source, name);
    match read_channel_set(path, source, &wanted)? {
        None => read_run_from(path, outputs, source),
        Some(set) => run_from_channels(set, path, outputs, source),
    }
}

/// A log's channels that `wanted` names, decoded by the reader of its format; `None` for a
/// CSV file (read by the contract's own reader, which knows lines and columns).
fn read_channel_set(
    path: &Path,
    source: &RunSource,
    wanted: &dyn Fn(&str) -> bool,
) -> Result<Option<ChannelSet>, DataError> {
    let format = detect_format(path)?;
    let database = source.dbc.as_deref().map(CanDatabase::read).transpose()?;
    Ok(Some(match format {
        LogFormat::Csv => {
            if let Some(dbc) = &source.dbc {
                return Err(DataError::in_file(
                    path,
                    DataErrorKind::InvalidValue {
                        key: "dbc".to_owned(),
                        value: dbc.display().to_string(),
                        reason: "a DBC decodes CAN frames, and this CSV file holds none (an MDF4 bus log or a candump log does)".to_owned(),
                    },
                ));
            }
            return Ok(None);
        }
        LogFormat::Mdf4 => mdf4::read_channels(path, wanted, database.as_ref())?,
        LogFormat::Parquet => parquet::read_channels(path, source, wanted)?,
        LogFormat::CanLog => match database.as_ref() {
            Some(database) => can::read_candump(path, database)?,
            None => return Err(needs_dbc(path)),
        },
    }))
}

/// The channels `names` of a log (MDF4, Parquet or CAN log) on one time axis, as `source`
/// resamples and decodes them (its column map only names the time column of a Parquet file):
/// what black-box identification reads. Values are as the file gives them, in its units.
pub fn read_signals(
    path: &Path,
    names: &[&str],
    source: &RunSource,
) -> Result<(Aligned, Vec<String>), DataError> {
    let wanted = |name: &str| names.contains(&name);
    let Some(set) = read_channel_set(path, source, &wanted)? else {
        return Err(DataError::in_file(
            path,
            DataErrorKind::InvalidValue {
                key: "format".to_owned(),
                value: "CSV".to_owned(),
                reason: "read CSV signals with the CSV reader".to_owned(),
            },
        ));
    };
    let mut notes = set.notes.clone();
    let aligned = set.signals(path, names, source.resample)?;
    notes.extend(aligned.note.clone());
    Ok((aligned, notes))
}

fn needs_dbc(path: &Path) -> DataError {
    DataError::new(
        Location::file(path),
        DataErrorKind::MissingKey {
            key: "dbc".to_owned(),
            expected: "a CAN log holds raw frames: name the DBC file that decodes them (`dbc = \"truck.dbc\"` in the study, `--dbc` on the command line)".to_owned(),
        },
    )
}

/// Reads a run whose outputs are required, from any supported log, with the contract's names.
pub fn read_plain_run(path: &Path) -> Result<Run, DataError> {
    read_run(path, Outputs::Required, &RunSource::default()).map(|loaded| loaded.run)
}

/// Writes a run as Parquet when `path` ends in `.parquet`, else as the contract's CSV; either
/// way atomically (write, then rename).
pub fn write_run(path: &Path, run: &Run) -> Result<(), DataError> {
    if is_parquet_path(path) {
        write_run_parquet(path, run)
    } else {
        airsus_data::write_run(path, run)
    }
}

/// Whether an output path asks for Parquet.
pub fn is_parquet_path(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("parquet"))
}

/// Whether channel `name` feeds a run column under `source`'s map (readers decode only these).
fn wanted_channel(source: &RunSource, name: &str) -> bool {
    airsus_data::source::RUN_COLUMNS
        .iter()
        .any(|(column, _)| source.columns.channel_for(column) == name)
}
