//! Prediction-error minimisation for ARMAX, OE and BJ (thesis eq 3.29–3.30, Ljung 1999 ch. 7
//! and §10.2–10.3).
//!
//! # Predictor and gradient
//!
//! For the general structure `A y = Σᵢ Bᵢ/Fᵢ uᵢ + C/D e` the one-step prediction error is
//!
//! ```text
//! wᵢ = (Bᵢ q^{−nkᵢ} / Fᵢ) uᵢ,   v = A y − Σᵢ wᵢ,   ε = (D / C) v
//! ```
//!
//! and its derivatives are again filtered signals (Ljung 1999 §10.3), so the Jacobian
//! costs a handful of IIR filters per iteration rather than finite differences:
//!
//! ```text
//! ∂ε/∂aₖ      =  (D/C) y(t−k)
//! ∂ε/∂b⁽ⁱ⁾ₗ   = −(D/(C Fᵢ)) uᵢ(t−nkᵢ−l+1)
//! ∂ε/∂f⁽ⁱ⁾ₖ   =  (D/(C Fᵢ)) wᵢ(t−k)
//! ∂ε/∂cₖ      = −(1/C) ε(t−k)
//! ∂ε/∂dₖ      =  (1/C) v(t−k)
//! ```
//!
//! All filters start from zero initial conditions (MATLAB `InitialCondition = 'zero'`) and
//! every one of the `N` prediction errors enters `V = (1/N) Σ ε²`.
//!
//! # Optimiser
//!
//! `V` is minimised by the `levenberg-marquardt` crate (a port of MINPACK's `lmder`, with
//! scaled trust region), which plays the role of MATLAB's `'lm'` search method.
//!
//! # Stability
//!
//! The predictor divides by `C` and `Fᵢ`, the simulation by `A` and `Fᵢ`; all of `A`, `C`,
//! `D`, `Fᵢ` are kept strictly stable:
//!
//! 1. the initial estimate has every root outside the unit circle reflected to `1/r̄`, as
//!    MATLAB does ([`crate::linear::reflect_into_unit_circle`]);
//! 2. during the search, a trial parameter vector with any of these polynomials unstable
//!    (Schur–Cohn test, [`crate::linear::is_stable`]) is answered with a huge residual
//!    vector, so the trust-region step is rejected and shrunk: every accepted iterate, and
//!    hence the result, is stable. When the data pull towards an unstable model the estimate
//!    ends at the best stable model near the stability boundary.

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt, TerminationReason};
use nalgebra::{DMatrix, DVector, Dyn, Owned, QR};
use serde::Serialize;

use super::arx::arx_least_squares;
use super::data::{IdData, check_input_varies};
use super::error::IdentError;
use super::estimate::{Estimate, Method, RawEstimate, StopReason, fit_percent};
use super::lstsq::{LagColumn, lagged_least_squares};
use super::model::{PolyModel, Structure};
use super::orders::{ArmaxOrders, ArxOrders, BjOrders, Layout, OeOrders};
use super::poly::{filter_delayed, is_stable, poly_mul, reflect_into_unit_circle};

/// Residual value returned for a trial point with an unstable polynomial. Large enough that
/// the trust-region step is always rejected, small enough that `‖r‖²` stays finite.
const UNSTABLE_RESIDUAL: f64 = 1e50;

/// Options of the prediction-error search (≙ a subset of MATLAB `oeOptions` & co).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PemOptions {
    /// Relative tolerance on the loss decrease, the parameter step and the gradient angle
    /// (MINPACK `ftol`, `xtol`, `gtol`).
    pub tolerance: f64,
    /// Evaluation budget: at most `max_evaluations_per_parameter · (d + 1)` predictor
    /// evaluations (MINPACK `maxfev` factor).
    pub max_evaluations_per_parameter: usize,
}

impl Default for PemOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-10,
            max_evaluations_per_parameter: 100,
        }
    }
}

impl PemOptions {
    fn check(&self) -> Result<(), IdentError> {
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(IdentError::InvalidOption(format!(
                "tolerance must be positive, got {}",
                self.tolerance
            )));
        }
        if self.max_evaluations_per_parameter == 0 {
            return Err(IdentError::InvalidOption(
                "max_evaluations_per_parameter must be at least 1".to_owned(),
            ));
        }
        Ok(())
    }
}

