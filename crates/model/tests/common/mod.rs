//! Shared test helpers: a classical RK4 integrator (the simulation engine is a separate
//! crate; a fixed small step is plenty for these physics checks) and input samples.
#![allow(dead_code)]

use airsus_data::{TruckParameters, ValveState};
use airsus_model::{InputSample, SuspensionModel};

pub const SPRUNG_KG: f64 = 2830.0;

pub fn reference() -> TruckParameters {
    TruckParameters::reference()
}

pub fn input(wheel_load_kg: f64) -> InputSample {
    InputSample {
        wheel_load_kg,
        valve: ValveState::Closed,
        supply_gauge_pa: 850e3,
        road_height_m: 0.0,
        road_rate_m_s: 0.0,
    }
}

/// The reference wheel load: sprung 2830 kg plus the unsprung mass.
pub fn reference_load(truck: &TruckParameters) -> f64 {
    SPRUNG_KG + truck.mass.unsprung_kg
}

/// One classical Runge–Kutta step.
pub fn rk4_step(model: &dyn SuspensionModel, t: f64, x: &mut [f64], u: &InputSample, dt: f64) {
    let n = x.len();
    let mut k1 = vec![0.0; n];
    let mut k2 = vec![0.0; n];
    let mut k3 = vec![0.0; n];
    let mut k4 = vec![0.0; n];
    let mut tmp = vec![0.0; n];
    model.rhs(t, x, u, &mut k1);
    for i in 0..n {
        tmp[i] = x[i] + 0.5 * dt * k1[i];
    }
    model.rhs(t + 0.5 * dt, &tmp, u, &mut k2);
    for i in 0..n {
        tmp[i] = x[i] + 0.5 * dt * k2[i];
    }
    model.rhs(t + 0.5 * dt, &tmp, u, &mut k3);
    for i in 0..n {
        tmp[i] = x[i] + dt * k3[i];
    }
    model.rhs(t + dt, &tmp, u, &mut k4);
    for i in 0..n {
        x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
}

/// Integrates from `t0` for `duration` with step `dt`, calling `observe(t, x)` after each step.
pub fn simulate(
    model: &dyn SuspensionModel,
    x: &mut [f64],
    u: &InputSample,
    t0: f64,
    duration: f64,
    dt: f64,
    mut observe: impl FnMut(f64, &[f64]),
) {
    let steps = (duration / dt).round() as usize;
    for k in 0..steps {
        let t = t0 + k as f64 * dt;
        rk4_step(model, t, x, u, dt);
        observe(t + dt, x);
    }
}
