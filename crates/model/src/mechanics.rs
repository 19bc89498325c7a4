//! Rigid-body mechanics of QCM 2: chassis height `x` and lever angle `α` (Lagrange's equations
//! derived in [`crate::m2`], which replace the thesis' eq 3.10–3.12). Shared by Model 2, its
//! extensions and any richer model on the same lever (the virtual truck), so the corrected
//! derivation lives in one place.

/// Masses and lever lengths of one corner at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeverBody {
    /// `M = m1 + m2`, kg.
    pub total_kg: f64,
    /// `m2`, the axle on the lever at `l1`, kg.
    pub unsprung_kg: f64,
    /// `I_g` about the hinge, kg m².
    pub inertia_kg_m2: f64,
    pub l1_m: f64,
    /// `l1 + l2`: hinge to bellow, m.
    pub l12_m: f64,
    /// `l1 + l3`: hinge to damper, m.
    pub l13_m: f64,
    pub gravity_m_s2: f64,
}

/// Forces on the lever, N, each positive in the direction named.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LeverForces {
    /// Tire force pushing the axle up.
    pub tire_n: f64,
    /// Total bellow force pushing the lever down (away from the chassis): gas force plus any
    /// slow, creep or friction force acting in the bellow.
    pub bellow_n: f64,
    /// Damper force resisting extension (+ = extension, SPEC §5 `[damper]`).
    pub damper_n: f64,
    /// Hinge friction force at the axle resisting the axle-to-chassis rate.
    pub friction_n: f64,
}

/// The smallest lever inertia, as a multiple of `c²/M` (see [`lever_accelerations`]).
pub const MIN_INERTIA_MARGIN: f64 = 1.1;

/// `(ẍ, α̈)` from
/// ```text
/// M ẍ - c α̈ = F_w - M g - m2 l1 sin α α̇²
/// -c ẍ + I_g α̈ = cos α [ l1 (m2 g - F_w) + (l1+l2) F_b - (l1+l3) F_d - l1 F_f ]
/// ```
/// with `c = m2 l1 cos α`, solved in closed form. `I_g` is floored at
/// [`MIN_INERTIA_MARGIN`]` · c²/M` (comment in the body).
pub fn lever_accelerations(
    body: &LeverBody,
    sin_a: f64,
    cos_a: f64,
    alpha_dot: f64,
    forces: &LeverForces,
) -> (f64, f64) {
    let g = body.gravity_m_s2;
    let m2 = body.unsprung_kg;
    let total = body.total_kg;
    let coupling = m2 * body.l1_m * cos_a;
    // The mass matrix [[M, c], [c, I_g]] is positive definite only for I_g > c²/M: below that
    // the lever would have negative kinetic energy and the model blows up within milliseconds
    // (a grey-box fit drove I_g there when the runs did not determine it). I_g is floored
    // just above it, so the model stays finite and continuous and such an I_g shows as no
    // sensitivity. The axle alone gives I_g ≥ m2 l1², far above the floor, on a real truck.
    let inertia = if total > 0.0 {
        body.inertia_kg_m2
            .max(MIN_INERTIA_MARGIN * coupling * coupling / total)
    } else {
        body.inertia_kg_m2
    };
    let r_x = forces.tire_n - total * g - m2 * body.l1_m * sin_a * alpha_dot * alpha_dot;
    let q_alpha = cos_a
        * (body.l1_m * (m2 * g - forces.tire_n) + body.l12_m * forces.bellow_n
            - body.l13_m * forces.damper_n
            - body.l1_m * forces.friction_n);
    // det > 0 by the floor above; this one only keeps absurd (zero-mass) bodies finite.
    let det = (total * inertia - coupling * coupling).max(1e-9 * total * inertia);
    (
        (inertia * r_x + coupling * q_alpha) / det,
        (coupling * r_x + total * q_alpha) / det,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn body() -> LeverBody {
        LeverBody {
            total_kg: 3350.0,
            unsprung_kg: 520.0,
            inertia_kg_m2: 200.0,
            l1_m: 0.62,
            l12_m: 0.90,
            l13_m: 0.74,
            gravity_m_s2: 9.81,
        }
    }

    #[test]
    fn static_balance_gives_zero_acceleration() {
        let b = body();
        let forces = LeverForces {
            tire_n: b.total_kg * b.gravity_m_s2,
            bellow_n: (b.total_kg - b.unsprung_kg) * b.gravity_m_s2 * b.l1_m / b.l12_m,
            ..Default::default()
        };
        let (xdd, add) = lever_accelerations(&b, 0.2_f64.sin(), 0.2_f64.cos(), 0.0, &forces);
        assert!(xdd.abs() < 1e-12 && add.abs() < 1e-12, "{xdd} {add}");
    }

    #[test]
    fn without_tire_or_bellow_the_corner_falls_freely_and_the_lever_keeps_its_angle() {
        // No tire, no bellow: everything falls at g; the lever's own weight torque is carried
        // by the hinge's acceleration, so α̈ = 0 exactly.
        let (xdd, add) = lever_accelerations(
            &body(),
            0.3_f64.sin(),
            0.3_f64.cos(),
            0.0,
            &LeverForces::default(),
        );
        assert!((xdd + 9.81).abs() < 1e-12, "{xdd}");
        assert!(add.abs() < 1e-12, "{add}");
    }
}