/// Estimates an ARMAX model `A(q)y(t) = Σᵢ Bᵢ(q)uᵢ(t − nkᵢ) + C(q)e(t)` (thesis eq 3.27,
/// ≙ MATLAB `armax`).
///
/// Initial estimate: Hannan–Rissanen / Ljung's `armax` start — a high-order ARX gives
/// innovation estimates `ê`, then least squares of `A y = B u + C ê`; `A` and `C` reflected into
/// the unit circle. Then PEM as described in the [module docs](self).
pub fn armax(
    data: &IdData,
    orders: &ArmaxOrders,
    options: &PemOptions,
) -> Result<Estimate, IdentError> {
    let layout = Layout::armax(orders);
    layout.validate(data)?;
    options.check()?;
    let initial = initial_armax(data, &layout)?;
    minimise(data, &layout, initial, options)
}

/// Estimates an output-error model `y(t) = Σᵢ Bᵢ(q)/Fᵢ(q) uᵢ(t − nkᵢ) + e(t)` (thesis eq
/// 3.26, ≙ MATLAB `oe`). The one-step predictor is the simulation, so this minimises the
/// simulation error ("simulation focus", thesis §5.2.5).
///
/// Initial estimate: a high-order ARX `B̂ᵢ/Â` (consistent for any noise colour as its order
/// grows) gives noise-free per-input outputs `ŵᵢ = B̂ᵢ/Â uᵢ`; each `Fᵢ, Bᵢ` is then fitted by
/// least squares to `Fᵢ ŵᵢ = Bᵢ uᵢ` ("high-order ARX, then reduce", Ljung 1999 §10.4) and
/// reflected stable. Then PEM as described in the [module docs](self).
pub fn oe(data: &IdData, orders: &OeOrders, options: &PemOptions) -> Result<Estimate, IdentError> {
    let layout = Layout::oe(orders);
    layout.validate(data)?;
    options.check()?;
    let initial = initial_oe(data, &layout)?;
    minimise(data, &layout, initial, options)
}

/// Estimates an OE model from several experiments at once (≙ MATLAB
/// `oe(merge(z1, z2, …), orders)`): one parameter vector, each experiment's filters started
/// from zero at its own first sample, every experiment's prediction errors in one loss.
///
/// Why not the experiments end to end: the filters would carry one experiment's end into the
/// next one's start, an input step that never happened. And why several at all: each
/// experiment may excite only some of what the model needs. A loading run moves a bellow's
/// pressure with its load, so the two inputs' effects cannot be told apart there; a run at
/// one load with the valve moving the air has the load constant; together they determine
/// both.
///
/// The search starts from the OE initial estimate (of the experiments end to end, or of one
/// of them) whose loss over all of them is least. Every experiment must have the same inputs
/// and sample time (to 1 ppm); each input must vary in at least one of them.
pub fn oe_merged(
    experiments: &[IdData],
    orders: &OeOrders,
    options: &PemOptions,
) -> Result<Estimate, IdentError> {
    minimise_merged(experiments, &Layout::oe(orders), initial_oe, options)
}

/// [`armax`] of several experiments at once (≙ MATLAB `armax(merge(z1, z2, …), orders)`),
/// as [`oe_merged`]: each experiment's filters, the noise model's among them, started at its
/// own first sample.
pub fn armax_merged(
    experiments: &[IdData],
    orders: &ArmaxOrders,
    options: &PemOptions,
) -> Result<Estimate, IdentError> {
    minimise_merged(experiments, &Layout::armax(orders), initial_armax, options)
}

/// [`bj`] of several experiments at once (≙ MATLAB `bj(merge(z1, z2, …), orders)`), as
/// [`oe_merged`].
pub fn bj_merged(
    experiments: &[IdData],
    orders: &BjOrders,
    options: &PemOptions,
) -> Result<Estimate, IdentError> {
    minimise_merged(experiments, &Layout::bj(orders), initial_bj, options)
}

/// Whether two sample times are one for merging: equal to 1 ppm (sample times read off
/// logs' time columns differ in their last digits).
pub(crate) fn same_sample_time(a_s: f64, b_s: f64) -> bool {
    (a_s / b_s - 1.0).abs() <= 1e-6
}

