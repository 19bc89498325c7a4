//! Model 2: quarter-car model QCM 2 (thesis 3.1.1, eq 3.6–3.13; state space eq 4.2), and its
//! two extensions with a slow bellow force: `m2x` (thesis 4.2.1, eq 4.3/4.4) and `m2xh` (the
//! height-driven creep element thesis 6.2 proposes).
//!
//! # Derivation (replaces the thesis' eq 3.10–3.12)
//!
//! Generalised coordinates: the chassis height `x` (chassis bottom, measured upward from the
//! axle's position when the unloaded tire just touches a level road — the same reference as
//! Model 1's `x1`) and the lever angle `α` below horizontal. The hinge hangs `h0` below the
//! chassis; the chassis only moves vertically (the rest of the truck holds it).
//!
//! Bodies: the chassis share `m1 = m_tot - m2`, a point mass at the chassis; the lever with the
//! axle, mass `m2` with its centre of mass at the axle, `l1` along the lever from the hinge,
//! and inertia `I_g` **about the hinge** (thesis eq 3.8: `I_g = m2 l1²` for the axle as a point
//! mass; a real axle and lever only add to it).
//!
//! Positions: axle height `y2 = x - h0 - l1 sin α`; bellow height (eq 2.2)
//! `h_b = h0 + (l1 + l2) sin α`; damper length `h0 + (l1 + l3) sin α` (+ const).
//!
//! Kinetic energy, with the hinge velocity `ẋ` (vertical) and the lever rotating about it
//! (`T = ½ m v_A² + m v_A·(ω × r_AG) + ½ I_A ω²` for a body moving with point `A`):
//! ```text
//! T = ½ (m1 + m2) ẋ² - m2 l1 cos α ẋ α̇ + ½ I_g α̇²
//! ```
//! (for `I_g = m2 l1²` this is exactly `½ m1 ẋ² + ½ m2 |v_axle|²`).
//!
//! Potential energy: `V = m1 g x + m2 g y2 + U_w(δ) + U_b(h_b)` with the tire compression
//! `δ = z_r - y2`, `U_w = ½ k_w δ²` for `δ > 0` (else 0, eq 3.15), and the bellow's potential
//! `U_b(h) = -∫ F_ab dh` (exact while `n` is constant: then `F_ab` depends on `h_b` only).
//!
//! Non-conservative generalised forces (virtual work): the damper `-F_d(v_d) (l1+l3) cos α`
//! with the damper extension rate `v_d = (l1+l3) cos α α̇`, the hinge friction
//! `-k_f l1 cos α · (l1 cos α α̇)` (viscous on the axle-to-chassis rate, as in Model 1), and
//! the slow bellow force `F_s (l1 + l2) cos α` of the extended models.
//!
//! Lagrange's equations with `M = m1 + m2`, `c = m2 l1 cos α`:
//! ```text
//! M ẍ - c α̈ = F_w - M g - m2 l1 sin α α̇²                                  =: R_x
//! -c ẍ + I_g α̈ = cos α [ l1 (m2 g - F_w) + (l1+l2)(F_ab + F_s) - (l1+l3) F_d
//!                        - k_f l1² cos α α̇ ]                             =: Q_α
//! ```
//! The second line is thesis eq 3.11 (torques about the hinge) plus the inertial coupling
//! `c ẍ`: Euler's law about the *accelerating* hinge needs `r_AG × m a_A`, the hinge's
//! acceleration — eq 3.7/3.10 use the axle's acceleration `a_m2` instead, which with `I_g`
//! about the hinge counts the axle's rotation twice (and eq 3.10 prints `α × r` for the
//! angular acceleration term). The first line is eq 3.6 corrected for the axle moving
//! relative to the chassis (eq 3.6 drops `c α̈` and the centripetal term). Solving the 2×2
//! system (`det = M I_g - c² > 0` whenever `I_g > m2² l1² / M`, always true for
//! `I_g ≥ m2 l1²`):
//! ```text
//! ẍ = (I_g R_x + c Q_α) / det,    α̈ = (c R_x + M Q_α) / det
//! ```
//! Statics (`α̇ = ẍ = α̈ = 0`): `F_w = M g` and `F_ab (l1 + l2) = (M - m2) g l1`, i.e.
//! `F_ab = m1 g / k_l` — the same balance as Model 1, so both models agree in statics.
//! Without damper, friction, slow force and air flow, `E = T + V` is conserved (tested).
//!
//! # Damper placement
//! The damper acts **along the lever** at `l1 + l3` from the hinge (thesis eq 3.11), vertical:
//! its stroke is the lever's vertical motion there. (On Scania's layout the lower damper eye
//! sits on the axle seat of the lever, `l3` behind the axle.)
//!
//! # Slow force (extended models)
//! * `m2x` (thesis eq 4.3/4.4): `F_s = F_ext = k_sd y_OE`, where `y_OE` is the thesis OE model
//!   (Table 5.5: `b1 = -8.672e-8`, `f1 = -0.997`, `nk = 2`, `Ts = 0.1 s`) driven by the **load
//!   change** since the initial condition (the static relation removed, thesis 5.2.4),
//!   converted to continuous time by zero-order hold. `y_OE` is the slow height change it was
//!   identified on, taken in metres per kg of load (static gain `-2.89e-5 m/kg`: a 300 kg
//!   step creeps about 9 mm with a 33 s time constant), so `k_sd` is in N/m. Default `k_sd`:
//!   one tenth of the bellow force carrying the thesis' initial load (sprung 2830 kg), thesis
//!   Table 5.9. The initial load is kept as a constant state (`load_ref_kg`, `ẋ = 0`) because
//!   the right-hand side only sees the current input.
//! * `m2xh` (thesis 6.2, future work): the slow force comes from the **bellow height**, so it
//!   also acts when the load is constant and the valve moves the truck (data-sets 3–4). The
//!   rubber wall of the bellow creeps: a Maxwell element (spring `k_sd` in series with a
//!   dashpot, relaxation time `τ_sd`) in parallel with the gas spring,
//!   ```text
//!   dF_s/dt = -k_sd ḣ_b - F_s / τ_sd,        F_s(0) = 0 in equilibrium
//!   ```
//!   A sudden compression first meets the extra stiffness `k_sd`, which then relaxes over
//!   `τ_sd`: the fast-then-slow settling of thesis Fig 5.2, after a load step *and* after a
//!   valve pulse. The element is passive (it stores `F_s²/2k_sd` and dissipates `F_s²/(k_sd τ)`).
//!   New names: `ksd` (creep stiffness, N/m, default 2.5e4 — about a third of the gas spring's
//!   stiffness at the bellow, so roughly a quarter of a step's deflection creeps), `tsd`
//!   (time constant, s, default `-Ts/ln(-f1)` = 33.3 s from the thesis OE pole).
//!
//! State `[x_m, alpha_rad, xdot_m_s, alphadot_rad_s, n_mol]`, then for `m2x` the OE states
//! `oe1..` and `load_ref_kg`, for `m2xh` `f_creep_n`.

