//! Where a run's columns come from in a log that was not written for airsus: a channel name
//! and unit per contract column, and whether (and how) to resample channels recorded on
//! different or irregular time bases. The same description serves every format (CSV, ASAM
//! MDF4, Parquet, CAN through a DBC); the `[run.columns]` table of a study file and the CLI's
//! `--columns`, `--resample`, `--sample-s` and `--dbc` fill it.

use std::fmt;
use std::path::PathBuf;

use crate::error::nearest_name;
use crate::run::columns;
use crate::units::Quantity;

/// The contract's run columns (SPEC §5) with the quantity each holds.
pub const RUN_COLUMNS: [(&str, Quantity); 7] = [
    (columns::TIME, Quantity::Time),
    (columns::WHEEL_LOAD, Quantity::Mass),
    (columns::VALVE, Quantity::Code),
    (columns::SUPPLY, Quantity::GaugePressure),
    (columns::ROAD, Quantity::Length),
    (columns::HEIGHT, Quantity::Length),
    (columns::PRESSURE, Quantity::GaugePressure),
];

/// The quantity of contract column `column`, if it is one.
pub fn column_quantity(column: &str) -> Option<Quantity> {
    RUN_COLUMNS
        .iter()
        .find(|(name, _)| *name == column)
        .map(|&(_, q)| q)
}

/// The channel of a log that feeds one contract column.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelRef {
    pub channel: String,
    /// The channel's unit when the log does not say (or to check what it says).
    pub unit: Option<String>,
}

/// Contract column → log channel. A column without an entry is read from the channel of its
/// own name (`height_mm`), in the contract's unit unless the log gives one.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ColumnMap {
    entries: Vec<(&'static str, ChannelRef)>,
}

impl ColumnMap {
    /// Maps `column` (a contract name; a misspelling is refused with the nearest name).
    pub fn insert(&mut self, column: &str, channel: ChannelRef) -> Result<(), String> {
        let Some(&(name, _)) = RUN_COLUMNS.iter().find(|(n, _)| *n == column) else {
            let suggestion = nearest_name(column, RUN_COLUMNS.iter().map(|(n, _)| *n))
                .map(|s| format!(" (did you mean `{s}`?)"))
                .unwrap_or_default();
            return Err(format!(
                "`{column}` is not a run column{suggestion}; the columns are {}",
                RUN_COLUMNS.map(|(n, _)| n).join(", ")
            ));
        };
        if channel.channel.trim().is_empty() {
            return Err(format!(
                "column `{column}` is mapped to an empty channel name"
            ));
        }
        self.entries.retain(|(n, _)| *n != name);
        self.entries.push((name, channel));
        Ok(())
    }

    /// The entry for `column`, if mapped.
    pub fn get(&self, column: &str) -> Option<&ChannelRef> {
        self.entries
            .iter()
            .find(|(n, _)| *n == column)
            .map(|(_, c)| c)
    }

    /// The channel name that feeds `column` (its own name when unmapped).
    pub fn channel_for<'a>(&'a self, column: &'a str) -> &'a str {
        self.get(column).map_or(column, |c| c.channel.as_str())
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    pub fn iter(&self) -> impl Iterator<Item = (&'static str, &ChannelRef)> {
        self.entries.iter().map(|(n, c)| (*n, c))
    }

    /// Parses the CLI form: `height_mm=AxleHeight,pressure_kpa=BellowP[bar]` (a unit in
    /// brackets after the channel name is optional).
    pub fn parse_list(text: &str) -> Result<Self, String> {
        let mut map = Self::default();
        for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let Some((column, channel)) = item.split_once('=') else {
                return Err(format!(
                    "`{item}`: expected COLUMN=CHANNEL or COLUMN=CHANNEL[unit], e.g. pressure_kpa=BellowP[bar]"
                ));
            };
            let (column, channel) = (column.trim(), channel.trim());
            // `Name[unit]` when the brackets hold a unit of the column's quantity; otherwise
            // the brackets belong to the channel's name (`Signal[0]`, an array element).
            let (name, unit) = match channel.strip_suffix(']').and_then(|c| c.rsplit_once('[')) {
                Some((name, unit))
                    if column_quantity(column)
                        .is_some_and(|q| q.conversion(unit.trim()).is_ok()) =>
                {
                    (name.trim(), Some(unit.trim().to_owned()))
                }
                _ => (channel, None),
            };
            map.insert(
                column.trim(),
                ChannelRef {
                    channel: name.to_owned(),
                    unit,
                },
            )?;
        }
        Ok(map)
    }
}

impl fmt::Display for ColumnMap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, (column, c)) in self.entries.iter().enumerate() {
            if i > 0 {
                f.write_str(",")?;
            }
            write!(f, "{column}={}", c.channel)?;
            if let Some(unit) = &c.unit {
                write!(f, "[{unit}]")?;
            }
        }
        Ok(())
    }
}

