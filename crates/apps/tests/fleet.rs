//! The virtual fleet's truck-days and the weighing at their standstills, against the truth
//! the generator keeps (issue #17). One sound and one leaking truck-day are simulated once and
//! shared by the tests.

use std::sync::OnceLock;

use airsus_apps::fleet::{
    ControllerMode, FleetSpec, FleetTruck, SAMPLES_PER_DAY, TARGET_HEIGHT_M, TruckDayLog,
    TruckSimulator, fleet_trucks, plan_day,
};
use airsus_apps::weigh::{
    StandstillDetector, StandstillSignals, StaticLaw, StaticWeigher, WeighingUncertainty,
    weigh_standstills,
};
use airsus_data::ValveState;

/// A fleet of four with truck 2 leaking from 02:00 on; its day 0 and truck 0's day 0.
fn days() -> &'static (FleetTruck, TruckDayLog, FleetTruck, TruckDayLog) {
    static DAYS: OnceLock<(FleetTruck, TruckDayLog, FleetTruck, TruckDayLog)> = OnceLock::new();
    DAYS.get_or_init(|| {
        let spec = FleetSpec::new(4, 1, 3)
            .expect("spec")
            .with_leaking_trucks(0)
            .expect("no leaks");
        let mut trucks = fleet_trucks(&spec);
        let sound = trucks[0].clone();
        let mut leaking = trucks.remove(2);
        leaking.leak = Some(airsus_apps::fleet::LeakGrowth {
            onset_s: 2.0 * 3600.0,
            growth_per_h: 5e-12,
            max_conductance: 1.5e-10,
        });
        let sound_day = TruckSimulator::new(sound.clone())
            .day(0)
            .expect("sound day");
        let leaking_day = TruckSimulator::new(leaking.clone())
            .day(0)
            .expect("leaking day");
        (sound, sound_day, leaking, leaking_day)
    })
}

fn hour_mean(values: &[f64], hour: f64) -> f64 {
    let k = (hour * 36_000.0) as usize;
    values[k..k + 600].iter().sum::<f64>() / 600.0
}

#[test]
fn a_truck_day_is_logged_whole_at_the_sensors_resolution() {
    let (_, day, _, _) = days();
    assert_eq!(day.len(), SAMPLES_PER_DAY);
    for k in (0..day.len()).step_by(997) {
        let h_tenths = day.height_m[k] * 1e4;
        let p_tenths = day.bellow_gauge_pa[k] / 100.0;
        assert!(
            (h_tenths - h_tenths.round()).abs() < 1e-6,
            "height {}",
            day.height_m[k]
        );
        assert!(
            (p_tenths - p_tenths.round()).abs() < 1e-6,
            "pressure {}",
            day.bellow_gauge_pa[k]
        );
        // What was logged is the truth plus the sensors' noise (0.15 mm, 0.2 kPa).
        assert!((day.height_m[k] - day.true_height_m[k]).abs() < 1e-3);
        assert!((day.bellow_gauge_pa[k] - day.true_gauge_pa[k]).abs() < 1.5e3);
    }
    assert!(
        day.time_s
            .windows(2)
            .all(|w| (w[1] - w[0] - 0.1).abs() < 1e-9)
    );
}

#[test]
fn the_controller_levels_awake_and_sleeps_parked() {
    let (truck, day, _, _) = days();
    let plan = plan_day(truck.loads, truck.seed, 0).expect("plan");
    let mut opened_asleep = 0;
    let mut openings = 0;
    let mut worst_standing_error: f64 = 0.0;
    for k in 1..day.len() {
        if day.valve[k] != ValveState::Closed {
            if plan.mode[k] == ControllerMode::Asleep {
                opened_asleep += 1;
            }
            if day.valve[k - 1] == ValveState::Closed {
                openings += 1;
            }
        }
        // Standing, 60 s after the load last changed: within the ±5 mm band (and a margin for
        // the stop lead and the gas settling after a fill).
        let settled = k >= 600
            && (k - 600..=k).all(|j| {
                plan.mode[j] == ControllerMode::Standing
                    && (plan.true_load_kg[j] - plan.true_load_kg[k]).abs() < 1e-9
            });
        if settled {
            worst_standing_error =
                worst_standing_error.max((day.true_height_m[k] - TARGET_HEIGHT_M).abs());
        }
    }
    assert_eq!(
        opened_asleep, 0,
        "the valve opened while the truck was parked"
    );
    // Each load change at the depot and the stops is levelled: a handful of openings, no
    // hunting (a pulse train would be hundreds).
    assert!((6..=60).contains(&openings), "{openings} valve openings");
    assert!(
        worst_standing_error < 7e-3,
        "standing height {worst_standing_error} m off target"
    );
}

