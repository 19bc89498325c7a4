//! `airsus fmu`: a model with its parameters as an FMI 2.0 co-simulation FMU for Linux x86-64.
//!
//! The FMU holds `modelDescription.xml` (generated from the model registry), the library
//! `binaries/linux64/airsus_fmu.so` (the `airsus-fmu` cdylib: the FMI C API around airsus' own
//! simulation engine) and `resources/airsus.toml` (model name, the truck file, the parameter
//! values, the initial height). See the `airsus_fmu` crate docs for variables and semantics.
//!
//! The library is not inside the `airsus` executable; it is found, in order, at `--binary`,
//! `$AIRSUS_FMU_LIBRARY`, or beside the executable (`target/release/libairsus_fmu.so` after
//! `cargo build --release -p airsus -p airsus-fmu`), and must be the build of this airsus
//! version (it carries a marker that is checked).

use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow, bail};

use airsus_data::atomic::refuse_overwriting_inputs;
use airsus_fmu::config::DEFAULT_INITIAL_HEIGHT_MM;
use airsus_fmu::description::{Causality, Variability};
use airsus_fmu::package::{check_library, write_fmu};
use airsus_fmu::{ExportConfig, Prepared};

use super::read_truck_listing_defaults;

/// Environment variable naming the FMU library.
pub const LIBRARY_ENV: &str = "AIRSUS_FMU_LIBRARY";
/// The library as cargo names it.
const LIBRARY_FILE: &str = "libairsus_fmu.so";

/// Export a model with its parameters as an FMI 2.0 co-simulation FMU (Linux x86-64).
#[derive(Debug, Clone, clap::Args)]
pub struct FmuArgs {
    /// Model to export: any registered model (`airsus models`).
    #[arg(long)]
    pub model: String,
    /// Truck parameter file (TOML), e.g. an estimated one; omitted *est* keys take the
    /// reference truck's values.
    #[arg(long, value_name = "T.toml")]
    pub truck: PathBuf,
    /// The FMU to write (extension .fmu).
    #[arg(long, value_name = "M.fmu")]
    pub out: PathBuf,
    /// Sensor height of the static equilibrium the FMU starts in, mm: the start value of its
    /// parameter `initial_height_mm`, which a host can change before initialisation.
    #[arg(long, default_value_t = DEFAULT_INITIAL_HEIGHT_MM)]
    pub initial_height_mm: f64,
    /// The FMU library to pack (libairsus_fmu.so); default: $AIRSUS_FMU_LIBRARY, else
    /// libairsus_fmu.so beside the airsus executable.
    #[arg(long, value_name = "PATH")]
    pub binary: Option<PathBuf>,
}

pub fn run(args: &FmuArgs) -> anyhow::Result<()> {
    if args.out.extension().and_then(|e| e.to_str()) != Some("fmu") {
        bail!(
            "--out {}: an FMU's file name must end in .fmu",
            args.out.display()
        );
    }
    if !(args.initial_height_mm.is_finite() && args.initial_height_mm > 0.0) {
        bail!(
            "--initial-height-mm {} must be a positive sensor height in mm",
            args.initial_height_mm
        );
    }
    let library_path = find_library(args.binary.as_deref())?;
    refuse_overwriting_inputs(&args.out, &[&args.truck, &library_path])?;

    let loaded = read_truck_listing_defaults(&args.truck)?;
    let config = ExportConfig::new(&args.model, &loaded.parameters, args.initial_height_mm)
        .with_context(|| format!("model {} from {}", args.model, args.truck.display()))?;
    let prepared = Prepared::new(config)
        .with_context(|| format!("preparing the FMU of model {}", args.model))?;
    for warning in &prepared.warnings {
        eprintln!("warning: {warning}");
    }

    let library = std::fs::read(&library_path)
        .with_context(|| format!("reading the FMU library {}", library_path.display()))?;
    check_library(&library).map_err(|reason| anyhow!("{}: {reason}", library_path.display()))?;
    let size = write_fmu(&args.out, &prepared, &library)
        .with_context(|| format!("writing {}", args.out.display()))?;

    let tunable = prepared
        .variables
        .iter()
        .filter(|v| v.causality == Causality::Parameter && v.variability == Variability::Tunable)
        .map(|v| v.name.as_str())
        .collect::<Vec<_>>();
    eprintln!(
        "{}: FMI 2.0 co-simulation FMU of model {} ({}), linux64, {:.1} MB, GUID {}",
        args.out.display(),
        prepared.config.model,
        prepared.model.description(),
        size as f64 / 1e6,
        prepared.guid
    );
    eprintln!("  inputs: wheel_load_kg, valve (0/1/2), supply_kpa, road_mm, road_rate_mm_s");
    eprintln!("  outputs: height_mm, pressure_kpa");
    eprintln!(
        "  parameters: initial_height_mm = {} (fixed); tunable: {}",
        prepared.config.initial_height_mm,
        tunable.join(", ")
    );
    eprintln!("  library: {}", library_path.display());
    Ok(())
}

/// `--binary`, else `$AIRSUS_FMU_LIBRARY`, else `libairsus_fmu.so` beside the executable (or in
/// its `deps/`, where cargo leaves a dependency's cdylib).
fn find_library(explicit: Option<&Path>) -> anyhow::Result<PathBuf> {
    if let Some(path) = explicit {
        if path.is_file() {
            return Ok(path.to_path_buf());
        }
        bail!("--binary {}: no such file", path.display());
    }
    if let Some(value) = std::env::var_os(LIBRARY_ENV) {
        let path = PathBuf::from(value);
        if path.is_file() {
            return Ok(path);
        }
        bail!("${LIBRARY_ENV} = {}: no such file", path.display());
    }
    let exe = std::env::current_exe().context("locating the airsus executable")?;
    let dir = exe.parent().unwrap_or(Path::new("."));
    for candidate in [dir.join(LIBRARY_FILE), dir.join("deps").join(LIBRARY_FILE)] {
        if candidate.is_file() {
            return Ok(candidate);
        }
    }
    bail!(
        "the FMU library {LIBRARY_FILE} is not beside {}: build it with `cargo build --release -p airsus -p airsus-fmu` (it lands in target/release/), or name it with --binary or ${LIBRARY_ENV}",
        exe.display()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_library_names_the_build_command() {
        let err = find_library(Some(Path::new("/nonexistent/libairsus_fmu.so")))
            .unwrap_err()
            .to_string();
        assert!(err.contains("no such file"), "{err}");
    }

    #[test]
    fn the_output_must_be_an_fmu_and_a_fake_library_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let truck = dir.path().join("truck.toml");
        airsus_data::write_truck(&truck, &airsus_data::TruckParameters::reference()).unwrap();
        let args = FmuArgs {
            model: "m2".to_owned(),
            truck: truck.clone(),
            out: dir.path().join("m2.zip"),
            initial_height_mm: 240.0,
            binary: None,
        };
        let err = run(&args).unwrap_err().to_string();
        assert!(err.contains(".fmu"), "{err}");
        let library = dir.path().join("lib.so");
        std::fs::write(&library, b"x").unwrap();
        let args = FmuArgs {
            out: truck.with_extension("fmu"),
            binary: Some(library.clone()),
            ..args
        };
        // A fake library is refused before anything is written.
        let err = format!("{:#}", run(&args).unwrap_err());
        assert!(err.contains("ELF"), "{err}");
        assert!(!truck.with_extension("fmu").exists());
        assert!(
            std::fs::read_to_string(&truck)
                .unwrap()
                .contains("[environment]")
        );
    }
}
