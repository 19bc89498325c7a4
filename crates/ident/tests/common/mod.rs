//! Shared helpers for the integration tests: known systems, seeded signals, and an
//! independent difference-equation simulator (deliberately not the library's filters).

#![allow(dead_code)]

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Seeded generator so every test is reproducible.
pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// Zero-mean Gaussian white noise with standard deviation `std`.
pub fn white(rng: &mut ChaCha8Rng, n: usize, std: f64) -> Vec<f64> {
    (0..n)
        .map(|_| {
            let z: f64 = StandardNormal.sample(rng);
            std * z
        })
        .collect()
}

/// Random binary signal ±1 that switches with probability `p` each sample (like MATLAB
/// `idinput` 'rbs' with a switching probability, the dryer's input).
pub fn binary(rng: &mut ChaCha8Rng, n: usize, p: f64) -> Vec<f64> {
    let mut level = 1.0;
    (0..n)
        .map(|_| {
            if rng.random_bool(p) {
                level = -level;
            }
            level
        })
        .collect()
}

/// `y = q^{-delay} num(q)/den(q) x` by the plain difference equation, `den[0] = 1`.
pub fn lfilter(num: &[f64], delay: usize, den: &[f64], x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; x.len()];
    for t in 0..x.len() {
        let mut acc = 0.0;
        for (k, b) in num.iter().enumerate() {
            if t >= delay + k {
                acc += b * x[t - delay - k];
            }
        }
        for (k, a) in den.iter().enumerate().skip(1) {
            if t >= k {
                acc -= a * y[t - k];
            }
        }
        y[t] = acc;
    }
    y
}

pub fn conv(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

pub fn add(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x + y).collect()
}

/// Asserts every estimated parameter lies within `k` reported standard deviations of the
/// truth, and that the standard deviations are plausible (positive, not absurdly large).
pub fn assert_within_sigmas(est: &airsus_ident::linear::Estimate, truth: &[f64], k: f64) {
    assert_eq!(est.parameters.len(), truth.len(), "parameter count");
    for (p, &t) in est.parameters.iter().zip(truth) {
        assert!(
            p.std > 0.0 && p.std.is_finite(),
            "{}: standard deviation {} is not positive and finite",
            p.name,
            p.std
        );
        assert!(
            (p.value - t).abs() <= k * p.std,
            "{}: estimate {} vs truth {} is {:.2} standard deviations ({}) away\n{est}",
            p.name,
            p.value,
            t,
            (p.value - t).abs() / p.std,
            p.std
        );
        assert!(
            p.std < 0.1 * t.abs().max(0.2),
            "{}: standard deviation {} is implausibly large for truth {t}",
            p.name,
            p.std
        );
    }
}
