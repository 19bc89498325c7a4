//! The noise floor: the noise std estimated from a measured signal alone, against the noise
//! that was added, on signals shaped like the suspension's runs (slow dynamics, load steps,
//! a 10 Hz sensor). The ceiling from the estimate equals the NRMSE of the noise-free signal.

use airsus_validate::{estimate_noise_std, noise_ceiling_percent, nrmse_percent};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// A height-like trace at 10 Hz: four load steps of 10–15 mm with a 1 s settling, creep, and
/// a slow valve ramp.
fn clean(n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| {
            let t = k as f64 * 0.1;
            let steps: f64 = [(200.0, -12.0), (500.0, 15.0), (800.0, -10.0), (1100.0, 7.0)]
                .iter()
                .filter(|(at, _)| t >= *at)
                .map(|(at, size)| {
                    size * (1.0 - (-(t - at) / 0.3).exp())
                        + 0.1 * size * (1.0 - (-(t - at) / 40.0).exp())
                })
                .sum();
            240.0 + steps + 3.0 * (t / 300.0).sin()
        })
        .collect()
}

/// The noise actually added: the rms of measured minus truth.
fn rms_difference(measured: &[f64], truth: &[f64]) -> f64 {
    let e: f64 = measured
        .iter()
        .zip(truth)
        .map(|(m, t)| (m - t).powi(2))
        .sum();
    (e / measured.len() as f64).sqrt()
}

#[test]
fn the_estimated_noise_matches_the_added_noise_and_the_ceiling_the_truth() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for (sigma, resolution) in [(0.15, 0.0), (0.5, 0.0), (0.15, 0.1), (2.0, 1.0)] {
        let truth = clean(15_001);
        let noise = Normal::new(0.0, sigma).unwrap();
        let measured: Vec<f64> = truth
            .iter()
            .map(|y| {
                let v = y + noise.sample(&mut rng);
                if resolution > 0.0 {
                    (v / resolution).round() * resolution
                } else {
                    v
                }
            })
            .collect();
        // What a model can at best reach: the noise-free signal against the measurement.
        let ceiling = nrmse_percent(&measured, &truth).unwrap();
        let actual_std = rms_difference(&measured, &truth);
        let estimated = estimate_noise_std(&measured).unwrap();
        assert!(
            (estimated / actual_std - 1.0).abs() < 0.03,
            "σ {sigma} at resolution {resolution}: estimated {estimated}, actual {actual_std}"
        );
        // The ceiling's distance to 100 % scales with σ, so a relative error of σ moves it by
        // that share of the distance: 1 % of it (the estimate's own scatter over 15,000
        // samples is about 0.8 %), at least 0.1 point.
        let implied = noise_ceiling_percent(&measured, estimated).unwrap();
        assert!(
            (implied - ceiling).abs() < (0.01 * (100.0 - ceiling)).max(0.1),
            "ceiling {ceiling} %, implied by the estimate {implied} %"
        );
    }
}

#[test]
fn too_short_or_broken_signals_have_no_estimate() {
    assert_eq!(estimate_noise_std(&[1.0; 50]), None);
    let mut y = vec![0.0; 200];
    y[10] = f64::NAN;
    assert_eq!(estimate_noise_std(&y), None);
    assert!(noise_ceiling_percent(&[1.0; 10], 0.1).is_err());
}

/// A road run's height at 10 Hz: standing for 5 s, then body and wheel motion at 1–4 Hz
/// (mm-sized, far above the noise in its second differences) until 5 s before the end, then
/// standing again.
fn road_like(n: usize) -> Vec<f64> {
    let end_s = (n as f64 - 1.0) * 0.1 - 5.0;
    (0..n)
        .map(|k| {
            let t = k as f64 * 0.1;
            let driving = if (5.0..end_s).contains(&t) {
                8.0 * (2.0 * std::f64::consts::PI * 1.3 * t).sin()
                    + 3.0 * (2.0 * std::f64::consts::PI * 3.7 * t + 1.0).sin()
            } else {
                0.0
            };
            235.0 + driving
        })
        .collect()
}

#[test]
fn the_noise_of_a_road_run_is_read_where_the_truck_stands() {
    // 90 s as the virtual truck's ISO road run, and 180 s: the standstills a twentieth of it.
    for n in [901, 1801] {
        the_noise_of_a_road_run_of(n);
    }
}

fn the_noise_of_a_road_run_of(n: usize) {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let noise = Normal::new(0.0, 0.15).unwrap();
    let truth = road_like(n);
    let measured: Vec<f64> = truth.iter().map(|y| y + noise.sample(&mut rng)).collect();
    let actual_std = rms_difference(&measured, &truth);
    // Two standstills of 5 s, the rest loud: the estimate reads the standstills.
    let estimated = estimate_noise_std(&measured).unwrap();
    assert!(
        (estimated / actual_std - 1.0).abs() < 0.15,
        "{n} samples: estimated {estimated}, actual {actual_std}"
    );
    let ceiling = nrmse_percent(&measured, &truth).unwrap();
    let implied = noise_ceiling_percent(&measured, estimated).unwrap();
    assert!(
        (implied - ceiling).abs() < 0.5,
        "{implied} % against {ceiling} %"
    );
}