#[test]
fn a_leak_empties_the_bellow_while_parked_and_a_sound_truck_holds_its_air() {
    let (_, sound, _, leaking) = days();
    // Both trucks are parked after 20:00 (their tours end by 14:00); the leak has grown for
    // 18 hours by then: 9e-11 mol/(s·Pa), about 0.9 % of the air an hour.
    assert!(leaking.leak_conductance[(20.0 * 36_000.0) as usize] > 8e-11);
    assert_eq!(
        sound.leak_conductance.iter().copied().fold(0.0, f64::max),
        0.0
    );
    let drop =
        |d: &TruckDayLog| hour_mean(&d.true_height_m, 20.0) - hour_mean(&d.true_height_m, 23.5);
    // A tight circuit sinks only as the evening cools the gas (a few kelvin: a few mm).
    assert!(
        drop(sound).abs() < 4e-3,
        "sound truck sank {} m",
        drop(sound)
    );
    assert!(
        drop(leaking) > 8e-3,
        "leaking truck sank only {} m",
        drop(leaking)
    );
}

#[test]
fn standstill_weighing_with_the_true_law_is_within_the_wall_friction() {
    let (truck, day, _, _) = days();
    let weigher = StaticWeigher::new(
        StaticLaw::from_virtual_truck(&truck.truth),
        WeighingUncertainty::default().sensors_only(),
    );
    let speed = day.speed_kmh.clone();
    let found = weigh_standstills(
        &StandstillSignals {
            time_s: &day.time_s,
            height_m: &day.height_m,
            gauge_pa: &day.bellow_gauge_pa,
            valve: &day.valve,
            speed_kmh: &speed,
            segment: &[],
        },
        &weigher,
        &StandstillDetector::default(),
    )
    .expect("weighing");
    assert!(found.len() >= 8, "{} standstills", found.len());
    let g = truck.truth.physical.environment.gravity_m_s2;
    let lever = truck.truth.physical.geometry.lever_gain();
    // The static law is exact but for the wall's friction (±F_c at the bellow) and the creep
    // force still relaxing; the sensors' noise averages out.
    let friction_kg = lever * truck.truth.effect_parameters.friction_force_n / g;
    for s in &found {
        let truth =
            day.true_load_kg[s.first..=s.last].iter().sum::<f64>() / (s.last - s.first + 1) as f64;
        // A load change ends a standstill: the truth is steady within each.
        let (low, high) = day.true_load_kg[s.first..=s.last]
            .iter()
            .fold((f64::MAX, f64::MIN), |(lo, hi), &m| (lo.min(m), hi.max(m)));
        assert!(high - low < 1.0, "the load changed by {} kg", high - low);
        let error = s.static_load_kg - truth;
        assert!(
            error.abs() < friction_kg + 5.0,
            "standstill {:.0}-{:.0} s: {error:.1} kg off (friction bound {friction_kg:.1} kg)",
            s.start_s,
            s.end_s
        );
        assert!((-1.0..=1.0).contains(&s.friction_state));
        // Standstills are at rest: the truck does not roll and the valve is shut.
        assert!(day.speed_kmh[s.first..=s.last].iter().all(|&v| v <= 0.5));
        assert!(
            day.valve[s.first..=s.last]
                .iter()
                .all(|&v| v == ValveState::Closed)
        );
    }
    // Loads at standstill span the day's range: empty and full.
    let loads: Vec<f64> = found.iter().map(|s| s.static_load_kg).collect();
    let span = loads.iter().copied().fold(f64::MIN, f64::max)
        - loads.iter().copied().fold(f64::MAX, f64::min);
    assert!(span > 400.0, "standstill loads span {span} kg");
}
