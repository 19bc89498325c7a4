//! What a grey-box estimation returns: estimates with uncertainty, fit per run and output
//! (thesis Tables 5.10–5.12), the identifiability findings and why the solver stopped.

use std::fmt;

use airsus_model::SuspensionModel;
use serde::Serialize;

use super::identifiability::{JacobianAnalysis, NotIdentifiable, Unidentifiable};

/// Why the solver stopped. Not an error: every variant comes with the best point found.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum StopReason {
    /// Relative loss decrease or scaled step below the tolerance (or residuals orthogonal
    /// to the Jacobian).
    Converged,
    /// The tolerance is below what floating point resolves here: a minimum to machine
    /// precision.
    NoFurtherImprovement,
    /// The iteration budget ran out before convergence.
    MaxIterations { iterations: usize },
    /// The evaluation budget ran out (trial steps kept being rejected).
    MaxEvaluations { evaluations: usize },
    /// The solver stopped without reaching a minimum; the reason says why.
    NotConverging { reason: String },
    /// Nothing was freed, or no freed parameter is identifiable from the runs.
    NothingToEstimate,
    /// The result equals the start: the fit moved no parameter (the identifiability screen
    /// reset `fixed` of them and the rest did not move). Never reported as converged.
    NoParameterMoved { fixed: usize, freed: usize },
}

impl StopReason {
    /// Whether the estimate is a (local) minimum of the loss.
    pub fn is_converged(&self) -> bool {
        matches!(self, Self::Converged | Self::NoFurtherImprovement)
    }
}

impl fmt::Display for StopReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Converged => write!(f, "converged"),
            Self::NoFurtherImprovement => {
                write!(
                    f,
                    "converged (no further improvement possible in floating point)"
                )
            }
            Self::MaxIterations { iterations } => write!(
                f,
                "NOT converged: iteration limit ({iterations}) reached; the best point found is returned"
            ),
            Self::MaxEvaluations { evaluations } => write!(
                f,
                "NOT converged: evaluation limit ({evaluations}) reached; the best point found is returned"
            ),
            Self::NotConverging { reason } => write!(
                f,
                "NOT converged: {reason}; the best point found is returned"
            ),
            Self::NothingToEstimate => {
                write!(f, "nothing to estimate: no identifiable parameter is free")
            }
            Self::NoParameterMoved { fixed, freed } => write!(
                f,
                "NOT estimated: no parameter moved from its start ({fixed} of {freed} found not identifiable); the result is the start"
            ),
        }
    }
}

/// What happened to one freed parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ParameterStatus {
    /// Estimated, inside its bounds.
    Estimated,
    /// Estimated, but it ended on a bound: the bound, not the data, fixed it (no standard
    /// deviation).
    AtBound,
    /// The runs cannot determine it: kept at its start value, the nominal one or, when a
    /// start of the global stage other than the nominal one won, that start's draw (see the
    /// identifiability report).
    FixedNotIdentifiable,
    /// Not identifiable, but estimated anyway ([`super::IdentifiabilityPolicy::ReportOnly`]):
    /// the value is arbitrary along the undetermined direction.
    NotIdentifiable,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EstimatedParameter {
    pub name: String,
    pub unit: String,
    pub nominal: f64,
    pub estimate: f64,
    /// One standard deviation (module docs of `identifiability`) as if the residuals were
    /// white; `None` when fixed, at a bound or undetermined.
    pub std: Option<f64>,
    /// One standard deviation allowing for residuals correlated in time (Newey–West over
    /// each run, [`GreyboxEstimate::residual_batches`]), where `std` takes each sample as
    /// independent: a model's slow misfit carries far less information than as many
    /// independent samples would. On the built-in study 1-46 times `std` (about 1 for the
    /// `truck` structure at its noise floor). Biased low by up to a quarter, and coarse where
    /// a run holds few correlation times. `None` where `std` is.
    pub std_correlated: Option<f64>,
    pub lower: f64,
    pub upper: f64,
    pub status: ParameterStatus,
}

/// NRMSE (thesis eq 3.33, `airsus_validate::nrmse_percent`) of one run, nominal and
/// estimated, per output; `None` where undefined (a constant measured output).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunFit {
    pub run: String,
    pub samples: usize,
    pub height_nominal_percent: Option<f64>,
    pub height_estimated_percent: Option<f64>,
    pub pressure_nominal_percent: Option<f64>,
    pub pressure_estimated_percent: Option<f64>,
}

