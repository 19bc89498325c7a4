//! Axle-load estimation from bellow pressure and height (SPEC §7, thesis 1.1: on-board weighing).
//!
//! Two estimators, both using only the measured height and pressure (plus, for the filter, the
//! valve command and the supply pressure) — never the logged load:
//! - [`static_law`]: the static force balance inverted, averaged over a short window, with the
//!   uncertainty propagated from the sensors and the parameters;
//! - [`ekf`]: an extended Kalman filter on a suspension model (Model 2 by default) whose state is
//!   augmented by the wheel load as a random walk.
//!
//! [`evaluate`] scores an estimate against the true load of a virtual-truck run.

pub mod ekf;
pub mod evaluate;
pub mod standstill;
pub mod static_law;

use std::io::Write;
use std::path::Path;

use airsus_data::Run;
use airsus_data::atomic::write_atomically;

use crate::error::{AppError, invalid};
pub use ekf::{EkfTuning, LoadEkf, weigh_ekf};
pub use evaluate::{
    AccuracySummary, ErrorStats, StandstillRule, evaluate_weighing, standstill_indices,
};
pub use standstill::{
    Standstill, StandstillDetector, StandstillSignals, friction_state, weigh_standstills,
};
pub use static_law::{LoadEstimate, StaticLaw, StaticWeigher, WeighingUncertainty};

/// A load estimate over time.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WeighSeries {
    pub time_s: Vec<f64>,
    /// Estimated wheel load `m_tot`, kg.
    pub wheel_load_kg: Vec<f64>,
    /// Its standard deviation, kg.
    pub std_kg: Vec<f64>,
}

impl WeighSeries {
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }
}

/// Static weighing of every sample of `run`, averaged over the last `window` samples (causal
/// moving average; `window = 1` is the raw per-sample inversion). The standard deviation of
/// the average divides the sensor part by `√n` (n samples in the window so far) and keeps the
/// parameter part. A sample whose inversion fails (e.g. an empty bellow) is an error naming it.
pub fn weigh_static(
    run: &Run,
    weigher: &StaticWeigher,
    window: usize,
) -> Result<WeighSeries, AppError> {
    let outputs = run.measured()?;
    if window == 0 {
        return Err(invalid(
            "averaging window",
            "it must hold at least one sample",
        ));
    }
    let mut raw = Vec::with_capacity(run.len());
    for (k, (&h, &p)) in outputs
        .sensor_height_m
        .iter()
        .zip(&outputs.bellow_gauge_pa)
        .enumerate()
    {
        let est = weigher.estimate(h, p).map_err(|e| match e {
            AppError::NoStaticSolution { what, reason } => AppError::NoStaticSolution {
                what: format!("{what} at t = {} s (sample {k})", run.time_s[k]),
                reason,
            },
            other => other,
        })?;
        raw.push(est);
    }
    let mut series = WeighSeries {
        time_s: run.time_s.clone(),
        ..WeighSeries::default()
    };
    let mut sum = 0.0;
    for k in 0..raw.len() {
        sum += raw[k].wheel_load_kg;
        if k >= window {
            sum -= raw[k - window].wheel_load_kg;
        }
        let n = (k + 1).min(window) as f64;
        let mean = sum / n;
        let meas = raw[k].measurement_std_kg / n.sqrt();
        series.wheel_load_kg.push(mean);
        series
            .std_kg
            .push((meas * meas + raw[k].parameter_std_kg.powi(2)).sqrt());
    }
    Ok(series)
}

/// Writes `time_s, wheel_load_kg, wheel_load_std_kg` atomically.
pub fn write_weigh_csv(path: &Path, series: &WeighSeries) -> Result<(), AppError> {
    if series.wheel_load_kg.len() != series.len() || series.std_kg.len() != series.len() {
        return Err(invalid(
            "load series",
            "time, load and standard deviation differ in length",
        ));
    }
    write_atomically(path, |w: &mut dyn Write| {
        writeln!(w, "time_s,wheel_load_kg,wheel_load_std_kg")?;
        for k in 0..series.len() {
            writeln!(
                w,
                "{},{:.3},{:.3}",
                series.time_s[k], series.wheel_load_kg[k], series.std_kg[k]
            )?;
        }
        Ok(())
    })?;
    Ok(())
}

