//! Weighing at standstills found in a truck's own log, with no load signal and no truth: what
//! an on-board scale reads, and what the fleet jobs compute per truck (issue #17).
//!
//! # Standstills
//! A sample is at **standstill** when the truck does not move (speed at most
//! `max_speed_kmh`, where a speed is logged), the valve has been closed for `settle_s`, and the
//! bellow pressure stays within `max_pressure_range_pa` over the `steady_window_s` before it
//! and the `look_ahead_s` after it (a load change moves it by tens of kPa; the road while
//! rolling by several; the log is read whole, so a load ramp is seen before it starts to
//! move the pressure). `settle_s`
//! lets the creep of the bellow wall (time constants 12–45 s on the virtual truck family) and
//! the gas temperature settle after the last valve action. A **standstill** is a maximal run
//! of such samples at least `min_duration_s` long; it is weighed once, from its mean height and
//! mean pressure through the static law ([`super::StaticWeigher`]), the gas's force alone
//! (the law's wall, [`super::WallForces`], is not used: by then the creep has relaxed, and
//! the wall friction's state is the calibration's `z`, below).
//!
//! # The wall friction state
//! The bellow wall's friction holds the same load at a different pressure after the bellow
//! last moved up (a fill) than after it last moved down (an exhaust, or unloading): the
//! hysteresis of thesis 6.1. Its state is estimated from the height alone by a normalised Dahl
//! model driven by the height's movement:
//! ```text
//! dz/dy = (1 − z sign(dy)) / δ,   z ∈ [−1, 1]
//! ```
//! with `y` the height after a 1 s moving average and a play (backlash) of `play_m` that keeps
//! the sensor's noise from dithering `z` towards zero, and `δ` the pre-sliding travel at the
//! sensor (virtual truck: F_c / σ = 6 mm at the bellow, about 4 mm at the sensor). `z = +1`
//! after the bellow rose, `−1` after it sank. The calibration (Python `airsus.fleet`) regresses
//! the known loads on the static estimate and `z`.

use airsus_data::ValveState;

use super::StaticWeigher;
use crate::error::{AppError, invalid};

/// When a sample counts as standstill (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct StandstillDetector {
    pub settle_s: f64,
    pub steady_window_s: f64,
    /// How far after a sample the pressure must stay steady too, s.
    pub look_ahead_s: f64,
    pub max_pressure_range_pa: f64,
    pub max_speed_kmh: f64,
    pub min_duration_s: f64,
    /// Pre-sliding travel of the wall friction at the sensor, m.
    pub presliding_m: f64,
    /// Play of the height before it drives the friction state, m.
    pub play_m: f64,
    /// A load arriving ([`super::WeighQuality::Loading`]): the mean bellow pressure over the
    /// `loading_window_s` after a sample differs from the mean over the window before it by
    /// more than `loading_shift_pa`, with the valve closed and the road still (the window
    /// after ends where the valve opens, half a window at least); the flag holds for
    /// `loading_hold_s` after the last such sample, and a valve opened within that hold (a
    /// levelling controller answering the load) carries it on to the valve's closing. A
    /// 300 kg step moves the pressure by about 30 kPa within seconds; the gas cooling after
    /// a fill by 1-2 kPa over 4 s.
    pub loading_shift_pa: f64,
    pub loading_window_s: f64,
    pub loading_hold_s: f64,
}

impl Default for StandstillDetector {
    fn default() -> Self {
        Self {
            settle_s: 120.0,
            steady_window_s: 60.0,
            look_ahead_s: 15.0,
            max_pressure_range_pa: 4000.0,
            max_speed_kmh: 0.5,
            min_duration_s: 20.0,
            presliding_m: 4e-3,
            play_m: 0.25e-3,
            loading_shift_pa: 3000.0,
            loading_window_s: 2.0,
            loading_hold_s: 10.0,
        }
    }
}

impl StandstillDetector {
    /// The default detector with the `loading` flag's thresholds replaced: the pressure shift
    /// between the windows, Pa, the windows' length, s, and how long the flag holds after the
    /// last shift, s. The defaults are tuned on the virtual truck (a 300 kg step moves the
    /// pressure by about 30 kPa, the gas cooling after a fill 1-2 kPa); a truck whose loads
    /// arrive in smaller steps, or a noisier pressure sensor, wants others. Each must be a
    /// positive number.
    pub fn with_loading(self, shift_pa: f64, window_s: f64, hold_s: f64) -> Result<Self, AppError> {
        for (name, value, unit) in [
            ("loading pressure shift", shift_pa, "Pa"),
            ("loading window", window_s, "s"),
            ("loading hold", hold_s, "s"),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(invalid(
                    "standstill detector",
                    format!("the {name} must be a positive number of {unit}, got {value}"),
                ));
            }
        }
        Ok(Self {
            loading_shift_pa: shift_pa,
            loading_window_s: window_s,
            loading_hold_s: hold_s,
            ..self
        })
    }
}