/// Identifiability findings before and after the fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IdentifiabilityReport {
    /// At the nominal point, all freed parameters, with the data's own noise level.
    pub before: JacobianAnalysis,
    /// At the estimate, the estimated parameters, with the residuals' noise level.
    pub after: Option<JacobianAnalysis>,
    /// Freed parameters the runs cannot determine.
    pub not_identifiable: Vec<NotIdentifiable>,
}

/// The correlation matrix of the estimated parameters.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Correlation {
    pub parameters: Vec<String>,
    /// Row-major.
    pub values: Vec<Vec<f64>>,
}

/// The batches [`EstimatedParameter::std_correlated`] summed one run's scores over.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResidualBatches {
    pub run: String,
    pub samples: usize,
    /// Samples per (sliding) batch: Andrews' bandwidth for the run's score series.
    pub batch_samples: usize,
    /// Whether the bandwidth asked for was longer than allowed (a quarter of the run, at
    /// least 1 sample), and cut: the run is short against its residuals' correlation.
    pub longest: bool,
}

/// The result of [`super::estimate`].
#[derive(Debug, Serialize)]
pub struct GreyboxEstimate {
    pub model: String,
    pub parameters: Vec<EstimatedParameter>,
    pub fits: Vec<RunFit>,
    pub identifiability: IdentifiabilityReport,
    pub correlation: Correlation,
    pub stop: StopReason,
    /// LM iterations over all fit rounds.
    pub iterations: usize,
    /// Fit rounds (more than one when parameters found not identifiable after a fit were
    /// fixed and the rest refitted).
    pub rounds: usize,
    /// Simulations of one run each, all included (nominal, Jacobians, trial steps, report).
    pub simulations: usize,
    /// Of those, how many failed (treated as a large loss, not an abort).
    pub failed_simulations: usize,
    /// Mean squared normalised residual at the nominal point and at the estimate.
    pub loss_nominal: f64,
    pub loss_estimated: f64,
    /// `‖∂loss/∂z‖` at the estimate over the parameters left free, `z` the solver's scaled
    /// coordinates (a parameter's offset from nominal in units of its scale); `None` when no
    /// parameter was left free or the final Jacobian is missing.
    pub gradient_norm: Option<f64>,
    /// Per estimation run, how [`EstimatedParameter::std_correlated`] was estimated; empty
    /// where it was not.
    pub residual_batches: Vec<ResidualBatches>,
    pub elapsed_s: f64,
    /// The model with the estimated parameters (write it back with
    /// [`SuspensionModel::write_parameters`]).
    #[serde(skip)]
    pub estimated_model: Box<dyn SuspensionModel>,
}

impl GreyboxEstimate {
    pub fn parameter(&self, name: &str) -> Option<&EstimatedParameter> {
        self.parameters.iter().find(|p| p.name == name)
    }

    /// Whether `name` was found not identifiable (at any stage).
    pub fn is_not_identifiable(&self, name: &str) -> bool {
        self.identifiability
            .not_identifiable
            .iter()
            .any(|n| n.name == name)
    }
}

fn pct(x: Option<f64>) -> String {
    x.map_or_else(|| "—".to_owned(), |v| format!("{v:.2} %"))
}

impl Unidentifiable {
    /// Why the runs cannot determine the parameter, in words for a report.
    pub fn describe(&self) -> String {
        reason_text(self)
    }
}

fn reason_text(reason: &Unidentifiable) -> String {
    match reason {
        Unidentifiable::NoSensitivity => {
            "no sensitivity: the outputs do not depend on it in these runs".to_owned()
        }
        Unidentifiable::SimulationFails => {
            "the model does not simulate when it moves either way from the point reached: its effect could not be measured there".to_owned()
        }
        Unidentifiable::Collinear { with } => {
            format!("only a combination with {} is determined", with.join(", "))
        }
        Unidentifiable::Undetermined {
            relative_std,
            limit,
        } => format!(
            "standard deviation {:.0} % of its scale (limit {:.0} %)",
            100.0 * relative_std,
            100.0 * limit
        ),
    }
}

