//! A study's files, loaded and checked up front: nothing is estimated before every file has
//! been read, so a typo in the last run fails in a second, not after a minute of fitting.

use std::path::{Path, PathBuf};

use airsus_data::{
    Channel, ForceMap, Outputs, Role, Run, RunOutputs, Study, TankDischarge, TruckParameters,
    read_discharge, read_force_map, read_run, read_study, read_truck,
};

use crate::StudyError;

/// One run of the study with its data.
#[derive(Debug, Clone)]
pub struct StudyRunData {
    pub name: String,
    pub file: PathBuf,
    pub role: Role,
    pub run: Run,
    /// The noise-free outputs on the run's time axis, when the study names a truth file.
    pub truth: Option<RunOutputs>,
    /// The noise-free outputs of the run as its log tells it (load changes the log does not
    /// show left out), when the study names such a file (`truth_logged_input`).
    pub truth_logged_input: Option<RunOutputs>,
    /// The file's format (`CSV`, `MDF4`, `Parquet`, `CAN log`).
    pub format: &'static str,
    /// What reading it assumed or did (units, resampling, timestamps), for the report.
    pub notes: Vec<String>,
}

impl StudyRunData {
    /// Whether the valve moves during the run (what makes flow parameters identifiable).
    pub fn valve_action(&self) -> bool {
        self.run.valve_action()
    }
}

#[derive(Debug, Clone)]
pub struct DischargeData {
    pub name: String,
    pub channel: Channel,
    pub tank_volume_m3: f64,
    pub temperature_k: f64,
    pub role: Role,
    pub discharge: TankDischarge,
}

/// Everything a study needs, in memory.
#[derive(Debug, Clone)]
pub struct StudyInput {
    /// How the study is named in the report (its path, or the built-in's description).
    pub label: String,
    pub truck_file: PathBuf,
    pub truck: TruckParameters,
    /// Estimable keys the truck file left out, with the values used.
    pub defaulted: Vec<String>,
    pub runs: Vec<StudyRunData>,
    pub force_map: Option<ForceMap>,
    pub discharges: Vec<DischargeData>,
    /// Every file read: the study file (when there is one) and the files it names. The
    /// pipeline refuses to write over any of them.
    pub files: Vec<PathBuf>,
}

impl StudyInput {
    pub fn run(&self, name: &str) -> Option<&StudyRunData> {
        self.runs.iter().find(|r| r.name == name)
    }

    /// Names of the runs with `role`.
    pub fn runs_with(&self, role: Role) -> Vec<String> {
        self.runs
            .iter()
            .filter(|r| r.role == role)
            .map(|r| r.name.clone())
            .collect()
    }
}

/// Loads a study file and every file it names.
pub fn load_study(path: &Path) -> Result<StudyInput, StudyError> {
    let study = read_study(path)?;
    let mut input = load_parts(path.display().to_string(), &study)?;
    input.files.insert(0, path.to_path_buf());
    Ok(input)
}

/// A run's truth file: its outputs, on exactly the run's time axis.
pub fn read_truth(path: &Path, run: &Run) -> Result<RunOutputs, StudyError> {
    let truth = read_run(path)?;
    let same_axis = truth.time_s.len() == run.time_s.len()
        && truth
            .time_s
            .iter()
            .zip(&run.time_s)
            .all(|(a, b)| (a - b).abs() <= 1e-9 * (1.0 + b.abs()));
    if !same_axis {
        return Err(StudyError::Truth {
            truth: path.to_path_buf(),
            reason: format!(
                "its time axis ({} samples) is not that of run `{}` ({} samples)",
                truth.time_s.len(),
                run.name,
                run.time_s.len()
            ),
        });
    }
    truth.outputs.ok_or_else(|| StudyError::Truth {
        truth: path.to_path_buf(),
        reason: "it has no height_mm and pressure_kpa columns".to_owned(),
    })
}

/// Loads the files a parsed study names; `label` names it in the report.
pub fn load_parts(label: String, study: &Study) -> Result<StudyInput, StudyError> {
    let loaded = read_truck(&study.truck)?;
    let runs = study
        .runs
        .iter()
        .map(|r| {
            let loaded = airsus_logs::read_run(&r.file, Outputs::Required, &r.source)?;
            let mut run = loaded.run;
            run.name = r.name.clone();
            let truth = r
                .truth
                .as_deref()
                .map(|path| read_truth(path, &run))
                .transpose()?;
            let truth_logged_input = r
                .truth_logged_input
                .as_deref()
                .map(|path| read_truth(path, &run))
                .transpose()?;
            Ok(StudyRunData {
                name: r.name.clone(),
                file: r.file.clone(),
                role: r.role,
                run,
                truth,
                truth_logged_input,
                format: loaded.format,
                notes: loaded.notes,
            })
        })
        .collect::<Result<Vec<_>, StudyError>>()?;
    let force_map = study.force_map.as_deref().map(read_force_map).transpose()?;
    let discharges = study
        .discharges
        .iter()
        .map(|d| {
            Ok(DischargeData {
                name: d
                    .file
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default(),
                channel: d.channel,
                tank_volume_m3: d.tank_volume_m3,
                temperature_k: d.temperature_k,
                role: d.role,
                discharge: read_discharge(&d.file)?,
            })
        })
        .collect::<Result<Vec<_>, StudyError>>()?;
    Ok(StudyInput {
        label,
        truck_file: study.truck.clone(),
        truck: loaded.parameters,
        defaulted: loaded
            .defaulted
            .iter()
            .map(|d| format!("{} = {}", d.key, d.value))
            .collect(),
        runs,
        force_map,
        discharges,
        files: study.files().into_iter().map(Path::to_path_buf).collect(),
    })
}
