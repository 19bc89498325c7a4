//! Effective area from a bellow force map (thesis 5.2.2, eq 3.16 and 5.4, Table 5.2).
//!
//! 1. Per height: eq 3.16, `F = p_gauge A_eff(h)`, is linear in `A_eff` with no intercept, so
//!    the least-squares area over that height's pressures is `A_h = Σ F p / Σ p²`.
//!    (Points whose heights agree within `height_tolerance_m` form one height.)
//! 2. A polynomial of degree 4 (eq 5.4) through the `(h, A_h)` points by least squares. The
//!    monomials `1, h, …, h⁴` over a 0.2 m stroke are nearly collinear, so the fit is done in
//!    the centred, scaled variable `x = (h − h̄)/s` by QR and converted back to monomial
//!    coefficients in `h` (the truck file's `p0..p4`); standard deviations are propagated
//!    through that linear map.
//!
//! Reported: the NRMSE of the polynomial against the per-height areas, and of the force it
//! predicts, `p A_eff(h)`, against every measured force (what thesis Fig 5.8 shows). The map
//! is measured with the bellow moved vertically; the truck's lever moves it on an arc — the
//! thesis refines `p0..p4` by grey-box estimation for that reason.

use airsus_data::{ForceMap, TruckParameters};
use airsus_validate::nrmse_percent;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::error::EstimateError;

const FIT: &str = "effective-area fit";

#[derive(Debug, Clone, PartialEq)]
pub struct EffectiveAreaOptions {
    /// Polynomial degree (thesis: 4).
    pub degree: usize,
    /// Heights closer than this are one height, m.
    pub height_tolerance_m: f64,
}

