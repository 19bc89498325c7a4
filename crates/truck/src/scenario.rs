//! Input profiles of the reference experiments (thesis 5.1, SPEC §6).
//!
//! Each scenario gives, at every 100 ms sample, what really acts on the truck (the true wheel
//! load, which ramps over several seconds while a traverse sets a tonne down or lifts it off)
//! and what the log says (a clean step, as the thesis' hand-made load signal), plus the valve
//! command. Supply pressure is not part of a scenario: the virtual truck's tank produces it.
//! Randomised details (step sizes 250–350 kg, ramp durations, pulse lengths) are drawn from a
//! seeded generator, so a seed fixes the experiment.

use airsus_data::ValveState;

use crate::error::TruckError;
use crate::physics::smoothstep;
use crate::road::{Iso8608Road, half_sine_bump_m};
use crate::sensors::NoiseSource;

/// Sample time of the truck's logger, s.
pub const SAMPLE_TIME_S: f64 = 0.1;
/// Sprung load on the modeled wheel during data-sets 3 and 4 (thesis 5.1.3), kg.
pub const REFERENCE_SPRUNG_KG: f64 = 2830.0;

/// One experiment's inputs at the logger's sample times.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    pub name: String,
    pub description: String,
    pub time_s: Vec<f64>,
    /// The load that really acts on the wheel, kg.
    pub true_load_kg: Vec<f64>,
    /// The load as logged: a clean step at the start of each ramp, kg.
    pub logged_load_kg: Vec<f64>,
    /// The part of the true load the log does not show at all (a mishap), kg; zeros when
    /// every change is logged.
    pub unlogged_load_kg: Vec<f64>,
    pub valve: Vec<ValveState>,
    /// Road height under the wheel, m.
    pub road_height_m: Vec<f64>,
}

impl Scenario {
    fn constant(name: &str, description: &str, duration_s: f64, wheel_load_kg: f64) -> Self {
        let n = (duration_s / SAMPLE_TIME_S).round() as usize + 1;
        Self {
            name: name.to_owned(),
            description: description.to_owned(),
            // Multiplying (not accumulating) keeps the time axis exact to one rounding.
            time_s: (0..n).map(|i| i as f64 * SAMPLE_TIME_S).collect(),
            true_load_kg: vec![wheel_load_kg; n],
            logged_load_kg: vec![wheel_load_kg; n],
            unlogged_load_kg: vec![0.0; n],
            valve: vec![ValveState::Closed; n],
            road_height_m: vec![0.0; n],
        }
    }

    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    fn index_at(&self, t_s: f64) -> usize {
        ((t_s / SAMPLE_TIME_S).round() as usize).min(self.len())
    }

    /// A load change of `delta_kg` starting at `start_s`: the truth follows a smooth ramp
    /// of `ramp_s`, the log jumps at `start_s`.
    fn load_step(&mut self, start_s: f64, delta_kg: f64, ramp_s: f64) {
        let start = self.index_at(start_s);
        for i in start..self.len() {
            let progress = (self.time_s[i] - start_s) / ramp_s;
            self.true_load_kg[i] += delta_kg * smoothstep(progress);
            self.logged_load_kg[i] += delta_kg;
        }
    }

    /// Loads of 250–350 kg set down (`+1`) or the last one still on the truck lifted off
    /// (`-1`) at the plan's times, each taken over a 3-8 s ramp; sizes and ramps drawn from
    /// `noise` in plan order.
    fn set_down_and_lift_off(&mut self, plan: &[(f64, i8)], noise: &mut NoiseSource) {
        let mut on_truck = Vec::new();
        for &(start_s, direction) in plan {
            let delta = if direction > 0 {
                let d = step_size(noise);
                on_truck.push(d);
                d
            } else {
                -on_truck.pop().unwrap_or(300.0)
            };
            self.load_step(start_s, delta, ramp(noise));
        }
    }

