//! Axle-load estimation against known loads: Model 2 data (exact structure) and the virtual
//! truck (richer than any model).

use airsus_apps::weigh::*;
use airsus_data::{Run, RunInputs, RunOutputs, TruckParameters, ValveState};
use airsus_model::{InitialCondition, Model2};
use airsus_sim::{InitialState, InputSeries, SimulationProblem, simulate};
use airsus_truck::experiments::run_experiment;
use airsus_truck::scenario::{data_set_1, data_set_2, data_set_3, data_set_4};
use airsus_truck::sensors::{NoiseSource, SensorSpec};
use airsus_truck::truth::VirtualTruck;

/// Model 2 with the virtual truck's thesis-structure parameters, valve closed, a 300 kg load
/// step at 20 s (3 s ramp) and -150 kg at 80 s; 140 s at 100 ms.
fn model2_run(noisy: bool) -> (Run, Vec<f64>, TruckParameters) {
    let truck = VirtualTruck::reference().physical;
    let model = Model2::new(&truck);
    let n = 1401;
    let time: Vec<f64> = (0..n).map(|k| k as f64 * 0.1).collect();
    let ramp = |t: f64, start: f64, len: f64| ((t - start) / len).clamp(0.0, 1.0);
    let load: Vec<f64> = time
        .iter()
        .map(|&t| 3390.0 + 300.0 * ramp(t, 20.0, 3.0) - 150.0 * ramp(t, 80.0, 3.0))
        .collect();
    let valve = vec![ValveState::Closed; n];
    let supply = vec![850e3; n];
    let road = vec![0.0; n];
    let inputs = InputSeries::new(&time, &load, &valve, &supply, &road).unwrap();
    let problem = SimulationProblem::new(
        &model,
        inputs,
        InitialState::Equilibrium(InitialCondition::SensorHeight { height_m: 0.24 }),
    );
    let r = simulate(&problem).unwrap();
    let (h, p) = if noisy {
        let mut noise = NoiseSource::new(7);
        (
            noise.measure(&r.sensor_height_m, SensorSpec::HEIGHT_M),
            noise.measure(&r.bellow_gauge_pa, SensorSpec::BELLOW_PRESSURE_PA),
        )
    } else {
        (r.sensor_height_m.clone(), r.bellow_gauge_pa.clone())
    };
    let run = Run {
        name: "m2-steps".into(),
        time_s: time,
        sample_time_s: 0.1,
        inputs: RunInputs {
            wheel_load_kg: load.clone(),
            valve,
            supply_gauge_pa: supply,
            road_height_m: road,
        },
        outputs: Some(RunOutputs {
            sensor_height_m: h,
            bellow_gauge_pa: p,
        }),
    };
    (run, load, truck)
}

fn score(run: &Run, truth: &[f64], s: &WeighSeries) -> AccuracySummary {
    evaluate_series(run, truth, s, &StandstillRule::default()).unwrap()
}

#[test]
fn static_weighing_with_true_parameters_on_noise_free_model_data_is_exact() {
    let (run, truth, truck) = model2_run(false);
    let w = StaticWeigher::new(
        StaticLaw::from_truck(&truck),
        WeighingUncertainty::default(),
    );
    let acc = score(&run, &truth, &weigh_static(&run, &w, 1).unwrap());
    // Same structure, same parameters: only the solver tolerance and the residual motion 30 s
    // after a step remain.
    assert!(acc.standstill.samples > 500);
    assert!(
        acc.standstill.max_abs_error_percent < 0.05,
        "{:?}",
        acc.standstill
    );
}

#[test]
fn static_weighing_on_the_virtual_truck_true_vs_nominal() {
    let vt = VirtualTruck::reference();
    let generated =
        run_experiment(&vt, &data_set_1(vt.physical.mass.unsprung_kg, 1), -120.0, 1).unwrap();
    let truth = &generated.truth.inputs.wheel_load_kg;
    let full = StaticWeigher::new(
        StaticLaw::from_virtual_truck(&vt),
        WeighingUncertainty::default(),
    );
    // Data-set 1 starts after the truck was lowered onto its height (the generator's plan).
    let start = HysteresisStart::Lowered;
    // Noise-free truth: with the complete true law, its wall's creep and friction among it,
    // what is left is the lever's and the gas's motion 30 s after a step.
    let clean = score(
        &generated.truth,
        truth,
        &weigh_static_from(&generated.truth, &full, 1, start).unwrap(),
    );
    println!(
        "virtual truck, true law, noise-free: {:?}",
        clean.standstill
    );
    assert!(clean.standstill.max_abs_error_percent < 0.02);
    assert!(clean.standstill.mean_error_percent.abs() < 0.01);
    // Logged (noisy, quantised) data, 2 s average: the sensors' noise adds a few kilograms.
    let noisy = score(
        &generated.logged,
        truth,
        &weigh_static_from(&generated.logged, &full, 20, start).unwrap(),
    );
    println!("virtual truck, true law, logged: {:?}", noisy.standstill);
    assert!(noisy.standstill.max_abs_error_percent < 0.15);
    assert!(noisy.standstill.mean_error_percent.abs() < 0.05);
    // The true law without its wall: the creep and the friction, 0.5 % at most and 0.04 %
    // on average (measured; it was this test's figure before the law had a wall).
    let gas_only = StaticWeigher::new(full.law.clone().without_wall(), full.uncertainty.clone());
    let g = score(
        &generated.logged,
        truth,
        &weigh_static(&generated.logged, &gas_only, 20).unwrap(),
    );
    assert!(
        g.standstill.max_abs_error_percent > 0.4,
        "{:?}",
        g.standstill
    );
    // The thesis structure with the true values lacks the wall stretch: about -1.2 %.
    let thesis = StaticWeigher::new(
        StaticLaw::from_truck(&vt.physical),
        WeighingUncertainty::default(),
    );
    let t = score(
        &generated.logged,
        truth,
        &weigh_static(&generated.logged, &thesis, 20).unwrap(),
    );
    assert!(
        (-1.6..-0.8).contains(&t.standstill.mean_error_percent),
        "{:?}",
        t.standstill
    );
    // Nominal parameters: about -5 %; the gap grey-box estimation has to close.
    let nominal = StaticWeigher::new(
        StaticLaw::from_truck(&TruckParameters::reference()),
        WeighingUncertainty::default(),
    );
    let n = score(
        &generated.logged,
        truth,
        &weigh_static(&generated.logged, &nominal, 20).unwrap(),
    );
    assert!(n.standstill.mean_error_percent < -3.0, "{:?}", n.standstill);
    // A two-point calibration against the logged loads takes most of that bias out.
    let est = weigh_static(&generated.logged, &nominal, 20).unwrap();
    let cal = LinearCalibration::fit(
        &generated.logged.time_s,
        &est.wheel_load_kg,
        &generated.logged.inputs.wheel_load_kg,
        &generated.logged.inputs.valve,
        None,
        &StandstillRule::default(),
    )
    .unwrap();
    let c = score(&generated.logged, truth, &cal.apply(&est, None).unwrap());
    // The calibrated interval on another run (data-set 2, its own loads and mishap): from
    // the calibration's residuals, it covers the true load about as often as it says.
    let validation =
        run_experiment(&vt, &data_set_2(vt.physical.mass.unsprung_kg, 2), -120.0, 2).unwrap();
    let v = score(
        &validation.logged,
        &validation.truth.inputs.wheel_load_kg,
        &cal.apply(
            &weigh_static(&validation.logged, &nominal, 20).unwrap(),
            None,
        )
        .unwrap(),
    );
    println!(
        "95 % interval coverage at standstill: true law {:.3}, thesis structure {:.3}, nominal {:.3}, calibrated {:.3}, calibrated on data-set 2 {:.3} (mean {:+.3} %, max {:.3} %)",
        noisy.standstill.within_95_interval,
        t.standstill.within_95_interval,
        n.standstill.within_95_interval,
        c.standstill.within_95_interval,
        v.standstill.within_95_interval,
        v.standstill.mean_error_percent,
        v.standstill.max_abs_error_percent
    );
    // The assumed parameter errors make the interval too wide with the true law (it covers
    // everything) and far too narrow around the nominal file's bias (it covers nothing);
    // calibrated on known loads it says what it covers.
    assert!(noisy.standstill.within_95_interval > 0.99);
    assert!(n.standstill.within_95_interval < 0.05);
    assert!((0.92..=0.98).contains(&v.standstill.within_95_interval));
    assert!(
        c.standstill.mean_error_percent.abs() < 0.3,
        "{:?}",
        c.standstill
    );
}

