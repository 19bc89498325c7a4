//! ARX by linear least squares (thesis eq 3.28, 3.31–3.32).

use super::data::IdData;
use super::error::IdentError;
use super::estimate::{Estimate, Method, RawEstimate, StopReason};
use super::lstsq::{LagColumn, LsFit, RegressionPart, lagged_least_squares_parts};
use super::orders::{ArxOrders, Layout};
use super::pem::merged_experiments;

/// Estimates an ARX model `A(q)y(t) = Σᵢ Bᵢ(q)uᵢ(t − nkᵢ) + e(t)` (≙ MATLAB `arx(data, [na nb nk])`).
///
/// The predictor `ŷ(t|θ) = θᵀφ(t)` with
/// `φ(t) = [−y(t−1) … −y(t−na), u₁(t−nk₁) … u₁(t−nk₁−nb₁+1), …]` is linear in `θ`, so
/// `θ̂ = argmin Σ (y(t) − θᵀφ(t))²` (thesis eq 3.30–3.32) is solved by QR of the regressor
/// matrix (see [`crate::linear`] for why never by the normal equations). Only rows with a
/// complete regressor enter, `t = t₀ … N−1` with `t₀ = max(na, nkᵢ + nbᵢ − 1)` (Ljung 1999
/// §10.1; the same rows as ControlSystemIdentification.jl and SIPPY use); the estimate is unique when `Φ` has full column rank, which is
/// checked.
///
/// The least-squares ARX is not forced to be stable: it is the unique minimiser, and its
/// predictor is an FIR filter, always stable. Check [`crate::linear::PolyModel::is_stable`]
/// before simulating it.
///
/// Errors: orders that do not match the data, a constant input, too few samples, or a rank
/// deficient regression (inputs that do not excite the model).
pub fn arx(data: &IdData, orders: &ArxOrders) -> Result<Estimate, IdentError> {
    let layout = Layout::arx(orders);
    layout.validate(data)?;
    let (theta, fit, t0) = arx_least_squares(data.y(), data.u(), &layout)?;
    let model = layout.model(&theta, data.ts_s());
    let prediction_fit = prediction_fit_percent(&data.y()[t0..], fit.rss);
    Ok(Estimate::assemble(RawEstimate {
        model,
        names: layout.names(),
        theta,
        inverse_gram: fit.inverse_gram()?,
        rss: fit.rss,
        n_samples: fit.rows,
        fit_percent: prediction_fit,
        // ARX is a one-step-prediction fit; a simulation would cost more than the fit itself
        // on long records. Callers who want it: `fit_percent(y, &model.simulate(u)?)`.
        simulation_fit_percent: None,
        method: Method::LeastSquaresQr,
        stop: StopReason::Exact,
        evaluations: 1,
    }))
}

/// [`arx`] of several experiments at once (≙ MATLAB `arx(merge(z1, z2, …), orders)`): one
/// regression over every experiment's complete regressor rows, none reaching from one
/// experiment into the next (each starts at its own `t₀`). For what no experiment alone
/// determines: in a bellow's loading run the pressure follows the load, in a valve run the
/// load is constant. The same inputs and sample time in every experiment, each input varying
/// in at least one (as [`crate::linear::oe_merged`]).
pub fn arx_merged(experiments: &[IdData], orders: &ArxOrders) -> Result<Estimate, IdentError> {
    let layout = Layout::arx(orders);
    merged_experiments(experiments, &layout)?;
    let t0 = layout.max_lag();
    let parts: Vec<RegressionPart<'_>> = experiments
        .iter()
        .map(|e| RegressionPart {
            columns: arx_columns(e.y(), e.u(), &layout),
            target: e.y(),
            t0,
        })
        .collect();
    let names = layout.names();
    let fit = lagged_least_squares_parts(&parts, &|j| names[j].clone())?;
    let theta: Vec<f64> = fit.theta.iter().copied().collect();
    let model = layout.model(&theta, experiments[0].ts_s());
    // The prediction fit over the rows that entered, pooled.
    let rows: Vec<f64> = experiments
        .iter()
        .flat_map(|e| e.y()[t0.min(e.len())..].iter().copied())
        .collect();
    Ok(Estimate::assemble(RawEstimate {
        model,
        names,
        theta,
        inverse_gram: fit.inverse_gram()?,
        rss: fit.rss,
        n_samples: fit.rows,
        fit_percent: prediction_fit_percent(&rows, fit.rss),
        simulation_fit_percent: None,
        method: Method::LeastSquaresQr,
        stop: StopReason::Exact,
        evaluations: 1,
    }))
}

/// `100 (1 − √(rss / Σ (y − ȳ)²))` over the regression's rows `y`.
fn prediction_fit_percent(rows: &[f64], rss: f64) -> f64 {
    let mean = rows.iter().sum::<f64>() / rows.len() as f64;
    let spread: f64 = rows.iter().map(|v| (v - mean) * (v - mean)).sum();
    100.0 * (1.0 - (rss / spread).sqrt())
}

/// The ARX regressors `−y(t−1) … −y(t−na), uᵢ(t−nkᵢ) … uᵢ(t−nkᵢ−nbᵢ+1)` of a layout.
fn arx_columns<'a>(y: &'a [f64], u: &'a [Vec<f64>], layout: &Layout) -> Vec<LagColumn<'a>> {
    let mut columns = Vec::with_capacity(layout.na + layout.nb.iter().sum::<usize>());
    columns.extend((1..=layout.na).map(|lag| LagColumn {
        signal: y,
        lag,
        negate: true,
    }));
    for (i, ui) in u.iter().enumerate() {
        columns.extend((0..layout.nb[i]).map(|l| LagColumn {
            signal: ui,
            lag: layout.nk[i] + l,
            negate: false,
        }));
    }
    columns
}

/// The ARX least-squares problem for a layout (only `na`, `nb`, `nk` are used): returns
/// `θ`, the fit and the first regression row `t₀`.
pub(crate) fn arx_least_squares(
    y: &[f64],
    u: &[Vec<f64>],
    layout: &Layout,
) -> Result<(Vec<f64>, LsFit, usize), IdentError> {
    let t0 = layout.max_lag();
    let names = layout.names();
    let fit = lagged_least_squares_parts(
        &[RegressionPart {
            columns: arx_columns(y, u, layout),
            target: y,
            t0,
        }],
        &|j| names[j].clone(),
    )?;
    Ok((fit.theta.iter().copied().collect(), fit, t0))
}
