//! Submodels (SPEC §2, thesis ch. 3): small pure functions, one physical law each.
//!
//! All take and return SI quantities (m, m/s, N, Pa, mol, K). Pressures are absolute where
//! the name says `abs` and gauge (relative to ambient) where it says `gauge`. The full models
//! compose these; tests check each against hand-computed values.
//!
//! The laws a truck file chooses between — effective area, gas volume, valve flow — are
//! values of `airsus_data::laws`; the models evaluate them through those values.

pub mod bellow;
pub mod damper;
pub mod friction;
pub mod gas;
pub mod lever;
pub mod tire;

pub use bellow::{
    EFFECTIVE_AREA_RANGE_M, bellow_force_n, effective_area_clamped_m2, effective_area_m2,
    effective_area_slope_m, first_upward_crossing_m,
};
pub use damper::Damper;
pub use friction::hinge_friction_n;
pub use gas::{
    AIR_GAMMA, GasEnergyBalance, MIN_VOLUME_M3, air_amount_mol, gas_temperature_rate,
    pressure_abs_pa,
};
pub use lever::{
    axle_height_from_bellow_m, bellow_height_from_angle_m, bellow_height_from_axle_m,
    bellow_height_from_sensor_m, lever_gain, sensor_height_m,
};
pub use tire::Tire;
