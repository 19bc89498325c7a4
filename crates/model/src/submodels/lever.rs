//! Lever geometry (thesis eq 2.1/2.2) and the height-sensor output map (SPEC §1, eq 3.14).
//!
//! Heights are measured downward from the chassis bottom: the hinge hangs `h0` below it, the
//! lever leaves the hinge at angle `α` below horizontal, so a point at distance `s` along the
//! lever sits `h0 + s sin α` below the chassis. The axle is at `s = l1`, the bellow at
//! `s = l1 + l2`, the damper at `s = l1 + l3`.

/// Lever gain `k_l = (l1 + l2) / l1` (thesis 3.1.1).
pub fn lever_gain(l1_m: f64, l2_m: f64) -> f64 {
    (l1_m + l2_m) / l1_m
}

/// Bellow height from the rigid-lever axle height, thesis eq 2.1:
/// `h_bellow = h0 + k_l (h_axle - h0)`, m.
pub fn bellow_height_from_axle_m(h0_m: f64, lever_gain: f64, axle_height_m: f64) -> f64 {
    h0_m + lever_gain * (axle_height_m - h0_m)
}

/// Inverse of eq 2.1: the rigid-lever axle height `h0 + (h_bellow - h0)/k_l`, m.
pub fn axle_height_from_bellow_m(h0_m: f64, lever_gain: f64, bellow_height_m: f64) -> f64 {
    h0_m + (bellow_height_m - h0_m) / lever_gain
}

/// Bellow height from the lever angle, thesis eq 2.2: `h_bellow = h0 + (l1 + l2) sin α`, m.
pub fn bellow_height_from_angle_m(h0_m: f64, l1_m: f64, l2_m: f64, alpha_rad: f64) -> f64 {
    h0_m + (l1_m + l2_m) * alpha_rad.sin()
}

/// What the height sensor reads, m (SPEC §1):
/// `height_sensor = h0 + (h_bellow - h0)/k_l - k_scl m_tot g`.
///
/// The first two terms are the rigid-lever axle height (eq 2.1 inverted); the last is the
/// leaf-spring lever's static flex under the wheel load (eq 3.14), which the dynamics do not
/// model: it is applied to the output only.
pub fn sensor_height_m(
    h0_m: f64,
    lever_gain: f64,
    bellow_height_m: f64,
    lever_compliance_m_per_n: f64,
    wheel_load_kg: f64,
    gravity_m_s2: f64,
) -> f64 {
    axle_height_from_bellow_m(h0_m, lever_gain, bellow_height_m)
        - lever_compliance_m_per_n * wheel_load_kg * gravity_m_s2
}

/// The bellow height a sensor reading implies under a wheel load, m: [`sensor_height_m`]
/// inverted (the lever's static flex added back, then eq 2.1).
pub fn bellow_height_from_sensor_m(
    h0_m: f64,
    lever_gain: f64,
    sensor_height_m: f64,
    lever_compliance_m_per_n: f64,
    wheel_load_kg: f64,
    gravity_m_s2: f64,
) -> f64 {
    let rigid_axle_m = sensor_height_m + lever_compliance_m_per_n * wheel_load_kg * gravity_m_s2;
    bellow_height_from_axle_m(h0_m, lever_gain, rigid_axle_m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sensor_map_and_its_inverse_round_trip() {
        let kl = lever_gain(0.62, 0.28);
        let hb = 0.3;
        let s = sensor_height_m(0.1, kl, hb, 2e-7, 3350.0, 9.81);
        // 0.1 + 0.2/1.4516129 - 2e-7·3350·9.81 = 0.2377778 - 0.0065727
        assert!((s - (0.1 + 0.2 / kl - 2e-7 * 3350.0 * 9.81)).abs() < 1e-15);
        assert!((bellow_height_from_sensor_m(0.1, kl, s, 2e-7, 3350.0, 9.81) - hb).abs() < 1e-15);
    }

    #[test]
    fn gain_and_eq_2_1_by_hand() {
        let kl = lever_gain(0.62, 0.28);
        assert!((kl - 0.9 / 0.62).abs() < 1e-15);
        // axle 0.2 m: 0.1 + 1.4516129 * 0.1 = 0.24516129
        let hb = bellow_height_from_axle_m(0.1, kl, 0.2);
        assert!((hb - 0.245_161_290_3).abs() < 1e-10);
        assert!((axle_height_from_bellow_m(0.1, kl, hb) - 0.2).abs() < 1e-15);
    }

    #[test]
    fn eq_2_2_agrees_with_eq_2_1_for_a_rigid_lever() {
        // Same lever angle seen at the axle (l1 sin α) and at the bellow ((l1+l2) sin α).
        let alpha = 0.25_f64;
        let axle = 0.1 + 0.62 * alpha.sin();
        let hb = bellow_height_from_angle_m(0.1, 0.62, 0.28, alpha);
        assert!((hb - bellow_height_from_axle_m(0.1, lever_gain(0.62, 0.28), axle)).abs() < 1e-15);
        assert!((hb - (0.1 + 0.9 * alpha.sin())).abs() < 1e-15);
    }

    #[test]
    fn sensor_map_by_hand() {
        // h_bellow 0.3: 0.1 + 0.2/1.4516129 = 0.23777778; flex 2e-7*3350*9.81 = 0.0065727
        let s = sensor_height_m(0.1, lever_gain(0.62, 0.28), 0.3, 2.0e-7, 3350.0, 9.81);
        assert!((s - (0.1 + 0.2 * 0.62 / 0.9 - 2.0e-7 * 3350.0 * 9.81)).abs() < 1e-15);
        assert!((s - 0.231_205_078).abs() < 1e-8, "{s}");
    }
}
