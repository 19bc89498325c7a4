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

use airsus_data::params::MAX_AREA_KNOTS;
use airsus_data::{EffectiveAreaLaw, ForceMap, TruckParameters};
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
    /// The law's growth of the area with pressure, `κ` per 100 kPa, when the truck's law has
    /// one (`polynomial_pressure`, a spline with `growth_per_100kpa`): the fitted areas are
    /// then those at zero gauge pressure, `F = p A(h) (1 + κ p / 100 kPa)`, so that the law
    /// written back does not count the stretch twice. `None`: `F = p A(h)` (thesis 5.2.2).
    pub growth_per_100kpa: Option<f64>,
    /// Fit `κ` from the map as well ([`fit_area_growth`]), in place of `growth_per_100kpa`:
    /// a map at several pressures per height determines it, and a `κ` assumed instead bends
    /// the areas by the error times the map's mean pressure (the virtual truck family: the
    /// built-in 0.004 for a bellow at 0.0048 put the area 0.4 % high over the whole stroke).
    pub fit_growth: bool,
}

impl Default for EffectiveAreaOptions {
    fn default() -> Self {
        Self {
            degree: 4,
            height_tolerance_m: 1e-4,
            growth_per_100kpa: None,
            fit_growth: false,
        }
    }
}

impl EffectiveAreaOptions {
    /// The defaults, with the growth of `truck`'s area law if it has one.
    pub fn for_truck(truck: &TruckParameters) -> Self {
        let area = &truck.bellow.effective_area;
        Self {
            growth_per_100kpa: area.depends_on_pressure().then(|| area.growth_per_100kpa()),
            ..Self::default()
        }
    }

    /// The growth the areas are fitted under: fitted from `map` when asked for
    /// ([`Self::fit_growth`]), with its standard deviation, else the given one.
    fn growth(&self, map: &ForceMap) -> Result<(Option<f64>, Option<f64>), EstimateError> {
        if self.fit_growth {
            let fit = fit_area_growth(map, self.height_tolerance_m)?;
            Ok((Some(fit.growth_per_100kpa), Some(fit.growth_std_per_100kpa)))
        } else {
            Ok((self.growth_per_100kpa, None))
        }
    }
}

/// The relative growth of the effective area with gauge pressure, `κ` per 100 kPa, read off a
/// force map: `F = p A_h (1 + κ p)` with one area `A_h` per height and one `κ` for the map.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AreaGrowthFit {
    pub growth_per_100kpa: f64,
    pub growth_std_per_100kpa: f64,
    /// Heights measured at two or more pressures (those that carry `κ`).
    pub heights: usize,
}

/// The range `κ` is searched over, per 100 kPa: a rolling-lobe bellow's area grows by a few
/// tenths of a percent per 100 kPa; ten times that either way is far outside any bellow.
const GROWTH_SEARCH_PER_100KPA: (f64, f64) = (-0.05, 0.05);

/// Golden-section steps after the scan: its bracket of 0.002 per 100 kPa times 0.618³¹ is
/// under 1e-9.
const GROWTH_GOLDEN_STEPS: usize = 31;

/// Pressures of one height closer than this (or than 1 %) are one pressure, Pa.
const PRESSURE_TOLERANCE_PA: f64 = 1e3;

