//! Typed errors. A fit that merely fails to converge is **not** an error: it returns its best
//! point with a [`crate::greybox::StopReason`]. Errors are for inputs that make the question
//! meaningless (no runs, unknown parameter names, bounds that exclude the start, a start that
//! cannot be simulated, too little data for a submodel fit).

use airsus_ident::linear::IdentError;
use airsus_model::ModelError;
use airsus_sim::SimError;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EstimateError {
    /// A parameter name or value the model rejects.
    #[error(transparent)]
    Model(#[from] ModelError),

    /// The same parameter was freed twice.
    #[error("parameter `{name}` is freed more than once")]
    DuplicateParameter { name: String },

    /// Bounds that are empty, not finite, outside the model's admissible range, or exclude
    /// the start value.
    #[error("parameter `{name}`: {reason}")]
    InvalidBounds { name: String, reason: String },

    /// An option out of its range.
    #[error("invalid option: {0}")]
    InvalidOption(String),

    /// Grey-box estimation needs at least one run with measured outputs.
    #[error("no estimation runs given")]
    NoRuns,

    /// A run is unusable for estimation (no measured outputs, too short, non-finite values).
    #[error("run `{run}`: {reason}")]
    InvalidRun { run: String, reason: String },

    /// The start parameters cannot be simulated: there is no point to improve from.
    #[error("run `{run}`: the start parameters do not simulate: {source}")]
    StartDoesNotSimulate {
        run: String,
        #[source]
        source: Box<SimError>,
    },

    /// Submodel data unusable for the requested fit (too few points, wrong valve state, …).
    #[error("{fit}: {reason}")]
    InsufficientData { fit: &'static str, reason: String },

    /// The linear identification (slow-dynamics OE fit) failed.
    #[error("slow-dynamics OE fit: {0}")]
    Ident(#[from] IdentError),
}
