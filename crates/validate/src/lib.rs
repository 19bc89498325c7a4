//! # airsus-validate: how well does a model fit?
//!
//! Pure functions on slices (thesis 3.4, SPEC §4):
//! - [`nrmse_percent`]: the fit measure of eq 3.33, per output;
//! - the noise floor: the best NRMSE a model can reach, from the noise-free truth
//!   (`nrmse_percent(measured, truth)`) or, without truth, from the noise
//!   [`estimate_noise_std`] finds ([`noise_ceiling_percent`]);
//! - [`residual_autocorrelation`] and [`input_residual_correlation`]: residual analysis of
//!   eq 3.35/3.36 over positive and negative lags, with a confidence band (99 % by default),
//!   normalised to correlation coefficients as MATLAB's `resid` shows them.

use serde::Serialize;
use statrs::distribution::{ContinuousCDF, Normal};

/// The confidence level the thesis plots (Figs 5.15–5.49).
pub const DEFAULT_CONFIDENCE: f64 = 0.99;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ValidateError {
    #[error("signals differ in length: {left} and {right} samples")]
    LengthMismatch { left: usize, right: usize },
    #[error("{what} needs at least {needed} samples, got {found}")]
    TooShort {
        what: &'static str,
        needed: usize,
        found: usize,
    },
    #[error("{which} contains a non-finite value at sample {index}")]
    NotFinite { which: &'static str, index: usize },
    #[error("{which} is constant, so {what} is undefined")]
    Constant {
        which: &'static str,
        what: &'static str,
    },
    #[error("confidence must lie strictly between 0 and 1, got {0}")]
    BadConfidence(f64),
}

fn check_pair(
    a: &[f64],
    b: &[f64],
    names: [&'static str; 2],
    needed: usize,
    what: &'static str,
) -> Result<(), ValidateError> {
    if a.len() != b.len() {
        return Err(ValidateError::LengthMismatch {
            left: a.len(),
            right: b.len(),
        });
    }
    if a.len() < needed {
        return Err(ValidateError::TooShort {
            what,
            needed,
            found: a.len(),
        });
    }
    for (signal, which) in [(a, names[0]), (b, names[1])] {
        if let Some(index) = signal.iter().position(|v| !v.is_finite()) {
            return Err(ValidateError::NotFinite { which, index });
        }
    }
    Ok(())
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// Normalised root-mean-square error fit in percent (thesis eq 3.33):
///
/// `NRMSE = 100 (1 − ‖y − ŷ‖ / ‖y − mean(y)‖)`
///
/// 100 % is a perfect fit, 0 % is no better than the measured mean, and it is negative when
/// the model is worse than the mean (as thesis Table 5.10's nominal Model 1).
pub fn nrmse_percent(measured: &[f64], simulated: &[f64]) -> Result<f64, ValidateError> {
    check_pair(
        measured,
        simulated,
        ["measured signal", "simulated signal"],
        2,
        "NRMSE",
    )?;
    let m = mean(measured);
    let error: f64 = measured
        .iter()
        .zip(simulated)
        .map(|(y, s)| (y - s).powi(2))
        .sum();
    let spread: f64 = measured.iter().map(|y| (y - m).powi(2)).sum();
    if spread == 0.0 {
        return Err(ValidateError::Constant {
            which: "measured signal",
            what: "NRMSE",
        });
    }
    Ok(100.0 * (1.0 - (error / spread).sqrt()))
}

/// Samples per stretch of [`estimate_noise_std`] (2 s at the loggers' 10 Hz: a road run's
/// 5 s standstills hold two whole ones).
const NOISE_STRETCH_SAMPLES: usize = 20;
/// Share of a stretch's second differences its loudness is read from (the quietest 90 %:
/// a stretch where a hump or a step begins in its last sample still reads as quiet).
const STRETCH_LOUDNESS_SHARE: f64 = 0.9;
/// A stretch counts as quiet while its loudness is at most this many times the quiet
/// stretches' mean. For white noise a stretch's loudness scatters by about 45 % around its
/// expectation (18 correlated second differences), so three times the mean is more than four
/// of those spreads away and drops almost none of them (0.2 % of the stretches of white noise).
const QUIET_STRETCH_FACTOR: f64 = 3.0;
/// Fraction of the quiet stretches' largest squared second differences the estimate drops:
/// steps and transients of the signal itself, which are not noise.
const NOISE_TRIM_FRACTION: f64 = 0.01;
/// `E[d²; |d| below its 99th percentile] / E[d²]` for Gaussian `d`: the share of the variance
/// the trim keeps, `1 − 2 z φ(z) / 0.99` at `z = 2.576`, divided out again.
const NOISE_TRIM_VARIANCE_KEPT: f64 = 0.9248;

/// The standard deviation of white measurement noise on `y`, estimated from its second
/// differences in its quiet stretches: for white noise of std `σ`, `d_k = y_{k+1} − 2 y_k +
/// y_{k−1}` has variance `6 σ²`, while a signal sampled fast against its dynamics contributes
/// almost nothing (a suspension at 10 Hz standing or loading: mm/s² × 0.01 s²). Not so on a
/// road: there the body and the wheel move at 1–5 Hz and their second differences are many
/// times the noise's (an ISO 8608 road run: the ceiling implied by all of them 57 % where the
/// truth's is 97 %). So the run is cut into stretches of 2 s, each stretch's loudness read
/// from its quietest 90 % of `d²`, and the quiet stretches kept: starting from the third
/// quietest, those within [`QUIET_STRETCH_FACTOR`] of their own mean, grown to a fixed point. A load step or a hump makes its stretch loud and it drops out; for white noise
/// alone nearly every stretch stays. Over the quiet stretches' `d²` the largest 1 % are
/// dropped (a step inside a quiet stretch) and the Gaussian share they carry is put back.
/// Stretches without any change (a quantised signal sitting on one level) carry no
/// information about the noise and are skipped.
///
/// Assumes the noise is white and stationary, and that the run has quiet stretches (standing,
/// loading, valve work; a road run's standstills and the level road between humps);
/// quantisation counts as noise (it is an error no model can remove). On the virtual truck's
/// runs it lands within 2 % of the true noise std (tested), on its ISO road run (5 s of
/// standstill at each end) within about 10 %. `None` below 100 samples or with non-finite
/// values.
pub fn estimate_noise_std(y: &[f64]) -> Option<f64> {
    if y.len() < 100 || y.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let squares: Vec<f64> = y
        .windows(3)
        .map(|w| (w[2] - 2.0 * w[1] + w[0]).powi(2))
        .collect();
    let mut stretches: Vec<&[f64]> = squares.chunks(NOISE_STRETCH_SAMPLES).collect();
    // A short last stretch joins the one before.
    if stretches.len() > 1 && stretches[stretches.len() - 1].len() < NOISE_STRETCH_SAMPLES / 2 {
        stretches.pop();
        let joined =
            squares.len() - (squares.len() % NOISE_STRETCH_SAMPLES) - NOISE_STRETCH_SAMPLES;
        if let Some(last) = stretches.last_mut() {
            *last = &squares[joined..];
        }
    }
    let loudness = |stretch: &[f64]| {
        let mut sorted = stretch.to_vec();
        sorted.sort_by(f64::total_cmp);
        let kept = ((STRETCH_LOUDNESS_SHARE * sorted.len() as f64) as usize).max(1);
        sorted[..kept].iter().sum::<f64>() / kept as f64
    };
    let mut informative: Vec<(f64, &[f64])> = stretches
        .into_iter()
        .filter(|s| s.iter().any(|&d| d > 0.0))
        .map(|s| (loudness(s), s))
        .collect();
    if informative.is_empty() {
        return Some(0.0);
    }
    informative.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Sorted by loudness: the quiet stretches are a prefix; find its length as a fixed point,
    // grown from the third quietest stretch that has any loudness. A start higher up (the
    // tenth percentile) is itself loud on a road run that stands for less than a tenth of its
    // time, and three times it lets every loud stretch in; the very quietest can be so quiet
    // by chance that three times it reaches no other (a 2 s stretch's loudness scatters by
    // 45 %); a loudness of 0 (a quantised signal on one level) would let none in.
    let audible: Vec<f64> = informative
        .iter()
        .map(|s| s.0)
        .filter(|&loud| loud > 0.0)
        .collect();
    let mut level = audible
        .get(2.min(audible.len().saturating_sub(1)))
        .copied()
        .unwrap_or(0.0);
    let mut quiet = 0;
    for _ in 0..50 {
        let now = informative
            .partition_point(|&(loud, _)| loud <= QUIET_STRETCH_FACTOR * level)
            .max(1);
        if now == quiet {
            break;
        }
        quiet = now;
        level = informative[..quiet].iter().map(|s| s.0).sum::<f64>() / quiet as f64;
    }
    let mut pooled: Vec<f64> = informative[..quiet]
        .iter()
        .flat_map(|s| s.1.iter().copied())
        .collect();
    pooled.sort_by(f64::total_cmp);
    let kept = (((1.0 - NOISE_TRIM_FRACTION) * pooled.len() as f64) as usize).max(1);
    let mean_square = pooled[..kept].iter().sum::<f64>() / kept as f64;
    Some((mean_square / 6.0 / NOISE_TRIM_VARIANCE_KEPT).sqrt())
}

/// The best NRMSE any model can reach on `measured` when its noise has std `noise_std`
/// (thesis eq 3.33 with `y − ŷ` = the noise): `100 (1 − σ √N / ‖y − mean(y)‖)`.
pub fn noise_ceiling_percent(measured: &[f64], noise_std: f64) -> Result<f64, ValidateError> {
    if measured.len() < 2 {
        return Err(ValidateError::TooShort {
            what: "the noise ceiling",
            needed: 2,
            found: measured.len(),
        });
    }
    if let Some(index) = measured.iter().position(|v| !v.is_finite()) {
        return Err(ValidateError::NotFinite {
            which: "measured signal",
            index,
        });
    }
    let m = mean(measured);
    let spread: f64 = measured.iter().map(|y| (y - m).powi(2)).sum::<f64>().sqrt();
    if spread == 0.0 {
        return Err(ValidateError::Constant {
            which: "measured signal",
            what: "the noise ceiling",
        });
    }
    Ok(100.0 * (1.0 - noise_std * (measured.len() as f64).sqrt() / spread))
}

/// Root-mean-square error, in the signals' unit.
pub fn rmse(measured: &[f64], simulated: &[f64]) -> Result<f64, ValidateError> {
    check_pair(
        measured,
        simulated,
        ["measured signal", "simulated signal"],
        1,
        "RMSE",
    )?;
    let sum: f64 = measured
        .iter()
        .zip(simulated)
        .map(|(y, s)| (y - s).powi(2))
        .sum();
    Ok((sum / measured.len() as f64).sqrt())
}

/// A correlation function over lags with its confidence band.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Correlation {
    /// Lags `τ` in samples, from `−max_lag` to `max_lag` (autocorrelation: `0..=max_lag`).
    pub lags: Vec<i64>,
    /// Correlation coefficients at those lags.
    pub values: Vec<f64>,
    /// Half-width of the band around 0 within which the values stay, at `confidence`, if the
    /// signals are uncorrelated.
    pub band: f64,
    pub confidence: f64,
    /// How many lags (excluding lag 0 of an autocorrelation) fall outside the band.
    pub outside: usize,
}

impl Correlation {
    /// The largest |value| relative to the band (`> 1`: outside somewhere).
    pub fn worst_ratio(&self) -> f64 {
        self.values
            .iter()
            .zip(&self.lags)
            .filter(|(_, lag)| self.lags[0] < 0 || **lag != 0)
            .map(|(v, _)| v.abs() / self.band)
            .fold(0.0, f64::max)
    }
}

fn z_score(confidence: f64) -> Result<f64, ValidateError> {
    if !(confidence > 0.0 && confidence < 1.0) {
        return Err(ValidateError::BadConfidence(confidence));
    }
    // Two-sided band: P(|Z| < z) = confidence.
    let normal = Normal::standard();
    Ok(normal.inverse_cdf(0.5 + confidence / 2.0))
}

/// `R(τ) = 1/N Σ_t a(t+τ) b(t)` over the valid `t`, for mean-removed `a`, `b` (eq 3.35).
fn covariance_at(a: &[f64], b: &[f64], lag: i64) -> f64 {
    let n = a.len();
    let shift = lag.unsigned_abs() as usize;
    if shift >= n {
        return 0.0;
    }
    let sum: f64 = if lag >= 0 {
        a[shift..]
            .iter()
            .zip(&b[..n - shift])
            .map(|(x, y)| x * y)
            .sum()
    } else {
        a[..n - shift]
            .iter()
            .zip(&b[shift..])
            .map(|(x, y)| x * y)
            .sum()
    };
    sum / n as f64
}

fn centred(x: &[f64]) -> Vec<f64> {
    let m = mean(x);
    x.iter().map(|v| v - m).collect()
}

/// Residual autocorrelation `r_ε(k) = R_ε(k)/R_ε(0)` for `k = 0..=max_lag`, with the band
/// `z/√N` that a white residual stays inside.
pub fn residual_autocorrelation(
    residual: &[f64],
    max_lag: usize,
    confidence: f64,
) -> Result<Correlation, ValidateError> {
    check_pair(
        residual,
        residual,
        ["residual", "residual"],
        max_lag + 2,
        "residual autocorrelation",
    )?;
    let z = z_score(confidence)?;
    let e = centred(residual);
    let r0 = covariance_at(&e, &e, 0);
    if r0 == 0.0 {
        return Err(ValidateError::Constant {
            which: "residual",
            what: "its autocorrelation",
        });
    }
    let lags: Vec<i64> = (0..=max_lag as i64).collect();
    let values: Vec<f64> = lags
        .iter()
        .map(|&k| covariance_at(&e, &e, k) / r0)
        .collect();
    let band = z / (residual.len() as f64).sqrt();
    let outside = values.iter().skip(1).filter(|v| v.abs() > band).count();
    Ok(Correlation {
        lags,
        values,
        band,
        confidence,
        outside,
    })
}

/// Input–residual cross-correlation `r_εu(τ) = R_εu(τ)/√(R_ε(0) R_u(0))` for
/// `τ = −max_lag..=max_lag` (eq 3.35), positive `τ` meaning the residual lags the input.
///
/// The band is eq 3.36: if ε and u are uncorrelated, `R_εu(τ)` is approximately normal with
/// variance `P/N`, `P = Σ_k R_ε(k) R_u(k)`. The sum runs over `|k| ≤ L` with
/// `L = min(N − 1, max(10·max_lag, 100))`: far enough for the slowly varying inputs of a
/// loading experiment, whose autocorrelation decays over many samples.
pub fn input_residual_correlation(
    residual: &[f64],
    input: &[f64],
    max_lag: usize,
    confidence: f64,
) -> Result<Correlation, ValidateError> {
    check_pair(
        residual,
        input,
        ["residual", "input"],
        max_lag + 2,
        "input-residual correlation",
    )?;
    let z = z_score(confidence)?;
    let e = centred(residual);
    let u = centred(input);
    let re0 = covariance_at(&e, &e, 0);
    let ru0 = covariance_at(&u, &u, 0);
    if re0 == 0.0 {
        return Err(ValidateError::Constant {
            which: "residual",
            what: "its correlation with the input",
        });
    }
    if ru0 == 0.0 {
        return Err(ValidateError::Constant {
            which: "input",
            what: "its correlation with the residual",
        });
    }
    let n = residual.len();
    let window = (n - 1).min((10 * max_lag).max(100)) as i64;
    let p: f64 = covariance_at(&e, &e, 0) * covariance_at(&u, &u, 0)
        + 2.0
            * (1..=window)
                .map(|k| covariance_at(&e, &e, k) * covariance_at(&u, &u, k))
                .sum::<f64>();
    let norm = (re0 * ru0).sqrt();
    let band = z * (p.max(0.0) / n as f64).sqrt() / norm;
    let lags: Vec<i64> = (-(max_lag as i64)..=max_lag as i64).collect();
    let values: Vec<f64> = lags
        .iter()
        .map(|&tau| covariance_at(&e, &u, tau) / norm)
        .collect();
    let outside = values.iter().filter(|v| v.abs() > band).count();
    Ok(Correlation {
        lags,
        values,
        band,
        confidence,
        outside,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nrmse_matches_hand_computed_values() {
        // y = [1, 2, 3], mean 2, ‖y − mean‖ = √2; ŷ = [1, 2, 4]: ‖y − ŷ‖ = 1.
        let fit = nrmse_percent(&[1.0, 2.0, 3.0], &[1.0, 2.0, 4.0]).unwrap();
        assert!((fit - 100.0 * (1.0 - 1.0 / 2f64.sqrt())).abs() < 1e-12);
        assert_eq!(
            nrmse_percent(&[1.0, 2.0, 3.0], &[1.0, 2.0, 3.0]).unwrap(),
            100.0
        );
        assert!(
            nrmse_percent(&[1.0, 2.0, 3.0], &[2.0, 2.0, 2.0])
                .unwrap()
                .abs()
                < 1e-12
        );
        assert!(nrmse_percent(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]).unwrap() < 0.0);
    }

    #[test]
    fn nrmse_rejects_bad_input() {
        assert!(matches!(
            nrmse_percent(&[1.0, 2.0], &[1.0]),
            Err(ValidateError::LengthMismatch { left: 2, right: 1 })
        ));
        assert!(matches!(
            nrmse_percent(&[1.0, f64::NAN], &[1.0, 1.0]),
            Err(ValidateError::NotFinite { index: 1, .. })
        ));
        assert!(matches!(
            nrmse_percent(&[2.0, 2.0], &[1.0, 1.0]),
            Err(ValidateError::Constant { .. })
        ));
        assert_eq!(rmse(&[1.0, 3.0], &[0.0, 0.0]).unwrap(), 5f64.sqrt());
    }

    #[test]
    fn z_score_of_99_percent_is_2_576() {
        assert!((z_score(0.99).unwrap() - 2.5758293).abs() < 1e-6);
        assert!((z_score(0.95).unwrap() - 1.9599640).abs() < 1e-6);
        assert!(z_score(1.0).is_err());
    }

    #[test]
    fn correlations_match_hand_computed_values() {
        // e = [1, −1, 1, −1] (mean 0), u = [1, 1, −1, −1] (mean 0); N = 4.
        let e = [1.0, -1.0, 1.0, -1.0];
        let u = [1.0, 1.0, -1.0, -1.0];
        let auto = residual_autocorrelation(&e, 2, 0.99).unwrap();
        // R(0) = 1, R(1) = (−1 −1 −1)/4 = −0.75, R(2) = (1 + 1)/4 = 0.5.
        assert_eq!(auto.values, vec![1.0, -0.75, 0.5]);
        assert!((auto.band - 2.5758293035489 / 2.0).abs() < 1e-9);
        let cross = input_residual_correlation(&e, &u, 1, 0.99).unwrap();
        // R_eu(−1) = Σ e(t) u(t+1) /4 = (1·1 + (−1)(−1) + 1·(−1))/4 = 0.25
        // R_eu(0) = (1 − 1 − 1 + 1)/4 = 0
        // R_eu(1) = Σ e(t+1) u(t) /4 = (−1·1 + 1·1 + (−1)(−1))/4 = 0.25
        assert_eq!(cross.lags, vec![-1, 0, 1]);
        assert_eq!(cross.values, vec![0.25, 0.0, 0.25]);
        // P = Σ_{|k|≤3} R_e(k) R_u(k): R_e = [1, −.75, .5, −.25], R_u = [1, .25, −.5, −.25]
        // P = 1 + 2(−.1875 − .25 + .0625) = 0.25, band = z √(P/N) = z · 0.25.
        assert!((cross.band - 2.5758293035489 * 0.25).abs() < 1e-9);
    }

    #[test]
    fn white_noise_stays_mostly_inside_the_band_and_a_dependent_residual_does_not() {
        // A deterministic pseudo-random sequence (LCG) keeps the test reproducible.
        let mut state: u64 = 12345;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let n = 5000;
        let u: Vec<f64> = (0..n).map(|_| next()).collect();
        let white: Vec<f64> = (0..n).map(|_| next()).collect();
        let cross = input_residual_correlation(&white, &u, 25, 0.99).unwrap();
        assert!(
            cross.outside <= 2,
            "{} of 51 lags outside a 99 % band",
            cross.outside
        );
        let auto = residual_autocorrelation(&white, 25, 0.99).unwrap();
        assert!(auto.outside <= 2);
        // A residual that still contains the input delayed by 3 samples.
        let dependent: Vec<f64> = (0..n)
            .map(|t| white[t] + if t >= 3 { 0.8 * u[t - 3] } else { 0.0 })
            .collect();
        let cross = input_residual_correlation(&dependent, &u, 25, 0.99).unwrap();
        let at3 = cross.values[cross.lags.iter().position(|&l| l == 3).unwrap()];
        assert!(
            at3 > 10.0 * cross.band,
            "lag 3: {at3} vs band {}",
            cross.band
        );
        assert!(cross.worst_ratio() > 10.0);
    }

    #[test]
    fn constant_input_is_reported() {
        let e = [1.0, -1.0, 0.5, 0.2];
        assert!(matches!(
            input_residual_correlation(&e, &[0.0; 4], 1, 0.99),
            Err(ValidateError::Constant { which: "input", .. })
        ));
        assert!(matches!(
            residual_autocorrelation(&e, 5, 0.99),
            Err(ValidateError::TooShort { .. })
        ));
    }
}
