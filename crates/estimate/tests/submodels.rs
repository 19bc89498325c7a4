//! Submodel fits recover known parameters from synthetic data (thesis 5.2).

mod common;

use airsus_data::{
    Channel, ForceMap, Role, RunOutputs, TankDischarge, TruckParameters, ValveState,
};
use airsus_estimate::EstimateError;
use airsus_estimate::submodel::{
    CrossSectionOptions, CrossSectionScale, DischargeData, EffectiveAreaOptions,
    SlowDynamicsOptions, ValveFitOptions, fit_area_growth, fit_cross_section, fit_dead_volume,
    fit_effective_area, fit_slow_dynamics, fit_valve,
};
use airsus_model::build_model;
use common::{load_step_run, measure, rng, valve_pulse_run};
use rand_distr::{Distribution, StandardNormal};

#[test]
fn cross_section_shape_from_a_closed_valve_run() {
    let truck = TruckParameters::reference();
    let truth = build_model("m2", &truck).unwrap();
    let est = measure(
        &*truth,
        load_step_run("ds1", 900.0, 3350.0, 300.0, 120.0),
        0.24,
        1,
    );
    let val = measure(
        &*truth,
        load_step_run("ds2", 600.0, 3200.0, 350.0, 90.0),
        0.25,
        2,
    );
    // Start from a wrong shape: the fit must find a1/a0 = −0.031/0.250 again.
    let mut start = truck.clone();
    start.bellow.gas_volume = airsus_data::GasVolumeLaw::cross_section([0.250, -0.06]);
    let fit = fit_cross_section(&est, &[&val], &start, &CrossSectionOptions::default()).unwrap();
    let ratio = -0.031 / 0.250;
    assert!(fit.converged);
    assert!(
        (fit.ratio_per_m - ratio).abs() <= 3.0 * fit.ratio_std_per_m,
        "{} ± {} vs {ratio}",
        fit.ratio_per_m,
        fit.ratio_std_per_m
    );
    assert!(fit.ratio_std_per_m < 0.2 * ratio.abs());
    assert_eq!(fit.a0_m2, 0.250, "scale kept from the truck");
    assert!((fit.a1_m + 0.031).abs() <= 3.0 * fit.a1_std_m);
    assert!(fit.nrmse_estimation_percent > 90.0, "{fit:?}");
    assert_eq!(fit.nrmse_validation_percent.len(), 1);
    assert!(fit.nrmse_validation_percent[0].1 > 90.0, "{fit:?}");
    // A known volume fixes the scale instead.
    let v = 0.3 * (0.25 - 0.031 * 0.3);
    let options = CrossSectionOptions {
        scale: CrossSectionScale::KnownVolume {
            bellow_height_m: 0.3,
            volume_m3: v,
        },
        ..CrossSectionOptions::default()
    };
    let fit = fit_cross_section(&est, &[], &start, &options).unwrap();
    assert!((fit.a0_m2 - 0.25).abs() < 0.01, "{}", fit.a0_m2);
    let mut t = truck.clone();
    fit.write_to(&mut t);
    assert_eq!(
        t.bellow.gas_volume.coefficients_m2(),
        Some(&[fit.a0_m2, fit.a1_m])
    );
    // A truck under the area-integral law has no cross-section to fit: refused, by name.
    let mut integral = truck.clone();
    integral.bellow.gas_volume = airsus_data::GasVolumeLaw::AreaIntegral {
        dead_volume_m3: 0.05,
        bellows: 2,
    };
    let err = fit_cross_section(&est, &[&val], &integral, &CrossSectionOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("`area_integral`"), "{err}");

    // Settled samples only: the 120 s holds at three loads, 60 s after each change. Model 2's
    // gas is isothermal, so the shape is the same; the holds are counted.
    let settled = |seconds: f64| CrossSectionOptions {
        settled_after_s: Some(seconds),
        ..CrossSectionOptions::default()
    };
    let fit = fit_cross_section(&est, &[&val], &start, &settled(60.0)).unwrap();
    // Seven holds give their last 60 s (600 samples each); the eighth, cut by the run's end
    // at 900 s, its last sample.
    assert_eq!((fit.holds, fit.samples), (8, 4201), "{fit:?}");
    assert!(
        (fit.ratio_per_m - ratio).abs() <= 3.0 * fit.ratio_std_per_m,
        "{fit:?}"
    );
    assert!(fit.validation_on_every_sample.is_empty(), "{fit:?}");
    // The validation run holds its loads 90 s: 100 s after each change it has no settled
    // sample, so it is scored on every sample, and named for it.
    let fit = fit_cross_section(&est, &[&val], &start, &settled(100.0)).unwrap();
    assert_eq!(fit.validation_on_every_sample, vec!["ds2".to_owned()]);
    assert_eq!(fit.nrmse_validation_percent.len(), 1);
    // No hold lasts 130 s: no settled sample at three loads, said so.
    let err = fit_cross_section(&est, &[], &start, &settled(130.0))
        .unwrap_err()
        .to_string();
    assert!(err.contains("three loads at least"), "{err}");
    let err = fit_cross_section(&est, &[], &start, &settled(f64::NAN))
        .unwrap_err()
        .to_string();
    assert!(err.contains("settled_after_s = NaN"), "{err}");
}

