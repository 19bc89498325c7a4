//! Scoring a load estimate against the true load (the virtual truck's `truth/` runs).
//!
//! A sample counts as **standstill** when, over the `settle_s` before it, the true load did not
//! change (by more than `steady_tolerance_kg`) and the valve stayed closed: what a truck's
//! on-board scale is read at. A standstill sample is **after valve activity** when the valve
//! was open at some time in the `after_valve_window_s` before that settling period, and
//! **quiet** otherwise. A sample is **during valve activity** when the valve is open or closed
//! less than `settle_s` ago while the load has been steady for `load_settle_s` (a levelling
//! controller at work after a load change: what the estimate reads while the air moves). A
//! sample is **driving** when the road under the wheel moved less than `settle_s` ago while
//! the load has been steady for `load_settle_s` (when the run logs the road): it is no
//! standstill, whatever the valve did. A sample is **load change** while the load changes and
//! less than `load_settle_s` after it last changed (what the estimate lags while a load
//! arrives), and **settling** at a steady load with the valve closed and the road still but
//! not yet rested `settle_s` (after a load change, and a run's first `settle_s`).

use airsus_data::{Run, ValveState};

use crate::weigh::WeighSeries;

use crate::error::{AppError, invalid};

/// When a sample counts as standstill (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct StandstillRule {
    pub settle_s: f64,
    pub after_valve_window_s: f64,
    pub steady_tolerance_kg: f64,
    /// How long the load must have been steady for a sample to count as during valve
    /// activity, s (a load still arriving is not the valve's doing).
    pub load_settle_s: f64,
    /// How far the bellow pressure may trail the load the truck feels while a load
    /// arrives, s: the felt load lies between the pressure's reading now and this much
    /// later (the calibration's `loading` interval, [`super::LinearCalibration`]). Measured
    /// 0.12-0.18 s on the virtual-truck variants (the wall friction and the damper).
    pub pressure_lag_s: f64,
}

impl Default for StandstillRule {
    /// 30 s of rest (a driver reads the scale after the loading has stopped); valve activity
    /// within the 120 s before that counts as "after valve activity".
    fn default() -> Self {
        Self {
            settle_s: 30.0,
            after_valve_window_s: 120.0,
            steady_tolerance_kg: 0.5,
            load_settle_s: 10.0,
            pressure_lag_s: 0.3,
        }
    }
}

/// Error statistics of `estimate - truth` over a set of samples.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ErrorStats {
    pub samples: usize,
    pub mean_error_kg: f64,
    pub rms_error_kg: f64,
    pub max_abs_error_kg: f64,
    /// Mean of `100 (est - true) / true`.
    pub mean_error_percent: f64,
    pub max_abs_error_percent: f64,
    /// Fraction of samples within ±1 % of the true load.
    pub within_1_percent: f64,
    /// Mean of the estimator's own standard deviation, kg.
    pub mean_std_kg: f64,
    /// Fraction of samples whose true load lies inside the estimate's 95 % interval
    /// (`± 1.96 σ`): an honest interval covers about 0.95, a too wide one about 1.
    pub within_95_interval: f64,
}

/// Accuracy over one run.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AccuracySummary {
    pub all: ErrorStats,
    pub standstill: ErrorStats,
    pub quiet_standstill: ErrorStats,
    pub after_valve: ErrorStats,
    /// Samples with the valve open or closed less than `settle_s` ago, the load steady.
    pub valve_activity: ErrorStats,
    /// Samples with the road moving or moved less than `settle_s` ago, the load steady.
    pub driving: ErrorStats,
    /// Samples while the load changes and less than `load_settle_s` after it last changed,
    /// whatever the valve and the road do: what the estimate lags while a load arrives (the
    /// other classes wait for a steady load).
    pub load_change: ErrorStats,
    /// Samples at a steady load with the valve closed and the road still, not yet rested
    /// `settle_s` (the 10-30 s after a load change, and a run's first `settle_s`): what the
    /// estimate misses while the truck settles.
    pub settling: ErrorStats,
    /// Mean standstill error per true load level (rounded to 10 kg): `(load_kg, stats)`.
    pub by_load_level: Vec<(f64, ErrorStats)>,
}

