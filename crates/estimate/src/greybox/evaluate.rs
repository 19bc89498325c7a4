//! Evaluating the loss: parameters → simulations of every run → normalised residuals; and the
//! forward-difference Jacobian, parallel over parameters.
//!
//! Scaled coordinates: every freed parameter `θ_i` is written `θ_i = θ0_i + s_i z_i` with
//! `θ0_i` the nominal value and the scale `s_i = |θ0_i|` (or, for a nominal 0, a thousandth
//! of the bound width, else 1), so `z` is O(1) whatever the units (an `m2` in kg and a
//! `kscl` in m/N both move by "a fraction of nominal"). Bounds are handled by projection:
//! the model always sees `clamp(θ, lower, upper)`; the least-squares vector carries one
//! extra penalty row per parameter, `κ (z_i − clamp(z_i))`, zero inside the box, so a step
//! that leaves the box costs more than anything it could gain and the solver is pushed back
//! to the boundary (an exterior penalty on top of the projection; the loss stays continuous).

use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};

use airsus_data::{EffectiveAreaLaw, ForceMap, Run};
use airsus_model::{ModelError, SuspensionModel};
use airsus_sim::{
    InitialState, InputSeries, SimError, SimulationProblem, SimulationResponse, SolverOptions,
    simulate,
};
use nalgebra::DMatrix;
use rayon::prelude::*;

use super::problem::{ForceMapPrior, GreyboxProblem, Normalisation};
use crate::error::EstimateError;

/// Sensor resolutions (SPEC §1), the floors of the normalisation: a run whose height or
/// pressure hardly moves is not allowed to blow its residuals up by dividing by ~0.
pub const HEIGHT_RESOLUTION_M: f64 = 1e-4;
pub const PRESSURE_RESOLUTION_PA: f64 = 100.0;

/// A freed parameter, resolved against the model.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Resolved {
    pub name: String,
    pub unit: String,
    pub nominal: f64,
    pub lower: f64,
    pub upper: f64,
    pub scale: f64,
}

impl Resolved {
    pub fn z_range(&self) -> (f64, f64) {
        (
            (self.lower - self.nominal) / self.scale,
            (self.upper - self.nominal) / self.scale,
        )
    }

    pub fn value(&self, z: f64) -> f64 {
        (self.nominal + self.scale * z).clamp(self.lower, self.upper)
    }
}

/// One estimation run, with its normalisation.
#[derive(Debug)]
pub(crate) struct RunData<'a> {
    pub name: String,
    pub inputs: InputSeries<'a>,
    pub initial: InitialState,
    pub height: &'a [f64],
    pub pressure: &'a [f64],
    /// `w_h / σ_h` and `w_p / σ_p`.
    pub height_factor: f64,
    pub pressure_factor: f64,
    /// Per sample 1, or 0 where the loss leaves it out (just after a logged load change,
    /// [`GreyboxProblem::exclude_after_load_change_s`]); empty: every sample counts.
    pub sample_weight: Vec<f64>,
}

impl RunData<'_> {
    pub(crate) fn len(&self) -> usize {
        self.height.len()
    }

    /// The measurement noise of height and pressure in normalised units (times their
    /// factors): what one residual of each block is at a model that explains all but the
    /// noise.
    fn normalised_noise(&self) -> [f64; 2] {
        [
            self.height_factor * measurement_noise(self.height, HEIGHT_RESOLUTION_M),
            self.pressure_factor * measurement_noise(self.pressure, PRESSURE_RESOLUTION_PA),
        ]
    }
}

/// The force map as a prior on the effective-area law ([`super::problem::ForceMapPrior`]):
/// one residual per lab point, `factor (p A_eff(h, p) − F)`, appended after the runs'
/// residuals as one more block. `factor = c / (σ_F √M)` over the map's `M` points, with `c²`
/// the mean squared noise the runs' blocks carry in normalised units.
#[derive(Debug)]
pub(crate) struct AreaPrior<'a> {
    pub map: &'a ForceMap,
    /// The wall friction in each reading ([`ForceMapPrior::friction_n`]).
    pub friction_n: Vec<f64>,
    pub factor: f64,
    /// `(factor σ_F)²`: the variance of one residual at the start's misfit, normalised.
    pub noise_variance: f64,
}

impl AreaPrior<'_> {
    fn residuals_into(&self, area: &EffectiveAreaLaw, out: &mut [f64]) {
        for (k, r) in out.iter_mut().enumerate() {
            *r = self.factor * ForceMapPrior::force_error_n(self.map, &self.friction_n, area, k);
        }
    }
}