#[test]
fn dead_volume_of_the_area_integral_from_a_closed_valve_run() {
    // A truck whose volume sweeps its area behind 12 L of dead volume; the fit starts from
    // nothing but the area and the bellows' count.
    let mut truck = TruckParameters::reference();
    truck.bellow.gas_volume = airsus_data::GasVolumeLaw::AreaIntegral {
        dead_volume_m3: 0.012,
        bellows: 2,
    };
    let truth = build_model("m2", &truck).unwrap();
    let run = measure(
        &*truth,
        load_step_run("ds1", 900.0, 3350.0, 300.0, 120.0),
        0.24,
        1,
    );
    let area = truck.bellow.effective_area.clone();
    let options = CrossSectionOptions::default();
    let fit = fit_dead_volume(&run, &truck, &area, 2, &options).unwrap();
    assert!((fit.dead_volume_m3 - 0.012).abs() < 0.02 * 0.012, "{fit:?}");
    assert!(
        matches!(
            fit.law(),
            airsus_data::GasVolumeLaw::AreaIntegral { bellows: 2, .. }
        ),
        "{fit:?}"
    );
    // The thesis' law on the same samples explains them worse: what the study's choice of
    // the structure's volume reads.
    let mut thesis = truck.clone();
    thesis.bellow.gas_volume = airsus_data::GasVolumeLaw::cross_section([0.25, -0.031]);
    let cross = fit_cross_section(&run, &[], &thesis, &options).unwrap();
    assert!(
        fit.nrmse_estimation_percent > cross.nrmse_estimation_percent,
        "{fit:?} against {cross:?}"
    );
    // And the other way round on a truck under the thesis' law.
    let truth = build_model("m2", &thesis).unwrap();
    let run = measure(
        &*truth,
        load_step_run("ds1", 900.0, 3350.0, 300.0, 120.0),
        0.24,
        1,
    );
    let fit = fit_dead_volume(&run, &thesis, &area, 2, &options).unwrap();
    let cross = fit_cross_section(&run, &[], &thesis, &options).unwrap();
    assert!(
        cross.nrmse_estimation_percent > fit.nrmse_estimation_percent,
        "{fit:?} against {cross:?}"
    );
    // A run whose pressure rises as the bellow extends has no dead volume to give.
    let mut upside_down = run.clone();
    let out = upside_down.outputs.as_mut().unwrap();
    let mean = out.bellow_gauge_pa.iter().sum::<f64>() / out.bellow_gauge_pa.len() as f64;
    for p in &mut out.bellow_gauge_pa {
        *p = 2.0 * mean - *p;
    }
    let err = fit_dead_volume(&upside_down, &thesis, &area, 2, &options)
        .unwrap_err()
        .to_string();
    assert!(err.contains("does not fall"), "{err}");
}

