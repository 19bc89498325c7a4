//! Estimation results: parameters with uncertainty, quality measures, toolbox-style printing.

use std::fmt;

use nalgebra::DMatrix;
use serde::Serialize;

use super::model::{PolyModel, Structure};

/// One estimated coefficient.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Parameter {
    /// `a1`, `b2`, `f1`, …; with several inputs the input is appended: `b1(u2)`.
    pub name: String,
    /// Estimated value.
    pub value: f64,
    /// One standard deviation, `√Pᵢᵢ` (see [`Estimate::covariance`]).
    pub std: f64,
}

/// How the estimate was computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Linear least squares solved by QR (ARX).
    LeastSquaresQr,
    /// Prediction-error minimisation by Levenberg–Marquardt (ARMAX, OE, BJ).
    PredictionErrorLm,
}

/// Why the estimator stopped. Not an error: every variant comes with a usable estimate.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// Closed-form solution (least squares).
    Exact,
    /// Relative change of loss or parameters fell below the tolerance, or the gradient is
    /// orthogonal to the residuals.
    Converged,
    /// The tolerance is below what floating point can resolve here; the point is a minimum
    /// to machine precision.
    NoFurtherImprovement,
    /// The evaluation budget ran out before convergence; consider more iterations.
    IterationLimit,
    /// The model reproduces the data exactly.
    ZeroResiduals,
}

/// A fitted polynomial model with its statistics (≙ an `idpoly` with its `Report`).
///
/// Quality measures follow the MATLAB System Identification Toolbox definitions, with `N` the
/// number of prediction errors in the criterion (for ARX the regression rows, `N − t₀`),
/// `d` the number of free parameters, `ε` the one-step prediction errors:
///
/// * loss `V = (1/N) Σ ε(t)²` (thesis eq 3.29; MATLAB `LossFcn`, equal to `MSE` here),
/// * `FPE = V (1 + d/N) / (1 − d/N)` (Akaike's final prediction error, MATLAB `fpe`),
/// * `AIC = N ln V + 2d + N (ln 2π + 1)` (MATLAB raw AIC, `aic(sys, 'aic')`),
/// * `nAIC = ln V + 2d/N` (MATLAB `aic(sys)` default),
/// * `BIC = N ln V + N (ln 2π + 1) + d ln N` (MATLAB `aic(sys, 'BIC')`),
/// * noise variance `λ̂ = N V / (N − d)` (the bias-corrected estimate: `d` degrees of freedom are spent on `θ`),
/// * parameter covariance `P = λ̂ (Σ ψψᵀ)⁻¹` with `ψ = ∂ŷ/∂θ` the predictor gradient (Ljung
///   1999 §9.3); for ARX `ψ` is the regressor so `P = λ̂ (ΦᵀΦ)⁻¹`,
/// * fit `= 100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖)` % (NRMSE, thesis eq 3.33) of the one-step
///   prediction, MATLAB `Report.Fit.FitPercent`; for OE it is the simulation fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Estimate {
    /// The model.
    pub model: PolyModel,
    /// Free parameters in MATLAB `getpvec` order: `a`, `b` per input, `c`, `d`, `f` per input.
    pub parameters: Vec<Parameter>,
    /// Parameter covariance `P`, row-major `d × d`.
    pub covariance: Vec<Vec<f64>>,
    /// `λ̂`, estimated variance of `e(t)`.
    pub noise_variance: f64,
    /// Loss `V`.
    pub loss: f64,
    /// Akaike's final prediction error.
    pub fpe: f64,
    /// Raw AIC.
    pub aic: f64,
    /// Normalised AIC.
    pub naic: f64,
    /// Bayesian information criterion.
    pub bic: f64,
    /// NRMSE fit of the one-step prediction on the estimation data, in percent.
    pub fit_percent: f64,
    /// NRMSE fit of the pure simulation `Σ Bᵢ/(A Fᵢ) uᵢ` on the estimation data, in percent.
    /// Computed by the prediction-error estimators (for OE it equals `fit_percent`); `None`
    /// for ARX, whose least-squares fit does not need a simulation (compute it with
    /// [`fit_percent`] and [`PolyModel::simulate`] if wanted), or if the simulation diverges.
    pub simulation_fit_percent: Option<f64>,
    /// `N`, number of prediction errors in the criterion.
    pub n_samples: usize,
    /// Estimation method.
    pub method: Method,
    /// Why the estimator stopped.
    pub stop: StopReason,
    /// Number of predictor evaluations (1 for least squares).
    pub evaluations: usize,
}

