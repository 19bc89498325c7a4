//! Static axle-load estimation: the force balance of one corner inverted for the wheel load.
//!
//! # The balance
//! In statics the bellow carries the sprung mass through the lever (thesis eq 3.11 with
//! `α̈ = 0`; the model crate's `Corner::static_bellow_force_n`):
//! ```text
//! F_ab(h_b, p) = p A_eff(h_b, p) = (m_tot - m2) g / k_l
//! A_eff(h_b, p) = A_poly(h_b) (1 + κ p / 100 kPa)           (κ = 0 in the thesis structure)
//! h_b(h_s, m_tot) = h0 + k_l (h_s + k_scl m_tot g - h0)      (SPEC §1 output map inverted)
//! ```
//! with `p` the measured bellow gauge pressure and `h_s` the measured sensor height. The
//! bellow height depends on the unknown load through the leaf-spring flex `k_scl`, so the load
//! solves the scalar fixed point
//! ```text
//! m_tot = m2 + k_l p A_eff(h_b(h_s, m_tot), p) / g.
//! ```
//! Its contraction factor is `|p A_eff' k_l² k_scl|` ≈ 0.015 on the reference truck (the area
//! is flat over the stroke), so plain iteration converges to 1e-9 kg in a handful of steps.
//!
//! # Uncertainty (first order, independent sources)
//! `σ_m² = Σ_i (∂m/∂θ_i σ_i)²`, the sensitivities by central differences of the solved load:
//! - pressure: white noise `σ_p` plus quantisation `q_p² / 12` (uniform rounding error);
//! - height: likewise `σ_h`, `q_h`;
//! - parameters: the relative error of the effective area (the lab force-map fit), of the
//!   lever gain, of the lever compliance, and the absolute error of the unsprung mass;
//! - the bellow wall's sliding friction `F_c`: the same height and load can stand at any bellow
//!   force within `±F_c` of the gas force (hysteresis, thesis 6.1); a uniform error on that
//!   band has `σ = F_c / √3`, i.e. `σ_m = k_l F_c / (g √3)` at the wheel.
//!
//! Averaging `N` samples divides the measurement part by `√N` (white noise, the quantisation
//! dithered by it); the parameter part does not average out. Both are reported.
//!
//! # The bellow wall (quasi-static)
//! A truck file of the `truck` structure (one whose `[effects]` name `kc`, `tc`, `fc` and
//! `kdahl`, [`WallForces::of_file`]) also says what the bellow wall holds beside the gas: `F = p A_eff + k_c (s − h_b) − F_dahl` (the structure's
//! bellow force, [`airsus_truck::model`]). At rest both wall forces are history, not noise: the
//! Maxwell creep still relaxes minutes after the bellow moved (`ds/dt = (h_b − s)/τ_c`), and
//! the Dahl friction stays where the last movement slid it. [`WallForces::series`] runs both
//! laws over the measured heights, so the load at a standstill 30 s after a load step is read
//! without the 0.5-1 % the relaxing creep puts on the gas pressure (variant 1's study file).

use airsus_data::{EffectiveAreaLaw, TruckParameters};
use airsus_model::submodels::lever_gain;
use airsus_truck::truth::{EffectParameters, VirtualTruck};

use crate::weigh::ekf::{HYSTERESIS_PLAY_M, HysteresisStart, KNOWN_START_SPREAD};
use crate::weigh::standstill::friction_state_from;

use crate::error::AppError;

/// The static law of one corner, SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct StaticLaw {
    pub gravity_m_s2: f64,
    pub h0_m: f64,
    /// `k_l = (l1 + l2) / l1`.
    pub lever_gain: f64,
    /// Highest bellow height the lever reaches, `h0 + l1 + l2`, m.
    pub max_bellow_height_m: f64,
    /// `k_scl`, m/N.
    pub lever_compliance_m_per_n: f64,
    /// `m2`, kg.
    pub unsprung_kg: f64,
    /// The effective-area law: eq 5.4 in the thesis structure, or the truck file's (the
    /// virtual truck's stretches with pressure, κ = 0.004).
    pub area: EffectiveAreaLaw,
    /// The bellow wall's creep and friction (module docs), when the file gives them; `None`:
    /// the gas carries the whole load (the thesis' static balance).
    pub wall: Option<WallForces>,
}

