//! State-space forms, and zero-order-hold conversion between discrete and continuous time.
//!
//! # Zero-order hold
//!
//! With the input held constant over each sample interval `T`, the continuous system
//! `ẋ = A x + B u` becomes `x(k+1) = A_d x(k) + B_d u(k)` with (Åström & Wittenmark,
//! *Computer-Controlled Systems*, eq 2.4; thesis eq 4.3/4.5 use it to embed OE models in the
//! continuous-time models)
//!
//! ```text
//! exp( [A B; 0 0] T ) = [A_d B_d; 0 I]
//! ```
//!
//! `c2d` evaluates that matrix exponential (nalgebra's scaling-and-squaring Padé `exp`).
//! `d2c` inverts it with the principal matrix logarithm of `[A_d B_d; 0 I]`, which exists and
//! is real exactly when `A_d` has no eigenvalue on the closed negative real axis: a discrete
//! pole at `z = 0` (e.g. from extra delays, or `nb > nf`) or at `z < 0` (a "ringing" mode at the
//! Nyquist frequency) has no ZOH continuous-time equivalent, and is reported as
//! [`IdentError::NoRealLogarithm`]. Poles with `|arg z| ≥ π` alias: `d2c` returns the
//! principal (lowest-frequency) continuous equivalent.
//!
//! nalgebra has `exp` but no matrix logarithm, so `logm` here is the inverse
//! scaling-and-squaring method (Higham, *Functions of Matrices*, §11.5): Denman–Beavers square
//! roots until `‖X − I‖ ≤ 1/4`, then `log X = 2 atanh((X − I)(X + I)⁻¹)` by its fast series.

use nalgebra::{Complex, DMatrix, Schur};

use super::error::IdentError;
use super::model::PolyModel;
use super::poly::poly_mul;

/// Continuous or discrete time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeDomain {
    /// `ẋ = A x + B u`.
    Continuous,
    /// `x(k+1) = A x(k) + B u(k)` with sample time `ts_s` seconds.
    Discrete {
        /// Sample time in seconds.
        ts_s: f64,
    },
}

/// `ẋ = Ax + Bu, y = Cx + Du` (or its discrete-time counterpart).
#[derive(Debug, Clone, PartialEq)]
pub struct StateSpace {
    /// State matrix, `n × n`.
    pub a: DMatrix<f64>,
    /// Input matrix, `n × m`.
    pub b: DMatrix<f64>,
    /// Output matrix, `p × n`.
    pub c: DMatrix<f64>,
    /// Feedthrough, `p × m`.
    pub d: DMatrix<f64>,
    /// Time domain.
    pub domain: TimeDomain,
}

/// The continuous-time ZOH equivalent of one input's transfer function of a polynomial model:
/// `y = C x + D u(t − input_delay_s)`, `ẋ = A x + B u(t − input_delay_s)`.
#[derive(Debug, Clone, PartialEq)]
pub struct ContinuousSubsystem {
    /// Zero-based input index.
    pub input: usize,
    /// Continuous-time state space (single input, single output).
    pub ss: StateSpace,
    /// Pure input delay `(nk − 1)·T` in seconds: the part of the discrete delay beyond the one
    /// sample that the zero-order hold itself accounts for.
    pub input_delay_s: f64,
}

