//! Gas-volume laws of the bellow circuit: `p = n R T / V(h)` (thesis eq 3.17).

use super::{LawDeclaration, LawTable, TaggedEntries};
use crate::error::DataError;
use crate::params::Field;

/// Smallest volume the gas law is evaluated at, m³. Only reached far outside the stroke (a
/// bellow squeezed to nothing, or a lever driven through the chassis by absurd inputs): the
/// pressure then grows very large but stays finite, acting like a bump stop instead of
/// producing a division by zero.
pub const MIN_VOLUME_M3: f64 = 1e-6;

/// The volume of the gas in the bellow circuit as a function of the bellow height. It covers
/// the whole axle circuit (both bellows share one air circuit and one pressure, SPEC §2).
#[derive(Debug, Clone, PartialEq)]
pub enum GasVolumeLaw {
    /// `V = h A(h)` with the mean cross-section `A(h) = A0 + A1 h` (thesis 3.1.3, eq 5.1;
    /// Table 5.1: `A0 = 0.250 m²`, `A1 = -0.0310 m`), `a0`, `a1`. Not the effective area: it
    /// only serves the volume.
    CrossSection { coefficients_m2: [f64; 2] },
}

/// The gas-volume laws a truck file can name.
pub const VOLUME_LAWS: &[LawDeclaration] = &[LawDeclaration {
    tag: "cross_section",
    description: "h (A0 + A1 h), thesis eq 5.1",
    keys: &["law", "coefficients_m2"],
}];

impl GasVolumeLaw {
    pub const LAWS: &'static [LawDeclaration] = VOLUME_LAWS;

    /// The SPEC's form: the linear cross-section of eq 5.1.
    pub const fn cross_section(coefficients_m2: [f64; 2]) -> Self {
        Self::CrossSection { coefficients_m2 }
    }

    pub fn tag(&self) -> &'static str {
        match self {
            Self::CrossSection { .. } => "cross_section",
        }
    }

    /// `[A0, A1]` of eq 5.1.
    pub fn coefficients_m2(&self) -> &[f64; 2] {
        match self {
            Self::CrossSection { coefficients_m2 } => coefficients_m2,
        }
    }

    pub fn coefficients_m2_mut(&mut self) -> &mut [f64; 2] {
        match self {
            Self::CrossSection { coefficients_m2 } => coefficients_m2,
        }
    }

    /// Mean cross-section `A(h)`, m² (eq 5.1).
    pub fn cross_section_m2(&self, height_m: f64) -> f64 {
        let c = self.coefficients_m2();
        c[0] + c[1] * height_m
    }

    /// Gas volume at bellow height `height_m`, m³, floored at [`MIN_VOLUME_M3`].
    pub fn volume_m3(&self, height_m: f64) -> f64 {
        (height_m * self.cross_section_m2(height_m)).max(MIN_VOLUME_M3)
    }

    /// `dV/dh`, m², for the gas's energy balance (work done by the moving wall).
    pub fn volume_slope_m2(&self, height_m: f64) -> f64 {
        let c = self.coefficients_m2();
        c[0] + 2.0 * c[1] * height_m
    }

    /// The law's parameters, in catalogue order.
    pub fn fields(&self) -> Vec<Field> {
        vec![Field::CrossSection(0), Field::CrossSection(1)]
    }

    pub fn get(&self, field: Field) -> Option<f64> {
        match field {
            Field::CrossSection(i) => self.coefficients_m2().get(i).copied(),
            _ => None,
        }
    }

    pub fn set(&mut self, field: Field, value: f64) -> bool {
        match field {
            Field::CrossSection(i) if i < 2 => {
                self.coefficients_m2_mut()[i] = value;
                true
            }
            _ => false,
        }
    }

    /// Reads the tagged table `[bellow.gas_volume]`.
    pub(crate) fn from_table(t: &LawTable) -> Result<Self, DataError> {
        let tag = t.tag()?.unwrap_or("cross_section");
        let decl = t.declaration(tag, VOLUME_LAWS)?;
        t.check_keys(decl.keys, tag)?;
        Ok(Self::CrossSection {
            coefficients_m2: t.array::<2>("coefficients_m2", Field::CrossSection)?,
        })
    }

    /// The tagged table's entries, or `None` for the thesis' law (written in the SPEC's form,
    /// `bellow.cross_section_m2`).
    pub(crate) fn tagged_entries(&self) -> Option<TaggedEntries> {
        match self {
            Self::CrossSection { .. } => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn volume_by_hand() {
        // h = 0.3 m: A = 0.25 - 0.0310*0.3 = 0.2407 m²; V = 0.07221 m³
        let law = GasVolumeLaw::cross_section([0.250, -0.0310]);
        assert!((law.cross_section_m2(0.3) - 0.2407).abs() < 1e-15);
        assert!((law.volume_m3(0.3) - 0.07221).abs() < 1e-15);
        assert_eq!(law.volume_m3(-0.1), MIN_VOLUME_M3);
        let d = 1e-6;
        let fd = (law.volume_m3(0.3 + d) - law.volume_m3(0.3 - d)) / (2.0 * d);
        assert!((law.volume_slope_m2(0.3) - fd).abs() < 1e-9);
    }
}
