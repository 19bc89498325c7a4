//! # airsus-model: parameters, submodels and the full suspension models
//!
//! Submodels (SPEC §2, thesis ch. 3) are small pure functions in [`submodels`]; the thesis
//! models (SPEC §3, thesis ch. 4) implement one trait, [`SuspensionModel`], and are built by
//! name with [`build_model`]:
//!
//! | name | model | state |
//! |---|---|---|
//! | `m1` | [`Model1`], QCM 1 (eq 3.4/4.1) | `x1, x2, v1, v2, n` |
//! | `m2` | [`Model2`], QCM 2 (eq 3.6–3.13/4.2, derivation corrected) | `x, α, ẋ, α̇, n` |
//! | `m2x` | Model 2 + OE slow force from load change (eq 4.3/4.4) | + OE states, `load_ref_kg` |
//! | `m2xh` | Model 2 + creep force from bellow height (thesis 6.2) | + `f_creep_n` |
//! | `m3` | [`Model3`], gas/valve + OE height (eq 4.5) | `n`, OE states, references |
//!
//! Parameters are addressed by the SPEC §5 short names ([`params`]); every model writes its
//! parameters back into a truck file with [`SuspensionModel::write_parameters`].

mod corner;
pub mod factory;
pub mod linear_block;
pub mod m1;
pub mod m2;
pub mod m3;
pub mod mechanics;
pub mod model;
pub mod params;
pub mod submodels;

pub use corner::MIN_SPRUNG_MASS_KG;
pub use factory::{Excitation, ModelEntry, THESIS_MODELS, build_model, find_model};
pub use linear_block::LinearBlock;
pub use m1::Model1;
pub use m2::Model2;
pub use m3::Model3;
pub use model::{
    InitialCondition, InputSample, ModelError, NamedParameters, OutputSample, ParameterInfo,
    StateInfo, StateRole, SuspensionModel,
};