#[test]
fn cross_section_refuses_a_run_with_valve_action() {
    let truck = TruckParameters::reference();
    let truth = build_model("m2", &truck).unwrap();
    let run = measure(
        &*truth,
        valve_pulse_run("ds3", 120.0, 3350.0, 60.0, 2.0, 2.0),
        0.24,
        3,
    );
    let err = fit_cross_section(&run, &[], &truck, &CrossSectionOptions::default()).unwrap_err();
    assert!(
        matches!(&err, EstimateError::InsufficientData { reason, .. } if reason.contains("valve is open")),
        "{err}"
    );
    let mut flat = run.clone();
    flat.inputs.valve = vec![ValveState::Closed; flat.len()];
    let n = flat.len();
    flat.outputs = Some(RunOutputs {
        sensor_height_m: vec![0.24; n],
        bellow_gauge_pa: vec![350e3; n],
    });
    assert!(fit_cross_section(&flat, &[], &truck, &CrossSectionOptions::default()).is_err());
}

/// The lab's bellow (the SPEC's quartic), m².
const LAB_AREA_POLY: [f64; 5] = [-0.0289, 0.8362, -3.0698, 4.9616, -2.9941];

fn lab_area_m2(h: f64) -> f64 {
    LAB_AREA_POLY.iter().rev().fold(0.0, |acc, p| acc * h + p)
}

/// A force map of [`lab_area_m2`] growing by `growth` per 100 kPa: 7 pressures, 10 heights,
/// each measured twice (up and down, `friction_n` apart either way of the mean), 20 N noise.
fn force_map(growth: f64, friction_n: f64, seed: u64) -> ForceMap {
    let mut r = rng(seed);
    let mut map = ForceMap::default();
    for i in 1..=7 {
        let p = 1e5 * f64::from(i);
        for k in 0..10 {
            let h = 0.22 + 0.02 * f64::from(k);
            for sweep in [-1.0, 1.0] {
                let z: f64 = StandardNormal.sample(&mut r);
                map.bellow_height_m.push(h);
                map.bellow_gauge_pa.push(p);
                map.force_n.push(
                    p * lab_area_m2(h) * (1.0 + growth * p / 1e5) + sweep * friction_n + 20.0 * z,
                );
            }
        }
    }
    map
}

#[test]
fn effective_area_polynomial_from_a_force_map() {
    let (poly, area) = (LAB_AREA_POLY, lab_area_m2);
    let map = force_map(0.0, 0.0, 7);
    let fit = fit_effective_area(&map, &EffectiveAreaOptions::default()).unwrap();
    assert_eq!(fit.per_height.len(), 10);
    assert_eq!(fit.points, 140);
    for (i, (est, truth)) in fit.poly.iter().zip(poly).enumerate() {
        let std = fit.poly_std[i];
        assert!(
            (est - truth).abs() <= 3.0 * std,
            "p{i}: {est} ± {std} vs {truth}"
        );
    }
    for h in [0.25, 0.3, 0.35] {
        assert!((fit.area_m2(h) - area(h)).abs() < 2e-4, "{h}");
    }
    assert!(
        fit.force_nrmse_percent > 99.0,
        "{}",
        fit.force_nrmse_percent
    );
    assert!(fit.area_nrmse_percent > 95.0, "{}", fit.area_nrmse_percent);
    let mut t = TruckParameters::reference();
    fit.write_to(&mut t).unwrap();
    assert_eq!(
        t.bellow.effective_area.coefficients_m2().unwrap().to_vec(),
        fit.poly
    );
    // Too few heights for a quartic.
    let few = ForceMap {
        bellow_height_m: vec![0.2, 0.25, 0.3, 0.35],
        bellow_gauge_pa: vec![1e5; 4],
        force_n: vec![5000.0; 4],
    };
    assert!(matches!(
        fit_effective_area(&few, &EffectiveAreaOptions::default()),
        Err(EstimateError::InsufficientData { .. })
    ));
}

