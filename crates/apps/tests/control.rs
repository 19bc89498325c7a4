//! Level control in closed loop: the band is held through a load sequence without hunting.

use airsus_apps::control::*;
use airsus_data::{TruckParameters, ValveState};
use airsus_model::build_model;
use airsus_truck::model::{SupplyMode, TruckModel};
use airsus_truck::truth::VirtualTruck;

fn controllers(guard: &GuardSettings) -> Vec<Box<dyn LevelController>> {
    controllers_designed_on(guard, &TruckParameters::reference())
}

/// The deadband controller and the predictive one with `design`'s valve, volume and law.
fn controllers_designed_on(
    guard: &GuardSettings,
    design: &TruckParameters,
) -> Vec<Box<dyn LevelController>> {
    vec![
        Box::new(DeadbandController::new(guard.clone())),
        Box::new(PredictiveController::new(
            guard.clone(),
            ValveModel::from_truck(design),
        )),
    ]
}

/// One closed-loop run and its scores (air in free litres at 20 °C, 101.325 kPa).
fn run_and_score(
    plant: &Plant,
    controller: &mut dyn LevelController,
    scenario: &LevelScenario,
    guard: &GuardSettings,
) -> (ClosedLoopRun, ControlScore) {
    let run =
        simulate_closed_loop(plant, controller, scenario, &ClosedLoopConfig::default()).unwrap();
    let s = score(
        &run,
        &scenario.events_s,
        guard,
        8.314462618 * 293.15,
        101325.0,
    );
    (run, s)
}

/// No opening shorter than the minimum on-time, and no fill-exhaust-fill (or the reverse)
/// cycle: a reversal never starts within the lock-out of the last opening.
fn assert_no_hunting(run: &ClosedLoopRun, guard: &GuardSettings) {
    let mut opened: Option<(ValveState, f64)> = None;
    let mut last: Option<(ValveState, f64)> = None;
    for k in 0..run.valve.len() {
        let prev = if k == 0 {
            ValveState::Closed
        } else {
            run.valve[k - 1]
        };
        let v = run.valve[k];
        if v == prev {
            continue;
        }
        let t = run.time_s[k];
        assert!(
            prev == ValveState::Closed || v == ValveState::Closed,
            "{}: direct switch {prev:?} -> {v:?} at {t} s",
            run.controller
        );
        if let Some((dir, since)) = opened.take() {
            assert!(
                t - since >= guard.min_on_s - 1e-9,
                "{}: {dir:?} open only {:.2} s at {t} s",
                run.controller,
                t - since
            );
            last = Some((dir, t));
        }
        if v != ValveState::Closed {
            if let Some((dir, end)) = last
                && dir != v
            {
                assert!(
                    t - end >= guard.reversal_lockout_s - 1e-9,
                    "{}: {v:?} {:.1} s after {dir:?}",
                    run.controller,
                    t - end
                );
            }
            opened = Some((v, t));
        }
    }
}

#[test]
fn both_controllers_hold_the_band_through_load_steps_on_the_virtual_truck() {
    let plant = Plant::Truck(Box::new(TruckModel::new(
        VirtualTruck::reference(),
        SupplyMode::Tank,
    )));
    let scenario = level_scenario("load-steps", 0.240, 3390.0).unwrap();
    let guard = GuardSettings::default();
    for mut c in controllers(&guard) {
        let (run, s) = run_and_score(&plant, c.as_mut(), &scenario, &guard);
        println!("{}: {s:?}", c.name());
        assert_no_hunting(&run, &guard);
        assert_eq!(s.short_openings, 0);
        assert_eq!(s.quick_reversals, 0);
        // One scored segment per load change: a score without segments would pass the loop
        // below vacuously.
        assert_eq!(
            s.segments.len(),
            scenario.events_s.len(),
            "{}: {s:?}",
            c.name()
        );
        assert!(s.openings >= scenario.events_s.len(), "{}: {s:?}", c.name());
        // Every event settles into the ±5 mm band within 100 s and stays there.
        for seg in &s.segments {
            let t = seg.settling_time_s.expect("settles");
            assert!(t < 100.0, "{}: settling {t} s at {}", c.name(), seg.start_s);
            assert!(seg.steady_error_m.abs() <= guard.tolerance_m);
        }
        // Bounded valve use: four load changes, at most five openings each.
        assert!(s.openings <= 20, "{}: {} openings", c.name(), s.openings);
        // Only the unloading (-600 kg) calls for exhaust after fill.
        assert!(s.reversals <= 2);
        // The air let in is what the load needs, not a multiple of it (hunting would burn air):
        // 850 kg added in total needs about 2.5 mol.
        assert!(
            (1.5..4.0).contains(&s.air_filled_mol),
            "{}",
            s.air_filled_mol
        );
    }
}

