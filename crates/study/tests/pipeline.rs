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
        initial: airsus_estimate::StartMethod::Equilibrium,
        prefix: airsus_estimate::PrefixOptions::default(),
        normalisation: airsus_estimate::Normalisation::PooledSpread,
        starts: 2,
        screen: 0,
        load_ramp: airsus_study::LoadRamp::Estimate,
        exclude_after_load_change_s: airsus_study::DEFAULT_EXCLUDE_AFTER_LOAD_CHANGE_S,
        validation_transitions: true,
        allow_trades: false,
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
    assert_eq!(
        p.estimation_runs,
        ["data-set 1", "data-set 3", "levelling 1", "road 1"]
    );
    for m in &p.models {
        assert!(m.error.is_none(), "{}: {:?}", m.model, m.error);
        assert_eq!(m.runs.len(), 8);
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
    // The logged load steps were eased over a fitted transition (the virtual truck's loads
    // ramp over 3 to 8 s while the log steps; Model 2, without slow dynamics, takes a longer
    // one), and the study says what it did.
    let tau = m2.load_ramp_s.expect("a load transition time for m2");
    // The held-out runs with logged load changes: each change over its own time, fitted
    // with the parameters fixed; the results say so.
    let validated: Vec<&str> = m2
        .validation_transitions
        .iter()
        .map(|t| t.run.as_str())
        .collect();
    assert_eq!(validated, ["data-set 2", "levelling 2"], "{:?}", m2.notes);
    assert!(
        m2.validation_transitions
            .iter()
            .flat_map(|t| &t.durations_s)
            .all(|d| *d > 0.0 && *d <= airsus_estimate::MAX_LOAD_RAMP_S)
    );
    assert!(
        m2.notes
            .iter()
            .any(|n| n.contains("with the parameters fixed"))
    );
    assert_eq!(r.validation_transitions.as_deref(), Some("fitted"));
    assert!(
        tau > 2.0 && tau <= airsus_estimate::MAX_LOAD_RAMP_S,
        "m2: load ramp {tau} s"
    );
    assert!(
        m2.notes
            .iter()
            .any(|n| n.contains("logged load steps eased over")),
        "{:?}",
        m2.notes
    );
    // The global stage ran: two starts, their local optima's losses best first.
    assert_eq!(m2.starts, 2);
    assert!(!m2.local_optima_losses.is_empty());
    assert!(m2.local_optima_losses.windows(2).all(|w| w[0] <= w[1]));
    assert!(
        m2.estimates.iter().any(|e| e.name == "rflow1"),
        "valve runs free the flow parameters"
    );
    // Estimation must do something, not merely not hurt: on the valve run the nominal m2
    // is far off (it starts from the submodel fits, which see no valve data) and the fit
    // must repair it; on data-set 1 it must gain half a point at least (m3 gains 0.95, its
    // pressure 86.7 -> 87.6 %, from the start the settled cross-section gives; a point and
    // more before).
    for m in &p.models {
        let fit = |run: &str| {
            let r = m.run(run).unwrap();
            (r.nominal.unwrap(), r.estimated.unwrap())
        };
        let (nominal, estimated) = fit("data-set 1");
        println!("{} data-set 1: {nominal:?} -> {estimated:?}", m.model);
        assert!(
            estimated.height_percent + estimated.pressure_percent
                >= nominal.height_percent + nominal.pressure_percent + 0.5,
            "{}: data-set 1 {nominal:?} -> {estimated:?}",
            m.model
        );
        let (nominal, estimated) = fit("data-set 3");
        println!("{} data-set 3: {nominal:?} -> {estimated:?}", m.model);
    }
    let ds3 = m2.run("data-set 3").unwrap();
    let (nominal, estimated) = (ds3.nominal.unwrap(), ds3.estimated.unwrap());
    assert!(
        nominal.height_percent < 0.0 && estimated.height_percent > 70.0,
        "m2 on the valve run: {nominal:?} -> {estimated:?}"
    );
    let moved = m2
        .estimates
        .iter()
        .filter(|e| e.identifiable && (e.estimate / e.nominal - 1.0).abs() > 0.02)
        .count();
    assert!(moved >= 2, "{:?}", m2.estimates);
    // A parameter the runs cannot determine says why, in results.json and in the notes.
    for m in &p.models {
        for e in &m.estimates {
            assert_eq!(
                e.identifiable,
                e.not_identifiable_because.is_none(),
                "{}: {e:?}",
                m.model
            );
            if let Some(why) = &e.not_identifiable_because {
                assert!(
                    m.notes
                        .iter()
                        .any(|n| n.starts_with(&format!("{} is not determined", e.name))
                            && n.contains(why.as_str())),
                    "{}: {e:?} {:?}",
                    m.model,
                    m.notes
                );
            }
        }
        assert!(m.failed_simulations <= m.simulations, "{}", m.model);
    }
    // "nominal" is where the study started (the submodel fits), not where a refit (after
    // the load transition, or from new starts) began.
    let mut compared = 0;
    for e in &m2.estimates {
        let fitted = r
            .submodels
            .fits
            .iter()
            .flat_map(|f| &f.parameters)
            .find(|v| v.name == e.name);
        if let Some(fitted) = fitted {
            assert!(
                (e.nominal / fitted.value - 1.0).abs() < 1e-9,
                "{}: nominal {} but the submodel fit gave {}",
                e.name,
                e.nominal,
                fitted.value
            );
            compared += 1;
        }
    }
    assert!(compared >= 3, "{:?}", m2.estimates);

    // Against the truth (structure mismatch: the virtual truck has hysteresis, creep, a
    // pressure-dependent area and an orifice valve that m2 lacks). The parameters themselves
    // have no true value in m2's structure, but its simulation has one: on the validation
    // run, the estimated m2 must follow the noise-free truth closer than m2 with the file's
    // nominal parameters does, in both outputs.
    let truth_run = airsus_data::read_run(&data.join("truth/ds2.csv")).unwrap();
    let logged = airsus_data::read_run(&data.join("ds2.csv")).unwrap();
    let truth_out = truth_run.outputs.as_ref().unwrap();
    let rms_error = |truck: &std::path::Path| {
        let truck = airsus_data::read_truck(truck).unwrap().parameters;
        let model = airsus_truck::models::build_any_model("m2", &truck).unwrap();
        let initial =
            airsus_sim::InitialState::Equilibrium(airsus_model::InitialCondition::SensorHeight {
                height_m: logged.outputs.as_ref().unwrap().sensor_height_m[0],
            });
        let problem = airsus_sim::SimulationProblem::new(
            &*model,
            airsus_sim::InputSeries::from_run(&logged).unwrap(),
            initial,
        );
        let sim = airsus_sim::simulate(&problem).unwrap();
        let rms = |a: &[f64], b: &[f64]| {
            (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
        };
        (
            rms(&sim.sensor_height_m, &truth_out.sensor_height_m) * 1e3,
            rms(&sim.bellow_gauge_pa, &truth_out.bellow_gauge_pa) * 1e-3,
        )
    };
    let (h_nominal, p_nominal) = rms_error(&data.join("truck.toml"));
    let (h_estimated, p_estimated) = rms_error(&out.join(m2.truck_file.as_ref().unwrap()));
    println!(
        "m2 on data-set 2 against the truth: nominal {h_nominal:.2} mm / {p_nominal:.2} kPa, estimated {h_estimated:.2} mm / {p_estimated:.2} kPa rms"
    );
    // The pressure error falls four-fold; the height error only slightly, because creep and
    // hysteresis (3 mm) are not in m2's structure — the gap issue #12 is about.
    assert!(
        h_estimated < 0.98 * h_nominal && p_estimated < 0.5 * p_nominal,
        "estimated {h_estimated} mm / {p_estimated} kPa vs nominal {h_nominal} mm / {p_nominal} kPa"
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
        initial: airsus_estimate::StartMethod::Equilibrium,
        prefix: airsus_estimate::PrefixOptions::default(),
        normalisation: airsus_estimate::Normalisation::PooledSpread,
        starts: 1,
        screen: 0,
        load_ramp: airsus_study::LoadRamp::Logged,
        exclude_after_load_change_s: 0.0,
        validation_transitions: false,
        allow_trades: false,
    };
    let err = run_study(&input, &options, &dir.path().join("out"), &|_| {})
        .err()
        .unwrap();
    assert!(
        err.to_string().contains("no run named `data-set 9`"),
        "{err}"
    );
}

#[test]
fn every_run_has_its_noise_ceiling_from_the_truth_and_the_estimate_agrees() {
    use airsus_study::ceiling::noise_ceiling;
    let dir = tempfile::tempdir().unwrap();
    let generated = airsus_truck::experiments::generate(dir.path(), 3, &mut |_| {}).unwrap();
    let mut input = load_study(&generated.study).unwrap();
    for run in &mut input.runs {
        let truth = noise_ceiling(run).expect("a generated run has a truth file");
        assert_eq!(truth.source, "truth");
        // The sensors of the virtual truck (SensorSpec): 0.15 mm and 0.2 kPa of noise.
        assert!((truth.height_noise_std_mm - 0.15).abs() < 0.01, "{truth:?}");
        assert!(
            (truth.pressure_noise_std_kpa - 0.2).abs() < 0.015,
            "{truth:?}"
        );
        // Without the truth file: the ceiling estimated from the measurements alone.
        run.truth = None;
        let estimated = noise_ceiling(run).unwrap();
        assert_eq!(estimated.source, "estimated");
        for (t, e) in [
            (truth.height_percent, estimated.height_percent),
            (truth.pressure_percent, estimated.pressure_percent),
        ] {
            assert!(
                (t - e).abs() < 0.3,
                "{}: truth {t} %, estimated {e} %",
                run.name
            );
        }
    }
}

#[test]
fn a_truth_file_on_another_time_axis_is_refused_with_its_name() {
    let dir = tempfile::tempdir().unwrap();
    let generated = airsus_truck::experiments::generate(dir.path(), 1, &mut |_| {}).unwrap();
    let text = std::fs::read_to_string(&generated.study)
        .unwrap()
        .replace("truth/ds2.csv", "truth/ds3.csv");
    let study = dir.path().join("swapped.toml");
    std::fs::write(&study, text).unwrap();
    let err = load_study(&study).unwrap_err().to_string();
    assert!(
        err.contains("truth/ds3.csv") && err.contains("data-set 2"),
        "{err}"
    );
}

#[test]
fn a_study_can_start_its_runs_from_the_first_seconds_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let generated = airsus_truck::experiments::generate(&data, 4, &mut |_| {}).unwrap();
    let input = load_study(&generated.study_valve).unwrap();
    // `joint` (the default): the estimation runs' starts refitted with the parameters;
    // `prefix`: fitted once under the start values and held.
    let study = |refit_starts: bool, out: &str| {
        let options = StudyOptions {
            models: vec!["m2".to_owned()],
            protocols: vec![Protocol::from_roles(&input)],
            max_iterations: 5,
            initial: airsus_estimate::StartMethod::Prefix,
            prefix: airsus_estimate::PrefixOptions {
                refit_starts,
                ..airsus_estimate::PrefixOptions::default()
            },
            normalisation: airsus_estimate::Normalisation::PooledSpread,
            starts: 1,
            screen: 0,
            load_ramp: airsus_study::LoadRamp::Logged,
            exclude_after_load_change_s: 0.0,
            validation_transitions: false,
            allow_trades: false,
        };
        run_study(&input, &options, &dir.path().join(out), &|_| {}).unwrap()
    };
    let joint = study(true, "joint");
    let r = &joint.results;
    assert_eq!(r.initial_state, "joint");
    let m2 = &r.protocols[0].models[0];
    assert!(m2.error.is_none(), "{:?}", m2.error);
    // The refit from estimated starts is either kept or declined, and the notes say which.
    assert!(
        m2.notes.iter().any(|n| n.contains("refit")),
        "{:?}",
        m2.notes
    );
    for run in &m2.runs {
        assert!(run.estimated.is_some(), "{}: {:?}", run.run, run.error);
    }
    let html = std::fs::read_to_string(dir.path().join("joint/report.html")).unwrap();
    assert!(html.contains("history states fitted to the first 10 s"));

    let held = study(false, "held");
    let r = &held.results;
    assert_eq!(r.initial_state, "prefix");
    let held_m2 = &r.protocols[0].models[0];
    assert!(
        held_m2
            .notes
            .iter()
            .any(|n| n.contains("under the start values and held")),
        "{:?}",
        held_m2.notes
    );
    // Held starts cost fewer simulations; refitted ones explain the estimation runs at least
    // as well.
    assert!(
        held_m2.simulations < m2.simulations,
        "{} against {}",
        held_m2.simulations,
        m2.simulations
    );
    let estimation_score = |m: &airsus_report::results::ModelResult| -> f64 {
        r.protocols[0]
            .estimation_runs
            .iter()
            .map(|name| {
                let f = m.run(name).and_then(|f| f.estimated).unwrap();
                f.height_percent + f.pressure_percent
            })
            .sum()
    };
    println!(
        "estimation runs' NRMSE sum: joint {:.2}, held {:.2}; simulations {} / {}",
        estimation_score(m2),
        estimation_score(held_m2),
        m2.simulations,
        held_m2.simulations
    );
    assert!(estimation_score(m2) >= estimation_score(held_m2) - 0.5);
}
