use std::path::{Path, PathBuf};

use clap::Args;

use airsus_data::{
    Outputs, Run, RunSource, read_discharge, read_force_map, read_run_with, read_study, read_truck,
};
use airsus_logs::LogFormat;

use super::RunSourceArgs;

#[derive(Args, Debug)]
pub struct CheckArgs {
    /// Files to check. The kind is told from the content: a TOML file with `truck =` is a
    /// study (every file it names is checked too), any other TOML a truck file; a CSV with
    /// `tank_kpa` is a tank discharge, with `force_n` a force map, otherwise a run.
    /// An MDF4, Parquet or CAN log is a run, read as --columns, --resample and --dbc say.
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<PathBuf>,
    #[command(flatten)]
    pub source: RunSourceArgs,
}

pub fn run(args: &CheckArgs) -> anyhow::Result<()> {
    let source = args.source.source()?;
    let mut failures = 0;
    for file in &args.files {
        match check_file(file, &source) {
            Ok(summary) => println!("ok    {}: {summary}", file.display()),
            Err(err) => {
                failures += 1;
                println!("error {err:#}");
            }
        }
    }
    if failures > 0 {
        anyhow::bail!(
            "{failures} of {} file(s) failed the check",
            args.files.len()
        );
    }
    Ok(())
}

fn check_file(path: &Path, source: &RunSource) -> anyhow::Result<String> {
    let is_toml = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    let format = airsus_logs::detect_format(path)?;
    if format != LogFormat::Csv || (!source.is_plain() && !is_toml) {
        let loaded = airsus_logs::read_run(path, Outputs::IfPresent, source)?;
        let mut summary = describe_run(&loaded.run, format.name());
        for note in &loaded.notes {
            summary.push_str(&format!("; {note}"));
        }
        return Ok(summary);
    }
    if is_toml {
        let text =
            std::fs::read_to_string(path).map_err(|e| airsus_data::DataError::io(path, e))?;
        let is_study = text
            .lines()
            .any(|l| l.trim_start().starts_with("truck") && l.contains('='));
        if is_study {
            return check_study(path);
        }
        let loaded = read_truck(path)?;
        let defaulted: Vec<_> = loaded.defaulted.iter().map(|d| d.key.as_str()).collect();
        return Ok(if defaulted.is_empty() {
            "truck file, every key given".to_owned()
        } else {
            format!(
                "truck file; to be estimated or defaulted: {}",
                defaulted.join(", ")
            )
        });
    }
    let header = first_line(path)?;
    let has = |name: &str| {
        header
            .split(',')
            .any(|h| h.trim().trim_matches('"') == name)
    };
    if has("tank_kpa") {
        let d = read_discharge(path)?;
        Ok(format!(
            "tank discharge, {} samples at {} s",
            d.time_s.len(),
            d.sample_time_s
        ))
    } else if has("force_n") {
        let m = read_force_map(path)?;
        Ok(format!("bellow force map, {} points", m.len()))
    } else {
        let run = read_run_with(path, Outputs::IfPresent)?;
        Ok(describe_run(&run, format.name()))
    }
}

fn describe_run(run: &Run, format: &str) -> String {
    format!(
        "run ({format}), {} samples at {} s ({:.1} min){}",
        run.len(),
        // A log's float time stamps leave digits below the nanosecond that say nothing.
        (run.sample_time_s * 1e9).round() / 1e9,
        (run.time_s[run.len() - 1] - run.time_s[0]) / 60.0,
        if run.outputs.is_some() {
            ""
        } else {
            ", inputs only"
        }
    )
}

fn check_study(path: &Path) -> anyhow::Result<String> {
    let study = read_study(path)?;
    read_truck(&study.truck)?;
    for run in &study.runs {
        let data = airsus_logs::read_run(&run.file, Outputs::Required, &run.source)?.run;
        for truth in run.truth.iter().chain(&run.truth_logged_input) {
            airsus_study::input::read_truth(truth, &data)?;
        }
    }
    if let Some(map) = &study.force_map {
        read_force_map(map)?;
    }
    for d in &study.discharges {
        read_discharge(&d.file)?;
    }
    Ok(format!(
        "study: truck file, {} run(s) ({} with a truth file), {} force map, {} tank discharge(s), all valid",
        study.runs.len(),
        study.runs.iter().filter(|r| r.truth.is_some()).count(),
        if study.force_map.is_some() { "a" } else { "no" },
        study.discharges.len()
    ))
}

fn first_line(path: &Path) -> anyhow::Result<String> {
    let bytes = std::fs::read(path).map_err(|e| airsus_data::DataError::io(path, e))?;
    let first = bytes.split(|&b| b == b'\n').next().unwrap_or_default();
    Ok(String::from_utf8_lossy(first).into_owned())
}
