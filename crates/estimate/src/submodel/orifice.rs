//! The ISO 6358 orifice valve law from tank discharges, by simulation of the tank's gas.
//!
//! The thesis' evaluation (5.2.3, [`super::fit_valve`]) reads the flow from the tank's pressure
//! slope as if the gas stayed at room temperature (eq 5.5/5.6). It does not: the air left in
//! the tank expands and cools, so the pressure falls faster than the air leaves, and the
//! isothermal reading takes the cooling for flow (on the virtual truck's rig an orifice fitted
//! that way came out 24 % too large). Here the tank is simulated as it is: amount `n` and
//! temperature `T` of its air, the flow out through the channel's orifice (ISO 6358-1,
//! [`iso6358_molar_flow`]: sonic conductance `C`, critical ratio `b`) and the first law with
//! heat exchange to the tank wall at room temperature (time constant `τ`;
//! [`airsus_sim::simulate_tank_discharge`], as the rig itself):
//!
//! ```text
//! dn/dt = −q(p, p_amb, T; C, b),     p = n R T / V,
//! dT/dt = −q R T / (n c_v) + (T_room − T)/τ,
//! ```
//!
//! and `C` of each channel, the common `b` (the truck file's `bcr` serves both channels) and
//! `τ` (one rig) are fitted by Levenberg–Marquardt to the logged tank pressures of the
//! estimation discharges. Each discharge starts at its first logged pressure and the room's
//! temperature.

use airsus_data::laws::iso6358_molar_flow;
use airsus_data::params::Field;
use airsus_data::{Channel, Role, TruckParameters, ValveFlowLaw};
use airsus_sim::{TankDischargeProblem, simulate_tank_discharge};
use airsus_validate::nrmse_percent;
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{DMatrix, DVector, Dyn, Owned};
use rayon::prelude::*;
use serde::Serialize;

use super::valve::DischargeData;
use crate::error::EstimateError;

const FIT: &str = "orifice valve fit";

#[derive(Debug, Clone, PartialEq)]
pub struct OrificeFitOptions {
    pub gas_constant_j_mol_k: f64,
    pub ambient_pressure_pa: f64,
    /// Where the fit starts: `c1`, `c2`, `bcr` (the truck's orifice law, or typical values;
    /// `bcr` strictly inside 0.05–0.95).
    pub start_fill_conductance_m3_s_pa: f64,
    pub start_exhaust_conductance_m3_s_pa: f64,
    pub start_critical_pressure_ratio: f64,
    /// The tank wall's thermal time constant to start from, s.
    pub start_tank_thermal_time_s: f64,
    /// Where [`fit_linear_valve`] starts: `rflow1`, `rflow2`, Pa·s/mol (the truck's linear law,
    /// or the thesis' values under another law).
    pub start_fill_resistance_pa_s_per_mol: f64,
    pub start_exhaust_resistance_pa_s_per_mol: f64,
}

impl OrificeFitOptions {
    /// The truck's gas constant and ambient pressure; its orifice law to start from, or
    /// typical values (0.5 and 1.2 dm³/(s·bar), b = 0.4) under another law.
    pub fn for_truck(truck: &TruckParameters) -> Self {
        let (c1, c2, b) = match truck.valve {
            ValveFlowLaw::Orifice {
                fill_conductance_m3_s_pa,
                exhaust_conductance_m3_s_pa,
                critical_pressure_ratio,
            } => (
                fill_conductance_m3_s_pa,
                exhaust_conductance_m3_s_pa,
                critical_pressure_ratio,
            ),
            _ => (5e-9, 1.2e-8, 0.4),
        };
        // The thesis' reference resistances under another law.
        let linear = match truck.valve {
            law @ ValveFlowLaw::LinearResistance { .. } => law,
            _ => TruckParameters::reference().valve,
        };
        let r1 = linear.get(Field::FillResistance).unwrap_or(f64::NAN);
        let r2 = linear.get(Field::ExhaustResistance).unwrap_or(f64::NAN);
        Self {
            gas_constant_j_mol_k: truck.environment.gas_constant_j_mol_k,
            ambient_pressure_pa: truck.environment.ambient_pressure_pa,
            start_fill_conductance_m3_s_pa: c1,
            start_exhaust_conductance_m3_s_pa: c2,
            start_critical_pressure_ratio: b,
            start_tank_thermal_time_s: 30.0,
            start_fill_resistance_pa_s_per_mol: r1,
            start_exhaust_resistance_pa_s_per_mol: r2,
        }
    }
}

