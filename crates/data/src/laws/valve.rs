//! Valve-flow laws of the 3-state levelling valve: the air flow into the bellow circuit
//! (thesis eq 3.18/3.19).

use super::{LawDeclaration, LawTable, TaggedEntries, toml_number};
use crate::error::DataError;
use crate::params::Field;
use crate::run::ValveState;

/// Molar mass of dry air, kg/mol.
pub const AIR_MOLAR_MASS_KG_MOL: f64 = 0.028_965;
/// ISO 6358 reference state: density 1.185 kg/m³ at 293.15 K and 100 kPa.
pub const ISO6358_REFERENCE_DENSITY_KG_M3: f64 = 1.185;
pub const ISO6358_REFERENCE_TEMPERATURE_K: f64 = 293.15;

/// Pressure ratio above which the flow is treated as laminar (linear in the pressure
/// difference). ISO 6358's subsonic law `√(1 − x²)` has an infinite slope at `p_down = p_up`,
/// which no ODE solver likes and no real valve shows; ISO 6358-3 introduces the same kind of
/// laminar range near equilibrium.
pub const LAMINAR_PRESSURE_RATIO: f64 = 0.995;

/// Molar flow through a pneumatic component from `p_a` to `p_b` (both absolute, Pa), positive
/// when air flows from a to b (ISO 6358-1:2013, eqs 1–2):
///
/// - choked, `r = p_down/p_up ≤ b`: `q_m = C p_up ρ0 √(T0/T_up)`;
/// - subsonic, `b < r`: `q_m = C p_up ρ0 √(T0/T_up) √(1 − ((r − b)/(1 − b))²)`;
/// - laminar near `r = 1` (see [`LAMINAR_PRESSURE_RATIO`]): linear in `1 − r`, continuous.
///
/// `conductance_m3_s_pa` is the sonic conductance `C` in m³/(s·Pa) (1 dm³/(s·bar) = 1e-8),
/// `critical_ratio` is `b`. The upstream gas is at `t_up_k`.
pub fn iso6358_molar_flow(
    conductance_m3_s_pa: f64,
    critical_ratio: f64,
    p_a_pa: f64,
    p_b_pa: f64,
    t_up_k: f64,
) -> f64 {
    let (p_up, p_down, sign) = if p_a_pa >= p_b_pa {
        (p_a_pa, p_b_pa, 1.0)
    } else {
        (p_b_pa, p_a_pa, -1.0)
    };
    if p_up <= 0.0 || conductance_m3_s_pa <= 0.0 {
        return 0.0;
    }
    let b = critical_ratio.clamp(0.0, LAMINAR_PRESSURE_RATIO - 1e-3);
    let subsonic = |r: f64| -> f64 {
        if r <= b {
            1.0
        } else {
            let x = (r - b) / (1.0 - b);
            (1.0 - x * x).max(0.0).sqrt()
        }
    };
    let r = (p_down / p_up).clamp(0.0, 1.0);
    let shape = if r > LAMINAR_PRESSURE_RATIO {
        subsonic(LAMINAR_PRESSURE_RATIO) * (1.0 - r) / (1.0 - LAMINAR_PRESSURE_RATIO)
    } else {
        subsonic(r)
    };
    let mass_flow = conductance_m3_s_pa
        * p_up
        * ISO6358_REFERENCE_DENSITY_KG_M3
        * (ISO6358_REFERENCE_TEMPERATURE_K / t_up_k.max(1.0)).sqrt()
        * shape;
    sign * mass_flow / AIR_MOLAR_MASS_KG_MOL
}

