//! Level controllers for the 3-state valve: the virtual truck's ECU (`airsus_truck::ecu`:
//! the valve guard, the height filter, the deadband controller; re-exported here) and the
//! model-based controller.
//!
//! [`PredictiveController`]: model-based pulse length; once a correction has started it
//! follows up with further computed pulses until the error is inside a narrow inner band. From
//! the filtered readings and the static law it computes the load, the amount of air in the
//! circuit now (`n = p V(h_b) / RT`) and at the target height
//! (`p* = (m_tot - m2) g / (k_l A_eff(h_b*))`, `n* = p*_abs V(h_b*) / RT`), and opens for
//! `τ = γ (n* - n) / ṅ`, with the model's valve flow `ṅ = (p_supply - p̄)/R_flow1` (fill) or
//! `(p̄ - p_amb)/R_flow2` (exhaust) at the mean `p̄` of the current and target pressures (or
//! the truck's orifice law), a fill fed through the supply line's resistance in series;
//! `γ ≤ 1` under-corrects on purpose (the flow law and the gas temperature are uncertain: an
//! overshoot costs a reversal, an undershoot only a second pulse in the same direction). It
//! shares the deadband controller's guard and measurement path.

use airsus_data::{GasVolumeLaw, TruckParameters, ValveFlowLaw, ValveState};
use airsus_truck::ecu::{
    DRIVING_INNER_BAND_SHARE_FACTOR, INNER_BAND_M, INNER_BAND_SHARE_FACTOR, MARGIN_SHARE_OF_BAND,
};
pub use airsus_truck::ecu::{
    DRIVING_SPEED_M_S, DeadbandController, GuardSettings, HeightFilter, LevelController, Reading,
    ValveGuard,
};

use crate::weigh::StaticLaw;

/// What the predictive controller knows of the truck: the static law, the gas-volume law and
/// the valve law (nominal or identified parameters).
#[derive(Debug, Clone, PartialEq)]
pub struct ValveModel {
    pub law: StaticLaw,
    pub volume: GasVolumeLaw,
    pub valve: ValveFlowLaw,
    /// The gas and supply air temperature, K, and `R T`, J/mol.
    pub temperature_k: f64,
    pub rt_j_mol: f64,
    pub ambient_pa: f64,
    /// The supply line's resistance between the measured tank and the valve, Pa s/mol
    /// (SPEC §1: the tank's pressure is not the valve's while air flows); 0: none.
    pub line_resistance_pa_s_per_mol: f64,
}

impl ValveModel {
    /// The model of `truck`'s file. The supply line's resistance is the file's `[effects]
    /// line_resistance_pa_s_per_mol` (what a study estimates as `rline`), or where the file
    /// names none, the `truck` structure's built-in value: what that structure would simulate
    /// the file with.
    pub fn from_truck(truck: &TruckParameters) -> Self {
        let line =
            airsus_truck::truth::EffectParameters::of_file(truck).line_resistance_pa_s_per_mol;
        Self {
            law: StaticLaw::from_truck(truck),
            volume: truck.bellow.gas_volume.clone(),
            valve: truck.valve,
            temperature_k: truck.environment.temperature_k,
            rt_j_mol: truck.environment.gas_constant_j_mol_k * truck.environment.temperature_k,
            ambient_pa: truck.environment.ambient_pressure_pa,
            line_resistance_pa_s_per_mol: line,
        }
    }

    /// The steady fill flow through the supply line and the valve in series, mol/s: the flow
    /// `ṅ` for which the valve, fed at `p_supply - ṅ R_line`, passes `ṅ` into the bellow at
    /// `bellow_abs_pa`. The valve's flow falls as its inlet pressure falls, so `ṅ - q(p_s - ṅ
    /// R)` rises with `ṅ` from `-q(p_s)` at 0: bisection (hand-written: a monotone scalar root
    /// between known brackets, 60 halvings to round-off).
    fn fill_flow_through_line_mol_s(&self, bellow_abs_pa: f64, supply_abs_pa: f64) -> f64 {
        let valve = |inlet_abs_pa: f64| {
            self.valve.flow_mol_s(
                ValveState::Fill,
                bellow_abs_pa,
                inlet_abs_pa,
                self.ambient_pa,
                self.temperature_k,
            )
        };
        let unrestricted = valve(supply_abs_pa);
        let line = self.line_resistance_pa_s_per_mol;
        if !(line > 0.0 && unrestricted > 0.0) {
            return unrestricted;
        }
        let (mut low, mut high) = (0.0, unrestricted);
        for _ in 0..60 {
            let mid = 0.5 * (low + high);
            if mid - valve(supply_abs_pa - mid * line) < 0.0 {
                low = mid;
            } else {
                high = mid;
            }
        }
        0.5 * (low + high)
    }