/// One discharge's tank pressure, simulated against logged.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OrificeDischargeFit {
    pub name: String,
    pub channel: Channel,
    pub role: Role,
    /// NRMSE of the simulated tank pressure against the logged one, percent.
    pub nrmse_percent: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OrificeFit {
    /// `c1`, m³/(s·Pa); `None` without a fill discharge to estimate it from.
    pub fill_conductance_m3_s_pa: Option<f64>,
    /// `c2`, m³/(s·Pa).
    pub exhaust_conductance_m3_s_pa: Option<f64>,
    /// `bcr`, both channels.
    pub critical_pressure_ratio: f64,
    /// The rig's tank wall, s (a property of the rig, not of the truck).
    pub tank_thermal_time_s: f64,
    /// Standard deviations, same order and units: c1, c2, bcr, τ (NaN where not estimated).
    pub std: [f64; 4],
    pub discharges: Vec<OrificeDischargeFit>,
    /// RMS of the estimation residuals, Pa.
    pub residual_rms_pa: f64,
    /// Simulations of the estimation discharges over all starts.
    pub evaluations: usize,
}

impl OrificeFit {
    /// The orifice law with these values; a channel without a discharge keeps the fit's start
    /// value (`options`: the truck's conductance, or the typical one).
    pub fn law(&self, options: &OrificeFitOptions) -> ValveFlowLaw {
        ValveFlowLaw::Orifice {
            fill_conductance_m3_s_pa: self
                .fill_conductance_m3_s_pa
                .unwrap_or(options.start_fill_conductance_m3_s_pa),
            exhaust_conductance_m3_s_pa: self
                .exhaust_conductance_m3_s_pa
                .unwrap_or(options.start_exhaust_conductance_m3_s_pa),
            critical_pressure_ratio: self.critical_pressure_ratio,
        }
    }

    /// Writes `c1`, `c2` (where estimated) and `bcr` into a truck under the orifice law; a
    /// truck under another valve law, or a value outside its declared range, leaves the truck
    /// unchanged and the error says which.
    pub fn write_to(&self, truck: &mut TruckParameters) -> Result<(), EstimateError> {
        write_valve(
            truck,
            "orifice",
            &[
                (Field::FillConductance, self.fill_conductance_m3_s_pa),
                (Field::ExhaustConductance, self.exhaust_conductance_m3_s_pa),
                (
                    Field::CriticalPressureRatio,
                    Some(self.critical_pressure_ratio),
                ),
            ],
        )
    }
}

/// Writes the fitted `values` into `truck`'s valve if it follows law `tag` and every value is
/// in its declared range; otherwise leaves the truck unchanged and says why.
fn write_valve(
    truck: &mut TruckParameters,
    tag: &str,
    values: &[(Field, Option<f64>)],
) -> Result<(), EstimateError> {
    if truck.valve.tag() != tag {
        return Err(EstimateError::InvalidOption(format!(
            "the truck's valve follows law \"{}\", not the {tag} law this fit is of",
            truck.valve.tag()
        )));
    }
    for &(field, value) in values {
        if let Some(value) = value {
            super::check_declared(field, value)?;
        }
    }
    for &(field, value) in values {
        if let Some(value) = value {
            truck.valve.set(field, value);
        }
    }
    Ok(())
}

/// The law the tank's air leaves by in a fit: each channel's coefficient (`C` of the orifice,
/// or `R` of the thesis' linear resistance) and, for the orifice, the common `b`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum TankLaw {
    Orifice,
    Linear,
}

