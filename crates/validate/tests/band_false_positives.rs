//! Monte Carlo: the 99 % confidence bands of eq 3.36 are exceeded about 1 % of the time by
//! a white residual, also when the input is strongly coloured (a slowly varying load). A
//! band that ignored the input's colour, or mis-scaled `P`, would flag good models on
//! every loading run; a band too wide would never flag a bad one.

use airsus_validate::{input_residual_correlation, residual_autocorrelation};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

fn white(rng: &mut ChaCha8Rng, n: usize) -> Vec<f64> {
    (0..n).map(|_| StandardNormal.sample(rng)).collect()
}

/// AR(1) `u(t) = a u(t-1) + w(t)`: autocorrelation `a^k`, 20 samples long at a = 0.95.
fn coloured(rng: &mut ChaCha8Rng, n: usize, a: f64) -> Vec<f64> {
    let w = white(rng, n + 200);
    let mut u = vec![0.0; n + 200];
    for t in 1..u.len() {
        u[t] = a * u[t - 1] + w[t];
    }
    u.split_off(200)
}

#[test]
fn white_residuals_leave_the_99_percent_band_about_1_percent_of_the_time() {
    let mut rng = ChaCha8Rng::seed_from_u64(2016);
    let (trials, n, max_lag) = (300, 2000, 20);
    let (mut cross_out, mut cross_total) = (0usize, 0usize);
    let (mut auto_out, mut auto_total) = (0usize, 0usize);
    for _ in 0..trials {
        let u = coloured(&mut rng, n, 0.95);
        let e = white(&mut rng, n);
        let cross = input_residual_correlation(&e, &u, max_lag, 0.99).unwrap();
        cross_out += cross.outside;
        cross_total += cross.values.len();
        let auto = residual_autocorrelation(&e, max_lag, 0.99).unwrap();
        auto_out += auto.outside;
        auto_total += auto.values.len() - 1;
    }
    let cross_rate = 100.0 * cross_out as f64 / cross_total as f64;
    let auto_rate = 100.0 * auto_out as f64 / auto_total as f64;
    println!("outside the 99 % band: cross {cross_rate:.2} %, auto {auto_rate:.2} %");
    // Binomial spread over 6000–12300 lags is ±0.1–0.15 points (1σ); neighbouring lags of a
    // coloured input are correlated, which widens it. 0.5–1.8 % still tells a right band
    // from one that is off by a factor of 1.3 in width either way.
    assert!((0.5..1.8).contains(&cross_rate), "cross {cross_rate} %");
    assert!((0.5..1.8).contains(&auto_rate), "auto {auto_rate} %");
}

#[test]
fn a_residual_that_follows_the_input_is_flagged() {
    // The other side of the coin: a residual that contains the input delayed by 3 samples.
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let n = 2000;
    let u = coloured(&mut rng, n, 0.95);
    let noise = white(&mut rng, n);
    let e: Vec<f64> = (0..n)
        .map(|t| noise[t] + if t >= 3 { 0.1 * u[t - 3] } else { 0.0 })
        .collect();
    let cross = input_residual_correlation(&e, &u, 20, 0.99).unwrap();
    assert!(cross.outside > 10, "{} lags outside", cross.outside);
}
