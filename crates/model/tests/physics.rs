//! Tests that prove the physics of the full models (statics, energy, air mass, output map,
//! the reference truck). Each compares the model against an independent computation.

mod common;

use airsus_data::params::{Field, get};
use airsus_data::{TruckParameters, ValveState};
use airsus_model::{InitialCondition, InputSample, ModelError, build_model};
use common::*;

const MODELS: &[&str] = &["m1", "m2", "m2x", "m2xh", "m3"];

/// `A_eff` written out again here (not the crate's function): eq 5.4.
fn area(truck: &TruckParameters, h: f64) -> f64 {
    let p = *truck
        .bellow
        .effective_area
        .coefficients_m2()
        .expect("the reference truck's area law is the thesis'");
    p[0] + p[1] * h + p[2] * h * h + p[3] * h.powi(3) + p[4] * h.powi(4)
}

fn lever_gain(truck: &TruckParameters) -> f64 {
    (truck.geometry.l1_m + truck.geometry.l2_m) / truck.geometry.l1_m
}

/// Bellow height from the sensor reading (SPEC §1 map inverted).
fn bellow_from_sensor(truck: &TruckParameters, sensor_m: f64, load_kg: f64) -> f64 {
    let g = &truck.geometry;
    let rigid = sensor_m + g.lever_compliance_m_per_n * load_kg * truck.environment.gravity_m_s2;
    g.h0_m + lever_gain(truck) * (rigid - g.h0_m)
}

fn volume(truck: &TruckParameters, h: f64) -> f64 {
    let a = *truck
        .bellow
        .gas_volume
        .coefficients_m2()
        .expect("the reference truck's volume law is the thesis'");
    h * (a[0] + a[1] * h)
}

fn rt(truck: &TruckParameters) -> f64 {
    truck.environment.gas_constant_j_mol_k * truck.environment.temperature_k
}

/// Bellow force at constant `n` (eq 3.16/3.17), written out independently.
fn bellow_force(truck: &TruckParameters, h: f64, n: f64) -> f64 {
    (n * rt(truck) / volume(truck, h) - truck.environment.ambient_pressure_pa) * area(truck, h)
}

/// `U_b(h) = -∫_{h_ref}^{h} F_ab dh` at constant `n`, composite Simpson with 2000 panels.
fn bellow_potential(truck: &TruckParameters, h_ref: f64, h: f64, n: f64) -> f64 {
    let panels = 2000;
    let step = (h - h_ref) / panels as f64;
    let mut sum = bellow_force(truck, h_ref, n) + bellow_force(truck, h, n);
    for i in 1..panels {
        let w = if i % 2 == 1 { 4.0 } else { 2.0 };
        sum += w * bellow_force(truck, h_ref + i as f64 * step, n);
    }
    -sum * step / 3.0
}

