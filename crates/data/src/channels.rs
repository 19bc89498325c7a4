//! From the channels of a log to a run: the one path every log format (MDF4, Parquet, CAN
//! through a DBC, and a resampled CSV) takes once its reader has decoded the file.
//!
//! A reader hands over named channels, each on a time base with its unit when the file gives
//! one. Here the contract columns are looked up through the column map, units converted to
//! the contract's, and the time bases checked: channels must share one uniform base unless
//! the caller asked for resampling, and what was done is returned as notes, never silent.

use std::path::Path;

use crate::error::{
    DataError, DataErrorKind, Location, MissingChannel, TimeBaseSummary, nearest_name,
};
use crate::run::{LoadedRun, Outputs, columns, run_from_table};
use crate::source::{ColumnMap, Resample, ResampleMethod, RunSource, column_quantity};
use crate::table::{NumericTable, TableOrigin};
use crate::units::{Quantity, UnitConversion};

/// The sample times shared by the channels of one group (an MDF4 channel group, a Parquet
/// file, a CAN message), in seconds.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeBase {
    /// What the base is called in errors: a master channel, a group, a message.
    pub name: String,
    /// The sample times in the base's own unit (`unit`, seconds when `None`).
    pub time_s: Vec<f64>,
    pub unit: Option<String>,
}

/// One decoded channel.
#[derive(Debug, Clone, PartialEq)]
pub struct LogChannel {
    pub name: String,
    /// The unit the file gives, if any (an empty unit counts as none).
    pub unit: Option<String>,
    /// Index of its time base in [`ChannelSet::bases`].
    pub base: usize,
    pub values: Vec<f64>,
}

/// What a log reader decoded.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ChannelSet {
    /// The format, as errors and notes name it (`MDF4`, `Parquet`, ...).
    pub format: &'static str,
    pub bases: Vec<TimeBase>,
    pub channels: Vec<LogChannel>,
    /// Channels the file has but the reader did not decode (nothing asked for them); errors
    /// list them with the decoded ones.
    pub unread: Vec<String>,
    /// What may explain a channel that is not there (e.g. CAN frames logged but no DBC).
    pub hint: Option<String>,
    /// What the reader itself did (a timestamp made relative, frames skipped, ...).
    pub notes: Vec<String>,
}

impl ChannelSet {
    /// A CSV table as one time base (column 0) and the columns it found, under their header
    /// names.
    pub(crate) fn from_table(table: &NumericTable, format: &'static str) -> Self {
        let channels = table
            .names
            .iter()
            .zip(&table.columns)
            .zip(&table.file_columns)
            .skip(1)
            .filter(|(_, file_column)| file_column.is_some())
            .map(|((name, values), _)| LogChannel {
                name: name.clone(),
                unit: None,
                base: 0,
                values: values.clone(),
            })
            .collect();
        Self {
            format,
            bases: vec![TimeBase {
                name: table.names.first().cloned().unwrap_or_default(),
                time_s: table.columns.first().cloned().unwrap_or_default(),
                unit: None,
            }],
            channels,
            unread: Vec::new(),
            hint: None,
            notes: Vec::new(),
        }
    }

    /// The channel called `name`, or an error naming the column it was wanted for.
    fn find(&self, path: &Path, column: &str, name: &str) -> Result<Option<usize>, DataError> {
        let mut found = self
            .channels
            .iter()
            .enumerate()
            .filter(|(_, c)| c.name == name);
        let Some((index, _)) = found.next() else {
            return Ok(None);
        };
        if found.next().is_some() {
            let groups: Vec<&str> = self
                .channels
                .iter()
                .filter(|c| c.name == name)
                .filter_map(|c| self.bases.get(c.base).map(|b| b.name.as_str()))
                .collect();
            return Err(DataError::new(
                Location::file(path).channel(name, None),
                DataErrorKind::InvalidValue {
                    key: column.to_owned(),
                    value: name.to_owned(),
                    reason: format!(
                        "the channel name appears {} times (on time bases {}); airsus cannot tell which one is meant",
                        groups.len(),
                        groups.join(", ")
                    ),
                },
            ));
        }
        Ok(Some(index))
    }