/// How air flows through the valve's fill channel (from the supply) and its exhaust channel
/// (to ambient).
///
/// **Backflow on fill.** A flow law read literally would let air flow from the bellow back into
/// the supply when the supply pressure drops below the bellow pressure. Truck levelling
/// circuits have a check (non-return) valve in the supply line so that a depleted supply tank
/// cannot empty the suspension; every law here models it: on fill, the flow is never negative.
/// Exhaust has no check valve: a bellow below ambient pressure (not reachable in practice)
/// would draw air in through the open exhaust, which is what the physics says.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ValveFlowLaw {
    /// Poiseuille: flow proportional to the pressure difference (thesis eq 3.19), resistances
    /// `R_flow1` (fill, `rflow1`) and `R_flow2` (exhaust, `rflow2`), Pa·s/mol. A non-positive
    /// resistance (not admissible) gives zero flow instead of an infinite one.
    LinearResistance {
        fill_pa_s_per_mol: f64,
        exhaust_pa_s_per_mol: f64,
    },
    /// An orifice with choking, ISO 6358-1 ([`iso6358_molar_flow`]): sonic conductances of
    /// the fill (`c1`) and exhaust (`c2`) channels, m³/(s·Pa), and the critical pressure
    /// ratio of both (`bcr`). Flow grows with the upstream pressure and saturates when the
    /// downstream pressure falls below `b` times it, which a linear resistance cannot show.
    Orifice {
        fill_conductance_m3_s_pa: f64,
        exhaust_conductance_m3_s_pa: f64,
        critical_pressure_ratio: f64,
    },
}

/// The valve-flow laws a truck file can name.
pub const VALVE_LAWS: &[LawDeclaration] = &[
    LawDeclaration {
        tag: "linear_resistance",
        description: "flow proportional to the pressure difference, thesis eq 3.19",
        keys: &[
            "law",
            "fill_resistance_pa_s_per_mol",
            "exhaust_resistance_pa_s_per_mol",
        ],
    },
    LawDeclaration {
        tag: "orifice",
        description: "orifice with choking, ISO 6358-1",
        keys: &[
            "law",
            "fill_conductance_m3_s_pa",
            "exhaust_conductance_m3_s_pa",
            "critical_pressure_ratio",
        ],
    },
];

/// The fill and the exhaust channel's flow coefficient under each law: the parameters that
/// play the same part in different laws.
pub const VALVE_CHANNELS: [&[Field]; 2] = [
    &[Field::FillResistance, Field::FillConductance],
    &[Field::ExhaustResistance, Field::ExhaustConductance],
];

impl ValveFlowLaw {
    pub const LAWS: &'static [LawDeclaration] = VALVE_LAWS;