fn tire_energy(truck: &TruckParameters, compression: f64) -> f64 {
    if compression > 0.0 {
        0.5 * truck.tire.stiffness_n_per_m * compression * compression
    } else {
        0.0
    }
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

#[test]
fn initial_state_is_a_rest_point_and_matches_the_static_force_balance() {
    let truck = reference();
    let load = reference_load(&truck);
    let u = input(load);
    let g = truck.environment.gravity_m_s2;
    for name in MODELS {
        let model = build_model(name, &truck).unwrap();
        for ic in [
            InitialCondition::BellowPressure { gauge_pa: 350e3 },
            InitialCondition::SensorHeight { height_m: 0.240 },
        ] {
            let x = model.initial_state(&u, &ic).unwrap();
            assert_eq!(x.len(), model.n_states(), "{name}");
            let mut dx = vec![1.0; x.len()];
            model.rhs(0.0, &x, &u, &mut dx);
            // Accelerations are in m/s² and rad/s²: 1e-9 is far below anything physical.
            assert!(max_abs(&dx) < 1e-9, "{name} {ic:?}: {dx:?}");
            let y = model.output(&x, &u);
            match ic {
                InitialCondition::BellowPressure { gauge_pa } => {
                    assert!((y.bellow_gauge_pa - gauge_pa).abs() < 1e-6, "{name}")
                }
                InitialCondition::SensorHeight { height_m } => {
                    assert!((y.sensor_height_m - height_m).abs() < 1e-12, "{name}")
                }
            }
            // Independent static balance: torque about the hinge with the tire carrying m_tot g.
            let h_b = bellow_from_sensor(&truck, y.sensor_height_m, load);
            let carried = y.bellow_gauge_pa * area(&truck, h_b) * lever_gain(&truck);
            let sprung_weight = (load - truck.mass.unsprung_kg) * g;
            assert!(
                (carried - sprung_weight).abs() < 1e-6 * sprung_weight,
                "{name}: {carried} vs {sprung_weight}"
            );
        }
    }
}

#[test]
fn tire_carries_the_whole_wheel_load_in_statics() {
    let truck = reference();
    let load = reference_load(&truck);
    let u = input(load);
    let ic = InitialCondition::BellowPressure { gauge_pa: 350e3 };
    let compression = load * truck.environment.gravity_m_s2 / truck.tire.stiffness_n_per_m;
    let x1 = build_model("m1", &truck)
        .unwrap()
        .initial_state(&u, &ic)
        .unwrap();
    assert!((x1[1] + compression).abs() < 1e-12);
    let x2 = build_model("m2", &truck)
        .unwrap()
        .initial_state(&u, &ic)
        .unwrap();
    let axle = x2[0] - truck.geometry.h0_m - truck.geometry.l1_m * x2[1].sin();
    assert!((axle + compression).abs() < 1e-12);
}

#[test]
fn models_1_and_2_agree_in_statics() {
    let truck = reference();
    for load in [2600.0, 3350.0, 3700.0] {
        let u = input(load);
        let m1 = build_model("m1", &truck).unwrap();
        let m2 = build_model("m2", &truck).unwrap();
        let x1 = m1
            .initial_state(&u, &InitialCondition::BellowPressure { gauge_pa: 420e3 })
            .unwrap();
        let y1 = m1.output(&x1, &u);
        // Model 2 from Model 1's sensor height must reproduce Model 1's pressure and amount.
        let x2 = m2
            .initial_state(
                &u,
                &InitialCondition::SensorHeight {
                    height_m: y1.sensor_height_m,
                },
            )
            .unwrap();
        let y2 = m2.output(&x2, &u);
        assert!(
            (y1.bellow_gauge_pa - y2.bellow_gauge_pa).abs() < 1e-6,
            "{load}: {y1:?} {y2:?}"
        );
        assert!((x1[4] - x2[4]).abs() < 1e-12 * x1[4], "{load}");
        // And both are rest points with the same n: statics agree for the same load and n.
        let mut dx = [0.0; 5];
        m2.rhs(0.0, &x2, &u, &mut dx);
        assert!(max_abs(&dx) < 1e-9, "{dx:?}");
    }
}

fn conservative(truck: &TruckParameters) -> TruckParameters {
    let mut t = truck.clone();
    t.damper.force_n.iter_mut().for_each(|f| *f = 0.0);
    t.bellow.hinge_friction_n_s_per_m = 0.0;
    t
}

#[test]
fn model_1_conserves_energy_without_damper_friction_and_flow() {
    let truck = conservative(&reference());
    let load = reference_load(&truck);
    let u = input(load);
    let model = build_model("m1", &truck).unwrap();
    let mut x = model
        .initial_state(&u, &InitialCondition::BellowPressure { gauge_pa: 350e3 })
        .unwrap();
    x[2] = 0.05; // chassis moving up, axle down: both springs work
    x[3] = -0.1;
    let g = truck.environment.gravity_m_s2;
    let (m1, m2) = (load - truck.mass.unsprung_kg, truck.mass.unsprung_kg);
    let kl = lever_gain(&truck);
    let h0 = truck.geometry.h0_m;
    let n = x[4];
    let h_ref = h0 + kl * (x[0] - x[1] - h0);
    let energy = |x: &[f64]| {
        let h_b = h0 + kl * (x[0] - x[1] - h0);
        0.5 * m1 * x[2] * x[2]
            + 0.5 * m2 * x[3] * x[3]
            + m1 * g * x[0]
            + m2 * g * x[1]
            + tire_energy(&truck, -x[1])
            + bellow_potential(&truck, h_ref, h_b, n)
    };
    let kinetic0 = 0.5 * m1 * 0.05 * 0.05 + 0.5 * m2 * 0.1 * 0.1;
    let e0 = energy(&x);
    let mut drift: f64 = 0.0;
    let mut max_hb_change: f64 = 0.0;
    simulate(model.as_ref(), &mut x, &u, 0.0, 2.0, 1e-4, |_, x| {
        drift = drift.max((energy(x) - e0).abs());
        max_hb_change = max_hb_change.max((h0 + kl * (x[0] - x[1] - h0) - h_ref).abs());
    });
    assert_eq!(x[4], n, "closed valve: n constant");
    assert!(
        max_hb_change > 1e-3,
        "the bellow must actually move ({max_hb_change})"
    );
    println!("relative energy drift {:.3e}", drift / kinetic0);
    assert!(
        drift / kinetic0 < 1e-6,
        "relative energy drift {}",
        drift / kinetic0
    );
}

#[test]
fn model_2_conserves_energy_without_damper_friction_and_flow() {
    let truck = conservative(&reference());
    let load = reference_load(&truck);
    let u = input(load);
    let model = build_model("m2", &truck).unwrap();
    let mut x = model
        .initial_state(&u, &InitialCondition::BellowPressure { gauge_pa: 350e3 })
        .unwrap();
    x[2] = 0.05;
    x[3] = 0.2;
    let g = truck.environment.gravity_m_s2;
    let (m1, m2) = (load - truck.mass.unsprung_kg, truck.mass.unsprung_kg);
    let (h0, l1, l12) = (
        truck.geometry.h0_m,
        truck.geometry.l1_m,
        truck.geometry.l1_m + truck.geometry.l2_m,
    );
    let inertia = truck.mass.lever_inertia_kg_m2;
    let n = x[4];
    let h_ref = h0 + l12 * x[1].sin();
    let energy = |x: &[f64]| {
        let (s, c) = x[1].sin_cos();
        let kinetic =
            0.5 * (m1 + m2) * x[2] * x[2] - m2 * l1 * c * x[2] * x[3] + 0.5 * inertia * x[3] * x[3];
        let axle = x[0] - h0 - l1 * s;
        kinetic
            + m1 * g * x[0]
            + m2 * g * axle
            + tire_energy(&truck, -axle)
            + bellow_potential(&truck, h_ref, h0 + l12 * s, n)
    };
    let kinetic0 = energy(&x) - {
        let mut rest = x.clone();
        rest[2] = 0.0;
        rest[3] = 0.0;
        energy(&rest)
    };
    assert!(kinetic0 > 1.0, "{kinetic0}");
    let e0 = energy(&x);
    let mut drift: f64 = 0.0;
    let mut alpha_range = (x[1], x[1]);
    simulate(model.as_ref(), &mut x, &u, 0.0, 2.0, 1e-4, |_, x| {
        drift = drift.max((energy(x) - e0).abs());
        alpha_range = (alpha_range.0.min(x[1]), alpha_range.1.max(x[1]));
    });
    assert_eq!(x[4], n);
    assert!(
        alpha_range.1 - alpha_range.0 > 1e-3,
        "the lever must actually swing"
    );
    println!("relative energy drift {:.3e}", drift / kinetic0);
    assert!(
        drift / kinetic0 < 1e-6,
        "relative energy drift {}",
        drift / kinetic0
    );
}

#[test]
fn damper_and_friction_only_dissipate() {
    let truck = reference();
    let load = reference_load(&truck);
    let u = input(load);
    let conservative_model = build_model("m2", &conservative(&truck)).unwrap();
    let model = build_model("m2", &truck).unwrap();
    let mut x = model
        .initial_state(&u, &InitialCondition::BellowPressure { gauge_pa: 350e3 })
        .unwrap();
    x[3] = 0.2;
    let mut y = x.clone();
    simulate(model.as_ref(), &mut x, &u, 0.0, 3.0, 1e-4, |_, _| {});
    simulate(
        conservative_model.as_ref(),
        &mut y,
        &u,
        0.0,
        3.0,
        1e-4,
        |_, _| {},
    );
    // Damped: back at rest; undamped: still swinging.
    assert!(x[3].abs() < 1e-3 && x[2].abs() < 1e-3, "{x:?}");
    assert!(y[3].abs().max(y[2].abs() * 10.0) > 1e-2, "{y:?}");
}

#[test]
fn closed_valve_keeps_the_air_amount() {
    let truck = reference();
    let u = input(reference_load(&truck));
    for name in MODELS {
        let model = build_model(name, &truck).unwrap();
        let mut x = model
            .initial_state(&u, &InitialCondition::BellowPressure { gauge_pa: 350e3 })
            .unwrap();
        // Disturb everything but n: the flow must stay zero anyway.
        for v in x.iter_mut().skip(1).take(3) {
            *v += 0.01;
        }
        let n_index = if *name == "m3" { 0 } else { 4 };
        let mut dx = vec![0.0; x.len()];
        model.rhs(0.0, &x, &u, &mut dx);
        assert_eq!(dx[n_index], 0.0, "{name}");
    }
}

/// Fill then exhaust: the air added, `∫ f_air dt` computed from the *outputs* with eq 3.19,
/// equals the change of `n = p V / (R T)` computed from the *outputs* with the ideal gas law.
#[test]
fn integrated_valve_flow_equals_the_change_in_air_amount() {
    let truck = reference();
    let load = reference_load(&truck);
    let amb = truck.environment.ambient_pressure_pa;
    for name in ["m1", "m2", "m2xh"] {
        let model = build_model(name, &truck).unwrap();
        let mut x = model
            .initial_state(
                &input(load),
                &InitialCondition::BellowPressure { gauge_pa: 350e3 },
            )
            .unwrap();
        let amount = |x: &[f64], u: &InputSample| {
            let y = model.output(x, u);
            let h_b = bellow_from_sensor(&truck, y.sensor_height_m, load);
            (y.bellow_gauge_pa + amb) * volume(&truck, h_b) / rt(&truck)
        };
        let n0 = amount(&x, &input(load));
        let mut t0 = 0.0;
        let mut integral = 0.0;
        for (valve, duration) in [(ValveState::Fill, 2.0), (ValveState::Exhaust, 1.5)] {
            let u = InputSample {
                valve,
                ..input(load)
            };
            let (r_fill, r_exhaust) = (
                get(&truck, Field::FillResistance),
                get(&truck, Field::ExhaustResistance),
            );
            let flow = |x: &[f64]| {
                let p = model.output(x, &u).bellow_gauge_pa + amb;
                match valve {
                    ValveState::Fill => (u.supply_gauge_pa + amb - p) / r_fill,
                    _ => -(p - amb) / r_exhaust,
                }
            };
            let dt = 1e-4;
            let mut previous = flow(&x);
            simulate(model.as_ref(), &mut x, &u, t0, duration, dt, |_, x| {
                let now = flow(x);
                integral += 0.5 * (previous + now) * dt;
                previous = now;
            });
            t0 += duration;
        }
        let n1 = amount(&x, &input(load));
        assert!(
            integral.abs() > 1e-2,
            "{name}: the valve must move air ({integral})"
        );
        assert!(
            ((n1 - n0) - integral).abs() < 1e-6 * n0,
            "{name}: Δn {} vs ∫f {integral}",
            n1 - n0
        );
    }
}

#[test]
fn output_map_matches_spec_section_1() {
    let truck = reference();
    let load = 3200.0;
    let u = input(load);
    let g = &truck.geometry;
    // Model 1: sensor = (x1 - x2) - k_scl m_tot g, i.e. the SPEC map on h_b = eq 2.1.
    let m1 = build_model("m1", &truck).unwrap();
    let x = [0.25, -0.02, 0.0, 0.0, 20.0];
    let h_b = g.h0_m + lever_gain(&truck) * (x[0] - x[1] - g.h0_m);
    let spec =
        g.h0_m + (h_b - g.h0_m) / lever_gain(&truck) - g.lever_compliance_m_per_n * load * 9.81;
    let y = m1.output(&x, &u);
    assert!(
        (y.sensor_height_m - spec).abs() < 1e-14,
        "{} vs {spec}",
        y.sensor_height_m
    );
    let p = 20.0 * rt(&truck) / volume(&truck, h_b) - truck.environment.ambient_pressure_pa;
    assert!((y.bellow_gauge_pa - p).abs() < 1e-8);
    // Model 2: h_b from eq 2.2.
    let m2 = build_model("m2", &truck).unwrap();
    let x = [0.3, 0.2, 0.0, 0.0, 20.0];
    let h_b = g.h0_m + (g.l1_m + g.l2_m) * 0.2_f64.sin();
    let spec =
        g.h0_m + (h_b - g.h0_m) / lever_gain(&truck) - g.lever_compliance_m_per_n * load * 9.81;
    assert!((m2.output(&x, &u).sensor_height_m - spec).abs() < 1e-14);
}

/// SPEC §5: "sprung load about 2830 kg, bellow gauge pressure about 350 kPa, sensor about
/// 240 mm, bellow about 300 mm". The numbers below are what the reference parameters give;
/// they show that those four figures are not mutually consistent (see the crate report).
#[test]
fn reference_truck_static_numbers() {
    let truck = reference();
    let load = reference_load(&truck);
    let u = input(load);
    let model = build_model("m2", &truck).unwrap();
    let at_350 = model.output(
        &model
            .initial_state(&u, &InitialCondition::BellowPressure { gauge_pa: 350e3 })
            .unwrap(),
        &u,
    );
    let h_b_350 = bellow_from_sensor(&truck, at_350.sensor_height_m, load);
    let at_240 = model.output(
        &model
            .initial_state(&u, &InitialCondition::SensorHeight { height_m: 0.240 })
            .unwrap(),
        &u,
    );
    let h_b_240 = bellow_from_sensor(&truck, at_240.sensor_height_m, load);
    let sensor_at_300 = 0.1 + 0.2 / lever_gain(&truck) - 2e-7 * load * 9.81;
    println!(
        "350 kPa: bellow {:.1} mm, sensor {:.1} mm; sensor 240 mm: bellow {:.1} mm, {:.1} kPa; bellow 300 mm: sensor {:.1} mm",
        h_b_350 * 1e3,
        at_350.sensor_height_m * 1e3,
        h_b_240 * 1e3,
        at_240.bellow_gauge_pa / 1e3,
        sensor_at_300 * 1e3
    );
    // 350 kPa: the rising branch of A_eff gives 263.7 mm bellow, 206 mm sensor.
    assert!((h_b_350 - 0.2637).abs() < 1e-3, "{h_b_350}");
    assert!((at_350.sensor_height_m - 0.2064).abs() < 1e-3);
    // 240 mm sensor: 312.8 mm bellow at 344.7 kPa.
    assert!((h_b_240 - 0.3128).abs() < 1e-3, "{h_b_240}");
    assert!(
        (at_240.bellow_gauge_pa - 344.7e3).abs() < 0.5e3,
        "{}",
        at_240.bellow_gauge_pa
    );
    // 300 mm bellow reads 231 mm on the sensor.
    assert!((sensor_at_300 - 0.2312).abs() < 1e-3);
}

#[test]
fn no_equilibrium_is_a_clear_error() {
    let truck = reference();
    let load = reference_load(&truck);
    for name in MODELS {
        let model = build_model(name, &truck).unwrap();
        let err = model
            .initial_state(
                &input(load),
                &InitialCondition::BellowPressure { gauge_pa: 200e3 },
            )
            .unwrap_err();
        assert!(matches!(err, ModelError::NoEquilibrium { .. }), "{err}");
        assert!(
            err.to_string().contains("too low to carry the load"),
            "{err}"
        );
        let err = model
            .initial_state(
                &input(300.0),
                &InitialCondition::BellowPressure { gauge_pa: 350e3 },
            )
            .unwrap_err();
        assert!(err.to_string().contains("unsprung mass"), "{err}");
        let err = model
            .initial_state(
                &input(load),
                &InitialCondition::SensorHeight { height_m: 2.0 },
            )
            .unwrap_err();
        assert!(matches!(err, ModelError::NoEquilibrium { .. }), "{err}");
        let err = model
            .initial_state(
                &input(load),
                &InitialCondition::BellowPressure { gauge_pa: f64::NAN },
            )
            .unwrap_err();
        assert!(matches!(err, ModelError::NoEquilibrium { .. }), "{err}");
    }
}

/// The wheel leaves the ground (road drops away by 0.3 m): the tire force is zero, the models
/// stay finite and the axle falls until the road catches it again.
#[test]
fn wheel_in_the_air_stays_well_defined() {
    let truck = reference();
    let load = reference_load(&truck);
    for name in ["m1", "m2", "m2x", "m2xh"] {
        let model = build_model(name, &truck).unwrap();
        let mut x = model
            .initial_state(
                &input(load),
                &InitialCondition::BellowPressure { gauge_pa: 350e3 },
            )
            .unwrap();
        let u = InputSample {
            road_height_m: -0.3,
            ..input(load)
        };
        let mut dx = vec![0.0; x.len()];
        model.rhs(0.0, &x, &u, &mut dx);
        // In the air the whole corner starts in free fall: the total vertical momentum changes
        // at -g (Model 1: both masses; Model 2: the chassis coordinate with the lever).
        if name == "m1" {
            let (m1, m2) = (load - truck.mass.unsprung_kg, truck.mass.unsprung_kg);
            assert!(
                ((m1 * dx[2] + m2 * dx[3]) / (m1 + m2) + 9.81).abs() < 1e-9,
                "{dx:?}"
            );
        }
        let mut finite = true;
        simulate(model.as_ref(), &mut x, &u, 0.0, 1.0, 1e-4, |_, x| {
            finite &= x.iter().all(|v| v.is_finite())
        });
        println!("{name}: {x:?}");
        assert!(finite, "{name}: {x:?}");
        let y = model.output(&x, &u);
        assert!(
            y.sensor_height_m.is_finite() && y.bellow_gauge_pa.is_finite(),
            "{name}"
        );
    }
}

/// A supply line the file names (`[effects] line_resistance_pa_s_per_mol`) sits between the
/// logged tank and every model's valve (issue #12 item 5): a state of its own, at the tank's
/// pressure at rest, refilling through `rline`, drawn on by the fill channel; in a steady
/// fill the linear valve and the line are two resistances in series, written out here.
#[test]
fn a_supply_line_the_file_names_sits_between_the_tank_and_every_models_valve() {
    let plain = reference();
    let (r_fill, r_line) = (2.5e6, 4e5);
    assert_eq!(get(&plain, Field::FillResistance), r_fill);
    let mut lined = plain.clone();
    lined.effects.line_resistance_pa_s_per_mol = Some(r_line);
    let volume_m3 = airsus_data::SUPPLY_LINE_VOLUME_M3;
    let load = reference_load(&plain);
    let ic = InitialCondition::SensorHeight { height_m: 0.240 };
    let ambient = plain.environment.ambient_pressure_pa;
    for name in MODELS {
        let without = build_model(name, &plain).unwrap();
        let model = build_model(name, &lined).unwrap();
        let names = |m: &dyn airsus_model::SuspensionModel| -> Vec<String> {
            m.parameters()
                .infos()
                .iter()
                .map(|p| p.name.to_owned())
                .collect()
        };
        assert!(!names(&*without).contains(&"rline".to_owned()), "{name}");
        assert!(names(&*model).contains(&"rline".to_owned()), "{name}");
        assert_eq!(model.n_states(), without.n_states() + 1, "{name}");
        assert_eq!(model.states().last().unwrap().name, "line_n_mol", "{name}");
        assert!(model.uses_supply_while_valve_shut() && !without.uses_supply_while_valve_shut());

        let closed = input(load);
        let tank_abs = closed.supply_gauge_pa + ambient;
        let x = model.initial_state(&closed, &ic).unwrap();
        let n = x.len();
        // At rest the line holds the tank's pressure, and nothing moves.
        let line_pa = |line_mol: f64| line_mol * rt(&plain) / volume_m3;
        assert!((line_pa(x[n - 1]) - tank_abs).abs() < 1e-6, "{name}");
        let mut dx = vec![1.0; n];
        model.rhs(0.0, &x, &closed, &mut dx);
        assert!(max_abs(&dx) < 1e-9, "{name}: {dx:?}");

        // The valve opens: at first the line is at the tank's pressure, so the bellow fills
        // as it would from the tank itself, and the line loses what the bellow gains.
        let fill = InputSample {
            valve: ValveState::Fill,
            ..closed
        };
        let bellow = |m: &dyn airsus_model::SuspensionModel, x: &[f64]| {
            let n_bellow = m.states().iter().position(|s| s.name == "n_mol").unwrap();
            let mut dx = vec![0.0; x.len()];
            m.rhs(0.0, x, &fill, &mut dx);
            (dx[n_bellow], dx[x.len() - 1])
        };
        let x_without = without.initial_state(&closed, &ic).unwrap();
        let (from_tank, _) = bellow(&*without, &x_without);
        let (into_bellow, into_line) = bellow(&*model, &x);
        assert!(from_tank > 0.0, "{name}");
        assert!((into_bellow - from_tank).abs() < 1e-12, "{name}");
        assert!((into_line + into_bellow).abs() < 1e-12, "{name}");

        // A steady fill: the line's pressure where its inflow through rline equals what the
        // valve draws, p_line = (R_fill p_tank + R_line p_bellow) / (R_fill + R_line); the
        // bellow then fills at (p_tank - p_bellow) / (R_fill + R_line).
        let bellow_abs = model.output(&x, &closed).bellow_gauge_pa + ambient;
        let steady_pa = (r_fill * tank_abs + r_line * bellow_abs) / (r_fill + r_line);
        let mut steady = x.clone();
        steady[n - 1] = steady_pa * volume_m3 / rt(&plain);
        let (into_bellow, into_line) = bellow(&*model, &steady);
        let series = (tank_abs - bellow_abs) / (r_fill + r_line);
        assert!((into_bellow / series - 1.0).abs() < 1e-9, "{name}");
        assert!(into_line.abs() < 1e-9 * series, "{name}");

        // The line refills from the tank with the valve shut, and rline is the model's to set.
        let mut model = model;
        let (_, refill) = {
            let mut dx = vec![0.0; n];
            model.rhs(0.0, &steady, &closed, &mut dx);
            (dx[0], dx[n - 1])
        };
        assert!(
            (refill - (tank_abs - steady_pa) / r_line).abs() < 1e-9 * refill,
            "{name}"
        );
        model.set_parameter("rline", 2.0 * r_line).unwrap();
        let mut dx = vec![0.0; n];
        model.rhs(0.0, &steady, &closed, &mut dx);
        assert!((dx[n - 1] / refill - 0.5).abs() < 1e-9, "{name}");
    }
}