/// Fits `κ` (module docs of [`AreaGrowthFit`]) by variable projection: for a given `κ` every
/// height's area is linear least squares in closed form (step 1), so the residual is a
/// function of `κ` alone, minimised by a scan and golden-section refinement (a smooth 1-D
/// profile; no crate needed for that). The standard deviation is from the profile's
/// curvature. Needs at least two heights measured at two or more pressures.
pub fn fit_area_growth(map: &ForceMap, tolerance_m: f64) -> Result<AreaGrowthFit, EstimateError> {
    let bad = |reason: String| EstimateError::InsufficientData { fit: FIT, reason };
    let rss = |growth: f64| -> Result<f64, EstimateError> {
        Ok(per_height_areas(map, tolerance_m, Some(growth))?
            .iter()
            .map(|g| g.residual_n2)
            .sum())
    };
    let groups = per_height_areas(map, tolerance_m, None)?;
    let heights = groups.iter().filter(|g| g.pressures > 1).count();
    if heights < 2 {
        return Err(bad(format!(
            "{heights} height(s) measured at two or more pressures; the area's growth with pressure needs two at least"
        )));
    }
    let (low, high) = GROWTH_SEARCH_PER_100KPA;
    let steps = 100;
    let at = |i: usize| low + (high - low) * i as f64 / steps as f64;
    let mut best = (0, f64::INFINITY);
    for i in 0..=steps {
        let r = rss(at(i))?;
        if r < best.1 {
            best = (i, r);
        }
    }
    // The profile is smooth: golden section in the scan's best bracket (two scan steps) to
    // 1e-9. `rss` fails only on the map itself, which the scan has already read.
    let (growth, _) = crate::load_ramp::golden_section_min(
        &mut |g| rss(g).unwrap_or(f64::INFINITY),
        at(best.0.saturating_sub(1)),
        at((best.0 + 1).min(steps)),
        GROWTH_GOLDEN_STEPS,
    );
    if growth <= low + 1e-6 || growth >= high - 1e-6 {
        return Err(bad(format!(
            "the map's forces call for an area growth of {growth} per 100 kPa, at the end of the plausible range {low}..{high}: check the map's pressure and force units"
        )));
    }
    // σ²(κ) = σ² / (½ d²RSS/dκ²), σ² = RSS / (N − number of heights − 1).
    let r0 = rss(growth)?;
    let step = 1e-4;
    let curvature = (rss(growth + step)? - 2.0 * r0 + rss(growth - step)?) / (step * step);
    let dof = map.len().saturating_sub(groups.len() + 1).max(1) as f64;
    let std = if curvature > 0.0 {
        (r0 / dof / (0.5 * curvature)).sqrt()
    } else {
        f64::INFINITY
    };
    Ok(AreaGrowthFit {
        growth_per_100kpa: growth,
        growth_std_per_100kpa: std,
        heights,
    })
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EffectiveAreaFit {
    /// `p0, p1, …` of `A_eff(h) = Σ p_i h^i` (h in m, area in m²).
    pub poly: Vec<f64>,
    pub poly_std: Vec<f64>,
    /// The growth with pressure the areas were fitted under, `κ` per 100 kPa (given, or
    /// fitted: [`EffectiveAreaOptions::fit_growth`]); `None`: `F = p A(h)`.
    pub growth_per_100kpa: Option<f64>,
    /// Its standard deviation where it was fitted.
    pub growth_std_per_100kpa: Option<f64>,
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
        // the truck's law has (`kap`) is kept, not dropped unsaid (fit with
        // `EffectiveAreaOptions::for_truck`, so that the quartic is the area at zero
        // pressure). A truck under a law without a quartic keeps its law: the fit of that law
        // is asked for by name.
        let law = truck.bellow.effective_area.tag();
        let coefficients = truck
            .bellow
            .effective_area
            .coefficients_m2_mut()
            .ok_or_else(|| {
                EstimateError::InvalidOption(format!(
                    "the truck's effective area follows law \"{law}\", which has no quartic to replace; fit that law instead (the spline fit of the force map)"
                ))
            })?;
        *coefficients = poly;
        if let Some(growth) = self.growth_per_100kpa {
            truck
                .bellow
                .effective_area
                .set(airsus_data::params::Field::AreaPressureGrowth, growth);
        }
        Ok(())
    }

    /// The fit as a law of its own: the quartic, stretched with pressure by the growth it was
    /// fitted under (`polynomial_pressure`) where it has one.
    pub fn law(&self) -> Result<EffectiveAreaLaw, EstimateError> {
        let coefficients_m2: [f64; 5] = self.poly.clone().try_into().map_err(|_| {
            EstimateError::InvalidOption(format!(
                "a truck's effective area is a quartic; this fit has degree {}",
                self.poly.len().saturating_sub(1)
            ))
        })?;
        Ok(match self.growth_per_100kpa {
            Some(growth_per_100kpa) => EffectiveAreaLaw::PressurePolynomial {
                coefficients_m2,
                growth_per_100kpa,
            },
            None => EffectiveAreaLaw::Polynomial { coefficients_m2 },
        })
    }
}

/// One height of the force map: the least-squares area of `F = p A` over its pressures.
#[derive(Debug, Clone, Copy, PartialEq)]
struct HeightArea {
    height_m: f64,
    area_m2: f64,
    /// From the scatter of the height's forces about `p A`; NaN for a single point.
    area_std_m2: f64,
    points: usize,
    /// `Σ p²` over the group: the area's weight when groups are merged.
    weight: f64,
    /// `Σ (F − q A)²` over the group, N².
    residual_n2: f64,
    /// Distinct pressures in the group.
    pressures: usize,
}