    pub fn tag(&self) -> &'static str {
        match self {
            Self::LinearResistance { .. } => "linear_resistance",
            Self::Orifice { .. } => "orifice",
        }
    }

    /// Flow through the open fill channel into the bellow, mol/s, never negative (check
    /// valve). `upstream_abs_pa` is the pressure before the valve (the supply), at
    /// `upstream_t_k`.
    pub fn fill_flow_mol_s(
        &self,
        upstream_abs_pa: f64,
        bellow_abs_pa: f64,
        upstream_t_k: f64,
    ) -> f64 {
        match *self {
            Self::LinearResistance {
                fill_pa_s_per_mol, ..
            } => {
                if fill_pa_s_per_mol > 0.0 {
                    ((upstream_abs_pa - bellow_abs_pa) / fill_pa_s_per_mol).max(0.0)
                } else {
                    0.0
                }
            }
            Self::Orifice {
                fill_conductance_m3_s_pa,
                critical_pressure_ratio,
                ..
            } => iso6358_molar_flow(
                fill_conductance_m3_s_pa,
                critical_pressure_ratio,
                upstream_abs_pa,
                bellow_abs_pa,
                upstream_t_k,
            )
            .max(0.0),
        }
    }

    /// Flow through the open exhaust channel out of the bellow to ambient, mol/s (negative
    /// only for a bellow below ambient pressure). The bellow gas is at `bellow_t_k`.
    pub fn exhaust_flow_mol_s(
        &self,
        bellow_abs_pa: f64,
        ambient_abs_pa: f64,
        bellow_t_k: f64,
    ) -> f64 {
        match *self {
            Self::LinearResistance {
                exhaust_pa_s_per_mol,
                ..
            } => {
                if exhaust_pa_s_per_mol > 0.0 {
                    (bellow_abs_pa - ambient_abs_pa) / exhaust_pa_s_per_mol
                } else {
                    0.0
                }
            }
            Self::Orifice {
                exhaust_conductance_m3_s_pa,
                critical_pressure_ratio,
                ..
            } => iso6358_molar_flow(
                exhaust_conductance_m3_s_pa,
                critical_pressure_ratio,
                bellow_abs_pa,
                ambient_abs_pa,
                bellow_t_k,
            ),
        }
    }

    /// Net air flow into the bellow circuit for a valve state, mol/s: the fill flow, minus the
    /// exhaust flow, or nothing while the valve is closed.
    pub fn flow_mol_s(
        &self,
        valve: ValveState,
        bellow_abs_pa: f64,
        supply_abs_pa: f64,
        ambient_abs_pa: f64,
        temperature_k: f64,
    ) -> f64 {
        match valve {
            ValveState::Closed => 0.0,
            ValveState::Fill => self.fill_flow_mol_s(supply_abs_pa, bellow_abs_pa, temperature_k),
            ValveState::Exhaust => {
                -self.exhaust_flow_mol_s(bellow_abs_pa, ambient_abs_pa, temperature_k)
            }
        }
    }

    /// The law's parameters, in catalogue order.
    pub fn fields(&self) -> Vec<Field> {
        match self {
            Self::LinearResistance { .. } => {
                vec![Field::FillResistance, Field::ExhaustResistance]
            }
            Self::Orifice { .. } => vec![
                Field::FillConductance,
                Field::ExhaustConductance,
                Field::CriticalPressureRatio,
            ],
        }
    }

    pub fn get(&self, field: Field) -> Option<f64> {
        let mut law = *self;
        law.slot(field).map(|v| *v)
    }

    fn slot(&mut self, field: Field) -> Option<&mut f64> {
        Some(match (self, field) {
            (
                Self::LinearResistance {
                    fill_pa_s_per_mol, ..
                },
                Field::FillResistance,
            ) => fill_pa_s_per_mol,
            (
                Self::LinearResistance {
                    exhaust_pa_s_per_mol,
                    ..
                },
                Field::ExhaustResistance,
            ) => exhaust_pa_s_per_mol,
            (
                Self::Orifice {
                    fill_conductance_m3_s_pa,
                    ..
                },
                Field::FillConductance,
            ) => fill_conductance_m3_s_pa,
            (
                Self::Orifice {
                    exhaust_conductance_m3_s_pa,
                    ..
                },
                Field::ExhaustConductance,
            ) => exhaust_conductance_m3_s_pa,
            (
                Self::Orifice {
                    critical_pressure_ratio,
                    ..
                },
                Field::CriticalPressureRatio,
            ) => critical_pressure_ratio,
            _ => return None,
        })
    }

    pub fn set(&mut self, field: Field, value: f64) -> bool {
        match self.slot(field) {
            Some(slot) => {
                *slot = value;
                true
            }
            None => false,
        }
    }
    /// Reads the `[valve]` table: tagged, or the SPEC's resistances without a tag.
    pub(crate) fn from_table(t: &LawTable) -> Result<Self, DataError> {
        let tag = t.tag()?.unwrap_or("linear_resistance");
        let decl = t.declaration(tag, VALVE_LAWS)?;
        t.check_keys(decl.keys, tag)?;
        Ok(match tag {
            "orifice" => Self::Orifice {
                fill_conductance_m3_s_pa: t
                    .number("fill_conductance_m3_s_pa", Field::FillConductance)?,
                exhaust_conductance_m3_s_pa: t
                    .number("exhaust_conductance_m3_s_pa", Field::ExhaustConductance)?,
                critical_pressure_ratio: t
                    .number("critical_pressure_ratio", Field::CriticalPressureRatio)?,
            },
            _ => Self::LinearResistance {
                fill_pa_s_per_mol: t
                    .number("fill_resistance_pa_s_per_mol", Field::FillResistance)?,
                exhaust_pa_s_per_mol: t
                    .number("exhaust_resistance_pa_s_per_mol", Field::ExhaustResistance)?,
            },
        })
    }

    /// The `[valve]` table's entries (after `law = ..`), or `None` for the thesis' law
    /// (written in the SPEC's form, without a tag).
    pub(crate) fn tagged_entries(&self) -> Option<TaggedEntries> {
        match *self {
            Self::LinearResistance { .. } => None,
            Self::Orifice {
                fill_conductance_m3_s_pa,
                exhaust_conductance_m3_s_pa,
                critical_pressure_ratio,
            } => Some(vec![
                (
                    "fill_conductance_m3_s_pa",
                    toml_number(fill_conductance_m3_s_pa),
                    "c1, ISO 6358 sonic conductance (est)",
                ),
                (
                    "exhaust_conductance_m3_s_pa",
                    toml_number(exhaust_conductance_m3_s_pa),
                    "c2 (est)",
                ),
                (
                    "critical_pressure_ratio",
                    toml_number(critical_pressure_ratio),
                    "bcr, b of both channels (est)",
                ),
            ]),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const AMB: f64 = 101_325.0;
    const LINEAR: ValveFlowLaw = ValveFlowLaw::LinearResistance {
        fill_pa_s_per_mol: 2.5e6,
        exhaust_pa_s_per_mol: 1.5e6,
    };

    #[test]
    fn poiseuille_by_hand() {
        let bellow = AMB + 350e3;
        let supply = AMB + 850e3;
        let t = 293.15;
        assert_eq!(
            LINEAR.flow_mol_s(ValveState::Closed, bellow, supply, AMB, t),
            0.0
        );
        // fill: 500 kPa / 2.5e6 Pa s/mol = 0.2 mol/s
        let fill = LINEAR.flow_mol_s(ValveState::Fill, bellow, supply, AMB, t);
        assert!((fill - 0.2).abs() < 1e-15);
        // exhaust: -350 kPa / 1.5e6 = -0.2333 mol/s
        let ex = LINEAR.flow_mol_s(ValveState::Exhaust, bellow, supply, AMB, t);
        assert!((ex + 350e3 / 1.5e6).abs() < 1e-15);
    }

    #[test]
    fn check_valve_blocks_backflow_on_fill_for_every_law() {
        let orifice = ValveFlowLaw::Orifice {
            fill_conductance_m3_s_pa: 5e-9,
            exhaust_conductance_m3_s_pa: 1.2e-8,
            critical_pressure_ratio: 0.4,
        };
        for law in [LINEAR, orifice] {
            let f = law.flow_mol_s(ValveState::Fill, AMB + 350e3, AMB + 300e3, AMB, 293.15);
            assert_eq!(f, 0.0, "{}", law.tag());
        }
    }

    #[test]
    fn non_positive_resistance_gives_no_flow() {
        let law = ValveFlowLaw::LinearResistance {
            fill_pa_s_per_mol: 0.0,
            exhaust_pa_s_per_mol: -1.0,
        };
        assert_eq!(
            law.flow_mol_s(ValveState::Fill, AMB, 2.0 * AMB, AMB, 293.0),
            0.0
        );
        assert_eq!(
            law.flow_mol_s(ValveState::Exhaust, 2.0 * AMB, AMB, AMB, 293.0),
            0.0
        );
    }

    #[test]
    fn parameters_by_field() {
        let mut law = LINEAR;
        assert_eq!(law.get(Field::FillConductance), None);
        assert!(!law.set(Field::FillConductance, 1e-9));
        assert!(law.set(Field::ExhaustResistance, 2e6));
        assert_eq!(law.get(Field::ExhaustResistance), Some(2e6));
    }
}
