//! The solver: Levenberg–Marquardt (MINPACK's trust-region variant, crate
//! `levenberg-marquardt`) on the scaled, box-projected least-squares problem of `evaluate`.

use std::cell::{Cell, RefCell};

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt, TerminationReason};
use nalgebra::storage::Owned;
use nalgebra::{DMatrix, DMatrixView, DVector, Dyn};

use super::evaluate::Evaluator;
use super::result::StopReason;
use crate::progress::{IterationInfo, Observer};

/// Trial steps in a row that fail to simulate before a stop at a tiny trust region counts
/// as "not converging" rather than "converged".
const FAILING_TRIALS_NOT_CONVERGED: usize = 3;

pub(crate) struct FitSettings {
    pub fd_step: f64,
    /// MINPACK's `xtol` and `gtol`.
    pub tolerance: f64,
    /// MINPACK's `ftol`.
    pub loss_tolerance: f64,
    pub max_iterations: usize,
    /// Residual value of every sample of a run that failed to simulate.
    pub fail_value: f64,
    /// Weight of the bound-penalty rows.
    pub kappa: f64,
    pub round: usize,
}

pub(crate) struct FitOutcome {
    /// Best point found (scaled, all freed parameters).
    pub z: Vec<f64>,
    /// Its data residuals.
    pub residuals: Vec<f64>,
    pub stop: StopReason,
    pub iterations: usize,
    /// The data Jacobian at the best point (active columns) and its failed columns, when
    /// the solver computed it there (a fit that converged at an accepted point): the caller
    /// need not simulate it again.
    pub jacobian: Option<ColumnsAt>,
}

/// Forward-difference data Jacobian columns (the active parameters') at a point, with the
/// columns whose simulations failed ([`Evaluator::jacobian`]).
pub(crate) struct ColumnsAt {
    pub z: Vec<f64>,
    /// The data rows, then (as the solver keeps it) zero rows where its penalty rows go.
    columns: DMatrix<f64>,
    data_rows: usize,
    pub failed: Vec<usize>,
}

impl ColumnsAt {
    pub fn new(z: Vec<f64>, columns: DMatrix<f64>, failed: Vec<usize>) -> Self {
        Self {
            z,
            data_rows: columns.nrows(),
            columns,
            failed,
        }
    }

    /// The data Jacobian: a row per data residual, a column per active parameter.
    pub fn data(&self) -> DMatrixView<'_, f64> {
        self.columns.rows(0, self.data_rows)
    }
}

struct Cached {
    z: Vec<f64>,
    residuals: DVector<f64>,
    data_loss: f64,
}

struct Best {
    z: Vec<f64>,
    residuals: Vec<f64>,
    loss: f64,
}

struct LmFit<'e, 'a, 'o> {
    ev: &'e Evaluator<'a>,
    active: Vec<usize>,
    z: Vec<f64>,
    settings: &'e FitSettings,
    cache: RefCell<Option<Cached>>,
    best: RefCell<Best>,
    iterations: Cell<usize>,
    budget_hit: Cell<bool>,
    failing_trials: Cell<usize>,
    observer: RefCell<&'o mut dyn Observer>,
    /// The last Jacobian computed (or the caller's, at the start): each costs a simulation
    /// per active parameter, and the caller's screen has one at the start and needs one at
    /// the end.
    last_jacobian: RefCell<Option<ColumnsAt>>,
}

impl LmFit<'_, '_, '_> {
    /// Data residuals then one penalty row per active parameter, at `self.z`.
    fn evaluate(&self) -> DVector<f64> {
        if let Some(c) = self.cache.borrow().as_ref()
            && c.z == self.z
        {
            return c.residuals.clone();
        }
        let ev = self.ev;
        let n_data = ev.n_data();
        let mut out = DVector::zeros(n_data + self.active.len());
        let theta = ev.theta(&self.z);
        let failed = match ev.simulate(&theta) {
            Ok(responses) => ev.residuals_into(
                &theta,
                &responses,
                self.settings.fail_value,
                &mut out.as_mut_slice()[..n_data],
            ),
            Err(_) => {
                out.as_mut_slice()[..n_data].fill(self.settings.fail_value);
                true
            }
        };
        let data_loss: f64 = out.as_slice()[..n_data].iter().map(|r| r * r).sum();
        if failed {
            self.failing_trials.set(self.failing_trials.get() + 1);
        } else {
            self.failing_trials.set(0);
            let mut best = self.best.borrow_mut();
            if data_loss < best.loss {
                *best = Best {
                    z: self.z.clone(),
                    residuals: out.as_slice()[..n_data].to_vec(),
                    loss: data_loss,
                };
            }
        }
        for (k, &j) in self.active.iter().enumerate() {
            let (lo, hi) = ev.params[j].z_range();
            out[n_data + k] = self.settings.kappa * (self.z[j] - self.z[j].clamp(lo, hi));
        }
        *self.cache.borrow_mut() = Some(Cached {
            z: self.z.clone(),
            residuals: out.clone(),
            data_loss,
        });
        out
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for LmFit<'_, '_, '_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        for (k, &j) in self.active.iter().enumerate() {
            self.z[j] = x[k];
        }
    }

    fn params(&self) -> DVector<f64> {
        DVector::from_iterator(self.active.len(), self.active.iter().map(|&j| self.z[j]))
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        Some(self.evaluate())
    }

    /// Called once per LM iteration at the accepted point; also where the iteration budget
    /// is enforced (returning `None` stops the solver, mapped to [`StopReason::MaxIterations`]).
    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let iteration = self.iterations.get() + 1;
        let r = self.evaluate();
        let n_data = self.ev.n_data();
        let loss = self
            .cache
            .borrow()
            .as_ref()
            .map_or(f64::NAN, |c| c.data_loss)
            / n_data as f64;
        if iteration > self.settings.max_iterations {
            self.budget_hit.set(true);
            return None;
        }
        self.iterations.set(iteration);
        self.observer.borrow_mut().iteration(&IterationInfo {
            round: self.settings.round,
            iteration,
            loss,
            simulations: self.ev.simulations(),
            failed_simulations: self.ev.failures(),
        });
        let p = self.active.len();
        // The solver's matrix is the data rows then a penalty row per active parameter; it
        // consumes it, so the columns kept for the caller are a copy.
        let known = self
            .last_jacobian
            .borrow()
            .as_ref()
            .filter(|known| known.z == self.z)
            .map(|known| {
                if known.data_rows == n_data && known.columns.nrows() == n_data + p {
                    known.columns.clone()
                } else {
                    let mut j = DMatrix::zeros(n_data + p, p);
                    j.rows_mut(0, n_data).copy_from(&known.data());
                    j
                }
            });
        let mut j = match known {
            Some(j) => j,
            None => {
                let (columns, failed) = self.ev.jacobian_padded(
                    &self.z,
                    &self.active,
                    &r.as_slice()[..n_data],
                    self.settings.fd_step,
                    p,
                );
                let kept = ColumnsAt {
                    z: self.z.clone(),
                    columns: columns.clone(),
                    data_rows: n_data,
                    failed,
                };
                *self.last_jacobian.borrow_mut() = Some(kept);
                columns
            }
        };
        for (k, &c) in self.active.iter().enumerate() {
            let (lo, hi) = self.ev.params[c].z_range();
            if self.z[c] < lo || self.z[c] > hi {
                j[(n_data + k, k)] = self.settings.kappa;
            }
        }
        Some(j)
    }
}

