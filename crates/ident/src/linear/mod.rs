//! Linear black-box identification: ARX, ARMAX, OE and BJ models in discrete time
//! (thesis §3.2.2–3.3, eq 3.20–3.30; Ljung, *System Identification — Theory for the User*,
//! 2nd ed. 1999, ch. 4, 7, 10).
//!
//! The family is `A(q) y(t) = Σᵢ Bᵢ(q)/Fᵢ(q) uᵢ(t − nkᵢ) + C(q)/D(q) e(t)` for any number of
//! inputs and one output, with `q⁻¹` the backward shift. It is modelled after
//! ControlSystemIdentification.jl and MATLAB's toolbox:
//!
//! * one data type, [`IdData`] (`y`, `u`, `Ts`), validated once;
//! * estimators are plain functions, data first then orders: [`arx`], [`armax`], [`oe`],
//!   [`bj`], and [`pem()`] to refine any model; they return an [`Estimate`] carrying the
//!   [`PolyModel`], parameter standard deviations, loss, FPE, AIC/BIC and fit;
//! * verbs on the model: [`PolyModel::simulate`], [`PolyModel::predict`] (k-step),
//!   [`PolyModel::residuals`], [`PolyModel::to_state_space`],
//!   [`PolyModel::to_continuous_state_space`]; [`StateSpace::c2d`] / [`StateSpace::d2c`];
//! * order selection: [`arx_struc`] + [`select_structure`].
//!
//! ARX is solved by QR least squares ([`arx`]); the others by prediction-error minimisation
//! with analytic, filter-based gradients and enforced stability ([`pem`](mod@pem) module docs; state space and ZOH in [`ss`]).
//!
//! ```
//! use airsus_ident::linear::{arx, ArxOrders, IdData};
//! let u: Vec<f64> = (0..200).map(|k| ((k * 7919) % 13) as f64 - 6.0).collect();
//! let mut y = vec![0.0; 200];
//! for t in 1..200 {
//!     y[t] = 0.8 * y[t - 1] + 0.5 * u[t - 1];
//! }
//! let data = IdData::siso(y, u, 0.1)?;
//! let est = arx(&data, &ArxOrders::siso(1, 1, 1))?;
//! assert!((est.model.a[1] + 0.8).abs() < 1e-9 && (est.model.b[0][0] - 0.5).abs() < 1e-9);
//! # Ok::<(), airsus_ident::linear::IdentError>(())
//! ```

mod arx;
mod data;
mod error;
mod estimate;
mod lstsq;
mod model;
mod orders;
pub mod pem;
mod poly;
pub mod request;
mod selstruc;
pub mod ss;

pub use arx::{arx, arx_merged};
pub use data::{IdData, Offsets};
pub use error::IdentError;
pub use estimate::{Estimate, Method, Parameter, StopReason, aic, bic, fit_percent, fpe, naic};
pub use model::{PolyModel, Structure};
pub use orders::{ArmaxOrders, ArxOrders, BjOrders, OeOrders};
pub use pem::{PemOptions, armax, armax_merged, bj, bj_merged, oe, oe_merged, pem};
pub use poly::{
    MAX_ROOT_RADIUS, is_stable, poly_from_roots, poly_mul, reflect_into_unit_circle, roots,
};
pub use request::{IdentReport, Identified, LabelledData, Request, RequestError, RequestedOrders};
pub use selstruc::{ArxGrid, OrderCandidate, SelectionCriterion, arx_struc, select_structure};
pub use ss::{ContinuousSubsystem, StateSpace, TimeDomain};
