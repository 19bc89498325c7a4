//! The physics shared by the lumped models: one suspension corner's constants, precomputed
//! from [`TruckParameters`] so that the right-hand sides only multiply and add, and the static
//! equilibrium solver every model's `initial_state` uses.

use airsus_data::{EffectiveAreaLaw, GasVolumeLaw, TruckParameters, ValveFlowLaw};

use crate::model::{InitialCondition, InputSample, ModelError};
use crate::submodels::{
    Damper, Tire, air_amount_mol, first_upward_crossing_m, lever_gain, pressure_abs_pa,
    sensor_height_m,
};

/// Smallest sprung mass a model uses, kg. A wheel load below the unsprung mass (a wheel
/// lifted off the scale, or bad data) leaves no sprung mass; flooring it keeps the mass
/// matrices invertible instead of dividing by zero.
pub const MIN_SPRUNG_MASS_KG: f64 = 1.0;

/// Height step of the equilibrium search grid, m.
const SEARCH_STEP_M: f64 = 1e-3;

/// Precomputed constants of one corner (SI units).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Corner {
    pub gravity_m_s2: f64,
    /// `R T`, J/mol (isothermal gas, thesis 3.1.3).
    pub rt_j_mol: f64,
    /// `T`, K: the gas and the supply air are at ambient temperature (thesis 3.1.3).
    pub temperature_k: f64,
    pub ambient_pa: f64,
    pub h0_m: f64,
    pub l1_m: f64,
    /// `l1 + l2`: hinge to bellow, m.
    pub l12_m: f64,
    /// `l1 + l3`: hinge to damper, m.
    pub l13_m: f64,
    /// `k_l = (l1 + l2)/l1`.
    pub lever_gain: f64,
    /// `k_d = (l1 + l3)/l1`: damper stroke per unit of axle stroke (rigid lever).
    pub damper_gain: f64,
    pub lever_compliance_m_per_n: f64,
    pub unsprung_kg: f64,
    pub lever_inertia_kg_m2: f64,
    pub tire: Tire,
    pub friction_n_s_per_m: f64,
    pub area: EffectiveAreaLaw,
    pub volume: GasVolumeLaw,
    pub valve: ValveFlowLaw,
    /// The supply line between the logged tank and the valve, when the file names one.
    pub supply_line: Option<SupplyLine>,
    pub damper: Damper,
}

/// A supply line between the logged tank and the valve (SPEC §1: the tank's pressure is not
/// the valve's while air flows): a volume at ambient temperature that fills from the tank
/// through a resistance and drains into the bellow through the valve's fill channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SupplyLine {
    /// `rline`, Pa s/mol (linear: the line's flow is laminar).
    pub resistance_pa_s_per_mol: f64,
    pub volume_m3: f64,
}

/// The air flows of a corner's valve circuit, mol/s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct AirFlows {
    /// Into the bellow (out of it while exhausting).
    pub bellow_mol_s: f64,
    /// Into the supply line (0 without one).
    pub line_mol_s: f64,
}

/// The state of a supply line's air, appended last to a model's states when the file names
/// a line.
pub(crate) const SUPPLY_LINE_STATE: crate::model::StateInfo =
    crate::model::StateInfo::new("line_n_mol", "mol", crate::model::StateRole::SupplyAir);

/// The static equilibrium of a corner under one input sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Equilibrium {
    pub bellow_height_m: f64,
    pub amount_mol: f64,
    /// Tire compression carrying the whole wheel load, m.
    pub tire_compression_m: f64,
    pub bellow_gauge_pa: f64,
}

impl Corner {
    pub fn new(truck: &TruckParameters) -> Self {
        let g = &truck.geometry;
        Self {
            gravity_m_s2: truck.environment.gravity_m_s2,
            rt_j_mol: truck.environment.gas_constant_j_mol_k * truck.environment.temperature_k,
            temperature_k: truck.environment.temperature_k,
            ambient_pa: truck.environment.ambient_pressure_pa,
            h0_m: g.h0_m,
            l1_m: g.l1_m,
            l12_m: g.l1_m + g.l2_m,
            l13_m: g.l1_m + g.l3_m,
            lever_gain: lever_gain(g.l1_m, g.l2_m),
            damper_gain: (g.l1_m + g.l3_m) / g.l1_m,
            lever_compliance_m_per_n: g.lever_compliance_m_per_n,
            unsprung_kg: truck.mass.unsprung_kg,
            lever_inertia_kg_m2: truck.mass.lever_inertia_kg_m2,
            tire: Tire::new(&truck.tire),
            friction_n_s_per_m: truck.bellow.hinge_friction_n_s_per_m,
            area: truck.bellow.effective_area.clone(),
            volume: truck.bellow.gas_volume.clone(),
            valve: truck.valve,
            supply_line: truck.effects.line_resistance_pa_s_per_mol.map(
                |resistance_pa_s_per_mol| SupplyLine {
                    resistance_pa_s_per_mol,
                    volume_m3: airsus_data::SUPPLY_LINE_VOLUME_M3,
                },
            ),
            damper: Damper::new(&truck.damper),
        }
    }

