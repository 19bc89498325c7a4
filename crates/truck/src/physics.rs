//! Physics the thesis' models leave out and the virtual truck carries (SPEC §6), each a small
//! pure function with its source.
//!
//! - Valve flow through an orifice with choking, ISO 6358-1:2013, instead of the linear
//!   (Poiseuille) resistance of eq 3.19: a valve-flow law of the truck file now
//!   (`airsus_data::laws::ValveFlowLaw::Orifice`), re-exported here.
//! - Gas temperature of an open, non-isothermal control volume with heat exchange to the
//!   wall (first law for an ideal gas), instead of the isothermal assumption of thesis 3.1.3.
//! - Bellow wall friction as a Dahl element (rate-independent hysteresis) and wall creep as
//!   a Maxwell element (spring in series with a damper): the slow height drift after load and
//!   height changes the thesis saw in data-sets 1–2 and attributed to the folding rubber wall
//!   (thesis 6.1).

// The orifice law is a valve-flow law of the truck file (`airsus_data::laws`); the gas
// energy balance below uses its air constants.
pub use airsus_data::laws::{
    AIR_MOLAR_MASS_KG_MOL, ISO6358_REFERENCE_DENSITY_KG_M3, ISO6358_REFERENCE_TEMPERATURE_K,
    LAMINAR_PRESSURE_RATIO, iso6358_molar_flow,
};
// The gas's energy balance is the model crate's (the estimator's lab fits use it too).
pub use airsus_model::submodels::{AIR_GAMMA, GasEnergyBalance, gas_temperature_rate};

/// Dahl friction: `dF/dt = σ (v − |v| F / F_c)`. A rate-independent hysteresis force that
/// approaches `±F_c` when sliding and acts as a spring of stiffness `σ` for small reversals.
pub fn dahl_force_rate(
    force_n: f64,
    velocity_m_s: f64,
    stiffness_n_per_m: f64,
    coulomb_force_n: f64,
) -> f64 {
    if coulomb_force_n <= 0.0 {
        return 0.0;
    }
    stiffness_n_per_m * (velocity_m_s - velocity_m_s.abs() * force_n / coulomb_force_n)
}

/// Dahl friction after a monotone displacement `Δ` from force `F₀`: the rate law integrated
/// in closed form over the path (it is rate-independent, so only the path counts),
/// `F = s F_c + (F₀ − s F_c) e^(−σ|Δ|/F_c)` with `s = sign Δ`.
pub fn dahl_force_after_displacement(
    force_n: f64,
    displacement_m: f64,
    stiffness_n_per_m: f64,
    coulomb_force_n: f64,
) -> f64 {
    if coulomb_force_n <= 0.0 || displacement_m == 0.0 {
        return force_n;
    }
    let s = displacement_m.signum() * coulomb_force_n;
    s + (force_n - s) * (-stiffness_n_per_m * displacement_m.abs() / coulomb_force_n).exp()
}

/// Maxwell element (spring `k` in series with a damper `c = k τ`): the damper's position `s`
/// follows the element's elongation `x` with `ds/dt = (x − s)/τ`; the force is `k (x − s)`.
/// After a step in `x` the force relaxes as `e^(−t/τ)`: creep under constant load.
pub fn maxwell_position_rate(
    elongation_m: f64,
    damper_position_m: f64,
    time_constant_s: f64,
) -> f64 {
    (elongation_m - damper_position_m) / time_constant_s.max(1e-6)
}

pub fn maxwell_force(elongation_m: f64, damper_position_m: f64, stiffness_n_per_m: f64) -> f64 {
    stiffness_n_per_m * (elongation_m - damper_position_m)
}

/// A smooth 0→1 ramp of `x` over `[0, 1]` (cubic smoothstep), for governors and valve spool
/// travel that should not jump.
pub fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

#[cfg(test)]
mod tests {
    use super::*;

    const C: f64 = 5e-9; // 0.5 dm³/(s·bar)
    const B: f64 = 0.4;