/// One weighed standstill.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Standstill {
    /// First and last sample index, inclusive.
    pub first: usize,
    pub last: usize,
    pub start_s: f64,
    pub end_s: f64,
    /// Mean sensor height, m, and mean bellow gauge pressure, Pa.
    pub height_m: f64,
    pub gauge_pa: f64,
    /// The static load of the mean reading, kg.
    pub static_load_kg: f64,
    /// Its standard deviation from the sensors (of the mean) and from the parameters, kg.
    pub measurement_std_kg: f64,
    pub parameter_std_kg: f64,
    /// Mean wall friction state over the standstill, −1 (last moved down) to +1 (up).
    pub friction_state: f64,
}

/// The range (max − min) of `values` over the `window` samples before each sample and the
/// sample itself; infinite where a non-finite value lies in that span. Monotone deques: O(n).
fn trailing_range(values: &[f64], window: usize) -> Vec<f64> {
    use std::collections::VecDeque;
    let (mut maxq, mut minq) = (VecDeque::<usize>::new(), VecDeque::<usize>::new());
    let mut last_bad: Option<usize> = None;
    let mut out = Vec::with_capacity(values.len());
    for (k, &v) in values.iter().enumerate() {
        if !v.is_finite() {
            last_bad = Some(k);
            maxq.clear();
            minq.clear();
            out.push(f64::INFINITY);
            continue;
        }
        while maxq.back().is_some_and(|&i| values[i] <= v) {
            maxq.pop_back();
        }
        maxq.push_back(k);
        while minq.back().is_some_and(|&i| values[i] >= v) {
            minq.pop_back();
        }
        minq.push_back(k);
        while maxq.front().is_some_and(|&i| i + window < k) {
            maxq.pop_front();
        }
        while minq.front().is_some_and(|&i| i + window < k) {
            minq.pop_front();
        }
        let clean = last_bad.is_none_or(|b| b + window < k);
        out.push(match (maxq.front(), minq.front()) {
            (Some(&hi), Some(&lo)) if clean => values[hi] - values[lo],
            _ => f64::INFINITY,
        });
    }
    out
}

/// The normalised wall-friction state at every sample (module docs), starting at 0.
pub fn friction_state(height_m: &[f64], sample_s: f64, presliding_m: f64, play_m: f64) -> Vec<f64> {
    friction_state_from(height_m, sample_s, presliding_m, play_m, 0.0)
}

/// [`friction_state`] starting at `z0` in `[-1, 1]` (−1: the friction holds the bellow up,
/// after it was lowered; +1: after it was raised).
pub fn friction_state_from(
    height_m: &[f64],
    sample_s: f64,
    presliding_m: f64,
    play_m: f64,
    z0: f64,
) -> Vec<f64> {
    let window = ((1.0 / sample_s).round() as usize).max(1);
    let mut z = z0.clamp(-1.0, 1.0);
    let mut out = Vec::with_capacity(height_m.len());
    // The moving mean over the finite readings of the last `window` samples: a missing
    // reading (NaN) holds the state and stays out of the mean.
    let (mut sum, mut finite) = (0.0, 0usize);
    let mut y: Option<f64> = None;
    for (k, &h) in height_m.iter().enumerate() {
        if h.is_finite() {
            sum += h;
            finite += 1;
        }
        if k >= window && height_m[k - window].is_finite() {
            sum -= height_m[k - window];
            finite -= 1;
        }
        if !h.is_finite() || finite == 0 {
            out.push(z);
            continue;
        }
        let mean = sum / finite as f64;
        let previous = *y.get_or_insert(mean);
        // Play (backlash): the output moves only when the input leaves ±play around it.
        let played = previous.clamp(mean - play_m, mean + play_m);
        let dy = played - previous;
        // The Dahl law integrated exactly over a monotone step.
        if dy > 0.0 {
            z = 1.0 - (1.0 - z) * (-dy / presliding_m).exp();
        } else if dy < 0.0 {
            z = -1.0 + (1.0 + z) * (dy / presliding_m).exp();
        }
        y = Some(played);
        out.push(z);
    }
    out
}

/// The signals of a log that standstills are found in. `speed_kmh` and `segment` may be
/// empty (not logged); a change of `segment`'s value between two samples ends a standstill
/// (e.g. where a known reference load starts, so it is weighed on its own).
#[derive(Debug, Clone, Copy)]
pub struct StandstillSignals<'a> {
    pub time_s: &'a [f64],
    pub height_m: &'a [f64],
    pub gauge_pa: &'a [f64],
    pub valve: &'a [ValveState],
    pub speed_kmh: &'a [f64],
    pub segment: &'a [f64],
}

