//! Ride-height (level) control with the 3-state valve, evaluated in closed loop (SPEC §7).
//!
//! [`controller`] holds the controllers, `airsus_truck::closed_loop` runs them on a model or the virtual
//! truck, this module the scenarios and the scores.
//!
//! # Scores (on the true, noise-free sensor height)
//! The scenario is cut into segments at its events (a load change starting, a new target).
//! Per segment:
//! - **settling time**: from the event until the height enters the band `target ± tolerance`
//!   and stays in it to the end of the segment (`None`: never settled);
//! - **overshoot**: the largest excursion past the target on the side opposite to the
//!   segment's largest deviation (how far the correction went beyond the target);
//! - **steady error**: mean `height - target` over the last 10 s of the segment.
//!
//! On a road the wheel and the body move by more than the band; what a level controller holds
//! is the ride height between bumps, so when the run has road input the height is scored as
//! its centred moving mean over [`ROAD_SCORE_WINDOW_S`].
//!
//! Over the run: valve **switches** (every change of the command) and **openings**, pulses
//! shorter than the minimum on-time, **reversals** (fill after exhaust or the reverse) and how
//! many of them came within the lock-out time, and the **air used**: moles let in through the
//! fill channel (drawn from the supply tank) and out through the exhaust, with the fill also as
//! litres of free air at ambient conditions (`V = n R T / p_amb`).

pub mod controller;

use airsus_data::ValveState;

use crate::error::{AppError, invalid};
use crate::road::profile::Iso8608Road;
pub use airsus_truck::closed_loop::{
    ClosedLoopConfig, ClosedLoopRun, LevelScenario, Plant, simulate_closed_loop,
};
use airsus_truck::scenario::distance_m;
pub use controller::{
    DeadbandController, GuardSettings, LevelController, PredictiveController, Reading, ValveGuard,
    ValveModel,
};

/// The scenarios `airsus control --scenario` knows.
pub const SCENARIO_NAMES: &[&str] = &["load-steps", "height-change", "road"];

/// Speed of the `road` scenario, m/s (50 km/h).
const ROAD_SPEED_M_S: f64 = 50.0 / 3.6;

/// `load-steps`: the target held while the load changes: +300 kg at 20 s, +300 kg at 110 s,
/// -600 kg at 200 s (unloading, 8 s), +250 kg at 290 s; 380 s. `height-change`: constant load,
/// the target raised by 40 mm at 10 s (a loading dock), lowered to 30 mm below the start at
/// 100 s, back at 190 s; 280 s. `road`: constant load and target, standing for 20 s, then
/// 200 s over an ISO 8608 class C road at 50 km/h (waves of 3.3–100 m, 0.14–4.2 Hz: what the
/// controller's 10 Hz samples resolve; the body's bounce is in it, wheel hop is not), then
/// standing again for 60 s — a good controller lets the road pass and opens the valve little
/// or not at all. All start in equilibrium at `target_m` with `load_kg`.
pub fn level_scenario(name: &str, target_m: f64, load_kg: f64) -> Result<LevelScenario, AppError> {
    if !(target_m.is_finite() && target_m > 0.0 && load_kg.is_finite() && load_kg > 0.0) {
        return Err(invalid(
            "scenario",
            format!("target {target_m} m and load {load_kg} kg must be positive"),
        ));
    }
    let sample_s = 0.1;
    match name {
        "load-steps" => {
            let mut s = LevelScenario::constant(name, 380.0, sample_s, load_kg, target_m);
            s.load_change(20.0, 300.0, 5.0);
            s.load_change(110.0, 300.0, 5.0);
            s.load_change(200.0, -600.0, 8.0);
            s.load_change(290.0, 250.0, 4.0);
            Ok(s)
        }
        "height-change" => {
            let mut s = LevelScenario::constant(name, 280.0, sample_s, load_kg, target_m);
            s.target_change(10.0, target_m + 0.040);
            s.target_change(100.0, target_m - 0.030);
            s.target_change(190.0, target_m);
            Ok(s)
        }
        "road" => {
            let mut s = LevelScenario::constant(name, 280.0, sample_s, load_kg, target_m);
            let road = Iso8608Road::new('C', 0.01, 0.3, 200, 8608)?;
            let (start_s, end_s) = (20.0, 220.0);
            let distance = distance_m(&s.time_s, start_s, end_s, ROAD_SPEED_M_S);
            let heights = road.heights_m(&distance);
            // Level at the start of the drive, and standing (constant) after it.
            let h0 = heights[0];
            s.road_height_m = heights.iter().map(|h| h - h0).collect();
            s.speed_m_s = s
                .time_s
                .iter()
                .map(|&t| {
                    if (start_s..end_s).contains(&t) {
                        ROAD_SPEED_M_S
                    } else {
                        0.0
                    }
                })
                .collect();
            s.events_s.push(start_s);
            s.events_s.push(end_s);
            Ok(s)
        }
        other => Err(invalid(
            "scenario",
            format!("`{other}`; the scenarios are {}", SCENARIO_NAMES.join(", ")),
        )),
    }
}

/// Scores of one segment between events.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentScore {
    pub start_s: f64,
    pub settling_time_s: Option<f64>,
    pub overshoot_m: f64,
    pub steady_error_m: f64,
    pub max_deviation_m: f64,
}

/// Scores of a closed-loop run (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ControlScore {
    pub segments: Vec<SegmentScore>,
    /// Worst settling time over the segments (`None` if one never settled).
    pub worst_settling_time_s: Option<f64>,
    pub max_overshoot_m: f64,
    /// Largest |steady error| over the segments, m.
    pub max_steady_error_m: f64,
    pub switches: usize,
    pub openings: usize,
    /// Openings shorter than the minimum on-time.
    pub short_openings: usize,
    /// Direction reversals, and those that began within the lock-out time of the last opening.
    pub reversals: usize,
    pub quick_reversals: usize,
    pub air_filled_mol: f64,
    pub air_exhausted_mol: f64,
    /// Fill air as free air at ambient, litres.
    pub air_filled_free_l: f64,
    /// Time the true height (on a road its 2 s mean) spent outside `target ± tolerance`, s.
    pub time_outside_band_s: f64,
}