/// The logged tank gauge pressures of `data` as the tank's gas gives them: the air leaves
/// through the channel with `coefficient` (`C` or `R`), `b` for the orifice, the wall's `τ`.
fn simulate(
    data: &DischargeData,
    law: TankLaw,
    coefficient: f64,
    critical_ratio: f64,
    thermal_time_s: f64,
    options: &OrificeFitOptions,
) -> Result<Vec<f64>, String> {
    let ambient = options.ambient_pressure_pa;
    let log = data.discharge;
    let t0 = log.time_s[0];
    let times: Vec<f64> = log.time_s.iter().map(|t| t - t0).collect();
    let discharge = TankDischargeProblem {
        volume_m3: data.tank_volume_m3,
        room_temperature_k: data.temperature_k,
        start_gauge_pa: log.tank_gauge_pa[0],
        times_s: &times,
        gas_constant_j_mol_k: options.gas_constant_j_mol_k,
        ambient_pressure_pa: ambient,
        thermal_time_s: Some(thermal_time_s),
    };
    match law {
        TankLaw::Orifice => simulate_tank_discharge(&discharge, |p, t| {
            iso6358_molar_flow(coefficient, critical_ratio, p, ambient, t)
        }),
        // Eq 3.19 / 5.5: the flow is the pressure difference over the resistance.
        TankLaw::Linear => simulate_tank_discharge(&discharge, |p, _| (p - ambient) / coefficient),
    }
}

/// `b` lies in (0.05, 0.9) (the top is the declared bound of `bcr`, so that what the fit
/// finds a truck file takes): the solver moves a logit of it, so that no step leaves the
/// range and the gradient never vanishes at a clamp.
const RATIO_RANGE: (f64, f64) = (0.05, 0.9);

fn ratio_from(z: f64) -> f64 {
    RATIO_RANGE.0 + (RATIO_RANGE.1 - RATIO_RANGE.0) / (1.0 + (-z).exp())
}

fn ratio_to(b: f64) -> f64 {
    let u = ((b - RATIO_RANGE.0) / (RATIO_RANGE.1 - RATIO_RANGE.0)).clamp(1e-6, 1.0 - 1e-6);
    (u / (1.0 - u)).ln()
}

/// The fit's unknowns in the solver's coordinates: logarithms of the channels' coefficients
/// (conductances or resistances) and of `τ` (positive, spanning decades), a logit of `b`.
struct Problem<'a> {
    data: &'a [DischargeData<'a>],
    options: &'a OrificeFitOptions,
    law: TankLaw,
    /// Which of `[ln c1, ln c2, b, ln τ]` are free (a channel without discharges is not; `b`
    /// under the linear law is not).
    free: [bool; 4],
    z: [f64; 4],
    evaluations: std::cell::Cell<usize>,
    /// The residuals at the last point simulated: the solver asks for them, then for the
    /// Jacobian (whose base they are) at the same point, and the caller before and after.
    last: std::cell::RefCell<Option<([f64; 4], Vec<f64>)>>,
}

impl Problem<'_> {
    fn values(z: &[f64; 4]) -> (f64, f64, f64, f64) {
        (z[0].exp(), z[1].exp(), ratio_from(z[2]), z[3].exp())
    }

    /// Residuals of the estimation discharges, Pa, or `None` where a simulation failed.
    fn residuals_at(&self, z: &[f64; 4]) -> Option<Vec<f64>> {
        if let Some((at, residuals)) = self.last.borrow().as_ref()
            && at == z
        {
            return Some(residuals.clone());
        }
        let residuals = self.simulate_residuals(z)?;
        *self.last.borrow_mut() = Some((*z, residuals.clone()));
        Some(residuals)
    }

    fn simulate_residuals(&self, z: &[f64; 4]) -> Option<Vec<f64>> {
        self.evaluations.set(self.evaluations.get() + 1);
        let (c1, c2, b, tau) = Self::values(z);
        let mut out = Vec::new();
        for d in self.data.iter().filter(|d| d.role == Role::Estimation) {
            let c = match d.channel {
                Channel::Fill => c1,
                Channel::Exhaust => c2,
            };
            let sim = simulate(d, self.law, c, b, tau, self.options).ok()?;
            out.extend(
                sim.iter()
                    .zip(&d.discharge.tank_gauge_pa)
                    .map(|(s, m)| s - m),
            );
        }
        Some(out)
    }

    fn free_indices(&self) -> Vec<usize> {
        (0..4).filter(|&i| self.free[i]).collect()
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        for (k, i) in self.free_indices().into_iter().enumerate() {
            self.z[i] = x[k];
        }
    }

    fn params(&self) -> DVector<f64> {
        DVector::from_iterator(
            self.free.iter().filter(|f| **f).count(),
            self.free_indices().into_iter().map(|i| self.z[i]),
        )
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        self.residuals_at(&self.z).map(DVector::from_vec)
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let base = self.residuals_at(&self.z)?;
        let free = self.free_indices();
        let mut jacobian = DMatrix::zeros(base.len(), free.len());
        for (column, &i) in free.iter().enumerate() {
            let step = 1e-5 * (1.0 + self.z[i].abs());
            let mut z = self.z;
            z[i] += step;
            let shifted = self.simulate_residuals(&z)?;
            for (row, (s, b)) in shifted.iter().zip(&base).enumerate() {
                jacobian[(row, column)] = (s - b) / step;
            }
        }
        Some(jacobian)
    }
}

