//! Ideal gas in the bellow circuit, thesis eq 3.17/3.18 with the volume law of eq 5.1.

/// Smallest volume the gas law is evaluated at, m³. Only reached far outside the stroke (a
/// bellow squeezed to nothing, or a lever driven through the chassis by absurd inputs): the
/// pressure then grows very large but stays finite, acting like a bump stop instead of
/// producing a division by zero.
pub const MIN_VOLUME_M3: f64 = 1e-6;

/// Mean cross-section `A(h) = A0 + A1 h`, m² (thesis eq 5.1, Table 5.1: `A0 = 0.250 m²`,
/// `A1 = -0.0310 m`). Not the effective area: it only serves the volume. It covers the whole
/// axle circuit (both bellows share one air circuit and one pressure, SPEC §2).
pub fn cross_section_m2(coeffs: &[f64; 2], height_m: f64) -> f64 {
    coeffs[0] + coeffs[1] * height_m
}

/// Gas volume `V = h A(h)`, m³ (thesis 3.1.3), floored at [`MIN_VOLUME_M3`].
pub fn bellow_volume_m3(coeffs: &[f64; 2], height_m: f64) -> f64 {
    (height_m * cross_section_m2(coeffs, height_m)).max(MIN_VOLUME_M3)
}

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
    fn volume_by_hand() {
        // h = 0.3 m: A = 0.25 - 0.0310*0.3 = 0.2407 m²; V = 0.07221 m³
        let a = [0.250, -0.0310];
        assert!((cross_section_m2(&a, 0.3) - 0.2407).abs() < 1e-15);
        assert!((bellow_volume_m3(&a, 0.3) - 0.07221).abs() < 1e-15);
        assert_eq!(bellow_volume_m3(&a, -0.1), MIN_VOLUME_M3);
    }

    #[test]
    fn ideal_gas_round_trip() {
        // 1 mol at 293.15 K in 0.024 m³: p = 8.314462618 * 293.15 / 0.024 = 101 557.70 Pa
        let p = pressure_abs_pa(1.0, R, 293.15, 0.024);
        assert!((p - 101_557.696_519).abs() < 1e-3, "{p}");
        let n = air_amount_mol(p, 0.024, R, 293.15);
        assert!((n - 1.0).abs() < 1e-14);
    }
}
