//! Parquet tables, through the `parquet` crate's low-level reader and writer.
//!
//! A Parquet run is one row per sample: a time column (`time_s`, or a timestamp column,
//! counted from its first row) and one numeric column per signal. Parquet has no per-column
//! unit; airsus reads and writes them as a JSON object under the file's key-value metadata key
//! `units` (`{"pressure_kpa": "kPa"}`), which pyarrow writes with
//! `table.replace_schema_metadata({b"units": json.dumps(units)})`.

use std::collections::HashMap;
use std::fs::File;
use std::path::Path;
use std::sync::Arc;

use airsus_data::error::MissingChannel;
use airsus_data::run::columns;
use airsus_data::{
    ChannelSet, DataError, DataErrorKind, Location, LogChannel, Run, RunSource, TimeBase,
};
use parquet::basic::{Compression, ConvertedType, LogicalType, TimeUnit, Type as PhysicalType};
use parquet::column::reader::{ColumnReader, ColumnReaderImpl};
use parquet::data_type::{DataType, DoubleType, Int32Type};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::parser::parse_message_type;

const FORMAT: &str = "Parquet";
/// The key-value metadata key that holds the columns' units as a JSON object.
pub const UNITS_KEY: &str = "units";
/// Rows per row group when writing: big enough for fast scans, small enough to stream.
const ROW_GROUP_ROWS: usize = 1 << 20;
/// Rows decoded per call: bounds what one call can allocate, whatever a page claims.
const BATCH_ROWS: usize = 1 << 16;
/// The most rows one file may declare: 100 M samples is 11.6 days at 100 Hz (0.8 GB per
/// column in memory). A damaged footer usually claims far more; a real log that long is
/// better split by day.
const MAX_ROWS: u64 = 100_000_000;

fn malformed(path: &Path, reason: impl std::fmt::Display) -> DataError {
    DataError::in_file(
        path,
        DataErrorKind::Malformed {
            format: FORMAT,
            reason: reason.to_string(),
        },
    )
}

fn in_column(path: &Path, column: &str, sample: Option<u64>, reason: String) -> DataError {
    DataError::new(
        Location::file(path).channel(column, sample),
        DataErrorKind::Malformed {
            format: FORMAT,
            reason,
        },
    )
}

/// How the time column's values become seconds.
enum TimeKind {
    /// Plain numbers, in the unit the metadata or the map gives (seconds by default).
    Numeric,
    /// Integer timestamps in units of `seconds_per_tick`, counted from the first row; `utc`
    /// says whether they are UTC or local time.
    Timestamp { seconds_per_tick: f64, utc: bool },
}