/// Checks that experiments can be merged for `layout`: the same inputs and sample time
/// ([`same_sample_time`]), the orders valid for them together, and each input varying in
/// at least one. Returns the experiments end to end (for initial estimates and the pooled
/// fit, never for the search).
pub(crate) fn merged_experiments(
    experiments: &[IdData],
    layout: &Layout,
) -> Result<IdData, IdentError> {
    let Some(first) = experiments.first() else {
        return Err(IdentError::Empty);
    };
    for (k, e) in experiments.iter().enumerate() {
        if e.n_inputs() != first.n_inputs() || !same_sample_time(e.ts_s(), first.ts_s()) {
            return Err(IdentError::InvalidOption(format!(
                "experiment {} has {} inputs at {} s; experiment 1 has {} at {} s",
                k + 1,
                e.n_inputs(),
                e.ts_s(),
                first.n_inputs(),
                first.ts_s()
            )));
        }
    }
    let together = IdData::new(
        experiments
            .iter()
            .flat_map(|e| e.y().iter().copied())
            .collect(),
        (0..first.n_inputs())
            .map(|i| {
                experiments
                    .iter()
                    .flat_map(|e| e.u()[i].iter().copied())
                    .collect()
            })
            .collect(),
        first.ts_s(),
    )?;
    layout.validate(&together)?;
    for input in 0..first.n_inputs() {
        // An input the orders give no coefficient (`nb = 0`) may be constant, as for one run.
        if layout.nb.get(input) == Some(&0) {
            continue;
        }
        let checks: Vec<Result<(), IdentError>> = experiments
            .iter()
            .map(|e| check_input_varies(input, &e.u()[input]))
            .collect();
        if !checks.iter().any(Result::is_ok)
            && let Some(Err(constant)) = checks.into_iter().next()
        {
            return Err(constant);
        }
    }
    Ok(together)
}

/// The prediction-error search of [`oe_merged`], [`armax_merged`] and [`bj_merged`]: from
/// the `initial` estimate (of the experiments end to end, or of one of them) whose loss
/// over all of them is least.
fn minimise_merged(
    experiments: &[IdData],
    layout: &Layout,
    initial: fn(&IdData, &Layout) -> Result<PolyModel, IdentError>,
    options: &PemOptions,
) -> Result<Estimate, IdentError> {
    options.check()?;
    let together = merged_experiments(experiments, layout)?;
    let merged_rss = |start: &PolyModel| -> Option<f64> {
        let problem = MergedPem::new(experiments, layout, start);
        problem.stable().then(|| problem.rss())
    };
    let mut best: Option<(f64, PolyModel)> = None;
    let mut last_error = None;
    // The experiments end to end give an initial estimate where none alone does; the
    // joints' false steps only blur a start the search then leaves.
    for e in std::iter::once(&together).chain(experiments) {
        match initial(e, layout) {
            Ok(start) => {
                if let Some(rss) = merged_rss(&start)
                    && best.as_ref().is_none_or(|(b, _)| rss < *b)
                {
                    best = Some((rss, start));
                }
            }
            Err(err) => last_error = Some(err),
        }
    }
    let Some((_, start)) = best else {
        return Err(last_error.unwrap_or(IdentError::OptimizerFailed(
            "no experiment gave a stable initial estimate".to_owned(),
        )));
    };
    let problem = MergedPem::new(experiments, layout, &start);
    let solver = search(options);
    let (problem, report) = solver.minimize(problem);
    let stop = stop_reason(&report.termination)?;
    if !problem.stable() {
        return Err(IdentError::OptimizerFailed(
            "the search ended at an unstable model".to_owned(),
        ));
    }
    let jac = problem
        .jacobian()
        .ok_or_else(|| IdentError::OptimizerFailed("no Jacobian at the optimum".to_owned()))?;
    let y: Vec<f64> = together.y().to_vec();
    let yhat: Vec<f64> = problem
        .parts
        .iter()
        .flat_map(|p| p.y.iter().zip(&p.eps).map(|(y, e)| y - e))
        .collect();
    let fit = fit_percent(&y, &yhat).unwrap_or(f64::NEG_INFINITY);
    let part = &problem.parts[0];
    let simulation_fit_percent = if part.model.structure == Structure::Oe {
        // The OE predictor is the simulation (none for outputs that do not vary, as `oe`).
        fit_percent(&y, &yhat)
    } else {
        // Each experiment simulated from rest at its own start, as it was estimated.
        let simulated = experiments
            .iter()
            .map(|e| part.model.simulate(e.u()))
            .collect::<Result<Vec<_>, _>>()?;
        fit_percent(&y, &simulated.concat())
    };
    Ok(Estimate::assemble(RawEstimate {
        model: part.model.clone(),
        names: layout.names(),
        theta: part.theta.iter().copied().collect(),
        inverse_gram: inverse_gram_from_jacobian(jac),
        rss: problem.rss(),
        n_samples: y.len(),
        fit_percent: fit,
        simulation_fit_percent,
        method: Method::PredictionErrorLm,
        stop,
        evaluations: report.number_of_evaluations,
    }))
}