    fn missing(&self, path: &Path, column: &str, name: &str) -> DataError {
        let available: Vec<String> = self
            .channels
            .iter()
            .map(|c| c.name.clone())
            .chain(self.unread.iter().cloned())
            .collect();
        DataError::new(
            Location::file(path),
            DataErrorKind::MissingChannel(Box::new(MissingChannel {
                column: column.to_owned(),
                channel: name.to_owned(),
                suggestion: nearest_name(name, available.iter().map(String::as_str)),
                available,
                hint: self.hint.clone(),
            })),
        )
    }
}

/// The conversion of one channel onto its contract column, and a note when a unit was assumed.
pub(crate) struct ColumnConversion {
    pub conversion: UnitConversion,
    pub note: Option<String>,
}

/// How channel `channel` (unit `file_unit` in the file, if any) converts onto `column`.
pub(crate) fn column_conversion(
    path: &Path,
    column: &str,
    channel: &str,
    file_unit: Option<&str>,
    map: &ColumnMap,
) -> Result<ColumnConversion, DataError> {
    let Some(quantity) = column_quantity(column) else {
        return Ok(ColumnConversion {
            conversion: UnitConversion::IDENTITY,
            note: None,
        });
    };
    let location = || Location::file(path).channel(channel, None);
    let convert = |unit: &str| {
        quantity.conversion(unit).map_err(|expected| {
            DataError::new(
                location(),
                DataErrorKind::UnknownUnit {
                    column: column.to_owned(),
                    unit: unit.to_owned(),
                    expected,
                },
            )
        })
    };
    // The valve is a code: its unit, if any, only has to be one a code may carry.
    let file_unit = file_unit.filter(|u| !u.trim().is_empty() || quantity == Quantity::Code);
    let mapped_unit = map.get(column).and_then(|c| c.unit.as_deref());
    match (file_unit, mapped_unit) {
        (Some(in_file), Some(mapped)) => {
            let (a, b) = (convert(in_file)?, convert(mapped)?);
            if a != b {
                return Err(DataError::new(
                    location(),
                    DataErrorKind::UnitConflict {
                        in_file: in_file.to_owned(),
                        mapped: mapped.to_owned(),
                    },
                ));
            }
            Ok(ColumnConversion {
                conversion: a,
                note: None,
            })
        }
        (Some(unit), None) | (None, Some(unit)) => Ok(ColumnConversion {
            conversion: convert(unit)?,
            note: None,
        }),
        (None, None) => Ok(ColumnConversion {
            conversion: UnitConversion::IDENTITY,
            // A channel named as the contract names it carries its unit in its name.
            note: (channel != column && quantity != Quantity::Code).then(|| {
                format!(
                    "channel `{channel}` has no unit: read as {} for `{column}`",
                    quantity.contract_unit()
                )
            }),
        }),
    }
}

/// What a run without a wheel-load column says about it.
pub(crate) const NO_LOAD_NOTE: &str = "no wheel-load channel: the load is read as 0 kg (weighing estimates it; nothing else may use it)";

/// Whether a run's outputs are read: always when required; else when the file has them or
/// the map names a channel for one (then a missing channel is an error, not a silent
/// inputs-only run).
pub(crate) fn outputs_wanted(outputs: Outputs, map: &ColumnMap, present: bool) -> bool {
    match outputs {
        Outputs::Required => true,
        Outputs::IfPresent => {
            present || map.get(columns::HEIGHT).is_some() || map.get(columns::PRESSURE).is_some()
        }
    }
}

