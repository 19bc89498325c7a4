//! Everything a study computes, as plain serialisable data: this is `results.json`.
//!
//! Keys are stable (snake_case field names, units in the names); a change that renames or
//! removes a key bumps [`SCHEMA_VERSION`]. NRMSE values are percent (thesis eq 3.33); `null`
//! means "not computed" and is always explained by an entry in a `notes` or `error` field.

use serde::{Deserialize, Serialize};

/// Version of the `results.json` layout.
pub const SCHEMA_VERSION: u32 = 1;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StudyResults {
    pub schema_version: u32,
    pub airsus_version: String,
    /// The study file, or `built-in virtual truck (seed N)`.
    pub study: String,
    /// The nominal truck file the study started from.
    pub truck: String,
    /// How every simulation of a run starts: `equilibrium` (static, at the first measured
    /// height), `joint` (history states fitted to the first 10 s; in estimation runs refitted
    /// with the parameters in turn) or `prefix` (the same, but in estimation runs fitted once
    /// under the start values and held). Validation runs start from their prefix with the
    /// parameters fixed under both.
    #[serde(default = "equilibrium")]
    pub initial_state: String,
    /// The prefix the runs' starts are fitted to, s (`--prefix-s`; 10 in files written
    /// before it was recorded).
    #[serde(default = "default_prefix_s")]
    pub prefix_s: f64,
    /// How the logged load reached the models: `estimate` (each change eased, see
    /// `ModelResult::load_transitions`) or `logged`; absent in files written before it was.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_ramp: Option<String>,
    /// Seconds after each logged load change the estimation's loss left out (0: none).
    #[serde(default)]
    pub exclude_after_load_change_s: f64,
    /// How a validation run's logged load changes were eased: `fitted` (each over its own
    /// time, fitted with the parameters fixed) or `common`; absent in files written before.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub validation_transitions: Option<String>,
    /// Whether a model's pooled estimate was kept where it explained an estimation run worse
    /// than the start values did (`--allow-trades`); `false`: refitted with the traded runs
    /// weighted more, and in files written before it was recorded.
    #[serde(default)]
    pub allow_trades: bool,
    pub runs: Vec<RunInfo>,
    pub submodels: SubmodelResults,
    /// One entry per estimation protocol (which runs the grey-box fits used).
    pub protocols: Vec<ProtocolResult>,
    /// Wall-clock time of the whole pipeline, s.
    pub elapsed_s: f64,
    /// What the study concludes from these numbers (the report renders it, decides nothing).
    #[serde(default)]
    pub findings: Findings,
}

fn one() -> usize {
    1
}

fn default_prefix_s() -> f64 {
    10.0
}

fn equilibrium() -> String {
    "equilibrium".to_owned()
}

/// The study's conclusions, decided by the study from the numbers above.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Findings {
    /// Which model to use for what, ranked on the last protocol's validation runs.
    pub uses: Vec<ModelUse>,
    /// What valve-action data buys: the first protocol against the last, on the valve runs
    /// neither estimated on.
    pub valve_data: Option<ValveDataGain>,
}

/// The models ranked for one purpose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelUse {
    /// `axle_load` (runs without valve action: weighing reads the static balance) or
    /// `level_control` (runs with valve action: a level controller acts through the valve).
    pub purpose: String,
    pub protocol: String,
    /// The validation runs ranked on.
    pub runs: Vec<String>,
    /// Best first: mean NRMSE of height and pressure over `runs`.
    pub ranking: Vec<RankedModel>,
    /// When the virtual truck's own structure ranks first (it generated the data), the best
    /// of the others: what a user of real data would choose among.
    pub best_other_than_truck: Option<RankedModel>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RankedModel {
    pub model: String,
    pub mean_nrmse_percent: f64,
}

