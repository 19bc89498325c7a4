//! One truck's day as a plan: what really acts on the modeled wheel at every 100 ms sample,
//! whether the levelling controller is awake, how fast the truck drives and over which road,
//! the ambient temperature, and which loads the operator knows (a weighbridge, a loading list).
//!
//! A distribution truck's day (all times and sizes drawn from the truck's and day's seed):
//! 1. **parked overnight** (ignition off, the levelling controller asleep) until 05:00–07:00;
//! 2. **depot**: ignition on, 5 minutes on the weighbridge (tare known), then 3–5 pallets of
//!    150–300 kg on this wheel set down one by one with the controller levelling after each,
//!    and the last one taken off and set down again (a swap); the loading list makes each
//!    level known;
//! 3. **deliveries**: 3–5 stops, each a 20–45 min drive at 50–80 km/h over an ISO 8608 class
//!    A or B road, a few minutes standing, one pallet off (the last stop takes what is left);
//!    one stop also picks up a return pallet. Loads at the stops are *not* known;
//! 4. **back at the depot**: the return pallet comes off, 10 minutes on the weighbridge (tare
//!    known again);
//! 5. **parked** until midnight.
//!
//! The ambient temperature follows a daily cosine (coolest at 03:00) in hourly steps; the gas
//! in the bellow follows it through its wall heat exchange.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Uniform};

use crate::error::AppError;
use crate::road::Iso8608Road;
use airsus_truck::physics::smoothstep;

/// Sample time of a fleet log, s (the SPEC's 100 ms; 10 Hz).
pub const SAMPLE_TIME_S: f64 = 0.1;
/// Samples in a day at 10 Hz.
pub const SAMPLES_PER_DAY: usize = 864_000;
/// Samples in an hour at 10 Hz.
pub const SAMPLES_PER_HOUR: usize = 36_000;

/// What the levelling controller does at a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ControllerMode {
    /// Ignition off: the valve stays closed.
    Asleep,
    /// Standing with the ignition on: the ECU's standstill band (±5 mm, quick).
    Standing,
    /// Driving: a wide band and slow filtering, so that the road does not work the valve.
    Driving,
}

/// The plan of one truck-day (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct DayPlan {
    /// Seconds since midnight.
    pub time_s: Vec<f64>,
    /// The true wheel load (what a scale under the wheel shows), kg.
    pub true_load_kg: Vec<f64>,
    pub mode: Vec<ControllerMode>,
    pub speed_kmh: Vec<f64>,
    /// Road height under the wheel, m (zero when standing).
    pub road_height_m: Vec<f64>,
    /// The wheel load the operator knows at this sample, kg; NaN where unknown.
    pub reference_load_kg: Vec<f64>,
    /// Ambient temperature of each hour, K.
    pub hourly_ambient_k: [f64; 24],
}

/// The loads a truck carries: its empty wheel load and its pallets' share on this wheel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruckLoads {
    /// Wheel load of the empty truck, kg.
    pub tare_kg: f64,
}

struct Builder {
    plan: DayPlan,
    /// Next sample to plan.
    k: usize,
    load_kg: f64,
    rng: ChaCha8Rng,
}

impl Builder {
    fn uniform(&mut self, low: f64, high: f64) -> f64 {
        Uniform::new(low, high).map_or(low, |d| d.sample(&mut self.rng))
    }

    fn count(&mut self, low: usize, high_inclusive: usize) -> usize {
        Uniform::new_inclusive(low, high_inclusive).map_or(low, |d| d.sample(&mut self.rng))
    }

    fn samples(seconds: f64) -> usize {
        (seconds / SAMPLE_TIME_S).round() as usize
    }

    /// Holds the current load for `seconds` in `mode`; the road stays at zero.
    fn hold(&mut self, seconds: f64, mode: ControllerMode) -> std::ops::Range<usize> {
        let end = self
            .k
            .saturating_add(Self::samples(seconds))
            .min(SAMPLES_PER_DAY);
        for i in self.k..end {
            self.plan.mode[i] = mode;
            self.plan.true_load_kg[i] = self.load_kg;
        }
        let range = self.k..end;
        self.k = end;
        range
    }

    /// Changes the load by `delta_kg` over `ramp_s` (a forklift setting a pallet down), then
    /// stands for `stand_s`.
    fn load_change(&mut self, delta_kg: f64, ramp_s: f64, stand_s: f64) -> std::ops::Range<usize> {
        let start = self.k;
        let from = self.load_kg;
        self.load_kg += delta_kg;
        let range = self.hold(stand_s, ControllerMode::Standing);
        for i in range.clone() {
            let progress = (i - start) as f64 * SAMPLE_TIME_S / ramp_s;
            self.plan.true_load_kg[i] = from + delta_kg * smoothstep(progress);
        }
        range
    }