/// The `truck` structure's bellow-wall laws, SI units: the Maxwell creep element and the Dahl
/// friction (the file's `[effects]`: `kc`, `tc`, `fc`, `kdahl`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallForces {
    pub creep_stiffness_n_per_m: f64,
    pub creep_time_constant_s: f64,
    pub friction_force_n: f64,
    pub friction_stiffness_n_per_m: f64,
    /// The bellow-height play the friction is driven through, m: the height sensor's noise
    /// (0.15 mm, a lever gain of about 1.6 onto the bellow) would otherwise wear the friction
    /// away at rest. The EKF's [`super::EkfTuning::hysteresis_play_m`] for the same reason.
    pub friction_play_m: f64,
}

impl WallForces {
    /// The wall of a truck file of the `truck` structure: one that names its four wall
    /// values, `kc`, `tc`, `fc` and `kdahl` (a `truck` study writes all of them, and
    /// `generate`'s `truth/truck_structure.toml`). `None` otherwise: the gas carries the
    /// whole load. A thesis model's file can carry `fc` alone (the study's lab stage writes
    /// the wall friction it reads into the start every model shares; `airsus fit
    /// wall-friction` writes `fc` and `kdahl`), and its model never estimated a creep: the
    /// structure's built-in one would be a guess.
    pub fn of_file(truck: &TruckParameters) -> Option<Self> {
        let e = &truck.effects;
        let named = [
            e.creep_stiffness_n_per_m,
            e.creep_time_constant_s,
            e.friction_force_n,
            e.friction_stiffness_n_per_m,
        ];
        named
            .iter()
            .all(Option::is_some)
            .then(|| Self::of_effects(&EffectParameters::of_file(truck), true, true))
    }

    fn of_effects(e: &EffectParameters, creep: bool, friction: bool) -> Self {
        Self {
            creep_stiffness_n_per_m: if creep {
                e.creep_stiffness_n_per_m
            } else {
                0.0
            },
            creep_time_constant_s: e.creep_time_constant_s,
            friction_force_n: if friction { e.friction_force_n } else { 0.0 },
            friction_stiffness_n_per_m: e.friction_stiffness_n_per_m,
            friction_play_m: HYSTERESIS_PLAY_M,
        }
    }

    /// The wall's force on the lever beside the gas's, `k_c (s − h_b) − F_dahl`, at every
    /// sample of a run at `sample_s` with bellow heights `bellow_height_m` (finite), and the
    /// standard deviation of its friction part.
    ///
    /// Assumptions: the creep starts relaxed (`s = h_b`: a run's history before its first
    /// sample is not known, and a truck parked for minutes has relaxed); the friction starts
    /// as `start` says. An unknown start is uniform over the friction's band, and each
    /// movement maps it affinely (the Dahl law over a monotone path), so its spread at a
    /// sample is half the distance between the states started at either end, over `√3`:
    /// the band's whole `F_c / √3` until the bellow first moves, nothing once a movement has
    /// slid it to one side. A told start keeps a tenth of the band's half width as the EKF
    /// does (the last movement may not have slid it all the way), shrinking the same way.
    /// A height that is not a number holds both states (the force there is not a number).
    /// The friction follows a 1 s moving mean of the heights through
    /// [`Self::friction_play_m`], as the calibration's friction state does
    /// ([`friction_state_from`]); the creep follows every sample (its force is a fraction of
    /// a kilogram per sensor-noise step).
    pub fn series(
        &self,
        bellow_height_m: &[f64],
        sample_s: f64,
        start: HysteresisStart,
    ) -> WallSeries {
        let n = bellow_height_m.len();
        let friction_from = |z0: f64| {
            if self.friction_force_n > 0.0 && self.friction_stiffness_n_per_m > 0.0 {
                friction_state_from(
                    bellow_height_m,
                    sample_s,
                    self.friction_force_n / self.friction_stiffness_n_per_m,
                    self.friction_play_m,
                    z0,
                )
            } else {
                vec![0.0; n]
            }
        };
        let friction = friction_from(start.preload());
        // What is left of the start's spread, as a fraction of the band's half width: the
        // states started at either end, half their distance apart.
        let start_spread = match start {
            HysteresisStart::Unknown => 1.0 / 3f64.sqrt(),
            HysteresisStart::Lowered | HysteresisStart::Raised => KNOWN_START_SPREAD,
        };
        let friction_std_n = friction_from(1.0)
            .iter()
            .zip(friction_from(-1.0))
            .map(|(high, low)| 0.5 * (high - low) * start_spread * self.friction_force_n)
            .collect();
        // The Maxwell element's damper position, integrated exactly over each sample with the
        // height held (a first-order lag).
        let decay = (-sample_s / self.creep_time_constant_s.max(1e-6)).exp();
        let mut damper_m = bellow_height_m
            .iter()
            .copied()
            .find(|h| h.is_finite())
            .unwrap_or(0.0);
        let force_n = bellow_height_m
            .iter()
            .zip(friction)
            .map(|(&h_b, z)| {
                if h_b.is_finite() {
                    damper_m = h_b + (damper_m - h_b) * decay;
                }
                self.creep_stiffness_n_per_m * (damper_m - h_b) - z * self.friction_force_n
            })
            .collect();
        WallSeries {
            force_n,
            friction_std_n,
        }
    }
}

