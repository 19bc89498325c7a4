//! The truck's sensors (thesis 2.2): 100 ms sampling, 0.1 mm height and 0.1 kPa pressure
//! resolution, plus white measurement noise. Deterministic for a seed (ChaCha8, whose stream
//! is fixed by its specification, unlike `StdRng`).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Noise and resolution of one sensor channel, in the channel's SI unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorSpec {
    /// Standard deviation of the white noise added before quantisation.
    pub noise_std: f64,
    /// Quantisation step (resolution); 0 disables quantisation.
    pub resolution: f64,
}

impl SensorSpec {
    /// Height sensor: 0.1 mm resolution (thesis 2.2.2), 0.15 mm noise.
    pub const HEIGHT_M: Self = Self {
        noise_std: 0.15e-3,
        resolution: 0.1e-3,
    };
    /// Bellow pressure sensor: 0.1 kPa resolution (thesis 2.2.3), 0.2 kPa noise.
    pub const BELLOW_PRESSURE_PA: Self = Self {
        noise_std: 200.0,
        resolution: 100.0,
    };
    /// Supply-tank pressure sensor: 1 kPa resolution, 1 kPa noise.
    pub const SUPPLY_PRESSURE_PA: Self = Self {
        noise_std: 1000.0,
        resolution: 1000.0,
    };
}

/// Rounds to the nearest multiple of `resolution` (none when `resolution <= 0`).
pub fn quantize(value: f64, resolution: f64) -> f64 {
    if resolution > 0.0 {
        (value / resolution).round() * resolution
    } else {
        value
    }
}

/// A seeded source of measurement noise.
pub struct NoiseSource {
    rng: ChaCha8Rng,
}

impl NoiseSource {
    pub fn new(seed: u64) -> Self {
        Self {
            rng: ChaCha8Rng::seed_from_u64(seed),
        }
    }

    /// The true signal as the sensor reports it: noise added, then quantised.
    pub fn measure(&mut self, truth: &[f64], spec: SensorSpec) -> Vec<f64> {
        let noise = Normal::new(0.0, spec.noise_std.max(0.0)).ok();
        truth
            .iter()
            .map(|&v| {
                let n = noise.as_ref().map_or(0.0, |d| d.sample(&mut self.rng));
                quantize(v + n, spec.resolution)
            })
            .collect()
    }

    /// A uniform draw in `[low, high)`, for randomised experiment details.
    pub fn uniform(&mut self, low: f64, high: f64) -> f64 {
        let u: f64 = rand_distr::Uniform::new(0.0, 1.0).map_or(0.0, |d| d.sample(&mut self.rng));
        low + (high - low) * u
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantize_rounds_to_resolution() {
        assert!((quantize(0.24037, 1e-4) - 0.2404).abs() < 1e-15);
        assert_eq!(quantize(350_049.0, 100.0), 350_000.0);
        assert_eq!(quantize(1.234, 0.0), 1.234);
    }

    #[test]
    fn noise_statistics_are_as_configured() {
        let mut source = NoiseSource::new(7);
        let spec = SensorSpec {
            noise_std: 2.0,
            resolution: 0.0,
        };
        let measured = source.measure(&vec![10.0; 20_000], spec);
        let mean = measured.iter().sum::<f64>() / measured.len() as f64;
        let var =
            measured.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (measured.len() - 1) as f64;
        // Standard error of the mean: 2/√20000 ≈ 0.014; of the std: 2/√40000 = 0.01.
        assert!((mean - 10.0).abs() < 0.05, "mean {mean}");
        assert!((var.sqrt() - 2.0).abs() < 0.04, "std {}", var.sqrt());
    }

    #[test]
    fn quantised_output_lies_on_the_grid() {
        let mut source = NoiseSource::new(1);
        let measured = source.measure(&[0.2401234; 100], SensorSpec::HEIGHT_M);
        for v in measured {
            let steps = v / 1e-4;
            assert!(
                (steps - steps.round()).abs() < 1e-6,
                "{v} is off the 0.1 mm grid"
            );
        }
    }

    #[test]
    fn same_seed_same_noise() {
        let a = NoiseSource::new(42).measure(&[1.0; 50], SensorSpec::BELLOW_PRESSURE_PA);
        let b = NoiseSource::new(42).measure(&[1.0; 50], SensorSpec::BELLOW_PRESSURE_PA);
        let c = NoiseSource::new(43).measure(&[1.0; 50], SensorSpec::BELLOW_PRESSURE_PA);
        assert_eq!(a, b);
        assert_ne!(a, c);
    }
}