impl Default for EffectiveAreaOptions {
    fn default() -> Self {
        Self {
            degree: 4,
            height_tolerance_m: 1e-4,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EffectiveAreaFit {
    /// `p0, p1, …` of `A_eff(h) = Σ p_i h^i` (h in m, area in m²).
    pub poly: Vec<f64>,
    pub poly_std: Vec<f64>,
    /// The per-height least-squares areas (step 1): height m, area m², points.
    pub per_height: Vec<(f64, f64, usize)>,
    /// NRMSE of the polynomial against the per-height areas, percent.
    pub area_nrmse_percent: f64,
    /// NRMSE of the predicted force `p A_eff(h)` against the measured forces, percent.
    pub force_nrmse_percent: f64,
    pub points: usize,
}

impl EffectiveAreaFit {
    /// The area at bellow height `h`, m².
    pub fn area_m2(&self, h: f64) -> f64 {
        self.poly.iter().rev().fold(0.0, |acc, p| acc * h + p)
    }

    /// Writes `p0..p4` into a truck (only a degree-4 fit fits the truck file's five keys).
    pub fn write_to(&self, truck: &mut TruckParameters) -> Result<(), EstimateError> {
        let poly: [f64; 5] = self.poly.clone().try_into().map_err(|_| {
            EstimateError::InvalidOption(format!(
                "the truck file holds a degree-4 effective area; this fit has degree {}",
                self.poly.len().saturating_sub(1)
            ))
        })?;
        // The fit is of the quartic (eq 5.4): it replaces the law's quartic; a pressure growth
        // the truck's law has (`kap`) is kept, not dropped unsaid.
        *truck.bellow.effective_area.coefficients_m2_mut() = poly;
        Ok(())
    }
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

pub fn fit_effective_area(
    map: &ForceMap,
    options: &EffectiveAreaOptions,
) -> Result<EffectiveAreaFit, EstimateError> {
    let bad = |reason: String| EstimateError::InsufficientData { fit: FIT, reason };
    let n = map.len();
    if map.bellow_gauge_pa.len() != n || map.force_n.len() != n {
        return Err(bad("the force map's columns differ in length".to_owned()));
    }
    // Step 1: group by height, LS area through the origin.
    let mut order: Vec<usize> = (0..n)
        .filter(|&k| {
            map.bellow_height_m[k].is_finite()
                && map.bellow_gauge_pa[k].is_finite()
                && map.force_n[k].is_finite()
                && map.bellow_gauge_pa[k] != 0.0
        })
        .collect();
    if order.len() < n {
        return Err(bad(format!(
            "{} of {n} points have a zero or non-finite pressure, height or force",
            n - order.len()
        )));
    }
    order.sort_by(|&a, &b| map.bellow_height_m[a].total_cmp(&map.bellow_height_m[b]));
    let mut per_height: Vec<(f64, f64, usize)> = Vec::new();
    let mut i = 0;
    while i < order.len() {
        let h_first = map.bellow_height_m[order[i]];
        let mut j = i;
        let (mut fp, mut pp, mut hs) = (0.0, 0.0, 0.0);
        while j < order.len()
            && map.bellow_height_m[order[j]] - h_first <= options.height_tolerance_m
        {
            let k = order[j];
            fp += map.force_n[k] * map.bellow_gauge_pa[k];
            pp += map.bellow_gauge_pa[k].powi(2);
            hs += map.bellow_height_m[k];
            j += 1;
        }
        per_height.push((hs / (j - i) as f64, fp / pp, j - i));
        i = j;
    }
    let d = options.degree;
    let m = per_height.len();
    if m < d + 2 {
        return Err(bad(format!(
            "{m} distinct heights; a degree-{d} polynomial needs at least {} (one more than its coefficients, to judge the fit)",
            d + 2
        )));
    }
    // Step 2: polynomial in x = (h − h̄)/s by QR.
    let h_mean = per_height.iter().map(|x| x.0).sum::<f64>() / m as f64;
    let s = per_height
        .iter()
        .map(|x| (x.0 - h_mean).abs())
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let x = DMatrix::from_fn(m, d + 1, |r, c| {
        ((per_height[r].0 - h_mean) / s).powi(c as i32)
    });
    let y = DVector::from_iterator(m, per_height.iter().map(|x| x.1));
    let qr = x.clone().qr();
    let r = qr.r();
    let qty = qr.q().transpose() * &y;
    let coef_x = r
        .solve_upper_triangular(&qty)
        .ok_or_else(|| bad("the heights do not determine the polynomial".to_owned()))?;
    let resid = &y - &x * &coef_x;
    let sigma2 = resid.norm_squared() / (m - d - 1) as f64;
    let r_inv = r
        .try_inverse()
        .ok_or_else(|| bad("the heights do not determine the polynomial".to_owned()))?;
    let cov_x = sigma2 * &r_inv * r_inv.transpose();
    // Monomials in h: ((h − h̄)/s)^c = s^{−c} Σ_i C(c,i) h^i (−h̄)^{c−i}, so p = T a.
    let t = DMatrix::from_fn(d + 1, d + 1, |i, c| {
        if i > c {
            0.0
        } else {
            binomial(c, i) * (-h_mean).powi((c - i) as i32) / s.powi(c as i32)
        }
    });
    let poly_v = &t * &coef_x;
    let cov_p = &t * cov_x * t.transpose();
    let poly: Vec<f64> = poly_v.iter().copied().collect();
    let poly_std: Vec<f64> = (0..=d).map(|i| cov_p[(i, i)].max(0.0).sqrt()).collect();
    let fit = EffectiveAreaFit {
        poly,
        poly_std,
        per_height,
        area_nrmse_percent: 0.0,
        force_nrmse_percent: 0.0,
        points: n,
    };
    let areas: Vec<f64> = fit.per_height.iter().map(|x| x.1).collect();
    let area_fit: Vec<f64> = fit.per_height.iter().map(|x| fit.area_m2(x.0)).collect();
    let force_fit: Vec<f64> = (0..n)
        .map(|k| map.bellow_gauge_pa[k] * fit.area_m2(map.bellow_height_m[k]))
        .collect();
    let nrmse = |a: &[f64], b: &[f64]| {
        nrmse_percent(a, b).map_err(|e| EstimateError::InsufficientData {
            fit: FIT,
            reason: format!("NRMSE: {e}"),
        })
    };
    Ok(EffectiveAreaFit {
        area_nrmse_percent: nrmse(&areas, &area_fit)?,
        force_nrmse_percent: nrmse(&map.force_n, &force_fit)?,
        ..fit
    })
}