impl StateSpace {
    /// Checked constructor.
    pub fn new(
        a: DMatrix<f64>,
        b: DMatrix<f64>,
        c: DMatrix<f64>,
        d: DMatrix<f64>,
        domain: TimeDomain,
    ) -> Result<Self, IdentError> {
        let n = a.nrows();
        if a.ncols() != n
            || b.nrows() != n
            || c.ncols() != n
            || d.nrows() != c.nrows()
            || d.ncols() != b.ncols()
        {
            return Err(IdentError::Dimension(format!(
                "A {}x{}, B {}x{}, C {}x{}, D {}x{}",
                a.nrows(),
                a.ncols(),
                b.nrows(),
                b.ncols(),
                c.nrows(),
                c.ncols(),
                d.nrows(),
                d.ncols()
            )));
        }
        if let TimeDomain::Discrete { ts_s } = domain
            && !(ts_s.is_finite() && ts_s > 0.0)
        {
            return Err(IdentError::InvalidSampleTime(ts_s));
        }
        if [&a, &b, &c, &d]
            .iter()
            .any(|m| m.iter().any(|v| !v.is_finite()))
        {
            return Err(IdentError::NonFinite {
                signal: "state-space matrix".to_owned(),
                index: 0,
                value: f64::NAN,
            });
        }
        Ok(Self { a, b, c, d, domain })
    }

    /// Number of states.
    pub fn n_states(&self) -> usize {
        self.a.nrows()
    }

    /// Observer canonical form of the SISO transfer function `num/den`, both in descending
    /// powers of `s` (or `z`), `num` no longer than `den` (MATLAB `tf` convention):
    ///
    /// ```text
    /// G = (b₀ sⁿ + b₁ sⁿ⁻¹ + … + bₙ) / (sⁿ + a₁ sⁿ⁻¹ + … + aₙ)
    /// A = [−a | I; 0],  B = (bᵢ − aᵢ b₀)ᵢ,  C = [1 0 … 0],  D = b₀
    /// ```
    ///
    /// (Kailath, *Linear Systems*, §2.1). For a discrete model in `q⁻¹`, `x₀ + x₁q⁻¹ + … +
    /// xₙq⁻ⁿ` has the same coefficient vector in descending powers of `z` once numerator and
    /// denominator are padded with trailing zeros to equal length.
    pub fn observer_canonical(
        num: &[f64],
        den: &[f64],
        domain: TimeDomain,
    ) -> Result<Self, IdentError> {
        let (bcoef, acoef) = normalised(num, den)?;
        let n = acoef.len() - 1;
        let b0 = bcoef[0];
        let mut a = DMatrix::zeros(n, n);
        let mut b = DMatrix::zeros(n, 1);
        for i in 0..n {
            a[(i, 0)] = -acoef[i + 1];
            if i + 1 < n {
                a[(i, i + 1)] = 1.0;
            }
            b[(i, 0)] = bcoef[i + 1] - acoef[i + 1] * b0;
        }
        let mut c = DMatrix::zeros(1, n);
        if n > 0 {
            c[(0, 0)] = 1.0;
        }
        Self::new(a, b, c, DMatrix::from_element(1, 1, b0), domain)
    }

    /// Controller canonical form of `num/den` (same conventions as
    /// [`StateSpace::observer_canonical`]; it is that form's dual):
    /// `A = [−a; I 0]`, `B = e₁`, `C = (bᵢ − aᵢ b₀)ᵢ`, `D = b₀`.
    pub fn controller_canonical(
        num: &[f64],
        den: &[f64],
        domain: TimeDomain,
    ) -> Result<Self, IdentError> {
        let o = Self::observer_canonical(num, den, domain)?;
        Self::new(
            o.a.transpose(),
            o.c.transpose(),
            o.b.transpose(),
            o.d,
            domain,
        )
    }

    /// Zero-order-hold discretisation with sample time `ts_s` (≙ MATLAB `c2d(sys, Ts, 'zoh')`).
    pub fn c2d(&self, ts_s: f64) -> Result<Self, IdentError> {
        if self.domain != TimeDomain::Continuous {
            return Err(IdentError::InvalidOption(
                "c2d needs a continuous-time system".to_owned(),
            ));
        }
        if !(ts_s.is_finite() && ts_s > 0.0) {
            return Err(IdentError::InvalidSampleTime(ts_s));
        }
        let (n, m) = (self.n_states(), self.b.ncols());
        let mut aug = DMatrix::zeros(n + m, n + m);
        aug.view_mut((0, 0), (n, n)).copy_from(&(&self.a * ts_s));
        aug.view_mut((0, n), (n, m)).copy_from(&(&self.b * ts_s));
        let e = aug.exp();
        Self::new(
            e.view((0, 0), (n, n)).into_owned(),
            e.view((0, n), (n, m)).into_owned(),
            self.c.clone(),
            self.d.clone(),
            TimeDomain::Discrete { ts_s },
        )
    }