#[test]
fn area_growth_with_pressure_from_a_force_map() {
    // A bellow whose area grows 0.5 % per 100 kPa, measured up and down at 7 pressures with a
    // wall friction of 150 N between the sweeps and 20 N of noise.
    let (area, growth) = (lab_area_m2, 0.005);
    let map = force_map(growth, 150.0, 11);
    let fit = fit_area_growth(&map, 1e-4).unwrap();
    assert_eq!(fit.heights, 10);
    assert!(
        (fit.growth_per_100kpa - growth).abs() <= 3.0 * fit.growth_std_per_100kpa
            && fit.growth_std_per_100kpa < 0.1 * growth,
        "{fit:?}"
    );
    // The quartic fitted under the fitted growth is the area at zero pressure; the thesis'
    // `F = p A(h)` averages the stretch into it (about 2 % here).
    let with = fit_effective_area(
        &map,
        &EffectiveAreaOptions {
            fit_growth: true,
            ..EffectiveAreaOptions::default()
        },
    )
    .unwrap();
    let without = fit_effective_area(&map, &EffectiveAreaOptions::default()).unwrap();
    assert_eq!(with.growth_per_100kpa, Some(fit.growth_per_100kpa));
    assert!(with.growth_std_per_100kpa.is_some());
    for h in [0.24, 0.3, 0.38] {
        let relative = |a: f64| a / area(h) - 1.0;
        assert!(
            relative(with.area_m2(h)).abs() < 3e-3,
            "{h}: {}",
            relative(with.area_m2(h))
        );
        assert!(relative(without.area_m2(h)) > 0.015, "{h}");
    }
    assert!(with.force_nrmse_percent > without.force_nrmse_percent);
    let law = with.law().unwrap();
    assert_eq!(law.tag(), "polynomial_pressure");
    assert!((law.area_m2(0.3, 4e5) / (area(0.3) * 1.02) - 1.0).abs() < 3e-3);
    // Into a truck whose law stretches with pressure: the quartic and the growth.
    let mut t = TruckParameters::reference();
    t.bellow.effective_area = law.clone();
    t.bellow
        .effective_area
        .set(airsus_data::params::Field::AreaPressureGrowth, 0.0);
    with.write_to(&mut t).unwrap();
    assert_eq!(t.bellow.effective_area, law);

    // A map at one pressure (logged with 0.3 kPa of jitter) cannot tell a growth from an
    // area: an error, not a guess.
    let one_pressure = ForceMap {
        bellow_height_m: map.bellow_height_m[..20].to_vec(),
        bellow_gauge_pa: map.bellow_gauge_pa[..20]
            .iter()
            .enumerate()
            .map(|(k, p)| p + 300.0 * (k % 3) as f64)
            .collect(),
        force_n: map.force_n[..20].to_vec(),
    };
    let err = fit_area_growth(&one_pressure, 1e-4)
        .unwrap_err()
        .to_string();
    assert!(err.contains("two or more pressures"), "{err}");
}

/// A tank emptied through a linear resistance R: `dn/dt = −p_gauge/R`, `p_gauge = n R T/V −
/// p_amb`, so `p_gauge(t) = p0 e^{−t/τ}` with `τ = R V/(R_gas T)` — exact.
fn discharge(r_flow: f64, start_pa: f64, noise_pa: f64, seed: u64) -> TankDischarge {
    let (v, t_k, r_gas, ts) = (0.020, 293.15, 8.314462618, 0.05);
    let tau = r_flow * v / (r_gas * t_k);
    let mut r = rng(seed);
    let n = (90.0 / ts) as usize + 1;
    TankDischarge {
        time_s: (0..n).map(|k| k as f64 * ts).collect(),
        sample_time_s: ts,
        tank_gauge_pa: (0..n)
            .map(|k| {
                let z: f64 = StandardNormal.sample(&mut r);
                start_pa * (-(k as f64 * ts) / tau).exp() + noise_pa * z
            })
            .collect(),
    }
}

