//! Valve flow resistances from tank discharges (thesis 5.2.3, eq 3.19, 5.5, 5.6, Table 5.3).
//!
//! A tank of volume `V` at temperature `T` empties to ambient through one valve channel. The
//! tank holds `n = p V/(R T)` (eq 5.5, isothermal, `T` = room temperature as in the thesis),
//! so the flow out of it is (eq 5.6)
//!
//! ```text
//! f_k = −(dp/dt)_k V / (R T)                 [mol/s]
//! ```
//!
//! with `dp/dt` from a Savitzky–Golay slope ([`super::derivative`]). Eq 3.19 for a channel
//! between the tank (the upstream side: the supply on fill, the bellow on exhaust) and
//! ambient is `f = (p_tank − p_amb)/R_flow = p_gauge/R_flow`. The conductance `1/R` is fitted
//! by least squares through the origin over all *estimation* discharges of a channel,
//! `1/R = Σ f p / Σ p²`; the NRMSE of `p_gauge/R` against `f` is reported per discharge, the
//! validation ones being Table 5.3's figure.
//!
//! Samples used: those with a centred derivative window, and a gauge pressure above
//! `min_gauge_fraction` of the discharge's peak (the near-empty tail is all quantisation
//! noise). The real discharge is neither isothermal nor Poiseuille (the gas cools as it
//! expands, an orifice chokes): the NRMSE shows how far the linear law carries.

use airsus_data::params::Field;
use airsus_data::{Channel, Role, TankDischarge, TruckParameters, ValveFlowLaw};
use airsus_validate::nrmse_percent;
use serde::Serialize;

use super::derivative::savitzky_golay_slope;
use crate::error::EstimateError;

const FIT: &str = "valve flow fit";

/// One discharge with its metadata (as a study file lists it).
#[derive(Debug, Clone)]
pub struct DischargeData<'a> {
    pub name: String,
    pub discharge: &'a TankDischarge,
    pub channel: Channel,
    pub tank_volume_m3: f64,
    pub temperature_k: f64,
    pub role: Role,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ValveFitOptions {
    /// Savitzky–Golay half window `m` (window `2m + 1` samples).
    pub half_window: usize,
    /// Samples below this fraction of the peak gauge pressure are not used.
    pub min_gauge_fraction: f64,
    pub gas_constant_j_mol_k: f64,
}

impl ValveFitOptions {
    /// Defaults with the gas constant of `truck`. (The logged tank pressure is gauge, i.e.
    /// already `p_tank − p_amb`.)
    pub fn for_truck(truck: &TruckParameters) -> Self {
        Self {
            half_window: 5,
            min_gauge_fraction: 0.05,
            gas_constant_j_mol_k: truck.environment.gas_constant_j_mol_k,
        }
    }
}