    /// The valve opening that moves the sensor height from `reading` to `target_m` at the
    /// current load: direction and duration, s (module docs, without the gain `γ`). `None`
    /// when the readings admit no static solution or the supply cannot fill.
    pub fn pulse(&self, reading: &Reading, target_m: f64) -> Option<(ValveState, f64)> {
        let law = &self.law;
        let load = law
            .wheel_load_kg(reading.sensor_height_m, reading.bellow_gauge_pa)
            .ok()?;
        let h_now = law.bellow_height_m(reading.sensor_height_m, load);
        let h_target = law.bellow_height_m(target_m, load);
        let area_target = law.effective_area_m2(h_target, reading.bellow_gauge_pa);
        if area_target <= 0.0 {
            return None;
        }
        let p_target = (load - law.unsprung_kg) * law.gravity_m_s2 / (law.lever_gain * area_target);
        let amount = |gauge: f64, h: f64| {
            (gauge + self.ambient_pa) * self.volume.volume_m3(&law.area, h) / self.rt_j_mol
        };
        let dn = amount(p_target, h_target) - amount(reading.bellow_gauge_pa, h_now);
        let p_mean_abs = 0.5 * (p_target + reading.bellow_gauge_pa) + self.ambient_pa;
        let direction = if dn > 0.0 {
            ValveState::Fill
        } else {
            ValveState::Exhaust
        };
        // The flow at the mean pressure of the pulse, by the truck's valve law, a fill fed
        // through the supply line.
        let supply_abs_pa = reading.supply_gauge_pa + self.ambient_pa;
        let flow = match direction {
            ValveState::Fill => self.fill_flow_through_line_mol_s(p_mean_abs, supply_abs_pa),
            _ => self.valve.flow_mol_s(
                direction,
                p_mean_abs,
                supply_abs_pa,
                self.ambient_pa,
                self.temperature_k,
            ),
        };
        if !(flow.is_finite() && flow != 0.0 && flow.signum() == dn.signum()) {
            return None;
        }
        let duration = dn / flow;
        duration.is_finite().then_some((direction, duration))
    }
}

/// Model-based pulse length (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct PredictiveController {
    pub settings: GuardSettings,
    pub model: ValveModel,
    /// `γ`: fraction of the computed pulse that is applied.
    pub gain: f64,
    /// Longest single pulse, s.
    pub max_pulse_s: f64,
    /// Once a correction has started, further pulses follow (after `follow_up_wait_s`) until the
    /// error is within this inner band, m: the under-correcting gain converges in two or three
    /// pulses instead of leaving the height anywhere in the tolerance band. Standing.
    pub inner_band_m: f64,
    /// The inner band while driving, m: wider, because the filtered height still swings with
    /// the road and follow-ups would chase it.
    pub driving_inner_band_m: f64,
    /// Wait after a pulse before the next follow-up decision, s (the body and gas settle).
    pub follow_up_wait_s: f64,
    active: bool,
    last_pulse_end_s: f64,
    guard: ValveGuard,
    filter: HeightFilter,
    pressure_filter: HeightFilter,
    /// End time of the pulse in progress.
    pulse_end_s: Option<f64>,
}

impl PredictiveController {
    pub fn new(settings: GuardSettings, model: ValveModel) -> Self {
        Self {
            gain: 0.85,
            max_pulse_s: 30.0,
            // Inside the tolerance band whatever its width (see `DeadbandController::new`),
            // with room for the drift after a pulse: the gas cools and the bellow creeps for a
            // minute after a fill, 1-2 mm on variants 1-3. At 1.5 times the share (1.5 mm of a
            // ±2 mm band), a controller designed on variant 0's study estimate stopped its
            // follow-ups 1.5 mm under the target on variant 2 and drifted out of the band.
            inner_band_m: INNER_BAND_M
                .min(INNER_BAND_SHARE_FACTOR * MARGIN_SHARE_OF_BAND * settings.tolerance_m),
            // As narrow while driving, the controller opened 5 times in 200 s of class C road
            // on variant 2 (3 at most at 1.5 times the share).
            driving_inner_band_m: INNER_BAND_M
                .min(DRIVING_INNER_BAND_SHARE_FACTOR * MARGIN_SHARE_OF_BAND * settings.tolerance_m),
            follow_up_wait_s: 3.0,
            active: false,
            last_pulse_end_s: f64::NEG_INFINITY,
            guard: ValveGuard::new(settings.clone()),
            filter: HeightFilter::new(settings.filter_time_constant_s),
            pressure_filter: HeightFilter::new(settings.filter_time_constant_s),
            pulse_end_s: None,
            settings,
            model,
        }
    }
}