/// What a tank fit found, in either law's coefficients.
struct TankFit {
    /// `[c1 or rflow1, c2 or rflow2, b, τ]` (b meaningless under the linear law).
    values: [f64; 4],
    /// Whether each was fitted.
    free: [bool; 4],
    std: [f64; 4],
    discharges: Vec<OrificeDischargeFit>,
    residual_rms_pa: f64,
    evaluations: usize,
}

fn fit_tank(
    data: &[DischargeData],
    options: &OrificeFitOptions,
    law: TankLaw,
) -> Result<TankFit, EstimateError> {
    let bad = |reason: String| EstimateError::InsufficientData { fit: FIT, reason };
    for d in data {
        let log = d.discharge;
        if log.time_s.len() < 3 || log.time_s.len() != log.tank_gauge_pa.len() {
            return Err(bad(format!(
                "discharge `{}` has {} samples; a fit needs at least 3",
                d.name,
                log.time_s.len()
            )));
        }
        if !(d.tank_volume_m3 > 0.0 && d.temperature_k > 0.0) {
            return Err(bad(format!(
                "discharge `{}`: the tank volume and temperature must be positive",
                d.name
            )));
        }
    }
    let has = |channel: Channel| {
        data.iter()
            .any(|d| d.channel == channel && d.role == Role::Estimation)
    };
    let orifice = law == TankLaw::Orifice;
    let free = [has(Channel::Fill), has(Channel::Exhaust), orifice, true];
    if !(free[0] || free[1]) {
        return Err(bad("no estimation discharge".to_owned()));
    }
    let (first, second) = if orifice {
        (
            options.start_fill_conductance_m3_s_pa,
            options.start_exhaust_conductance_m3_s_pa,
        )
    } else {
        (
            options.start_fill_resistance_pa_s_per_mol,
            options.start_exhaust_resistance_pa_s_per_mol,
        )
    };
    let start = [
        first.ln(),
        second.ln(),
        ratio_to(options.start_critical_pressure_ratio),
        options.start_tank_thermal_time_s.ln(),
    ];
    if start.iter().any(|v| !v.is_finite()) {
        return Err(EstimateError::InvalidOption(
            "the valve fit's start values must be positive".to_owned(),
        ));
    }
    // The pressure trace is explained almost as well by a slow wall and an early choke as by
    // the truth (measured: from b = 0.5 and τ = 30 s the fit ended at b = 0.05, τ = 269 s
    // with ten times the noise, from τ = 60 s at the truth): the solver is started from the
    // given start and from a grid over b (the orifice's) and τ, and the best end point is
    // kept.
    let mut starts = vec![start];
    let ratios: &[f64] = if orifice { &[0.2, 0.35, 0.5] } else { &[0.4] };
    for &b in ratios {
        for tau in [15.0_f64, 60.0, 240.0] {
            starts.push([start[0], start[1], ratio_to(b), tau.ln()]);
        }
    }
    let ends: Vec<(Problem, f64)> = starts
        .into_par_iter()
        .filter_map(|z| {
            let problem = Problem {
                data,
                options,
                law,
                free,
                z,
                evaluations: std::cell::Cell::new(0),
                last: std::cell::RefCell::new(None),
            };
            problem.residuals()?;
            let (problem, _) = LevenbergMarquardt::new().minimize(problem);
            let loss = problem.residuals()?.norm_squared();
            loss.is_finite().then_some((problem, loss))
        })
        .collect();
    let evaluations: usize = ends.iter().map(|(p, _)| p.evaluations.get()).sum();
    let problem = ends
        .into_iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(p, _)| p)
        .ok_or_else(|| bad("the tank cannot be simulated from any start".to_owned()))?;
    let residuals = problem
        .residuals()
        .ok_or_else(|| bad("the fit ended where the tank cannot be simulated".to_owned()))?;
    let m = residuals.len();
    let rms = (residuals.norm_squared() / m as f64).sqrt();
    // Standard deviations from the Gauss–Newton covariance, back through the logarithms.
    let mut std = [f64::NAN; 4];
    if let Some(j) = problem.jacobian() {
        let k = j.ncols();
        if let Some(inverse) = (j.transpose() * &j).try_inverse() {
            let sigma2 = residuals.norm_squared() / (m.saturating_sub(k).max(1)) as f64;
            let (c1, c2, b, tau) = Problem::values(&problem.z);
            // d value / d z of each coordinate.
            let db_dz = (b - RATIO_RANGE.0) * (RATIO_RANGE.1 - b) / (RATIO_RANGE.1 - RATIO_RANGE.0);
            let scale = [c1, c2, db_dz, tau];
            for (column, i) in problem.free_indices().into_iter().enumerate() {
                std[i] = scale[i] * (sigma2 * inverse[(column, column)]).max(0.0).sqrt();
            }
            // At a bound of b the transform's slope vanishes and so would its spread: say
            // nothing rather than a spread of zero.
            if (b - RATIO_RANGE.0).min(RATIO_RANGE.1 - b) < 1e-3 {
                std[2] = f64::NAN;
            }
        }
    }
    let (c1, c2, b, tau) = Problem::values(&problem.z);
    let mut discharges = Vec::with_capacity(data.len());
    // A discharge through a channel no estimation discharge went through is not scored: its
    // coefficient was not fitted.
    for d in data.iter().filter(|d| match d.channel {
        Channel::Fill => free[0],
        Channel::Exhaust => free[1],
    }) {
        let c = match d.channel {
            Channel::Fill => c1,
            Channel::Exhaust => c2,
        };
        let sim =
            simulate(d, law, c, b, tau, options).map_err(|e| bad(format!("{}: {e}", d.name)))?;
        discharges.push(OrificeDischargeFit {
            name: d.name.clone(),
            channel: d.channel,
            role: d.role,
            nrmse_percent: nrmse_percent(&d.discharge.tank_gauge_pa, &sim)
                .map_err(|e| bad(format!("{}: NRMSE: {e}", d.name)))?,
        });
    }
    Ok(TankFit {
        values: [c1, c2, b, tau],
        free,
        std,
        discharges,
        residual_rms_pa: rms,
        evaluations,
    })
}