#[test]
fn uncertainty_propagation_matches_hand_numbers() {
    let truck = TruckParameters::reference();
    let w = StaticWeigher::new(
        StaticLaw::from_truck(&truck),
        WeighingUncertainty::default(),
    );
    let e = w.estimate(0.240, 330e3).unwrap();
    // dm/dp ≈ k_l A / g = 1.4516 * 0.0553 / 9.81 = 8.2e-3 kg/Pa; σ_p = √(200² + 100²/12)
    // = 202 Pa → 1.66 kg per sample (the height adds little: the area is flat).
    assert!(
        (1.4..2.0).contains(&e.measurement_std_kg),
        "{}",
        e.measurement_std_kg
    );
    // Parameters: 1 % of the sprung load (~27 kg), 20 kg unsprung, friction 100 N → 8.6 kg.
    assert!(
        (30.0..45.0).contains(&e.parameter_std_kg),
        "{}",
        e.parameter_std_kg
    );
    let sensors = StaticWeigher::new(
        StaticLaw::from_truck(&truck),
        WeighingUncertainty::default().sensors_only(),
    );
    assert!(sensors.estimate(0.240, 330e3).unwrap().parameter_std_kg < 1e-9);
}

#[test]
fn bad_readings_are_errors_not_panics() {
    let law = StaticLaw::from_truck(&TruckParameters::reference());
    assert!(law.wheel_load_kg(0.24, -5.0).is_err());
    assert!(law.wheel_load_kg(f64::NAN, 330e3).is_err());
    assert!(law.wheel_load_kg(5.0, 330e3).is_err());
}

/// Bounded innovations: a single pressure spike (+60 kPa) and a height dropout (-25 mm) in
/// steady stretches move the estimate by a few kg with the gate, by far more without it.
#[test]
fn ekf_glitches_are_bounded() {
    let (mut run, truth, truck) = model2_run(true);
    let w = StaticWeigher::new(
        StaticLaw::from_truck(&truck),
        WeighingUncertainty::default(),
    );
    let outputs = run.outputs.as_mut().unwrap();
    outputs.bellow_gauge_pa[500] += 60e3;
    outputs.sensor_height_m[1100] -= 0.025;
    let worst = |tuning: &EkfTuning| {
        let s = weigh_ekf(&run, Box::new(Model2::new(&truck)), &w, tuning).unwrap();
        [500usize, 1100]
            .iter()
            .map(|&g| {
                (g..g + 60)
                    .map(|k| (s.wheel_load_kg[k] - truth[k]).abs())
                    .fold(0.0f64, f64::max)
            })
            .fold(0.0f64, f64::max)
    };
    let gated = worst(&EkfTuning::default());
    let open = worst(&EkfTuning {
        innovation_gate_sigma: f64::INFINITY,
        ..EkfTuning::default()
    });
    println!("worst error within 6 s of a glitch: gated {gated:.1} kg, ungated {open:.1} kg");
    assert!(gated < 10.0, "gated: {gated} kg");
    assert!(open > 3.0 * gated, "ungated {open} kg, gated {gated} kg");
}

#[test]
fn ekf_converges_on_a_load_step() {
    let (run, truth, truck) = model2_run(true);
    let w = StaticWeigher::new(
        StaticLaw::from_truck(&truck),
        WeighingUncertainty::default(),
    );
    let s = weigh_ekf(
        &run,
        Box::new(Model2::new(&truck)),
        &w,
        &EkfTuning::default(),
    )
    .unwrap();
    // Step ramps from 20 s to 23 s (+300 kg). Within 1 % of the true load 2 s after the ramp
    // ends, and within 0.2 % from 10 s after it to the next step.
    let at = |t: f64| (t / 0.1).round() as usize;
    for (k, (&est, &m)) in s.wheel_load_kg.iter().zip(&truth).enumerate() {
        if !(at(25.0)..at(80.0)).contains(&k) {
            continue;
        }
        let err = (est - m).abs() / m;
        assert!(
            err < 0.01,
            "t = {:.1}: error {:.3} %",
            run.time_s[k],
            100.0 * err
        );
        if k >= at(33.0) {
            assert!(
                err < 0.002,
                "t = {:.1}: error {:.3} %",
                run.time_s[k],
                100.0 * err
            );
        }
    }
    let acc = score(&run, &truth, &s);
    println!("EKF on noisy Model 2 data: {:?}", acc.standstill);
    assert!(acc.standstill.max_abs_error_percent < 0.2);
}

/// A levelling run on `vt`: the load-steps sequence at 240 mm while the deadband controller
/// works the valve, the plant the virtual truck with its tank. Returns the log and the true load.
fn levelling_run(vt: &VirtualTruck, seed: u64) -> (Run, Vec<f64>) {
    use airsus_apps::control::{
        ClosedLoopConfig, DeadbandController, GuardSettings, Plant, level_scenario,
        simulate_closed_loop,
    };
    use airsus_truck::model::{SupplyMode, TruckModel};
    let plant = Plant::Truck(Box::new(TruckModel::new(vt.clone(), SupplyMode::Tank)));
    let scenario = level_scenario("load-steps", 0.240, 3390.0).unwrap();
    let mut controller = DeadbandController::new(GuardSettings::default());
    let closed = simulate_closed_loop(
        &plant,
        &mut controller,
        &scenario,
        &ClosedLoopConfig {
            seed,
            ..ClosedLoopConfig::default()
        },
    )
    .unwrap();
    let (logged, _) = closed.to_runs("levelling");
    (logged, closed.true_load_kg)
}

fn cal_run<'a>(run: &'a Run, est: &'a WeighSeries, h: Option<&'a [f64]>) -> CalibrationRun<'a> {
    CalibrationRun {
        time_s: &run.time_s,
        estimate_kg: &est.wheel_load_kg,
        known_kg: &run.inputs.wheel_load_kg,
        valve: &run.inputs.valve,
        height_m: h,
        quality: None,
        measurement_std_kg: None,
        road_m: Some(&run.inputs.road_height_m),
        bellow_gauge_pa: None,
    }
}

fn flags(run: &Run) -> Vec<WeighQuality> {
    quality_flags(run, &StandstillDetector::default()).unwrap()
}