/// The prediction-error problem of several experiments sharing one parameter vector
/// ([`oe_merged`], [`armax_merged`], [`bj_merged`]): each experiment's own [`PemProblem`],
/// residuals and Jacobian rows stacked.
struct MergedPem<'a> {
    parts: Vec<PemProblem<'a>>,
}

impl<'a> MergedPem<'a> {
    fn new(experiments: &'a [IdData], layout: &'a Layout, start: &PolyModel) -> Self {
        Self {
            parts: experiments
                .iter()
                .map(|e| PemProblem::new(e, layout, start))
                .collect(),
        }
    }

    fn stable(&self) -> bool {
        self.parts.iter().all(|p| p.stable)
    }

    fn rss(&self) -> f64 {
        self.parts.iter().map(PemProblem::rss).sum()
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for MergedPem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        for p in &mut self.parts {
            p.set_params(x);
        }
    }

    fn params(&self) -> DVector<f64> {
        self.parts[0].params()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        let parts: Option<Vec<DVector<f64>>> = self.parts.iter().map(|p| p.residuals()).collect();
        let parts = parts?;
        Some(DVector::from_iterator(
            parts.iter().map(|r| r.len()).sum(),
            parts.iter().flat_map(|r| r.iter().copied()),
        ))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let parts: Option<Vec<DMatrix<f64>>> = self.parts.iter().map(|p| p.jacobian()).collect();
        let parts = parts?;
        let rows = parts.iter().map(|j| j.nrows()).sum();
        let cols = parts.first().map_or(0, |j| j.ncols());
        let mut jac = DMatrix::<f64>::zeros(rows, cols);
        let mut at = 0;
        for j in &parts {
            jac.view_mut((at, 0), (j.nrows(), cols)).copy_from(j);
            at += j.nrows();
        }
        Some(jac)
    }
}

/// Estimates a Box–Jenkins model `y(t) = Σᵢ Bᵢ/Fᵢ uᵢ(t − nkᵢ) + C(q)/D(q) e(t)` (thesis eq
/// 3.25, ≙ MATLAB `bj`).
///
/// Initial estimate: `Bᵢ, Fᵢ` as for [`oe`]; then the output residual `v = y − Σ Bᵢ/Fᵢ uᵢ`
/// gets an ARMA(`nd`, `nc`) model by Hannan–Rissanen (high-order AR for `ê`, then least
/// squares of `D v = C ê`), reflected stable. Then PEM as described in the
/// [module docs](self).
pub fn bj(data: &IdData, orders: &BjOrders, options: &PemOptions) -> Result<Estimate, IdentError> {
    let layout = Layout::bj(orders);
    layout.validate(data)?;
    options.check()?;
    let initial = initial_bj(data, &layout)?;
    minimise(data, &layout, initial, options)
}

/// Refines any polynomial model by prediction-error minimisation on `data`, starting from
/// `initial` (≙ MATLAB `pem(data, sys)`). Unstable polynomials of `initial` are first
/// reflected into the unit circle.
pub fn pem(
    data: &IdData,
    initial: &PolyModel,
    options: &PemOptions,
) -> Result<Estimate, IdentError> {
    initial.validate()?;
    let layout = Layout::of_model(initial);
    layout.validate(data)?;
    options.check()?;
    let mut start = initial.clone();
    stabilise(&mut start)?;
    minimise(data, &layout, start, options)
}

fn stabilise(m: &mut PolyModel) -> Result<(), IdentError> {
    m.a = reflect_into_unit_circle(&m.a)?;
    m.c = reflect_into_unit_circle(&m.c)?;
    m.d = reflect_into_unit_circle(&m.d)?;
    for f in &mut m.f {
        *f = reflect_into_unit_circle(f)?;
    }
    Ok(())
}

/// Order of the high-order ARX / AR models used for initial estimates: well above the model
/// order (so the approximation error is small) but with at least ten samples per parameter.
fn high_order(base: usize, n_samples: usize, n_signals: usize) -> usize {
    let cap = n_samples / (10 * n_signals.max(1));
    (2 * base + 4)
        .clamp(base.max(1), 20.max(base))
        .min(cap.max(base.max(1)))
}

