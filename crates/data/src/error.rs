//! One error type for every file of the data contract.
//!
//! Every error names the file and, where the fault sits in a particular place, the line and
//! the column, and says what was expected. Nothing in this crate panics on bad input.

use std::fmt;
use std::path::{Path, PathBuf};

/// Where in a file a fault was found. Lines and columns are 1-based, as editors show them.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Location {
    pub file: PathBuf,
    pub line: Option<u64>,
    /// 1-based column number and, for CSV files, the column's header name.
    pub column: Option<(u64, Option<String>)>,
    /// For logs that have no lines (MDF4, Parquet, CAN): the channel and its 1-based sample.
    pub sample: Option<(String, u64)>,
}

impl Location {
    pub fn file(file: &Path) -> Self {
        Self {
            file: file.to_path_buf(),
            line: None,
            column: None,
            sample: None,
        }
    }

    /// A channel of a log file, optionally at its 1-based sample `number`.
    pub fn channel(mut self, name: &str, number: Option<u64>) -> Self {
        self.sample = Some((name.to_owned(), number.unwrap_or(0)));
        self
    }

    pub fn line(mut self, line: u64) -> Self {
        self.line = Some(line);
        self
    }

    pub fn column(mut self, number: u64, name: Option<&str>) -> Self {
        self.column = Some((number, name.map(str::to_owned)));
        self
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
            if let Some((number, _)) = &self.column {
                write!(f, ":{number}")?;
            }
        }
        if let Some((_, Some(name))) = &self.column {
            write!(f, " (column `{name}`)")?;
        }
        match &self.sample {
            Some((channel, 0)) => write!(f, " (channel `{channel}`)")?,
            Some((channel, number)) => write!(f, " (channel `{channel}`, sample {number})")?,
            None => {}
        }
        Ok(())
    }
}

/// What was wrong.
#[derive(Debug, thiserror::Error)]
pub enum DataErrorKind {
    #[error("cannot read or write the file: {0}")]
    Io(std::io::Error),
    #[error("malformed CSV: {0}")]
    Csv(String),
    #[error("the file is empty: expected a header row and at least {needed} data row(s)")]
    Empty { needed: usize },
    #[error("expected at least {needed} data rows, found {found}")]
    TooFewRows { needed: usize, found: usize },
    #[error("required column `{name}` is missing{}; the header has: {}", suggestion_text(suggestion), available.join(", "))]
    MissingColumn {
        name: String,
        suggestion: Option<String>,
        available: Vec<String>,
    },
    #[error("column `{name}` appears twice in the header")]
    DuplicateColumn { name: String },
    #[error("expected a number, found `{found}`")]
    NotANumber { found: String },
    #[error("expected a finite number, found `{found}`")]
    NotFinite { found: String },
    #[error("time must increase strictly: {current} s follows {previous} s")]
    TimeNotIncreasing { previous: f64, current: f64 },
    #[error(
        "non-uniform sampling: this interval is {found_s} s where the run's sample time is {expected_s} s (off by {:.3} %, tolerance {:.1} %); airsus never resamples silently: resample it (study `resample` with `sample_s`, CLI --resample with --sample-s) or split the file at the gap",
        100.0 * (found_s - expected_s).abs() / expected_s,
        100.0 * tolerance
    )]
    NonUniformSampling {
        expected_s: f64,
        found_s: f64,
        tolerance: f64,
    },
    #[error("expected valve state 0 (closed), 1 (fill) or 2 (exhaust), found `{found}`")]
    InvalidValve { found: String },
    #[error("{quantity} must not be negative, found {value}")]
    Negative { quantity: String, value: f64 },
    #[error("{quantity} {value} is below absolute vacuum ({min} {unit} gauge)")]
    BelowVacuum {
        quantity: String,
        value: f64,
        min: f64,
        unit: &'static str,
    },
    #[error("TOML: {0}")]
    Toml(String),
    #[error("unknown key `{key}`{}; valid keys here: {}", suggestion_text(suggestion), valid.join(", "))]
    UnknownKey {
        key: String,
        suggestion: Option<String>,
        valid: Vec<String>,
    },
    #[error("missing key `{key}`: {expected}")]
    MissingKey { key: String, expected: String },
    #[error(
        "refusing to write here: this output is the input file {} (same file{}); choose another output path",
        input.display(),
        if *same_path { "" } else { " through another path" }
    )]
    OutputIsInput { input: PathBuf, same_path: bool },
    #[error("`{key}` = {value}: {reason}")]
    InvalidValue {
        key: String,
        value: String,
        reason: String,
    },
    #[error("not a readable {format} file: {reason}")]
    Malformed {
        format: &'static str,
        reason: String,
    },
    #[error("{0}")]
    MissingChannel(Box<MissingChannel>),
    #[error("unit `{unit}` cannot be read as column `{column}` (expected one of: {})", expected.join(", "))]
    UnknownUnit {
        column: String,
        unit: String,
        expected: Vec<String>,
    },
    #[error(
        "the file gives unit `{in_file}` but the column map says `{mapped}`; remove the unit from the map or correct it"
    )]
    UnitConflict { in_file: String, mapped: String },
    #[error(
        "channels on different time bases: {first} but {second}; airsus never resamples silently: set `resample = \"zoh\"` or `\"linear\"` with `sample_s` (CLI: --resample, --sample-s)"
    )]
    TimeBases {
        first: Box<TimeBaseSummary>,
        second: Box<TimeBaseSummary>,
    },
}