/// Step 1 of both fits: the map's points grouped by height (within `tolerance_m`), each
/// group's area by least squares through the origin, in increasing height.
fn per_height_areas(
    map: &ForceMap,
    tolerance_m: f64,
    growth_per_100kpa: Option<f64>,
) -> Result<Vec<HeightArea>, EstimateError> {
    let kappa = growth_per_100kpa.unwrap_or(0.0) / 1e5;
    // The regressor of the area: F = A q.
    let q = |k: usize| map.bellow_gauge_pa[k] * (1.0 + kappa * map.bellow_gauge_pa[k]);
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
    let mut per_height: Vec<HeightArea> = Vec::new();
    let mut i = 0;
    while i < order.len() {
        let h_first = map.bellow_height_m[order[i]];
        let mut j = i;
        let (mut fp, mut pp, mut hs) = (0.0, 0.0, 0.0);
        while j < order.len() && map.bellow_height_m[order[j]] - h_first <= tolerance_m {
            let k = order[j];
            fp += map.force_n[k] * q(k);
            pp += q(k).powi(2);
            hs += map.bellow_height_m[k];
            j += 1;
        }
        let area = fp / pp;
        // The area's standard deviation from the group's own scatter about F = A q.
        let residual: f64 = order[i..j]
            .iter()
            .map(|&k| (map.force_n[k] - q(k) * area).powi(2))
            .sum();
        let std = if j - i > 1 {
            (residual / (j - i - 1) as f64 / pp).sqrt()
        } else {
            f64::NAN
        };
        let mut pressures: Vec<f64> = order[i..j]
            .iter()
            .map(|&k| map.bellow_gauge_pa[k])
            .collect();
        pressures.sort_by(f64::total_cmp);
        // One nominal pressure logged with some jitter is one pressure.
        pressures.dedup_by(|a, b| (*a - *b).abs() <= PRESSURE_TOLERANCE_PA.max(0.01 * b.abs()));
        per_height.push(HeightArea {
            height_m: hs / (j - i) as f64,
            area_m2: area,
            area_std_m2: std,
            points: j - i,
            weight: pp,
            residual_n2: residual,
            pressures: pressures.len(),
        });
        i = j;
    }
    Ok(per_height)
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
    let (growth_per_100kpa, growth_std_per_100kpa) = options.growth(map)?;
    let per_height: Vec<(f64, f64, usize)> =
        per_height_areas(map, options.height_tolerance_m, growth_per_100kpa)?
            .iter()
            .map(|g| (g.height_m, g.area_m2, g.points))
            .collect();
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
        growth_per_100kpa,
        growth_std_per_100kpa,
        per_height,
        area_nrmse_percent: 0.0,
        force_nrmse_percent: 0.0,
        points: n,
    };
    let areas: Vec<f64> = fit.per_height.iter().map(|x| x.1).collect();
    let area_fit: Vec<f64> = fit.per_height.iter().map(|x| fit.area_m2(x.0)).collect();
    let kappa = growth_per_100kpa.unwrap_or(0.0) / 1e5;
    let force_fit: Vec<f64> = (0..n)
        .map(|k| {
            let p = map.bellow_gauge_pa[k];
            p * fit.area_m2(map.bellow_height_m[k]) * (1.0 + kappa * p)
        })
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

/// The effective area as a monotone spline (the truck file's law `spline`) through the force
/// map's per-height areas: one knot per measured height, its area the least-squares area of
/// step 1. Where the map has more heights than a spline has knots ([`MAX_AREA_KNOTS`]),
/// neighbouring heights are merged into equal-count groups (their areas averaged with the
/// weights `Σ p²` of step 1, their heights by point count).
///
/// Unlike the quartic, the spline follows the map's own shape (no fitted curve between the
/// heights to miss a bend), never overshoots it between heights, and holds its end areas
/// beyond the measured stroke instead of extrapolating.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SplineAreaFit {
    /// Knot bellow heights, m, increasing.
    pub heights_m: Vec<f64>,
    /// Knot areas `s0, s1, ..`, m².
    pub areas_m2: Vec<f64>,
    /// Their standard deviations from each height's scatter, m² (NaN for a single point).
    pub areas_std_m2: Vec<f64>,
    /// NRMSE of the predicted force `p A_eff(h, p)` against the measured forces, percent.
    pub force_nrmse_percent: f64,
    /// The growth with pressure the areas were fitted under ([`EffectiveAreaOptions`]).
    pub growth_per_100kpa: Option<f64>,
    /// The map's distinct heights (more than the knots where groups were merged).
    pub map_heights: usize,
    pub points: usize,
}

impl SplineAreaFit {
    /// The spline law of this fit, stretched by `growth_per_100kpa` when given.
    pub fn law(&self, growth_per_100kpa: Option<f64>) -> Result<EffectiveAreaLaw, EstimateError> {
        EffectiveAreaLaw::spline(
            self.heights_m.clone(),
            self.areas_m2.clone(),
            growth_per_100kpa,
        )
        .map_err(|reason| EstimateError::InsufficientData { fit: FIT, reason })
    }

