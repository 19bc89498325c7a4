//! A rigid tank emptied through a valve channel: the lab's discharge test (thesis 5.2.3). The
//! virtual truck's rig logs it and the estimator's orifice fit simulates it, through this one
//! function.
//!
//! States: the amount `n` of air in the tank and its temperature `T`; `p = n R T / V`. The air
//! leaves through `outflow(p, T)` (mol/s) and, with a wall time constant `τ`, cools as it
//! expands and warms again from the wall at room temperature (the first law,
//! [`gas_temperature_rate`] with `dV = 0`); without one it stays at room temperature (the
//! thesis' isothermal assumption, eq 5.5). Solved with diffsol's Tsit45: two smooth, non-stiff
//! states.

use airsus_model::submodels::{GasEnergyBalance, gas_temperature_rate};
use diffsol::{NalgebraMat, OdeBuilder, OdeSolverMethod, VectorCommon};

/// One discharge test, SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TankDischargeProblem<'a> {
    pub volume_m3: f64,
    /// Room (wall) temperature, which the air starts at, K.
    pub room_temperature_k: f64,
    pub start_gauge_pa: f64,
    /// Times at which the tank pressure is wanted, s from the start (increasing, from 0).
    pub times_s: &'a [f64],
    pub gas_constant_j_mol_k: f64,
    pub ambient_pressure_pa: f64,
    /// The tank wall's thermal time constant, s; `None`: isothermal.
    pub thermal_time_s: Option<f64>,
}

/// The tank's gauge pressure at `discharge.times_s`, Pa; `outflow(p_abs, T)` is the flow out,
/// mol/s. An error says why the solver stopped.
pub fn simulate_tank_discharge(
    discharge: &TankDischargeProblem,
    outflow: impl Fn(f64, f64) -> f64,
) -> Result<Vec<f64>, String> {
    let d = *discharge;
    let (r_gas, volume, room) = (d.gas_constant_j_mol_k, d.volume_m3, d.room_temperature_k);
    let rhs = |x: &[f64], _p: &[f64], _t: f64, dx: &mut [f64]| {
        let n = x[0].max(1e-12);
        let t = match d.thermal_time_s {
            Some(_) => x[1].max(1.0),
            None => room,
        };
        let p = n * r_gas * t / volume;
        let out = outflow(p, t);
        dx[0] = -out;
        dx[1] = match d.thermal_time_s {
            Some(tau) => gas_temperature_rate(
                &GasEnergyBalance {
                    amount_mol: n,
                    temperature_k: t,
                    pressure_pa: p,
                    volume_rate_m3_s: 0.0,
                    net_inflow_mol_s: -out,
                    inflow_temperature_k: t,
                    wall_temperature_k: room,
                    thermal_time_constant_s: tau,
                },
                r_gas,
            ),
            None => 0.0,
        };
    };
    // Tsit45 never asks for the Jacobian; a forward difference keeps the closure honest anyway.
    let jac = |x: &[f64], p: &[f64], t: f64, v: &[f64], y: &mut [f64]| {
        let (mut f0, mut f1) = ([0.0; 2], [0.0; 2]);
        let eps = 1e-7 * (1.0 + x[0].abs().max(x[1].abs()));
        rhs(x, p, t, &mut f0);
        rhs(&[x[0] + eps * v[0], x[1] + eps * v[1]], p, t, &mut f1);
        for i in 0..2 {
            y[i] = (f1[i] - f0[i]) / eps;
        }
    };
    let n0 = (d.start_gauge_pa + d.ambient_pressure_pa) * volume / (r_gas * room);
    let ode = OdeBuilder::<NalgebraMat<f64>>::new()
        .rtol(1e-8)
        .atol([1e-9 * n0, 1e-6])
        .rhs_implicit(rhs, jac)
        .init(
            move |_p: &[f64], _t: f64, y: &mut [f64]| y.copy_from_slice(&[n0, room]),
            2,
        )
        .build()
        .map_err(|e| e.to_string())?;
    let mut solver = ode.tsit45().map_err(|e| e.to_string())?;
    let gauge = |x: &[f64]| {
        let t = match d.thermal_time_s {
            Some(_) => x[1],
            None => room,
        };
        x[0] * r_gas * t / volume - d.ambient_pressure_pa
    };
    let Some(&t_end) = d.times_s.last() else {
        return Ok(Vec::new());
    };
    // Stepped by hand on a budget: an orifice whose laminar range near ambient is steep makes
    // the end of a discharge stiff, and the explicit method then crawls (a fit's trial point
    // on a truck whose valve is no orifice took minutes). A normal discharge takes a few
    // hundred steps.
    let budget = STEPS_PER_SAMPLE * d.times_s.len() + 1000;
    let mut out = Vec::with_capacity(d.times_s.len());
    let mut next = 0;
    while next < d.times_s.len() && d.times_s[next] <= solver.state().t {
        out.push(gauge(solver.state().y.inner().as_slice()));
        next += 1;
    }
    if next < d.times_s.len() {
        solver.set_stop_time(t_end).map_err(|e| e.to_string())?;
    }
    let mut steps = 0;
    while next < d.times_s.len() {
        if steps >= budget {
            return Err(format!(
                "the tank's simulation took more than {budget} steps to {:.2} s (stiff: check the valve law)",
                solver.state().t
            ));
        }
        solver.step().map_err(|e| e.to_string())?;
        steps += 1;
        let t_now = solver.state().t;
        while next < d.times_s.len() && d.times_s[next] <= t_now {
            let y = solver
                .interpolate(d.times_s[next])
                .map_err(|e| e.to_string())?;
            out.push(gauge(y.inner().as_slice()));
            next += 1;
        }
    }
    Ok(out)
}

/// The explicit method's step budget per sample (see [`simulate_tank_discharge`]).
const STEPS_PER_SAMPLE: usize = 20;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_linear_outflow_empties_an_isothermal_tank_exponentially() {
        // n' = -k (p - p_amb) with p = n R T / V: the gauge pressure decays as e^(-k R T t / V).
        let times: Vec<f64> = (0..=20).map(|i| f64::from(i) * 0.5).collect();
        let (r, t, v, amb) = (8.314, 293.15, 0.02, 101_325.0);
        let k = 2e-7;
        let d = TankDischargeProblem {
            volume_m3: v,
            room_temperature_k: t,
            start_gauge_pa: 7e5,
            times_s: &times,
            gas_constant_j_mol_k: r,
            ambient_pressure_pa: amb,
            thermal_time_s: None,
        };
        let p = simulate_tank_discharge(&d, |p, _| k * (p - amb)).unwrap();
        for (p, time) in p.iter().zip(&times) {
            let exact = 7e5 * (-k * r * t / v * time).exp();
            assert!((p - exact).abs() < 1e-3, "{time}: {p} {exact}");
        }
        // The cooling gas loses pressure faster than the isothermal one.
        let cooling = simulate_tank_discharge(
            &TankDischargeProblem {
                thermal_time_s: Some(60.0),
                ..d
            },
            |p, _| k * (p - amb),
        )
        .unwrap();
        assert!(cooling[10] < p[10] - 1e3, "{} {}", cooling[10], p[10]);
    }
}