/// The effective-area law a model uses, if it keeps a truck file.
fn area_law(model: &dyn SuspensionModel) -> Option<&EffectiveAreaLaw> {
    model.truck_parameters().map(|t| &t.bellow.effective_area)
}

/// Simulated outputs of all runs at one parameter point.
pub(crate) type Responses = Vec<Result<SimulationResponse, SimError>>;

/// The loss machinery shared by the solver, the identifiability analysis and the report.
#[derive(Debug)]
pub(crate) struct Evaluator<'a> {
    pub base: Box<dyn SuspensionModel>,
    pub params: Vec<Resolved>,
    pub runs: Vec<RunData<'a>>,
    /// The force map as a prior on the effective-area law ([`GreyboxProblem::force_map`]).
    pub prior: Option<AreaPrior<'a>>,
    pub solver: SolverOptions,
    pub parallel: bool,
    pub simulations: AtomicUsize,
    pub failures: AtomicUsize,
}

fn std_dev(x: &[f64]) -> f64 {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt()
}

impl<'a> Evaluator<'a> {
    pub fn new(problem: &GreyboxProblem<'a>) -> Result<Self, EstimateError> {
        let model = problem.model;
        if problem.runs.is_empty() {
            return Err(EstimateError::NoRuns);
        }
        let w = problem.weights;
        if !(w.height.is_finite() && w.pressure.is_finite() && w.height >= 0.0 && w.pressure >= 0.0)
            || w.height + w.pressure <= 0.0
        {
            return Err(EstimateError::InvalidOption(format!(
                "output weights must be finite, non-negative and not both zero, got height {} and pressure {}",
                w.height, w.pressure
            )));
        }
        let mut params: Vec<Resolved> = Vec::new();
        for free in &problem.free {
            if params.iter().any(|p| p.name == free.name) {
                return Err(EstimateError::DuplicateParameter {
                    name: free.name.clone(),
                });
            }
            let nominal = model.parameter(&free.name)?;
            let info = model
                .parameter_info()
                .iter()
                .find(|i| i.name == free.name)
                .ok_or_else(|| EstimateError::InvalidBounds {
                    name: free.name.clone(),
                    reason: "the model lists no admissible range for it".to_owned(),
                })?;
            let lower = free.lower.unwrap_or(info.lower);
            let upper = free.upper.unwrap_or(info.upper);
            let bad = |reason: String| EstimateError::InvalidBounds {
                name: free.name.clone(),
                reason,
            };
            if !(lower.is_finite() && upper.is_finite() && lower < upper) {
                return Err(bad(format!(
                    "bounds [{lower}, {upper}] must be finite with lower < upper"
                )));
            }
            if lower < info.lower || upper > info.upper {
                return Err(bad(format!(
                    "bounds [{lower}, {upper}] reach outside the admissible range [{}, {}] {}",
                    info.lower, info.upper, info.unit
                )));
            }
            if !(nominal >= lower && nominal <= upper) {
                return Err(bad(format!(
                    "the nominal value {nominal} lies outside the bounds [{lower}, {upper}]"
                )));
            }
            // Relative to the nominal, but never below the parameter's usual magnitude where it
            // declares one (an effect a file may leave at or near 0): a scale that is a sliver
            // of it makes the finite-difference step move the outputs less than the solver's
            // tolerance, and the screen's "undetermined" threshold meaningless (the tire's
            // damping from 0 with a thousandth of its range: a step of 0.01 N s/m, and a fit
            // that stopped at 28 N s/m of a true 4000).
            let scale = match info.typical {
                Some(typical) => nominal.abs().max(typical),
                None if nominal != 0.0 => nominal.abs(),
                None => 1e-3 * (upper - lower),
            };
            params.push(Resolved {
                name: free.name.clone(),
                unit: info.unit.to_owned(),
                nominal,
                lower,
                upper,
                scale,
            });
        }
        let mut runs = Vec::with_capacity(problem.runs.len());
        for (i, run) in problem.runs.iter().enumerate() {
            let start = problem.start_states.get(i).cloned().flatten();
            runs.push(run_data(run, problem, w, start)?);
        }
        match problem.normalisation {
            Normalisation::PooledSpread => {
                // One scale per output, pooled over the runs (see GreyboxProblem): a per-run
                // scale would give a run in which an output hardly moves (the pressure at
                // constant load during valve pulses) an enormous weight on that output.
                let heights: Vec<&[f64]> = runs.iter().map(|r| r.height).collect();
                let pressures: Vec<&[f64]> = runs.iter().map(|r| r.pressure).collect();
                let sigma_h = pooled_spread(&heights, HEIGHT_RESOLUTION_M);
                let sigma_p = pooled_spread(&pressures, PRESSURE_RESOLUTION_PA);
                for r in &mut runs {
                    r.height_factor /= sigma_h;
                    r.pressure_factor /= sigma_p;
                }
            }
            Normalisation::NoiseLevel => {
                // Each output of each run in units of its own measurement noise, and each run
                // scaled by 1/√N so that every run weighs the same whatever its length.
                for r in &mut runs {
                    let per_run = 1.0 / (r.len() as f64).sqrt();
                    r.height_factor *= per_run / measurement_noise(r.height, HEIGHT_RESOLUTION_M);
                    r.pressure_factor *=
                        per_run / measurement_noise(r.pressure, PRESSURE_RESOLUTION_PA);
                }
            }
        }
        let prior = match (&problem.force_map, area_law(model)) {
            (Some(prior), Some(_)) if !prior.map.is_empty() => {
                let map = prior.map;
                let m = map.len() as f64;
                let rms_force = (map.force_n.iter().map(|f| f * f).sum::<f64>() / m).sqrt();
                // Floored: a map given as exact must not weigh infinitely.
                let sigma_f = prior.force_noise_n.max(1e-3 * rms_force);
                let block_noise: Vec<f64> = runs
                    .iter()
                    .flat_map(|r| r.normalised_noise().map(|s| r.len() as f64 * s.powi(2)))
                    .collect();
                let c2 = block_noise.iter().sum::<f64>() / block_noise.len() as f64;
                (sigma_f.is_finite() && sigma_f > 0.0 && c2 > 0.0).then(|| AreaPrior {
                    map,
                    friction_n: prior.friction_n.clone(),
                    factor: c2.sqrt() / (sigma_f * m.sqrt()),
                    noise_variance: c2 / m,
                })
            }
            _ => None,
        };
        problem.check_run_weights()?;
        for (run, w) in runs.iter_mut().zip(&problem.run_weights) {
            if !(w.height.is_finite() && w.pressure.is_finite())
                || w.height < 0.0
                || w.pressure < 0.0
            {
                return Err(EstimateError::InvalidOption(format!(
                    "run {}'s weights must be finite and non-negative, got height {} and pressure {}",
                    run.name, w.height, w.pressure
                )));
            }
            // After the prior's weight is set: it stays what the runs as given make it.
            run.height_factor *= w.height;
            run.pressure_factor *= w.pressure;
        }
        Ok(Self {
            base: model.box_clone(),
            params,
            runs,
            prior,
            solver: problem.solver.clone(),
            parallel: true,
            simulations: AtomicUsize::new(0),
            failures: AtomicUsize::new(0),
        })
    }

