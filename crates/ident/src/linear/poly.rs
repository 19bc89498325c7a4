//! Polynomials in the backward shift operator `q⁻¹` and the filters built from them.
//!
//! A polynomial `A(q) = a₀ + a₁q⁻¹ + … + aₙq⁻ⁿ` is stored as `[a₀, a₁, …, aₙ]`. Its roots are
//! the roots of `a₀zⁿ + a₁zⁿ⁻¹ + … + aₙ`, i.e. the poles (or zeros) it contributes in the
//! `z` plane; "stable" means every root strictly inside the unit circle.

use nalgebra::{Complex, DMatrix, Schur};

use super::error::IdentError;

/// Roots pulled onto or inside this radius when [`reflect_into_unit_circle`] stabilises a
/// polynomial, so a root that sat exactly on the unit circle ends up strictly inside it.
pub const MAX_ROOT_RADIUS: f64 = 1.0 - 1e-8;

/// `out(t) = Σₖ num[k]·x(t−delay−k) − Σₖ₌₁ den[k]·out(t−k)`, zero initial conditions.
///
/// This is `out = q^{-delay}·num(q)/den(q) · x` with `den[0] = 1` (monic, as every
/// denominator in the model structures is). It is the inner loop of the prediction-error
/// method; it does not allocate.
pub(crate) fn filter_delayed(num: &[f64], delay: usize, den: &[f64], x: &[f64], out: &mut [f64]) {
    debug_assert_eq!(x.len(), out.len());
    debug_assert!(den.first().is_none_or(|&d| d == 1.0));
    let n = x.len();
    let den_tail = den.get(1..).unwrap_or(&[]);
    let start = (delay + num.len()).max(den_tail.len() + 1).min(n);
    // Start-up: some taps reach before t = 0, where the signals are zero.
    for t in 0..start {
        let mut acc = 0.0;
        for (k, &b) in num.iter().enumerate() {
            if let Some(idx) = t.checked_sub(delay + k) {
                acc += b * x[idx];
            }
        }
        for (k, &a) in den_tail.iter().enumerate() {
            if let Some(idx) = t.checked_sub(k + 1) {
                acc -= a * out[idx];
            }
        }
        out[t] = acc;
    }
    // Steady state: every tap is in range, no bounds logic in the loop.
    for t in start..n {
        let mut acc = 0.0;
        let xs = &x[t + 1 - delay - num.len()..=t - delay];
        for (b, xv) in num.iter().zip(xs.iter().rev()) {
            acc += b * xv;
        }
        // Oldest output first, `out(t−1)` last: the loop-carried dependency through the
        // previous output is then a single multiply-add per sample instead of `nf` of them.
        let ys = &out[t - den_tail.len()..t];
        for (a, yv) in den_tail.iter().rev().zip(ys.iter()) {
            acc -= a * yv;
        }
        out[t] = acc;
    }
}

/// `num(q)/den(q) · x` with zero initial conditions, into a new vector.
pub(crate) fn filter(num: &[f64], den: &[f64], x: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; x.len()];
    filter_delayed(num, 0, den, x, &mut out);
    out
}

/// Product of two polynomials (convolution of the coefficient vectors).
pub fn poly_mul(a: &[f64], b: &[f64]) -> Vec<f64> {
    if a.is_empty() || b.is_empty() {
        return Vec::new();
    }
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, &ai) in a.iter().enumerate() {
        for (j, &bj) in b.iter().enumerate() {
            out[i + j] += ai * bj;
        }
    }
    out
}

/// `true` if every root of the polynomial lies strictly inside the unit circle.
///
/// Schur–Cohn (Jury) step-down recursion: with `k = aₙ/a₀` the polynomial is stable iff
/// `|k| < 1` and the degree-`n−1` polynomial `(aᵢ − k·aₙ₋ᵢ)/(1 − k²)` is stable (Åström &
/// Wittenmark, *Computer-Controlled Systems*, §3.3). Exact, cheap and free of eigenvalue
/// iterations, so it can run on every trial step of the optimiser.
pub fn is_stable(poly: &[f64]) -> bool {
    let Some(&lead) = poly.first() else {
        return true;
    };
    if lead == 0.0 || !poly.iter().all(|c| c.is_finite()) {
        return false;
    }
    let mut p: Vec<f64> = poly.iter().map(|c| c / lead).collect();
    while p.len() > 1 {
        let n = p.len() - 1;
        let k = p[n];
        if k.abs() >= 1.0 {
            return false;
        }
        let scale = 1.0 - k * k;
        let next: Vec<f64> = (0..n).map(|i| (p[i] - k * p[n - i]) / scale).collect();
        p = next;
    }
    true
}