/// What [`WallForces::series`] gives for a run.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WallSeries {
    /// The wall's force on the lever beside the gas's, N.
    pub force_n: Vec<f64>,
    /// The standard deviation of its friction part from an unknown start, N.
    pub friction_std_n: Vec<f64>,
}

impl StaticLaw {
    /// The law with a truck file's parameters and effective-area law, and its wall where
    /// the file names one ([`WallForces::of_file`]).
    pub fn from_truck(truck: &TruckParameters) -> Self {
        let g = &truck.geometry;
        Self {
            gravity_m_s2: truck.environment.gravity_m_s2,
            h0_m: g.h0_m,
            lever_gain: lever_gain(g.l1_m, g.l2_m),
            max_bellow_height_m: g.h0_m + g.l1_m + g.l2_m,
            lever_compliance_m_per_n: g.lever_compliance_m_per_n,
            unsprung_kg: truck.mass.unsprung_kg,
            area: truck.bellow.effective_area.clone(),
            wall: WallForces::of_file(truck),
        }
    }

    /// The virtual truck's complete static law: its true parameters, the pressure dependence
    /// of the effective area and its wall's creep and friction (what a perfect quasi-static
    /// model would know).
    pub fn from_virtual_truck(truck: &VirtualTruck) -> Self {
        Self {
            area: truck.area_law(),
            wall: Some(WallForces::of_effects(
                &truck.effect_parameters,
                truck.effects.creep,
                truck.effects.hysteresis,
            )),
            ..Self::from_truck(&truck.physical)
        }
    }

    /// The law without the wall: the gas carries the whole load.
    pub fn without_wall(self) -> Self {
        Self { wall: None, ..self }
    }

    /// Bellow height for a sensor reading under a wheel load, m (SPEC §1 inverted).
    pub fn bellow_height_m(&self, sensor_height_m: f64, wheel_load_kg: f64) -> f64 {
        airsus_model::submodels::bellow_height_from_sensor_m(
            self.h0_m,
            self.lever_gain,
            sensor_height_m,
            self.lever_compliance_m_per_n,
            wheel_load_kg,
            self.gravity_m_s2,
        )
    }

    /// `A_eff(h, p)`, m² (eq 5.4, held constant outside the trusted range, times the stretch).
    pub fn effective_area_m2(&self, bellow_height_m: f64, gauge_pa: f64) -> f64 {
        self.area.area_clamped_m2(bellow_height_m, gauge_pa)
    }

    /// The wheel load `m_tot` that the measured height and pressure carry in statics, kg.
    pub fn wheel_load_kg(&self, sensor_height_m: f64, gauge_pa: f64) -> Result<f64, AppError> {
        self.wheel_load_with_wall_kg(sensor_height_m, gauge_pa, 0.0)
    }

    /// The same with the wall adding `wall_force_n` to the gas's force on the lever
    /// ([`WallForces::series`]), kg.
    pub fn wheel_load_with_wall_kg(
        &self,
        sensor_height_m: f64,
        gauge_pa: f64,
        wall_force_n: f64,
    ) -> Result<f64, AppError> {
        let what = || {
            format!(
                "sensor height {:.1} mm and bellow pressure {:.1} kPa",
                sensor_height_m * 1e3,
                gauge_pa / 1e3
            )
        };
        if !(sensor_height_m.is_finite() && gauge_pa.is_finite()) {
            return Err(AppError::NoStaticSolution {
                what: what(),
                reason: "a measurement is not finite".to_owned(),
            });
        }
        if gauge_pa <= 0.0 {
            return Err(AppError::NoStaticSolution {
                what: what(),
                reason: "an empty bellow (gauge pressure <= 0) carries no load".to_owned(),
            });
        }
        let mut load = self.unsprung_kg;
        for _ in 0..100 {
            let h_b = self.bellow_height_m(sensor_height_m, load);
            if !(h_b > 0.0 && h_b < self.max_bellow_height_m) {
                return Err(AppError::NoStaticSolution {
                    what: what(),
                    reason: format!(
                        "it implies a bellow height of {:.1} mm, outside the lever's range 0 to {:.1} mm",
                        h_b * 1e3,
                        self.max_bellow_height_m * 1e3
                    ),
                });
            }
            let area = self.effective_area_m2(h_b, gauge_pa);
            if area <= 0.0 {
                return Err(AppError::NoStaticSolution {
                    what: what(),
                    reason: format!("the effective area is {area:.5} m² there"),
                });
            }
            let next = self.unsprung_kg
                + self.lever_gain * (gauge_pa * area + wall_force_n) / self.gravity_m_s2;
            if (next - load).abs() < 1e-9 {
                return Ok(next);
            }
            load = next;
        }
        Ok(load)
    }
}