/// How channels are brought onto one uniform time base when asked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ResampleMethod {
    /// Zero-order hold: each sample holds until the next (right for states such as the valve).
    Zoh,
    /// Linear interpolation between samples (continuous signals). The valve is always held.
    Linear,
}

impl ResampleMethod {
    pub fn as_str(self) -> &'static str {
        match self {
            ResampleMethod::Zoh => "zoh",
            ResampleMethod::Linear => "linear",
        }
    }
}

impl std::str::FromStr for ResampleMethod {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "zoh" => Ok(Self::Zoh),
            "linear" => Ok(Self::Linear),
            _ => Err(format!("`{s}`: expected `zoh` or `linear`")),
        }
    }
}

/// A request to resample every channel onto `sample_s` steps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resample {
    pub method: ResampleMethod,
    pub sample_s: f64,
}

impl Resample {
    /// The request from its two settings, given together or not at all (a study's `resample`
    /// and `sample_s`, the CLI's `--resample` and `--sample-s`, Python's keywords).
    pub fn from_parts(
        method: Option<ResampleMethod>,
        sample_s: Option<f64>,
    ) -> Result<Option<Self>, String> {
        match (method, sample_s) {
            (None, None) => Ok(None),
            (Some(method), Some(sample_s)) => Self::new(method, sample_s).map(Some),
            (Some(_), None) => {
                Err("`resample` needs `sample_s`, the sample time to resample onto".to_owned())
            }
            (None, Some(_)) => {
                Err("`sample_s` needs `resample = \"zoh\"` or `\"linear\"`".to_owned())
            }
        }
    }

    pub fn new(method: ResampleMethod, sample_s: f64) -> Result<Self, String> {
        if !(sample_s.is_finite() && sample_s > 0.0) {
            return Err(format!(
                "sample_s = {sample_s}: expected a positive sample time in seconds"
            ));
        }
        Ok(Self { method, sample_s })
    }
}

/// Everything needed to read a run out of a log besides the file itself.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunSource {
    pub columns: ColumnMap,
    /// `None`: never resample; channels must share one uniform time base.
    pub resample: Option<Resample>,
    /// The CAN database that decodes bus-logging MDF4 files and CAN logs.
    pub dbc: Option<PathBuf>,
    /// The wheel-load column may be absent (weighing estimates the load, and a truck's own
    /// logs have none): it is then read as zeros and a note says so. Off by default: a model
    /// needs the load as an input.
    pub load_optional: bool,
}

impl RunSource {
    /// Whether the source is the contract's own: no mapping, no resampling, no CAN.
    pub fn is_plain(&self) -> bool {
        self.columns.is_empty()
            && self.resample.is_none()
            && self.dbc.is_none()
            && !self.load_optional
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cli_list_parses_names_and_units() {
        let map = ColumnMap::parse_list("height_mm=AxleH, pressure_kpa = BellowP[bar]").unwrap();
        assert_eq!(map.channel_for("height_mm"), "AxleH");
        assert_eq!(map.get("height_mm").unwrap().unit, None);
        assert_eq!(
            map.get("pressure_kpa").unwrap().unit.as_deref(),
            Some("bar")
        );
        assert_eq!(map.channel_for("valve"), "valve");
        assert_eq!(map.to_string(), "height_mm=AxleH,pressure_kpa=BellowP[bar]");
        assert_eq!(ColumnMap::parse_list(&map.to_string()).unwrap(), map);
        // Brackets that hold no unit of the column belong to the channel's name.
        let map = ColumnMap::parse_list("height_mm=Height[0]").unwrap();
        assert_eq!(map.channel_for("height_mm"), "Height[0]");
        assert_eq!(map.get("height_mm").unwrap().unit, None);
    }

    #[test]
    fn a_misspelt_column_is_refused_with_the_nearest_name() {
        let err = ColumnMap::parse_list("hieght_mm=X").unwrap_err();
        assert!(err.contains("did you mean `height_mm`"), "{err}");
        assert!(ColumnMap::parse_list("height_mm").is_err());
        assert!(ColumnMap::parse_list("height_mm=").is_err());
    }

    #[test]
    fn resample_needs_a_positive_step() {
        assert!(Resample::new(ResampleMethod::Zoh, 0.0).is_err());
        assert_eq!(Resample::from_parts(None, None), Ok(None));
        assert!(Resample::from_parts(Some(ResampleMethod::Zoh), None).is_err());
        assert!(Resample::from_parts(None, Some(0.1)).is_err());
        assert!(Resample::new(ResampleMethod::Linear, f64::NAN).is_err());
        assert_eq!(
            "linear".parse::<ResampleMethod>(),
            Ok(ResampleMethod::Linear)
        );
        assert!("cubic".parse::<ResampleMethod>().is_err());
    }
}
