//! One module per subcommand: each has an `Args` struct and a `run` function.

pub mod check;
pub mod control;
pub mod fit;
pub mod fmu;
pub mod generate;
pub mod greybox;
pub mod ident;
pub mod models;
pub mod params;
pub mod road;
pub mod simulate;
pub mod study;
pub mod weigh;
