//! `airsus generate`: the reference experiments from the built-in virtual truck.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};

use airsus_truck::experiments::generate_variant;

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
    /// Member of the virtual truck family to generate with: 0 (the default) is the reference
    /// truck; every other number is a truck whose laws and values differ within a model
    /// line's spread (effective-area shape, gas volume, valve law and flow, friction, creep,
    /// masses, tire, damping); from 4 on the laws' forms differ too (a spline area, an
    /// area-integral volume). The nominal truck.toml is the same for all; truth/ holds the
    /// variant's own values.
    #[arg(long, default_value_t = 0)]
    pub variant: u32,
}

pub fn run(args: &GenerateArgs) -> anyhow::Result<()> {
    let started = Instant::now();
    let bar = ProgressBar::new_spinner();
    // indicatif draws only on a terminal; in a pipe the bar stays silent.
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    let study = generate_variant(&args.out, args.seed, args.variant, &mut |step: &str| {
        bar.set_message(step.to_owned());
        bar.tick();
    })
    .with_context(|| format!("generating the reference study into {}", args.out.display()))?;
    bar.finish_and_clear();
    eprintln!(
        "wrote {} files to {} in {:.1} s (seed {}, virtual truck variant {})",
        study.files.len(),
        args.out.display(),
        started.elapsed().as_secs_f64(),
        args.seed,
        args.variant
    );
    println!("{}", study.study.display());
    println!("{}", study.study_valve.display());
    Ok(())
}
