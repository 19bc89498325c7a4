//! Online axle-load estimation: an extended Kalman filter on a suspension model whose state is
//! augmented by the wheel load.
//!
//! # Model
//! Augmented state `z = [x; m_tot]`, with `x` the model's own state (Model 2: chassis height,
//! lever angle, their rates, the amount of air `n`) and the wheel load a random walk:
//! ```text
//! ẋ = f(x, u(m_tot)),   ṁ_tot = w_m,   E[w_m²] = q_m   (kg²/s)
//! y = [h_sensor, p_gauge] = g(x, m_tot) + v,   R = diag(σ_h², σ_p²)
//! ```
//! where `u(m_tot)` is the measured input sample (valve, supply, road) with the wheel load
//! taken from the state. Nothing else is reduced: the filter runs the full model, so the load
//! shows both in the static balance (`p A_eff = (m_tot - m2) g / k_l`) and in the dynamics
//! (a load step accelerates the chassis).
//!
//! # Why an EKF (and not a UKF)
//! Over one 100 ms sample the model is close to linear at standstill and during valve action
//! (gas law and lever geometry are smooth; the piecewise-affine damper and the tire's contact
//! loss are the only non-smooth parts, and neither matters while weighing). The EKF needs
//! `n + 2` propagations per sample (one plus one per state for the Jacobian), a UKF `2n + 3`
//! for the same accuracy here; and the EKF's Jacobian of the *discrete* map (finite
//! differences through the integrator) is exact for what the filter propagates.
//!
//! # Discretisation
//! `x_{k+1} = Φ(x_k, u_k)`: classical Runge–Kutta with `substeps` equal steps over the sample
//! (default 20 × 5 ms; Model 2's fastest pole — the axle on the tire and damper, about
//! 80 1/s — needs `h < 2.8/80 s` for RK4 stability). `F = ∂Φ/∂z` by forward differences.
//!
//! # Process noise (diagonal, per sample of length `T`)
//! - load: `q_m T`;
//! - air amount: `(ε_n n)² T + (ε_f ṅ)² T`: a slow drift (the gas temperature the isothermal
//!   model lacks, leaks) plus a relative error `ε_f` of the valve flow while it is open;
//! - the rates (`xdot`, `alphadot` and the like): `σ_v² T`, unmodelled forces (wall friction,
//!   creep); the hysteresis states none (below); every other extra state a small relative
//!   drift.
//!
//! The defaults were tuned on the reference experiments (module tests give the numbers).
//!
//! # Wall friction (a model with a hysteresis: `truck`)
//! The bellow wall's friction holds part of the load (up after the truck was lowered, down
//! after it was raised), so the same load reads at another pressure after a fill than after an
//! exhaust. The model carries it as a Dahl element driven by the bellow's motion; the filter
//! must not drive it by its own estimate's motion, which jitters by a fraction of a millimetre
//! with the sensors' noise: a dithered Dahl element relaxes to zero within tens of seconds,
//! and the standstills then read off by the friction (0.5-0.9 % on the virtual-truck variants,
//! by the sign of the last movement). So the friction is
//! - held through each prediction and moved after each correction only by what the estimated
//!   bellow height moved beyond a play ([`EkfTuning::hysteresis_play_m`]), by its law in closed
//!   form ([`SuspensionModel::follow_hysteresis`]);
//! - considered, not estimated (Schmidt-Kalman: its rows of the gain are zero): at rest the
//!   friction and the load trade off exactly, so no reading can tell them apart, and
//!   corrections pushed it beyond its range while the load stepped. Its uncertainty still
//!   widens the load's through the covariance;
//! - started as said ([`HysteresisStart`]): an unknown start is uniform over the friction's
//!   range, so the load's interval holds it until the first movement slides the friction to one
//!   side (the movement's map shrinks its standard deviation by `e^(−σ|Δ|/F_c)`).

use airsus_model::{InitialCondition, InputSample, StateRole, SuspensionModel};
use nalgebra::{DMatrix, DVector};

use crate::error::{AppError, invalid};
use crate::weigh::WeighSeries;
use crate::weigh::static_law::{StaticLaw, StaticWeigher};

