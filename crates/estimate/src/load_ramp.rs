//! The load as the wheel felt it, from the load as it was logged.
//!
//! A loading log records a load change as a step (a crane operator's entry, a weighbridge
//! reading), while the wheel takes the load over seconds as the traverse lowers it. Fed the
//! step, every model jumps where the truck eased, and the simulation error around each load
//! change alone keeps the fit of a loading run several NRMSE points below its noise floor
//! (the virtual truck's data-set 1, simulated with its true parameters from a fitted start:
//! height 93.4 → 98.1 % once the steps are eased over 5.5 s; the ceiling is 98.9 %).
//!
//! Assumption: each change of the logged load starts a smooth transition of the same
//! duration `τ`, shaped as a motion that starts and stops at rest (smoothstep,
//! `S(p) = 3p² − 2p³`): the felt load is `m(t) = m(t₀) + Σᵢ Δmᵢ S((t − tᵢ)/τ)`. `τ` is one
//! number per logging set-up, estimated from the runs with the model's parameters fixed
//! ([`fit_load_ramp`]); `τ = 0` is the logged load itself.

use airsus_data::Run;
use airsus_sim::{LoadInput, SolverOptions};

use crate::error::EstimateError;
use crate::greybox::{GreyboxOptions, GreyboxProblem, estimate};
use crate::progress::NoProgress;

/// The longest transition [`fit_load_ramp`] considers, s.
pub const MAX_LOAD_RAMP_S: f64 = 15.0;

/// Checks a transition time given by a user (`--load-ramp-s`, Python's `load_ramp_s`).
pub fn check_load_ramp_s(duration_s: f64) -> Result<f64, String> {
    if duration_s.is_finite() && (0.0..=MAX_LOAD_RAMP_S).contains(&duration_s) {
        Ok(duration_s)
    } else {
        Err(format!(
            "load ramp {duration_s} s: expected a transition time from 0 to {MAX_LOAD_RAMP_S} s"
        ))
    }
}

/// Smoothstep: 0 before the start, 1 after the end, zero slope at both.
fn smoothstep(progress: f64) -> f64 {
    let p = progress.clamp(0.0, 1.0);
    p * p * (3.0 - 2.0 * p)
}

/// The run with every change of its logged load eased over `duration_s` (a copy; `0` or
/// less returns it unchanged). Linear in the number of samples for step-wise logs: only the
/// changes within the last `duration_s` are summed at each sample.
pub fn ramp_logged_load(run: &Run, duration_s: f64) -> Run {
    let mut out = run.clone();
    if !(duration_s > 0.0) || run.is_empty() {
        return out;
    }
    let load = &run.inputs.wheel_load_kg;
    let time = &run.time_s;
    // (time, change) of every logged change.
    let changes: Vec<(f64, f64)> = (1..load.len())
        .filter(|&k| load[k] != load[k - 1])
        .map(|k| (time[k], load[k] - load[k - 1]))
        .collect();
    let mut settled = load[0];
    let mut first_open = 0;
    for (k, felt) in out.inputs.wheel_load_kg.iter_mut().enumerate() {
        let t = time[k];
        // Changes older than the ramp have fully arrived.
        while first_open < changes.len() && changes[first_open].0 + duration_s <= t {
            settled += changes[first_open].1;
            first_open += 1;
        }
        let arriving: f64 = changes[first_open..]
            .iter()
            .take_while(|(start, _)| *start <= t)
            .map(|(start, delta)| delta * smoothstep((t - start) / duration_s))
            .sum();
        *felt = settled + arriving;
    }
    out
}

/// The estimated transition time and what it bought.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadRampFit {
    /// `τ`, s.
    pub duration_s: f64,
    /// The grey-box loss of the problem's model on the runs as logged, and eased by `τ`.
    pub loss_logged: f64,
    pub loss_ramped: f64,
    /// Loss evaluations (each simulates every run once).
    pub evaluations: usize,
}

