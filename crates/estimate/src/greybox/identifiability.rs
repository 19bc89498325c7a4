//! Identifiability from the Jacobian of the normalised residuals (local, linearised).
//!
//! With `J = ∂r/∂z` (scaled coordinates, see `evaluate`) over the data rows and noise
//! variances `λ_b` per (run, output) block, the estimator's covariance is the sandwich
//!
//! ```text
//! C_z = (JᵀJ)⁻¹ (Σ_b λ_b J_bᵀ J_b) (JᵀJ)⁻¹
//! ```
//!
//! which is `σ² (JᵀJ)⁻¹` when every block has the same noise level `σ²` in normalised units,
//! and stays right when height and pressure noise differ (the loss weights them by their
//! spread, not by their noise). `C_z` is in units of each parameter's scale, so
//! `√C_z,ii` is a *relative* standard deviation.
//!
//! That covariance takes each sample's residual as independent of the next. What a model
//! short of the truck leaves is mostly slow misfit, correlated over tens of seconds, and the
//! estimate also reports standard deviations with the middle matrix estimated from the
//! residuals' own correlation in time ([`correlated_covariance`],
//! `EstimatedParameter::std_correlated`): on the built-in study 1-46 times the white ones.
//! The screen below uses the white covariance, as it did before the correlated one was
//! measured: freezing on the correlated one would fix more parameters of every model that
//! misses the truck.
//!
//! A freed parameter is reported as not identifiable from the given runs when
//! 1. **no sensitivity**: its Jacobian column is zero (the outputs do not depend on it at
//!    all in these runs — `rflow1` in a run where the valve never fills), or **the
//!    simulation fails** when it moves either way (its column could not be measured; said
//!    apart, since it is a different problem with a different cure);
//! 2. **structural collinearity**: the column-normalised Jacobian `J D⁻¹` (`D` = column
//!    norms) has a singular value below `rcond · s_max`; only a combination of the
//!    parameters in the corresponding right singular vector is determined. The parameters
//!    that carry that direction (component ≥ half the largest, in scaled units) form the
//!    group;
//! 3. **statistically undetermined**: the largest relative standard deviation exceeds
//!    `max_relative_std`. If that parameter is correlated above `correlation_warning` with
//!    others whose uncertainty is also large (≥ half of it), they form a group and only a
//!    combination is determined (reported as collinear: `a0` and `a1` on a closed-valve
//!    run, where only `a1/a0` shows, SPEC §4 — finite-difference and solver noise keep the
//!    exact null direction from being exactly singular); otherwise it is undetermined alone.
//!
//! From a group, the parameter listed *first in the model's parameter order* (`p0..p4, a0,
//! a1, m2, ig, kf, kw, kscl, rflow1, rflow2, …`) is fixed — deterministic, and it fixes the
//! gas volume's scale `a0` rather than its shape `a1` or the flow resistances. One parameter
//! is fixed at a time and the analysis repeated, since fixing one member of a group usually
//! determines the others.
//!
//! Correlations above `correlation_warning` are reported, not acted on alone: two parameters
//! can be 0.995-correlated and both well determined from 30 000 samples.

use std::ops::Range;

use nalgebra::DMatrix;
use serde::Serialize;

/// Why a freed parameter cannot be determined by the runs.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Unidentifiable {
    /// The outputs do not depend on it in these runs (zero Jacobian column).
    NoSensitivity,
    /// The model does not simulate when it moves from the point reached (both finite-
    /// difference steps failed): its effect could not be measured there.
    SimulationFails,
    /// Only a combination with these parameters is determined: a (numerical) null direction
    /// of the Jacobian, or correlations near ±1 with an uncertainty above the limit.
    Collinear { with: Vec<String> },
    /// Its standard deviation is larger than the limit (a fraction of its scale).
    Undetermined { relative_std: f64, limit: f64 },
}

/// When a parameter was found not identifiable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    /// From the Jacobian at the nominal point, with the data's own noise level.
    BeforeFit,
    /// From the Jacobian at the estimate, with the residuals' noise level.
    AfterFit,
}

