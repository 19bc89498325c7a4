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

use airsus_data::{EffectiveAreaLaw, TruckParameters};
use airsus_model::submodels::lever_gain;
use airsus_truck::truth::VirtualTruck;

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
}

impl StaticLaw {
    /// The law with a truck file's parameters and effective-area law.
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
        }
    }

    /// The virtual truck's complete static law: its true parameters and the pressure
    /// dependence of the effective area (what a perfect static model would know).
    pub fn from_virtual_truck(truck: &VirtualTruck) -> Self {
        Self {
            area: truck.area_law(),
            ..Self::from_truck(&truck.physical)
        }
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
            let next = self.unsprung_kg + self.lever_gain * gauge_pa * area / self.gravity_m_s2;
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
        let friction_std =
            self.law.lever_gain * u.wall_friction_n / (self.law.gravity_m_s2 * 3f64.sqrt());
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
        })
    }
}