/// NRMSE fit in percent, thesis eq 3.33: `100 (1 − ‖y − ŷ‖ / ‖y − mean(y)‖)`.
///
/// `100` is a perfect fit, `0` is no better than the mean, negative is worse. Returns `None`
/// if the lengths differ, `y` is constant or the result is not finite.
pub fn fit_percent(y: &[f64], yhat: &[f64]) -> Option<f64> {
    if y.len() != yhat.len() || y.is_empty() {
        return None;
    }
    let m = y.iter().sum::<f64>() / y.len() as f64;
    let err: f64 = y.iter().zip(yhat).map(|(a, b)| (a - b) * (a - b)).sum();
    let var: f64 = y.iter().map(|a| (a - m) * (a - m)).sum();
    let fit = 100.0 * (1.0 - (err / var).sqrt());
    (var > 0.0 && fit.is_finite()).then_some(fit)
}

/// Akaike's final prediction error `V (1 + d/N) / (1 − d/N)`; infinite if `d ≥ N`.
pub fn fpe(loss: f64, n_params: usize, n_samples: usize) -> f64 {
    let r = n_params as f64 / n_samples as f64;
    if r >= 1.0 {
        f64::INFINITY
    } else {
        loss * (1.0 + r) / (1.0 - r)
    }
}

/// Raw AIC `N ln V + 2d + N (ln 2π + 1)` (MATLAB `aic(sys,'aic')`, single output).
pub fn aic(loss: f64, n_params: usize, n_samples: usize) -> f64 {
    let n = n_samples as f64;
    n * loss.ln() + 2.0 * n_params as f64 + n * ((2.0 * std::f64::consts::PI).ln() + 1.0)
}

/// Normalised AIC `ln V + 2d/N` (MATLAB `aic(sys)`).
pub fn naic(loss: f64, n_params: usize, n_samples: usize) -> f64 {
    loss.ln() + 2.0 * n_params as f64 / n_samples as f64
}

/// BIC `N ln V + N (ln 2π + 1) + d ln N` (MATLAB `aic(sys,'BIC')`).
pub fn bic(loss: f64, n_params: usize, n_samples: usize) -> f64 {
    let n = n_samples as f64;
    n * loss.ln() + n * ((2.0 * std::f64::consts::PI).ln() + 1.0) + n_params as f64 * n.ln()
}

/// Everything an estimator hands to [`Estimate::assemble`].
pub(crate) struct RawEstimate {
    pub model: PolyModel,
    pub names: Vec<String>,
    pub theta: Vec<f64>,
    /// `(Σ ψψᵀ)⁻¹`.
    pub inverse_gram: DMatrix<f64>,
    /// `Σ ε²`.
    pub rss: f64,
    pub n_samples: usize,
    pub fit_percent: f64,
    pub simulation_fit_percent: Option<f64>,
    pub method: Method,
    pub stop: StopReason,
    pub evaluations: usize,
}

impl Estimate {
    pub(crate) fn assemble(raw: RawEstimate) -> Self {
        let d = raw.theta.len();
        let n = raw.n_samples;
        let loss = raw.rss / n as f64;
        let noise_variance = if n > d {
            raw.rss / (n - d) as f64
        } else {
            f64::INFINITY
        };
        let cov = raw.inverse_gram * noise_variance;
        let parameters = raw
            .names
            .into_iter()
            .zip(&raw.theta)
            .enumerate()
            .map(|(i, (name, &value))| Parameter {
                name,
                value,
                std: cov[(i, i)].max(0.0).sqrt(),
            })
            .collect();
        let covariance = (0..d)
            .map(|i| (0..d).map(|j| cov[(i, j)]).collect())
            .collect();
        Self {
            model: raw.model,
            parameters,
            covariance,
            noise_variance,
            loss,
            fpe: fpe(loss, d, n),
            aic: aic(loss, d, n),
            naic: naic(loss, d, n),
            bic: bic(loss, d, n),
            fit_percent: raw.fit_percent,
            simulation_fit_percent: raw.simulation_fit_percent,
            n_samples: n,
            method: raw.method,
            stop: raw.stop,
            evaluations: raw.evaluations,
        }
    }

    /// The parameter called `name` (e.g. `"f1"`, `"b2(u1)"`).
    pub fn parameter(&self, name: &str) -> Option<&Parameter> {
        self.parameters.iter().find(|p| p.name == name)
    }

    /// Parameter values in [`Estimate::parameters`] order (≙ MATLAB `getpvec`).
    pub fn values(&self) -> Vec<f64> {
        self.parameters.iter().map(|p| p.value).collect()
    }