#[test]
fn flow_resistances_from_exact_exponential_discharges() {
    let truck = TruckParameters::reference();
    let (r1, r2) = (2.5e6, 1.5e6);
    let d = [
        discharge(r1, 800e3, 0.0, 1),
        discharge(r1, 750e3, 0.0, 2),
        discharge(r2, 800e3, 0.0, 3),
        discharge(r2, 750e3, 0.0, 4),
    ];
    let data = |i: usize, channel, role| DischargeData {
        name: format!("d{i}"),
        discharge: &d[i],
        channel,
        tank_volume_m3: 0.020,
        temperature_k: 293.15,
        role,
    };
    let all = [
        data(0, Channel::Fill, Role::Estimation),
        data(1, Channel::Fill, Role::Validation),
        data(2, Channel::Exhaust, Role::Estimation),
        data(3, Channel::Exhaust, Role::Validation),
    ];
    let fit = fit_valve(&all, &ValveFitOptions::for_truck(&truck)).unwrap();
    let fill = fit.fill.as_ref().unwrap();
    let exhaust = fit.exhaust.as_ref().unwrap();
    // Noise-free: only the Savitzky–Golay truncation error, ~3 (Ts/τ)² ≈ 1e-5.
    assert!(
        (fill.resistance_pa_s_per_mol / r1 - 1.0).abs() < 1e-4,
        "{fill:?}"
    );
    assert!(
        (exhaust.resistance_pa_s_per_mol / r2 - 1.0).abs() < 1e-4,
        "{exhaust:?}"
    );
    for f in fill.discharges.iter().chain(&exhaust.discharges) {
        assert!(f.nrmse_percent.unwrap() > 99.0, "{f:?}");
    }
    let mut t = truck.clone();
    let fill_field = airsus_data::params::Field::FillResistance;
    airsus_data::params::set(&mut t, fill_field, 1.0e6);
    fit.write_to(&mut t).unwrap();
    assert_eq!(
        airsus_data::params::get(&t, fill_field),
        fill.resistance_pa_s_per_mol
    );
    // Under the orifice law the file's law stays: writing the resistances is an error that
    // says why, and the truck is unchanged, with one channel fitted or both.
    let mut orifice = truck.clone();
    orifice.valve = airsus_data::ValveFlowLaw::Orifice {
        fill_conductance_m3_s_pa: 5e-9,
        exhaust_conductance_m3_s_pa: 1.2e-8,
        critical_pressure_ratio: 0.4,
    };
    let half = airsus_estimate::submodel::ValveFit {
        exhaust: None,
        ..fit.clone()
    };
    let before = orifice.clone();
    for fit in [&half, &fit] {
        let err = fit.write_to(&mut orifice).unwrap_err().to_string();
        assert!(
            err.contains("`orifice`") && err.contains("do not replace it"),
            "{err}"
        );
        assert_eq!(orifice, before);
    }
}

