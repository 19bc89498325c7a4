//! The polynomial model (≙ MATLAB `idpoly`) and its verbs: simulate, predict, residuals.

use serde::Serialize;

use super::error::IdentError;
use super::poly::{filter, filter_delayed, impulse, is_stable, poly_mul, roots};
use nalgebra::Complex;

/// Which member of the family `A y = Σᵢ Bᵢ/Fᵢ uᵢ + C/D e` a model is (thesis eq 3.25–3.28,
/// Ljung 1999 §4.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Structure {
    /// `A(q) y(t) = Σᵢ Bᵢ(q) uᵢ(t−nkᵢ) + e(t)` (eq 3.28).
    Arx,
    /// `A(q) y(t) = Σᵢ Bᵢ(q) uᵢ(t−nkᵢ) + C(q) e(t)` (eq 3.27).
    Armax,
    /// `y(t) = Σᵢ Bᵢ(q)/Fᵢ(q) uᵢ(t−nkᵢ) + e(t)` (eq 3.26).
    Oe,
    /// `y(t) = Σᵢ Bᵢ(q)/Fᵢ(q) uᵢ(t−nkᵢ) + C(q)/D(q) e(t)` (eq 3.25).
    Bj,
}

impl Structure {
    /// Upper-case name as the toolbox prints it.
    pub fn label(self) -> &'static str {
        match self {
            Structure::Arx => "ARX",
            Structure::Armax => "ARMAX",
            Structure::Oe => "OE",
            Structure::Bj => "BJ",
        }
    }
}

/// A discrete-time, multi-input single-output polynomial model
///
/// `A(q) y(t) = Σᵢ [Bᵢ(q)/Fᵢ(q)] uᵢ(t − nkᵢ) + [C(q)/D(q)] e(t)`
///
/// with `A, C, D, Fᵢ` monic (`[1, x₁, …, xₙ]`) and
/// `Bᵢ(q) = b₁ + b₂q⁻¹ + … + b_{nb}q^{−nb+1}`, so `b₁` multiplies `uᵢ(t − nkᵢ)` (thesis
/// eq 3.22). Unlike MATLAB, which pads `B` with `nk` leading zeros, `b` holds only the `nb`
/// free coefficients and the delay is in `nk`. Unused polynomials are `[1]`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PolyModel {
    /// Model family.
    pub structure: Structure,
    /// `A(q)`, monic.
    pub a: Vec<f64>,
    /// `Bᵢ(q)` per input, `nbᵢ` coefficients starting at delay `nkᵢ`.
    pub b: Vec<Vec<f64>>,
    /// `C(q)`, monic.
    pub c: Vec<f64>,
    /// `D(q)`, monic.
    pub d: Vec<f64>,
    /// `Fᵢ(q)` per input, monic.
    pub f: Vec<Vec<f64>>,
    /// Input delays in samples.
    pub nk: Vec<usize>,
    /// Sample time in seconds.
    pub ts_s: f64,
}

impl PolyModel {
    /// Number of inputs.
    pub fn n_inputs(&self) -> usize {
        self.b.len()
    }

    /// Checks that the fields describe a model: one `b`, `f` and `nk` entry per input, `A`,
    /// `C`, `D`, `Fᵢ` monic, every coefficient finite and `ts_s > 0`. Models built by the
    /// estimators always pass; this guards hand-built ones (the fields are public).
    pub fn validate(&self) -> Result<(), IdentError> {
        let m = self.b.len();
        if self.f.len() != m || self.nk.len() != m {
            return Err(IdentError::InvalidOrder(format!(
                "model has {m} B polynomial(s) but {} F and {} nk entries",
                self.f.len(),
                self.nk.len()
            )));
        }
        let monic = |p: &[f64]| p.first() == Some(&1.0);
        if !(monic(&self.a) && monic(&self.c) && monic(&self.d) && self.f.iter().all(|f| monic(f)))
        {
            return Err(IdentError::InvalidOrder(
                "A, C, D and F must be monic (leading coefficient 1)".to_owned(),
            ));
        }
        let all = self
            .a
            .iter()
            .chain(&self.c)
            .chain(&self.d)
            .chain(self.b.iter().flatten())
            .chain(self.f.iter().flatten());
        if let Some(&value) = all.clone().find(|v| !v.is_finite()) {
            return Err(IdentError::NonFinite {
                signal: "model coefficient".to_owned(),
                index: 0,
                value,
            });
        }
        if !(self.ts_s.is_finite() && self.ts_s > 0.0) {
            return Err(IdentError::InvalidSampleTime(self.ts_s));
        }
        Ok(())
    }

    fn check_signals(&self, y: Option<&[f64]>, u: &[Vec<f64>]) -> Result<usize, IdentError> {
        self.validate()?;
        if u.len() != self.n_inputs() {
            return Err(IdentError::InputCountMismatch {
                orders: self.n_inputs(),
                data: u.len(),
            });
        }
        let n = match (y, u.first()) {
            (Some(y), _) => y.len(),
            (None, Some(u0)) => u0.len(),
            (None, None) => 0,
        };
        for (input, ui) in u.iter().enumerate() {
            if ui.len() != n {
                return Err(IdentError::LengthMismatch {
                    input,
                    input_len: ui.len(),
                    output_len: n,
                });
            }
        }
        Ok(n)
    }