/// Designed on the nominal truck file, or on what the study estimated from variant 0's runs
/// (`tests/fixtures/study_truck_variant0.toml`), tried on trucks of the family it was not
/// designed on (other effective-area shapes, volume, valve laws — variant 3 flows through
/// linear resistances — friction, creep, masses): both controllers hold ±2 mm through the
/// load sequence without hunting.
#[test]
fn both_controllers_hold_2_mm_on_trucks_they_were_not_designed_on() {
    let estimated = airsus_data::read_truck(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/study_truck_variant0.toml"),
    )
    .unwrap()
    .parameters;
    for (design, name) in [
        (TruckParameters::reference(), "the nominal file"),
        (estimated, "variant 0's study estimate"),
    ] {
        hold_2_mm_on_variants_1_to_3(&design, name);
    }
}

fn hold_2_mm_on_variants_1_to_3(design: &TruckParameters, design_name: &str) {
    let scenario = level_scenario("load-steps", 0.240, 3390.0).unwrap();
    let guard = GuardSettings {
        tolerance_m: 2e-3,
        ..GuardSettings::default()
    };
    let mut air = Vec::new();
    for variant in 1..=3 {
        let plant = Plant::Truck(Box::new(TruckModel::new(
            VirtualTruck::variant(variant),
            SupplyMode::Tank,
        )));
        for mut c in controllers_designed_on(&guard, design) {
            let (run, s) = run_and_score(&plant, c.as_mut(), &scenario, &guard);
            let who = format!(
                "{} designed on {design_name}, on variant {variant}",
                c.name()
            );
            assert_no_hunting(&run, &guard);
            assert_eq!((s.short_openings, s.quick_reversals), (0, 0), "{who}");
            assert_eq!(s.segments.len(), scenario.events_s.len(), "{who}");
            for seg in &s.segments {
                let t = seg
                    .settling_time_s
                    .unwrap_or_else(|| panic!("{who}: never settles after {} s", seg.start_s));
                assert!(t < 100.0, "{who}: settling {t} s at {}", seg.start_s);
                assert!(
                    seg.steady_error_m.abs() <= guard.tolerance_m,
                    "{who}: steady error {} mm",
                    seg.steady_error_m * 1e3
                );
            }
            // A narrow band costs openings, not hunting: at most eight per load change, and
            // only the unloading reverses.
            assert!(s.openings <= 32, "{who}: {} openings", s.openings);
            assert!(s.reversals <= 2, "{who}: {} reversals", s.reversals);
            // Settling is timed to the last entry into the band, so a creep across its edge
            // long after the fill counts whole (up to 88 s measured); the time actually
            // outside the band says how long the truck stood off its height: 39-59 s over
            // the four load changes measured, by far most of it the load steps themselves.
            assert!(
                s.time_outside_band_s < 75.0,
                "{who}: {:.1} s outside ±2 mm",
                s.time_outside_band_s
            );
            println!(
                "{who}: {} openings, {} reversals, {:.2} mol filled, worst settling {:?} s, {:.1} s outside the band",
                s.openings,
                s.reversals,
                s.air_filled_mol,
                s.worst_settling_time_s,
                s.time_outside_band_s
            );
            air.push((who, s.air_filled_mol));
        }
    }
    // The air both let in is what the loads need (850 kg up, 600 down: about 2.5–3.5 mol on
    // these trucks); neither burns a multiple of it. The predictive controller does not save
    // air here: the air a load change needs is fixed by the load, and what is left to save
    // (overshoot, follow-ups) is within ±6 % either way (measured: 2.78-3.06 mol against the
    // deadband's 2.92-3.16; README, "Level control").
    for (who, mol) in &air {
        assert!((2.0..4.0).contains(mol), "{who}: {mol} mol");
    }
}

