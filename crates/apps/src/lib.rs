//! # airsus-apps: what the models are for
//!
//! The thesis modelled the air suspension to enable two things (thesis 1.1–1.2, SPEC §7); this
//! crate does them, against the models and the virtual truck:
//! - [`weigh`]: axle-load estimation from bellow pressure and height, static (the force
//!   balance inverted, with propagated uncertainty) and online (an extended Kalman filter on
//!   Model 2 with the load as a random-walk state);
//! - [`control`]: ride-height (level) control with the 3-state valve — which must not be
//!   pulsed at high frequency (thesis 2.2.1) — closed-loop on any model or the virtual truck;
//! - [`fleet`]: a virtual fleet of the truck family, each truck logging its days at 10 Hz
//!   with a levelling controller at work, some with a growing air leak;
//! - [`road`]: the response to road input (a bump, an ISO 8608 random road), and Model 2
//!   linearised about its equilibrium.
//!
//! All quantities are SI unless a name says otherwise (`_mm`, `_kpa`, `_kmh`).

pub mod control;
pub mod error;
pub mod fleet;
pub mod plot;
pub mod road;
pub mod weigh;

pub use error::AppError;