/// Which samples of a log are standstill samples (module docs): the valve closed for
/// `settle_s`, the pressure steady over the window before and the look-ahead after, not
/// rolling. Non-finite readings are never standstill. Also the friction state `z`.
pub fn standstill_mask(
    signals: &StandstillSignals,
    detector: &StandstillDetector,
) -> Result<(Vec<bool>, Vec<f64>), AppError> {
    let StandstillSignals {
        time_s,
        height_m,
        gauge_pa,
        valve,
        speed_kmh,
        segment,
    } = *signals;
    let n = time_s.len();
    if height_m.len() != n || gauge_pa.len() != n || valve.len() != n {
        return Err(invalid(
            "standstill signals",
            "time, height, pressure and valve differ in length",
        ));
    }
    if !speed_kmh.is_empty() && speed_kmh.len() != n {
        return Err(invalid("speed", "it differs in length from the time"));
    }
    if !segment.is_empty() && segment.len() != n {
        return Err(invalid("segment", "it differs in length from the time"));
    }
    if n < 2 {
        return Ok((vec![false; n], vec![0.0; n]));
    }
    if time_s
        .windows(2)
        .any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
    {
        return Err(invalid("time", "it is not strictly increasing"));
    }
    let sample_s = (time_s[n - 1] - time_s[0]) / (n - 1) as f64;
    let z = friction_state(height_m, sample_s, detector.presliding_m, detector.play_m);
    // The pressure must be steady over the window before a sample and the look-ahead after
    // it: the log is read whole, so the start of a load ramp is seen before it moves the
    // pressure past the tolerance (a causal test would let its first ~40 kg in).
    let window = (detector.steady_window_s / sample_s).round() as usize;
    let ahead = (detector.look_ahead_s / sample_s).round() as usize;
    let before = trailing_range(gauge_pa, window);
    let reversed: Vec<f64> = gauge_pa.iter().rev().copied().collect();
    let mut after = trailing_range(&reversed, ahead);
    after.reverse();
    let mut closed_since: Option<f64> = None;
    let mut still = vec![false; n];
    for k in 0..n {
        let moving = speed_kmh
            .get(k)
            .is_some_and(|v| v.is_nan() || v.abs() > detector.max_speed_kmh);
        if valve[k] != ValveState::Closed || !height_m[k].is_finite() || moving {
            closed_since = None;
            continue;
        }
        let since = *closed_since.get_or_insert(time_s[k]);
        still[k] = time_s[k] - since >= detector.settle_s
            && before[k] <= detector.max_pressure_range_pa
            && after[k] <= detector.max_pressure_range_pa;
    }

    Ok((still, z))
}