    /// Masses and lengths for [`crate::mechanics::lever_accelerations`] under a wheel load.
    pub fn lever_body(&self, wheel_load_kg: f64) -> crate::mechanics::LeverBody {
        crate::mechanics::LeverBody {
            total_kg: self.sprung_kg(wheel_load_kg) + self.unsprung_kg,
            unsprung_kg: self.unsprung_kg,
            inertia_kg_m2: self.lever_inertia_kg_m2,
            l1_m: self.l1_m,
            l12_m: self.l12_m,
            l13_m: self.l13_m,
            gravity_m_s2: self.gravity_m_s2,
        }
    }

    /// Sprung mass `m1 = m_tot - m2` (thesis eq 3.1), floored at [`MIN_SPRUNG_MASS_KG`].
    pub fn sprung_kg(&self, wheel_load_kg: f64) -> f64 {
        (wheel_load_kg - self.unsprung_kg).max(MIN_SPRUNG_MASS_KG)
    }

    /// Absolute bellow pressure, Pa, for `n` mol at bellow height `h` (eq 3.17, 5.1).
    pub fn pressure_abs_pa(&self, bellow_height_m: f64, amount_mol: f64) -> f64 {
        pressure_abs_pa(
            amount_mol,
            1.0,
            self.rt_j_mol,
            self.volume.volume_m3(&self.area, bellow_height_m),
        )
    }

    /// Bellow force, N (eq 3.16), and absolute pressure, Pa. The effective area is held
    /// constant outside [`crate::submodels::EFFECTIVE_AREA_RANGE_M`] (see
    /// [`EffectiveAreaLaw::area_clamped_m2`]).
    pub fn bellow_force_n(&self, bellow_height_m: f64, amount_mol: f64) -> (f64, f64) {
        let p_abs = self.pressure_abs_pa(bellow_height_m, amount_mol);
        let gauge = p_abs - self.ambient_pa;
        (
            gauge * self.area.area_clamped_m2(bellow_height_m, gauge),
            p_abs,
        )
    }

    /// Valve air flow into the circuit, mol/s (eq 3.19 or the truck file's valve law), the
    /// supply air and the bellow gas at ambient temperature.
    pub fn air_flow_mol_s(&self, bellow_abs_pa: f64, u: &InputSample) -> f64 {
        self.valve.flow_mol_s(
            u.valve,
            bellow_abs_pa,
            u.supply_gauge_pa + self.ambient_pa,
            self.ambient_pa,
            self.temperature_k,
        )
    }

    /// The valve circuit's flows (eq 3.19 or the truck file's valve law) with the bellow at
    /// `bellow_abs_pa` and, with a supply line, `line_mol` in it: the fill channel then draws
    /// from the line, which refills from the logged tank through `rline`. Without a line,
    /// [`Self::air_flow_mol_s`]. The supply air is at ambient temperature.
    pub fn air_flows(
        &self,
        bellow_abs_pa: f64,
        line_mol: Option<f64>,
        u: &InputSample,
    ) -> AirFlows {
        let tank_abs_pa = u.supply_gauge_pa + self.ambient_pa;
        let (Some(line), Some(line_mol)) = (self.supply_line, line_mol) else {
            return AirFlows {
                bellow_mol_s: self.air_flow_mol_s(bellow_abs_pa, u),
                line_mol_s: 0.0,
            };
        };
        let line_abs_pa = line_mol * self.rt_j_mol / line.volume_m3;
        let bellow_mol_s = self.valve.flow_mol_s(
            u.valve,
            bellow_abs_pa,
            line_abs_pa,
            self.ambient_pa,
            self.temperature_k,
        );
        let drawn_mol_s = if u.valve == airsus_data::ValveState::Fill {
            bellow_mol_s
        } else {
            0.0
        };
        AirFlows {
            bellow_mol_s,
            line_mol_s: (tank_abs_pa - line_abs_pa) / line.resistance_pa_s_per_mol - drawn_mol_s,
        }
    }

