//! The one trait every full model implements (thesis ch. 4; SPEC §3).
//!
//! A model is plain data (its parameters) plus four verbs: the right-hand side
//! `dx = f(t, x, u)`, the output map to the sensor quantities, the initial state in static
//! equilibrium, and name-addressed parameter access for the grey-box estimator. Parameters
//! live inside the model value; "same problem, new parameters" is `clone` then
//! `set_parameter` (SciML's `remake`).
//!
//! All quantities are SI: kg, m, s, Pa (gauge where named so), mol.

use airsus_data::{LawFamily, TruckParameters, ValveState};

/// Inputs at one instant (SPEC §3: `m_tot`, `u`, `p_supply`, `z_r`). The simulator holds them
/// constant between samples (zero-order hold) and restarts the solver where they jump; the
/// road it follows linearly by default, and then gives its rate too.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InputSample {
    /// `m_tot`: the mass a scale under the wheel shows, kg.
    pub wheel_load_kg: f64,
    pub valve: ValveState,
    /// Supply (actuator tank) gauge pressure, Pa.
    pub supply_gauge_pa: f64,
    /// Road height under the wheel, m (0 = level road).
    pub road_height_m: f64,
    /// Rate of the road height, m/s: what a tire's damper feels (0 where the road is held
    /// between samples or not known, as in a single sample).
    pub road_rate_m_s: f64,
}

/// The two measured quantities a model predicts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutputSample {
    /// Axle-to-chassis height as the sensor reads it, incl. the lever's static flex (eq 3.14), m.
    pub sensor_height_m: f64,
    /// Bellow gauge pressure, Pa.
    pub bellow_gauge_pa: f64,
}

/// What fixes the initial static equilibrium besides the first sample's inputs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum InitialCondition {
    /// The measured bellow gauge pressure (the usual case: a run's first sample).
    BellowPressure { gauge_pa: f64 },
    /// The measured sensor height (e.g. a scenario without a pressure log).
    SensorHeight { height_m: f64 },
}

/// What a state is: the simulator's admissibility checks and the apps' look-ups go by role,
/// never by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StateRole {
    /// A position or height, m.
    Position,
    /// A lever angle, rad.
    Angle,
    /// A velocity, m/s, or an angular velocity, rad/s.
    Velocity,
    /// The air in the bellow, mol (eq 3.17): must stay positive. Weighing and level control
    /// estimate it.
    BellowAir,
    /// Air elsewhere on the supply side (line, tank), mol: must stay positive.
    SupplyAir,
    /// A gas temperature, K: must stay positive.
    GasTemperature,
    /// A force element's state (creep, friction), N, or a creep element's position, m.
    Force,
    /// A state of an identified linear block (OE), in the block's own scaling.
    Filter,
    /// An input or output remembered at the start, against which a deviation model works.
    Reference,
}

impl StateRole {
    /// A state of this role must stay strictly positive (amounts of gas, absolute temperatures).
    pub fn must_stay_positive(self) -> bool {
        matches!(
            self,
            Self::BellowAir | Self::SupplyAir | Self::GasTemperature
        )
    }

    /// The role's name as `airsus models --json` prints it.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Position => "position",
            Self::Angle => "angle",
            Self::Velocity => "velocity",
            Self::BellowAir => "bellow_air",
            Self::SupplyAir => "supply_air",
            Self::GasTemperature => "gas_temperature",
            Self::Force => "force",
            Self::Filter => "filter",
            Self::Reference => "reference",
        }
    }
}

/// One state variable: name (with its unit, e.g. `x_m`), unit and role.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StateInfo {
    pub name: &'static str,
    pub unit: &'static str,
    pub role: StateRole,
}

impl StateInfo {
    pub const fn new(name: &'static str, unit: &'static str, role: StateRole) -> Self {
        Self { name, unit, role }
    }
}

