//! The virtual truck as a model (`truck`): Model 2's corrected lever mechanics
//! ([`airsus_model::mechanics`]) with every effect of [`crate::physics`] on top. It sits
//! behind the same [`SuspensionModel`] trait as the thesis models, so it can be simulated and
//! fitted like them: the richest structure airsus offers.
//!
//! State `[x_m, alpha_rad, xdot_m_s, alphadot_rad_s, n_mol, gas_t_k, creep_s_m, dahl_f_n,
//! line_n_mol, tank_n_mol]`:
//! - `gas_t_k`: bellow gas temperature ([`crate::physics::gas_temperature_rate`]); held at
//!   ambient when heat exchange is off (isothermal, as the thesis);
//! - `creep_s_m`: the Maxwell creep element's damper position in bellow-height coordinates;
//!   the creep force `k_c (s − h_b)` pushes back against recent compression;
//! - `dahl_f_n`: the Dahl friction force opposing bellow motion (hysteresis);
//! - `line_n_mol`: air in the supply line between tank and valve (isothermal, ambient);
//! - `tank_n_mol`: air in the actuator tank — a state only in [`SupplyMode::Tank`], where the
//!   tank droops while air flows and the compressor governor refills it. In
//!   [`SupplyMode::Measured`] the logged tank pressure is the input, as for every model.
//!
//! The bellow force is `F = p_g A_eff(h_b, p_g) + k_c (s − h_b) − F_dahl`, with the effective
//! area stretching with pressure (`A_eff = A_poly(h)(1 + κ p_g / 100 kPa)`).

use airsus_data::{EffectiveAreaLaw, GasVolumeLaw, TruckParameters, ValveFlowLaw, ValveState};
use airsus_model::mechanics::{LeverBody, LeverForces, lever_accelerations};
use airsus_model::params::{Field, LEVER_MODEL_FIELDS, TruckParams};
use airsus_model::submodels::{Damper, Tire, first_upward_crossing_m, lever_gain, sensor_height_m};
use airsus_model::{
    InitialCondition, InputSample, MIN_SPRUNG_MASS_KG, ModelError, NamedParameters, OutputSample,
    StateInfo, StateRole, SuspensionModel,
};

use crate::physics::{
    GasEnergyBalance, dahl_force_after_displacement, dahl_force_rate, gas_temperature_rate,
    maxwell_position_rate, smoothstep,
};
use crate::truth::{EffectParameters, VirtualTruck};

/// Index of `dahl_f_n` in [`STATES`].
const DAHL_STATE: usize = 7;

const STATES: &[StateInfo] = &[
    StateInfo::new("x_m", "m", StateRole::Position),
    StateInfo::new("alpha_rad", "rad", StateRole::Angle),
    StateInfo::new("xdot_m_s", "m/s", StateRole::Velocity),
    StateInfo::new("alphadot_rad_s", "rad/s", StateRole::Velocity),
    StateInfo::new("n_mol", "mol", StateRole::BellowAir),
    StateInfo::new("gas_t_k", "K", StateRole::GasTemperature),
    StateInfo::new("creep_s_m", "m", StateRole::Force),
    StateInfo::new("dahl_f_n", "N", StateRole::Force),
    StateInfo::new("line_n_mol", "mol", StateRole::SupplyAir),
    StateInfo::new("tank_n_mol", "mol", StateRole::SupplyAir),
];

/// Where the valve's supply pressure comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SupplyMode {
    /// The logged tank pressure is an input (fitting and validating against a run).
    #[default]
    Measured,
    /// The tank is simulated: it droops while air flows and the compressor refills it
    /// (generating experiments; the input's supply pressure is ignored after the start).
    Tank,
}

/// The wall, gas and supply-line effects of the `[effects]` section, after Model 2's
/// parameters (`LEVER_MODEL_FIELDS`, under the truck's laws: usually the area stretching with
/// pressure, `kap`, and an orifice valve, `c1`, `c2`, `bcr`). Every one is declared once, in
/// `airsus_data::params`.
const EFFECT_FIELDS: &[Field] = &[
    Field::WallCreepStiffness,
    Field::WallCreepTime,
    Field::WallFrictionForce,
    Field::WallFrictionStiffness,
    Field::GasThermalTime,
    Field::LineResistance,
];