/// Calibrated with the nominal truck file (a larger mismatch than any estimated file) on the
/// known loads of our protocol's estimation runs — data-set 1 (load steps) and data-set 3
/// (valve pulses at one load) — then weighing held-out runs on every virtual-truck variant:
/// data-set 2 (other loads, a mishap), data-set 4 (one load, long valve steps) and a levelling
/// run (load steps while the controller works the valve, at another height).
#[test]
fn calibrated_weighing_on_every_variant_held_out() {
    let nominal = StaticWeigher::new(
        StaticLaw::from_truck(&TruckParameters::reference()),
        WeighingUncertainty::default(),
    );
    let heights = |run: &Run| run.measured().unwrap().sensor_height_m.clone();
    for variant in 0..=3 {
        let vt = VirtualTruck::variant(variant);
        let m2 = vt.physical.mass.unsprung_kg;
        let friction = vt.effect_parameters.friction_force_n;
        let ds1 = run_experiment(&vt, &data_set_1(m2, 1), -friction, 1).unwrap();
        let ds3 = run_experiment(&vt, &data_set_3(m2, 3), friction, 3).unwrap();
        let est1 = weigh_static(&ds1.logged, &nominal, 20).unwrap();
        let est3 = weigh_static(&ds3.logged, &nominal, 20).unwrap();
        let (h1, h3) = (heights(&ds1.logged), heights(&ds3.logged));
        let rule = StandstillRule::default();
        let plain =
            LinearCalibration::fit_runs(&[cal_run(&ds1.logged, &est1, None)], &rule).unwrap();
        let loading_only =
            LinearCalibration::fit_runs(&[cal_run(&ds1.logged, &est1, Some(&h1))], &rule).unwrap();
        let cal = LinearCalibration::fit_runs(
            &[
                cal_run(&ds1.logged, &est1, Some(&h1)),
                cal_run(&ds3.logged, &est3, Some(&h3)),
            ],
            &rule,
        )
        .unwrap();
        let who = format!("variant {variant}");
        assert!(
            cal.hysteresis_kg < -10.0,
            "{who}: a fill reads high: {cal:?}"
        );
        println!(
            "{who}: load = {:.4} m̂ {:+.1} kg {:+.1} kg z {:+.2} kg/mm (h - {:.1} mm), q95 {:.1} kg, dropped {:?}; ds1 alone dropped {:?}",
            cal.gain,
            cal.offset_kg,
            cal.hysteresis_kg,
            cal.height_kg_per_mm,
            cal.reference_height_mm,
            cal.residual_q95_kg,
            cal.dropped,
            loading_only.dropped,
        );
        let ds2 = run_experiment(&vt, &data_set_2(m2, 2), -friction, 2).unwrap();
        let ds4 = run_experiment(&vt, &data_set_4(m2, 4), friction, 4).unwrap();
        let (lev, lev_truth) = levelling_run(&vt, 40 + u64::from(variant));
        let held_out = [
            ("ds2", &ds2.logged, &ds2.truth.inputs.wheel_load_kg),
            ("ds4", &ds4.logged, &ds4.truth.inputs.wheel_load_kg),
            ("levelling", &lev, &lev_truth),
        ];
        for (name, run, truth) in held_out {
            let est = weigh_static(run, &nominal, 20).unwrap();
            let h = heights(run);
            let p = score(run, truth, &plain.apply(&est, None).unwrap());
            let l = score(run, truth, &loading_only.apply(&est, Some(&h)).unwrap());
            let v = score(run, truth, &cal.apply(&est, Some(&h)).unwrap());
            if name == "ds2" {
                // Gain and offset alone: the interval says what it covers (95 % ± 3 %), but
                // single standstills reach about 1 %: the wall friction, read one way after a
                // fill and the other after an exhaust.
                assert!(
                    (0.92..=0.98).contains(&p.standstill.within_95_interval),
                    "{who}: the gain-offset interval covers {:.3}",
                    p.standstill.within_95_interval
                );
                assert!(p.standstill.max_abs_error_percent < 1.5, "{who}: {p:?}");
                // With the hysteresis and height terms: every held-out standstill within
                // 0.43-0.65 % (measured), the bias under 0.11 %, the interval from the
                // calibration's residuals covering 94-100 %.
                assert!(v.standstill.max_abs_error_percent < 0.7, "{who}: {v:?}");
                assert!(v.standstill.mean_error_percent.abs() < 0.15, "{who}: {v:?}");
                assert!(
                    v.standstill.within_95_interval >= 0.92,
                    "{who}: the interval covers {:.3}",
                    v.standstill.within_95_interval
                );
            }
            println!(
                "  {name}: standstill max: gain+offset {:.3} %, ds1 alone {:.3} %, ds1+ds3 {:.3} % (mean {:+.3} %, coverage {:.3}, {} samples); after valve max {:.3} % coverage {:.3} ({}); valve at work max {:.3} % coverage {:.3} ({})",
                p.standstill.max_abs_error_percent,
                l.standstill.max_abs_error_percent,
                v.standstill.max_abs_error_percent,
                v.standstill.mean_error_percent,
                v.standstill.within_95_interval,
                v.standstill.samples,
                v.after_valve.max_abs_error_percent,
                v.after_valve.within_95_interval,
                v.after_valve.samples,
                v.valve_activity.max_abs_error_percent,
                v.valve_activity.within_95_interval,
                v.valve_activity.samples,
            );
        }
    }
}

/// The filter on a truck richer than its model: Model 2 with the nominal file on variants 1
/// and 3 (ISO 6358 and linear valve laws, creep, wall friction, a stretching bellow),
/// calibrated on data-sets 1+3 through its own estimates, weighing data-set 2 held out. The
/// calibrated interval comes from the calibration's residuals and the filter's own spread,
/// not from assumed parameter errors, so it says what it covers.
#[test]
fn ekf_on_a_richer_truck_calibrated_held_out() {
    let nominal_truck = TruckParameters::reference();
    let nominal = StaticWeigher::new(
        StaticLaw::from_truck(&nominal_truck),
        WeighingUncertainty::default(),
    );
    let ekf = |run: &Run| {
        weigh_ekf(
            run,
            Box::new(Model2::new(&nominal_truck)),
            &nominal,
            &EkfTuning::default(),
        )
        .unwrap()
    };
    let heights = |run: &Run| run.measured().unwrap().sensor_height_m.clone();
    for variant in [1, 3] {
        let vt = VirtualTruck::variant(variant);
        let m2 = vt.physical.mass.unsprung_kg;
        let friction = vt.effect_parameters.friction_force_n;
        let ds1 = run_experiment(&vt, &data_set_1(m2, 1), -friction, 1).unwrap();
        let ds3 = run_experiment(&vt, &data_set_3(m2, 3), friction, 3).unwrap();
        let ds2 = run_experiment(&vt, &data_set_2(m2, 2), -friction, 2).unwrap();
        let (est1, est3) = (ekf(&ds1.logged), ekf(&ds3.logged));
        let (h1, h3) = (heights(&ds1.logged), heights(&ds3.logged));
        let (q1, q3) = (flags(&ds1.logged), flags(&ds3.logged));
        let cal = LinearCalibration::fit_runs(
            &[
                cal_run(&ds1.logged, &est1, Some(&h1)).with_quality(&q1),
                cal_run(&ds3.logged, &est3, Some(&h3)).with_quality(&q3),
            ],
            &StandstillRule::default(),
        )
        .unwrap();
        println!(
            "variant {variant}: residual q95 standstill {:.1} kg, settling {:?}, valve {:?}",
            cal.residual_q95_kg, cal.settling_q95_kg, cal.valve_q95_kg
        );
        let raw = ekf(&ds2.logged);
        let truth = &ds2.truth.inputs.wheel_load_kg;
        let uncalibrated = score(&ds2.logged, truth, &raw);
        let calibrated = score(
            &ds2.logged,
            truth,
            &cal.apply_with_quality(
                &raw,
                Some(&heights(&ds2.logged)),
                Some(&flags(&ds2.logged)),
                Some(&ds2.logged.inputs.valve),
            )
            .unwrap(),
        );
        println!(
            "variant {variant}: EKF nominal: mean {:+.3} %, max {:.3} %, coverage {:.3}; calibrated: mean {:+.3} %, max {:.3} %, coverage {:.3}, mean σ {:.1} kg",
            uncalibrated.standstill.mean_error_percent,
            uncalibrated.standstill.max_abs_error_percent,
            uncalibrated.standstill.within_95_interval,
            calibrated.standstill.mean_error_percent,
            calibrated.standstill.max_abs_error_percent,
            calibrated.standstill.within_95_interval,
            calibrated.standstill.mean_std_kg,
        );
        for (name, run, truth) in [
            {
                let ds4 = run_experiment(&vt, &data_set_4(m2, 4), friction, 4).unwrap();
                ("ds4", ds4.logged, ds4.truth.inputs.wheel_load_kg)
            },
            {
                let (lev, t) = levelling_run(&vt, 40 + u64::from(variant));
                ("levelling", lev, t)
            },
        ] {
            let a = score(
                &run,
                &truth,
                &cal.apply_with_quality(
                    &ekf(&run),
                    Some(&heights(&run)),
                    Some(&flags(&run)),
                    Some(&run.inputs.valve),
                )
                .unwrap(),
            );
            println!(
                "  {name}: standstill max {:.3} % cov {:.3}; after valve max {:.3} % cov {:.3}; valve at work max {:.3} % mean {:+.3} % cov {:.3}",
                a.standstill.max_abs_error_percent,
                a.standstill.within_95_interval,
                a.after_valve.max_abs_error_percent,
                a.after_valve.within_95_interval,
                a.valve_activity.max_abs_error_percent,
                a.valve_activity.mean_error_percent,
                a.valve_activity.within_95_interval,
            );
        }
        let who = format!("variant {variant}");
        // The nominal file is 7-10 % off and its assumed parameter errors do not cover it.
        assert!(
            uncalibrated.standstill.within_95_interval < 0.05,
            "{who}: {uncalibrated:?}"
        );
        // Calibrated: within 0.44-0.68 % (measured), the interval a few kg wide where it
        // was 40-50 kg while the assumed parameter errors set it, covering 94-100 %.
        let c = &calibrated.standstill;
        assert!(c.max_abs_error_percent < 0.75, "{who}: {c:?}");
        assert!(c.mean_error_percent.abs() < 0.15, "{who}: {c:?}");
        assert!(c.mean_std_kg < 15.0, "{who}: {c:?}");
        assert!(c.within_95_interval >= 0.92, "{who}: {c:?}");
    }
}

