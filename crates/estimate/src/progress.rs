//! Observing a running estimation (argmin's observers): the executor reports stages and
//! iterations; [`TerminalProgress`] shows them with `indicatif` on a terminal and stays
//! silent otherwise, [`NoProgress`] ignores them.

use std::io::IsTerminal;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// One Levenberg–Marquardt iteration, as reported to an [`Observer`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IterationInfo {
    /// Fit round: 1, then 2.. if parameters found not identifiable after a fit were fixed and
    /// the rest refitted.
    pub round: usize,
    pub iteration: usize,
    /// Mean squared normalised residual at the current point.
    pub loss: f64,
    pub simulations: usize,
    pub failed_simulations: usize,
}

/// Receives progress events. Every method has an empty default.
pub trait Observer {
    /// A new stage begins ("nominal simulation", "Jacobian", "fit", …).
    fn stage(&mut self, _message: &str) {}
    fn iteration(&mut self, _info: &IterationInfo) {}
    fn finish(&mut self) {}
}

/// Ignores every event.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoProgress;

impl Observer for NoProgress {}

/// A spinner on stderr with stage, iteration and loss; hidden when stderr is not a terminal
/// (piped output and logs stay clean).
#[derive(Debug)]
pub struct TerminalProgress {
    bar: ProgressBar,
}

impl TerminalProgress {
    pub fn new() -> Self {
        let target = if std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        };
        let bar = ProgressBar::with_draw_target(None, target);
        if let Ok(style) = ProgressStyle::with_template("{spinner} [{elapsed}] {msg}") {
            bar.set_style(style);
        }
        bar.enable_steady_tick(Duration::from_millis(120));
        Self { bar }
    }
}

impl Default for TerminalProgress {
    fn default() -> Self {
        Self::new()
    }
}

impl Observer for TerminalProgress {
    fn stage(&mut self, message: &str) {
        self.bar.set_message(message.to_owned());
    }

    fn iteration(&mut self, info: &IterationInfo) {
        self.bar.set_message(format!(
            "fit {} iteration {}: loss {:.4e}, {} simulations{}",
            info.round,
            info.iteration,
            info.loss,
            info.simulations,
            if info.failed_simulations > 0 {
                format!(" ({} failed)", info.failed_simulations)
            } else {
                String::new()
            }
        ));
    }

    fn finish(&mut self) {
        self.bar.finish_and_clear();
    }
}
