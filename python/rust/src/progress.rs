//! Progress reports from long calls to an optional Python callable.
//!
//! The computation runs with the GIL released; each event attaches to the interpreter just
//! long enough to build a `dict` and call the callback with it. Events from worker threads
//! (the study estimates its models in parallel) are serialised by a mutex. An exception
//! raised by the callback is kept, no further events are sent, and the exception is raised
//! when the call returns (the computation itself cannot be interrupted half-way).

use std::sync::Mutex;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use airsus_estimate::{IterationInfo, Observer};

pub struct Progress {
    callback: Option<Py<PyAny>>,
    error: Mutex<Option<PyErr>>,
}

impl Progress {
    pub fn new(callback: Option<Py<PyAny>>) -> Self {
        Self {
            callback,
            error: Mutex::new(None),
        }
    }

    /// Calls the callback with one event dict, filled by `fill`.
    pub fn emit<F>(&self, fill: F)
    where
        F: for<'py> FnOnce(&Bound<'py, PyDict>) -> PyResult<()>,
    {
        let Some(callback) = &self.callback else {
            return;
        };
        let Ok(mut failed) = self.error.lock() else {
            return;
        };
        if failed.is_some() {
            return;
        }
        let result = Python::attach(|py| -> PyResult<()> {
            let event = PyDict::new(py);
            fill(&event)?;
            callback.bind(py).call1((event,))?;
            Ok(())
        });
        if let Err(err) = result {
            *failed = Some(err);
        }
    }

    /// A stage message (`{"event": "stage", "message": ...}`).
    pub fn stage(&self, message: &str) {
        self.emit(|d| {
            d.set_item("event", "stage")?;
            d.set_item("message", message)
        });
    }

    /// The callback's exception, if it raised one.
    pub fn finish(self) -> PyResult<()> {
        match self.error.into_inner() {
            Ok(Some(err)) => Err(err),
            _ => Ok(()),
        }
    }
}

/// The grey-box estimator's observer, forwarding to a [`Progress`].
pub struct ProgressObserver<'a>(pub &'a Progress);

impl Observer for ProgressObserver<'_> {
    fn stage(&mut self, message: &str) {
        self.0.stage(message);
    }

    fn iteration(&mut self, info: &IterationInfo) {
        let info = *info;
        self.0.emit(|d| {
            d.set_item("event", "iteration")?;
            d.set_item("round", info.round)?;
            d.set_item("iteration", info.iteration)?;
            d.set_item("loss", info.loss)?;
            d.set_item("simulations", info.simulations)?;
            d.set_item("failed_simulations", info.failed_simulations)
        });
    }
}