/// The truck file the study estimated on variant `k` (our protocol, the `truck` structure,
/// seed 1; `tools/weigh/make_fixtures.sh` writes them): what weighing may use, never the truth.
fn study_estimate(k: u32) -> TruckParameters {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(format!("tests/fixtures/study_truck_variant{k}.toml"));
    airsus_data::read_truck(&path).unwrap().parameters
}

/// Variant `k` with its study estimate: the truck, its unsprung mass, its wall friction (N),
/// and the EKF on the `truck` structure with that estimate, told how a run starts.
struct StudiedVariant {
    truck: VirtualTruck,
    unsprung_kg: f64,
    friction_n: f64,
    estimate: TruckParameters,
    weigher: StaticWeigher,
}

impl StudiedVariant {
    fn new(k: u32) -> Self {
        let truck = VirtualTruck::variant(k);
        let estimate = study_estimate(k);
        Self {
            unsprung_kg: truck.physical.mass.unsprung_kg,
            friction_n: truck.effect_parameters.friction_force_n,
            truck,
            weigher: StaticWeigher::new(
                StaticLaw::from_truck(&estimate),
                WeighingUncertainty::default(),
            ),
            estimate,
        }
    }

    fn ekf(&self, run: &Run, start: HysteresisStart) -> WeighSeries {
        let tuning = EkfTuning {
            start_hysteresis: start,
            ..EkfTuning::default()
        };
        let model = Box::new(airsus_truck::model::TruckModel::from_truck_parameters(
            &self.estimate,
        ));
        weigh_ekf(run, model, &self.weigher, &tuning).unwrap()
    }
}

/// One held-out run weighed with a variant's study estimate ([`weigh_variants_held_out`]).
struct HeldOut {
    who: String,
    calibration: LinearCalibration,
    score: AccuracySummary,
}

/// Each variant's study estimate weighing runs the study did not see (new noise and step
/// seeds), by `weigh(variant, run, start)`. The interval is sized on the study's estimation
/// runs (data-sets 1 and 3, levelling 1, their logged loads; `terms` says what the calibration
/// may also correct); then data-set 2, data-set 4 and levelling 2 are weighed. Data-sets 1-2
/// start after the truck was lowered onto its height, 3-4 after it was raised (the
/// generator's plan), levelling runs with the wall unloaded: said to the estimator.
fn weigh_variants_held_out(
    weigh: &dyn Fn(&StudiedVariant, &Run, HysteresisStart) -> WeighSeries,
    terms: CalibrationTerms,
) -> Vec<HeldOut> {
    use airsus_truck::experiments::{GeneratedRun, levelling_run};
    use airsus_truck::scenario::{levelling_1, levelling_2};
    let mut out = Vec::new();
    for k in 0..=3 {
        let variant = StudiedVariant::new(k);
        let (vt, m2, friction) = (&variant.truck, variant.unsprung_kg, variant.friction_n);
        let seed = 100 + u64::from(k);
        let experiment =
            |scenario, f: f64| -> GeneratedRun { run_experiment(vt, &scenario, f, seed).unwrap() };
        let calibration = [
            (
                experiment(data_set_1(m2, seed), -friction).logged,
                HysteresisStart::Lowered,
            ),
            (
                experiment(data_set_3(m2, seed), friction).logged,
                HysteresisStart::Raised,
            ),
            (
                levelling_run(vt, levelling_1(m2, seed), seed)
                    .unwrap()
                    .logged,
                HysteresisStart::Unknown,
            ),
        ];
        let estimates: Vec<WeighSeries> = calibration
            .iter()
            .map(|(run, start)| weigh(&variant, run, *start))
            .collect();
        let pairs: Vec<(&Run, &WeighSeries)> = calibration
            .iter()
            .map(|(run, _)| run)
            .zip(&estimates)
            .collect();
        let cal =
            LinearCalibration::fit_weighed_runs(&pairs, &StandstillRule::default(), terms).unwrap();
        println!(
            "variant {k}: interval: the estimate's own σ × {:.3}, beside it {:.2} kg at standstill; settling × {:.3}, {:.2} kg",
            cal.own_std_scale,
            cal.standstill_std_kg,
            cal.settling_own_scale.unwrap_or(f64::NAN),
            cal.settling_std_kg.unwrap_or(f64::NAN),
        );
        let held_out = [
            (
                "ds2",
                experiment(data_set_2(m2, seed), -friction),
                HysteresisStart::Lowered,
            ),
            (
                "ds4",
                experiment(data_set_4(m2, seed), friction),
                HysteresisStart::Raised,
            ),
            (
                "levelling 2",
                levelling_run(vt, levelling_2(m2, seed), seed).unwrap(),
                HysteresisStart::Unknown,
            ),
        ];
        for (name, run, start) in held_out {
            let raw = weigh(&variant, &run.logged, start);
            let heights = run.logged.measured().unwrap().sensor_height_m.clone();
            let flags = flags(&run.logged);
            let weighed = cal
                .apply_with_quality(
                    &raw,
                    Some(&heights),
                    Some(&flags),
                    Some(&run.logged.inputs.valve),
                )
                .unwrap();
            let a = score(&run.logged, &run.truth.inputs.wheel_load_kg, &weighed);
            let who = format!("variant {k}, {name}");
            println!(
                "{who}: standstill max {:.3} % mean {:+.3} % σ {:.1} kg coverage {:.3} ({} samples); valve at work max {:.3} % coverage {:.3}; after valve max {:.3} %; load arriving max {:.3} % coverage {:.3}; settling max {:.3} %",
                a.standstill.max_abs_error_percent,
                a.standstill.mean_error_percent,
                a.standstill.mean_std_kg,
                a.standstill.within_95_interval,
                a.standstill.samples,
                a.valve_activity.max_abs_error_percent,
                a.valve_activity.within_95_interval,
                a.after_valve.max_abs_error_percent,
                a.load_change.max_abs_error_percent,
                a.load_change.within_95_interval,
                a.settling.max_abs_error_percent,
            );
            out.push(HeldOut {
                who,
                calibration: cal.clone(),
                score: a,
            });
        }
    }
    out
}

/// The coverage of the 95 % interval over the held-out runs' samples of one class: pooled,
/// and on the average run.
fn held_out_coverage(runs: &[HeldOut], class: fn(&AccuracySummary) -> &ErrorStats) -> (f64, f64) {
    let (mut covered, mut samples) = (0.0, 0usize);
    let mut per_run = Vec::new();
    for run in runs {
        let stats = class(&run.score);
        covered += stats.within_95_interval * stats.samples as f64;
        samples += stats.samples;
        if stats.samples > 0 {
            per_run.push(stats.within_95_interval);
        }
    }
    (
        covered / samples as f64,
        per_run.iter().sum::<f64>() / per_run.len() as f64,
    )
}