    /// The area at bellow height `h` and zero gauge pressure, m² (the spline through the
    /// knots).
    pub fn area_m2(&self, h: f64) -> f64 {
        self.law(None).map_or(f64::NAN, |law| law.area_m2(h, 0.0))
    }

    /// Makes the truck's effective area this spline, with the growth it was fitted under
    /// (fit with [`EffectiveAreaOptions::for_truck`] to keep the truck's). Under the
    /// area-integral gas volume the dead volume takes up the change of the integral at the
    /// middle knot, so that the gas volume there stays what it was (the spline is held at its
    /// first knot's area below it, where a quartic was integrated as it stands). A knot area
    /// outside its declared range leaves the truck unchanged, with the error.
    pub fn write_to(&self, truck: &mut TruckParameters) -> Result<(), EstimateError> {
        for (i, &area) in self.areas_m2.iter().enumerate() {
            super::check_declared(airsus_data::params::Field::AreaKnot(i), area)?;
        }
        let law = self.law(self.growth_per_100kpa)?;
        if let airsus_data::GasVolumeLaw::AreaIntegral {
            dead_volume_m3,
            bellows,
        } = truck.bellow.gas_volume
        {
            let reference_m = self.heights_m[self.heights_m.len() / 2];
            let swept =
                |area: &EffectiveAreaLaw| f64::from(bellows) * area.integral_m3(reference_m);
            let dead = dead_volume_m3 + swept(&truck.bellow.effective_area) - swept(&law);
            super::check_declared(airsus_data::params::Field::DeadVolume, dead)?;
            truck.bellow.gas_volume = airsus_data::GasVolumeLaw::AreaIntegral {
                dead_volume_m3: dead,
                bellows,
            };
        }
        truck.bellow.effective_area = law;
        Ok(())
    }
}

pub fn fit_effective_area_spline(
    map: &ForceMap,
    options: &EffectiveAreaOptions,
) -> Result<SplineAreaFit, EstimateError> {
    let (growth_per_100kpa, _) = options.growth(map)?;
    let groups = per_height_areas(map, options.height_tolerance_m, growth_per_100kpa)?;
    let map_heights = groups.len();
    if map_heights < 2 {
        return Err(EstimateError::InsufficientData {
            fit: FIT,
            reason: format!("{map_heights} distinct height(s); a spline needs at least 2"),
        });
    }
    let knots: Vec<HeightArea> = if map_heights <= MAX_AREA_KNOTS {
        groups
    } else {
        (0..MAX_AREA_KNOTS)
            .map(|b| {
                let merged = &groups
                    [b * map_heights / MAX_AREA_KNOTS..(b + 1) * map_heights / MAX_AREA_KNOTS];
                let weight: f64 = merged.iter().map(|g| g.weight).sum();
                let points: usize = merged.iter().map(|g| g.points).sum();
                HeightArea {
                    height_m: merged
                        .iter()
                        .map(|g| g.height_m * g.points as f64)
                        .sum::<f64>()
                        / points as f64,
                    area_m2: merged.iter().map(|g| g.area_m2 * g.weight).sum::<f64>() / weight,
                    area_std_m2: merged
                        .iter()
                        .map(|g| (g.area_std_m2 * g.weight).powi(2))
                        .sum::<f64>()
                        .sqrt()
                        / weight,
                    points,
                    weight,
                    residual_n2: merged.iter().map(|g| g.residual_n2).sum(),
                    pressures: merged.iter().map(|g| g.pressures).max().unwrap_or(0),
                }
            })
            .collect()
    };
    let mut fit = SplineAreaFit {
        heights_m: knots.iter().map(|g| g.height_m).collect(),
        areas_m2: knots.iter().map(|g| g.area_m2).collect(),
        areas_std_m2: knots.iter().map(|g| g.area_std_m2).collect(),
        force_nrmse_percent: f64::NAN,
        growth_per_100kpa,
        map_heights,
        points: map.len(),
    };
    let law = fit.law(fit.growth_per_100kpa)?;
    let force_fit: Vec<f64> = (0..map.len())
        .map(|k| {
            let p = map.bellow_gauge_pa[k];
            p * law.area_m2(map.bellow_height_m[k], p)
        })
        .collect();
    fit.force_nrmse_percent =
        nrmse_percent(&map.force_n, &force_fit).map_err(|e| EstimateError::InsufficientData {
            fit: FIT,
            reason: format!("NRMSE: {e}"),
        })?;
    Ok(fit)
}