/// Builds a run from decoded channels, as `source` maps and resamples them.
pub fn run_from_channels(
    set: ChannelSet,
    path: &Path,
    outputs: Outputs,
    source: &RunSource,
) -> Result<LoadedRun, DataError> {
    use columns::*;
    let map = &source.columns;
    let find = |column: &str| set.find(path, column, map.channel_for(column));
    let mut notes = set.notes.clone();

    let height = find(HEIGHT)?;
    let pressure = find(PRESSURE)?;
    let with_outputs = outputs_wanted(outputs, map, height.is_some() || pressure.is_some());
    let mut wanted: Vec<(&str, Option<usize>)> = vec![
        (WHEEL_LOAD, find(WHEEL_LOAD)?),
        (VALVE, find(VALVE)?),
        (SUPPLY, find(SUPPLY)?),
        (ROAD, find(ROAD)?),
    ];
    if with_outputs {
        wanted.push((HEIGHT, height));
        wanted.push((PRESSURE, pressure));
    }
    for (column, index) in &wanted {
        // The road may be absent (flat) unless the map names a channel for it; the load when
        // the caller does not need it (weighing).
        let may_be_absent = match *column {
            ROAD => map.get(ROAD).is_none(),
            WHEEL_LOAD => source.load_optional && map.get(WHEEL_LOAD).is_none(),
            _ => false,
        };
        if index.is_none() && !may_be_absent {
            return Err(set.missing(path, column, map.channel_for(column)));
        }
        if index.is_none() && *column == WHEEL_LOAD {
            notes.push(NO_LOAD_NOTE.to_owned());
        }
    }

    let mut set = set;
    let chosen: Vec<(usize, ResampleMethod)> = wanted
        .iter()
        .filter_map(|(column, index)| {
            // The valve is a state: held, never interpolated.
            let method = match source.resample {
                Some(r) if *column != VALVE => r.method,
                _ => ResampleMethod::Zoh,
            };
            index.map(|i| (i, method))
        })
        .collect();
    let aligned = set.align(path, &chosen, source.resample, map)?;
    notes.extend(aligned.note.clone());

    let n = aligned.time_s.len();
    let mut names = vec![TIME.to_owned()];
    let mut header = vec![aligned.time_name.clone()];
    let mut table_columns = vec![aligned.time_s];
    let mut aligned_values = aligned.values.into_iter();
    for (column, index) in &wanted {
        names.push((*column).to_owned());
        let Some(i) = index else {
            header.push(map.channel_for(column).to_owned());
            table_columns.push(vec![0.0; n]);
            continue;
        };
        let channel = &set.channels[*i];
        let conversion =
            column_conversion(path, column, &channel.name, channel.unit.as_deref(), map)?;
        if let Some(note) = conversion.note {
            notes.push(note);
        }
        let mut values = aligned_values.next().unwrap_or_default();
        conversion.conversion.apply(&mut values);
        header.push(channel.name.clone());
        table_columns.push(values);
    }
    let table = NumericTable {
        names,
        columns: table_columns,
        lines: (1..=n as u64).collect(),
        file_columns: vec![None; header.len()],
        header,
        origin: TableOrigin::Samples,
    };
    let run = run_from_table(&table, path, with_outputs)?;
    Ok(LoadedRun {
        run,
        notes,
        format: set.format,
    })
}

/// Channels brought onto one time axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Aligned {
    /// Seconds.
    pub time_s: Vec<f64>,
    /// The base's name (or `resampled ...`), for errors about the time axis.
    pub time_name: String,
    /// One column per channel asked for, in order.
    pub values: Vec<Vec<f64>>,
    /// What resampling did, if it was asked.
    pub note: Option<String>,
}

impl ChannelSet {
    fn base(&self, path: &Path, b: usize) -> Result<&TimeBase, DataError> {
        self.bases.get(b).ok_or_else(|| {
            DataError::in_file(
                path,
                DataErrorKind::Malformed {
                    format: self.format,
                    reason: format!("time base {b} is missing"),
                },
            )
        })
    }

