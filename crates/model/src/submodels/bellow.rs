//! Bellow force, thesis eq 3.16 with the effective-area polynomial of eq 5.4.

// The thesis' effective-area law (eq 5.4) is a value of the truck file
// (`airsus_data::laws::EffectiveAreaLaw`); its polynomial is evaluated there, once.
pub use airsus_data::laws::{
    EFFECTIVE_AREA_RANGE_M, polynomial_area_m2 as effective_area_m2,
    polynomial_area_slope_m as effective_area_slope_m,
};

/// The quartic of eq 5.4 with the height clamped to [`EFFECTIVE_AREA_RANGE_M`], as every law
/// is evaluated ([`airsus_data::laws::EffectiveAreaLaw::area_clamped_m2`]).
pub fn effective_area_clamped_m2(poly: &[f64; 5], height_m: f64) -> f64 {
    airsus_data::laws::EffectiveAreaLaw::polynomial(*poly).area_clamped_m2(height_m, 0.0)
}

/// Bellow force, N, thesis eq 3.16: `F_ab = (p_abs - p_amb) A_eff(h)`. Positive pushes the
/// chassis and the lever apart (extends the bellow). `gauge_pa = p_abs - p_amb`.
pub fn bellow_force_n(poly: &[f64; 5], height_m: f64, gauge_pa: f64) -> f64 {
    gauge_pa * effective_area_m2(poly, height_m)
}

/// The lowest height in `(0, h_max_m]` where `f` crosses zero upward, found by a scan in
/// steps of `step_m` and bisection to machine precision; `None` when it never does.
///
/// Static equilibria of a bellow solve `p A_eff(h) = F`; the effective area (eq 5.4) rises,
/// peaks and falls over the stroke, so a pressure can have two heights. The upward crossing
/// is the one on the rising branch, the convention every model's `initial_state` follows.
pub fn first_upward_crossing_m(f: impl Fn(f64) -> f64, h_max_m: f64, step_m: f64) -> Option<f64> {
    let mut lo = step_m;
    let mut f_lo = f(lo);
    while lo < h_max_m {
        let hi = (lo + step_m).min(h_max_m);
        let f_hi = f(hi);
        if f_lo <= 0.0 && f_hi > 0.0 {
            let (mut a, mut b) = (lo, hi);
            // 60 halvings take a millimetre bracket below f64 resolution.
            for _ in 0..60 {
                let mid = 0.5 * (a + b);
                if f(mid) <= 0.0 { a = mid } else { b = mid }
            }
            return Some(0.5 * (a + b));
        }
        lo = hi;
        f_lo = f_hi;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_upward_crossing_takes_the_rising_branch() {
        // A hump: rises to 1 at 0.5, falls after; the level 0.75 is crossed at 0.25 (up) and
        // 0.75 (down).
        let hump = |h: f64| 1.0 - 4.0 * (h - 0.5) * (h - 0.5) - 0.75;
        let h = first_upward_crossing_m(hump, 1.0, 1e-3).unwrap();
        assert!((h - 0.25).abs() < 1e-12, "{h}");
        assert_eq!(first_upward_crossing_m(|h| h - 2.0, 1.0, 1e-3), None);
    }

    const REF: [f64; 5] = [-0.0289, 0.8362, -3.0698, 4.9616, -2.9941];

    #[test]
    fn effective_area_by_hand() {
        // h = 0.3: -0.0289 + 0.25086 - 0.276282 + 0.1339632 - 0.02425221 = 0.05538899
        assert!((effective_area_m2(&REF, 0.3) - 0.055_388_99).abs() < 1e-10);
        assert_eq!(effective_area_m2(&REF, 0.0), -0.0289);
        // The corrected p1 keeps the area in 0.050..0.056 m² over the stroke.
        for i in 0..=25 {
            let a = effective_area_m2(&REF, 0.2 + 0.01 * f64::from(i));
            assert!((0.050..0.056).contains(&a), "{a}");
        }
    }

    #[test]
    fn clamped_area_is_held_outside_the_trusted_range() {
        assert_eq!(
            effective_area_clamped_m2(&REF, 0.3),
            effective_area_m2(&REF, 0.3)
        );
        assert_eq!(
            effective_area_clamped_m2(&REF, 2.0),
            effective_area_m2(&REF, 0.60)
        );
        assert_eq!(
            effective_area_clamped_m2(&REF, -1.0),
            effective_area_m2(&REF, 0.05)
        );
        assert!(
            effective_area_m2(&REF, 2.0) < -10.0,
            "the raw quartic diverges"
        );
    }

    #[test]
    fn slope_matches_a_finite_difference() {
        let h = 0.27;
        let d = 1e-6;
        let fd = (effective_area_m2(&REF, h + d) - effective_area_m2(&REF, h - d)) / (2.0 * d);
        assert!((effective_area_slope_m(&REF, h) - fd).abs() < 1e-8);
    }

    #[test]
    fn force_is_gauge_pressure_times_area() {
        // 350 kPa gauge * 0.05538899 m² = 19 386.1465 N
        assert!((bellow_force_n(&REF, 0.3, 350e3) - 19_386.146_5).abs() < 1e-6);
        assert_eq!(bellow_force_n(&REF, 0.3, 0.0), 0.0);
    }
}