/// Roots of the polynomial in the `z` plane (eigenvalues of its companion matrix).
pub fn roots(poly: &[f64]) -> Result<Vec<Complex<f64>>, IdentError> {
    let lead = poly.first().copied().unwrap_or(0.0);
    if lead == 0.0 {
        return Err(IdentError::InvalidOption(
            "polynomial with zero leading coefficient".to_owned(),
        ));
    }
    let n = poly.len() - 1;
    if n == 0 {
        return Ok(Vec::new());
    }
    let mut companion = DMatrix::<f64>::zeros(n, n);
    for j in 0..n {
        companion[(0, j)] = -poly[j + 1] / lead;
    }
    for i in 1..n {
        companion[(i, i - 1)] = 1.0;
    }
    let schur =
        Schur::try_new(companion, f64::EPSILON, 10_000).ok_or(IdentError::EigenNoConvergence(n))?;
    Ok(schur.complex_eigenvalues().iter().copied().collect())
}

/// Monic real polynomial with the given roots (complex roots must come in conjugate pairs).
pub fn poly_from_roots(roots: &[Complex<f64>]) -> Vec<f64> {
    let mut c = vec![Complex::new(1.0, 0.0)];
    for &r in roots {
        let mut next = vec![Complex::new(0.0, 0.0); c.len() + 1];
        for (k, &ck) in c.iter().enumerate() {
            next[k] += ck;
            next[k + 1] -= r * ck;
        }
        c = next;
    }
    c.into_iter().map(|v| v.re).collect()
}

/// The polynomial with every root `r` outside the unit circle replaced by its mirror image
/// `1/r̄`, and roots on the circle pulled to radius [`MAX_ROOT_RADIUS`].
///
/// This is what MATLAB's System Identification Toolbox does (`fstab`) to make initial
/// estimates and predictors stable: the reflected polynomial has the same spectral shape on
/// the unit circle up to a constant gain. A stable polynomial is returned unchanged.
pub fn reflect_into_unit_circle(poly: &[f64]) -> Result<Vec<f64>, IdentError> {
    if is_stable(poly) {
        return Ok(poly.to_vec());
    }
    let lead = poly[0];
    let reflected: Vec<Complex<f64>> = roots(poly)?
        .into_iter()
        .map(|r| {
            let r = if r.norm() > 1.0 { r.conj().inv() } else { r };
            if r.norm() > MAX_ROOT_RADIUS {
                r * (MAX_ROOT_RADIUS / r.norm())
            } else {
                r
            }
        })
        .collect();
    Ok(poly_from_roots(&reflected)
        .into_iter()
        .map(|c| c * lead)
        .collect())
}

/// First `n` impulse-response coefficients of `num(q)/den(q)` (den monic).
pub(crate) fn impulse(num: &[f64], den: &[f64], n: usize) -> Vec<f64> {
    let mut pulse = vec![0.0; n];
    if let Some(p) = pulse.first_mut() {
        *p = 1.0;
    }
    filter(num, den, &pulse)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filter_matches_difference_equation() {
        // y(t) = 0.5 y(t-1) + 2 u(t-1)
        let u = [1.0, 0.0, 0.0, 1.0];
        let mut y = [0.0; 4];
        filter_delayed(&[2.0], 1, &[1.0, -0.5], &u, &mut y);
        assert_eq!(y, [0.0, 2.0, 1.0, 0.5]);
    }

    #[test]
    fn stability_tests_agree_with_roots() {
        assert!(is_stable(&[1.0, -1.5, 0.7]));
        assert!(!is_stable(&[1.0, -2.5, 1.0]));
        assert!(!is_stable(&[1.0, -1.0]));
        let r = reflect_into_unit_circle(&[1.0, -2.5, 1.0]).expect("roots");
        assert!(is_stable(&r));
        // roots 2 and 0.5 -> 0.5 and 0.5
        assert!((r[1] + 1.0).abs() < 1e-9 && (r[2] - 0.25).abs() < 1e-9);
    }
}