/// A freed parameter the runs cannot determine, and what was done.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NotIdentifiable {
    pub name: String,
    pub reason: Unidentifiable,
    pub stage: Stage,
    /// Parameters it is strongly correlated with at that stage (name, correlation).
    pub correlated_with: Vec<(String, f64)>,
    /// What data would determine it (from the parameter's declaration; empty if not said).
    pub determined_by: String,
}

/// A strongly correlated pair of estimated parameters.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CorrelatedPair {
    pub a: String,
    pub b: String,
    pub correlation: f64,
}

/// The Jacobian seen as an identifiability question.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct JacobianAnalysis {
    /// The parameters (columns) analysed.
    pub parameters: Vec<String>,
    /// `‖∂r/∂z_i‖`: change of the normalised residual vector per unit of scaled parameter.
    pub sensitivities: Vec<f64>,
    /// Singular values of the column-normalised Jacobian, descending.
    pub singular_values: Vec<f64>,
    /// `s_max / s_min` of the column-normalised Jacobian (∞ if rank-deficient).
    pub condition_number: f64,
    /// `√C_z,ii`: standard deviation relative to each parameter's scale (∞ where undetermined).
    pub relative_std: Vec<f64>,
    /// Pairs with |correlation| above the warning level.
    pub high_correlations: Vec<CorrelatedPair>,
}

/// Covariance and SVD facts of a Jacobian, in scaled coordinates.
pub(crate) struct Linearised {
    pub norms: Vec<f64>,
    pub singular_values: Vec<f64>,
    /// Right singular vectors (columns), in column-normalised coordinates.
    pub v: DMatrix<f64>,
    /// `(JnᵀJn)⁻¹ = V S⁻² Vᵀ` (column-normalised) if `Jn` has full numerical rank: the
    /// sandwich's bread, for [`correlated_covariance`] too.
    pub gram_inverse: Option<DMatrix<f64>>,
    /// `C_z` if the normalised Jacobian has full numerical rank.
    pub covariance: Option<DMatrix<f64>>,
}

/// [`analyse`]'s linearisation of the columns it could analyse, kept for the caller.
pub(crate) struct LiveColumns {
    /// Their indices among the Jacobian's columns.
    pub columns: Vec<usize>,
    /// Those columns.
    pub j: DMatrix<f64>,
    pub lin: Linearised,
}

/// SVD of `J D⁻¹` and the sandwich covariance (module docs). Zero columns must be removed
/// before (they have no normalisation).
pub(crate) fn linearise(
    j: &DMatrix<f64>,
    blocks: &[Range<usize>],
    lambda: &[f64],
    rcond: f64,
) -> Linearised {
    let n = j.ncols();
    if n == 0 || j.nrows() == 0 {
        return Linearised {
            norms: Vec::new(),
            singular_values: Vec::new(),
            v: DMatrix::zeros(0, 0),
            gram_inverse: None,
            covariance: None,
        };
    }
    let norms: Vec<f64> = (0..n).map(|c| j.column(c).norm()).collect();
    let mut jn = j.clone();
    for (c, &d) in norms.iter().enumerate() {
        if d > 0.0 {
            jn.column_mut(c).scale_mut(1.0 / d);
        }
    }
    // SVD of the small n×n Gram matrix would square the condition number; the m×n SVD keeps it.
    let svd = jn.clone().svd(false, true);
    let s: Vec<f64> = svd.singular_values.iter().copied().collect();
    let v = svd
        .v_t
        .map(|vt| vt.transpose())
        .unwrap_or_else(|| DMatrix::identity(n, n));
    let s_max = s.first().copied().unwrap_or(0.0);
    // Fewer rows than columns: fewer singular values than parameters, never full rank.
    let full_rank = n > 0 && s.len() == n && s.iter().all(|&x| x > rcond * s_max && x > 0.0);
    // (JnᵀJn)⁻¹ = V S⁻² Vᵀ
    let gram_inverse = full_rank.then(|| {
        let s_inv2 = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
            n,
            s.iter().map(|x| 1.0 / (x * x)),
        ));
        &v * s_inv2 * v.transpose()
    });
    let covariance = gram_inverse.as_ref().map(|a_inv| {
        let mut b = DMatrix::zeros(n, n);
        for (range, &l) in blocks.iter().zip(lambda) {
            let jb = jn.rows(range.start, range.len());
            b += l * jb.transpose() * jb;
        }
        let cw = a_inv * b * a_inv;
        // back to z: C_z = D⁻¹ C_w D⁻¹
        DMatrix::from_fn(n, n, |r, c| cw[(r, c)] / (norms[r] * norms[c]))
    });
    Linearised {
        norms,
        singular_values: s,
        v,
        gram_inverse,
        covariance,
    }
}

