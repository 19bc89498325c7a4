//! A small study end to end: generate the reference experiments, run the pipeline on the
//! study file with two models, and check what it wrote.

use airsus_report::results::StudyResults;
use airsus_study::{Protocol, StudyOptions, load_study, run_study, summary_table};

#[test]
fn a_small_study_runs_end_to_end_and_its_results_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let generated = airsus_truck::experiments::generate(&data, 5, &mut |_| {}).unwrap();
    let input = load_study(&generated.study_valve).unwrap();
    let options = StudyOptions {
        models: vec!["m2".to_owned(), "m3".to_owned()],
        protocols: vec![Protocol::from_roles(&input)],
        max_iterations: 8,
    };
    let out = dir.path().join("out");
    let events = std::sync::Mutex::new(Vec::new());
    let outcome = run_study(&input, &options, &out, &|e| {
        if let Ok(mut v) = events.lock() {
            v.push(format!("{e:?}"));
        }
    })
    .unwrap();
    assert!(
        events
            .lock()
            .unwrap()
            .iter()
            .any(|e| e.contains("ModelDone")),
        "progress reported"
    );

    let r = &outcome.results;
    // Every submodel fit of thesis 5.2 ran on the generated lab data.
    for fit in [
        "effective_area",
        "cross_section",
        "fill_valve",
        "exhaust_valve",
        "slow_dynamics",
        "model3_oe",
    ] {
        let f = r
            .submodels
            .get(fit)
            .unwrap_or_else(|| panic!("{fit} missing"));
        assert!(f.error.is_none(), "{fit}: {:?}", f.error);
    }
    let valve = r.submodels.get("fill_valve").unwrap();
    assert!(
        valve.nrmse_validation_percent.unwrap() > 80.0,
        "discharge fit on validation data"
    );

    let p = &r.protocols[0];
    assert_eq!(p.estimation_runs, ["data-set 1", "data-set 3"]);
    for m in &p.models {
        assert!(m.error.is_none(), "{}: {:?}", m.model, m.error);
        assert_eq!(m.runs.len(), 4);
        let ds1 = m.run("data-set 1").unwrap();
        let (nominal, estimated) = (ds1.nominal.unwrap(), ds1.estimated.unwrap());
        // Estimation never makes the estimation run's combined fit worse.
        assert!(
            estimated.height_percent + estimated.pressure_percent
                >= nominal.height_percent + nominal.pressure_percent - 1e-6,
            "{}: {nominal:?} -> {estimated:?}",
            m.model
        );
        assert!(!ds1.residuals.is_empty());
        let truck = out.join(m.truck_file.as_ref().unwrap());
        airsus_data::read_truck(&truck).unwrap();
    }
    let m2 = p.models.iter().find(|m| m.model == "m2").unwrap();
    assert!(
        m2.estimates.iter().any(|e| e.name == "rflow1"),
        "valve runs free the flow parameters"
    );

    let json: StudyResults =
        serde_json::from_str(&std::fs::read_to_string(&outcome.report.json).unwrap()).unwrap();
    assert!(
        json == *r,
        "results.json differs from the results after a round trip"
    );
    let html = std::fs::read_to_string(&outcome.report.html).unwrap();
    assert!(html.contains("Which model for what") && html.contains("<svg"));
    assert!(
        outcome.report.chart_failures.is_empty(),
        "{:?}",
        outcome.report.chart_failures
    );
    let table = summary_table(r);
    assert!(
        table.contains("m2") && table.contains("data-set 4"),
        "{table}"
    );
}

#[test]
fn a_protocol_without_estimation_runs_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let generated = airsus_truck::experiments::generate(dir.path(), 1, &mut |_| {}).unwrap();
    let input = load_study(&generated.study).unwrap();
    let options = StudyOptions {
        models: vec!["m2".to_owned()],
        protocols: vec![Protocol {
            name: "none".to_owned(),
            description: String::new(),
            estimation: vec!["data-set 9".to_owned()],
        }],
        max_iterations: 5,
    };
    let err = run_study(&input, &options, &dir.path().join("out"), &|_| {})
        .err()
        .unwrap();
    assert!(
        err.to_string().contains("no run named `data-set 9`"),
        "{err}"
    );
}
