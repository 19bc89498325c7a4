//! One module per subcommand: each has an `Args` struct and a `run` function.

pub mod check;
pub mod generate;
pub mod ident;
pub mod params;
pub mod simulate;
