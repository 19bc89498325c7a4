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

/// Up (+1), down (−1) or unknown (0) for each row of `map`, from the row order. A height
/// change within `tolerance_m` is no move (a held height logged twice, or its jitter): such a
/// row takes the direction of its sweep; at a turning point a single such reading belongs to
/// the sweep that leaves it, and several are unknown (left out).
fn sweep_directions(map: &ForceMap, tolerance_m: f64) -> Vec<i8> {
    let n = map.len();
    let same_pressure = |a: usize, b: usize| {
        (map.bellow_gauge_pa[a] - map.bellow_gauge_pa[b]).abs() < PRESSURE_TOLERANCE_PA
    };
    // The move into row k from row k − 1 of the same sweep.
    let step = |k: usize| -> i8 {
        if k == 0 || !same_pressure(k - 1, k) {
            return 0;
        }
        let dh = map.bellow_height_m[k] - map.bellow_height_m[k - 1];
        if dh > tolerance_m {
            1
        } else if dh < -tolerance_m {
            -1
        } else {
            0
        }
    };
    let steps: Vec<i8> = (0..n).map(step).collect();
    (0..n)
        .map(|k| {
            if steps[k] != 0 {
                return steps[k];
            }
            let next = (k + 1..n)
                .take_while(|&j| same_pressure(j - 1, j))
                .map(|j| steps[j])
                .find(|&s| s != 0);
            let last = (1..=k)
                .rev()
                .take_while(|&j| same_pressure(j - 1, j))
                .map(|j| steps[j])
                .find(|&s| s != 0);
            match (last, next) {
                (Some(before), Some(after)) if before != after => {
                    // A turning point. One reading there without a move (the classic map:
                    // the top height read once going up, once going down) starts the sweep
                    // that leaves it; several cannot be told apart and are left out.
                    let held = |j: usize| j > 0 && steps[j] == 0 && same_pressure(j - 1, j);
                    let held_next = k + 1 < n && held(k + 1);
                    let alone = !(held(k - 1) || held_next);
                    if alone { after } else { 0 }
                }
                _ => next.or(last).unwrap_or(0),
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
    let n = map.len();
    if map.bellow_height_m.len() != n || map.bellow_gauge_pa.len() != n {
        return Err(EstimateError::InsufficientData {
            fit: FIT,
            reason: "the force map's columns differ in length".to_owned(),
        });
    }
    if let Some(k) = (0..n).find(|&k| {
        !(map.bellow_height_m[k].is_finite()
            && map.bellow_gauge_pa[k].is_finite()
            && map.force_n[k].is_finite())
    }) {
        return Err(EstimateError::InsufficientData {
            fit: FIT,
            reason: format!("point {} has a non-finite height, pressure or force", k + 1),
        });
    }
    let directions = sweep_directions(map, height_tolerance_m);
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
            // The two readings' pressures differ a little (within the tolerance): the
            // difference the pressure makes, through the upward reading's own F/p, is not
            // friction.
            let (p_up, p_down) = (map.bellow_gauge_pa[up], map.bellow_gauge_pa[down]);
            let pressure_part = if p_up != 0.0 {
                (p_down - p_up) * map.force_n[up] / p_up
            } else {
                0.0
            };
            halves.push(0.5 * (map.force_n[down] - map.force_n[up] - pressure_part));
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

/// The part of each reading of `map` that is wall friction, N: `−F_c` on an upward sweep,
/// `+F_c` on a downward one (the sliding force against the motion), 0 where the direction is
/// unknown, with `F_c` from [`fit_wall_friction`]; `None` when the map shows no hysteresis.
/// Subtracted from the readings, what remains is `p A_eff(h, p)` and the load cell's noise.
pub fn sweep_friction_n(map: &ForceMap, height_tolerance_m: f64) -> Option<Vec<f64>> {
    let fit = fit_wall_friction(map, height_tolerance_m).ok()?;
    Some(
        sweep_directions(map, height_tolerance_m)
            .into_iter()
            .map(|direction| -f64::from(direction) * fit.friction_force_n)
            .collect(),
    )
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
    fn held_heights_logged_twice_and_pressures_a_little_apart_do_not_bias_it() {
        // Every height read twice with 0.05 mm of jitter, and the downward sweeps 0.5 kPa
        // above the upward ones.
        let clean = swept_map(150.0, 0.0);
        let mut map = ForceMap::default();
        for k in 0..clean.len() {
            let down = (k / 10) % 2 == 1;
            let p = clean.bellow_gauge_pa[k] + if down { 500.0 } else { 0.0 };
            for jitter in [0.0, 5e-5] {
                let h = clean.bellow_height_m[k] + jitter;
                map.bellow_height_m.push(h);
                map.bellow_gauge_pa.push(p);
                let direction = if down { -1.0 } else { 1.0 };
                map.force_n.push(p * (0.06 - 0.02 * h) - direction * 150.0);
            }
        }
        let fit = fit_wall_friction(&map, 1e-4).unwrap();
        // At each turning point the last three of the four readings without a move between
        // them cannot be told apart and are left out, and the first finds no partner: the
        // turning height's two pairs per pressure are lost, none is wrong.
        assert_eq!(fit.pairs, 140 - 2 * 7);
        assert!((fit.friction_force_n - 150.0).abs() < 0.5, "{fit:?}");
    }

    #[test]
    fn taken_out_of_the_readings_the_sweeps_friction_leaves_the_area_force() {
        let map = swept_map(150.0, 0.0);
        let friction = sweep_friction_n(&map, 1e-4).unwrap();
        assert_eq!(friction.len(), map.len());
        for (k, f) in friction.iter().enumerate() {
            let (h, p) = (map.bellow_height_m[k], map.bellow_gauge_pa[k]);
            let without = map.force_n[k] - f;
            assert!(
                (without - p * (0.06 - 0.02 * h)).abs() < 1e-6,
                "point {k}: {without} N"
            );
        }
        // Up first at each pressure: the friction reads low going up.
        assert!((friction[0] + 150.0).abs() < 1e-9 && (friction[15] - 150.0).abs() < 1e-9);
        // A map without hysteresis has none to take out.
        assert!(sweep_friction_n(&swept_map(0.0, 0.0), 1e-4).is_none());
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
