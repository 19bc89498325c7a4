//! Effective-area laws of the bellow: `F_ab = p_g A_eff` (thesis eq 3.16).

use super::{LawDeclaration, LawTable, TaggedEntries, toml_number};
use crate::error::DataError;
use crate::params::Field;

/// Effective area `A_eff(h) = p0 + p1 h + p2 h² + p3 h³ + p4 h⁴`, m² (thesis eq 5.4), `h` the
/// bellow height in m, `poly = [p0, p1, p2, p3, p4]`.
///
/// Thesis Table 5.2 prints `p1 = 0.08362`; the correct value is `0.8362` (SPEC §2), which gives
/// 0.050–0.056 m² over the 0.2–0.45 m stroke. The polynomial was fitted over the lab stroke
/// only; outside it, it is an extrapolation (it turns negative below about 0.04 m and above
/// about 0.75 m).
pub fn polynomial_area_m2(poly: &[f64; 5], height_m: f64) -> f64 {
    // Horner's scheme: four multiply-adds.
    poly.iter().rev().fold(0.0, |acc, p| acc * height_m + p)
}

/// `dA_eff/dh`, m (derivative of eq 5.4), for stiffness and equilibrium checks.
pub fn polynomial_area_slope_m(poly: &[f64; 5], height_m: f64) -> f64 {
    let h = height_m;
    poly[1] + h * (2.0 * poly[2] + h * (3.0 * poly[3] + h * 4.0 * poly[4]))
}

/// Heights between which the full models trust an effective-area law, m: the lab stroke
/// (0.2–0.45 m, thesis Fig 5.8) widened by 0.15 m on each side.
pub const EFFECTIVE_AREA_RANGE_M: (f64, f64) = (0.05, 0.60);

/// The effective area of the bellow as a function of its height (and, for some laws, its
/// gauge pressure).
#[derive(Debug, Clone, PartialEq)]
pub enum EffectiveAreaLaw {
    /// The thesis' quartic in height (eq 5.4), `p0`..`p4`.
    Polynomial { coefficients_m2: [f64; 5] },
    /// The quartic stretched by the gauge pressure, `A_eff(h) (1 + κ p_g / 100 kPa)`: the
    /// rubber wall stretching, thesis 6.1's explanation of Fig 5.7 (the force map's lines of
    /// constant pressure are not parallel). `κ` is `kap`.
    PressurePolynomial {
        coefficients_m2: [f64; 5],
        growth_per_100kpa: f64,
    },
}

/// The effective-area laws a truck file can name.
pub const AREA_LAWS: &[LawDeclaration] = &[
    LawDeclaration {
        tag: "polynomial",
        description: "quartic in bellow height, thesis eq 5.4",
        keys: &["law", "coefficients_m2"],
    },
    LawDeclaration {
        tag: "polynomial_pressure",
        description: "quartic in height times (1 + κ p / 100 kPa), the wall stretch of thesis 6.1",
        keys: &["law", "coefficients_m2", "growth_per_100kpa"],
    },
];

impl EffectiveAreaLaw {
    /// The laws a truck file can name.
    pub const LAWS: &'static [LawDeclaration] = AREA_LAWS;

    /// The SPEC's form: the quartic of eq 5.4.
    pub const fn polynomial(coefficients_m2: [f64; 5]) -> Self {
        Self::Polynomial { coefficients_m2 }
    }