/// Decodes the time column and the columns `wanted` names.
pub(crate) fn read_channels(
    path: &Path,
    source: &RunSource,
    wanted: &dyn Fn(&str) -> bool,
) -> Result<ChannelSet, DataError> {
    let file = File::open(path).map_err(|e| DataError::io(path, e))?;
    let reader = SerializedFileReader::new(file).map_err(|e| malformed(path, e))?;
    let metadata = reader.metadata().file_metadata();
    if u64::try_from(metadata.num_rows()).map_or(true, |rows| rows > MAX_ROWS) {
        return Err(malformed(
            path,
            format!(
                "it declares {} rows; airsus reads at most {MAX_ROWS} rows (11.6 days at 100 Hz) from one file: split it, e.g. by day",
                metadata.num_rows()
            ),
        ));
    }
    let units = file_units(path, metadata.key_value_metadata())?;
    let schema = metadata.schema_descr();
    let time_name = source.columns.channel_for(columns::TIME);

    let mut set = ChannelSet {
        format: FORMAT,
        ..ChannelSet::default()
    };
    let mut time: Option<(usize, TimeKind)> = None;
    let mut chosen = Vec::new();
    for (index, column) in schema.columns().iter().enumerate() {
        let name = column.path().string();
        if name == time_name {
            if column.physical_type() == PhysicalType::INT96 {
                return Err(in_column(
                    path,
                    &name,
                    None,
                    "a legacy INT96 timestamp: write the time as an INT64 timestamp (pyarrow does by default; Spark with spark.sql.parquet.outputTimestampType=TIMESTAMP_MICROS)".to_owned(),
                ));
            }
            let kind = match column.logical_type_ref() {
                Some(LogicalType::Timestamp(ts)) => TimeKind::Timestamp {
                    seconds_per_tick: match ts.unit {
                        TimeUnit::MILLIS => 1e-3,
                        TimeUnit::MICROS => 1e-6,
                        TimeUnit::NANOS => 1e-9,
                    },
                    utc: ts.is_adjusted_to_u_t_c,
                },
                _ => match column.converted_type() {
                    ConvertedType::TIMESTAMP_MILLIS => TimeKind::Timestamp {
                        seconds_per_tick: 1e-3,
                        utc: true,
                    },
                    ConvertedType::TIMESTAMP_MICROS => TimeKind::Timestamp {
                        seconds_per_tick: 1e-6,
                        utc: true,
                    },
                    _ => TimeKind::Numeric,
                },
            };
            time = Some((index, kind));
        } else if wanted(&name) {
            chosen.push((index, name));
        } else {
            set.unread.push(name);
        }
    }
    let Some((time_index, time_kind)) = time else {
        let available: Vec<String> = schema.columns().iter().map(|c| c.path().string()).collect();
        return Err(DataError::in_file(
            path,
            DataErrorKind::MissingChannel(Box::new(MissingChannel {
                column: columns::TIME.to_owned(),
                channel: time_name.to_owned(),
                suggestion: airsus_data::error::nearest_name(
                    time_name,
                    available.iter().map(String::as_str),
                ),
                available,
                hint: None,
            })),
        ));
    };

    let time_s = match time_kind {
        TimeKind::Numeric => read_numeric(&reader, path, time_index, time_name)?,
        TimeKind::Timestamp {
            seconds_per_tick,
            utc,
        } => {
            let ticks = read_timestamps(&reader, path, time_index, time_name)?;
            let first = ticks.first().copied().unwrap_or_default();
            set.notes.push(format!(
                "time counted from the first timestamp of `{time_name}` ({} s since 1970, {})",
                first as f64 * seconds_per_tick,
                if utc { "UTC" } else { "local time" }
            ));
            // Differences in integers first: epoch nanoseconds do not fit an f64 exactly.
            ticks
                .iter()
                .enumerate()
                .map(|(row, &t)| {
                    t.checked_sub(first)
                        .map(|ticks| ticks as f64 * seconds_per_tick)
                        .ok_or_else(|| {
                            in_column(
                                path,
                                time_name,
                                Some(row as u64 + 1),
                                format!("timestamp {t} is out of range"),
                            )
                        })
                })
                .collect::<Result<Vec<f64>, DataError>>()?
        }
    };
    set.bases.push(TimeBase {
        name: time_name.to_owned(),
        time_s,
        unit: match time_kind {
            TimeKind::Numeric => units.get(time_name).cloned(),
            // Already seconds: a unit in the map must not scale it again.
            TimeKind::Timestamp { .. } => Some("s".to_owned()),
        },
    });
    for (index, name) in chosen {
        let values = read_numeric(&reader, path, index, &name)?;
        set.channels.push(LogChannel {
            unit: units.get(&name).cloned(),
            name,
            base: 0,
            values,
        });
    }
    Ok(set)
}

/// The `units` key-value entry as a column → unit map (empty when absent).
fn file_units(
    path: &Path,
    metadata: Option<&Vec<KeyValue>>,
) -> Result<HashMap<String, String>, DataError> {
    let Some(text) = metadata
        .into_iter()
        .flatten()
        .find(|kv| kv.key == UNITS_KEY)
        .and_then(|kv| kv.value.as_deref())
    else {
        return Ok(HashMap::new());
    };
    serde_json::from_str::<HashMap<String, String>>(text).map_err(|e| {
        malformed(
            path,
            format!("key-value metadata `{UNITS_KEY}` is not a JSON object of unit strings: {e}"),
        )
    })
}

/// Every row of a typed column, with its definition levels when the column is nullable.
fn read_typed<T: DataType>(
    reader: &SerializedFileReader<File>,
    path: &Path,
    index: usize,
    name: &str,
    read: impl Fn(ColumnReader) -> Option<ColumnReaderImpl<T>>,
) -> Result<Vec<T::T>, DataError> {
    let max_def = reader
        .metadata()
        .file_metadata()
        .schema_descr()
        .column(index)
        .max_def_level();
    let mut out = Vec::new();
    let mut row = 0u64;
    for group in 0..reader.num_row_groups() {
        let group = reader
            .get_row_group(group)
            .map_err(|e| malformed(path, e))?;
        let declared = group.metadata().num_rows();
        let rows = usize::try_from(declared)
            .ok()
            .filter(|&r| r as u64 <= MAX_ROWS)
            .ok_or_else(|| malformed(path, format!("a row group declares {declared} rows")))?;
        let column = group
            .get_column_reader(index)
            .map_err(|e| in_column(path, name, None, e.to_string()))?;
        let Some(mut column) = read(column) else {
            return Err(in_column(
                path,
                name,
                None,
                "unexpected column type".to_owned(),
            ));
        };
        // Capacity follows the data actually decoded, in batches, never a declared count
        // alone: a damaged footer must not make us reserve gigabytes.
        let mut values = Vec::with_capacity(rows.min(BATCH_ROWS));
        let mut levels = Vec::with_capacity(if max_def > 0 { rows.min(BATCH_ROWS) } else { 0 });
        let mut read_rows = 0;
        while read_rows < rows {
            let (records, _, _) = column
                .read_records(
                    (rows - read_rows).min(BATCH_ROWS),
                    (max_def > 0).then_some(&mut levels),
                    None,
                    &mut values,
                )
                .map_err(|e| in_column(path, name, None, e.to_string()))?;
            if records == 0 {
                break;
            }
            read_rows += records;
        }
        if read_rows != rows || (max_def == 0 && values.len() != rows) {
            return Err(in_column(
                path,
                name,
                None,
                format!("a row group declares {rows} rows but holds {read_rows}"),
            ));
        }
        if let Some(null) = levels.iter().position(|&d| d < max_def) {
            return Err(in_column(
                path,
                name,
                Some(row + null as u64 + 1),
                "missing value (null): every sample of a run needs a value".to_owned(),
            ));
        }
        row += values.len() as u64;
        out.extend(values);
    }
    Ok(out)
}

