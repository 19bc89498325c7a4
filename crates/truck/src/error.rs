//! Errors of the virtual truck.

use airsus_data::DataError;
use airsus_model::ModelError;
use airsus_sim::SimError;

#[derive(Debug, thiserror::Error)]
pub enum TruckError {
    #[error(transparent)]
    Model(#[from] ModelError),
    #[error(transparent)]
    Simulation(#[from] SimError),
    #[error(transparent)]
    Data(#[from] DataError),
    /// An argument or a signal is out of its admissible range.
    #[error("invalid {what}: {reason}")]
    InvalidInput { what: String, reason: String },
    #[error("tank discharge simulation failed: {0}")]
    Discharge(String),
    #[error("cannot create the output folder {path}: {source}")]
    OutputFolder {
        path: std::path::PathBuf,
        source: std::io::Error,
    },
}

pub(crate) fn invalid(what: impl Into<String>, reason: impl Into<String>) -> TruckError {
    TruckError::InvalidInput {
        what: what.into(),
        reason: reason.into(),
    }
}
