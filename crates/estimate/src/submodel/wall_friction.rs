//! The bellow wall's sliding friction from the hysteresis of a force map.
//!
//! A force map is measured in sweeps: at each pressure the bellow is moved up through its
//! heights and down again, slowly. Moving slowly, the wall's friction element (the `truck`
//! structure's Dahl element, `fc`) slides at its full force against the motion: moving up
//! (extension) it lowers the force the load cell reads, moving down it raises it. At one
//! height and pressure the two readings therefore differ by twice the sliding force,
//!
//! ```text
//! F_down(h, p) − F_up(h, p) = 2 F_c,
//! ```
//!
//! whatever the effective area. The thesis' evaluation (5.2.2) averages the two away; this fit
//! reads `F_c` from them, the one value of the wall a lab measures directly (the valve runs
//! otherwise take it for volume or flow: on virtual-truck variant 2, `fc` at the built-in
//! 120 N instead of the true 183 N costs the held-out data-set 4 ten points of pressure).
//!
//! The sweep direction of each point comes from the map's row order: a point is on an upward
//! sweep when its height is above the previous point's at the same pressure (the first point
//! of a sweep, and a repeated turning point, take the direction of the point after them).
//! Each upward point is paired with a downward point at the same height and pressure.

use airsus_data::ForceMap;
use serde::Serialize;

use crate::error::EstimateError;

const FIT: &str = "wall-friction fit";

/// Pressures closer than this are one pressure, Pa.
const PRESSURE_TOLERANCE_PA: f64 = 1e3;

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WallFrictionFit {
    /// `F_c`: half the mean difference of the downward and upward forces, N.
    pub friction_force_n: f64,
    /// Its standard deviation from the pairs' scatter, N.
    pub friction_force_std_n: f64,
    /// Up/down pairs at the same height and pressure.
    pub pairs: usize,
}

/// Up (+1), down (−1) or unknown (0) for each row of `map`, from the row order.
fn sweep_directions(map: &ForceMap) -> Vec<i8> {
    let n = map.len();
    let same_pressure = |a: usize, b: usize| {
        (map.bellow_gauge_pa[a] - map.bellow_gauge_pa[b]).abs() < PRESSURE_TOLERANCE_PA
    };
    let step = |a: usize, b: usize| -> i8 {
        if !same_pressure(a, b) {
            return 0;
        }
        let dh = map.bellow_height_m[b] - map.bellow_height_m[a];
        if dh > 0.0 {
            1
        } else if dh < 0.0 {
            -1
        } else {
            0
        }
    };
    (0..n)
        .map(|k| {
            let from_previous = if k > 0 { step(k - 1, k) } else { 0 };
            if from_previous != 0 {
                from_previous
            } else if k + 1 < n {
                step(k, k + 1)
            } else {
                0
            }
        })
        .collect()
}

/// `F_c` from a force map measured in up and down sweeps; an error says why the map has no
/// hysteresis to read (no point measured both ways).
pub fn fit_wall_friction(
    map: &ForceMap,
    height_tolerance_m: f64,
) -> Result<WallFrictionFit, EstimateError> {
    let directions = sweep_directions(map);
    let n = map.len();
    let mut used = vec![false; n];
    let mut halves = Vec::new();
    for up in (0..n).filter(|&k| directions[k] > 0) {
        let partner = (0..n).find(|&k| {
            directions[k] < 0
                && !used[k]
                && (map.bellow_gauge_pa[k] - map.bellow_gauge_pa[up]).abs() < PRESSURE_TOLERANCE_PA
                && (map.bellow_height_m[k] - map.bellow_height_m[up]).abs() <= height_tolerance_m
        });
        if let Some(down) = partner {
            used[down] = true;
            halves.push(0.5 * (map.force_n[down] - map.force_n[up]));
        }
    }
    let pairs = halves.len();
    if pairs < 2 {
        return Err(EstimateError::InsufficientData {
            fit: FIT,
            reason: format!(
                "{pairs} point(s) measured both ways at one height and pressure; the wall friction shows in the difference of an upward and a downward sweep (rows in the order measured)"
            ),
        });
    }
    let mean = halves.iter().sum::<f64>() / pairs as f64;
    let variance = halves.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (pairs - 1) as f64;
    if !(mean.is_finite() && mean > 0.0) {
        return Err(EstimateError::InsufficientData {
            fit: FIT,
            reason: format!(
                "the downward sweeps read {:.1} N less than the upward ones on average ({pairs} pairs): no wall friction shows (a friction raises the force moving down)",
                -2.0 * mean
            ),
        });
    }
    Ok(WallFrictionFit {
        friction_force_n: mean,
        friction_force_std_n: (variance / pairs as f64).sqrt(),
        pairs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A map of `p A(h)` swept up and down at each pressure with friction `fc` against the
    /// motion, plus deterministic "noise".
    fn swept_map(fc: f64, noise_n: f64) -> ForceMap {
        let mut map = ForceMap::default();
        let heights: Vec<f64> = (0..10).map(|i| 0.22 + 0.02 * f64::from(i)).collect();
        let mut k = 0u32;
        for p in (1..=7).map(|i| 1e5 * f64::from(i)) {
            let up = heights.iter().map(|&h| (h, 1.0));
            let down = heights.iter().rev().map(|&h| (h, -1.0));
            for (h, direction) in up.chain(down) {
                k += 1;
                let wiggle = noise_n * (f64::from(k) * 2.399).sin();
                map.bellow_height_m.push(h);
                map.bellow_gauge_pa.push(p);
                map.force_n
                    .push(p * (0.06 - 0.02 * h) - direction * fc + wiggle);
            }
        }
        map
    }

    #[test]
    fn half_the_sweeps_difference_is_the_sliding_force() {
        let fit = fit_wall_friction(&swept_map(150.0, 0.0), 1e-4).unwrap();
        assert!((fit.friction_force_n - 150.0).abs() < 1e-9, "{fit:?}");
        assert_eq!(fit.pairs, 70);
        let noisy = fit_wall_friction(&swept_map(150.0, 40.0), 1e-4).unwrap();
        assert!(
            (noisy.friction_force_n - 150.0).abs() < 3.0 * noisy.friction_force_std_n + 1.0,
            "{noisy:?}"
        );
        assert!(noisy.friction_force_std_n > 0.5 && noisy.friction_force_std_n < 10.0);
    }

    #[test]
    fn sweeps_that_read_the_wrong_way_are_refused() {
        let err = fit_wall_friction(&swept_map(-50.0, 0.0), 1e-4)
            .unwrap_err()
            .to_string();
        assert!(err.contains("read 100.0 N less"), "{err}");
    }

    #[test]
    fn a_map_measured_one_way_has_no_hysteresis_to_read() {
        let full = swept_map(150.0, 0.0);
        // Only the upward sweeps: every second block of ten rows.
        let keep: Vec<usize> = (0..full.len()).filter(|k| (k / 10) % 2 == 0).collect();
        let one_way = ForceMap {
            bellow_height_m: keep.iter().map(|&k| full.bellow_height_m[k]).collect(),
            bellow_gauge_pa: keep.iter().map(|&k| full.bellow_gauge_pa[k]).collect(),
            force_n: keep.iter().map(|&k| full.force_n[k]).collect(),
        };
        let err = fit_wall_friction(&one_way, 1e-4).unwrap_err().to_string();
        assert!(err.contains("0 point(s) measured both ways"), "{err}");
    }
}
