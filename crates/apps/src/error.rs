//! Errors of the applications: typed, naming what was wrong; never a panic on bad input.

use airsus_data::DataError;
use airsus_model::ModelError;
use airsus_sim::SimError;
use airsus_truck::error::TruckError;

#[derive(Debug, thiserror::Error)]
pub enum AppError {
    #[error(transparent)]
    Data(#[from] DataError),
    #[error(transparent)]
    Model(#[from] ModelError),
    #[error(transparent)]
    Simulation(#[from] SimError),
    #[error(transparent)]
    Truck(#[from] TruckError),
    #[error(transparent)]
    Validate(#[from] airsus_validate::ValidateError),
    /// An argument or a signal is out of its admissible range.
    #[error("invalid {what}: {reason}")]
    InvalidInput { what: String, reason: String },
    /// The static force balance has no solution for a measurement.
    #[error("no static load for {what}: {reason}")]
    NoStaticSolution { what: String, reason: String },
    /// The model does not carry what an application needs (e.g. a tire for road input).
    #[error("model {model} cannot be used here: {reason}")]
    UnsupportedModel { model: String, reason: String },
    /// The Kalman filter's covariance lost positive definiteness or a state turned non-finite.
    #[error("the load estimator diverged at t = {time_s:.2} s: {reason}")]
    FilterDiverged { time_s: f64, reason: String },
    #[error("plot {path}: {reason}")]
    Plot { path: String, reason: String },
}

pub(crate) fn invalid(what: impl Into<String>, reason: impl Into<String>) -> AppError {
    AppError::InvalidInput {
        what: what.into(),
        reason: reason.into(),
    }
}
