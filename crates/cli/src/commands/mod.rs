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

/// Reads a truck file and lists on stderr the *est* keys it left out, with the value used.
pub fn read_truck_listing_defaults(
    path: &std::path::Path,
) -> Result<airsus_data::LoadedTruck, airsus_data::DataError> {
    let loaded = airsus_data::read_truck(path)?;
    if !loaded.defaulted.is_empty() {
        eprintln!(
            "truck {}: {} key(s) not in the file, using defaults:",
            path.display(),
            loaded.defaulted.len()
        );
        for key in &loaded.defaulted {
            eprintln!("  {} = {}", key.key, key.value);
        }
    }
    Ok(loaded)
}