/// Per model and output, mean NRMSE before (first protocol) and after (last protocol).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ValveDataGain {
    pub runs: Vec<String>,
    pub before_protocol: String,
    pub after_protocol: String,
    pub models: Vec<ModelGain>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelGain {
    pub model: String,
    pub height_before_percent: f64,
    pub height_after_percent: f64,
    pub pressure_before_percent: f64,
    pub pressure_after_percent: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunInfo {
    pub name: String,
    pub file: String,
    /// `estimation` or `validation`, as the study file says.
    pub role: String,
    pub samples: usize,
    pub duration_s: f64,
    /// Whether the valve moves during the run (what makes flow parameters identifiable).
    pub valve_action: bool,
    /// The thesis data-set this run reproduces (the built-in study's `data-set N`), for the
    /// thesis' numbers beside ours; `null` for other runs.
    #[serde(default)]
    pub thesis_data_set: Option<u32>,
    /// The noise floor: the best NRMSE any model can reach on this run.
    #[serde(default)]
    pub ceiling: Option<NoiseCeiling>,
    /// The run file's format: `CSV`, `MDF4`, `Parquet` or `CAN log`.
    #[serde(default = "csv_format")]
    pub format: String,
    /// What reading the file assumed or did: units taken as the contract's, channels
    /// resampled (how, onto what), timestamps made relative. Empty for a contract CSV.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

fn csv_format() -> String {
    "CSV".to_owned()
}

/// The best NRMSE any model can reach on a run: its noise-free outputs against the
/// measurements (`source` = `truth`), or, without truth, the fit of an error of the size of
/// the noise estimated from the measurements themselves (`estimated`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseCeiling {
    /// `truth` or `estimated`.
    pub source: String,
    pub height_percent: f64,
    pub pressure_percent: f64,
    /// The measurement noise's standard deviation (from the truth, or estimated), mm.
    pub height_noise_std_mm: f64,
    /// Likewise, kPa.
    pub pressure_noise_std_kpa: f64,
    /// Where the truck felt load changes its log does not show (the built-in data-set 2's
    /// mishap): the ceiling of a model driven by the logged load, the noise-free outputs of
    /// the run as its log tells it against the measurements. Absent when the log shows
    /// every change (the ceiling above is then that ceiling too).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub logged_input: Option<LoggedInputCeiling>,
}

/// [`NoiseCeiling::logged_input`]: NRMSE, %.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LoggedInputCeiling {
    pub height_percent: f64,
    pub pressure_percent: f64,
}

impl NoiseCeiling {
    /// How a ceiling shows beside the fits: `~` when estimated from the measurements.
    pub fn mark(&self) -> &'static str {
        if self.source == "truth" { "" } else { "~" }
    }
}

/// A named number with its unit and, where known, its standard deviation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NamedValue {
    pub name: String,
    pub unit: String,
    pub value: f64,
    pub std: Option<f64>,
}

/// One submodel fit of thesis 5.2.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SubmodelFit {
    /// `cross_section`, `effective_area`, `fill_valve`, `exhaust_valve`, `slow_dynamics`.
    pub name: String,
    pub description: String,
    pub parameters: Vec<NamedValue>,
    pub nrmse_estimation_percent: Option<f64>,
    pub nrmse_validation_percent: Option<f64>,
    pub notes: Vec<String>,
    /// Set when the fit could not be done; the other fields are then empty.
    pub error: Option<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct SubmodelResults {
    pub fits: Vec<SubmodelFit>,
}

impl SubmodelResults {
    pub fn get(&self, name: &str) -> Option<&SubmodelFit> {
        self.fits.iter().find(|f| f.name == name)
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProtocolResult {
    /// `thesis` (estimation on data-set 1) or `valve` (plus data-set 3), or the study's own.
    pub name: String,
    pub description: String,
    pub estimation_runs: Vec<String>,
    pub models: Vec<ModelResult>,
}

/// A parameter the grey-box fit freed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParameterEstimate {
    pub name: String,
    pub unit: String,
    pub nominal: f64,
    pub estimate: f64,
    /// One standard deviation as if the residuals were white.
    pub std: Option<f64>,
    /// One standard deviation allowing for residuals correlated in time (Newey–West over
    /// each estimation run): the one to believe where a model's misfit is slow, as it mostly
    /// is; biased low by up to a quarter.
    pub std_correlated: Option<f64>,
    /// False when the estimation runs cannot determine it; it is then kept at its start
    /// value: the nominal one, or the draw of the global stage's start that won.
    pub identifiable: bool,
    /// Why not, when not (`no sensitivity: ...`, `only a combination with a0 is
    /// determined`, `standard deviation 240 % of its scale (limit 100 %)`); `null` when
    /// identifiable.
    pub not_identifiable_because: Option<String>,
}

/// NRMSE of both outputs, percent.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OutputFit {
    pub height_percent: f64,
    pub pressure_percent: f64,
}

