//! One module per subcommand: each has an `Args` struct and a `run` function.

pub mod check;
pub mod control;
pub mod fit;
pub mod fleet;
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

use std::path::{Path, PathBuf};

use airsus_data::{ColumnMap, Outputs, Resample, ResampleMethod, Run, RunSource};

/// How a run's columns are found in a log that does not use the contract's names (MDF4,
/// Parquet, CAN through a DBC, or a CSV with other headers): the CLI side of a study file's
/// `[run.columns]`, `resample`, `sample_s` and `dbc`.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct RunSourceArgs {
    /// Map run columns onto the log's channels, e.g.
    /// `height_mm=AxleHeight,pressure_kpa=BellowP[bar]`; a unit in brackets is used where the
    /// log gives none. Unmapped columns are read from the channel of their own name.
    #[arg(long, value_name = "COLUMN=CHANNEL[unit],...")]
    pub columns: Option<String>,
    /// Resample channels recorded on different or irregular time bases onto one uniform
    /// base (never done unless asked): `zoh` holds each sample, `linear` interpolates (the
    /// valve is always held). Needs --sample-s.
    #[arg(long, value_enum, requires = "sample_s")]
    pub resample: Option<ResampleArg>,
    /// Sample time to resample onto, s.
    #[arg(long, requires = "resample")]
    pub sample_s: Option<f64>,
    /// DBC file that decodes the CAN frames of a bus-logging MDF4 file or a candump log
    /// (SAE J1939 messages are matched on their PGN when the DBC declares J1939).
    #[arg(long, value_name = "FILE")]
    pub dbc: Option<PathBuf>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ResampleArg {
    Zoh,
    Linear,
}

impl RunSourceArgs {
    pub fn source(&self) -> anyhow::Result<RunSource> {
        let columns = match &self.columns {
            Some(text) => {
                ColumnMap::parse_list(text).map_err(|e| anyhow::anyhow!("--columns: {e}"))?
            }
            None => ColumnMap::default(),
        };
        let method = self.resample.map(|m| match m {
            ResampleArg::Zoh => ResampleMethod::Zoh,
            ResampleArg::Linear => ResampleMethod::Linear,
        });
        let resample = Resample::from_parts(method, self.sample_s)
            .map_err(|e| anyhow::anyhow!("--resample/--sample-s: {e}"))?;
        Ok(RunSource {
            columns,
            resample,
            dbc: self.dbc.clone(),
            load_optional: false,
        })
    }
}

/// Reads a run from any supported log (CSV, MDF4, Parquet, CAN log) and prints on stderr
/// what the reader assumed or did (units, resampling, timestamps).
pub fn read_run_file(path: &Path, outputs: Outputs, source: &RunSource) -> anyhow::Result<Run> {
    // The error names the file already (and where in it).
    let loaded = airsus_logs::read_run(path, outputs, source)?;
    for note in &loaded.notes {
        eprintln!("note: {}: {note}", path.display());
    }
    Ok(loaded.run)
}

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
