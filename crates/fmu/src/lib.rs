//! # airsus-fmu: any airsus model as an FMI 2.0 co-simulation FMU
//!
//! Controller developers simulate in Simulink, Dymola or OpenModelica; the standard way to hand
//! them a model is a Functional Mock-up Unit (FMI 2.0, <https://fmi-standard.org>). This crate is
//! both halves of that:
//!
//! * the **binary** (`cdylib`, packed as `binaries/linux64/airsus_fmu.so`): the FMI 2.0 C API
//!   ([`fmi2`](crate#the-c-api), all 44 `fmi2*` functions) around one [`slave::Slave`] per
//!   instance, which runs the project's own engine ([`airsus_sim::simulate`]) for every
//!   `fmi2DoStep`;
//! * the **export** (`rlib`, used by `airsus fmu`): the resources file
//!   ([`config::ExportConfig`]), `modelDescription.xml` generated from the model registry
//!   ([`description`]) and the zip archive ([`package`]).
//!
//! One binary serves every model: `fmi2Instantiate` reads `resources/airsus.toml` (model name,
//! the truck file, the parameter values, the initial height), rebuilds the model with
//! [`airsus_truck::models::build_any_model`] and regenerates the model description; the GUID is
//! a fingerprint of both ([`config::Prepared`]), so a `modelDescription.xml`, resources file or
//! binary from another export is refused at instantiation instead of simulating the wrong model.
//!
//! ## Variables
//!
//! | name | causality | type | unit | meaning |
//! |---|---|---|---|---|
//! | `wheel_load_kg` | input | Real | kg | mass a scale under the wheel shows |
//! | `valve` | input | Integer | – | 0 closed, 1 fill, 2 exhaust |
//! | `supply_kpa` | input | Real | kPa | supply (actuator tank) gauge pressure |
//! | `road_mm` | input | Real | mm | road height under the wheel |
//! | `road_rate_mm_s` | input | Real | mm/s | the road height's rate (default 0: held) |
//! | `height_mm` | output | Real | mm | axle-to-chassis height (the sensor) |
//! | `pressure_kpa` | output | Real | kPa | bellow gauge pressure |
//! | `initial_height_mm` | parameter, fixed | Real | mm | sensor height of the starting equilibrium |
//! | `p0`, `kw`, … | parameter, tunable | Real | registry | every parameter the model names |
//!
//! ## Semantics
//!
//! * Inputs are held constant over a communication step (zero-order hold, as `airsus simulate`
//!   holds a run's samples), but for the road, which moves at `road_rate_mm_s` from `road_mm`
//!   over the step (a host that feeds the slope towards its next road sample gets the road
//!   followed linearly, as `airsus simulate` follows a run's road, and a damped tire, `cw`,
//!   feels the rate; 0, the default, holds it). Outputs are computed from the state and the current inputs (the
//!   sensor height feeds the wheel load through the lever flex, eq 3.14).
//! * `fmi2ExitInitializationMode` puts the model in static equilibrium at `initial_height_mm`
//!   under the inputs set at that moment — `airsus simulate --initial-height-mm`, i.e. what
//!   `simulate` does with a run's first measured height.
//! * `fmi2DoStep(t, h)` integrates from the current state over `[t, t + h]` with the adaptive
//!   solver and tolerances of `airsus simulate` (rtol 1e-6; a host's tighter tolerance wins);
//!   any `h > 0` works.
//! * Tunable parameters may be changed between steps; the next step uses them. The fixed
//!   `initial_height_mm` can be set until `fmi2ExitInitializationMode`.
//! * Errors never cross the C boundary as panics: every function reports through the status
//!   code and the logger callback; a failed step leaves the instance in the error state, from
//!   which `fmi2Reset` or `fmi2SetFMUstate` bring it back.
//!
//! ## The C API
//!
//! `src/fmi2.rs` holds every `extern "C"` function and all of the crate's unsafe code. Model
//! Exchange functions exist (FMI hosts resolve every symbol) and return `fmi2Error`.

pub mod config;
pub mod description;
mod fmi2;
mod hash;
pub mod package;
pub mod slave;
pub mod units;
pub mod uri;

pub use config::{ExportConfig, FmuError, ParameterValue, Prepared, RESOURCE_FILE};

/// `<CoSimulation modelIdentifier>`: the binary inside the FMU is
/// `binaries/linux64/<MODEL_IDENTIFIER>.so`.
pub const MODEL_IDENTIFIER: &str = "airsus_fmu";

/// Bumped whenever the variables, value references or resources format change, so that a
/// binary and an exporter of different layouts never pass for each other.
pub const LAYOUT_VERSION: u32 = 2;

/// A string the FMU library carries and `airsus fmu` looks for before packing a library: the
/// crate version and the layout. (`LAYOUT_VERSION` is repeated literally here: `concat!` takes
/// literals only.)
pub const BUILD_MARKER: &str =
    concat!("airsus-fmu-build:", env!("CARGO_PKG_VERSION"), ":layout-2;");
