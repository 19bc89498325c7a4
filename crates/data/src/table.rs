//! Numeric CSV tables with a header row: the layer every CSV file of the contract reads through.
//!
//! Column order is free, extra columns are ignored, names are matched exactly (a near miss is
//! reported with the nearest valid name). Every cell must be a finite number. The reader keeps
//! the line number of every row so that later checks (time, valve, signs) can point at the
//! offending cell.

use std::path::Path;

use crate::error::{DataError, DataErrorKind, Location, nearest_name};

/// What the reader should do with one column.
#[derive(Debug, Clone, Copy)]
pub struct ColumnSpec<'a> {
    pub name: &'a str,
    /// `None`: the column is required. `Some(v)`: optional, filled with `v` when absent.
    pub default: Option<f64>,
}

impl<'a> ColumnSpec<'a> {
    pub const fn required(name: &'a str) -> Self {
        Self {
            name,
            default: None,
        }
    }

    pub const fn optional(name: &'a str, default: f64) -> Self {
        Self {
            name,
            default: Some(default),
        }
    }
}

/// Named numeric columns, in the order they were asked for.
#[derive(Debug, Clone, PartialEq)]
pub struct NumericTable {
    pub names: Vec<String>,
    pub columns: Vec<Vec<f64>>,
    /// The 1-based file line of each data row.
    pub lines: Vec<u64>,
    /// The 1-based file column of each requested column (`None` where it was absent and defaulted).
    pub file_columns: Vec<Option<u64>>,
    /// All header names as found in the file; for a log, the channel behind each column.
    pub header: Vec<String>,
    pub origin: TableOrigin,
}

/// What the rows of a table are, which decides how a cell is located in errors.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TableOrigin {
    /// Lines of a CSV file.
    #[default]
    Csv,
    /// Samples of log channels (MDF4, Parquet, CAN), which have no lines: a cell is named
    /// by its channel (`header[index]`) and 1-based sample number (`lines[row]`).
    Samples,
}

impl NumericTable {
    pub fn rows(&self) -> usize {
        self.lines.len()
    }

    /// The column asked for under `name`.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| self.columns[i].as_slice())
    }

    /// The location of row `row` of requested column `index`, for error messages.
    pub fn cell_location(&self, file: &Path, index: usize, row: usize) -> Location {
        let mut loc = Location::file(file);
        if self.origin == TableOrigin::Samples {
            let channel = self.header.get(index).map_or("?", String::as_str);
            return loc.channel(channel, self.lines.get(row).copied());
        }
        if let Some(&line) = self.lines.get(row) {
            loc = loc.line(line);
        }
        if let Some(Some(col)) = self.file_columns.get(index) {
            loc = loc.column(*col, self.names.get(index).map(String::as_str));
        }
        loc
    }
}

/// Reads the named columns of a CSV file, all of them required.
pub fn read_columns(path: &Path, names: &[&str]) -> Result<NumericTable, DataError> {
    let specs: Vec<ColumnSpec> = names.iter().map(|n| ColumnSpec::required(n)).collect();
    read_table(path, &specs)
}

/// Reads a CSV file from disk according to `specs`.
pub fn read_table(path: &Path, specs: &[ColumnSpec]) -> Result<NumericTable, DataError> {
    let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
    parse_table(&bytes, path, specs)
}

/// Parses CSV bytes according to `specs`; `path` is used only to name the source in errors.
pub fn parse_table(
    bytes: &[u8],
    path: &Path,
    specs: &[ColumnSpec],
) -> Result<NumericTable, DataError> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::All)
        .flexible(false)
        .from_reader(bytes);

    let header: Vec<String> = reader
        .headers()
        .map_err(|e| csv_error(path, &e))?
        .iter()
        .map(str::to_owned)
        .collect();
    if header.iter().all(String::is_empty) {
        return Err(DataError::new(
            Location::file(path).line(1),
            DataErrorKind::Empty { needed: 1 },
        ));
    }
    for (i, name) in header.iter().enumerate() {
        if !name.is_empty() && header[..i].contains(name) {
            return Err(DataError::new(
                Location::file(path)
                    .line(1)
                    .column(i as u64 + 1, Some(name)),
                DataErrorKind::DuplicateColumn { name: name.clone() },
            ));
        }
    }

    let mut indices: Vec<Option<usize>> = Vec::with_capacity(specs.len());
    for spec in specs {
        let found = header.iter().position(|h| h == spec.name);
        if found.is_none() && spec.default.is_none() {
            let unclaimed = header
                .iter()
                .map(String::as_str)
                .filter(|h| !specs.iter().any(|s| s.name == *h));
            return Err(DataError::new(
                Location::file(path).line(1),
                DataErrorKind::MissingColumn {
                    name: spec.name.to_owned(),
                    suggestion: nearest_name(spec.name, unclaimed),
                    available: header.clone(),
                },
            ));
        }
        indices.push(found);
    }

    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); specs.len()];
    let mut lines = Vec::new();
    let mut record = csv::StringRecord::new();
    loop {
        match reader.read_record(&mut record) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => return Err(csv_error(path, &e)),
        }
        let line = record.position().map_or(0, |p| p.line());
        for (k, (spec, index)) in specs.iter().zip(&indices).enumerate() {
            let value = match index {
                None => spec.default.unwrap_or(f64::NAN),
                Some(i) => {
                    let cell = record.get(*i).unwrap_or("");
                    let loc = || {
                        Location::file(path)
                            .line(line)
                            .column(*i as u64 + 1, Some(spec.name))
                    };
                    let value: f64 = cell.parse().map_err(|_| {
                        DataError::new(
                            loc(),
                            DataErrorKind::NotANumber {
                                found: if cell.is_empty() {
                                    "(an empty cell)".to_owned()
                                } else {
                                    cell.to_owned()
                                },
                            },
                        )
                    })?;
                    if !value.is_finite() {
                        return Err(DataError::new(
                            loc(),
                            DataErrorKind::NotFinite {
                                found: cell.to_owned(),
                            },
                        ));
                    }
                    value
                }
            };
            columns[k].push(value);
        }
        lines.push(line);
    }

    Ok(NumericTable {
        names: specs.iter().map(|s| s.name.to_owned()).collect(),
        columns,
        lines,
        file_columns: indices.iter().map(|i| i.map(|i| i as u64 + 1)).collect(),
        header,
        origin: TableOrigin::Csv,
    })
}

