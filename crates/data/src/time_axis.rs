//! Checks of the `time_s` column shared by every time-series file.
//!
//! Policy (SPEC §5: "the tool states clearly what it does with gaps or jitter"): time must
//! increase strictly, and every interval must be within [`SAMPLING_TOLERANCE`] of the median
//! interval. Jitter inside the tolerance is accepted and the median is taken as the sample
//! time; anything outside it (a gap, a dropped sample, a clock jump) is an error naming the
//! line. Nothing is ever resampled.

use std::path::Path;

use crate::error::{DataError, DataErrorKind, Location};
use crate::table::NumericTable;

/// Largest accepted relative deviation of one sample interval from the median interval.
pub const SAMPLING_TOLERANCE: f64 = 0.01;

/// Validates column `index` of `table` as a time axis and returns the sample time in seconds.
pub fn check_time_axis(
    table: &NumericTable,
    index: usize,
    path: &Path,
    min_rows: usize,
) -> Result<f64, DataError> {
    check_uniform(
        &table.columns[index],
        path,
        |row| table.cell_location(path, index, row),
        min_rows,
    )
}

/// Validates `time` as a uniform time axis and returns the sample time in seconds;
/// `location(row)` places a fault at (0-based) sample `row`.
pub fn check_uniform(
    time: &[f64],
    path: &Path,
    location: impl Fn(usize) -> Location,
    min_rows: usize,
) -> Result<f64, DataError> {
    if time.len() < min_rows.max(2) {
        let kind = if time.is_empty() {
            DataErrorKind::Empty {
                needed: min_rows.max(2),
            }
        } else {
            DataErrorKind::TooFewRows {
                needed: min_rows.max(2),
                found: time.len(),
            }
        };
        return Err(DataError::in_file(path, kind));
    }
    let mut intervals = Vec::with_capacity(time.len() - 1);
    for (row, pair) in time.windows(2).enumerate() {
        let dt = pair[1] - pair[0];
        // `<= 0` or NaN: the cells are finite, but their difference may still not be positive.
        if dt.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return Err(DataError::new(
                location(row + 1),
                DataErrorKind::TimeNotIncreasing {
                    previous: pair[0],
                    current: pair[1],
                },
            ));
        }
        intervals.push(dt);
    }
    let mut sorted = intervals.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    for (row, &dt) in intervals.iter().enumerate() {
        if (dt - median).abs() > SAMPLING_TOLERANCE * median {
            return Err(DataError::new(
                location(row + 1),
                DataErrorKind::NonUniformSampling {
                    expected_s: median,
                    found_s: dt,
                    tolerance: SAMPLING_TOLERANCE,
                },
            ));
        }
    }
    Ok(median)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{ColumnSpec, parse_table};

    fn axis(text: &str) -> Result<f64, DataError> {
        let p = Path::new("r.csv");
        let t = parse_table(text.as_bytes(), p, &[ColumnSpec::required("time_s")]).unwrap();
        check_time_axis(&t, 0, p, 2)
    }

    #[test]
    fn uniform_and_slightly_jittered_axes_pass() {
        assert!((axis("time_s\n0\n0.1\n0.2\n0.3\n").unwrap() - 0.1).abs() < 1e-12);
        assert!((axis("time_s\n0\n0.1001\n0.2\n0.3\n").unwrap() - 0.1).abs() < 2e-4);
    }

    #[test]
    fn repeated_time_names_its_line() {
        let err = axis("time_s\n0\n0.1\n0.1\n0.2\n").unwrap_err();
        assert_eq!(err.location.line, Some(4));
        assert!(
            err.to_string()
                .contains("time must increase strictly: 0.1 s follows 0.1 s"),
            "{err}"
        );
    }

    #[test]
    fn gap_says_where_and_by_how_much() {
        let err = axis("time_s\n0\n0.1\n0.2\n0.4\n0.5\n0.6\n").unwrap_err();
        assert_eq!(err.location.line, Some(5));
        let text = err.to_string();
        assert!(text.contains("this interval is 0.2"), "{text}");
        assert!(text.contains("off by 100.000 %"), "{text}");
    }

    #[test]
    fn a_single_row_is_too_few() {
        assert!(matches!(
            axis("time_s\n0\n").unwrap_err().kind,
            DataErrorKind::TooFewRows { .. }
        ));
        assert!(matches!(
            axis("time_s\n").unwrap_err().kind,
            DataErrorKind::Empty { .. }
        ));
    }
}
