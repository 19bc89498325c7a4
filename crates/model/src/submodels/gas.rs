//! Ideal gas in the bellow circuit, thesis eq 3.17/3.18; the volume is a law of the truck
//! file (`airsus_data::laws::GasVolumeLaw`).

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