    /// Continuous-time system whose zero-order-hold discretisation is this one (≙ MATLAB
    /// `d2c(sys, 'zoh')`); see the [module docs](self) for when none exists.
    pub fn d2c(&self) -> Result<Self, IdentError> {
        let TimeDomain::Discrete { ts_s } = self.domain else {
            return Err(IdentError::InvalidOption(
                "d2c needs a discrete-time system".to_owned(),
            ));
        };
        let (n, m) = (self.n_states(), self.b.ncols());
        for p in self.poles()? {
            let tol = 1e-9 * p.norm().max(1.0);
            if p.norm() <= 1e-12 || (p.re <= 0.0 && p.im.abs() <= tol) {
                return Err(IdentError::NoRealLogarithm {
                    re: p.re,
                    im: p.im,
                    hint: if p.norm() <= 1e-12 {
                        "a pole at z = 0 usually comes from nb > nf or from delays; model the delay as nk instead"
                    } else {
                        "a real negative discrete pole (sign-alternating mode) has no ZOH continuous equivalent"
                    },
                });
            }
        }
        let mut aug = DMatrix::identity(n + m, n + m);
        aug.view_mut((0, 0), (n, n)).copy_from(&self.a);
        aug.view_mut((0, n), (n, m)).copy_from(&self.b);
        let l = logm(&aug)? / ts_s;
        Self::new(
            l.view((0, 0), (n, n)).into_owned(),
            l.view((0, n), (n, m)).into_owned(),
            self.c.clone(),
            self.d.clone(),
            TimeDomain::Continuous,
        )
    }

    /// Eigenvalues of `A`.
    pub fn poles(&self) -> Result<Vec<Complex<f64>>, IdentError> {
        let n = self.n_states();
        if n == 0 {
            return Ok(Vec::new());
        }
        let schur = Schur::try_new(self.a.clone(), f64::EPSILON, 10_000)
            .ok_or(IdentError::EigenNoConvergence(n))?;
        Ok(schur.complex_eigenvalues().iter().copied().collect())
    }

    /// First `n` Markov parameters from input `input` of a discrete system:
    /// `h(0) = D`, `h(k) = C Aᵏ⁻¹ B` — one row per output, one column per sample.
    pub fn impulse_response(&self, input: usize, n: usize) -> Result<DMatrix<f64>, IdentError> {
        if self.domain == TimeDomain::Continuous {
            return Err(IdentError::InvalidOption(
                "impulse_response needs a discrete-time system".to_owned(),
            ));
        }
        if input >= self.b.ncols() {
            return Err(IdentError::Dimension(format!(
                "input {input} of a {}-input system",
                self.b.ncols()
            )));
        }
        let p = self.c.nrows();
        let mut h = DMatrix::zeros(p, n);
        let mut x = self.b.column(input).into_owned();
        for k in 0..n {
            if k == 0 {
                h.set_column(0, &self.d.column(input));
            } else {
                h.set_column(k, &(&self.c * &x));
                x = &self.a * x;
            }
        }
        Ok(h)
    }

