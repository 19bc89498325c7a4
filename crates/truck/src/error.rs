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
    #[error("tank discharge simulation failed: {0}")]
    Discharge(String),
    #[error("cannot create the output folder {path}: {source}")]
    OutputFolder {
        path: std::path::PathBuf,
        source: std::io::Error,
    },
}