/// On a road the controllers let the bumps pass: the ride height between them (its 2 s mean)
/// stays near the target and the valve opens at most four times, with at most one reversal,
/// in 200 s of class C road (without the driving filter the deadband controller opened 4–5
/// times; with the standing filter on the stop decision too it hunted, 10 openings). Measured:
/// the deadband controller 1 opening; the predictive one a fill and its follow-up, an exhaust
/// and its follow-up (4; 3 before it counted the supply line's drop, which lengthened its
/// fill by 0.1 s and left the exhaust 0.5 mm outside its inner band).
#[test]
fn both_controllers_let_a_road_pass() {
    let scenario = level_scenario("road", 0.240, 3390.0).unwrap();
    assert!(
        scenario
            .road_height_m
            .iter()
            .map(|z| z.abs())
            .fold(0.0, f64::max)
            > 0.01,
        "the road is a road"
    );
    let guard = GuardSettings {
        tolerance_m: 2e-3,
        ..GuardSettings::default()
    };
    let plant = Plant::Truck(Box::new(TruckModel::new(
        VirtualTruck::variant(2),
        SupplyMode::Tank,
    )));
    for mut c in controllers(&guard) {
        let (run, s) = run_and_score(&plant, c.as_mut(), &scenario, &guard);
        let raw_swing = run
            .height_m
            .iter()
            .fold(0.0f64, |a, h| a.max((h - 0.240).abs()));
        assert_no_hunting(&run, &guard);
        assert!(
            raw_swing > 3.0 * guard.tolerance_m,
            "{}: the body moves",
            c.name()
        );
        assert!(s.openings <= 4 && s.reversals <= 1, "{}: {s:?}", c.name());
        // The ride height (2 s mean) never strays by more than twice the band, and is back
        // in it when the truck stands again.
        for seg in &s.segments {
            assert!(
                seg.max_deviation_m < 2.5 * guard.tolerance_m,
                "{}: {s:?}",
                c.name()
            );
        }
        let last = s.segments.last().unwrap();
        assert!(
            last.steady_error_m.abs() <= guard.tolerance_m,
            "{}: {s:?}",
            c.name()
        );
    }
}

#[test]
fn height_changes_on_model_2() {
    let plant = Plant::Model(build_model("m2", &TruckParameters::reference()).unwrap());
    let scenario = level_scenario("height-change", 0.240, 3390.0).unwrap();
    let guard = GuardSettings::default();
    for mut c in controllers(&guard) {
        let (run, s) = run_and_score(&plant, c.as_mut(), &scenario, &guard);
        assert_no_hunting(&run, &guard);
        assert!(s.worst_settling_time_s.is_some_and(|t| t < 40.0), "{s:?}");
        assert!(s.max_overshoot_m < guard.tolerance_m);
    }
}

#[test]
fn guard_enforces_on_time_rest_and_lockout() {
    let guard = GuardSettings::default();
    let mut g = ValveGuard::new(guard.clone());
    // Requests flipping every sample never produce a pulse shorter than the minimum.
    let mut t = 0.0;
    let mut applied = Vec::new();
    for k in 0..400 {
        // 20 s of requests flipping every sample, then 20 s that ask only to exhaust: the
        // second half exercises the reversal lock-out after the fills of the first.
        let req = match (k < 200, k % 3) {
            (true, 0) => ValveState::Fill,
            (true, 1) => ValveState::Exhaust,
            (true, _) => ValveState::Closed,
            (false, 0) => ValveState::Closed,
            (false, _) => ValveState::Exhaust,
        };
        applied.push(g.apply(t, req));
        t += 0.1;
    }
    let run = ClosedLoopRun {
        controller: "guard".into(),
        time_s: (0..400).map(|k| k as f64 * 0.1).collect(),
        valve: applied,
        ..ClosedLoopRun::default()
    };
    assert_no_hunting(&run, &guard);
    // A guard that never opens would pass the check above; this one must pass requests on,
    // in both directions, each held for the minimum on-time.
    let openings = |dir: ValveState| {
        run.valve
            .windows(2)
            .filter(|w| w[0] != dir && w[1] == dir)
            .count()
            + usize::from(run.valve.first() == Some(&dir))
    };
    let (fills, exhausts) = (openings(ValveState::Fill), openings(ValveState::Exhaust));
    assert!(
        fills >= 2 && exhausts >= 2,
        "fills {fills}, exhausts {exhausts}"
    );
    let open_samples = run
        .valve
        .iter()
        .filter(|&&v| v != ValveState::Closed)
        .count();
    assert!(
        open_samples as f64 * 0.1 >= (fills + exhausts) as f64 * guard.min_on_s - 1e-9,
        "{open_samples} open samples for {} openings",
        fills + exhausts
    );
}