/// Sensor and parameter uncertainties for the static load (one standard deviation).
#[derive(Debug, Clone, PartialEq)]
pub struct WeighingUncertainty {
    /// White noise of the pressure sensor, Pa (virtual truck: 0.2 kPa).
    pub pressure_noise_pa: f64,
    /// Pressure resolution, Pa (thesis 2.2.3: 0.1 kPa).
    pub pressure_resolution_pa: f64,
    /// White noise of the height sensor, m (virtual truck: 0.15 mm).
    pub height_noise_m: f64,
    /// Height resolution, m (thesis 2.2.2: 0.1 mm).
    pub height_resolution_m: f64,
    /// Relative standard error of the effective area at the working point (assumed: 1 %, a
    /// lab force-map fit's scatter; set 0 when the parameters are known to be true).
    pub effective_area_rel: f64,
    /// Relative standard error of the lever gain (assumed 0.2 %, drawing tolerances).
    pub lever_gain_rel: f64,
    /// Relative standard error of the lever compliance `k_scl` (assumed 20 %).
    pub lever_compliance_rel: f64,
    /// Standard error of the unsprung mass, kg (assumed 20 kg).
    pub unsprung_kg: f64,
    /// Half-width of the bellow wall friction band, N (assumed 100 N; uniform on ±F).
    pub wall_friction_n: f64,
}

impl Default for WeighingUncertainty {
    fn default() -> Self {
        Self {
            pressure_noise_pa: 200.0,
            pressure_resolution_pa: 100.0,
            height_noise_m: 0.15e-3,
            height_resolution_m: 0.1e-3,
            effective_area_rel: 0.01,
            lever_gain_rel: 0.002,
            lever_compliance_rel: 0.2,
            unsprung_kg: 20.0,
            wall_friction_n: 100.0,
        }
    }
}

impl WeighingUncertainty {
    /// Per-sample standard deviation of the pressure reading, Pa.
    pub fn pressure_std_pa(&self) -> f64 {
        (self.pressure_noise_pa.powi(2) + self.pressure_resolution_pa.powi(2) / 12.0).sqrt()
    }

    /// Per-sample standard deviation of the height reading, m.
    pub fn height_std_m(&self) -> f64 {
        (self.height_noise_m.powi(2) + self.height_resolution_m.powi(2) / 12.0).sqrt()
    }

    /// Sensor noise only: what is left when the parameters are taken as exact.
    pub fn sensors_only(&self) -> Self {
        Self {
            effective_area_rel: 0.0,
            lever_gain_rel: 0.0,
            lever_compliance_rel: 0.0,
            unsprung_kg: 0.0,
            wall_friction_n: 0.0,
            ..self.clone()
        }
    }
}

/// One static load estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadEstimate {
    pub wheel_load_kg: f64,
    /// Total standard deviation, kg.
    pub std_kg: f64,
    /// Part from the sensors (per sample, or of the average), kg.
    pub measurement_std_kg: f64,
    /// Part from the parameters and the wall friction, kg.
    pub parameter_std_kg: f64,
    /// Part from a modelled wall friction's unknown state ([`WallSeries::friction_std_n`]),
    /// kg: state, not parameter (the estimate's own part, as the EKF's covariance holds it),
    /// but the same at every sample of a window, so an average does not shrink it.
    pub friction_state_std_kg: f64,
}

/// A static weigher: the law and what is uncertain about it.
#[derive(Debug, Clone, PartialEq)]
pub struct StaticWeigher {
    pub law: StaticLaw,
    pub uncertainty: WeighingUncertainty,
}

