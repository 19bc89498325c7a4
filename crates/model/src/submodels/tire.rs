//! Tire force, thesis eq 3.15.

/// Tire force on the axle, N (up positive), thesis eq 3.15: `F_w = k_w Δr` for a radial
/// compression `Δr >= 0` and `0` otherwise — the tire cannot pull the axle down, so a wheel in
/// the air (negative compression) carries nothing.
///
/// `stiffness_n_per_m` is `k_w`; `compression_m` is `Δr`, the radial compression from the
/// unloaded tire, m. Linear spring, no tire damping (as the thesis).
pub fn tire_force_n(stiffness_n_per_m: f64, compression_m: f64) -> f64 {
    if compression_m > 0.0 {
        stiffness_n_per_m * compression_m
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_in_compression_and_never_pulls() {
        // 1.8e6 N/m * 18 mm = 32 400 N
        assert!((tire_force_n(1.8e6, 0.018) - 32_400.0).abs() < 1e-9);
        assert_eq!(tire_force_n(1.8e6, 0.0), 0.0);
        assert_eq!(tire_force_n(1.8e6, -0.05), 0.0);
    }
}
