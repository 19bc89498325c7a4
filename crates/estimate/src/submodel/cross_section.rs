//! Gas-volume cross-section `A(h) = A0 + A1 h` from a closed-valve run (thesis 5.2.1,
//! eq 5.1–5.3, Table 5.1).
//!
//! With the valve closed the amount of air `n` is constant (eq 3.18), so the ideal gas law
//! (eq 3.17) with `V = h A(h)` gives, sample by sample,
//!
//! ```text
//! p_abs,k = n R T / (h_k (A0 + A1 h_k)) = C / (h_k (1 + c h_k)),   c = A1/A0,  C = n R T / A0
//! ```
//!
//! with `h_k` the bellow height from the measured sensor height (SPEC §1 map inverted:
//! `h_b = h0 + k_l (s + k_scl m_tot g − h0)`) and `p_abs` the measured gauge pressure plus
//! ambient.
//!
//! **What a closed-valve run can and cannot determine (SPEC §4).** `A0`, `A1` and `n` enter
//! only through `C` and `c`: scaling `A0`, `A1` by any factor and `n` by the same factor
//! leaves every pressure unchanged. So the run fixes the *shape* `c = A1/A0` (and the
//! nuisance constant `C`), never the scale `A0`. We fit `(C, c)` by Gauss–Newton (separable
//! least squares, `C` in closed form for the start) and resolve the scale by
//! [`CrossSectionScale`]: keep `A0` from the nominal truck (default) and set `A1 = c A0`, or
//! take it from a known circuit volume at one height. The scale matters only when air
//! flows (it converts moles to pascals); [`crate::greybox`] can fit it from valve runs.
//!
//! NRMSE of the pressure model (Table 5.1): on the estimation run with its fitted `C`; on a
//! validation run with `c` fixed and that run's own `C` (its own amount of air) fitted by
//! least squares in closed form.

use airsus_data::{EffectiveAreaLaw, GasVolumeLaw};
use airsus_data::{Run, TruckParameters, ValveState};
use airsus_model::submodels::bellow_height_from_sensor_m;
use airsus_validate::nrmse_percent;
use serde::Serialize;

use crate::error::EstimateError;

const FIT: &str = "cross-section fit";

/// How the scale `A0`, which a closed-valve run cannot determine, is fixed.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum CrossSectionScale {
    /// `A0` from the nominal truck, `A1 = c A0` (default).
    #[default]
    KeepA0,
    /// The circuit's gas volume is known at one bellow height: `V = h A0 (1 + c h)`.
    KnownVolume {
        bellow_height_m: f64,
        volume_m3: f64,
    },
}

#[derive(Debug, Clone, PartialEq)]
pub struct CrossSectionOptions {
    pub scale: CrossSectionScale,
    /// Gauss–Newton iterations (each cheap: two parameters).
    pub max_iterations: usize,
    /// Fit only samples at least this long after the logged wheel load last changed, s
    /// (`None`: every sample, as thesis 5.2.1). A load step compresses or expands the gas
    /// faster than it exchanges heat, and the wall creeps after it: until both have settled
    /// `p V` is not the isothermal constant eq 5.2 assumes, and fitting the transients
    /// bends the shape (the virtual truck family: `c` 35 % short of the truth from every
    /// sample, 2-18 % from samples 120 s after a change). The first hold is timed from the
    /// run's start. At least three settled holds at different loads are needed.
    pub settled_after_s: Option<f64>,
}

impl Default for CrossSectionOptions {
    fn default() -> Self {
        Self::new()
    }
}