/// Noise intensities and discretisation of the load filter.
#[derive(Debug, Clone, PartialEq)]
pub struct EkfTuning {
    /// `√q_m`: random-walk intensity of the wheel load, kg/√s.
    pub load_random_walk_kg_per_sqrt_s: f64,
    /// Standard deviation of the initial load (from the static balance), kg.
    pub initial_load_std_kg: f64,
    /// `ε_n`: relative drift of the air amount, 1/√s.
    pub amount_drift_rel_per_sqrt_s: f64,
    /// `ε_f`: relative error of the valve flow while the valve is open.
    pub flow_relative_error: f64,
    /// `σ_v`: random walk of every rate state (m/s or rad/s per √s).
    pub rate_random_walk_per_sqrt_s: f64,
    /// Standard deviation of one height reading, m (noise and quantisation).
    pub height_std_m: f64,
    /// Standard deviation of one pressure reading, Pa.
    pub pressure_std_pa: f64,
    /// Runge–Kutta steps per sample.
    pub substeps: usize,
    /// Innovation gate: a reading whose Mahalanobis distance from the prediction exceeds it
    /// corrects the state only as far as the gate (bounded innovations), so a glitch (a
    /// pressure spike, a height dropout) cannot throw the estimate. Infinity turns it off.
    pub innovation_gate_sigma: f64,
    /// The longest run of readings beyond the gate that is bounded as a glitch; readings that
    /// stay beyond it longer are a real change (a load set down) and are taken whole.
    pub glitch_samples: usize,
    /// Width of the play the estimate's motion passes before it moves the model's hysteresis
    /// (the wall friction), in the hysteresis coordinate's unit (m of bellow height): about
    /// twice the sample-to-sample jitter of the estimate, far below the millimetres a load or
    /// a valve moves the bellow.
    pub hysteresis_play_m: f64,
    /// How the truck came to its first reading, which sets the hysteresis the run starts with.
    pub start_hysteresis: HysteresisStart,
}

/// How the truck came to a run's first reading: what its wall friction holds at the start.
/// At rest the friction and the load trade off exactly (a load `F_c` heavier on a wall whose
/// friction holds `F_c` up reads the same), so an unknown start is as uncertain as the
/// friction's range until the bellow first moves far enough to slide it to one side.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum HysteresisStart {
    /// Not known: the friction's mean is zero, its spread uniform over its range.
    #[default]
    Unknown,
    /// Lowered onto its height (a load set down, an exhaust): the friction holds it up.
    Lowered,
    /// Raised onto its height (a fill, a load taken off): the friction holds it down.
    Raised,
}

impl HysteresisStart {
    /// The preload of [`SuspensionModel::initial_state_with_hysteresis`].
    pub fn preload(self) -> f64 {
        match self {
            Self::Unknown => 0.0,
            Self::Lowered => -1.0,
            Self::Raised => 1.0,
        }
    }
}

/// The spread of a known start's hysteresis, as a fraction of its half range: the last
/// movement may not have slid the friction all the way.
pub(crate) const KNOWN_START_SPREAD: f64 = 0.1;

/// The default play of the hysteresis coordinate, m ([`EkfTuning::hysteresis_play_m`]; the
/// static law's wall, [`super::WallForces::friction_play_m`], the same).
pub(crate) const HYSTERESIS_PLAY_M: f64 = 0.3e-3;

/// A travel of the hysteresis coordinate that slides it to its limit whichever way (a Dahl
/// wall friction saturates within `F_c / σ`, millimetres).
const SATURATING_TRAVEL_M: f64 = 1.0;

impl Default for EkfTuning {
    fn default() -> Self {
        Self {
            load_random_walk_kg_per_sqrt_s: 2.0,
            initial_load_std_kg: 300.0,
            amount_drift_rel_per_sqrt_s: 2e-3,
            flow_relative_error: 0.3,
            rate_random_walk_per_sqrt_s: 1e-3,
            // 0.15 mm noise, 0.1 mm resolution; 0.2 kPa noise, 0.1 kPa resolution.
            height_std_m: (0.15e-3f64.powi(2) + 0.1e-3f64.powi(2) / 12.0).sqrt(),
            pressure_std_pa: (200.0f64.powi(2) + 100.0f64.powi(2) / 12.0).sqrt(),
            substeps: 20,
            innovation_gate_sigma: 6.0,
            glitch_samples: 2,
            hysteresis_play_m: HYSTERESIS_PLAY_M,
            start_hysteresis: HysteresisStart::Unknown,
        }
    }
}