    #[test]
    fn dahl_after_a_displacement_is_its_rate_law_integrated() {
        let (sigma, fc) = (20_000.0, 120.0);
        for (f0, travel) in [(0.0, 3e-3), (-120.0, 4e-3), (80.0, -2e-3), (-30.0, -10e-3)] {
            // The rate law over the path at 1 µm steps (explicit Euler, far finer than 6 mm).
            let steps = (travel / 1e-6_f64).abs().round() as usize;
            let dx = travel / steps as f64;
            let mut f = f0;
            for _ in 0..steps {
                f += dahl_force_rate(f, dx, sigma, fc);
            }
            let closed = dahl_force_after_displacement(f0, travel, sigma, fc);
            assert!(
                (closed - f).abs() < 0.05,
                "{f0} {travel}: {closed} against {f}"
            );
        }
        // A long travel saturates at the sliding force, either way; none moves nothing.
        assert!((dahl_force_after_displacement(30.0, 1.0, sigma, fc) - fc).abs() < 1e-9);
        assert!((dahl_force_after_displacement(30.0, -1.0, sigma, fc) + fc).abs() < 1e-9);
        assert_eq!(dahl_force_after_displacement(30.0, 0.0, sigma, fc), 30.0);
        assert_eq!(dahl_force_after_displacement(30.0, 1e-3, sigma, 0.0), 30.0);
    }

    #[test]
    fn choked_flow_is_proportional_to_upstream_pressure_only() {
        let t0 = ISO6358_REFERENCE_TEMPERATURE_K;
        let q1 = iso6358_molar_flow(C, B, 900e3, 100e3, t0);
        let q2 = iso6358_molar_flow(C, B, 900e3, 300e3, t0);
        let expected = C * 900e3 * ISO6358_REFERENCE_DENSITY_KG_M3 / AIR_MOLAR_MASS_KG_MOL;
        assert!((q1 - expected).abs() < 1e-12 * expected);
        assert_eq!(
            q1, q2,
            "below the critical ratio the downstream pressure does not matter"
        );
    }

    #[test]
    fn subsonic_flow_follows_the_elliptic_law() {
        let t0 = ISO6358_REFERENCE_TEMPERATURE_K;
        let (p_up, p_down) = (500e3, 400e3);
        let x: f64 = (0.8 - B) / (1.0 - B);
        let expected = C * p_up * ISO6358_REFERENCE_DENSITY_KG_M3 / AIR_MOLAR_MASS_KG_MOL
            * (1.0 - x * x).sqrt();
        let q = iso6358_molar_flow(C, B, p_up, p_down, t0);
        assert!((q - expected).abs() < 1e-12 * expected);
    }

    #[test]
    fn flow_reverses_with_the_pressure_difference_and_vanishes_at_equality() {
        let t = 293.15;
        let forward = iso6358_molar_flow(C, B, 500e3, 450e3, t);
        let backward = iso6358_molar_flow(C, B, 450e3, 500e3, t);
        assert!(forward > 0.0);
        assert!((forward + backward).abs() < 1e-15);
        assert_eq!(iso6358_molar_flow(C, B, 500e3, 500e3, t), 0.0);
    }

    #[test]
    fn laminar_range_joins_continuously() {
        let t = 293.15;
        let p_up = 500e3;
        let at = |r: f64| iso6358_molar_flow(C, B, p_up, r * p_up, t);
        let r = LAMINAR_PRESSURE_RATIO;
        assert!((at(r - 1e-12) - at(r + 1e-12)).abs() < 1e-6 * at(r));
        // Linear inside: half the distance to 1, half the flow.
        let mid = 0.5 * (1.0 + r);
        assert!((at(mid) - 0.5 * at(r)).abs() < 1e-9 * at(r));
    }

    #[test]
    fn hotter_upstream_gas_flows_less_mass() {
        let cold = iso6358_molar_flow(C, B, 900e3, 100e3, 293.15);
        let hot = iso6358_molar_flow(C, B, 900e3, 100e3, 4.0 * 293.15);
        assert!((hot - 0.5 * cold).abs() < 1e-12 * cold);
    }

    fn balance(temperature_k: f64) -> GasEnergyBalance {
        GasEnergyBalance {
            amount_mol: 10.0,
            temperature_k,
            pressure_pa: 4e5,
            volume_rate_m3_s: 0.0,
            net_inflow_mol_s: 0.0,
            inflow_temperature_k: 293.15,
            wall_temperature_k: 293.15,
            thermal_time_constant_s: 20.0,
        }
    }