    /// Brings `chosen` channels (index, how to resample it) onto one axis: their shared base,
    /// or with `resample` a uniform grid over the span they all cover. Bases are first put in
    /// seconds by their unit (or the map's unit for `time_s`). Different bases without
    /// `resample` are an error; so is a value that is not finite.
    pub(crate) fn align(
        &mut self,
        path: &Path,
        chosen: &[(usize, ResampleMethod)],
        resample: Option<Resample>,
        map: &ColumnMap,
    ) -> Result<Aligned, DataError> {
        let mut bases: Vec<usize> = Vec::new();
        for &(i, _) in chosen {
            let base = self.channels[i].base;
            if !bases.contains(&base) {
                bases.push(base);
            }
        }
        let Some(&first_base) = bases.first() else {
            return Err(DataError::in_file(
                path,
                DataErrorKind::MissingKey {
                    key: "channels".to_owned(),
                    expected: "at least one channel to read".to_owned(),
                },
            ));
        };
        for &b in &bases {
            let Some(base) = self.bases.get_mut(b) else {
                continue;
            };
            let conversion =
                column_conversion(path, columns::TIME, &base.name, base.unit.as_deref(), map)?;
            conversion.conversion.apply(&mut base.time_s);
            base.unit = None;
        }
        for &(i, _) in chosen {
            let channel = &self.channels[i];
            let base = self.base(path, channel.base)?;
            if base.time_s.is_empty() {
                return Err(DataError::new(
                    Location::file(path).channel(&channel.name, None),
                    DataErrorKind::Malformed {
                        format: self.format,
                        reason: format!("the channel has no samples (time base `{}`)", base.name),
                    },
                ));
            }
            if channel.values.len() != base.time_s.len() {
                return Err(DataError::new(
                    Location::file(path).channel(&channel.name, None),
                    DataErrorKind::Malformed {
                        format: self.format,
                        reason: format!(
                            "{} values on a time base of {} samples",
                            channel.values.len(),
                            base.time_s.len()
                        ),
                    },
                ));
            }
            if let Some(row) = channel.values.iter().position(|v| !v.is_finite()) {
                return Err(DataError::new(
                    Location::file(path).channel(&channel.name, Some(row as u64 + 1)),
                    DataErrorKind::NotFinite {
                        found: channel.values[row].to_string(),
                    },
                ));
            }
        }

        let Some(resample) = resample else {
            let first = self.base(path, first_base)?;
            for &b in &bases[1..] {
                let other = self.base(path, b)?;
                if other.time_s != first.time_s {
                    return Err(DataError::in_file(
                        path,
                        DataErrorKind::TimeBases {
                            first: Box::new(summary(first)),
                            second: Box::new(summary(other)),
                        },
                    ));
                }
            }
            return Ok(Aligned {
                time_s: first.time_s.clone(),
                time_name: first.name.clone(),
                values: chosen
                    .iter()
                    .map(|&(i, _)| self.channels[i].values.clone())
                    .collect(),
                note: None,
            });
        };

        let mut span = (f64::NEG_INFINITY, f64::INFINITY);
        for &b in &bases {
            let base = self.base(path, b)?;
            check_increasing(path, base)?;
            if let (Some(first), Some(last)) = (base.time_s.first(), base.time_s.last()) {
                span = (span.0.max(*first), span.1.min(*last));
            }
        }
        // A grid far denser than the data (a damaged or absolute time stamp stretching the
        // span) would only invent samples, and could exhaust memory: refuse it by its size.
        let most_samples = bases
            .iter()
            .filter_map(|&b| self.bases.get(b))
            .map(|base| base.time_s.len())
            .max()
            .unwrap_or(0);
        let limit = most_samples.saturating_mul(MAX_UPSAMPLING).max(1000);
        let count = grid_count(span, resample.sample_s);
        let bad_step = |reason: String| {
            DataError::in_file(
                path,
                DataErrorKind::InvalidValue {
                    key: "sample_s".to_owned(),
                    value: resample.sample_s.to_string(),
                    reason,
                },
            )
        };
        if count > limit {
            return Err(bad_step(format!(
                "resampling would make {count} samples from channels of at most {most_samples} (they span {} s to {} s): check the time channels for a damaged or absolute time stamp, or choose a longer sample_s",
                span.0, span.1
            )));
        }
        let grid = uniform_grid(span, resample.sample_s);
        if grid.len() < 2 {
            return Err(bad_step(format!(
                "the channels overlap from {} s to {} s only: fewer than two samples to resample onto",
                span.0, span.1
            )));
        }
        let values = chosen
            .iter()
            .map(|&(i, method)| {
                let channel = &self.channels[i];
                let base = self.base(path, channel.base)?;
                Ok(resample_onto(&base.time_s, &channel.values, &grid, method))
            })
            .collect::<Result<Vec<_>, DataError>>()?;
        let held = chosen
            .iter()
            .filter(|(_, m)| *m == ResampleMethod::Zoh)
            .count();
        let note = format!(
            "resampled {} channel(s) from {} time base(s) onto {} samples every {} s from {} s, {}",
            chosen.len(),
            bases.len(),
            grid.len(),
            resample.sample_s,
            grid[0],
            match resample.method {
                ResampleMethod::Zoh => "zero-order hold".to_owned(),
                ResampleMethod::Linear if held > 0 =>
                    format!("linear interpolation ({held} state channel(s) held)"),
                ResampleMethod::Linear => "linear interpolation".to_owned(),
            }
        );
        Ok(Aligned {
            time_s: grid,
            time_name: format!("resampled {}", map.channel_for(columns::TIME)),
            values,
            note: Some(note),
        })
    }