    /// Discrete-time simulation from zero state; `u` one vector per input, returns one
    /// vector per output.
    pub fn simulate(&self, u: &[Vec<f64>]) -> Result<Vec<Vec<f64>>, IdentError> {
        if self.domain == TimeDomain::Continuous {
            return Err(IdentError::InvalidOption(
                "simulate needs a discrete-time system".to_owned(),
            ));
        }
        let m = self.b.ncols();
        if u.len() != m {
            return Err(IdentError::InputCountMismatch {
                orders: m,
                data: u.len(),
            });
        }
        let len = u.first().map_or(0, Vec::len);
        if let Some(i) = u.iter().position(|ui| ui.len() != len) {
            return Err(IdentError::LengthMismatch {
                input: i,
                input_len: u[i].len(),
                output_len: len,
            });
        }
        let p = self.c.nrows();
        let mut y = vec![vec![0.0; len]; p];
        let mut x = nalgebra::DVector::zeros(self.n_states());
        let mut uk = nalgebra::DVector::zeros(m);
        for k in 0..len {
            for (j, uj) in u.iter().enumerate() {
                uk[j] = uj[k];
            }
            let yk = &self.c * &x + &self.d * &uk;
            for (o, yo) in y.iter_mut().enumerate() {
                yo[k] = yk[o];
            }
            x = &self.a * x + &self.b * &uk;
        }
        Ok(y)
    }
}

/// `(num, den)` as equal-length descending-power vectors with `den[0] = 1`.
fn normalised(num: &[f64], den: &[f64]) -> Result<(Vec<f64>, Vec<f64>), IdentError> {
    let lead = den.first().copied().unwrap_or(0.0);
    if lead == 0.0 || !lead.is_finite() {
        return Err(IdentError::InvalidOrder(
            "the denominator's leading coefficient must be non-zero".to_owned(),
        ));
    }
    if num.len() > den.len() {
        return Err(IdentError::InvalidOrder(format!(
            "improper transfer function: numerator degree {} > denominator degree {}",
            num.len() - 1,
            den.len() - 1
        )));
    }
    let acoef: Vec<f64> = den.iter().map(|v| v / lead).collect();
    let mut bcoef = vec![0.0; den.len() - num.len()];
    bcoef.extend(num.iter().map(|v| v / lead));
    Ok((bcoef, acoef))
}

/// Principal square root by the Denman–Beavers iteration (Higham, *Functions of Matrices*,
/// eq 6.15).
fn sqrtm(a: &DMatrix<f64>) -> Result<DMatrix<f64>, IdentError> {
    let n = a.nrows();
    let mut y = a.clone();
    let mut z = DMatrix::identity(n, n);
    for _ in 0..100 {
        let y_inv = y
            .clone()
            .try_inverse()
            .ok_or(IdentError::Singular("matrix square root"))?;
        let z_inv = z
            .clone()
            .try_inverse()
            .ok_or(IdentError::Singular("matrix square root"))?;
        let y_next = (&y + z_inv) * 0.5;
        z = (&z + y_inv) * 0.5;
        let change = (&y_next - &y).norm();
        y = y_next;
        if change <= 1e-15 * y.norm() {
            return Ok(y);
        }
    }
    Err(IdentError::Singular(
        "matrix square root (Denman–Beavers did not converge)",
    ))
}

/// Principal matrix logarithm by inverse scaling and squaring (see the module docs).
pub(crate) fn logm(m: &DMatrix<f64>) -> Result<DMatrix<f64>, IdentError> {
    let n = m.nrows();
    let id = DMatrix::<f64>::identity(n, n);
    let mut x = m.clone();
    let mut squarings = 0;
    while (&x - &id).norm() > 0.25 {
        if squarings >= 60 {
            return Err(IdentError::Singular("matrix logarithm"));
        }
        x = sqrtm(&x)?;
        squarings += 1;
    }
    let z = (&x - &id)
        * (&x + &id)
            .try_inverse()
            .ok_or(IdentError::Singular("matrix logarithm"))?;
    let z2 = &z * &z;
    let mut term = z.clone();
    let mut sum = z;
    for j in 1..200 {
        term = &term * &z2;
        let add = &term / (2 * j + 1) as f64;
        sum += &add;
        if add.norm() <= 1e-18 * sum.norm().max(f64::MIN_POSITIVE) {
            break;
        }
    }
    Ok(sum * (2.0 * 2f64.powi(squarings)))
}

