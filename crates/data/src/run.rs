//! Runs: drive and loading experiments (SPEC §5, thesis data-sets 1–4).
//!
//! The file speaks the units engineers log in (kg, kPa gauge, mm); the program holds SI units
//! (kg, Pa gauge, m). Conversion happens here and nowhere else.

use std::io::Write;
use std::path::Path;

use crate::atomic::write_atomically;
use crate::error::{DataError, DataErrorKind};
use crate::source::RunSource;
use crate::table::{ColumnSpec, NumericTable, parse_table};
use crate::time_axis::check_time_axis;
use crate::units::{PA_PER_KPA, STANDARD_ATMOSPHERE_KPA, m_from_mm, mm_from_m};

/// Column names of the run format, fixed by the data contract.
pub mod columns {
    pub const TIME: &str = "time_s";
    pub const WHEEL_LOAD: &str = "wheel_load_kg";
    pub const VALVE: &str = "valve";
    pub const SUPPLY: &str = "supply_kpa";
    pub const ROAD: &str = "road_mm";
    pub const HEIGHT: &str = "height_mm";
    pub const PRESSURE: &str = "pressure_kpa";
    /// Every run column, in the order files are written.
    pub const ALL: [&str; 7] = [TIME, WHEEL_LOAD, VALVE, SUPPLY, ROAD, HEIGHT, PRESSURE];
}

/// The 3-state solenoid valve between bellow circuit and supply tank (SPEC §1).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum ValveState {
    #[default]
    Closed = 0,
    Fill = 1,
    Exhaust = 2,
}

impl ValveState {
    /// The value written in the `valve` column.
    pub fn code(self) -> u8 {
        self as u8
    }

    pub fn from_code(value: f64) -> Option<Self> {
        if value == 0.0 {
            Some(Self::Closed)
        } else if value == 1.0 {
            Some(Self::Fill)
        } else if value == 2.0 {
            Some(Self::Exhaust)
        } else {
            None
        }
    }
}

/// Inputs of a run, one value per sample, SI units.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunInputs {
    /// `m_tot`: the mass a scale under the modeled wheel shows, kg.
    pub wheel_load_kg: Vec<f64>,
    pub valve: Vec<ValveState>,
    /// Actuator-tank gauge pressure, Pa (measured upstream of the valve).
    pub supply_gauge_pa: Vec<f64>,
    /// Road height under the wheel, m.
    pub road_height_m: Vec<f64>,
}

/// Measured outputs of a run, one value per sample, SI units.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunOutputs {
    /// Axle-to-chassis height as the sensor reads it, m.
    pub sensor_height_m: Vec<f64>,
    /// Bellow gauge pressure, Pa.
    pub bellow_gauge_pa: Vec<f64>,
}

/// One experiment: a uniform time base, the inputs, and (when measured) the outputs.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    pub name: String,
    pub time_s: Vec<f64>,
    /// The (median) sample interval; every interval is within 1 % of it.
    pub sample_time_s: f64,
    pub inputs: RunInputs,
    /// `None` for an inputs-only file (e.g. a scenario to simulate).
    pub outputs: Option<RunOutputs>,
}

/// The least road height range, m, that counts as road action ([`Run::road_action`]): a
/// millimetre, above a level road's logged jitter and far below a hump.
pub const ROAD_ACTION_M: f64 = 1e-3;

impl Run {
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// Whether the valve moves during the run (what makes flow parameters identifiable).
    pub fn valve_action(&self) -> bool {
        self.inputs.valve.iter().any(|&v| v != ValveState::Closed)
    }

