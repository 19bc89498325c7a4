//! One Python exception for everything airsus rejects.

use pyo3::PyErr;

pyo3::create_exception!(
    airsus,
    AirsusError,
    pyo3::exceptions::PyValueError,
    "An input airsus rejects: a malformed file or frame (the message names file, line and \
     column), an unknown model or parameter, a parameter out of range, a simulation that \
     fails. The message is the one the `airsus` command prints after `error: `."
);

/// The error as the command line prints it: anyhow's alternate form, the context chain joined
/// by `: ` (crates/cli/src/main.rs prints `error: {err:#}`).
pub fn to_py(err: anyhow::Error) -> PyErr {
    AirsusError::new_err(format!("{err:#}"))
}

/// `Result<T, E>` → `PyResult<T>` with the error as [`AirsusError`].
pub trait OrPy<T> {
    fn or_py(self) -> pyo3::PyResult<T>;
}

impl<T, E: Into<anyhow::Error>> OrPy<T> for Result<T, E> {
    fn or_py(self) -> pyo3::PyResult<T> {
        self.map_err(|e| to_py(e.into()))
    }
}
