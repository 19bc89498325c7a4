//! The virtual truck's level-control ECU: the valve guard every level controller shares, the
//! height filter, and the deadband controller a truck's ECU runs; with [`crate::closed_loop`]
//! it makes the levelling runs of the reference experiments. The model-based controller, the
//! control scenarios and their scores live in `airsus-apps` (`control`).
//!
//! The valve must not be pulsed at high frequency (thesis 2.2.1: it is not built for it), so
//! every controller shares one [`ValveGuard`] that enforces
//! - a **minimum on-time**: once opened, the valve stays open at least `min_on_s`;
//! - a **minimum rest**: after closing, it stays closed at least `min_rest_s` (the body and the
//!   gas settle before the next decision);
//! - a **reversal lock-out** (anti-hunting): fill may not follow exhaust, nor exhaust fill,
//!   within `reversal_lockout_s` of the end of the last opening;
//!
//! and one measurement path: the height reading (quantised, noisy, every 100 ms) is low-pass
//! filtered (`τ_f`, [`HeightFilter`]), and the controller acts only when the filtered error has
//! been outside the tolerance band for `debounce_s` (a bump or a noise spike does not open the
//! valve). While the truck drives ([`Reading::speed_m_s`] above [`DRIVING_SPEED_M_S`]) the
//! decision to open reads a slower filter and debounce (`driving_filter_time_constant_s`,
//! `driving_debounce_s`): on a road the wheel and the body move by more than the band every few
//! seconds, and what the controller holds is the ride height between the bumps.
//!
//! [`DeadbandController`]: bang-bang with hysteresis — open when the error leaves the band
//! `±tolerance`, close when the height predicted `lead_s` ahead (filtered height plus its rate
//! times `lead_s`, which compensates the filter lag and the body still moving) comes within
//! `stop_margin` of the target.

use airsus_data::ValveState;

/// What the controller sees every sample (quantised, noisy sensor readings).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    pub sensor_height_m: f64,
    pub bellow_gauge_pa: f64,
    /// Supply-tank gauge pressure as its sensor reads it, Pa.
    pub supply_gauge_pa: f64,
    /// Vehicle speed from the bus, m/s (0 standing): above [`DRIVING_SPEED_M_S`] the
    /// controllers use their driving filter and debounce.
    pub speed_m_s: f64,
}

/// Speed above which the truck counts as driving, m/s.
pub const DRIVING_SPEED_M_S: f64 = 1.0;

/// A level controller, called once per sample.
pub trait LevelController: Send {
    fn name(&self) -> &'static str;

    /// The valve command for the next sample interval, from the reading at `t_s` and the
    /// target sensor height.
    fn update(&mut self, t_s: f64, target_m: f64, reading: &Reading) -> ValveState;
}

/// Timing limits shared by the controllers (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct GuardSettings {
    pub min_on_s: f64,
    pub min_rest_s: f64,
    pub reversal_lockout_s: f64,
    /// Tolerance band half-width around the target, m.
    pub tolerance_m: f64,
    /// Time the filtered error must stay outside the band before the valve opens, s.
    pub debounce_s: f64,
    /// Time constant of the height filter, s.
    pub filter_time_constant_s: f64,
    /// The same two while driving, s: on a road the wheel and the body move by more than the
    /// band every few seconds, and what the controller is to hold is the height between the
    /// bumps (level controllers of trucks switch to slow filtering at speed).
    pub driving_filter_time_constant_s: f64,
    pub driving_debounce_s: f64,
}

impl GuardSettings {
    /// Filter time constant and debounce for a reading taken at `speed_m_s`.
    pub fn filter_and_debounce_s(&self, speed_m_s: f64) -> (f64, f64) {
        if speed_m_s > DRIVING_SPEED_M_S {
            (self.driving_filter_time_constant_s, self.driving_debounce_s)
        } else {
            (self.filter_time_constant_s, self.debounce_s)
        }
    }
}

