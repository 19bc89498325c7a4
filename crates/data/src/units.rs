//! Unit conversions between the file units of the data contract and the SI units held inside.

pub const PA_PER_KPA: f64 = 1000.0;
/// Standard atmosphere, kPa; used only to sanity-check gauge pressures in files.
pub const STANDARD_ATMOSPHERE_KPA: f64 = 101.325;
pub const M3_PER_L: f64 = 1e-3;

pub fn m_from_mm(mm: f64) -> f64 {
    mm * 1e-3
}

pub fn mm_from_m(m: f64) -> f64 {
    m * 1e3
}

/// A unit a log gives a channel, as a factor and offset onto the contract's file unit:
/// `contract = scale * value + offset`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnitConversion {
    pub scale: f64,
    pub offset: f64,
}

impl UnitConversion {
    pub const IDENTITY: Self = Self {
        scale: 1.0,
        offset: 0.0,
    };

    pub fn apply(self, values: &mut [f64]) {
        if self != Self::IDENTITY {
            for v in values {
                *v = self.scale * *v + self.offset;
            }
        }
    }
}

/// The quantity a contract column holds, which decides the units it accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// Seconds.
    Time,
    /// Kilograms.
    Mass,
    /// A state code without unit (the valve).
    Code,
    /// Kilopascal gauge.
    GaugePressure,
    /// Millimetres.
    Length,
}

impl Quantity {
    /// The spellings each quantity accepts, with their factor onto the contract unit. Gauge
    /// pressures only: a log in absolute pressure would need the day's ambient pressure,
    /// which a run does not carry, so `bar(a)`-style units are refused rather than guessed.
    fn table(self) -> &'static [(&'static str, f64)] {
        match self {
            Quantity::Time => &[
                ("s", 1.0),
                ("sec", 1.0),
                ("ms", 1e-3),
                ("us", 1e-6),
                ("µs", 1e-6),
                ("ns", 1e-9),
                ("min", 60.0),
                ("h", 3600.0),
            ],
            Quantity::Mass => &[("kg", 1.0), ("g", 1e-3), ("t", 1e3)],
            Quantity::Code => &[("", 1.0), ("-", 1.0), ("1", 1.0), ("state", 1.0)],
            Quantity::GaugePressure => &[
                ("kpa", 1.0),
                ("pa", 1e-3),
                ("hpa", 0.1),
                ("mpa", 1e3),
                ("bar", 100.0),
                ("mbar", 0.1),
                ("psi", 6.894_757_293_168),
            ],
            Quantity::Length => &[
                ("mm", 1.0),
                ("cm", 10.0),
                ("m", 1e3),
                ("um", 1e-3),
                ("µm", 1e-3),
            ],
        }
    }

    /// The unit the contract's column is written in.
    pub fn contract_unit(self) -> &'static str {
        match self {
            Quantity::Time => "s",
            Quantity::Mass => "kg",
            Quantity::Code => "",
            Quantity::GaugePressure => "kPa",
            Quantity::Length => "mm",
        }
    }

    /// The conversion from `unit` (as a log spells it: case, spaces and a `(g)`/`gauge`
    /// marker are ignored) onto the contract unit, or the accepted spellings when unknown.
    pub fn conversion(self, unit: &str) -> Result<UnitConversion, Vec<String>> {
        let key = normalise_unit(unit);
        self.table()
            .iter()
            .find(|(name, _)| *name == key)
            .map(|&(_, scale)| UnitConversion { scale, offset: 0.0 })
            .ok_or_else(|| {
                self.table()
                    .iter()
                    .map(|(n, _)| {
                        if n.is_empty() {
                            "(none)".to_owned()
                        } else {
                            (*n).to_owned()
                        }
                    })
                    .collect()
            })
    }
}

/// `" kPa (g) "` → `"kpa"`, `"bar gauge"` → `"bar"`; `"bar(a)"` stays unknown.
fn normalise_unit(unit: &str) -> String {
    let lower = unit.trim().to_lowercase();
    let stripped = lower
        .trim_end_matches("(g)")
        .trim_end_matches("gauge")
        .trim_end_matches('g')
        .trim();
    // Only a trailing `g` after a pressure unit is a gauge marker (`barg`, `kpag`), never the
    // gram: `g` alone, `kg` and `mg` keep theirs.
    let stripped = if ["barg", "kpag", "mbarg", "pag", "psig", "hpag", "mpag"]
        .contains(&lower.as_str())
        || lower.ends_with("(g)")
        || lower.ends_with("gauge")
    {
        stripped
    } else {
        lower.as_str()
    };
    stripped.replace(' ', "")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pressure_units_reach_kpa_gauge() {
        let kpa = |u| Quantity::GaugePressure.conversion(u).unwrap().scale;
        assert_eq!(kpa("kPa"), 1.0);
        assert_eq!(kpa("bar"), 100.0);
        assert_eq!(kpa(" barg "), 100.0);
        assert_eq!(kpa("kPa (g)"), 1.0);
        assert_eq!(kpa("Pa"), 1e-3);
        assert_eq!(kpa("MPa"), 1e3);
        assert!(Quantity::GaugePressure.conversion("bar(a)").is_err());
        assert!(Quantity::GaugePressure.conversion("degC").is_err());
    }

    #[test]
    fn gram_is_not_a_gauge_marker() {
        assert_eq!(Quantity::Mass.conversion("kg").unwrap().scale, 1.0);
        assert_eq!(Quantity::Mass.conversion("g").unwrap().scale, 1e-3);
        assert_eq!(Quantity::Mass.conversion("t").unwrap().scale, 1e3);
        assert_eq!(Quantity::Length.conversion("m").unwrap().scale, 1e3);
        assert_eq!(Quantity::Time.conversion("ms").unwrap().scale, 1e-3);
        let expected = Quantity::Length.conversion("inch").unwrap_err();
        assert!(expected.contains(&"mm".to_owned()), "{expected:?}");
    }
}