    /// Writes the line's rate of `flows` into its entry of `dx`, the last
    /// ([`SUPPLY_LINE_STATE`]); nothing without a line.
    pub fn set_line_rate(&self, dx: &mut [f64], flows: AirFlows) {
        if self.supply_line.is_some()
            && let Some(line) = dx.last_mut()
        {
            *line = flows.line_mol_s;
        }
    }

    /// The supply line's air in state `x`, mol: its last entry ([`SUPPLY_LINE_STATE`]);
    /// `None` without a line.
    pub fn line_mol(&self, x: &[f64]) -> Option<f64> {
        self.supply_line.and(x.last().copied())
    }

    /// `states` with the supply line's state appended when the corner has a line.
    pub fn with_line_state(
        &self,
        mut states: Vec<crate::model::StateInfo>,
    ) -> Vec<crate::model::StateInfo> {
        if self.supply_line.is_some() {
            states.push(SUPPLY_LINE_STATE);
        }
        states
    }

    /// The supply line's air at rest under `u` (at the logged tank's pressure), mol; `None`
    /// without a line.
    pub fn line_amount_at_rest_mol(&self, u: &InputSample) -> Option<f64> {
        self.supply_line
            .map(|line| (u.supply_gauge_pa + self.ambient_pa) * line.volume_m3 / self.rt_j_mol)
    }

    /// The sensor reading for a bellow height (SPEC §1).
    pub fn sensor_height_m(&self, bellow_height_m: f64, wheel_load_kg: f64) -> f64 {
        sensor_height_m(
            self.h0_m,
            self.lever_gain,
            bellow_height_m,
            self.lever_compliance_m_per_n,
            wheel_load_kg,
            self.gravity_m_s2,
        )
    }

    /// Both measured quantities for a bellow height and amount of air (SPEC §1 output map,
    /// eq 3.17).
    pub fn outputs(
        &self,
        bellow_height_m: f64,
        amount_mol: f64,
        wheel_load_kg: f64,
    ) -> crate::model::OutputSample {
        crate::model::OutputSample {
            sensor_height_m: self.sensor_height_m(bellow_height_m, wheel_load_kg),
            bellow_gauge_pa: self.pressure_abs_pa(bellow_height_m, amount_mol) - self.ambient_pa,
        }
    }

    /// The bellow height the sensor reading implies (SPEC §1 inverted).
    pub fn bellow_height_from_sensor_m(&self, sensor_height_m: f64, wheel_load_kg: f64) -> f64 {
        crate::submodels::bellow_height_from_sensor_m(
            self.h0_m,
            self.lever_gain,
            sensor_height_m,
            self.lever_compliance_m_per_n,
            wheel_load_kg,
            self.gravity_m_s2,
        )
    }

    /// Highest bellow height the lever geometry allows: lever hanging vertically, m.
    pub fn max_bellow_height_m(&self) -> f64 {
        self.h0_m + self.l12_m
    }

    /// The bellow force that carries the sprung mass in statics: torque balance about the
    /// hinge with the tire carrying `m_tot g` (thesis eq 3.11 with α̈ = 0; the `cos α` of every
    /// vertical force cancels): `F_ab (l1 + l2) = (m_tot g - m2 g) l1`, i.e. `F_ab = m1 g / k_l`.
    pub fn static_bellow_force_n(&self, wheel_load_kg: f64) -> f64 {
        self.sprung_kg(wheel_load_kg) * self.gravity_m_s2 / self.lever_gain
    }