fn csv_error(path: &Path, err: &csv::Error) -> DataError {
    let mut loc = Location::file(path);
    if let Some(pos) = err.position() {
        loc = loc.line(pos.line());
    }
    let message = match err.kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => format!("expected {expected_len} fields like the header, found {len}"),
        csv::ErrorKind::Utf8 { .. } => "the file is not valid UTF-8 text".to_owned(),
        csv::ErrorKind::Io(e) => e.to_string(),
        _ => err.to_string(),
    };
    DataError::new(loc, DataErrorKind::Csv(message))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str, specs: &[ColumnSpec]) -> Result<NumericTable, DataError> {
        parse_table(text.as_bytes(), Path::new("t.csv"), specs)
    }

    #[test]
    fn reads_columns_in_requested_order_ignoring_extras() {
        let t = parse(
            "b, extra ,a\n1,x,2\n3,y,4\n",
            &[ColumnSpec::required("a"), ColumnSpec::required("b")],
        )
        .unwrap();
        assert_eq!(t.columns, vec![vec![2.0, 4.0], vec![1.0, 3.0]]);
        assert_eq!(t.lines, vec![2, 3]);
        assert_eq!(t.file_columns, vec![Some(3), Some(1)]);
    }

    #[test]
    fn optional_column_takes_its_default() {
        let t = parse(
            "a\n1\n2\n",
            &[
                ColumnSpec::required("a"),
                ColumnSpec::optional("road_mm", 0.0),
            ],
        )
        .unwrap();
        assert_eq!(t.column("road_mm"), Some(&[0.0, 0.0][..]));
        assert_eq!(t.file_columns[1], None);
    }

    #[test]
    fn bad_cell_names_line_and_column() {
        let err = parse(
            "a,b\n1,2\n3,oops\n",
            &[ColumnSpec::required("a"), ColumnSpec::required("b")],
        )
        .unwrap_err();
        assert_eq!(
            err.to_string(),
            "t.csv:3:2 (column `b`): expected a number, found `oops`"
        );
        let err = parse("a,b\n1,2\n3,NaN\n", &[ColumnSpec::required("b")]).unwrap_err();
        assert_eq!(
            err.to_string(),
            "t.csv:3:2 (column `b`): expected a finite number, found `NaN`"
        );
        let err = parse("a,b\n1,2\n3,-inf\n", &[ColumnSpec::required("b")]).unwrap_err();
        assert!(matches!(err.kind, DataErrorKind::NotFinite { .. }));
    }

    #[test]
    fn ragged_row_is_reported_with_its_line() {
        let err = parse("a,b\n1,2\n3\n", &[ColumnSpec::required("a")]).unwrap_err();
        assert_eq!(err.location.line, Some(3));
        assert!(err.to_string().contains("expected 2 fields"), "{err}");
    }

    #[test]
    fn missing_column_suggests_nearest_unclaimed_header() {
        let err = parse(
            "time_s,heigth_mm\n0,1\n",
            &[
                ColumnSpec::required("time_s"),
                ColumnSpec::required("height_mm"),
            ],
        )
        .unwrap_err();
        let text = err.to_string();
        assert!(
            text.starts_with(
                "t.csv:1: required column `height_mm` is missing (did you mean `heigth_mm`?)"
            ),
            "{text}"
        );
    }

    #[test]
    fn duplicate_header_is_an_error() {
        let err = parse("a,a\n1,2\n", &[ColumnSpec::required("a")]).unwrap_err();
        assert!(matches!(err.kind, DataErrorKind::DuplicateColumn { .. }));
    }
}
