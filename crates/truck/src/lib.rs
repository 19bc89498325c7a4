//! # airsus-truck: the virtual truck
//!
//! No real truck logs ship with airsus, so this crate is the project's "real" truck: a richer
//! one-corner simulator than any model structure it is used to test, its sensors, and the
//! reference experiments of thesis 5.1 (SPEC §6).

pub mod closed_loop;
pub mod ecu;
pub mod error;
pub mod experiments;
pub mod lab;
pub mod model;
pub mod models;
pub mod physics;
pub mod road;
pub mod scenario;
pub mod sensors;
pub mod truth;