    /// Number of data residuals (both outputs of all runs).
    pub fn n_data(&self) -> usize {
        self.runs.iter().map(|r| 2 * r.len()).sum::<usize>() + self.n_prior()
    }

    /// Residuals of the force-map prior (0 without one).
    fn n_prior(&self) -> usize {
        self.prior.as_ref().map_or(0, |p| p.map.len())
    }

    /// Row ranges of the (run, output) blocks: run `r` height is block `2r`, pressure `2r+1`.
    pub fn blocks(&self) -> Vec<Range<usize>> {
        let mut out = Vec::with_capacity(2 * self.runs.len());
        let mut start = 0;
        for r in &self.runs {
            let n = r.len();
            out.push(start..start + n);
            out.push(start + n..start + 2 * n);
            start += 2 * n;
        }
        if self.prior.is_some() {
            out.push(start..start + self.n_prior());
        }
        out
    }

    /// Physical values (projected onto the box) for scaled coordinates `z` (all freed).
    pub fn theta(&self, z: &[f64]) -> Vec<f64> {
        self.params
            .iter()
            .zip(z)
            .map(|(p, &zi)| p.value(zi))
            .collect()
    }

    /// The model with the freed parameters set to `theta`.
    pub fn model_at(&self, theta: &[f64]) -> Result<Box<dyn SuspensionModel>, ModelError> {
        let mut model = self.base.box_clone();
        for (p, &v) in self.params.iter().zip(theta) {
            model.set_parameter(&p.name, v)?;
        }
        Ok(model)
    }