/// Issue #14: the EKF on the `truck` structure with each variant's study estimate, on runs
/// the study did not see ([`weigh_variants_held_out`]). Its interval must hold the held-out
/// truth on 95 ± 3 % of the standstills, pooled and on the average run, and of the samples
/// while the valve works and after it.
/// Before the filter drove the wall friction through a play, the noise's jitter wore the
/// friction away and standstills read 0.5-0.9 % off, by the friction's sign.
#[test]
fn ekf_with_the_study_estimate_weighs_every_variant_to_half_a_percent() {
    let runs = weigh_variants_held_out(
        &|variant, run, start| variant.ekf(run, start),
        CalibrationTerms::IntervalOnly,
    );
    for HeldOut {
        who,
        calibration: cal,
        score: a,
    } in &runs
    {
        // Nothing corrected: the model carries the scale.
        assert_eq!((cal.gain, cal.offset_kg), (1.0, 0.0));
        // The filter's covariance is wider than its errors at standstill: scaled down
        // (measured 0.54-0.90).
        assert!(cal.own_std_scale < 1.0, "{cal:?}");
        assert!(a.standstill.samples > 1000, "{who}: {a:?}");
        // Measured: at most 0.136 % (variant 0's data-set 4); 0.303 % on variant 2's
        // before its study reached data-set 4's ceiling (the valve held at the lab's).
        assert!(a.standstill.max_abs_error_percent < 0.25, "{who}: {a:?}");
        assert!(a.valve_activity.max_abs_error_percent < 1.0, "{who}: {a:?}");
        assert!(a.after_valve.max_abs_error_percent < 1.0, "{who}: {a:?}");
        // While a load arrives (its first 10 s) the filter lags it: measured 1.7-2.2 %; in
        // the 10-30 s after, 0.15-0.42 %.
        assert!(a.load_change.max_abs_error_percent < 3.0, "{who}: {a:?}");
        assert!(a.settling.max_abs_error_percent < 0.6, "{who}: {a:?}");
        // An interval of a few kilograms (0.3 % of the load at most), not the 36-38 kg
        // the assumed parameter errors give.
        assert!(a.standstill.mean_std_kg < 12.0, "{who}: {a:?}");
        // Each run's standstills mostly inside it. Measured 0.911-0.997 (0.897-1.000 since the
        // family's hinges damp: variant 2's levelling 2 the lowest). Data-set 4's long
        // valve steps lift the bellow 10-30 mm above the calibration's heights, where the
        // study's law reads up to 4 kg off (variant 0): before the interval widened beyond
        // the calibrated heights, that run held 0.841.
        assert!(a.standstill.within_95_interval > 0.88, "{who}: {a:?}");
    }
    // Every sample of the held-out runs, whatever its class: measured 0.970 pooled, 0.969
    // on the average run (0.961 and 0.959 before the family's hinges damped).
    let (every, every_run_mean) = held_out_coverage(&runs, |a| &a.all);
    println!("every sample: pooled {every:.3}, average run {every_run_mean:.3}");
    assert!((0.92..=0.98).contains(&every), "{every}");
    assert!((0.92..=0.98).contains(&every_run_mean), "{every_run_mean}");
    // The 10-30 s after a load change, the valve closed: measured 0.983 pooled, 0.992 on
    // the average run (0.991 and 0.995 while they got the settling part sized on the
    // seconds after a valve step too). Still a little wide: their own part's scale, sized
    // at 0.47-0.61, is raised to the standstill's (0.54-0.90), which every class is held
    // to; without that floor they held 0.963, but the valve's work 0.912.
    let (settling, _) = held_out_coverage(&runs, |a| &a.settling);
    println!("settling: pooled {settling:.3}");
    assert!((0.92..=0.985).contains(&settling), "{settling}");
    let (valve_coverage, _) = held_out_coverage(&runs, |a| &a.valve_activity);
    let (after_coverage, _) = held_out_coverage(&runs, |a| &a.after_valve);
    println!(
        "coverage of the 95 % interval while the valve works {valve_coverage:.3}, at standstill after it {after_coverage:.3}"
    );
    // Measured 0.956 and 0.976 (0.932 and 0.966 before the family's hinges damped; 0.889
    // and 0.971 while the study's joint fit held the hinge's friction at the file's 0.1 N s/m).
    // Without the interval's widening beyond the calibrated heights, 0.914 and 0.933:
    // data-set 4's valve steps and their settling are where the bellow leaves the
    // calibration's heights.
    assert!((0.92..=0.98).contains(&valve_coverage), "{valve_coverage}");
    assert!((0.92..=0.98).contains(&after_coverage), "{after_coverage}");
    let (coverage, run_mean) = held_out_coverage(&runs, |a| &a.standstill);
    // Measured: 0.974 pooled and on the average run (0.965 and 0.966 before the family's
    // hinges damped); 0.976 and 0.975 while the standstill
    // interval was sized on every known standstill of the calibration runs, not only those
    // their flags call standstill. With the filter's own covariance unscaled, 0.994: the
    // interval said less than it could.
    println!(
        "standstill coverage of the 95 % interval: pooled {coverage:.3}, average run {run_mean:.3}"
    );
    assert!((0.92..=0.98).contains(&coverage), "{coverage}");
    assert!((0.92..=0.98).contains(&run_mean), "{run_mean}");
    // While a load arrives: the samples flagged `loading` (from the run alone) get the
    // interval the calibration runs' arrivals measured. Before that flag they got the
    // settling interval, sized at a steady load, and it held 39-68 % of them; before the
    // flag carried on while the levelling controller opens the valve, those samples got the
    // valve's interval and the levelling run held 74-78 %.
    // Measured 0.950 pooled, 0.949 on the average run (0.952 and 0.951 before the family's
    // hinges damped; 0.895-0.988 per run then). The calibration
    // runs log the load set down as a step when it starts to arrive (what a log knows);
    // sized against that step, 280-300 kg from the estimate at the arrival's start while
    // the truck's load moves there over 3-8 s, the interval held 1.000. Sized against
    // where the pressure says the load was (within the lag it trails by,
    // `arriving_load_kg`), it holds what it says; against the pressure's reading without
    // the lag, 0.86 (the static weighing's).
    let (arriving, arriving_run_mean) = held_out_coverage(&runs, |a| &a.load_change);
    println!("load arriving: pooled {arriving:.3}, average run {arriving_run_mean:.3}");
    assert!((0.92..=0.98).contains(&arriving), "{arriving}");
    assert!(
        (0.92..=0.98).contains(&arriving_run_mean),
        "{arriving_run_mean}"
    );
}

