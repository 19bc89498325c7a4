//! Effective-area laws of the bellow: `F_ab = p_g A_eff` (thesis eq 3.16).

use super::spline::MonotoneSpline;
use super::{LawDeclaration, LawTable, TaggedEntries, toml_number};
use crate::error::DataError;
use crate::params::{Field, MAX_AREA_KNOTS};

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

/// The highest knot height a spline law takes, m: well above any truck bellow's stroke, and
/// below the same heights written in mm.
const KNOT_HEIGHT_MAX_M: f64 = 2.0;

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
    /// A monotone, shape-preserving cubic through knots `(h_k, A_k)` ([`MonotoneSpline`]),
    /// held at its end values outside them, optionally stretched by the gauge pressure as
    /// [`Self::PressurePolynomial`] is (`growth_per_100kpa`). The knot heights are fixed (where
    /// the force map was measured); the knot areas `s0, s1, ..` are the law's parameters. For
    /// a bellow whose area bends where a quartic cannot follow (a rolling lobe near the ends
    /// of its stroke) and a law that cannot run away between or beyond its knots.
    Spline {
        knots: MonotoneSpline,
        growth_per_100kpa: Option<f64>,
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
    LawDeclaration {
        tag: "spline",
        description: "monotone cubic through knot areas at fixed heights, optionally times (1 + κ p / 100 kPa)",
        keys: &["law", "heights_m", "areas_m2", "growth_per_100kpa"],
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
            Self::Spline { .. } => "spline",
        }
    }

    /// A spline law through `heights_m` and `areas_m2` (see [`Self::Spline`]); an error says
    /// why the knots make none.
    pub fn spline(
        heights_m: Vec<f64>,
        areas_m2: Vec<f64>,
        growth_per_100kpa: Option<f64>,
    ) -> Result<Self, String> {
        if heights_m.len() > MAX_AREA_KNOTS {
            return Err(format!(
                "{} knots; a spline area law has at most {MAX_AREA_KNOTS}",
                heights_m.len()
            ));
        }
        let knots = MonotoneSpline::new(heights_m, areas_m2).map_err(|e| e.to_string())?;
        Ok(Self::Spline {
            knots,
            growth_per_100kpa,
        })
    }

    /// The quartic of a polynomial law; `None` for a spline.
    pub fn coefficients_m2(&self) -> Option<&[f64; 5]> {
        match self {
            Self::Polynomial { coefficients_m2 }
            | Self::PressurePolynomial {
                coefficients_m2, ..
            } => Some(coefficients_m2),
            Self::Spline { .. } => None,
        }
    }

    pub fn coefficients_m2_mut(&mut self) -> Option<&mut [f64; 5]> {
        match self {
            Self::Polynomial { coefficients_m2 }
            | Self::PressurePolynomial {
                coefficients_m2, ..
            } => Some(coefficients_m2),
            Self::Spline { .. } => None,
        }
    }

    /// The knots of a spline law; `None` for a polynomial.
    pub fn knots(&self) -> Option<&MonotoneSpline> {
        match self {
            Self::Spline { knots, .. } => Some(knots),
            _ => None,
        }
    }

    /// `∫_0^h A_eff(h', p = 0) dh'`, m³ per bellow: the volume an area-integral gas volume
    /// sweeps. The quartic is integrated as it stands from zero height (where it is an
    /// extrapolation; a dead volume takes up the difference); a spline is held at its first
    /// knot's area below it.
    pub fn integral_m3(&self, height_m: f64) -> f64 {
        match self {
            Self::Polynomial { coefficients_m2 }
            | Self::PressurePolynomial {
                coefficients_m2, ..
            } => {
                coefficients_m2
                    .iter()
                    .enumerate()
                    .rev()
                    .fold(0.0, |acc, (i, p)| acc * height_m + p / (i + 1) as f64)
                    * height_m
            }
            Self::Spline { knots, .. } => knots.integral_from_zero(height_m),
        }
    }

    /// `κ`, the relative growth per 100 kPa; 0 for a law without pressure dependence.
    pub fn growth_per_100kpa(&self) -> f64 {
        match self {
            Self::Polynomial { .. } => 0.0,
            Self::PressurePolynomial {
                growth_per_100kpa, ..
            } => *growth_per_100kpa,
            Self::Spline {
                growth_per_100kpa, ..
            } => growth_per_100kpa.unwrap_or(0.0),
        }
    }

    /// Whether the area depends on the pressure.
    pub fn depends_on_pressure(&self) -> bool {
        matches!(
            self,
            Self::PressurePolynomial { .. }
                | Self::Spline {
                    growth_per_100kpa: Some(_),
                    ..
                }
        )
    }

    /// Effective area at bellow height `height_m` and gauge pressure `gauge_pa`, m², as the
    /// law says, also outside the stroke it was fitted over.
    pub fn area_m2(&self, height_m: f64, gauge_pa: f64) -> f64 {
        match self {
            Self::Polynomial { coefficients_m2 } => polynomial_area_m2(coefficients_m2, height_m),
            Self::PressurePolynomial {
                coefficients_m2,
                growth_per_100kpa,
            } => {
                polynomial_area_m2(coefficients_m2, height_m)
                    * (1.0 + growth_per_100kpa * gauge_pa / 1e5)
            }
            Self::Spline {
                knots,
                growth_per_100kpa,
            } => knots.value(height_m) * (1.0 + growth_per_100kpa.unwrap_or(0.0) * gauge_pa / 1e5),
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
        let mut fields: Vec<Field> = match self {
            Self::Spline { knots, .. } => (0..knots.values().len()).map(Field::AreaKnot).collect(),
            _ => (0..5).map(Field::EffectiveArea).collect(),
        };
        if self.depends_on_pressure() {
            fields.push(Field::AreaPressureGrowth);
        }
        fields
    }

    /// The value of one of the law's parameters; `None` if the law has no such parameter.
    pub fn get(&self, field: Field) -> Option<f64> {
        match (field, self) {
            (Field::EffectiveArea(i), _) => self.coefficients_m2()?.get(i).copied(),
            (Field::AreaKnot(i), Self::Spline { knots, .. }) => knots.values().get(i).copied(),
            (
                Field::AreaPressureGrowth,
                Self::PressurePolynomial {
                    growth_per_100kpa, ..
                },
            ) => Some(*growth_per_100kpa),
            (
                Field::AreaPressureGrowth,
                Self::Spline {
                    growth_per_100kpa, ..
                },
            ) => *growth_per_100kpa,
            _ => None,
        }
    }

    /// Sets one of the law's parameters; `false` if the law has no such parameter.
    pub fn set(&mut self, field: Field, value: f64) -> bool {
        match field {
            Field::EffectiveArea(i) if i < 5 => match self.coefficients_m2_mut() {
                Some(c) => {
                    c[i] = value;
                    true
                }
                None => false,
            },
            Field::AreaKnot(i) => match self {
                Self::Spline { knots, .. } => knots.set_value(i, value),
                _ => false,
            },
            Field::AreaPressureGrowth => match self {
                Self::PressurePolynomial {
                    growth_per_100kpa, ..
                } => {
                    *growth_per_100kpa = value;
                    true
                }
                Self::Spline {
                    growth_per_100kpa: Some(growth),
                    ..
                } => {
                    *growth = value;
                    true
                }
                _ => false,
            },
            _ => false,
        }
    }

    /// Reads the tagged table `[bellow.effective_area]`.
    pub(crate) fn from_table(t: &LawTable) -> Result<Self, DataError> {
        let tag = t.tag()?.unwrap_or("polynomial");
        let decl = t.declaration(tag, AREA_LAWS)?;
        t.check_keys(decl.keys, tag)?;
        if tag == "spline" {
            return Self::spline_from_table(t);
        }
        let coefficients_m2 = t.array::<5>("coefficients_m2", Field::EffectiveArea)?;
        Ok(match tag {
            "polynomial_pressure" => Self::PressurePolynomial {
                coefficients_m2,
                growth_per_100kpa: t.number("growth_per_100kpa", Field::AreaPressureGrowth)?,
            },
            _ => Self::Polynomial { coefficients_m2 },
        })
    }

    fn spline_from_table(t: &LawTable) -> Result<Self, DataError> {
        let heights_m = t.vector("heights_m", MAX_AREA_KNOTS, |_| None)?;
        if let Some((i, h)) = heights_m
            .iter()
            .enumerate()
            .find(|(_, h)| !(**h > 0.0 && **h <= KNOT_HEIGHT_MAX_M))
        {
            return Err(t.invalid(
                "heights_m",
                h,
                format!(
                    "knot {i}: a bellow height in m, above 0 and at most {KNOT_HEIGHT_MAX_M} m; check the unit"
                ),
            ));
        }
        let areas_m2 = t.vector("areas_m2", MAX_AREA_KNOTS, |i| Some(Field::AreaKnot(i)))?;
        let growth_per_100kpa = match t.optional_number("growth_per_100kpa")? {
            Some(_) => Some(t.number("growth_per_100kpa", Field::AreaPressureGrowth)?),
            None => None,
        };
        let key = if heights_m.len() == areas_m2.len() {
            "heights_m"
        } else {
            "areas_m2"
        };
        Self::spline(heights_m, areas_m2, growth_per_100kpa).map_err(|reason| {
            t.invalid(
                key,
                "[..]",
                format!("{reason} (heights in m, strictly increasing, one area per height)"),
            )
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
            Self::Spline {
                knots,
                growth_per_100kpa,
            } => {
                let mut entries = vec![
                    (
                        "heights_m",
                        format!("{:?}", knots.knots_x()),
                        "knot bellow heights (fixed)",
                    ),
                    (
                        "areas_m2",
                        format!("{:?}", knots.values()),
                        "s0..: knot effective areas (est)",
                    ),
                ];
                if let Some(growth) = growth_per_100kpa {
                    entries.push((
                        "growth_per_100kpa",
                        toml_number(*growth),
                        "kap: area growth per 100 kPa (est)",
                    ));
                }
                Some(entries)
            }
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
        assert_eq!(law.coefficients_m2().unwrap()[1], 0.9);
        let law = EffectiveAreaLaw::PressurePolynomial {
            coefficients_m2: REF,
            growth_per_100kpa: 0.004,
        };
        assert_eq!(law.fields().last(), Some(&Field::AreaPressureGrowth));
        assert_eq!(law.get(Field::AreaPressureGrowth), Some(0.004));
    }
}
