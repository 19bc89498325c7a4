//! The response: outputs at the sample times, optionally the states, and solver statistics.

/// What the solver did, for one simulation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SolverStatistics {
    /// The method that finished the run after the requested one failed (see the `solve`
    /// module's fallback policy); `None` when the requested method did.
    pub fallback: Option<crate::problem::Method>,
    /// Accepted steps.
    pub steps: usize,
    /// Steps rejected by the local error test.
    pub rejected_steps: usize,
    /// Calls of the model's `rhs`, all included (steps, Newton iterations, finite-difference
    /// Jacobians, restarts).
    pub rhs_evaluations: usize,
    /// Finite-difference Jacobian evaluations (each costs `n_states + 1` rhs calls).
    pub jacobian_evaluations: usize,
    /// Newton iterations (implicit methods).
    pub newton_iterations: usize,
    /// Newton matrix (LU) factorisations.
    pub linear_solver_setups: usize,
    /// Clean restarts at input discontinuities (the first start not counted).
    pub restarts: usize,
    /// Under `Method::Auto`, the restarts at which one solver handed the state to another.
    pub method_changes: usize,
}

impl SolverStatistics {
    fn accumulate(&mut self, other: &Self) {
        self.steps += other.steps;
        self.rejected_steps += other.rejected_steps;
        self.rhs_evaluations += other.rhs_evaluations;
        self.jacobian_evaluations += other.jacobian_evaluations;
        self.newton_iterations += other.newton_iterations;
        self.linear_solver_setups += other.linear_solver_setups;
        self.restarts += other.restarts;
        self.method_changes += other.method_changes;
    }
}

impl std::ops::AddAssign for SolverStatistics {
    fn add_assign(&mut self, rhs: Self) {
        self.accumulate(&rhs);
    }
}

/// States at the sample times, row-major: `values[k * n_states + i]` is state `i` at sample `k`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StateHistory {
    pub names: Vec<&'static str>,
    pub values: Vec<f64>,
}

impl StateHistory {
    pub fn n_states(&self) -> usize {
        self.names.len()
    }

    pub fn len(&self) -> usize {
        self.values.len().checked_div(self.names.len()).unwrap_or(0)
    }

    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// The state vector at sample `k`.
    pub fn at(&self, k: usize) -> Option<&[f64]> {
        let n = self.names.len();
        self.values.get(k * n..(k + 1) * n)
    }

    /// One state's trajectory, by name.
    pub fn trajectory(&self, name: &str) -> Option<Vec<f64>> {
        let n = self.names.len();
        let i = self.names.iter().position(|s| *s == name)?;
        Some(self.values.iter().skip(i).step_by(n).copied().collect())
    }
}

/// The simulated response at exactly the input sample times.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SimulationResponse {
    /// Name of the model simulated.
    pub model: String,
    pub time_s: Vec<f64>,
    /// Axle-to-chassis height as the sensor reads it, m.
    pub sensor_height_m: Vec<f64>,
    /// Bellow gauge pressure, Pa.
    pub bellow_gauge_pa: Vec<f64>,
    /// The states at the sample times, when [`crate::SolverOptions::record_states`] is set.
    pub states: Option<StateHistory>,
    pub statistics: SolverStatistics,
}

impl SimulationResponse {
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// The state at the last sample, when states were recorded.
    pub fn final_state(&self) -> Option<&[f64]> {
        let states = self.states.as_ref()?;
        states.at(states.len().checked_sub(1)?)
    }
}