    /// Static equilibrium under `u`, matched to the measured pressure or sensor height.
    ///
    /// * Pressure given: solve `p_gauge A_eff(h) = m1 g / k_l` for the bellow height `h`. The
    ///   effective area is not monotonic (eq 5.4 peaks near 0.33 m and is flat from 0.28 to
    ///   0.5 m), so there can be two solutions; we take the lowest one on the rising branch
    ///   (`dA_eff/dh > 0`), scanning from the lowest height with positive area up to the lever's
    ///   geometric limit. The flat top also means the pressure pins the height down poorly near
    ///   the peak: prefer [`InitialCondition::SensorHeight`] when the height was measured.
    /// * Sensor height given: the bellow height follows from the output map, the pressure from
    ///   the force balance.
    ///
    /// Then `n = p_abs V(h) / (R T)` (eq 3.18).
    pub fn equilibrium(
        &self,
        model: &str,
        u: &InputSample,
        ic: &InitialCondition,
    ) -> Result<Equilibrium, ModelError> {
        let fail = |what: String, reason: String| ModelError::NoEquilibrium {
            model: model.to_owned(),
            what,
            reason,
        };
        let load = u.wheel_load_kg;
        if !(load.is_finite() && load > self.unsprung_kg) {
            return Err(fail(
                format!("wheel load {load} kg"),
                format!(
                    "the wheel load must exceed the unsprung mass m2 = {} kg, or the bellow carries nothing",
                    self.unsprung_kg
                ),
            ));
        }
        let force_n = self.static_bellow_force_n(load);
        let (bellow_height_m, gauge_pa) = match *ic {
            InitialCondition::BellowPressure { gauge_pa } => {
                let what = format!(
                    "bellow pressure {:.1} kPa gauge and wheel load {load} kg",
                    gauge_pa / 1e3
                );
                if !(gauge_pa.is_finite() && gauge_pa > 0.0) {
                    return Err(fail(
                        what,
                        "a bellow needs a positive gauge pressure to carry a load".to_owned(),
                    ));
                }
                let target_m2 = force_n / gauge_pa;
                let h = self.rising_root(target_m2, gauge_pa).ok_or_else(|| {
                    let (h_max, a_max) = self.max_effective_area(gauge_pa);
                    fail(
                        what,
                        format!(
                            "the pressure is too low to carry the load: it needs an effective area of {target_m2:.5} m², the bellow offers at most {a_max:.5} m² (at {:.0} mm), i.e. it carries at most {:.0} N < {force_n:.0} N",
                            h_max * 1e3,
                            a_max * gauge_pa
                        ),
                    )
                })?;
                (h, gauge_pa)
            }
            InitialCondition::SensorHeight { height_m } => {
                let h = self.bellow_height_from_sensor_m(height_m, load);
                let what = format!(
                    "sensor height {:.1} mm and wheel load {load} kg",
                    height_m * 1e3
                );
                if !(h.is_finite() && h > 0.0 && h < self.max_bellow_height_m()) {
                    return Err(fail(
                        what,
                        format!(
                            "it implies a bellow height of {:.1} mm, outside the lever's range 0 to {:.1} mm",
                            h * 1e3,
                            self.max_bellow_height_m() * 1e3
                        ),
                    ));
                }
                let Some(gauge_pa) = self.area.gauge_for_force_pa(h, force_n) else {
                    return Err(fail(
                        what,
                        format!(
                            "the effective area is {:.5} m² at bellow height {:.1} mm",
                            self.area.area_clamped_m2(h, 0.0),
                            h * 1e3
                        ),
                    ));
                };
                (h, gauge_pa)
            }
        };
        let p_abs = gauge_pa + self.ambient_pa;
        let volume = self.volume.volume_m3(&self.area, bellow_height_m);
        Ok(Equilibrium {
            bellow_height_m,
            amount_mol: air_amount_mol(p_abs, volume, 1.0, self.rt_j_mol),
            tire_compression_m: self.tire.static_compression_m(load * self.gravity_m_s2),
            bellow_gauge_pa: gauge_pa,
        })
    }

    /// Lowest `h` in (0, max] with `A_eff(h, p) = target` and `A_eff` rising there.
    fn rising_root(&self, target_m2: f64, gauge_pa: f64) -> Option<f64> {
        first_upward_crossing_m(
            |h| self.area.area_clamped_m2(h, gauge_pa) - target_m2,
            self.max_bellow_height_m(),
            SEARCH_STEP_M,
        )
    }

    /// Largest effective area over the lever's range and where it occurs (for error messages).
    fn max_effective_area(&self, gauge_pa: f64) -> (f64, f64) {
        let n = (self.max_bellow_height_m() / SEARCH_STEP_M) as usize;
        (1..=n)
            .map(|i| {
                let h = i as f64 * SEARCH_STEP_M;
                (h, self.area.area_clamped_m2(h, gauge_pa))
            })
            .fold((0.0, f64::NEG_INFINITY), |best, x| {
                if x.1 > best.1 { x } else { best }
            })
    }
}