use airsus_data::TruckParameters;

use crate::corner::Corner;
use crate::linear_block::{LinearBlock, OE_STATES, OeInput};
use crate::mechanics::{LeverForces, lever_accelerations};
use crate::model::{
    InitialCondition, InputSample, ModelError, NamedParameters, OutputSample, StateInfo, StateRole,
    SuspensionModel,
};
use crate::params::{Field, TruckParams};

/// Sprung mass at the thesis' initial condition (data-set 1; SPEC §5), kg: the load at which
/// the default `k_sd` of `m2x` is one tenth of the bellow force (thesis Table 5.9).
pub const THESIS_INITIAL_SPRUNG_KG: f64 = 2830.0;
/// Default creep stiffness of `m2xh`, N/m (see the module docs).
pub const DEFAULT_CREEP_STIFFNESS_N_PER_M: f64 = 2.5e4;

const BASE_STATES: &[StateInfo] = &[
    StateInfo::new("x_m", "m", StateRole::Position),
    StateInfo::new("alpha_rad", "rad", StateRole::Angle),
    StateInfo::new("xdot_m_s", "m/s", StateRole::Velocity),
    StateInfo::new("alphadot_rad_s", "rad/s", StateRole::Velocity),
    StateInfo::new("n_mol", "mol", StateRole::BellowAir),
];
/// The largest slow-dynamics OE block `m2x` carries.
const MAX_OE_STATES: usize = 8;