    /// Simulates every run at `theta`. A parameter set the model rejects fails every run.
    pub fn simulate(&self, theta: &[f64]) -> Result<Responses, ModelError> {
        let model = self.model_at(theta)?;
        let one = |run: &RunData<'a>| {
            self.simulations.fetch_add(1, Ordering::Relaxed);
            let problem = SimulationProblem::new(&*model, run.inputs, run.initial.clone())
                .with_options(self.solver.clone());
            let result = simulate(&problem);
            if result.is_err() {
                self.failures.fetch_add(1, Ordering::Relaxed);
            }
            result
        };
        Ok(if self.parallel && self.runs.len() > 1 {
            self.runs.par_iter().map(one).collect()
        } else {
            self.runs.iter().map(one).collect()
        })
    }

    /// Writes the normalised residuals `w (y − ŷ)/σ` of `responses`, simulated at `theta`,
    /// into `out` (length [`Self::n_data`]), then the force-map prior's at `theta`; a failed
    /// run's residuals are `fail_value`. Returns whether any run failed.
    pub fn residuals_into(
        &self,
        theta: &[f64],
        responses: &Responses,
        fail_value: f64,
        out: &mut [f64],
    ) -> bool {
        let mut failed = false;
        let mut start = 0;
        for (run, response) in self.runs.iter().zip(responses) {
            let n = run.len();
            let (h_out, rest) = out[start..start + 2 * n].split_at_mut(n);
            let weight = |k: usize| run.sample_weight.get(k).copied().unwrap_or(1.0);
            match response {
                Ok(sim) => {
                    for (k, r) in h_out.iter_mut().enumerate() {
                        *r = weight(k)
                            * run.height_factor
                            * (run.height[k] - sim.sensor_height_m[k]);
                    }
                    for (k, r) in rest.iter_mut().enumerate() {
                        *r = weight(k)
                            * run.pressure_factor
                            * (run.pressure[k] - sim.bellow_gauge_pa[k]);
                    }
                }
                Err(_) => {
                    failed = true;
                    h_out.fill(fail_value);
                    rest.fill(fail_value);
                }
            }
            start += 2 * n;
        }
        if let Some(prior) = &self.prior {
            let out = &mut out[start..start + prior.map.len()];
            match self.model_at(theta) {
                Ok(model) => match area_law(&*model) {
                    Some(area) => prior.residuals_into(area, out),
                    None => out.fill(0.0),
                },
                Err(_) => {
                    failed = true;
                    out.fill(fail_value);
                }
            }
        }
        failed
    }

    /// Data residuals at scaled point `z`; `None` if any simulation failed (or the model
    /// rejected the values).
    pub fn residuals_at(&self, z: &[f64]) -> Option<Vec<f64>> {
        let mut out = vec![0.0; self.n_data()];
        self.residuals_at_into(z, &mut out).then_some(out)
    }

    /// [`Self::residuals_at`] written into `out` (length [`Self::n_data`]); whether the model
    /// accepted the values and every run simulated. `out` is left unspecified where not.
    fn residuals_at_into(&self, z: &[f64], out: &mut [f64]) -> bool {
        let theta = self.theta(z);
        match self.simulate(&theta) {
            Ok(responses) => !self.residuals_into(&theta, &responses, 0.0, out),
            Err(_) => false,
        }
    }

    /// Forward-difference Jacobian `∂r/∂z` of the data residuals at `z` for the columns
    /// `cols` (indices into the freed parameters), given the residuals `r0` at `z`.
    /// Columns are computed in parallel (rayon) unless the evaluator is serial. The step is
    /// `+fd_step`, or `−fd_step` where that would leave the box; if the simulation fails,
    /// the other direction is tried; if both fail, the column is zero, counted, and
    /// returned in the list of failed columns (freed-parameter indices: the identifiability
    /// screen then says the model does not simulate there, not that the outputs do not
    /// depend on the parameter).
    pub fn jacobian(
        &self,
        z: &[f64],
        cols: &[usize],
        r0: &[f64],
        fd_step: f64,
    ) -> (DMatrix<f64>, Vec<usize>) {
        self.jacobian_padded(z, cols, r0, fd_step, 0)
    }

    /// [`Self::jacobian`] with `pad` rows of zeros below the data rows (where the solver puts
    /// its penalty rows). Each column is simulated straight into its place in the matrix: the
    /// data Jacobian of the `truck` structure on two 25-min runs is 60,000 rows by 17
    /// columns, and a fresh vector per column, allocated, zeroed, then gathered into the
    /// matrix and copied again below the penalty rows, took a tenth of its fit.
    pub fn jacobian_padded(
        &self,
        z: &[f64],
        cols: &[usize],
        r0: &[f64],
        fd_step: f64,
        pad: usize,
    ) -> (DMatrix<f64>, Vec<usize>) {
        let m = r0.len();
        debug_assert_eq!(
            m,
            self.n_data(),
            "the residuals at z are the data residuals"
        );
        let rows = m + pad;
        let mut jac = DMatrix::zeros(rows, cols.len());
        if rows == 0 || cols.is_empty() {
            return (jac, Vec::new());
        }
        // Whether column `j` simulated, written into `out` (its data rows; zero where not).
        let column = |(&j, out): (&usize, &mut [f64])| -> bool {
            let out = &mut out[..m];
            let (_, hi) = self.params[j].z_range();
            let first = if z[j] + fd_step <= hi {
                fd_step
            } else {
                -fd_step
            };
            for step in [first, -first] {
                let mut zp = z.to_vec();
                zp[j] += step;
                if self.residuals_at_into(&zp, out) {
                    for (a, b) in out.iter_mut().zip(r0) {
                        *a = (*a - b) / step;
                    }
                    return true;
                }
            }
            out.fill(0.0);
            false
        };
        // Column-major: each column's rows are one contiguous chunk.
        let simulated: Vec<bool> = if self.parallel {
            cols.par_iter()
                .zip(jac.as_mut_slice().par_chunks_mut(rows))
                .map(column)
                .collect()
        } else {
            cols.iter()
                .zip(jac.as_mut_slice().chunks_mut(rows))
                .map(column)
                .collect()
        };
        let failed: Vec<usize> = cols
            .iter()
            .zip(&simulated)
            .filter(|(_, ok)| !**ok)
            .map(|(&j, _)| j)
            .collect();
        (jac, failed)
    }

    pub fn simulations(&self) -> usize {
        self.simulations.load(Ordering::Relaxed)
    }

    pub fn failures(&self) -> usize {
        self.failures.load(Ordering::Relaxed)
    }
}