    /// Whether the road moves the wheel during the run by more than [`ROAD_ACTION_M`] (what
    /// strokes the damper and compresses the tire fast enough to tell their laws).
    pub fn road_action(&self) -> bool {
        let road = &self.inputs.road_height_m;
        let (low, high) = road
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &z| {
                (lo.min(z), hi.max(z))
            });
        high - low > ROAD_ACTION_M
    }

    /// The run's columns in the contract's file units and order, as (name, unit, values):
    /// the valve as its code, the outputs only when measured.
    pub fn file_columns(&self) -> Vec<(&'static str, &'static str, Vec<f64>)> {
        let kpa = |pa: &[f64]| pa.iter().map(|p| p / PA_PER_KPA).collect();
        let mm = |m: &[f64]| m.iter().map(|&x| mm_from_m(x)).collect();
        let i = &self.inputs;
        let mut out = vec![
            (columns::TIME, "s", self.time_s.clone()),
            (columns::WHEEL_LOAD, "kg", i.wheel_load_kg.clone()),
            (
                columns::VALVE,
                "",
                i.valve.iter().map(|v| f64::from(v.code())).collect(),
            ),
            (columns::SUPPLY, "kPa", kpa(&i.supply_gauge_pa)),
            (columns::ROAD, "mm", mm(&i.road_height_m)),
        ];
        if let Some(o) = &self.outputs {
            out.push((columns::HEIGHT, "mm", mm(&o.sensor_height_m)));
            out.push((columns::PRESSURE, "kPa", kpa(&o.bellow_gauge_pa)));
        }
        out
    }

    /// Refuses to write a run whose signals differ in length (an error naming `path`).
    pub fn check_writable(&self, path: &Path) -> Result<(), DataError> {
        let n = self.len();
        let inputs = &self.inputs;
        let consistent = inputs.wheel_load_kg.len() == n
            && inputs.valve.len() == n
            && inputs.supply_gauge_pa.len() == n
            && inputs.road_height_m.len() == n
            && self
                .outputs
                .as_ref()
                .is_none_or(|o| o.sensor_height_m.len() == n && o.bellow_gauge_pa.len() == n);
        if consistent {
            return Ok(());
        }
        Err(DataError::in_file(
            path,
            DataErrorKind::InvalidValue {
                key: "run".to_owned(),
                value: self.name.clone(),
                reason: "signals of different lengths cannot be written".to_owned(),
            },
        ))
    }

    /// The measured outputs, or an error naming the run when it has none.
    pub fn measured(&self) -> Result<&RunOutputs, DataError> {
        self.outputs.as_ref().ok_or_else(|| {
            DataError::in_file(
                Path::new(&self.name),
                DataErrorKind::MissingColumn {
                    name: format!("{} and {}", columns::HEIGHT, columns::PRESSURE),
                    suggestion: None,
                    available: vec!["(inputs only)".to_owned()],
                },
            )
        })
    }
}

/// Whether a reader insists on the output columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outputs {
    Required,
    /// Read them when both are present; accept an inputs-only file.
    IfPresent,
}

/// Reads a run file whose outputs are required.
pub fn read_run(path: &Path) -> Result<Run, DataError> {
    read_run_with(path, Outputs::Required)
}

pub fn read_run_with(path: &Path, outputs: Outputs) -> Result<Run, DataError> {
    read_run_from(path, outputs, &RunSource::default()).map(|loaded| loaded.run)
}

/// Reads a run CSV file whose columns `source` maps (names, units, resampling).
pub fn read_run_from(
    path: &Path,
    outputs: Outputs,
    source: &RunSource,
) -> Result<LoadedRun, DataError> {
    let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
    parse_run_from(&bytes, path, outputs, source)
}

/// Parses run CSV bytes; `path` names the source in errors and gives the run its name.
pub fn parse_run(bytes: &[u8], path: &Path, outputs: Outputs) -> Result<Run, DataError> {
    parse_run_from(bytes, path, outputs, &RunSource::default()).map(|loaded| loaded.run)
}

/// A run read from a log, with what the reader did to it that the user should hear about
/// (units assumed, channels resampled, a timestamp made relative).
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedRun {
    pub run: Run,
    pub notes: Vec<String>,
    /// The file's format as errors and reports name it (`CSV`, `MDF4`, `Parquet`, ...).
    pub format: &'static str,
}

