//! Model 1: quarter-car model QCM 1 (thesis 3.1.1, eq 3.4; state space eq 4.1).
//!
//! Two vertical masses: the sprung mass `m1 = m_tot - m2` (chassis share) at height `x1` and
//! the unsprung mass `m2` (axle, wheel) at height `x2`, both measured upward from the axle's
//! position when the unloaded tire just touches a level road (`z_r = 0`). So `x2 < 0` under
//! load, the tire compression is `z_r - x2`, and the rigid-lever axle-to-chassis distance is
//! `h_axle = x1 - x2`.
//!
//! Forces (up positive):
//! ```text
//! m1 ẍ1 = -m1 g + k_l F_ab(h_b, n) - k_d F_d(k_d (ẋ1 - ẋ2)) - k_f (ẋ1 - ẋ2)
//! m2 ẍ2 = -m2 g - k_l F_ab(h_b, n) + k_d F_d(k_d (ẋ1 - ẋ2)) + k_f (ẋ1 - ẋ2) + F_w(z_r - x2)
//! ṅ     = f_air(p(h_b, n), u)                         h_b = h0 + k_l (h_axle - h0)   (eq 2.1)
//! ```
//!
//! Two corrections to the thesis, both for consistency with the lever and with Model 2:
//! * **Bellow height.** Eq 3.5 sets `h_bellow = x1 - x2` while eq 3.4 multiplies the bellow
//!   force by `k_l`. A force `k_l F_ab` on the masses does the work of `F_ab` over a bellow
//!   stroke `k_l` times the axle stroke, so the bellow height must follow eq 2.1; otherwise the
//!   model creates energy and its statics disagree with Model 2's. We use eq 2.1.
//! * **Damper lever.** Model 2 (eq 3.11) puts the damper at `l1 + l3` from the hinge; a
//!   vertical damper there strokes `k_d = (l1 + l3)/l1` times the axle stroke and acts on the
//!   axle with `k_d` times its force. Model 1 uses the same gain (eq 3.4 has none), so both
//!   models describe the same truck.
//!
//! The hinge friction (`k_f`, eq 3.4) is viscous on the relative velocity. The thesis writes
//! it only on `m1`; as an internal force between the two bodies it acts on both (on `m1` alone
//! it would brake the whole truck's vertical motion).
//!
//! State `[x1_m, x2_m, v1_m_s, v2_m_s, n_mol]`, and `line_n_mol` when the file names a supply
//! line (`rline`).

use airsus_data::TruckParameters;

use crate::corner::Corner;
use crate::model::{
    InitialCondition, InputSample, ModelError, NamedParameters, OutputSample, StateInfo, StateRole,
    SuspensionModel,
};
use crate::params::{Field, TruckParams};

const NAME: &str = "m1";
const STATES: &[StateInfo] = &[
    StateInfo::new("x1_m", "m", StateRole::Position),
    StateInfo::new("x2_m", "m", StateRole::Position),
    StateInfo::new("v1_m_s", "m/s", StateRole::Velocity),
    StateInfo::new("v2_m_s", "m/s", StateRole::Velocity),
    StateInfo::new("n_mol", "mol", StateRole::BellowAir),
];

/// The parameters Model 1 uses.
const FIELDS: &[Field] = &[
    Field::EffectiveArea(0),
    Field::EffectiveArea(1),
    Field::EffectiveArea(2),
    Field::EffectiveArea(3),
    Field::EffectiveArea(4),
    Field::CrossSection(0),
    Field::CrossSection(1),
    Field::Unsprung,
    Field::HingeFriction,
    Field::TireStiffness,
    Field::LeverCompliance,
    Field::FillResistance,
    Field::ExhaustResistance,
    Field::DamperScale,
    Field::TireDamping,
];

/// Model 1 (QCM 1). Build with [`Model1::new`] or `build_model("m1", ..)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Model1 {
    corner: Corner,
    params: TruckParams,
    states: Vec<StateInfo>,
}

impl Model1 {
    pub fn new(truck: &TruckParameters) -> Self {
        let corner = Corner::new(truck);
        Self {
            states: corner.with_line_state(STATES.to_vec()),
            corner,
            params: TruckParams::new(NAME, FIELDS, truck.clone()),
        }
    }

    /// The parameters as a truck (everything, not just the freeable subset).
    pub fn truck(&self) -> &TruckParameters {
        self.params.truck()
    }

    /// Bellow height of state `x`, m (eq 2.1 on `h_axle = x1 - x2`).
    pub fn bellow_height_m(&self, x: &[f64]) -> f64 {
        let c = &self.corner;
        c.h0_m + c.lever_gain * (x[0] - x[1] - c.h0_m)
    }
}

impl SuspensionModel for Model1 {
    fn name(&self) -> &'static str {
        NAME
    }

    fn description(&self) -> &'static str {
        "Model 1: quarter-car model QCM 1, two vertical masses, bellow through the lever gain (thesis eq 3.4/4.1)"
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
        self.corner = Corner::new(self.params.truck());
    }

    fn rhs(&self, _t: f64, x: &[f64], u: &InputSample, dx: &mut [f64]) {
        let c = &self.corner;
        let g = c.gravity_m_s2;
        let m1 = c.sprung_kg(u.wheel_load_kg);
        let m2 = c.unsprung_kg;
        let (f_ab, p_abs) = c.bellow_force_n(self.bellow_height_m(x), x[4]);
        let v_rel = x[2] - x[3];
        let f_damper = c.damper_gain * c.damper.force_n(c.damper_gain * v_rel);
        let f_friction = c.friction_n_s_per_m * v_rel;
        let f_tire = c
            .tire
            .force_n(u.road_height_m - x[1], u.road_rate_m_s - x[3]);
        let internal = c.lever_gain * f_ab - f_damper - f_friction;
        dx[0] = x[2];
        dx[1] = x[3];
        dx[2] = internal / m1 - g;
        dx[3] = (f_tire - internal) / m2 - g;
        let flows = c.air_flows(p_abs, c.line_mol(x), u);
        dx[4] = flows.bellow_mol_s;
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
        let eq = c.equilibrium(NAME, u, ic)?;
        let x2 = u.road_height_m - eq.tire_compression_m;
        let h_axle = c.h0_m + (eq.bellow_height_m - c.h0_m) / c.lever_gain;
        let mut x = vec![x2 + h_axle, x2, 0.0, 0.0, eq.amount_mol];
        x.extend(c.line_amount_at_rest_mol(u));
        Ok(x)
    }
}