fn truck_fields() -> Vec<Field> {
    LEVER_MODEL_FIELDS
        .iter()
        .chain(EFFECT_FIELDS)
        .copied()
        .collect()
}

/// The virtual truck behind the model trait.
#[derive(Debug, Clone, PartialEq)]
pub struct TruckModel {
    /// The named parameters, kept in the virtual truck they describe.
    params: TruckParams<VirtualTruck>,
    supply: SupplyMode,
    c: Consts,
}

/// Constants precomputed from the parameters so that `rhs` only multiplies and adds.
#[derive(Debug, Clone, PartialEq)]
struct Consts {
    g: f64,
    gas_constant: f64,
    ambient_t_k: f64,
    rt: f64,
    ambient_pa: f64,
    h0_m: f64,
    l1_m: f64,
    l12_m: f64,
    l13_m: f64,
    lever_gain: f64,
    compliance: f64,
    unsprung_kg: f64,
    inertia: f64,
    tire: Tire,
    friction: f64,
    area: EffectiveAreaLaw,
    volume: GasVolumeLaw,
    valve: ValveFlowLaw,
    damper: Damper,
    e: EffectParameters,
}

impl Consts {
    fn new(truth: &VirtualTruck) -> Self {
        let p = &truth.physical;
        let g = &p.geometry;
        let env = &p.environment;
        let mut e = truth.effect_parameters.clone();
        let fx = truth.effects;
        // Switching an effect off sets it to its neutral value, so rhs has one path.
        if !fx.creep {
            e.creep_stiffness_n_per_m = 0.0;
        }
        if !fx.hysteresis {
            e.friction_force_n = 0.0;
        }
        Self {
            g: env.gravity_m_s2,
            gas_constant: env.gas_constant_j_mol_k,
            ambient_t_k: env.temperature_k,
            rt: env.gas_constant_j_mol_k * env.temperature_k,
            ambient_pa: env.ambient_pressure_pa,
            h0_m: g.h0_m,
            l1_m: g.l1_m,
            l12_m: g.l1_m + g.l2_m,
            l13_m: g.l1_m + g.l3_m,
            lever_gain: lever_gain(g.l1_m, g.l2_m),
            compliance: g.lever_compliance_m_per_n,
            unsprung_kg: p.mass.unsprung_kg,
            inertia: p.mass.lever_inertia_kg_m2,
            tire: Tire::new(&p.tire),
            friction: p.bellow.hinge_friction_n_s_per_m,
            area: p.bellow.effective_area.clone(),
            volume: p.bellow.gas_volume.clone(),
            valve: p.valve,
            damper: Damper::new(&p.damper),
            e,
        }
    }

    fn effective_area_m2(&self, h_m: f64, gauge_pa: f64) -> f64 {
        self.area.area_clamped_m2(h_m, gauge_pa)
    }

    fn sprung_kg(&self, load_kg: f64) -> f64 {
        (load_kg - self.unsprung_kg).max(MIN_SPRUNG_MASS_KG)
    }
}

impl TruckModel {
    pub fn new(mut truth: VirtualTruck, supply: SupplyMode) -> Self {
        truth.resolve_laws();
        let c = Consts::new(&truth);
        Self {
            params: TruckParams::new("truck", &truck_fields(), truth),
            supply,
            c,
        }
    }

    /// The built-in virtual truck, supply pressure from the input.
    pub fn reference() -> Self {
        Self::new(VirtualTruck::reference(), SupplyMode::Measured)
    }

    /// The `truck` model structure started from a truck file's values: its laws where it
    /// names other laws than the thesis', its `[effects]` values where it gives them, the
    /// built-in effects elsewhere (see [`VirtualTruck::resolve_laws`]), as the grey-box
    /// estimator would start it.
    pub fn from_truck_parameters(truck: &TruckParameters) -> Self {
        let mut truth = VirtualTruck::reference();
        truth.physical = truck.clone();
        Self::new(truth, SupplyMode::Measured)
    }

    pub fn truth(&self) -> &VirtualTruck {
        self.params.holder()
    }

    pub fn supply_mode(&self) -> SupplyMode {
        self.supply
    }