const FIELDS: &[Field] = crate::params::LEVER_MODEL_FIELDS;

/// Which slow bellow force the model carries.
#[derive(Debug, Clone, PartialEq)]
enum SlowForce {
    None,
    /// `m2x`: OE from load change; `oe` states follow the base states, then `load_ref_kg`.
    LoadOe {
        block: LinearBlock,
        ksd_n_per_m: f64,
    },
    /// `m2xh`: Maxwell creep element on the bellow height; one state `f_creep_n`.
    Creep {
        ksd_n_per_m: f64,
        tau_s: f64,
    },
}

/// Model 2 (QCM 2) and its extensions `m2x`, `m2xh`.
#[derive(Debug, Clone, PartialEq)]
pub struct Model2 {
    name: &'static str,
    corner: Corner,
    params: TruckParams,
    slow: SlowForce,
    states: Vec<StateInfo>,
}

impl Model2 {
    /// Model 2 without slow force (`m2`).
    pub fn new(truck: &TruckParameters) -> Self {
        let corner = Corner::new(truck);
        Self {
            name: "m2",
            states: corner.with_line_state(BASE_STATES.to_vec()),
            corner,
            params: TruckParams::new("m2", FIELDS, truck.clone()),
            slow: SlowForce::None,
        }
    }

    /// Model 2 extended (`m2x`, thesis eq 4.3/4.4) with the `[slow_dynamics]` OE model.
    /// A missing `force_scale` is set to the thesis default (see the module docs).
    pub fn extended(truck: &TruckParameters) -> Result<Self, ModelError> {
        let mut truck = truck.clone();
        let sd = &truck.slow_dynamics;
        let block = LinearBlock::from_oe(
            "m2x",
            &[OeInput {
                b: &sd.oe_b,
                f: &sd.oe_f,
                nk: sd.oe_nk,
            }],
            sd.oe_sample_time_s,
        )?;
        if block.n_states() > MAX_OE_STATES {
            return Err(ModelError::InvalidStructure {
                model: "m2x".to_owned(),
                reason: format!(
                    "the slow-dynamics OE model has {} states; at most {} are supported",
                    block.n_states(),
                    MAX_OE_STATES
                ),
            });
        }
        let ksd = match sd.force_scale {
            Some(k) => k,
            None => {
                0.1 * THESIS_INITIAL_SPRUNG_KG * truck.environment.gravity_m_s2
                    / truck.geometry.lever_gain()
            }
        };
        truck.slow_dynamics.force_scale = Some(ksd);
        let mut fields = FIELDS.to_vec();
        fields.push(Field::SlowForceScale);
        let mut states = BASE_STATES.to_vec();
        states.extend_from_slice(&OE_STATES[..block.n_states()]);
        states.push(StateInfo::new("load_ref_kg", "kg", StateRole::Reference));
        let corner = Corner::new(&truck);
        Ok(Self {
            name: "m2x",
            states: corner.with_line_state(states),
            corner,
            params: TruckParams::new("m2x", &fields, truck),
            slow: SlowForce::LoadOe {
                block,
                ksd_n_per_m: ksd,
            },
        })
    }