    pub fn tag(&self) -> &'static str {
        match self {
            Self::Polynomial { .. } => "polynomial",
            Self::PressurePolynomial { .. } => "polynomial_pressure",
        }
    }

    /// The quartic every law here is built on.
    pub fn coefficients_m2(&self) -> &[f64; 5] {
        match self {
            Self::Polynomial { coefficients_m2 }
            | Self::PressurePolynomial {
                coefficients_m2, ..
            } => coefficients_m2,
        }
    }

    pub fn coefficients_m2_mut(&mut self) -> &mut [f64; 5] {
        match self {
            Self::Polynomial { coefficients_m2 }
            | Self::PressurePolynomial {
                coefficients_m2, ..
            } => coefficients_m2,
        }
    }

    /// `κ`, the relative growth per 100 kPa; 0 for a law without pressure dependence.
    pub fn growth_per_100kpa(&self) -> f64 {
        match self {
            Self::Polynomial { .. } => 0.0,
            Self::PressurePolynomial {
                growth_per_100kpa, ..
            } => *growth_per_100kpa,
        }
    }

    /// Whether the area depends on the pressure.
    pub fn depends_on_pressure(&self) -> bool {
        matches!(self, Self::PressurePolynomial { .. })
    }

    /// Effective area at bellow height `height_m` and gauge pressure `gauge_pa`, m², as the
    /// law says, also outside the stroke it was fitted over.
    pub fn area_m2(&self, height_m: f64, gauge_pa: f64) -> f64 {
        let base = polynomial_area_m2(self.coefficients_m2(), height_m);
        match self {
            Self::Polynomial { .. } => base,
            Self::PressurePolynomial {
                growth_per_100kpa, ..
            } => base * (1.0 + growth_per_100kpa * gauge_pa / 1e5),
        }
    }

    /// [`Self::area_m2`] with the height clamped to [`EFFECTIVE_AREA_RANGE_M`]: outside it the
    /// area is held at its end value.
    ///
    /// Why: a quartic fitted over 0.2–0.45 m diverges outside. Far out (above ~0.75 m) it
    /// turns negative and then falls like `-3 h⁴`; with a gauge pressure that also turns
    /// negative as the volume grows, the "force" then pushes the bellow further apart without
    /// bound — a wheel in the air (Model 1 has no geometric limit on the bellow stroke) ran
    /// away to infinity. Holding the area constant is what a rolling-lobe bellow does near
    /// its ends, keeps the force a function of height only (so energy is still conserved), and
    /// leaves the model unchanged over the whole working stroke.
    pub fn area_clamped_m2(&self, height_m: f64, gauge_pa: f64) -> f64 {
        self.area_m2(
            height_m.clamp(EFFECTIVE_AREA_RANGE_M.0, EFFECTIVE_AREA_RANGE_M.1),
            gauge_pa,
        )
    }

    /// The gauge pressure at which the bellow at `height_m` (clamped as in
    /// [`Self::area_clamped_m2`]) carries `force_n`, Pa; `None` where the area is not
    /// positive, or where no pressure carries the force (a shrinking law, `κ < 0`, carries at
    /// most `A / (4 |κ'|)`). For a pressure-dependent law, `p A(h) (1 + κ' p) = F` is a
    /// quadratic in `p` and its root nearest zero is taken.
    pub fn gauge_for_force_pa(&self, height_m: f64, force_n: f64) -> Option<f64> {
        let area = self.area_clamped_m2(height_m, 0.0);
        if area <= 0.0 {
            return None;
        }
        let k = self.growth_per_100kpa() / 1e5;
        if k.abs() < 1e-18 {
            return Some(force_n / area);
        }
        let discriminant = area * area + 4.0 * k * area * force_n;
        (discriminant >= 0.0).then(|| (-area + discriminant.sqrt()) / (2.0 * k * area))
    }

    /// The law's parameters, in catalogue order.
    pub fn fields(&self) -> Vec<Field> {
        let mut fields: Vec<Field> = (0..5).map(Field::EffectiveArea).collect();
        if self.depends_on_pressure() {
            fields.push(Field::AreaPressureGrowth);
        }
        fields
    }

    /// The value of one of the law's parameters; `None` if the law has no such parameter.
    pub fn get(&self, field: Field) -> Option<f64> {
        match (field, self) {
            (Field::EffectiveArea(i), _) => self.coefficients_m2().get(i).copied(),
            (
                Field::AreaPressureGrowth,
                Self::PressurePolynomial {
                    growth_per_100kpa, ..
                },
            ) => Some(*growth_per_100kpa),
            _ => None,
        }
    }

    /// Sets one of the law's parameters; `false` if the law has no such parameter.
    pub fn set(&mut self, field: Field, value: f64) -> bool {
        match field {
            Field::EffectiveArea(i) if i < 5 => {
                self.coefficients_m2_mut()[i] = value;
                true
            }
            Field::AreaPressureGrowth => match self {
                Self::PressurePolynomial {
                    growth_per_100kpa, ..
                } => {
                    *growth_per_100kpa = value;
                    true
                }
                Self::Polynomial { .. } => false,
            },
            _ => false,
        }
    }

    /// Reads the tagged table `[bellow.effective_area]`.
    pub(crate) fn from_table(t: &LawTable) -> Result<Self, DataError> {
        let tag = t.tag()?.unwrap_or("polynomial");
        let decl = t.declaration(tag, AREA_LAWS)?;
        t.check_keys(decl.keys, tag)?;
        let coefficients_m2 = t.array::<5>("coefficients_m2", Field::EffectiveArea)?;
        Ok(match tag {
            "polynomial_pressure" => Self::PressurePolynomial {
                coefficients_m2,
                growth_per_100kpa: t.number("growth_per_100kpa", Field::AreaPressureGrowth)?,
            },
            _ => Self::Polynomial { coefficients_m2 },
        })
    }

    /// The tagged table's entries, or `None` for the thesis' law (written in the SPEC's form,
    /// `bellow.effective_area_poly_m2`).
    pub(crate) fn tagged_entries(&self) -> Option<TaggedEntries> {
        match self {
            Self::Polynomial { .. } => None,
            Self::PressurePolynomial {
                coefficients_m2,
                growth_per_100kpa,
            } => Some(vec![
                (
                    "coefficients_m2",
                    format!("{coefficients_m2:?}"),
                    "p0..p4 (est)",
                ),
                (
                    "growth_per_100kpa",
                    toml_number(*growth_per_100kpa),
                    "kap: area growth per 100 kPa (est)",
                ),
            ]),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const REF: [f64; 5] = [-0.0289, 0.8362, -3.0698, 4.9616, -2.9941];

    #[test]
    fn pressure_law_solves_its_quadratic() {
        let law = EffectiveAreaLaw::PressurePolynomial {
            coefficients_m2: REF,
            growth_per_100kpa: 0.004,
        };
        let force = 20_000.0;
        let p = law.gauge_for_force_pa(0.3, force).unwrap();
        assert!(
            (p * law.area_clamped_m2(0.3, p) - force).abs() < 1e-6,
            "{p}"
        );
        let plain = EffectiveAreaLaw::polynomial(REF);
        let p0 = plain.gauge_for_force_pa(0.3, force).unwrap();
        assert_eq!(p0, force / polynomial_area_m2(&REF, 0.3));
        assert!(p < p0, "a stretching wall needs less pressure");
        // A shrinking wall carries at most A / (4 |κ'|): beyond it, no pressure does.
        let shrinking = EffectiveAreaLaw::PressurePolynomial {
            coefficients_m2: REF,
            growth_per_100kpa: -0.1,
        };
        let most = polynomial_area_m2(&REF, 0.3) / (4.0 * 0.1 / 1e5);
        assert_eq!(shrinking.gauge_for_force_pa(0.3, 1.01 * most), None);
        let p = shrinking.gauge_for_force_pa(0.3, 0.5 * most).unwrap();
        assert!((p * shrinking.area_clamped_m2(0.3, p) - 0.5 * most).abs() < 1e-6 * most);
    }

    #[test]
    fn parameters_by_field() {
        let mut law = EffectiveAreaLaw::polynomial(REF);
        assert_eq!(law.fields().len(), 5);
        assert_eq!(law.get(Field::AreaPressureGrowth), None);
        assert!(!law.set(Field::AreaPressureGrowth, 0.1));
        assert!(law.set(Field::EffectiveArea(1), 0.9));
        assert_eq!(law.coefficients_m2()[1], 0.9);
        let law = EffectiveAreaLaw::PressurePolynomial {
            coefficients_m2: REF,
            growth_per_100kpa: 0.004,
        };
        assert_eq!(law.fields().last(), Some(&Field::AreaPressureGrowth));
        assert_eq!(law.get(Field::AreaPressureGrowth), Some(0.004));
    }
}