fn stats(idx: &[usize], est: &[f64], truth: &[f64], std: &[f64]) -> ErrorStats {
    if idx.is_empty() {
        return ErrorStats::default();
    }
    let n = idx.len() as f64;
    let mut s = ErrorStats {
        samples: idx.len(),
        ..ErrorStats::default()
    };
    let mut within = 0usize;
    let mut covered = 0usize;
    for &k in idx {
        let e = est[k] - truth[k];
        let pct = 100.0 * e / truth[k];
        s.mean_error_kg += e / n;
        s.rms_error_kg += e * e / n;
        s.max_abs_error_kg = s.max_abs_error_kg.max(e.abs());
        s.mean_error_percent += pct / n;
        s.max_abs_error_percent = s.max_abs_error_percent.max(pct.abs());
        s.mean_std_kg += std[k] / n;
        if pct.abs() <= 1.0 {
            within += 1;
        }
        if e.abs() <= 1.96 * std[k] {
            covered += 1;
        }
    }
    s.rms_error_kg = s.rms_error_kg.sqrt();
    s.within_1_percent = within as f64 / n;
    s.within_95_interval = covered as f64 / n;
    s
}

/// Scores `estimate_kg` (with its standard deviation `std_kg`) against `true_kg`; `road_m`,
/// the road under the wheel where the run logs it, tells driving from standing.
pub fn evaluate_weighing(
    time_s: &[f64],
    estimate_kg: &[f64],
    std_kg: &[f64],
    true_kg: &[f64],
    valve: &[ValveState],
    road_m: Option<&[f64]>,
    rule: &StandstillRule,
) -> Result<AccuracySummary, AppError> {
    let n = time_s.len();
    if [estimate_kg.len(), std_kg.len(), true_kg.len(), valve.len()]
        .iter()
        .chain(road_m.map(<[f64]>::len).as_ref())
        .any(|&l| l != n)
    {
        return Err(invalid(
            "evaluation signals",
            "time, estimate, std, true load, valve and road must have the same length",
        ));
    }
    if let Some(k) = true_kg.iter().position(|m| !(m.is_finite() && *m > 0.0)) {
        return Err(invalid(
            "true load",
            format!("sample {k} is {} kg; it must be positive", true_kg[k]),
        ));
    }
    let Classes {
        standstill,
        quiet,
        after,
        valve_activity,
        driving,
        load_change,
        settling,
    } = classify(time_s, true_kg, valve, road_m, rule);
    let all: Vec<usize> = (0..n).collect();
    let mut levels: Vec<(f64, Vec<usize>)> = Vec::new();
    for &k in &standstill {
        let level = (true_kg[k] / 10.0).round() * 10.0;
        match levels.iter_mut().find(|(l, _)| *l == level) {
            Some((_, v)) => v.push(k),
            None => levels.push((level, vec![k])),
        }
    }
    levels.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(AccuracySummary {
        all: stats(&all, estimate_kg, true_kg, std_kg),
        standstill: stats(&standstill, estimate_kg, true_kg, std_kg),
        quiet_standstill: stats(&quiet, estimate_kg, true_kg, std_kg),
        after_valve: stats(&after, estimate_kg, true_kg, std_kg),
        valve_activity: stats(&valve_activity, estimate_kg, true_kg, std_kg),
        driving: stats(&driving, estimate_kg, true_kg, std_kg),
        load_change: stats(&load_change, estimate_kg, true_kg, std_kg),
        settling: stats(&settling, estimate_kg, true_kg, std_kg),
        by_load_level: levels
            .into_iter()
            .map(|(l, idx)| (l, stats(&idx, estimate_kg, true_kg, std_kg)))
            .collect(),
    })
}

/// [`evaluate_weighing`] of a weighed `series` of `run` against the true load `true_kg`,
/// with the run's valve and its logged road (one value per sample; a run without a road
/// logs zeros, which never move).
pub fn evaluate_series(
    run: &Run,
    true_kg: &[f64],
    series: &WeighSeries,
    rule: &StandstillRule,
) -> Result<AccuracySummary, AppError> {
    evaluate_weighing(
        &run.time_s,
        &series.wheel_load_kg,
        &series.std_kg,
        true_kg,
        &run.inputs.valve,
        Some(&run.inputs.road_height_m),
        rule,
    )
}