/// Description of one freeable parameter (declared in the data crate, with the truck-file keys).
pub use airsus_data::params::ParameterInfo;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    #[error("model {model} has no parameter `{name}`{}; its parameters are: {}", suggestion.as_ref().map(|s| format!(" (did you mean `{s}`?)")).unwrap_or_default(), valid.join(", "))]
    UnknownParameter {
        model: String,
        name: String,
        suggestion: Option<String>,
        valid: Vec<String>,
    },
    #[error(
        "model {model}: parameter `{name}` = {value} is outside its admissible range {lower} to {upper} {unit}"
    )]
    ParameterOutOfRange {
        model: String,
        name: String,
        value: f64,
        lower: f64,
        upper: f64,
        unit: String,
    },
    #[error("model {model}: no static equilibrium for {what}: {reason}")]
    NoEquilibrium {
        model: String,
        what: String,
        reason: String,
    },
    /// The parameters do not make a model of this structure (e.g. an OE block without a
    /// continuous-time equivalent, or an order too high).
    #[error("model {model}: {reason}")]
    InvalidStructure { model: String, reason: String },
    /// `build_model` was asked for a name it does not know.
    #[error("unknown model `{name}`{}; the models are: {}", suggestion.as_ref().map(|s| format!(" (did you mean `{s}`?)")).unwrap_or_default(), valid.join(", "))]
    UnknownModel {
        name: String,
        suggestion: Option<String>,
        valid: Vec<String>,
    },
}

/// A model's named parameters: their descriptions, values and checked setting. Written once
/// for every model built on a truck file ([`crate::params::TruckParams`]); a model whose
/// parameters are its own (the simulator's reference models) implements it itself.
pub trait NamedParameters: Send + Sync + std::fmt::Debug {
    /// Every parameter the estimator may free.
    fn infos(&self) -> &[ParameterInfo];

    /// The value of the parameter called `name`.
    fn value(&self, name: &str) -> Result<f64, ModelError>;

    /// Sets a parameter by short name; rejects unknown names and values outside the range.
    fn set_value(&mut self, name: &str, value: f64) -> Result<(), ModelError>;

    /// The truck parameters (laws included) they live in, if any.
    fn truck(&self) -> Option<&TruckParameters> {
        None
    }
}

/// A full suspension model: state layout, dynamics and output map — the physics. Its named
/// parameters are a [`NamedParameters`] value it hands out; the parameter methods below are
/// written once, here.
pub trait SuspensionModel: BoxClone + Send + Sync + std::fmt::Debug {
    /// Short name as used on the command line (`m1`, `m2`, `m2x`, `m2xh`, `m3`, `truck`).
    fn name(&self) -> &'static str;

    /// One line saying what the model is, with its thesis source.
    fn description(&self) -> &'static str;

    /// The state variables, in state-vector order.
    fn states(&self) -> &[StateInfo];

