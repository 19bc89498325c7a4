//! Submodel laws as values: the effective area of the bellow, the volume of its gas and the
//! flow through the valve. A law is a value that carries its own parameters, evaluates itself,
//! names its parameters (through [`crate::params::Field`]) and reads and writes its part of a
//! truck file.
//!
//! A law lives here, in the data crate, because it is part of the file contract: the truck
//! file names the law and holds its parameters. The models in `airsus-model` evaluate laws
//! through these values and never look at their shape.
//!
//! In a truck file a law is a *tagged table*:
//!
//! ```toml
//! [bellow.effective_area]
//! law = "polynomial_pressure"          # A_eff(h) (1 + κ p / 100 kPa)
//! coefficients_m2 = [-0.0289, 0.8362, -3.0698, 4.9616, -2.9941]
//! growth_per_100kpa = 0.004
//!
//! [valve]
//! law = "orifice"                      # ISO 6358-1
//! fill_conductance_m3_s_pa = 5e-9
//! exhaust_conductance_m3_s_pa = 1.2e-8
//! critical_pressure_ratio = 0.4
//! ```
//!
//! The thesis' laws also load, and are written, in the SPEC §5 form (plain arrays
//! `effective_area_poly_m2`, `cross_section_m2` and the `[valve]` resistances without a `law`
//! key), so every file written before laws were values still loads unchanged, and files of the
//! thesis' structure stay exactly as the SPEC shows them.
//!
//! Adding a law: a variant in its family's file here (its parameters, evaluation, tag and
//! keys), its parameters' declarations in [`crate::params::CATALOG`], and its fit in
//! `airsus-estimate`. The models, the reader, the writer and the estimator pick it up, as
//! long as the law keeps its family's shape.

mod area;
mod spline;
mod valve;
mod volume;

pub use area::{
    EFFECTIVE_AREA_RANGE_M, EffectiveAreaLaw, polynomial_area_m2, polynomial_area_slope_m,
};
pub use spline::{MonotoneSpline, SplineError};
pub use valve::{
    AIR_MOLAR_MASS_KG_MOL, ISO6358_REFERENCE_DENSITY_KG_M3, ISO6358_REFERENCE_TEMPERATURE_K,
    LAMINAR_PRESSURE_RATIO, VALVE_CHANNELS, ValveFlowLaw, iso6358_molar_flow,
};
pub use volume::{DEFAULT_BELLOWS, GasVolumeLaw, MIN_VOLUME_M3, VOLUME_SCALES};

use std::path::Path;

use crate::error::{DataError, DataErrorKind, Location};
use crate::params::Field;
use crate::toml_file::find_key_line;

/// The submodel a law serves: the laws of one family replace each other.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LawFamily {
    EffectiveArea,
    GasVolume,
    ValveFlow,
}

/// One law of a family as a truck file names it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LawDeclaration {
    /// The `law = ".."` tag.
    pub tag: &'static str,
    /// What it is, with its source.
    pub description: &'static str,
    /// The keys of its tagged table, `law` included.
    pub keys: &'static [&'static str],
}

/// Reads one tagged table (or the SPEC's untagged form of a thesis law), locating every
/// error in the file.
pub(crate) struct LawTable<'a> {
    pub section: &'a str,
    pub table: &'a toml::Table,
    pub text: &'a str,
    pub path: &'a Path,
}

