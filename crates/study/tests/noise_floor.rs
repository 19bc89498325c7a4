//! Issue #12's measure of an identification: on the built-in virtual truck under our valve
//! protocol, the `truck` structure estimated from the nominal truck file explains every run
//! up to the sensors' noise. The data are the virtual truck's, made by a richer simulation
//! than the structure fitted (Dahl friction, gas heat exchange, the supply line, an ISO 6358
//! valve, a pressure-dependent area, lever flex) and logged as a real truck logs them: the
//! load as steps the wheel takes over 3-8 s, one load change not logged at all; the runs are
//! loading, valve, levelling (the truck's deadband ECU at work) and road runs.

mod common;

use airsus_apps::weigh::{EkfTuning, HysteresisStart, weigh_ekf, weigh_static_from};
use airsus_study::{LoadRamp, Protocol, StudyOptions, load_study, run_study};
use airsus_truck::models::build_any_model;
use common::{estimated_weigher, generated_run, scored};

#[test]
fn the_truck_structure_reaches_the_noise_ceiling_of_its_logged_inputs_on_every_run() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let generated = airsus_truck::experiments::generate(&data, 1, &mut |_| {}).unwrap();
    let input = load_study(&generated.study_valve).unwrap();
    // The study's defaults: starts fitted with the parameters, each logged load change eased
    // over its own time.
    let options = StudyOptions {
        models: vec!["truck".to_owned()],
        ..StudyOptions::new(vec![Protocol::from_roles(&input)])
    };
    assert_eq!(options.load_ramp, LoadRamp::Estimate);
    let outcome = run_study(&input, &options, &dir.path().join("out"), &|_| {}).unwrap();
    let r = &outcome.results;
    let truck = &r.protocols[0].models[0];
    assert!(truck.error.is_none(), "{:?}", truck.error);
    // Within 2 points of the ceiling on every run and output. Data-set 2, held out, has a
    // load change its log does not show (a mishap at 960 s): no model driven by the logged
    // load can follow it, so its ceiling is that of the run as the log tells it (measured
    // 92.4/90.3 % against 92.8/90.7 %; the truth with the mishap scores 98.5/99.1 %), and
    // that one is well below the full ceiling (the mishap costs more than 5 points).
    // The held-out levelling run: the controller holds the height within a few millimetres
    // and the pressure follows the load, so the tenths of a millimetre and kilopascal that
    // each logged step's unknown transition time costs weigh more there than anywhere else:
    // the truth structure itself scores 95.5/99.1 % with each change eased over its true
    // time, 90.1/96.4 % over the study's common ramp. Each change of a validation run is now
    // eased over its own time, fitted with the parameters fixed (measured 95.4/99.1 %; with
    // the common ramp 90.0/96.4 %).
    // The held-out long valve steps of data-set 4 reach heights the estimation
    // runs do not: there the force map holds the effective area (without it their pressure
    // moved between 91.8 and 95.2 % with the noise estimate of the road run alone; with it
    // 96.4 % against the ceiling's 97.0 %).
    let names: Vec<&str> = r.runs.iter().map(|info| info.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "data-set 1",
            "data-set 2",
            "data-set 3",
            "data-set 4",
            "levelling 1",
            "levelling 2",
            "road 1",
            "road 2"
        ]
    );
    for info in &r.runs {
        let run = info.name.as_str();
        let ceiling = info.ceiling.clone().expect("a generated run has its truth");
        let (height, pressure) = match ceiling.logged_input {
            Some(logged) => {
                assert_eq!(run, "data-set 2", "only data-set 2 hides a load change");
                assert!(logged.height_percent < ceiling.height_percent - 5.0);
                assert!(logged.pressure_percent < ceiling.pressure_percent - 5.0);
                (logged.height_percent, logged.pressure_percent)
            }
            None => (ceiling.height_percent, ceiling.pressure_percent),
        };
        assert!(run != "data-set 2" || ceiling.logged_input.is_some());
        let fit = truck.run(run).and_then(|f| f.estimated).expect(run);
        for (output, got, best) in [
            ("height", fit.height_percent, height),
            ("pressure", fit.pressure_percent, pressure),
        ] {
            let margin = 2.0;
            assert!(
                got > best - margin,
                "{run} {output}: {got:.1} % against the ceiling {best:.1} %; notes {:?}",
                truck.notes
            );
        }
    }
    // Each logged change of the loading and the levelling run was eased over its own time,
    // and so was each of the held-out runs with logged changes (data-set 2: 6 and the
    // mishap's one logged step; levelling 2: 6), with the parameters fixed.
    assert_eq!(truck.load_transitions.len(), 2, "{:?}", truck.notes);
    for transitions in &truck.load_transitions {
        assert_eq!(transitions.durations_s.len(), 6, "{}", transitions.run);
    }
    let validated: Vec<&str> = truck
        .validation_transitions
        .iter()
        .map(|t| t.run.as_str())
        .collect();
    assert_eq!(
        validated,
        ["data-set 2", "levelling 2"],
        "{:?}",
        truck.notes
    );
    assert_eq!(r.validation_transitions.as_deref(), Some("fitted"));
    // At least its nominal fit on every estimation run and output (issue #12; the thesis
    // models' in `every_model.rs`). Measured: every one gains.
    for fit in truck.runs.iter().filter(|f| f.role == "estimation") {
        let (start, estimate) = (fit.nominal.unwrap(), fit.estimated.unwrap());
        println!("{}: {start:?} -> {estimate:?}", fit.run);
        assert!(
            estimate.height_percent >= start.height_percent - 0.1
                && estimate.pressure_percent >= start.pressure_percent - 0.1,
            "{}: {start:?} -> {estimate:?}",
            fit.run
        );
    }

    // Issue #13: the tire force the estimate simulates over a road it never saw (an ISO
    // 8608 class C road at 50 km/h, a new seed) against the truth's, both from the run's
    // first height at its load. The weighing and road tests hold the variants' fixtures to
    // this; here the study as it estimates today.
    {
        use airsus_apps::road::simulate_road;
        use airsus_truck::model::TruckModel;
        let mut truth = airsus_truck::truth::VirtualTruck::reference();
        let (m2, friction) = (
            truth.physical.mass.unsprung_kg,
            truth.effect_parameters.friction_force_n,
        );
        let road = airsus_truck::experiments::run_experiment(
            &truth,
            &airsus_truck::scenario::road_2(m2, 300).unwrap(),
            friction,
            300,
        )
        .unwrap();
        truth.resolve_laws();
        let file = dir
            .path()
            .join("out")
            .join(truck.truck_file.as_ref().unwrap());
        let estimate = airsus_data::read_truck(&file).unwrap().parameters;
        let (time, road_m) = (&road.logged.time_s, &road.logged.inputs.road_height_m);
        let load_kg = road.truth.inputs.wheel_load_kg[0];
        let height_m = road.logged.measured().unwrap().sensor_height_m[0];
        let tire_force = |p: &airsus_data::TruckParameters| {
            let model = TruckModel::from_truck_parameters(p);
            simulate_road(&model, p, time, road_m, load_kg, height_m)
                .unwrap()
                .tire_force_n
        };
        let fit =
            airsus_validate::nrmse_percent(&tire_force(&truth.physical), &tire_force(&estimate))
                .unwrap();
        // Measured 99.18 % (the fixture of variant 0 gives the same).
        println!("tire force on a new road: NRMSE {fit:.2} %");
        assert!(fit > 98.0, "{fit:.2} %");
    }

    // Issue #14: weighing with what the study estimated, nothing else. The load filter on the
    // estimated `truck` file, told how each held-out run starts (data-set 2 after the truck
    // was lowered, data-set 4 after it was raised, the levelling run with the wall
    // unloaded), scored against the true load. Measured: standstills within 0.09 % (data-set
    // 2), 0.13 % (data-set 4) and 0.08 % (levelling 2), 0.15 % and 0.10 % while the valve
    // works. (Before the filter moved the wall friction through a play: 0.59 %, 0.6 % and
    // 0.13 %.)
    let (estimated, weigher) = estimated_weigher(&dir.path().join("out"), truck);
    for (run, start, standstill_max, valve_max) in [
        ("ds2", HysteresisStart::Lowered, 0.25, 0.0),
        ("ds4", HysteresisStart::Raised, 0.25, 0.3),
        ("lev2", HysteresisStart::Unknown, 0.2, 0.3),
    ] {
        let (logged, truth) = generated_run(&data, run);
        let model = build_any_model("truck", &estimated).unwrap();
        let tuning = EkfTuning {
            start_hysteresis: start,
            ..EkfTuning::default()
        };
        let series = weigh_ekf(&logged, model, &weigher, &tuning).unwrap();
        let score = scored(&logged, &truth, &series);
        assert!(
            score.standstill.samples > 1000,
            "{run}: {:?}",
            score.standstill
        );
        assert!(
            score.standstill.max_abs_error_percent < standstill_max
                && score.standstill.mean_error_percent.abs() < 0.1,
            "{run} standstill: {:?}",
            score.standstill
        );
        if valve_max > 0.0 {
            assert!(
                score.valve_activity.samples > 1000
                    && score.valve_activity.max_abs_error_percent < valve_max,
                "{run} valve at work: {:?}",
                score.valve_activity
            );
        }
        // The static method with the same file follows its wall (creep and friction) over
        // the heights: measured 0.07 / 0.11 / 0.10 % at standstills (this is the study's own
        // file, as estimated today; the weighing tests use the variants' fixtures).
        let static_series = weigh_static_from(&logged, &weigher, 20, start).unwrap();
        let static_score = scored(&logged, &truth, &static_series);
        println!("{run}, static: {:?}", static_score.standstill);
        assert!(
            static_score.standstill.max_abs_error_percent < 0.15,
            "{run} static standstill: {:?}",
            static_score.standstill
        );
    }
}
