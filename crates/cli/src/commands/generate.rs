//! `airsus generate`: the reference experiments from the built-in virtual truck.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};

use airsus_truck::experiments::generate;

/// Generate the thesis' reference experiments with the virtual truck: data-sets 1-4, a bellow
/// force map, four tank discharges, their noise-free truth, a nominal truck.toml and the
/// study files that tie them together.
#[derive(Debug, Clone, clap::Args)]
pub struct GenerateArgs {
    /// Output folder (created if needed; existing files of the same names are replaced).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Seed of every random detail (step sizes, ramp times, pulse lengths, sensor noise): the
    /// same seed writes the same bytes.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

pub fn run(args: &GenerateArgs) -> anyhow::Result<()> {
    let started = Instant::now();
    let bar = ProgressBar::new_spinner();
    // indicatif draws only on a terminal; in a pipe the bar stays silent.
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    let study = generate(&args.out, args.seed, &mut |step: &str| {
        bar.set_message(step.to_owned());
        bar.tick();
    })
    .with_context(|| format!("generating the reference study into {}", args.out.display()))?;
    bar.finish_and_clear();
    eprintln!(
        "wrote {} files to {} in {:.1} s (seed {})",
        study.files.len(),
        args.out.display(),
        started.elapsed().as_secs_f64(),
        args.seed
    );
    println!("{}", study.study.display());
    println!("{}", study.study_valve.display());
    Ok(())
}