    /// Bellow height of state `x`, m (eq 2.2).
    pub fn bellow_height_m(&self, x: &[f64]) -> f64 {
        self.c.h0_m + self.c.l12_m * x[1].sin()
    }

    /// Tank gauge pressure in state `x`, Pa: the simulated tank in [`SupplyMode::Tank`], the
    /// input otherwise. This is what the truck's supply sensor logs.
    pub fn tank_gauge_pa(&self, x: &[f64], u: &InputSample) -> f64 {
        match self.supply {
            SupplyMode::Tank => x[9] * self.c.rt / self.c.e.tank_volume_m3 - self.c.ambient_pa,
            SupplyMode::Measured => u.supply_gauge_pa,
        }
    }

    fn gas_temperature_k(&self, x: &[f64]) -> f64 {
        if self.truth().effects.heat_exchange {
            x[5]
        } else {
            self.c.ambient_t_k
        }
    }

    /// The static equilibrium under `u` matching `ic`, with the bellow wall's friction element
    /// preloaded to `wall_friction_n` (as left by the last movement: positive after the bellow
    /// extended, negative after it was compressed). The gas then carries the static force plus
    /// that friction, so the same height shows a different pressure depending on how the
    /// truck got there — the hysteresis the thesis saw between data-sets 1–2 and 3–4.
    pub fn equilibrium_with_friction(
        &self,
        u: &InputSample,
        ic: &InitialCondition,
        wall_friction_n: f64,
    ) -> Result<Vec<f64>, ModelError> {
        let friction = if self.truth().effects.hysteresis {
            wall_friction_n.clamp(-self.c.e.friction_force_n, self.c.e.friction_force_n)
        } else {
            0.0
        };
        let c = &self.c;
        let (h_b, gauge_pa) = self.equilibrium(u, ic, friction)?;
        let sin_a = (h_b - c.h0_m) / c.l12_m;
        if !(-1.0..=1.0).contains(&sin_a) {
            return Err(ModelError::NoEquilibrium {
                model: "truck".to_owned(),
                what: format!("bellow height {:.1} mm", h_b * 1e3),
                reason: "the lever cannot reach it".to_owned(),
            });
        }
        let tire_compression = c.tire.static_compression_m(u.wheel_load_kg * c.g);
        let axle = u.road_height_m - tire_compression;
        let n = (gauge_pa + c.ambient_pa) * c.volume.volume_m3(&c.area, h_b) / c.rt;
        let supply_abs = u.supply_gauge_pa + c.ambient_pa;
        Ok(vec![
            axle + c.h0_m + c.l1_m * sin_a,
            sin_a.asin(),
            0.0,
            0.0,
            n,
            c.ambient_t_k,
            h_b,
            friction,
            supply_abs * c.e.line_volume_m3 / c.rt,
            supply_abs * c.e.tank_volume_m3 / c.rt,
        ])
    }

    /// Bellow height in static equilibrium under `u` for `ic`, and the gauge pressure there;
    /// the gas carries the static force plus `friction_n` (the Dahl force opposing it).
    fn equilibrium(
        &self,
        u: &InputSample,
        ic: &InitialCondition,
        friction_n: f64,
    ) -> Result<(f64, f64), ModelError> {
        let c = &self.c;
        let fail = |what: String, reason: String| ModelError::NoEquilibrium {
            model: "truck".to_owned(),
            what,
            reason,
        };
        let load = u.wheel_load_kg;
        if !(load.is_finite() && load > c.unsprung_kg) {
            return Err(fail(
                format!("wheel load {load} kg"),
                format!("it must exceed the unsprung mass {} kg", c.unsprung_kg),
            ));
        }
        let force = c.sprung_kg(load) * c.g / c.lever_gain + friction_n;
        let h_max = c.h0_m + c.l12_m;
        match *ic {
            InitialCondition::SensorHeight { height_m } => {
                let h = airsus_model::submodels::bellow_height_from_sensor_m(
                    c.h0_m,
                    c.lever_gain,
                    height_m,
                    c.compliance,
                    load,
                    c.g,
                );
                if !(h > 0.0 && h < h_max) {
                    return Err(fail(
                        format!("sensor height {:.1} mm", height_m * 1e3),
                        "the lever cannot reach it".to_owned(),
                    ));
                }
                match c.area.gauge_for_force_pa(h, force) {
                    Some(p) => Ok((h, p)),
                    None => Err(fail(
                        format!("sensor height {:.1} mm", height_m * 1e3),
                        "the effective area is not positive there".to_owned(),
                    )),
                }
            }
            InitialCondition::BellowPressure { gauge_pa } => {
                let what = format!("bellow pressure {:.1} kPa", gauge_pa / 1e3);
                if gauge_pa.is_nan() || gauge_pa <= 0.0 {
                    return Err(fail(
                        what,
                        "a bellow needs a positive gauge pressure".to_owned(),
                    ));
                }
                let target = |h: f64| gauge_pa * c.effective_area_m2(h, gauge_pa) - force;
                // Lowest root on the rising branch, as the thesis models do.
                if let Some(h) = first_upward_crossing_m(target, h_max, 1e-3) {
                    return Ok((h, gauge_pa));
                }
                Err(fail(
                    what,
                    "the pressure is too low to carry the load at any bellow height".to_owned(),
                ))
            }
        }
    }