    /// The channels called `names` on one axis (or an error naming the first that is missing,
    /// with the nearest names): for black-box identification on any signals of a log.
    pub fn signals(
        mut self,
        path: &Path,
        names: &[&str],
        resample: Option<Resample>,
    ) -> Result<Aligned, DataError> {
        let mut chosen = Vec::with_capacity(names.len());
        for name in names {
            match self.find(path, name, name)? {
                Some(i) => chosen.push((i, resample.map_or(ResampleMethod::Zoh, |r| r.method))),
                None => return Err(self.missing(path, name, name)),
            }
        }
        self.align(path, &chosen, resample, &ColumnMap::default())
    }
}

fn summary(base: &TimeBase) -> TimeBaseSummary {
    let samples = base.time_s.len();
    let start_s = base.time_s.first().copied().unwrap_or(f64::NAN);
    let step_s = if samples > 1 {
        (base.time_s[samples - 1] - start_s) / (samples - 1) as f64
    } else {
        f64::NAN
    };
    TimeBaseSummary {
        name: base.name.clone(),
        samples,
        start_s,
        step_s,
    }
}

fn check_increasing(path: &Path, base: &TimeBase) -> Result<(), DataError> {
    match base
        .time_s
        .windows(2)
        .position(|w| w[1] <= w[0] || w[1].is_nan())
    {
        Some(i) => Err(DataError::new(
            Location::file(path).channel(&base.name, Some(i as u64 + 2)),
            DataErrorKind::TimeNotIncreasing {
                previous: base.time_s[i],
                current: base.time_s[i + 1],
            },
        )),
        None => Ok(()),
    }
}

/// How many times more samples than its densest channel a resampled run may have.
const MAX_UPSAMPLING: usize = 100;

/// The number of samples of [`uniform_grid`].
fn grid_count((start, end): (f64, f64), step: f64) -> usize {
    if !(start.is_finite() && end.is_finite() && end >= start) {
        return 0;
    }
    // `as` saturates: an absurd span gives usize::MAX, which the caller refuses.
    (((end - start) / step + 1e-6).floor() as usize).saturating_add(1)
}

/// `start, start + step, ...` up to `end` (inclusive to a millionth of a step).
fn uniform_grid(span: (f64, f64), step: f64) -> Vec<f64> {
    (0..grid_count(span, step))
        .map(|k| span.0 + k as f64 * step)
        .collect()
}

/// How close to a grid time a sample counts as at it, as a fraction of the grid step: logger
/// timestamps carry float and clock jitter far above a ten-thousandth of a step, and without
/// it a hold could take the previous sample for one that was meant to be simultaneous.
const SAME_TIME_FRACTION: f64 = 1e-3;

