//! # airsus-estimate: grey-box estimation and submodel fits (thesis 5.2)
//!
//! * [`greybox`] — any model, any named subset of its parameters, free or fixed, with
//!   bounds, fitted by minimising the normalised simulation error of height and pressure over
//!   one or more runs at once (thesis 3.2.3, 5.2.6, Tables 5.10–5.12; ≙ MATLAB `nlgreyest`).
//!   Problem, options and executor are separate (argmin); the stop reason is a value, not an
//!   error; identifiability is checked before and after the fit and undetermined parameters
//!   are kept at their nominal values.
//! * [`submodel`] — the thesis' submodel fits as plain functions from data: gas-volume
//!   cross-section (eq 5.1–5.3), effective area (eq 3.16/5.4), valve flow resistances
//!   (eq 3.19/5.5/5.6) and the slow-dynamics OE block (5.2.4).
//! * [`initial_state`], [`joint`] — a run's start fitted to its first seconds, and
//!   parameters and starts estimated together.
//! * [`load_ramp`] — the load the wheel felt from the load that was logged: each logged
//!   step eased over a transition time estimated from the runs.
//! * [`no_trade`] — an estimate that explains no estimation run worse than the start values
//!   did: traded runs weighted more and refitted.
//! * [`progress`] — observers of a running estimation (an `indicatif` display on a
//!   terminal).
//!
//! ```text
//! let model = build_model("m2", &truck)?;
//! let problem = GreyboxProblem::new(&*model, &[&ds1, &ds3], &["p0", "p1", "m2", "rflow1"]);
//! let result = estimate(&problem, &GreyboxOptions::default(), &mut TerminalProgress::new())?;
//! println!("{result}");                       // NRMSE table, estimates ± std, notes
//! result.estimated_model.write_parameters(&mut truck);
//! ```

// `!(x > limit)` is deliberate throughout: it is true for NaN, so a NaN fails every check
// instead of slipping through as `x <= limit` would let it.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod error;
pub mod greybox;
pub mod initial_state;
pub mod joint;
pub mod load_ramp;
pub mod no_trade;
pub mod progress;
pub mod submodel;

pub use error::EstimateError;
pub use greybox::{
    ForceMapPrior, FreeParameter, GreyboxEstimate, GreyboxOptions, GreyboxProblem,
    IdentifiabilityPolicy, InitialChoice, MultiStart, MultiStartSummary, Normalisation,
    OutputWeights, StopReason, check_force_map_noise_n, check_load_change_exclusion_s, estimate,
    estimate_multistart, estimate_multistart_capped, loss_at,
};
pub use initial_state::{
    EstimatedStart, PrefixOptions, StartChoice, StartMethod, check_prefix_s,
    estimate_initial_state, resolve_start,
};
pub use joint::{
    JointEstimate, JointRound, continue_jointly, estimate_jointly,
    estimate_jointly_with_transitions, estimate_with_starts, estimation_start, prefix_starts,
};
pub use load_ramp::{
    LoadRamp, LoadRampFit, LoadTransitionsFit, MAX_LOAD_RAMP_S, check_load_ramp_s,
    check_load_transitions, ease_logged_load, ease_runs, fit_load_ramp, fit_load_transitions,
    logged_load_changes, longest_transition_s, ramp_logged_load, solver_for_ramp,
};
pub use progress::{IterationInfo, NoProgress, Observer, TerminalProgress};