/// Minimises from `z0` over the `active` parameters; returns the best point found.
pub(crate) fn fit(
    ev: &Evaluator<'_>,
    active: &[usize],
    z0: Vec<f64>,
    start_residuals: Vec<f64>,
    settings: &FitSettings,
    start_jacobian: Option<ColumnsAt>,
    observer: &mut dyn Observer,
) -> FitOutcome {
    let start_loss: f64 = start_residuals.iter().map(|r| r * r).sum();
    // The start was simulated by the caller: seed the cache so the solver does not repeat it.
    let n_data = start_residuals.len();
    let mut seeded = DVector::zeros(n_data + active.len());
    seeded.as_mut_slice()[..n_data].copy_from_slice(&start_residuals);
    for (k, &j) in active.iter().enumerate() {
        let (lo, hi) = ev.params[j].z_range();
        seeded[n_data + k] = settings.kappa * (z0[j] - z0[j].clamp(lo, hi));
    }
    let problem = LmFit {
        ev,
        active: active.to_vec(),
        z: z0.clone(),
        settings,
        cache: RefCell::new(Some(Cached {
            z: z0.clone(),
            residuals: seeded,
            data_loss: start_loss,
        })),
        best: RefCell::new(Best {
            z: z0,
            residuals: start_residuals,
            loss: start_loss,
        }),
        iterations: Cell::new(0),
        budget_hit: Cell::new(false),
        failing_trials: Cell::new(0),
        observer: RefCell::new(observer),
        last_jacobian: RefCell::new(start_jacobian),
    };
    // The evaluation budget (MINPACK maxfev = patience·(n+1)) is generous: the iteration
    // budget is the limit users set; this only catches a trust region that never accepts.
    let lm = LevenbergMarquardt::new()
        .with_ftol(settings.loss_tolerance)
        .with_xtol(settings.tolerance)
        .with_gtol(settings.tolerance)
        .with_patience(4 * settings.max_iterations.max(1));
    let (problem, report) = lm.minimize(problem);
    let iterations = problem.iterations.get();
    let stop = match report.termination {
        TerminationReason::User(_) if problem.budget_hit.get() => StopReason::MaxIterations {
            iterations: settings.max_iterations,
        },
        TerminationReason::Converged { .. }
        | TerminationReason::Orthogonal
        | TerminationReason::ResidualsZero
            if problem.failing_trials.get() >= FAILING_TRIALS_NOT_CONVERGED =>
        {
            StopReason::NotConverging {
                reason: format!(
                    "the last {} trial steps failed to simulate: the solver stopped at the edge of the region where the model simulates, not at a minimum",
                    problem.failing_trials.get()
                ),
            }
        }
        TerminationReason::Converged { .. }
        | TerminationReason::Orthogonal
        | TerminationReason::ResidualsZero => StopReason::Converged,
        TerminationReason::NoImprovementPossible(_) => StopReason::NoFurtherImprovement,
        TerminationReason::LostPatience => StopReason::MaxEvaluations {
            evaluations: report.number_of_evaluations,
        },
        TerminationReason::Numerical(what) => StopReason::NotConverging {
            reason: format!("numerical breakdown ({what} not finite)"),
        },
        other => StopReason::NotConverging {
            reason: format!("the solver stopped: {other:?}"),
        },
    };
    let best = problem.best.into_inner();
    let jacobian = problem
        .last_jacobian
        .into_inner()
        .filter(|known| known.z == best.z);
    FitOutcome {
        z: best.z,
        residuals: best.residuals,
        stop,
        iterations,
        jacobian,
    }
}
