//! Issue #12: every model's estimate is at least its nominal fit on every estimation run. The
//! thesis models on the built-in virtual truck under our protocol (loading, valve, levelling
//! and road runs), a richer truck than any of them: the data are not the fitted model's own,
//! so a pooled loss can trade runs against each other, and the study's guard
//! (`airsus_study::no_trade`) must not let it.

mod common;

use airsus_apps::weigh::{EkfTuning, weigh_ekf};
use airsus_report::results::StudyResults;
use airsus_study::{Protocol, StudyOptions, load_study, run_study};
use common::{estimated_weigher, generated_run, scored};

/// `(run, output, start %, estimate %)` of each estimation run and output the estimate
/// explains worse than the start values did, by more than `margin` NRMSE points.
fn worse_than_the_start(
    model: &airsus_report::results::ModelResult,
    margin: f64,
) -> Vec<(String, &'static str, f64, f64)> {
    let mut worse = Vec::new();
    for fit in model.runs.iter().filter(|f| f.role == "estimation") {
        let (start, estimate) = (fit.nominal.unwrap(), fit.estimated.unwrap());
        for (output, before, after) in [
            ("height", start.height_percent, estimate.height_percent),
            (
                "pressure",
                start.pressure_percent,
                estimate.pressure_percent,
            ),
        ] {
            if after < before - margin {
                worse.push((fit.run.clone(), output, before, after));
            }
        }
    }
    worse
}

/// Our protocol's study of `models` on member `variant` of the virtual truck family (seed 1;
/// 0: the built-in truck), with `allow_trades`; the folder holds `data/` and `out/`.
fn valve_study(
    variant: u32,
    models: &[&str],
    allow_trades: bool,
) -> (tempfile::TempDir, StudyResults) {
    let dir = tempfile::tempdir().unwrap();
    let generated = airsus_truck::experiments::generate_variant(
        &dir.path().join("data"),
        1,
        variant,
        &mut |_| {},
    )
    .unwrap();
    let input = load_study(&generated.study_valve).unwrap();
    let options = StudyOptions {
        models: models.iter().map(|m| (*m).to_owned()).collect(),
        allow_trades,
        ..StudyOptions::new(vec![Protocol::from_roles(&input)])
    };
    let outcome = run_study(&input, &options, &dir.path().join("out"), &|_| {}).unwrap();
    (dir, outcome.results)
}

#[test]
fn every_thesis_model_gains_on_every_estimation_run() {
    let (dir, results) = valve_study(0, &["m1", "m2", "m2x", "m2xh", "m3"], false);
    let data = dir.path().join("data");
    let protocol = &results.protocols[0];
    let estimation_runs = ["data-set 1", "data-set 3", "levelling 1", "road 1"];
    // Model 3's OE is identified on the estimation run whose load and pressure are the least
    // correlated, and the submodel report says which.
    let oe = results
        .submodels
        .fits
        .iter()
        .find(|f| f.name == "model3_oe")
        .unwrap();
    assert!(
        oe.notes[0].starts_with("identified on levelling 1"),
        "{:?}",
        oe.notes
    );
    for model in &protocol.models {
        assert!(model.error.is_none(), "{}: {:?}", model.model, model.error);
        let estimated: Vec<&str> = model
            .runs
            .iter()
            .filter(|f| f.role == "estimation")
            .map(|f| f.run.as_str())
            .collect();
        assert_eq!(estimated, estimation_runs, "{}", model.model);
        for fit in model.runs.iter().filter(|f| f.role == "estimation") {
            println!(
                "{} {}: {:?} -> {:?}",
                model.model, fit.run, fit.nominal, fit.estimated
            );
        }
        // Every model, Model 3 too, explains every estimation run and output at least as
        // well as its start values did. Measured (seed 1): m1, m2, m2x, m2xh gain on every
        // run and output, 4-315 points on the height and 4-96 on the pressure.
        let worse = worse_than_the_start(model, 0.1);
        assert!(worse.is_empty(), "{}: {worse:?}", model.model);
        if model.model == "m3" {
            // Model 3's pooled estimate traded data-set 3's pressure (-202.0 -> -237.0 %),
            // the levelling run's (86.5 -> 58.4 %) and road 1 (about 0 -> -1.7 / -2.7 %) for
            // the heights; the guard refitted it with those blocks weighted more, and the
            // result says so. Measured after the guard: data-set 3 54.7 / -20.1 %,
            // levelling 1 -43.8 / 93.3 % (start -109.7 / -202.0 and -76.7 / 86.5).
            assert!(
                model
                    .notes
                    .iter()
                    .any(|n| n.contains("it explains every estimation run and output at least as well as the start values")),
                "{:?}",
                model.notes
            );
            let fit = |run: &str| {
                model
                    .runs
                    .iter()
                    .find(|f| f.run == run)
                    .unwrap()
                    .estimated
                    .unwrap()
            };
            assert!(
                fit("data-set 3").pressure_percent > -100.0
                    && fit("levelling 1").pressure_percent > 86.5,
                "{:?}",
                model.runs
            );
            // The pooled estimate the guard refitted is reported beside it: its fit of each
            // estimation run in results.json, and each trade named in the note.
            let pooled = |run: &str| {
                model
                    .runs
                    .iter()
                    .find(|f| f.run == run)
                    .unwrap()
                    .pooled
                    .unwrap_or_else(|| panic!("{run}: no pooled fit"))
            };
            assert!(
                pooled("levelling 1").pressure_percent < 80.0
                    && pooled("data-set 3").pressure_percent < -202.0,
                "{:?}",
                model.runs
            );
            assert!(
                model
                    .notes
                    .iter()
                    .any(|n| n.contains("the pooled estimate explained")
                        && n.contains("data-set 3's pressure -2")
                        && n.contains("(start values -202.0 %)")),
                "{:?}",
                model.notes
            );
            assert!(
                model
                    .runs
                    .iter()
                    .all(|f| f.role == "estimation" || f.pooled.is_none()),
                "{:?}",
                model.runs
            );
        } else {
            // A model whose estimate traded nothing has no pooled fits to report.
            assert!(
                model.runs.iter().all(|f| f.pooled.is_none()),
                "{}",
                model.model
            );
        }
        // Issue #14: the load filter on each model's estimated file (nothing of the truth)
        // neither fails nor runs away on the held-out runs. An issue measured Model 1's
        // file diverging on another truck's loading run and the others spiking to 200 %.
        let (estimated, weigher) = estimated_weigher(&dir.path().join("out"), model);
        for run in ["ds2", "ds4", "lev2"] {
            let (logged, truth) = generated_run(&data, run);
            let filter = airsus_truck::models::build_any_model(&model.model, &estimated).unwrap();
            let series = weigh_ekf(&logged, filter, &weigher, &EkfTuning::default())
                .unwrap_or_else(|e| panic!("{} on {run}: {e}", model.model));
            let score = scored(&logged, &truth, &series);
            println!(
                "{} EKF on {run}: every sample max {:.2} %, standstills max {:.2} %",
                model.model,
                score.all.max_abs_error_percent,
                score.standstill.max_abs_error_percent
            );
            assert!(series.wheel_load_kg.iter().all(|m| m.is_finite()));
            // Measured (seed 1), every sample / standstills: m1, m2, m2x 1.9-4.5 / 0.3-1.9 %;
            // m2xh 1.5-5.4 / 0.5-4.7 %; m3 3.9-10.9 / 1.1-10.9 % (4.6-8.9 / 2.5-8.9 % from
            // the pooled fit that traded runs; 2.7-39 / 1.1-32 % with its OE identified on
            // data-set 1). None runs away; only the `truck` structure
            // weighs to 0.5 % (README, Weighing).
            let (every_max, standstill_max) = match model.model.as_str() {
                "m3" => (12.0, 12.0),
                "m2xh" => (7.0, 6.0),
                _ => (6.0, 2.5),
            };
            assert!(
                score.all.max_abs_error_percent < every_max
                    && score.standstill.max_abs_error_percent < standstill_max,
                "{} on {run}: {:?}",
                model.model,
                score.all
            );
        }
    }
}