/// The values of a channel sampled at `time_s`, read at each of `grid` (inside its span).
fn resample_onto(time_s: &[f64], values: &[f64], grid: &[f64], method: ResampleMethod) -> Vec<f64> {
    let step = if grid.len() > 1 {
        grid[1] - grid[0]
    } else {
        0.0
    };
    let tolerance = SAME_TIME_FRACTION * step;
    let mut out = Vec::with_capacity(grid.len());
    let mut k = 0;
    for &t in grid {
        while k + 1 < time_s.len() && time_s[k + 1] <= t + tolerance {
            k += 1;
        }
        let value = match method {
            ResampleMethod::Zoh => values[k],
            ResampleMethod::Linear if k + 1 < time_s.len() && t > time_s[k] + tolerance => {
                let w = (t - time_s[k]) / (time_s[k + 1] - time_s[k]);
                values[k] + w * (values[k + 1] - values[k])
            }
            ResampleMethod::Linear => values[k],
        };
        out.push(value);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::ChannelRef;

    fn channel(name: &str, unit: Option<&str>, base: usize, values: Vec<f64>) -> LogChannel {
        LogChannel {
            name: name.to_owned(),
            unit: unit.map(str::to_owned),
            base,
            values,
        }
    }

    fn set() -> ChannelSet {
        let t: Vec<f64> = (0..5).map(|k| k as f64 * 0.1).collect();
        ChannelSet {
            format: "test",
            bases: vec![TimeBase {
                name: "group 1".to_owned(),
                time_s: t,
                unit: None,
            }],
            channels: vec![
                channel("load", Some("t"), 0, vec![3.0; 5]),
                channel("valve", None, 0, vec![0.0, 1.0, 1.0, 0.0, 2.0]),
                channel("supply_kpa", None, 0, vec![850.0; 5]),
                channel("AxleHeight", Some("m"), 0, vec![0.25; 5]),
                channel("BellowP", Some("bar"), 0, vec![3.5; 5]),
            ],
            unread: vec!["EngineSpeed".to_owned()],
            hint: None,
            notes: Vec::new(),
        }
    }

    /// `run_from_channels` on a file called `x.mf4`.
    fn read(set: ChannelSet, outputs: Outputs, source: &RunSource) -> Result<LoadedRun, DataError> {
        run_from_channels(set, Path::new("x.mf4"), outputs, source)
    }

    /// Maps run column `column` onto channel `channel`.
    fn map_channel(source: &mut RunSource, column: &str, channel: &str) {
        let channel = ChannelRef {
            channel: channel.to_owned(),
            unit: None,
        };
        source.columns.insert(column, channel).unwrap();
    }

    fn source() -> RunSource {
        RunSource {
            columns: ColumnMap::parse_list(
                "wheel_load_kg=load,height_mm=AxleHeight,pressure_kpa=BellowP",
            )
            .unwrap(),
            ..RunSource::default()
        }
    }

    #[test]
    fn mapped_channels_convert_to_si() {
        let loaded = read(set(), Outputs::Required, &source()).unwrap();
        let run = loaded.run;
        assert_eq!(run.inputs.wheel_load_kg, vec![3000.0; 5]);
        assert_eq!(run.outputs.as_ref().unwrap().bellow_gauge_pa[0], 350_000.0);
        assert!((run.outputs.as_ref().unwrap().sensor_height_m[0] - 0.25).abs() < 1e-15);
        assert_eq!(run.inputs.road_height_m, vec![0.0; 5]);
        assert!(loaded.notes.is_empty(), "{:?}", loaded.notes);
    }

    #[test]
    fn missing_channel_names_column_and_nearest_channel() {
        let mut source = source();
        map_channel(&mut source, "pressure_kpa", "BelowP");
        let err = read(set(), Outputs::Required, &source).unwrap_err();
        let text = err.to_string();
        assert!(
            text.starts_with("x.mf4: channel `BelowP` for column `pressure_kpa` is not in the file (did you mean `BellowP`?)"),
            "{text}"
        );
    }

    #[test]
    fn conflicting_and_unknown_units_are_refused() {
        let mut source = source();
        source.columns = ColumnMap::parse_list(
            "wheel_load_kg=load,height_mm=AxleHeight,pressure_kpa=BellowP[kPa]",
        )
        .unwrap();
        let err = read(set(), Outputs::Required, &source).unwrap_err();
        assert!(
            matches!(err.kind, DataErrorKind::UnitConflict { .. }),
            "{err}"
        );
        let mut bad = set();
        bad.channels[4].unit = Some("degC".to_owned());
        let err = read(bad, Outputs::Required, &self::source()).unwrap_err();
        assert_eq!(
            err.to_string(),
            "x.mf4 (channel `BellowP`): unit `degC` cannot be read as column `pressure_kpa` (expected one of: kPa, Pa, hPa, MPa, bar, mbar, psi)"
        );
    }

    #[test]
    fn a_mapped_road_or_output_channel_that_is_missing_is_an_error_not_a_default() {
        let mut mapped = source();
        map_channel(&mut mapped, "road_mm", "RoadProfile");
        let err = read(set(), Outputs::Required, &mapped).unwrap_err();
        assert!(
            err.to_string()
                .contains("channel `RoadProfile` for column `road_mm`"),
            "{err}"
        );
        // Outputs optional, but the map names them: a missing one is not an inputs-only run.
        let mut inputs_only = set();
        inputs_only.channels.truncate(3);
        let err = read(inputs_only.clone(), Outputs::IfPresent, &source()).unwrap_err();
        assert!(err.to_string().contains("for column `height_mm`"), "{err}");
        let plain = RunSource {
            columns: ColumnMap::parse_list("wheel_load_kg=load").unwrap(),
            ..RunSource::default()
        };
        let run = read(inputs_only, Outputs::IfPresent, &plain).unwrap().run;
        assert!(run.outputs.is_none());
    }

    #[test]
    fn the_load_may_be_absent_only_where_the_caller_allows_it() {
        let mut no_load = set();
        no_load.channels.remove(0);
        let err = read(no_load.clone(), Outputs::Required, &RunSource::default()).unwrap_err();
        assert!(
            err.to_string().contains("for column `wheel_load_kg`"),
            "{err}"
        );
        let weighing = RunSource {
            load_optional: true,
            columns: ColumnMap::parse_list("height_mm=AxleHeight,pressure_kpa=BellowP").unwrap(),
            ..RunSource::default()
        };
        let loaded = read(no_load, Outputs::Required, &weighing).unwrap();
        assert_eq!(loaded.run.inputs.wheel_load_kg, vec![0.0; 5]);
        assert_eq!(loaded.notes, vec![NO_LOAD_NOTE.to_owned()]);
    }

    #[test]
    fn bad_values_are_located_by_channel_and_sample() {
        let mut bad = set();
        bad.channels[1].values[3] = 7.0;
        let err = read(bad, Outputs::Required, &source()).unwrap_err();
        assert_eq!(
            err.to_string(),
            "x.mf4 (channel `valve`, sample 4): expected valve state 0 (closed), 1 (fill) or 2 (exhaust), found `7`"
        );
    }

    #[test]
    fn different_time_bases_need_an_explicit_resample() {
        let mut two = set();
        two.bases.push(TimeBase {
            name: "group 2".to_owned(),
            time_s: (0..9).map(|k| 20.0 + k as f64 * 50.0).collect(),
            unit: Some("ms".to_owned()),
        });
        two.channels[4] = channel(
            "BellowP",
            Some("bar"),
            1,
            (0..9).map(|k| k as f64).collect(),
        );
        let err = read(two.clone(), Outputs::Required, &source()).unwrap_err();
        assert!(matches!(err.kind, DataErrorKind::TimeBases { .. }), "{err}");
        assert!(
            err.to_string().contains("never resamples silently"),
            "{err}"
        );

        let mut source = source();
        source.resample = Some(Resample::new(ResampleMethod::Linear, 0.1).unwrap());
        let loaded = read(two, Outputs::Required, &source).unwrap();
        // Common span 0.02..0.4 s: samples at 0.02, 0.12, 0.22, 0.32.
        assert_eq!(loaded.run.len(), 4);
        let p = &loaded.run.outputs.as_ref().unwrap().bellow_gauge_pa;
        // BellowP at t = 0.12 s: index (0.12 - 0.02)/0.05 = 2 → 2 bar.
        assert!((p[1] - 200_000.0).abs() < 1e-6, "{p:?}");
        // The valve is held, not interpolated: at 0.12 s it is still sample 1's state.
        assert_eq!(loaded.run.inputs.valve[1], crate::ValveState::Fill);
        assert!(
            loaded.notes.iter().any(|n| n.contains("resampled")),
            "{:?}",
            loaded.notes
        );
    }

    #[test]
    fn an_irregular_base_is_refused_by_sample_and_resampled_on_request() {
        let mut jittered = set();
        jittered.bases[0].time_s = vec![0.0, 0.1, 0.25, 0.3, 0.4];
        let err = read(jittered.clone(), Outputs::Required, &source()).unwrap_err();
        assert!(
            err.to_string().starts_with(
                "x.mf4 (channel `group 1`, sample 3): non-uniform sampling: this interval is 0.15 s"
            ),
            "{err}"
        );
        let mut resampled = source();
        resampled.resample = Some(Resample::new(ResampleMethod::Zoh, 0.1).unwrap());
        let run = read(jittered, Outputs::Required, &resampled).unwrap().run;
        assert_eq!(run.time_s.len(), 5);
        // Held at 0.2 s: the sample of 0.1 s (the valve was 1 there).
        assert_eq!(run.inputs.valve[2], crate::ValveState::Fill);
    }

    #[test]
    fn resampling_holds_or_interpolates() {
        let t = [0.0, 1.0, 2.0];
        let v = [0.0, 10.0, 20.0];
        let grid = [0.0, 0.5, 1.5, 2.0];
        assert_eq!(
            resample_onto(&t, &v, &grid, ResampleMethod::Zoh),
            vec![0.0, 0.0, 10.0, 20.0]
        );
        assert_eq!(
            resample_onto(&t, &v, &grid, ResampleMethod::Linear),
            vec![0.0, 5.0, 15.0, 20.0]
        );
        assert_eq!(uniform_grid((0.0, 0.3), 0.1).len(), 4);
    }
}