fn run_data<'a>(
    run: &'a Run,
    problem: &GreyboxProblem<'a>,
    w: super::problem::OutputWeights,
    start: Option<InitialState>,
) -> Result<RunData<'a>, EstimateError> {
    let invalid = |reason: String| EstimateError::InvalidRun {
        run: run.name.clone(),
        reason,
    };
    let outputs = run
        .outputs
        .as_ref()
        .ok_or_else(|| invalid("it has no measured height and pressure".to_owned()))?;
    let n = run.len();
    if n < 2 {
        return Err(invalid(format!(
            "it has {n} samples; at least 2 are needed"
        )));
    }
    if outputs.sensor_height_m.len() != n || outputs.bellow_gauge_pa.len() != n {
        return Err(invalid(
            "its output columns differ in length from its time axis".to_owned(),
        ));
    }
    for (name, signal) in [
        ("height", &outputs.sensor_height_m),
        ("pressure", &outputs.bellow_gauge_pa),
    ] {
        if let Some(k) = signal.iter().position(|v| !v.is_finite()) {
            return Err(invalid(format!(
                "measured {name} at sample {k} is not finite"
            )));
        }
    }
    let inputs = InputSeries::from_run(run).map_err(|e| invalid(e.to_string()))?;
    let ic = problem
        .initial
        .condition(run)
        .ok_or_else(|| invalid("it has no first measured sample".to_owned()))?;
    // The spread normalisation is pooled over all runs afterwards (Evaluator::new).
    Ok(RunData {
        name: run.name.clone(),
        inputs,
        initial: start.unwrap_or(InitialState::Equilibrium(ic)),
        height: &outputs.sensor_height_m,
        pressure: &outputs.bellow_gauge_pa,
        height_factor: w.height,
        pressure_factor: w.pressure,
        sample_weight: load_change_weights(run, problem.exclude_after_load_change_s),
    })
}

/// 0 for the samples within `window_s` after a change of the logged load (from the change
/// on, through an eased transition, to `window_s` after its last changing sample), 1
/// elsewhere; empty when nothing is left out.
fn load_change_weights(run: &Run, window_s: f64) -> Vec<f64> {
    if !(window_s > 0.0) {
        return Vec::new();
    }
    let load = &run.inputs.wheel_load_kg;
    let mut last_change = f64::NEG_INFINITY;
    let weights: Vec<f64> = (0..run.len())
        .map(|k| {
            if k > 0 && load[k] != load[k - 1] {
                last_change = run.time_s[k];
            }
            if run.time_s[k] - last_change < window_s {
                0.0
            } else {
                1.0
            }
        })
        .collect();
    if weights.iter().all(|w| *w == 1.0) {
        Vec::new()
    } else {
        weights
    }
}