impl Default for GuardSettings {
    /// Typical of truck ECUs: ±5 mm band, 0.3 s minimum opening, 2 s rest, 10 s reversal
    /// lock-out, 1 s debounce, 0.5 s filter; while driving a 10 s filter and 5 s debounce.
    fn default() -> Self {
        Self {
            min_on_s: 0.3,
            min_rest_s: 2.0,
            reversal_lockout_s: 10.0,
            tolerance_m: 5e-3,
            debounce_s: 1.0,
            filter_time_constant_s: 0.5,
            driving_filter_time_constant_s: 10.0,
            driving_debounce_s: 5.0,
        }
    }
}

/// Enforces minimum on-time, minimum rest and the reversal lock-out on requested commands.
#[derive(Debug, Clone, PartialEq)]
pub struct ValveGuard {
    settings: GuardSettings,
    state: ValveState,
    since_s: f64,
    /// Direction and end time of the last opening.
    last_open: Option<(ValveState, f64)>,
}

impl ValveGuard {
    pub fn new(settings: GuardSettings) -> Self {
        Self {
            settings,
            state: ValveState::Closed,
            since_s: f64::NEG_INFINITY,
            last_open: None,
        }
    }

    pub fn state(&self) -> ValveState {
        self.state
    }

    /// Time the valve has been in its current state at `t_s`, s.
    pub fn age_s(&self, t_s: f64) -> f64 {
        t_s - self.since_s
    }

    /// Whether an opening in `direction` would be allowed at `t_s`.
    pub fn may_open(&self, t_s: f64, direction: ValveState) -> bool {
        if self.state != ValveState::Closed {
            return self.state == direction;
        }
        match self.last_open {
            None => true,
            Some((last, end)) => {
                let gap = t_s - end;
                gap >= self.settings.min_rest_s
                    && (last == direction || gap >= self.settings.reversal_lockout_s)
            }
        }
    }

    /// The command actually applied when `requested` is asked for at `t_s`.
    pub fn apply(&mut self, t_s: f64, requested: ValveState) -> ValveState {
        // Small tolerance: sample times are multiples of 0.1 s in floating point.
        let eps = 1e-9;
        let next = match (self.state, requested) {
            (current, req) if current == req => current,
            (ValveState::Closed, req) => {
                if self.may_open(t_s + eps, req) {
                    req
                } else {
                    ValveState::Closed
                }
            }
            (current, _) if self.age_s(t_s) + eps < self.settings.min_on_s => current,
            // Open and asked to change: close (never switch fill <-> exhaust directly).
            (_, _) => ValveState::Closed,
        };
        if next != self.state {
            if self.state != ValveState::Closed {
                self.last_open = Some((self.state, t_s));
            }
            self.state = next;
            self.since_s = t_s;
        }
        next
    }
}

/// The filtered height and its rate, and the debounce timer.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightFilter {
    tau_s: f64,
    value_m: Option<f64>,
    /// The filtered rate, m/s.
    pub rate_m_s: f64,
    last_t_s: f64,
    outside_since_s: Option<f64>,
}

impl HeightFilter {
    pub fn new(tau_s: f64) -> Self {
        Self {
            tau_s: tau_s.max(0.0),
            value_m: None,
            rate_m_s: 0.0,
            last_t_s: 0.0,
            outside_since_s: None,
        }
    }

    /// First-order low-pass of the height with the time constant for `speed_m_s`.
    pub fn update_at(
        &mut self,
        t_s: f64,
        h_m: f64,
        settings: &GuardSettings,
        speed_m_s: f64,
    ) -> f64 {
        self.tau_s = settings.filter_and_debounce_s(speed_m_s).0.max(0.0);
        self.update(t_s, h_m)
    }

    /// First-order low-pass of the height; its rate low-passed with the same time constant.
    pub fn update(&mut self, t_s: f64, h_m: f64) -> f64 {
        match self.value_m {
            None => {
                self.value_m = Some(h_m);
                self.last_t_s = t_s;
                h_m
            }
            Some(v) => {
                let dt = (t_s - self.last_t_s).max(0.0);
                let a = if self.tau_s > 0.0 {
                    1.0 - (-dt / self.tau_s).exp()
                } else {
                    1.0
                };
                let next = v + a * (h_m - v);
                if dt > 0.0 {
                    self.rate_m_s += a * ((next - v) / dt - self.rate_m_s);
                }
                self.value_m = Some(next);
                self.last_t_s = t_s;
                next
            }
        }
    }

