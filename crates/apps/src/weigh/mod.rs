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
    Standstill, StandstillDetector, StandstillSignals, friction_state, standstill_mask,
    weigh_standstills,
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
    /// The part of it the sensors' noise makes, kg (empty when the estimator does not split
    /// it off); the rest is the parameters' uncertainty.
    pub measurement_std_kg: Vec<f64>,
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
        series.measurement_std_kg.push(meas);
        series
            .std_kg
            .push((meas * meas + raw[k].parameter_std_kg.powi(2)).sqrt());
    }
    Ok(series)
}

/// How far a sample's estimate can be trusted, from the run alone (no true load needed).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WeighQuality {
    /// A standstill ([`StandstillDetector`]): valve closed long enough, pressure steady
    /// before and after. What an on-board scale is read at.
    Standstill,
    /// Valve closed, but the load or the gas is still moving (a load change, creep and heat
    /// after a valve pulse): the estimate lags or leads the load.
    Settling,
    /// The valve is open: the pressure is not the static one.
    Valve,
}

impl WeighQuality {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Standstill => "standstill",
            Self::Settling => "settling",
            Self::Valve => "valve",
        }
    }
}

/// The quality flag of every sample of `run` (see [`WeighQuality`]).
pub fn quality_flags(
    run: &Run,
    detector: &StandstillDetector,
) -> Result<Vec<WeighQuality>, AppError> {
    let outputs = run.measured()?;
    let (still, _) = standstill_mask(
        &StandstillSignals {
            time_s: &run.time_s,
            height_m: &outputs.sensor_height_m,
            gauge_pa: &outputs.bellow_gauge_pa,
            valve: &run.inputs.valve,
            speed_kmh: &[],
            segment: &[],
        },
        detector,
    )?;
    Ok(run
        .inputs
        .valve
        .iter()
        .zip(&still)
        .map(|(v, &still)| match (v, still) {
            (airsus_data::ValveState::Closed, true) => WeighQuality::Standstill,
            (airsus_data::ValveState::Closed, false) => WeighQuality::Settling,
            _ => WeighQuality::Valve,
        })
        .collect())
}

/// Writes `time_s, wheel_load_kg, wheel_load_std_kg` and, when given, `quality` (one flag per
/// sample, [`WeighQuality::as_str`]) atomically.
pub fn write_weigh_csv(
    path: &Path,
    series: &WeighSeries,
    quality: Option<&[WeighQuality]>,
) -> Result<(), AppError> {
    if series.wheel_load_kg.len() != series.len()
        || series.std_kg.len() != series.len()
        || quality.is_some_and(|q| q.len() != series.len())
    {
        return Err(invalid(
            "load series",
            "time, load, standard deviation and quality differ in length",
        ));
    }
    write_atomically(path, |w: &mut dyn Write| {
        match quality {
            Some(_) => writeln!(w, "time_s,wheel_load_kg,wheel_load_std_kg,quality")?,
            None => writeln!(w, "time_s,wheel_load_kg,wheel_load_std_kg")?,
        }
        for k in 0..series.len() {
            write!(
                w,
                "{},{:.3},{:.3}",
                series.time_s[k], series.wheel_load_kg[k], series.std_kg[k]
            )?;
            match quality {
                Some(q) => writeln!(w, ",{}", q[k].as_str())?,
                None => writeln!(w)?,
            }
        }
        Ok(())
    })?;
    Ok(())
}

/// The wall-friction state of a run's sensor heights, with the standstill detector's Dahl
/// parameters (0 where the run is too short to have a sample time).
fn run_friction_state(time_s: &[f64], height_m: &[f64]) -> Vec<f64> {
    let n = time_s.len();
    if n < 2 {
        return vec![0.0; n];
    }
    let sample_s = (time_s[n - 1] - time_s[0]) / (n - 1) as f64;
    let d = StandstillDetector::default();
    friction_state(height_m, sample_s, d.presliding_m, d.play_m)
}

/// A linear scale calibration `m = gain · m̂ + offset (+ hysteresis · z)`, fitted by least squares on the
/// standstill samples of a run whose load is known (a weighbridge, or the logged load of a
/// loading test). This is what fitters of commercial on-board scales do, and the cheapest way
/// to take out the bias of wrong nominal parameters; it does not replace grey-box estimation
/// (it corrects one working height and the load range it saw, nothing dynamic).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearCalibration {
    pub gain: f64,
    pub offset_kg: f64,
    /// Load read per unit of the wall-friction state `z` ([`friction_state`]: +1 after the
    /// bellow rose, −1 after it sank), kg: the hysteresis, fitted when the heights are given
    /// (the wall friction holds part of the load after a rise, so the gas, and the estimate,
    /// read high after a fill: `hysteresis_kg < 0` takes it out). 0 without heights.
    pub hysteresis_kg: f64,
    /// Residual RMS of the fit, kg.
    pub residual_rms_kg: f64,
    /// 95th percentile of the residuals' magnitude, kg: the half-width of an interval that
    /// held 95 % of the known standstill loads. Wall friction makes the residuals bounded,
    /// not Gaussian, so `1.96 × rms` would cover nearly all of them.
    pub residual_q95_kg: f64,
    pub samples: usize,
}