/// Fits `τ` in `[sample step, MAX_LOAD_RAMP_S]` to `problem`'s runs with its model's
/// parameters fixed (its free list is ignored): golden-section search on the grey-box loss,
/// which is unimodal in `τ` around the true transition (too short keeps the jump, too long
/// lags). `τ = 0` (the load as logged) is kept unless easing lowers the loss by
/// [`MIN_RELATIVE_GAIN`]. Runs without load changes do not depend on `τ`. Only a failure to
/// simulate the logged load itself is an error.
pub fn fit_load_ramp(problem: &GreyboxProblem<'_>) -> Result<LoadRampFit, EstimateError> {
    let options = GreyboxOptions::default();
    let mut evaluations = 0;
    let mut loss = |tau: f64| -> Result<f64, EstimateError> {
        evaluations += 1;
        let ramped: Vec<Run> = problem
            .runs
            .iter()
            .map(|r| ramp_logged_load(r, tau))
            .collect();
        let fixed = GreyboxProblem {
            runs: ramped.iter().collect(),
            free: vec![],
            solver: solver_for_ramp(&problem.solver, tau),
            ..problem.clone()
        };
        Ok(estimate(&fixed, &options, &mut NoProgress)?.loss_estimated)
    };
    let loss_logged = loss(0.0)?;
    // A trial that does not simulate is a bad trial, not the end of the search.
    let mut trial = |tau: f64| loss(tau).unwrap_or(f64::INFINITY);
    // Below one sample step a ramp is only a one-sample delay of each change (inputs hold
    // between samples): the search starts at the step.
    let step_s = problem
        .runs
        .iter()
        .map(|r| r.sample_time_s)
        .fold(0.0, f64::max);
    let golden = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (step_s.min(MAX_LOAD_RAMP_S), MAX_LOAD_RAMP_S);
    let mut c = b - golden * (b - a);
    let mut d = a + golden * (b - a);
    let (mut fc, mut fd) = (trial(c), trial(d));
    // 16 steps shrink the bracket to 15 s × 0.618¹⁶ ≈ 7 ms.
    for _ in 0..16 {
        if fc < fd {
            b = d;
            (d, fd) = (c, fc);
            c = b - golden * (b - a);
            fc = trial(c);
        } else {
            a = c;
            (c, fc) = (d, fd);
            d = a + golden * (b - a);
            fd = trial(d);
        }
    }
    let (duration_s, loss_ramped) = if fc < fd { (c, fc) } else { (d, fd) };
    // The logged load itself stays the answer unless easing it helps by a clear margin
    // (1 %): a continuously measured load must not be smoothed for a rounding's gain.
    let (duration_s, loss_ramped) = if loss_ramped < (1.0 - MIN_RELATIVE_GAIN) * loss_logged {
        (duration_s, loss_ramped)
    } else {
        (0.0, loss_logged)
    };
    Ok(LoadRampFit {
        duration_s,
        loss_logged,
        loss_ramped,
        evaluations,
    })
}

/// The solver options for a run whose load was eased over `duration_s`
/// ([`ramp_logged_load`]): the eased load followed linearly between samples
/// ([`LoadInput::Linear`]) rather than as a staircase that restarts the solver at every
/// sample; `options` unchanged for the load as logged (`duration_s` 0).
pub fn solver_for_ramp(options: &SolverOptions, duration_s: f64) -> SolverOptions {
    if duration_s > 0.0 {
        options.clone().with_load(LoadInput::Linear)
    } else {
        options.clone()
    }
}

/// The least relative loss reduction for which [`fit_load_ramp`] eases the load at all.
pub const MIN_RELATIVE_GAIN: f64 = 0.01;

#[cfg(test)]
mod tests {
    use super::*;
    use airsus_data::{RunInputs, ValveState};

    fn step_run() -> Run {
        let n = 101;
        let time_s: Vec<f64> = (0..n).map(|k| k as f64 * 0.1).collect();
        let load = time_s
            .iter()
            .map(|&t| {
                if t < 2.0 {
                    3000.0
                } else if t < 6.0 {
                    3300.0
                } else {
                    3100.0
                }
            })
            .collect();
        Run {
            name: "steps".to_owned(),
            sample_time_s: 0.1,
            inputs: RunInputs {
                wheel_load_kg: load,
                valve: vec![ValveState::Closed; n],
                supply_gauge_pa: vec![850e3; n],
                road_height_m: vec![0.0; n],
            },
            outputs: None,
            time_s,
        }
    }

    #[test]
    fn a_step_becomes_a_smoothstep_of_the_given_duration() {
        let run = step_run();
        let eased = ramp_logged_load(&run, 1.0);
        let load = &eased.inputs.wheel_load_kg;
        assert_eq!(load[19], 3000.0);
        assert_eq!(load[20], 3000.0, "the ramp starts at the logged step");
        assert!(
            (load[25] - 3150.0).abs() < 1e-9,
            "half way at half time: {}",
            load[25]
        );
        assert!((load[30] - 3300.0).abs() < 1e-9);
        // The second change (−200 kg at 6 s) after the first has arrived.
        assert!((load[65] - 3200.0).abs() < 1e-9, "{}", load[65]);
        assert!((load[100] - 3100.0).abs() < 1e-9);
        // τ = 0 is the log itself.
        assert_eq!(ramp_logged_load(&run, 0.0), run);
        // Overlapping ramps add: with τ = 6 s the first change is still arriving at 6.5 s.
        let slow = ramp_logged_load(&run, 6.0);
        let expect = 3000.0 + 300.0 * smoothstep(4.5 / 6.0) - 200.0 * smoothstep(0.5 / 6.0);
        assert!((slow.inputs.wheel_load_kg[65] - expect).abs() < 1e-9);
    }
}