    /// The load is known over the last `seconds` of `range` (it is steady there).
    fn known(&mut self, range: std::ops::Range<usize>, seconds: f64) {
        let from = range
            .end
            .saturating_sub(Self::samples(seconds))
            .max(range.start);
        for i in from..range.end {
            self.plan.reference_load_kg[i] = self.plan.true_load_kg[i];
        }
    }

    /// Drives for `seconds` at `speed_kmh` (30 s to speed up and to stop) over `road`.
    fn drive(&mut self, seconds: f64, speed_kmh: f64, road: &Iso8608Road) {
        let range = self.hold(seconds, ControllerMode::Driving);
        let n = range.len() as f64;
        let ramp = 30.0 / SAMPLE_TIME_S;
        let mut distance_m = Vec::with_capacity(range.len());
        let mut s = 0.0;
        for (j, i) in range.clone().enumerate() {
            let j = j as f64;
            let speed = speed_kmh * smoothstep(j / ramp).min(smoothstep((n - 1.0 - j) / ramp));
            self.plan.speed_kmh[i] = speed;
            distance_m.push(s);
            s += speed / 3.6 * SAMPLE_TIME_S;
        }
        // The road starts and ends level where the truck stands.
        let heights = road.heights_m(&distance_m);
        let (z0, z1) = (
            heights.first().copied().unwrap_or(0.0),
            heights.last().copied().unwrap_or(0.0),
        );
        for (j, i) in range.enumerate() {
            let w = if n > 1.0 { j as f64 / (n - 1.0) } else { 0.0 };
            self.plan.road_height_m[i] = heights[j] - (z0 + (z1 - z0) * w);
        }
    }
}