/// Fits `C` of each channel with estimation discharges, the common `b` and the rig's `τ`.
pub fn fit_orifice(
    data: &[DischargeData],
    options: &OrificeFitOptions,
) -> Result<OrificeFit, EstimateError> {
    let fit = fit_tank(data, options, TankLaw::Orifice)?;
    let [c1, c2, b, tau] = fit.values;
    Ok(OrificeFit {
        fill_conductance_m3_s_pa: fit.free[0].then_some(c1),
        exhaust_conductance_m3_s_pa: fit.free[1].then_some(c2),
        critical_pressure_ratio: b,
        tank_thermal_time_s: tau,
        std: fit.std,
        discharges: fit.discharges,
        residual_rms_pa: fit.residual_rms_pa,
        evaluations: fit.evaluations,
    })
}

/// The thesis' linear resistances (eq 3.19) fitted as [`fit_orifice`] fits the orifice: the
/// tank's gas simulated with its cooling (unlike [`super::fit_valve`], the thesis'
/// isothermal reading of eq 5.5). Its residual beside the orifice's says which law the valve
/// follows.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinearValveFit {
    /// `rflow1`, Pa·s/mol; `None` without a fill discharge to estimate it from.
    pub fill_resistance_pa_s_per_mol: Option<f64>,
    /// `rflow2`, Pa·s/mol.
    pub exhaust_resistance_pa_s_per_mol: Option<f64>,
    /// The rig's tank wall, s.
    pub tank_thermal_time_s: f64,
    /// Standard deviations: rflow1, rflow2, τ (NaN where not estimated).
    pub std: [f64; 3],
    pub discharges: Vec<OrificeDischargeFit>,
    /// RMS of the estimation residuals, Pa.
    pub residual_rms_pa: f64,
    pub evaluations: usize,
}