    /// The truth alone changes (a mishap the log does not show), smoothly over `ramp_s`.
    fn unlogged_load_change(&mut self, start_s: f64, delta_kg: f64, ramp_s: f64) {
        let start = self.index_at(start_s);
        for i in start..self.len() {
            let progress = (self.time_s[i] - start_s) / ramp_s;
            let felt = delta_kg * smoothstep(progress);
            self.true_load_kg[i] += felt;
            self.unlogged_load_kg[i] += felt;
        }
    }

    /// The scenario as its log tells it: every logged change as the truck felt it (its
    /// ramp), without the changes the log does not show; `None` when it shows them all.
    /// What a model driven by the logged load can at best follow.
    pub fn as_logged(&self) -> Option<Scenario> {
        if self.unlogged_load_kg.iter().all(|&m| m == 0.0) {
            return None;
        }
        let mut logged = self.clone();
        for (load, unlogged) in logged
            .true_load_kg
            .iter_mut()
            .zip(&mut logged.unlogged_load_kg)
        {
            *load -= *unlogged;
            *unlogged = 0.0;
        }
        Some(logged)
    }

    fn valve_pulse(&mut self, start_s: f64, duration_s: f64, state: ValveState) {
        let (start, end) = (self.index_at(start_s), self.index_at(start_s + duration_s));
        for v in &mut self.valve[start..end] {
            *v = state;
        }
    }
}

/// Wheel load (what a scale under the wheel shows) for a sprung load, kg: the thesis' sprung
/// mass is the scale reading less the unsprung share (thesis 5.1.2).
pub fn wheel_load_kg(sprung_kg: f64, unsprung_kg: f64) -> f64 {
    sprung_kg + unsprung_kg
}

fn step_size(noise: &mut NoiseSource) -> f64 {
    noise.uniform(250.0, 350.0)
}

fn ramp(noise: &mut NoiseSource) -> f64 {
    noise.uniform(3.0, 8.0)
}

/// Data-set 1 (estimation): three tonnes set down one by one, then lifted off one by one;
/// 25 minutes, valve closed.
pub fn data_set_1(unsprung_kg: f64, seed: u64) -> Scenario {
    let mut noise = NoiseSource::new(seed ^ 0x0d5e_0001);
    let mut s = Scenario::constant(
        "ds1",
        "data-set 1 (estimation): load steps up, up, up, down, down, down; valve closed",
        1500.0,
        wheel_load_kg(REFERENCE_SPRUNG_KG, unsprung_kg),
    );
    s.set_down_and_lift_off(
        &[
            (120.0, 1),
            (320.0, 1),
            (520.0, 1),
            (720.0, -1),
            (920.0, -1),
            (1120.0, -1),
        ],
        &mut noise,
    );
    s
}

/// Data-set 2 (validation): the same tonnes in another order — up, down, up, up, down, down —
/// with a loading mishap near 950 s (a tonne set down, caught again and lifted off part-way,
/// then set down for good; the log shows one clean step). 25 minutes, valve closed.
pub fn data_set_2(unsprung_kg: f64, seed: u64) -> Scenario {
    let mut noise = NoiseSource::new(seed ^ 0x0d5e_0002);
    let mut s = Scenario::constant(
        "ds2",
        "data-set 2 (validation): load steps up, down, up, up (with a mishap), down, down; valve closed",
        1500.0,
        wheel_load_kg(REFERENCE_SPRUNG_KG, unsprung_kg),
    );
    let a = step_size(&mut noise);
    s.load_step(100.0, a, ramp(&mut noise));
    s.load_step(330.0, -a, ramp(&mut noise));
    let b = step_size(&mut noise);
    s.load_step(560.0, b, ramp(&mut noise));
    let c = step_size(&mut noise);
    // The mishap: the tonne lands, is partly lifted again for ~25 s, then settles.
    s.load_step(950.0, c, 4.0);
    s.unlogged_load_change(960.0, -0.6 * c, 3.0);
    s.unlogged_load_change(985.0, 0.6 * c, 5.0);
    s.load_step(1150.0, -c, ramp(&mut noise));
    s.load_step(1330.0, -b, ramp(&mut noise));
    s
}