/// The model's own balance at the first reading: the load at which the model's equilibrium at
/// the measured height has the measured pressure (secant iteration from the static law's
/// load), and that equilibrium. Starting from the static law's load alone, a model whose
/// balance differs from the law's (another structure, the lever's own weight, a tire
/// deflection) starts millimetres from its reading, and the first corrections throw the load
/// by hundreds of kilograms. `None` when the model has no equilibrium near there.
fn consistent_start(
    model: &dyn SuspensionModel,
    first_input: &InputSample,
    preload: f64,
    static_load_kg: f64,
    sensor_height_m: f64,
    gauge_pa: f64,
) -> Option<(f64, Vec<f64>)> {
    let balance = |load_kg: f64| -> Option<(Vec<f64>, f64)> {
        let u = InputSample {
            wheel_load_kg: load_kg,
            ..*first_input
        };
        let x = model
            .initial_state_with_hysteresis(
                &u,
                &InitialCondition::SensorHeight {
                    height_m: sensor_height_m,
                },
                preload,
            )
            .ok()?;
        let gap = model.output(&x, &u).bellow_gauge_pa - gauge_pa;
        gap.is_finite().then_some((x, gap))
    };
    let (mut m0, mut m1) = (static_load_kg, static_load_kg * 1.01);
    let (_, mut g0) = balance(m0)?;
    let (mut x1, mut g1) = balance(m1)?;
    // 12 secant updates, each tested (the 13th pass only tests the last one).
    for _ in 0..13 {
        // 1 Pa is far below the sensor's noise (0.2 kPa).
        if g1.abs() < 1.0 {
            return (m1 > 0.0).then_some((m1, x1));
        }
        if g1 == g0 {
            return None;
        }
        let m2 = m1 - g1 * (m1 - m0) / (g1 - g0);
        if !(m2.is_finite() && m2 > 0.0) {
            return None;
        }
        (m0, g0) = (m1, g1);
        m1 = m2;
        (x1, g1) = balance(m1)?;
    }
    None
}

/// The load filter: a model, the augmented state estimate and its covariance.
#[derive(Debug)]
pub struct LoadEkf {
    model: Box<dyn SuspensionModel>,
    tuning: EkfTuning,
    /// Index of the air-amount state (`n_mol`), if the model has one.
    amount_index: Option<usize>,
    /// Indices of rate states (names with `dot`, or `v1`/`v2`).
    rate_indices: Vec<usize>,
    z: DVector<f64>,
    p: DMatrix<f64>,
    time_s: f64,
    /// Readings beyond the innovation gate in a row, up to this one.
    beyond_gate: usize,
    /// The play's output on the model's hysteresis coordinate (see `play_hysteresis`).
    played_m: Option<f64>,
    /// Indices of the model's hysteresis states.
    hysteresis: Vec<usize>,
    /// The hysteresis states' standard deviations at the start (an unknown start's range).
    hysteresis_start_std: Vec<f64>,
    /// When every hysteresis state's standard deviation first fell below half its start:
    /// the bellow's movement slid the friction to one side.
    hysteresis_resolved_at_s: Option<f64>,
}