/// [`correlated_covariance`]'s batch length is at most a run's samples over this.
const RUN_SAMPLES_PER_LONGEST_BATCH: usize = 4;

/// The estimator's covariance (scaled coordinates) allowing for residuals correlated in time,
/// and the batches it used.
pub(crate) struct CorrelatedCovariance {
    /// `C_z` over the columns of the Jacobian it was given.
    pub covariance: DMatrix<f64>,
    /// Per run, in the runs' order: the samples summed per batch, and whether that is the
    /// longest allowed (the run is then short against its residuals' correlation, and the
    /// standard deviations the more biased low).
    pub batch_samples: Vec<(usize, bool)>,
}

/// [`linearise`]'s sandwich with the middle matrix estimated from the residuals themselves
/// instead of a white-noise level per block:
///
/// ```text
/// C_z = (JᵀJ)⁻¹ Ω (JᵀJ)⁻¹,   Ω = Σ_runs (1/b) Σ_j S_j S_jᵀ = Σ_runs Σ_k,m (1 − |k−m|/b)₊ g_k g_mᵀ,
/// S_j = Σ_{k=j}^{j+b−1} g_k (samples outside the run count as zero),
/// g_k = J_h,kᵀ r_h,k + J_p,kᵀ r_p,k
/// ```
///
/// the Newey–West (Bartlett kernel) estimator of each run's score series `g` (height and
/// pressure of a sample together; runs independent of each other), summed as batches of `b`
/// samples sliding over the run and past its ends. With white residuals only `k = m`
/// remains in expectation, `Σ_k g_k g_kᵀ`: [`linearise`]'s with each sample's own residuals
/// as its noise level. Why: what a model short of the truck leaves of a run is mostly not the
/// sensors' noise but slow misfit (creep, heat, a law's shape), correlated over tens to
/// hundreds of seconds; the white covariance takes each sample as independent, and on the
/// built-in study this one came out 1-46 times as large (about 1 for the `truck` structure
/// at its noise floor, the most for the models furthest from the truck).
///
/// The batch length `b` is Andrews' (1991) AR(1) plug-in bandwidth for the Bartlett kernel
/// (`1.1447 (α̂ n)^{1/3}`, `α̂` from an AR(1) fit of each score component, centred per run),
/// at least 1 and at most a run's samples over [`RUN_SAMPLES_PER_LONGEST_BATCH`] (that cap at
/// least 1).
/// Assumptions: the residuals are stationary within a run and their correlation dies out
/// within a batch. The kernel's weights fall off inside a batch, and the fit has taken the
/// scores' sum to zero, so the estimate is biased low, by roughly `b/n` (up to a quarter at
/// the longest batch), and coarse where a run holds few correlation times. Rows after the
/// runs' (the force-map prior) are independent points, counted as in [`linearise`]. `None`
/// where `lin` is rank-deficient (no covariance) or the rows do not match the runs.
pub(crate) fn correlated_covariance(
    j: &DMatrix<f64>,
    lin: &Linearised,
    residuals: &[f64],
    blocks: &[Range<usize>],
    lambda: &[f64],
    runs: usize,
) -> Option<CorrelatedCovariance> {
    let n = j.ncols();
    let a_inv = lin.gram_inverse.as_ref()?;
    if n == 0
        || lin.norms.len() != n
        || residuals.len() != j.nrows()
        || blocks.len() < 2 * runs
        || lambda.len() != blocks.len()
        || blocks.iter().any(|b| b.end > j.nrows())
    {
        return None;
    }
    let norms = &lin.norms;
    debug_assert!(
        (0..n).all(|c| (j.column(c).norm() - norms[c]).abs() <= 1e-9 * norms[c]),
        "`lin` is the linearisation of `j`"
    );
    let normalised = |row: usize, c: usize| j[(row, c)] / norms[c];

    let mut omega = DMatrix::zeros(n, n);
    let mut batch_samples = Vec::with_capacity(runs);
    for run in 0..runs {
        let (h, p) = (&blocks[2 * run], &blocks[2 * run + 1]);
        let samples = h.len();
        if p.len() != samples {
            return None;
        }
        if samples == 0 {
            batch_samples.push((0, false));
            continue;
        }
        let scores = DMatrix::from_fn(samples, n, |k, c| {
            normalised(h.start + k, c) * residuals[h.start + k]
                + normalised(p.start + k, c) * residuals[p.start + k]
        });
        let longest = (samples / RUN_SAMPLES_PER_LONGEST_BATCH).max(1);
        let wanted = bartlett_bandwidth(&scores).ceil();
        let b = (wanted as usize).clamp(1, longest);
        batch_samples.push((b, wanted > longest as f64));
        // Every window of `b` samples that overlaps the run, from the one ending at its first
        // sample to the one starting at its last: each sample lies in exactly `b` of them.
        let mut sum = nalgebra::DVector::zeros(n);
        let mut acc = DMatrix::zeros(n, n);
        for last in 0..samples + b - 1 {
            if last < samples {
                sum += scores.row(last).transpose();
            }
            if last >= b {
                sum -= scores.row(last - b).transpose();
            }
            acc.ger(1.0, &sum, &sum, 1.0);
        }
        omega += acc / b as f64;
    }
    for (block, &l) in blocks.iter().zip(lambda).skip(2 * runs) {
        for row in block.clone() {
            let jr = nalgebra::DVector::from_fn(n, |c, _| normalised(row, c));
            omega.ger(l, &jr, &jr, 1.0);
        }
    }
    let cw = a_inv * omega * a_inv;
    Some(CorrelatedCovariance {
        covariance: DMatrix::from_fn(n, n, |r, c| cw[(r, c)] / (norms[r] * norms[c])),
        batch_samples,
    })
}