impl LinearCalibration {
    /// Identity (no calibration).
    pub fn identity() -> Self {
        Self {
            gain: 1.0,
            offset_kg: 0.0,
            hysteresis_kg: 0.0,
            residual_rms_kg: 0.0,
            residual_q95_kg: 0.0,
            samples: 0,
        }
    }

    /// Fits the calibration on the samples where the known load has been steady and the valve
    /// closed for `rule.settle_s` (see [`evaluate`]). Needs at least two distinct load levels.
    /// With the sensor heights, the hysteresis term is fitted too (see [`Self::hysteresis_kg`]).
    pub fn fit(
        time_s: &[f64],
        estimate_kg: &[f64],
        known_kg: &[f64],
        valve: &[airsus_data::ValveState],
        height_m: Option<&[f64]>,
        rule: &StandstillRule,
    ) -> Result<Self, AppError> {
        let n = time_s.len();
        if estimate_kg.len() != n
            || known_kg.len() != n
            || valve.len() != n
            || height_m.is_some_and(|h| h.len() != n)
        {
            return Err(invalid(
                "calibration signals",
                "time, estimate, known load, valve and height differ in length",
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
        let z = match height_m {
            Some(h) => run_friction_state(time_s, h),
            None => vec![0.0; n],
        };
        // Least squares on [estimate, 1, z] (z only with heights), centred so that the 3x3
        // normal equations stay well conditioned; a z that never moves drops out.
        let mean = |v: &dyn Fn(usize) -> f64| idx.iter().map(|&k| v(k)).sum::<f64>() / m;
        let (mx, my, mz) = (
            mean(&|k| estimate_kg[k]),
            mean(&|k| known_kg[k]),
            mean(&|k| z[k]),
        );
        let (mut sxx, mut sxz, mut szz, mut sxy, mut szy) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &k in &idx {
            let (dx, dz, dy) = (estimate_kg[k] - mx, z[k] - mz, known_kg[k] - my);
            sxx += dx * dx;
            sxz += dx * dz;
            szz += dz * dz;
            sxy += dx * dy;
            szy += dz * dy;
        }
        if sxx <= 0.0 {
            return Err(invalid("calibration run", "the estimate does not vary"));
        }
        let det = sxx * szz - sxz * sxz;
        let (gain, hysteresis_kg) =
            if height_m.is_some() && szz > 1e-6 * m && det > 1e-9 * sxx * szz {
                ((sxy * szz - szy * sxz) / det, (szy * sxx - sxy * sxz) / det)
            } else {
                (sxy / sxx, 0.0)
            };
        let offset_kg = my - gain * mx - hysteresis_kg * mz;
        let mut residuals: Vec<f64> = idx
            .iter()
            .map(|&k| {
                (gain * estimate_kg[k] + offset_kg + hysteresis_kg * z[k] - known_kg[k]).abs()
            })
            .collect();
        let residual_rms_kg = (residuals.iter().map(|r| r * r).sum::<f64>() / m).sqrt();
        residuals.sort_by(f64::total_cmp);
        let q95 = residuals[((0.95 * m).ceil() as usize).clamp(1, residuals.len()) - 1];
        Ok(Self {
            gain,
            offset_kg,
            hysteresis_kg,
            residual_rms_kg,
            residual_q95_kg: q95,
            samples: idx.len(),
        })
    }

    /// Applies the calibration to a series.
    ///
    /// The interval then comes from the data, not from assumed parameter errors: what is left
    /// at the calibration's known standstills (wall friction, hysteresis, the law's shape
    /// between the levels, the noise) sets it, `σ = q95 / 1.96` with `q95` the residuals' 95th
    /// percentile, and a sample noisier than the calibration's (a shorter average) widens it,
    /// `σ = max(q95 / 1.96, g σ_meas)`. The assumed parameter part is dropped: the calibration
    /// measured what it does. Without the noise part (the EKF does not split it off), the
    /// standard deviation only scales with the gain: the interval from the residuals is the
    /// static method's.
    ///
    /// The hysteresis term needs the run's sensor heights; without them it is left out.
    pub fn apply(&self, series: &WeighSeries, height_m: Option<&[f64]>) -> WeighSeries {
        let g = self.gain.abs();
        let z = match height_m {
            Some(h) if h.len() == series.len() && self.hysteresis_kg != 0.0 => {
                run_friction_state(&series.time_s, h)
            }
            _ => vec![0.0; series.len()],
        };
        let std_kg = if series.measurement_std_kg.len() == series.len() && self.samples > 0 {
            series
                .measurement_std_kg
                .iter()
                .map(|s| (g * s).max(self.residual_q95_kg / 1.96))
                .collect()
        } else {
            series.std_kg.iter().map(|s| g * s).collect()
        };
        WeighSeries {
            time_s: series.time_s.clone(),
            wheel_load_kg: series
                .wheel_load_kg
                .iter()
                .zip(&z)
                .map(|(m, z)| self.gain * m + self.offset_kg + self.hysteresis_kg * z)
                .collect(),
            std_kg,
            measurement_std_kg: series.measurement_std_kg.iter().map(|s| g * s).collect(),
        }
    }
}