#[test]
fn flow_resistances_from_noisy_discharges() {
    let truck = TruckParameters::reference();
    let r1 = 2.5e6;
    // The rig's 0.1 kPa sensor noise.
    let d = [
        discharge(r1, 800e3, 100.0, 11),
        discharge(r1, 750e3, 100.0, 12),
    ];
    let all: Vec<DischargeData<'_>> = d
        .iter()
        .enumerate()
        .map(|(i, x)| DischargeData {
            name: format!("fill {i}"),
            discharge: x,
            channel: Channel::Fill,
            tank_volume_m3: 0.020,
            temperature_k: 293.15,
            role: if i == 0 {
                Role::Estimation
            } else {
                Role::Validation
            },
        })
        .collect();
    let fit = fit_valve(&all, &ValveFitOptions::for_truck(&truck)).unwrap();
    assert!(fit.exhaust.is_none(), "no exhaust discharges");
    let fill = fit.fill.unwrap();
    assert!(
        (fill.resistance_pa_s_per_mol - r1).abs() <= 3.0 * fill.resistance_std,
        "{} ± {}",
        fill.resistance_pa_s_per_mol,
        fill.resistance_std
    );
    assert!((fill.resistance_pa_s_per_mol / r1 - 1.0).abs() < 0.02);
    let validation = &fill.discharges[1];
    assert_eq!(validation.role, Role::Validation);
    assert!(validation.nrmse_percent.unwrap() > 60.0, "{validation:?}");
    // Only validation discharges: nothing to fit.
    let only_validation: Vec<DischargeData<'_>> = all
        .into_iter()
        .map(|mut x| {
            x.role = Role::Validation;
            x
        })
        .collect();
    assert!(fit_valve(&only_validation, &ValveFitOptions::for_truck(&truck)).is_err());
}

#[test]
fn slow_dynamics_oe_from_an_isolated_load_step() {
    // Height: a fast static drop plus the thesis' slow creep, an OE nb=1 nf=1 nk=2 model
    // (Table 5.5: b1 = −8.672e-8 m/kg, f1 = −0.997) driven by the load change, plus noise.
    let (b1, f1) = (-8.672e-8, -0.997);
    let ts = 0.1;
    let n = 3000;
    let k_step = 200;
    let step = 300.0;
    let mut r = rng(21);
    let load: Vec<f64> = (0..n)
        .map(|k| 3350.0 + if k >= k_step { step } else { 0.0 })
        .collect();
    let mut creep = vec![0.0; n];
    for k in 1..n {
        let u = if k >= 2 { load[k - 2] - load[0] } else { 0.0 };
        creep[k] = -f1 * creep[k - 1] + b1 * u;
    }
    let height: Vec<f64> = (0..n)
        .map(|k| {
            let fast = if k >= k_step { -0.016 } else { 0.0 };
            let z: f64 = StandardNormal.sample(&mut r);
            0.24 + fast + creep[k] + 5e-5 * z
        })
        .collect();
    let mut run = load_step_run("step", (n - 1) as f64 * ts, 3350.0, 0.0, 1e9);
    run.inputs.wheel_load_kg = load;
    run.outputs = Some(RunOutputs {
        sensor_height_m: height,
        bellow_gauge_pa: vec![350e3; n],
    });
    let fit = fit_slow_dynamics(&run, &SlowDynamicsOptions::default()).unwrap();
    assert_eq!(fit.step_kg, step);
    assert!((fit.step_time_s - 20.0).abs() < 1e-9);
    assert_eq!(fit.nk, 2);
    let f_std = fit.estimate.parameters[1].std;
    assert!(
        (fit.f[0] - f1).abs() <= 3.0 * f_std + 1e-5,
        "f1 {} ± {f_std}",
        fit.f[0]
    );
    // The corrected numerator gives the whole creep from the step: within 2 %.
    assert!(
        (fit.b[0] / b1 - 1.0).abs() < 0.02,
        "b1 {} vs {b1}",
        fit.b[0]
    );
    let tau = -ts / (-f1).ln();
    assert!((fit.time_constant_s.unwrap() / tau - 1.0).abs() < 0.02);
    assert!(fit.nrmse_percent > 90.0, "{}", fit.nrmse_percent);
    let mut t = TruckParameters::reference();
    fit.write_to(&mut t);
    assert_eq!(t.slow_dynamics.oe_b, fit.b);
    assert_eq!(t.slow_dynamics.oe_f, fit.f);
    // A run without a load change has no step.
    let mut flat = run.clone();
    flat.inputs.wheel_load_kg = vec![3350.0; n];
    assert!(fit_slow_dynamics(&flat, &SlowDynamicsOptions::default()).is_err());
}