/// A numeric column as `f64`: DOUBLE, FLOAT, INT32, INT64 and BOOLEAN.
fn read_numeric(
    reader: &SerializedFileReader<File>,
    path: &Path,
    index: usize,
    name: &str,
) -> Result<Vec<f64>, DataError> {
    let physical = reader
        .metadata()
        .file_metadata()
        .schema_descr()
        .column(index)
        .physical_type();
    match physical {
        PhysicalType::DOUBLE => read_typed(reader, path, index, name, |c| match c {
            ColumnReader::DoubleColumnReader(r) => Some(r),
            _ => None,
        }),
        PhysicalType::FLOAT => read_typed(reader, path, index, name, |c| match c {
            ColumnReader::FloatColumnReader(r) => Some(r),
            _ => None,
        })
        .map(|v| v.into_iter().map(f64::from).collect()),
        PhysicalType::INT32 => read_typed(reader, path, index, name, |c| match c {
            ColumnReader::Int32ColumnReader(r) => Some(r),
            _ => None,
        })
        .map(|v| v.into_iter().map(f64::from).collect()),
        PhysicalType::INT64 => read_typed(reader, path, index, name, |c| match c {
            ColumnReader::Int64ColumnReader(r) => Some(r),
            _ => None,
        })
        .map(|v| v.into_iter().map(|x| x as f64).collect()),
        PhysicalType::BOOLEAN => read_typed(reader, path, index, name, |c| match c {
            ColumnReader::BoolColumnReader(r) => Some(r),
            _ => None,
        })
        .map(|v| v.into_iter().map(|b| f64::from(u8::from(b))).collect()),
        other => Err(in_column(
            path,
            name,
            None,
            format!(
                "the column holds {} values, where a run needs numbers",
                match other {
                    PhysicalType::BYTE_ARRAY | PhysicalType::FIXED_LEN_BYTE_ARRAY =>
                        "string or binary".to_owned(),
                    other => other.to_string(),
                }
            ),
        )),
    }
}

/// An INT64 timestamp column (an INT96 legacy timestamp was refused by name above).
fn read_timestamps(
    reader: &SerializedFileReader<File>,
    path: &Path,
    index: usize,
    name: &str,
) -> Result<Vec<i64>, DataError> {
    read_typed(reader, path, index, name, |c| match c {
        ColumnReader::Int64ColumnReader(r) => Some(r),
        _ => None,
    })
}

/// The values of one column of a [`write_table_parquet`] table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ColumnValues<'a> {
    /// DOUBLE, every row present.
    Double(&'a [f64]),
    /// DOUBLE, NaN written as null (a value known only at some rows).
    NullableDouble(&'a [f64]),
    /// INT32 (the valve state, a day number).
    Int32(&'a [i32]),
}

impl ColumnValues<'_> {
    fn len(&self) -> usize {
        match self {
            Self::Double(v) | Self::NullableDouble(v) => v.len(),
            Self::Int32(v) => v.len(),
        }
    }
}

/// One column of a [`write_table_parquet`] table: its name, its unit (`""` for none) and its
/// values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableColumn<'a> {
    pub name: &'a str,
    pub unit: &'a str,
    pub values: ColumnValues<'a>,
}

impl<'a> TableColumn<'a> {
    /// A DOUBLE column, every row present.
    pub fn double(name: &'a str, unit: &'a str, values: &'a [f64]) -> Self {
        Self {
            name,
            unit,
            values: ColumnValues::Double(values),
        }
    }

    /// A DOUBLE column with NaN written as null.
    pub fn nullable(name: &'a str, unit: &'a str, values: &'a [f64]) -> Self {
        Self {
            name,
            unit,
            values: ColumnValues::NullableDouble(values),
        }
    }