/// Issue #14: static weighing with each variant's study estimate, on the runs the EKF weighs
/// above. The estimate is a `truck`-structure file, so the static law carries its wall: the
/// creep still relaxing after a load step and the friction where the last movement slid it
/// ([`WallForces`]), told how each run starts. Without the wall, the same file read data-set
/// 2's standstills up to 0.86-1.07 % off (0.52-0.74 % after a calibration's gain, offset,
/// hysteresis and height terms): the creep held 30 s after a 300 kg step is worth 0.5-1 %.
#[test]
fn static_weighing_with_the_study_estimate_reads_its_wall() {
    let weigh_with = |wall: bool| {
        move |variant: &StudiedVariant, run: &Run, start| {
            let weigher = if wall {
                variant.weigher.clone()
            } else {
                StaticWeigher::new(
                    variant.weigher.law.clone().without_wall(),
                    WeighingUncertainty::default(),
                )
            };
            weigh_static_from(run, &weigher, 20, start).unwrap()
        }
    };
    let runs = weigh_variants_held_out(&weigh_with(true), CalibrationTerms::IntervalOnly);
    for HeldOut {
        who,
        calibration: cal,
        score: a,
    } in &runs
    {
        assert!(a.standstill.samples > 1000, "{who}: {a:?}");
        // Measured at most 0.108 % (variant 0's levelling 2), 0.04-0.11 % on every run.
        assert!(a.standstill.max_abs_error_percent < 0.25, "{who}: {a:?}");
        // Measured 0.11-0.58 % while the valve works: the gas's temperature and the
        // lever's dynamics are not in a static law, and its 2 s average lags.
        assert!(a.valve_activity.max_abs_error_percent < 1.0, "{who}: {a:?}");
        assert!(a.after_valve.max_abs_error_percent < 0.25, "{who}: {a:?}");
        // While a load arrives its 2 s average lags further than the filter: measured
        // 2.8-3.9 % in the first 10 s; then the wall's creep reads the settling truck to
        // 0.04-0.10 % (the file without its wall: 0.13-0.94 %).
        assert!(a.load_change.max_abs_error_percent < 5.0, "{who}: {a:?}");
        assert!(a.settling.max_abs_error_percent < 0.25, "{who}: {a:?}");
        // A standstill interval of 1.3-3.6 kg (0.1 % of the load), not the 36-38 kg the
        // assumed parameter errors give.
        assert!(a.standstill.mean_std_kg < 5.0, "{who}: {a:?} {cal:?}");
        // Measured 0.915-1.000 per run.
        assert!(a.standstill.within_95_interval > 0.9, "{who}: {a:?}");
    }
    // The interval says what it holds: measured 0.972 pooled, 0.977 on the average run
    // (0.960 and 0.972 before the family's hinges damped).
    // It held 0.999 and 0.998-1.0 per run while (1) the standstill interval was sized on
    // every known standstill of the calibration runs: the levelling run's, which its flags
    // call settling (the pressure drifts for minutes after the controller's fills), set it
    // at twice what the loading runs need; and (2) one settling interval served the first
    // seconds after a valve step, when the gas is still warm (data-set 3 misses by up to
    // 13 kg), and the minutes after (1-2 kg), where every standstill of data-set 4 and of
    // the levelling run is flagged settling. (1) alone: 0.967 pooled, 0.984 on the average
    // run.
    let (coverage, run_mean) = held_out_coverage(&runs, |a| &a.standstill);
    println!("static, standstill coverage: pooled {coverage:.3}, average run {run_mean:.3}");
    // The 10-30 s after a load change, the valve closed: measured 0.959 pooled, 0.981 on
    // the average run, a little above 98 % (0.953 and 0.978 before the family's hinges
    // damped; the band's upper end is 0.985 since). They held 1.000 while every early
    // `settling` sample got one part, sized on the seconds after a valve step too (the gas
    // still warm, up to 13 kg off);
    // settling after a load's arrival with the valve closed has its own part now.
    let (settling, settling_run_mean) = held_out_coverage(&runs, |a| &a.settling);
    println!("static, settling: pooled {settling:.3}, average run {settling_run_mean:.3}");
    // Since the family's hinges damp: 0.959 pooled, 0.981 on the average run.
    assert!((0.92..=0.98).contains(&settling), "{settling}");
    assert!(
        (0.92..=0.985).contains(&settling_run_mean),
        "{settling_run_mean}"
    );
    // Every sample of the held-out runs, whatever its class: measured 0.970 pooled, 0.975 on
    // the average run since the family's hinges damp; before, 0.961 pooled, 0.969
    // on the average run (0.967 and 0.973 before the part after a load). Over-covered
    // still (left alone), at 0.980-0.985: the valve's work and the standstills after it.
    let (every, every_run_mean) = held_out_coverage(&runs, |a| &a.all);
    println!("static, every sample: pooled {every:.3}, average run {every_run_mean:.3}");
    assert!((0.92..=0.98).contains(&every), "{every}");
    assert!((0.92..=0.98).contains(&every_run_mean), "{every_run_mean}");
    assert!((0.92..=0.98).contains(&coverage), "{coverage}");
    assert!((0.92..=0.98).contains(&run_mean), "{run_mean}");
    // Measured 0.946 pooled and on the average run (0.947 and 0.946 before the family's
    // hinges damped; 0.872-0.992 per run then): sized against
    // where the pressure says the load was, as the filter's above. Sized against the
    // logged step, 0.999; against the pressure's reading without the lag it trails by,
    // 0.862.
    let (arriving, arriving_run_mean) = held_out_coverage(&runs, |a| &a.load_change);
    println!("static, load arriving: pooled {arriving:.3}, average run {arriving_run_mean:.3}");
    assert!((0.92..=0.98).contains(&arriving), "{arriving}");
    assert!(
        (0.92..=0.98).contains(&arriving_run_mean),
        "{arriving_run_mean}"
    );
    // The wall is what reads to a tenth of a percent: the same file without it, calibrated
    // with every term a static law lacks, misses 0.5 % on data-set 2.
    let plain =
        weigh_variants_held_out(&weigh_with(false), CalibrationTerms::ScaleHysteresisHeight);
    let worst_ds2 = plain
        .iter()
        .filter(|r| r.who.ends_with("ds2"))
        .map(|r| r.score.standstill.max_abs_error_percent)
        .fold(0.0, f64::max);
    assert!(worst_ds2 > 0.5, "without the wall: {worst_ds2} %");
}

/// Weighing while the truck drives (#14): the EKF on the `truck` structure with each variant's
/// study estimate over the variant's road runs (humps and potholes at 20 km/h; an ISO 8608
/// class C road at 50 km/h), at a steady load, on seeds the study did not see. The filter
/// follows the road linearly between the logged samples, as the simulator and the truck do;
/// held as a staircase, each 100 ms road sample was a step into the tire, and the load read
/// up to 8.5 % off (variant 0's road 1 here; 4.5-7.4 % on the variants' seed-1 road runs).
#[test]
fn ekf_weighs_a_driving_truck_over_humps_and_a_rough_road() {
    use airsus_truck::scenario::{road_1, road_2};
    for k in 0..=3 {
        let variant = StudiedVariant::new(k);
        let (vt, m2, friction) = (&variant.truck, variant.unsprung_kg, variant.friction_n);
        let seed = 200 + u64::from(k);
        let runs = [
            (
                "road 1",
                run_experiment(vt, &road_1(m2, seed), -friction, seed).unwrap(),
                HysteresisStart::Lowered,
                1.0,
            ),
            (
                "road 2",
                run_experiment(vt, &road_2(m2, seed).unwrap(), friction, seed).unwrap(),
                HysteresisStart::Raised,
                1.0,
            ),
        ];
        for (name, run, start, max_percent) in runs {
            let (max, rms) = percent_errors(&variant.ekf(&run.logged, start), &run);
            println!("variant {k}, {name}: max {max:.3} %, rms {rms:.3} %");
            assert!(
                max < max_percent && rms < 0.5,
                "variant {k}, {name}: max {max} %, rms {rms} %"
            );
        }
    }
}

/// A road run given as a calibration run adds no standstills while the road moves: the
/// calibration on a loading run and a road run at a steady load (an ISO 8608 road, moving at
/// every sample) is the loading run's alone. Before the road was looked at, each of the road
/// run's samples counted as a standstill, and the interval was sized on a driving truck.
#[test]
fn a_road_run_adds_no_standstills_to_a_calibration() {
    use airsus_truck::scenario::road_2;
    let variant = StudiedVariant::new(0);
    let (vt, m2, friction) = (&variant.truck, variant.unsprung_kg, variant.friction_n);
    let loading = run_experiment(vt, &data_set_1(m2, 7), -friction, 7).unwrap();
    let road = run_experiment(vt, &road_2(m2, 7).unwrap(), friction, 7).unwrap();
    let weigh = |run: &Run| weigh_static(run, &variant.weigher, 20).unwrap();
    let (on_loading, on_road) = (weigh(&loading.logged), weigh(&road.logged));
    let rule = StandstillRule::default();
    let calibrate = |runs: &[(&Run, &WeighSeries)]| {
        let runs: Vec<CalibrationRun> = runs
            .iter()
            .map(|(run, s)| CalibrationRun::from_run(run, s).unwrap())
            .collect();
        LinearCalibration::fit_runs(&runs, &rule).unwrap()
    };
    let alone = calibrate(&[(&loading.logged, &on_loading)]);
    let with_road = calibrate(&[(&loading.logged, &on_loading), (&road.logged, &on_road)]);
    assert!(alone.samples > 1000, "{alone:?}");
    assert_eq!(with_road.samples, alone.samples);
    assert_eq!(with_road.gain, alone.gain);
    assert_eq!(with_road.standstill_std_kg, alone.standstill_std_kg);
    // Alone, it has nothing to size an interval on.
    let err = LinearCalibration::fit_weighed_runs(
        &[(&road.logged, &on_road)],
        &rule,
        CalibrationTerms::IntervalOnly,
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("no steady load"), "{err}");
}