/// A run column whose channel a log does not have (boxed in [`DataErrorKind`]: it is large).
#[derive(Debug, thiserror::Error)]
#[error(
    "channel `{channel}` for column `{column}` is not in the file{}; map another channel with `[run.columns]` or `--columns {column}=NAME`; the file has: {}{}",
    suggestion_text(suggestion),
    available.join(", "),
    hint.as_deref().map(|h| format!(" ({h})")).unwrap_or_default()
)]
pub struct MissingChannel {
    pub column: String,
    pub channel: String,
    pub suggestion: Option<String>,
    pub available: Vec<String>,
    /// What the reader knows that may explain it (e.g. CAN frames but no DBC).
    pub hint: Option<String>,
}

/// One time base as an error describes it.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeBaseSummary {
    pub name: String,
    pub samples: usize,
    pub start_s: f64,
    /// Mean step, s.
    pub step_s: f64,
}

impl fmt::Display for TimeBaseSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "`{}` has {} samples from {} s every {} s",
            self.name, self.samples, self.start_s, self.step_s
        )
    }
}

fn suggestion_text(suggestion: &Option<String>) -> String {
    match suggestion {
        Some(s) => format!(" (did you mean `{s}`?)"),
        None => String::new(),
    }
}

/// A fault in a data-contract file: where, and what.
#[derive(Debug, thiserror::Error)]
// The kind is displayed, not chained as a source: `{:#}` would print it twice.
#[error("{location}: {kind}")]
pub struct DataError {
    /// Boxed to keep `Result<_, DataError>` small on the happy path.
    pub location: Box<Location>,
    pub kind: DataErrorKind,
}

impl DataError {
    pub fn new(location: Location, kind: DataErrorKind) -> Self {
        Self {
            location: Box::new(location),
            kind,
        }
    }

    pub fn in_file(file: &Path, kind: DataErrorKind) -> Self {
        Self::new(Location::file(file), kind)
    }

    pub fn io(file: &Path, err: std::io::Error) -> Self {
        Self::in_file(file, DataErrorKind::Io(err))
    }
}

/// The candidate closest to `name`, if it is close enough to be a plausible misspelling.
pub fn nearest_name<'a>(
    name: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<String> {
    let lower = name.to_ascii_lowercase();
    candidates
        .into_iter()
        .map(|c| (strsim::jaro_winkler(&lower, &c.to_ascii_lowercase()), c))
        .filter(|(score, _)| *score >= 0.8)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, c)| c.to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn location_renders_file_line_column_and_name() {
        let loc = Location::file(Path::new("ds1.csv"))
            .line(12)
            .column(3, Some("valve"));
        assert_eq!(loc.to_string(), "ds1.csv:12:3 (column `valve`)");
    }

    #[test]
    fn nearest_name_finds_misspellings_only() {
        let names = ["height_mm", "pressure_kpa", "time_s"];
        assert_eq!(
            nearest_name("heigth_mm", names).as_deref(),
            Some("height_mm")
        );
        assert_eq!(
            nearest_name("Pressure_kPa", names).as_deref(),
            Some("pressure_kpa")
        );
        assert_eq!(nearest_name("valve", names), None);
    }
}