    #[test]
    fn closed_volume_relaxes_to_the_wall_with_its_time_constant() {
        let r = 8.314462618;
        let rate = gas_temperature_rate(&balance(303.15), r);
        assert!((rate - (-10.0 / 20.0)).abs() < 1e-12);
        assert_eq!(gas_temperature_rate(&balance(293.15), r), 0.0);
    }

    #[test]
    fn adiabatic_compression_follows_t_v_gamma_minus_one() {
        // Integrate dT/dt for a compression at constant dV/dt with no heat exchange and check
        // T V^(γ−1) stays constant.
        let r = 8.314462618;
        let n = 10.0;
        let (mut t, mut v): (f64, f64) = (293.15, 0.07);
        let dv = -0.01; // m³/s
        let invariant = t * v.powf(AIR_GAMMA - 1.0);
        let h = 1e-4;
        for _ in 0..20_000 {
            // Midpoint rule: second order, plenty here.
            let f = |t: f64, v: f64| {
                gas_temperature_rate(
                    &GasEnergyBalance {
                        amount_mol: n,
                        temperature_k: t,
                        pressure_pa: n * r * t / v,
                        volume_rate_m3_s: dv,
                        net_inflow_mol_s: 0.0,
                        inflow_temperature_k: t,
                        wall_temperature_k: t,
                        thermal_time_constant_s: f64::INFINITY,
                    },
                    r,
                )
            };
            let k1 = f(t, v);
            let k2 = f(t + 0.5 * h * k1, v + 0.5 * h * dv);
            t += h * k2;
            v += h * dv;
        }
        assert!((v - 0.05).abs() < 1e-9);
        let after = t * v.powf(AIR_GAMMA - 1.0);
        assert!(
            (after - invariant).abs() < 1e-6 * invariant,
            "{after} vs {invariant}"
        );
        assert!(t > 320.0, "compression heats the gas: {t}");
    }

    #[test]
    fn filling_with_gas_at_the_same_temperature_heats_the_volume() {
        // Flow work: gas pushed in at T_in = T raises T at rate ṅ (c_p − c_v) T /(n c_v).
        let r = 8.314462618;
        let mut b = balance(293.15);
        b.net_inflow_mol_s = 0.5;
        b.thermal_time_constant_s = f64::INFINITY;
        let rate = gas_temperature_rate(&b, r);
        let expected = 0.5 * (AIR_GAMMA - 1.0) * 293.15 / 10.0;
        assert!((rate - expected).abs() < 1e-9);
        // Letting gas out cools what stays.
        b.net_inflow_mol_s = -0.5;
        assert!(gas_temperature_rate(&b, r) < 0.0);
    }

    #[test]
    fn dahl_friction_saturates_at_the_coulomb_force_and_shows_hysteresis() {
        let (sigma, fc) = (1e5, 150.0);
        let mut force = 0.0;
        let h = 1e-4;
        // Slide up at 10 mm/s for 1 s, then down.
        for _ in 0..10_000 {
            force += h * dahl_force_rate(force, 0.01, sigma, fc);
        }
        assert!((force - fc).abs() < 1.0, "saturates: {force}");
        let mut down = force;
        for _ in 0..10_000 {
            down += h * dahl_force_rate(down, -0.01, sigma, fc);
        }
        assert!((down + fc).abs() < 1.0, "reverses to -F_c: {down}");
        assert_eq!(
            dahl_force_rate(42.0, 0.0, sigma, fc),
            0.0,
            "no motion, no change"
        );
    }

    #[test]
    fn maxwell_force_relaxes_exponentially_after_a_step() {
        let (k, tau) = (2e4, 30.0);
        let x = 0.01;
        let mut s = 0.0;
        let h = 1e-3;
        for _ in 0..30_000 {
            s += h * maxwell_position_rate(x, s, tau);
        }
        let force = maxwell_force(x, s, k);
        let expected = k * x * (-1.0f64).exp();
        assert!(
            (force - expected).abs() < 1e-3 * expected,
            "{force} vs {expected}"
        );
    }

    #[test]
    fn smoothstep_is_monotone_and_clamped() {
        assert_eq!(smoothstep(-1.0), 0.0);
        assert_eq!(smoothstep(2.0), 1.0);
        assert_eq!(smoothstep(0.5), 0.5);
        assert!(smoothstep(0.3) < smoothstep(0.31));
    }
}