/// A linear scale calibration `m = gain · m̂ + offset`, fitted by least squares on the
/// standstill samples of a run whose load is known (a weighbridge, or the logged load of a
/// loading test). This is what fitters of commercial on-board scales do, and the cheapest way
/// to take out the bias of wrong nominal parameters; it does not replace grey-box estimation
/// (it corrects one working height and the load range it saw, nothing dynamic).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearCalibration {
    pub gain: f64,
    pub offset_kg: f64,
    /// Residual RMS of the fit, kg.
    pub residual_rms_kg: f64,
    pub samples: usize,
}

impl LinearCalibration {
    /// Identity (no calibration).
    pub fn identity() -> Self {
        Self {
            gain: 1.0,
            offset_kg: 0.0,
            residual_rms_kg: 0.0,
            samples: 0,
        }
    }

    /// Fits the calibration on the samples where the known load has been steady and the valve
    /// closed for `rule.settle_s` (see [`evaluate`]). Needs at least two distinct load levels.
    pub fn fit(
        time_s: &[f64],
        estimate_kg: &[f64],
        known_kg: &[f64],
        valve: &[airsus_data::ValveState],
        rule: &StandstillRule,
    ) -> Result<Self, AppError> {
        let n = time_s.len();
        if estimate_kg.len() != n || known_kg.len() != n || valve.len() != n {
            return Err(invalid(
                "calibration signals",
                "time, estimate, known load and valve differ in length",
            ));
        }
        let idx = evaluate::standstill_indices(time_s, known_kg, valve, rule);
        let levels = {
            let mut l: Vec<f64> = idx.iter().map(|&k| (known_kg[k] / 10.0).round()).collect();
            l.sort_by(f64::total_cmp);
            l.dedup();
            l.len()
        };
        if levels < 2 {
            return Err(invalid(
                "calibration run",
                format!(
                    "it has {levels} steady load level(s) with the valve closed for {} s; a gain and an offset need at least two",
                    rule.settle_s
                ),
            ));
        }
        let m = idx.len() as f64;
        let mean_x = idx.iter().map(|&k| estimate_kg[k]).sum::<f64>() / m;
        let mean_y = idx.iter().map(|&k| known_kg[k]).sum::<f64>() / m;
        let (mut sxx, mut sxy) = (0.0, 0.0);
        for &k in &idx {
            let dx = estimate_kg[k] - mean_x;
            sxx += dx * dx;
            sxy += dx * (known_kg[k] - mean_y);
        }
        if sxx <= 0.0 {
            return Err(invalid("calibration run", "the estimate does not vary"));
        }
        let gain = sxy / sxx;
        let offset_kg = mean_y - gain * mean_x;
        let residual_rms_kg = (idx
            .iter()
            .map(|&k| (gain * estimate_kg[k] + offset_kg - known_kg[k]).powi(2))
            .sum::<f64>()
            / m)
            .sqrt();
        Ok(Self {
            gain,
            offset_kg,
            residual_rms_kg,
            samples: idx.len(),
        })
    }

    /// Applies the calibration to a series (the standard deviation scales with the gain).
    pub fn apply(&self, series: &WeighSeries) -> WeighSeries {
        WeighSeries {
            time_s: series.time_s.clone(),
            wheel_load_kg: series
                .wheel_load_kg
                .iter()
                .map(|m| self.gain * m + self.offset_kg)
                .collect(),
            std_kg: series.std_kg.iter().map(|s| self.gain.abs() * s).collect(),
        }
    }
}