/// Andrews' (1991) AR(1) plug-in bandwidth for the Bartlett kernel over the columns
/// of `scores` (samples × components, each centred), each weighted alike: `1.1447 (α̂(1) n)^{1/3}`,
/// `α̂(1) = Σ 4ρ²σ⁴/((1−ρ)⁶(1+ρ)²) / Σ σ⁴/(1−ρ)⁴`. A component's `ρ` is held inside ±0.999
/// (a random walk has no finite bandwidth; the caller caps it at a quarter of the run).
fn bartlett_bandwidth(scores: &DMatrix<f64>) -> f64 {
    let samples = scores.nrows();
    if samples < 3 {
        return 1.0;
    }
    let (mut num, mut den) = (0.0, 0.0);
    for col in scores.column_iter() {
        let mean = col.mean();
        let col: Vec<f64> = col.iter().map(|g| g - mean).collect();
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for k in 1..samples {
            sxy += col[k] * col[k - 1];
            sxx += col[k - 1] * col[k - 1];
        }
        if !(sxx > 0.0) {
            continue;
        }
        let rho = (sxy / sxx).clamp(-0.999, 0.999);
        let sigma2 = (1..samples)
            .map(|k| (col[k] - rho * col[k - 1]).powi(2))
            .sum::<f64>()
            / (samples - 1) as f64;
        let s4 = sigma2 * sigma2;
        num += 4.0 * rho * rho * s4 / ((1.0 - rho).powi(6) * (1.0 + rho).powi(2));
        den += s4 / (1.0 - rho).powi(4);
    }
    if !(den > 0.0) {
        return 1.0;
    }
    1.1447 * (num / den * samples as f64).cbrt()
}