    /// Model 2 with the height-driven creep element (`m2xh`, see the module docs). Missing
    /// creep parameters are set to their defaults.
    pub fn height_creep(truck: &TruckParameters) -> Self {
        let mut truck = truck.clone();
        let sd = &truck.slow_dynamics;
        let ksd = sd
            .creep_stiffness_n_per_m
            .unwrap_or(DEFAULT_CREEP_STIFFNESS_N_PER_M);
        let tau = sd
            .creep_time_constant_s
            .unwrap_or_else(|| thesis_time_constant_s(&sd.oe_f, sd.oe_sample_time_s));
        truck.slow_dynamics.creep_stiffness_n_per_m = Some(ksd);
        truck.slow_dynamics.creep_time_constant_s = Some(tau);
        let mut fields = FIELDS.to_vec();
        fields.extend([Field::CreepStiffness, Field::CreepTimeConstant]);
        let mut states = BASE_STATES.to_vec();
        states.push(StateInfo::new("f_creep_n", "N", StateRole::Force));
        let corner = Corner::new(&truck);
        Self {
            name: "m2xh",
            states: corner.with_line_state(states),
            corner,
            params: TruckParams::new("m2xh", &fields, truck),
            slow: SlowForce::Creep {
                ksd_n_per_m: ksd,
                tau_s: tau,
            },
        }
    }

    pub fn truck(&self) -> &TruckParameters {
        self.params.truck()
    }

    /// Bellow height of state `x`, m (eq 2.2).
    pub fn bellow_height_m(&self, x: &[f64]) -> f64 {
        self.corner.h0_m + self.corner.l12_m * x[1].sin()
    }

    /// The slow bellow force in state `x` under `u`, N (0 for `m2`).
    pub fn slow_force_n(&self, x: &[f64], u: &InputSample) -> f64 {
        match &self.slow {
            SlowForce::None => 0.0,
            SlowForce::LoadOe { block, ksd_n_per_m } => {
                let k = block.n_states();
                let du = [u.wheel_load_kg - x[5 + k]];
                ksd_n_per_m * block.output(&x[5..5 + k], &du)
            }
            SlowForce::Creep { .. } => x[5],
        }
    }

    fn rebuild(&mut self) {
        self.corner = Corner::new(self.params.truck());
        let sd = &self.params.truck().slow_dynamics;
        match &mut self.slow {
            SlowForce::None => {}
            SlowForce::LoadOe { ksd_n_per_m, .. } => {
                *ksd_n_per_m = sd.force_scale.unwrap_or(*ksd_n_per_m)
            }
            SlowForce::Creep { ksd_n_per_m, tau_s } => {
                *ksd_n_per_m = sd.creep_stiffness_n_per_m.unwrap_or(*ksd_n_per_m);
                *tau_s = sd.creep_time_constant_s.unwrap_or(*tau_s);
            }
        }
    }
}

/// Time constant of the discrete first-order pole `-f1` sampled at `ts`: `-ts / ln(-f1)`, s;
/// 33.3 s for the thesis' `f1 = -0.997`, `Ts = 0.1 s`. Falls back to that value if the
/// pole is not a stable positive real one.
fn thesis_time_constant_s(oe_f: &[f64], ts_s: f64) -> f64 {
    let pole = oe_f.first().map_or(0.997, |f| -f);
    if pole > 0.0 && pole < 1.0 {
        -ts_s / pole.ln()
    } else {
        -0.1 / 0.997_f64.ln()
    }
}

