//! The slow-dynamics OE model of Model 2 extended from one isolated load step (thesis
//! 5.2.4, Tables 5.4/5.5): input the load change (kg), output the slow height change (m),
//! default orders `nb = 1, nf = 1, nk = 2`, fitted with [`airsus_ident::linear::oe`].
//!
//! Isolating the slow part (thesis: "the slow dynamics in one step is isolated … the static
//! relation is removed, meaning that the initial values of the input and output signal are
//! zero"): the window starts `settle_s` after the load step, when the fast mechanical
//! response (chassis and wheel modes, < 1 s) has settled, and ends at the next load change
//! (or the run's end, or `window_s`). There
//!
//! ```text
//! u_k = Δm                           (the load step, held)
//! y_k = h(t_a + k Ts) − h(t_a)       (height change since the window start, t_a)
//! ```
//!
//! so both start at zero; a few zero samples (10 + `nk`) are put before the window, the
//! step applied at `t_a`. What the fast response leaves, the slow creep, is what the OE
//! block models (the `m2x` model scales its output by `k_sd` into a bellow force).
//!
//! **Settling correction.** The creep starts at the step, not at `t_a`; by `t_a` a first-order
//! creep has already covered `1 − a^{n_s}` of its way (`a = −f1` the pole, `n_s` the settle
//! samples), so the window sees the gain scaled by `a^{n_s}`. For `nf = 1` the numerator is
//! divided by `a^{n_s}` to give the step's full creep (reported as `gain_correction`); for
//! higher orders no correction is applied (and the report says so).

use airsus_data::{Run, TruckParameters};
use airsus_ident::linear::{Estimate, IdData, OeOrders, PemOptions, oe};
use serde::Serialize;

use crate::error::EstimateError;

const FIT: &str = "slow-dynamics fit";
/// Zero samples put before the window (plus the input delay).
const PRE_SAMPLES: usize = 10;

#[derive(Debug, Clone, PartialEq)]
pub struct SlowDynamicsOptions {
    pub orders: OeOrders,
    /// Time of the load step to use, s; `None`: the largest load change of the run.
    pub step_time_s: Option<f64>,
    /// Time after the step before the window starts, s.
    pub settle_s: f64,
    /// Longest window, s; `None`: up to the next load change or the run's end.
    pub window_s: Option<f64>,
    pub pem: PemOptions,
}

