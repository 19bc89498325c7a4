//! ARX order selection over a grid (≙ MATLAB `arxstruc` + `selstruc`).

use rayon::prelude::*;
use serde::Serialize;

use super::arx::arx_least_squares;
use super::data::IdData;
use super::error::IdentError;
use super::orders::{ArxOrders, Layout};

/// Candidate orders: every combination of `na × nb × nk`, with `nb` and `nk` applied to every
/// input (≙ MATLAB `struc(na, nb, nk)`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ArxGrid {
    /// Candidate `na` values.
    pub na: Vec<usize>,
    /// Candidate `nb` values (same for every input).
    pub nb: Vec<usize>,
    /// Candidate `nk` values (same for every input).
    pub nk: Vec<usize>,
}

/// One evaluated candidate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OrderCandidate {
    /// The orders.
    pub orders: ArxOrders,
    /// `d`, number of parameters.
    pub n_parameters: usize,
    /// Loss on the estimation data, `V = (1/N) Σ ε²`.
    pub estimation_loss: f64,
    /// Loss of the one-step predictor on the validation data (what `arxstruc` reports).
    pub validation_loss: f64,
    /// Number of estimation data points `N` used in the criteria.
    pub n_estimation: usize,
}

/// How to choose among candidates (≙ the second argument of MATLAB `selstruc`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum SelectionCriterion {
    /// Smallest validation loss `V` (`selstruc(V, 0)`).
    BestFit,
    /// Akaike: smallest `log V + 2d/N` (`selstruc(V, 'aic')`).
    Aic,
    /// Rissanen's minimum description length: smallest `V (1 + d log(N)/N)`
    /// (`selstruc(V, 'mdl')`).
    Mdl,
}

impl OrderCandidate {
    /// The modified criterion that `criterion` minimises, with `V` the validation loss and `N`
    /// the number of estimation samples.
    pub fn criterion(&self, criterion: SelectionCriterion) -> f64 {
        let v = self.validation_loss;
        let d = self.n_parameters as f64;
        let n = self.n_estimation as f64;
        match criterion {
            SelectionCriterion::BestFit => v,
            SelectionCriterion::Aic => v.ln() + 2.0 * d / n,
            SelectionCriterion::Mdl => v * (1.0 + d * n.ln() / n),
        }
    }
}

/// Fits an ARX model for every candidate in `grid` on `estimation` and evaluates its one-step
/// prediction loss on `validation` (≙ MATLAB `arxstruc(ze, zv, NN)`).
///
/// All candidates are scored on the same validation rows (from the largest start-up lag of the
/// grid on), so their losses are comparable. Candidates whose regression is rank deficient
/// are skipped; other errors are returned.
pub fn arx_struc(
    estimation: &IdData,
    validation: &IdData,
    grid: &ArxGrid,
) -> Result<Vec<OrderCandidate>, IdentError> {
    if grid.na.is_empty() || grid.nb.is_empty() || grid.nk.is_empty() {
        return Err(IdentError::InvalidOption(
            "every order list in the grid needs at least one value".to_owned(),
        ));
    }
    if validation.n_inputs() != estimation.n_inputs() {
        return Err(IdentError::InputCountMismatch {
            orders: estimation.n_inputs(),
            data: validation.n_inputs(),
        });
    }
    let m = estimation.n_inputs();
    let mut candidates = Vec::new();
    for &na in &grid.na {
        for &nb in &grid.nb {
            for &nk in &grid.nk {
                candidates.push(ArxOrders {
                    na,
                    nb: vec![nb; m],
                    nk: vec![nk; m],
                });
            }
        }
    }
    let layouts: Vec<Layout> = candidates.iter().map(Layout::arx).collect();
    let t0_validation = layouts.iter().map(Layout::max_lag).max().unwrap_or(0);
    if validation.len() <= t0_validation {
        return Err(IdentError::TooFewSamples {
            available: validation.len(),
            parameters: 0,
            required: t0_validation + 1,
        });
    }
    for layout in &layouts {
        layout.validate(estimation)?;
    }
    let results: Vec<Result<Option<OrderCandidate>, IdentError>> = candidates
        .into_par_iter()
        .zip(layouts.into_par_iter())
        .map(|(orders, layout)| {
            let (theta, fit, _) = match arx_least_squares(estimation.y(), estimation.u(), &layout) {
                Ok(r) => r,
                Err(IdentError::RankDeficient { .. }) => return Ok(None),
                Err(e) => return Err(e),
            };
            let model = layout.model(&theta, estimation.ts_s());
            let eps = model.residuals(validation.y(), validation.u())?;
            let tail = &eps[t0_validation..];
            let validation_loss = tail.iter().map(|e| e * e).sum::<f64>() / tail.len() as f64;
            Ok(Some(OrderCandidate {
                n_parameters: theta.len(),
                estimation_loss: fit.rss / fit.rows as f64,
                validation_loss,
                n_estimation: fit.rows,
                orders,
            }))
        })
        .collect();
    let mut out = Vec::with_capacity(results.len());
    for r in results {
        if let Some(c) = r? {
            out.push(c);
        }
    }
    Ok(out)
}

/// The candidate minimising `criterion` (≙ MATLAB `selstruc(V, c)`); ties go to the fewer
/// parameters. `None` only for an empty list.
pub fn select_structure(
    candidates: &[OrderCandidate],
    criterion: SelectionCriterion,
) -> Option<&OrderCandidate> {
    candidates.iter().min_by(|a, b| {
        a.criterion(criterion)
            .total_cmp(&b.criterion(criterion))
            .then(a.n_parameters.cmp(&b.n_parameters))
    })
}