pub(crate) fn correlation(cov: &DMatrix<f64>) -> DMatrix<f64> {
    let n = cov.nrows();
    DMatrix::from_fn(n, n, |r, c| {
        let d = (cov[(r, r)] * cov[(c, c)]).sqrt();
        if d > 0.0 { cov[(r, c)] / d } else { 0.0 }
    })
}

/// The report for the columns `cols` of `j` (named `names[cols[i]]`), and its linearisation
/// of those with some sensitivity (`None` where none has any): the estimate's covariances
/// are those of the same matrix.
pub(crate) fn analyse(
    j: &DMatrix<f64>,
    cols: &[usize],
    names: &[String],
    blocks: &[Range<usize>],
    lambda: &[f64],
    rcond: f64,
    correlation_warning: f64,
) -> (JacobianAnalysis, Option<LiveColumns>) {
    let sub = j.select_columns(cols);
    let parameters: Vec<String> = cols.iter().map(|&c| names[c].clone()).collect();
    let sensitivities: Vec<f64> = (0..sub.ncols()).map(|c| sub.column(c).norm()).collect();
    // Columns with no sensitivity make the normalised matrix meaningless: analyse the rest.
    let live: Vec<usize> = (0..sub.ncols())
        .filter(|&c| sensitivities[c] > 0.0)
        .collect();
    if live.is_empty() {
        let analysis = JacobianAnalysis {
            relative_std: vec![f64::INFINITY; parameters.len()],
            singular_values: vec![0.0; parameters.len()],
            condition_number: f64::INFINITY,
            parameters,
            sensitivities,
            high_correlations: Vec::new(),
        };
        return (analysis, None);
    }
    let live_j = sub.select_columns(&live);
    let lin = linearise(&live_j, blocks, lambda, rcond);
    let mut singular_values = lin.singular_values.clone();
    singular_values.extend(std::iter::repeat_n(0.0, sub.ncols() - live.len()));
    let s_max = singular_values.first().copied().unwrap_or(0.0);
    let s_min = singular_values.last().copied().unwrap_or(0.0);
    let condition_number = if s_min > 0.0 {
        s_max / s_min
    } else {
        f64::INFINITY
    };
    let mut relative_std = vec![f64::INFINITY; sub.ncols()];
    let mut high_correlations = Vec::new();
    if let Some(cov) = &lin.covariance {
        for (i, &c) in live.iter().enumerate() {
            relative_std[c] = cov[(i, i)].sqrt();
        }
        let corr = correlation(cov);
        for a in 0..live.len() {
            for b in a + 1..live.len() {
                if corr[(a, b)].abs() > correlation_warning {
                    high_correlations.push(CorrelatedPair {
                        a: parameters[live[a]].clone(),
                        b: parameters[live[b]].clone(),
                        correlation: corr[(a, b)],
                    });
                }
            }
        }
    }
    let analysis = JacobianAnalysis {
        parameters,
        sensitivities,
        singular_values,
        condition_number,
        relative_std,
        high_correlations,
    };
    let kept = LiveColumns {
        columns: live.iter().map(|&c| cols[c]).collect(),
        j: live_j,
        lin,
    };
    (analysis, Some(kept))
}

/// Settings of [`select_identifiable`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct Screen {
    pub rcond: f64,
    pub max_relative_std: f64,
    pub correlation_warning: f64,
    pub stage: Stage,
}