impl SuspensionModel for Model2 {
    fn name(&self) -> &'static str {
        self.name
    }

    fn description(&self) -> &'static str {
        match self.slow {
            SlowForce::None => {
                "Model 2: QCM 2, chassis height and lever angle, rigid-body lever about the hinge (thesis eq 3.6-3.13/4.2, derivation corrected)"
            }
            SlowForce::LoadOe { .. } => {
                "Model 2 extended: Model 2 plus an OE slow force from load change, ZOH to continuous time (thesis eq 4.3/4.4)"
            }
            SlowForce::Creep { .. } => {
                "Model 2 with bellow creep: Model 2 plus a Maxwell creep force driven by bellow height (thesis 6.2 future work)"
            }
        }
    }

    fn states(&self) -> &[StateInfo] {
        &self.states
    }

    fn parameters(&self) -> &dyn NamedParameters {
        &self.params
    }

    fn parameters_mut(&mut self) -> &mut dyn NamedParameters {
        &mut self.params
    }

    fn parameters_changed(&mut self) {
        self.rebuild();
    }

    fn rhs(&self, _t: f64, x: &[f64], u: &InputSample, dx: &mut [f64]) {
        let c = &self.corner;
        let (sin_a, cos_a) = x[1].sin_cos();
        let alpha_dot = x[3];
        let h_b = c.h0_m + c.l12_m * sin_a;
        let (f_ab, p_abs) = c.bellow_force_n(h_b, x[4]);
        let f_slow = self.slow_force_n(x, u);
        let axle_height_m = x[0] - c.h0_m - c.l1_m * sin_a;
        let axle_velocity_m_s = x[2] - c.l1_m * cos_a * alpha_dot;
        let f_tire = c.tire.force_n(
            u.road_height_m - axle_height_m,
            u.road_rate_m_s - axle_velocity_m_s,
        );
        let f_damper = c.damper.force_n(c.l13_m * cos_a * alpha_dot);
        let f_friction = c.friction_n_s_per_m * c.l1_m * cos_a * alpha_dot;
        let forces = LeverForces {
            tire_n: f_tire,
            bellow_n: f_ab + f_slow,
            damper_n: f_damper,
            friction_n: f_friction,
        };
        let (x_dd, alpha_dd) = lever_accelerations(
            &c.lever_body(u.wheel_load_kg),
            sin_a,
            cos_a,
            alpha_dot,
            &forces,
        );
        dx[0] = x[2];
        dx[1] = alpha_dot;
        dx[2] = x_dd;
        dx[3] = alpha_dd;
        let flows = c.air_flows(p_abs, c.line_mol(x), u);
        dx[4] = flows.bellow_mol_s;
        match &self.slow {
            SlowForce::None => {}
            SlowForce::LoadOe { block, .. } => {
                let k = block.n_states();
                let du = [u.wheel_load_kg - x[5 + k]];
                let (state, rest) = dx[5..].split_at_mut(k);
                block.derivative(&x[5..5 + k], &du, state);
                rest[0] = 0.0;
            }
            SlowForce::Creep { ksd_n_per_m, tau_s } => {
                let h_b_dot = c.l12_m * cos_a * alpha_dot;
                dx[5] = -ksd_n_per_m * h_b_dot - x[5] / tau_s;
            }
        }
        c.set_line_rate(dx, flows);
    }

    fn uses_supply_while_valve_shut(&self) -> bool {
        self.corner.supply_line.is_some()
    }

    fn output(&self, x: &[f64], u: &InputSample) -> OutputSample {
        self.corner
            .outputs(self.bellow_height_m(x), x[4], u.wheel_load_kg)
    }

    fn initial_state(
        &self,
        u: &InputSample,
        ic: &InitialCondition,
    ) -> Result<Vec<f64>, ModelError> {
        let c = &self.corner;
        let eq = c.equilibrium(self.name, u, ic)?;
        let sin_a = (eq.bellow_height_m - c.h0_m) / c.l12_m;
        // equilibrium() keeps h_b inside (0, h0 + l1 + l2); a negative h0 could still put
        // sin α below -1.
        if !(-1.0..=1.0).contains(&sin_a) {
            return Err(ModelError::NoEquilibrium {
                model: self.name.to_owned(),
                what: format!("bellow height {:.1} mm", eq.bellow_height_m * 1e3),
                reason: "the lever cannot reach it".to_owned(),
            });
        }
        let alpha = sin_a.asin();
        let axle_height_m = u.road_height_m - eq.tire_compression_m;
        let mut x = vec![
            axle_height_m + c.h0_m + c.l1_m * sin_a,
            alpha,
            0.0,
            0.0,
            eq.amount_mol,
        ];
        match &self.slow {
            SlowForce::None => {}
            SlowForce::LoadOe { block, .. } => {
                x.extend(std::iter::repeat_n(0.0, block.n_states()));
                x.push(u.wheel_load_kg);
            }
            SlowForce::Creep { .. } => x.push(0.0),
        }
        x.extend(c.line_amount_at_rest_mol(u));
        Ok(x)
    }
}
