//! What the study concludes from its numbers: which model for what, and what valve-action
//! data buys. The study decides; the report renders ([`airsus_report::results::Findings`]).

use airsus_report::results::{
    Findings, ModelGain, ModelResult, ModelUse, OutputFit, ProtocolResult, RankedModel, RunInfo,
    ValveDataGain,
};
use airsus_truck::models::TRUCK_MODEL;

/// The thesis data-set a run reproduces: the built-in study (and any study that follows its
/// naming) calls the runs `data-set N`, N = 1..4 (thesis 2.2).
pub fn thesis_data_set(run_name: &str) -> Option<u32> {
    run_name
        .strip_prefix("data-set ")?
        .parse()
        .ok()
        .filter(|n| (1..=4).contains(n))
}

/// The estimated fits of `model` on exactly `runs`; `None` if it failed on any of them (a
/// model is never ranked on an easier subset of the runs than the others).
fn fits_on(model: &ModelResult, runs: &[&str]) -> Option<Vec<OutputFit>> {
    let fits: Vec<OutputFit> = runs
        .iter()
        .map(|name| model.run(name).and_then(|r| r.estimated))
        .collect::<Option<_>>()?;
    (!fits.is_empty()).then_some(fits)
}

/// Mean over `fits` of `pick`.
fn mean(fits: &[OutputFit], pick: impl Fn(&OutputFit) -> f64) -> f64 {
    fits.iter().map(pick).sum::<f64>() / fits.len() as f64
}

/// The models of `protocol` ranked by mean NRMSE on those of `runs` it did not estimate on.
fn rank(protocol: &ProtocolResult, runs: &[&str], purpose: &str) -> Option<ModelUse> {
    let validation: Vec<String> = runs
        .iter()
        .filter(|r| !protocol.estimation_runs.iter().any(|e| e == *r))
        .map(|r| (*r).to_owned())
        .collect();
    let names: Vec<&str> = validation.iter().map(String::as_str).collect();
    let mut ranking: Vec<RankedModel> = protocol
        .models
        .iter()
        .filter_map(|m| {
            let fits = fits_on(m, &names)?;
            Some(RankedModel {
                model: m.model.clone(),
                mean_nrmse_percent: mean(&fits, |f| 0.5 * (f.height_percent + f.pressure_percent)),
            })
        })
        .collect();
    ranking.sort_by(|a, b| b.mean_nrmse_percent.total_cmp(&a.mean_nrmse_percent));
    let first = ranking.first()?;
    // The virtual truck's own structure wins on data it generated; name the best of the
    // others too, which is what a user of real data would choose among.
    let best_other_than_truck = (first.model == TRUCK_MODEL.name)
        .then(|| {
            ranking
                .iter()
                .find(|m| m.model != TRUCK_MODEL.name)
                .cloned()
        })
        .flatten();
    Some(ModelUse {
        purpose: purpose.to_owned(),
        protocol: protocol.name.clone(),
        runs: validation,
        ranking,
        best_other_than_truck,
    })
}

/// Per model and output, the mean NRMSE over `runs` under the first and the last protocol.
fn valve_data_gain(
    first: &ProtocolResult,
    last: &ProtocolResult,
    runs: &[&str],
) -> Option<ValveDataGain> {
    let runs: Vec<&str> = runs
        .iter()
        .copied()
        .filter(|r| !last.estimation_runs.iter().any(|e| e == r))
        .collect();
    let models: Vec<ModelGain> = last
        .models
        .iter()
        .filter_map(|after| {
            let before = first.models.iter().find(|f| f.model == after.model)?;
            let (b, a) = (fits_on(before, &runs)?, fits_on(after, &runs)?);
            Some(ModelGain {
                model: after.model.clone(),
                height_before_percent: mean(&b, |f| f.height_percent),
                height_after_percent: mean(&a, |f| f.height_percent),
                pressure_before_percent: mean(&b, |f| f.pressure_percent),
                pressure_after_percent: mean(&a, |f| f.pressure_percent),
            })
        })
        .collect();
    (!models.is_empty()).then(|| ValveDataGain {
        runs: runs.iter().map(|r| (*r).to_owned()).collect(),
        before_protocol: first.name.clone(),
        after_protocol: last.name.clone(),
        models,
    })
}

/// The findings of a study: the last protocol ranks the models on loading runs (axle load)
/// and on valve runs (level control); with two or more protocols, the first against the last
/// shows what valve-action data buys.
pub fn findings(runs: &[RunInfo], protocols: &[ProtocolResult]) -> Findings {
    let Some(last) = protocols.last() else {
        return Findings::default();
    };
    let valve_runs: Vec<&str> = runs
        .iter()
        .filter(|r| r.valve_action)
        .map(|r| r.name.as_str())
        .collect();
    let load_runs: Vec<&str> = runs
        .iter()
        .filter(|r| !r.valve_action)
        .map(|r| r.name.as_str())
        .collect();
    let uses = [
        rank(last, &load_runs, "axle_load"),
        rank(last, &valve_runs, "level_control"),
    ]
    .into_iter()
    .flatten()
    .collect();
    let valve_data = match protocols {
        [first, .., _] => valve_data_gain(first, last, &valve_runs),
        _ => None,
    };
    Findings { uses, valve_data }
}

#[cfg(test)]
mod tests {
    use super::*;
    use airsus_report::results::RunFit;