/// Indices of the standstill samples (module docs): with the logged road (`road_m`, one value
/// per sample), a sample less than `rule.settle_s` after the road moved is driving, no
/// standstill.
pub fn standstill_indices(
    time_s: &[f64],
    load_kg: &[f64],
    valve: &[ValveState],
    road_m: Option<&[f64]>,
    rule: &StandstillRule,
) -> Vec<usize> {
    classify(time_s, load_kg, valve, road_m, rule).standstill
}

/// The load's changes by more than `rule.steady_tolerance_kg` from the level it had
/// settled at: `(index, the level before, the level after)` (a drift within the tolerance
/// accumulates until it exceeds it).
pub(crate) fn load_steps(load_kg: &[f64], rule: &StandstillRule) -> Vec<(usize, f64, f64)> {
    let mut steps = Vec::new();
    let mut reference_load = load_kg.first().copied().unwrap_or(0.0);
    for (k, &m) in load_kg.iter().enumerate() {
        if (m - reference_load).abs() > rule.steady_tolerance_kg {
            steps.push((k, reference_load, m));
            reference_load = m;
        }
    }
    steps
}

/// At every sample, the time the load last moved by more than `rule.steady_tolerance_kg`
/// from the level it had settled at (−∞ before the first change; [`load_steps`]).
pub(crate) fn last_load_change_s(
    time_s: &[f64],
    load_kg: &[f64],
    rule: &StandstillRule,
) -> Vec<f64> {
    let mut steps = load_steps(load_kg, rule).into_iter().peekable();
    let mut last_change_s = f64::NEG_INFINITY;
    time_s
        .iter()
        .enumerate()
        .map(|(k, &t)| {
            if steps.next_if(|step| step.0 == k).is_some() {
                last_change_s = t;
            }
            last_change_s
        })
        .collect()
}

/// Sample indices of each class (module docs).
struct Classes {
    standstill: Vec<usize>,
    quiet: Vec<usize>,
    after: Vec<usize>,
    valve_activity: Vec<usize>,
    driving: Vec<usize>,
    load_change: Vec<usize>,
    settling: Vec<usize>,
}

/// The least change of the logged road between samples that counts as the road moving, m:
/// half the file's resolution (a hundredth of a millimetre), so that one step of it counts
/// whatever the conversion from millimetres rounds it to.
const ROAD_MOVES_M: f64 = 5e-6;

