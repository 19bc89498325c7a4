//! Linear least squares on lagged-signal regressors, by QR.
//!
//! Solves `min_θ ‖Y − Φθ‖²` where each column of `Φ` is a (signed, delayed) copy of a signal,
//! rows `t = t₀ … N−1`. The normal equations `ΦᵀΦ θ = ΦᵀY` square the condition number and are
//! never formed. Instead the triangular factor of the augmented matrix `[Φ | Y]` is built by
//! *tall-skinny QR*: the rows are processed in cache-sized blocks, each block stacked under the
//! current `R` and re-factorised with nalgebra's Householder QR (Demmel et al., "Communication-
//! optimal parallel and sequential QR", 2012). This is as stable as one Householder QR of the
//! full matrix but never materialises the `N × (d+1)` matrix (64 MB for ARX(4,4) on 10⁶
//! samples), which is what makes the million-sample ARX fast.
//!
//! With `R = [[R₁₁, r₁₂], [0, ρ]]` the estimate is `θ = R₁₁⁻¹ r₁₂`, the residual sum of squares
//! is `ρ²`, and `(ΦᵀΦ)⁻¹ = R₁₁⁻¹R₁₁⁻ᵀ` gives the parameter covariance.

use nalgebra::{DMatrix, DVector, QR};

use super::error::IdentError;

/// Rows per block: 1024 rows × 9 columns (74 kB) stays in L2 cache, and stays below glibc's
/// mmap threshold so the per-block buffer is recycled from the heap instead of page-faulted.
const BLOCK_ROWS: usize = 1024;

/// A regressor column: `sign · signal(t − lag)`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LagColumn<'a> {
    pub signal: &'a [f64],
    pub lag: usize,
    pub negate: bool,
}

/// Result of a least-squares fit.
#[derive(Debug, Clone)]
pub(crate) struct LsFit {
    pub theta: DVector<f64>,
    /// Upper-triangular `R₁₁` (d × d) with `ΦᵀΦ = R₁₁ᵀR₁₁`.
    pub r11: DMatrix<f64>,
    /// Residual sum of squares `‖Y − Φθ‖²`.
    pub rss: f64,
    /// Number of regression rows.
    pub rows: usize,
}

impl LsFit {
    /// `(ΦᵀΦ)⁻¹ = R₁₁⁻¹R₁₁⁻ᵀ`, computed from the triangular factor.
    pub fn inverse_gram(&self) -> Result<DMatrix<f64>, IdentError> {
        let d = self.r11.nrows();
        let r_inv = self
            .r11
            .solve_upper_triangular(&DMatrix::identity(d, d))
            .ok_or(IdentError::Singular("least-squares covariance"))?;
        Ok(&r_inv * r_inv.transpose())
    }
}

/// Least squares `target(t) ≈ Σⱼ θⱼ·column_j(t)` over rows `t ∈ [t0, N)`.
///
/// `names` label the columns in a rank-deficiency error. Every column must satisfy
/// `lag ≤ t0` and have the target's length.
pub(crate) fn lagged_least_squares(
    columns: &[LagColumn<'_>],
    target: &[f64],
    t0: usize,
    names: &dyn Fn(usize) -> String,
) -> Result<LsFit, IdentError> {
    lagged_least_squares_parts(
        &[RegressionPart {
            columns: columns.to_vec(),
            target,
            t0,
        }],
        names,
    )
}

/// The rows of one experiment in a regression over several ([`lagged_least_squares_parts`]).
#[derive(Debug, Clone)]
pub(crate) struct RegressionPart<'a> {
    pub columns: Vec<LagColumn<'a>>,
    pub target: &'a [f64],
    pub t0: usize,
}

/// [`lagged_least_squares`] over the rows of several experiments at once, each with its own
/// signals and first row: one `θ` for them all, no row reaching across from one experiment
/// into another (≙ MATLAB `arx(merge(z1, z2), …)`). Every part has the same number of
/// columns, in the same meaning.
pub(crate) fn lagged_least_squares_parts(
    parts: &[RegressionPart<'_>],
    names: &dyn Fn(usize) -> String,
) -> Result<LsFit, IdentError> {
    let d = parts.first().map_or(0, |p| p.columns.len());
    let rows: usize = parts
        .iter()
        .map(|p| p.target.len().saturating_sub(p.t0))
        .sum();
    if rows < d + 1 {
        return Err(IdentError::TooFewSamples {
            available: rows,
            parameters: d,
            required: d + 1,
        });
    }
    debug_assert!(parts.iter().all(|p| {
        p.columns.len() == d
            && p.columns
                .iter()
                .all(|c| c.lag <= p.t0 && c.signal.len() == p.target.len())
    }));
    let p = d + 1;
    let mut r = DMatrix::<f64>::zeros(0, p);
    let mut buf: Vec<f64> = Vec::with_capacity((BLOCK_ROWS + p) * p);
    for part in parts {
        let (columns, target, n) = (&part.columns, part.target, part.target.len());
        let mut block_start = part.t0;
        while block_start < n {
            let block_end = (block_start + BLOCK_ROWS).min(n);
            let r_rows = r.nrows();
            let m = r_rows + (block_end - block_start);
            buf.clear();
            for (j, column) in columns.iter().map(Some).chain([None]).enumerate() {
                buf.extend(r.column(j).iter().copied());
                match column {
                    Some(c) => {
                        let src = &c.signal[block_start - c.lag..block_end - c.lag];
                        if c.negate {
                            buf.extend(src.iter().map(|v| -v));
                        } else {
                            buf.extend_from_slice(src);
                        }
                    }
                    // The last column of [Φ | Y] is the target.
                    None => buf.extend_from_slice(&target[block_start..block_end]),
                }
            }
            let stacked = DMatrix::from_vec(m, p, std::mem::take(&mut buf));
            r = QR::new(stacked).r();
            buf = Vec::with_capacity((BLOCK_ROWS + p) * p);
            block_start = block_end;
        }
    }
    // Rank: |R_jj| / ‖φ_j‖ is the sine of the angle between column j and the span of the
    // columns before it. Q is orthogonal, so ‖φ_j‖ = ‖R e_j‖ and needs no extra pass.
    for j in 0..d {
        let norm = r.view((0, j), (j + 1, 1)).norm();
        if norm == 0.0 || r[(j, j)].abs() <= 1e-10 * norm {
            return Err(IdentError::RankDeficient {
                column: j,
                name: names(j),
            });
        }
    }
    let r11 = r.view((0, 0), (d, d)).into_owned();
    let r12 = r.view((0, d), (d, 1)).into_owned();
    let theta = r11
        .solve_upper_triangular(&r12)
        .ok_or(IdentError::Singular("least squares"))?;
    let rho = if r.nrows() > d { r[(d, d)] } else { 0.0 };
    Ok(LsFit {
        theta: theta.column(0).into_owned(),
        r11,
        rss: rho * rho,
        rows,
    })
}
