//! Tire force, thesis eq 3.15, with an optional damper beside the spring.

use airsus_data::TireParameters;

/// The tire between axle and road: eq 3.15's linear spring `k_w` and, beside it, a linear
/// damper `c_w` (0 in the thesis). A law value: built once from the truck file, evaluated in
/// every right-hand side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tire {
    pub stiffness_n_per_m: f64,
    pub damping_n_s_per_m: f64,
}

impl Tire {
    pub fn new(p: &TireParameters) -> Self {
        Self {
            stiffness_n_per_m: p.stiffness_n_per_m,
            damping_n_s_per_m: p.damping_n_s_per_m,
        }
    }

    /// Tire force on the axle, N (up positive): `F_w = k_w Δr + c_w Δṙ` (eq 3.15 with the
    /// damper beside the spring) while the tire touches the road (`Δr > 0`), and never
    /// pulling: a wheel in the air (`Δr <= 0`) carries nothing, and a tire springing back
    /// faster than its rubber follows lets go of the road rather than pull it (the force is
    /// floored at 0). `compression_m` is `Δr`, the radial compression from the unloaded tire,
    /// m; `compression_rate_m_s` its rate, m/s (road rate minus axle velocity).
    ///
    /// Assumption: the damper acts from the first touch, so a wheel landing at speed feels a
    /// step of `c_w Δṙ` (the Kelvin-Voigt contact's known jump); with `c_w = 0` the force is
    /// continuous as in the thesis.
    pub fn force_n(&self, compression_m: f64, compression_rate_m_s: f64) -> f64 {
        if compression_m > 0.0 {
            (self.stiffness_n_per_m * compression_m + self.damping_n_s_per_m * compression_rate_m_s)
                .max(0.0)
        } else {
            0.0
        }
    }

    /// The compression carrying `force_n` at rest, m (the damper carries nothing at rest).
    pub fn static_compression_m(&self, force_n: f64) -> f64 {
        force_n / self.stiffness_n_per_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tire(damping_n_s_per_m: f64) -> Tire {
        Tire {
            stiffness_n_per_m: 1.8e6,
            damping_n_s_per_m,
        }
    }

    #[test]
    fn linear_in_compression_and_never_pulls() {
        // 1.8e6 N/m * 18 mm = 32 400 N
        assert!((tire(0.0).force_n(0.018, 0.0) - 32_400.0).abs() < 1e-9);
        assert_eq!(tire(0.0).force_n(0.0, 0.0), 0.0);
        assert_eq!(tire(0.0).force_n(-0.05, 0.0), 0.0);
    }

    #[test]
    fn the_damper_adds_its_rate_force_only_in_contact_and_never_pulls() {
        // 18 mm compressed, compressing at 0.5 m/s through 3 kN s/m: 32 400 + 1 500 N.
        assert!((tire(3000.0).force_n(0.018, 0.5) - 33_900.0).abs() < 1e-9);
        // Springing back at 0.5 m/s: 32 400 - 1 500 N.
        assert!((tire(3000.0).force_n(0.018, -0.5) - 30_900.0).abs() < 1e-9);
        // 1 mm compressed, springing back at 1 m/s: the damper would pull; the tire lets go.
        assert_eq!(tire(3000.0).force_n(0.001, -1.0), 0.0);
        // In the air the damper does nothing either.
        assert_eq!(tire(3000.0).force_n(-0.01, 1.0), 0.0);
        assert!((tire(3000.0).static_compression_m(32_400.0) - 0.018).abs() < 1e-15);
    }
}