impl fmt::Display for GreyboxEstimate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "Grey-box estimation, model {}", self.model)?;
        writeln!(f, "stop: {}", self.stop)?;
        writeln!(
            f,
            "{} iteration(s) in {} round(s), {} simulations ({} failed), {:.2} s; loss {:.4e} -> {:.4e}",
            self.iterations,
            self.rounds,
            self.simulations,
            self.failed_simulations,
            self.elapsed_s,
            self.loss_nominal,
            self.loss_estimated
        )?;
        if let Some(g) = self.gradient_norm {
            writeln!(
                f,
                "gradient norm at the estimate {g:.3e} (scaled parameters; loss {:.4e})",
                self.loss_estimated
            )?;
        }
        writeln!(f)?;
        writeln!(
            f,
            "{:<24} {:>8} {:>12} {:>12} {:>14} {:>14}",
            "run", "samples", "height nom", "height est", "pressure nom", "pressure est"
        )?;
        for r in &self.fits {
            writeln!(
                f,
                "{:<24} {:>8} {:>12} {:>12} {:>14} {:>14}",
                r.run,
                r.samples,
                pct(r.height_nominal_percent),
                pct(r.height_estimated_percent),
                pct(r.pressure_nominal_percent),
                pct(r.pressure_estimated_percent)
            )?;
        }
        writeln!(f, "(NRMSE, thesis eq 3.33)")?;
        writeln!(f)?;
        writeln!(
            f,
            "{:<8} {:>14} {:>14} {:>12} {:>12} {:>8}  status",
            "param", "nominal", "estimate", "± std", "± std corr.", "unit"
        )?;
        for p in &self.parameters {
            let status = match p.status {
                ParameterStatus::Estimated => "estimated",
                ParameterStatus::AtBound => "AT BOUND",
                ParameterStatus::FixedNotIdentifiable => "fixed: not identifiable",
                ParameterStatus::NotIdentifiable => "NOT IDENTIFIABLE (estimated anyway)",
            };
            writeln!(
                f,
                "{:<8} {:>14.6e} {:>14.6e} {:>12} {:>12} {:>8}  {}",
                p.name,
                p.nominal,
                p.estimate,
                p.std.map_or_else(|| "—".to_owned(), |s| format!("{s:.3e}")),
                p.std_correlated
                    .map_or_else(|| "—".to_owned(), |s| format!("{s:.3e}")),
                p.unit,
                status
            )?;
        }
        if !self.residual_batches.is_empty() {
            writeln!(
                f,
                "(± std: white residuals; ± std corr.: residuals correlated in time allowed for, batches of {})",
                self.residual_batches
                    .iter()
                    .map(|b| format!(
                        "{} of {} samples in {}{}",
                        b.batch_samples,
                        b.samples,
                        b.run,
                        if b.longest {
                            " (cut to the longest allowed)"
                        } else {
                            ""
                        }
                    ))
                    .collect::<Vec<_>>()
                    .join(", ")
            )?;
        }
        let id = &self.identifiability;
        if !id.not_identifiable.is_empty() {
            writeln!(f)?;
            writeln!(f, "Not identifiable from these runs:")?;
            for n in &id.not_identifiable {
                let stage = match n.stage {
                    super::identifiability::Stage::BeforeFit => "before the fit",
                    super::identifiability::Stage::AfterFit => "after the fit",
                };
                write!(f, "  {} ({stage}): {}", n.name, reason_text(&n.reason))?;
                if !n.determined_by.is_empty() {
                    write!(f, "; it needs {}", n.determined_by)?;
                }
                if !n.correlated_with.is_empty() {
                    write!(
                        f,
                        "; correlated with {}",
                        n.correlated_with
                            .iter()
                            .map(|(name, r)| format!("{name} ({r:+.3})"))
                            .collect::<Vec<_>>()
                            .join(", ")
                    )?;
                }
                writeln!(f)?;
            }
        }
        writeln!(f)?;
        let b = &id.before;
        writeln!(
            f,
            "Jacobian before the fit: condition number {:.3e} (column-normalised), singular values {}",
            b.condition_number,
            b.singular_values
                .iter()
                .map(|s| format!("{s:.2e}"))
                .collect::<Vec<_>>()
                .join(" ")
        )?;
        if let Some(a) = &id.after {
            writeln!(
                f,
                "Jacobian after the fit:  condition number {:.3e}, singular values {}",
                a.condition_number,
                a.singular_values
                    .iter()
                    .map(|s| format!("{s:.2e}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            )?;
            for c in &a.high_correlations {
                writeln!(
                    f,
                    "  strongly correlated: {} and {} ({:+.4})",
                    c.a, c.b, c.correlation
                )?;
            }
        }
        if self.correlation.parameters.len() > 1 {
            writeln!(f)?;
            writeln!(f, "Correlation of the estimates:")?;
            write!(f, "{:<8}", "")?;
            for name in &self.correlation.parameters {
                write!(f, " {name:>7}")?;
            }
            writeln!(f)?;
            for (name, row) in self
                .correlation
                .parameters
                .iter()
                .zip(&self.correlation.values)
            {
                write!(f, "{name:<8}")?;
                for v in row {
                    write!(f, " {v:>7.3}")?;
                }
                writeln!(f)?;
            }
        }
        Ok(())
    }
}
