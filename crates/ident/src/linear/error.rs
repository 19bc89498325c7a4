//! Errors of the linear identification library.

use thiserror::Error;

/// Why a linear identification call could not produce a result.
///
/// Bad input is always reported here, never by a panic. An optimiser that stops on an iteration
/// limit is *not* an error: it is reported as [`crate::linear::StopReason`] in the estimate.
///
/// Index fields (`input`, `index`, `column`) are zero-based; the messages count inputs from 1,
/// matching `u1`, `u2` in printed models.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum IdentError {
    /// The data set has no samples.
    #[error("the data set is empty")]
    Empty,
    /// An input signal and the output have different lengths.
    #[error("input {} has {input_len} samples but the output has {output_len}", .input + 1)]
    LengthMismatch {
        /// Zero-based input index.
        input: usize,
        /// Samples in that input.
        input_len: usize,
        /// Samples in the output.
        output_len: usize,
    },
    /// A sample is NaN or infinite.
    #[error("{signal} sample {index} is not finite ({value})")]
    NonFinite {
        /// `"output"` or `"input k"` (`k` counted from 1, like `u1`, `u2` in printed models).
        signal: String,
        /// Zero-based sample index.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// The sample time is not a positive finite number.
    #[error("the sample time must be positive and finite, got {0} s")]
    InvalidSampleTime(f64),
    /// The orders describe a different number of inputs than the data have.
    #[error("the orders describe {orders} input(s) but the data have {data}")]
    InputCountMismatch {
        /// Inputs described by the orders.
        orders: usize,
        /// Inputs in the data.
        data: usize,
    },
    /// An order is zero where the structure needs at least one coefficient, or the model has
    /// no free parameter at all.
    #[error("invalid order: {0}")]
    InvalidOrder(String),
    /// Fewer usable samples than the estimate needs.
    #[error(
        "too few samples: {available} usable sample(s) for {parameters} parameter(s); at least {required} are needed"
    )]
    TooFewSamples {
        /// Samples left after the regressor start-up.
        available: usize,
        /// Free parameters of the model.
        parameters: usize,
        /// Minimum number of usable samples.
        required: usize,
    },
    /// An input never changes, so the coefficients that multiply it cannot be told apart.
    #[error("input {} is constant ({value}); its coefficients are not identifiable", .input + 1)]
    ConstantInput {
        /// Zero-based input index.
        input: usize,
        /// The constant value.
        value: f64,
    },
    /// The regressors are linearly dependent: the data do not excite the model structure.
    #[error(
        "the regression problem is rank deficient: regressor column {column} ({name}) is a linear combination of the previous ones"
    )]
    RankDeficient {
        /// Zero-based regressor column.
        column: usize,
        /// Parameter name of that column.
        name: String,
    },
    /// The optimiser could not make a single evaluation (e.g. the start point already failed).
    #[error("prediction-error minimisation failed: {0}")]
    OptimizerFailed(String),
    /// Eigenvalue computation did not converge.
    #[error("eigenvalue computation did not converge for a {0}x{0} matrix")]
    EigenNoConvergence(usize),
    /// A discrete-time pole on the closed negative real axis (or at zero) has no real
    /// continuous-time counterpart under zero-order hold.
    #[error(
        "no continuous-time equivalent: pole {re:+.6}{im:+.6}i lies on the negative real axis or at zero (the matrix logarithm is not real); {hint}"
    )]
    NoRealLogarithm {
        /// Real part of the offending discrete pole.
        re: f64,
        /// Imaginary part of the offending discrete pole.
        im: f64,
        /// What usually causes it.
        hint: &'static str,
    },
    /// A matrix needed in a conversion is singular.
    #[error("singular matrix in {0}")]
    Singular(&'static str),
    /// Matrix shapes do not fit together.
    #[error("dimension mismatch: {0}")]
    Dimension(String),
    /// Invalid prediction horizon.
    #[error("the prediction horizon must be at least 1 sample")]
    InvalidHorizon,
    /// An empty search grid or invalid option.
    #[error("invalid option: {0}")]
    InvalidOption(String),
}