    /// Standard deviations in [`Estimate::parameters`] order.
    pub fn std_devs(&self) -> Vec<f64> {
        self.parameters.iter().map(|p| p.std).collect()
    }
}

/// Parameter names in `getpvec` order for the given orders.
pub(crate) fn parameter_names(
    na: usize,
    nb: &[usize],
    nc: usize,
    nd: usize,
    nf: &[usize],
) -> Vec<String> {
    let multi = nb.len() > 1;
    let tag = |i: usize| {
        if multi {
            format!("(u{})", i + 1)
        } else {
            String::new()
        }
    };
    let mut names: Vec<String> = (1..=na).map(|k| format!("a{k}")).collect();
    for (i, &n) in nb.iter().enumerate() {
        names.extend((1..=n).map(|k| format!("b{k}{}", tag(i))));
    }
    names.extend((1..=nc).map(|k| format!("c{k}")));
    names.extend((1..=nd).map(|k| format!("d{k}")));
    for (i, &n) in nf.iter().enumerate() {
        names.extend((1..=n).map(|k| format!("f{k}{}", tag(i))));
    }
    names
}

/// `x` with `sig` significant digits, like C's `%g` (MATLAB prints coefficients as `%.4g`).
pub(crate) fn fmt_g(x: f64, sig: usize) -> String {
    if x == 0.0 {
        return "0".to_owned();
    }
    if !x.is_finite() {
        return format!("{x}");
    }
    let exp = x.abs().log10().floor() as i32;
    if exp < -4 || exp >= sig as i32 {
        let s = format!("{:.*e}", sig.saturating_sub(1), x);
        // Rust prints `1.5e-5`; keep the mantissa trimmed and a two-digit signed exponent.
        let (mant, e) = s.split_once('e').unwrap_or((&s, "0"));
        let mant = trim_zeros(mant);
        let e: i32 = e.parse().unwrap_or(0);
        format!("{mant}e{}{:02}", if e < 0 { '-' } else { '+' }, e.abs())
    } else {
        let decimals = (sig as i32 - 1 - exp).max(0) as usize;
        trim_zeros(&format!("{x:.decimals$}")).to_owned()
    }
}

fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

/// Writes `name(z) = c₀ z^-p₀ + …` with `(±σ)` after every free coefficient.
fn write_poly(
    f: &mut fmt::Formatter<'_>,
    name: &str,
    terms: &[(f64, Option<f64>, usize)],
) -> fmt::Result {
    write!(f, "  {name}(z) = ")?;
    for (k, &(value, std, power)) in terms.iter().enumerate() {
        let mag = fmt_g(value.abs(), 4);
        match (k, value < 0.0) {
            (0, true) => write!(f, "-{mag}")?,
            (0, false) => write!(f, "{mag}")?,
            (_, true) => write!(f, " - {mag}")?,
            (_, false) => write!(f, " + {mag}")?,
        }
        if let Some(s) = std {
            write!(f, " (±{})", fmt_g(s, 4))?;
        }
        if power > 0 {
            write!(f, " z^-{power}")?;
        }
    }
    writeln!(f)
}

/// A monic polynomial: the leading 1 has no uncertainty, the rest take the next deviations.
fn write_monic(
    f: &mut fmt::Formatter<'_>,
    name: &str,
    p: &[f64],
    stds: &mut impl Iterator<Item = f64>,
) -> fmt::Result {
    let mut terms = vec![(1.0, None, 0)];
    terms.extend(
        p.iter()
            .enumerate()
            .skip(1)
            .map(|(k, &v)| (v, stds.next(), k)),
    );
    write_poly(f, name, &terms)
}

fn orders_text(v: &[usize]) -> String {
    if v.len() == 1 {
        v[0].to_string()
    } else {
        let parts: Vec<String> = v.iter().map(ToString::to_string).collect();
        format!("[{}]", parts.join(" "))
    }
}