/// Max and rms of the error (% of the true load) over every sample of `run`.
fn percent_errors(
    weighed: &WeighSeries,
    run: &airsus_truck::experiments::GeneratedRun,
) -> (f64, f64) {
    let errors: Vec<f64> = weighed
        .wheel_load_kg
        .iter()
        .zip(&run.truth.inputs.wheel_load_kg)
        .map(|(w, t)| 100.0 * (w - t) / t)
        .collect();
    let max = errors.iter().fold(0.0_f64, |m, e| m.max(e.abs()));
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    (max, rms)
}

/// A truck whose tires damp (4 kN s/m), driving on a rough road: the filter whose model knows the
/// tire's damping, fed the road's rate, reads the load closer than one whose tire is the
/// thesis' undamped spring (the rate reaches the tire through the filter's prediction).
#[test]
fn ekf_with_a_damped_tire_feels_the_road_rate() {
    use airsus_truck::scenario::road_2;
    let mut variant = StudiedVariant::new(0);
    variant.truck.physical.tire.damping_n_s_per_m = 4000.0;
    let (m2, friction) = (variant.unsprung_kg, variant.friction_n);
    let run = run_experiment(&variant.truck, &road_2(m2, 5).unwrap(), friction, 5).unwrap();
    let undamped = percent_errors(&variant.ekf(&run.logged, HysteresisStart::Raised), &run);
    variant.estimate.tire.damping_n_s_per_m = 4000.0;
    let damped = percent_errors(&variant.ekf(&run.logged, HysteresisStart::Raised), &run);
    println!(
        "undamped filter: max {:.3} % rms {:.3} %; damped: max {:.3} % rms {:.3} %",
        undamped.0, undamped.1, damped.0, damped.1
    );
    // Measured (rms): 0.055 % against 0.079 % undamped; 0.063 % when the filter's tire is
    // damped but not told the road's rate.
    assert!(damped.1 < 0.75 * undamped.1, "{damped:?} {undamped:?}");
}

/// A run that starts at rest with an unknown wall friction: the friction and the load trade off
/// exactly there, so the first standstill reads off by up to the friction's force (variant 2:
/// 183 N at the bellow), and the filter's interval says so: wide until the first load change
/// slides the friction to one side, a few kilograms after it.
#[test]
fn an_unknown_start_friction_widens_the_interval_until_the_bellow_moves() {
    let variant = StudiedVariant::new(2);
    let friction = variant.friction_n;
    let scenario = data_set_2(variant.unsprung_kg, 7);
    let run = run_experiment(&variant.truck, &scenario, -friction, 7).unwrap();
    let truth = &run.truth.inputs.wheel_load_kg;
    let weigh = |start| variant.ekf(&run.logged, start);
    let (unknown, lowered) = (
        weigh(HysteresisStart::Unknown),
        weigh(HysteresisStart::Lowered),
    );
    // The filter says until when (the first load change, about 100 s in), only when unknown.
    assert!(lowered.notes.is_empty(), "{:?}", lowered.notes);
    assert_eq!(unknown.notes.len(), 1, "{:?}", unknown.notes);
    assert!(
        unknown.notes[0].contains("first moved (1"),
        "{:?}",
        unknown.notes
    );
    let first_change = truth
        .iter()
        .position(|&m| (m - truth[0]).abs() > 1.0)
        .unwrap();
    // The first standstill (its last 60 s before the first load change) and the last.
    let dt = run.logged.sample_time_s;
    let first = first_change - (60.0 / dt) as usize..first_change;
    let n = truth.len();
    let last = n - (60.0 / dt) as usize..n;
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let err = |s: &WeighSeries, r: std::ops::Range<usize>| {
        mean(
            &r.clone()
                .map(|i| s.wheel_load_kg[i] - truth[i])
                .collect::<Vec<_>>(),
        )
    };
    // The filter's own part (the assumed parameter part is the same everywhere).
    let own = |s: &WeighSeries, r: std::ops::Range<usize>| mean(&s.measurement_std_kg[r]);
    let (e_first, s_first) = (err(&unknown, first.clone()), own(&unknown, first.clone()));
    let (e_last, s_last) = (err(&unknown, last.clone()), own(&unknown, last.clone()));
    println!(
        "unknown start: first standstill {e_first:+.1} kg (filter σ {s_first:.1} kg), last {e_last:+.1} kg (σ {s_last:.1} kg); lowered: first {:+.1} kg (σ {:.1} kg)",
        err(&lowered, first.clone()),
        own(&lowered, first.clone())
    );
    // The friction held the lowered truck up: the unknown start reads light by about F_c.
    assert!(e_first < -0.3 * friction / 9.81, "{e_first}");
    // ... and its interval holds that; the known start needs no such width, nor the last
    // standstill, after the loads have slid the friction.
    assert!(e_first.abs() < 1.96 * s_first, "{e_first} {s_first}");
    assert!(s_first > 4.0 * s_last, "{s_first} {s_last}");
    assert!(s_first > 4.0 * own(&lowered, first.clone()));
    assert!(err(&lowered, first).abs() < 0.3 * friction / 9.81);
    assert!(e_last.abs() < 0.2e-2 * truth[n - 1], "{e_last}");
}

/// An unknown start whose first movement is the valve's (a valve run at one load, as a truck
/// levels itself after standing): the load did not change until the friction was known, so
/// the offline filter takes the load it reads after the movement back to the start, and reads
/// as if it had been told how the truck came there. Variant 2 (the widest friction, 183 N).
/// Where the first movement is a load change the start stays open (the test above).
#[test]
fn an_unknown_start_resolved_backwards_when_the_valve_moved_first() {
    let variant = StudiedVariant::new(2);
    let scenario = data_set_4(variant.unsprung_kg, 9);
    let run = run_experiment(&variant.truck, &scenario, variant.friction_n, 9).unwrap();
    let truth = &run.truth.inputs.wheel_load_kg;
    let unknown = variant.ekf(&run.logged, HysteresisStart::Unknown);
    let raised = variant.ekf(&run.logged, HysteresisStart::Raised);
    assert_eq!(unknown.notes.len(), 1, "{:?}", unknown.notes);
    assert!(
        unknown.notes[0].contains("taken back"),
        "{:?}",
        unknown.notes
    );
    let (a, b) = (
        score(&run.logged, truth, &unknown),
        score(&run.logged, truth, &raised),
    );
    println!(
        "standstill max: unknown start {:.3} %, told raised {:.3} %",
        a.standstill.max_abs_error_percent, b.standstill.max_abs_error_percent
    );
    // Measured: 0.290 % against 0.301 % told (0.827 % without taking the load back: the
    // unknown start's first standstill; on the study's seed-1 run 0.362 % both, 0.843 %).
    assert!(
        (a.standstill.max_abs_error_percent - b.standstill.max_abs_error_percent).abs() < 0.05,
        "{a:?} {b:?}"
    );
    // Before the valve first opens the load reads within 0.2 % (the friction's 183 N is
    // 0.55 % of it).
    let k_valve = run
        .logged
        .inputs
        .valve
        .iter()
        .position(|&v| v != ValveState::Closed)
        .unwrap();
    for ((estimate, known), t) in unknown.wheel_load_kg[..k_valve]
        .iter()
        .zip(truth)
        .zip(&run.logged.time_s)
    {
        let error = 100.0 * (estimate - known) / known;
        assert!(error.abs() < 0.2, "{t} s: {error:.3} %");
    }
    // The same run from the valve's opening on: nothing before it to see steady, so nothing
    // is taken back, and the note says the start is unknown.
    let from_valve = |v: &[f64]| v[k_valve..].to_vec();
    let logged = &run.logged;
    let measured = logged.measured().unwrap();
    let cut = Run {
        name: "from the valve".to_owned(),
        time_s: from_valve(&logged.time_s),
        sample_time_s: logged.sample_time_s,
        inputs: RunInputs {
            wheel_load_kg: from_valve(&logged.inputs.wheel_load_kg),
            valve: logged.inputs.valve[k_valve..].to_vec(),
            supply_gauge_pa: from_valve(&logged.inputs.supply_gauge_pa),
            road_height_m: from_valve(&logged.inputs.road_height_m),
        },
        outputs: Some(RunOutputs {
            sensor_height_m: from_valve(&measured.sensor_height_m),
            bellow_gauge_pa: from_valve(&measured.bellow_gauge_pa),
        }),
    };
    let notes = variant.ekf(&cut, HysteresisStart::Unknown).notes;
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(!notes[0].contains("taken back"), "{notes:?}");
}