/// Data-set 3: short fill and exhaust pulses (1–3 s) at the reference load, 10 minutes.
pub fn data_set_3(unsprung_kg: f64, seed: u64) -> Scenario {
    let mut noise = NoiseSource::new(seed ^ 0x0d5e_0003);
    let mut s = Scenario::constant(
        "ds3",
        "data-set 3 (validation): short fill/exhaust valve pulses at constant load 2830 kg sprung",
        600.0,
        wheel_load_kg(REFERENCE_SPRUNG_KG, unsprung_kg),
    );
    let mut t = 30.0;
    let mut fill = true;
    while t < 560.0 {
        let length = noise.uniform(1.0, 3.0);
        let state = if fill {
            ValveState::Fill
        } else {
            ValveState::Exhaust
        };
        s.valve_pulse(t, length, state);
        // Fill and exhaust alternate in pairs so the height wanders but stays in its stroke.
        fill = !fill;
        t += length + noise.uniform(15.0, 30.0);
    }
    s
}

/// Data-set 4: long fill and exhaust steps (8–15 s) at the reference load, 10 minutes.
pub fn data_set_4(unsprung_kg: f64, seed: u64) -> Scenario {
    let mut noise = NoiseSource::new(seed ^ 0x0d5e_0004);
    let mut s = Scenario::constant(
        "ds4",
        "data-set 4 (validation): long fill/exhaust valve steps at constant load 2830 kg sprung",
        600.0,
        wheel_load_kg(REFERENCE_SPRUNG_KG, unsprung_kg),
    );
    let plan = [
        (ValveState::Fill, 40.0),
        (ValveState::Exhaust, 130.0),
        (ValveState::Exhaust, 240.0),
        (ValveState::Fill, 340.0),
        (ValveState::Fill, 440.0),
        (ValveState::Exhaust, 520.0),
    ];
    for (state, start) in plan {
        s.valve_pulse(start, noise.uniform(8.0, 15.0), state);
    }
    s
}

/// A levelling run: load steps of 250–350 kg ([`Scenario::set_down_and_lift_off`]) with the
/// truck's level-control ECU at work. The valve column stays closed here:
/// [`crate::experiments::levelling_run`] fills in what the ECU commanded.
fn levelling(
    name: &str,
    description: &str,
    duration_s: f64,
    plan: &[(f64, i8)],
    unsprung_kg: f64,
    noise: &mut NoiseSource,
) -> Scenario {
    let mut s = Scenario::constant(
        name,
        description,
        duration_s,
        wheel_load_kg(REFERENCE_SPRUNG_KG, unsprung_kg),
    );
    s.set_down_and_lift_off(plan, noise);
    s
}

/// Levelling run 1 (estimation in our protocol): up, up, down, up, down, down, 70 s apart,
/// while the ECU's deadband controller holds the ride height; 8 minutes.
pub fn levelling_1(unsprung_kg: f64, seed: u64) -> Scenario {
    let mut noise = NoiseSource::new(seed ^ 0x1e7e_0001);
    levelling(
        "lev1",
        "levelling run 1 (estimation): load steps up, up, down, up, down, down; deadband level control",
        480.0,
        &[
            (30.0, 1),
            (100.0, 1),
            (170.0, -1),
            (240.0, 1),
            (310.0, -1),
            (380.0, -1),
        ],
        unsprung_kg,
        &mut noise,
    )
}

/// Levelling run 2 (validation): up, down, up, up, down, down at uneven gaps (a second step
/// may come before the level has settled); 8 minutes.
pub fn levelling_2(unsprung_kg: f64, seed: u64) -> Scenario {
    let mut noise = NoiseSource::new(seed ^ 0x1e7e_0002);
    levelling(
        "lev2",
        "levelling run 2 (validation): load steps up, down, up, up, down, down; deadband level control",
        480.0,
        &[
            (40.0, 1),
            (130.0, -1),
            (200.0, 1),
            (225.0, 1),
            (330.0, -1),
            (400.0, -1),
        ],
        unsprung_kg,
        &mut noise,
    )
}