/// Plans day `day` of a truck (module docs). `seed` fixes the truck's days; the same seed and
/// day give the same plan.
pub fn plan_day(loads: TruckLoads, seed: u64, day: u32) -> Result<DayPlan, AppError> {
    let n = SAMPLES_PER_DAY;
    let rng = ChaCha8Rng::seed_from_u64(seed ^ (u64::from(day) << 32) ^ 0xF1EE_7DA7);
    let mut b = Builder {
        plan: DayPlan {
            time_s: (0..n).map(|i| i as f64 * SAMPLE_TIME_S).collect(),
            true_load_kg: vec![loads.tare_kg; n],
            mode: vec![ControllerMode::Asleep; n],
            speed_kmh: vec![0.0; n],
            road_height_m: vec![0.0; n],
            reference_load_kg: vec![f64::NAN; n],
            hourly_ambient_k: [293.15; 24],
        },
        k: 0,
        load_kg: loads.tare_kg,
        rng,
    };
    let mean_k = b.uniform(276.0, 296.0);
    let swing_k = b.uniform(3.0, 7.0);
    for (h, t) in b.plan.hourly_ambient_k.iter_mut().enumerate() {
        let phase = 2.0 * std::f64::consts::PI * (h as f64 + 0.5 - 15.0) / 24.0;
        *t = mean_k + swing_k * phase.cos();
    }
    let road_class = if b.uniform(0.0, 1.0) < 0.5 { 'A' } else { 'B' };
    let road_seed = seed ^ (u64::from(day) << 16) ^ 0x0AD5;
    // Wavelengths of 5 m and longer: what a 10 Hz log resolves at these speeds.
    let road = Iso8608Road::new(road_class, 0.011, 0.2, 120, road_seed)?;

    let start_s = b.uniform(5.0, 7.0) * 3600.0;
    b.hold(start_s, ControllerMode::Asleep);
    let tare = b.hold(300.0, ControllerMode::Standing);
    b.known(tare, 180.0);
    let pallets: Vec<f64> = (0..b.count(3, 5))
        .map(|_| b.uniform(150.0, 300.0))
        .collect();
    for &pallet in &pallets {
        let (ramp, stand) = (b.uniform(3.0, 8.0), b.uniform(180.0, 300.0));
        let level = b.load_change(pallet, ramp, stand);
        b.known(level, 90.0);
    }
    // A pallet swapped for another (a wrong one was loaded): the level after it came off is
    // known too, weighed after the bellow sank back (the other side of the hysteresis).
    let (swap_ramp, swap_stand) = (b.uniform(3.0, 8.0), b.uniform(180.0, 300.0));
    let wrong = pallets.last().copied().unwrap_or(0.0);
    let off = b.load_change(-wrong, swap_ramp, swap_stand);
    b.known(off, 90.0);
    let (ramp, stand) = (b.uniform(3.0, 8.0), b.uniform(180.0, 300.0));
    let level = b.load_change(wrong, ramp, stand);
    b.known(level, 90.0);
    let stops = b.count(3, 5).min(pallets.len());
    let pickup_stop = b.count(0, stops - 1);
    let mut on_board = pallets.clone();
    let mut return_pallet = 0.0;
    for stop in 0..stops {
        let (drive_s, speed) = (b.uniform(20.0, 45.0) * 60.0, b.uniform(50.0, 80.0));
        b.drive(drive_s, speed, &road);
        let arrive = b.uniform(120.0, 240.0);
        b.hold(arrive, ControllerMode::Standing);
        let off: f64 = if stop + 1 == stops {
            on_board.drain(..).sum()
        } else {
            on_board.pop().unwrap_or(0.0)
        };
        let (ramp, stand) = (b.uniform(3.0, 8.0), b.uniform(240.0, 420.0));
        b.load_change(-off, ramp, stand);
        if stop == pickup_stop {
            return_pallet = b.uniform(100.0, 250.0);
            let (ramp, stand) = (b.uniform(3.0, 8.0), b.uniform(180.0, 300.0));
            b.load_change(return_pallet, ramp, stand);
        }
    }
    let (drive_s, speed) = (b.uniform(20.0, 45.0) * 60.0, b.uniform(50.0, 80.0));
    b.drive(drive_s, speed, &road);
    b.hold(120.0, ControllerMode::Standing);
    let (ramp, stand) = (b.uniform(3.0, 8.0), 600.0);
    let tare = b.load_change(-return_pallet, ramp, stand);
    b.known(tare, 300.0);
    b.hold(f64::INFINITY, ControllerMode::Asleep);
    if b.k < n {
        return Err(crate::error::invalid(
            "day plan",
            "it does not fill the day",
        ));
    }
    Ok(b.plan)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_day_starts_and_ends_empty_and_asleep_with_known_tares() {
        let tare = 3000.0;
        let plan = plan_day(TruckLoads { tare_kg: tare }, 7, 0).unwrap();
        assert_eq!(plan.time_s.len(), SAMPLES_PER_DAY);
        assert_eq!(plan.mode[0], ControllerMode::Asleep);
        assert_eq!(plan.mode[SAMPLES_PER_DAY - 1], ControllerMode::Asleep);
        assert!((plan.true_load_kg[SAMPLES_PER_DAY - 1] - tare).abs() < 1e-9);
        let max = plan.true_load_kg.iter().copied().fold(0.0, f64::max);
        assert!(
            max >= tare + 450.0 && max <= tare + 1500.0,
            "max load {max}"
        );
        // Known loads equal the truth, and both the tare and loaded levels are among them.
        let known: Vec<(usize, f64)> = plan
            .reference_load_kg
            .iter()
            .copied()
            .enumerate()
            .filter(|(_, r)| r.is_finite())
            .collect();
        assert!(known.iter().all(|&(i, r)| r == plan.true_load_kg[i]));
        assert!(known.iter().any(|&(_, r)| (r - tare).abs() < 1e-9));
        assert!(known.iter().any(|&(_, r)| r > tare + 400.0));
        // Driving happens only awake, and the road is level where the truck stands.
        for i in 0..SAMPLES_PER_DAY {
            if plan.speed_kmh[i] > 0.0 {
                assert_eq!(plan.mode[i], ControllerMode::Driving);
            }
            if plan.mode[i] != ControllerMode::Driving {
                assert_eq!(plan.road_height_m[i], 0.0);
            }
        }
        let driving = plan
            .mode
            .iter()
            .filter(|m| **m == ControllerMode::Driving)
            .count() as f64
            * SAMPLE_TIME_S
            / 3600.0;
        assert!((1.3..=4.5).contains(&driving), "{driving} h driving");
        // Coolest at night, warmest in the afternoon.
        assert!(plan.hourly_ambient_k[3] < plan.hourly_ambient_k[15]);
        // The same seed and day give the same plan (NaN, the unknown loads, compared by bits).
        let bits = |p: &DayPlan| -> Vec<u64> {
            p.true_load_kg
                .iter()
                .chain(&p.reference_load_kg)
                .chain(&p.road_height_m)
                .map(|v| v.to_bits())
                .collect()
        };
        let again = plan_day(TruckLoads { tare_kg: tare }, 7, 0).unwrap();
        assert!(bits(&plan) == bits(&again) && plan.mode == again.mode);
        let other_day = plan_day(TruckLoads { tare_kg: tare }, 7, 1).unwrap();
        assert!(bits(&plan) != bits(&other_day));
    }
}