/// Parses run CSV bytes whose columns `source` maps (names and units) and may resample.
pub fn parse_run_from(
    bytes: &[u8],
    path: &Path,
    outputs: Outputs,
    source: &RunSource,
) -> Result<LoadedRun, DataError> {
    use columns::*;
    let map = &source.columns;
    let with_outputs = crate::channels::outputs_wanted(
        outputs,
        map,
        header_has(bytes, map.channel_for(HEIGHT)) || header_has(bytes, map.channel_for(PRESSURE)),
    );
    // The road may be absent (flat) unless the map names a column for it.
    let road = match map.get(ROAD) {
        Some(_) => ColumnSpec::required(map.channel_for(ROAD)),
        None => ColumnSpec::optional(ROAD, 0.0),
    };
    // The load may be absent when the caller does not need it (weighing).
    let load = if source.load_optional && map.get(WHEEL_LOAD).is_none() {
        ColumnSpec::optional(WHEEL_LOAD, 0.0)
    } else {
        ColumnSpec::required(map.channel_for(WHEEL_LOAD))
    };
    let mut specs = vec![
        ColumnSpec::required(map.channel_for(TIME)),
        load,
        ColumnSpec::required(map.channel_for(VALVE)),
        ColumnSpec::required(map.channel_for(SUPPLY)),
        road,
    ];
    if with_outputs {
        specs.push(ColumnSpec::required(map.channel_for(HEIGHT)));
        specs.push(ColumnSpec::required(map.channel_for(PRESSURE)));
    }
    let mut table = parse_table(bytes, path, &specs)?;
    if source.resample.is_some() {
        // A CSV table is one time base; resampling it goes the way of every log.
        let set = crate::channels::ChannelSet::from_table(&table, "CSV");
        return crate::channels::run_from_channels(set, path, outputs, source);
    }
    let mut notes = Vec::new();
    if table.file_columns.get(1) == Some(&None) {
        notes.push(crate::channels::NO_LOAD_NOTE.to_owned());
    }
    for (index, column) in ALL.iter().take(table.columns.len()).enumerate() {
        // A CSV header carries no unit: only the map's unit converts.
        let conversion =
            crate::channels::column_conversion(path, column, map.channel_for(column), None, map)?;
        if let Some(note) = conversion.note {
            notes.push(note);
        }
        conversion.conversion.apply(&mut table.columns[index]);
    }
    let run = run_from_table(&table, path, with_outputs)?;
    Ok(LoadedRun {
        run,
        notes,
        format: "CSV",
    })
}