impl LoadEkf {
    /// Starts the filter from the first reading: at the load where the model's own static
    /// equilibrium at the measured height has the measured pressure, and in that equilibrium
    /// (the static balance `law`'s load is the first guess). Where the model has no such
    /// equilibrium nearby, from the law's load and the model's equilibrium at the measured
    /// pressure.
    pub fn new(
        model: Box<dyn SuspensionModel>,
        law: &StaticLaw,
        tuning: EkfTuning,
        time_s: f64,
        first_input: &InputSample,
        sensor_height_m: f64,
        gauge_pa: f64,
    ) -> Result<Self, AppError> {
        if tuning.substeps == 0 {
            return Err(invalid("filter tuning", "substeps must be at least 1"));
        }
        for (name, v) in [
            ("load random walk", tuning.load_random_walk_kg_per_sqrt_s),
            ("initial load std", tuning.initial_load_std_kg),
            ("height std", tuning.height_std_m),
            ("pressure std", tuning.pressure_std_pa),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(invalid(
                    "filter tuning",
                    format!("{name} must be positive, got {v}"),
                ));
            }
        }
        if !(tuning.hysteresis_play_m.is_finite() && tuning.hysteresis_play_m >= 0.0) {
            return Err(invalid(
                "filter tuning",
                format!(
                    "the hysteresis play must be a finite length of zero or more, got {}",
                    tuning.hysteresis_play_m
                ),
            ));
        }
        // Infinity is allowed: no gate.
        if tuning.innovation_gate_sigma.is_nan() || tuning.innovation_gate_sigma <= 0.0 {
            return Err(invalid(
                "filter tuning",
                format!(
                    "the innovation gate must be positive, got {}",
                    tuning.innovation_gate_sigma
                ),
            ));
        }
        let static_load = law.wheel_load_kg(sensor_height_m, gauge_pa)?;
        let preload = tuning.start_hysteresis.preload();
        let (load, x0) = match consistent_start(
            model.as_ref(),
            first_input,
            preload,
            static_load,
            sensor_height_m,
            gauge_pa,
        ) {
            Some(start) => start,
            None => {
                let u = InputSample {
                    wheel_load_kg: static_load,
                    ..*first_input
                };
                (
                    static_load,
                    model.initial_state_with_hysteresis(
                        &u,
                        &InitialCondition::BellowPressure { gauge_pa },
                        preload,
                    )?,
                )
            }
        };
        let n = x0.len();
        let amount_index = model.state_index(StateRole::BellowAir);
        let rate_indices = model
            .states()
            .iter()
            .enumerate()
            .filter(|(_, s)| s.role == StateRole::Velocity)
            .map(|(i, _)| i)
            .collect();
        let mut z = DVector::zeros(n + 1);
        for (i, v) in x0.iter().enumerate() {
            z[i] = *v;
        }
        z[n] = load;
        let mut p = DMatrix::zeros(n + 1, n + 1);
        for i in 0..n {
            p[(i, i)] = (1e-3 * x0[i].abs().max(1e-3)).powi(2);
        }
        if let Some(i) = amount_index {
            p[(i, i)] = (0.01 * x0[i]).powi(2);
        }
        // The hysteresis's start: its range is where a long travel either way slides it (its
        // law in closed form, so no equilibrium is needed); an unknown history is uniform
        // over it.
        let hysteresis = model.hysteresis_states().to_vec();
        if !hysteresis.is_empty() {
            let slid = |metres: f64| {
                let mut x = x0.clone();
                model.follow_hysteresis(&mut x, metres);
                x
            };
            let (low, high) = (slid(-SATURATING_TRAVEL_M), slid(SATURATING_TRAVEL_M));
            for &i in &hysteresis {
                let half_range = 0.5 * (high[i] - low[i]).abs();
                let std = match tuning.start_hysteresis {
                    HysteresisStart::Unknown => half_range / 3f64.sqrt(),
                    HysteresisStart::Lowered | HysteresisStart::Raised => {
                        KNOWN_START_SPREAD * half_range
                    }
                };
                p[(i, i)] = std.powi(2);
            }
        }
        p[(n, n)] = tuning.initial_load_std_kg.powi(2);
        let played_m = model.hysteresis_coordinate_m(&x0);
        let hysteresis_start_std = hysteresis.iter().map(|&i| p[(i, i)].sqrt()).collect();
        Ok(Self {
            model,
            tuning,
            amount_index,
            rate_indices,
            z,
            p,
            time_s,
            beyond_gate: 0,
            played_m,
            hysteresis,
            hysteresis_start_std,
            hysteresis_resolved_at_s: None,
        })
    }

    fn n_model(&self) -> usize {
        self.z.len() - 1
    }

    /// The current load estimate and its standard deviation, kg.
    pub fn load(&self) -> (f64, f64) {
        let n = self.n_model();
        (self.z[n], self.p[(n, n)].max(0.0).sqrt())
    }

    /// Whether the model has a hysteresis (a wall friction) the filter carries.
    pub fn has_hysteresis(&self) -> bool {
        !self.hysteresis.is_empty()
    }

    /// When the hysteresis's start stopped mattering: every hysteresis state's standard
    /// deviation fell below half its start (`None` while it has not, or without one).
    pub fn hysteresis_resolved_at_s(&self) -> Option<f64> {
        self.hysteresis_resolved_at_s
    }

    /// The model part of the state estimate.
    pub fn state(&self) -> &[f64] {
        &self.z.as_slice()[..self.n_model()]
    }

    fn input_with_load(&self, u: &InputSample, z: &[f64]) -> InputSample {
        InputSample {
            wheel_load_kg: z[z.len() - 1],
            ..*u
        }
    }

    /// `Φ(z)`: RK4 over `dt` with the input held but for the road, which moves at its rate;
    /// the load is constant.
    fn propagate(&self, z: &[f64], u: &InputSample, dt: f64) -> Vec<f64> {
        let n = z.len() - 1;
        let u = self.input_with_load(u, z);
        let h = dt / self.tuning.substeps as f64;
        let mut x = z[..n].to_vec();
        let (mut k1, mut k2, mut k3, mut k4) =
            (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let mut tmp = vec![0.0; n];
        let t0 = self.time_s;
        let mut t = t0;
        // The road moves at its rate over the interval (linear between the logged samples, as
        // the simulator follows it); the other inputs are held.
        let at = |t: f64| InputSample {
            road_height_m: u.road_height_m + u.road_rate_m_s * (t - t0),
            ..u
        };
        // The hysteresis is held through the prediction (its rates zeroed in every stage) and
        // moved after the correction (`play_hysteresis`).
        let hold = |k: &mut [f64]| {
            for &i in &self.hysteresis {
                k[i] = 0.0;
            }
        };
        for _ in 0..self.tuning.substeps {
            self.model.rhs(t, &x, &at(t), &mut k1);
            hold(&mut k1);
            for i in 0..n {
                tmp[i] = x[i] + 0.5 * h * k1[i];
            }
            self.model.rhs(t + 0.5 * h, &tmp, &at(t + 0.5 * h), &mut k2);
            hold(&mut k2);
            for i in 0..n {
                tmp[i] = x[i] + 0.5 * h * k2[i];
            }
            self.model.rhs(t + 0.5 * h, &tmp, &at(t + 0.5 * h), &mut k3);
            hold(&mut k3);
            for i in 0..n {
                tmp[i] = x[i] + h * k3[i];
            }
            self.model.rhs(t + h, &tmp, &at(t + h), &mut k4);
            hold(&mut k4);
            for i in 0..n {
                x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            t += h;
        }
        x.push(z[n]);
        x
    }

    fn measure(&self, z: &[f64], u: &InputSample) -> [f64; 2] {
        let n = z.len() - 1;
        let o = self.model.output(&z[..n], &self.input_with_load(u, z));
        [o.sensor_height_m, o.bellow_gauge_pa]
    }

    fn perturbation(v: f64) -> f64 {
        1e-7 * v.abs().max(1e-2)
    }

    /// The model's hysteresis (wall friction) driven through a play. The state estimate
    /// jitters with the sensors' noise by a fraction of a millimetre from sample to sample,
    /// and a rate-independent hysteresis driven by that jitter wears away (a dithered Dahl
    /// element relaxes to zero, where the truck's wall, which did not jitter, holds its
    /// friction). So the prediction holds the hysteresis states (`step`), and after each
    /// correction they follow the estimate's hysteresis coordinate only by what it moved
    /// beyond the play, by their law in closed form; the covariance goes through that map's
    /// Jacobian (forward differences in the hysteresis states).
    fn play_hysteresis(&mut self, z: &mut DVector<f64>, p: &mut DMatrix<f64>) {
        let n = self.n_model();
        let (Some(played), Some(coordinate)) = (
            self.played_m,
            self.model.hysteresis_coordinate_m(&z.as_slice()[..n]),
        ) else {
            return;
        };
        let play = self.tuning.hysteresis_play_m;
        let gap = coordinate - played;
        let moved = if gap > play {
            gap - play
        } else if gap < -play {
            gap + play
        } else {
            return;
        };
        let before: Vec<f64> = z.as_slice()[..n].to_vec();
        let mut after = before.clone();
        self.model.follow_hysteresis(&mut after, moved);
        let m = z.len();
        let mut jac = DMatrix::identity(m, m);
        for &j in &self.hysteresis {
            let d = Self::perturbation(before[j]);
            let mut shifted = before.clone();
            shifted[j] += d;
            self.model.follow_hysteresis(&mut shifted, moved);
            for &i in &self.hysteresis {
                jac[(i, j)] = (shifted[i] - after[i]) / d;
            }
        }
        for &i in &self.hysteresis {
            z[i] = after[i];
        }
        *p = &jac * &*p * jac.transpose();
        self.played_m = Some(played + moved);
    }

    /// One filter cycle: predict over `dt` under the input `u` (held over the interval, as the
    /// logger recorded it, but for the road, which moves at `u.road_rate_m_s` from
    /// `u.road_height_m`), then correct with the reading taken at the end of it.
    pub fn step(
        &mut self,
        dt: f64,
        u: &InputSample,
        sensor_height_m: f64,
        gauge_pa: f64,
    ) -> Result<(f64, f64), AppError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(invalid("filter step", format!("dt = {dt} s")));
        }
        if !(sensor_height_m.is_finite() && gauge_pa.is_finite()) {
            return Err(invalid(
                "filter reading",
                format!("non-finite reading at t = {} s", self.time_s + dt),
            ));
        }
        let m = self.z.len();
        let n = m - 1;
        let z0: Vec<f64> = self.z.iter().copied().collect();
        // Predict.
        let z_pred = self.propagate(&z0, u, dt);
        let mut f = DMatrix::zeros(m, m);
        for j in 0..m {
            let d = Self::perturbation(z0[j]);
            let mut zj = z0.clone();
            zj[j] += d;
            let pj = self.propagate(&zj, u, dt);
            for i in 0..m {
                f[(i, j)] = (pj[i] - z_pred[i]) / d;
            }
        }
        let mut q = DMatrix::zeros(m, m);
        let t = &self.tuning;
        q[(n, n)] = t.load_random_walk_kg_per_sqrt_s.powi(2) * dt;
        for i in 0..n {
            q[(i, i)] = (1e-6 * z0[i].abs().max(1e-3)).powi(2) * dt;
        }
        for &i in &self.rate_indices {
            q[(i, i)] = t.rate_random_walk_per_sqrt_s.powi(2) * dt;
        }
        for &i in &self.hysteresis {
            q[(i, i)] = 0.0;
        }
        if let Some(i) = self.amount_index {
            let flow = (z_pred[i] - z0[i]) / dt;
            q[(i, i)] = ((t.amount_drift_rel_per_sqrt_s * z0[i]).powi(2)
                + (t.flow_relative_error * flow).powi(2))
                * dt;
        }
        let p_pred = &f * &self.p * f.transpose() + q;

        // Correct.
        let y_pred = self.measure(&z_pred, u);
        let mut h = DMatrix::zeros(2, m);
        for j in 0..m {
            let d = Self::perturbation(z_pred[j]);
            let mut zj = z_pred.clone();
            zj[j] += d;
            let yj = self.measure(&zj, u);
            for i in 0..2 {
                h[(i, j)] = (yj[i] - y_pred[i]) / d;
            }
        }
        let r = DMatrix::from_diagonal(&DVector::from_vec(vec![
            t.height_std_m.powi(2),
            t.pressure_std_pa.powi(2),
        ]));
        let innovation = DVector::from_vec(vec![sensor_height_m - y_pred[0], gauge_pa - y_pred[1]]);
        let time_s = self.time_s + dt;
        let singular = || AppError::FilterDiverged {
            time_s,
            reason: "the innovation covariance is singular".to_owned(),
        };
        let s = &h * &p_pred * h.transpose() + &r;
        let s_inv = s.try_inverse().ok_or_else(singular)?;
        let distance = innovation.dot(&(&s_inv * &innovation)).max(0.0).sqrt();
        // The gain is scaled, not the innovation, so that the covariance (Joseph form, valid
        // for any gain) says how little a bounded reading was believed.
        let mut trust = 1.0;
        if distance > t.innovation_gate_sigma {
            // A glitch is short; readings that stay beyond the gate are a real change (a load
            // set down) and are taken whole, or the estimate would crawl after it.
            if self.beyond_gate < t.glitch_samples {
                trust = t.innovation_gate_sigma / distance;
            }
            self.beyond_gate += 1;
        } else {
            self.beyond_gate = 0;
        }
        let mut k = &p_pred * h.transpose() * s_inv * trust;
        // The hysteresis states are considered, not estimated (a Schmidt-Kalman filter): at
        // rest the wall friction and the load trade off exactly, so a reading cannot tell them
        // apart, and corrections would push the friction beyond its range while the load
        // steps. Their uncertainty still widens the load's through the covariance (the Joseph
        // form below holds for any gain); they move only with the bellow (`play_hysteresis`).
        for &i in &self.hysteresis {
            k.row_mut(i).fill(0.0);
        }
        let mut z_new = DVector::from_vec(z_pred) + &k * innovation;
        let i_kh = DMatrix::identity(m, m) - &k * &h;
        // Joseph form keeps P symmetric positive semi-definite.
        let mut p_new = &i_kh * &p_pred * i_kh.transpose() + &k * r * k.transpose();
        self.play_hysteresis(&mut z_new, &mut p_new);
        let p_new = (&p_new + p_new.transpose()) * 0.5;
        if z_new.iter().any(|v| !v.is_finite()) || p_new.iter().any(|v| !v.is_finite()) {
            return Err(AppError::FilterDiverged {
                time_s,
                reason: "a state or covariance turned non-finite".to_owned(),
            });
        }
        self.z = z_new;
        self.p = p_new;
        self.time_s = time_s;
        if self.hysteresis_resolved_at_s.is_none()
            && !self.hysteresis.is_empty()
            && self
                .hysteresis
                .iter()
                .zip(&self.hysteresis_start_std)
                .all(|(&i, &start)| self.p[(i, i)].max(0.0).sqrt() < 0.5 * start)
        {
            self.hysteresis_resolved_at_s = Some(time_s);
        }
        Ok(self.load())
    }
}