    /// Input-to-output transfer function of input `i` as `(numerator, denominator)` in `q⁻¹`:
    /// `q^{−nk}Bᵢ(q) / (A(q)Fᵢ(q))`, the numerator including the `nk` leading zeros; `None`
    /// for a missing input or an invalid model (see [`PolyModel::validate`]).
    pub fn transfer_function(&self, input: usize) -> Option<(Vec<f64>, Vec<f64>)> {
        self.validate().ok()?;
        let b = self.b.get(input)?;
        let mut num = vec![0.0; self.nk[input]];
        num.extend_from_slice(b);
        Some((num, poly_mul(&self.a, &self.f[input])))
    }

    /// Noise-free simulated output `ŷ_s(t) = Σᵢ Bᵢ/(A Fᵢ) uᵢ(t − nkᵢ)`, zero initial
    /// conditions (≙ MATLAB `sim`).
    pub fn simulate(&self, u: &[Vec<f64>]) -> Result<Vec<f64>, IdentError> {
        let n = self.check_signals(None, u)?;
        let mut out = vec![0.0; n];
        let mut part = vec![0.0; n];
        for (i, ui) in u.iter().enumerate() {
            let den = poly_mul(&self.a, &self.f[i]);
            filter_delayed(&self.b[i], self.nk[i], &den, ui, &mut part);
            out.iter_mut().zip(&part).for_each(|(o, p)| *o += p);
        }
        Ok(out)
    }

    /// `k`-step-ahead prediction `ŷ(t | t−k)` (≙ MATLAB `predict(sys, data, k)`), zero
    /// initial conditions.
    ///
    /// Ljung (1999) §3.2: `ŷ(t|t−k) = W_k G u + (1 − W_k) y` with `G = B/(AF)`,
    /// `H = C/(AD)`, `W_k = H̄_k H⁻¹` and `H̄_k = Σ_{l<k} h(l) q⁻ˡ` the first `k` terms of the
    /// noise impulse response. Written as
    /// `ŷ = y − (H̄_k A D / C) y + (H̄_k D / C) Σᵢ (Bᵢ/Fᵢ) uᵢ`
    /// it only divides by `C` and `Fᵢ`, which are stable for every estimate here, so it stays
    /// bounded even for an ARX model with an unstable `A`. `k = 1` is the one-step predictor
    /// whose errors PEM minimises; for OE every `k` gives the simulation.
    pub fn predict(&self, y: &[f64], u: &[Vec<f64>], k: usize) -> Result<Vec<f64>, IdentError> {
        if k == 0 {
            return Err(IdentError::InvalidHorizon);
        }
        let n = self.check_signals(Some(y), u)?;
        let ad = poly_mul(&self.a, &self.d);
        let h_bar = impulse(&self.c, &ad, k);
        let num_y = poly_mul(&h_bar, &ad);
        let num_u = poly_mul(&h_bar, &self.d);
        let mut yhat = y.to_vec();
        let from_y = filter(&num_y, &self.c, y);
        yhat.iter_mut().zip(&from_y).for_each(|(p, v)| *p -= v);
        let mut g_u = vec![0.0; n];
        let mut part = vec![0.0; n];
        for (i, ui) in u.iter().enumerate() {
            filter_delayed(&self.b[i], self.nk[i], &self.f[i], ui, &mut part);
            g_u.iter_mut().zip(&part).for_each(|(o, p)| *o += p);
        }
        let from_u = filter(&num_u, &self.c, &g_u);
        yhat.iter_mut().zip(&from_u).for_each(|(p, v)| *p += v);
        Ok(yhat)
    }

    /// One-step prediction errors `ε(t) = y(t) − ŷ(t|t−1)` (≙ MATLAB `resid`, `pe`).
    pub fn residuals(&self, y: &[f64], u: &[Vec<f64>]) -> Result<Vec<f64>, IdentError> {
        let yhat = self.predict(y, u, 1)?;
        Ok(y.iter().zip(&yhat).map(|(a, b)| a - b).collect())
    }

    /// First `n` samples of the impulse response from input `i` to the output; `None` for a
    /// missing input or an invalid model.
    pub fn impulse_response(&self, input: usize, n: usize) -> Option<Vec<f64>> {
        let (num, den) = self.transfer_function(input)?;
        Some(impulse(&num, &den, n))
    }

    /// Poles of the transfer function from input `i`: roots of `A(z)Fᵢ(z)`.
    pub fn poles(&self, input: usize) -> Result<Vec<Complex<f64>>, IdentError> {
        let f = self
            .f
            .get(input)
            .ok_or_else(|| IdentError::InvalidOption(format!("no input {input}")))?;
        roots(&poly_mul(&self.a, f))
    }

    /// `true` if `A`, `C`, `D` and every `Fᵢ` have all roots strictly inside the unit circle:
    /// the one-step predictor and the simulation are both stable.
    pub fn is_stable(&self) -> bool {
        is_stable(&self.a)
            && is_stable(&self.c)
            && is_stable(&self.d)
            && self.f.iter().all(|f| is_stable(f))
    }
}