impl StaticWeigher {
    pub fn new(law: StaticLaw, uncertainty: WeighingUncertainty) -> Self {
        Self { law, uncertainty }
    }

    /// The load for one reading with its first-order standard deviation (module docs).
    pub fn estimate(&self, sensor_height_m: f64, gauge_pa: f64) -> Result<LoadEstimate, AppError> {
        self.estimate_gas(sensor_height_m, gauge_pa, true)
    }

    /// [`Self::estimate`] with the wall adding `wall_force_n` to the gas's force
    /// ([`StaticLaw::wheel_load_with_wall_kg`]) and its friction part uncertain by
    /// `friction_std_n` ([`WallSeries`]). The law's wall replaces the assumed friction band
    /// ([`WeighingUncertainty::wall_friction_n`]): what is left of it, an unknown start's
    /// friction, is state, not parameter ([`LoadEstimate::friction_state_std_kg`]).
    pub fn estimate_with_wall(
        &self,
        sensor_height_m: f64,
        gauge_pa: f64,
        wall_force_n: f64,
        friction_std_n: f64,
    ) -> Result<LoadEstimate, AppError> {
        let mut estimate = self.estimate_gas(sensor_height_m, gauge_pa, false)?;
        estimate.wheel_load_kg =
            self.law
                .wheel_load_with_wall_kg(sensor_height_m, gauge_pa, wall_force_n)?;
        estimate.friction_state_std_kg =
            self.law.lever_gain * friction_std_n / self.law.gravity_m_s2;
        estimate.std_kg = estimate.std_kg.hypot(estimate.friction_state_std_kg);
        Ok(estimate)
    }