/// A modelled wall friction's unknown start is a state, the same at every sample of the
/// static method's averaging window: the window shrinks the sensors' part by `√n`, not it.
/// Data-set 2 stands 100 s before its first load step; started unknown, the interval holds
/// the friction's whole band `k_l F_c / (g √3)` until then, and a tenth of it told.
#[test]
fn static_averaging_does_not_shrink_an_unknown_wall_friction() {
    let variant = StudiedVariant::new(0);
    let (vt, m2, friction) = (&variant.truck, variant.unsprung_kg, variant.friction_n);
    let ds2 = run_experiment(vt, &data_set_2(m2, 5), -friction, 5).unwrap();
    let wall = variant
        .weigher
        .law
        .wall
        .expect("a truck-structure file has a wall");
    let band_kg = variant.weigher.law.lever_gain * wall.friction_force_n
        / (variant.weigher.law.gravity_m_s2 * 3f64.sqrt());
    let weigh = |start| weigh_static_from(&ds2.logged, &variant.weigher, 20, start).unwrap();
    let (unknown, lowered) = (
        weigh(HysteresisStart::Unknown),
        weigh(HysteresisStart::Lowered),
    );
    // 90 s in: standing since the start.
    let k = 900;
    println!(
        "band {band_kg:.2} kg; own part unknown {:.2} kg, lowered {:.2} kg",
        unknown.measurement_std_kg[k], lowered.measurement_std_kg[k]
    );
    // Measured 10.20 kg of 10.25: the noise's jitter past the play slides it a little.
    assert!(
        unknown.measurement_std_kg[k] >= 0.95 * band_kg,
        "{}",
        unknown.measurement_std_kg[k]
    );
    assert!(unknown.measurement_std_kg[k] < 1.1 * band_kg);
    assert!(lowered.measurement_std_kg[k] < 0.25 * band_kg);
    // After the first steps the friction has slid: the two agree (measured 0.46 and 0.40 kg
    // at 200 s, the same to 0.1 g at 400 s), at the sensors' part alone.
    let later = 4000;
    assert!(
        (unknown.measurement_std_kg[later] - lowered.measurement_std_kg[later]).abs() < 0.01
            && unknown.measurement_std_kg[later] < 0.1 * band_kg
    );
}

/// The `loading` flag from the run alone: a load step's arrival and the seconds after are
/// flagged, a valve run's pulses and their settling hardly, a road run not at all (its
/// pressure swings with the road, which the log shows moving).
#[test]
fn a_load_arriving_is_flagged_from_the_run_alone() {
    use airsus_truck::scenario::road_2;
    let vt = VirtualTruck::reference();
    let m2 = vt.physical.mass.unsprung_kg;
    let friction = vt.effect_parameters.friction_force_n;
    // The samples of `run` that `detector` flags `loading`.
    let flagged_by = |run: &Run, detector: &StandstillDetector| {
        quality_flags(run, detector)
            .unwrap()
            .iter()
            .filter(|&&q| q == WeighQuality::Loading)
            .count()
    };
    let defaults = StandstillDetector::default();
    let count = |run: &Run| flagged_by(run, &defaults);
    // The samples of a generated run within 10 s of a change of its true load, and how
    // many of them are flagged `loading`; those with the valve open among each.
    let rule = StandstillRule::default();
    let arrivals = |run: &airsus_truck::experiments::GeneratedRun| {
        let truth = &run.truth.inputs.wheel_load_kg;
        let flagged = flags(&run.logged);
        let (mut arriving, mut caught) = ((0, 0), (0, 0));
        let mut last_change = f64::NEG_INFINITY;
        let mut level = truth[0];
        for (k, &m) in truth.iter().enumerate() {
            if (m - level).abs() > rule.steady_tolerance_kg {
                last_change = run.logged.time_s[k];
                level = m;
            }
            if run.logged.time_s[k] - last_change < rule.load_settle_s {
                let open = usize::from(run.logged.inputs.valve[k] != ValveState::Closed);
                let flagged = usize::from(flagged[k] == WeighQuality::Loading);
                arriving = (arriving.0 + 1, arriving.1 + open);
                caught = (caught.0 + flagged, caught.1 + flagged * open);
            }
        }
        (arriving, caught)
    };
    let ds1 = run_experiment(&vt, &data_set_1(m2, 9), -friction, 9).unwrap();
    let ((arriving, _), (caught, _)) = arrivals(&ds1);
    let all = count(&ds1.logged);
    println!("data-set 1: {caught} of {arriving} arriving samples flagged, {all} flagged in all");
    assert!(
        caught as f64 > 0.95 * arriving as f64,
        "{caught} of {arriving}"
    );
    assert!(
        (all as f64) < 1.1 * arriving as f64,
        "{all} flagged, {arriving} arriving"
    );
    let ds3 = run_experiment(&vt, &data_set_3(m2, 9), friction, 9).unwrap();
    let road = run_experiment(&vt, &road_2(m2, 9).unwrap(), friction, 9).unwrap();
    let (valve_run, road_run) = (count(&ds3.logged), count(&road.logged));
    println!("data-set 3 (no load change): {valve_run} flagged; road 2: {road_run}");
    assert!(valve_run < ds3.logged.len() / 50, "{valve_run}");
    assert_eq!(road_run, 0);
    // While a levelling controller works the valve, a load arriving is still what the
    // estimate misses: those samples are flagged `loading` too, and get the interval the
    // calibration's arrivals measured, not the valve's (sized at a steady load, it held 40
    // of 238 such samples of a variant's held-out levelling run).
    let levelling = airsus_truck::experiments::levelling_run(
        &vt,
        airsus_truck::scenario::levelling_2(m2, 9),
        9,
    )
    .unwrap();
    let ((arriving, arriving_open), (caught, caught_open)) = arrivals(&levelling);
    println!(
        "levelling 2: {caught} of {arriving} arriving samples flagged; with the valve open {caught_open} of {arriving_open}"
    );
    assert!(arriving_open > 100, "{arriving_open}");
    assert!(
        caught as f64 > 0.95 * arriving as f64,
        "{caught} of {arriving}"
    );
    assert!(
        caught_open as f64 > 0.95 * arriving_open as f64,
        "{caught_open} of {arriving_open}"
    );

    // The thresholds are the caller's (`weigh --loading-shift-kpa` etc.): a shift above what
    // a 250-350 kg step moves the pressure by (about 30 kPa) flags no arrival, a longer hold
    // flags more samples, a threshold that is not a positive number is an error naming it.
    let above_any_step = defaults.clone().with_loading(80e3, 2.0, 10.0).unwrap();
    assert_eq!(flagged_by(&ds1.logged, &above_any_step), 0);
    let held_longer = defaults.clone().with_loading(3e3, 2.0, 20.0).unwrap();
    let longer = flagged_by(&ds1.logged, &held_longer);
    println!("held 20 s: {longer} flagged");
    assert!(longer > all + 5 * 5, "{longer} against {all}");
    for (shift, window, hold, named) in [
        (-1.0, 2.0, 10.0, "loading pressure shift"),
        (3e3, f64::NAN, 10.0, "loading window"),
        (3e3, 2.0, 0.0, "loading hold"),
    ] {
        let err = defaults
            .clone()
            .with_loading(shift, window, hold)
            .unwrap_err()
            .to_string();
        assert!(err.contains(named), "{err}");
    }
}