/// A long ARX model `Â y = Σ B̂ᵢ uᵢ` fitted from row `t0` on.
struct HighOrderArx {
    a: Vec<f64>,
    b: Vec<Vec<f64>>,
    t0: usize,
}

/// High-order ARX `Â y = Σ B̂ᵢ uᵢ`, with `Â` reflected stable; falls back to the given minimum
/// order when the data cannot support the high order.
fn high_order_arx(data: &IdData, nk: &[usize], base: usize) -> Result<HighOrderArx, IdentError> {
    let m = data.n_inputs();
    let preferred = high_order(base, data.len(), m + 1);
    let mut last_err = None;
    for order in [preferred, base.max(1)] {
        let layout = Layout::arx(&ArxOrders {
            na: order,
            nb: vec![order; m],
            nk: nk.to_vec(),
        });
        match arx_least_squares(data.y(), data.u(), &layout) {
            Ok((theta, _, t0)) => {
                let model = layout.model(&theta, data.ts_s());
                return Ok(HighOrderArx {
                    a: reflect_into_unit_circle(&model.a)?,
                    b: model.b,
                    t0,
                });
            }
            Err(e) => last_err = Some(e),
        }
    }
    Err(last_err.unwrap_or(IdentError::InvalidOrder("no initial order".to_owned())))
}

fn initial_armax(data: &IdData, layout: &Layout) -> Result<PolyModel, IdentError> {
    let ts = data.ts_s();
    let (theta, _, _) = arx_least_squares(data.y(), data.u(), layout)?;
    let mut model = layout.model(&theta, ts);
    if layout.nc > 0 {
        // Hannan–Rissanen: innovations from a long ARX, then one linear regression with them.
        let base = layout.max_lag() + layout.nc;
        if let Ok(refined) = high_order_arx(data, &layout.nk, base).and_then(
            |HighOrderArx {
                 a: a_h,
                 b: b_h,
                 t0: t0h,
             }| {
                let n = data.len();
                let mut e_hat = vec![0.0; n];
                let mut part = vec![0.0; n];
                filter_delayed(&a_h, 0, &[1.0], data.y(), &mut e_hat);
                for (i, ui) in data.u().iter().enumerate() {
                    filter_delayed(&b_h[i], layout.nk[i], &[1.0], ui, &mut part);
                    e_hat.iter_mut().zip(&part).for_each(|(e, p)| *e -= p);
                }
                e_hat[..t0h.min(n)].fill(0.0);
                let y = data.y();
                let mut columns: Vec<LagColumn<'_>> = (1..=layout.na)
                    .map(|lag| LagColumn {
                        signal: y,
                        lag,
                        negate: true,
                    })
                    .collect();
                for (i, ui) in data.u().iter().enumerate() {
                    columns.extend((0..layout.nb[i]).map(|l| LagColumn {
                        signal: ui,
                        lag: layout.nk[i] + l,
                        negate: false,
                    }));
                }
                columns.extend((1..=layout.nc).map(|lag| LagColumn {
                    signal: &e_hat,
                    lag,
                    negate: false,
                }));
                let t0 = layout.max_lag().max(t0h + layout.nc);
                let names = layout.names();
                let fit = lagged_least_squares(&columns, y, t0, &|j| names[j].clone())?;
                Ok(layout.model(fit.theta.as_slice(), ts))
            },
        ) {
            model = refined;
        }
    }
    stabilise(&mut model)?;
    Ok(model)
}