impl fmt::Display for Estimate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = &self.model;
        let multi = m.n_inputs() > 1;
        let bu = if multi {
            "Σᵢ Bᵢ(z)uᵢ(t)"
        } else {
            "B(z)u(t)"
        };
        let bfu = if multi {
            "Σᵢ [Bᵢ(z)/Fᵢ(z)]uᵢ(t)"
        } else {
            "[B(z)/F(z)]u(t)"
        };
        let equation = match m.structure {
            Structure::Arx => format!("A(z)y(t) = {bu} + e(t)"),
            Structure::Armax => format!("A(z)y(t) = {bu} + C(z)e(t)"),
            Structure::Oe => format!("y(t) = {bfu} + e(t)"),
            Structure::Bj => format!("y(t) = {bfu} + [C(z)/D(z)]e(t)"),
        };
        writeln!(f, "Discrete-time {} model: {equation}", m.structure.label())?;
        // Display order A, B, C, D, F is the parameter order, so one pass over the standard
        // deviations pairs each coefficient with its own.
        let mut stds = self.parameters.iter().map(|p| p.std);
        let input_name = |base: &str, i: usize| {
            if multi {
                format!("{base}{}", i + 1)
            } else {
                base.to_owned()
            }
        };
        let uses_a = matches!(m.structure, Structure::Arx | Structure::Armax);
        let uses_f = matches!(m.structure, Structure::Oe | Structure::Bj);
        let uses_c = matches!(m.structure, Structure::Armax | Structure::Bj);
        let uses_d = matches!(m.structure, Structure::Bj);
        if uses_a {
            write_monic(f, "A", &m.a, &mut stds)?;
        }
        for (i, b) in m.b.iter().enumerate() {
            let terms: Vec<_> = b
                .iter()
                .enumerate()
                .map(|(k, &v)| (v, stds.next(), m.nk[i] + k))
                .collect();
            write_poly(f, &input_name("B", i), &terms)?;
        }
        if uses_c {
            write_monic(f, "C", &m.c, &mut stds)?;
        }
        if uses_d {
            write_monic(f, "D", &m.d, &mut stds)?;
        }
        if uses_f {
            for (i, fp) in m.f.iter().enumerate() {
                write_monic(f, &input_name("F", i), fp, &mut stds)?;
            }
        }
        let na = m.a.len() - 1;
        writeln!(f)?;
        writeln!(f, "Sample time: {} seconds", fmt_g(m.ts_s, 6))?;
        writeln!(f)?;
        writeln!(f, "Parameterization:")?;
        let nb: Vec<usize> = m.b.iter().map(Vec::len).collect();
        let nf: Vec<usize> = m.f.iter().map(|p| p.len() - 1).collect();
        let mut orders = Vec::new();
        if uses_a {
            orders.push(format!("na={}", na));
        }
        orders.push(format!("nb={}", orders_text(&nb)));
        if uses_c {
            orders.push(format!("nc={}", m.c.len() - 1));
        }
        if uses_d {
            orders.push(format!("nd={}", m.d.len() - 1));
        }
        if uses_f {
            orders.push(format!("nf={}", orders_text(&nf)));
        }
        orders.push(format!("nk={}", orders_text(&m.nk)));
        writeln!(f, "   Polynomial orders:   {}", orders.join("   "))?;
        writeln!(
            f,
            "   Number of free coefficients: {}",
            self.parameters.len()
        )?;
        writeln!(f)?;
        writeln!(f, "Status:")?;
        let how = match self.method {
            Method::LeastSquaresQr => "least squares (QR)".to_owned(),
            Method::PredictionErrorLm => format!(
                "prediction-error minimisation (Levenberg–Marquardt, stability enforced), {} evaluations",
                self.evaluations
            ),
        };
        let stop = match self.stop {
            StopReason::Exact => "exact solution",
            StopReason::Converged => "converged",
            StopReason::NoFurtherImprovement => "converged to machine precision",
            StopReason::IterationLimit => "stopped at the iteration limit",
            StopReason::ZeroResiduals => "zero residuals",
        };
        writeln!(
            f,
            "Estimated using {how} on {} samples: {stop}.",
            self.n_samples
        )?;
        write!(f, "Fit to estimation data: {:.2}%", self.fit_percent)?;
        match (m.structure, self.simulation_fit_percent) {
            (Structure::Oe, _) => writeln!(f)?,
            (_, Some(s)) => writeln!(f, " (prediction focus); simulation: {s:.2}%")?,
            (_, None) => writeln!(f, " (prediction focus)")?,
        }
        writeln!(
            f,
            "FPE: {}, MSE: {}, noise variance: {}",
            fmt_g(self.fpe, 4),
            fmt_g(self.loss, 4),
            fmt_g(self.noise_variance, 4)
        )?;
        writeln!(
            f,
            "AIC: {}, nAIC: {}, BIC: {}",
            fmt_g(self.aic, 6),
            fmt_g(self.naic, 4),
            fmt_g(self.bic, 6)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fmt_g_matches_printf() {
        assert_eq!(fmt_g(-8.672e-8, 4), "-8.672e-08");
        assert_eq!(fmt_g(0.8404, 4), "0.8404");
        assert_eq!(fmt_g(1.84, 4), "1.84");
        assert_eq!(fmt_g(12345.0, 4), "1.234e+04");
        assert_eq!(fmt_g(0.08, 6), "0.08");
    }
}