impl LevelController for PredictiveController {
    fn name(&self) -> &'static str {
        "predictive"
    }

    fn update(&mut self, t_s: f64, target_m: f64, reading: &Reading) -> ValveState {
        let s = self.settings.clone();
        let h = self
            .filter
            .update_at(t_s, reading.sensor_height_m, &s, reading.speed_m_s);
        let p = self
            .pressure_filter
            .update_at(t_s, reading.bellow_gauge_pa, &s, reading.speed_m_s);
        let error = target_m - h;
        let debounce_s = s.filter_and_debounce_s(reading.speed_m_s).1;
        let outside = self
            .filter
            .outside_for(t_s, error, s.tolerance_m, debounce_s);
        let inner_band_m = if reading.speed_m_s > DRIVING_SPEED_M_S {
            self.driving_inner_band_m
        } else {
            self.inner_band_m
        };
        if error.abs() <= inner_band_m {
            self.active = false;
        }
        let follow_up = self.active
            && error.abs() > inner_band_m
            && t_s - self.last_pulse_end_s + 1e-9 >= self.follow_up_wait_s;
        let requested = match (self.guard.state(), self.pulse_end_s) {
            (ValveState::Closed, _) if outside || follow_up => {
                let filtered = Reading {
                    sensor_height_m: h,
                    bellow_gauge_pa: p,
                    ..*reading
                };
                let (direction, duration) = self.model.pulse(&filtered, target_m).unwrap_or((
                    // No model answer: fall back to a minimum pulse in the right direction.
                    if error > 0.0 {
                        ValveState::Fill
                    } else {
                        ValveState::Exhaust
                    },
                    s.min_on_s,
                ));
                if self.guard.may_open(t_s + 1e-9, direction) {
                    let length = (self.gain * duration).clamp(s.min_on_s, self.max_pulse_s);
                    self.pulse_end_s = Some(t_s + length);
                    self.active = true;
                    direction
                } else {
                    ValveState::Closed
                }
            }
            (ValveState::Closed, _) => ValveState::Closed,
            (open, Some(end)) if t_s + 1e-9 < end => open,
            _ => {
                self.pulse_end_s = None;
                self.last_pulse_end_s = t_s;
                ValveState::Closed
            }
        };
        self.guard.apply(t_s, requested)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fill_through_the_supply_line_flows_as_the_series_resistance_says() {
        let mut truck = TruckParameters::reference();
        let (r_fill, r_line) = (2.5e6, 4e5);
        truck.valve = ValveFlowLaw::LinearResistance {
            fill_pa_s_per_mol: r_fill,
            exhaust_pa_s_per_mol: 1e6,
        };
        let mut model = ValveModel::from_truck(&truck);
        // The reference file names no line: the `truck` structure's built-in one; a file
        // that names one gets its own.
        assert_eq!(model.line_resistance_pa_s_per_mol, r_line);
        let mut named = truck.clone();
        assert!(airsus_data::params::set(
            &mut named,
            airsus_data::params::Field::LineResistance,
            3e5
        ));
        assert_eq!(
            ValveModel::from_truck(&named).line_resistance_pa_s_per_mol,
            3e5
        );
        let (bellow, supply) = (450e3, 900e3);
        let series = model.fill_flow_through_line_mol_s(bellow, supply);
        let expected = (supply - bellow) / (r_fill + r_line);
        assert!(
            (series / expected - 1.0).abs() < 1e-9,
            "{series} against {expected}"
        );
        model.line_resistance_pa_s_per_mol = 0.0;
        let direct = model.fill_flow_through_line_mol_s(bellow, supply);
        assert!((direct / ((supply - bellow) / r_fill) - 1.0).abs() < 1e-12);
        // A fill pulse lasts as much longer as the line takes off the flow.
        let reading = Reading {
            sensor_height_m: 0.230,
            bellow_gauge_pa: 350e3,
            supply_gauge_pa: 800e3,
            speed_m_s: 0.0,
        };
        let (_, without_line) = model.pulse(&reading, 0.240).unwrap();
        model.line_resistance_pa_s_per_mol = r_line;
        let (direction, with_line) = model.pulse(&reading, 0.240).unwrap();
        assert_eq!(direction, ValveState::Fill);
        assert!(
            (with_line / without_line - (r_fill + r_line) / r_fill).abs() < 1e-9,
            "{with_line} s against {without_line} s"
        );
    }
}