/// A model with `Bᵢ, Fᵢ` from "high-order ARX, then reduce" (see [`oe`]) and the other
/// polynomials at 1.
fn initial_transfer_functions(data: &IdData, layout: &Layout) -> Result<PolyModel, IdentError> {
    let base = layout
        .nb
        .iter()
        .zip(&layout.nf)
        .map(|(b, f)| b + f)
        .max()
        .unwrap_or(1);
    let HighOrderArx { a: a_h, b: b_h, .. } = high_order_arx(data, &layout.nk, base)?;
    let n = data.len();
    let mut b = Vec::with_capacity(layout.n_inputs());
    let mut f = Vec::with_capacity(layout.n_inputs());
    for (i, ui) in data.u().iter().enumerate() {
        let (nb, nf, nk) = (layout.nb[i], layout.nf[i], layout.nk[i]);
        let mut w = vec![0.0; n];
        filter_delayed(&b_h[i], nk, &a_h, ui, &mut w);
        let mut columns: Vec<LagColumn<'_>> = (1..=nf)
            .map(|lag| LagColumn {
                signal: &w,
                lag,
                negate: true,
            })
            .collect();
        columns.extend((0..nb).map(|l| LagColumn {
            signal: ui,
            lag: nk + l,
            negate: false,
        }));
        let t0 = nf.max(nk + nb - 1);
        let reduced = lagged_least_squares(&columns, &w, t0, &|j| {
            if j < nf {
                format!("f{}(u{})", j + 1, i + 1)
            } else {
                format!("b{}(u{})", j - nf + 1, i + 1)
            }
        });
        match reduced {
            Ok(fit) => {
                let mut fi = vec![1.0];
                fi.extend(fit.theta.iter().take(nf));
                b.push(fit.theta.iter().skip(nf).copied().collect());
                f.push(reflect_into_unit_circle(&fi)?);
            }
            // The high-order model saw no dynamics from this input (e.g. w ≡ 0): start from
            // a static gain of zero and let the search find the rest.
            Err(IdentError::RankDeficient { .. }) => {
                b.push(vec![0.0; nb]);
                let mut fi = vec![0.0; nf + 1];
                fi[0] = 1.0;
                f.push(fi);
            }
            Err(e) => return Err(e),
        }
    }
    let mut model = layout.model(&vec![0.0; layout.n_params()], data.ts_s());
    model.b = b;
    model.f = f;
    Ok(model)
}

fn initial_oe(data: &IdData, layout: &Layout) -> Result<PolyModel, IdentError> {
    initial_transfer_functions(data, layout)
}

fn initial_bj(data: &IdData, layout: &Layout) -> Result<PolyModel, IdentError> {
    let mut model = initial_oe(data, layout)?;
    if layout.nc + layout.nd == 0 {
        return Ok(model);
    }
    let sim = model.simulate(data.u())?;
    let v: Vec<f64> = data.y().iter().zip(&sim).map(|(y, s)| y - s).collect();
    if let Ok((c, d)) = initial_arma(&v, layout.nc, layout.nd) {
        model.c = c;
        model.d = d;
    }
    Ok(model)
}

/// ARMA `D v = C e` by Hannan–Rissanen, both polynomials reflected stable.
fn initial_arma(v: &[f64], nc: usize, nd: usize) -> Result<(Vec<f64>, Vec<f64>), IdentError> {
    let n = v.len();
    let order = high_order(nc + nd, n, 1);
    let ar_columns: Vec<LagColumn<'_>> = (1..=order)
        .map(|lag| LagColumn {
            signal: v,
            lag,
            negate: true,
        })
        .collect();
    let ar = lagged_least_squares(&ar_columns, v, order, &|j| format!("ar{}", j + 1))?;
    let mut a_h = vec![1.0];
    a_h.extend(ar.theta.iter());
    let mut e_hat = vec![0.0; n];
    filter_delayed(&a_h, 0, &[1.0], v, &mut e_hat);
    e_hat[..order.min(n)].fill(0.0);
    let mut columns: Vec<LagColumn<'_>> = (1..=nd)
        .map(|lag| LagColumn {
            signal: v,
            lag,
            negate: true,
        })
        .collect();
    columns.extend((1..=nc).map(|lag| LagColumn {
        signal: &e_hat,
        lag,
        negate: false,
    }));
    let fit = lagged_least_squares(&columns, v, nd.max(order + nc), &|j| {
        if j < nd {
            format!("d{}", j + 1)
        } else {
            format!("c{}", j - nd + 1)
        }
    })?;
    let mut d = vec![1.0];
    d.extend(fit.theta.iter().take(nd));
    let mut c = vec![1.0];
    c.extend(fit.theta.iter().skip(nd));
    Ok((reflect_into_unit_circle(&c)?, reflect_into_unit_circle(&d)?))
}

/// The prediction-error problem in the form the `levenberg-marquardt` crate wants:
/// residuals `ε(t, θ)` and their Jacobian `∂ε/∂θ`.
struct PemProblem<'a> {
    y: &'a [f64],
    u: &'a [Vec<f64>],
    layout: &'a Layout,
    ts_s: f64,
    theta: DVector<f64>,
    model: PolyModel,
    stable: bool,
    /// `wᵢ = Bᵢ/Fᵢ uᵢ`
    w: Vec<Vec<f64>>,
    /// `v = A y − Σ wᵢ`
    v: Vec<f64>,
    /// `ε = D/C v`
    eps: Vec<f64>,
}

