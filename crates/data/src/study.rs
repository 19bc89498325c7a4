//! The study file (SPEC §5): one TOML file that ties a truck, its runs and its lab data
//! together, so one command runs the whole thesis pipeline on it. Relative paths are resolved
//! against the study file's folder, never the working directory.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::atomic::write_text_atomically;
use crate::error::{DataError, DataErrorKind, Location};
use crate::source::{ChannelRef, ColumnMap, Resample, ResampleMethod, RunSource};
use crate::toml_file::{
    TableSchema, check_finite, check_keys, deserialize, find_key_line, parse_toml,
};
use crate::units::M3_PER_L;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    Estimation,
    Validation,
}

impl Role {
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Estimation => "estimation",
            Role::Validation => "validation",
        }
    }
}

/// The valve channel a tank discharge went through.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Channel {
    Fill,
    Exhaust,
}

impl Channel {
    pub fn as_str(self) -> &'static str {
        match self {
            Channel::Fill => "fill",
            Channel::Exhaust => "exhaust",
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct StudyRun {
    pub name: String,
    /// Absolute, or relative to the working directory when the study path was.
    pub file: PathBuf,
    pub role: Role,
    /// The run's noise-free outputs, when known (optional key `truth`, ours: a generated
    /// run's truth file). The study reports the noise ceiling from it: the NRMSE of the
    /// truth against the measurements, the best any model can score.
    pub truth: Option<PathBuf>,
    /// The noise-free outputs of the run as its log tells it (optional key
    /// `truth_logged_input`; ours: a generated run whose truck felt load changes the log does
    /// not show). The study reports a second ceiling from it: the best a model driven by the
    /// logged load can score.
    pub truth_logged_input: Option<PathBuf>,
    /// How the file's channels map onto the run columns (`[run.columns]`, `resample`,
    /// `sample_s`, `dbc`); the contract's own names when absent.
    pub source: RunSource,
}

#[derive(Debug, Clone, PartialEq)]
pub struct StudyDischarge {
    pub file: PathBuf,
    pub channel: Channel,
    pub tank_volume_m3: f64,
    pub temperature_k: f64,
    pub role: Role,
}

/// A loaded study with every path resolved.
#[derive(Debug, Clone, PartialEq)]
pub struct Study {
    pub truck: PathBuf,
    pub runs: Vec<StudyRun>,
    pub force_map: Option<PathBuf>,
    pub discharges: Vec<StudyDischarge>,
}

impl Study {
    /// Every file the study names: truck, runs, force map, discharges.
    pub fn files(&self) -> Vec<&Path> {
        std::iter::once(self.truck.as_path())
            .chain(self.runs.iter().map(|r| r.file.as_path()))
            .chain(self.runs.iter().filter_map(|r| r.truth.as_deref()))
            .chain(
                self.runs
                    .iter()
                    .filter_map(|r| r.truth_logged_input.as_deref()),
            )
            .chain(self.runs.iter().filter_map(|r| r.source.dbc.as_deref()))
            .chain(self.force_map.as_deref())
            .chain(self.discharges.iter().map(|d| d.file.as_path()))
            .collect()
    }
}

const SCHEMA: &[TableSchema] = &[
    TableSchema {
        name: "",
        keys: &["truck", "run", "force_map", "discharge"],
    },
    TableSchema {
        name: "run",
        keys: &[
            "name",
            "file",
            "role",
            "truth",
            "truth_logged_input",
            "columns",
            "resample",
            "sample_s",
            "dbc",
        ],
    },
    TableSchema {
        name: "run.columns",
        keys: &crate::run::columns::ALL,
    },
    TableSchema {
        name: "run.columns.*",
        keys: &["channel", "unit"],
    },
    TableSchema {
        name: "force_map",
        keys: &["file"],
    },
    TableSchema {
        name: "discharge",
        keys: &["file", "channel", "tank_volume_l", "temperature_k", "role"],
    },
];

#[derive(Deserialize)]
struct FileRun {
    name: String,
    file: String,
    role: Role,
    truth: Option<String>,
    truth_logged_input: Option<String>,
    #[serde(default)]
    columns: std::collections::BTreeMap<String, FileChannel>,
    resample: Option<ResampleMethod>,
    sample_s: Option<f64>,
    dbc: Option<String>,
}

/// `height_mm = "AxleHeight"` or `pressure_kpa = { channel = "BellowP", unit = "bar" }`.
#[derive(Deserialize)]
#[serde(untagged)]
enum FileChannel {
    Name(String),
    Full {
        channel: String,
        unit: Option<String>,
    },
}

#[derive(Deserialize)]
struct FileForceMap {
    file: String,
}

#[derive(Deserialize)]
struct FileDischarge {
    file: String,
    channel: Channel,
    tank_volume_l: f64,
    temperature_k: f64,
    role: Role,
}

#[derive(Deserialize)]
struct StudyFile {
    truck: String,
    #[serde(default)]
    run: Vec<FileRun>,
    force_map: Option<FileForceMap>,
    #[serde(default)]
    discharge: Vec<FileDischarge>,
}

pub fn read_study(path: &Path) -> Result<Study, DataError> {
    let text = std::fs::read_to_string(path).map_err(|e| DataError::io(path, e))?;
    parse_study(&text, path)
}

/// Parses study text; relative paths are resolved against `path`'s folder.
pub fn parse_study(text: &str, path: &Path) -> Result<Study, DataError> {
    let table = parse_toml(text, path)?;
    check_keys(&table, SCHEMA, text, path)?;
    check_finite(&table, text, path)?;
    let file: StudyFile = deserialize(text, path)?;
    let base = path.parent().unwrap_or(Path::new(""));
    let resolve = |p: &str| -> PathBuf {
        let p = Path::new(p);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            base.join(p)
        }
    };
    let invalid = |section: &str, key: &str, value: String, reason: &str| {
        let mut loc = Location::file(path);
        if let Some(line) = find_key_line(text, section, key) {
            loc = loc.line(line);
        }
        DataError::new(
            loc,
            DataErrorKind::InvalidValue {
                key: format!("{section}.{key}"),
                value,
                reason: reason.to_owned(),
            },
        )
    };

    if file.run.is_empty() {
        return Err(DataError::new(
            Location::file(path),
            DataErrorKind::MissingKey {
                key: "[[run]]".to_owned(),
                expected: "at least one run".to_owned(),
            },
        ));
    }
    for (i, run) in file.run.iter().enumerate() {
        if file.run[..i].iter().any(|r| r.name == run.name) {
            return Err(invalid(
                "run",
                "name",
                format!("{:?}", run.name),
                "run names must be unique",
            ));
        }
    }
    for d in &file.discharge {
        if !(d.tank_volume_l > 0.0 && d.tank_volume_l < 1e4) {
            return Err(invalid(
                "discharge",
                "tank_volume_l",
                d.tank_volume_l.to_string(),
                "expected a positive tank volume in litres (below 10000)",
            ));
        }
        if !(200.0..=400.0).contains(&d.temperature_k) {
            return Err(invalid(
                "discharge",
                "temperature_k",
                d.temperature_k.to_string(),
                "outside the plausible range 200 to 400 K (not °C)",
            ));
        }
    }

    let mut runs = Vec::with_capacity(file.run.len());
    for r in file.run {
        let mut columns = ColumnMap::default();
        for (column, channel) in r.columns {
            let channel = match channel {
                FileChannel::Name(channel) => ChannelRef {
                    channel,
                    unit: None,
                },
                FileChannel::Full { channel, unit } => ChannelRef { channel, unit },
            };
            columns.insert(&column, channel).map_err(|reason| {
                invalid("run.columns", &column, format!("{:?}", r.name), &reason)
            })?;
        }
        let resample = Resample::from_parts(r.resample, r.sample_s).map_err(|reason| {
            let key = if r.sample_s.is_some() && r.resample.is_some() {
                "sample_s"
            } else if r.resample.is_some() {
                "resample"
            } else {
                "sample_s"
            };
            invalid("run", key, format!("{:?}", r.name), &reason)
        })?;
        runs.push(StudyRun {
            file: resolve(&r.file),
            name: r.name,
            role: r.role,
            truth: r.truth.as_deref().map(resolve),
            truth_logged_input: r.truth_logged_input.as_deref().map(resolve),
            source: RunSource {
                columns,
                resample,
                dbc: r.dbc.as_deref().map(resolve),
                load_optional: false,
            },
        });
    }

    Ok(Study {
        truck: resolve(&file.truck),
        runs,
        force_map: file.force_map.map(|f| resolve(&f.file)),
        discharges: file
            .discharge
            .into_iter()
            .map(|d| StudyDischarge {
                file: resolve(&d.file),
                channel: d.channel,
                tank_volume_m3: d.tank_volume_l * M3_PER_L,
                temperature_k: d.temperature_k,
                role: d.role,
            })
            .collect(),
    })
}

/// The study as TOML, with paths written relative to `base` where they lie below it.
pub fn study_to_toml(study: &Study, base: &Path) -> String {
    let rel = |p: &Path| -> String {
        p.strip_prefix(base)
            .unwrap_or(p)
            .to_string_lossy()
            .replace('\\', "/")
    };
    let quote = |s: &str| toml::Value::String(s.to_owned()).to_string();
    let mut s = String::new();
    let _ = writeln!(s, "truck = {}", quote(&rel(&study.truck)));
    for run in &study.runs {
        let _ = writeln!(s, "\n[[run]]");
        let _ = writeln!(s, "name = {}", quote(&run.name));
        let _ = writeln!(s, "file = {}", quote(&rel(&run.file)));
        let _ = writeln!(s, "role = \"{}\"", run.role.as_str());
        if let Some(truth) = &run.truth {
            let _ = writeln!(s, "truth = {}  # noise-free outputs", quote(&rel(truth)));
        }
        if let Some(truth) = &run.truth_logged_input {
            let _ = writeln!(
                s,
                "truth_logged_input = {}  # noise-free outputs, the load as logged",
                quote(&rel(truth))
            );
        }
        if let Some(dbc) = &run.source.dbc {
            let _ = writeln!(s, "dbc = {}", quote(&rel(dbc)));
        }
        if let Some(resample) = &run.source.resample {
            let _ = writeln!(s, "resample = \"{}\"", resample.method.as_str());
            let _ = writeln!(s, "sample_s = {:?}", resample.sample_s);
        }
        if !run.source.columns.is_empty() {
            let _ = writeln!(s, "[run.columns]");
            for (column, channel) in run.source.columns.iter() {
                match &channel.unit {
                    None => {
                        let _ = writeln!(s, "{column} = {}", quote(&channel.channel));
                    }
                    Some(unit) => {
                        let _ = writeln!(
                            s,
                            "{column} = {{ channel = {}, unit = {} }}",
                            quote(&channel.channel),
                            quote(unit)
                        );
                    }
                }
            }
        }
    }
    if let Some(map) = &study.force_map {
        let _ = writeln!(s, "\n[force_map]");
        let _ = writeln!(s, "file = {}", quote(&rel(map)));
    }
    for d in &study.discharges {
        let _ = writeln!(s, "\n[[discharge]]");
        let _ = writeln!(s, "file = {}", quote(&rel(&d.file)));
        let _ = writeln!(s, "channel = \"{}\"", d.channel.as_str());
        let _ = writeln!(s, "tank_volume_l = {:?}", d.tank_volume_m3 / M3_PER_L);
        let _ = writeln!(s, "temperature_k = {:?}", d.temperature_k);
        let _ = writeln!(s, "role = \"{}\"", d.role.as_str());
    }
    s
}

pub fn write_study(path: &Path, study: &Study) -> Result<(), DataError> {
    let base = path.parent().unwrap_or(Path::new(""));
    write_text_atomically(path, &study_to_toml(study, base))
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXAMPLE: &str = r#"truck = "truck.toml"                     # nominal parameters, below
[[run]]
name = "data-set 1"
file = "ds1.csv"
role = "estimation"                      # or "validation"
[force_map]
file = "force_map.csv"
[[discharge]]
file = "fill_a.csv"
channel = "fill"                         # or "exhaust"
tank_volume_l = 20.0
temperature_k = 293.15
role = "estimation"                      # or "validation"
"#;

    #[test]
    fn spec_example_loads_with_paths_resolved_against_the_study_folder() {
        let study = parse_study(EXAMPLE, Path::new("/data/truck7/study.toml")).unwrap();
        assert_eq!(study.truck, Path::new("/data/truck7/truck.toml"));
        assert_eq!(study.runs[0].file, Path::new("/data/truck7/ds1.csv"));
        assert_eq!(study.runs[0].role, Role::Estimation);
        assert_eq!(
            study.force_map.as_deref(),
            Some(Path::new("/data/truck7/force_map.csv"))
        );
        let d = &study.discharges[0];
        assert_eq!(d.channel, Channel::Fill);
        assert!((d.tank_volume_m3 - 0.020).abs() < 1e-15);
    }

    #[test]
    fn absolute_paths_are_kept() {
        let text = EXAMPLE.replace("\"ds1.csv\"", "\"/elsewhere/ds1.csv\"");
        let study = parse_study(&text, Path::new("/data/study.toml")).unwrap();
        assert_eq!(study.runs[0].file, Path::new("/elsewhere/ds1.csv"));
    }

    #[test]
    fn round_trips_through_toml() {
        let study = parse_study(EXAMPLE, Path::new("/data/study.toml")).unwrap();
        let text = study_to_toml(&study, Path::new("/data"));
        assert_eq!(
            parse_study(&text, Path::new("/data/study.toml")).unwrap(),
            study
        );
        // With both truth files (a generated data-set 2).
        let with_truths = EXAMPLE.replace(
            "role = \"estimation\"                      # or \"validation\"\n[force_map]",
            "role = \"estimation\"\ntruth = \"truth/ds1.csv\"\ntruth_logged_input = \"truth/ds1_logged_input.csv\"\n[force_map]",
        );
        let study = parse_study(&with_truths, Path::new("/data/study.toml")).unwrap();
        assert_eq!(
            study.runs[0].truth_logged_input.as_deref(),
            Some(Path::new("/data/truth/ds1_logged_input.csv"))
        );
        assert!(
            study
                .files()
                .contains(&Path::new("/data/truth/ds1_logged_input.csv"))
        );
        let text = study_to_toml(&study, Path::new("/data"));
        assert_eq!(
            parse_study(&text, Path::new("/data/study.toml")).unwrap(),
            study
        );
    }

    #[test]
    fn bad_role_and_unknown_key_and_negative_volume_are_errors() {
        let err = parse_study(
            &EXAMPLE.replace(
                "role = \"estimation\"                      # or \"validation\"\n[force_map]",
                "role = \"estimaton\"\n[force_map]",
            ),
            Path::new("s.toml"),
        )
        .unwrap_err();
        assert_eq!(err.location.line, Some(5));
        assert!(err.to_string().contains("estimaton"), "{err}");
        let err = parse_study(
            &EXAMPLE.replace("channel = ", "chanel = "),
            Path::new("s.toml"),
        )
        .unwrap_err();
        assert!(
            err.to_string().contains("(did you mean `channel`?)"),
            "{err}"
        );
        let err = parse_study(
            &EXAMPLE.replace("tank_volume_l = 20.0", "tank_volume_l = -20.0"),
            Path::new("s.toml"),
        )
        .unwrap_err();
        assert_eq!(err.location.line, Some(11));
    }

    #[test]
    fn a_run_maps_log_channels_and_resamples() {
        let text = format!(
            "{EXAMPLE}\n[[run]]\nname = \"drive\"\nfile = \"drive.mf4\"\nrole = \"validation\"\n\
             dbc = \"truck.dbc\"\nresample = \"linear\"\nsample_s = 0.1\n[run.columns]\n\
             height_mm = \"AxleHeight\"\npressure_kpa = {{ channel = \"BellowP\", unit = \"bar\" }}\n"
        );
        let study = parse_study(&text, Path::new("/data/study.toml")).unwrap();
        let source = &study.runs[1].source;
        assert_eq!(source.columns.channel_for("height_mm"), "AxleHeight");
        assert_eq!(
            source.columns.get("pressure_kpa").unwrap().unit.as_deref(),
            Some("bar")
        );
        assert_eq!(source.dbc.as_deref(), Some(Path::new("/data/truck.dbc")));
        assert_eq!(
            source.resample,
            Some(Resample::new(ResampleMethod::Linear, 0.1).unwrap())
        );
        assert!(study.runs[0].source.is_plain());
        let back = study_to_toml(&study, Path::new("/data"));
        assert_eq!(
            parse_study(&back, Path::new("/data/study.toml")).unwrap(),
            study
        );

        let err = parse_study(
            &text.replace("height_mm = \"AxleHeight\"", "hight_mm = \"AxleHeight\""),
            Path::new("s.toml"),
        )
        .unwrap_err();
        assert!(
            err.to_string().contains("did you mean `height_mm`"),
            "{err}"
        );
        let err = parse_study(
            &text.replace("unit = \"bar\"", "units = \"bar\""),
            Path::new("s.toml"),
        )
        .unwrap_err();
        assert!(err.to_string().contains("did you mean `unit`"), "{err}");
        let err =
            parse_study(&text.replace("sample_s = 0.1\n", ""), Path::new("s.toml")).unwrap_err();
        assert!(err.to_string().contains("needs `sample_s`"), "{err}");
    }

    #[test]
    fn a_study_needs_a_run_and_unique_names() {
        let err = parse_study("truck = \"t.toml\"\n", Path::new("s.toml")).unwrap_err();
        assert!(err.to_string().contains("at least one run"), "{err}");
        let twice = format!(
            "{EXAMPLE}\n[[run]]\nname = \"data-set 1\"\nfile = \"x.csv\"\nrole = \"validation\"\n"
        );
        assert!(parse_study(&twice, Path::new("s.toml")).is_err());
    }
}