#[test]
fn unknown_scenario_is_an_error() {
    let err = level_scenario("bumpy", 0.24, 3390.0)
        .unwrap_err()
        .to_string();
    assert!(err.contains("load-steps"), "{err}");
    assert!(level_scenario("load-steps", -1.0, 3390.0).is_err());
}

/// A band narrower than the controllers' default margins (a 1 mm stop margin, a 1.5 mm
/// inner band) is still held: the margins shrink with the band, so a correction ends inside
/// it instead of just short of it, where the next opening follows after each rest. Measured
/// at ±0.8 mm on the reference truck: the deadband controller 16 openings for four load
/// changes (25 with the fixed 1 mm margin), the predictive one 31.
#[test]
fn a_narrow_band_is_held_without_chained_pulses() {
    let scenario = level_scenario("load-steps", 0.240, 3390.0).unwrap();
    let guard = GuardSettings {
        tolerance_m: 0.8e-3,
        ..GuardSettings::default()
    };
    let plant = Plant::Truck(Box::new(TruckModel::new(
        VirtualTruck::reference(),
        SupplyMode::Tank,
    )));
    for mut c in controllers(&guard) {
        let (run, s) = run_and_score(&plant, c.as_mut(), &scenario, &guard);
        let who = c.name();
        assert_no_hunting(&run, &guard);
        assert_eq!(s.segments.len(), scenario.events_s.len(), "{who}");
        for seg in &s.segments {
            assert!(
                seg.settling_time_s.is_some_and(|t| t < 100.0),
                "{who}: {seg:?}"
            );
            assert!(
                seg.steady_error_m.abs() <= guard.tolerance_m,
                "{who}: steady error {} mm",
                seg.steady_error_m * 1e3
            );
        }
        let most = if who == "deadband" { 18 } else { 40 };
        assert!(s.openings <= most, "{who}: {} openings", s.openings);
    }
}

/// A controller designed on a study's estimate must be tried on another truck: `control`'s
/// default plant is the family member next to the one the design file is nearest. Each
/// variant's study estimate (the weighing fixtures: the `truck` structure, seed 1) is nearest
/// its own variant, by a margin: measured 0.04-0.5 % from its own, 3.7 % or more from any
/// other. The nominal file is nearest the reference truck, variant 0, whose nominal values
/// it carries.
#[test]
fn a_study_estimate_is_nearest_its_own_variant() {
    for k in 0..=3 {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join(format!("tests/fixtures/study_truck_variant{k}.toml"));
        let estimate = airsus_data::read_truck(&path).unwrap().parameters;
        let (nearest, distance) = VirtualTruck::nearest_variant(&estimate, 0..=7);
        let others = (0..=7u32)
            .filter(|&j| j != k)
            .map(|j| VirtualTruck::variant_distance(&estimate, j))
            .fold(f64::INFINITY, f64::min);
        println!(
            "variant {k}'s estimate: nearest {nearest} at {distance:.4}, the next at {others:.4}"
        );
        assert_eq!(nearest, k);
        assert!(
            distance < 0.01 && others > 5.0 * distance,
            "{distance} {others}"
        );
    }
    // The nominal file has the thesis' laws (no area stretch, a linear valve), 5.4 % from
    // the reference's resolved ones, and 6.7 % or more from every other member.
    let nominal = TruckParameters::reference();
    let (nearest, distance) = VirtualTruck::nearest_variant(&nominal, 0..=7);
    let others = (1..=7u32)
        .map(|j| VirtualTruck::variant_distance(&nominal, j))
        .fold(f64::INFINITY, f64::min);
    println!("the nominal file: nearest {nearest} at {distance:.4}, the next at {others:.4}");
    assert_eq!(nearest, 0);
    assert!(others > 1.2 * distance, "{distance} {others}");
}