/// Runs the load filter over a run's readings. The run's logged load is not used.
///
/// The filter's own covariance only knows the noise it was told about; the model's parameters
/// are taken as exact. The reported standard deviation therefore adds, in quadrature, the
/// parameter part of `weigher`'s static uncertainty at the filter's current load (the same
/// parameters fix the static balance the filter converges to). `weigher.law` gives the first
/// guess of the initial load ([`LoadEkf::new`]).
pub fn weigh_ekf(
    run: &airsus_data::Run,
    model: Box<dyn SuspensionModel>,
    weigher: &StaticWeigher,
    tuning: &EkfTuning,
) -> Result<WeighSeries, AppError> {
    let law = &weigher.law;
    let outputs = run.measured()?;
    if run.is_empty() {
        return Err(invalid("run", "it has no samples"));
    }
    let road = &run.inputs.road_height_m;
    // The inputs over (t_k, t_k+1]: the road from its sample k towards sample k+1.
    let input = |k: usize| InputSample {
        wheel_load_kg: 0.0,
        valve: run.inputs.valve[k],
        supply_gauge_pa: run.inputs.supply_gauge_pa[k],
        road_height_m: road[k],
        road_rate_m_s: crate::road::road_rate_at(&run.time_s, road, k),
    };
    let mut ekf = LoadEkf::new(
        model,
        law,
        tuning.clone(),
        run.time_s[0],
        &input(0),
        outputs.sensor_height_m[0],
        outputs.bellow_gauge_pa[0],
    )?;
    let mut series = WeighSeries::default();
    let parameter_std = |k: usize| {
        weigher
            .estimate(outputs.sensor_height_m[k], outputs.bellow_gauge_pa[k])
            .map_or(0.0, |e| e.parameter_std_kg)
    };
    let (m0, s0) = ekf.load();
    series.time_s.push(run.time_s[0]);
    series.wheel_load_kg.push(m0);
    series.std_kg.push(s0.hypot(parameter_std(0)));
    // The filter's own part (the sensors' noise and the process noise it was told about):
    // a calibration replaces the parameter part by what its residuals measured.
    series.measurement_std_kg.push(s0);
    for k in 1..run.len() {
        // The valve state logged at sample k-1 acted over (t_{k-1}, t_k].
        let (m, s) = ekf.step(
            run.time_s[k] - run.time_s[k - 1],
            &input(k - 1),
            outputs.sensor_height_m[k],
            outputs.bellow_gauge_pa[k],
        )?;
        series.time_s.push(run.time_s[k]);
        series.wheel_load_kg.push(m);
        series.std_kg.push(s.hypot(parameter_std(k)));
        series.measurement_std_kg.push(s);
    }
    if ekf.has_hysteresis() && tuning.start_hysteresis == HysteresisStart::Unknown {
        let resolved_at_s = ekf.hysteresis_resolved_at_s();
        let note = match resolve_start_backwards(&mut series, run, tuning, resolved_at_s) {
            Some(note) => note,
            None => unknown_start_note(&series, resolved_at_s),
        };
        series.notes.push(note);
    }
    Ok(series)
}