/// Residual analysis of one output against one input (eq 3.35/3.36), or the residual's
/// autocorrelation (`input` = `self`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResidualSummary {
    /// `height` or `pressure`.
    pub output: String,
    /// `wheel_load`, `valve`, `supply` or `self`.
    pub input: String,
    pub confidence: f64,
    pub band: f64,
    pub lags_outside: usize,
    pub lags_total: usize,
    /// Largest |r| over the band; above 1 the residual is correlated somewhere.
    pub worst_ratio: f64,
    /// Why it could not be computed (e.g. a constant input).
    pub note: Option<String>,
}

/// How one model did on one run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunFit {
    pub run: String,
    pub role: String,
    /// With the nominal (start) parameters.
    pub nominal: Option<OutputFit>,
    /// With the estimated parameters.
    pub estimated: Option<OutputFit>,
    /// An estimation run's fit by the pooled estimate, where that explained some estimation
    /// run worse than the start values did (issue #12): the estimate the guard refitted, or
    /// kept with `--allow-trades`. Absent where it traded nothing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pooled: Option<OutputFit>,
    pub residuals: Vec<ResidualSummary>,
    pub error: Option<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelResult {
    pub model: String,
    pub description: String,
    pub free: Vec<String>,
    pub estimates: Vec<ParameterEstimate>,
    /// The optimiser's stop reason (`converged`, `max_iterations`, ...).
    pub stop_reason: Option<String>,
    pub simulations: usize,
    /// Local fits the global stage ran, the start's included (1: the plain local fit, or no
    /// screened point explained the runs better than the start, see
    /// [`Self::screened_better`]).
    #[serde(default = "one")]
    pub starts: usize,
    /// The loss (mean squared normalised residual) of every start's local optimum, best
    /// first: their spread says how many optima the fit has.
    #[serde(default)]
    pub local_optima_losses: Vec<f64>,
    /// Trial simulations of the estimation that failed (each counted as a large loss), of
    /// [`Self::simulations`].
    pub failed_simulations: usize,
    /// Starts of the global stage whose local fit failed as a whole (of [`Self::starts`]).
    pub failed_starts: usize,
    /// Design points the global stage screened by their loss before its local fits (0:
    /// none, the starts were not screened).
    #[serde(default)]
    pub screened_starts: usize,
    /// Of [`Self::screened_starts`], the points whose runs did not all simulate.
    #[serde(default)]
    pub screened_failed: usize,
    /// Of [`Self::screened_starts`], the points that explained the estimation runs better
    /// than the start did: the local fits beside the start's began at the best of them.
    #[serde(default)]
    pub screened_better: usize,
    pub estimation_time_s: f64,
    /// The norm of the loss gradient over the free parameters at the estimate (scaled
    /// coordinates: offsets from nominal in units of each parameter's scale); small against
    /// the loss means a true stationary point.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gradient_norm: Option<f64>,
    /// The logged load's steps eased over this common transition time, s, fitted to the
    /// estimation runs (`--load-ramp estimate`): where the validation runs start from, and
    /// what they keep with `--validation-transitions common`; absent when the load was used
    /// as logged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_ramp_s: Option<f64>,
    /// Each logged load change of an estimation run eased over its own fitted time (the
    /// validation runs' are in `validation_transitions`); empty when no change has its own
    /// time.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub load_transitions: Vec<LoadTransitions>,
    /// Each logged load change of a validation run eased over its own time, fitted to that
    /// run with the parameters fixed (`--validation-transitions fitted`); empty otherwise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub validation_transitions: Vec<LoadTransitions>,
    pub runs: Vec<RunFit>,
    /// The estimated truck file, relative to the output folder.
    pub truck_file: Option<String>,
    pub notes: Vec<String>,
    /// Set when the model failed as a whole (its runs may be empty).
    pub error: Option<String>,
}

/// The transition time of each logged load change of one estimation run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LoadTransitions {
    pub run: String,
    /// In the order of the run's logged changes, s.
    pub durations_s: Vec<f64>,
}

