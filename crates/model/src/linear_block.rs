//! Discrete OE models embedded in continuous time by zero-order hold (thesis eq 4.3, 4.5).
//!
//! The thesis identified its black-box blocks as discrete OE models (MATLAB `oe`), then
//! converted them with `d2c(…, 'zoh')` and appended their states to the ODE. We do the same
//! with `airsus-ident`'s [`PolyModel::to_continuous_state_space`], one SISO block per input,
//! stacked block-diagonally, and evaluate `ẋ = A x + B u`, `y = C x + D u` on plain slices
//! without allocating.
//!
//! **Delays.** ZOH accounts for one sample of delay; `nk - 1` further samples are a pure time
//! delay, which an ODE state vector cannot hold exactly. We drop it and report it
//! ([`LinearBlock::dropped_delay_s`]): for the thesis models it is 0.1 s (Model 2 extended,
//! `nk = 2`, against a 33 s time constant) or zero (Model 3, `nk = 1`).

use airsus_ident::linear::{PolyModel, Structure};

use crate::model::{ModelError, StateInfo, StateRole};

/// States of an OE block inside a model (`oe1`, `oe2`, ..): the block's own scaling, no unit.
pub const OE_STATES: &[StateInfo] = &[
    StateInfo::new("oe1", "1", StateRole::Filter),
    StateInfo::new("oe2", "1", StateRole::Filter),
    StateInfo::new("oe3", "1", StateRole::Filter),
    StateInfo::new("oe4", "1", StateRole::Filter),
    StateInfo::new("oe5", "1", StateRole::Filter),
    StateInfo::new("oe6", "1", StateRole::Filter),
    StateInfo::new("oe7", "1", StateRole::Filter),
    StateInfo::new("oe8", "1", StateRole::Filter),
    StateInfo::new("oe9", "1", StateRole::Filter),
    StateInfo::new("oe10", "1", StateRole::Filter),
    StateInfo::new("oe11", "1", StateRole::Filter),
    StateInfo::new("oe12", "1", StateRole::Filter),
];

/// A continuous-time, multi-input single-output linear block in state-space form.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearBlock {
    n_states: usize,
    n_inputs: usize,
    /// Row-major `n × n`.
    a: Vec<f64>,
    /// Row-major `n × m`.
    b: Vec<f64>,
    c: Vec<f64>,
    d: Vec<f64>,
    dc_gain: Vec<f64>,
    dropped_delay_s: f64,
}

/// One input's discrete OE transfer function `q^-nk B(q) / F(q)`.
#[derive(Debug, Clone, Copy)]
pub struct OeInput<'a> {
    /// `b1, b2, ..` (the delay is `nk`, not leading zeros).
    pub b: &'a [f64],
    /// `f1, f2, ..` (the leading 1 implicit).
    pub f: &'a [f64],
    pub nk: usize,
}