impl<'a> PemProblem<'a> {
    fn new(data: &'a IdData, layout: &'a Layout, start: &PolyModel) -> Self {
        let n = data.len();
        let theta = DVector::from_vec(layout.theta(start));
        let mut problem = Self {
            y: data.y(),
            u: data.u(),
            layout,
            ts_s: data.ts_s(),
            model: start.clone(),
            theta: theta.clone(),
            stable: false,
            w: vec![vec![0.0; n]; layout.n_inputs()],
            v: vec![0.0; n],
            eps: vec![0.0; n],
        };
        problem.set_params(&theta);
        problem
    }

    fn evaluate(&mut self) {
        let m = &self.model;
        self.stable = is_stable(&m.a)
            && is_stable(&m.c)
            && is_stable(&m.d)
            && m.f.iter().all(|f| is_stable(f));
        if !self.stable {
            return;
        }
        filter_delayed(&m.a, 0, &[1.0], self.y, &mut self.v);
        for (i, ui) in self.u.iter().enumerate() {
            filter_delayed(&m.b[i], m.nk[i], &m.f[i], ui, &mut self.w[i]);
            self.v.iter_mut().zip(&self.w[i]).for_each(|(v, w)| *v -= w);
        }
        if m.c.len() == 1 && m.d.len() == 1 {
            self.eps.copy_from_slice(&self.v);
        } else {
            filter_delayed(&m.d, 0, &m.c, &self.v, &mut self.eps);
        }
    }

    fn rss(&self) -> f64 {
        self.eps.iter().map(|e| e * e).sum()
    }
}

/// Writes `sign · base(t − shift)` (zero before the start) into `column`.
fn shifted_into(column: &mut [f64], base: &[f64], shift: usize, negate: bool) {
    let n = column.len();
    let shift = shift.min(n);
    column[..shift].fill(0.0);
    let src = &base[..n - shift];
    if negate {
        column[shift..]
            .iter_mut()
            .zip(src)
            .for_each(|(c, b)| *c = -b);
    } else {
        column[shift..].copy_from_slice(src);
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for PemProblem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.theta.copy_from(x);
        self.model = self.layout.model(x.as_slice(), self.ts_s);
        self.evaluate();
    }

    fn params(&self) -> DVector<f64> {
        self.theta.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        if self.stable {
            Some(DVector::from_column_slice(&self.eps))
        } else {
            Some(DVector::from_element(self.eps.len(), UNSTABLE_RESIDUAL))
        }
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        if !self.stable {
            return None;
        }
        let n = self.y.len();
        let l = self.layout;
        let m = &self.model;
        let mut jac = DMatrix::<f64>::zeros(n, l.n_params());
        let mut base = vec![0.0; n];
        let mut col = 0;
        let data = jac.as_mut_slice();
        let one = [1.0];
        // a: (D/C) y
        if l.na > 0 {
            filter_delayed(&m.d, 0, &m.c, self.y, &mut base);
            for k in 1..=l.na {
                shifted_into(&mut data[col * n..(col + 1) * n], &base, k, false);
                col += 1;
            }
        }
        // b: −(D/(C Fᵢ)) uᵢ
        let mut den_cf = Vec::new();
        for (i, ui) in self.u.iter().enumerate() {
            if l.nb[i] == 0 {
                continue;
            }
            den_cf.clear();
            den_cf.extend(poly_mul(&m.c, &m.f[i]));
            filter_delayed(&m.d, 0, &den_cf, ui, &mut base);
            for lag in 0..l.nb[i] {
                shifted_into(
                    &mut data[col * n..(col + 1) * n],
                    &base,
                    l.nk[i] + lag,
                    true,
                );
                col += 1;
            }
        }
        // c: −(1/C) ε
        if l.nc > 0 {
            filter_delayed(&one, 0, &m.c, &self.eps, &mut base);
            for k in 1..=l.nc {
                shifted_into(&mut data[col * n..(col + 1) * n], &base, k, true);
                col += 1;
            }
        }
        // d: (1/C) v
        if l.nd > 0 {
            filter_delayed(&one, 0, &m.c, &self.v, &mut base);
            for k in 1..=l.nd {
                shifted_into(&mut data[col * n..(col + 1) * n], &base, k, false);
                col += 1;
            }
        }
        // f: (D/(C Fᵢ)) wᵢ
        for i in 0..self.u.len() {
            if l.nf[i] == 0 {
                continue;
            }
            let den = poly_mul(&m.c, &m.f[i]);
            filter_delayed(&m.d, 0, &den, &self.w[i], &mut base);
            for k in 1..=l.nf[i] {
                shifted_into(&mut data[col * n..(col + 1) * n], &base, k, false);
                col += 1;
            }
        }
        debug_assert_eq!(col, l.n_params());
        Some(jac)
    }
}

