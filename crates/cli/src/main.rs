//! `airsus`: model and identify the air suspension of heavy trucks from the command line.
//!
//! The binary is thin: arguments are parsed here, validated into library objects, and every
//! command lives in `commands/`.

use clap::{Parser, Subcommand};

mod commands;

const AFTER_HELP: &str = "\
Typical workflow:
  airsus study --builtin --out out/          the whole pipeline on the built-in virtual truck
  airsus study study.toml --out out/         the same on your own files
  airsus params --builtin > truck.toml       start from the reference truck
  airsus models [--json]                     the models, their parameters and states
  airsus check study.toml                    validate a study and every file it names
  airsus generate --out ref/                 the virtual truck's reference experiments
  airsus simulate --model m2 --truck ref/truck.toml --run ref/ds1.csv --out sim.csv
  airsus greybox --model m2 --free p0,p1,p2,p3,p4,m2,ig --truck ref/truck.toml \\
      --run ref/ds1.csv --out est.toml
  airsus ident --structure oe --nb 2 --nf 2 --nk 1 \\
      --inputs wheel_load_kg,pressure_kpa --output height_mm ds1.csv
  airsus fmu --model m2 --truck est.toml --out m2.fmu   an FMU for Simulink, Dymola, FMPy

File formats (runs, force maps, tank discharges, study and truck files) are described in the
README and fixed by the project's SPEC §5. All commands exit non-zero with a message naming
the file, line and column when an input is malformed.";

#[derive(Parser, Debug)]
#[command(
    name = "airsus",
    version,
    about = "Model, identify and validate truck air suspensions (thesis models QCM 1/2, grey-box, ARX/ARMAX/OE/BJ)",
    after_help = AFTER_HELP
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print the built-in reference truck, or check and print a truck parameter file.
    Params(commands::params::ParamsArgs),
    /// Validate data-contract files (runs, force maps, discharges, truck and study files).
    Check(commands::check::CheckArgs),
    /// Estimate a linear black-box model (ARX, ARMAX, OE, BJ) from columns of a CSV file.
    Ident(commands::ident::IdentArgs),
    /// Simulate a model over a run's inputs and write the simulated outputs as a run file.
    Simulate(commands::simulate::SimulateArgs),
    /// List the models by name with their parameters (units, bounds, reference values) and states.
    Models(commands::models::ModelsArgs),
    /// Export a model with its parameters as an FMI 2.0 co-simulation FMU (Linux x86-64).
    Fmu(commands::fmu::FmuArgs),
    /// Grey-box estimation: fit any named subset of a model's parameters to one or more runs.
    Greybox(commands::greybox::GreyboxArgs),
    /// Submodel fits from lab and run data (thesis 5.2): cross-section, effective area, valve, slow dynamics.
    Fit(commands::fit::FitArgs),
    /// The whole thesis pipeline: submodel fits, grey-box estimation of every model, validation, report.
    Study(commands::study::StudyArgs),
    /// Estimate the wheel load over time from bellow pressure and height (static or EKF).
    Weigh(commands::weigh::WeighArgs),
    /// Level controllers for the 3-state valve, compared in closed loop.
    Control(commands::control::ControlArgs),
    /// Drive a model over a bump or an ISO 8608 random road.
    Road(commands::road::RoadArgs),
    /// Generate the reference experiments (data-sets 1-4, lab data, study) with the virtual truck.
    Generate(commands::generate::GenerateArgs),
    /// Fleet-scale data: `airsus fleet generate` writes a virtual fleet as a Parquet dataset.
    Fleet(commands::fleet::FleetArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Params(args) => commands::params::run(args),
        Command::Check(args) => commands::check::run(args),
        Command::Ident(args) => commands::ident::run(args),
        Command::Simulate(args) => commands::simulate::run(args),
        Command::Fmu(args) => commands::fmu::run(args),
        Command::Models(args) => commands::models::run(args),
        Command::Generate(args) => commands::generate::run(args),
        Command::Fleet(args) => commands::fleet::run(args),
        Command::Greybox(args) => commands::greybox::run(args),
        Command::Fit(args) => commands::fit::run(args),
        Command::Study(args) => commands::study::run(args),
        Command::Weigh(args) => commands::weigh::run(args),
        Command::Control(args) => commands::control::run(args),
        Command::Road(args) => commands::road::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn cli_definition_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn the_study_estimates_every_model_with_60_iterations_by_default() {
        // The README's main command; these defaults are what its numbers were measured with.
        let cli = Cli::try_parse_from(["airsus", "study", "--builtin", "--out", "out"]).unwrap();
        let Command::Study(args) = cli.command else {
            panic!("parsed as another command");
        };
        assert_eq!(args.models, ["m1", "m2", "m2x", "m2xh", "m3", "truck"]);
        assert_eq!(args.max_iterations, 60);
        assert_eq!(args.seed, 1);
        assert!(args.builtin && args.study.is_none());
    }
}
