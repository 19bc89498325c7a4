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
    /// The spellings each quantity accepts (matched exactly, after spaces and a gauge marker
    /// are removed), with their factor onto the contract unit. Case matters where it carries
    /// meaning: `MPa` is not `mPa`. Gauge pressures only: a log in absolute pressure would
    /// need the day's ambient pressure, which a run does not carry, so `bar(a)`-style units
    /// are refused rather than guessed.
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
            Quantity::Mass => &[
                ("kg", 1.0),
                ("Kg", 1.0),
                ("KG", 1.0),
                ("g", 1e-3),
                ("t", 1e3),
            ],
            Quantity::Code => &[("", 1.0), ("-", 1.0), ("1", 1.0), ("state", 1.0)],
            Quantity::GaugePressure => &[
                ("kPa", 1.0),
                ("kpa", 1.0),
                ("KPa", 1.0),
                ("KPA", 1.0),
                ("Pa", 1e-3),
                ("pa", 1e-3),
                ("hPa", 0.1),
                ("MPa", 1e3),
                ("MPA", 1e3),
                ("bar", 100.0),
                ("Bar", 100.0),
                ("BAR", 100.0),
                ("mbar", 0.1),
                ("mBar", 0.1),
                ("psi", 6.894_757_293_168),
                ("PSI", 6.894_757_293_168),
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

    /// The conversion from `unit` as a log spells it onto the contract unit, or the accepted
    /// spellings when it is unknown.
    pub fn conversion(self, unit: &str) -> Result<UnitConversion, Vec<String>> {
        let compact: String = unit.chars().filter(|c| !c.is_whitespace()).collect();
        let key = if self == Quantity::GaugePressure {
            strip_gauge_marker(&compact)
        } else {
            compact.as_str()
        };
        self.table()
            .iter()
            .find(|(name, _)| *name == key)
            .map(|&(_, scale)| UnitConversion { scale, offset: 0.0 })
            .ok_or_else(|| {
                // One spelling per unit (the first), not every case variant.
                let mut shown: Vec<String> = Vec::new();
                for &(name, _) in self.table() {
                    let name = if name.is_empty() { "(none)" } else { name };
                    if !shown.iter().any(|s| s.eq_ignore_ascii_case(name)) {
                        shown.push(name.to_owned());
                    }
                }
                shown
            })
    }
}

/// `kPa(g)`, `kPag`, `barg`, `bar gauge` (spaces already removed) → the pressure unit.
/// `bar(a)` and `kPaabs` stay as they are, and are refused.
fn strip_gauge_marker(unit: &str) -> &str {
    for marker in ["(g)", "(G)", "gauge", "Gauge", "g"] {
        if let Some(base) = unit.strip_suffix(marker)
            && !base.is_empty()
        {
            return base;
        }
    }
    unit
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
        assert_eq!(kpa("kPa(g)"), 1.0);
        assert_eq!(kpa("Pa"), 1e-3);
        assert_eq!(kpa("MPa"), 1e3);
        assert_eq!(kpa("bar g"), 100.0);
        assert_eq!(kpa("kPa g"), 1.0);
        assert_eq!(kpa("psig"), 6.894_757_293_168);
        assert!(Quantity::GaugePressure.conversion("bar(a)").is_err());
        assert!(Quantity::GaugePressure.conversion("degC").is_err());
        // Milli is not mega.
        assert!(Quantity::GaugePressure.conversion("mPa").is_err());
        assert!(Quantity::Time.conversion("Ms").is_err());
        assert!(Quantity::Length.conversion("Mm").is_err());
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