    fn rebuild(&mut self) {
        self.params.holder_mut().resolve_laws();
        self.c = Consts::new(self.params.holder());
    }
}

impl SuspensionModel for TruckModel {
    fn name(&self) -> &'static str {
        "truck"
    }

    fn description(&self) -> &'static str {
        "Virtual truck: Model 2 mechanics plus bellow creep, wall friction hysteresis, gas heat exchange, ISO 6358 valve flow and supply line"
    }

    fn states(&self) -> &[StateInfo] {
        STATES
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
        let c = &self.c;
        let fx = self.truth().effects;
        let (sin_a, cos_a) = x[1].sin_cos();
        let alpha_dot = x[3];
        let h_b = c.h0_m + c.l12_m * sin_a;
        let h_b_dot = c.l12_m * cos_a * alpha_dot;
        let temperature = self.gas_temperature_k(x);
        let volume = c.volume.volume_m3(&c.area, h_b);
        let p_abs = x[4] * c.gas_constant * temperature / volume;
        let p_gauge = p_abs - c.ambient_pa;
        let creep_force = c.e.creep_stiffness_n_per_m * (x[6] - h_b);
        let bellow = p_gauge * c.effective_area_m2(h_b, p_gauge) + creep_force - x[7];

        let axle_height_m = x[0] - c.h0_m - c.l1_m * sin_a;
        let axle_velocity_m_s = x[2] - c.l1_m * cos_a * alpha_dot;
        let forces = LeverForces {
            tire_n: c.tire.force_n(
                u.road_height_m - axle_height_m,
                u.road_rate_m_s - axle_velocity_m_s,
            ),
            bellow_n: bellow,
            damper_n: c.damper.force_n(c.l13_m * cos_a * alpha_dot),
            friction_n: c.friction * c.l1_m * cos_a * alpha_dot,
        };
        let body = LeverBody {
            total_kg: c.sprung_kg(u.wheel_load_kg) + c.unsprung_kg,
            unsprung_kg: c.unsprung_kg,
            inertia_kg_m2: c.inertia,
            l1_m: c.l1_m,
            l12_m: c.l12_m,
            l13_m: c.l13_m,
            gravity_m_s2: c.g,
        };
        let (x_dd, alpha_dd) = lever_accelerations(&body, sin_a, cos_a, alpha_dot, &forces);
        dx[0] = x[2];
        dx[1] = alpha_dot;
        dx[2] = x_dd;
        dx[3] = alpha_dd;

        // Supply side: tank -> line -> valve -> bellow.
        let tank_pa = match self.supply {
            SupplyMode::Tank => x[9] * c.rt / c.e.tank_volume_m3,
            SupplyMode::Measured => u.supply_gauge_pa + c.ambient_pa,
        };
        let line_pa = if fx.supply_line {
            x[8] * c.rt / c.e.line_volume_m3
        } else {
            tank_pa
        };
        // The fill channel's check valve (no backflow) is part of every valve law.
        let fill = match u.valve {
            ValveState::Fill => c.valve.fill_flow_mol_s(line_pa, p_abs, c.ambient_t_k),
            _ => 0.0,
        };
        let exhaust = match u.valve {
            ValveState::Exhaust => c.valve.exhaust_flow_mol_s(p_abs, c.ambient_pa, temperature),
            _ => 0.0,
        };
        // The leak (zero on a sound truck) vents to ambient whatever the valve does.
        let leak = c.e.leak_conductance_mol_s_pa * p_gauge.max(0.0);
        let into_bellow = fill - exhaust - leak;
        dx[4] = into_bellow;

        dx[5] = if fx.heat_exchange {
            let dv_dh = c.volume.volume_slope_m2(&c.area, h_b);
            gas_temperature_rate(
                &GasEnergyBalance {
                    amount_mol: x[4],
                    temperature_k: temperature,
                    pressure_pa: p_abs,
                    volume_rate_m3_s: dv_dh * h_b_dot,
                    net_inflow_mol_s: into_bellow,
                    inflow_temperature_k: c.ambient_t_k,
                    wall_temperature_k: c.ambient_t_k,
                    thermal_time_constant_s: c.e.thermal_time_constant_s,
                },
                c.gas_constant,
            )
        } else {
            0.0
        };
        dx[6] = if fx.creep {
            maxwell_position_rate(h_b, x[6], c.e.creep_time_constant_s)
        } else {
            0.0
        };
        dx[7] = dahl_force_rate(
            x[7],
            h_b_dot,
            c.e.friction_stiffness_n_per_m,
            c.e.friction_force_n,
        );

        let line_inflow = if fx.supply_line {
            (tank_pa - line_pa) / c.e.line_resistance_pa_s_per_mol
        } else {
            fill
        };
        dx[8] = if fx.supply_line {
            line_inflow - fill
        } else {
            0.0
        };
        dx[9] = match self.supply {
            SupplyMode::Tank => {
                let governor = smoothstep(
                    (c.e.governor_cutout_gauge_pa - (tank_pa - c.ambient_pa))
                        / c.e.governor_band_pa,
                );
                c.e.compressor_flow_mol_s * governor - line_inflow
            }
            SupplyMode::Measured => 0.0,
        };
    }

    /// With a supply line in [`SupplyMode::Measured`], the line fills from the logged tank
    /// pressure whatever the valve does, so every change of it matters.
    fn uses_supply_while_valve_shut(&self) -> bool {
        self.supply == SupplyMode::Measured && self.truth().effects.supply_line
    }

    /// The wall friction (Dahl) follows the bellow height.
    fn hysteresis_coordinate_m(&self, x: &[f64]) -> Option<f64> {
        (self.c.e.friction_force_n > 0.0).then(|| self.bellow_height_m(x))
    }

    fn hysteresis_states(&self) -> &[usize] {
        &[DAHL_STATE]
    }

    fn follow_hysteresis(&self, x: &mut [f64], displacement_m: f64) {
        x[DAHL_STATE] = dahl_force_after_displacement(
            x[DAHL_STATE],
            displacement_m,
            self.c.e.friction_stiffness_n_per_m,
            self.c.e.friction_force_n,
        );
    }

    fn output(&self, x: &[f64], u: &InputSample) -> OutputSample {
        let c = &self.c;
        let h_b = self.bellow_height_m(x);
        let p_abs =
            x[4] * c.gas_constant * self.gas_temperature_k(x) / c.volume.volume_m3(&c.area, h_b);
        OutputSample {
            sensor_height_m: sensor_height_m(
                c.h0_m,
                c.lever_gain,
                h_b,
                c.compliance,
                u.wheel_load_kg,
                c.g,
            ),
            bellow_gauge_pa: p_abs - c.ambient_pa,
        }
    }

    fn initial_state(
        &self,
        u: &InputSample,
        ic: &InitialCondition,
    ) -> Result<Vec<f64>, ModelError> {
        self.equilibrium_with_friction(u, ic, 0.0)
    }

    fn initial_state_with_hysteresis(
        &self,
        u: &InputSample,
        ic: &InitialCondition,
        preload: f64,
    ) -> Result<Vec<f64>, ModelError> {
        self.equilibrium_with_friction(u, ic, preload.clamp(-1.0, 1.0) * self.c.e.friction_force_n)
    }
}