/// Where no weighting brings every estimation run back to the start values' fit, the refit
/// that falls least short is kept. Model 3 on variant 1 (seed 1): its pooled estimate fell
/// 63 NRMSE points short in all (data-set 3's pressure −792 → −825 %, the levelling run's
/// −28.7 → −35.3 %, road 1's −0.1 → −23.3 %); its height on road 1, which its OE model of
/// load and pressure does not see (only the start's offset sets it), no weight brings back.
#[test]
fn model_3_keeps_the_refit_that_trades_least_where_none_trades_nothing() {
    let (_dir, results) = valve_study(1, &["m3"], false);
    let m3 = &results.protocols[0].models[0];
    assert!(m3.error.is_none(), "{:?}", m3.error);
    assert!(
        m3.notes
            .iter()
            .any(|n| n.contains("falls least short") && n.contains("is kept")),
        "{:?}",
        m3.notes
    );
    // Measured: only road 1's height is left short (-1.0 -> -1.4 %); data-set 3's
    // pressure -247.7 % and the levelling run's 50.2 %.
    let worse = worse_than_the_start(m3, 0.1);
    assert!(
        worse
            .iter()
            .all(|(run, output, before, after)| run == "road 1"
                && *output == "height"
                && before - after < 1.0),
        "{worse:?}"
    );
    let estimated = |run: &str| m3.run(run).and_then(|f| f.estimated).unwrap();
    assert!(estimated("data-set 3").pressure_percent > -400.0);
    assert!(estimated("levelling 1").pressure_percent > 40.0);
}

/// `--allow-trades` keeps each model's pooled estimate, as MATLAB's `greyest` returns it:
/// Model 3 on the built-in study (seed 1, our protocol) then explains data-set 3's and the
/// levelling run's pressure worse than its start values, and the result says so.
#[test]
fn model_3_keeps_its_pooled_estimate_where_trades_are_allowed() {
    let (_dir, results) = valve_study(0, &["m3"], true);
    assert!(results.allow_trades);
    let m3 = &results.protocols[0].models[0];
    assert!(m3.error.is_none(), "{:?}", m3.error);
    assert!(
        m3.notes
            .iter()
            .any(|n| n.contains("kept as fitted (trades allowed)")
                && n.contains("levelling 1's pressure")),
        "{:?}",
        m3.notes
    );
    let worse = worse_than_the_start(m3, 0.1);
    assert!(
        worse
            .iter()
            .any(|(run, output, ..)| run == "levelling 1" && *output == "pressure"),
        "{worse:?}"
    );
    // The pooled estimate is the one kept: its fits are the estimated ones.
    for fit in m3.runs.iter().filter(|f| f.role == "estimation") {
        let (pooled, estimated) = (fit.pooled.unwrap(), fit.estimated.unwrap());
        assert!(
            (pooled.height_percent - estimated.height_percent).abs() < 1e-9
                && (pooled.pressure_percent - estimated.pressure_percent).abs() < 1e-9,
            "{}: {pooled:?} against {estimated:?}",
            fit.run
        );
    }
}