/// The within-run spread of one output pooled over all runs,
/// `σ = √(Σ_r Σ_k (y_rk − ȳ_r)² / Σ_r N_r)`, floored at the sensor resolution.
fn pooled_spread(signals: &[&[f64]], floor: f64) -> f64 {
    let (mut squares, mut count) = (0.0, 0usize);
    for y in signals {
        let s = std_dev(y);
        squares += s * s * y.len() as f64;
        count += y.len();
    }
    (squares / count.max(1) as f64).sqrt().max(floor)
}

/// The measurement noise std of `signal` ([`airsus_validate::estimate_noise_std`]: trimmed
/// second differences), floored at the quantisation noise `q/√12` of resolution `q`.
pub(crate) fn measurement_noise(signal: &[f64], q: f64) -> f64 {
    airsus_validate::estimate_noise_std(signal)
        .unwrap_or(0.0)
        .max(q / 12f64.sqrt())
}

/// A model-free estimate of the white measurement-noise variance of each (run, output) block
/// in normalised units, for the identifiability check *before* the fit (when the residuals
/// still carry the start's model error): [`measurement_noise`].
pub(crate) fn noise_variance_from_data(ev: &Evaluator<'_>) -> Vec<f64> {
    let mut out = Vec::with_capacity(2 * ev.runs.len());
    for run in &ev.runs {
        for s in run.normalised_noise() {
            // A zero weight leaves the block out: its "noise" is irrelevant, keep it finite.
            let s = s.max(f64::MIN_POSITIVE);
            out.push(s * s);
        }
    }
    if let Some(prior) = &ev.prior {
        out.push(prior.noise_variance);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use airsus_data::{RunInputs, RunOutputs, TruckParameters, ValveState};

    fn run() -> Run {
        let n = 50;
        Run {
            name: "flat".to_owned(),
            time_s: (0..n).map(|k| k as f64 * 0.1).collect(),
            sample_time_s: 0.1,
            inputs: RunInputs {
                wheel_load_kg: vec![3350.0; n],
                valve: vec![ValveState::Closed; n],
                supply_gauge_pa: vec![850e3; n],
                road_height_m: vec![0.0; n],
            },
            outputs: Some(RunOutputs {
                sensor_height_m: (0..n).map(|k| 0.24 + 1e-4 * k as f64).collect(),
                bellow_gauge_pa: (0..n).map(|k| 350e3 + 100.0 * k as f64).collect(),
            }),
        }
    }

    #[test]
    fn a_failed_simulation_is_a_large_residual_and_is_counted() {
        let truck = TruckParameters::reference();
        let model = airsus_model::build_model("m2", &truck).unwrap();
        let r = run();
        let problem = GreyboxProblem::new(&*model, &[&r], &["p0"]);
        let ev = Evaluator::new(&problem).unwrap();
        // p0 = −0.5 makes the effective area negative: no equilibrium, the run fails.
        let z = [(-0.5 - ev.params[0].nominal) / ev.params[0].scale];
        let responses = ev.simulate(&ev.theta(&z)).unwrap();
        let mut out = vec![0.0; ev.n_data()];
        assert!(ev.residuals_into(&ev.theta(&z), &responses, 123.0, &mut out));
        assert!(out.iter().all(|&x| x == 123.0));
        assert_eq!((ev.simulations(), ev.failures()), (1, 1));
        assert!(ev.residuals_at(&z).is_none());
        // The nominal point simulates.
        assert!(ev.residuals_at(&[0.0]).is_some());
        assert_eq!((ev.simulations(), ev.failures()), (3, 2));
    }

    #[test]
    fn projection_keeps_values_inside_the_bounds() {
        let p = Resolved {
            name: "m2".to_owned(),
            unit: "kg".to_owned(),
            nominal: 500.0,
            lower: 400.0,
            upper: 700.0,
            scale: 500.0,
        };
        assert_eq!(p.z_range(), (-0.2, 0.4));
        assert_eq!(p.value(0.1), 550.0);
        assert_eq!(p.value(-1.0), 400.0);
        assert_eq!(p.value(3.0), 700.0);
    }
}
