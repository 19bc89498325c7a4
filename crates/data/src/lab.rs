//! Lab data: the bellow force map (thesis 5.2.2, Fig 5.8) and tank discharges (thesis 5.2.3).

use std::io::Write;
use std::path::Path;

use crate::atomic::write_atomically;
use crate::error::{DataError, DataErrorKind, Location};
use crate::run::{check_above_vacuum, check_non_negative};
use crate::table::{ColumnSpec, parse_table};
use crate::time_axis::check_time_axis;
use crate::units::{PA_PER_KPA, m_from_mm, mm_from_m};

/// Bellow force measured in a vertical lab test at several heights and pressures.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ForceMap {
    pub bellow_height_m: Vec<f64>,
    pub bellow_gauge_pa: Vec<f64>,
    pub force_n: Vec<f64>,
}

impl ForceMap {
    pub fn len(&self) -> usize {
        self.force_n.len()
    }

    pub fn is_empty(&self) -> bool {
        self.force_n.is_empty()
    }
}

pub mod force_map_columns {
    pub const HEIGHT: &str = "bellow_height_mm";
    pub const PRESSURE: &str = "pressure_kpa";
    pub const FORCE: &str = "force_n";
}

pub fn read_force_map(path: &Path) -> Result<ForceMap, DataError> {
    let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
    parse_force_map(&bytes, path)
}

pub fn parse_force_map(bytes: &[u8], path: &Path) -> Result<ForceMap, DataError> {
    use force_map_columns::*;
    let table = parse_table(
        bytes,
        path,
        &[
            ColumnSpec::required(HEIGHT),
            ColumnSpec::required(PRESSURE),
            ColumnSpec::required(FORCE),
        ],
    )?;
    if table.rows() < 5 {
        return Err(DataError::in_file(
            path,
            DataErrorKind::TooFewRows {
                needed: 5,
                found: table.rows(),
            },
        ));
    }
    check_non_negative(&table, 0, path, "bellow height")?;
    check_above_vacuum(&table, 1, path, "bellow pressure")?;
    Ok(ForceMap {
        bellow_height_m: table.columns[0].iter().copied().map(m_from_mm).collect(),
        bellow_gauge_pa: table.columns[1].iter().map(|p| p * PA_PER_KPA).collect(),
        force_n: table.columns[2].clone(),
    })
}

pub fn write_force_map(path: &Path, map: &ForceMap) -> Result<(), DataError> {
    use force_map_columns::*;
    write_atomically(path, |w: &mut dyn Write| {
        writeln!(w, "{HEIGHT},{PRESSURE},{FORCE}")?;
        for i in 0..map.len() {
            writeln!(
                w,
                "{},{},{}",
                mm_from_m(map.bellow_height_m[i]),
                map.bellow_gauge_pa[i] / PA_PER_KPA,
                map.force_n[i]
            )?;
        }
        Ok(())
    })
}

/// A tank emptied to ambient through one valve channel; channel, volume and temperature come
/// from the study file.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TankDischarge {
    pub time_s: Vec<f64>,
    pub sample_time_s: f64,
    pub tank_gauge_pa: Vec<f64>,
}

pub mod discharge_columns {
    pub const TIME: &str = "time_s";
    pub const TANK: &str = "tank_kpa";
}

pub fn read_discharge(path: &Path) -> Result<TankDischarge, DataError> {
    let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
    parse_discharge(&bytes, path)
}

pub fn parse_discharge(bytes: &[u8], path: &Path) -> Result<TankDischarge, DataError> {
    use discharge_columns::*;
    let table = parse_table(
        bytes,
        path,
        &[ColumnSpec::required(TIME), ColumnSpec::required(TANK)],
    )?;
    // A numerical derivative needs a few samples either side of every point.
    let sample_time_s = check_time_axis(&table, 0, path, 5)?;
    check_above_vacuum(&table, 1, path, "tank pressure")?;
    Ok(TankDischarge {
        time_s: table.columns[0].clone(),
        sample_time_s,
        tank_gauge_pa: table.columns[1].iter().map(|p| p * PA_PER_KPA).collect(),
    })
}

pub fn write_discharge(path: &Path, discharge: &TankDischarge) -> Result<(), DataError> {
    use discharge_columns::*;
    if discharge.time_s.len() != discharge.tank_gauge_pa.len() {
        return Err(DataError::new(
            Location::file(path),
            DataErrorKind::InvalidValue {
                key: "discharge".to_owned(),
                value: format!(
                    "{} times, {} pressures",
                    discharge.time_s.len(),
                    discharge.tank_gauge_pa.len()
                ),
                reason: "signals of different lengths cannot be written".to_owned(),
            },
        ));
    }
    write_atomically(path, |w: &mut dyn Write| {
        writeln!(w, "{TIME},{TANK}")?;
        for (t, p) in discharge.time_s.iter().zip(&discharge.tank_gauge_pa) {
            writeln!(w, "{},{}", t, p / PA_PER_KPA)?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn force_map_reads_in_si_and_round_trips() {
        let text = "force_n,bellow_height_mm,pressure_kpa\n\
            5000,250,100\n10000,250,200\n5200,300,100\n10400,300,200\n15600,300,300\n";
        let map = parse_force_map(text.as_bytes(), Path::new("f.csv")).unwrap();
        assert_eq!(map.len(), 5);
        assert!((map.bellow_height_m[2] - 0.3).abs() < 1e-15);
        assert_eq!(map.bellow_gauge_pa[4], 300_000.0);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.csv");
        write_force_map(&path, &map).unwrap();
        assert_eq!(read_force_map(&path).unwrap(), map);
    }

    #[test]
    fn force_map_needs_enough_points() {
        let text = "bellow_height_mm,pressure_kpa,force_n\n250,100,5000\n";
        let err = parse_force_map(text.as_bytes(), Path::new("f.csv")).unwrap_err();
        assert!(matches!(
            err.kind,
            DataErrorKind::TooFewRows {
                needed: 5,
                found: 1
            }
        ));
    }

    #[test]
    fn negative_bellow_height_is_rejected() {
        let text = "bellow_height_mm,pressure_kpa,force_n\n250,100,1\n250,100,1\n-3,100,1\n250,100,1\n250,100,1\n";
        let err = parse_force_map(text.as_bytes(), Path::new("f.csv")).unwrap_err();
        assert_eq!(err.location.line, Some(4));
    }

    #[test]
    fn discharge_reads_and_checks_time() {
        let text = "time_s,tank_kpa\n0,800\n0.1,700\n0.2,610\n0.3,530\n0.4,460\n";
        let d = parse_discharge(text.as_bytes(), Path::new("d.csv")).unwrap();
        assert_eq!(d.tank_gauge_pa[1], 700_000.0);
        let text = "time_s,tank_kpa\n0,800\n0.1,700\n0.1,610\n0.3,530\n0.4,460\n";
        let err = parse_discharge(text.as_bytes(), Path::new("d.csv")).unwrap_err();
        assert!(matches!(err.kind, DataErrorKind::TimeNotIncreasing { .. }));
    }
}
