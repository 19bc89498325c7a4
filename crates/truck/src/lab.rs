//! Lab experiments on the virtual truck's parts (thesis 5.2.2–5.2.3): the bellow force map.

use airsus_data::ForceMap;

use crate::sensors::NoiseSource;
use crate::truth::VirtualTruck;

/// Heights and pressures of the vertical force test, like thesis Fig 5.8: heights
/// 220–400 mm in 20 mm steps, gauge pressures 100–700 kPa in 100 kPa steps.
pub fn force_map_grid() -> (Vec<f64>, Vec<f64>) {
    let heights = (0..10).map(|i| 0.22 + 0.02 * f64::from(i)).collect();
    let pressures = (1..=7).map(|i| 1e5 * f64::from(i)).collect();
    (heights, pressures)
}

/// Force noise of the lab load cell: relative and absolute parts.
const FORCE_NOISE_RELATIVE: f64 = 0.003;
const FORCE_NOISE_ABSOLUTE_N: f64 = 20.0;

/// The bellow force map as a lab rig measures it: at each pressure the bellow is moved up
/// through all heights, then down again, so wall friction adds to the force on the way up and
/// subtracts on the way down (hysteresis), and the effective area stretches with pressure.
pub fn measure_force_map(truck: &VirtualTruck, seed: u64) -> ForceMap {
    let mut noise = NoiseSource::new(seed ^ 0xf0ce_0001);
    let (heights, pressures) = force_map_grid();
    let e = &truck.effect_parameters;
    let mut map = ForceMap::default();
    for &p in &pressures {
        let up = heights.iter().map(|&h| (h, 1.0));
        let down = heights.iter().rev().map(|&h| (h, -1.0));
        for (h, direction) in up.chain(down) {
            // A slow quasi-static move drives the Dahl element to its fixed point, the sliding
            // force F_c in the direction of motion (see `physics::dahl_force_rate`).
            let friction = if truck.effects.hysteresis {
                direction * e.friction_force_n
            } else {
                0.0
            };
            // Moving up (extension) the wall friction resists, lowering the measured force.
            let force = p * truck.effective_area_m2(h, p) - friction;
            let sigma = FORCE_NOISE_RELATIVE * force.abs() + FORCE_NOISE_ABSOLUTE_N;
            let measured = noise.measure(
                &[force],
                crate::sensors::SensorSpec {
                    noise_std: sigma,
                    resolution: 1.0,
                },
            )[0];
            map.bellow_height_m.push(h);
            map.bellow_gauge_pa.push(p);
            map.force_n.push(measured);
        }
    }
    map
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn force_map_covers_the_grid_both_ways_with_hysteresis() {
        let truck = VirtualTruck::reference();
        let map = measure_force_map(&truck, 1);
        assert_eq!(map.len(), 7 * 20);
        // Same height and pressure, up versus down: the down force is larger by ≈ 2 F_c.
        let (h, p) = (0.30, 4e5);
        let at = |i: usize| {
            (map.bellow_height_m[i] - h).abs() < 1e-9 && (map.bellow_gauge_pa[i] - p).abs() < 1e-6
        };
        let forces: Vec<f64> = (0..map.len())
            .filter(|&i| at(i))
            .map(|i| map.force_n[i])
            .collect();
        assert_eq!(forces.len(), 2);
        let gap = forces[1] - forces[0];
        assert!((gap - 240.0).abs() < 150.0, "hysteresis gap {gap} N");
        // The level is the true effective area times pressure.
        let mean = 0.5 * (forces[0] + forces[1]);
        let truth = p * truck.effective_area_m2(h, p);
        assert!((mean / truth - 1.0).abs() < 0.01, "{mean} vs {truth}");
    }

    #[test]
    fn without_hysteresis_up_and_down_agree_within_noise() {
        let mut truck = VirtualTruck::reference();
        truck.effects.hysteresis = false;
        let map = measure_force_map(&truck, 1);
        let n = map.len() / 7;
        for k in 0..7 {
            for j in 0..n / 2 {
                let up = map.force_n[k * n + j];
                let down = map.force_n[k * n + n - 1 - j];
                assert!(
                    (up - down).abs() < 6.0 * (FORCE_NOISE_RELATIVE * up + FORCE_NOISE_ABSOLUTE_N)
                );
            }
        }
    }

    #[test]
    fn same_seed_same_map() {
        let truck = VirtualTruck::reference();
        assert_eq!(measure_force_map(&truck, 5), measure_force_map(&truck, 5));
    }
}
