//! The identification data set: one output, any number of inputs, one sample time.

use std::ops::Range;

use serde::Serialize;

use super::error::IdentError;

/// Sampled input–output data for a single-output system (≙ MATLAB `iddata(y, u, Ts)`).
///
/// Invariants, checked by [`IdData::new`]: at least one sample, every input as long as the
/// output, every value finite, `ts_s > 0`. Fields are private so the invariants hold for the
/// whole life of the value; the estimators rely on them.
#[derive(Debug, Clone, PartialEq)]
pub struct IdData {
    y: Vec<f64>,
    u: Vec<Vec<f64>>,
    ts_s: f64,
}

/// Means removed by [`IdData::detrend`], to apply the same offsets to validation data.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Offsets {
    /// Mean of the output.
    pub y: f64,
    /// Mean of each input.
    pub u: Vec<f64>,
}

impl IdData {
    /// Validated data set: `y` the output, `u` one vector per input, `ts_s` the sample time.
    pub fn new(y: Vec<f64>, u: Vec<Vec<f64>>, ts_s: f64) -> Result<Self, IdentError> {
        if y.is_empty() {
            return Err(IdentError::Empty);
        }
        if !(ts_s.is_finite() && ts_s > 0.0) {
            return Err(IdentError::InvalidSampleTime(ts_s));
        }
        for (input, ui) in u.iter().enumerate() {
            if ui.len() != y.len() {
                return Err(IdentError::LengthMismatch {
                    input,
                    input_len: ui.len(),
                    output_len: y.len(),
                });
            }
        }
        check_finite("output", &y)?;
        for (k, ui) in u.iter().enumerate() {
            check_finite(&format!("input {}", k + 1), ui)?;
        }
        Ok(Self { y, u, ts_s })
    }

    /// Single-input data set.
    pub fn siso(y: Vec<f64>, u: Vec<f64>, ts_s: f64) -> Result<Self, IdentError> {
        Self::new(y, vec![u], ts_s)
    }

    /// The output samples.
    pub fn y(&self) -> &[f64] {
        &self.y
    }

    /// All inputs, one slice per input.
    pub fn u(&self) -> &[Vec<f64>] {
        &self.u
    }

    /// Input `k`, if it exists.
    pub fn input(&self, k: usize) -> Option<&[f64]> {
        self.u.get(k).map(Vec::as_slice)
    }

    /// Sample time in seconds.
    pub fn ts_s(&self) -> f64 {
        self.ts_s
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.y.len()
    }

    /// Always `false` for a validated data set; present for API completeness.
    pub fn is_empty(&self) -> bool {
        self.y.is_empty()
    }

    /// Number of inputs.
    pub fn n_inputs(&self) -> usize {
        self.u.len()
    }

    /// The samples in `range` (zero-based, end exclusive), like MATLAB `z(501:1000)` is
    /// `samples(500..1000)`.
    pub fn samples(&self, range: Range<usize>) -> Result<Self, IdentError> {
        if range.start >= range.end || range.end > self.len() {
            return Err(IdentError::InvalidOption(format!(
                "sample range {}..{} is empty or outside 0..{}",
                range.start,
                range.end,
                self.len()
            )));
        }
        Ok(Self {
            y: self.y[range.clone()].to_vec(),
            u: self.u.iter().map(|ui| ui[range.clone()].to_vec()).collect(),
            ts_s: self.ts_s,
        })
    }

    /// Means of output and inputs.
    pub fn means(&self) -> Offsets {
        Offsets {
            y: mean(&self.y),
            u: self.u.iter().map(|ui| mean(ui)).collect(),
        }
    }

    /// Data with the means removed (≙ MATLAB `detrend(z, 0)`), and the removed means.
    ///
    /// Linear black-box models describe deviations from an operating point; fit them to
    /// detrended data and remove the *same* offsets from validation data with
    /// [`IdData::remove_offsets`].
    pub fn detrend(&self) -> (Self, Offsets) {
        let offsets = self.means();
        (self.remove_offsets(&offsets), offsets)
    }

    /// Data with the given offsets subtracted. Offsets for missing inputs count as zero.
    pub fn remove_offsets(&self, offsets: &Offsets) -> Self {
        Self {
            y: self.y.iter().map(|v| v - offsets.y).collect(),
            u: self
                .u
                .iter()
                .enumerate()
                .map(|(k, ui)| {
                    let m = offsets.u.get(k).copied().unwrap_or(0.0);
                    ui.iter().map(|v| v - m).collect()
                })
                .collect(),
            ts_s: self.ts_s,
        }
    }
}

/// Error if input `input` is constant: the coefficients that multiply it cannot be separated
/// from one another (or, after detrending, from zero).
pub(crate) fn check_input_varies(input: usize, values: &[f64]) -> Result<(), IdentError> {
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    let scale = lo.abs().max(hi.abs());
    if hi - lo <= 1e-12 * scale || hi == lo {
        return Err(IdentError::ConstantInput { input, value: lo });
    }
    Ok(())
}

fn check_finite(signal: &str, values: &[f64]) -> Result<(), IdentError> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(IdentError::NonFinite {
            signal: signal.to_owned(),
            index,
            value: values[index],
        }),
        None => Ok(()),
    }
}

pub(crate) fn mean(values: &[f64]) -> f64 {
    if values.is_empty() {
        0.0
    } else {
        values.iter().sum::<f64>() / values.len() as f64
    }
}
