//! Linearisation of a model about a static equilibrium, numerically.
//!
//! About the equilibrium `(x0, u0)` with `f(x0, u0) = 0`:
//! ```text
//! δẋ = A δx + B δz_r + B_r ż_r,      δy = C δx + D δz_r + D_r ż_r,
//! A = ∂f/∂x,  B = ∂f/∂z_r,  B_r = ∂f/∂ż_r,  C = ∂g/∂x, ...       (central differences)
//! ```
//! with `y` the sensor height and the tire force; the road's rate `ż_r` acts through the
//! tire's damper (`B_r = D_r = 0` without one). Discretised exactly for a road linear between
//! samples (first-order hold, as the simulator follows it).
//!
//! Model 2's damper is a piecewise-affine table with different slopes in compression and
//! rebound: it has no derivative at zero velocity, and the central difference takes the mean
//! of the two slopes. Even a tiny input then gives an asymmetric response the linear model
//! cannot follow; compare with a symmetric damper table to see the smooth nonlinearities alone.

use airsus_model::submodels::Tire;
use airsus_model::{InputSample, SuspensionModel};
use nalgebra::{DMatrix, DVector};

use crate::error::{AppError, invalid};
use crate::road::AxleGeometry;

/// `(A, B, B_r, C, D, D_r)` about `x0`, outputs `[sensor height, tire force]`.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearModel {
    pub x0: Vec<f64>,
    pub y0: [f64; 2],
    pub a: DMatrix<f64>,
    /// Per metre of road height.
    pub b: DVector<f64>,
    /// Per m/s of road rate (the tire's damper).
    pub b_rate: DVector<f64>,
    pub c: DMatrix<f64>,
    pub d: DVector<f64>,
    pub d_rate: DVector<f64>,
}

fn outputs(
    model: &dyn SuspensionModel,
    axle: &AxleGeometry,
    tire: &Tire,
    x: &[f64],
    u: &InputSample,
) -> [f64; 2] {
    let o = model.output(x, u);
    [
        o.sensor_height_m,
        axle.tire_force_n(tire, x, u.road_height_m, u.road_rate_m_s),
    ]
}

/// Central-difference linearisation of `model` about `x0` under `u0` (module docs).
pub fn linearize(
    model: &dyn SuspensionModel,
    axle: &AxleGeometry,
    tire: &Tire,
    x0: &[f64],
    u0: &InputSample,
) -> Result<LinearModel, AppError> {
    let n = model.n_states();
    if x0.len() != n {
        return Err(invalid(
            "linearisation point",
            format!("{} values for {n} states", x0.len()),
        ));
    }
    let mut a = DMatrix::zeros(n, n);
    let mut c = DMatrix::zeros(2, n);
    let (mut fp, mut fm) = (vec![0.0; n], vec![0.0; n]);
    for j in 0..n {
        let d = 1e-6 * x0[j].abs().max(1e-3);
        let (mut xp, mut xm) = (x0.to_vec(), x0.to_vec());
        xp[j] += d;
        xm[j] -= d;
        model.rhs(0.0, &xp, u0, &mut fp);
        model.rhs(0.0, &xm, u0, &mut fm);
        let (yp, ym) = (
            outputs(model, axle, tire, &xp, u0),
            outputs(model, axle, tire, &xm, u0),
        );
        for i in 0..n {
            a[(i, j)] = (fp[i] - fm[i]) / (2.0 * d);
        }
        for i in 0..2 {
            c[(i, j)] = (yp[i] - ym[i]) / (2.0 * d);
        }
    }
    // One input (`shift` moves it by a step): its columns of the state and output equations
    // by central differences.
    let mut input_columns = |shift: fn(&mut InputSample, f64), step: f64| {
        let (mut up, mut um) = (*u0, *u0);
        shift(&mut up, step);
        shift(&mut um, -step);
        model.rhs(0.0, x0, &up, &mut fp);
        model.rhs(0.0, x0, &um, &mut fm);
        let b = DVector::from_iterator(n, (0..n).map(|i| (fp[i] - fm[i]) / (2.0 * step)));
        let (yp, ym) = (
            outputs(model, axle, tire, x0, &up),
            outputs(model, axle, tire, x0, &um),
        );
        let d = DVector::from_vec(vec![
            (yp[0] - ym[0]) / (2.0 * step),
            (yp[1] - ym[1]) / (2.0 * step),
        ]);
        (b, d)
    };
    let (b, d) = input_columns(|u, dz| u.road_height_m += dz, 1e-6);
    let (b_rate, d_rate) = input_columns(|u, dv| u.road_rate_m_s += dv, 1e-6);
    if a.iter()
        .chain(b.iter())
        .chain(b_rate.iter())
        .any(|v| !v.is_finite())
    {
        return Err(invalid("linearisation", "the Jacobian is not finite"));
    }
    Ok(LinearModel {
        x0: x0.to_vec(),
        y0: outputs(model, axle, tire, x0, u0),
        a,
        b,
        b_rate,
        c,
        d,
        d_rate,
    })
}

/// Outputs `[sensor height, tire force]` of the linear model over a road linear between the
/// uniformly spaced samples `time_s` (exact first-order-hold discretisation, as the simulator
/// follows a road, `airsus_sim::RoadInput::Linear`), absolute (`y0 + δy`).
///
/// With `u(τ) = u_k + δ τ` over the normalised interval `τ ∈ [0, 1]`, δ = `u_{k+1} − u_k`
/// and so `ż_r = δ/Δt`, the augmented system `[x; u; δ]` has the matrix
/// `[[A Δt, B Δt, B_r], [0, 0, 1], [0, 0, 0]]`; its exponential gives
/// `x_{k+1} = Φ x_k + Γ1 u_k + Γ2 δ`. The outputs at sample `k` take the rate of the segment
/// ahead, as the simulator's road does.
pub fn simulate_linear(
    lin: &LinearModel,
    time_s: &[f64],
    road_m: &[f64],
) -> Result<Vec<[f64; 2]>, AppError> {
    let n = lin.a.nrows();
    if time_s.len() != road_m.len() || time_s.len() < 2 {
        return Err(invalid(
            "linear simulation",
            "time and road differ in length",
        ));
    }
    let dt = time_s[1] - time_s[0];
    let mut m = DMatrix::zeros(n + 2, n + 2);
    m.view_mut((0, 0), (n, n)).copy_from(&(&lin.a * dt));
    m.view_mut((0, n), (n, 1)).copy_from(&(&lin.b * dt));
    m.view_mut((0, n + 1), (n, 1)).copy_from(&lin.b_rate);
    m[(n, n + 1)] = 1.0;
    let e = m.exp();
    let phi = e.view((0, 0), (n, n)).into_owned();
    let gamma_level = e.view((0, n), (n, 1)).into_owned();
    let gamma_slope = e.view((0, n + 1), (n, 1)).into_owned();
    let mut dx = DVector::zeros(n);
    let mut out = Vec::with_capacity(time_s.len());
    for (k, &z) in road_m.iter().enumerate() {
        let slope = road_m.get(k + 1).map_or(0.0, |next| next - z);
        let dy = &lin.c * &dx + &lin.d * z + &lin.d_rate * (slope / dt);
        out.push([lin.y0[0] + dy[0], lin.y0[1] + dy[1]]);
        dx = &phi * dx + &gamma_level * z + &gamma_slope * slope;
    }
    Ok(out)
}