/// Fits `R` of each channel with estimation discharges and the rig's `τ`, the tank's gas
/// simulated (see [`LinearValveFit`]).
pub fn fit_linear_valve(
    data: &[DischargeData],
    options: &OrificeFitOptions,
) -> Result<LinearValveFit, EstimateError> {
    let fit = fit_tank(data, options, TankLaw::Linear)?;
    let [r1, r2, _, tau] = fit.values;
    Ok(LinearValveFit {
        fill_resistance_pa_s_per_mol: fit.free[0].then_some(r1),
        exhaust_resistance_pa_s_per_mol: fit.free[1].then_some(r2),
        tank_thermal_time_s: tau,
        std: [fit.std[0], fit.std[1], fit.std[3]],
        discharges: fit.discharges,
        residual_rms_pa: fit.residual_rms_pa,
        evaluations: fit.evaluations,
    })
}

impl LinearValveFit {
    /// Writes `rflow1`, `rflow2` (where estimated) into a truck under the linear law; another
    /// law, or a value outside its declared range, leaves the truck unchanged and says so.
    pub fn write_to(&self, truck: &mut TruckParameters) -> Result<(), EstimateError> {
        write_valve(
            truck,
            "linear_resistance",
            &[
                (Field::FillResistance, self.fill_resistance_pa_s_per_mol),
                (
                    Field::ExhaustResistance,
                    self.exhaust_resistance_pa_s_per_mol,
                ),
            ],
        )
    }

    /// The linear law with these resistances; a channel without a discharge keeps the fit's
    /// start value (`options`: the truck's resistance, or the thesis' reference).
    pub fn law(&self, options: &OrificeFitOptions) -> ValveFlowLaw {
        ValveFlowLaw::LinearResistance {
            fill_pa_s_per_mol: self
                .fill_resistance_pa_s_per_mol
                .unwrap_or(options.start_fill_resistance_pa_s_per_mol),
            exhaust_pa_s_per_mol: self
                .exhaust_resistance_pa_s_per_mol
                .unwrap_or(options.start_exhaust_resistance_pa_s_per_mol),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_outside_its_declared_range_is_not_written() {
        let mut truck = TruckParameters::reference();
        truck.valve = ValveFlowLaw::Orifice {
            fill_conductance_m3_s_pa: 5e-9,
            exhaust_conductance_m3_s_pa: 1.2e-8,
            critical_pressure_ratio: 0.4,
        };
        let before = truck.clone();
        let fit = OrificeFit {
            fill_conductance_m3_s_pa: Some(6e-9),
            exhaust_conductance_m3_s_pa: None,
            critical_pressure_ratio: 0.95,
            tank_thermal_time_s: 60.0,
            std: [f64::NAN; 4],
            discharges: vec![],
            residual_rms_pa: 100.0,
            evaluations: 1,
        };
        let err = fit.write_to(&mut truck).unwrap_err().to_string();
        assert!(err.contains("`bcr` = 0.95"), "{err}");
        assert_eq!(truck, before, "nothing written");
        let fine = OrificeFit {
            critical_pressure_ratio: 0.35,
            ..fit
        };
        fine.write_to(&mut truck).unwrap();
        assert_eq!(truck.valve.get(Field::FillConductance), Some(6e-9));
        assert_eq!(truck.valve.get(Field::ExhaustConductance), Some(1.2e-8));
        assert_eq!(truck.valve.get(Field::CriticalPressureRatio), Some(0.35));
    }
}