    /// An INT32 column without a unit.
    pub fn int32(name: &'a str, values: &'a [i32]) -> Self {
        Self {
            name,
            unit: "",
            values: ColumnValues::Int32(values),
        }
    }
}

/// Writes a run as Parquet (snappy), atomically: the contract's columns and units, the valve
/// as INT32, every other column DOUBLE, and the `units` metadata.
pub fn write_run_parquet(path: &Path, run: &Run) -> Result<(), DataError> {
    use columns::*;
    run.check_writable(path)?;
    let file_columns = run.file_columns();
    let valve: Vec<i32> = file_columns
        .iter()
        .find(|(name, _, _)| *name == VALVE)
        .map(|(_, _, codes)| codes.iter().map(|&code| code as i32).collect())
        .unwrap_or_default();
    // Schema order: time, valve, then the other columns.
    let mut table: Vec<TableColumn> = Vec::with_capacity(file_columns.len());
    for (k, (name, unit, values)) in file_columns.iter().enumerate() {
        if k == 1 {
            table.push(TableColumn::int32(VALVE, &valve));
        }
        if *name != VALVE {
            table.push(TableColumn::double(name, unit, values));
        }
    }
    write_table_parquet(path, "run", &run.name, &table)
}

/// Writes a table as Parquet (snappy), atomically: one column per [`TableColumn`], in order,
/// their units as the `units` metadata (the form [`read_run`] and pyarrow read), and
/// `airsus.<kind>` = `name` in the key-value metadata. Every column must have the same length.
pub fn write_table_parquet(
    path: &Path,
    kind: &str,
    name: &str,
    table: &[TableColumn],
) -> Result<(), DataError> {
    let n = table.first().map_or(0, |c| c.values.len());
    if let Some(c) = table.iter().find(|c| c.values.len() != n) {
        return Err(malformed(
            path,
            format!(
                "column {} has {} rows where the first has {n}; nothing was written",
                c.name,
                c.values.len()
            ),
        ));
    }
    let mut message = format!("message {kind} {{");
    for c in table {
        let field = match c.values {
            ColumnValues::Double(_) => "required double",
            ColumnValues::NullableDouble(_) => "optional double",
            ColumnValues::Int32(_) => "required int32",
        };
        message.push_str(&format!(" {field} {};", c.name));
    }
    message.push_str(" }");
    let units: serde_json::Map<String, serde_json::Value> = table
        .iter()
        .map(|c| (c.name.to_owned(), c.unit.into()))
        .collect();
    let fail = |e: parquet::errors::ParquetError| malformed(path, e);
    let schema = Arc::new(parse_message_type(&message).map_err(fail)?);
    let properties = Arc::new(
        WriterProperties::builder()
            .set_compression(Compression::SNAPPY)
            .set_key_value_metadata(Some(vec![
                KeyValue::new(
                    UNITS_KEY.to_owned(),
                    serde_json::Value::Object(units).to_string(),
                ),
                KeyValue::new(format!("airsus.{kind}"), name.to_owned()),
            ]))
            .build(),
    );
    // The writer needs `Write + Send`; it fills a buffer that is then written atomically.
    let mut buffer = Vec::new();
    let mut writer = SerializedFileWriter::new(&mut buffer, schema, properties).map_err(fail)?;
    let mut start = 0;
    while start < n.max(1) {
        let end = (start + ROW_GROUP_ROWS).min(n);
        let mut group = writer.next_row_group().map_err(fail)?;
        let mut columns = table.iter();
        while let Some(mut out) = group.next_column().map_err(fail)? {
            let Some(column) = columns.next() else {
                return Err(malformed(
                    path,
                    "the schema has more columns than the table",
                ));
            };
            match column.values {
                ColumnValues::Double(v) => {
                    out.typed::<DoubleType>()
                        .write_batch(&v[start..end], None, None)
                        .map_err(fail)?;
                }
                ColumnValues::NullableDouble(v) => {
                    let rows = &v[start..end];
                    let present: Vec<f64> = rows.iter().copied().filter(|x| !x.is_nan()).collect();
                    let levels: Vec<i16> = rows.iter().map(|x| i16::from(!x.is_nan())).collect();
                    out.typed::<DoubleType>()
                        .write_batch(&present, Some(&levels), None)
                        .map_err(fail)?;
                }
                ColumnValues::Int32(v) => {
                    out.typed::<Int32Type>()
                        .write_batch(&v[start..end], None, None)
                        .map_err(fail)?;
                }
            }
            out.close().map_err(fail)?;
        }
        group.close().map_err(fail)?;
        start = end.max(start + 1);
    }
    writer.close().map_err(fail)?;
    airsus_data::atomic::write_atomically(path, |w| w.write_all(&buffer))
}