/// How long after the first valve episode closed (and the unknown start friction was resolved)
/// the filter is given to settle before its load is read for the samples before, and how long
/// it is averaged over then, s.
const BACKWARDS_SETTLE_S: f64 = 5.0;
const BACKWARDS_WINDOW_S: f64 = 10.0;

/// How soon after the valve first opened the friction must be resolved for the valve to have
/// moved the bellow, s (a valve slides the friction within seconds of opening).
const BACKWARDS_VALVE_LEAD_S: f64 = 10.0;

/// An offline smoothing of an unknown start (the whole run is at hand), where the bellow's
/// first movement was the valve's: the logged height and pressure stayed steady (within
/// eight of the sensors' standard deviations, at least 1.5 mm and 3 kPa) until the valve first
/// opened, and the friction was resolved after it opened and within
/// [`BACKWARDS_VALVE_LEAD_S`]. Then no load change moved the bellow before, and the load read
/// after that valve episode, when the friction is known, is the load of the samples before
/// the valve opened: they take it, with its standard deviation. Assumed: the load did not
/// change while the valve worked (a valve opened at rest, as a truck levels itself after
/// standing). The samples from the valve's opening on keep the filter's own reading. `None`
/// (the series untouched) otherwise: where the valve is open from the run's first or second
/// sample, or where the run ends before the reading.
fn resolve_start_backwards(
    series: &mut WeighSeries,
    run: &airsus_data::Run,
    tuning: &EkfTuning,
    resolved_at_s: Option<f64>,
) -> Option<String> {
    use airsus_data::ValveState;
    let resolved_at_s = resolved_at_s?;
    let t = &series.time_s;
    let t0 = *t.first()?;
    let valve = &run.inputs.valve;
    let k_valve = valve.iter().position(|&v| v != ValveState::Closed)?;
    // Open from the first sample (or the second) there is no rest before it to see steady:
    // one reading is always "steady", and the note would claim what the run does not show.
    if k_valve < 2 {
        return None;
    }
    // The valve logged at sample k acts over (t_k, t_k+1]: a friction resolved at t_k moved
    // before it.
    if !(resolved_at_s > t[k_valve] && resolved_at_s <= t[k_valve] + BACKWARDS_VALVE_LEAD_S) {
        return None;
    }
    let measured = run.measured().ok()?;
    let range = |v: &[f64]| {
        let v = &v[..k_valve.max(1)];
        v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
            - v.iter().copied().fold(f64::INFINITY, f64::min)
    };
    let steady = range(&measured.sensor_height_m) <= (8.0 * tuning.height_std_m).max(1.5e-3)
        && range(&measured.bellow_gauge_pa) <= (8.0 * tuning.pressure_std_pa).max(3e3);
    if !steady {
        return None;
    }
    // The reading: after the first valve episode closed and the friction was resolved, with
    // the valve closed throughout.
    let k_closed = (k_valve..valve.len()).find(|&k| valve[k] == ValveState::Closed)?;
    let from = t[k_closed].max(resolved_at_s) + BACKWARDS_SETTLE_S;
    let window: Vec<usize> = (0..series.len())
        .filter(|&k| t[k] >= from && t[k] < from + BACKWARDS_WINDOW_S)
        .collect();
    let dt = (t[t.len() - 1] - t0) / (t.len() - 1).max(1) as f64;
    let enough = (0.5 * BACKWARDS_WINDOW_S / dt).max(1.0) as usize;
    if window.len() < enough || window.iter().any(|&k| valve[k] != ValveState::Closed) {
        return None;
    }
    let mean = |v: &[f64]| window.iter().map(|&k| v[k]).sum::<f64>() / window.len() as f64;
    let load_kg = mean(&series.wheel_load_kg);
    let std_kg = mean(&series.std_kg);
    let own_std_kg =
        (series.measurement_std_kg.len() == series.len()).then(|| mean(&series.measurement_std_kg));
    for k in 0..k_valve {
        series.wheel_load_kg[k] = load_kg;
        series.std_kg[k] = std_kg;
        if let Some(own) = own_std_kg {
            series.measurement_std_kg[k] = own;
        }
    }
    Some(format!(
        "the run starts at rest with an unknown wall friction, which trades off exactly against the load; its first movement was the valve's (opened at {:.0} s, the friction known from {:.0} s), the readings steady before it: the load read after it ({load_kg:.0} kg, {:.0}-{:.0} s) is taken back to the start, assuming no load change while the valve worked",
        t[k_valve] - t0,
        resolved_at_s - t0,
        from - t0,
        from + BACKWARDS_WINDOW_S - t0,
    ))
}