/// One discharge's flow data and its fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DischargeFit {
    pub name: String,
    pub role: Role,
    pub samples_used: usize,
    /// NRMSE of the flow model against the flow from eq 5.6, percent.
    pub nrmse_percent: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChannelFit {
    pub channel: Channel,
    /// `R_flow`, Pa·s/mol.
    pub resistance_pa_s_per_mol: f64,
    pub resistance_std: f64,
    pub discharges: Vec<DischargeFit>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ValveFit {
    /// `R_flow1` (fill), if the data had estimation discharges through the fill channel.
    pub fill: Option<ChannelFit>,
    /// `R_flow2` (exhaust).
    pub exhaust: Option<ChannelFit>,
}

impl ValveFit {
    /// Writes the fitted resistances into a truck under the linear-resistance valve law (eq
    /// 3.19). A channel without a fit is left alone. A truck under another law is an error and
    /// stays as it was: the file chose that law, and these resistances are the thesis'
    /// isothermal evaluation of another one (an ISO 6358 fit of the discharges needs the
    /// tank's energy balance: the rig's gas cools as it empties, and read as isothermal flow
    /// that cooling put a sonic conductance 24 % high on the virtual truck's rig).
    pub fn write_to(&self, truck: &mut TruckParameters) -> Result<(), EstimateError> {
        if !matches!(truck.valve, ValveFlowLaw::LinearResistance { .. }) {
            return Err(EstimateError::InvalidOption(format!(
                "the truck's valve law is `{}`: the linear resistances fitted to the discharges do not replace it",
                truck.valve.tag()
            )));
        }
        let fitted = [
            (Field::FillResistance, &self.fill),
            (Field::ExhaustResistance, &self.exhaust),
        ];
        for (field, fit) in fitted {
            if let Some(fit) = fit {
                truck.valve.set(field, fit.resistance_pa_s_per_mol);
            }
        }
        Ok(())
    }
}

/// `(gauge pressure, flow out)` pairs of one discharge (module docs).
fn flow_points(
    d: &DischargeData<'_>,
    options: &ValveFitOptions,
) -> Result<(Vec<f64>, Vec<f64>), EstimateError> {
    let bad = |reason: String| EstimateError::InsufficientData {
        fit: FIT,
        reason: format!("discharge `{}`: {reason}", d.name),
    };
    if !(d.tank_volume_m3 > 0.0 && d.tank_volume_m3.is_finite()) {
        return Err(bad(format!("tank volume {} m³", d.tank_volume_m3)));
    }
    if !(d.temperature_k > 0.0 && d.temperature_k.is_finite()) {
        return Err(bad(format!("temperature {} K", d.temperature_k)));
    }
    let p = &d.discharge.tank_gauge_pa;
    if let Some(k) = p.iter().position(|v| !v.is_finite()) {
        return Err(bad(format!("tank pressure at sample {k} is not finite")));
    }
    let m = options.half_window.max(1);
    let slope = savitzky_golay_slope(p, d.discharge.sample_time_s, m);
    let peak = p.iter().copied().fold(0.0, f64::max);
    let factor = d.tank_volume_m3 / (options.gas_constant_j_mol_k * d.temperature_k);
    let (mut pg, mut flow) = (Vec::new(), Vec::new());
    for (i, s) in slope.iter().enumerate() {
        let pk = p[i + m];
        if pk > options.min_gauge_fraction * peak {
            pg.push(pk);
            flow.push(-s * factor);
        }
    }
    if pg.len() < 3 {
        return Err(bad(format!(
            "{} usable samples (needs at least 3 with a gauge pressure above {:.0} % of the peak and a full {}-sample derivative window)",
            pg.len(),
            100.0 * options.min_gauge_fraction,
            2 * m + 1
        )));
    }
    Ok((pg, flow))
}

fn fit_channel(
    channel: Channel,
    discharges: &[DischargeData<'_>],
    options: &ValveFitOptions,
) -> Result<Option<ChannelFit>, EstimateError> {
    let mine: Vec<&DischargeData<'_>> =
        discharges.iter().filter(|d| d.channel == channel).collect();
    let mut points = Vec::with_capacity(mine.len());
    for d in &mine {
        points.push(flow_points(d, options)?);
    }
    let (mut fp, mut pp, mut n_est) = (0.0, 0.0, 0usize);
    for (d, (p, f)) in mine.iter().zip(&points) {
        if d.role == Role::Estimation {
            fp += f.iter().zip(p).map(|(a, b)| a * b).sum::<f64>();
            pp += p.iter().map(|x| x * x).sum::<f64>();
            n_est += p.len();
        }
    }
    if n_est == 0 {
        return Ok(None);
    }
    let conductance = fp / pp;
    if !(conductance > 0.0 && conductance.is_finite()) {
        return Err(EstimateError::InsufficientData {
            fit: FIT,
            reason: format!(
                "{} channel: the tank pressure does not fall with a positive flow (fitted conductance {conductance:e} mol/(s·Pa))",
                channel.as_str()
            ),
        });
    }
    let mut rss = 0.0;
    for (d, (p, f)) in mine.iter().zip(&points) {
        if d.role == Role::Estimation {
            rss += f
                .iter()
                .zip(p)
                .map(|(fi, pi)| (fi - conductance * pi).powi(2))
                .sum::<f64>();
        }
    }
    // Var(1/R) = σ²/Σp²; R = 1/g so std(R) = std(g)/g². The SG derivative correlates
    // neighbouring flow samples (window 2m+1), so σ² is inflated by the window length to
    // keep the standard deviation honest.
    let sigma2 = rss / (n_est as f64 - 1.0).max(1.0) * (2 * options.half_window.max(1) + 1) as f64;
    let g_std = (sigma2 / pp).sqrt();
    let resistance = 1.0 / conductance;
    let fits = mine
        .iter()
        .zip(&points)
        .map(|(d, (p, f))| {
            let model: Vec<f64> = p.iter().map(|x| conductance * x).collect();
            DischargeFit {
                name: d.name.clone(),
                role: d.role,
                samples_used: p.len(),
                nrmse_percent: nrmse_percent(f, &model).ok(),
            }
        })
        .collect();
    Ok(Some(ChannelFit {
        channel,
        resistance_pa_s_per_mol: resistance,
        resistance_std: g_std * resistance * resistance,
        discharges: fits,
    }))
}

/// Fits `R_flow1` and `R_flow2` from tank discharges (module docs). A channel without
/// estimation discharges gets no fit (`None`); having none at all is an error.
pub fn fit_valve(
    discharges: &[DischargeData<'_>],
    options: &ValveFitOptions,
) -> Result<ValveFit, EstimateError> {
    if !(options.gas_constant_j_mol_k > 0.0 && options.min_gauge_fraction >= 0.0) {
        return Err(EstimateError::InvalidOption(
            "the gas constant must be positive and min_gauge_fraction non-negative".to_owned(),
        ));
    }
    let fit = ValveFit {
        fill: fit_channel(Channel::Fill, discharges, options)?,
        exhaust: fit_channel(Channel::Exhaust, discharges, options)?,
    };
    if fit.fill.is_none() && fit.exhaust.is_none() {
        return Err(EstimateError::InsufficientData {
            fit: FIT,
            reason: "no discharge has the role `estimation`".to_owned(),
        });
    }
    Ok(fit)
}
