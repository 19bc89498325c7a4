//! # airsus-sim: the simulation engine
//!
//! A [`SimulationProblem`] (model + inputs at the sample times + initial condition + solver
//! options) goes into [`simulate`], a [`SimulationResponse`] (outputs at exactly the sample
//! times, optionally states, solver statistics) comes out; failure is a typed [`SimError`]
//! naming model, time and state — never a panic, never a silent NaN.
//!
//! ```text
//! let inputs = InputSeries::from_run(&run)?;
//! let problem = SimulationProblem::new(&*model, inputs, InitialState::from_run(&run).unwrap());
//! let response = simulate(&problem)?;
//! // grey-box loop: same problem, new parameters
//! let mut m = model.clone(); m.set_parameter("kw", 2.0e6)?;
//! let response = simulate(&problem.with_model(&*m))?;
//! ```
//!
//! Integration uses diffsol's adaptive solvers (BDF by default). Inputs are held constant
//! between samples (zero-order hold), but for the road, which is followed linearly and gives
//! the model its rate (`RoadInput::Linear`, the default); the solver restarts cleanly where an
//! input that matters changes: wheel load and valve state always, the road where it starts or
//! stops moving, supply pressure only while the valve fills (see [`SupplyRelevance`] and the
//! [`solve`] module docs).
//!
//! [`tank`] simulates the lab's tank discharge (the rig and the orifice fit share it).
//!
//! [`reference`] holds test models with analytic solutions, shared by the tests and benches.

pub mod error;
pub mod problem;
pub mod reference;
pub mod response;
pub mod solve;
pub mod tank;

pub use error::{NamedState, SimError, SolverFailure, StateViolation};
pub use problem::{
    AbsoluteTolerance, DEFAULT_SUPPLY_DEADBAND_PA, InitialState, InputSeries, LoadInput, Method,
    RoadInput, SimulationProblem, SolverOptions, StateBounds, SupplyRelevance,
};
pub use response::{SimulationResponse, SolverStatistics, StateHistory};
pub use solve::{input_change_matters, simulate, simulate_into};
pub use tank::{TankDischargeProblem, simulate_tank_discharge};