/// Finds and weighs the standstills of a log (module docs). Non-finite readings break a
/// standstill.
pub fn weigh_standstills(
    signals: &StandstillSignals,
    weigher: &StaticWeigher,
    detector: &StandstillDetector,
) -> Result<Vec<Standstill>, AppError> {
    let (still, z) = standstill_mask(signals, detector)?;
    let StandstillSignals {
        time_s,
        height_m,
        gauge_pa,
        segment,
        ..
    } = *signals;
    let n = time_s.len();
    if n < 2 {
        return Ok(Vec::new());
    }
    let sample_s = (time_s[n - 1] - time_s[0]) / (n - 1) as f64;

    let mut standstills = Vec::new();
    let mut k = 0;
    while k < n {
        if !still[k] {
            k += 1;
            continue;
        }
        let first = k;
        let same_segment = |k: usize| segment.is_empty() || segment[k + 1] == segment[k];
        while k + 1 < n && still[k + 1] && same_segment(k) {
            k += 1;
        }
        let last = k;
        k += 1;
        if time_s[last] - time_s[first] + sample_s < detector.min_duration_s {
            continue;
        }
        let count = (last - first + 1) as f64;
        let mean = |v: &[f64]| v[first..=last].iter().sum::<f64>() / count;
        let (h, p) = (mean(height_m), mean(gauge_pa));
        let estimate = weigher.estimate(h, p)?;
        standstills.push(Standstill {
            first,
            last,
            start_s: time_s[first],
            end_s: time_s[last],
            height_m: h,
            gauge_pa: p,
            static_load_kg: estimate.wheel_load_kg,
            // White sensor noise averages down over the standstill's samples.
            measurement_std_kg: estimate.measurement_std_kg / count.sqrt(),
            parameter_std_kg: estimate.parameter_std_kg,
            friction_state: mean(&z),
        });
    }
    Ok(standstills)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::weigh::{StaticLaw, WeighingUncertainty};
    use airsus_data::TruckParameters;

    #[test]
    fn friction_state_follows_the_last_movement_and_ignores_noise() {
        // Rise 10 mm, rest 200 s under the height sensor's noise (0.15 mm, quantised to
        // 0.1 mm), sink 10 mm, rest.
        let mut h = Vec::new();
        for k in 0..100 {
            h.push(0.235 + 1e-4 * f64::from(k));
        }
        let mut noise = airsus_truck::sensors::NoiseSource::new(3);
        h.extend(noise.measure(&[0.245; 2000], airsus_truck::sensors::SensorSpec::HEIGHT_M));
        let after_rise = h.len() - 1;
        for k in 0..100 {
            h.push(0.245 - 1e-4 * f64::from(k));
        }
        h.extend(std::iter::repeat_n(0.235, 500));
        let z = friction_state(&h, 0.1, 4e-3, 0.25e-3);
        assert!(z[after_rise] > 0.85, "after the rise z = {}", z[after_rise]);
        // From about +0.9, 10 mm down less the play with δ = 4 mm: −1 + 1.9 e^(−2.4) ≈ −0.83.
        assert!(
            *z.last().unwrap() < -0.75,
            "after the fall z = {}",
            z.last().unwrap()
        );
        assert!(z.iter().all(|v| (-1.0..=1.0).contains(v)));
        // A missing reading holds the state; it never panics or poisons what follows.
        let mut gappy = h.clone();
        gappy[after_rise - 5] = f64::NAN;
        gappy[10] = f64::INFINITY;
        let held = friction_state(&gappy, 0.1, 4e-3, 0.25e-3);
        assert!(held.iter().all(|v| v.is_finite()));
        assert!(held[after_rise] > 0.85 && *held.last().unwrap() < -0.75);
        // Without the play, the dither drags the state towards zero.
        let dithered = friction_state(&h, 0.1, 4e-3, 0.0);
        assert!(dithered[after_rise] < z[after_rise] - 0.1);
    }

    #[test]
    fn standstills_skip_load_changes_open_valves_and_driving() {
        let truck = TruckParameters::reference();
        let weigher = StaticWeigher::new(
            StaticLaw::from_truck(&truck),
            WeighingUncertainty::default(),
        );
        let n = 6000;
        let time: Vec<f64> = (0..n).map(|k| k as f64 * 0.1).collect();
        let height = vec![0.235; n];
        // 350 kPa, a step to 380 kPa at 200 s; the valve open 300–305 s; driving 450–500 s.
        let pressure: Vec<f64> = time
            .iter()
            .map(|&t| if t < 200.0 { 350e3 } else { 380e3 })
            .collect();
        let valve: Vec<ValveState> = time
            .iter()
            .map(|&t| {
                if (300.0..305.0).contains(&t) {
                    ValveState::Fill
                } else {
                    ValveState::Closed
                }
            })
            .collect();
        let speed: Vec<f64> = time
            .iter()
            .map(|&t| {
                if (450.0..500.0).contains(&t) {
                    40.0
                } else {
                    0.0
                }
            })
            .collect();
        let signals = StandstillSignals {
            time_s: &time,
            height_m: &height,
            gauge_pa: &pressure,
            valve: &valve,
            speed_kmh: &speed,
            segment: &[],
        };
        let detector = StandstillDetector::default();
        let found = weigh_standstills(&signals, &weigher, &detector).unwrap();
        let spans: Vec<(f64, f64)> = found.iter().map(|s| (s.start_s, s.end_s)).collect();
        // 120–184.9 (settled, steady, 15 s before the step); 260–299.9 (60 s window after the
        // step); 425–449.9 (settled after the valve); 500+120 = 620 onwards is past the end.
        assert_eq!(spans.len(), 3, "{spans:?}");
        assert!((spans[0].0 - 120.0).abs() < 1e-9 && (spans[0].1 - 184.9).abs() < 1e-9);
        assert!((spans[1].0 - 260.1).abs() < 0.15, "{spans:?}");
        assert!((spans[2].0 - 425.0).abs() < 1e-9 && (spans[2].1 - 449.9).abs() < 1e-9);
        let heavier = found[1].static_load_kg - found[0].static_load_kg;
        assert!(heavier > 100.0, "30 kPa more carries {heavier} kg more");
        assert!(found[0].measurement_std_kg < 1.0);
        // A segment change splits the first standstill in two.
        let segment: Vec<f64> = time
            .iter()
            .map(|&t| f64::from(u8::from(t >= 150.0)))
            .collect();
        let split = weigh_standstills(
            &StandstillSignals {
                segment: &segment,
                ..signals
            },
            &weigher,
            &detector,
        )
        .unwrap();
        assert_eq!(split.len(), 4);
        assert!((split[0].end_s - 149.9).abs() < 1e-9 && (split[1].start_s - 150.0).abs() < 1e-9);
        let short = StandstillSignals {
            time_s: &time[..10],
            ..signals
        };
        assert!(weigh_standstills(&short, &weigher, &detector).is_err());
    }
}