/// Speed of road run 1, m/s (20 km/h: a test track's humps and potholes).
pub const ROAD_1_SPEED_M_S: f64 = 20.0 / 3.6;
/// Speed of road run 2, m/s (50 km/h).
pub const ROAD_2_SPEED_M_S: f64 = 50.0 / 3.6;

/// The distance driven at every sample: standing until `start_s`, at `speed_m_s` until
/// `end_s`, standing again after.
pub fn distance_m(time_s: &[f64], start_s: f64, end_s: f64, speed_m_s: f64) -> Vec<f64> {
    time_s
        .iter()
        .map(|&t| (t.clamp(start_s, end_s) - start_s) * speed_m_s)
        .collect()
}

/// Road run 1 (estimation in our protocol): at 20 km/h over four humps (half-sines of 40–70 mm
/// over 1.5–2.5 m: 0.3–0.45 s each, near the half period of the body's bounce) and three
/// potholes (30–50 mm deep over 1–1.5 m), standing for 5 s before and after; reference load,
/// valve closed; 70 s. The logger's 100 ms samples see the body's bounce and the humps; the
/// wheel hop (about 9 Hz) is above them.
pub fn road_1(unsprung_kg: f64, seed: u64) -> Scenario {
    let mut noise = NoiseSource::new(seed ^ 0x70ad_0001);
    let mut s = Scenario::constant(
        "road1",
        "road run 1 (estimation): speed humps and potholes at 20 km/h, valve closed",
        70.0,
        wheel_load_kg(REFERENCE_SPRUNG_KG, unsprung_kg),
    );
    let distance = distance_m(&s.time_s, 5.0, 65.0, ROAD_1_SPEED_M_S);
    // Hump, pothole, hump, ... every 40-48 m, so the body settles between them.
    let mut features = Vec::new();
    let mut at_m = 20.0;
    for k in 0..7 {
        let (length_m, height_m) = if k % 2 == 0 {
            (noise.uniform(1.5, 2.5), noise.uniform(0.040, 0.070))
        } else {
            (noise.uniform(1.0, 1.5), -noise.uniform(0.030, 0.050))
        };
        features.push((at_m, length_m, height_m));
        at_m += noise.uniform(40.0, 48.0);
    }
    s.road_height_m = distance
        .iter()
        .map(|&d| {
            features
                .iter()
                .map(|&(start, length, height)| half_sine_bump_m(d, start, length, height))
                .sum()
        })
        .collect();
    s
}