    fn model(name: &str, fits: &[(&str, f64, f64)]) -> ModelResult {
        let mut result = ModelResult::new(name);
        result.runs = fits
            .iter()
            .map(|(run, h, p)| RunFit {
                run: (*run).to_owned(),
                role: "validation".to_owned(),
                nominal: None,
                estimated: Some(OutputFit {
                    height_percent: *h,
                    pressure_percent: *p,
                }),
                pooled: None,
                residuals: vec![],
                error: None,
            })
            .collect();
        result
    }

    fn run(name: &str, valve: bool) -> RunInfo {
        RunInfo {
            name: name.to_owned(),
            file: String::new(),
            role: "validation".to_owned(),
            samples: 1,
            duration_s: 0.0,
            valve_action: valve,
            thesis_data_set: thesis_data_set(name),
            ceiling: None,
            format: "CSV".to_owned(),
            notes: Vec::new(),
        }
    }

    #[test]
    fn ranks_on_validation_runs_and_names_the_best_other_than_the_truck() {
        let runs = [
            run("data-set 1", false),
            run("data-set 2", false),
            run("data-set 3", true),
        ];
        let protocol = |name: &str, est: &[&str], models: Vec<ModelResult>| ProtocolResult {
            name: name.to_owned(),
            description: String::new(),
            estimation_runs: est.iter().map(|s| (*s).to_owned()).collect(),
            models,
        };
        let thesis = protocol(
            "thesis",
            &["data-set 1"],
            vec![
                model(
                    "m2",
                    &[("data-set 2", 80.0, 70.0), ("data-set 3", 10.0, 0.0)],
                ),
                model(
                    "truck",
                    &[("data-set 2", 90.0, 88.0), ("data-set 3", 50.0, 20.0)],
                ),
            ],
        );
        let valve = protocol(
            "valve",
            &["data-set 1", "data-set 3"],
            vec![
                // data-set 1 was estimated on: it must not count.
                model(
                    "m2",
                    &[("data-set 1", 99.0, 99.0), ("data-set 2", 82.0, 72.0)],
                ),
                model("m1", &[("data-set 2", 60.0, 50.0)]),
                model("truck", &[("data-set 2", 95.0, 90.0)]),
            ],
        );
        let f = findings(&runs, &[thesis.clone(), valve]);
        let load = &f.uses[0];
        assert_eq!(
            (load.purpose.as_str(), load.protocol.as_str()),
            ("axle_load", "valve")
        );
        assert_eq!(load.runs, ["data-set 2"]);
        let order: Vec<&str> = load.ranking.iter().map(|m| m.model.as_str()).collect();
        assert_eq!(order, ["truck", "m2", "m1"]);
        assert_eq!(load.ranking[1].mean_nrmse_percent, 77.0);
        assert_eq!(load.best_other_than_truck.as_ref().unwrap().model, "m2");
        // Every valve run was estimated on by the last protocol: nothing to rank, no gain.
        assert_eq!(f.uses.len(), 1);
        assert!(f.valve_data.is_none());

        // With a valve run left for validation, the gain is before → after per output.
        let runs = [runs[0].clone(), runs[2].clone(), run("data-set 4", true)];
        let before = protocol(
            "thesis",
            &["data-set 1"],
            vec![model(
                "m2",
                &[("data-set 3", 1.0, 1.0), ("data-set 4", 5.0, -20.0)],
            )],
        );
        let after = protocol(
            "valve",
            &["data-set 1", "data-set 3"],
            vec![model("m2", &[("data-set 4", 85.0, 40.0)])],
        );
        let f = findings(&runs, &[before, after]);
        let gain = f.valve_data.unwrap();
        assert_eq!(gain.runs, ["data-set 4"]);
        let m2 = &gain.models[0];
        assert_eq!(
            (m2.height_before_percent, m2.height_after_percent),
            (5.0, 85.0)
        );
        assert_eq!(
            (m2.pressure_before_percent, m2.pressure_after_percent),
            (-20.0, 40.0)
        );
        let control = f
            .uses
            .iter()
            .find(|u| u.purpose == "level_control")
            .unwrap();
        assert_eq!(control.runs, ["data-set 4"]);
        assert!(control.best_other_than_truck.is_none());
    }

    #[test]
    fn a_model_that_failed_a_validation_run_is_not_ranked_on_the_others() {
        let runs = [
            run("data-set 1", false),
            run("data-set 2", false),
            run("load b", false),
        ];
        let mut failing = model("m1", &[("data-set 2", 99.0, 99.0), ("load b", 0.0, 0.0)]);
        failing.runs[1].estimated = None; // it did not simulate "load b"
        let protocol = ProtocolResult {
            name: "thesis".to_owned(),
            description: String::new(),
            estimation_runs: vec!["data-set 1".to_owned()],
            models: vec![
                failing,
                model("m2", &[("data-set 2", 80.0, 80.0), ("load b", 70.0, 70.0)]),
            ],
        };
        let f = findings(&runs, &[protocol]);
        let order: Vec<&str> = f.uses[0].ranking.iter().map(|m| m.model.as_str()).collect();
        assert_eq!(order, ["m2"]);
    }

    #[test]
    fn only_the_thesis_data_sets_are_recognised() {
        assert_eq!(thesis_data_set("data-set 2"), Some(2));
        assert_eq!(thesis_data_set("data-set 7"), None);
        assert_eq!(thesis_data_set("my run"), None);
    }
}
