//! Air flow through the 3-state valve, thesis eq 3.19 (Poiseuille: flow ∝ pressure difference).

use airsus_data::ValveState;

/// Air flow into the bellow circuit, mol/s (thesis eq 3.19):
/// - closed: `0`;
/// - fill: `(p_supply_abs - p_abs) / R_flow1` when the supply is above the bellow, else `0`;
/// - exhaust: `-(p_abs - p_amb) / R_flow2`.
///
/// **Backflow on fill.** Eq 3.19 read literally would let air flow from the bellow back into
/// the supply when the supply pressure drops below the bellow pressure. Truck levelling
/// circuits have a check (non-return) valve in the supply line so that a depleted supply
/// tank cannot empty the suspension; we model that: on fill, the flow is never negative.
/// Exhaust has no check valve: a bellow below ambient pressure (not reachable in practice)
/// would draw air in through the open exhaust, which is what the physics says.
///
/// Pressures absolute, Pa; resistances Pa·s/mol. A non-positive resistance (not admissible)
/// gives zero flow instead of an infinite one.
pub fn air_flow_mol_s(
    valve: ValveState,
    bellow_abs_pa: f64,
    supply_abs_pa: f64,
    ambient_abs_pa: f64,
    fill_resistance_pa_s_per_mol: f64,
    exhaust_resistance_pa_s_per_mol: f64,
) -> f64 {
    match valve {
        ValveState::Closed => 0.0,
        ValveState::Fill if fill_resistance_pa_s_per_mol > 0.0 => {
            ((supply_abs_pa - bellow_abs_pa) / fill_resistance_pa_s_per_mol).max(0.0)
        }
        ValveState::Exhaust if exhaust_resistance_pa_s_per_mol > 0.0 => {
            -(bellow_abs_pa - ambient_abs_pa) / exhaust_resistance_pa_s_per_mol
        }
        ValveState::Fill | ValveState::Exhaust => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const AMB: f64 = 101_325.0;

    #[test]
    fn poiseuille_by_hand() {
        let bellow = AMB + 350e3;
        let supply = AMB + 850e3;
        assert_eq!(
            air_flow_mol_s(ValveState::Closed, bellow, supply, AMB, 2.5e6, 1.5e6),
            0.0
        );
        // fill: 500 kPa / 2.5e6 Pa s/mol = 0.2 mol/s
        let fill = air_flow_mol_s(ValveState::Fill, bellow, supply, AMB, 2.5e6, 1.5e6);
        assert!((fill - 0.2).abs() < 1e-15);
        // exhaust: -350 kPa / 1.5e6 = -0.2333 mol/s
        let ex = air_flow_mol_s(ValveState::Exhaust, bellow, supply, AMB, 2.5e6, 1.5e6);
        assert!((ex + 350e3 / 1.5e6).abs() < 1e-15);
    }

    #[test]
    fn check_valve_blocks_backflow_on_fill() {
        let bellow = AMB + 350e3;
        let supply = AMB + 300e3;
        assert_eq!(
            air_flow_mol_s(ValveState::Fill, bellow, supply, AMB, 2.5e6, 1.5e6),
            0.0
        );
    }

    #[test]
    fn non_positive_resistance_gives_no_flow() {
        assert_eq!(
            air_flow_mol_s(ValveState::Fill, AMB, 2.0 * AMB, AMB, 0.0, 1.0),
            0.0
        );
        assert_eq!(
            air_flow_mol_s(ValveState::Exhaust, 2.0 * AMB, AMB, AMB, 1.0, -1.0),
            0.0
        );
    }
}
