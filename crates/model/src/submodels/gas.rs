//! Ideal gas in the bellow circuit, thesis eq 3.17/3.18; the volume is a law of the truck
//! file (`airsus_data::laws::GasVolumeLaw`). And the gas's energy balance the thesis leaves
//! out (it assumes an isothermal gas, 3.1.3): the virtual truck's bellow and lab tank, and
//! the estimator's fit of tank discharges, share it.

// The gas-volume law (eq 5.1 and others) is a value of the truck file
// (`airsus_data::laws::GasVolumeLaw`).
pub use airsus_data::laws::MIN_VOLUME_M3;

/// Absolute pressure, Pa, from the ideal gas law (thesis eq 3.17): `p = n R T / V`.
/// Isothermal: `T` is the ambient temperature (thesis 3.1.3).
pub fn pressure_abs_pa(
    amount_mol: f64,
    gas_constant_j_mol_k: f64,
    temperature_k: f64,
    volume_m3: f64,
) -> f64 {
    amount_mol * gas_constant_j_mol_k * temperature_k / volume_m3.max(MIN_VOLUME_M3)
}

/// Amount of air, mol, at absolute pressure `p` in volume `V` (thesis eq 3.18's initial value):
/// `n = p V / (R T)`.
pub fn air_amount_mol(
    pressure_abs_pa: f64,
    volume_m3: f64,
    gas_constant_j_mol_k: f64,
    temperature_k: f64,
) -> f64 {
    pressure_abs_pa * volume_m3 / (gas_constant_j_mol_k * temperature_k)
}

/// Heat capacity ratio of air.
pub const AIR_GAMMA: f64 = 1.4;

/// Inputs of [`gas_temperature_rate`], SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GasEnergyBalance {
    /// Amount of gas in the volume, mol.
    pub amount_mol: f64,
    /// Gas temperature, K.
    pub temperature_k: f64,
    /// Absolute pressure, Pa.
    pub pressure_pa: f64,
    /// `dV/dt`, m³/s.
    pub volume_rate_m3_s: f64,
    /// Net molar flow into the volume, mol/s (negative: out).
    pub net_inflow_mol_s: f64,
    /// Temperature of gas flowing in, K.
    pub inflow_temperature_k: f64,
    /// Wall (ambient) temperature, K.
    pub wall_temperature_k: f64,
    /// Thermal time constant of the heat exchange with the wall, s.
    pub thermal_time_constant_s: f64,
}

/// `dT/dt` of an ideal gas in a variable volume with flow and heat exchange (first law for an
/// open system, constant `c_v`, `c_p = γ c_v`, `R = c_p − c_v`):
///
/// `n c_v dT/dt = ṅ_in (c_p T_in − c_v T) − ṅ_out R T − p dV/dt + Q̇`,
/// `Q̇ = n c_v (T_wall − T)/τ`.
///
/// With no flow and `τ → ∞` this is the adiabatic `T V^(γ−1) = const`; with `τ → 0`
/// isothermal, the thesis' assumption. Outflow leaves at the gas temperature.
pub fn gas_temperature_rate(b: &GasEnergyBalance, gas_constant: f64) -> f64 {
    let cv = gas_constant / (AIR_GAMMA - 1.0);
    let cp = AIR_GAMMA * cv;
    let t = b.temperature_k;
    let (inflow, outflow) = if b.net_inflow_mol_s >= 0.0 {
        (b.net_inflow_mol_s, 0.0)
    } else {
        (0.0, -b.net_inflow_mol_s)
    };
    let flow_term = inflow * (cp * b.inflow_temperature_k - cv * t) - outflow * gas_constant * t;
    let work = b.pressure_pa * b.volume_rate_m3_s;
    let heat = (b.wall_temperature_k - t) / b.thermal_time_constant_s.max(1e-6);
    (flow_term - work) / (b.amount_mol.max(1e-9) * cv) + heat
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = 8.314462618;

    #[test]
    fn ideal_gas_round_trip() {
        // 1 mol at 293.15 K in 0.024 m³: p = 8.314462618 * 293.15 / 0.024 = 101 557.70 Pa
        let p = pressure_abs_pa(1.0, R, 293.15, 0.024);
        assert!((p - 101_557.696_519).abs() < 1e-3, "{p}");
        let n = air_amount_mol(p, 0.024, R, 293.15);
        assert!((n - 1.0).abs() < 1e-14);
    }
}
