//! Hinge friction (thesis 3.1.1, QCM 1).

/// Hinge friction force, N, thesis eq 3.4a: `k_f (ẋ1 - ẋ2)`, viscous (proportional to the
/// relative vertical velocity of chassis and axle), opposing the relative motion.
/// `relative_velocity_m_s` is the axle-to-chassis extension rate; the returned force is the
/// resisting force, positive in extension (same convention as the damper).
pub fn hinge_friction_n(friction_n_s_per_m: f64, relative_velocity_m_s: f64) -> f64 {
    friction_n_s_per_m * relative_velocity_m_s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viscous() {
        assert!((hinge_friction_n(0.1, 0.5) - 0.05).abs() < 1e-15);
        assert!((hinge_friction_n(200.0, -0.2) + 40.0).abs() < 1e-12);
    }
}
