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

/// Writes a run as Parquet (snappy), atomically: the contract's columns and units, the valve
/// as INT32, every other column DOUBLE, and the `units` metadata.
pub fn write_run_parquet(path: &Path, run: &Run) -> Result<(), DataError> {
    use columns::*;
    run.check_writable(path)?;
    let n = run.len();
    // Schema order: time, valve, then the other columns, all DOUBLE.
    let mut doubles = run.file_columns();
    let valve: Vec<i32> = doubles
        .iter()
        .position(|(name, _, _)| *name == VALVE)
        .map(|k| doubles.remove(k).2)
        .unwrap_or_default()
        .into_iter()
        .map(|code| code as i32)
        .collect();

    let mut message = format!("message run {{ required double {TIME}; required int32 {VALVE};");
    for (name, _, _) in &doubles[1..] {
        message.push_str(&format!(" required double {name};"));
    }
    message.push_str(" }");
    let units: serde_json::Map<String, serde_json::Value> = doubles
        .iter()
        .map(|(name, unit, _)| ((*name).to_owned(), (*unit).into()))
        .chain(std::iter::once((VALVE.to_owned(), "".into())))
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
                KeyValue::new("airsus.run".to_owned(), run.name.clone()),
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
        let mut column = 0;
        while let Some(mut out) = group.next_column().map_err(fail)? {
            // Schema order: time, valve, then the other doubles.
            if column == 1 {
                out.typed::<Int32Type>()
                    .write_batch(&valve[start..end], None, None)
                    .map_err(fail)?;
            } else {
                let k = if column == 0 { 0 } else { column - 1 };
                out.typed::<DoubleType>()
                    .write_batch(&doubles[k].2[start..end], None, None)
                    .map_err(fail)?;
            }
            out.close().map_err(fail)?;
            column += 1;
        }
        group.close().map_err(fail)?;
        start = end.max(start + 1);
    }
    writer.close().map_err(fail)?;
    airsus_data::atomic::write_atomically(path, |w| w.write_all(&buffer))
}