/// Builds a run from a table whose columns are, in order, time, load, valve, supply, road and
/// (with outputs) height and pressure, in the contract's file units; checks every value.
pub(crate) fn run_from_table(
    table: &NumericTable,
    path: &Path,
    with_outputs: bool,
) -> Result<Run, DataError> {
    let sample_time_s = check_time_axis(table, 0, path, 2)?;

    let valve = table.columns[2]
        .iter()
        .enumerate()
        .map(|(row, &v)| {
            ValveState::from_code(v).ok_or_else(|| {
                DataError::new(
                    table.cell_location(path, 2, row),
                    DataErrorKind::InvalidValve {
                        found: v.to_string(),
                    },
                )
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    check_non_negative(table, 1, path, "wheel load")?;
    check_above_vacuum(table, 3, path, "supply pressure")?;

    let kpa_to_pa = |c: &[f64]| c.iter().map(|v| v * PA_PER_KPA).collect::<Vec<_>>();
    let inputs = RunInputs {
        wheel_load_kg: table.columns[1].clone(),
        valve,
        supply_gauge_pa: kpa_to_pa(&table.columns[3]),
        road_height_m: table.columns[4].iter().copied().map(m_from_mm).collect(),
    };
    let outputs = if with_outputs {
        check_above_vacuum(table, 6, path, "bellow pressure")?;
        Some(RunOutputs {
            sensor_height_m: table.columns[5].iter().copied().map(m_from_mm).collect(),
            bellow_gauge_pa: kpa_to_pa(&table.columns[6]),
        })
    } else {
        None
    };
    Ok(Run {
        name: path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        time_s: table.columns[0].clone(),
        sample_time_s,
        inputs,
        outputs,
    })
}

fn header_has(bytes: &[u8], name: &str) -> bool {
    let first = bytes.split(|&b| b == b'\n').next().unwrap_or_default();
    String::from_utf8_lossy(first)
        .split(',')
        .any(|h| h.trim().trim_matches('"') == name)
}

pub(crate) fn check_non_negative(
    table: &NumericTable,
    index: usize,
    path: &Path,
    quantity: &str,
) -> Result<(), DataError> {
    match table.columns[index].iter().position(|&v| v < 0.0) {
        Some(row) => Err(DataError::new(
            table.cell_location(path, index, row),
            DataErrorKind::Negative {
                quantity: quantity.to_owned(),
                value: table.columns[index][row],
            },
        )),
        None => Ok(()),
    }
}

/// A gauge pressure below -1 atm would be a negative absolute pressure: a unit or sign error.
pub(crate) fn check_above_vacuum(
    table: &NumericTable,
    index: usize,
    path: &Path,
    quantity: &str,
) -> Result<(), DataError> {
    match table.columns[index]
        .iter()
        .position(|&v| v <= -STANDARD_ATMOSPHERE_KPA)
    {
        Some(row) => Err(DataError::new(
            table.cell_location(path, index, row),
            DataErrorKind::BelowVacuum {
                quantity: quantity.to_owned(),
                value: table.columns[index][row],
                min: -STANDARD_ATMOSPHERE_KPA,
                unit: "kPa",
            },
        )),
        None => Ok(()),
    }
}

/// How many decimals each column of a written run carries, in the file's units (s, kg, kPa,
/// mm); `None` writes Rust's shortest round-trip form of the value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RunPrecision {
    pub time_decimals: Option<usize>,
    pub wheel_load_decimals: Option<usize>,
    pub supply_decimals: Option<usize>,
    pub road_decimals: Option<usize>,
    pub height_decimals: Option<usize>,
    pub pressure_decimals: Option<usize>,
}

impl RunPrecision {
    /// Every value in its shortest round-trip form (simulations, truth files).
    pub const FULL: Self = Self {
        time_decimals: None,
        wheel_load_decimals: None,
        supply_decimals: None,
        road_decimals: None,
        height_decimals: None,
        pressure_decimals: None,
    };

    /// The decimals that show a quantisation step `step` (in file units) exactly: 0.1 → 1,
    /// 1 → 0, 0.25 → 2. Steps that are not finite and positive get the full form.
    pub fn decimals_for_step(step: f64) -> Option<usize> {
        if !(step.is_finite() && step > 0.0) {
            return None;
        }
        (0..=12).find(|&d| {
            let scaled = step * 10f64.powi(d as i32);
            (scaled - scaled.round()).abs() <= 1e-9 * scaled.max(1.0)
        })
    }
}

/// One value as the file shows it: with `decimals` fixed (and never `-0.0`), or shortest.
fn format_value(value: f64, decimals: Option<usize>) -> String {
    match decimals {
        Some(d) => {
            let scale = 10f64.powi(d as i32);
            // + 0.0 turns a rounded -0.0 into 0.0, so a sensor reading never shows as `-0.0`.
            let rounded = (value * scale).round() / scale + 0.0;
            format!("{rounded:.d$}")
        }
        None => format!("{value}"),
    }
}

/// Writes a run in the contract's format and units, atomically. Values are written in Rust's
/// shortest round-trip form, so a run written and read back is the same to the last bit of the
/// file units (the SI conversion itself may round in the last place).
pub fn write_run(path: &Path, run: &Run) -> Result<(), DataError> {
    write_run_with_precision(path, run, &RunPrecision::FULL)
}

/// Writes a run with the given decimals per column, atomically: a measurement file at its
/// sensors' resolution reads `235.2`, not the float artefact `235.20000000000002` that the
/// conversion from SI leaves.
pub fn write_run_with_precision(
    path: &Path,
    run: &Run,
    precision: &RunPrecision,
) -> Result<(), DataError> {
    run.check_writable(path)?;
    let n = run.len();
    let inputs = &run.inputs;
    write_atomically(path, |w: &mut dyn Write| {
        use columns::*;
        write!(w, "{TIME},{WHEEL_LOAD},{VALVE},{SUPPLY},{ROAD}")?;
        if run.outputs.is_some() {
            write!(w, ",{HEIGHT},{PRESSURE}")?;
        }
        writeln!(w)?;
        for i in 0..n {
            let p = precision;
            write!(
                w,
                "{},{},{},{},{}",
                format_value(run.time_s[i], p.time_decimals),
                format_value(inputs.wheel_load_kg[i], p.wheel_load_decimals),
                inputs.valve[i].code(),
                format_value(inputs.supply_gauge_pa[i] / PA_PER_KPA, p.supply_decimals),
                format_value(mm_from_m(inputs.road_height_m[i]), p.road_decimals),
            )?;
            if let Some(o) = &run.outputs {
                write!(
                    w,
                    ",{},{}",
                    format_value(mm_from_m(o.sensor_height_m[i]), p.height_decimals),
                    format_value(o.bellow_gauge_pa[i] / PA_PER_KPA, p.pressure_decimals)
                )?;
            }
            writeln!(w)?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "time_s,wheel_load_kg,valve,supply_kpa,height_mm,pressure_kpa\n\
        0.0,2830,0,850,240.0,350.0\n\
        0.1,2830,1,850,240.1,350.2\n\
        0.2,3130,2,849.5,239.0,361.0\n";

    fn parse(text: &str) -> Result<Run, DataError> {
        parse_run(text.as_bytes(), Path::new("ds1.csv"), Outputs::Required)
    }

    #[test]
    fn reads_and_converts_to_si() {
        let run = parse(GOOD).unwrap();
        assert_eq!(run.name, "ds1");
        assert_eq!(run.len(), 3);
        assert!((run.sample_time_s - 0.1).abs() < 1e-12);
        assert_eq!(
            run.inputs.valve,
            vec![ValveState::Closed, ValveState::Fill, ValveState::Exhaust]
        );
        assert_eq!(run.inputs.supply_gauge_pa[2], 849_500.0);
        assert_eq!(run.inputs.road_height_m, vec![0.0; 3]);
        let out = run.outputs.as_ref().unwrap();
        assert!((out.sensor_height_m[1] - 0.2401).abs() < 1e-15);
        assert_eq!(out.bellow_gauge_pa[2], 361_000.0);
    }

    #[test]
    fn decimals_follow_the_quantisation_step() {
        assert_eq!(RunPrecision::decimals_for_step(0.1), Some(1));
        assert_eq!(RunPrecision::decimals_for_step(1.0), Some(0));
        assert_eq!(RunPrecision::decimals_for_step(0.25), Some(2));
        assert_eq!(RunPrecision::decimals_for_step(0.0), None);
        assert_eq!(format_value(235.200_000_000_000_02, Some(1)), "235.2");
        assert_eq!(format_value(850.000_000_000_1, Some(0)), "850");
        assert_eq!(format_value(-0.04, Some(1)), "0.0");
        assert_eq!(format_value(0.1 + 0.2, None), "0.30000000000000004");
    }

    #[test]
    fn a_run_written_at_sensor_resolution_has_no_float_artefacts() {
        let dir = tempfile::tempdir().unwrap();
        let mut run = parse(GOOD).unwrap();
        // SI values as a quantiser leaves them: 0.2352 m reads back as 235.20000000000002 mm.
        let out = run.outputs.as_mut().unwrap();
        out.sensor_height_m[0] = 2352.0 * 1e-4;
        out.bellow_gauge_pa[0] = 350_100.000_000_000_06;
        run.inputs.supply_gauge_pa[0] = 850_000.000_000_000_1;
        let full = dir.path().join("full.csv");
        write_run(&full, &run).unwrap();
        assert!(
            std::fs::read_to_string(&full)
                .unwrap()
                .contains("235.20000000000002"),
            "the shortest form keeps every bit"
        );
        let precision = RunPrecision {
            time_decimals: Some(1),
            wheel_load_decimals: Some(1),
            supply_decimals: Some(0),
            road_decimals: Some(1),
            height_decimals: Some(1),
            pressure_decimals: Some(1),
        };
        let path = dir.path().join("sensor.csv");
        write_run_with_precision(&path, &run, &precision).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(
            text.lines().nth(1).unwrap(),
            "0.0,2830.0,0,850,0.0,235.2,350.1",
            "{text}"
        );
        let back = parse_run(text.as_bytes(), &path, Outputs::Required).unwrap();
        assert_eq!(back.len(), run.len());
    }

    #[test]
    fn invalid_valve_names_cell() {
        let text = GOOD.replace("0.1,2830,1,", "0.1,2830,3,");
        let err = parse(&text).unwrap_err();
        assert_eq!(
            err.to_string(),
            "ds1.csv:3:3 (column `valve`): expected valve state 0 (closed), 1 (fill) or 2 (exhaust), found `3`"
        );
        let text = GOOD.replace("0.1,2830,1,", "0.1,2830,0.5,");
        assert!(matches!(
            parse(&text).unwrap_err().kind,
            DataErrorKind::InvalidValve { .. }
        ));
    }

    #[test]
    fn negative_load_is_rejected() {
        let text = GOOD.replace("0.2,3130,", "0.2,-5,");
        let err = parse(&text).unwrap_err();
        assert_eq!(err.location.line, Some(4));
        assert!(
            err.to_string().contains("wheel load must not be negative"),
            "{err}"
        );
    }

    #[test]
    fn pressure_below_vacuum_is_rejected() {
        let text = GOOD.replace(",350.2\n", ",-350.2\n");
        let err = parse(&text).unwrap_err();
        assert!(
            err.to_string()
                .contains("bellow pressure -350.2 is below absolute vacuum"),
            "{err}"
        );
    }

    #[test]
    fn inputs_only_file_reads_when_outputs_are_optional() {
        let text = "time_s,wheel_load_kg,valve,supply_kpa\n0,2830,0,850\n0.1,2830,0,850\n";
        let run = parse_run(text.as_bytes(), Path::new("s.csv"), Outputs::IfPresent).unwrap();
        assert!(run.outputs.is_none());
        assert!(run.measured().is_err());
        assert!(parse_run(text.as_bytes(), Path::new("s.csv"), Outputs::Required).is_err());
    }

    #[test]
    fn write_then_read_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ds1.csv");
        let run = parse(GOOD).unwrap();
        write_run(&path, &run).unwrap();
        let back = read_run(&path).unwrap();
        assert_eq!(back.time_s, run.time_s);
        assert_eq!(back.inputs.valve, run.inputs.valve);
        assert_eq!(back.inputs.wheel_load_kg, run.inputs.wheel_load_kg);
        for (a, b) in back
            .inputs
            .supply_gauge_pa
            .iter()
            .zip(&run.inputs.supply_gauge_pa)
        {
            assert!((a - b).abs() <= 1e-9 * b.abs());
        }
        let (o1, o2) = (back.outputs.unwrap(), run.outputs.unwrap());
        for (a, b) in o1.sensor_height_m.iter().zip(&o2.sensor_height_m) {
            assert!((a - b).abs() <= 1e-15);
        }
    }
}
