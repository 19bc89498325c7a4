//! Typed simulation errors. Every failure names the model; failures during integration also
//! name the time and the state (with the model's state names), so that a user can see *where*
//! a model went wrong, not only that it did.

use std::fmt;

use airsus_model::ModelError;

/// A state vector with its names, as carried by errors.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedState {
    pub names: Vec<&'static str>,
    pub values: Vec<f64>,
}

impl NamedState {
    pub fn new(names: &[&'static str], values: &[f64]) -> Self {
        Self {
            names: names.to_vec(),
            values: values.to_vec(),
        }
    }

    /// The value of the state called `name`.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.names
            .iter()
            .position(|n| *n == name)
            .map(|i| self.values[i])
    }
}

impl fmt::Display for NamedState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "[")?;
        for (i, v) in self.values.iter().enumerate() {
            if i > 0 {
                write!(f, ", ")?;
            }
            match self.names.get(i) {
                Some(name) => write!(f, "{name} = {v:.6e}")?,
                None => write!(f, "x{i} = {v:.6e}")?,
            }
        }
        write!(f, "]")
    }
}

/// Why a state is not acceptable.
#[derive(Debug, Clone, PartialEq)]
pub enum StateViolation {
    /// A state component is NaN or infinite.
    NonFinite { name: &'static str },
    /// A state component left its admissible range (see [`crate::StateBounds`]).
    OutOfBounds {
        name: &'static str,
        value: f64,
        lower: f64,
        upper: f64,
    },
}

impl fmt::Display for StateViolation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NonFinite { name } => write!(f, "state `{name}` is not finite"),
            Self::OutOfBounds {
                name,
                value,
                lower,
                upper,
            } => write!(
                f,
                "state `{name}` = {value:.6e} left its admissible range [{lower:e}, {upper:e}]"
            ),
        }
    }
}

/// Why the ODE solver gave up.
#[derive(Debug, Clone, PartialEq)]
pub enum SolverFailure {
    /// The step size fell below the solver's minimum (typically a discontinuity the model does
    /// not announce, or a singularity).
    StepSizeTooSmall,
    /// The error test failed too often in a row.
    TooManyErrorTestFailures,
    /// The Newton iteration of the implicit method failed too often.
    TooManyNonlinearSolverFailures,
    /// The step budget [`crate::SolverOptions::max_steps`] was used up.
    TooManySteps { max_steps: usize },
    /// Anything else diffsol reports, with its message.
    Other(String),
}

impl fmt::Display for SolverFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::StepSizeTooSmall => write!(f, "step size too small"),
            Self::TooManyErrorTestFailures => write!(f, "too many error test failures"),
            Self::TooManyNonlinearSolverFailures => write!(f, "too many Newton failures"),
            Self::TooManySteps { max_steps } => write!(f, "more than {max_steps} steps"),
            Self::Other(message) => write!(f, "{message}"),
        }
    }
}

/// Everything that can go wrong in [`crate::simulate`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// The input signals are malformed (lengths, time axis, non-finite values).
    #[error("invalid inputs: {reason}")]
    InvalidInputs { reason: String },

    /// The problem itself is malformed (signal lengths, time axis, tolerances, initial state).
    #[error("model {model}: invalid simulation problem: {reason}")]
    InvalidProblem { model: String, reason: String },

    /// The model found no initial static equilibrium.
    #[error("model {model}: no initial state: {source}")]
    InitialState {
        model: String,
        #[source]
        source: Box<ModelError>,
    },

    /// The state blew up or left the physically admissible region.
    #[error("model {model} at t = {time_s:.4} s: {violation}; state {state}")]
    InadmissibleState {
        model: String,
        time_s: f64,
        violation: StateViolation,
        state: NamedState,
    },

    /// An output (sensor height or bellow pressure) came out NaN or infinite.
    #[error("model {model} at t = {time_s:.4} s: output `{output}` is not finite; state {state}")]
    NonFiniteOutput {
        model: String,
        time_s: f64,
        output: &'static str,
        state: NamedState,
    },

    /// The adaptive ODE solver failed.
    #[error("model {model} at t = {time_s:.4} s: the ODE solver failed ({failure}); state {state}")]
    SolverFailed {
        model: String,
        time_s: f64,
        failure: SolverFailure,
        state: NamedState,
    },
}

impl SimError {
    /// The simulated time at which the failure happened, when it happened during integration.
    pub fn time_s(&self) -> Option<f64> {
        match self {
            Self::InadmissibleState { time_s, .. }
            | Self::NonFiniteOutput { time_s, .. }
            | Self::SolverFailed { time_s, .. } => Some(*time_s),
            Self::InvalidInputs { .. }
            | Self::InvalidProblem { .. }
            | Self::InitialState { .. } => None,
        }
    }

    /// The state at the failure, when there was one.
    pub fn state(&self) -> Option<&NamedState> {
        match self {
            Self::InadmissibleState { state, .. }
            | Self::NonFiniteOutput { state, .. }
            | Self::SolverFailed { state, .. } => Some(state),
            Self::InvalidInputs { .. }
            | Self::InvalidProblem { .. }
            | Self::InitialState { .. } => None,
        }
    }
}