    /// Whether the error has been outside `±tol` for at least `debounce_s`.
    pub fn outside_for(&mut self, t_s: f64, error_m: f64, tol_m: f64, debounce_s: f64) -> bool {
        if error_m.abs() > tol_m {
            let since = *self.outside_since_s.get_or_insert(t_s);
            t_s - since + 1e-9 >= debounce_s
        } else {
            self.outside_since_s = None;
            false
        }
    }
}

/// Bang-bang with hysteresis and a lead (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct DeadbandController {
    pub settings: GuardSettings,
    /// Close when the predicted height is within this of the target, m.
    pub stop_margin_m: f64,
    /// Prediction horizon of the stop decision, s.
    pub lead_s: f64,
    guard: ValveGuard,
    /// The height for the stop decision (the standing filter, always).
    filter: HeightFilter,
    /// The height for the open decision (slower while driving: the ride height between
    /// bumps). Standing, the two are the same.
    level_filter: HeightFilter,
}

impl DeadbandController {
    pub fn new(settings: GuardSettings) -> Self {
        Self {
            // Within the band whatever its width: a fill stopped 1 mm short of the target
            // leaves a ±0.5 mm band's error outside it, and the next opening follows the
            // rest time (chained pulses).
            stop_margin_m: STOP_MARGIN_M.min(MARGIN_SHARE_OF_BAND * settings.tolerance_m),
            lead_s: 0.8,
            guard: ValveGuard::new(settings.clone()),
            filter: HeightFilter::new(settings.filter_time_constant_s),
            level_filter: HeightFilter::new(settings.filter_time_constant_s),
            settings,
        }
    }
}

impl LevelController for DeadbandController {
    fn name(&self) -> &'static str {
        "deadband"
    }

    fn update(&mut self, t_s: f64, target_m: f64, reading: &Reading) -> ValveState {
        let s = &self.settings;
        // A filter that lags by seconds would stop a fill seconds late and overshoot: the
        // stop decision always reads the standing filter; only the decision to open reads the
        // slower level while driving.
        let h = self.filter.update(t_s, reading.sensor_height_m);
        let level = self
            .level_filter
            .update_at(t_s, reading.sensor_height_m, s, reading.speed_m_s);
        let level_error = target_m - level;
        let debounce_s = s.filter_and_debounce_s(reading.speed_m_s).1;
        let outside = self
            .level_filter
            .outside_for(t_s, level_error, s.tolerance_m, debounce_s);
        let requested = match self.guard.state() {
            ValveState::Closed if outside => {
                if level_error > 0.0 {
                    ValveState::Fill
                } else {
                    ValveState::Exhaust
                }
            }
            ValveState::Closed => ValveState::Closed,
            open => {
                let predicted = h + self.filter.rate_m_s * self.lead_s;
                let remaining = target_m - predicted;
                let done = match open {
                    ValveState::Fill => remaining <= self.stop_margin_m,
                    _ => remaining >= -self.stop_margin_m,
                };
                if done { ValveState::Closed } else { open }
            }
        };
        self.guard.apply(t_s, requested)
    }
}

/// The deadband controller's stop margin and the predictive controller's inner band for
/// the default ±5 mm band, m; narrow bands scale them by [`MARGIN_SHARE_OF_BAND`] (the stop
/// margin under ±2 mm) and [`INNER_BAND_SHARE_FACTOR`] times that (the standing inner band
/// under ±4 mm), which keeps both inside the band with room for the drift after a pulse.
pub const STOP_MARGIN_M: f64 = 1e-3;
pub const INNER_BAND_M: f64 = 1.5e-3;
pub const MARGIN_SHARE_OF_BAND: f64 = 0.5;
/// The predictive controller's inner band as a multiple of [`MARGIN_SHARE_OF_BAND`] of a
/// narrow band: standing, and while driving (wider than standing under ±4 mm; both are
/// capped by [`INNER_BAND_M`], so from ±4 mm on they are the same).
pub const INNER_BAND_SHARE_FACTOR: f64 = 0.75;
pub const DRIVING_INNER_BAND_SHARE_FACTOR: f64 = 1.5;