    /// The gas's load and its uncertainty, the assumed wall friction band among the
    /// parameters' part when `with_friction_band`.
    fn estimate_gas(
        &self,
        sensor_height_m: f64,
        gauge_pa: f64,
        with_friction_band: bool,
    ) -> Result<LoadEstimate, AppError> {
        let load = self.law.wheel_load_kg(sensor_height_m, gauge_pa)?;
        let u = &self.uncertainty;
        // Sensitivities by central differences of the solved load.
        let dp = u.pressure_std_pa().max(1.0);
        let dm_dp = (self.law.wheel_load_kg(sensor_height_m, gauge_pa + dp)?
            - self.law.wheel_load_kg(sensor_height_m, gauge_pa - dp)?)
            / (2.0 * dp);
        let dh = u.height_std_m().max(1e-6);
        let dm_dh = (self.law.wheel_load_kg(sensor_height_m + dh, gauge_pa)?
            - self.law.wheel_load_kg(sensor_height_m - dh, gauge_pa)?)
            / (2.0 * dh);
        let measurement_var =
            (dm_dp * u.pressure_std_pa()).powi(2) + (dm_dh * u.height_std_m()).powi(2);

        let perturbed = |f: &dyn Fn(&mut StaticLaw)| -> Result<f64, AppError> {
            let mut law = self.law.clone();
            f(&mut law);
            law.wheel_load_kg(sensor_height_m, gauge_pa)
        };
        let sprung = load - self.law.unsprung_kg;
        // The area enters as a factor on the sprung part: exact sensitivity sprung * rel.
        let area_var = (sprung * u.effective_area_rel).powi(2);
        let gain_sens = if u.lever_gain_rel > 0.0 {
            let d = u.lever_gain_rel;
            (perturbed(&|l| l.lever_gain *= 1.0 + d)? - perturbed(&|l| l.lever_gain *= 1.0 - d)?)
                / 2.0
        } else {
            0.0
        };
        let compliance_sens = if u.lever_compliance_rel > 0.0 {
            let d = u.lever_compliance_rel;
            (perturbed(&|l| l.lever_compliance_m_per_n *= 1.0 + d)?
                - perturbed(&|l| l.lever_compliance_m_per_n *= 1.0 - d)?)
                / 2.0
        } else {
            0.0
        };
        let friction_std = if with_friction_band {
            self.law.lever_gain * u.wall_friction_n / (self.law.gravity_m_s2 * 3f64.sqrt())
        } else {
            0.0
        };
        let parameter_var = area_var
            + gain_sens.powi(2)
            + compliance_sens.powi(2)
            + u.unsprung_kg.powi(2)
            + friction_std.powi(2);
        Ok(LoadEstimate {
            wheel_load_kg: load,
            std_kg: (measurement_var + parameter_var).sqrt(),
            measurement_std_kg: measurement_var.sqrt(),
            parameter_std_kg: parameter_var.sqrt(),
            friction_state_std_kg: 0.0,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wall() -> WallForces {
        WallForces {
            creep_stiffness_n_per_m: 20_000.0,
            creep_time_constant_s: 30.0,
            friction_force_n: 100.0,
            friction_stiffness_n_per_m: 250_000.0,
            friction_play_m: 0.3e-3,
        }
    }

    /// A 20 mm rise over 2 s, then 300 s at rest, at 10 Hz.
    fn rise() -> Vec<f64> {
        (0..3021)
            .map(|k| 0.200 + 0.020 * (f64::from(k) / 20.0).min(1.0))
            .collect()
    }

    #[test]
    fn the_creep_relaxes_with_its_time_constant_and_the_friction_holds_after_a_rise() {
        let w = wall();
        let s = w.series(&rise(), 0.1, HysteresisStart::Unknown);
        // At rest the friction has slid to +F_c (20 mm is 50 pre-sliding lengths), so the
        // wall pulls the lever down by F_c plus what the creep still holds: k_c Δh e^(−t/τ)
        // with the rise's lag taken into the start.
        let at = |t_s: f64| s.force_n[20 + (t_s * 10.0) as usize];
        let creep = |t_s: f64| at(t_s) + w.friction_force_n;
        assert!(
            creep(30.0) < 0.0,
            "the creep resists the rise: {}",
            creep(30.0)
        );
        let ratio = creep(60.0) / creep(30.0);
        assert!(
            (ratio - (-1.0f64).exp()).abs() < 1e-3,
            "e^(-30 s / 30 s) expected, {ratio}"
        );
        // The rise's 20 mm, less what relaxed during the 2 s ramp: 400 N at most.
        assert!((-400.0..-360.0).contains(&creep(0.0)), "{}", creep(0.0));
        assert!(creep(300.0).abs() < 0.03, "{}", creep(300.0));
        // The unknown start's spread: the band's F_c/√3 before the bellow moves, none after.
        assert!((s.friction_std_n[0] - 100.0 / 3f64.sqrt()).abs() < 1e-9);
        assert!(s.friction_std_n[500] < 1e-6, "{}", s.friction_std_n[500]);
    }

    #[test]
    fn a_told_start_sets_the_friction_and_leaves_a_tenth_of_the_band() {
        let flat = vec![0.22; 100];
        let lowered = wall().series(&flat, 0.1, HysteresisStart::Lowered);
        let raised = wall().series(&flat, 0.1, HysteresisStart::Raised);
        // Lowered onto its height, the friction holds the bellow up: the wall carries F_c.
        assert!(lowered.force_n.iter().all(|&f| (f - 100.0).abs() < 1e-9));
        assert!(raised.force_n.iter().all(|&f| (f + 100.0).abs() < 1e-9));
        // A tenth of the band's half width, as the EKF's told start.
        assert!(
            lowered
                .friction_std_n
                .iter()
                .all(|&s| (s - 10.0).abs() < 1e-9)
        );
    }

    #[test]
    fn only_a_file_naming_the_whole_wall_has_one_and_it_moves_the_load_by_its_force() {
        let mut truck = TruckParameters::reference();
        assert_eq!(WallForces::of_file(&truck), None);
        // A thesis model's file from a study can carry the lab's wall friction alone; with
        // its stiffness too (`airsus fit wall-friction`) it still names no creep.
        truck.effects.friction_force_n = Some(80.0);
        truck.effects.friction_stiffness_n_per_m = Some(20e3);
        assert_eq!(WallForces::of_file(&truck), None);
        truck.effects.creep_stiffness_n_per_m = Some(15e3);
        truck.effects.creep_time_constant_s = Some(40.0);
        let wall = WallForces::of_file(&truck).expect("a wall");
        assert_eq!(
            (wall.friction_force_n, wall.creep_time_constant_s),
            (80.0, 40.0)
        );
        let law = StaticLaw::from_truck(&truck);
        let gas = law.wheel_load_kg(0.24, 350e3).unwrap();
        let with = law.wheel_load_with_wall_kg(0.24, 350e3, 100.0).unwrap();
        // 100 N at the bellow is k_l × 100 N / g at the wheel, within the lever compliance's
        // feedback through the area (0.012 kg here).
        let expected = law.lever_gain * 100.0 / law.gravity_m_s2;
        assert!(
            ((with - gas) - expected).abs() < 0.03,
            "{} {expected}",
            with - gas
        );
    }
}
