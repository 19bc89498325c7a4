//! Road profiles: a single bump and ISO 8608 random roads (the virtual truck's road runs and
//! `airsus road`).
//!
//! # ISO 8608
//! The displacement power spectral density over spatial frequency `n` (cycles/m) is
//! ```text
//! Gd(n) = Gd(n0) (n / n0)^-w,   n0 = 0.1 cycles/m,   w = 2
//! ```
//! with the class's geometric-mean `Gd(n0)`: A 16, B 64, C 256, D 1024, E 4096, F 16384,
//! G 65536, H 262144 × 10⁻⁶ m³ (each class 4× the one before, ISO 8608:2016 Table 1).
//!
//! # Generation (spectral method, sum of cosines)
//! ```text
//! z(s) = Σ_i √(2 Gd(n_i) Δn) cos(2π n_i s + φ_i),   n_i = n_min + (i + ½) Δn,
//! ```
//! with `φ_i` independent and uniform on `[0, 2π)` from a seeded ChaCha8 generator (its stream
//! is fixed by its specification: a seed gives the same road everywhere). Each cosine carries
//! the variance `Gd(n_i) Δn` of its band, so the one-sided PSD of `z` is `Gd` on
//! `[n_min, n_max]`. The band defaults to 0.011–2.83 cycles/m (ISO 8608's range of classes),
//! cut to what the time sampling can carry (`n v < 0.4 / Δt`).

use std::f64::consts::PI;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::{TruckError, invalid};

/// Reference spatial frequency of ISO 8608, cycles/m.
pub const ISO8608_N0: f64 = 0.1;

/// `Gd(n0)` of an ISO 8608 class letter (A–H), m³ (geometric mean of the class).
pub fn iso8608_gd_n0_m3(class: char) -> Result<f64, TruckError> {
    let k = match class.to_ascii_uppercase() {
        c @ 'A'..='H' => c as u32 - 'A' as u32,
        other => {
            return Err(invalid(
                "ISO 8608 class",
                format!("`{other}`; the classes are A to H"),
            ));
        }
    };
    Ok(16e-6 * 4f64.powi(k as i32))
}

/// `Gd(n) = Gd(n0) (n/n0)^-2`, m³.
pub fn iso8608_psd_m3(gd_n0_m3: f64, n_cycles_per_m: f64) -> f64 {
    gd_n0_m3 * (n_cycles_per_m / ISO8608_N0).powi(-2)
}

/// A random road of one ISO 8608 class (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Iso8608Road {
    pub class: char,
    pub gd_n0_m3: f64,
    frequencies: Vec<f64>,
    amplitudes: Vec<f64>,
    phases: Vec<f64>,
}

impl Iso8608Road {
    /// `components` cosines over `[n_min, n_max]` cycles/m.
    pub fn new(
        class: char,
        n_min: f64,
        n_max: f64,
        components: usize,
        seed: u64,
    ) -> Result<Self, TruckError> {
        let gd_n0_m3 = iso8608_gd_n0_m3(class)?;
        if !(n_min.is_finite() && n_min > 0.0 && n_max > n_min && n_max.is_finite()) {
            return Err(invalid(
                "ISO 8608 band",
                format!("{n_min} to {n_max} cycles/m; need 0 < n_min < n_max"),
            ));
        }
        if components == 0 {
            return Err(invalid("ISO 8608 road", "it needs at least one component"));
        }
        let dn = (n_max - n_min) / components as f64;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let frequencies: Vec<f64> = (0..components)
            .map(|i| n_min + (i as f64 + 0.5) * dn)
            .collect();
        let amplitudes = frequencies
            .iter()
            .map(|&n| (2.0 * iso8608_psd_m3(gd_n0_m3, n) * dn).sqrt())
            .collect();
        let phases = (0..components)
            .map(|_| rng.random::<f64>() * 2.0 * PI)
            .collect();
        Ok(Self {
            class: class.to_ascii_uppercase(),
            gd_n0_m3,
            frequencies,
            amplitudes,
            phases,
        })
    }

    /// Heights at the distances `s_m` (m), sharing one phasor rotation per component.
    pub fn heights_m(&self, s_m: &[f64]) -> Vec<f64> {
        let mut z = vec![0.0; s_m.len()];
        for ((&n, &a), &phi) in self
            .frequencies
            .iter()
            .zip(&self.amplitudes)
            .zip(&self.phases)
        {
            for (zk, &s) in z.iter_mut().zip(s_m) {
                *zk += a * (2.0 * PI * n * s + phi).cos();
            }
        }
        z
    }

    /// The variance the profile carries, `Σ Gd(n_i) Δn`, m².
    pub fn variance_m2(&self) -> f64 {
        self.amplitudes.iter().map(|a| a * a / 2.0).sum()
    }
}

/// A half-sine bump: `z = H sin(π (s - s0) / L)` for `s0 ≤ s ≤ s0 + L`, else 0.
pub fn half_sine_bump_m(s_m: f64, start_m: f64, length_m: f64, height_m: f64) -> f64 {
    let x = (s_m - start_m) / length_m;
    if (0.0..=1.0).contains(&x) {
        height_m * (PI * x).sin()
    } else {
        0.0
    }
}

/// Estimated one-sided PSD of a uniformly sampled profile `z` (spacing `ds_m`), by averaging
/// the periodograms of `segments` non-overlapping, mean-removed, Hann-windowed segments,
/// evaluated at `n_cycles_per_m` (a direct DFT: no FFT needed for a handful of frequencies).
pub fn estimate_psd_m3(z: &[f64], ds_m: f64, segments: usize, n_cycles_per_m: &[f64]) -> Vec<f64> {
    let segments = segments.max(1);
    let len = z.len() / segments;
    if len < 2 || ds_m <= 0.0 {
        return vec![f64::NAN; n_cycles_per_m.len()];
    }
    let window: Vec<f64> = (0..len)
        .map(|k| 0.5 - 0.5 * (2.0 * PI * k as f64 / len as f64).cos())
        .collect();
    let w2: f64 = window.iter().map(|w| w * w).sum();
    n_cycles_per_m
        .iter()
        .map(|&n| {
            let mut acc = 0.0;
            for seg in 0..segments {
                let part = &z[seg * len..(seg + 1) * len];
                let mean = part.iter().sum::<f64>() / len as f64;
                let (mut re, mut im) = (0.0, 0.0);
                for (k, (&v, &w)) in part.iter().zip(&window).enumerate() {
                    let arg = 2.0 * PI * n * k as f64 * ds_m;
                    re += (v - mean) * w * arg.cos();
                    im -= (v - mean) * w * arg.sin();
                }
                // One-sided: 2 |X|² Δs / Σw².
                acc += 2.0 * (re * re + im * im) * ds_m / w2;
            }
            acc / segments as f64
        })
        .collect()
}