impl Default for SlowDynamicsOptions {
    fn default() -> Self {
        Self {
            orders: OeOrders::siso(1, 1, 2),
            step_time_s: None,
            settle_s: 3.0,
            window_s: None,
            pem: PemOptions::default(),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SlowDynamicsFit {
    /// The OE estimate on the window (parameters with standard deviations, NRMSE as
    /// `simulation_fit_percent`).
    pub estimate: Estimate,
    /// `b1..` after the settling correction, m/kg.
    pub b: Vec<f64>,
    /// `f1..` (monic `F` without its leading 1).
    pub f: Vec<f64>,
    pub nk: usize,
    pub sample_time_s: f64,
    /// The step used: time, s, and size, kg.
    pub step_time_s: f64,
    pub step_kg: f64,
    /// Window start and end, s.
    pub window_s: (f64, f64),
    /// Factor the numerator was divided by (1 when not applied).
    pub gain_correction: f64,
    /// Static gain `B(1)/F(1)` after correction, m/kg.
    pub static_gain_m_per_kg: f64,
    /// `−Ts / ln(−f1)` for a first-order stable positive pole, s.
    pub time_constant_s: Option<f64>,
    /// NRMSE of the OE simulation on the window, percent (thesis: 95.8 %).
    pub nrmse_percent: f64,
}

impl SlowDynamicsFit {
    /// Writes the OE block into the truck's `[slow_dynamics]` (what `m2x` uses).
    pub fn write_to(&self, truck: &mut TruckParameters) {
        let sd = &mut truck.slow_dynamics;
        sd.oe_b = self.b.clone();
        sd.oe_f = self.f.clone();
        sd.oe_nk = self.nk;
        sd.oe_sample_time_s = self.sample_time_s;
    }
}

pub fn fit_slow_dynamics(
    run: &Run,
    options: &SlowDynamicsOptions,
) -> Result<SlowDynamicsFit, EstimateError> {
    let bad = |reason: String| EstimateError::InsufficientData {
        fit: FIT,
        reason: format!("run `{}`: {reason}", run.name),
    };
    let out = run
        .outputs
        .as_ref()
        .ok_or_else(|| bad("it has no measured height".to_owned()))?;
    let load = &run.inputs.wheel_load_kg;
    let n = run.len();
    if n < 3 {
        return Err(bad(format!("{n} samples")));
    }
    if !(options.settle_s.is_finite() && options.settle_s >= 0.0) {
        return Err(EstimateError::InvalidOption(format!(
            "settle_s must be non-negative, got {}",
            options.settle_s
        )));
    }
    let ts = run.sample_time_s;
    let change = |k: usize| load[k] - load[k - 1];
    let k_step = match options.step_time_s {
        Some(t) => (1..n)
            .filter(|&k| run.time_s[k] >= t - 0.5 * ts && change(k) != 0.0)
            .find(|&k| run.time_s[k] <= t + 5.0)
            .ok_or_else(|| bad(format!("no load change within 5 s after t = {t} s")))?,
        None => (1..n)
            .max_by(|&a, &b| change(a).abs().total_cmp(&change(b).abs()))
            .filter(|&k| change(k) != 0.0)
            .ok_or_else(|| bad("the load never changes".to_owned()))?,
    };
    let step_kg = change(k_step);
    let settle = (options.settle_s / ts).round() as usize;
    let start = k_step + settle;
    let mut end = (start + 1..n).find(|&k| change(k) != 0.0).unwrap_or(n);
    if let Some(w) = options.window_s {
        end = end.min(start + (w / ts).round() as usize);
    }
    let needed = 10 * (options.orders.nk.iter().sum::<usize>() + 2).max(5);
    if start >= n || end.saturating_sub(start) < needed {
        return Err(bad(format!(
            "the window after the step at t = {} s has {} samples; at least {needed} are needed (a shorter settle_s, or a step with more time before the next)",
            run.time_s[k_step],
            end.saturating_sub(start)
        )));
    }
    // Zeros before the window: the slow part starts from rest at t_a (and an estimator
    // cannot identify anything from an input that never changes).
    let pre = PRE_SAMPLES + options.orders.nk.first().copied().unwrap_or(0);
    let mut y = vec![0.0; pre];
    y.extend((start..end).map(|k| out.sensor_height_m[k] - out.sensor_height_m[start]));
    let mut u = vec![0.0; pre];
    u.resize(y.len(), step_kg);
    let data = IdData::siso(y, u, ts)?;
    let estimate = oe(&data, &options.orders, &options.pem)?;
    let model = &estimate.model;
    let mut b = model.b.first().cloned().unwrap_or_default();
    let f: Vec<f64> = model
        .f
        .first()
        .map(|f| f.iter().skip(1).copied().collect())
        .unwrap_or_default();
    let nk = model.nk.first().copied().unwrap_or(0);
    let pole = f.first().map(|f1| -f1);
    let first_order_pole = (f.len() == 1)
        .then_some(pole)
        .flatten()
        .filter(|a| *a > 0.0 && *a < 1.0);
    let gain_correction = first_order_pole.map_or(1.0, |a| a.powi(settle as i32));
    for bi in &mut b {
        *bi /= gain_correction;
    }
    let f_at_1 = 1.0 + f.iter().sum::<f64>();
    let static_gain = b.iter().sum::<f64>() / f_at_1;
    let nrmse_percent = estimate
        .simulation_fit_percent
        .unwrap_or(estimate.fit_percent);
    Ok(SlowDynamicsFit {
        b,
        f,
        nk,
        sample_time_s: ts,
        step_time_s: run.time_s[k_step],
        step_kg,
        window_s: (run.time_s[start], run.time_s[end - 1]),
        gain_correction,
        static_gain_m_per_kg: static_gain,
        time_constant_s: first_order_pole.map(|a| -ts / a.ln()),
        nrmse_percent,
        estimate,
    })
}