/// Splits `cols` into the identifiable ones and the rest (module docs, rules 1–3), greedily:
/// one parameter at a time, recomputing after each removal.
///
/// `priority[c]` is column `c`'s position in the model's parameter order (the tie-break).
#[allow(clippy::too_many_arguments)]
pub(crate) fn select_identifiable(
    j: &DMatrix<f64>,
    failed: &[usize],
    cols: &[usize],
    names: &[String],
    priority: &[usize],
    blocks: &[Range<usize>],
    lambda: &[f64],
    screen: Screen,
) -> (Vec<usize>, Vec<NotIdentifiable>) {
    let mut keep: Vec<usize> = cols.to_vec();
    let mut removed = Vec::new();
    let max_norm = keep.iter().map(|&c| j.column(c).norm()).fold(0.0, f64::max);
    // Rule 1: zero columns (bitwise zero when the outputs do not depend on the parameter;
    // the relative floor catches round-off in a column that should be zero).
    keep.retain(|&c| {
        let norm = j.column(c).norm();
        let zero = !(norm > 1e-10 * max_norm) || !norm.is_finite();
        if zero {
            removed.push(NotIdentifiable {
                name: names[c].clone(),
                reason: if failed.contains(&c) {
                    Unidentifiable::SimulationFails
                } else {
                    Unidentifiable::NoSensitivity
                },
                stage: screen.stage,
                correlated_with: Vec::new(),
                determined_by: String::new(),
            });
        }
        !zero
    });
    while !keep.is_empty() {
        let sub = j.select_columns(&keep);
        let lin = linearise(&sub, blocks, lambda, screen.rcond);
        let n = keep.len();
        let s_max = lin.singular_values.first().copied().unwrap_or(0.0);
        let s_min = lin.singular_values.last().copied().unwrap_or(0.0);
        // The group of parameters sharing an undetermined direction, and the reason.
        let (group, undetermined, correlated_with): (Vec<usize>, Option<f64>, Vec<(String, f64)>) =
            if !(s_min > screen.rcond * s_max) {
                // Rule 2: the null direction, in scaled units (D⁻¹ v).
                let v = lin.v.column(n - 1);
                let u: Vec<f64> = (0..n).map(|i| v[i] / lin.norms[i]).collect();
                let u_max = u.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
                let group = (0..n).filter(|&i| u[i].abs() >= 0.5 * u_max).collect();
                (group, None, Vec::new())
            } else {
                let Some(cov) = lin.covariance else { break };
                let rel: Vec<f64> = (0..n).map(|i| cov[(i, i)].sqrt()).collect();
                let Some((worst, &worst_std)) =
                    rel.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))
                else {
                    break;
                };
                if !(worst_std > screen.max_relative_std) {
                    break;
                }
                let corr = correlation(&cov);
                let correlated: Vec<usize> = (0..n)
                    .filter(|&i| i != worst && corr[(worst, i)].abs() > screen.correlation_warning)
                    .collect();
                let mut group: Vec<usize> = correlated
                    .iter()
                    .copied()
                    .filter(|&i| rel[i] >= 0.5 * worst_std)
                    .collect();
                group.push(worst);
                let correlated_with = correlated
                    .iter()
                    .map(|&i| (names[keep[i]].clone(), corr[(worst, i)]))
                    .collect();
                (group, Some(worst_std), correlated_with)
            };
        let pick = group
            .iter()
            .copied()
            .min_by_key(|&i| priority[keep[i]])
            .unwrap_or(n - 1);
        let with: Vec<String> = group
            .iter()
            .filter(|&&i| i != pick)
            .map(|&i| names[keep[i]].clone())
            .collect();
        let reason = match undetermined {
            Some(relative_std) if with.is_empty() => Unidentifiable::Undetermined {
                relative_std,
                limit: screen.max_relative_std,
            },
            _ => Unidentifiable::Collinear { with },
        };
        removed.push(NotIdentifiable {
            name: names[keep[pick]].clone(),
            reason,
            stage: screen.stage,
            correlated_with,
            determined_by: String::new(),
        });
        keep.remove(pick);
    }
    (keep, removed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    /// A linear least-squares problem in [`correlated_covariance`]'s layout (two runs, each
    /// a height block and a pressure block of `n` samples) with AR(1) noise of correlation
    /// `rho` per sample: over many noise draws, the spread of the estimates against the
    /// standard deviations the white and the correlated sandwich report.
    fn spread_against_reported(rho: f64, early: bool) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let (n, runs, draws) = (2_000, 2, 300);
        let rows = 2 * n * runs;
        let blocks: Vec<Range<usize>> = (0..2 * runs).map(|b| b * n..(b + 1) * n).collect();
        // An offset on both outputs, a slow sweep on the heights, a faster one on the
        // pressures: columns as a model's sensitivities are, smooth over a run. With `early`
        // the last is a parameter only a run's first tenth shows (a start, a first load
        // step), where the batches reach past the run's edge.
        let j = DMatrix::from_fn(rows, 3, |row, c| {
            let (block, k) = (row / n, row % n);
            let t = k as f64 / n as f64;
            let height = block % 2 == 0;
            match c {
                0 => 1.0,
                1 if height => (2.0 * std::f64::consts::PI * 2.0 * t).sin(),
                1 => 0.0,
                _ if early => f64::from(u8::from(t < 0.1)),
                _ if height => 0.0,
                _ => (2.0 * std::f64::consts::PI * 7.0 * t).cos(),
            }
        });
        let gram_inv = (j.transpose() * &j).try_inverse().unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut estimates = Vec::with_capacity(draws);
        let (mut white, mut correlated) = (vec![0.0; 3], vec![0.0; 3]);
        for _ in 0..draws {
            let mut noise = Vec::with_capacity(rows);
            for _ in 0..2 * runs {
                // Stationary from the first sample: each block its own stretch of noise.
                let mut e: f64 = StandardNormal.sample(&mut rng);
                for _ in 0..n {
                    noise.push(e);
                    let w: f64 = StandardNormal.sample(&mut rng);
                    e = rho * e + (1.0 - rho * rho).sqrt() * w;
                }
            }
            let y = nalgebra::DVector::from_vec(noise);
            let theta = &gram_inv * j.transpose() * &y;
            let residuals = &y - &j * &theta;
            let lambda: Vec<f64> = blocks
                .iter()
                .map(|b| residuals.rows(b.start, b.len()).norm_squared() / (b.len() as f64 - 1.5))
                .collect();
            let lin = linearise(&j, &blocks, &lambda, 1e-12);
            let hac = correlated_covariance(&j, &lin, residuals.as_slice(), &blocks, &lambda, runs)
                .unwrap();
            let cov = lin.covariance.unwrap();
            for c in 0..3 {
                white[c] += cov[(c, c)].sqrt() / draws as f64;
                correlated[c] += hac.covariance[(c, c)].sqrt() / draws as f64;
            }
            estimates.push(theta);
        }
        let spread: Vec<f64> = (0..3)
            .map(|c| {
                let mean = estimates.iter().map(|t| t[c]).sum::<f64>() / draws as f64;
                (estimates.iter().map(|t| (t[c] - mean).powi(2)).sum::<f64>() / (draws - 1) as f64)
                    .sqrt()
            })
            .collect();
        (spread, white, correlated)
    }

    /// Residuals correlated over about a hundred samples: the white standard deviations are
    /// several times too small (0.10-0.13 of the estimates' spread), the correlated ones
    /// match it (0.81-0.88). A parameter that only a run's first 200 samples show is the
    /// hard case, a stretch of two correlation times that the fit has centred: 0.68, where
    /// batches that stop at the run's start (overlapping batch means without the kernel's
    /// reach past the edges) gave 0.54.
    #[test]
    fn correlated_std_matches_the_spread_where_the_white_one_understates_it() {
        for early in [false, true] {
            let (spread, white, correlated) = spread_against_reported(0.98, early);
            for c in 0..3 {
                let (w, h) = (white[c] / spread[c], correlated[c] / spread[c]);
                assert!(
                    w < 0.4,
                    "column {c} (early {early}): white std {w:.2} of the spread"
                );
                let lowest = if early && c == 2 { 0.6 } else { 0.75 };
                assert!(
                    (lowest..1.25).contains(&h),
                    "column {c} (early {early}): correlated std {h:.2} of the spread (white {w:.2})"
                );
            }
        }
    }

    /// White residuals: both agree with the spread (the batches shrink to a sample or so).
    #[test]
    fn correlated_std_is_the_white_one_for_white_residuals() {
        let (spread, white, correlated) = spread_against_reported(0.0, true);
        for c in 0..3 {
            let (w, h) = (white[c] / spread[c], correlated[c] / spread[c]);
            assert!((0.85..1.15).contains(&w), "column {c}: white {w:.2}");
            assert!((0.85..1.15).contains(&h), "column {c}: correlated {h:.2}");
        }
    }
}