impl ModelResult {
    /// A result for `model` with nothing computed yet.
    pub fn new(model: &str) -> Self {
        Self {
            model: model.to_owned(),
            description: String::new(),
            free: vec![],
            estimates: vec![],
            stop_reason: None,
            simulations: 0,
            starts: 1,
            local_optima_losses: vec![],
            failed_simulations: 0,
            failed_starts: 0,
            screened_starts: 0,
            screened_failed: 0,
            screened_better: 0,
            estimation_time_s: 0.0,
            gradient_norm: None,
            load_ramp_s: None,
            load_transitions: vec![],
            validation_transitions: vec![],
            runs: vec![],
            truck_file: None,
            notes: vec![],
            error: None,
        }
    }

    pub fn run(&self, name: &str) -> Option<&RunFit> {
        self.runs.iter().find(|r| r.run == name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> StudyResults {
        StudyResults {
            schema_version: SCHEMA_VERSION,
            airsus_version: "0.1.0".to_owned(),
            study: "study.toml".to_owned(),
            truck: "truck.toml".to_owned(),
            initial_state: "equilibrium".to_owned(),
            prefix_s: 10.0,
            load_ramp: Some("estimate".to_owned()),
            exclude_after_load_change_s: 0.0,
            validation_transitions: None,
            allow_trades: false,
            runs: vec![RunInfo {
                name: "data-set 1".to_owned(),
                file: "ds1.csv".to_owned(),
                role: "estimation".to_owned(),
                samples: 15_001,
                duration_s: 1500.0,
                valve_action: false,
                thesis_data_set: Some(1),
                ceiling: Some(NoiseCeiling {
                    source: "truth".to_owned(),
                    height_percent: 98.9,
                    pressure_percent: 99.4,
                    height_noise_std_mm: 0.15,
                    pressure_noise_std_kpa: 0.2,
                    logged_input: Some(LoggedInputCeiling {
                        height_percent: 92.8,
                        pressure_percent: 90.8,
                    }),
                }),
                format: "CSV".to_owned(),
                notes: Vec::new(),
            }],
            submodels: SubmodelResults {
                fits: vec![SubmodelFit {
                    name: "cross_section".to_owned(),
                    description: "A(h) = A0 + A1 h".to_owned(),
                    parameters: vec![NamedValue {
                        name: "a0".to_owned(),
                        unit: "m2".to_owned(),
                        value: 0.25,
                        std: Some(1e-3),
                    }],
                    nrmse_estimation_percent: Some(90.85),
                    nrmse_validation_percent: None,
                    notes: vec![],
                    error: None,
                }],
            },
            protocols: vec![ProtocolResult {
                name: "thesis".to_owned(),
                description: "estimation on data-set 1".to_owned(),
                estimation_runs: vec!["data-set 1".to_owned()],
                models: vec![ModelResult {
                    model: "m2".to_owned(),
                    description: "Model 2".to_owned(),
                    free: vec!["m2".to_owned()],
                    estimates: vec![],
                    stop_reason: Some("converged".to_owned()),
                    simulations: 42,
                    starts: 3,
                    local_optima_losses: vec![0.01, 0.01, 0.5],
                    failed_simulations: 0,
                    failed_starts: 0,
                    screened_starts: 32,
                    screened_failed: 3,
                    screened_better: 2,
                    estimation_time_s: 0.2,
                    gradient_norm: Some(2.5e-6),
                    load_ramp_s: Some(5.5),
                    load_transitions: vec![LoadTransitions {
                        run: "data-set 1".to_owned(),
                        durations_s: vec![4.9, 6.6],
                    }],
                    validation_transitions: vec![],
                    runs: vec![RunFit {
                        run: "data-set 1".to_owned(),
                        role: "estimation".to_owned(),
                        nominal: Some(OutputFit {
                            height_percent: 65.18,
                            pressure_percent: 65.77,
                        }),
                        estimated: None,
                        pooled: None,
                        residuals: vec![],
                        error: Some("failed".to_owned()),
                    }],
                    truck_file: None,
                    notes: vec![],
                    error: None,
                }],
            }],
            elapsed_s: 1.5,
            findings: Findings {
                uses: vec![ModelUse {
                    purpose: "axle_load".to_owned(),
                    protocol: "thesis".to_owned(),
                    runs: vec!["data-set 2".to_owned()],
                    ranking: vec![RankedModel {
                        model: "m2".to_owned(),
                        mean_nrmse_percent: 80.0,
                    }],
                    best_other_than_truck: None,
                }],
                valve_data: Some(ValveDataGain {
                    runs: vec!["data-set 4".to_owned()],
                    before_protocol: "thesis".to_owned(),
                    after_protocol: "valve".to_owned(),
                    models: vec![ModelGain {
                        model: "m2".to_owned(),
                        height_before_percent: 5.0,
                        height_after_percent: 85.0,
                        pressure_before_percent: -76.0,
                        pressure_after_percent: -48.0,
                    }],
                }),
            },
        }
    }

    #[test]
    fn results_round_trip_through_json() {
        let results = sample();
        let json = serde_json::to_string_pretty(&results).unwrap();
        assert!(json.contains("\"height_percent\": 65.18"));
        let back: StudyResults = serde_json::from_str(&json).unwrap();
        assert_eq!(back, results);
    }

    /// Every key path of a JSON value, arrays as `[]`.
    fn key_paths(
        value: &serde_json::Value,
        prefix: &str,
        out: &mut std::collections::BTreeSet<String>,
    ) {
        match value {
            serde_json::Value::Object(map) => {
                for (k, v) in map {
                    let path = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    out.insert(path.clone());
                    key_paths(v, &path, out);
                }
            }
            serde_json::Value::Array(items) => {
                for v in items {
                    key_paths(v, &format!("{prefix}[]"), out);
                }
            }
            _ => {}
        }
    }

    /// results.json is read by other people's scripts: its key names are a contract. A change
    /// here must bump SCHEMA_VERSION and the README's results.json section.
    #[test]
    fn results_json_key_names_are_pinned() {
        let mut r = sample();
        let model = &mut r.protocols[0].models[0];
        model.estimates.push(ParameterEstimate {
            name: "m2".to_owned(),
            unit: "kg".to_owned(),
            nominal: 520.0,
            estimate: 560.0,
            std: Some(3.0),
            std_correlated: Some(30.0),
            identifiable: true,
            not_identifiable_because: None,
        });
        model.runs[0].estimated = model.runs[0].nominal;
        model.runs[0].pooled = model.runs[0].nominal;
        model.validation_transitions.push(LoadTransitions {
            run: "data-set 2".to_owned(),
            durations_s: vec![5.1],
        });
        model.runs[0].residuals.push(ResidualSummary {
            output: "height".to_owned(),
            input: "self".to_owned(),
            confidence: 0.99,
            band: 0.02,
            lags_outside: 1,
            lags_total: 50,
            worst_ratio: 1.1,
            note: None,
        });
        r.validation_transitions = Some("fitted".to_owned());
        let mut keys = std::collections::BTreeSet::new();
        key_paths(&serde_json::to_value(&r).unwrap(), "", &mut keys);
        let expected = [
            "airsus_version",
            "elapsed_s",
            "findings",
            "exclude_after_load_change_s",
            "initial_state",
            "prefix_s",
            "load_ramp",
            "validation_transitions",
            "allow_trades",
            "findings.uses",
            "findings.uses[].best_other_than_truck",
            "findings.uses[].protocol",
            "findings.uses[].purpose",
            "findings.uses[].ranking",
            "findings.uses[].ranking[].mean_nrmse_percent",
            "findings.uses[].ranking[].model",
            "findings.uses[].runs",
            "findings.valve_data",
            "findings.valve_data.after_protocol",
            "findings.valve_data.before_protocol",
            "findings.valve_data.models",
            "findings.valve_data.models[].height_after_percent",
            "findings.valve_data.models[].height_before_percent",
            "findings.valve_data.models[].model",
            "findings.valve_data.models[].pressure_after_percent",
            "findings.valve_data.models[].pressure_before_percent",
            "findings.valve_data.runs",
            "protocols",
            "protocols[].description",
            "protocols[].estimation_runs",
            "protocols[].models",
            "protocols[].models[].description",
            "protocols[].models[].error",
            "protocols[].models[].estimates",
            "protocols[].models[].estimates[].estimate",
            "protocols[].models[].estimates[].identifiable",
            "protocols[].models[].estimates[].name",
            "protocols[].models[].estimates[].not_identifiable_because",
            "protocols[].models[].estimates[].nominal",
            "protocols[].models[].estimates[].std",
            "protocols[].models[].estimates[].std_correlated",
            "protocols[].models[].estimates[].unit",
            "protocols[].models[].estimation_time_s",
            "protocols[].models[].failed_simulations",
            "protocols[].models[].failed_starts",
            "protocols[].models[].free",
            "protocols[].models[].gradient_norm",
            "protocols[].models[].load_ramp_s",
            "protocols[].models[].load_transitions",
            "protocols[].models[].load_transitions[].durations_s",
            "protocols[].models[].load_transitions[].run",
            "protocols[].models[].validation_transitions",
            "protocols[].models[].validation_transitions[].durations_s",
            "protocols[].models[].validation_transitions[].run",
            "protocols[].models[].local_optima_losses",
            "protocols[].models[].model",
            "protocols[].models[].notes",
            "protocols[].models[].runs",
            "protocols[].models[].screened_better",
            "protocols[].models[].screened_failed",
            "protocols[].models[].screened_starts",
            "protocols[].models[].runs[].error",
            "protocols[].models[].runs[].estimated",
            "protocols[].models[].runs[].estimated.height_percent",
            "protocols[].models[].runs[].estimated.pressure_percent",
            "protocols[].models[].runs[].nominal",
            "protocols[].models[].runs[].nominal.height_percent",
            "protocols[].models[].runs[].nominal.pressure_percent",
            "protocols[].models[].runs[].pooled",
            "protocols[].models[].runs[].pooled.height_percent",
            "protocols[].models[].runs[].pooled.pressure_percent",
            "protocols[].models[].runs[].residuals",
            "protocols[].models[].runs[].residuals[].band",
            "protocols[].models[].runs[].residuals[].confidence",
            "protocols[].models[].runs[].residuals[].input",
            "protocols[].models[].runs[].residuals[].lags_outside",
            "protocols[].models[].runs[].residuals[].lags_total",
            "protocols[].models[].runs[].residuals[].note",
            "protocols[].models[].runs[].residuals[].output",
            "protocols[].models[].runs[].residuals[].worst_ratio",
            "protocols[].models[].runs[].role",
            "protocols[].models[].runs[].run",
            "protocols[].models[].simulations",
            "protocols[].models[].starts",
            "protocols[].models[].stop_reason",
            "protocols[].models[].truck_file",
            "protocols[].name",
            "runs",
            "runs[].ceiling",
            "runs[].ceiling.height_noise_std_mm",
            "runs[].ceiling.height_percent",
            "runs[].ceiling.logged_input",
            "runs[].ceiling.logged_input.height_percent",
            "runs[].ceiling.logged_input.pressure_percent",
            "runs[].ceiling.pressure_noise_std_kpa",
            "runs[].ceiling.pressure_percent",
            "runs[].ceiling.source",
            "runs[].duration_s",
            "runs[].file",
            "runs[].format",
            "runs[].name",
            "runs[].role",
            "runs[].samples",
            "runs[].thesis_data_set",
            "runs[].valve_action",
            "schema_version",
            "study",
            "submodels",
            "submodels.fits",
            "submodels.fits[].description",
            "submodels.fits[].error",
            "submodels.fits[].name",
            "submodels.fits[].notes",
            "submodels.fits[].nrmse_estimation_percent",
            "submodels.fits[].nrmse_validation_percent",
            "submodels.fits[].parameters",
            "submodels.fits[].parameters[].name",
            "submodels.fits[].parameters[].std",
            "submodels.fits[].parameters[].unit",
            "submodels.fits[].parameters[].value",
            "truck",
        ];
        let expected: std::collections::BTreeSet<String> =
            expected.iter().map(|k| (*k).to_owned()).collect();
        let added: Vec<_> = keys.difference(&expected).collect();
        let removed: Vec<_> = expected.difference(&keys).collect();
        assert!(
            added.is_empty() && removed.is_empty(),
            "results.json keys changed (bump SCHEMA_VERSION = {SCHEMA_VERSION} and the README): added {added:?}, removed {removed:?}"
        );
        assert_eq!(SCHEMA_VERSION, 1);
    }
}