impl LinearBlock {
    /// ZOH continuous equivalent of the multi-input OE model `y = Σ q^-nkᵢ Bᵢ/Fᵢ uᵢ` sampled at
    /// `ts_s`. Errors if a block has no continuous equivalent (a pole at zero or on the negative
    /// real axis, e.g. `nb > nf`).
    pub fn from_oe(model: &str, inputs: &[OeInput<'_>], ts_s: f64) -> Result<Self, ModelError> {
        let fail = |reason: String| ModelError::InvalidStructure {
            model: model.to_owned(),
            reason,
        };
        let poly = PolyModel {
            structure: Structure::Oe,
            a: vec![1.0],
            b: inputs.iter().map(|i| i.b.to_vec()).collect(),
            c: vec![1.0],
            d: vec![1.0],
            f: inputs
                .iter()
                .map(|i| std::iter::once(1.0).chain(i.f.iter().copied()).collect())
                .collect(),
            nk: inputs.iter().map(|i| i.nk).collect(),
            ts_s,
        };
        let blocks = poly.to_continuous_state_space().map_err(|e| {
            fail(format!(
                "cannot convert the OE model to continuous time by zero-order hold: {e}"
            ))
        })?;
        let n: usize = blocks.iter().map(|b| b.ss.n_states()).sum();
        let m = inputs.len();
        let mut out = Self {
            n_states: n,
            n_inputs: m,
            a: vec![0.0; n * n],
            b: vec![0.0; n * m],
            c: vec![0.0; n],
            d: vec![0.0; m],
            dc_gain: vec![0.0; m],
            dropped_delay_s: 0.0,
        };
        let mut offset = 0;
        for (i, blk) in blocks.iter().enumerate() {
            let k = blk.ss.n_states();
            for r in 0..k {
                for c in 0..k {
                    out.a[(offset + r) * n + offset + c] = blk.ss.a[(r, c)];
                }
                out.b[(offset + r) * m + i] = blk.ss.b[(r, 0)];
                out.c[offset + r] = blk.ss.c[(0, r)];
            }
            out.d[i] = blk.ss.d[(0, 0)];
            out.dropped_delay_s = out.dropped_delay_s.max(blk.input_delay_s);
            // Static gain of this input: D - C A⁻¹ B, computed on the block.
            let gain = match blk.ss.a.clone().try_inverse() {
                Some(inv) => blk.ss.d[(0, 0)] - (&blk.ss.c * inv * &blk.ss.b)[(0, 0)],
                None => f64::INFINITY,
            };
            out.dc_gain[i] = gain;
            offset += k;
        }
        Ok(out)
    }

    pub fn n_states(&self) -> usize {
        self.n_states
    }

    /// Steady-state gain of each input (`y/u` for constant `u`).
    pub fn dc_gain(&self) -> &[f64] {
        &self.dc_gain
    }

    /// The pure delay left out of the ODE, s (see the module docs).
    pub fn dropped_delay_s(&self) -> f64 {
        self.dropped_delay_s
    }

    /// `dx = A x + B u`. `x`, `dx` have [`Self::n_states`] entries, `u` one per input.
    pub fn derivative(&self, x: &[f64], u: &[f64], dx: &mut [f64]) {
        let (n, m) = (self.n_states, self.n_inputs);
        for (r, out) in dx.iter_mut().enumerate().take(n) {
            let row_a = &self.a[r * n..(r + 1) * n];
            let row_b = &self.b[r * m..(r + 1) * m];
            *out = row_a.iter().zip(x).map(|(a, x)| a * x).sum::<f64>()
                + row_b.iter().zip(u).map(|(b, u)| b * u).sum::<f64>();
        }
    }

    /// `y = C x + D u`.
    pub fn output(&self, x: &[f64], u: &[f64]) -> f64 {
        self.c.iter().zip(x).map(|(c, x)| c * x).sum::<f64>()
            + self.d.iter().zip(u).map(|(d, u)| d * u).sum::<f64>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_order_zoh_by_hand() {
        // y(k) = 0.5 u(k-1) + 0.9 y(k-1): pole a = ln 0.9 / 0.1, gain 0.5/(1-0.9) = 5.
        let blk = LinearBlock::from_oe(
            "t",
            &[OeInput {
                b: &[0.5],
                f: &[-0.9],
                nk: 1,
            }],
            0.1,
        )
        .unwrap();
        assert_eq!(blk.n_states(), 1);
        assert!((blk.dc_gain()[0] - 5.0).abs() < 1e-9, "{:?}", blk.dc_gain());
        // Continuous step response sampled at 0.1 s equals the discrete one: after one sample
        // y = 0.5, after two 0.5 + 0.45.
        let mut x = [0.0];
        let dt = 1e-4;
        let mut ys = Vec::new();
        for step in 1..=2000 {
            let mut dx = [0.0];
            // RK2 is plenty for a linear first-order system at this step.
            blk.derivative(&x, &[1.0], &mut dx);
            let mid = [x[0] + 0.5 * dt * dx[0]];
            blk.derivative(&mid, &[1.0], &mut dx);
            x[0] += dt * dx[0];
            if step % 1000 == 0 {
                ys.push(blk.output(&x, &[1.0]));
            }
        }
        assert!((ys[0] - 0.5).abs() < 1e-6, "{ys:?}");
        assert!((ys[1] - 0.95).abs() < 1e-6, "{ys:?}");
    }

    #[test]
    fn delay_beyond_one_sample_is_reported_and_pole_at_zero_rejected() {
        let blk = LinearBlock::from_oe(
            "t",
            &[OeInput {
                b: &[-8.672e-8],
                f: &[-0.997],
                nk: 2,
            }],
            0.1,
        )
        .unwrap();
        assert!((blk.dropped_delay_s() - 0.1).abs() < 1e-12);
        assert!((blk.dc_gain()[0] + 8.672e-8 / 0.003).abs() < 1e-9);
        let err = LinearBlock::from_oe(
            "t",
            &[OeInput {
                b: &[1.0, 1.0],
                f: &[],
                nk: 1,
            }],
            0.1,
        )
        .unwrap_err();
        assert!(matches!(err, ModelError::InvalidStructure { .. }), "{err}");
    }
}
