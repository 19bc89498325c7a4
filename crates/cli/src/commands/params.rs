use std::path::PathBuf;

use airsus_data::atomic::refuse_overwriting_inputs;
use anyhow::Context;
use clap::Args;

use airsus_data::{TruckParameters, read_truck, truck_to_toml, write_truck};

#[derive(Args, Debug)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["builtin", "truck"])))]
pub struct ParamsArgs {
    /// Print the built-in reference truck of the SPEC as a truck file.
    #[arg(long)]
    pub builtin: bool,
    /// Check a truck parameter file and print it with every value it resolves to.
    #[arg(long, value_name = "TRUCK.toml")]
    pub truck: Option<PathBuf>,
    /// Write the file here (atomically) instead of printing it.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

pub fn run(args: &ParamsArgs) -> anyhow::Result<()> {
    if let (Some(out), Some(truck)) = (&args.out, &args.truck) {
        refuse_overwriting_inputs(out, &[truck])?;
    }
    let parameters = match &args.truck {
        Some(path) => {
            let loaded = read_truck(path)?;
            for d in &loaded.defaulted {
                eprintln!(
                    "note: {}: `{}` not given, using {}",
                    path.display(),
                    d.key,
                    d.value
                );
            }
            loaded.parameters
        }
        None => TruckParameters::reference(),
    };
    match &args.out {
        Some(out) => {
            write_truck(out, &parameters).with_context(|| format!("writing {}", out.display()))?
        }
        None => print!("{}", truck_to_toml(&parameters)),
    }
    Ok(())
}
