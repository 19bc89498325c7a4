//! What the study tests that weigh with a study's own estimate share: the estimated file and
//! its static weigher, a generated held-out run with its truth, and a weighed series scored
//! against that truth.

use std::path::Path;

use airsus_apps::weigh::{
    AccuracySummary, StandstillRule, StaticLaw, StaticWeigher, WeighSeries, WeighingUncertainty,
    evaluate_series,
};
use airsus_data::{Run, TruckParameters, read_run};
use airsus_report::results::ModelResult;

/// The truck file the study wrote for `model` (its `truck_file`, relative to `out`) and a
/// static weigher on it, with the default assumed parameter errors.
pub fn estimated_weigher(out: &Path, model: &ModelResult) -> (TruckParameters, StaticWeigher) {
    let file = out.join(model.truck_file.as_ref().unwrap());
    let estimated = airsus_data::read_truck(&file).unwrap().parameters;
    let weigher = StaticWeigher::new(
        StaticLaw::from_truck(&estimated),
        WeighingUncertainty::default(),
    );
    (estimated, weigher)
}

/// The generated run `name` in `data` and its truth (`data/truth/{name}.csv`).
pub fn generated_run(data: &Path, name: &str) -> (Run, Run) {
    let logged = read_run(&data.join(format!("{name}.csv"))).unwrap();
    let truth = read_run(&data.join(format!("truth/{name}.csv"))).unwrap();
    (logged, truth)
}

/// `series`, weighed on `logged`, scored against the true load of `truth` under the default
/// standstill rule.
pub fn scored(logged: &Run, truth: &Run, series: &WeighSeries) -> AccuracySummary {
    evaluate_series(
        logged,
        &truth.inputs.wheel_load_kg,
        series,
        &StandstillRule::default(),
    )
    .unwrap()
}