fn minimise(
    data: &IdData,
    layout: &Layout,
    start: PolyModel,
    options: &PemOptions,
) -> Result<Estimate, IdentError> {
    let problem = PemProblem::new(data, layout, &start);
    if !problem.stable {
        return Err(IdentError::OptimizerFailed(
            "the initial estimate is not stable after reflection".to_owned(),
        ));
    }
    let solver = search(options);
    let (problem, report) = solver.minimize(problem);
    let stop = stop_reason(&report.termination)?;
    if !problem.stable {
        // Unreachable by construction (unstable trials are never accepted); kept as a guard
        // so an unstable model can never be returned.
        return Err(IdentError::OptimizerFailed(
            "the search ended at an unstable model".to_owned(),
        ));
    }
    let jac = problem
        .jacobian()
        .ok_or_else(|| IdentError::OptimizerFailed("no Jacobian at the optimum".to_owned()))?;
    let inverse_gram = inverse_gram_from_jacobian(jac);
    let rss = problem.rss();
    let n = data.len();
    let yhat: Vec<f64> = data
        .y()
        .iter()
        .zip(&problem.eps)
        .map(|(y, e)| y - e)
        .collect();
    let model = problem.model.clone();
    let simulation = model.simulate(data.u())?;
    let structure = model.structure;
    Ok(Estimate::assemble(RawEstimate {
        model,
        names: layout.names(),
        theta: problem.theta.iter().copied().collect(),
        inverse_gram,
        rss,
        n_samples: n,
        fit_percent: fit_percent(data.y(), &yhat).unwrap_or(f64::NEG_INFINITY),
        simulation_fit_percent: if structure == Structure::Oe {
            fit_percent(data.y(), &yhat)
        } else {
            fit_percent(data.y(), &simulation)
        },
        method: Method::PredictionErrorLm,
        stop,
        evaluations: report.number_of_evaluations,
    }))
}

/// The Levenberg–Marquardt search `options` ask for.
fn search(options: &PemOptions) -> LevenbergMarquardt<f64> {
    LevenbergMarquardt::new()
        .with_ftol(options.tolerance)
        .with_xtol(options.tolerance)
        .with_gtol(options.tolerance)
        .with_patience(options.max_evaluations_per_parameter)
}

/// What the search's termination says, or the error it is.
fn stop_reason(termination: &TerminationReason) -> Result<StopReason, IdentError> {
    Ok(match termination {
        TerminationReason::Converged { .. } | TerminationReason::Orthogonal => {
            StopReason::Converged
        }
        TerminationReason::ResidualsZero => StopReason::ZeroResiduals,
        TerminationReason::NoImprovementPossible(_) => StopReason::NoFurtherImprovement,
        TerminationReason::LostPatience => StopReason::IterationLimit,
        other => return Err(IdentError::OptimizerFailed(format!("{other:?}"))),
    })
}

/// `(JᵀJ)⁻¹ = R⁻¹R⁻ᵀ` from the QR factor of the Jacobian; if `R` is singular (a parameter
/// without influence on the predictor) the pseudo-inverse is used, giving that parameter no
/// finite precision only through the near-zero singular values.
fn inverse_gram_from_jacobian(jac: DMatrix<f64>) -> DMatrix<f64> {
    let d = jac.ncols();
    let r = QR::new(jac).r();
    match r.solve_upper_triangular(&DMatrix::identity(d, d)) {
        Some(r_inv) if r_inv.iter().all(|v| v.is_finite()) => &r_inv * r_inv.transpose(),
        _ => {
            let gram = r.transpose() * &r;
            gram.pseudo_inverse(1e-300)
                .unwrap_or_else(|_| DMatrix::from_element(d, d, f64::INFINITY))
        }
    }
}