fn classify(
    time_s: &[f64],
    true_kg: &[f64],
    valve: &[ValveState],
    road_m: Option<&[f64]>,
    rule: &StandstillRule,
) -> Classes {
    let n = time_s.len().min(true_kg.len()).min(valve.len());
    let mut standstill = Vec::new();
    let mut quiet = Vec::new();
    let mut after = Vec::new();
    let mut valve_activity = Vec::new();
    let mut driving = Vec::new();
    let mut load_change = Vec::new();
    let mut settling = Vec::new();
    // Last time the load changed, the valve was open or the road moved, scanning forward.
    let load_changed_s = last_load_change_s(&time_s[..n], &true_kg[..n], rule);
    let mut last_valve_s = f64::NEG_INFINITY;
    let mut last_road_s = f64::NEG_INFINITY;
    for k in 0..n {
        let t = time_s[k];
        let last_change_s = load_changed_s[k];
        if valve[k] != ValveState::Closed {
            last_valve_s = t;
        }
        if let Some(road) = road_m
            && k > 0
            && (road[k] - road[k - 1]).abs() > ROAD_MOVES_M
        {
            last_road_s = t;
        }
        let since_start = t - time_s[0];
        let rested = t - last_change_s.max(last_valve_s).max(last_road_s);
        let load_steady = t - last_change_s >= rule.load_settle_s;
        if t - last_valve_s < rule.settle_s && load_steady {
            valve_activity.push(k);
        }
        if t - last_road_s < rule.settle_s && load_steady {
            driving.push(k);
        }
        if !load_steady {
            load_change.push(k);
        }
        if since_start >= rule.settle_s && rested >= rule.settle_s {
            standstill.push(k);
            if t - last_valve_s <= rule.settle_s + rule.after_valve_window_s {
                after.push(k);
            } else {
                quiet.push(k);
            }
        } else if load_steady
            && t - last_valve_s >= rule.settle_s
            && t - last_road_s >= rule.settle_s
        {
            settling.push(k);
        }
    }
    Classes {
        standstill,
        quiet,
        after,
        valve_activity,
        driving,
        load_change,
        settling,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 300 s at 1 s, a steady load, the valve closed, the road moving from 100 to 150 s.
    #[test]
    fn a_moving_road_is_driving_not_standstill() {
        let time: Vec<f64> = (0..=300).map(f64::from).collect();
        let n = time.len();
        let truth = vec![3000.0; n];
        let estimate: Vec<f64> = (0..n)
            .map(|k| {
                if (100..150).contains(&k) {
                    3030.0
                } else {
                    3001.0
                }
            })
            .collect();
        let std = vec![10.0; n];
        let valve = vec![ValveState::Closed; n];
        let road: Vec<f64> = time
            .iter()
            .map(|&t| {
                if (100.0..150.0).contains(&t) {
                    0.01 * (t * 0.7).sin()
                } else {
                    0.0
                }
            })
            .collect();
        let rule = StandstillRule::default();
        let scored = |road: Option<&[f64]>| {
            evaluate_weighing(&time, &estimate, &std, &truth, &valve, road, &rule).unwrap()
        };
        let with_road = scored(Some(&road));
        // Driving: from the road's first move (100 s) to 30 s after its last (150 s, back on
        // the level).
        assert_eq!(with_road.driving.samples, 180 - 100, "{with_road:?}");
        assert!((with_road.driving.max_abs_error_kg - 30.0).abs() < 1e-9);
        // The standstills are the rest after the first 30 s: the driving error stays out.
        assert_eq!(with_road.standstill.samples, (100 - 30) + (301 - 180));
        assert!((with_road.standstill.max_abs_error_kg - 1.0).abs() < 1e-9);
        // Without the road the whole run after its first 30 s reads as standing.
        let without = scored(None);
        assert_eq!(without.driving.samples, 0);
        assert_eq!(without.standstill.samples, 301 - 30);
        assert!((without.standstill.max_abs_error_kg - 30.0).abs() < 1e-9);
        // No load change: nothing lags one; the run's first 30 s are settling.
        assert_eq!(with_road.load_change.samples, 0);
        assert_eq!(with_road.settling.samples, 30);
        // A road of another length is an error.
        let err = evaluate_weighing(
            &time,
            &estimate,
            &std,
            &truth,
            &valve,
            Some(&road[1..]),
            &rule,
        );
        assert!(err.is_err());
    }

    /// Every sample lands in a class: a load step at 100 s (over 5 s), a fill at 200-205 s.
    #[test]
    fn a_load_change_and_its_settling_are_scored_apart() {
        let time: Vec<f64> = (0..=400).map(f64::from).collect();
        let n = time.len();
        let truth: Vec<f64> = time
            .iter()
            .map(|&t| 3000.0 + 300.0 * ((t - 100.0) / 5.0).clamp(0.0, 1.0))
            .collect();
        // The estimate lags the step by 20 kg while it arrives, 5 kg while it settles.
        let estimate: Vec<f64> = time
            .iter()
            .zip(&truth)
            .map(|(&t, &m)| match t {
                t if (100.0..115.0).contains(&t) => m - 20.0,
                t if (115.0..135.0).contains(&t) => m - 5.0,
                _ => m,
            })
            .collect();
        let valve: Vec<ValveState> = time
            .iter()
            .map(|&t| {
                if (200.0..205.0).contains(&t) {
                    ValveState::Fill
                } else {
                    ValveState::Closed
                }
            })
            .collect();
        let a = evaluate_weighing(
            &time,
            &estimate,
            &[10.0; 401],
            &truth,
            &valve,
            None,
            &StandstillRule::default(),
        )
        .unwrap();
        // The load moves from 101 s to 105 s and is steady 10 s after: 101-114 s.
        assert_eq!(a.load_change.samples, 14, "{a:?}");
        assert!((a.load_change.max_abs_error_kg - 20.0).abs() < 1e-9);
        // Settling: the run's first 30 s and 115-134 s (standstill from 135 s).
        assert_eq!(a.settling.samples, 30 + 20, "{a:?}");
        assert!((a.settling.max_abs_error_kg - 5.0).abs() < 1e-9);
        // Valve at work from 200 s until 30 s after its last open sample (204 s).
        assert_eq!(a.valve_activity.samples, 34);
        assert_eq!(
            a.standstill.samples
                + a.load_change.samples
                + a.settling.samples
                + a.valve_activity.samples,
            n
        );
    }
}
