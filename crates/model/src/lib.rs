//! # airsus-model: parameters, submodels and the full suspension models
//!
//! Submodels (SPEC §2, thesis ch. 3) are small pure functions; the four thesis models
//! (SPEC §3, thesis ch. 4) implement one trait, [`SuspensionModel`].

pub mod model;

pub use model::{InitialCondition, InputSample, ModelError, OutputSample, ParameterInfo, SuspensionModel};