fn unknown_start_note(series: &WeighSeries, resolved_at_s: Option<f64>) -> String {
    let t0 = series.time_s.first().copied().unwrap_or(0.0);
    let k = series
        .time_s
        .iter()
        .position(|&t| t - t0 >= UNKNOWN_START_READ_S)
        .unwrap_or(series.len().saturating_sub(1));
    let half_width_kg = 1.96
        * series
            .measurement_std_kg
            .get(k)
            .copied()
            .unwrap_or(f64::NAN);
    let what = "the run starts at rest with an unknown wall friction, which trades off exactly against the load";
    let how = "--start-hysteresis lowered|raised (Python start_hysteresis=) says how the truck came to its first reading";
    match resolved_at_s {
        Some(t) => format!(
            "{what}: until the bellow first moved ({:.0} s) the filter's own 95 % interval is about ±{half_width_kg:.0} kg wide for it; {how}",
            t - t0
        ),
        None => format!(
            "{what}, and the bellow never moved far enough to slide it to one side: the whole run's load is uncertain by it (the filter's own 95 % interval about ±{half_width_kg:.0} kg); {how}"
        ),
    }
}

/// When the unknown start's width is read: after the filter's first readings (its load prior
/// is hundreds of kilograms wide on the first sample).
const UNKNOWN_START_READ_S: f64 = 10.0;