/// Window of the moving mean the height is scored by on a road (module docs), s.
pub const ROAD_SCORE_WINDOW_S: f64 = 2.0;

/// The height the scores are computed on: the true height, or on a road its centred moving
/// mean over [`ROAD_SCORE_WINDOW_S`].
fn scored_height_m(run: &ClosedLoopRun) -> Vec<f64> {
    let n = run.height_m.len();
    if run.road_height_m.iter().all(|&z| z == 0.0) || n < 2 {
        return run.height_m.clone();
    }
    let dt = (run.time_s[n - 1] - run.time_s[0]) / (n - 1) as f64;
    let half = ((0.5 * ROAD_SCORE_WINDOW_S / dt).round() as usize).max(1);
    // Prefix sums: one pass, whatever the window.
    let mut prefix = Vec::with_capacity(n + 1);
    prefix.push(0.0);
    for h in &run.height_m {
        prefix.push(prefix.last().copied().unwrap_or(0.0) + h);
    }
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(half), (k + half + 1).min(n));
            (prefix[b] - prefix[a]) / (b - a) as f64
        })
        .collect()
}

/// Scores `run` (module docs). `ambient_pa` and `rt_j_mol` convert moles to free-air litres.
pub fn score(
    run: &ClosedLoopRun,
    events_s: &[f64],
    guard: &GuardSettings,
    rt_j_mol: f64,
    ambient_pa: f64,
) -> ControlScore {
    let n = run.time_s.len();
    let height = scored_height_m(run);
    let mut bounds: Vec<f64> = events_s.to_vec();
    bounds.sort_by(f64::total_cmp);
    let t_end = run.time_s.last().copied().unwrap_or(0.0);
    let mut segments = Vec::new();
    for (i, &start) in bounds.iter().enumerate() {
        let end = bounds.get(i + 1).copied().unwrap_or(t_end + 1.0);
        let idx: Vec<usize> = (0..n)
            .filter(|&k| run.time_s[k] >= start - 1e-9 && run.time_s[k] < end - 1e-9)
            .collect();
        let Some(&last) = idx.last() else { continue };
        let dev = |k: usize| height[k] - run.target_m[k];
        let worst = idx.iter().map(|&k| dev(k)).fold(
            0.0,
            |a: f64, d| {
                if d.abs() > a.abs() { d } else { a }
            },
        );
        let overshoot = idx
            .iter()
            .map(|&k| (-worst.signum() * dev(k)).max(0.0))
            .fold(0.0, f64::max);
        let settled_from = idx
            .iter()
            .rev()
            .take_while(|&&k| dev(k).abs() <= guard.tolerance_m)
            .last()
            .copied();
        let settling = match settled_from {
            Some(k) if dev(last).abs() <= guard.tolerance_m => Some(run.time_s[k] - start),
            _ => None,
        };
        let tail: Vec<f64> = idx
            .iter()
            .filter(|&&k| run.time_s[k] >= run.time_s[last] - 10.0)
            .map(|&k| dev(k))
            .collect();
        segments.push(SegmentScore {
            start_s: start,
            settling_time_s: settling,
            overshoot_m: overshoot,
            steady_error_m: tail.iter().sum::<f64>() / tail.len().max(1) as f64,
            max_deviation_m: worst.abs(),
        });
    }

    let mut switches = 0;
    let mut openings = 0;
    let mut short_openings = 0;
    let mut reversals = 0;
    let mut quick_reversals = 0;
    let mut opened_at: Option<(ValveState, f64)> = None;
    let mut last_open: Option<(ValveState, f64)> = None;
    for k in 0..n {
        let prev = if k == 0 {
            ValveState::Closed
        } else {
            run.valve[k - 1]
        };
        let v = run.valve[k];
        if v == prev {
            continue;
        }
        switches += 1;
        let t = run.time_s[k];
        if let Some((dir, since)) = opened_at.take() {
            if t - since + 1e-9 < guard.min_on_s {
                short_openings += 1;
            }
            last_open = Some((dir, t));
        }
        if v != ValveState::Closed {
            openings += 1;
            if let Some((dir, end)) = last_open
                && dir != v
            {
                reversals += 1;
                if t - end + 1e-9 < guard.reversal_lockout_s {
                    quick_reversals += 1;
                }
            }
            opened_at = Some((v, t));
        }
    }
    let worst_settling_time_s = segments
        .iter()
        .try_fold(0.0f64, |a, s| s.settling_time_s.map(|t| a.max(t)));
    ControlScore {
        worst_settling_time_s,
        max_overshoot_m: segments.iter().map(|s| s.overshoot_m).fold(0.0, f64::max),
        max_steady_error_m: segments
            .iter()
            .map(|s| s.steady_error_m.abs())
            .fold(0.0, f64::max),
        segments,
        switches,
        openings,
        short_openings,
        reversals,
        quick_reversals,
        air_filled_mol: run.air_filled_mol,
        air_exhausted_mol: run.air_exhausted_mol,
        air_filled_free_l: run.air_filled_mol * rt_j_mol / ambient_pa * 1e3,
        time_outside_band_s: (1..n)
            .filter(|&k| (height[k] - run.target_m[k]).abs() > guard.tolerance_m)
            .map(|k| run.time_s[k] - run.time_s[k - 1])
            .sum(),
    }
}