impl PolyModel {
    /// Discrete-time state space of the input-to-output part `Σᵢ q^{−nkᵢ}Bᵢ/(A Fᵢ) uᵢ`: one
    /// observer-canonical block per input, stacked block-diagonally (the noise model is not
    /// included). Delays are kept as states at `z = 0`, so the impulse response is exactly
    /// that of the transfer functions.
    pub fn to_state_space(&self) -> Result<StateSpace, IdentError> {
        self.validate()?;
        let domain = TimeDomain::Discrete { ts_s: self.ts_s };
        let blocks: Vec<StateSpace> = (0..self.n_inputs())
            .map(|i| {
                let (num, den) = self
                    .transfer_function(i)
                    .ok_or_else(|| IdentError::Dimension(format!("input {i}")))?;
                let (num, den) = equal_length(num, den);
                StateSpace::observer_canonical(&num, &den, domain)
            })
            .collect::<Result<_, _>>()?;
        let n: usize = blocks.iter().map(StateSpace::n_states).sum();
        let m = blocks.len();
        let mut a = DMatrix::zeros(n, n);
        let mut b = DMatrix::zeros(n, m);
        let mut c = DMatrix::zeros(1, n);
        let mut d = DMatrix::zeros(1, m);
        let mut offset = 0;
        for (i, blk) in blocks.iter().enumerate() {
            let k = blk.n_states();
            a.view_mut((offset, offset), (k, k)).copy_from(&blk.a);
            b.view_mut((offset, i), (k, 1)).copy_from(&blk.b);
            c.view_mut((0, offset), (1, k)).copy_from(&blk.c);
            d[(0, i)] = blk.d[(0, 0)];
            offset += k;
        }
        StateSpace::new(a, b, c, d, domain)
    }

    /// Continuous-time zero-order-hold equivalents of each input's transfer function
    /// `q^{−nk}B/(A F)`, as `(A, B, C, D)` plus an input delay (≙ MATLAB `d2c(sys, 'zoh')`
    /// with the delay returned as `InputDelay`). This is how thesis Model 2 extended and
    /// Model 3 embed the identified OE models (eq 4.3, 4.5).
    ///
    /// A ZOH-sampled strictly proper system already has one sample of delay, so with
    /// `nk ≥ 1` the state space describes `q⁻¹B/(AF)` and the remaining `nk − 1` samples
    /// become `input_delay_s = (nk − 1)·T`; with `nk = 0` there is direct feedthrough `D`.
    /// Errors with [`IdentError::NoRealLogarithm`] if `A·F` has a root at zero or on the
    /// negative real axis, or if `nb > nf + na` (which puts poles at `z = 0`).
    pub fn to_continuous_state_space(&self) -> Result<Vec<ContinuousSubsystem>, IdentError> {
        self.validate()?;
        let domain = TimeDomain::Discrete { ts_s: self.ts_s };
        (0..self.n_inputs())
            .map(|i| {
                let nk = self.nk[i];
                let mut num = Vec::with_capacity(self.b[i].len() + 1);
                if nk >= 1 {
                    num.push(0.0);
                }
                num.extend_from_slice(&self.b[i]);
                let den = poly_mul(&self.a, &self.f[i]);
                let (num, den) = equal_length(num, den);
                let discrete = StateSpace::observer_canonical(&num, &den, domain)?;
                Ok(ContinuousSubsystem {
                    input: i,
                    ss: discrete.d2c()?,
                    input_delay_s: nk.saturating_sub(1) as f64 * self.ts_s,
                })
            })
            .collect()
    }
}

/// Pads two `q⁻¹` polynomials with trailing zeros to equal length, which makes them the
/// descending-`z` coefficient vectors of the same rational function.
fn equal_length(mut num: Vec<f64>, mut den: Vec<f64>) -> (Vec<f64>, Vec<f64>) {
    let len = num.len().max(den.len());
    num.resize(len, 0.0);
    den.resize(len, 0.0);
    (num, den)
}