/// Road run 2 (validation): an ISO 8608 class C road at 50 km/h, standing for 5 s before and
/// after; reference load, valve closed; 90 s. The road carries waves the logger's 100 ms
/// samples resolve (0.011–0.29 cycles/m: 0.15–4 Hz at that speed) and starts level.
pub fn road_2(unsprung_kg: f64, seed: u64) -> Result<Scenario, TruckError> {
    let mut s = Scenario::constant(
        "road2",
        "road run 2 (validation): ISO 8608 class C at 50 km/h, valve closed",
        90.0,
        wheel_load_kg(REFERENCE_SPRUNG_KG, unsprung_kg),
    );
    let distance = distance_m(&s.time_s, 5.0, 85.0, ROAD_2_SPEED_M_S);
    let n_max = 0.4 / (SAMPLE_TIME_S * ROAD_2_SPEED_M_S);
    let road = Iso8608Road::new('C', 0.011, n_max, 200, seed ^ 0x70ad_0002)?;
    let heights = road.heights_m(&distance);
    let start = heights.first().copied().unwrap_or(0.0);
    s.road_height_m = heights.iter().map(|h| h - start).collect();
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn steps(load: &[f64]) -> Vec<(usize, f64)> {
        load.windows(2)
            .enumerate()
            .filter(|(_, w)| (w[1] - w[0]).abs() > 1.0)
            .map(|(i, w)| (i + 1, w[1] - w[0]))
            .collect()
    }

    #[test]
    fn data_set_1_has_three_steps_up_then_three_down_of_250_to_350_kg() {
        let s = data_set_1(520.0, 1);
        assert_eq!(s.len(), 15_001);
        assert!((s.time_s[15_000] - 1500.0).abs() < 1e-9);
        let logged = steps(&s.logged_load_kg);
        assert_eq!(logged.len(), 6);
        for (k, (_, delta)) in logged.iter().enumerate() {
            assert!((250.0..=350.0).contains(&delta.abs()), "step {k}: {delta}");
            assert_eq!(delta.signum(), if k < 3 { 1.0 } else { -1.0 });
        }
        assert!(
            (s.logged_load_kg[15_000] - 3350.0).abs() < 1e-9,
            "all tonnes lifted off again"
        );
        assert!(s.valve.iter().all(|&v| v == ValveState::Closed));
    }

    #[test]
    fn the_true_load_ramps_over_seconds_while_the_log_steps() {
        let s = data_set_1(520.0, 1);
        let (at, delta) = steps(&s.logged_load_kg)[0];
        // One second after the logged step the truth has not arrived yet (ramps take ≥ 3 s)…
        let lag = s.logged_load_kg[at + 10] - s.true_load_kg[at + 10];
        assert!(
            lag > 0.1 * delta,
            "true load already at {lag} kg from the log"
        );
        // …and ten seconds after, it has.
        assert!((s.logged_load_kg[at + 100] - s.true_load_kg[at + 100]).abs() < 1e-9);
    }

    #[test]
    fn data_set_2_differs_in_order_and_hides_a_mishap_from_the_log() {
        let s = data_set_2(520.0, 1);
        let signs: Vec<f64> = steps(&s.logged_load_kg)
            .iter()
            .map(|(_, d)| d.signum())
            .collect();
        assert_eq!(signs, vec![1.0, -1.0, 1.0, 1.0, -1.0, -1.0]);
        let i = s.index_at(970.0);
        assert!(
            s.logged_load_kg[i] - s.true_load_kg[i] > 100.0,
            "mishap invisible in the log"
        );
        // As the log tells it: the mishap gone, every logged change still ramped.
        let logged = s.as_logged().expect("data-set 2 has an unlogged change");
        assert!((logged.true_load_kg[i] - s.logged_load_kg[i]).abs() < 1e-9);
        let (at, _) = steps(&s.logged_load_kg)[0];
        assert_eq!(logged.true_load_kg[at + 10], s.true_load_kg[at + 10]);
        assert!(s.logged_load_kg[at + 10] - logged.true_load_kg[at + 10] > 10.0);
        for k in (0..s.len()).filter(|&k| s.time_s[k] < 955.0 || s.time_s[k] > 995.0) {
            assert_eq!(logged.true_load_kg[k], s.true_load_kg[k], "sample {k}");
        }
        assert!(data_set_1(520.0, 1).as_logged().is_none());
    }

    #[test]
    fn valve_data_sets_keep_the_load_constant_and_pulse_the_valve() {
        for s in [data_set_3(520.0, 3), data_set_4(520.0, 3)] {
            assert!(s.true_load_kg.iter().all(|&m| m == 3350.0));
            let fills =
                s.valve.iter().filter(|&&v| v == ValveState::Fill).count() as f64 * SAMPLE_TIME_S;
            let exhausts = s
                .valve
                .iter()
                .filter(|&&v| v == ValveState::Exhaust)
                .count() as f64
                * SAMPLE_TIME_S;
            assert!(
                fills > 5.0 && exhausts > 5.0,
                "{}: fill {fills} s, exhaust {exhausts} s",
                s.name
            );
        }
        let pulses = |s: &Scenario| {
            s.valve
                .windows(2)
                .filter(|w| w[0] == ValveState::Closed && w[1] != ValveState::Closed)
                .count()
        };
        let (short, long) = (data_set_3(520.0, 3), data_set_4(520.0, 3));
        assert!(pulses(&short) >= 12, "{} short pulses", pulses(&short));
        assert_eq!(pulses(&long), 6);
    }

    #[test]
    fn a_seed_fixes_the_experiment() {
        assert_eq!(data_set_1(520.0, 9), data_set_1(520.0, 9));
        assert_ne!(data_set_1(520.0, 9), data_set_1(520.0, 10));
    }
}