    /// Names of the state variables, in state-vector order (with units, e.g. `x1_m`).
    fn state_names(&self) -> Vec<&'static str> {
        self.states().iter().map(|s| s.name).collect()
    }

    fn n_states(&self) -> usize {
        self.states().len()
    }

    /// Index of the first state with `role` (e.g. the bellow's air amount).
    fn state_index(&self, role: StateRole) -> Option<usize> {
        self.states().iter().position(|s| s.role == role)
    }

    /// Where the model's named parameters live.
    fn parameters(&self) -> &dyn NamedParameters;

    fn parameters_mut(&mut self) -> &mut dyn NamedParameters;

    /// Recomputes what the model derived from its parameters (precomputed constants); called
    /// after every [`Self::set_parameter`].
    fn parameters_changed(&mut self) {}

    /// Every parameter the estimator may free.
    fn parameter_info(&self) -> &[ParameterInfo] {
        self.parameters().infos()
    }

    fn parameter(&self, name: &str) -> Result<f64, ModelError> {
        self.parameters().value(name)
    }

    /// Sets a parameter by short name; rejects unknown names and values outside the range.
    fn set_parameter(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
        self.parameters_mut().set_value(name, value)?;
        self.parameters_changed();
        Ok(())
    }

    /// The right-hand side `dx = f(t, x, u)`. Must not allocate: the solver calls it millions
    /// of times. `x` and `dx` have length [`Self::n_states`].
    fn rhs(&self, t: f64, x: &[f64], u: &InputSample, dx: &mut [f64]);

    /// The sensor quantities for state `x` under inputs `u`.
    fn output(&self, x: &[f64], u: &InputSample) -> OutputSample;

    /// Whether the supply pressure acts on the state while the valve is closed or exhausting
    /// (a modelled supply line filling from the tank, say). The thesis models use it only in
    /// the fill flow (eq 3.19), so a simulator may ignore supply changes while the valve is
    /// shut; a model that returns `true` must see every change.
    fn uses_supply_while_valve_shut(&self) -> bool {
        false
    }

    /// The coordinate the model's rate-independent hysteresis follows (the bellow height, m,
    /// for a wall friction), or `None` when the model has none. An estimator whose state
    /// estimate jitters with the sensors' noise would drive such a hysteresis by the jitter,
    /// which wears it away (a dithered Dahl element relaxes to zero whatever its history);
    /// with the coordinate it can pass the estimate's motion through a play first and move
    /// the hysteresis only by what is left ([`follow_hysteresis`]).
    ///
    /// [`follow_hysteresis`]: SuspensionModel::follow_hysteresis
    fn hysteresis_coordinate_m(&self, x: &[f64]) -> Option<f64> {
        let _ = x;
        None
    }

    /// Indices of the hysteresis states that [`follow_hysteresis`] moves.
    ///
    /// [`follow_hysteresis`]: SuspensionModel::follow_hysteresis
    fn hysteresis_states(&self) -> &[usize] {
        &[]
    }

    /// Moves the hysteresis states of `x` from their current values along a monotone
    /// displacement of [`hysteresis_coordinate_m`], by their rate-independent law in closed
    /// form (only the path counts, not how fast it was taken).
    ///
    /// [`hysteresis_coordinate_m`]: SuspensionModel::hysteresis_coordinate_m
    fn follow_hysteresis(&self, x: &mut [f64], displacement_m: f64) {
        let _ = (x, displacement_m);
    }

    /// [`initial_state`] with the hysteresis preloaded to `preload` of its range: −1 as left
    /// by lowering the truck onto its height (the wall friction holding it up), +1 by raising
    /// it, 0 unloaded. Models without a hysteresis return [`initial_state`].
    ///
    /// [`initial_state`]: SuspensionModel::initial_state
    fn initial_state_with_hysteresis(
        &self,
        u: &InputSample,
        ic: &InitialCondition,
        preload: f64,
    ) -> Result<Vec<f64>, ModelError> {
        let _ = preload;
        self.initial_state(u, ic)
    }

    /// The state in static equilibrium under `u` that matches `ic`.
    fn initial_state(&self, u: &InputSample, ic: &InitialCondition)
    -> Result<Vec<f64>, ModelError>;

    /// The truck parameters the model was built on and holds its parameters in (its laws
    /// included); `None` for a model that keeps its own (the simulator's reference models).
    fn truck_parameters(&self) -> Option<&TruckParameters> {
        self.parameters().truck()
    }

    /// Writes this model's parameters into `truck`, so that grey-box results can be saved as a
    /// truck file (`airsus_data::write_truck`). Parameters the model does not have are left
    /// untouched.
    ///
    /// Written once: every parameter goes to its declared truck-file home
    /// ([`ParameterInfo::field`]); parameters without one are skipped. A law the model's
    /// parameters belong to replaces `truck`'s law of that family (a model under an orifice
    /// valve law writes an orifice law, whatever law `truck` had).
    fn write_parameters(&self, truck: &mut TruckParameters) {
        if let Some(own) = self.truck_parameters() {
            let families: Vec<_> = self
                .parameter_info()
                .iter()
                .filter_map(|i| i.field.and_then(|f| f.law_family()))
                .collect();
            for family in families {
                match family {
                    LawFamily::EffectiveArea => {
                        truck.bellow.effective_area = own.bellow.effective_area.clone();
                    }
                    LawFamily::GasVolume => truck.bellow.gas_volume = own.bellow.gas_volume.clone(),
                    LawFamily::ValveFlow => {
                        truck.valve = own.valve;
                        truck.valve_law_named = own.valve_law_named;
                    }
                }
            }
        }
        // Each parameter's own truck-file home (`ksd` is the OE force scale in `m2x`, the
        // creep stiffness in `m2xh`): never looked up by name.
        for info in self.parameter_info() {
            if let (Ok(value), Some(field)) = (self.parameter(info.name), info.field) {
                crate::params::set(truck, field, value);
            }
        }
    }
}

/// A boxed copy of a model, for "same model, new parameters" loops over trait objects:
/// implemented once, for every model that is `Clone`.
pub trait BoxClone {
    fn box_clone(&self) -> Box<dyn SuspensionModel>;
}

impl<T: SuspensionModel + Clone + 'static> BoxClone for T {
    fn box_clone(&self) -> Box<dyn SuspensionModel> {
        Box::new(self.clone())
    }
}

impl Clone for Box<dyn SuspensionModel> {
    fn clone(&self) -> Self {
        self.box_clone()
    }
}
