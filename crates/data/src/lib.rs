//! # airsus-data: the data contract
//!
//! Readers and writers for every file of SPEC §5 — runs, bellow force maps, tank discharges,
//! the study file and the truck parameter file — with the exact column and key names fixed
//! there. Files speak the units engineers log in (kg, kPa gauge, mm); everything this crate
//! hands out is in SI units (kg, Pa gauge, m, s).
//!
//! Bad input is an error, never a panic: every [`DataError`] names the file, and where it can
//! the line and column, and says what was expected. Writers are atomic (write, then rename).
//!
//! This crate knows no models: it sits at the bottom of the workspace.

pub mod atomic;
pub mod channels;
pub mod error;
pub mod lab;
pub mod laws;
pub mod params;
pub mod run;
pub mod source;
pub mod study;
pub mod table;
pub mod time_axis;
pub mod toml_file;
pub mod truck;
pub mod units;

pub use channels::{ChannelSet, LogChannel, TimeBase, run_from_channels};
pub use error::{DataError, DataErrorKind, Location};
pub use lab::{
    ForceMap, TankDischarge, read_discharge, read_force_map, write_discharge, write_force_map,
};
pub use laws::{EffectiveAreaLaw, GasVolumeLaw, LawFamily, ValveFlowLaw};
pub use run::{
    LoadedRun, Outputs, Run, RunInputs, RunOutputs, RunPrecision, ValveState, read_run,
    read_run_with, write_run, write_run_with_precision,
};
pub use source::{ChannelRef, ColumnMap, Resample, ResampleMethod, RunSource};
pub use study::{Channel, Role, Study, StudyDischarge, StudyRun, read_study, write_study};
pub use truck::{
    BellowParameters, DamperTable, DefaultedKey, EffectValues, Environment, Geometry, LoadedTruck,
    MassParameters, REFERENCE_AREA_POLY_M2, SUPPLY_LINE_VOLUME_M3, SlowDynamics, TireParameters,
    TruckParameters, read_truck, truck_to_toml, write_truck,
};