impl LawTable<'_> {
    fn location(&self, key: &str) -> Location {
        let mut loc = Location::file(self.path);
        if let Some(line) = find_key_line(self.text, self.section, key) {
            loc = loc.line(line);
        }
        loc
    }

    pub fn invalid(&self, key: &str, value: impl ToString, reason: String) -> DataError {
        DataError::new(
            self.location(key),
            DataErrorKind::InvalidValue {
                key: format!("{}.{key}", self.section),
                value: value.to_string(),
                reason,
            },
        )
    }

    /// The `law` tag; `None` when the table has none (the SPEC form).
    pub fn tag(&self) -> Result<Option<&str>, DataError> {
        match self.table.get("law") {
            None => Ok(None),
            Some(toml::Value::String(s)) => Ok(Some(s.as_str())),
            Some(other) => Err(self.invalid(
                "law",
                other,
                "expected the law's name as a string".to_owned(),
            )),
        }
    }

    /// The law declared by `tag` among `laws`, or an error listing them.
    pub fn declaration<'l>(
        &self,
        tag: &str,
        laws: &'l [LawDeclaration],
    ) -> Result<&'l LawDeclaration, DataError> {
        laws.iter().find(|l| l.tag == tag).ok_or_else(|| {
            let names: Vec<String> = laws
                .iter()
                .map(|l| format!("`{}` ({})", l.tag, l.description))
                .collect();
            self.invalid(
                "law",
                format!("\"{tag}\""),
                format!("unknown law; the laws are {}", names.join(", ")),
            )
        })
    }

    /// Every key of the table must be one of `keys` (the law's own).
    pub fn check_keys(&self, keys: &'static [&'static str], law: &str) -> Result<(), DataError> {
        for key in self.table.keys() {
            if !keys.contains(&key.as_str()) {
                return Err(DataError::new(
                    self.location(key),
                    DataErrorKind::UnknownKey {
                        key: format!("{}.{key} (law \"{law}\")", self.section),
                        suggestion: crate::error::nearest_name(key, keys.iter().copied()),
                        valid: keys.iter().map(|k| (*k).to_owned()).collect(),
                    },
                ));
            }
        }
        Ok(())
    }

    /// A number the table may leave out (not range-checked here).
    pub fn optional_number(&self, key: &str) -> Result<Option<f64>, DataError> {
        match self.table.get(key) {
            None => Ok(None),
            Some(toml::Value::Float(f)) => Ok(Some(*f)),
            Some(toml::Value::Integer(i)) => Ok(Some(*i as f64)),
            Some(other) => Err(self.invalid(key, other, "expected a number".to_owned())),
        }
    }

    /// A number the law needs, checked against the declared range of `field`.
    pub fn number(&self, key: &str, field: Field) -> Result<f64, DataError> {
        let value = match self.table.get(key) {
            Some(toml::Value::Float(f)) => *f,
            Some(toml::Value::Integer(i)) => *i as f64,
            Some(other) => {
                return Err(self.invalid(key, other, "expected a number".to_owned()));
            }
            None => {
                return Err(DataError::new(
                    self.location(self.section),
                    DataErrorKind::MissingKey {
                        key: format!("{}.{key}", self.section),
                        expected: format!("a number in {}", field.param().info.unit),
                    },
                ));
            }
        };
        self.check(key, None, field, value)
    }

    /// An array of exactly `N` numbers, each checked against its field's range.
    pub fn array<const N: usize>(
        &self,
        key: &str,
        field: impl Fn(usize) -> Field,
    ) -> Result<[f64; N], DataError> {
        let values = self.numbers(key, &format!("an array of {N} numbers"), N..=N, |i| {
            Some(field(i))
        })?;
        values.try_into().map_err(|v: Vec<f64>| {
            self.invalid(
                key,
                format!("[{} values]", v.len()),
                format!("expected exactly {N} values"),
            )
        })
    }

    /// An array of 1 to `max` numbers, each checked against its field's range where
    /// `field(i)` names one.
    pub fn vector(
        &self,
        key: &str,
        max: usize,
        field: impl Fn(usize) -> Option<Field>,
    ) -> Result<Vec<f64>, DataError> {
        self.numbers(
            key,
            &format!("an array of 1 to {max} numbers"),
            1..=max,
            field,
        )
    }

    /// The numbers of the array `key` (`expected` says what it should be), each checked
    /// against its field's range where `field(i)` names one. An array whose length is outside
    /// `lengths` is refused, except that [`Self::array`] reports a wrong length itself.
    fn numbers(
        &self,
        key: &str,
        expected: &str,
        lengths: std::ops::RangeInclusive<usize>,
        field: impl Fn(usize) -> Option<Field>,
    ) -> Result<Vec<f64>, DataError> {
        let Some(value) = self.table.get(key) else {
            return Err(DataError::new(
                self.location(self.section),
                DataErrorKind::MissingKey {
                    key: format!("{}.{key}", self.section),
                    expected: expected.to_owned(),
                },
            ));
        };
        let items = value
            .as_array()
            .ok_or_else(|| self.invalid(key, value, format!("expected {expected}")))?;
        if !lengths.contains(&items.len()) {
            return Err(self.invalid(
                key,
                format!("[{} values]", items.len()),
                format!("expected {expected}"),
            ));
        }
        let mut out = Vec::with_capacity(items.len());
        for (i, item) in items.iter().enumerate() {
            let v = match item {
                toml::Value::Float(f) => *f,
                toml::Value::Integer(n) => *n as f64,
                other => {
                    return Err(self.invalid(key, other, format!("entry {i} is not a number")));
                }
            };
            out.push(match field(i) {
                Some(field) => self.check(key, Some(i), field, v)?,
                None => v,
            });
        }
        Ok(out)
    }

    fn check(
        &self,
        key: &str,
        index: Option<usize>,
        field: Field,
        value: f64,
    ) -> Result<f64, DataError> {
        check_declared(self.location(key), self.section, key, index, field, value)
    }
}

/// `value` against the declared range of `field` ([`crate::params`]), written at
/// `section.key[index]`; the error names the key, the value and the range.
pub(crate) fn check_declared(
    location: Location,
    section: &str,
    key: &str,
    index: Option<usize>,
    field: Field,
    value: f64,
) -> Result<f64, DataError> {
    let info = &field.param().info;
    if info.admits(value) {
        return Ok(value);
    }
    let shown = match index {
        Some(i) => format!("{key}[{i}]"),
        None => key.to_owned(),
    };
    Err(DataError::new(
        location,
        DataErrorKind::InvalidValue {
            key: format!("{section}.{shown}"),
            value: value.to_string(),
            reason: format!(
                "outside the admissible range of `{}` ({}), {} to {} {}; check the unit",
                info.name, info.description, info.lower, info.upper, info.unit
            ),
        },
    ))
}

/// A tagged table as text: `law = ".."` then its entries, `(key, value, comment)`.
pub(crate) type TaggedEntries = Vec<(&'static str, String, &'static str)>;

/// `{:?}` on f64 is Rust's shortest round-trip form and always a valid TOML float.
pub(crate) fn toml_number(v: f64) -> String {
    format!("{v:?}")
}