impl CrossSectionOptions {
    pub fn new() -> Self {
        Self {
            scale: CrossSectionScale::KeepA0,
            max_iterations: 50,
            settled_after_s: None,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CrossSectionFit {
    /// `c = A1/A0`, 1/m: the shape, what the run determines.
    pub ratio_per_m: f64,
    pub ratio_std_per_m: f64,
    pub a0_m2: f64,
    pub a1_m: f64,
    /// Standard deviation of `A1` given `A0` (`A0 · std(c)`).
    pub a1_std_m: f64,
    pub scale: CrossSectionScale,
    /// `C = n R T / A0`, Pa·m: the run's amount of air (nuisance).
    pub constant_pa_m: f64,
    pub samples: usize,
    /// Load holds the fitted samples come from ([`CrossSectionOptions::settled_after_s`];
    /// every hold when all samples are fitted).
    pub holds: usize,
    /// Bellow heights covered, m.
    pub bellow_height_range_m: (f64, f64),
    /// NRMSE of the pressure model on the estimation run, percent.
    pub nrmse_estimation_percent: f64,
    /// Per validation run: name and NRMSE, percent.
    pub nrmse_validation_percent: Vec<(String, f64)>,
    /// Validation runs scored on every sample because their loads were not held
    /// [`CrossSectionOptions::settled_after_s`] long enough for settled ones (empty when every
    /// sample is fitted anyway).
    pub validation_on_every_sample: Vec<String>,
    pub converged: bool,
}

impl CrossSectionFit {
    /// Writes `A0`, `A1` into a truck.
    pub fn write_to(&self, truck: &mut TruckParameters) {
        // The fit is of the thesis' law (eq 5.1); `fit_cross_section` refuses a truck under
        // another.
        truck.bellow.gas_volume = GasVolumeLaw::cross_section([self.a0_m2, self.a1_m]);
    }
}

/// Bellow heights (m) and absolute pressures (Pa) of a closed-valve run.
fn heights_and_pressures(
    run: &Run,
    truck: &TruckParameters,
    settled_after_s: Option<f64>,
) -> Result<(Vec<f64>, Vec<f64>, usize), EstimateError> {
    let bad = |reason: String| EstimateError::InsufficientData {
        fit: FIT,
        reason: format!("run `{}`: {reason}", run.name),
    };
    let out = run
        .outputs
        .as_ref()
        .ok_or_else(|| bad("it has no measured height and pressure".to_owned()))?;
    if let Some(k) = run
        .inputs
        .valve
        .iter()
        .position(|v| *v != ValveState::Closed)
    {
        return Err(bad(format!(
            "the valve is open at t = {} s; eq 5.2 needs a constant amount of air (valve closed throughout)",
            run.time_s[k]
        )));
    }
    let g = &truck.geometry;
    let kl = g.lever_gain();
    let grav = truck.environment.gravity_m_s2;
    let amb = truck.environment.ambient_pressure_pa;
    let mut h = Vec::with_capacity(run.len());
    let mut p = Vec::with_capacity(run.len());
    if let Some(settle) = settled_after_s
        && !(settle.is_finite() && settle >= 0.0)
    {
        return Err(EstimateError::InvalidOption(format!(
            "settled_after_s = {settle}: expected a time of zero or more seconds"
        )));
    }
    if run.is_empty() {
        return Err(bad("0 samples; at least 3 are needed".to_owned()));
    }
    let load = &run.inputs.wheel_load_kg;
    let (mut changed_s, mut holds, mut hold_counted) = (run.time_s[0], 0, false);
    // The loads of the settled holds: the shape needs three different ones.
    let mut settled_loads: Vec<f64> = Vec::new();
    for k in 0..run.len() {
        if k > 0 && load[k] != load[k - 1] {
            changed_s = run.time_s[k];
            hold_counted = false;
        }
        if settled_after_s.is_some_and(|settle| run.time_s[k] - changed_s < settle) {
            continue;
        }
        if !hold_counted {
            holds += 1;
            hold_counted = true;
            if !settled_loads.contains(&load[k]) {
                settled_loads.push(load[k]);
            }
        }
        let hb = bellow_height_from_sensor_m(
            g.h0_m,
            kl,
            out.sensor_height_m[k],
            g.lever_compliance_m_per_n,
            run.inputs.wheel_load_kg[k],
            grav,
        );
        let pa = out.bellow_gauge_pa[k] + amb;
        if !(hb.is_finite() && hb > 0.0 && pa.is_finite() && pa > 0.0) {
            return Err(bad(format!(
                "sample {k}: bellow height {hb} m and absolute pressure {pa} Pa are not physical"
            )));
        }
        h.push(hb);
        p.push(pa);
    }
    if let Some(settle) = settled_after_s
        && settled_loads.len() < 3
    {
        return Err(bad(format!(
            "{holds} load hold(s) at {} different load(s) last longer than {settle} s; the shape needs settled samples at three loads at least (hold each load longer, or fit every sample)",
            settled_loads.len()
        )));
    }
    if h.len() < 3 {
        return Err(bad(format!("{} samples; at least 3 are needed", h.len())));
    }
    Ok((h, p, holds))
}

/// `g_k = 1/(h (1 + c h))`.
fn basis(h: &[f64], c: f64) -> Option<Vec<f64>> {
    h.iter()
        .map(|&x| {
            let d = x * (1.0 + c * x);
            (d > 0.0).then(|| 1.0 / d)
        })
        .collect()
}

/// Closed-form `C` for a fixed shape, and the residual sum of squares.
fn best_constant(h: &[f64], p: &[f64], c: f64) -> Option<(f64, f64)> {
    let g = basis(h, c)?;
    let gg: f64 = g.iter().map(|x| x * x).sum();
    let gp: f64 = g.iter().zip(p).map(|(a, b)| a * b).sum();
    let big_c = gp / gg;
    let rss = g
        .iter()
        .zip(p)
        .map(|(gi, pi)| (pi - big_c * gi).powi(2))
        .sum();
    Some((big_c, rss))
}

/// Fits the shape of the volume law to a closed-valve run (module docs); `validation` runs
/// (also closed-valve) are scored with the fitted shape.
pub fn fit_cross_section(
    run: &Run,
    validation: &[&Run],
    truck: &TruckParameters,
    options: &CrossSectionOptions,
) -> Result<CrossSectionFit, EstimateError> {
    let (h, p, holds) = heights_and_pressures(run, truck, options.settled_after_s)?;
    let h_min = h.iter().copied().fold(f64::INFINITY, f64::min);
    let h_max = h.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !(h_max - h_min > 1e-4) {
        return Err(EstimateError::InsufficientData {
            fit: FIT,
            reason: format!(
                "the bellow height hardly changes ({:.3} mm): the run needs load steps that move it",
                (h_max - h_min) * 1e3
            ),
        });
    }
    let Some(&nominal) = truck.bellow.gas_volume.coefficients_m2() else {
        return Err(EstimateError::InvalidOption(format!(
            "the truck's gas-volume law is `{}`: the cross-section fit (thesis 5.2.1) fits the thesis' law `cross_section`; under the area integral the volume's shape is the effective area's, and only its dead volume `vd` is left to a grey-box fit with valve action",
            truck.bellow.gas_volume.tag()
        )));
    };
    let mut c = nominal[1] / nominal[0];
    let Some((mut big_c, mut rss)) = best_constant(&h, &p, c) else {
        return Err(EstimateError::InsufficientData {
            fit: FIT,
            reason: "the nominal cross-section gives a non-positive volume over the run".to_owned(),
        });
    };
    // Gauss–Newton on (C, c) with step halving: ∂p̂/∂C = g, ∂p̂/∂c = −C h² g².
    let mut converged = false;
    let max_iterations = options.max_iterations.max(1);
    for _ in 0..max_iterations {
        let Some(g) = basis(&h, c) else { break };
        let (mut a11, mut a12, mut a22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for k in 0..h.len() {
            let j1 = g[k];
            let j2 = -big_c * h[k] * h[k] * g[k] * g[k];
            let r = p[k] - big_c * g[k];
            a11 += j1 * j1;
            a12 += j1 * j2;
            a22 += j2 * j2;
            b1 += j1 * r;
            b2 += j2 * r;
        }
        let det = a11 * a22 - a12 * a12;
        if !(det > 0.0) {
            break;
        }
        let d_big_c = (a22 * b1 - a12 * b2) / det;
        let dc = (a11 * b2 - a12 * b1) / det;
        let mut step = 1.0;
        let mut improved = false;
        while step > 1e-6 {
            let (nc, nbc) = (c + step * dc, big_c + step * d_big_c);
            if let Some(gn) = basis(&h, nc) {
                let nrss: f64 = gn
                    .iter()
                    .zip(&p)
                    .map(|(gi, pi)| (pi - nbc * gi).powi(2))
                    .sum();
                if nrss <= rss {
                    let rel = (rss - nrss) / rss.max(f64::MIN_POSITIVE);
                    c = nc;
                    big_c = nbc;
                    rss = nrss;
                    improved = true;
                    if rel < 1e-14 || (dc * step).abs() < 1e-12 * (1.0 + c.abs()) {
                        converged = true;
                    }
                    break;
                }
            }
            step *= 0.5;
        }
        if !improved {
            converged = true; // no descent direction left: a minimum to rounding
            break;
        }
        if converged {
            break;
        }
    }
    // Standard deviations: σ² (JᵀJ)⁻¹ at the optimum.
    let g = basis(&h, c).unwrap_or_default();
    let (mut a11, mut a12, mut a22) = (0.0, 0.0, 0.0);
    for k in 0..g.len() {
        let j1 = g[k];
        let j2 = -big_c * h[k] * h[k] * g[k] * g[k];
        a11 += j1 * j1;
        a12 += j1 * j2;
        a22 += j2 * j2;
    }
    let det = a11 * a22 - a12 * a12;
    let sigma2 = rss / (h.len() as f64 - 2.0);
    let ratio_std = if det > 0.0 {
        (sigma2 * a11 / det).sqrt()
    } else {
        f64::INFINITY
    };
    let fitted: Vec<f64> = g.iter().map(|gi| big_c * gi).collect();
    let nrmse_estimation_percent =
        nrmse_percent(&p, &fitted).map_err(|e| EstimateError::InsufficientData {
            fit: FIT,
            reason: format!("NRMSE: {e}"),
        })?;

    let a0 = match options.scale {
        CrossSectionScale::KeepA0 => nominal[0],
        CrossSectionScale::KnownVolume {
            bellow_height_m,
            volume_m3,
        } => {
            let denom = bellow_height_m * (1.0 + c * bellow_height_m);
            if !(denom > 0.0 && volume_m3 > 0.0 && volume_m3.is_finite()) {
                return Err(EstimateError::InvalidOption(format!(
                    "known volume {volume_m3} m³ at {bellow_height_m} m does not give a positive A0 with c = {c}"
                )));
            }
            volume_m3 / denom
        }
    };
    let mut nrmse_validation_percent = Vec::new();
    let mut validation_on_every_sample = Vec::new();
    for v in validation {
        // A validation run whose loads are not held long enough is scored on every sample,
        // and named.
        let (hv, pv, _) = match heights_and_pressures(v, truck, options.settled_after_s) {
            Ok(settled) => settled,
            Err(_) => {
                validation_on_every_sample.push(v.name.clone());
                heights_and_pressures(v, truck, None)?
            }
        };
        let nrmse = best_constant(&hv, &pv, c)
            .and_then(|(cv, _)| {
                let g = basis(&hv, c)?;
                let fit: Vec<f64> = g.iter().map(|gi| cv * gi).collect();
                nrmse_percent(&pv, &fit).ok()
            })
            .ok_or_else(|| EstimateError::InsufficientData {
                fit: FIT,
                reason: format!(
                    "validation run `{}`: the fitted shape gives no usable pressure model",
                    v.name
                ),
            })?;
        nrmse_validation_percent.push((v.name.clone(), nrmse));
    }
    // Sanity: the fitted law must give a positive cross-section over the run.
    let fitted = GasVolumeLaw::cross_section([a0, c * a0]);
    let area = &truck.bellow.effective_area;
    if !(fitted.cross_section_m2(area, h_min) > 0.0 && fitted.cross_section_m2(area, h_max) > 0.0) {
        return Err(EstimateError::InsufficientData {
            fit: FIT,
            reason: format!("the fitted shape c = {c} 1/m gives a non-positive cross-section"),
        });
    }
    Ok(CrossSectionFit {
        ratio_per_m: c,
        ratio_std_per_m: ratio_std,
        a0_m2: a0,
        a1_m: c * a0,
        a1_std_m: ratio_std * a0,
        scale: options.scale,
        constant_pa_m: big_c,
        samples: h.len(),
        holds,
        bellow_height_range_m: (h_min, h_max),
        nrmse_estimation_percent,
        nrmse_validation_percent,
        validation_on_every_sample,
        converged,
    })
}

/// The area-integral volume law `V = V_d + N ∫ A_eff` fitted to a closed-valve run in place
/// of the thesis' cross-section ([`fit_dead_volume`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DeadVolumeFit {
    /// `V_d`, m³.
    pub dead_volume_m3: f64,
    /// `N`, the bellows sharing the circuit.
    pub bellows: u32,
    /// `n R T`, J: the run's amount of air (nuisance).
    pub constant_j: f64,
    pub samples: usize,
    /// NRMSE of the pressure model on the fitted samples, percent: comparable with
    /// [`CrossSectionFit::nrmse_estimation_percent`] on the same samples.
    pub nrmse_estimation_percent: f64,
}

impl DeadVolumeFit {
    /// The volume law it fitted.
    pub fn law(&self) -> GasVolumeLaw {
        GasVolumeLaw::AreaIntegral {
            dead_volume_m3: self.dead_volume_m3,
            bellows: self.bellows,
        }
    }
}

/// The area-integral volume (`GasVolumeLaw::AreaIntegral`, `dV/dh = N A_eff`, #13 item 3)
/// fitted to the same closed-valve samples as [`fit_cross_section`]: with the valve closed,
/// `p_abs = n R T / (V_d + N S(h))`, `S(h) = ∫₀ʰ A_eff`, so `1/p_abs` is linear in `S`:
/// `1/p = V_d/(nRT) + N S/(nRT)`. Solved by least squares in `1/p` weighted by `p⁴` (the
/// residual in pressure to first order), in closed form: two parameters, no iteration.
///
/// Why beside the thesis' law: a bellow's volume sweeps its effective area (virtual work);
/// with a large dead volume (piping, an auxiliary tank) the volume changes with height far
/// less, relative to its size, than `h (A0 + A1 h)` can without bending over. Fitted to such
/// a truck, the thesis' law took `A1/A0` so negative that its volume peaked inside the
/// stroke (virtual-truck variant 5: at 0.27 m bellow height), above which the gas spring's
/// stiffness is negative and no simulation survives.
///
/// `area`: the effective area the models use (its zero-gauge law; a stretch with pressure
/// changes the force, not the volume swept). `bellows`: `N`.
pub fn fit_dead_volume(
    run: &Run,
    truck: &TruckParameters,
    area: &EffectiveAreaLaw,
    bellows: u32,
    options: &CrossSectionOptions,
) -> Result<DeadVolumeFit, EstimateError> {
    const FIT_DV: &str = "dead-volume fit";
    let (h, p, _) = heights_and_pressures(run, truck, options.settled_after_s)?;
    let n = f64::from(bellows.max(1));
    let swept: Vec<f64> = h.iter().map(|&x| n * area.integral_m3(x)).collect();
    // Weighted least squares of y = 1/p on (1, S), weights p⁴.
    let (mut sw, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (&s_k, &p_k) in swept.iter().zip(&p) {
        let w = p_k.powi(4);
        let y = 1.0 / p_k;
        sw += w;
        sx += w * s_k;
        sy += w * y;
        sxx += w * s_k * s_k;
        sxy += w * s_k * y;
    }
    let det = sw * sxx - sx * sx;
    let insufficient = |reason: String| EstimateError::InsufficientData {
        fit: FIT_DV,
        reason: format!("run `{}`: {reason}", run.name),
    };
    if !(det > 0.0) {
        return Err(insufficient(
            "the swept volume hardly changes over the run".to_owned(),
        ));
    }
    let intercept = (sxx * sy - sx * sxy) / det;
    let slope = (sw * sxy - sx * sy) / det;
    if !(slope > 0.0 && intercept.is_finite()) {
        return Err(insufficient(format!(
            "the pressure does not fall as the swept volume grows (slope {slope:e} 1/(Pa m³))"
        )));
    }
    let constant_j = 1.0 / slope;
    let dead_volume_m3 = intercept / slope;
    let fitted: Vec<f64> = swept
        .iter()
        .map(|s_k| constant_j / (dead_volume_m3 + s_k))
        .collect();
    if !(dead_volume_m3 > 0.0) || fitted.iter().any(|f| !(f.is_finite() && *f > 0.0)) {
        return Err(insufficient(format!(
            "the fitted dead volume {dead_volume_m3:.4e} m³ is not positive"
        )));
    }
    let nrmse_estimation_percent =
        nrmse_percent(&p, &fitted).map_err(|e| insufficient(format!("NRMSE: {e}")))?;
    Ok(DeadVolumeFit {
        dead_volume_m3,
        bellows,
        constant_j,
        samples: h.len(),
        nrmse_estimation_percent,
    })
}
